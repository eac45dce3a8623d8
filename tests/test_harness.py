# SPDX-License-Identifier: GPL-3.0-or-later
"""The measurement harness measured against formulas written here.

- The gonioreflectometer's analytic geometry (no Blender).
- Native Cycles closures on the gonio scene: Diffuse = Lambert, Glossy GGX =
  GGX with height-correlated Smith and alpha = roughness^2; the per-pixel
  normal, UV tangent and incoming direction match the geometry arrays.
- The OSL path: internal Script nodes compiled by ``addon.backends.osl.compile`` render
  what they compute; the closure facts of docs/cycles-closures.md.
- The white furnace gives back the albedo of a Diffuse BSDF.

Every expectation is computed here from its formula, independently of the
render and of ``addon.reference``.  Measured numbers are printed (``-s``).
"""

import textwrap
from pathlib import Path

import numpy as np
import pytest

from verification import harness as common
from verification.scenes import furnace, gonio

LIGHT = gonio.normalize((0.5, -0.3, 0.8))
LOW_LIGHT = gonio.normalize((1.0, 0.3, 0.25))  # grazing: tiles shadow each other


def dot(a, b):
    return np.sum(a * b, axis=-1)


def lambert(c):
    c = np.asarray(c, dtype=np.float64)
    return lambda wi, wo, n, t: c / np.pi * np.maximum(0.0, dot(n, wi))[:, None]


def ggx_smith(wi, wo, n, t, ax, ay):
    """GGX (Trowbridge-Reitz) with height-correlated Smith shadowing, times
    max(0, N.wi); ax along t, ay along n x t."""
    b = np.cross(n, t)
    ci, co = dot(n, wi), dot(n, wo)
    h = gonio.normalize(wi + wo)
    hx, hy, hz = dot(h, t) / ax, dot(h, b) / ay, dot(h, n)
    d = 1.0 / (np.pi * ax * ay * (hx * hx + hy * hy + hz * hz) ** 2)

    def lam(w):
        c = dot(n, w)
        tan2 = ((ax * dot(w, t)) ** 2 + (ay * dot(w, b)) ** 2) / (c * c)
        return 0.5 * (-1.0 + np.sqrt(1.0 + tan2))

    with np.errstate(divide="ignore", invalid="ignore"):
        g = 1.0 / (1.0 + lam(wi) + lam(wo))
        f = d * g / (4.0 * ci * co)
    return np.where((ci > 0) & (co > 0), f * ci, 0.0)


def ggx_iso_textbook(wi, wo, n, a):
    """The isotropic form as usually printed: D = a^2 / (pi ((a^2-1) cos^2 + 1)^2),
    Lambda = (-1 + sqrt(1 + a^2 tan^2)) / 2, G = 1 / (1 + Li + Lo)."""
    ci, co = dot(n, wi), dot(n, wo)
    ch = dot(n, gonio.normalize(wi + wo))
    a2 = a * a
    d = a2 / (np.pi * ((a2 - 1.0) * ch * ch + 1.0) ** 2)

    def lam(c):
        return 0.5 * (-1.0 + np.sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)))

    with np.errstate(divide="ignore", invalid="ignore"):
        f = d / (1.0 + lam(ci) + lam(co)) / (4.0 * ci * co)
    return np.where((ci > 0) & (co > 0), f * ci, 0.0)


def fresnel_exact(cos_h, n, k):
    """Unpolarised Fresnel reflectance for the complex index n + ik (k = 0:
    dielectric, total internal reflection included), per channel."""
    c = np.asarray(cos_h, dtype=np.float64)[..., None]
    eta = np.asarray(n, dtype=np.float64) + 1j * np.asarray(k, dtype=np.float64)
    cos_t = np.sqrt(1.0 - (1.0 - c * c) / (eta * eta) + 0j)
    r_p = (eta * c - cos_t) / (eta * c + cos_t)
    r_s = (c - eta * cos_t) / (c + eta * cos_t)
    return 0.5 * (np.abs(r_p) ** 2 + np.abs(r_s) ** 2)


# --------------------------------------------------------------------------
# Blender helpers

def new_material(bpy, name):
    """An empty node material: returns (material, node_tree, output node)."""
    return common.empty_material(name)


def uv_tangent_node(tree):
    node = tree.nodes.new("ShaderNodeTangent")
    node.direction_type = 'UV_MAP'
    node.uv_map = "UVMap"
    return node


def osl_material(bpy, tmp_path, name, source, tangent=False, **inputs):
    """A material whose surface is the OSL shader ``source`` (output ``Out``),
    written to ``tmp_path`` and compiled by addon.backends.osl.compile."""
    from addon.backends.osl import compile as oslutil

    (tmp_path / f"{name}.osl").write_text(textwrap.dedent(source))
    mat, tree, out = new_material(bpy, name)
    node = oslutil.make_script_node(tree, name, search_dir=tmp_path)
    for key, value in inputs.items():
        socket = node.inputs[key]
        if socket.type == 'RGBA' and len(value) == 3:
            value = (*value, 1.0)
        socket.default_value = value
    if tangent:
        tree.links.new(uv_tangent_node(tree).outputs[0], node.inputs["Tangent"])
    tree.links.new(node.outputs["Out"], out.inputs["Surface"])
    return mat, node


