# SPDX-License-Identifier: GPL-3.0-or-later
"""Node groups built from the catalogue (``addon.groups``) and the Shader
Editor interface of the installed extension (``ui``): sockets, variants,
upgrade, the Add menu, the sidebar panel, handlers and unregistration.
Parametrised over ``catalogue.MODELS``.
"""

import importlib
import logging
import math
from types import SimpleNamespace

import pytest

from addon import catalogue
from verification.harness import session as bpy_env
from verification.suites import lighting

F32 = dict(rel=1e-6, abs=1e-7)  # interface values are stored as float32


@pytest.fixture
def nodes(bpy):
    bpy_env.reset_scene()
    from addon import groups as module
    return module


def interface_sockets(tree, in_out):
    return [item for item in tree.interface.items_tree
            if item.item_type == "SOCKET" and item.in_out == in_out]


def new_material(bpy, name="M"):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True  # Blender < 5.0
    return mat


def add_group_node(mat, tree):
    node = mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    return node


# ---------------------------------------------------------------------------
# Variants and names (no shader needed)

def test_group_names_follow_the_variant(nodes):
    assert nodes.group_name("lambert") == "RM Lambert"
    assert nodes.group_name("phong") == "RM Phong (None)"
    assert nodes.group_name("blinn_phong", {"normalization": "energy"}) == "RM Blinn-Phong (Energy)"
    assert nodes.group_name("microfacet") == "RM Microfacet (Beckmann, Smith, None)"
    assert nodes.group_name("microfacet", {"fresnel": "conductor"}) == \
        "RM Microfacet (Beckmann, Smith, Conductor)"
    assert nodes.group_name("microfacet", {"distribution": "trowbridge_reitz",
                                           "width_mode": "alpha_xy"}) == \
        "RM Microfacet (GGX, Smith, None, Alpha XY)"


def test_every_group_name_is_unique_and_fits_an_id_name(nodes):
    """Blender 4.5 cuts ID names at 63 characters: a cut name would not be
    found again and the group would be rebuilt on every use."""
    import itertools
    names = set()
    for model_id in catalogue.MODELS:
        params = nodes.variant_params(model_id)
        for values in itertools.product(*(p.choices for p in params)):
            enums = dict(zip((p.name for p in params), values))
            try:
                name = nodes.group_name(model_id, enums)
            except ValueError:
                continue  # a forbidden combination
            assert len(name) <= nodes.MAX_NAME, name
            assert name not in names
            names.add(name)
    assert len(names) > 100


def test_presets_map_to_their_base_model_variant(nodes):
    for preset in catalogue.PRESETS.values():
        enums = {**preset.fixed, **preset.defaults}
        assert nodes.variant_key(preset.id) == nodes.variant_key(preset.base, enums)
        assert nodes.group_name(preset.id) == nodes.group_name(preset.base, enums)
    assert nodes.group_name("cook_torrance") == "RM Microfacet (Beckmann, V-Groove, Dielectric)"
    with pytest.raises(ValueError, match="fixed"):
        nodes.variant_key("cook_torrance", {"distribution": "gaussian"})


@pytest.mark.parametrize("model_id, enums, match", [
    ("nope", {}, "allowed: lambert"),
    ("phong", {"normalization": "bogus"}, "one of 'none', 'energy'"),
    ("phong", {"exponent": 3.0}, "not a structural parameter"),
    ("microfacet", {"width_mode": "alpha", "distribution": "blinn"}, "native widths"),
    ("microfacet", {"width_mode": "bogus"}, "'beta', 'alpha', 'alpha_xy'"),
    ("microfacet", {"shadowing": "smith_1967", "distribution": "gaussian"}, "beckmann"),
])
def test_bad_variants_raise_value_errors_naming_what_is_allowed(nodes, model_id, enums, match):
    with pytest.raises(ValueError, match=match):
        nodes.variant_key(model_id, enums)


def test_width_modes_choose_the_width_sockets(nodes):
    def names(**enums):
        return [p.name for p in nodes.socket_params("microfacet", enums)]

    assert "beta" in names() and not {"alpha", "alpha_x", "alpha_y"} & set(names())
    assert "alpha" in names(width_mode="alpha") and "beta" not in names(width_mode="alpha")
    assert {"alpha_x", "alpha_y"} <= set(names(width_mode="alpha_xy"))
    assert not {"beta", "alpha"} & set(names(width_mode="alpha_xy"))
    # the tangent inputs appear only where the variant depends on a tangent
    assert not nodes.uses_tangent("microfacet")
    assert nodes.uses_tangent("microfacet", {"width_mode": "alpha_xy"})
    assert nodes.uses_tangent("ward") and nodes.uses_tangent("kajiya_kay")
    assert not nodes.uses_tangent("lambert")


def test_output_labels(nodes):
    assert nodes.output_label("cos_theta_i") == "Cos Theta I"
    for name in ("BSDF", "Direct", "Color", "D", "G", "F", "Lobe"):
        assert nodes.output_label(name) == name


def test_enum_codes_match_the_generated_shaders(nodes):
    """The ints set on the Script nodes are the codes the shaders compare with:
    each choice's code appears in the generated shader's if chain, and the
    shader's default is the catalogue default's code."""
    from addon.backends.osl import generate
    for model_id in catalogue.MODELS:
        src = (generate.SHADERS / f"{generate.shader_name(model_id)}.osl").read_text()
        for p in nodes.variant_params(model_id):
            if p.name == "backend":
                continue  # the group's switch, not a shader input
            codes = generate.enum_codes(model_id)[p.name]
            assert codes == {c: i for i, c in enumerate(p.choices)}
            assert f"int {p.name} = {codes[p.default]}" in src


# ---------------------------------------------------------------------------
# Building groups

@pytest.mark.parametrize("model_id", list(catalogue.MODELS))
def test_every_default_group_matches_the_catalogue(nodes, model_id):
    tree = nodes.ensure_group(model_id)
    assert tree.name == nodes.group_name(model_id)
    assert tree["rm_model"] == model_id and tree["rm_version"] == nodes.NODES_VERSION
    _model, variant = nodes.resolve_variant(model_id)
    assert tree["rm_variant"].to_dict() == variant

    params = nodes.input_params(model_id)
    inputs = interface_sockets(tree, "INPUT")
    assert [s.name for s in inputs] == [p.label for p in params]
    for item, p in zip(inputs, params):
        assert item.description == p.description and item.description.strip()
        assert (item.parent.name if item.parent else "") in ("", p.panel)
        if p.panel:
            assert item.parent.name == p.panel
        expected_subtype = {"angle": "ANGLE", "factor": "FACTOR", "direction": "DIRECTION",
                            "position": "TRANSLATION"}.get(p.kind)
        if p.kind == "color":
            assert item.socket_type == "NodeSocketColor"
            rgb = (p.default,) * 3 if isinstance(p.default, float) else p.default
            assert tuple(item.default_value)[:3] == pytest.approx(rgb, **F32)
            continue
        if expected_subtype:
            assert item.subtype == expected_subtype, p.name
        elif p.kind == "float":
            assert item.subtype == "NONE", p.name
        if p.kind == "normal":
            assert item.hide_value, p.name
        if p.minimum is not None:
            assert item.min_value == pytest.approx(p.minimum, **F32), p.name
            assert item.max_value == pytest.approx(p.maximum, **F32), p.name
        default = item.default_value
        if hasattr(default, "__len__"):
            assert tuple(default) == pytest.approx(p.default, **F32)
        else:
            assert default == pytest.approx(p.default, **F32)

    # Three scripts: the model (exact outputs, terms), its closure alone
    # (BSDF) and the flag that is 1 where OSL runs; and the native nodes.
    from addon.backends.osl import generate
    scripts = {n.script.name: n for n in tree.nodes if n.bl_idname == "ShaderNodeScript"}
    script = scripts.pop(f"rm_{model_id}.osl")
    closure = scripts.pop(generate.shader_name(model_id, True, variant) + ".osl")
    flag = scripts.pop("rm_osl.osl")
    assert not scripts
    assert tree["rm_native_nodes"] > 0
    frame = next(n for n in tree.nodes if n.bl_idname == "NodeFrame")
    native = [n for n in tree.nodes if n.parent == frame]
    # a plan of more than PART_SIZE nodes is built in nested groups, hidden
    # from the Add menu (a name starting with a dot)
    from addon.backends.native import build as native_build
    parts = [n.node_tree for n in native if n.bl_idname == "ShaderNodeGroup"]
    assert all(p.get("rm_part") and p.name.startswith(".") for p in parts)
    inner = [len(p.nodes) - 2 for p in parts]  # less the Group Input and Output
    assert all(0 < k <= native_build.PART_SIZE for k in inner)
    assert bool(parts) == (tree["rm_native_nodes"] > native_build.PART_SIZE)
    assert len(native) - len(parts) + sum(inner) >= tree["rm_native_nodes"]

    # outputs: BSDF, Direct, Color, then every term, each from a switch
    # between the OSL output of the same name and the native one
    outputs = interface_sockets(tree, "OUTPUT")
    assert [s.name for s in outputs[:3]] == list(catalogue.MAIN_OUTPUTS)
    assert [s.socket_type for s in outputs[:3]] == ["NodeSocketShader", "NodeSocketShader",
                                                     "NodeSocketColor"]
    osl_outputs = [o.name for o in script.outputs]
    assert [s.name for s in outputs] == [nodes.output_label(n) for n in ["BSDF"] + osl_outputs]
    assert all(s.description.strip() for s in outputs)
    group_out = next(n for n in tree.nodes if n.bl_idname == "NodeGroupOutput")
    for item in outputs:
        (link,) = [l for l in tree.links
                   if l.to_node == group_out and l.to_socket.identifier == item.identifier]
        switch = link.from_node
        assert switch.bl_idname in ("ShaderNodeMixShader", "ShaderNodeMix"), item.name
        (fac_link,) = switch.inputs[0].links
        assert fac_link.from_node == flag and switch.inputs[0].default_value == 0.0
        sources = {l.from_node for s in switch.inputs[1:] for l in s.links}
        osl_source = closure if item.name == "BSDF" else script
        assert osl_source in sources, item.name
        assert any(n.parent == frame for n in sources) or len(sources) == 1, item.name

    # inside: every group input feeds the script inputs of the same parameter
    group_in = next(n for n in tree.nodes if n.bl_idname == "NodeGroupInput")
    tangents = [n for n in tree.nodes if n.bl_idname == "ShaderNodeTangent"]
    if nodes.uses_tangent(model_id, variant):
        assert tangents and all(t.direction_type == "UV_MAP" for t in tangents)
    else:  # an isotropic model needs no tangent; the node would cost render time
        assert not tangents
    for node in (script, closure):
        for item, p in zip(inputs, params):
            if node is closure and p.name not in node.inputs:
                # the closure needs no light, and a tangent only if it uses one
                assert p.panel == "Light" or p.panel == "Geometry" and p.name != "shading_normal", p.name
                continue
            (link,) = node.inputs[p.name].links
            assert link.from_node == group_in and link.from_socket.identifier == item.identifier
        if tangents and (node is script or "tangent" in node.inputs):
            assert node.inputs["default_tangent"].links[0].from_node in tangents
        elif not tangents:
            assert not any(s.is_linked for s in node.inputs if "tangent" in s.name)
        codes = generate.enum_codes(model_id)
        for p in nodes.variant_params(model_id):
            if p.name not in codes:
                continue  # the backend is the group's, not a shader input
            if p.name in node.inputs:
                assert node.inputs[p.name].default_value == p.choices.index(variant[p.name])
                assert not node.inputs[p.name].is_linked
        assert node.bytecode


