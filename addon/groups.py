# SPDX-License-Identifier: GPL-3.0-or-later
"""Node groups of the reflection models in Blender.

One shader node group per model variant (:mod:`addon.core.variants`: the
name, the sockets, the width modes), built from the catalogue: Group Input
-> the model's shaders -> Group Output.  Today the shaders are OSL Script
nodes (:mod:`addon.backends.osl`): the model's exact shader for the Direct,
Color and term outputs, its closure-only shader for the BSDF output, the
enum parameters set as constant integers, and, in the variants that use a
tangent, a Tangent node (UV map) feeding ``default_tangent``.

Each group stores ``tree["rm_model"]`` (model id), ``tree["rm_variant"]``
(its structural choices), ``tree["rm_version"]`` (:data:`NODES_VERSION` when
built), ``tree["rm_native"]`` (the native capabilities its native nodes
were planned for, where it has them) and ``tree["rm_sockets"]`` (interface
identifier -> ``"in:<param>"`` or ``"out:<shader output>"``), which lets :func:`upgrade_group` and
:func:`switch_variant` carry socket values, links, drivers and keyframes
across a rebuild.

Imports bpy: only for use inside Blender.
"""

from __future__ import annotations

import re

import bpy

from .backends.native import build as native_build
from .backends.osl import compile as osl_compile
from .backends.osl.generate import enum_codes, shader_name
from .core import catalogue
from .core.formulas.models import NATIVE_CLOSURES
from .core.variants import (  # noqa: F401  (re-exported for the UI and the tests)
    BACKEND_PARAM, CHOICE_LABELS, GROUP_PREFIX, LIGHTS_PARAM, MAX_NAME, NAME_LABELS,
    OUTPUT_DESCRIPTIONS, WIDTH_FROM_REFERENCE, WIDTH_MODES, WIDTH_PARAM, WIDTH_SOCKETS,
    choice_label, group_name, input_params,
    output_label, resolve_variant, socket_params, uses_tangent, variant_key, variant_params,
)

