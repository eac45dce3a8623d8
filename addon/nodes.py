# SPDX-License-Identifier: GPL-3.0-or-later
"""Node groups of the reflection models, built from the catalogue.

One shader node group per model and per combination of its structural (enum)
parameters, e.g. ``RM Microfacet (Beckmann, Smith, Conductor)``.  Inside a
group: Group Input -> the model's OSL Script node (internal text, compiled
headlessly by :mod:`oslutil`) -> Group Output, with the enum parameters set as
constant integers on the Script node, and, in the variants that use a tangent
(:func:`uses_tangent`), a Tangent node (UV map) feeding the shader's
``default_tangent``.

Interface: the model's non-enum parameters (the catalogue's labels,
tooltips, hard limits, defaults; angles in degrees, factors as sliders), then
the Light and Geometry inputs, in panels; outputs BSDF, Direct, Color and
every term the shader writes.

The microfacet model has one more structural choice, ``width_mode``
(:data:`WIDTH_MODES`): its width is the half-angle ``beta`` (socket
"Half-Angle"), a native isotropic ``alpha`` ("Roughness") or native
``alpha_x``/``alpha_y`` ("Roughness X"/"Roughness Y"); the group shows only
the sockets of its mode.

Each group stores ``tree["rm_model"]`` (model id), ``tree["rm_variant"]``
(its enum values), ``tree["rm_version"]`` (:data:`NODES_VERSION` when built)
and ``tree["rm_sockets"]`` (interface identifier -> ``"in:<param>"`` or
``"out:<shader output>"``), which lets :func:`upgrade_group` and
:func:`switch_variant` carry socket values, links and drivers across a
rebuild.

Imports bpy: only for use inside Blender.
"""

from __future__ import annotations

import re

import bpy

from . import catalogue, oslutil, reference

NODES_VERSION = 3  # 2: a closure-only shader feeds the BSDF output;
# 3: the UV Tangent node only in variants that use a tangent
"""Bump when the layout of the groups changes; older groups are then listed by
:func:`find_outdated_groups` and rebuilt by :func:`upgrade_group`."""

GROUP_PREFIX = "RM "

# Codes of the microfacet shader's int width_mode (RM_WIDTH_* in osl/rm_generated.h).
WIDTH_MODES = ("beta", "alpha", "alpha_xy")
WIDTH_PARAM = catalogue.Param(
    "width_mode", "Width", "enum", "beta",
    "How the width of the distribution is given: 'beta' the highlight half-angle "
    "(every distribution), 'alpha' the native isotropic roughness, 'alpha_xy' native "
    "anisotropic roughness along and across the tangent (Trowbridge-Reitz and "
    "Beckmann only)",
    choices=WIDTH_MODES)
WIDTH_SOCKETS = {"beta": ("beta",), "alpha": ("alpha",), "alpha_xy": ("alpha_x", "alpha_y")}
# reference._check's name for the width it was given -> our width mode
WIDTH_FROM_REFERENCE = {"beta": "beta", "alpha": "alpha", "alpha_x": "alpha_xy"}

CHOICE_LABELS = {  # in menus
    "none": "None", "energy": "Energy",
    "blinn": "Blinn", "gaussian": "Gaussian", "trowbridge_reitz": "Trowbridge-Reitz (GGX)",
    "beckmann": "Beckmann",
    "smith": "Smith", "smith_correlated": "Smith Height-Correlated", "vgroove": "V-Groove",
    "smith_1967": "Smith 1967",
    "dielectric": "Dielectric", "conductor": "Conductor",
    "beta": "Half-Angle", "alpha": "Roughness (alpha)",
    "alpha_xy": "Anisotropic Roughness (alpha x, y)",
}
NAME_LABELS = {  # in group names: Blender 4.5 cuts ID names at 63 characters
    "trowbridge_reitz": "GGX", "smith_correlated": "Smith Corr.",
    "alpha": "Alpha", "alpha_xy": "Alpha XY",
}
MAX_NAME = 63