def test_angles_and_factors_show_their_units_on_the_node(nodes, bpy):
    tree = nodes.ensure_group("lambert")
    node = add_group_node(new_material(bpy), tree)
    kinds = {p.name: p.kind for p in catalogue.LIGHT_INPUTS + catalogue.GEOMETRY_INPUTS}
    for socket in node.inputs:
        kind = kinds.get(nodes.socket_key(node, socket)[3:])
        if kind == "factor":
            assert socket.bl_idname == "NodeSocketFloatFactor"
        elif kind == "direction":
            assert socket.bl_idname == "NodeSocketVectorDirection"


def test_half_angle_socket_is_an_angle(nodes):
    tree = nodes.ensure_group("microfacet")
    (item,) = [s for s in interface_sockets(tree, "INPUT") if s.name == "Half-Angle"]
    assert item.subtype == "ANGLE"
    assert item.max_value == pytest.approx(85 * math.pi / 180, **F32)


def test_rebuilding_does_not_duplicate(nodes, bpy):
    first = nodes.ensure_group("phong")
    counts = (len(bpy.data.node_groups), len(bpy.data.texts))
    assert nodes.ensure_group("phong", normalization="none") == first
    assert (len(bpy.data.node_groups), len(bpy.data.texts)) == counts
    energy = nodes.ensure_group("phong", normalization="energy")
    assert energy != first and energy.name == "RM Phong (Energy)"
    # the new group, and the nested groups its native nodes are built in
    assert len(bpy.data.node_groups) == counts[0] + 1 + len(nodes._parts(energy))
    assert len(bpy.data.texts) == counts[1]  # one text per shader, shared by variants


def test_a_build_that_fails_leaves_no_group_and_no_part(nodes, bpy, monkeypatch):
    """A group whose build fails after its native nodes were made (here the
    OSL switch, made last, raises) is removed with the nested groups its
    native nodes were built in: the file holds no group more than before."""
    before = set(bpy.data.node_groups)
    made = []
    native = nodes._build_native

    def build_native(*args):
        out = native(*args)
        made.extend(nodes._parts(args[0]))
        return out

    def switch(*_args):
        raise RuntimeError("the switch failed")

    monkeypatch.setattr(nodes, "_build_native", build_native)
    monkeypatch.setattr(nodes, "_switch", switch)
    with pytest.raises(RuntimeError, match="the switch failed"):
        nodes.ensure_group("phong")
    assert made  # Phong's native nodes are more than one part
    assert set(bpy.data.node_groups) == before


@pytest.mark.parametrize("model_id", list(catalogue.MODELS))
def test_input_sockets_finds_what_input_socket_finds(nodes, bpy, model_id):
    """``input_sockets`` (one walk of a node's inputs, for the lamp
    bindings' upkeep) names every input of a four-light group by its
    parameter, each the socket ``input_socket`` finds."""
    tree = nodes.ensure_group(model_id, lights="4")
    node = add_group_node(new_material(bpy), tree)
    found = nodes.input_sockets(node)
    names = [p.name for p in nodes.input_params(model_id, {"lights": "4"})]
    assert list(found) == names and "light_position_4" in found
    for name in names:
        assert found[name] == nodes.input_socket(node, name)


def test_a_foreign_group_with_the_same_name_is_not_taken(nodes, bpy):
    foreign = bpy.data.node_groups.new("RM Lambert", "ShaderNodeTree")
    tree = nodes.ensure_group("lambert")
    assert tree != foreign and tree["rm_model"] == "lambert"
    assert "rm_model" not in foreign


# ---------------------------------------------------------------------------
# Keeping a user's values, links and drivers

def _user_setup(bpy, nodes, tree, value_param, value):
    """A material using ``tree``: one input set by hand, one linked from a
    Value node, a driver on Light Strength, the BSDF wired to the output."""
    mat = new_material(bpy)
    node = add_group_node(mat, tree)
    node.name = "RMNode"
    nt = mat.node_tree
    socket = nodes.input_socket(node, value_param)
    socket.default_value = (*value, 1.0) if isinstance(value, tuple) else value
    source = nt.nodes.new("ShaderNodeValue")
    source.name = "Source"
    nt.links.new(source.outputs[0], nodes.input_socket(node, "shadows"))
    out = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    nt.links.new(nodes.output_socket(node, "BSDF"), out.inputs["Surface"])
    fcurve = nodes.input_socket(node, "light_strength").driver_add("default_value")
    fcurve.driver.expression = "2.5"
    return mat, node, source, out


def _assert_user_setup_kept(nodes, mat, node, source, out, value_param, value):
    sock = nodes.input_socket(node, value_param)
    got = sock.default_value
    assert (tuple(got)[:len(value)] if hasattr(got, "__len__") else got) == \
        pytest.approx(value, **F32)
    (link,) = nodes.input_socket(node, "shadows").links
    assert link.from_node == source
    (link,) = out.inputs["Surface"].links
    assert link.from_node == node and nodes.socket_key(node, link.from_socket) == "out:BSDF"
    (fcurve,) = mat.node_tree.animation_data.drivers
    assert fcurve.data_path == nodes.input_socket(node, "light_strength").path_from_id(
        "default_value")
    assert fcurve.driver.is_valid and fcurve.driver.expression == "2.5"


def test_upgrade_keeps_the_group_and_the_users_values_and_links(nodes, bpy):
    tree = nodes.ensure_group("lambert")
    setup = _user_setup(bpy, nodes, tree, "albedo", (0.1, 0.2, 0.3))
    marker = tree.nodes.new("NodeReroute")
    marker.name = "stale"
    tree["rm_version"] = nodes.NODES_VERSION - 1
    assert nodes.find_outdated_groups() == [tree]
    n_groups = len(bpy.data.node_groups)

    nodes.upgrade_group(tree)

    assert nodes.find_outdated_groups() == []
    assert tree["rm_version"] == nodes.NODES_VERSION
    assert "stale" not in tree.nodes  # rebuilt, not left alone
    assert len(bpy.data.node_groups) == n_groups
    mat, node, source, out = setup
    assert node.node_tree == tree and tree.name == "RM Lambert"
    _assert_user_setup_kept(nodes, mat, node, source, out, "albedo", (0.1, 0.2, 0.3))


def test_a_group_built_for_another_blenders_native_nodes_is_rebuilt(nodes, monkeypatch):
    """A file made in 4.5 and opened in 5.2 (or the other way round) holds
    native nodes planned for the other Blender: in 5.2 its exact mode had
    no shadow ray, and its Metallic BSDFs' weights would correct a Fresnel
    5.2 computes exactly.  Such a group is outdated: listed by
    find_outdated_groups, and built again for this Blender by ensure_group."""
    from addon.backends.native import build as native_build

    here = native_build.capabilities()
    tree = nodes.ensure_group("microfacet", fresnel="dielectric")
    assert dict(tree["rm_native"]) == here and nodes.find_outdated_groups() == []
    other = {**here, "exact_conductor": not here["exact_conductor"]}
    with monkeypatch.context() as m:  # built as the other Blender builds it
        m.setattr(native_build, "capabilities", lambda: other)
        nodes.upgrade_group(tree)
        assert nodes.find_outdated_groups() == []
    assert dict(tree["rm_native"]) == other
    assert nodes.find_outdated_groups() == [tree] and nodes.built_for_another_blender(tree)
    assert nodes.ensure_group("microfacet", fresnel="dielectric") == tree
    assert dict(tree["rm_native"]) == here and nodes.find_outdated_groups() == []
    osl_only = nodes.ensure_group("lambert", backend="osl")  # no native nodes: nothing recorded
    assert "rm_native" not in osl_only and not nodes.built_for_another_blender(osl_only)


def test_ensure_group_upgrades_an_outdated_group_in_place(nodes):
    tree = nodes.ensure_group("lambert")
    tree["rm_version"] = 0
    assert nodes.ensure_group("lambert") == tree
    assert tree["rm_version"] == nodes.NODES_VERSION


