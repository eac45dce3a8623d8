# SPDX-License-Identifier: GPL-3.0-or-later
"""Static checks of the renderer-side description and the OSL generated
from it (no bpy): generated files up to date, the formula library mirrors
the reference by name, one pair of shaders per catalogue model with its
parameters, no distribution string Cycles would silently turn into GGX, no
loops."""

import re

import pytest

from addon import catalogue, reference
from addon.backends.osl import generate
from addon.core.formulas import expr as E
from addon.core.formulas import library

OSL = generate.SHADERS
LIBRARY = (OSL / generate.LIBRARY).read_text()

# Formulas the description must mirror by name (same argument order by review).
MIRRORED = [name for name in reference.__all__
            if name.split("_")[0] in ("D", "Lambda", "F", "G", "S")
            or name.endswith("_from_beta") or name == "gaussian_norm"]
# The reference's name for the series (and its older alias) -> the description's.
RENAMED = {"Lambda_table": "Lambda_chebyshev_x", "Lambda_chebyshev": "Lambda_chebyshev_x"}


# generated once for the module: each file's test compares against the same
# output (generating every file for each of them took 18 s)
GENERATED = generate.outputs()


@pytest.mark.parametrize("path", sorted(GENERATED), ids=lambda p: p.name)
def test_generated_shaders_are_up_to_date(path):
    assert path.read_text() == GENERATED[path], "run: python -m tools.gen_osl"


@pytest.mark.parametrize("name", MIRRORED)
def test_reference_formula_has_a_twin_in_the_description(name):
    assert callable(getattr(library, RENAMED.get(name, name), None)), name


@pytest.mark.parametrize("model", sorted(catalogue.MODELS))
def test_every_model_has_shaders_with_its_parameters(model):
    """The exact shader (Direct, Color: the BSDF output is the closure
    shaders') and every closure shader take every parameter of the model."""
    m = catalogue.MODELS[model]
    shaders = [(generate.shader_name(model), ("Direct", "Color"))]
    shaders += [(name, ("BSDF",)) for name, _fixed in generate.closure_variants(model)]
    assert len(shaders) >= 2
    for name, outputs in shaders:
        src = (OSL / f"{name}.osl").read_text()
        assert re.search(rf"\bshader\s+{name}\s*\(", src)
        for p in m.params:
            kind = "int" if p.is_enum else "color" if p.kind == "color" else "float"
            assert re.search(rf"\b{kind}\s+{p.name}\s*=", src), (model, p.name)
        for out in outputs:
            assert re.search(rf"output\s+(closure\s+)?color\s+{out}\b", src), (model, out)


def test_closures_only_get_known_distribution_strings():
    """Cycles renders any unknown distribution string as GGX, silently."""
    known = {"ggx", "beckmann", "ashikhmin_shirley"}
    for path in OSL.glob("*.osl"):
        src = path.read_text()
        for call in re.finditer(r"\b(microfacet|conductor_bsdf|dielectric_bsdf)\s*\(([^;]*)", src):
            for literal in re.findall(r'"([^"]*)"', call.group(2)):
                assert literal in known, (path.name, literal)


def test_the_emitter_refuses_an_unknown_distribution():
    from addon.backends.osl.emit import statements
    bad = E.closure("microfacet", 1.0, E.geometry("N"), E.geometry("N"), 0.1, 0.1,
                    distribution="blinn")
    with pytest.raises(ValueError, match="silently render as GGX"):
        statements({"BSDF": bad}, {})




def test_no_loops_in_the_shaders():
    """OSL's runtime optimiser folds straight-line code on constant inputs but
    not a loop (measured: a 64-node loop over beta cost 0.8x a native render,
    written out 0.35x, the same as a constant).  The generated code is
    straight-line by construction (a table is an array read, not a search);
    the hand-written header too."""
    for source in [LIBRARY] + [p.read_text() for p in sorted(OSL.glob("*.osl"))]:
        assert not re.search(r"\b(for|while|do)\b", re.sub(r"//[^\n]*", "", source))


def test_the_generated_shaders_fold_a_choice_into_an_if_chain():
    """A structural parameter becomes an ``if`` on the shader's int input
    (folded by OSL's optimiser), never a per-sample computation of every
    branch: in the microfacet shader every distribution's D sits in its own
    branch."""
    src = (OSL / "rm_microfacet.osl").read_text()
    codes = generate.enum_codes("microfacet")["distribution"]
    for choice, code in codes.items():
        assert f"distribution == {code}" in src, choice


def test_a_packed_vector_stays_whole_and_folds_like_a_constant():
    """Three series evaluated at once: arithmetic on a packed constant stays
    one vector operation (a vconst would be split into three float
    operations), folds when both sides are constant, and its components
    are the numbers it was made of."""
    t = E.input_("t_packed_test")
    v = E.packed(1.0, 2.0, 3.0)
    s = E.vscale(v, t) + E.packed(0.5, 0.5, 0.5)
    assert s.op == "vadd" and s.kind == "v"
    assert E.count([s]) == 2
    assert (E.packed(1.0, 2.0, 3.0) + E.packed(1.0, 1.0, 1.0)).data == (2.0, 3.0, 4.0)
    assert E.vscale(v, 2.0).data == (2.0, 4.0, 6.0)
    assert [E.comp(v, i).data for i in range(3)] == [1.0, 2.0, 3.0]
    assert s - E.packed(0.0, 0.0, 0.0) is s


def test_negations_cancel_in_products_and_comparisons_with_zero():
    """(-x)(-y) is x y and -x > 0 is x < 0 (NaN is neither), so a cosine
    taken from a reflected vector costs no extra node."""
    x, y = E.input_("x_sign_test"), E.input_("y_sign_test")
    assert (-x) * (-y) is x * y
    assert E.gt(-x, 0.0) is E.lt(x, 0.0)
    assert E.lt(-x, 0.0) is E.gt(x, 0.0)
    assert E.gt(-x, 1.0).op == "gt" and E.gt(-x, 1.0).args[0].op == "neg"  # only against 0


def test_reflect_is_one_operation_on_both_backends():
    from addon.backends.native import emit as native_emit
    from addon.backends.osl import emit as osl_emit

    r = E.reflect(E.geometry("I"), E.geometry("N"))
    nodes, _refs = native_emit.plan({"R": r})
    assert [(n.type, n.props.get("operation")) for n in nodes] == \
        [("ShaderNodeVectorMath", "REFLECT")]
    assert "reflect(rm_view(), N)" in "\n".join(osl_emit.statements({"R": r}, {}))


def test_a_vector_chebyshev_series_is_three_scalar_series():
    """Clenshaw's recurrence with packed coefficients gives, per component,
    the scalar recurrence's value (checked numerically at a constant t,
    where both fold)."""
    rows = [(0.3, -1.0, 2.0), (0.1, 0.5, -0.25), (-0.2, 0.05, 0.75), (0.01, -0.3, 0.2)]
    t = 0.37
    packed = library.chebyshev([E.packed(*r) for r in rows], E.const(t))
    for i in range(3):
        scalar = library.chebyshev([r[i] for r in rows], E.const(t))
        assert packed[i].data == pytest.approx(scalar.data, rel=1e-12)
