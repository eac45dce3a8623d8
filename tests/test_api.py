# SPDX-License-Identifier: GPL-3.0-or-later
"""The scripting API (``addon.api``): add_model in both modes on the
gonioreflectometer, validation, set_params, enable_osl, and bind_light
(simple-expression drivers that follow a sun or a point lamp, measured
against Cycles' own lamps, and kept across save and reload in a fresh
process).

Parametrised over the catalogue.  Measured numbers are printed (``pytest -s``).
"""

import math
from pathlib import Path

import numpy as np
import pytest

from addon import catalogue
from verification import harness as common
from verification.scenes import gonio
from verification.scenes.lit import move_to_collection
from verification.harness import session as bpy_env

REPO_ROOT = Path(__file__).resolve().parent.parent
LIGHT = gonio.normalize((0.3, 0.2, 0.93))
RES = 32


@pytest.fixture
def api(bpy):
    bpy_env.reset_scene()
    from addon import api as module
    return module


def new_material(bpy, name="M"):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True  # Blender < 5.0
    return mat


def surface_link(mat):
    out = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"
               and n.is_active_output)
    (link,) = out.inputs["Surface"].links
    return link


def euler_toward(direction):
    """An XYZ Euler rotation whose +Z axis is ``direction``."""
    from mathutils import Vector
    return Vector(direction).to_track_quat("Z", "Y").to_euler("XYZ")


# ---------------------------------------------------------------------------
# add_model

@pytest.mark.parametrize("mode", ["path_traced", "exact"])
@pytest.mark.parametrize("name", catalogue.names())
def test_every_model_renders_finite_non_black_pixels(api, bpy, name, mode):
    mat = new_material(bpy)
    node = api.add_model(mat, name, mode=mode)
    g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=RES)
    if mode == "exact":
        api.bind_light(node, g.sun)
    img = g.render()
    assert np.isfinite(img).all()
    assert img[g.mask].max() > 1e-3, f"{name} {mode}: black"


EXACT_CASES = [
    ("lambert", {"albedo": (0.2, 0.5, 0.7)}),
    ("phong", {"exponent": 7.0, "ks": 0.6, "normalization": "energy"}),
    ("blinn_phong", {"exponent": 12.0, "ks": (0.9, 0.5, 0.2)}),
    ("microfacet", {"distribution": "trowbridge_reitz", "alpha": 0.3, "fresnel": "conductor",
                    "ior": catalogue.METALS["gold"][0], "k": catalogue.METALS["gold"][1]}),
    ("microfacet", {"distribution": "beckmann", "alpha_x": 0.4, "alpha_y": 0.15,
                    "shadowing": "smith_correlated"}),
    ("microfacet", {"distribution": "blinn", "beta": 0.3, "shadowing": "vgroove",
                    "fresnel": "dielectric", "ior": 1.8}),
    ("cook_torrance", {"beta": 0.25, "ks": 0.7}),
    ("ward", {"alpha_x": 0.25, "alpha_y": 0.1, "ks": 0.5}),
    ("kajiya_kay", {"exponent": 10.0, "kd": (0.3, 0.2, 0.1)}),
]


@pytest.mark.parametrize("name, params", EXACT_CASES,
                         ids=[f"{n}-{i}" for i, (n, _p) in enumerate(EXACT_CASES)])
def test_exact_mode_renders_the_reference_for_the_parameters_given(api, bpy, name, params):
    """End to end: the API's values (radians, RGB, enums, widths) reach the
    shader; the Direct output under a bound sun equals addon.reference."""
    mat = new_material(bpy)
    node = api.add_model(mat, name, mode="exact", **params)
    g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=48)
    api.bind_light(node, g.sun)
    stats = common.compare(g.render(), g.reference(name, **params), g.mask)
    print(f"\n{name} {params}: max rel {stats['max_rel_error']:.2e}")
    assert stats["max_rel_error"] < 1e-4, stats


def test_add_model_wires_the_chosen_output_and_leaves_the_scene_alone(api, bpy):
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_EEVEE_NEXT" if bpy.app.version < (5, 0) else "BLENDER_EEVEE"
    before = (scene.render.engine, scene.cycles.shading_system, scene.cycles.device)

    mat = new_material(bpy, "path")
    node = api.add_model(mat, "phong", exponent=5.0, ks=(0.1, 0.2, 0.3),
                         normalization="energy")
    assert node.node_tree.name == "RM Phong (Energy)"
    assert node.inputs["Exponent"].default_value == pytest.approx(5.0)
    assert tuple(node.inputs["Specular"].default_value) == pytest.approx((0.1, 0.2, 0.3, 1.0))
    link = surface_link(mat)
    assert link.from_node == node and link.from_socket.name == "BSDF"
    assert mat.cycles.emission_sampling != "NONE"

    mat = new_material(bpy, "exact")
    node = api.add_model(mat, "phong", mode="exact")
    assert node.inputs["Exponent"].default_value == pytest.approx(20.0)  # catalogue default
    link = surface_link(mat)
    assert link.from_node == node and link.from_socket.name == "Direct"
    assert mat.cycles.emission_sampling == "NONE"

    assert (scene.render.engine, scene.cycles.shading_system, scene.cycles.device) == before