OUTPUT_DESCRIPTIONS = {
    "BSDF": ("Path traced: the model as a Cycles closure, lit by every light of the "
             "scene (where Cycles has no matching closure, the nearest one)"),
    "Direct": ("Exact: the analytic radiance reflected from the light given by the "
               "Light inputs, as an emission (shadowed by a ray toward the light)"),
    "Color": "Exact: the analytic reflected radiance for the light of the Light inputs",
    "cos_theta_i": "N.L: cosine of the angle of incidence",
    "cos_theta_o": "N.E: cosine of the viewing angle",
    "cos_theta_s": "E.R(L): cosine of the angle between the view and the mirror direction",
    "D": "Microfacet distribution D(H)",
    "G": "Shadowing-masking G",
    "F": "Fresnel factor F(L.H)",
}

_SOCKET_TYPES = {"VALUE": "NodeSocketFloat", "INT": "NodeSocketInt",
                 "RGBA": "NodeSocketColor", "VECTOR": "NodeSocketVector",
                 "SHADER": "NodeSocketShader"}


# ---------------------------------------------------------------------------
# Variants (pure: no Blender data is read or written)

def variant_params(model_id: str) -> tuple:
    """The structural parameters of a model (or a preset's base model): its
    enum params, plus :data:`WIDTH_PARAM` for models with a width rule."""
    model, _fixed, _defaults = catalogue.resolve(model_id)
    params = tuple(p for p in model.params if p.is_enum)
    if "width" in model.rules:
        params += (WIDTH_PARAM,)
    return params


def resolve_variant(model_id: str, enums: dict | None = None) -> tuple:
    """``(model, variant)`` for a model or preset name and enum values.

    ``variant`` holds every structural parameter of the model (defaults and a
    preset's fixed values filled in), in :func:`variant_params` order.
    Validation is :func:`addon.reference._check`'s: unknown names, values and
    forbidden combinations raise ``ValueError`` naming what is allowed.
    """
    enums = dict(enums or {})
    model, _fixed, _defaults = catalogue.resolve(model_id)
    structural = {p.name for p in variant_params(model_id)}
    for key in enums:
        if key not in structural:
            raise ValueError(
                f"{key!r} is not a structural parameter of {model_id!r}; structural: "
                f"{', '.join(sorted(structural)) or 'none'} (set other parameters on the "
                "node's sockets)")
    check = {k: v for k, v in enums.items() if k != WIDTH_PARAM.name}
    width = None
    if "width" in model.rules:
        width = enums.get(WIDTH_PARAM.name, WIDTH_PARAM.default)
        if width not in WIDTH_MODES:
            raise ValueError(f"width_mode={width!r} is not allowed; width_mode must be "
                             f"{WIDTH_PARAM.allowed()}")
        if width != "beta":  # let the reference check the distribution allows it
            check.update({n: model.param(n).default for n in WIDTH_SOCKETS[width]})
    _model, values, _given = reference._check(model_id, check)
    variant = {p.name: values[p.name] for p in model.params if p.is_enum}
    if width is not None:
        variant[WIDTH_PARAM.name] = width
    return model, variant


def variant_key(model_id: str, enums: dict | None = None) -> tuple:
    """Hashable identity of a group: ``(model id, ((name, value), ...))``;
    a preset maps to its base model with its fixed values."""
    model, variant = resolve_variant(model_id, enums)
    return model.id, tuple(variant.items())


def choice_label(value: str) -> str:
    return CHOICE_LABELS.get(value, value.replace("_", " ").title())


def group_name(model_id: str, enums: dict | None = None) -> str:
    """``"RM <Label>"`` followed by the variant's choices in parentheses
    (the width mode only when it is not the default half-angle), at most
    :data:`MAX_NAME` characters."""
    model, variant = resolve_variant(model_id, enums)
    parts = [NAME_LABELS.get(v) or choice_label(v) for k, v in variant.items()
             if not (k == WIDTH_PARAM.name and v == WIDTH_PARAM.default)]
    return GROUP_PREFIX + model.label + (f" ({', '.join(parts)})" if parts else "")