def emission_of_vector(bpy, name, link_source):
    """Material emitting 0.5 + 0.5 v for the vector output chosen by
    ``link_source(tree)``."""
    mat, tree, out = new_material(bpy, name)
    encode = tree.nodes.new("ShaderNodeVectorMath")
    encode.operation = 'MULTIPLY_ADD'
    encode.inputs[1].default_value = (0.5, 0.5, 0.5)
    encode.inputs[2].default_value = (0.5, 0.5, 0.5)
    emit = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(link_source(tree), encode.inputs[0])
    tree.links.new(encode.outputs[0], emit.inputs["Color"])
    tree.links.new(emit.outputs[0], out.inputs["Surface"])
    return mat


def measure(bpy, mat, expected_fn, *, light=LIGHT, resolution=96, **kw):
    g = gonio.build_gonio_scene(mat, light_dir=light, resolution=resolution,
                                name=mat.name, **kw)
    img = gonio.render(g)
    return g, img, gonio.compare(img, g.expected(expected_fn), g.mask)


# --------------------------------------------------------------------------
# geometry without Blender

def test_hemisphere_tiles_are_orthonormal_and_face_the_camera():
    view = gonio.normalize((0.2, -0.4, 0.9))
    tiles = gonio.hemisphere_tiles((0, 30, 60), (0, 90, 180, 270), view_dir=view, twist_deg=25)
    assert len(tiles) == 1 + 2 * 4
    n = np.array([t.normal for t in tiles])
    t = np.array([t.tangent for t in tiles])
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1, atol=1e-12)
    np.testing.assert_allclose(dot(n, t), 0, atol=1e-12)
    tilts = np.degrees(np.arccos(np.clip(n @ view, -1, 1)))
    np.testing.assert_allclose(sorted(set(np.round(tilts, 9))), [0, 30, 60], atol=1e-7)


def test_gonio_plan_masks_and_shadows():
    g = gonio.plan_gonio(light_dir=LIGHT, resolution=128)
    assert g.mask.shape == (128, 128)
    # every tile has measured pixels, and they all see that tile
    for k in range(len(g.tiles)):
        assert np.count_nonzero(g.mask & (g.tile_index == k)) > 0, k
    assert not g.shadowed.any()  # a high sun over 25 tiles casts no shadow on them
    np.testing.assert_allclose(np.linalg.norm(g.normal[g.mask], axis=1), 1, atol=1e-12)
    np.testing.assert_allclose(g.wo[g.mask], np.broadcast_to((0, 0, 1), (g.mask.sum(), 3)))
    # the hit points lie on their tiles' planes
    c = np.asarray(g.centres)[g.tile_index[g.mask]]
    np.testing.assert_allclose(dot(g.position[g.mask] - c, g.normal[g.mask]), 0, atol=1e-12)
    # a grazing sun shadows neighbours; the umbra lies inside the shadow
    low = gonio.plan_gonio(light_dir=LOW_LIGHT, resolution=128)
    assert low.shadowed.sum() > 100
    assert not (low.umbra & ~low.shadowed).any()
    assert not (low.mask & low.shadowed).any()