def test_width_and_presets_choose_the_variant(api, bpy):
    mat = new_material(bpy)
    node = api.add_model(mat, "microfacet", distribution="trowbridge_reitz", alpha=0.3)
    assert node.node_tree.name == "RM Microfacet (GGX, Smith, None, Alpha)"
    assert node.inputs["Roughness"].default_value == pytest.approx(0.3)
    assert "Half-Angle" not in node.inputs and "Roughness X" not in node.inputs

    node = api.add_model(mat, "microfacet", beta=math.radians(20))
    assert node.node_tree.name == "RM Microfacet (Beckmann, Smith, None)"
    assert node.inputs["Half-Angle"].default_value == pytest.approx(math.radians(20))

    node = api.add_model(mat, "torrance_sparrow")
    assert node.node_tree.name == "RM Microfacet (Gaussian, V-Groove, Dielectric)"
    assert node.label == "Torrance-Sparrow 1967"


@pytest.mark.parametrize("model, kwargs, match", [
    ("nope", {}, "allowed: lambert, phong"),
    ("phong", {"shininess": 3}, "allowed: exponent, ks, normalization"),
    ("phong", {"exponent": -1.0}, r"exponent must be a number in \[0, 10000\]"),
    ("phong", {"normalization": "unit"}, "one of 'none', 'energy'"),
    ("lambert", {"albedo": (0.5, 0.5)}, "albedo"),
    ("phong", {"exponent": [1.0, 2.0]}, "one number"),
    ("lambert", {"albedo": [[0.1, 0.2, 0.3]] * 2}, "one RGB colour"),
    ("cook_torrance", {"distribution": "blinn"}, "fixed"),
    ("microfacet", {"distribution": "blinn", "alpha": 0.3}, "native widths"),
    ("microfacet", {"beta": 0.2, "alpha": 0.3}, "give one width"),
    ("microfacet", {"beta": 2.0}, r"rad \(85 deg\)"),
    ("lambert", {"mode": "fast"}, "'path_traced', 'exact'"),
])
def test_add_model_rejects_bad_arguments(api, bpy, model, kwargs, match):
    mat = new_material(bpy)
    n_nodes = len(mat.node_tree.nodes)
    with pytest.raises(ValueError, match=match):
        api.add_model(mat, model, **kwargs)
    assert len(mat.node_tree.nodes) == n_nodes


def test_add_model_needs_a_material(api, bpy):
    world = bpy.data.worlds.new("rm_not_a_material")
    try:
        for target in (None, world, "Material"):
            with pytest.raises(ValueError, match="needs a material"):
                api.add_model(target, "lambert")
    finally:
        bpy.data.worlds.remove(world)


def test_the_scene_functions_default_to_the_context_scene(api, bpy):
    assert api.rendering_backend() == api.rendering_backend(bpy.context.scene)
    assert api.osl_status() == api.osl_status(bpy.context.scene)
    # anything else than a scene: a ValueError saying what they take (was an AttributeError)
    for call in (api.rendering_backend, api.osl_status, api.enable_osl):
        for wrong in ("Scene", new_material(bpy)):
            with pytest.raises(ValueError, match="takes a scene"):
                call(wrong)


def test_set_params_changes_values_and_variant(api, bpy):
    mat = new_material(bpy)
    node = api.add_model(mat, "microfacet", distribution="trowbridge_reitz", alpha=0.3)
    api.set_params(node, ks=0.5)
    assert node.node_tree.name.endswith("Alpha)")  # width mode kept
    assert tuple(node.inputs["Specular"].default_value)[:3] == pytest.approx((0.5,) * 3)
    api.set_params(node, alpha_x=0.2, alpha_y=0.1, fresnel="dielectric")
    assert node.node_tree.name == \
        "RM Microfacet (GGX, Smith, Dielectric, Alpha XY)"
    assert node.inputs["Roughness X"].default_value == pytest.approx(0.2)
    assert tuple(node.inputs["Specular"].default_value)[:3] == pytest.approx((0.5,) * 3)
    assert surface_link(mat).from_node == node
    with pytest.raises(ValueError, match="native widths"):
        api.set_params(node, distribution="gaussian")


WIDTHS = ("beta", "alpha", "alpha_x", "alpha_y")