def test_variant_switch_keeps_values_links_and_drivers(nodes, bpy):
    tree = nodes.ensure_group("phong")
    setup = _user_setup(bpy, nodes, tree, "exponent", 7.0)
    mat, node, source, out = setup
    nodes.input_socket(node, "ks").default_value = (0.2, 0.4, 0.6, 1.0)

    new_tree, reset = nodes.switch_variant(node, normalization="energy")

    assert reset == ()
    assert node.node_tree == new_tree and new_tree.name == "RM Phong (Energy)"
    assert tree.name == "RM Phong (None)"  # the other variant stays for its users
    _assert_user_setup_kept(nodes, mat, node, source, out, "exponent", 7.0)
    assert tuple(nodes.input_socket(node, "ks").default_value)[:3] == \
        pytest.approx((0.2, 0.4, 0.6), **F32)


def test_width_switch_moves_drivers_to_the_right_sockets(nodes, bpy):
    """Sockets appear and disappear between width modes: index-based driver
    paths must follow their parameter."""
    tree = nodes.ensure_group("microfacet", distribution="trowbridge_reitz")
    mat, node, source, out = _user_setup(bpy, nodes, tree, "ks", (0.5, 0.6, 0.7))
    old_index = list(node.inputs).index(nodes.input_socket(node, "light_strength"))
    nodes.switch_variant(node, width_mode="alpha_xy")
    assert list(node.inputs).index(nodes.input_socket(node, "light_strength")) != old_index
    _assert_user_setup_kept(nodes, mat, node, source, out, "ks", (0.5, 0.6, 0.7))


def test_width_switch_keeps_keyframes_on_their_parameters(nodes, bpy):
    """Keyframes are index-based paths too: after a switch that moves sockets
    they must still animate their own parameter, and the keys of a socket the
    new variant lacks must come back with it."""
    tree = nodes.ensure_group("microfacet", distribution="trowbridge_reitz")
    mat = new_material(bpy)
    node = add_group_node(mat, tree)
    strength = nodes.input_socket(node, "light_strength")
    beta = nodes.input_socket(node, "beta")
    for frame, s, b in ((1, 1.0, 0.1), (10, 3.0, 0.4)):
        strength.default_value, beta.default_value = s, b
        strength.keyframe_insert("default_value", frame=frame)
        beta.keyframe_insert("default_value", frame=frame)
    fcurves = {fc.data_path: fc for fc in nodes._action_fcurves(mat.node_tree.animation_data)}
    strength_curve = fcurves[strength.path_from_id("default_value")]
    beta_curve = fcurves[beta.path_from_id("default_value")]
    old_index = list(node.inputs).index(strength)

    nodes.switch_variant(node, width_mode="alpha_xy")

    strength = nodes.input_socket(node, "light_strength")
    assert list(node.inputs).index(strength) != old_index
    assert strength_curve.data_path == strength.path_from_id("default_value")
    assert strength_curve.evaluate(10) == pytest.approx(3.0)
    with pytest.raises(KeyError):
        nodes.input_socket(node, "beta")
    with pytest.raises(ValueError):  # kept, but it animates nothing in this variant
        mat.node_tree.path_resolve(beta_curve.data_path)
    assert [k.co[1] for k in beta_curve.keyframe_points] == pytest.approx([0.1, 0.4], **F32)

    nodes.switch_variant(node, width_mode="beta")

    socket_path, prop = beta_curve.data_path.rsplit(".", 1)
    assert prop == "default_value"
    assert mat.node_tree.path_resolve(socket_path) == nodes.input_socket(node, "beta")
    assert strength_curve.data_path == nodes.input_socket(node, "light_strength").path_from_id(
        "default_value")


@pytest.mark.parametrize("model_id", ["kajiya_kay", "ward"])
def test_a_switch_to_fewer_lights_keeps_drivers_past_them(nodes, bpy, model_id):
    """A driver on an input after the Light inputs (the tangent's), in a tree
    that also has keyframes: at the swap of the node's group for one with
    fewer lights Blender deleted the F-curves whose index path no longer
    resolved, and writing their new path crashed Blender (5.2.4). The
    driver and the keyframes stay, on their own inputs."""
    mat = new_material(bpy)
    node = add_group_node(mat, nodes.ensure_group(model_id, lights="4"))
    tangent = nodes.input_socket(node, "tangent").driver_add("default_value")
    for i, fcurve in enumerate(tangent):
        fcurve.driver.expression = f"0.{i + 1}"
    turn = nodes.input_socket(node, "tangent_rotation")
    spot = nodes.input_socket(node, "spot")
    for frame, value in ((1, 0.25), (9, 0.75)):
        turn.default_value = spot.default_value = value
        turn.keyframe_insert("default_value", frame=frame)
        spot.keyframe_insert("default_value", frame=frame)
    for lights in ("1", "3", "1"):
        nodes.switch_variant(node, lights=lights)
    anim = mat.node_tree.animation_data
    path = nodes.input_socket(node, "tangent").path_from_id("default_value")
    assert sorted((fc.array_index, fc.driver.expression) for fc in anim.drivers
                  if fc.data_path == path) == [(0, "0.1"), (1, "0.2"), (2, "0.3")]
    keys = {fc.data_path: fc for fc in nodes._action_fcurves(anim)}
    for name in ("tangent_rotation", "spot"):
        fcurve = keys[nodes.input_socket(node, name).path_from_id("default_value")]
        assert fcurve.evaluate(9) == pytest.approx(0.75)


def test_variant_switch_resets_a_conflicting_enum(nodes, bpy):
    tree = nodes.ensure_group("microfacet", shadowing="smith_1967")
    node = add_group_node(new_material(bpy), tree)
    new_tree, reset = nodes.switch_variant(node, distribution="trowbridge_reitz")
    assert reset == ("shadowing",)
    assert new_tree["rm_variant"].to_dict()["shadowing"] == "smith"
    with pytest.raises(ValueError):
        nodes.switch_variant(node, distribution="nope")


def test_scene_uses_rm_groups(nodes, bpy):
    scene = bpy.context.scene
    mat = new_material(bpy)
    mesh = bpy.data.meshes.new("mesh")
    mesh.materials.append(mat)
    scene.collection.objects.link(bpy.data.objects.new("obj", mesh))
    assert not nodes.scene_uses_rm_groups(scene)
    wrapper = bpy.data.node_groups.new("wrapper", "ShaderNodeTree")
    add_group_node(SimpleNamespace(node_tree=wrapper), nodes.ensure_group("lambert"))
    add_group_node(mat, wrapper)  # nested one level down
    assert nodes.scene_uses_rm_groups(scene)


def test_scene_uses_rm_groups_through_instancing_and_geometry_nodes(nodes, bpy):
    """A material no slot of the scene names still counts when an object
    renders it: a collection instance of an object that has it, and
    Geometry Nodes setting it (read in the depsgraph the view layer has)."""
    scene = bpy.data.scenes.new("rm_uses_indirectly")
    mat = new_material(bpy, "rm instanced material")
    add_group_node(mat, nodes.ensure_group("lambert"))
    mesh = bpy.data.meshes.new("rm instanced mesh")
    mesh.materials.append(mat)
    source = bpy.data.collections.new("rm instanced source")
    source.objects.link(bpy.data.objects.new("rm instanced", mesh))
    empty = bpy.data.objects.new("rm instancer", None)
    scene.collection.objects.link(empty)
    assert not nodes.scene_uses_rm_groups(scene)
    empty.instance_type, empty.instance_collection = 'COLLECTION', source
    assert nodes.scene_uses_rm_groups(scene)
    empty.instance_collection = None
    assert not nodes.scene_uses_rm_groups(scene)
    points = bpy.data.meshes.new("rm set material mesh")
    points.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    host = bpy.data.objects.new("rm set material", points)
    scene.collection.objects.link(host)
    tree = lighting.material_by_geometry_nodes(host, mat)
    setter = next(n for n in tree.nodes if n.bl_idname == "GeometryNodeSetMaterial")
    layer = scene.view_layers[0]
    with bpy.context.temp_override(scene=scene, view_layer=layer):
        bpy.context.evaluated_depsgraph_get()  # as the interface keeps one
    assert nodes.scene_uses_rm_groups(scene)
    setter.inputs["Material"].default_value = None
    with bpy.context.temp_override(scene=scene, view_layer=layer):
        bpy.context.evaluated_depsgraph_get()
    assert not nodes.scene_uses_rm_groups(scene)
    bpy.data.scenes.remove(scene)


# ---------------------------------------------------------------------------
# The installed extension: Add menu, sidebar, operators, handlers

class Recorder:
    """A stand-in for ``UILayout`` that records what a draw function asks for."""

    def __init__(self, log=None):
        self.log = [] if log is None else log

    def operator(self, idname, text="", **_kw):
        props = SimpleNamespace()
        self.log.append(("operator", idname, text, props))
        return props

    def operator_menu_enum(self, idname, prop, text="", **_kw):
        self.log.append(("operator_menu_enum", idname, text, prop))

    def menu(self, idname, text="", **_kw):
        self.log.append(("menu", idname, text))

    def label(self, text="", **_kw):
        self.log.append(("label", text))

    def separator(self, **_kw):
        pass

    def _child(self, *_a, **_kw):
        return Recorder(self.log)

    box = row = column = split = _child

    def of(self, kind):
        return [entry for entry in self.log if entry[0] == kind]


@pytest.fixture
def ui(installed_extension):
    bpy_env.reset_scene()
    return importlib.import_module(installed_extension + ".ui")


def shader_editor(tree_type="ShaderNodeTree", **extra):
    return SimpleNamespace(space_data=SimpleNamespace(type="NODE_EDITOR", tree_type=tree_type),
                           **extra)