def _brute_force_coverage_and_shadows(g, light_dir):
    """Which tile each pixel centre sees and which pixels a tile shadows,
    every pixel against every tile (what gonio's windows must reproduce)."""
    h, w = g.tile_index.shape
    px = g.ortho_scale / w
    half = g.tile_size / 2.0
    wi = np.asarray(light_dir, float) / np.linalg.norm(light_dir)
    n = np.array([t.normal for t in g.tiles])
    u = np.array([t.tangent for t in g.tiles])
    v = np.cross(n, u)
    basis = common.camera_basis(g.view_dir, None)
    right, up = basis[:, 0], basis[:, 1]
    col, row = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    index = np.full((h, w), -1)
    for k, c in enumerate(g.centres):
        corners = [c + a * half * u[k] + b * half * v[k] for a, b in
                   ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        q = np.array([[p @ right / px + w / 2.0, h / 2.0 - p @ up / px] for p in corners])
        area = sum(q[i, 0] * q[i - 3, 1] - q[i - 3, 0] * q[i, 1] for i in range(4))
        d = np.min([np.sign(area) * ((q[i - 3] - q[i])[0] * (row - q[i, 1])
                                     - (q[i - 3] - q[i])[1] * (col - q[i, 0]))
                    / np.hypot(*(q[i - 3] - q[i])) for i in range(4)], axis=0)
        index[d >= 0] = k
    shadowed = np.zeros((h, w), bool)
    for r, c in zip(*np.nonzero(g.inside)):
        p = g.position[r, c]
        for m, cm in enumerate(g.centres):
            if m == index[r, c] or abs(wi @ n[m]) < 1e-12:
                continue
            t = (cm - p) @ n[m] / (wi @ n[m])
            q = p + t * wi - cm
            if t > 1e-9 and max(abs(q @ u[m]), abs(q @ v[m])) <= half + px:
                shadowed[r, c] = True
    return index, shadowed


@pytest.mark.parametrize("light", [(0.3, 0.2, 0.93), (1.0, 0.0, 0.05), (0.99, 0.14, 0.014),
                                   (-0.5, 0.8, 0.3), (0.0, 1.0, 1e-7)])
def test_gonio_plan_finds_what_every_pixel_against_every_tile_finds(light):
    """The plan looks for a tile's pixels and shadows in a window of the
    image about it (the robustness tests' EEVEE bench has 12,960 tiles);
    the same as every pixel against every tile, lights from high to in the
    image plane."""
    g = gonio.plan_gonio(light_dir=light, resolution=(72, 60))
    index, shadowed = _brute_force_coverage_and_shadows(g, light)
    assert np.array_equal(g.tile_index, index)
    assert np.array_equal(g.shadowed, shadowed)
    if light[2] < 0.1:
        assert shadowed.sum() > 50  # the low lights cast shadows


def test_a_case_with_ward_own_alphas_has_wards_status():
    """Ward's alpha_x and alpha_y are its own sockets, not the microfacet
    model's width mode: its case resolves to Ward's variant (the case once
    raised ValueError for a width_mode Ward does not have)."""
    from verification.suites import cases as cases_mod
    ward = cases_mod.Case("ward", {"alpha_x": 0.2, "alpha_y": 0.5}, "own alphas")
    assert "width_mode" not in ward.enums
    assert ward.path_traced_status() == "approx"
    aniso = cases_mod.Case("microfacet", {"distribution": "beckmann", "shadowing": "smith_correlated",
                                          "alpha_x": 0.2, "alpha_y": 0.5}, "aniso")
    assert aniso.enums["width_mode"] == "alpha_xy"


def test_compare_relative_error_and_floor():
    e = np.zeros((2, 2, 3))
    e[0, 0] = 1.0
    r = e.copy()
    r[0, 0, 1] = 1.001
    r[1, 1, 2] = 2e-3  # expected 0: relative to the floor 1e-3 of the peak
    stats = gonio.compare(r, e, np.ones((2, 2), bool))
    assert stats["floor"] == pytest.approx(1e-3)
    assert stats["max_rel_error"] == pytest.approx(2.0)
    assert stats["worst"] == (1, 1, 2)


def test_compare_a_black_expectation_against_the_scale_given():
    """An expectation black everywhere has no peak: the given scale stands
    for it, so float dust passes and a visible error does not."""
    e = np.zeros((2, 2, 3))
    r = e.copy()
    r[0, 1, 0] = 1e-8                        # float32 dust on a radiance of order 0.3
    stats = gonio.compare(r, e, np.ones((2, 2), bool), scale=0.3)
    assert stats["floor"] == pytest.approx(3e-4) and stats["scale"] == 0.3
    assert stats["max_rel_error"] < 1e-4
    r[1, 0, 2] = 0.03                        # a tenth of the scale: a real error
    assert gonio.compare(r, e, np.ones((2, 2), bool), scale=0.3)["max_rel_error"] == \
        pytest.approx(100.0)
    with pytest.raises(ValueError, match="scale"):
        gonio.compare(r, e, np.ones((2, 2), bool), scale=0.0)


# --------------------------------------------------------------------------
# native closures on the gonio scene

def test_pixel_geometry_matches_cycles(bpy):
    """Cycles' own normal, UV tangent and incoming vector equal the arrays,
    which also fixes the image orientation (row 0 = top)."""
    sources = {
        "normal": lambda tree: tree.nodes.new("ShaderNodeNewGeometry").outputs["Normal"],
        "tangent": lambda tree: uv_tangent_node(tree).outputs[0],
        "wo": lambda tree: tree.nodes.new("ShaderNodeNewGeometry").outputs["Incoming"],
    }
    for key, source in sources.items():
        mat = emission_of_vector(bpy, "geo_" + key, source)
        g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=96, name=mat.name)
        img = gonio.render(g)
        err = np.abs(img - (0.5 + 0.5 * getattr(g, key)))[g.inside].max()
        print(f"{key}: max abs error {err:.2e}")
        assert err < 1e-6, key
        assert np.all(img[g.tile_index < 0] == 0.0)  # the world is black


@pytest.mark.parametrize("light", [LIGHT, LOW_LIGHT], ids=["high_sun", "low_sun"])
def test_diffuse_bsdf_is_lambert(bpy, light):
    c = (0.8, 0.5, 0.2)
    mat, tree, out = new_material(bpy, "diffuse")
    node = tree.nodes.new("ShaderNodeBsdfDiffuse")
    node.inputs["Color"].default_value = (*c, 1.0)
    node.inputs["Roughness"].default_value = 0.0
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    g, img, stats = measure(bpy, mat, lambert(c), light=light)
    print(f"Diffuse vs Lambert: {stats}")
    assert stats["max_rel_error"] < 1e-5
    assert stats["n_pixels"] > 1000
    # the pixels the sun cannot reach are black in the render too
    assert np.all(img[g.umbra] == 0.0)
    assert np.all(img[g.tile_index < 0] == 0.0)