def socket_params(model_id: str, enums: dict | None = None) -> tuple:
    """The model parameters that are input sockets of the variant's group:
    every non-enum parameter, but of the width parameters only those of the
    variant's width mode."""
    model, variant = resolve_variant(model_id, enums)
    skip = set()
    if WIDTH_PARAM.name in variant:
        mode = variant[WIDTH_PARAM.name]
        skip = {n for m, names in WIDTH_SOCKETS.items() if m != mode for n in names}
    return tuple(p for p in model.params if not p.is_enum and p.name not in skip)


def uses_tangent(model_id: str, enums: dict | None = None) -> bool:
    """Whether the variant depends on a tangent (fibres, anisotropic widths):
    only then does its group show the Tangent inputs."""
    model, _variant = resolve_variant(model_id, enums)
    names = {p.name for p in socket_params(model_id, enums)}
    return model.kind == "fibre" or bool(names & {"alpha_x", "alpha_y"})


def input_params(model_id: str, enums: dict | None = None) -> tuple:
    """Every input socket's catalogue :class:`~catalogue.Param`, in order."""
    geometry = catalogue.GEOMETRY_INPUTS
    if not uses_tangent(model_id, enums):
        geometry = tuple(p for p in geometry if p.name not in ("tangent", "tangent_rotation"))
    return socket_params(model_id, enums) + catalogue.LIGHT_INPUTS + geometry


def output_label(name: str) -> str:
    """Socket label of a shader output: ``cos_theta_i`` -> ``Cos Theta I``;
    names without underscores that are not all lower case stay (BSDF, D)."""
    if "_" not in name and not name.islower():
        return name
    return " ".join(w[:1].upper() + w[1:] for w in name.split("_") if w)


def shader_name(model_id: str) -> str:
    model, _fixed, _defaults = catalogue.resolve(model_id)
    return (model.shader or f"rm_{model.id}.osl")[:-4]


# ---------------------------------------------------------------------------
# Finding groups

def rm_info(tree) -> tuple | None:
    """``(model id, variant dict)`` of a Reflection Models group, else None."""
    if tree is None or getattr(tree, "bl_idname", "") != "ShaderNodeTree":
        return None
    model_id = tree.get("rm_model")
    if not model_id or model_id not in catalogue.MODELS:
        return None
    variant = tree.get("rm_variant")
    variant = variant.to_dict() if hasattr(variant, "to_dict") else dict(variant or {})
    return str(model_id), variant


def is_rm_node(node) -> bool:
    return (getattr(node, "bl_idname", "") == "ShaderNodeGroup"
            and rm_info(node.node_tree) is not None)


def find_group(model_id: str, enums: dict | None = None):
    """The local group of this model variant, or None (a group named like it
    but without the same stored identity is not taken)."""
    model, variant = resolve_variant(model_id, enums)
    name = group_name(model_id, enums)
    found = [t for t in bpy.data.node_groups
             if t.library is None and rm_info(t) == (model.id, variant)]
    found.sort(key=lambda t: t.name != name)
    return found[0] if found else None


def find_outdated_groups() -> list:
    """Local groups built by an older :data:`NODES_VERSION`."""
    return [t for t in bpy.data.node_groups
            if t.library is None and rm_info(t) is not None
            and int(t.get("rm_version", 0)) < NODES_VERSION]


def _trees_with_nodes():
    """Every node tree that can hold a shader group node."""
    for coll in (bpy.data.materials, bpy.data.worlds, bpy.data.lights,
                 getattr(bpy.data, "linestyles", ())):
        for owner in coll:
            tree = getattr(owner, "node_tree", None)
            if tree is not None:
                yield tree
    for tree in bpy.data.node_groups:
        if tree.bl_idname == "ShaderNodeTree":
            yield tree