def node_context(scene, node, **extra):
    """A shader editor's context with ``node`` active in ``scene`` and no
    object selected."""
    return shader_editor(scene=scene, active_node=node, active_object=None, selected_objects=[],
                         **extra)


def sidebar_labels(bpy, ctx) -> list:
    """The texts of the labels the sidebar draws in ``ctx``."""
    layout = Recorder()
    bpy.types.NODE_PT_rm_sidebar.draw(SimpleNamespace(layout=layout), ctx)
    return [e[1] for e in layout.of("label")]


def test_sidebar_says_where_exact_mode_casts_no_or_screen_space_shadows(ui, bpy):
    """Exact mode's shadow ray where the node's native nodes render: none in
    Blender 4.5 (no Raycast node), screen space in EEVEE; a node set to
    native nodes counts in a scene that runs OSL, an automatic one not."""
    nodes = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
    api = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".api")
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.shading_system = True
    scene.cycles.device = "CPU"
    mat = new_material(bpy)
    auto = add_group_node(mat, nodes.ensure_group("lambert"))
    native = add_group_node(mat, nodes.ensure_group("lambert"))
    api.set_params(native, backend="native")
    for node in (auto, native):
        api.set_mode(node, "exact")
    none_45 = "Blender 4.5 native nodes: exact mode casts no shadows"
    screen = ("EEVEE: exact mode's shadow ray is traced in screen space (only what the view "
              "sees casts a shadow)")
    raycast = bpy.app.version >= (5, 0)
    assert none_45 not in sidebar_labels(bpy, node_context(scene, auto))
    assert (none_45 in sidebar_labels(bpy, node_context(scene, native))) != raycast
    scene.render.engine = "BLENDER_EEVEE" if raycast else "BLENDER_EEVEE_NEXT"
    labels = sidebar_labels(bpy, node_context(scene, auto))
    assert (screen in labels) == raycast and (none_45 in labels) != raycast, labels
    api.set_mode(auto, "path_traced")  # no shadow ray
    labels = sidebar_labels(bpy, node_context(scene, auto))
    assert screen not in labels and none_45 not in labels, labels


def test_add_menu_lists_every_model_and_preset(ui, bpy):
    appended = [f for f in bpy.types.NODE_MT_shader_node_add_all._dyn_ui_initialize()
                if getattr(f, "__module__", "") == ui.__name__]
    assert len(appended) == 1
    layout = Recorder()
    appended[0](SimpleNamespace(layout=layout), shader_editor())
    assert layout.of("menu") == [("menu", "NODE_MT_rm_add", "")]
    other = Recorder()
    appended[0](SimpleNamespace(layout=other), shader_editor("GeometryNodeTree"))
    assert other.log == []

    menu = bpy.types.NODE_MT_rm_add
    assert menu.bl_label == "Reflection Models"
    layout = Recorder()
    menu.draw(SimpleNamespace(layout=layout), None)
    added = {props.model: text for _k, idname, text, props in layout.of("operator")
             if idname == "node.rm_add_model"}
    submenus = {text: idname for _k, idname, text in layout.of("menu")}
    assert submenus == {"Microfacet": "NODE_MT_rm_add_microfacet"}
    for model in catalogue.MODELS.values():
        assert added.get(model.id) == model.label or model.label in submenus
    for preset in catalogue.PRESETS.values():
        assert added[preset.id] == preset.label
    assert all(props.use_transform for *_x, props in layout.of("operator"))

    layout = Recorder()
    bpy.types.NODE_MT_rm_add_microfacet.draw(SimpleNamespace(layout=layout), None)
    dists = [(props.model, props.distribution) for *_x, props in layout.of("operator")]
    assert dists == [("microfacet", d) for d in catalogue.DISTRIBUTIONS]

    # tooltips come from the catalogue
    op = bpy.types.NODE_OT_rm_add_model
    for model in catalogue.MODELS.values():
        assert op.description(None, SimpleNamespace(model=model.id, distribution="")) == \
            model.description
    assert op.description(None, SimpleNamespace(model="cook_torrance", distribution="")) == \
        catalogue.PRESETS["cook_torrance"].description


def test_add_operator_places_a_selected_group_node_at_the_cursor(ui, bpy):
    mat = new_material(bpy)
    tree = mat.node_tree
    before = set(tree.nodes)
    for n in before:
        n.select = True
    space = SimpleNamespace(type="NODE_EDITOR", tree_type="ShaderNodeTree", edit_tree=tree,
                            cursor_location=(120.0, -40.0))
    reports = []
    fake = SimpleNamespace(model="lambert", distribution="", report=lambda *a: reports.append(a))
    result = bpy.types.NODE_OT_rm_add_model.execute(fake, SimpleNamespace(space_data=space))
    assert result == {"FINISHED"}, reports
    (node,) = set(tree.nodes) - before
    assert node.node_tree.name == "RM Lambert"
    assert tuple(node.location) == pytest.approx((120.0, -40.0))
    assert node.select and tree.nodes.active == node
    assert not any(n.select for n in before)

    fake.model = "nope"
    assert bpy.types.NODE_OT_rm_add_model.execute(fake, SimpleNamespace(space_data=space)) \
        == {"CANCELLED"}
    assert "nope" in reports[-1][1]


def test_hair_curves_get_the_strand_direction_from_the_add_menu_and_the_sidebar(ui, bpy):
    """On a hair Curves object the Tangent input's default (the UV map's
    tangent) is 0: adding a node with a tangent while a Curves object is
    active links the Geometry node's Tangent to it; a node left unconnected
    in a material a Curves object renders gets a sidebar label and the
    button that links it; a mesh's material gets neither."""
    base = ui.__name__.rsplit(".", 1)[0]
    nodes = importlib.import_module(base + ".groups")
    hair = bpy.data.hair_curves.new("Hair")
    hair.add_curves([2])
    mat = new_material(bpy, "HairMat")
    hair.materials.append(mat)
    curves = bpy.data.objects.new("Hair", hair)
    bpy.context.scene.collection.objects.link(curves)
    space = SimpleNamespace(type="NODE_EDITOR", tree_type="ShaderNodeTree",
                            edit_tree=mat.node_tree, cursor_location=(0.0, 0.0))

    def add(model, obj):
        before = set(mat.node_tree.nodes)
        fake = SimpleNamespace(model=model, distribution="", report=lambda *a: None)
        ctx = SimpleNamespace(space_data=space, object=obj)
        assert bpy.types.NODE_OT_rm_add_model.execute(fake, ctx) == {"FINISHED"}
        (node,) = [n for n in set(mat.node_tree.nodes) - before if n.type == 'GROUP']
        return node

    def strand_fed(node):
        links = nodes.input_socket(node, "tangent").links
        return len(links) == 1 and links[0].from_node.bl_idname == "ShaderNodeNewGeometry" \
            and links[0].from_socket.name == "Tangent"

    assert strand_fed(add("kajiya_kay", curves))
    assert "tangent" not in nodes.input_sockets(add("lambert", curves))  # nothing to feed

    hint = "On hair curves the unconnected Tangent is 0 (no UV map there)"
    node = add("ward", None)
    assert not strand_fed(node)
    ctx = node_context(bpy.context.scene, node)
    assert hint in sidebar_labels(bpy, ctx)
    assert bpy.types.NODE_OT_rm_use_strand_tangent.poll(ctx)
    assert bpy.types.NODE_OT_rm_use_strand_tangent.execute(SimpleNamespace(), ctx) == \
        {"FINISHED"}
    assert strand_fed(node) and hint not in sidebar_labels(bpy, ctx)

    mesh_mat = new_material(bpy, "MeshMat")
    mesh = bpy.data.objects.new("Mesh", bpy.data.meshes.new("Mesh"))
    mesh.data.materials.append(mesh_mat)
    bpy.context.scene.collection.objects.link(mesh)
    other = add_group_node(mesh_mat, nodes.ensure_group("kajiya_kay"))
    assert hint not in sidebar_labels(bpy, node_context(bpy.context.scene, other))
    assert not bpy.types.NODE_OT_rm_use_strand_tangent.poll(
        node_context(bpy.context.scene, add_group_node(mesh_mat, nodes.ensure_group("phong"))))