def _random_calls(api, rng, pool, node, lamps, state):
    """Two to six API calls on ``node`` drawn by ``rng`` (set_params with a
    whole parameter set or a part of one from ``pool``, set_mode,
    bind_light, unbind_light, another backend), each refused call
    (a ValueError: a part giving a width the distribution does not take,
    say) changing nothing.  ``state``: the start's ``(params given, mode,
    backend, bound lamps)``; returns the end's."""
    params, mode, backend, bound = state
    for _step in range(rng.randint(2, 6)):
        op = rng.choice(["params", "part", "mode", "bind", "unbind", "backend"])
        if op in ("params", "part"):
            new = dict(rng.choice(pool))
            if op == "part":
                keys = [k for k in new if rng.random() < 0.4]
                if any(k in WIDTHS for k in keys):  # a width is given whole
                    keys = [k for k in keys if k not in WIDTHS] + [k for k in new if k in WIDTHS]
                new = {k: new[k] for k in keys}
            try:
                api.set_params(node, **new)
            except ValueError:
                continue
            if any(k in WIDTHS for k in new):
                params = {k: v for k, v in params.items() if k not in WIDTHS}
            params = {**params, **new}
        elif op == "mode":
            mode = rng.choice(list(api.MODES))
            api.set_mode(node, mode)
        elif op == "bind":
            bound = rng.sample(lamps, rng.randint(1, len(lamps)))
            api.bind_light(node, *bound)
        elif op == "unbind":
            api.unbind_light(node)
            bound = []
        else:
            backend = rng.choice(api.BACKENDS)
            api.set_params(node, backend=backend)
    return params, mode, backend, bound


def test_a_node_taken_through_random_calls_renders_as_one_made_with_its_end_state(api, bpy):
    """Held out (seeded): a node of a random model and parameters is taken
    through random API calls (:func:`_random_calls`: parameters and
    variants, modes, backends, lamps bound and unbound), then a node made
    at once with the end state (``add_model`` with the parameters given
    last, the mode and backend, ``bind_light`` with the lamps) must be the
    same group and render the same to the bit on the gonio under four
    lamps, with OSL on and off (the same group and socket values: Cycles
    is deterministic).  Unbinding leaves the Light inputs at the lamp's
    last values, so an unbound node's are copied to the new one."""
    import random

    from addon import groups, lighting
    from verification.scenes import lit
    from verification.suites import cases

    rng = random.Random(43)
    pool = {}
    for case in cases.random_cases(n_microfacet=20, n_other=6, seed=43):
        pool.setdefault(case.model, []).append(case.params)
    g = gonio.build_gonio_scene(None, light_dir=LIGHT, resolution=RES, osl=True, name="calls")
    lamps = [g.sun] + [lit.add_lamp(g.scene, lamp, f"calls {lamp.kind}") for lamp in (
        lit.Lamp("POINT", position=(1.0, -0.5, 3.0), strength=3.0),
        lit.Lamp("SPOT", position=(-0.5, 0.5, 3.0), direction=(0.1, -0.1, 1.0), strength=4.0,
                 size=1.5, blend=0.3),
        lit.Lamp("SUN", direction=(-0.6, 0.3, 0.75), strength=0.7, color=(1.0, 0.6, 0.3)))]
    slots = g.tiles_object.data.materials
    seen = set()
    for trial in range(12):
        model = rng.choice(sorted(pool))
        params = dict(rng.choice(pool[model]))
        mode, backend = rng.choice(list(api.MODES)), rng.choice(api.BACKENDS)
        mat, made = new_material(bpy, f"calls {trial}"), new_material(bpy, f"made {trial}")
        node = api.add_model(mat, model, mode=mode, backend=backend, **params)
        params, mode, backend, bound = _random_calls(api, rng, pool[model], node, lamps,
                                                     (params, mode, backend, []))
        direct = api.add_model(made, model, mode=mode, backend=backend, **params)
        if bound:
            api.bind_light(direct, *bound)
        for name in lighting.LIGHT_NAMES:  # an unbound node keeps the lamp's last values
            try:
                value = groups.input_socket(node, lighting.socket_name(name, 1)).default_value
            except KeyError:
                continue
            groups.input_socket(direct, lighting.socket_name(name, 1)).default_value = value
        assert direct.node_tree == node.node_tree, (trial, model)
        for osl in (True, False):
            g.scene.cycles.shading_system = osl
            images = []
            for material in (mat, made):
                if slots:
                    slots[0] = material
                else:
                    slots.append(material)
                images.append(g.render())
            assert np.isfinite(images[0]).all()
            assert np.array_equal(images[0], images[1]), (trial, model, osl, params, mode)
        seen |= {model, mode, backend, len(bound)}
        api.unbind_light(node)
        api.unbind_light(direct)
        slots[0] = None
        bpy.data.materials.remove(mat)
        bpy.data.materials.remove(made)
    # the draw reached several models, every mode and backend, bound and unbound nodes
    assert {"path_traced", "exact", "hybrid", "auto", "osl", "native", 0} <= seen, seen
    assert len(seen & set(pool)) >= 4, seen