def group_nodes(tree) -> list:
    """Every group node (in any material, world, light or group) using ``tree``."""
    return [node for owner in _trees_with_nodes() for node in owner.nodes
            if node.bl_idname == "ShaderNodeGroup" and node.node_tree == tree]


def _tree_uses_rm(tree, seen) -> bool:
    if tree is None or tree.as_pointer() in seen:
        return False
    seen.add(tree.as_pointer())
    for node in tree.nodes:
        if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None:
            if rm_info(node.node_tree) is not None or _tree_uses_rm(node.node_tree, seen):
                return True
    return False


def scene_uses_rm_groups(scene) -> bool:
    """Whether a material of an object of ``scene``, or its world, holds an
    RM group node (directly or inside other groups)."""
    seen = set()
    if scene.world is not None and _tree_uses_rm(scene.world.node_tree, seen):
        return True
    materials = {slot.material for obj in scene.objects for slot in obj.material_slots
                 if slot.material is not None}
    return any(_tree_uses_rm(m.node_tree, seen) for m in materials)


# ---------------------------------------------------------------------------
# Building

def ensure_group(model_id: str, **enums):
    """The node group of ``model_id`` (a model or preset name) with the given
    enum values (defaults for the others): reused if it exists, upgraded in
    place if an older version built it, else built.  Raises ``ValueError``
    for bad names or values, :class:`oslutil.OSLCompileError` if the shader
    does not compile, ``FileNotFoundError`` if it does not exist."""
    model, variant = resolve_variant(model_id, enums)
    tree = find_group(model.id, variant)
    if tree is None:
        tree = bpy.data.node_groups.new(group_name(model.id, variant), "ShaderNodeTree")
        try:
            _build(tree, model.id, variant)
        except Exception:
            bpy.data.node_groups.remove(tree)
            raise
    elif int(tree.get("rm_version", 0)) < NODES_VERSION:
        upgrade_group(tree)
    return tree


def _set_interface_socket(item, param) -> None:
    kind = param.kind
    if kind in ("angle", "factor"):
        item.subtype = "ANGLE" if kind == "angle" else "FACTOR"
    elif kind == "direction":
        item.subtype = "DIRECTION"
    elif kind == "position":
        item.subtype = "TRANSLATION"
    elif kind == "normal":
        item.hide_value = True
    if hasattr(item, "min_value"):
        if param.minimum is not None:
            item.min_value = param.minimum
        if param.maximum is not None:
            item.max_value = param.maximum
    default = param.default
    if kind == "color":
        rgb = (default,) * 3 if isinstance(default, (int, float)) else tuple(default)
        item.default_value = (*rgb, 1.0)
    else:
        item.default_value = default