NODES_VERSION = 30  # 2: a closure-only shader feeds the BSDF output;
# 3: the UV Tangent node only in variants that use a tangent;
# 4: shaders generated from the formula description (rm_library.h);
# 5: native nodes beside the OSL shaders, switched by rm_osl (backend 'auto');
#    spot inputs; 1 to 4 lights
# 6: exact mode's cos^s from the angle's tangent and beta's tan / -2 ln cos
#    from their series below 8.6 deg (float32 precision of narrow lobes), so
#    that groups saved before get them
# 7: fewer native nodes in exact mode (one Reflect node for Phong's mirror
#    direction, a colour times one masked float): cheaper groups for files
#    saved before
# 8: fewer native nodes in the fitted mixtures (the weight series by
#    Horner's rule, three members per vector operation, no tangent for an
#    isotropic closure, a colour times a weight in one node, no unused nodes)
# 9: the microfacet model's exact mode with one width computes no tangent
#    (lengths across the normal; cheaper in OSL and in native nodes)
# 10: Kajiya-Kay's fibre, where it falls back to the frame's tangent, is
#    turned by Tangent Rotation once (it was turned twice)
# 11: the native tables (Float Curves) of one variable share one clamp of
#    it: 68 fewer nodes in each fitted mixture with 35 tables
# 12: native Phong's BSDF output is a mixture of Toon lobes in Cycles (the
#    Glossy one in EEVEE, behind a switch between the engines)
# 13: native Phong's Toon mixture fitted again (its narrowest node from a
#    second start): groups saved before get the new data
# 14: native Phong's Toon mixture fitted to the linear programme's whole
#    objective (the albedo too), everywhere in Cycles (no Glossy band)
# 15: its node at s = 0.85 from a second start (the albedo-held floor's lobes)
# 16: the microfacet mixtures' diffuse member takes the model's Fresnel at
#    the mean L.H of the lights it reflects (was: at the view)
# 17: Blinn with correlated Smith's mixture re-solved with the lights on the
#    domain's edge (fitting/assemble.py's finish_edge): groups saved before
#    get the new data
# 18: Gaussian with separable Smith's mixture re-solved with the lights on
#    the domain's edge, one interval at a time: groups saved before get the
#    new data
# 19: Blinn with separable Smith's mixture re-solved with the lights on the
#    domain's edge, one interval at a time, the error under Fresnel held:
#    groups saved before get the new data
# 20: ... and a second pass of that step over what the first left (every
#    width within the bound without Fresnel): groups saved before get it
# 21: Gaussian with separable Smith's mixture through the same step,
#    three passes under its present keep rule (its worst interval 0.0343 ->
#    0.0317): groups saved before get the new data
# 22: the microfacet model's exact value takes L.H as |L + E| / 2 (it was a
#    dot product, which float32 halved or made negative with L and E almost
#    opposite near grazing: a silhouette lit from behind), and the conductor
#    Fresnel n^2 - k^2 - sin^2 as n^2 - k^2 - 1 + c^2 (1 - c^2 lost c^2);
#    Kajiya-Kay's sines as |T x w| (sqrt(1 - cos^2) erred near the fibre)
# 23: in Blender 4.5 the native BSDF output's GGX lobes with a dielectric's
#    Fresnel are the Principled BSDF's specular layer (exact; a coloured
#    weight the tint of a coat of index 1) where the index is one number (the
#    Metallic BSDF's conductor Fresnel at k = 0, an older approximation
#    there, was 2.1 of the peak off); 5.2's graphs as before
# 24: in Blender 4.5 that lobe also where the index differs by channel: one
#    Principled BSDF per channel, its coat's tint the channel's unit colour
#    (the Metallic BSDF there measured 0.06-0.14 of the peak off); 5.2's
#    graphs as before
# 25: in Blender 4.5 the native Metallic BSDF's weight times the exact
#    Fresnel over 4.5's approximation at the view (exact at the lobe's
#    mirror direction); groups record the Blender capabilities their native
#    nodes were built for (``rm_native``), and a group built for another
#    Blender's is outdated too (a file made in 4.5 opened in 5.2 had no
#    shadow ray in native exact mode)
# 26: native Phong's switch between the engines takes Shader to RGB's Alpha
#    through a Maximum node (Blender 5.3.0's EEVEE crashed on the Mix Shader
#    fed by it directly, next to an Add Shader): files saved before get it
# 27: Kajiya-Kay's hair reflection lobe takes a weight of the view that sets
#    its peak to the model's (it was a normalised lobe, 3.8 times the model's
#    peak at the default exponent, 600 toward 10,000), a latitudinal
#    roughness 0.38 times the former and an azimuthal one of 1 (in EEVEE,
#    which renders it as a diffuse closure, without the weight, behind the
#    switch between the engines): groups saved before get it
# 28: Kajiya-Kay's diffuse closure weighted 2 / (1 + cos 70 deg) = 1.49
#    (its largest difference from kd sin theta_L over lights to 70 deg 0.49
#    of the peak, 0.66 before): groups saved before get it
# 29: the hair weight's normalisation a - b as one arc tangent of two
#    arguments (it was two arc tangents and two divisions): fewer native
#    nodes for groups saved before
# 30: Kajiya-Kay's BSDF output adds an anisotropic GGX lobe about the fibre,
#    which lights the mirror cone across the fibre from the view, where the
#    hair lobe is 0 (its figure over every light 0.87 of the peak, 1.0
#    before): groups saved before get it
"""Bump when the layout of the groups changes; older groups are then listed by
:func:`find_outdated_groups` and rebuilt by :func:`upgrade_group`."""

_SOCKET_TYPES = {"VALUE": "NodeSocketFloat", "INT": "NodeSocketInt",
                 "RGBA": "NodeSocketColor", "VECTOR": "NodeSocketVector",
                 "SHADER": "NodeSocketShader"}


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
             if t.library is None and _resolved_info(t) == (model.id, variant)]
    found.sort(key=lambda t: t.name != name)
    return found[0] if found else None


def _resolved_info(tree):
    """``rm_info`` with the variant's defaults filled in (a group made before
    a structural parameter existed has the default), or None."""
    info = rm_info(tree)
    if info is None:
        return None
    try:
        return info[0], resolve_variant(*info)[1]
    except ValueError:
        return None


def find_outdated_groups() -> list:
    """Local groups built by an older :data:`NODES_VERSION`, or whose native
    nodes were planned for another Blender's (:func:`built_for_another_blender`)."""
    return [t for t in bpy.data.node_groups
            if t.library is None and rm_info(t) is not None and is_outdated(t)]