def test_ensure_groups_builds_every_default_variant_once(api, bpy):
    groups = api.ensure_groups()
    assert sorted(groups) == sorted(catalogue.MODELS)
    from addon import groups as nodes
    for model_id, tree in groups.items():
        assert tree.name == nodes.group_name(model_id)
    n_groups = len(bpy.data.node_groups)
    assert api.ensure_groups() == groups and len(bpy.data.node_groups) == n_groups


def test_enable_osl_and_osl_status(api, bpy):
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"
    problems, _warnings = api.osl_status(scene)
    assert problems and "Cycles" in problems[0]
    assert api.enable_osl(scene) == scene
    assert api.osl_status(scene) == ([], [])
    assert (scene.render.engine, scene.cycles.device, scene.cycles.shading_system) == \
        ("CYCLES", "CPU", True)
    scene.cycles.shading_system = False
    assert api.osl_status(scene)[0] == ["Open Shading Language is off"]


# ---------------------------------------------------------------------------
# bind_light

def test_bound_sun_drivers_are_simple_and_follow_the_rotation(api, bpy):
    mat = new_material(bpy)
    params = {"exponent": 30.0}
    node = api.add_model(mat, "phong", mode="exact", **params)
    g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=RES)
    g.sun.data.energy = 2.0
    g.sun.data.color = (1.0, 0.5, 0.25)
    api.bind_light(node, g.sun)

    fcurves = api.light_drivers(node)
    # direction xyz, strength, shadows (the lamp's Cast Shadow), colour rgb
    assert len(fcurves) == 3 + 1 + 1 + 3
    assert all(fc.driver.is_simple_expression and fc.driver.is_valid for fc in fcurves)
    assert api.bound_light(node) == g.sun
    assert node.inputs["Point Light"].default_value == 0.0
    tint = np.array([1.0, 0.5, 0.25]) * 2.0

    first = g.render()
    stats = common.compare(first, g.reference("phong", **params) * tint, g.mask)
    assert stats["max_rel_error"] < 1e-3, stats

    new_dir = gonio.normalize((-0.4, 0.35, 0.85))
    g.sun.rotation_euler = euler_toward(new_dir)
    moved = gonio.plan_gonio(light_dir=new_dir, resolution=RES)
    second = g.render()
    stats = common.compare(second, moved.reference("phong", **params) * tint, moved.mask)
    print(f"\nsun rotated: max rel {stats['max_rel_error']:.2e}")
    assert stats["max_rel_error"] < 1e-3, stats
    assert np.abs(second - first).max() > 0.1  # the highlight moved

    # Disable in Renders: Cycles renders no such lamp, and neither does exact mode
    # (the bound node lit the tiles as before until its strength followed it)
    g.sun.hide_render = True
    assert not g.render()[g.mask].any()
    g.sun.hide_render = False
    assert np.array_equal(g.render(), second)

    api.unbind_light(node)
    assert api.light_drivers(node) == [] and api.bound_light(node) is None


@pytest.mark.parametrize("normalize", [True, False])
def test_bound_point_light_matches_cycles_point_lamp(api, bpy, normalize):
    """Lambert in exact mode vs a Diffuse BSDF lit by the same point lamp:
    Cycles' point lamp of power P has intensity P/(4 pi) W/sr (normalize on)."""
    images = {}
    for kind in ("diffuse", "exact"):
        mat = new_material(bpy, kind)
        if kind == "diffuse":
            tree = mat.node_tree
            bsdf = tree.nodes.new("ShaderNodeBsdfDiffuse")
            bsdf.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
            out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
            tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
        else:
            node = api.add_model(mat, "lambert", mode="exact", albedo=0.8)
        g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=48, name=kind)
        g.sun.data.energy = 0.0
        lamp = bpy.data.lights.new(kind, "POINT")
        lamp.energy = 500.0
        lamp.shadow_soft_size = 0.0  # a point: one sample is exact
        lamp.normalize = normalize
        lamp.color = (1.0, 0.9, 0.7)
        obj = bpy.data.objects.new(kind, lamp)
        obj.location = (0.6, -0.4, 5.0)
        g.scene.collection.objects.link(obj)
        if kind == "exact":
            api.bind_light(node, obj)
            assert node.inputs["Point Light"].default_value == 1.0
            assert all(fc.driver.is_simple_expression for fc in api.light_drivers(node))
        images[kind] = g.render()
    lit = g.mask & (images["diffuse"][..., 1] > 1e-2 * images["diffuse"].max())
    ratio = images["exact"][lit] / images["diffuse"][lit]
    print(f"\npoint lamp, normalize={normalize}: exact / Cycles = {ratio.min():.6f} .. "
          f"{ratio.max():.6f} over {lit.sum()} pixels")
    assert lit.sum() > 100
    assert ratio == pytest.approx(1.0, abs=1e-4)


