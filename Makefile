# SPDX-License-Identifier: GPL-3.0-or-later
#
# Reflection Models: build, test and demo targets.
#
#   make test                  run the test suite (Blender 5.2 if Python 3.13 exists, else 4.5)
#   make test BLENDER=4.5      run it against bpy 4.5 (Python 3.11) in .venv-4.5
#   make test BLENDER=5.3      against bpy 5.3 (Python 3.13) in .venv-5.3 (not in CI)
#   make test-all              both versions, one after the other
#   make test TESTS=tests/test_packaging.py PYTEST_ARGS=-x   a subset, extra pytest options
#   make test TEST_JOBS=1      in one process (default: two, a test file each)
#   make zip                   dist/reflection_models-<version>.zip
#   make demo / make bench     the demo and benchmark scripts
#   make fit                   the offline fit of the closure mixtures (about 5 h, resumable)
#   make venv                  only create/update the virtual environment
#   make clean                 remove build/ and dist/ (the venvs stay; see distclean)
#
# Every target creates its own virtual environment on first use.  A stamp file
# named after a hash of the requirements makes later runs skip the setup.

SHELL := /bin/bash
.DEFAULT_GOAL := test

ifeq ($(origin PYENV_ROOT),undefined)
  PYENV_ROOT := $(shell pyenv root 2>/dev/null)
endif

# A usable interpreter of version $(1) ("3.13"): pyenv's installs first, then
# python$(1) on PATH.  Each candidate is run once, because a pyenv shim can
# exist on PATH without the version being selected.  Free-threaded builds are
# skipped (bpy does not support them).
python_check = import sys, sysconfig; sys.exit(not (sys.version_info[:2] == tuple(map(int, "$(1)".split("."))) and not sysconfig.get_config_var("Py_GIL_DISABLED")))
python_ok = $(shell "$(1)" -c '$(call python_check,$(2))' >/dev/null 2>&1 && echo ok)
# first_python(candidates, version): the first candidate that passes the check.
first_python = $(if $(1),$(if $(call python_ok,$(firstword $(1)),$(2)),$(firstword $(1)),$(call first_python,$(wordlist 2,999,$(1)),$(2))))
find_python = $(or $(call first_python,$(sort $(wildcard $(PYENV_ROOT)/versions/$(1)*/bin/python3)),$(1)),$(call first_python,$(shell command -v python$(1) 2>/dev/null),$(1)))

# BLENDER selects the bpy series; without it, 5.2 if a Python 3.13 exists.
# An unrelated BLENDER in the environment (say, a path to a binary) is ignored.
ifeq ($(origin BLENDER),environment)
  ifeq ($(filter 5.2 4.5 5.3,$(BLENDER)),)
    BLENDER :=
  endif
endif
ifeq ($(strip $(BLENDER)),)
  PYTHON_313 := $(call find_python,3.13)
  BLENDER := $(if $(PYTHON_313),5.2,4.5)
endif

ifeq ($(BLENDER),5.2)
  PYVER := 3.13
  VENV := .venv
else ifeq ($(BLENDER),4.5)
  PYVER := 3.11
  VENV := .venv-4.5
else ifeq ($(BLENDER),5.3)
  PYVER := 3.13
  VENV := .venv-5.3
else
  $(error BLENDER must be 5.2, 4.5 or 5.3, not "$(BLENDER)")
endif

REQUIREMENTS := bpy==$(BLENDER).* numpy OpenImageIO pytest pytest-xdist matplotlib jinja2 mpmath scipy highspy
REQ_HASH := $(shell printf '%s' '$(PYVER) $(REQUIREMENTS)' | md5sum | cut -c1-12)
STAMP := $(VENV)/.reflection-models-$(REQ_HASH).stamp
PY := $(VENV)/bin/python

# Throwaway temp folders (every OSL compile leaves an .oso there).  Each test
# run gets its own under the system temp folder, so runs at the same time do
# not collide, and the OSL compiler sees absolute paths (with a path inside
# the working directory it reports line numbers one too high).
RUN_TMP := $(CURDIR)/build/tmp/run-$(BLENDER)
TESTS ?= tests
PYTEST_ARGS ?=
# The suite runs in TEST_JOBS processes (pytest-xdist), a test file per
# process at a time (its tests keep their order); 1 runs it in this process.
TEST_JOBS ?= 2
XDIST_ARGS := $(if $(filter-out 0 1,$(TEST_JOBS)),-n $(TEST_JOBS) --dist loadfile,-p no:xdist)