def outdated_counts(outdated=None) -> tuple:
    """``(older, other)``: of the outdated groups (``outdated``, else
    :func:`find_outdated_groups`), how many an older version built and how
    many were planned for another Blender's native nodes (counted there only)."""
    outdated = find_outdated_groups() if outdated is None else outdated
    other = sum(map(built_for_another_blender, outdated))
    return len(outdated) - other, other


def is_outdated(tree) -> bool:
    """Whether the RM group ``tree`` is to be built again: by an older
    :data:`NODES_VERSION`, or for another Blender's native nodes."""
    return int(tree.get("rm_version", 0)) < NODES_VERSION or built_for_another_blender(tree)


def built_for_another_blender(tree) -> bool:
    """Whether the native nodes of RM group ``tree`` were planned for a
    Blender with other native capabilities than this one's
    (``native.build.capabilities``: the Raycast node, the exact conductor
    Fresnel), as when a file made in 4.5 is opened in 5.2: its exact mode
    has no shadow ray, and its Metallic BSDFs' weights correct a Fresnel
    that 5.2 no longer approximates.  A group without native nodes (backend
    'osl'), or one an older version built, records none."""
    built = tree.get("rm_native")
    if built is None:
        return False
    return {key: bool(built.get(key)) for key in native_build.capabilities()} \
        != native_build.capabilities()


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


def rm_nodes_in(tree, seen=None):
    """The RM group nodes in ``tree`` and in the user's groups inside it, at
    any depth (not inside RM groups).  ``seen``: the pointers of the trees
    walked already, shared between calls to walk each tree once."""
    seen = set() if seen is None else seen
    if tree is None or tree.as_pointer() in seen:
        return
    seen.add(tree.as_pointer())
    for node in tree.nodes:
        if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None:
            if rm_info(node.node_tree) is not None:
                yield node
            else:
                yield from rm_nodes_in(node.node_tree, seen)


def materials_of(node) -> list:
    """The materials whose tree holds RM group ``node``, directly or inside
    groups of the user's."""
    return [mat for mat in bpy.data.materials
            if any(other == node for other in rm_nodes_in(mat.node_tree))]


def _tree_uses_rm(tree, seen) -> bool:
    return any(True for _node in rm_nodes_in(tree, seen))


def _tree_backends(tree, seen, out) -> None:
    for node in rm_nodes_in(tree, seen):
        info = _resolved_info(node.node_tree)
        if info is not None:
            out.add(info[1].get(BACKEND_PARAM.name, BACKEND_PARAM.default))


def kept_depsgraph(layer):
    """The depsgraph Blender keeps of the view layer ``layer``, not brought
    up to date; None where it keeps none (before the layer's first
    evaluation, after loading a file)."""
    try:
        return layer.depsgraph
    except (AttributeError, RuntimeError):
        return None


def kept_depsgraphs(scene) -> list:
    """:func:`kept_depsgraph` of each view layer of ``scene`` that has one."""
    return [g for g in map(kept_depsgraph, scene.view_layers) if g is not None]


def object_scenes() -> dict:
    """Object pointer -> the scenes it is in, from one walk of every
    scene's objects (``Object.users_scene`` walks them for each object, so
    asking every object made a large scene's checks grow with its size
    squared)."""
    out = {}
    for scene in bpy.data.scenes:
        for obj in scene.objects:
            out.setdefault(obj.as_pointer(), []).append(scene)
    return out


def materials_as_kept(obj, graphs=None) -> set:
    """The materials ``obj`` renders with (:func:`rendered_materials`) in
    the depsgraphs ``graphs`` (by default those Blender keeps of its
    scenes' view layers, :func:`kept_depsgraphs`), none evaluated; without
    one, its slots and its instancing outside Geometry Nodes."""
    if graphs is None:
        graphs = [g for scene in obj.users_scene for g in kept_depsgraphs(scene)]
    out = set()
    for graph in graphs or [None]:
        out |= rendered_materials(obj, graph)
    return out