def test_sidebar_shows_osl_state_variant_menus_and_bind_light(ui, bpy):
    nodes = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.shading_system = False
    node = add_group_node(new_material(bpy), nodes.ensure_group("phong"))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    panel = bpy.types.NODE_PT_rm_sidebar
    ctx = shader_editor(scene=scene, active_node=node, active_object=sun,
                        selected_objects=[sun])
    assert panel.poll(ctx) and not panel.poll(shader_editor("GeometryNodeTree"))

    layout = Recorder()
    panel.draw(SimpleNamespace(layout=layout), ctx)
    ops = [entry[1] for entry in layout.of("operator")]
    assert "node.rm_enable_osl" in ops
    # with OSL off the 'auto' groups render their native nodes, and the panel says so
    assert ("label", "Renders with: native nodes") in [e[:2] for e in layout.log]
    assert ("label", "Open Shading Language is off") in layout.log
    assert ("menu", "NODE_MT_rm_variant_normalization", "None") in layout.of("menu")
    assert ("menu", "NODE_MT_rm_variant_backend", "Automatic") in layout.of("menu")
    assert ("operator", "node.rm_bind_selected_lights", "Bind Sun") == \
        layout.of("operator")[-1][:3]
    assert [e[1:] for e in layout.of("operator_menu_enum")] == [
        ("node.rm_set_mode", "Path Traced", "mode"), ("node.rm_bind_light", "Bind One", "light")]
    assert "node.rm_upgrade_groups" not in ops
    # the BSDF output's status as the scene renders it: native nodes have no Phong lobe
    labels = [e[1] for e in layout.of("label")]
    at = labels.index("BSDF output: approximate (Direct is exact)")
    assert labels[at + 1].startswith("Measured: at most ") and \
        labels[at + 2].startswith("At its worst width"), labels  # the fitter's figure

    scene.cycles.shading_system = True
    scene.cycles.device = "CPU"
    node.node_tree["rm_version"] = 0
    layout = Recorder()
    panel.draw(SimpleNamespace(layout=layout), ctx)
    ops = [entry[1] for entry in layout.of("operator")]
    assert "node.rm_enable_osl" not in ops and "node.rm_upgrade_groups" in ops
    assert ("label", "BSDF output: exact (a Cycles closure is the model)") in \
        [e[:2] for e in layout.log]  # OSL's phong_ramp
    node.node_tree["rm_version"] = nodes.NODES_VERSION
    # a group whose native nodes another Blender planned: its own label, the same button
    here = dict(node.node_tree["rm_native"])
    node.node_tree["rm_native"] = {**here, "raycast": not here["raycast"]}
    layout = Recorder()
    panel.draw(SimpleNamespace(layout=layout), ctx)
    labels = [e[1] for e in layout.log if e[0] == "label"]
    assert "1 group(s) built for another Blender's native nodes" in labels
    assert not [text for text in labels if "older version" in text]
    assert "node.rm_upgrade_groups" in [entry[1] for entry in layout.of("operator")]
    node.node_tree["rm_native"] = here

    # the variant menu offers every choice and the operator switches
    layout = Recorder()
    bpy.types.NODE_MT_rm_variant_normalization.draw(SimpleNamespace(layout=layout), ctx)
    choices = [props.value for *_x, props in layout.of("operator")]
    assert choices == ["none", "energy"]
    fake = SimpleNamespace(param="normalization", value="energy", report=lambda *a: None)
    assert bpy.types.NODE_OT_rm_switch_variant.execute(fake, ctx) == {"FINISHED"}
    assert node.node_tree.name == "RM Phong (Energy)"


def test_sidebar_names_hybrid_objects_that_also_use_other_materials_and_sized_lamps(ui, bpy):
    api = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".api")
    scene = bpy.context.scene
    mat, plain = new_material(bpy, "rm partly hybrid"), new_material(bpy, "rm plain")
    node = api.add_model(mat, "lambert", mode="hybrid")
    mesh = bpy.data.meshes.new("rm partly")
    mesh.materials.append(mat)
    obj = bpy.data.objects.new("rm partly", mesh)
    scene.collection.objects.link(obj)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    api.bind_light(node, sun)
    ctx = shader_editor(scene=scene, active_node=node, active_object=sun,
                        selected_objects=[sun])
    message = "1 excluded object(s) also use other materials, which the bound lamps no longer light"
    sized = "Taken as a direction or point, size ignored: Sun"
    assert sun.data.angle > 0  # a new sun's 0.526 degrees
    for expected in (False, True):
        labels = sidebar_labels(bpy, ctx)
        assert (message in labels) == expected
        assert (sized in labels) != expected
        mesh.materials.append(plain)
        sun.data.angle = 0.0
    api.unbind_light(node)


def test_the_interactive_sidebar_keeps_what_walks_every_object_until_the_next_update(
        ui, bpy, monkeypatch):
    """In the interactive UI the hybrid labels and the groups the scene's
    materials use (each read by walking every object) are read at the
    first redraw of the sidebar and kept for the next ones until an update
    of the depsgraph, an undo or a redo, or a file opened: each makes the
    next redraw read them again, and then it says what changed.  Without
    a UI (here) every draw reads them."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm kept")
    plain = new_material(bpy, "rm kept plain")
    mesh = bpy.data.meshes.new("rm kept")
    mesh.materials.append(mat)
    obj = bpy.data.objects.new("rm kept", mesh)
    scene.collection.objects.link(obj)
    other = new_material(bpy, "rm kept other")
    other_node = api.add_model(other, "lambert", mode="hybrid")
    ctx = node_context(scene, node)
    message = "1 excluded object(s) also use other materials, which the bound lamps no longer light"
    reads = []
    read = ui.hybrid_linking_labels
    monkeypatch.setattr(ui, "hybrid_linking_labels",
                        lambda *a: reads.append(a[1].as_pointer()) or read(*a))
    try:
        api.bind_light(node, sun)
        api.bind_light(other_node, sun)
        assert ui._keeps_reads() is False  # no UI here: read at every draw
        sidebar_labels(bpy, ctx)
        sidebar_labels(bpy, ctx)
        assert len(reads) == 2
        monkeypatch.setattr(ui, "_keeps_reads", lambda: True)
        for forget in (lambda: ui.on_depsgraph_update_post(scene, None),
                       ui.on_undo_redo_post, ui.on_load_post):
            forget()
            reads.clear()
            assert message not in sidebar_labels(bpy, ctx)
            mesh.materials.append(plain)  # no update yet: the labels kept say nothing of it
            assert message not in sidebar_labels(bpy, ctx) and reads == [node.as_pointer()]
            sidebar_labels(bpy, node_context(scene, other_node))  # another node: its own
            assert reads == [node.as_pointer(), other_node.as_pointer()]
            forget()
            assert message in sidebar_labels(bpy, ctx)
            assert message in sidebar_labels(bpy, ctx) and reads.count(node.as_pointer()) == 2
            mesh.materials.pop()
        forced = "A node forced to OSL renders black here"
        scene.render.engine, scene.cycles.shading_system = 'CYCLES', False
        ui.forget_kept_reads()
        assert forced not in sidebar_labels(bpy, ctx)
        api.set_params(node, backend="osl")  # no update yet
        assert forced not in sidebar_labels(bpy, ctx)
        ui.on_depsgraph_update_post(scene, None)
        assert forced in sidebar_labels(bpy, ctx)
    finally:
        api.unbind_light(other_node)
        ui.forget_kept_reads()
        _remove_hybrid_scene(bpy, api, node, scene, mat, [obj, sun, sun.data, mesh, plain, other])


def test_sidebar_names_unevenly_scaled_spot_lamps(ui, bpy):
    """Cycles scales a spot's cone with the lamp's scale where it is not
    the same along the three axes (tests/test_lighting.py renders it);
    exact mode takes the cone unscaled: the sidebar names such spots, by
    their world scale (a parent's counts), in exact and hybrid mode."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm scaled")
    spot = bpy.data.objects.new("rm scaled spot", bpy.data.lights.new("rm scaled spot", "SPOT"))
    parent = bpy.data.objects.new("rm scaled parent", None)
    for obj in (spot, parent):
        scene.collection.objects.link(obj)
    ctx = node_context(scene, node)
    message = ("Spot cone taken unscaled (Cycles scales it with the lamp's uneven scale): "
               "rm scaled spot")

    def said():
        scene.view_layers[0].update()  # the world matrices
        return message in sidebar_labels(bpy, ctx)

    try:
        api.bind_light(node, sun, spot)
        assert not said()
        spot.scale = (2.0, 1.0, 1.0)
        assert said()
        spot.scale = (2.0, 2.0, 2.0)
        assert not said()
        spot.scale = (1.0, 1.0, 1.0)
        spot.parent = parent
        parent.scale = (1.0, 1.0, 3.0)
        assert said()
        api.set_mode(node, "path_traced")  # Cycles' own cone
        assert not said()
    finally:
        _remove_hybrid_scene(bpy, api, node, scene, mat, [sun, spot, parent])


def test_sidebar_says_when_a_binding_is_an_earlier_versions(ui, bpy):
    """A node bound before binding drove Shadows from Cast Shadow, or the
    strength from Disable in Renders, keeps the values it had (a user may
    have set them): the sidebar names the lamps of such lights in exact
    and hybrid mode, and binding again takes it away."""
    api = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".api")
    lighting = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".lighting")
    groups = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
    scene = bpy.context.scene
    mat = new_material(bpy, "rm shadows follow")
    node = api.add_model(mat, "lambert", mode="exact")
    lamps = []
    for name in ("Key", "Fill"):
        lamps.append(bpy.data.objects.new(name, bpy.data.lights.new(name, "SUN")))
        scene.collection.objects.link(lamps[-1])
    api.bind_light(node, *lamps)
    ctx = node_context(scene, node)

    def message(names):
        return ("Bound by an earlier version, not following Cast Shadow or Disable in Renders: "
                f"{names}: bind again")

    try:
        assert lighting.outdated_bindings(node) == []
        assert not [t for t in sidebar_labels(bpy, ctx) if t.startswith("Bound by")]
        # as a node bound by an older version: no driver on light 2's Shadows
        socket = groups.input_socket(node, lighting.socket_name("shadows", 2))
        assert socket.name == "Shadows 2"
        socket.driver_remove("default_value")
        assert lighting.outdated_bindings(node) == [lamps[1]]
        assert message("Fill") in sidebar_labels(bpy, ctx)
        # ... and light 1's strength without Disable in Renders
        strength = groups.input_socket(node, lighting.socket_name("light_strength", 1))
        driver = next(fc.driver for fc in mat.node_tree.animation_data.drivers
                      if fc.data_path == strength.path_from_id("default_value"))
        driver.variables.remove(next(v for v in driver.variables
                                     if v.name == lighting.HIDDEN))
        assert message("Key, Fill") in sidebar_labels(bpy, ctx)
        api.set_mode(node, "path_traced")  # no exact evaluation: nothing to say
        assert message("Key, Fill") not in sidebar_labels(bpy, ctx)
        api.set_mode(node, "exact")
        api.bind_light(node, *lamps)
        assert lighting.outdated_bindings(node) == []
        assert not [t for t in sidebar_labels(bpy, ctx) if t.startswith("Bound by")]
    finally:
        api.unbind_light(node)
        bpy.data.batch_remove(lamps)
        bpy.data.materials.remove(mat)