@pytest.mark.parametrize("roughness", [0.3, 0.5, 0.8])
def test_glossy_ggx_is_ggx_smith_with_alpha_roughness_squared(bpy, roughness):
    mat, tree, out = new_material(bpy, f"glossy_{roughness}")
    node = tree.nodes.new("ShaderNodeBsdfGlossy")
    node.distribution = 'GGX'
    node.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    node.inputs["Roughness"].default_value = roughness
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    a = roughness ** 2
    g, img, stats = measure(bpy, mat, lambda wi, wo, n, t: ggx_iso_textbook(wi, wo, n, a)[:, None])
    print(f"Glossy GGX r={roughness} vs GGX+Smith(alpha=r^2): {stats}")
    assert stats["max_rel_error"] < 1e-4


# --------------------------------------------------------------------------
# OSL

EMIT_CONSTANT = """
    #include "stdcycles.h"
    shader t_constant(color C = color(0.25, 0.5, 0.75), output closure color Out = 0)
    {
        Out = C * emission();
    }
"""

EMIT_COSINE = """
    #include "stdcycles.h"
    #include "rm_t_util.h"
    shader t_cosine(vector Light = vector(0, 0, 1), color Tint = color(1, 0.5, 0.25),
                    output closure color Out = 0)
    {
        Out = t_clamped_cosine(N, Light) * Tint * emission();
    }
"""

UTIL_HEADER = """
    float t_clamped_cosine(vector n, vector l) { return max(0.0, dot(n, normalize(l))); }
"""


def test_osl_emission_constant_and_light_dependent(bpy, tmp_path):
    mat, _ = osl_material(bpy, tmp_path, "t_constant", EMIT_CONSTANT)
    g, img, stats = measure(bpy, mat, lambda wi, wo, n, t: np.array([0.25, 0.5, 0.75]))
    assert g.scene.cycles.shading_system
    print(f"OSL constant emission: {stats}")
    assert stats["max_rel_error"] < 1e-6

    (tmp_path / "rm_t_util.h").write_text(textwrap.dedent(UTIL_HEADER))
    light = gonio.normalize((-0.4, 0.6, 0.7))
    mat, node = osl_material(bpy, tmp_path, "t_cosine", EMIT_COSINE, Light=tuple(light))
    assert "#include" not in node.script.as_string().replace('#include "stdcycles.h"', "")
    tint = np.array([1.0, 0.5, 0.25])
    # the sun plays no part: light the scene from elsewhere
    g, img, stats = measure(bpy, mat, lambda wi, wo, n, t: np.maximum(0, n @ light)[:, None] * tint)
    print(f"OSL emission of max(0, N.L): {stats}")
    # float32 N.L carries ~6e-8 of absolute rounding; at the smallest values measured
    # (3.6e-3, near grazing) that is 1.7e-5 relative (bpy 4.5.16 measured 1.3e-5)
    assert stats["max_rel_error"] < 2e-5


GLOBALS = """
    #include "stdcycles.h"
    shader t_globals(int Which = 0, vector Tangent = vector(0), output closure color Out = 0)
    {
        vector w = N;
        if (Which == 1) w = I;
        if (Which == 2) w = Tangent;
        if (Which == 3) w = normalize(dPdu);
        Out = (color(0.5) + 0.5 * color(w[0], w[1], w[2])) * emission();
    }
"""


def test_osl_globals_conventions(bpy, tmp_path):
    """In Cycles OSL, N is the world-space normal and I points toward the
    viewer (= wo); dPdu is not the UV tangent (feed the Tangent node in)."""
    mat, node = osl_material(bpy, tmp_path, "t_globals", GLOBALS, tangent=True)
    errors = {}
    for which, key in enumerate(("normal", "wo", "tangent", "tangent")):
        node.inputs["Which"].default_value = which
        g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=64, name=f"globals{which}")
        img = gonio.render(g)
        errors[which] = float(np.abs(img - (0.5 + 0.5 * getattr(g, key)))[g.inside].max())
    print(f"OSL globals, max abs error: N {errors[0]:.1e}, I {errors[1]:.1e}, "
          f"Tangent input {errors[2]:.1e}, dPdu {errors[3]:.2f}")
    assert errors[0] < 1e-6 and errors[1] < 1e-6 and errors[2] < 1e-6
    assert errors[3] > 0.1


def test_make_script_node_reports_compiler_errors(bpy, tmp_path):
    from addon.backends.osl import compile as oslutil

    (tmp_path / "t_broken.osl").write_text(
        '#include "stdcycles.h"\nshader t_broken(output closure color Out = 0)\n'
        "{\n    Out = no_such_thing * emission();\n}\n")
    _, tree, _ = new_material(bpy, "broken")
    with pytest.raises(oslutil.OSLCompileError, match=r"t_broken.osl:4: error: .no_such_thing"):
        oslutil.make_script_node(tree, "t_broken", search_dir=tmp_path)