def test_bind_light_rejects_other_lamps_and_nodes(api, bpy):
    mat = new_material(bpy)
    node = api.add_model(mat, "lambert", mode="exact")
    obj = bpy.data.objects.new("AREA", bpy.data.lights.new("AREA", "AREA"))
    with pytest.raises(ValueError, match="allowed: SUN, POINT, SPOT"):
        api.bind_light(node, obj)
    with pytest.raises(ValueError, match="not a light"):
        api.bind_light(node, bpy.data.objects.new("empty", None))
    other = mat.node_tree.nodes.new("ShaderNodeBsdfDiffuse")
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    with pytest.raises(ValueError, match="not a Reflection Models node"):
        api.bind_light(other, sun)
    for call in (api.bound_lights, api.bound_light, api.unbind_light, api.light_drivers):
        for wrong in (other, "node", None):
            with pytest.raises(ValueError, match="not a Reflection Models node"):
                call(wrong)
    assert api.light_drivers(node) == []


def test_bound_light_survives_save_and_reload_in_a_fresh_process(api, bpy, tmp_path):
    """The drivers are evaluated in a process with no extension and no Python
    auto-run: the sun's rotation is animated, the file is saved at frame 1
    and rendered at frame 10, where only the drivers know the direction.
    The sun is in a collection of the scene's: saved again with that
    collection excluded from the view layer, the file renders black there
    (the strength driver's context property read in that process too)."""
    mat = new_material(bpy)
    params = {"exponent": 25.0}
    node = api.add_model(mat, "phong", mode="exact", **params)
    g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=RES, name="fresh")
    rig = bpy.data.collections.new("fresh rig")
    g.scene.collection.children.link(rig)
    move_to_collection(g.sun, rig)
    api.bind_light(node, g.sun)
    end_dir = gonio.normalize((-0.35, -0.3, 0.88))
    sun = g.sun
    sun.rotation_mode = "XYZ"
    sun.rotation_euler = euler_toward(LIGHT)
    sun.keyframe_insert("rotation_euler", frame=1)
    sun.rotation_euler = euler_toward(end_dir)
    sun.keyframe_insert("rotation_euler", frame=10)
    # Blender renders a scene that is not the window's at its frame-1 pose
    # even after frame_set(10): make the gonio scene the window's.
    bpy.context.window.scene = g.scene
    g.scene.frame_set(1)
    path = tmp_path / "bound.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)

    out = tmp_path / "frame10.exr"
    report = bpy_env.render_in_fresh_process(path, out, scene=g.scene.name, frame=10)
    assert not any("reflection_models" in a for a in report["addons"])
    img = common.read_exr(out)
    moved = gonio.plan_gonio(light_dir=end_dir, resolution=RES)
    stats = common.compare(img, moved.reference("phong", **params), moved.mask)
    print(f"\nfresh process, frame 10: max rel {stats['max_rel_error']:.2e}")
    assert stats["max_rel_error"] < 1e-3, stats
    g.scene.view_layers[0].layer_collection.children[rig.name].exclude = True
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    bpy_env.render_in_fresh_process(path, out, scene=g.scene.name, frame=10)
    assert not common.read_exr(out)[moved.mask].any()


def test_use_strand_tangent_feeds_the_tangent_input_once(api, bpy):
    """The Geometry node's Tangent into the Tangent input (hair curves:
    tests/test_anisotropy.py renders it), once however often it is called,
    replacing what fed the input; a node without a Tangent input, or not
    of the extension, raises ValueError naming the variants that have one."""
    from addon import groups as nodes
    mat = new_material(bpy)
    tree = mat.node_tree
    node = api.add_model(mat, "microfacet", distribution="beckmann", alpha_x=0.2, alpha_y=0.4)
    value = tree.nodes.new("ShaderNodeCombineXYZ")
    tree.links.new(value.outputs[0], nodes.input_socket(node, "tangent"))
    geometry = api.use_strand_tangent(node)
    assert api.use_strand_tangent(node) == geometry
    (link,) = nodes.input_socket(node, "tangent").links
    assert (link.from_node, link.from_socket.name) == (geometry, "Tangent")
    assert sum(n.bl_idname == "ShaderNodeNewGeometry" for n in tree.nodes) == 1
    with pytest.raises(ValueError, match="kajiya_kay, ward, microfacet with alpha_x"):
        api.use_strand_tangent(api.add_model(mat, "microfacet", alpha=0.2))
    with pytest.raises(ValueError, match="not a Reflection Models node"):
        api.use_strand_tangent(value)