def _scene_materials(scene) -> set:
    """The materials ``scene``'s objects render with, as Blender keeps
    them (:func:`materials_as_kept`)."""
    graphs = kept_depsgraphs(scene)
    out = set()
    for obj in scene.objects:
        out |= materials_as_kept(obj, graphs)
    return out


def scene_backends(scene) -> set:
    """The backends ('auto', 'osl', 'native') of the RM groups that the
    materials of ``scene``'s objects (through slots, Geometry Nodes and
    instancing) and its world use."""
    seen, out = set(), set()
    if scene.world is not None:
        _tree_backends(scene.world.node_tree, seen, out)
    for material in _scene_materials(scene):
        _tree_backends(material.node_tree, seen, out)
    return out


def scene_uses_rm_groups(scene) -> bool:
    """Whether a material of an object of ``scene`` (through slots,
    Geometry Nodes and instancing), or its world, holds an RM group node
    (directly or inside other groups)."""
    seen = set()
    if scene.world is not None and _tree_uses_rm(scene.world.node_tree, seen):
        return True
    return any(_tree_uses_rm(m.node_tree, seen) for m in _scene_materials(scene))


_GEOMETRY = ("mesh", "curves", "pointcloud", "volume", "grease_pencil")


def _geometry_materials(geometry, graph, seen) -> set:
    """The materials of a Geometry Nodes geometry set and of what it
    instances, at any depth."""
    out = set()
    for name in _GEOMETRY:
        data = getattr(geometry, name, None)
        if data is not None:
            out |= {m.original for m in getattr(data, "materials", ()) if m is not None}
    for ref in geometry.instance_references():
        if isinstance(ref, bpy.types.Object):
            out |= rendered_materials(ref, graph, seen)
        elif isinstance(ref, bpy.types.Collection):
            for obj in ref.all_objects:
                out |= rendered_materials(obj, graph, seen)
        else:
            out |= _geometry_materials(ref, graph, seen)
    return out


def rendered_materials(obj, graph=None, seen=None) -> set:
    """The materials ``obj`` renders with in the depsgraph ``graph``: its
    evaluated slots (a Set Material node of its Geometry Nodes included)
    and those of what it instances (a collection, its children as vertex
    or face instances, its particles' objects, its Geometry Nodes
    instances), read from the instancing's references, not from each
    instance.  Without ``graph``: its slots and what it instances outside
    Geometry Nodes."""
    seen = set() if seen is None else seen
    key = obj.original.as_pointer()
    if key in seen:
        return set()
    seen.add(key)
    evaluated = obj
    if graph is not None:
        try:
            evaluated = obj.evaluated_get(graph)
        except (RuntimeError, ReferenceError):
            pass
    out = {slot.material.original for slot in getattr(evaluated, "material_slots", ())
           if slot.material is not None}
    instanced = []
    if obj.instance_type == 'COLLECTION' and obj.instance_collection is not None:
        instanced += list(obj.instance_collection.all_objects)
    elif obj.instance_type in ('VERTS', 'FACES'):
        instanced += list(obj.children)
    for system in getattr(obj, "particle_systems", ()):
        settings = system.settings
        if settings.render_type == 'OBJECT' and settings.instance_object is not None:
            instanced.append(settings.instance_object)
        elif settings.render_type == 'COLLECTION' and settings.instance_collection is not None:
            instanced += list(settings.instance_collection.all_objects)
    for other in instanced:
        out |= rendered_materials(other, graph, seen)
    if graph is not None and hasattr(evaluated, "evaluated_geometry") \
            and any(m.type == 'NODES' for m in getattr(obj, "modifiers", ())):
        out |= _geometry_materials(evaluated.evaluated_geometry(), graph, seen)
    return out


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
            remove_group(tree)
            raise
    elif is_outdated(tree):
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


class _Spec:
    """One interface socket of a group: its key (``"in:<param>"`` or
    ``"out:<output>"``), label, direction, socket type, tooltip, panel and,
    for inputs, the catalogue parameter that sets its subtype and limits."""

    def __init__(self, key, label, in_out, socket_type, description, panel="", param=None):
        self.key, self.label, self.in_out = key, label, in_out
        self.socket_type, self.description = socket_type, description
        self.panel, self.param = panel, param


# The closures of the native nodes: all but Phong's lobe (phong_ramp).