def test_inline_includes_once_and_recursively(tmp_path):
    from addon.backends.osl import compile as oslutil

    (tmp_path / "rm_a.h").write_text('#include "rm_b.h"\nfloat a() { return b(); }\n')
    (tmp_path / "rm_b.h").write_text("float b() { return 1.0; }\n")
    src = '#include "stdcycles.h"\n#include "rm_a.h"\n  #include "rm_b.h"\nshader s() {}\n'
    out = oslutil.inline_includes(src, tmp_path)
    assert out.count("float b()") == 1
    assert out.index("float b()") < out.index("float a()")
    assert '#include "stdcycles.h"' in out
    assert '#include "rm_' not in out
    with pytest.raises(FileNotFoundError):
        oslutil.inline_includes('#include "rm_missing.h"\n', tmp_path)


def test_osl_dir_is_the_backend_shader_folder():
    from addon.backends.osl import compile as oslutil

    assert oslutil.osl_dir() == (Path(__file__).resolve().parent.parent / "addon" / "backends"
                                 / "osl" / "shaders")
    assert (oslutil.osl_dir() / "rm_library.h").is_file()


# --------------------------------------------------------------------------
# closure facts of docs/cycles-closures.md

MICROFACET = """
    #include "stdcycles.h"
    shader t_microfacet(float AX = 0.3, float AY = 0.3, vector Tangent = vector(1, 0, 0),
                        output closure color Out = 0)
    {
        Out = microfacet("ggx", N, Tangent, AX, AY, 0.0, 0);
    }
"""


@pytest.mark.parametrize("ax,ay", [(0.2, 0.2), (0.5, 0.5), (1.0, 1.0), (0.2, 0.6)])
def test_osl_microfacet_ggx_is_ggx_smith_with_alpha_as_given(bpy, tmp_path, ax, ay):
    mat, _ = osl_material(bpy, tmp_path, "t_microfacet", MICROFACET, tangent=True, AX=ax, AY=ay)
    g, img, stats = measure(bpy, mat, lambda wi, wo, n, t: ggx_smith(wi, wo, n, t, ax, ay)[:, None])
    print(f"OSL microfacet ggx ax={ax} ay={ay}: {stats}")
    assert stats["max_rel_error"] < 1e-4


CONDUCTOR = """
    #include "stdcycles.h"
    shader t_conductor(float A = 0.3, vector Tangent = vector(1, 0, 0),
                       color Ior = color(1.2, 0.9, 0.2), color K = color(7.0, 6.0, 2.5),
                       output closure color Out = 0)
    {
        Out = conductor_bsdf(N, Tangent, A, A, Ior, K, "ggx");
    }
"""

DIELECTRIC = """
    #include "stdcycles.h"
    shader t_dielectric(float A = 0.3, vector Tangent = vector(1, 0, 0), float Ior = 1.5,
                        output closure color Out = 0)
    {
        Out = dielectric_bsdf(N, Tangent, color(1), color(0), A, A, Ior, "ggx");
    }
"""

METALS = {  # (n, k) per RGB channel
    "gold_like": ((0.18, 0.42, 1.37), (3.42, 2.35, 1.77)),
    "aluminium_like": ((1.35, 0.97, 0.62), (7.47, 6.4, 5.3)),
    "low_k": ((1.5, 2.0, 2.5), (0.3, 0.6, 1.0)),
    "k_near_zero": ((2.5, 3.0, 4.0), (0.01, 0.1, 0.2)),
}


THETA_D = (10.0, 45.0, 70.0, 80.0)  # angle(L, H): one per render (see gonio)


def fresnel_measure(bpy, mat, n_, k_, a, theta_d):
    light = gonio.light_for_half_angle(theta_d, azimuth_deg=30.0)
    # tiles around H (tilt theta_d toward azimuth 30), facing both L and E
    tilts = [t for t in np.linspace(theta_d - 25.0, theta_d + 8.0, 6) if 0.0 <= t < 88.0]
    tiles = gonio.hemisphere_tiles(tilts, (0.0, 30.0, 60.0), twist_deg=20.0)

    def expected(wi, wo, n, t):
        h = gonio.normalize(wi + wo)
        return ggx_smith(wi, wo, n, t, a, a)[:, None] * fresnel_exact(dot(wi, h), n_, k_)

    g, img, stats = measure(bpy, mat, expected, light=light, tiles=tiles, resolution=128)
    assert g.lit.sum() > 100
    return stats


@pytest.mark.parametrize("theta_d", THETA_D)
@pytest.mark.parametrize("metal", sorted(METALS))
def test_conductor_bsdf_is_exact_fresnel_times_ggx(bpy, tmp_path, metal, theta_d):
    n_, k_ = METALS[metal]
    a = 0.3
    mat, _ = osl_material(bpy, tmp_path, "t_conductor", CONDUCTOR, tangent=True,
                          A=a, Ior=n_, K=k_)
    stats = fresnel_measure(bpy, mat, n_, k_, a, theta_d)
    print(f"conductor_bsdf {metal} theta_d={theta_d} (Blender {bpy.app.version_string}): "
          f"max rel {stats['max_rel_error']:.2e}, rms rel {stats['rms_rel_error']:.2e}")
    if bpy.app.version >= (5, 0):
        assert stats["max_rel_error"] < 1e-4
    else:  # 4.5 approximates the complex Fresnel: up to 31 % off for low k (measured)
        assert stats["max_rel_error"] < 0.5