def _hybrid_lambert_under_a_sun(ui, bpy, name):
    """``(api, scene, material, node, sun)``: a new scene with a sun named
    ``name + " sun"`` and a material with a hybrid Lambert node."""
    api = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".api")
    scene = bpy.data.scenes.new(name)
    mat = new_material(bpy, name)
    node = api.add_model(mat, "lambert", mode="hybrid")
    sun = bpy.data.objects.new(name + " sun", bpy.data.lights.new(name + " sun", "SUN"))
    scene.collection.objects.link(sun)
    return api, scene, mat, node, sun


def _remove_hybrid_scene(bpy, api, node, scene, mat, made):
    """Undo :func:`_hybrid_lambert_under_a_sun` and what a test ``made``."""
    api.unbind_light(node)
    bpy.data.batch_remove(made)
    bpy.data.scenes.remove(scene)
    bpy.data.materials.remove(mat)


def test_sidebar_says_when_a_bound_lamps_type_changed(ui, bpy):
    """Binding fixes whether light k is a sun, a point or a spot lamp; a
    lamp whose type changes afterwards is taken as the type it had until
    the viewport's next update, a render, a save or *Repair Light Linking*
    binds it again (tests/test_lighting.py).  Until then the sidebar names
    it and offers *Repair Light Linking*, which binds it again (pressed
    through ``bpy.ops``); an area lamp cannot be bound, and stays named.
    The viewport's handler is out: no update here may bind it first."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm retyped")
    lighting = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".lighting")
    ctx = node_context(scene, node)
    handlers = bpy.app.handlers.depsgraph_update_post
    handlers.remove(ui.on_depsgraph_update_post)

    def said():
        return [t for t in sidebar_labels(bpy, ctx) if t.startswith("rm retyped sun:")]

    try:
        api.set_mode(node, "exact")
        api.bind_light(node, sun)
        assert said() == [] and lighting.retyped_lamps(node) == []
        sun.data.type = 'SPOT'
        assert said() == ["rm retyped sun: bound as Sun, now Spot: bound again at the next "
                          "update, render or save"]
        assert _repair_buttons(bpy, ctx) == 1
        assert bpy.ops.node.rm_sync_light_linking() == {'FINISHED'}
        assert said() == [] and lighting.retyped_lamps(node) == []
        groups = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
        assert groups.input_socket(node, "spot").default_value == 1.0
        sun.data.type = 'POINT'
        assert lighting.retyped_lamps(node) == [(sun, 'SPOT')]
        sun.data.type = 'AREA'
        assert said() == ["rm retyped sun: bound as Spot, now Area: exact mode follows sun, "
                          "point and spot lamps"]
        assert _repair_buttons(bpy, ctx) == 0
    finally:
        handlers.append(ui.on_depsgraph_update_post)
        _remove_hybrid_scene(bpy, api, node, scene, mat, [sun])


def test_sidebar_says_when_a_bound_lamp_moved_to_other_collections(ui, bpy):
    """Exact mode's strength follows the Disable in Renders of the
    collections the lamp was in when bound; a lamp moved to others is
    bound again at the viewport's next update, a render or a save
    (tests/test_lighting.py).  Until then the sidebar names the light and
    offers *Repair Light Linking*, which binds it again.  The viewport's
    handler is out: no update here may bind it first."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm moved")
    lighting = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".lighting")
    rig = bpy.data.collections.new("rm moved rig")
    scene.collection.children.link(rig)
    ctx = node_context(scene, node)
    message = ("Lamp in other or renamed collections or with other light data since binding, "
               "or bound by an older version, for light 1: bound again at the next update, "
               "render or save")
    handlers = bpy.app.handlers.depsgraph_update_post
    handlers.remove(ui.on_depsgraph_update_post)
    try:
        api.set_mode(node, "exact")
        api.bind_light(node, sun)
        assert message not in sidebar_labels(bpy, ctx) and not _repair_buttons(bpy, ctx)
        rig.objects.link(sun)
        scene.collection.objects.unlink(sun)
        assert lighting.moved_lamp_lights(node) == [1]
        assert message in sidebar_labels(bpy, ctx) and _repair_buttons(bpy, ctx) == 1
        assert bpy.ops.node.rm_sync_light_linking() == {'FINISHED'}
        assert lighting.bound_collections(node, 1) == [rig]
        assert message not in sidebar_labels(bpy, ctx) and not _repair_buttons(bpy, ctx)
    finally:
        handlers.append(ui.on_depsgraph_update_post)
        _remove_hybrid_scene(bpy, api, node, scene, mat, [sun, rig])


def test_sidebar_says_when_a_bound_lamp_is_not_rendered_in_the_view_layer(ui, bpy):
    """Exact mode's drivers follow the lamp object's Disable in Renders, and
    the Disable in Renders and the view layer's exclusion of the
    collections on every way down to it from the scene's collection (a
    lamp in several renders while any way does; tests/test_lighting.py
    renders it), not a lamp in another scene's collections, alone or as
    well: the sidebar names a bound lamp the view layer does not render
    when the drivers do not follow that.  A renamed collection is bound
    again at the update, and its exclusion followed."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm unrendered")
    rig = bpy.data.collections.new("rm unrendered rig")
    other = bpy.data.collections.new("rm unrendered other")
    scene.collection.children.link(rig)
    scene.collection.children.link(other)
    rig.objects.link(sun)
    scene.collection.objects.unlink(sun)
    layer = scene.view_layers[0]
    ctx = node_context(scene, node, view_layer=layer)
    message = ("Exact mode lights with lamps this view layer does not render (in another "
               "scene's collections or in no scene's, or instanced): rm unrendered sun")

    def said():
        layer.update()  # Blender builds the layer collections lazily; the UI has them
        return message in sidebar_labels(bpy, ctx)

    try:
        api.bind_light(node, sun)
        assert not said()
        rig.hide_render = True  # followed by the drivers
        assert not said()
        rig.hide_render = False
        layer.layer_collection.children[rig.name].exclude = True  # followed by the drivers
        assert not said()
        layer.layer_collection.children[rig.name].exclude = False
        rig.name = "rm unrendered rig renamed"  # its path changed: bound again at the update
        layer.layer_collection.children[rig.name].exclude = True
        assert not said()
        layer.layer_collection.children[rig.name].exclude = False
        other.objects.link(sun)  # in two collections: rendered where either renders
        rig.hide_render = other.hide_render = True
        assert not said()  # followed: bound again at the update, the max over the two ways
        other.hide_render = False  # rendered through the other one
        assert not said()
        other.objects.unlink(sun)
        assert not said()  # in the rig alone again, bound again at the update: followed
        sun.hide_render = True  # followed by the drivers: nothing to say
        assert not said()
        sun.hide_render = False
        elsewhere = bpy.data.scenes.new("rm unrendered elsewhere")
        elsewhere.collection.children.link(other)
        scene.collection.children.unlink(other)
        other.objects.link(sun)
        rig.hide_render = True  # in another scene's collection as well: not followed
        assert said()
        rig.hide_render = False
        rig.objects.unlink(sun)  # in another scene's collection only
        assert said()
        elsewhere.collection.children.unlink(other)  # in a collection of no scene's
        assert not any(sun.name in s.objects for s in bpy.data.scenes) and said()
        bpy.data.scenes.remove(elsewhere)
    finally:
        _remove_hybrid_scene(bpy, api, node, scene, mat, [sun, rig, other])


def test_sidebar_says_when_a_bound_lamp_has_shadow_linking(ui, bpy):
    """Exact mode's shadow ray (the Raycast node, OSL's trace) sees every
    object; a lamp's shadow linking (its blocker collection) limits which
    objects cast its shadows in Cycles (measured, 5.2.4, with OSL and on
    the native nodes: an occluder excluded from the sun's blockers shadowed
    the exact gonio, 0.0, and not the path-traced one, the model).  The sidebar names such lamps in
    exact and hybrid mode."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm blockers")
    blockers = bpy.data.collections.new("rm blockers")
    ctx = node_context(scene, node)
    message = ("Shadow linking not followed: exact mode's shadow ray sees every object for "
               "rm blockers sun")
    try:
        api.bind_light(node, sun)
        assert message not in sidebar_labels(bpy, ctx)
        sun.light_linking.blocker_collection = blockers
        assert message in sidebar_labels(bpy, ctx)
        api.set_mode(node, "path_traced")  # Cycles' own shadows: nothing to say
        assert message not in sidebar_labels(bpy, ctx)
    finally:
        _remove_hybrid_scene(bpy, api, node, scene, mat, [sun, blockers])