def test_apply_metal_makes_a_conductor_with_the_measured_index(api, bpy):
    """The metal preset switches the variant to the conductor Fresnel, sets
    n and k, and the exact render equals the reference for that metal."""
    from addon import groups as nodes
    mat = new_material(bpy)
    node = api.add_model(mat, "microfacet", mode="exact", distribution="trowbridge_reitz",
                         alpha=0.3)
    assert nodes.rm_info(node.node_tree)[1]["fresnel"] == "none"
    api.apply_metal(node, "gold")
    assert nodes.rm_info(node.node_tree)[1]["fresnel"] == "conductor"
    n, k = catalogue.METALS["gold"]
    assert tuple(nodes.input_socket(node, "ior").default_value)[:3] == pytest.approx(n, rel=1e-6)
    assert tuple(nodes.input_socket(node, "k").default_value)[:3] == pytest.approx(k, rel=1e-6)
    g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=48)
    api.bind_light(node, g.sun)
    expected = g.reference("microfacet", distribution="trowbridge_reitz", alpha=0.3,
                           fresnel="conductor", ior=n, k=k)
    stats = common.compare(g.render(), expected, g.mask)
    assert stats["max_rel_error"] < 1e-4, stats  # float32 shading, as for every exact render
    with pytest.raises(ValueError, match="allowed: aluminium"):
        api.apply_metal(node, "unobtainium")
    phong = api.add_model(new_material(bpy, "P"), "phong")
    with pytest.raises(ValueError, match="microfacet"):
        api.apply_metal(phong, "gold")


def test_the_sidebar_status_reads_the_nodes_width_and_fresnel(api, bpy):
    """The sidebar's words for the BSDF output follow the node's own width
    and Fresnel indices (fitting/bounds.py: per width interval and Fresnel
    class), and fall back to the variant's where a socket is linked."""
    from addon import groups as nodes
    from addon import ui
    from addon.core.formulas import models as formulas
    mat = new_material(bpy)
    node = api.add_model(mat, "microfacet", distribution="blinn", shadowing="smith_correlated",
                         fresnel="dielectric", beta=math.radians(20.0), ior=1.5)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.shading_system = True

    def status():
        return ui.bsdf_status_lines(scene, node)[0][0]
    fitted, approx = ui._STATUS_TEXT["fitted"][0], ui._STATUS_TEXT["approx"][0]
    variant = {"distribution": "blinn", "shadowing": "smith_correlated", "width_mode": "beta",
               "fresnel": "dielectric"}
    assert formulas.path_traced_status("microfacet", variant, {"beta": 0.35, "ior": 1.5}) \
        == "fitted"
    assert status() == fitted
    api.set_params(node, ior=0.8)  # a dielectric index below 1: not measured
    assert status() == approx
    api.set_params(node, ior=1.5)
    assert status() == fitted
    value = mat.node_tree.nodes.new("ShaderNodeValue")
    mat.node_tree.links.new(value.outputs[0], nodes.input_socket(node, "beta"))
    assert status() == approx  # the width unknown: with Fresnel no bound holds