@pytest.mark.parametrize("theta_d", THETA_D)
@pytest.mark.parametrize("ior", [1.5, 2.4, 0.7])
def test_dielectric_bsdf_reflection_is_exact_fresnel_times_ggx(bpy, tmp_path, ior, theta_d):
    a = 0.3
    mat, _ = osl_material(bpy, tmp_path, "t_dielectric", DIELECTRIC, tangent=True, A=a, Ior=ior)
    stats = fresnel_measure(bpy, mat, [ior] * 3, [0.0] * 3, a, theta_d)
    print(f"dielectric_bsdf ior={ior} theta_d={theta_d}: max rel {stats['max_rel_error']:.2e}")
    assert stats["max_rel_error"] < 1e-4


SCHLICK = """
    #include "stdcycles.h"
    shader t_schlick(float A = 0.3, vector Tangent = vector(1, 0, 0),
                     color F0 = color(0.04, 0.5, 0.9), color F90 = color(1.0, 0.9, 0.8),
                     float Exponent = 5.0, output closure color Out = 0)
    {
        Out = generalized_schlick_bsdf(N, Tangent, color(1), color(0), A, A, F0, F90,
                                       Exponent, "ggx");
    }
"""


@pytest.mark.parametrize("theta_d", THETA_D)
def test_generalized_schlick_bsdf_is_schlick_times_ggx(bpy, tmp_path, theta_d):
    a, f0, f90, p = 0.3, np.array([0.04, 0.5, 0.9]), np.array([1.0, 0.9, 0.8]), 5.0
    mat, _ = osl_material(bpy, tmp_path, "t_schlick", SCHLICK, tangent=True, A=a)
    light = gonio.light_for_half_angle(theta_d, azimuth_deg=30.0)
    tilts = [t for t in np.linspace(theta_d - 25.0, theta_d + 8.0, 6) if 0.0 <= t < 88.0]
    tiles = gonio.hemisphere_tiles(tilts, (0.0, 30.0, 60.0))

    def expected(wi, wo, n, t):
        c = dot(wi, gonio.normalize(wi + wo))[:, None]
        return ggx_smith(wi, wo, n, t, a, a)[:, None] * (f0 + (f90 - f0) * (1.0 - c) ** p)

    g, img, stats = measure(bpy, mat, expected, light=light, tiles=tiles, resolution=128)
    print(f"generalized_schlick_bsdf theta_d={theta_d}: max rel {stats['max_rel_error']:.2e}")
    assert stats["max_rel_error"] < 1e-4


TRACE = """
    #include "stdcycles.h"
    shader t_trace(vector Light = vector(0, 0, 1), float MinDist = 1e-5,
                   output closure color Out = 0)
    {
        int hit = MinDist > 0.0 ? trace(P, normalize(Light), "mindist", MinDist)
                                : trace(P, normalize(Light));
        Out = (hit ? color(0) : color(1)) * emission();
    }
"""


@pytest.mark.parametrize("mindist", [1e-5, 0.0])
def test_osl_trace_finds_the_shadows(bpy, tmp_path, mindist):
    mat, _ = osl_material(bpy, tmp_path, "t_trace", TRACE, Light=tuple(LOW_LIGHT), MinDist=mindist)
    g = gonio.build_gonio_scene(mat, light_dir=LOW_LIGHT, resolution=128, name=mat.name)
    img = gonio.render(g)[..., 0]
    lit_wrong = np.count_nonzero(g.mask & (img != 1.0))
    dark_wrong = np.count_nonzero(g.inside & g.umbra & (img != 0.0))
    print(f"trace mindist={mindist}: {g.mask.sum()} unshadowed, {g.umbra.sum()} in umbra, "
          f"wrong: {lit_wrong} + {dark_wrong}")
    assert g.umbra.sum() > 100
    assert lit_wrong == 0 and dark_wrong == 0


NAN_WEIGHTS = """
    #include "stdcycles.h"
    shader t_nan(int Mode = 0, float Big = 1e30, output closure color Out = 0)
    {
        float inf = Big * Big;   // not folded at compile time: Big is a parameter
        float nan = inf - inf;
        if (Mode == 0) Out = nan * diffuse(N) + 0.5 * emission();
        if (Mode == 1) Out = color(nan, 1, 1) * diffuse(N) + 0.5 * emission();
        if (Mode == 2) Out = inf * diffuse(N) + 0.5 * emission();
        if (Mode == 3) Out = nan * emission() + 0.5 * emission();
        if (Mode == 4) Out = (isnan(nan) && isinf(inf) ? 1.0 : 0.0) * emission();
    }
"""