_OUTPUT_TYPES = {"c": "NodeSocketShader", "v": "NodeSocketColor", "f": "NodeSocketFloat"}
_INPUT_TYPES = {"color": "NodeSocketColor", "direction": "NodeSocketVector",
                "position": "NodeSocketVector", "normal": "NodeSocketVector"}


def interface_specs(model_id: str, variant: dict) -> list:
    """The group's interface in order: the outputs (BSDF, Direct, Color, the
    model's terms), then the inputs with their panels."""
    from .core.formulas.models import FORMULAS

    terms = FORMULAS[model_id].terms
    specs = []
    for name, kind in (("BSDF", "c"), ("Direct", "c"), ("Color", "v")) + tuple(terms):
        specs.append(_Spec("out:" + name, output_label(name), "OUTPUT", _OUTPUT_TYPES[kind],
                           OUTPUT_DESCRIPTIONS.get(
                               name, f"{output_label(name)}: a term of the model for the light "
                                     "of the Light inputs")))
    for p in input_params(model_id, variant):
        specs.append(_Spec("in:" + p.name, p.label, "INPUT",
                           _INPUT_TYPES.get(p.kind, "NodeSocketFloat"), p.description,
                           p.panel, p))
    return specs


def _sync_interface(tree, specs) -> dict:
    """Make ``tree``'s interface the ``specs``, in order, keeping the items
    of sockets that stay (same key, direction and type): their identifiers,
    and so the values, links, drivers and keyframes on the nodes using the
    group (clearing the interface would delete the drivers and keyframes of
    every socket).  Returns ``{identifier: key}``."""
    iface = tree.interface
    keys = dict(tree.get("rm_sockets") or {})
    existing, panels = {}, {}
    for item in list(iface.items_tree):
        if item.item_type == "SOCKET":
            key = keys.get(item.identifier)
            if key is None or key in existing:
                iface.remove(item)  # not ours, or a duplicate: rebuilt below
            else:
                existing[key] = item
        elif item.item_type == "PANEL":
            panels[item.name] = item
    used_panels, placed, sockets = set(), {}, {}
    for spec in specs:
        parent = None
        if spec.panel:
            parent = panels.get(spec.panel)
            if parent is None:
                parent = panels[spec.panel] = iface.new_panel(spec.panel)
            parent.default_closed = spec.panel in ("Light", "Geometry")
            used_panels.add(spec.panel)
        item = existing.pop(spec.key, None)
        if item is not None and (item.in_out != spec.in_out
                                 or item.socket_type != spec.socket_type):
            iface.remove(item)
            item = None
        if item is None:
            item = iface.new_socket(spec.label, in_out=spec.in_out, socket_type=spec.socket_type,
                                    description=spec.description, parent=parent)
        else:
            item.name = spec.label
            item.description = spec.description
        if spec.param is not None:
            _set_interface_socket(item, spec.param)
        target = parent if parent is not None else item.parent
        position = placed.get(target.name, 0)
        if item.parent.name != target.name or item.position != position:
            iface.move_to_parent(item, target, position)
        placed[target.name] = position + 1
        sockets[item.identifier] = spec.key
    for item in existing.values():
        iface.remove(item)
    for name, panel in panels.items():
        if name not in used_panels:
            iface.remove(panel)
    return sockets


def _build(tree, model_id: str, variant: dict) -> None:
    """(Re)build ``tree`` in place as the group of ``model_id`` ``variant``:
    the OSL shaders, the native nodes, or both with a switch (backend
    'auto'), between the Group Input and the Group Output."""
    model, _fixed, _defaults = catalogue.resolve(model_id)
    sockets = _sync_interface(tree, interface_specs(model.id, variant))
    parts = _parts(tree)
    tree.nodes.clear()
    _remove_unused(parts)
    group_in = tree.nodes.new("NodeGroupInput")
    group_in.location = (-700.0, 0.0)
    group_out = tree.nodes.new("NodeGroupOutput")
    group_out.location = (700.0, 0.0)
    by_key = {key: identifier for identifier, key in sockets.items()}

    def group_input(name):
        return _by_identifier(group_in.outputs, by_key["in:" + name])

    backend = variant.get(BACKEND_PARAM.name, BACKEND_PARAM.default)
    results = {}
    if backend in ("auto", "osl"):
        results["osl"] = _build_osl(tree, model, variant, group_input)
    if backend in ("auto", "native"):
        results["native"] = _build_native(tree, model, variant, group_input)
    if backend == "auto":
        outputs = _switch(tree, results["native"], results["osl"])
    else:
        outputs = results[backend]
    for identifier, key in sockets.items():
        kind, name = key.split(":", 1)
        if kind == "out" and outputs.get(name) is not None:
            tree.links.new(outputs[name], _by_identifier(group_out.inputs, identifier))

    tree["rm_model"] = model.id
    tree["rm_variant"] = dict(variant)
    tree["rm_version"] = NODES_VERSION
    if "native" in results:
        tree["rm_native"] = native_build.capabilities()
    elif "rm_native" in tree:
        del tree["rm_native"]
    tree["rm_sockets"] = sockets
    if hasattr(tree, "description"):
        tree.description = model.description