def test_sidebar_says_what_of_a_lamps_visibility_exact_mode_does_not_follow(ui, bpy):
    """Exact mode follows the lamp's Diffuse or Glossy ray visibility, the
    one for the model's kind (tests/test_lighting.py renders it), but not
    one of them alone for Kajiya-Kay, whose diffuse and specular terms
    share one light (lit while either is on, black with both off), nor
    EEVEE's Diffuse and Specular light factors (EEVEE scales each kind of
    closure's light by them, Cycles ignores them, and a driver cannot tell
    the engine): the sidebar names such lamps, the factors only where the
    scene renders in EEVEE and only the model's kind's."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm rays")
    rays = ("Ray visibility not followed (Kajiya-Kay's diffuse and specular terms share one "
            "light): rm rays sun")
    factors = "EEVEE's Diffuse and Specular light factors not followed by exact mode: rm rays sun"
    eevee = "BLENDER_EEVEE_NEXT" if bpy.app.version < (5, 0) else "BLENDER_EEVEE"
    hair = None

    def said(active):
        labels = sidebar_labels(bpy, node_context(scene, active))
        return rays in labels, factors in labels

    try:
        api.bind_light(node, sun)
        sun.visible_diffuse = False
        assert said(node) == (False, False)  # followed by Lambert's strength
        sun.visible_diffuse = True
        sun.data.specular_factor = 0.5
        scene.render.engine = eevee
        assert said(node) == (False, False)  # not Lambert's kind
        sun.data.diffuse_factor = 0.5
        assert said(node) == (False, True)
        scene.render.engine = 'CYCLES'
        assert said(node) == (False, False)
        sun.data.diffuse_factor = 1.0
        hair = api.add_model(mat, "kajiya_kay", mode="exact")
        api.bind_light(hair, sun)
        assert said(hair) == (False, False)
        sun.visible_glossy = False
        assert said(hair) == (True, False)
        sun.visible_diffuse = False  # both off: followed, no light
        assert said(hair) == (False, False)
        sun.visible_diffuse = True
        scene.render.engine = eevee
        assert said(hair) == (True, True)  # its specular factor
        api.set_mode(hair, "path_traced")  # Cycles' and EEVEE's own light: nothing to say
        assert said(hair) == (False, False)
    finally:
        if hair is not None:
            api.unbind_light(hair)
        _remove_hybrid_scene(bpy, api, node, scene, mat, [sun])


def test_sidebar_says_when_a_bound_lamp_has_light_linking_of_the_users(ui, bpy):
    """A lamp's light linking (a receiver collection of the user's) limits
    which objects it lights; exact mode evaluates the lamp once per
    material and lights every object with it.  The sidebar names such
    lamps in exact mode; not in path-traced mode (Cycles' own light), nor
    for the collection the hybrid mode made."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm receivers")
    receivers = bpy.data.collections.new("rm receivers")
    ctx = node_context(scene, node)
    message = ("Light linking not followed: exact mode lights every object with the material "
               "from rm receivers sun")
    try:
        api.set_mode(node, "exact")
        api.bind_light(node, sun)
        assert message not in sidebar_labels(bpy, ctx)
        sun.light_linking.receiver_collection = receivers
        assert message in sidebar_labels(bpy, ctx)
        api.set_mode(node, "path_traced")
        assert message not in sidebar_labels(bpy, ctx)
        api.set_mode(node, "exact")
        sun.light_linking.receiver_collection = None
        other = new_material(bpy, "rm receivers other")
        hybrid = api.add_model(other, "lambert", mode="hybrid")
        api.bind_light(hybrid, sun)  # the extension's collection, for the other material
        assert sun.light_linking.receiver_collection is not None
        assert message not in sidebar_labels(bpy, ctx)
        api.unbind_light(hybrid)
        bpy.data.materials.remove(other)
    finally:
        _remove_hybrid_scene(bpy, api, node, scene, mat, [sun, receivers])


def _repair_buttons(bpy, ctx) -> int:
    """How many *Repair Light Linking* buttons the sidebar draws in ``ctx``."""
    layout = Recorder()
    bpy.types.NODE_PT_rm_sidebar.draw(SimpleNamespace(layout=layout), ctx)
    return len([e for e in layout.of("operator") if "rm_sync_light_linking" in str(e)])


def test_sidebar_says_when_a_bound_lamp_was_deleted(ui, bpy):
    """A light whose lamp was deleted keeps its last values until the next
    update, render or save sets it to 0 (tests/test_lighting.py); the sidebar says
    so meanwhile, with the Repair button, which does it at once."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm deleted")
    lighting = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".lighting")
    groups = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
    ctx = node_context(scene, node)
    message = ("Lamp deleted for light 1: lit as before until the next update, render or save "
               "sets it to 0")

    try:
        api.bind_light(node, sun)
        assert message not in sidebar_labels(bpy, ctx) and not _repair_buttons(bpy, ctx)
        bpy.data.objects.remove(sun)
        assert message in sidebar_labels(bpy, ctx) and _repair_buttons(bpy, ctx) == 1
        strength = groups.input_socket(node, lighting.socket_name("light_strength", 1))
        assert strength.default_value > 0
        assert bpy.ops.node.rm_sync_light_linking() == {'FINISHED'}
        assert message not in sidebar_labels(bpy, ctx) and not _repair_buttons(bpy, ctx)
        assert strength.default_value == 0 and api.light_drivers(node) == []
    finally:
        api.unbind_light(node)
        bpy.data.scenes.remove(scene)
        bpy.data.materials.remove(mat)


def test_sidebar_says_when_the_scene_has_more_light_linking_collections_than_blender_applies(
        ui, bpy):
    """Blender applies at most 63 receiver collections in a scene (measured:
    with 64 lamps each excluding its own object, one object was lit by its
    lamp all the same, Cycles 5.2.4 and 4.5.15 and EEVEE).  The hybrid
    mode adds one per set of lamps bound by the same hybrid materials; the
    sidebar says when the scene holds more, counting the user's too."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm many sets")
    lighting = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".lighting")
    made = [sun]
    for i in range(lighting.RECEIVER_COLLECTIONS_MAX):  # the user's lamps, each with its own
        lamp = bpy.data.objects.new(f"rm sets {i}", bpy.data.lights.new(f"rm sets {i}", "POINT"))
        scene.collection.objects.link(lamp)
        lamp.light_linking.receiver_collection = bpy.data.collections.new(f"rm sets {i}")
        made += [lamp, lamp.light_linking.receiver_collection]
    ctx = node_context(scene, node)
    message = (f"{lighting.RECEIVER_COLLECTIONS_MAX + 1} light linking collections in the "
               f"scene; Blender applies at most {lighting.RECEIVER_COLLECTIONS_MAX}: some "
               "links are ignored")

    try:
        assert lighting.receiver_collections(scene) == lighting.RECEIVER_COLLECTIONS_MAX
        assert message not in sidebar_labels(bpy, ctx)  # not bound yet
        api.bind_light(node, sun)  # the hybrid mode's collection for the sun
        assert lighting.receiver_collections(scene) == lighting.RECEIVER_COLLECTIONS_MAX + 1
        assert message in sidebar_labels(bpy, ctx)
        made[1].light_linking.receiver_collection = made[-1]  # two lamps share one
        assert lighting.receiver_collections(scene) == lighting.RECEIVER_COLLECTIONS_MAX
        assert message not in sidebar_labels(bpy, ctx)
    finally:
        _remove_hybrid_scene(bpy, api, node, scene, mat, made)


def test_sidebar_names_a_copy_of_a_bound_lamp_that_excludes_the_hybrid_objects(ui, bpy):
    """A copy of a bound lamp keeps the original's light linking and so does
    not light the hybrid objects; the sidebar names it until the light
    linking is brought up to date (the render and save handlers do that
    too: tests/test_lighting.py)."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm stray")
    ctx = node_context(scene, node)
    message = ("Bound to no node, yet not lighting the hybrid objects (a copy of a bound "
               "lamp?): rm stray sun.001")
    made = [sun]
    try:
        api.bind_light(node, sun)
        made.append(sun.copy())
        scene.collection.objects.link(made[-1])
        assert message in sidebar_labels(bpy, ctx)
        assert api.sync_light_linking() == 1
        assert message not in sidebar_labels(bpy, ctx)
        assert made[-1].light_linking.receiver_collection is None
    finally:
        _remove_hybrid_scene(bpy, api, node, scene, mat, made)


def test_sidebar_names_an_unbound_lamp_sharing_a_users_collection_with_a_bound_one(ui, bpy):
    """The user gave two lamps one light linking collection; binding one of
    them adds the hybrid exclusions to it, so the other does not light the
    hybrid objects either.  The collection is the user's and stays as it
    is; the sidebar names the other lamp while the exclusions are there."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm sharer")
    other = bpy.data.objects.new("rm sharer 2", bpy.data.lights.new("rm sharer 2", "POINT"))
    scene.collection.objects.link(other)
    users = bpy.data.collections.new("rm sharer's")
    sun.light_linking.receiver_collection = other.light_linking.receiver_collection = users
    obj = bpy.data.objects.new("rm sharer obj", bpy.data.meshes.new("rm sharer obj"))
    obj.data.materials.append(mat)
    scene.collection.objects.link(obj)
    ctx = node_context(scene, node)
    message = ("Not lighting the hybrid objects, sharing a bound lamp's light linking "
               "collection: rm sharer 2")
    try:
        assert message not in sidebar_labels(bpy, ctx)
        api.bind_light(node, sun)
        assert obj.name in users.objects
        assert sun.light_linking.receiver_collection == users
        assert other.light_linking.receiver_collection == users
        assert message in sidebar_labels(bpy, ctx)
        api.unbind_light(node)
        assert message not in sidebar_labels(bpy, ctx)
    finally:
        _remove_hybrid_scene(bpy, api, node, scene, mat, [sun, other, obj, users])