def test_non_finite_closure_weights(bpy, tmp_path):
    """A BSDF closure whose weight is NaN or inf in every channel is dropped;
    a NaN in one channel drops that channel but leaves the others unreliable;
    an emission that sums to NaN makes the whole emission 0."""
    mat, node = osl_material(bpy, tmp_path, "t_nan", NAN_WEIGHTS)
    lambert_grey = lambert((1.0, 1.0, 1.0))
    expected = {
        0: lambda *a: np.full((len(a[0]), 3), 0.5),
        2: lambda *a: np.full((len(a[0]), 3), 0.5),
        3: lambda *a: np.zeros((len(a[0]), 3)),
        4: lambda *a: np.ones((len(a[0]), 3)),  # the NaN really is one
    }
    for mode, fn in expected.items():
        node.inputs["Mode"].default_value = mode
        g, img, stats = measure(bpy, mat, fn, resolution=64)
        print(f"NaN mode {mode}: max abs error {stats['max_abs_error']:.2e}")
        assert np.isfinite(img).all()
        assert stats["max_abs_error"] < 1e-6, mode

    node.inputs["Mode"].default_value = 1  # color(nan, 1, 1) * diffuse(N)
    g, img, _ = measure(bpy, mat, lambert_grey, resolution=64)
    assert np.isfinite(img).all()
    assert np.all(img[g.mask][:, 0] == 0.5)  # red: the diffuse is dropped
    grey = g.expected(lambert_grey)[g.lit][:, 1]
    ratio = (img[g.lit][:, 1] - 0.5) / grey
    print(f"NaN in red only: green/Lambert from {ratio.min():.3f} to {ratio.max():.3f}, "
          f"{np.mean(np.abs(ratio - 1) > 1e-4):.1%} of pixels off")
    assert ratio.min() > 1 - 1e-4  # green and blue are never too dark ...


# --------------------------------------------------------------------------
# furnace and timing

@pytest.mark.parametrize("albedo", [1.0, 0.5])
def test_furnace_gives_back_diffuse_albedo(bpy, albedo):
    mat, tree, out = new_material(bpy, f"furnace_{albedo}")
    node = tree.nodes.new("ShaderNodeBsdfDiffuse")
    node.inputs["Color"].default_value = (albedo, albedo, albedo, 1.0)
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    f = furnace.build_furnace_scene(mat, resolution=96, samples=16, name=mat.name)
    img = furnace.render(f)
    mean = f.mean(img)
    _, by_angle, counts = f.albedo_by_angle(img, bins=4)
    print(f"furnace albedo {albedo}: mean {mean}, by angle {by_angle[:, 0]}, "
          f"{f.last_render_seconds:.2f} s")
    np.testing.assert_allclose(mean, albedo, rtol=2e-3)
    filled = counts > 20  # the outermost ring may be eroded away
    assert filled.sum() >= 3
    np.testing.assert_allclose(by_angle[filled], albedo, rtol=1e-2)
    assert np.all(img[f.mask] <= 1.0 + 0.05)  # per-pixel noise stays small


def test_render_time(bpy, tmp_path):
    """Wall time of gonio renders (printed), native and OSL; a loose bound
    only catches a scene that stopped being trivial to render."""
    mat, tree, out = new_material(bpy, "timing")
    node = tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    osl_mat, _ = osl_material(bpy, tmp_path, "t_microfacet", MICROFACET, tangent=True)
    for m in (mat, osl_mat):
        for res in (64, 256):
            g = gonio.build_gonio_scene(m, light_dir=LIGHT, resolution=res, name=f"time_{res}")
            gonio.render(g)  # the first render of a kind loads kernels
            g.render()
            print(f"{'OSL' if g.scene.cycles.shading_system else 'SVM'} {res}x{res}: "
                  f"{g.last_render_seconds * 1000:.0f} ms")
            assert g.last_render_seconds < 20


def test_the_reference_benchmarks_working_memory_is_what_numpy_allocates():
    """``make bench``'s memory column for the reference: a temporary of
    8 MB counts, the result does not; and the reference, which evaluates a
    batch slice by slice, needs no more for 40 slices than for 4 (its
    working memory does not grow with the batch)."""
    from addon import reference
    from addon.core.reference import CHUNK
    from verification.bench.reference import GROWTH_MB, _directions, working_memory

    def temporary(a, b):
        scratch = np.ones(1_000_000)  # 8 MB, freed on return
        return a[:, 0] + scratch[0]
    wi, wo = _directions(40 * CHUNK, np.random.default_rng(3))
    measured = working_memory(temporary, wi, wo)
    assert 8e6 <= measured < 8e6 + 1e5  # the scratch, plus the few small arrays numpy makes

    def shade(a, b):
        return reference.shade("microfacet", a, b, distribution="gaussian", fresnel="conductor",
                               ior=(1.47, 0.96, 0.62), k=(7.8, 6.7, 5.5))
    small = working_memory(shade, wi[:4 * CHUNK], wo[:4 * CHUNK])
    large = working_memory(shade, wi, wo)
    print(f"reference working memory: {small / 1e6:.1f} MB for 4 slices, "
          f"{large / 1e6:.1f} MB for 40")
    # the bench's own allowance (1 MB): the slices' temporaries are freed before the next slice
    assert large <= small + GROWTH_MB * 1e6