def _parts(tree) -> list:
    """The nested groups the native nodes of ``tree`` are built in
    (:meth:`.backends.native.build.Builder.instantiate`)."""
    return [n.node_tree for n in tree.nodes
            if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None
            and n.node_tree.get("rm_part")]


def remove_group(tree) -> None:
    """Remove the group ``tree`` with the nested groups its native nodes
    are built in (those no other group uses)."""
    parts = _parts(tree)
    bpy.data.node_groups.remove(tree)
    _remove_unused(parts)


# the NODES_VERSION since which native Phong's engine switch has its Maximum node
SWITCH_THROUGH_MAXIMUM = 26


def mend_engine_switches() -> int:
    """Groups built before :data:`SWITCH_THROUGH_MAXIMUM` feed native Phong's
    switch between the engines (a Mix Shader) from a Shader to RGB node's
    Alpha directly, which Blender 5.3.0's EEVEE crashes on (a segmentation
    fault in a render, measured: ``docs/compatibility.md``).
    Each such link of a local RM group (and of its nested parts) gets the
    Maximum node the groups have since (its other input 0; the one the
    link feeds 0 where Cycles drops the link): what renders is unchanged in
    both engines, and nothing else of the group is touched (it stays listed
    as outdated).  Run at each file's load.  Returns the links mended."""
    mended, seen = 0, set()
    for tree in [t for t in bpy.data.node_groups if t.library is None and rm_info(t)]:
        if int(tree.get("rm_version", 0)) >= SWITCH_THROUGH_MAXIMUM:
            continue
        for sub in [tree] + _parts(tree):
            if sub.name_full in seen:
                continue
            seen.add(sub.name_full)
            for link in [ln for ln in sub.links
                         if ln.from_node.bl_idname == "ShaderNodeShaderToRGB"
                         and ln.to_node.bl_idname == "ShaderNodeMixShader"
                         and ln.to_socket == ln.to_node.inputs[0]]:
                source, factor = link.from_socket, link.to_socket
                top = sub.nodes.new("ShaderNodeMath")
                top.operation = 'MAXIMUM'
                top.label = "EEVEE's 1, Cycles' 0"
                top.location = (link.from_node.location.x + 100.0, link.from_node.location.y)
                if link.from_node.parent is not None:
                    top.parent = link.from_node.parent
                top.inputs[0].default_value = 0.0
                top.inputs[1].default_value = 0.0
                sub.links.remove(link)
                sub.links.new(source, top.inputs[0])
                sub.links.new(top.outputs[0], factor)
                mended += 1
    return mended


def _remove_unused(parts) -> None:
    """Remove the parts no group uses any more (a copy of the group, made by
    the user, still uses its parts)."""
    for part in parts:
        if part.users == 0:
            bpy.data.node_groups.remove(part)


