# SPDX-License-Identifier: GPL-3.0-or-later
"""The layout: imports point one way, and every file of the core stays
free of Blender.

Layers, lowest first (README, "Layout"):

    addon.core  <-  addon (backends, groups, api, ui)  <-  verification
                <-  report  <-  tools

A module may import its own layer and the layers below it, never above;
nothing imports ``tools`` (command-line entry points only); ``fitting``
(offline numerics) sees the core only.  Checked statically on every
``import`` and ``from ... import`` of every Python file, including the ones
inside functions.  ``fitting`` is run by ``tools.fit`` (and checked by the
tests) only.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

LAYERS = ["addon.core", "addon", "verification", "report", "tools"]
ALLOWED_EXTRA = {"fitting": {"addon.core"}}  # besides its own package
PROJECT = ("addon", "verification", "report", "tools", "fitting")


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path):
    """(line, absolute module name) of every import in the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = _module_name(path)
    if path.name != "__init__.py":
        package = package.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                prefix = ".".join(base)
                mod = f"{prefix}.{node.module}" if node.module else prefix
            else:
                mod = node.module or ""
            yield node.lineno, mod
            for alias in node.names:  # "from addon import reference" imports addon.reference
                yield node.lineno, f"{mod}.{alias.name}"


def _layer(module: str):
    for i, name in reversed(list(enumerate(LAYERS))):
        if module == name or module.startswith(name + "."):
            return i
    return None


def _files(*tops):
    for top in tops:
        yield from sorted((ROOT / top).rglob("*.py"))


def _project_import(mod):
    return mod.split(".")[0] in PROJECT


@pytest.mark.parametrize("path", list(_files("addon", "verification", "report", "tools")),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_point_down_the_layers(path):
    own = _layer(_module_name(path))
    bad = []
    for line, mod in _imports(path):
        if not _project_import(mod):
            continue
        if mod.split(".")[0] == "fitting":
            if not _module_name(path).startswith("tools"):
                bad.append((line, mod, "fitting is offline numerics: only its tool runs it"))
            continue
        layer = _layer(mod)
        if layer is not None and layer > own:
            bad.append((line, mod, f"{LAYERS[layer]} is above {LAYERS[own]}"))
        if mod.split(".")[0] == "tools" and not _module_name(path).startswith("tools"):
            bad.append((line, mod, "nothing imports the tools"))
    assert not bad, bad


@pytest.mark.parametrize("path", list(_files("fitting")), ids=lambda p: str(p.relative_to(ROOT)))
def test_the_fitter_sees_the_core_only(path):
    for line, mod in _imports(path):
        if _project_import(mod) and mod.split(".")[0] != "fitting":
            assert any(mod == a or mod.startswith(a + ".") for a in ALLOWED_EXTRA["fitting"]), \
                (line, mod)


@pytest.mark.parametrize("path", list(_files("tests")), ids=lambda p: p.name)
def test_tests_do_not_import_the_tools(path):
    """Tests check the library layers; the tools are command-line wrappers."""
    for line, mod in _imports(path):
        assert mod.split(".")[0] != "tools", (line, mod)


@pytest.mark.parametrize("path", list(_files("addon/core")), ids=lambda p: str(p.relative_to(ROOT)))
def test_the_core_needs_neither_blender_nor_a_renderer(path):
    for line, mod in _imports(path):
        top = mod.split(".")[0]
        assert top not in ("bpy", "mathutils", "bmesh", "cycles", "OpenImageIO"), (line, mod)
        if _project_import(mod):
            assert mod == "addon.core" or mod.startswith("addon.core."), (line, mod)


@pytest.mark.parametrize("path", list(_files("addon")), ids=lambda p: str(p.relative_to(ROOT)))
def test_the_extension_imports_itself_relatively(path):
    """Installed, the extension is the package ``bl_ext.<repository>.
    reflection_models`` and no package ``addon`` exists: a module of it
    that imports ``addon`` by name fails in Blender (three did, until the
    forty-eighth session; tests/test_packaging.py installs the zip where
    the source tree is out of reach)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            assert not [a.name for a in node.names if a.name.split(".")[0] == "addon"], \
                node.lineno
        elif isinstance(node, ast.ImportFrom) and not node.level:
            assert (node.module or "").split(".")[0] != "addon", node.lineno


def test_the_layers_exist_and_the_old_ones_are_gone():
    for name in ("addon/core", "addon/backends/osl", "verification/harness",
                 "verification/scenes", "verification/experiments", "verification/suites",
                 "report", "tools", "fitting"):
        assert (ROOT / name).is_dir(), name
    for gone in ("test_scenes", "osl", "addon/nodes.py", "addon/oslutil.py"):
        assert not (ROOT / gone).exists(), gone