def test_render_benchmark_runs_every_kind_of_row(bpy, capsys):
    """``make bench``'s render table at a toy size: every kind of row (a
    native floor, a model in both modes) renders and is reported.  Speed is
    printed by ``make bench``, never asserted in a test."""
    from addon import api
    from verification.bench import render as bench_render

    rows = [row for row in bench_render.ROWS if row[1] is None and "anisotropic" in row[2]]
    rows += [row for row in bench_render.ROWS if row[1] is None and "hair" in row[2]]
    rows += [("ward", "ward", {})]
    n_materials = len(bpy.data.materials)
    results = bench_render.bench(api, resolution=16, samples=1, frames=2, rounds=1, rows=rows)
    # a model's row twice: with OSL, and the native nodes with OSL off
    assert [r["label"] for r in results] == [rows[0][0], rows[1][0], "ward",
                                            "ward" + bench_render.NATIVE]
    assert set(results[0]) == set(results[1]) == {"label", "path_traced"}
    assert set(results[2]) == set(results[3]) == {"label", "path_traced", "exact"}
    for row in results:
        for mode in ("path_traced", "exact"):
            if mode in row:
                med, lo, hi = row[mode]["ratio"]
                assert 0.0 < lo <= med <= hi < float("inf")
    # the benchmark cleans up after itself (the extension's shader texts stay)
    assert len(bpy.data.materials) == n_materials
    assert not [t.name for t in bpy.data.texts if t.name.startswith("bench ")]
    bench_render.print_table(results, resolution=16, samples=1, frames=2, rounds=1)
    table = capsys.readouterr().out
    assert "native aniso" in table and "hair_reflection+GGX alone" in table and "ward" in table
    assert "ward" + bench_render.NATIVE in table
    assert "<= 1.15x with OSL" in table and "<=0.7" in table and "<= 1.3x" in table


def test_instruction_counts_pair_each_frame_with_its_dump(tmp_path):
    """``make bench``'s instruction table: callgrind writes dump k at the
    k-th mark, holding the instructions since the previous one; the count of
    a material is the dump written after its last frame.  Checked on
    hand-written dumps (running callgrind takes minutes: ``make bench``)."""
    import json

    from verification.bench import count as bench_count

    marks = []
    for label, mode in (("base", "path_traced"), ("m", "path_traced"), ("m", "exact")):
        for frame in (1, 2):
            marks += [[label, mode, frame, "pre"], [label, mode, frame, "post"]]
    (tmp_path / "marks").write_text("".join(json.dumps(m) + "\n" for m in marks))
    for k in range(1, len(marks) + 1):  # dump k: summary 1000 * k
        (tmp_path / f"cg.{k}").write_text(f"version: 1\nevents: Ir\nsummary: {1000 * k}\n")
    (tmp_path / "cg").write_text("summary: 5\n")  # the dump at exit is not a frame
    counts = bench_count.frame_counts(tmp_path / "marks", str(tmp_path / "cg"))
    assert counts == {("base", "path_traced"): 4000, ("m", "path_traced"): 8000,
                      ("m", "exact"): 12000}
    (tmp_path / f"cg.{len(marks) + 1}").write_text("summary: 1\n")  # another caller
    with pytest.raises(RuntimeError, match="marks but"):
        bench_count.frame_counts(tmp_path / "marks", str(tmp_path / "cg"))
    with pytest.raises(RuntimeError, match="no dump"):
        bench_count.frame_counts(tmp_path / "marks", str(tmp_path / "none"))


def test_instruction_count_renders_mark_every_frame(bpy, tmp_path):
    """The process that callgrind watches renders the native baseline, then
    each material two frames, and marks before and after every frame in that
    order; it leaves no material or scene behind."""
    import json

    from addon import api
    from verification.bench import count as bench_count
    from verification.bench import render as bench_render

    n_materials, n_scenes = len(bpy.data.materials), len(bpy.data.scenes)
    marks_path = tmp_path / "marks"
    bench_count.render_marked(api, [("lambert", "lambert", {})], marks_path,
                              resolution=8, samples=1)
    marks = [json.loads(line) for line in marks_path.read_text().splitlines()]
    expected = []
    native = "lambert" + bench_render.NATIVE  # the native nodes, OSL off
    for label, mode in ((bench_count.BASELINE, "path_traced"), ("lambert", "path_traced"),
                        ("lambert", "exact"), (native, "path_traced"), (native, "exact")):
        for frame in (1, 2):
            expected += [[label, mode, frame, "pre"], [label, mode, frame, "post"]]
    assert marks == expected
    assert (len(bpy.data.materials), len(bpy.data.scenes)) == (n_materials, n_scenes)


def test_the_report_shows_a_tolerance_to_its_own_digits():
    """0.025 (the fitted mixtures' bound) was shown as 3e-02 in the report."""
    from report.pages import fmt
    assert fmt(0.025, "tol") == "2.5e-02"
    assert fmt(1e-4, "tol") == "1e-04" and fmt(3e-3, "tol") == "3e-03"
    assert fmt(None, "tol") == "—"