def _build_osl(tree, model, variant, group_input) -> dict:
    """The OSL shaders: the exact one (Direct, Color, terms) and the variant's
    closure-only one (BSDF: a path-traced material compiles only that)."""
    script = osl_compile.make_script_node(tree, shader_name(model.id))
    script.location = (0.0, 0.0)
    script.label = model.label + " (OSL, exact)"
    closure = osl_compile.make_script_node(tree, shader_name(model.id, True, variant))
    closure.location = (0.0, 400.0)
    closure.label = model.label + " (OSL, BSDF)"
    scripts = (closure, script)
    codes = enum_codes(model.id)
    for p in variant_params(model.id):
        if p.name not in codes:
            continue
        for node in scripts:
            if p.name not in node.inputs:
                raise RuntimeError(f"shader {node.name!r} has no int input {p.name!r}")
            node.inputs[p.name].default_value = codes[p.name][variant[p.name]]
            node.inputs[p.name].hide = True
    for p in input_params(model.id, variant):
        if p.name not in script.inputs:
            raise RuntimeError(f"shader {shader_name(model.id)!r} has no input {p.name!r}")
        for node in scripts:
            if p.name in node.inputs:
                tree.links.new(group_input(p.name), node.inputs[p.name])
    # The UV tangent only where the variant uses one: Cycles computes the
    # mesh's tangents for every render and looks them up at every shading
    # point once the node is in the graph, used or not (measured in
    # verification/bench/render.py).
    if uses_tangent(model.id, variant):
        tangent = tree.nodes.new("ShaderNodeTangent")
        tangent.direction_type = "UV_MAP"
        tangent.location = (-350.0, -450.0)
        tangent.label = "Default Tangent (UV Map)"
        for node in scripts:
            if "default_tangent" in node.inputs:
                tree.links.new(tangent.outputs["Tangent"], node.inputs["default_tangent"])
    out = {"BSDF": closure.outputs["BSDF"]}
    out.update({o.name: o for o in script.outputs})
    return out


def _build_native(tree, model, variant, group_input) -> dict:
    """The native nodes, generated from the same description as the OSL:
    the exact evaluation (the shadow through the Raycast node where Blender
    has one) and the path-traced closures."""
    from .backends.native import emit as native_emit
    from .core.formulas import models as formulas

    formula = formulas.FORMULAS[model.id]
    enums = {k: v for k, v in variant.items() if k != BACKEND_PARAM.name}
    v = formulas.Values(model.id, enums, known=True)
    s = formulas.shading(model.id, enums, caps=NATIVE_CLOSURES)
    exact = formulas.exact(model.id, v, s)
    graphs = {"BSDF": formula.closure(v, s), **exact}
    plan, refs = native_emit.plan(graphs, **native_build.capabilities())
    builder = native_build.Builder(tree, group_input, origin=(-350.0, -900.0),
                                   label=f"{model.label}: native nodes (GPU, EEVEE, OSL off)")
    out = builder.instantiate(plan, refs)
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.parent = builder.frame
    emission.location = (-350.0, -700.0)
    emission.inputs["Strength"].default_value = 1.0
    _feed(tree, emission.inputs["Color"], out["Color"])
    out["Direct"] = emission.outputs["Emission"]
    tree["rm_native_nodes"] = builder.count
    return out


def _feed(tree, socket, src):
    """Link an output socket, or set a constant ``("const", value)``."""
    if src is None:
        return
    if isinstance(src, tuple) and src and src[0] == "const":
        native_build.set_constant(socket, src[1])
        return
    tree.links.new(src, socket)


def _switch(tree, native: dict, osl: dict) -> dict:
    """Per output, the OSL result where OSL runs, else the native one: the
    factor comes from the rm_osl Script node (1), whose link Cycles drops
    without OSL (the factor's default, 0, stays)."""
    flag = osl_compile.make_script_node(tree, "rm_osl")
    flag.location = (200.0, 700.0)
    flag.label = "1 where OSL runs"
    out = {}
    y = 300.0
    for name, osl_socket in osl.items():
        native_src = native.get(name)
        if osl_socket.type == "SHADER":
            mix = tree.nodes.new("ShaderNodeMixShader")
            mix.inputs[0].default_value = 0.0
            tree.links.new(flag.outputs["osl"], mix.inputs[0])
            _feed(tree, mix.inputs[1], native_src)
            tree.links.new(osl_socket, mix.inputs[2])
            result = mix.outputs[0]
        else:
            mix = tree.nodes.new("ShaderNodeMix")
            mix.data_type = "RGBA" if osl_socket.type == "RGBA" else "FLOAT"
            mix.clamp_factor = True
            fac = mix.inputs[0]
            fac.default_value = 0.0
            tree.links.new(flag.outputs["osl"], fac)
            ins = [s for s in mix.inputs if s.enabled][1:3]
            _feed(tree, ins[0], native_src)
            tree.links.new(osl_socket, ins[1])
            result = next(s for s in mix.outputs if s.enabled)
        mix.location = (450.0, y)
        mix.label = f"{name}: OSL or native"
        y -= 160.0
        out[name] = result
    return out