def _build(tree, model_id: str, variant: dict) -> None:
    """(Re)build ``tree`` in place as the group of ``model_id`` ``variant``."""
    model, _fixed, _defaults = catalogue.resolve(model_id)
    tree.nodes.clear()
    tree.interface.clear()

    # Two shaders: the model (exact outputs and terms) and its closure alone
    # for the BSDF output, so that a material using only BSDF compiles only
    # the closure (Cycles leaves out nodes not connected to the output).
    script = oslutil.make_script_node(tree, shader_name(model.id))
    script.location = (0.0, 0.0)
    script.label = model.label
    closure = oslutil.make_script_node(tree, shader_name(model.id) + "_bsdf")
    closure.location = (0.0, 400.0)
    closure.label = model.label + " (BSDF)"
    scripts = (closure, script)
    for p in variant_params(model.id):
        for node in scripts:
            if p.name not in node.inputs:
                raise RuntimeError(f"shader {node.name!r} has no int input {p.name!r}")
            node.inputs[p.name].default_value = p.choices.index(variant[p.name])
            node.inputs[p.name].hide = True

    sockets = {}
    outputs = [(closure, closure.outputs["BSDF"])]
    outputs += [(script, out) for out in script.outputs if out.name != "BSDF"]
    for node, out in outputs:
        item = tree.interface.new_socket(
            output_label(out.name), in_out="OUTPUT", socket_type=_SOCKET_TYPES[out.type],
            description=OUTPUT_DESCRIPTIONS.get(
                out.name, f"{output_label(out.name)}: a term of the model for the light "
                          "of the Light inputs"))
        sockets[item.identifier] = "out:" + out.name

    params = input_params(model.id, variant)
    panels = {}
    inputs = []
    for p in params:
        parent = None
        if p.panel:
            parent = panels.get(p.panel)
            if parent is None:
                parent = panels[p.panel] = tree.interface.new_panel(p.panel)
                parent.default_closed = p.panel in ("Light", "Geometry")
        socket_type = {"color": "NodeSocketColor", "direction": "NodeSocketVector",
                       "position": "NodeSocketVector",
                       "normal": "NodeSocketVector"}.get(p.kind, "NodeSocketFloat")
        item = tree.interface.new_socket(p.label, in_out="INPUT", socket_type=socket_type,
                                         description=p.description, parent=parent)
        _set_interface_socket(item, p)
        sockets[item.identifier] = "in:" + p.name
        inputs.append((item, p))

    group_in = tree.nodes.new("NodeGroupInput")
    group_in.location = (-450.0, 0.0)
    group_out = tree.nodes.new("NodeGroupOutput")
    group_out.location = (350.0, 0.0)
    # The UV tangent only where the variant uses one: Cycles computes the
    # mesh's tangents for every render and looks them up at every shading
    # point once the node is in the graph, used or not (measured in
    # tools/bench_render.py).  Without it, an isotropic model's frame takes
    # any perpendicular (rm_frame), which changes nothing.
    tangent = None
    if uses_tangent(model.id, variant):
        tangent = tree.nodes.new("ShaderNodeTangent")
        tangent.direction_type = "UV_MAP"
        tangent.location = (-450.0, -450.0)
        tangent.label = "Default Tangent (UV Map)"

    links = tree.links
    for item, p in inputs:
        if p.name not in script.inputs:
            raise RuntimeError(f"shader {shader_name(model.id)!r} has no input {p.name!r}")
        for node in scripts:
            if p.name in node.inputs:
                links.new(_by_identifier(group_in.outputs, item.identifier), node.inputs[p.name])
    for node in scripts:
        if tangent is not None and "default_tangent" in node.inputs:
            links.new(tangent.outputs["Tangent"], node.inputs["default_tangent"])
    producers = {"BSDF": closure}
    for identifier, key in sockets.items():
        if key.startswith("out:"):
            name = key[4:]
            node = producers.get(name, script)
            links.new(node.outputs[name], _by_identifier(group_out.inputs, identifier))

    tree["rm_model"] = model.id
    tree["rm_variant"] = dict(variant)
    tree["rm_version"] = NODES_VERSION
    tree["rm_sockets"] = sockets
    if hasattr(tree, "description"):
        tree.description = model.description


def _by_identifier(collection, identifier):
    for socket in collection:
        if socket.identifier == identifier:
            return socket
    raise KeyError(identifier)


def socket_key(node, socket) -> str:
    """``"in:<param>"`` / ``"out:<output>"`` of a socket of an RM group node."""
    keys = node.node_tree.get("rm_sockets") or {}
    key = keys.get(socket.identifier)
    if key:
        return str(key)
    return ("in:" if not socket.is_output else "out:") + socket.name


def input_socket(node, name: str):
    """The input socket of RM group ``node`` for parameter ``name``
    (a catalogue name such as ``"beta"`` or ``"light_direction"``)."""
    for socket in node.inputs:
        if socket_key(node, socket) == "in:" + name:
            return socket
    raise KeyError(f"{node.name!r} has no input for {name!r}")