.PHONY: test test-all zip demo bench fit venv clean distclean

venv: $(STAMP)

$(STAMP):
	@set -e; \
	if [ ! -x "$(PY)" ]; then \
	  base="$(call find_python,$(PYVER))"; \
	  if [ -z "$$base" ]; then \
	    echo "error: BLENDER=$(BLENDER) needs Python $(PYVER) (pyenv's $(PYENV_ROOT)/versions/$(PYVER)*/bin/python3 or python$(PYVER) on PATH); none found" >&2; \
	    exit 1; \
	  fi; \
	  echo "Creating $(VENV) with $$base"; \
	  "$$base" -m venv "$(VENV)"; \
	fi
	$(PY) -m pip install --quiet $(REQUIREMENTS)
	@rm -f $(VENV)/.reflection-models-*.stamp
	@touch $@

test: $(STAMP)
	@run=$$(mktemp -d -t reflection-models-test-$(BLENDER).XXXXXX); \
	TMPDIR="$$run" $(PY) -m pytest $(TESTS) -q $(XDIST_ARGS) $(PYTEST_ARGS); status=$$?; \
	rm -rf "$$run"; exit $$status

test-all:
	$(MAKE) test BLENDER=5.2
	$(MAKE) test BLENDER=4.5

zip: $(STAMP)
	$(PY) -m tools.build_zip

demo: zip
	@mkdir -p "$(RUN_TMP)"
	@if [ -f tools/demo.py ]; then \
	  TMPDIR="$(RUN_TMP)" $(PY) -m tools.demo; \
	else \
	  echo "tools/demo.py does not exist yet: nothing to demo"; \
	fi

bench: $(STAMP)
	@mkdir -p "$(RUN_TMP)"
	TMPDIR="$(RUN_TMP)" $(PY) -m tools.bench