def _by_identifier(collection, identifier):
    for socket in collection:
        if socket.identifier == identifier:
            return socket
    raise KeyError(identifier)


def socket_key(node, socket, keys=None) -> str:
    """``"in:<param>"`` / ``"out:<output>"`` of a socket of an RM group node.
    ``keys``: the group's ``rm_sockets`` property, read here if None."""
    keys = (node.node_tree.get("rm_sockets") or {}) if keys is None else keys
    key = keys.get(socket.identifier)
    if key:
        return str(key)
    return ("in:" if not socket.is_output else "out:") + socket.name


def input_sockets(node) -> dict:
    """Parameter name -> input socket of RM group ``node``, in one walk of
    its inputs (for code that looks up many: :func:`input_socket` walks
    them each time)."""
    keys = node.node_tree.get("rm_sockets") or {}
    out = {}
    for socket in node.inputs:
        out.setdefault(socket_key(node, socket, keys)[3:], socket)
    return out


def has_tangent(node) -> bool:
    """Whether RM group ``node``'s variant has a Tangent input (Kajiya-Kay,
    Ward, the microfacet widths alpha_x and alpha_y)."""
    return "tangent" in input_sockets(node)


def _socket(sockets, node, want):
    keys = node.node_tree.get("rm_sockets") or {}  # read once, not once a socket
    return next((s for s in sockets if socket_key(node, s, keys) == want), None)


def input_socket(node, name: str):
    """The input socket of RM group ``node`` for parameter ``name``
    (a catalogue name such as ``"beta"`` or ``"light_direction"``)."""
    socket = _socket(node.inputs, node, "in:" + name)
    if socket is None:
        raise KeyError(f"{node.name!r} has no input for {name!r}")
    return socket


def output_socket(node, name: str):
    """The output socket of RM group ``node`` for shader output ``name``."""
    socket = _socket(node.outputs, node, "out:" + name)
    if socket is None:
        raise KeyError(f"{node.name!r} has no output {name!r}")
    return socket


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
    paths held socket indices, and are set here to paths by the socket's
    identifier until :func:`restore` writes them by index again.  (At the
    swap of a node's group Blender can delete the F-curves whose index path
    no longer resolves, an index past the new group's inputs: drivers when
    the tree also has keyframes, and keyframes; writing to such an F-curve
    crashed Blender, measured in 5.2.4.  A path by identifier keeps them.)"""
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
                socket = node.inputs[int(m.group("index"))]
                snap["drivers"].append((fcurve, socket_key(node, socket), m.group("rest")))
                fcurve.data_path = _identifier_path(prefix, socket, m.group("rest"))
        for fcurve in _action_fcurves(anim):
            m = _INPUT_PATH.match(fcurve.data_path)
            if m and m.group("node") == prefix and int(m.group("index")) < len(node.inputs):
                socket = node.inputs[int(m.group("index"))]
                snap["keyframes"].append(
                    (fcurve, socket_key(node, socket), socket.name, m.group("rest")))
                fcurve.data_path = _identifier_path(prefix, socket, m.group("rest"))
    return snap


def _identifier_path(prefix, socket, rest) -> str:
    return f'{prefix}.inputs["{bpy.utils.escape_identifier(socket.identifier)}"].{rest}'


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
    alive = {fcurve.as_pointer() for fcurve in anim.drivers} if anim is not None else set()
    for fcurve, key, rest in snap["drivers"]:
        if fcurve.as_pointer() not in alive:  # deleted by Blender after all: never touched
            continue
        if key not in index_of:
            anim.drivers.remove(fcurve)
            continue
        fcurve.data_path = f"{prefix}.inputs[{index_of[key]}].{rest}"
        fcurve.driver.is_valid = True
    alive = {fcurve.as_pointer() for fcurve in _action_fcurves(anim)} if anim is not None \
        else set()
    for fcurve, key, name, rest in snap["keyframes"]:
        if fcurve.as_pointer() not in alive:
            continue
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