def output_socket(node, name: str):
    """The output socket of RM group ``node`` for shader output ``name``."""
    for socket in node.outputs:
        if socket_key(node, socket) == "out:" + name:
            return socket
    raise KeyError(f"{node.name!r} has no output {name!r}")


# ---------------------------------------------------------------------------
# Rebuilding while keeping the user's values, links and drivers

_INPUT_PATH = re.compile(r'^(?P<node>nodes\[".*"\])\.inputs\[(?P<index>\d+)\]\.(?P<rest>.+)$')


def _socket_value(socket):
    if not hasattr(socket, "default_value"):
        return None
    value = socket.default_value
    return tuple(value) if hasattr(value, "__len__") else value


def snapshot(node) -> dict:
    """Input values, links, drivers and keyframes of RM group ``node``, by
    socket key.

    Drivers and keyframes are kept as the F-curves themselves: their data
    paths hold socket indices, which :func:`restore` rewrites."""
    owner = node.id_data
    snap = {"inputs": {}, "in_links": {}, "out_links": {}, "drivers": [], "keyframes": []}
    for socket in node.inputs:
        value = _socket_value(socket)
        if value is not None:
            snap["inputs"][socket_key(node, socket)] = value
    for link in owner.links:
        if link.to_node == node:
            snap["in_links"][socket_key(node, link.to_socket)] = (
                link.from_node.name, link.from_socket.identifier)
        elif link.from_node == node:
            snap["out_links"].setdefault(socket_key(node, link.from_socket), []).append(
                (link.to_node.name, link.to_socket.identifier))
    anim = owner.animation_data
    if anim is not None:
        prefix = node.path_from_id()
        for fcurve in anim.drivers:
            m = _INPUT_PATH.match(fcurve.data_path)
            if m and m.group("node") == prefix and int(m.group("index")) < len(node.inputs):
                key = socket_key(node, node.inputs[int(m.group("index"))])
                snap["drivers"].append((fcurve, key, m.group("rest")))
        for fcurve in _action_fcurves(anim):
            m = _INPUT_PATH.match(fcurve.data_path)
            if m and m.group("node") == prefix and int(m.group("index")) < len(node.inputs):
                socket = node.inputs[int(m.group("index"))]
                snap["keyframes"].append(
                    (fcurve, socket_key(node, socket), socket.name, m.group("rest")))
    return snap


def _action_fcurves(anim) -> list:
    """The F-curves (keyframes) of the action animating ``anim``'s owner:
    through its slot in Blender's layered actions (4.4 and later), else the
    action's own list."""
    action = getattr(anim, "action", None)
    if action is None:
        return []
    try:
        from bpy_extras.anim_utils import action_get_channelbag_for_slot
    except ImportError:
        return list(action.fcurves)
    bag = action_get_channelbag_for_slot(action, anim.action_slot)
    return list(bag.fcurves) if bag is not None else []


def _values_fit(current, value) -> bool:
    if hasattr(current, "__len__"):
        return isinstance(value, tuple) and len(value) == len(current)
    return not isinstance(value, tuple)