def test_sidebar_says_a_lamp_linked_from_a_library_keeps_no_light_linking(ui, bpy, tmp_path):
    """A lamp linked from a library file takes the hybrid mode's light
    linking for the session only (rendered in a fresh process:
    tests/test_lighting.py); a library override keeps it where Blender
    lets it (5.2, not 4.5), else making the lamp local does.  The sidebar
    names the bound lamps whose linking will not be saved."""
    api, scene, mat, node, sun = _hybrid_lambert_under_a_sun(ui, bpy, "rm library")
    library = tmp_path / "lamps.blend"
    bpy.data.libraries.write(str(library), {sun})
    bpy.data.objects.remove(sun)
    with bpy.data.libraries.load(str(library), link=True) as (_src, dst):
        dst.objects = ["rm library sun"]
    linked = dst.objects[0]
    scene.collection.objects.link(linked)
    ctx = node_context(scene, node)
    lighting = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".lighting")
    keeps = lighting.override_keeps_light_linking()
    assert keeps == (bpy.app.version >= (5, 2, 0))  # measured in 5.2.4 and 4.5.15
    remedy = "make a library override" if keeps else "make it local"
    message = (f"Linked from a library, so their light linking is not saved ({remedy}): "
               "rm library sun")
    try:
        api.bind_light(node, linked)
        assert linked.light_linking.receiver_collection is not None  # for now
        assert message in sidebar_labels(bpy, ctx)
        override = linked.override_create(remap_local_usages=True)
        api.bind_light(node, override)
        assert (message in sidebar_labels(bpy, ctx)) == (not keeps)
        api.bind_light(node, override.make_local())
        assert message not in sidebar_labels(bpy, ctx)
    finally:
        api.unbind_light(node)
        bpy.data.scenes.remove(scene)
        bpy.data.materials.remove(mat)
        for obj in [o for o in bpy.data.objects if o.name == "rm library sun"]:
            bpy.data.objects.remove(obj)
        bpy.data.libraries.remove(bpy.data.libraries[library.name])


def test_sidebar_says_where_the_bsdf_output_is_not_the_model(ui, bpy):
    """GGX with correlated Smith is Cycles' own closure up to alpha 1; the
    sidebar reads the node's width and says when Cycles' clamp makes it
    approximate, and when a link makes the width unknown."""
    nodes = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
    api = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".api")
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.shading_system = True
    scene.cycles.device = "CPU"
    mat = new_material(bpy)
    node = api.add_model(mat, "microfacet", distribution="trowbridge_reitz",
                         shadowing="smith_correlated", alpha=0.5)
    panel = bpy.types.NODE_PT_rm_sidebar
    ctx = node_context(scene, node)

    def labels():
        layout = Recorder()
        panel.draw(SimpleNamespace(layout=layout), ctx)
        return [e[1] for e in layout.log if e[0] == "label" and e[1].startswith("BSDF output")]

    assert labels() == ["BSDF output: exact (a Cycles closure is the model)"]
    nodes.input_socket(node, "alpha").default_value = 2.0
    assert labels() == ["BSDF output: approximate (Direct is exact)"]
    value = mat.node_tree.nodes.new("ShaderNodeValue")
    mat.node_tree.links.new(value.outputs[0], nodes.input_socket(node, "alpha"))
    assert labels() == ["BSDF output: exact (a Cycles closure is the model)"]  # the variant's
    scene.render.engine = "BLENDER_WORKBENCH"
    assert labels() == ["BSDF output: not rendered"]
    scene.render.engine = "CYCLES"
    api.set_mode(node, "exact")
    assert labels() == []  # the Direct output is the model


def test_bind_light_operator_binds_the_lamp_chosen_not_the_active_one(ui, bpy):
    nodes = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
    node = add_group_node(new_material(bpy), nodes.ensure_group("lambert"))
    chosen = bpy.data.objects.new("Chosen", bpy.data.lights.new("Chosen", "POINT"))
    active = bpy.data.objects.new("Active", bpy.data.lights.new("Active", "SUN"))
    for obj in (chosen, active):
        bpy.context.scene.collection.objects.link(obj)
    op = bpy.types.NODE_OT_rm_bind_light
    ctx = shader_editor(scene=bpy.context.scene, active_node=node, active_object=active)
    items = [item[0] for item in ui._light_items(None, ctx)]
    assert items == ["Active", "Chosen"]

    fake = SimpleNamespace(light="Chosen", report=lambda *a: None,
                           properties=SimpleNamespace(is_property_set=lambda name: True))
    fake.execute = lambda context: op.execute(fake, context)
    assert op.invoke(fake, ctx, None) == {"FINISHED"}
    assert node.inputs["Point Light"].default_value == 1.0  # the point lamp, not the sun

    fake.properties = SimpleNamespace(is_property_set=lambda name: False)
    assert op.invoke(fake, ctx, None) == {"FINISHED"}
    assert fake.light == "Active" and node.inputs["Point Light"].default_value == 0.0


def test_enable_osl_operator(ui, bpy):
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"
    result = bpy.types.NODE_OT_rm_enable_osl.execute(None, SimpleNamespace(scene=scene))
    assert result == {"FINISHED"}
    assert (scene.render.engine, scene.cycles.device, scene.cycles.shading_system) == \
        ("CYCLES", "CPU", True)


def test_load_and_render_handlers_warn_when_osl_is_off(ui, bpy, tmp_path, caplog):
    """Only a group forced to OSL needs it: the warning names that case; an
    'auto' group renders native nodes and warns about nothing."""
    nodes = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.shading_system = False
    mat = new_material(bpy)
    add_group_node(mat, nodes.ensure_group("lambert"))
    with caplog.at_level(logging.WARNING):
        ui.on_render_init(bpy.context.scene)
    assert not caplog.records
    add_group_node(mat, nodes.ensure_group("lambert", backend="osl"))
    mesh = bpy.data.meshes.new("mesh")
    mesh.materials.append(mat)
    scene.collection.objects.link(bpy.data.objects.new("obj", mesh))
    path = tmp_path / "osl_off.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)

    with caplog.at_level(logging.WARNING):
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    assert any(ui.OSL_OFF_WARNING in r.getMessage() for r in caplog.records)

    caplog.clear()
    with caplog.at_level(logging.WARNING):
        ui.on_render_init(bpy.context.scene)
    assert any(ui.OSL_OFF_WARNING in r.getMessage() for r in caplog.records)

    caplog.clear()
    bpy.context.scene.cycles.shading_system = True
    bpy.context.scene.cycles.device = "CPU"
    with caplog.at_level(logging.WARNING):
        ui.on_render_init(bpy.context.scene)
    assert not caplog.records
    bpy_env.reset_scene()


def test_load_warns_of_groups_to_upgrade_and_the_api_upgrades_them(ui, bpy, tmp_path, caplog):
    """A file holding groups an older version built, or planned for another
    Blender's native nodes, says so in the log when it is opened (a render
    farm's script sees it); api.upgrade_groups() rebuilds them."""
    nodes = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".groups")
    api = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".api")
    old = nodes.ensure_group("lambert")
    other = nodes.ensure_group("phong")
    mat = new_material(bpy)
    add_group_node(mat, old)
    add_group_node(mat, other)
    old["rm_version"] = nodes.NODES_VERSION - 1
    here = dict(other["rm_native"])
    other["rm_native"] = {**here, "exact_conductor": not here["exact_conductor"]}
    names = sorted([old.name, other.name])
    path = tmp_path / "outdated.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)

    with caplog.at_level(logging.WARNING):
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    (message,) = [r.getMessage() for r in caplog.records if "Upgrade Groups" in r.getMessage()]
    assert "1 by an older version" in message and "1 for another Blender" in message
    assert sorted(api.upgrade_groups()) == names
    assert not nodes.find_outdated_groups() and api.upgrade_groups() == []
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        ui.on_load_post()
    assert not caplog.records
    bpy_env.reset_scene()


def _names(items):
    return sorted(x if isinstance(x, str) else x.__name__ for x in items)


def _registered_by(bpy, prefix):
    found = [name for name in dir(bpy.types)
             if getattr(getattr(bpy.types, name), "__module__", "").startswith(prefix)]
    draw_funcs = bpy.types.NODE_MT_shader_node_add_all._dyn_ui_initialize()
    found += [f for f in draw_funcs if getattr(f, "__module__", "").startswith(prefix)]
    for name in ("load_post", "render_init", "save_pre", "depsgraph_update_post", "undo_post",
                 "redo_post"):
        found += [h for h in getattr(bpy.app.handlers, name)
                  if getattr(h, "__module__", "").startswith(prefix)]
    return found


def test_a_failing_step_of_a_handler_stops_neither_its_other_steps_nor_the_render(
        ui, bpy, monkeypatch, caplog):
    """Each handler's steps run each on its own: with the release of deleted
    lamps' lights raising (a read-only property raises AttributeError), the
    render, save and viewport handlers still run their next step (the
    light linking's update, the copied lamps' release), return normally,
    and log what could not be done."""
    lighting = importlib.import_module(ui.__name__.rsplit(".", 1)[0] + ".lighting")
    ran = []

    def fail():
        raise AttributeError("read-only here")

    monkeypatch.setattr(lighting, "release_deleted_lamps", fail)
    monkeypatch.setattr(lighting, "sync_light_linking",
                        lambda **_kwargs: ran.append("sync") or 0)
    monkeypatch.setattr(lighting, "release_stray_lamps", lambda: ran.append("stray") or 0)
    with caplog.at_level(logging.WARNING):
        ui.on_render_init(bpy.context.scene)
        ui.on_save_pre()
        ui.on_undo_redo_post()  # so that the viewport's handler looks
        ui.on_depsgraph_update_post(bpy.context.scene, bpy.context.evaluated_depsgraph_get())
    assert ran == ["sync", "sync", "stray"]
    failed = [r for r in caplog.records if "could not release the lights of deleted lamps: "
              "read-only here" in r.getMessage()]
    assert len(failed) == 3


def test_unregister_leaves_no_classes_menu_entries_or_handlers(installed_extension, bpy):
    registered = _registered_by(bpy, installed_extension)
    assert {"NODE_OT_rm_add_model", "NODE_MT_rm_add", "NODE_PT_rm_sidebar"} <= set(registered)
    for handler in ("on_load_post", "on_render_init", "on_save_pre", "on_depsgraph_update_post",
                    "on_undo_redo_post"):
        assert any(callable(x) and x.__name__ == handler for x in registered), handler
    bpy_env.disable_extension(installed_extension)
    try:
        assert _registered_by(bpy, installed_extension) == []
    finally:
        bpy_env.enable_extension(installed_extension)
    assert _names(_registered_by(bpy, installed_extension)) == _names(registered)