def test_bsdf_accuracy_says_how_far_the_bsdf_output_is_from_the_model(api, bpy):
    """``api.bsdf_accuracy`` (and the sidebar's lines from it): the status
    with the fitter's figure where it measured one, at the node's width
    (its worst width where the width is linked), the figure on the side of
    FIT_BOUND the status says; the shaders that render the node, its own
    backend choice included; why no figure where there is none."""
    from addon import groups as nodes
    from addon import ui
    from addon.core.formulas import models as formulas
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.shading_system = True
    scene.cycles.device = "CPU"
    mat = new_material(bpy)
    node = api.add_model(mat, "microfacet", distribution="gaussian", shadowing="smith")
    at_width = []
    for deg in np.linspace(1.0, 85.0, 29):
        api.set_params(node, beta=math.radians(float(deg)))
        got = api.bsdf_accuracy(node, scene)
        assert got["backend"] == "osl" and got["note"] == formulas.AT_THIS_WIDTH, got
        error = got["max_abs_over_peak"]
        assert 0.0 < error < 1.0, (deg, got)
        assert got["status"] == ("fitted" if error <= formulas.FIT_BOUND else "approx"), got
        at_width.append(error)
    assert min(at_width) <= formulas.FIT_BOUND < max(at_width)  # both sides seen
    value = mat.node_tree.nodes.new("ShaderNodeValue")
    mat.node_tree.links.new(value.outputs[0], nodes.input_socket(node, "beta"))
    worst = api.bsdf_accuracy(node)
    assert worst["note"] == formulas.AT_WORST_WIDTH and worst["status"] == "approx"
    assert worst["max_abs_over_peak"] >= max(at_width)
    lines = ui.bsdf_status_lines(scene, node)
    assert lines[0] == ui._STATUS_TEXT["approx"]
    assert f"{worst['max_abs_over_peak']:.2g}" in lines[1][0], lines

    glass = api.add_model(mat, "microfacet", fresnel="dielectric", ior=0.8)  # not measured
    got = api.bsdf_accuracy(glass)
    assert got["status"] == "approx" and got["max_abs_over_peak"] is None
    assert "indices" in got["note"]
    brushed = api.bsdf_accuracy(api.add_model(mat, "microfacet", alpha_x=0.1, alpha_y=0.3))
    assert brushed["status"] == "approx" and brushed["max_abs_over_peak"] is None
    assert "one width" in brushed["note"]  # the fits are isotropic
    # Kajiya-Kay's two closures: measured per exponent and colour ratio
    hair = api.add_model(mat, "kajiya_kay", exponent=40.0, kd=0.2, ks=0.5)
    got = api.bsdf_accuracy(hair)
    assert got["status"] == "approx" and got["note"] == formulas.AT_THESE_SETTINGS
    # the hair lobe's peak is set to the model's times 0.95 at every exponent
    # (it was a normalised lobe, 63 times the model's peak at 1000) and a GGX
    # lobe lights the fibre's far side, where the hair lobe is 0 and the
    # model's cone 1: under 0.9 of the peak off (1.0 without it), less on
    # the view's side
    api.set_params(hair, exponent=1000.0)
    wide = api.bsdf_accuracy(hair)
    assert wide["max_abs_over_peak"] <= 0.9, wide
    for one in (got, wide):
        near = float(one["detail"].split()[0])
        assert near < one["max_abs_over_peak"] and "view's side" in one["detail"], one
    assert len(ui.bsdf_status_lines(scene, hair)) == 4  # status, figure, where, the side
    # Ward's weighted lobe: measured per cell of its widths (fitting/ward.py)
    ward = api.add_model(mat, "ward", alpha_x=0.3, alpha_y=0.08)
    got = api.bsdf_accuracy(ward)
    assert got["status"] == "approx" and got["note"] == formulas.AT_THIS_WIDTH
    assert formulas.FIT_BOUND < got["max_abs_over_peak"] < 1.0 and got["detail"] is None
    api.set_params(ward, alpha_x=0.002, alpha_y=0.004)  # narrow: near the mirror direction
    got = api.bsdf_accuracy(ward)
    assert got["status"] == "fitted" and got["max_abs_over_peak"] <= formulas.FIT_BOUND
    # a socket set out of range from Python: read as the shaders clamp it
    # (NaN to the lower limit), as the figure of the clamped width
    for bad, like in ((math.nan, 0.001), (math.inf, 1.0), (-5.0, 0.001), (50.0, 1.0)):
        nodes.input_socket(ward, "alpha_x").default_value = bad
        nodes.input_socket(ward, "alpha_y").default_value = 0.3
        got = api.bsdf_accuracy(ward)["max_abs_over_peak"]
        api.set_params(ward, alpha_x=like, alpha_y=0.3)
        assert got == api.bsdf_accuracy(ward)["max_abs_over_peak"], (bad, got)
    beta = nodes.input_socket(node, "beta")
    mat.node_tree.links.remove(beta.links[0])
    for bad in (math.nan, math.inf, -1.0):
        beta.default_value = bad
        got = api.bsdf_accuracy(node)
        assert got["note"] == formulas.AT_THIS_WIDTH and math.isfinite(got["max_abs_over_peak"])

    # Phong: OSL's phong_ramp is the model; the native nodes' Toon mixture is not
    phong = api.add_model(mat, "phong")
    assert api.bsdf_accuracy(phong)["status"] == "exact"
    assert len(ui.bsdf_status_lines(scene, phong)) == 1
    native = api.add_model(mat, "phong", backend="native")
    got = api.bsdf_accuracy(native)
    assert got["backend"] == "native" and got["status"] == "approx", got
    assert api.rendering_backend(scene)[0] == "osl"
    assert api.rendering_backend(scene, native) == ("native", "the node is set to native nodes")
    assert got["max_abs_over_peak"] > formulas.FIT_BOUND and got["note"] == \
        formulas.AT_WORST_WIDTH
    forced = api.add_model(mat, "phong", backend="osl")
    scene.cycles.shading_system = False
    assert api.bsdf_accuracy(phong)["backend"] == "native"
    got = api.bsdf_accuracy(forced)
    assert (got["backend"], got["status"]) == ("none", "none"), got
    assert "Open Shading Language is off" in got["note"]
    assert ui.bsdf_status_lines(scene, forced)[0] == ui._STATUS_TEXT["none"]
    scene.render.engine = "BLENDER_EEVEE" if bpy.app.version >= (5, 0) else "BLENDER_EEVEE_NEXT"
    got = api.bsdf_accuracy(phong)
    assert (got["backend"], got["status"], got["max_abs_over_peak"]) == \
        ("native", "approx", None) and "EEVEE" in got["note"]

    with pytest.raises(ValueError, match="not a Reflection Models node"):
        api.bsdf_accuracy(value)
    with pytest.raises(ValueError, match="takes a scene"):
        api.bsdf_accuracy(phong, "Scene")


