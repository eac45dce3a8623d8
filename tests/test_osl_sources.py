# SPDX-License-Identifier: GPL-3.0-or-later
"""Static checks of the OSL sources (no bpy): generated header up to date,
function names mirrored from the reference, one shader per catalogue model,
and no closure fed a distribution string Cycles would silently turn into GGX."""

import re
from pathlib import Path

import pytest

from addon import catalogue, reference
from tools import gen_osl

OSL = Path(__file__).resolve().parent.parent / "osl"
COMMON = (OSL / "rm_common.h").read_text()

# Formulas the OSL header must mirror by name (same argument order by review).
MIRRORED = [name for name in reference.__all__
            if name.split("_")[0] in ("D", "Lambda", "F", "G", "S")
            or name.endswith("_from_beta") or name == "gaussian_norm"]
# The reference tabulates the quadrature; the shaders evaluate its Chebyshev series.
RENAMED = {"Lambda_table": "Lambda_chebyshev"}


NUMBER = re.compile(r"-?\d+\.\d*(?:e-?\d+)?")


@pytest.mark.parametrize("path", sorted(gen_osl.outputs()), ids=lambda p: p.name)
def test_generated_files_are_up_to_date(path):
    committed = path.read_text()
    fresh = gen_osl.outputs()[path]
    # Text equal up to the numbers; numbers equal to 1e-10 (numpy versions
    # differ in the last digits of the Gauss-Legendre nodes).
    assert NUMBER.sub("#", committed) == NUMBER.sub("#", fresh), "run: python -m tools.gen_osl"
    a = [float(x) for x in NUMBER.findall(committed)]
    b = [float(x) for x in NUMBER.findall(fresh)]
    assert a == pytest.approx(b, rel=1e-10, abs=1e-14), "run: python -m tools.gen_osl"


@pytest.mark.parametrize("name", MIRRORED)
def test_reference_formula_has_an_osl_twin(name):
    osl_name = RENAMED.get(name, name)
    assert re.search(rf"\b(float|color)\s+{osl_name}\s*\(", COMMON), osl_name


@pytest.mark.parametrize("model", sorted(catalogue.MODELS))
def test_every_model_has_a_shader_with_its_parameters(model):
    m = catalogue.MODELS[model]
    src = (OSL / m.shader).read_text()
    assert re.search(rf"\bshader\s+{Path(m.shader).stem}\s*\(", src)
    for p in m.params:
        kind = "int" if p.is_enum else "color" if p.kind == "color" else "float"
        assert re.search(rf"\b{kind}\s+{p.name}\s*=", src), (model, p.name)
    for out in catalogue.MAIN_OUTPUTS:
        assert re.search(rf"output\s+(closure\s+)?color\s+{out}\b", src), (model, out)


def test_closures_only_get_known_distribution_strings():
    """Cycles renders any unknown distribution string as GGX, silently."""
    known = {"ggx", "beckmann"}
    for path in OSL.glob("*.osl"):
        src = path.read_text()
        for call in re.finditer(r"\b(microfacet|conductor_bsdf|dielectric_bsdf)\s*\(([^;]*)", src):
            for literal in re.findall(r'"([^"]*)"', call.group(2)):
                assert literal in known, (path.name, literal)
    # the shared mapping from the enum code returns only known names
    body = COMMON[COMMON.index("string rm_closure_distribution"):]
    body = body[:body.index("}")]
    assert set(re.findall(r'"([^"]*)"', body)) <= known


def test_readme_model_table_is_generated_from_the_catalogue():
    from tools import gen_docs
    text = gen_docs.README.read_text()
    assert gen_docs.render(text) == text, "run: python -m tools.gen_docs"
    for model in catalogue.MODELS:
        assert f"`{model}`" in text


def _function_bodies(source):
    """{name: body} of the top-level functions of an OSL source."""
    bodies = {}
    for m in re.finditer(r"^\w[\w ]*?\b(\w+)\s*\([^;{]*?\)\s*\{", source, re.M):
        depth, i = 1, m.end()
        while depth:
            depth += {"{": 1, "}": -1}.get(source[i], 0)
            i += 1
        bodies[m.group(1)] = source[m.end():i - 1]
    return bodies


def test_no_loops_in_the_shaders():
    """OSL's runtime optimiser folds straight-line code on constant inputs but
    not a loop (measured: a 64-node loop over beta cost 0.8x a native render,
    written out 0.35x, the same as a constant).  So every quadrature and
    series is written out (tools/gen_osl.py), and so are the input checks,
    which run on every unconnected vector socket (measured: Kajiya-Kay exact
    0.655x -> 0.619x of a native render, in instructions)."""
    sources = [COMMON, (OSL / "rm_generated.h").read_text(), (OSL / "rm_closures.h").read_text()]
    sources += [p.read_text() for p in sorted(OSL.glob("*.osl"))]
    sources = [re.sub(r"//[^\n]*", "", s) for s in sources]
    looping = set()
    for source in sources:
        for name, body in _function_bodies(source).items():
            if re.search(r"\b(for|while|do)\b", body):
                looping.add(name)
    assert looping == set()