def restore(node, snap: dict) -> None:
    """Put a :func:`snapshot` back on ``node`` after its group changed:
    sockets that still exist (same key) get their values, links, drivers and
    keyframes back; drivers of sockets that no longer exist are removed, and
    their keyframes are kept on a path by socket name, which animates the
    input again once a variant that has it is back."""
    owner = node.id_data
    by_key = {socket_key(node, s): s for s in list(node.inputs) + list(node.outputs)}
    for key, value in snap["inputs"].items():
        socket = by_key.get(key)
        if socket is not None and hasattr(socket, "default_value") \
                and _values_fit(socket.default_value, value):
            socket.default_value = value
    for key, (from_name, from_identifier) in snap["in_links"].items():
        socket = by_key.get(key)
        from_node = owner.nodes.get(from_name)
        if socket is not None and from_node is not None:
            for out in from_node.outputs:
                if out.identifier == from_identifier:
                    owner.links.new(out, socket)
    for key, targets in snap["out_links"].items():
        socket = by_key.get(key)
        for to_name, to_identifier in (targets if socket is not None else ()):
            to_node = owner.nodes.get(to_name)
            for inp in (to_node.inputs if to_node is not None else ()):
                if inp.identifier == to_identifier:
                    owner.links.new(socket, inp)
    anim = owner.animation_data
    prefix = node.path_from_id()
    index_of = {socket_key(node, s): i for i, s in enumerate(node.inputs)}
    for fcurve, key, rest in snap["drivers"]:
        if key not in index_of:
            anim.drivers.remove(fcurve)
            continue
        fcurve.data_path = f"{prefix}.inputs[{index_of[key]}].{rest}"
        fcurve.driver.is_valid = True
    for fcurve, key, name, rest in snap["keyframes"]:
        if key in index_of:
            fcurve.data_path = f"{prefix}.inputs[{index_of[key]}].{rest}"
        else:
            fcurve.data_path = f'{prefix}.inputs["{bpy.utils.escape_identifier(name)}"].{rest}'
        fcurve.is_valid = True


def _reset(node) -> None:
    """Remove every link of ``node`` and give its inputs the group's defaults
    (a swapped group may reuse socket identifiers for other parameters)."""
    owner = node.id_data
    for link in list(owner.links):
        if link.to_node == node or link.from_node == node:
            owner.links.remove(link)
    items = {item.identifier: item for item in node.node_tree.interface.items_tree
             if item.item_type == "SOCKET" and item.in_out == "INPUT"}
    for socket in node.inputs:
        item = items.get(socket.identifier)
        if item is not None and hasattr(item, "default_value"):
            socket.default_value = item.default_value


def upgrade_group(tree) -> None:
    """Rebuild an RM group in place from the current catalogue and shader,
    keeping the group itself (its name, and every node that uses it) and, on
    those nodes, the values, links, drivers and keyframes of the sockets that
    still exist."""
    info = rm_info(tree)
    if info is None:
        raise ValueError(f"{tree.name!r} is not a Reflection Models group")
    model_id, variant = info
    _model, variant = resolve_variant(model_id, variant)
    snaps = [(node, snapshot(node)) for node in group_nodes(tree)]
    _build(tree, model_id, variant)
    for node, snap in snaps:
        _reset(node)
        restore(node, snap)


def switch_variant(node, **changes):
    """Give RM group ``node`` the group of another variant of its model
    (``changes``: enum values, e.g. ``distribution="trowbridge_reitz"``),
    keeping the values, links, drivers and keyframes of the sockets both
    variants have (keyframes of a socket the new variant lacks are kept for a
    switch back, see :func:`restore`).

    When the change makes another enum invalid (``smith_1967`` needs
    ``beckmann``; native widths need Trowbridge-Reitz or Beckmann), that enum
    falls back to its default.  Returns ``(tree, reset)``, ``reset`` the
    names of the enums so reset.  Raises ``ValueError`` for bad names or
    values."""
    info = rm_info(node.node_tree)
    if info is None:
        raise ValueError(f"{node.name!r} is not a Reflection Models node")
    model_id, current = info
    merged = {**current, **changes}
    reset = []
    for p in (None,) + variant_params(model_id):
        if p is not None:
            if p.name in changes or merged.get(p.name) == p.default:
                continue
            merged[p.name] = p.default
            reset.append(p.name)
        try:
            resolve_variant(model_id, merged)
            break
        except ValueError:
            if p is None:
                resolve_variant(model_id, changes)  # raises if the change itself is bad
    tree = ensure_group(model_id, **merged)
    snap = snapshot(node)
    if node.node_tree != tree:
        node.node_tree = tree
    _reset(node)
    restore(node, snap)
    return tree, tuple(reset)