def test_direct_accuracy_says_where_exact_mode_is_not_the_model(api, bpy):
    """``api.direct_accuracy``: the bound the checks hold exact mode to on
    the backend that renders the node (the checks' own tolerances), the
    shadow ray it has there (a ray in Cycles; screen space in EEVEE;
    none in Blender 4.5's native nodes), and the bound lamps' settings it
    does not follow, by name."""
    from verification.harness.checks import tolerance
    assert api.EXACT_MAX_REL_ERROR == tolerance("exact_mode")
    assert api.EEVEE_EXACT_MAX_ABS_OVER_PEAK == tolerance("eevee_exact")
    raycast = bpy.app.version >= (5, 0)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.shading_system = True
    scene.cycles.device = "CPU"
    mat = new_material(bpy)
    node = api.add_model(mat, "kajiya_kay", mode="exact")
    forced = api.add_model(mat, "lambert", mode="exact", backend="osl")
    sun = bpy.data.objects.new("Key", bpy.data.lights.new("Key", "SUN"))
    scene.collection.objects.link(sun)
    sun.data.angle = 0.0
    api.bind_light(node, sun)
    got = api.direct_accuracy(node)
    assert got == {"backend": "osl", "max_rel_error": 1e-4, "max_abs_over_peak": None,
                   "shadows": "ray", "notes": []}, got
    sun.data.angle = 0.1  # a sun with a size: taken as one direction
    sun.visible_diffuse = False  # Kajiya-Kay's two terms share one light
    notes = api.direct_accuracy(node)["notes"]
    assert len(notes) == 2 and all(n.startswith("Key: ") for n in notes), notes
    assert "size ignored" in notes[0] and "ray visibility" in notes[1]
    scene.cycles.shading_system = False
    got = api.direct_accuracy(node)
    assert (got["backend"], got["shadows"]) == ("native", "ray" if raycast else "none")
    got = api.direct_accuracy(forced)
    assert (got["backend"], got["shadows"], got["max_rel_error"]) == ("none", None, None)
    assert "Open Shading Language is off" in got["notes"][0]
    scene.render.engine = "BLENDER_EEVEE" if raycast else "BLENDER_EEVEE_NEXT"
    got = api.direct_accuracy(node)
    assert (got["backend"], got["max_rel_error"], got["max_abs_over_peak"], got["shadows"]) \
        == ("native", None, 3e-3, "screen_space" if raycast else "none"), got
    with pytest.raises(ValueError, match="not a Reflection Models node"):
        api.direct_accuracy(sun)


def test_add_model_compiles_osl_in_a_plain_bpy_process(tmp_path):
    """A script that imports the ``bpy`` module (the pip wheel) and nothing
    else: there Cycles' ``oslquery`` does not import (Blender's bundled
    site-packages are off ``sys.path``), and the extension puts them on it
    before it compiles its shaders (``addon/backends/osl/compile.py``)."""
    import os
    import subprocess
    import sys

    code = (
        "import bpy\n"
        "try:\n"
        "    import oslquery\n"
        "    print('oslquery importable before')\n"
        "except ImportError:\n"
        "    pass\n"
        "from addon import api\n"
        "mat = bpy.data.materials.new('m')\n"
        "node = api.add_model(mat, 'phong')\n"
        "scripts = [n for n in node.node_tree.nodes if n.type == 'SCRIPT']\n"
        "print('scripts', len(scripts) > 0 and all(len(n.bytecode) > 0 for n in scripts))\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONSTARTUP")}
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1])
    for var, sub in bpy_env._USER_DIRS.items():  # throwaway user folders, as prepare() makes
        (tmp_path / sub).mkdir()
        env[var] = str(tmp_path / sub)
    env["TMPDIR"] = str(tmp_path)
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.splitlines()
    assert "oslquery importable before" not in lines  # else this tests nothing
    assert [x for x in lines if x.startswith("scripts ")] == ["scripts True"], out.stdout


def test_the_readmes_scripting_example_runs_as_written(bpy, installed_extension):
    """The README's scripting example against the installed extension (the
    tests install it in their own repository, so its module path differs
    from the README's default one only in the repository's name)."""
    from tests.test_docs import readme_python_blocks
    block = readme_python_blocks()[1]
    default = "bl_ext.user_default.reflection_models"
    assert default in block
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    bpy.context.scene.collection.objects.link(sun)
    names = {}
    try:
        exec(compile(block.replace(default, installed_extension), "README.md", "exec"), names)
        api = names["api"]
        node = names["node"]
        assert api.bound_lights(node) == [sun] and api.get_mode(node) == "exact"
        assert bpy.context.scene.cycles.shading_system
        assert api.rendering_backend(bpy.context.scene)[0] == "osl"
    finally:
        bpy.data.materials.remove(names["mat"])
        bpy.data.objects.remove(sun)