# The offline fit of the closure mixtures (numpy, scipy and highspy; seeded,
# so the same code gives the same data): about 3.5 hours on two cores when last
# run whole, before the steps that settle and jointly re-solve the Smith
# variants were added (those, run alone, took about half an hour more; the
# last part chooses what ships for each variant).  Writes
# addon/core/fits/mixtures.py; `make fit ONLY="key ..."` refits some.
# Then the step that halves the width nodes (fitting/halve.py), for the
# variants in HALVE only: it takes about an hour a variant, and was run for
# these two (Trowbridge-Reitz with separable Smith in beta, the one other
# variant it would try, has not been run through it).  With ONLY, only
# those of them that were fitted again.  Last, the Smith variants in alpha
# get their siblings in beta's fits, resampled, where that measures better
# (fitting/reparam.py; 5-10 minutes; with ONLY, those named or whose
# sibling is).  Between the two, the step that moves the members' widths
# node by node and then solves the series of the nodes around the worst
# widths together (fitting/widths.py), for the variants in MOVE (two sweeps
# of moves) and MOVE_ONCE (one) only: about an hour and a half for
# Gaussian's, longer for Blinn's (its joint solve alone took two hours on
# one core); it ships for both, and each has the number of sweeps that
# measured better (docs/verification.md).  After the moves, for the variants
# in EDGE, the series of the nodes around the width intervals that
# fitting/bounds.py measures over the bound solved together again, at its
# views and with the lights on the domain's 70-degree edge, which the steps
# before did not see, one interval at a time, the nearest the bound first
# (fitting/assemble.py's finish_edge; 2-7 minutes an interval: 36 minutes
# for Gaussian with separable Smith's ten), the error under the Fresnel
# indices that err most there held from rising, the fitter's worst case
# allowed to rise only where fitting/bounds.py sees the rise (an hour for
# Blinn with separable Smith's fourteen intervals over the bound, on two
# cores: ten windows, nine kept, four intervals brought within the bound
# by their neighbours' windows; then a second pass from what the first
# left, up to EDGE_PASSES, 11 minutes: one window, every interval within
# the bound).  The data of Blinn and of Gaussian with separable Smith
# comes from this form (Gaussian's run from the data of an earlier form,
# one interval at a time with no Fresnel held; three passes, 87 minutes
# on one core: its worst interval 0.0343 -> 0.0317, none brought within
# the bound); Blinn with correlated Smith's from the first form (its
# three intervals in one programme).  Not in EDGE:
# Trowbridge-Reitz with separable Smith (tried: no interval brought within
# the bound, none lowered by more than 0.001).  And Phong's
# mixture of Toon lobes for Cycles' native nodes (fitting/toon.py; about 45 minutes, on two cores;
# with ONLY, when it names phong), written to addon/core/fits/toon.py.
# Then how far Ward's weighted Beckmann lobe is from Ward's model, cell by
# cell of its widths (fitting/ward.py; about 6 minutes on two cores; with
# ONLY, when it names ward), written to addon/core/fits/ward.py; and the
# same for Kajiya-Kay's diffuse and hair reflection closures, cell by cell
# of its exponent and colour ratio (fitting/kajiya_kay.py; about a minute;
# with ONLY, when it names kajiya_kay), to addon/core/fits/kajiya_kay.py.
# Last, where each microfacet mixture holds the fitted bound, interval by
# interval of its width nodes, without and with the model's Fresnel
# (fitting/bounds.py; about 21 minutes on two cores), written to
# addon/core/fits/bounds.py: the status "fitted" per width and Fresnel.
JOBS ?= 2
HALVE ?= microfacet/blinn/smith/beta microfacet/gaussian/smith/beta
HALVE_NOW = $(if $(ONLY),$(filter $(ONLY),$(HALVE)),$(HALVE))
MOVE ?= microfacet/gaussian/smith/beta
MOVE_NOW = $(if $(ONLY),$(filter $(ONLY),$(MOVE)),$(MOVE))
MOVE_ONCE ?= microfacet/blinn/smith/beta
MOVE_ONCE_NOW = $(if $(ONLY),$(filter $(ONLY),$(MOVE_ONCE)),$(MOVE_ONCE))
EDGE ?= microfacet/blinn/smith/beta microfacet/blinn/smith_correlated/beta \
        microfacet/gaussian/smith/beta
EDGE_NOW = $(if $(ONLY),$(filter $(ONLY),$(EDGE)),$(EDGE))
TOON_NOW = $(if $(ONLY),$(filter phong,$(ONLY)),phong)
WARD_NOW = $(if $(ONLY),$(filter ward,$(ONLY)),ward)
KK_NOW = $(if $(ONLY),$(filter kajiya_kay,$(ONLY)),kajiya_kay)
fit: $(STAMP)
	$(PY) -m tools.fit --mixtures --jobs $(JOBS) $(if $(ONLY),--only $(ONLY),)
	$(if $(strip $(HALVE_NOW)),$(PY) -m tools.fit --finish --halve --jobs $(JOBS) --only $(HALVE_NOW),)
	$(if $(strip $(MOVE_NOW)),$(PY) -m tools.fit --move --jobs $(JOBS) --only $(MOVE_NOW),)
	$(if $(strip $(MOVE_ONCE_NOW)),$(PY) -m tools.fit --move --sweeps 1 --jobs $(JOBS) --only $(MOVE_ONCE_NOW),)
	$(if $(strip $(EDGE_NOW)),$(PY) -m tools.fit --edge --jobs $(JOBS) --only $(EDGE_NOW),)
	$(PY) -m tools.fit --derive --jobs $(JOBS) $(if $(ONLY),--only $(ONLY),)
	$(if $(strip $(TOON_NOW)),$(PY) -m tools.fit --toon --jobs $(JOBS),)
	$(if $(strip $(WARD_NOW)),$(PY) -m tools.fit --ward --jobs $(JOBS),)
	$(if $(strip $(KK_NOW)),$(PY) -m tools.fit --kajiya-kay --jobs $(JOBS),)
	$(PY) -m tools.fit --bounds --jobs $(JOBS)

clean:
	rm -rf build dist .pytest_cache
	find . \( -path ./.git -o -path './.venv*' \) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf .venv .venv-4.5 .venv-5.3
