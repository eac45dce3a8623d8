# SPDX-License-Identifier: GPL-3.0-or-later
"""Lamps for exact mode: binding the Light inputs of RM nodes to lamps by
drivers, and the light linking of the hybrid mode.

Binding (:func:`bind_lights`): light k of a node (its inputs ``<name>`` for
k = 1, ``<name>_<k>`` after) follows lamp k through drivers made of simple
expressions only (no Python auto-run needed): a sun's direction from its
world matrix, a point or spot lamp's position from its world location, a
spot's axis, size and blend, the strength (none while the lamp object is
disabled in renders, or while every way down to it from the scene's
collection has a collection disabled in renders or excluded from the view
layer being rendered, or while its ray visibility for the model's kind of
surface, diffuse or glossy, is off) and colour, and whether it casts
shadows.  Binding n lamps gives the node the group variant with n lights
(structural: each light costs a shadow ray).

Hybrid mode: the material renders the bound lamps exactly (the Direct
output) and everything else with the path-traced BSDF.  So that no lamp
counts twice, every object using the material is excluded from the bound
lamps' light by light linking (the lamp's ``light_linking.receiver_collection``,
link state EXCLUDE; lamps bound by the same hybrid materials share one, and a
lamp bound to none loses the extension's: see :func:`sync_light_linking`).
A hybrid node counts in the material's tree and inside the user's groups
there; an object uses the material through a slot or
through the geometry its Geometry Nodes modifiers make (a Set Material
node), and an instancer (a collection instance, particles, Geometry Nodes
instances) uses the materials of what it instances: EEVEE applies an
instancer's light linking to its instances and not the instanced object's
own, and so does Cycles to Geometry Nodes instances (to the others the
instancer's where it has some).  These are read from the
evaluated depsgraphs of the bound lamps' scenes' view layers.
What the extension adds is recorded on the collection
(``rm_added``, the objects themselves, not their names: :func:`added_objects`;
``rm_made`` when it made the collection), so that
:func:`sync_light_linking` adds objects that got the material later, drops
those that lost it, and unbinding removes exactly what binding added and
nothing a user linked by hand.  The links are ordinary file data: a file
renders the same without the extension.

Imports bpy.
"""

from __future__ import annotations

import contextlib
import logging
import re

import bpy

from . import groups
from .core import catalogue, variants

log = logging.getLogger(__name__)

SUPPORTED_LIGHTS = ("SUN", "POINT", "SPOT")
LIGHT_NAMES = tuple(p.name for p in catalogue.LIGHT_INPUTS)
HYBRID = "hybrid"


def socket_name(name: str, k: int) -> str:
    return name if k == 1 else f"{name}_{k}"


# ---------------------------------------------------------------------------
# Drivers

def _drive(socket, index, expression, variables):
    """A scripted driver on ``socket.default_value[index]`` (index -1 for a
    scalar) with a simple expression; ``variables``: name -> callable
    filling a new driver variable."""
    fcurve = socket.driver_add("default_value", index) if index >= 0 \
        else socket.driver_add("default_value")
    driver = fcurve.driver
    driver.type = 'SCRIPTED'
    while driver.variables:
        driver.variables.remove(driver.variables[0])
    for name, fill in variables.items():
        var = driver.variables.new()
        var.name = name
        fill(var)
    driver.expression = expression
    for mod in list(fcurve.modifiers):  # driver_add adds a Generator modifier
        fcurve.modifiers.remove(mod)
    return fcurve


def _prop(data, path):
    """A driver variable reading ``path`` of the ID ``data`` (a light's data
    or a lamp object)."""
    def fill(var):
        var.type = 'SINGLE_PROP'
        target = var.targets[0]
        target.id_type = data.id_type
        target.id = data
        target.data_path = path
    return fill


def _layer_prop(path):
    """A driver variable reading ``path`` of the view layer being evaluated
    (a render's view layer, the viewport's)."""
    def fill(var):
        var.type = 'CONTEXT_PROP'
        target = var.targets[0]
        target.context_property = 'ACTIVE_VIEW_LAYER'
        target.data_path = path
    return fill


def _transform(obj, channel):
    def fill(var):
        var.type = 'TRANSFORMS'
        target = var.targets[0]
        target.id = obj
        target.transform_type = channel
        target.transform_space = 'WORLD_SPACE'
        target.rotation_mode = 'XYZ'
    return fill


# A sun shines along its local -Z, a spot points along it: the lamp's world
# +Z axis (toward a sun; a spot's axis reversed) is the third column of its world
# matrix, component i read as ``matrix_world[2][i]`` (the shader normalises it).  Cycles
# takes it so, a mirrored lamp's flipped axis included (measured, 5.2.4 and 4.5.15:
# with a scale of -1 on one axis the Euler angles of the world rotation, which bindings
# before the forty-second session read, gave the opposite axis).
LAMP_Z = "matrix_world[2][{}]"
LAMP_MATRIX = "matrix_world"
# the Light inputs whose drivers read where the lamp is (:func:`_lamp_targets`)
PLACE_INPUTS = ("light_direction", "light_position")
# A sun's strength is the irradiance (W/m^2).  Radiant intensity (W/sr) of a
# point or spot lamp of power P, measured against a Diffuse BSDF in Cycles
# (tests/test_api.py): P / (4 pi) with "normalize" on (the default); with it
# off, P r^2 for a radius r > 0 and P / pi for r = 0.
# h: the lamp object's Disable in Renders (a lamp hidden from renders lights nothing)
HIDDEN = "h"
SUN_STRENGTH = "e * pow(2, x) * (1 - h)"
POINT_STRENGTH = ("e * pow(2, x) * (1 / (4 * pi) if n else (r * r if r > 0 else 1 / pi))"
                  " * (1 - h)")
LIGHT_COLOR = "c * (t if u else 1)"
# c0, c1, ...: the Disable in Renders of the collections the lamp is in, its own and
# their parents' (a lamp only in collections disabled in renders lights nothing)
COLLECTION_VAR = re.compile(r"c\d+")
# v0, v1, ...: whether the view layer being evaluated excludes those collections (a
# context property, so each view layer's render and the viewport read their own)
LAYER_VAR = re.compile(r"v\d+")
# ray, ray1: the lamp object's ray visibility for the kinds of surface the model is in
# Cycles' and EEVEE's terms (measured in 5.2.4 and 4.5.15, both engines: a lamp
# with Diffuse off lights no diffuse closure, with Glossy off no glossy one)
RAY = "ray"
DIFFUSE, GLOSSY = "visible_diffuse", "visible_glossy"
RAY_VISIBILITY = {"lambert": (DIFFUSE,), "phong": (GLOSSY,), "blinn_phong": (GLOSSY,),
                  "microfacet": (GLOSSY,), "ward": (GLOSSY,),
                  # diffuse and specular terms sharing one light: lit while either is
                  "kajiya_kay": (DIFFUSE, GLOSSY)}


def ray_visibility(node) -> tuple:
    """The lamp object's properties (``visible_diffuse``,
    ``visible_glossy``) that decide whether a lamp lights ``node``'s model
    in path tracing, which its strength driver follows: one for a model of
    one kind, both for Kajiya-Kay, whose diffuse and specular terms share
    one light (lit while either is on); ``()`` for another node."""
    info = groups.rm_info(getattr(node, "node_tree", None))
    return RAY_VISIBILITY.get(info[0], ()) if info else ()


def _ray_names(count) -> list:
    """The names of the strength driver's ray visibility variables."""
    return [RAY if i == 0 else f"{RAY}{i}" for i in range(count)]


def _collection_parents() -> dict:
    """Collection pointer -> the collections (a scene's among them) it is a
    child of, from one walk."""
    parents = {}
    for coll in list(bpy.data.collections) + [scene.collection for scene in bpy.data.scenes]:
        for child in coll.children:
            parents.setdefault(child.as_pointer(), []).append(coll)
    return parents


# the most ways down to a lamp that its strength driver follows (each adds a term to a max)
MAX_PATHS = 8


def collection_paths(lamp, parents=None):
    """The ways down from a scene's collection to ``lamp``, each the
    collections on it, nearest first: the lamp renders where every
    collection on one of them renders (enabled in renders, not excluded
    from the view layer; measured: Cycles renders a lamp in two
    collections, or in a collection with two parents, while any way
    renders).  ``[[]]`` for a lamp in a scene's collection itself (no
    switch decides).  None where the drivers cannot follow them: a way
    up ends in no scene (an instanced lamp), the ways come down from
    several scenes' collections (a view layer finds another scene's by
    name only), or there are more than ``MAX_PATHS``.  ``parents``:
    :func:`_collection_parents`, read here if None."""
    masters = {scene.collection.as_pointer() for scene in bpy.data.scenes}
    parents = _collection_parents() if parents is None else parents
    paths, tops, todo = [], set(), [(coll, []) for coll in lamp.users_collection]
    while todo:
        coll, below = todo.pop()
        if coll.as_pointer() in masters:
            paths.append(below)
            tops.add(coll.as_pointer())
            continue
        above = parents.get(coll.as_pointer(), [])
        if not above or len(paths) + len(todo) + len(above) > MAX_PATHS:
            return None  # in no scene (an instanced lamp), or too many ways
        todo.extend((parent, below + [coll]) for parent in above)
    if len(tops) != 1:
        return None
    return [[]] if [] in paths else sorted(paths, key=lambda p: [c.name for c in p])


def layer_paths(chain) -> list:
    """For each collection of ``chain`` (a way of :func:`collection_paths`,
    nearest first) the path from a view layer to its layer collection's
    Exclude switch on that way, which is by the collections' names (a path
    that no longer resolves, a collection renamed, say, reads as 0: not
    excluded; measured, 5.2.4 and 4.5.15)."""
    names = [f'.children["{bpy.utils.escape_identifier(c.name)}"]' for c in reversed(chain)]
    return ["layer_collection" + "".join(names[:len(chain) - i]) + ".exclude"
            for i in range(len(chain))]


def collection_factor(paths):
    """``(expression, collections, layer paths)`` for the ways ``paths``
    (:func:`collection_paths`; None or ``[[]]``: ``("", [], [])``): the
    factor of the strength driver that is 1 where the lamp renders and 0
    where it does not, the product of ``(1 - c_i) * (1 - v_j)`` along each
    way and their ``max`` for several ways, with ``c_i`` the Disable in
    Renders of ``collections[i]`` and ``v_j`` the Exclude switch at
    ``layer paths[j]``."""
    collections, switches, terms = [], [], []
    for chain in paths or ():
        factors = []
        for coll, path in zip(chain, layer_paths(chain)):
            if coll not in collections:
                collections.append(coll)
            if path not in switches:
                switches.append(path)
            factors.append(f"(1 - c{collections.index(coll)}) * (1 - v{switches.index(path)})")
        terms.append(" * ".join(factors))
    if not terms or "" in terms:
        return "", [], []
    return (" * " + terms[0] if len(terms) == 1 else " * max(" + ", ".join(terms) + ")",
            collections, switches)


def _check_node(node):
    info = groups.rm_info(getattr(node, "node_tree", None))
    if info is None:
        raise ValueError(f"{getattr(node, 'name', node)!r} is not a Reflection Models node")
    return info


def light_count(node) -> int:
    _model, variant = _check_node(node)
    return int(variant.get(variants.LIGHTS_PARAM.name, variants.LIGHTS_PARAM.default))


def _light_sockets(node, k, sockets=None):
    """Light k's input sockets of ``node``; ``sockets``: its
    :func:`groups.input_sockets`, read here if None."""
    sockets = groups.input_sockets(node) if sockets is None else sockets
    return [sockets[name] for name in (socket_name(n, k) for n in LIGHT_NAMES)
            if name in sockets]


def light_drivers(node) -> list:
    """The driver F-curves on the Light inputs of ``node`` (every light)."""
    _check_node(node)
    anim = node.id_data.animation_data
    if anim is None:
        return []
    sockets = groups.input_sockets(node)
    paths = {s.path_from_id("default_value")
             for k in range(1, light_count(node) + 1) for s in _light_sockets(node, k, sockets)}
    return [fc for fc in anim.drivers if fc.data_path in paths]


def _remove_drivers(node, k, sockets=None):
    """Remove the drivers of light k's inputs; ``sockets``:
    :func:`groups.input_sockets`, read here if None."""
    for socket in _light_sockets(node, k, sockets):
        size = len(socket.default_value) if hasattr(socket.default_value, "__len__") else 0
        if size:
            for i in range(size):
                socket.driver_remove("default_value", i)
        else:
            socket.driver_remove("default_value")


def _bind_one(node, k, light_object):
    light = light_object.data
    kind = light.type

    def sock(name):
        return groups.input_socket(node, socket_name(name, k))

    _remove_drivers(node, k)
    sock("point_light").default_value = 0.0 if kind == 'SUN' else 1.0
    sock("spot").default_value = 1.0 if kind == 'SPOT' else 0.0
    if kind in ('SUN', 'SPOT'):
        for i in range(3):
            _drive(sock("light_direction"), i, "z", {"z": _prop(light_object, LAMP_Z.format(i))})
    if kind in ('POINT', 'SPOT'):
        for i, axis in enumerate("xyz"):
            _drive(sock("light_position"), i, axis,
                   {axis: _transform(light_object, f"LOC_{axis.upper()}")})
    if kind == 'SPOT':
        _drive(sock("spot_size"), -1, "s", {"s": _prop(light, "spot_size")})
        _drive(sock("spot_blend"), -1, "b", {"b": _prop(light, "spot_blend")})
    strength = {"e": _prop(light, "energy"), "x": _prop(light, "exposure"),
                HIDDEN: _prop(light_object, "hide_render")}
    rays = ray_visibility(node)
    strength.update({name: _prop(light_object, prop)
                     for name, prop in zip(_ray_names(len(rays)), rays)})
    if kind != 'SUN':
        strength.update(n=_prop(light, "normalize"), r=_prop(light, "shadow_soft_size"))
    factor, collections, switches = collection_factor(collection_paths(light_object))
    strength.update({f"c{i}": _prop(coll, "hide_render") for i, coll in enumerate(collections)})
    strength.update({f"v{j}": _layer_prop(path) for j, path in enumerate(switches)})
    _drive(sock("light_strength"), -1, (SUN_STRENGTH if kind == 'SUN' else POINT_STRENGTH)
           + ("" if not rays else f" * {RAY}" if len(rays) == 1
              else f" * max({', '.join(_ray_names(len(rays)))})") + factor, strength)
    # the lamp's Cast Shadow (Cycles honours it: measured in 5.2 and 4.5)
    _drive(sock("shadows"), -1, "s", {"s": _prop(light, "use_shadow")})
    for i in range(3):
        _drive(sock("light_color"), i, LIGHT_COLOR,
               {"c": _prop(light, f"color[{i}]"), "t": _prop(light, f"temperature_color[{i}]"),
                "u": _prop(light, "use_temperature")})


def sized_lamps(lamps) -> list:
    """The names of ``lamps`` with a size: a sun's Angle or a point or spot
    lamp's Radius above 0.  Exact mode takes every bound lamp as ideal (a
    sun as one direction, the others as points, with hard shadows), where
    Cycles' path tracing spreads a sized lamp over its disc or sphere."""
    return [obj.name for obj in lamps
            if (obj.data.angle if obj.data.type == 'SUN' else obj.data.shadow_soft_size) > 0]


def unevenly_scaled_spots(lamps) -> list:
    """The names of the spot lamps among ``lamps`` whose world scale is not
    the same along their three axes: Cycles scales a spot's cone with it
    (measured, 5.2.4: scale (2, 1, 1) lit 49 gonio pixels where the
    unscaled spot lit 29, (1, 1, 3) 16; a uniform scale changed nothing),
    where exact mode takes the cone unscaled, Spot Size about the axis."""
    out = []
    for obj in lamps:
        if obj.data.type != 'SPOT':
            continue
        scale = [abs(c) for c in obj.matrix_world.to_scale()]
        if max(scale) - min(scale) > 1e-6 * max(max(scale), 1e-30):
            out.append(obj.name)
    return out


def _check_lamps(lamps):
    if not lamps:
        raise ValueError("bind_light needs at least one lamp")
    if len(lamps) > catalogue.MAX_LIGHTS:
        raise ValueError(f"{len(lamps)} lamps: exact mode follows 1 to {catalogue.MAX_LIGHTS}")
    seen = set()
    for obj in lamps:
        if getattr(obj, "type", None) != 'LIGHT':
            raise ValueError(f"{getattr(obj, 'name', obj)!r} is not a light object")
        if obj.data.type not in SUPPORTED_LIGHTS:
            raise ValueError(f"{obj.name!r} is a light of type {obj.data.type}; allowed: "
                             + ", ".join(SUPPORTED_LIGHTS))
        if obj.name in seen:
            raise ValueError(f"{obj.name!r} is given twice")
        seen.add(obj.name)


def bind_lights(node, *lamps) -> None:
    """Light k of ``node`` follows ``lamps[k - 1]`` (1 to MAX_LIGHTS sun,
    point or spot lamps); the node gets the group variant with that many
    lights.  In hybrid mode the material's objects are excluded from the
    lamps by light linking."""
    _check_node(node)
    _check_lamps(lamps)
    _unbind(node)
    if light_count(node) != len(lamps):
        groups.switch_variant(node, **{variants.LIGHTS_PARAM.name: str(len(lamps))})
    for k, obj in enumerate(lamps, start=1):
        _bind_one(node, k, obj)
    linking_changed()


def unbind_lights(node) -> None:
    """Remove the drivers binding put on the Light inputs, go back to one
    light, and remove the light linking binding added (nothing else): the
    first light's inputs keep the lamp's last values."""
    _check_node(node)
    _unbind(node)
    linking_changed()


# [depth, pending]: the depth of :func:`deferred_linking` blocks entered, and whether a
# binding or a mode changed inside them
_DEFERRED = [0, False]


def linking_changed() -> None:
    """A binding or a mode changed: bring the light linking up to date now,
    or at the end of the outermost :func:`deferred_linking` block."""
    if _DEFERRED[0]:
        _DEFERRED[1] = True
    else:
        sync_light_linking()


@contextlib.contextmanager
def deferred_linking():
    """Inside the block, binding, unbinding and mode changes leave the light
    linking as it is, and it is brought up to date once on leaving the
    outermost block (an exception too): each update reads every hybrid
    node in the file, so n of them one by one read n times n."""
    _DEFERRED[0] += 1
    try:
        yield
    except BaseException as exc:
        _leave_deferred(exc)
        raise
    _leave_deferred(None)


def _leave_deferred(exc) -> None:
    """Leaving a :func:`deferred_linking` block: the light linking brought up
    to date if it is the outermost and something changed.  Where the block
    is left by ``exc``, an update that fails is logged rather than raised,
    so that the caller sees ``exc``, its own error."""
    _DEFERRED[0] -= 1
    if _DEFERRED[0] or not _DEFERRED[1]:
        return
    _DEFERRED[1] = False
    try:
        sync_light_linking()
    except Exception as failure:
        if exc is None:
            raise
        log.warning("Reflection Models: could not update the light linking after %r: %s",
                    exc, failure)


def _unbind(node) -> None:
    """:func:`unbind_lights` but for the light linking, which its callers
    bring up to date once (the linking walks every hybrid node)."""
    sockets = groups.input_sockets(node)
    for k in range(1, light_count(node) + 1):
        _remove_drivers(node, k, sockets)
    if light_count(node) != 1:
        groups.switch_variant(node, **{variants.LIGHTS_PARAM.name: "1"})


def bound_lights(node) -> list:
    """The lamp objects the lights of ``node`` follow, in order."""
    return [lamp for _k, lamp in _bound_by_light(node)]


def outdated_bindings(node, bound=None, driver_of=None) -> list:
    """The bound lamps that light k follows as an earlier version bound
    them: its Shadows not driven by the lamp's Cast Shadow, or its
    strength not by the lamp's Disable in Renders.  Such a node keeps the
    values it had (a user may have set them) until bound again.
    ``bound``: :func:`_bound_by_light`, and ``driver_of``:
    :func:`_driver_lookup` of ``node``, read here if None."""
    driver_of = _driver_lookup(node) if driver_of is None else driver_of
    out = []
    for k, lamp in _bound_by_light(node, driver_of=driver_of) if bound is None else bound:
        strength = driver_of("light_strength", k)
        if driver_of("shadows", k) is None or strength is None \
                or HIDDEN not in {v.name for v in strength.variables}:
            out.append(lamp)
    return out


def deleted_lamp_lights(node) -> list:
    """The lights k of ``node`` whose bound lamp was deleted: their drivers
    lost their lamp and no longer evaluate, so the light keeps the values
    they last gave it and lit the tiles as before (measured: Delete on
    the bound sun, and exact mode rendered a light where the scene had
    none).  :func:`release_deleted_lamps` takes them away."""
    return [k for k, targets in _lamp_targets(node).items()
            if targets and all(t is None for t in targets)]


def release_deleted_lamps() -> int:
    """For every light whose bound lamp was deleted (:func:`deleted_lamp_lights`),
    in every material's RM nodes: its drivers removed and its strength set
    to 0, as the deleted lamp would light: nothing.  Returns how many
    lights.  Run on render and save, as the light linking's update is."""
    count = 0
    for node in _local_rm_nodes():
        for k in deleted_lamp_lights(node):
            _remove_drivers(node, k)
            groups.input_socket(node, socket_name("light_strength", k)).default_value = 0.0
            count += 1
    return count


def _local_rm_nodes():
    """Every material's RM nodes (in its tree and the user's groups there)
    but those in linked data, which is read-only here."""
    for mat in bpy.data.materials:
        for node in groups.rm_nodes_in(mat.node_tree):
            if node.id_data.library is None:
                yield node


def _renders_in(lamp, layer) -> bool:
    """Whether ``lamp`` is in a collection of ``layer`` that renders: not
    excluded from the view layer and not disabled in renders, down from
    the scene's collection.  Blender builds a view layer's tree of layer
    collections lazily: a layer without one yet counts as rendering."""
    if layer.layer_collection is None:
        return True
    todo = [layer.layer_collection]
    while todo:
        node = todo.pop()
        if node.exclude or node.collection.hide_render:
            continue
        if node.collection.objects.get(lamp.name) == lamp:
            return True
        todo.extend(node.children)
    return False


def _excluded_in(layer, chain) -> bool:
    """Whether the view layer ``layer`` excludes a collection of ``chain``
    (a way of :func:`collection_paths`), its layer collections found by
    name from the scene's down, as the drivers' paths find them; False
    where they are not found (a way in another scene)."""
    found = layer.layer_collection
    for coll in reversed(chain):
        found = found.children.get(coll.name) if found is not None else None
        if found is None or found.collection != coll:
            return False
        if found.exclude:
            return True
    return False


def unrendered_lamps(node, layer) -> list:
    """The bound lamps of ``node`` that the view layer ``layer`` does not
    render (in no collection of it, or only in collections excluded from it
    or disabled in renders) and with which exact mode lights all the same:
    its drivers follow the lamp object's Disable in Renders, and the
    Disable in Renders and the view layer's exclusion of the collections on
    every way down to it from its scene's collection
    (:func:`collection_paths`, bound as they are now), not a lamp in
    another scene only, nor one :func:`collection_paths` cannot follow
    (the sidebar names these)."""
    out, parents, driver_of = [], None, _driver_lookup(node)
    for k, lamp in _bound_by_light(node, driver_of=driver_of):
        if lamp.hide_render or _renders_in(lamp, layer):
            continue
        parents = _collection_parents() if parents is None else parents
        ways = collection_paths(lamp, parents)
        _factor, collections, switches = collection_factor(ways)
        reads = _strength_reads(node, k, driver_of("light_strength", k))
        followed = ways is not None and reads[:2] == (collections, switches) \
            and all(any(c.hide_render for c in chain) or _excluded_in(layer, chain)
                    for chain in ways)
        if not followed:
            out.append(lamp)
    return out


def _driver_lookup(node, sockets=None):
    """A function ``(name, k, every=False)`` -> the driver of light k's
    input ``name`` of ``node`` (of its first component), or None; with
    ``every``, the drivers of all its components, by component.  The
    node's sockets (``sockets``: :func:`groups.input_sockets`, read here
    if None) and the material's drivers read once, for many lookups."""
    anim = node.id_data.animation_data
    curves = {}
    for fc in (anim.drivers if anim else ()):
        curves.setdefault(fc.data_path, []).append(fc)
    sockets = groups.input_sockets(node) if sockets is None else sockets

    def lookup(name, k, every=False):
        socket = sockets.get(socket_name(name, k))
        found = curves.get(socket.path_from_id("default_value"), ()) if socket else ()
        if every:
            return [fc.driver for fc in sorted(found, key=lambda fc: fc.array_index)]
        return found[0].driver if found else None
    return lookup


def _strength_driver(node, k):
    """The driver of light k's strength, or None."""
    return _driver_lookup(node)("light_strength", k)


def _strength_reads(node, k, driver=None):
    """``(collections, paths, light)`` that light k's strength driver
    reads: the collections whose Disable in Renders it follows (its
    variables c0, c1, ...; None for a collection deleted since), nearest
    first, the view layer's paths to their Exclude switches (v0, v1, ...;
    none in a binding made before the forty-second session), and the
    light datablock of its energy; ``(None, None, None)`` without a
    driver.  ``driver``: that driver, looked up here if None."""
    driver = _strength_driver(node, k) if driver is None else driver
    if driver is None:
        return None, None, None

    def by_index(pattern, read):
        found = sorted((int(v.name[1:]), read(v.targets[0])) for v in driver.variables
                       if pattern.fullmatch(v.name))
        return [value for _i, value in found]

    energy = driver.variables.get("e")
    return (by_index(COLLECTION_VAR, lambda t: t.id), by_index(LAYER_VAR, lambda t: t.data_path),
            energy.targets[0].id if energy is not None else None)


def _ray_read(node, k, driver=None) -> tuple:
    """The lamp object's ray visibility properties light k's strength
    driver reads (as :func:`ray_visibility` gives them); ``driver``: that
    driver, looked up here if None."""
    driver = _strength_driver(node, k) if driver is None else driver
    out = []
    for name in _ray_names(2):
        var = driver.variables.get(name) if driver is not None else None
        if var is None:
            break
        out.append(var.targets[0].data_path)
    return tuple(out)


def bound_collections(node, k) -> list | None:
    """The collections whose Disable in Renders, and exclusion from the
    view layer being rendered, light k's strength follows
    (:func:`_strength_reads`); None if light k's strength has no driver."""
    return _strength_reads(node, k)[0]


def shadow_linked_lamps(node) -> list:
    """The bound lamps with shadow linking (a blocker collection): exact
    mode's shadow ray sees every object, where Cycles casts the lamp's
    shadows from the collection's objects only (measured, 5.2.4, OSL and
    native nodes: an occluder excluded from the sun's blockers shadowed the
    exact render and not the path-traced one)."""
    return [lamp for lamp in bound_lights(node)
            if lamp.light_linking.blocker_collection is not None]


def light_linked_lamps(node) -> list:
    """The bound lamps with light linking of the user's (a receiver
    collection the extension did not make): Cycles and EEVEE light only the
    objects it lets through, where exact mode, one evaluation per material,
    lights every object with the material.  Named in exact mode (the
    hybrid mode adds its exclusions to such a collection)."""
    return [lamp for lamp in bound_lights(node)
            if lamp.light_linking.receiver_collection is not None
            and not lamp.light_linking.receiver_collection.get(MADE)]


def unfollowed_ray_lamps(node) -> list:
    """The bound lamps of a Kajiya-Kay node with one of the Diffuse and
    Glossy ray visibilities off: its diffuse and specular terms share one
    light, lit while either is on (the path-traced output loses that
    part); with both off it lights nothing, as in path tracing."""
    if len(ray_visibility(node)) < 2:  # a model of one kind follows its visibility
        return []
    return [lamp for lamp in bound_lights(node) if lamp.visible_diffuse != lamp.visible_glossy]


def is_eevee(scene) -> bool:
    """Whether ``scene`` renders in EEVEE ('BLENDER_EEVEE' in 5.x,
    'BLENDER_EEVEE_NEXT' in 4.2-4.5)."""
    return getattr(getattr(scene, "render", None), "engine", "").startswith("BLENDER_EEVEE")


def eevee_factor_lamps(node, scene) -> list:
    """The bound lamps whose light has a Diffuse or Specular factor other
    than 1 (the model's kind: :func:`ray_visibility`; both for Kajiya-Kay)
    when ``scene`` renders in EEVEE, which scales each kind of closure's
    light by them (measured, 5.2.4 and 4.5.15; Cycles ignores them): exact
    mode does not follow them, a driver having no way to know the engine."""
    if not is_eevee(scene):
        return []
    factor = {DIFFUSE: "diffuse_factor", GLOSSY: "specular_factor"}
    names = [factor[prop] for prop in ray_visibility(node)]
    return [lamp for lamp in bound_lights(node)
            if any(getattr(lamp.data, name, 1.0) != 1.0 for name in names)]


def retyped_lamps(node, bound=None, sockets=None) -> list:
    """``(lamp, the type it was bound as)`` for each bound lamp whose type
    changed since binding: the node still takes it as that type (a sun as
    a direction, a point or spot lamp from its position); an area lamp is
    not one exact mode follows.  ``bound``: :func:`_bound_by_light`, and
    ``sockets``: :func:`groups.input_sockets`, read here if None."""
    out = []
    sockets = groups.input_sockets(node) if sockets is None else sockets
    for k, lamp in _bound_by_light(node) if bound is None else bound:
        try:
            point = sockets[socket_name("point_light", k)].default_value
            spot = sockets[socket_name("spot", k)].default_value
        except KeyError:
            continue
        was = 'SPOT' if spot > 0.5 else 'POINT' if point > 0.5 else 'SUN'
        if lamp.data.type != was:
            out.append((lamp, was))
    return out


def moved_lamp_lights(node, parents=None, bound=None, sockets=None, factors=None) -> list:
    """The lights k of ``node`` bound by this version (their strength
    follows the lamp's Disable in Renders) whose lamp is no longer in the
    collections binding read (:func:`collection_paths`: moved to another
    collection or linked into one more, a collection deleted, nested or
    renamed since, the last two changing the view layer's paths to them),
    whose binding reads no view layer's exclusion of its collections, or
    none of a lamp in several, or not the lamp's ray visibility
    (:func:`ray_visibility`), or its direction from Euler angles
    (:func:`_euler_direction`; bound in the fortieth or forty-first
    session), or that has other light data than binding read
    (the Object Data's light replaced: the drivers read the old light's
    strength, colour and cone).  Bindings of the earlier versions are left
    (:func:`outdated_bindings` names them).  ``parents``:
    :func:`_collection_parents`, ``bound``: :func:`_bound_by_light`, and
    ``sockets``: :func:`groups.input_sockets`, read here if None;
    ``factors``: a dict in which a lamp's :func:`collection_factor` is kept
    for the next call (by the lamp's pointer), or None."""
    sockets = groups.input_sockets(node) if sockets is None else sockets
    driver_of = _driver_lookup(node, sockets)
    bound = _bound_by_light(node, sockets, driver_of) if bound is None else bound
    outdated, out = set(outdated_bindings(node, bound, driver_of)), []
    parents = _collection_parents() if parents is None else parents
    factors = {} if factors is None else factors
    for k, lamp in bound:
        if lamp in outdated:
            continue
        strength = driver_of("light_strength", k)
        collections, switches, light = _strength_reads(node, k, strength)
        if lamp.as_pointer() not in factors:
            factors[lamp.as_pointer()] = collection_factor(collection_paths(lamp, parents))
        _factor, *expected = factors[lamp.as_pointer()]
        if [collections, switches] != expected or light != lamp.data \
                or _ray_read(node, k, strength) != ray_visibility(node) \
                or _euler_direction(node, k, driver_of):
            out.append(k)
    return out


# what :func:`rebind_changed_lamps` last read of the lamps and the file
# (:func:`_read_state`); None: nothing yet
_PLACES_READ = [None]


def lamp_places(parents=None) -> dict:
    """Each lamp object's light data, its type and the ways down to it
    (:func:`collection_paths`, each collection by its session uid and
    name), by session uids: what of a lamp an edit of its light or of a
    collection can change that :func:`rebind_changed_lamps` looks at (the
    collections' Disable in Renders and the view layers' exclusions are
    read by the drivers).  ``parents``: :func:`_collection_parents`, read
    here if None."""
    parents = _collection_parents() if parents is None else parents
    places = {}
    for obj in bpy.data.objects:
        if obj.type != 'LIGHT' or obj.data is None:
            continue
        paths = collection_paths(obj, parents)
        places[obj.session_uid] = (
            obj.data.session_uid, obj.data.type,
            None if paths is None else tuple(tuple((c.session_uid, c.name) for c in path)
                                             for path in paths))
    return places


def _read_state(parents=None) -> tuple:
    """What :func:`rebind_changed_lamps` reads that an update can change
    and the drivers do not follow: :func:`lamp_places`, and how many
    materials and node groups the file holds (an appended material brings
    its bindings, perhaps an older version's; measured: appending updates
    every kind of data, the collections among them)."""
    return lamp_places(parents), len(bpy.data.materials), len(bpy.data.node_groups)


def lamps_or_materials_changed() -> bool:
    """Whether a lamp's light data, type or collections changed (or a lamp
    came or went), or materials or node groups came or went, since
    :func:`rebind_changed_lamps` last ran: after an edit of a light or a
    collection alone, nothing else it reads can have (a light's energy or
    colour, a collection's Disable in Renders or exclusion: the drivers
    read them)."""
    return _PLACES_READ[0] is None or _read_state() != _PLACES_READ[0]


def rebind_changed_lamps() -> int:
    """Bind again, light by light, each bound lamp whose type changed since
    binding to another type exact mode follows (:func:`retyped_lamps`: a
    sun turned into a spot lamp, say), and each whose collections or light
    data changed, or that an older version bound (:func:`moved_lamp_lights`):
    its drivers made as binding it now would make them.  An area lamp is
    left as it is (exact mode follows none; the sidebar names it).  In
    every material's RM nodes but linked ones.  Returns how many lights."""
    count, parents, factors = 0, _collection_parents(), {}
    _PLACES_READ[0] = _read_state(parents)
    for node in _local_rm_nodes():
        sockets = groups.input_sockets(node)
        bound = _bound_by_light(node, sockets)
        retyped = {lamp.as_pointer() for lamp, _was in retyped_lamps(node, bound, sockets)}
        moved = set(moved_lamp_lights(node, parents, bound, sockets, factors))
        for k, lamp in bound:
            if (lamp.as_pointer() in retyped or k in moved) \
                    and lamp.data.type in SUPPORTED_LIGHTS:
                _bind_one(node, k, lamp)
                count += 1
    return count


def _places_lamp(var) -> bool:
    """Whether the driver variable ``var`` reads where a lamp is: a
    transform channel, or its world matrix."""
    return var.type == 'TRANSFORMS' or (
        var.type == 'SINGLE_PROP' and var.targets[0].data_path.startswith(LAMP_MATRIX))


def _lamp_targets(node, sockets=None, driver_of=None) -> dict:
    """Light k -> the objects the variables of its drivers read the place of
    (:func:`_places_lamp`; None where that object was deleted), for each
    light of ``node``: the drivers of its Light Direction and Light
    Position, the inputs binding drives from where the lamp is (every
    version's binding: no other input's driver reads it).  ``sockets``:
    :func:`groups.input_sockets`, and ``driver_of``: :func:`_driver_lookup`
    of ``node``, read here if None."""
    driver_of = _driver_lookup(node, sockets) if driver_of is None else driver_of
    out = {}
    for k in range(1, light_count(node) + 1):
        out[k] = [var.targets[0].id for name in PLACE_INPUTS
                  for driver in driver_of(name, k, every=True)
                  for var in driver.variables if _places_lamp(var)]
    return out


def _euler_direction(node, k, driver_of=None) -> bool:
    """Whether light k's direction is driven from the Euler angles of the
    lamp's world rotation, as bindings before the forty-second session
    made it (a mirrored lamp's axis comes out reversed).  ``driver_of``:
    :func:`_driver_lookup` of ``node``, made here if None."""
    driver = (driver_of or _driver_lookup(node))("light_direction", k)
    return driver is not None and any(var.type == 'TRANSFORMS' for var in driver.variables)


def _bound_by_light(node, sockets=None, driver_of=None) -> list:
    """``(k, lamp object)`` for each light k of ``node`` that follows a lamp;
    ``sockets``: :func:`groups.input_sockets`, and ``driver_of``:
    :func:`_driver_lookup` of ``node``, read here if None."""
    out = []
    for k, targets in _lamp_targets(node, sockets, driver_of).items():
        found = next((t for t in targets if t is not None), None)
        if found is not None:
            out.append((k, found))
    return out


# ---------------------------------------------------------------------------
# Modes and the hybrid mode's light linking

def node_mode(node) -> str:
    return str(node.get("rm_mode", "")) or _wired_mode(node)


def _wired_mode(node):
    """The mode a node is wired for when it has no rm_mode (older files)."""
    for name, mode in (("Direct", "exact"), ("BSDF", "path_traced")):
        try:
            if groups.output_socket(node, name).is_linked:
                return mode
        except KeyError:
            pass
    return "path_traced"


def hybrid_nodes():
    """``(material, node)`` of every RM node in hybrid mode, in the
    material's tree or in a group of the user's there (a group used by
    several materials gives its nodes once per material)."""
    for mat in bpy.data.materials:
        for node in groups.rm_nodes_in(mat.node_tree):
            if node.get("rm_mode") == HYBRID:
                yield mat, node


def _slot_users(in_scenes=None) -> dict:
    """Material pointer -> the objects in a scene (``in_scenes``:
    :func:`groups.object_scenes`, read here if None) with it in a slot, in
    one walk of the objects.  An object in no scene renders only as an
    instance, and then its instancer is excluded (the engines apply the
    instancer's light linking); one deleted from its scene stays in the
    data while the extension's collection holds it, and would be held for
    ever."""
    in_scenes = groups.object_scenes() if in_scenes is None else in_scenes
    out = {}
    for obj in bpy.data.objects:
        if obj.as_pointer() not in in_scenes:
            continue
        for slot in getattr(obj, "material_slots", ()):
            if slot.material is not None:
                out.setdefault(slot.material.as_pointer(), set()).add(obj)
    return out


def _users(material, evaluated=None, slot_users=None):
    """Objects in a scene with ``material`` in a slot (``slot_users``:
    :func:`_slot_users`, read here if None), and those ``evaluated`` (from
    :func:`_evaluated_users`) gives for it."""
    slot_users = _slot_users() if slot_users is None else slot_users
    return slot_users.get(material.as_pointer(), set()) | (evaluated or {}).get(material, set())


def _depsgraphs(scenes, evaluate):
    """``(scene, depsgraph)`` of each view layer of ``scenes``.  ``evaluate``: True,
    each brought up to date (the context's through
    ``evaluated_depsgraph_get``, another scene's through a context
    override); "context", the context's only (a render handler: measured
    to work there in 5.2 and 4.5), the others as Blender keeps them; False,
    none brought up to date (a panel's draw).  A view layer Blender keeps
    no depsgraph of is left out unless evaluated."""
    context = bpy.context
    for scene in scenes:
        for layer in scene.view_layers:
            here = scene == context.scene and layer == context.view_layer
            try:
                if here and evaluate is not False:
                    graph = context.evaluated_depsgraph_get()
                elif evaluate is True:
                    with context.temp_override(scene=scene, view_layer=layer):
                        graph = context.evaluated_depsgraph_get()
                else:
                    graph = groups.kept_depsgraph(layer)
            except (AttributeError, RuntimeError, TypeError):
                graph = None
            if graph is not None:
                yield scene, graph


def _evaluated_users(evaluate=True, lamp_scenes=None):
    """``(users, unknown)``.  ``users``: material -> the objects that render
    it without a slot naming it: those whose Geometry Nodes modifiers give
    their geometry the material (a Set Material node), and the instancers
    (a collection instance, vertex or face instancing, particles, Geometry
    Nodes instances) of geometry carrying it, whose light linking EEVEE
    applies to their instances (measured in 5.2 and 4.5: an excluded
    plane instanced by each kind was lit twice in EEVEE until the
    instancer was excluded too, and in Cycles through Geometry Nodes;
    Cycles lit the other kinds once, taking the instanced object's set
    where the instancer has none).  Read in every view layer of their
    scenes that are in ``lamp_scenes`` (where the bound lamps are, and so
    where an exclusion can matter; every scene if None); ``evaluate``:
    True, each view layer evaluated; "context", the context's only (a
    render handler); False, none (a panel's draw).  ``unknown``: such
    objects in scenes none of which had a depsgraph to read (their
    exclusions are kept as they are)."""
    candidates = [obj for obj in bpy.data.objects if _renders_beyond_slots(obj)]
    if not candidates:
        return {}, set()
    scenes_of = groups.object_scenes()
    of = {obj.as_pointer(): scenes_of.get(obj.as_pointer(), []) for obj in candidates}
    scenes = {scene for obj in candidates for scene in of[obj.as_pointer()]
              if lamp_scenes is None or scene in lamp_scenes}
    out, read = {}, set()
    for scene, graph in _depsgraphs(sorted(scenes, key=lambda s: s.name), evaluate):
        read.add(scene.name)
        for obj in candidates:
            if scene in of[obj.as_pointer()]:
                for material in groups.rendered_materials(obj, graph):
                    out.setdefault(material, set()).add(obj)
    unknown = {obj for obj in candidates if any(scene in scenes for scene in of[obj.as_pointer()])
               and not any(scene.name in read for scene in of[obj.as_pointer()])}
    return out, unknown


def hybrid_bindings() -> list:
    """``(material, node, its bound lamps)`` of every RM node in hybrid mode
    (:func:`hybrid_nodes`)."""
    return [(mat, node, bound_lights(node)) for mat, node in hybrid_nodes()]


def hybrid_material_ids() -> set:
    """The session uids of the materials whose hybrid nodes are bound to a
    lamp (whose objects the light linking excludes).  A session uid is
    never given to another datablock; a pointer is, once its datablock was
    freed (which made the viewport's comparisons miss a change now and
    then)."""
    return _bound_material_ids(hybrid_bindings())


def _bound_material_ids(hybrid) -> set:
    """The session uids of the materials of ``hybrid`` (:func:`hybrid_bindings`)
    whose nodes are bound to a lamp."""
    return {mat.session_uid for mat, _node, lamps in hybrid if lamps}


def _renders_beyond_slots(obj) -> bool:
    """Whether ``obj`` may render materials its slots do not name: it
    instances (a collection, vertices or faces, particles) or has a
    Geometry Nodes modifier (a Set Material node, instances)."""
    return obj.instance_type != 'NONE' or bool(len(getattr(obj, "particle_systems", ()))) \
        or any(m.type == 'NODES' for m in getattr(obj, "modifiers", ()))


def slot_materials(obj, graph=None) -> tuple:
    """The session uids of the materials in ``obj``'s slots (0 for an empty
    slot), to compare between the viewport's updates; with the depsgraph
    ``graph``, for an object that instances or has Geometry Nodes
    (:func:`_renders_beyond_slots`), those it renders there too
    (:func:`groups.rendered_materials`), sorted after them."""
    slots = tuple(slot.material.session_uid if slot.material is not None else 0
                  for slot in getattr(obj, "material_slots", ()))
    if graph is None or not _renders_beyond_slots(obj):
        return slots
    try:
        in_graph = obj.evaluated_get(graph).is_evaluated
    except (RuntimeError, ReferenceError):
        in_graph = False
    if not in_graph:  # another scene's object: ``evaluated_get`` gave the original
        return slots
    return slots + tuple(sorted(m.session_uid for m in groups.rendered_materials(obj, graph)))


def _hybrid_lamps() -> set:
    """The lamps hybrid nodes are bound to: the keys of :func:`needed_exclusions`,
    read without any object's materials."""
    return {lamp for _mat, _node, lamps in hybrid_bindings() for lamp in lamps}


def _exclusions(evaluate=True, hybrid=None):
    """``(need, unknown)``: lamp object -> the objects hybrid mode must
    exclude from it (every lamp a hybrid node is bound to, with no object
    yet too), and the objects whose use of a material could not be read
    (:func:`_evaluated_users`).  ``hybrid``: :func:`hybrid_bindings`, if
    the caller has it."""
    need = {}
    hybrid = hybrid_bindings() if hybrid is None else hybrid
    # each lamp asked once: ``users_scene`` walks every scene
    bound = {lamp for _m, _n, lamps in hybrid for lamp in lamps}
    lamp_scenes = {scene for lamp in bound for scene in lamp.users_scene}
    evaluated, unknown = _evaluated_users(evaluate, lamp_scenes) if hybrid else ({}, set())
    slot_users = _slot_users() if hybrid else {}
    for mat, _node, lamps in hybrid:
        users = _users(mat, evaluated, slot_users)
        for lamp in lamps:
            need.setdefault(lamp, set()).update(users)
    return need, unknown


def also_other_materials(node, hybrid=None) -> list:
    """The objects hybrid mode excludes from ``node``'s bound lamps that
    also render a material no hybrid node bound to that lamp renders with
    (another slot, or what they instance): light linking excludes a whole
    object, so the bound lamp no longer lights those parts.  Read from
    slots and instancing, and from Geometry Nodes where Blender keeps a
    depsgraph of the object's scene (none is evaluated: the sidebar draws
    it; :func:`groups.materials_as_kept`).  Sorted by name.  ``hybrid``:
    :func:`hybrid_bindings`, read here if None."""
    lamps = set(bound_lights(node))
    if not lamps:
        return []
    exact = {}
    for mat, _other, bound in hybrid_bindings() if hybrid is None else hybrid:
        for lamp in bound:
            exact.setdefault(lamp, set()).add(mat)
    out, scenes_of, graphs_of = set(), groups.object_scenes(), {}
    for lamp in lamps:
        coll = lamp.light_linking.receiver_collection
        if coll is None:
            continue
        for obj in added_objects(coll):
            graphs = []
            for scene in scenes_of.get(obj.as_pointer(), ()):
                if scene.name_full not in graphs_of:
                    graphs_of[scene.name_full] = groups.kept_depsgraphs(scene)
                graphs += graphs_of[scene.name_full]
            if groups.materials_as_kept(obj, graphs) - exact.get(lamp, set()):
                out.add(obj)
    return sorted(out, key=lambda o: o.name)


ADDED = "rm_added"
MADE = "rm_made"


def added_objects(coll) -> list:
    """The members of ``coll`` the extension added, from its record
    (``rm_added``): the objects themselves, so that the record follows an
    object renamed afterwards (an object deleted since reads as None and is
    left out).  Older files recorded names: those are read by name, and the
    record is written back as objects at the next update."""
    members = {obj.as_pointer(): obj for obj in coll.objects}
    out = []
    for item in coll.get(ADDED, []):
        obj = coll.objects.get(item) if isinstance(item, str) else item
        if obj is not None and obj.as_pointer() in members:
            out.append(members[obj.as_pointer()])
    return out


def _ours(coll) -> bool:
    """Whether ``coll`` is a collection the extension made and holds only
    what it added (a user who adds an entry, or a child collection, makes
    it theirs too: then it is neither shared out nor taken from a lamp)."""
    if coll is None or not coll.get(MADE) or coll.children:
        return False
    added = {obj.as_pointer() for obj in added_objects(coll)}
    return all(obj.as_pointer() in added for obj in coll.objects)


def _lamps_of(coll) -> list:
    return [o for o in bpy.data.objects
            if o.type == 'LIGHT' and o.light_linking.receiver_collection == coll]


def _collection_name(lamps) -> str:
    names = sorted(lamp.name for lamp in lamps)
    return f"RM Hybrid: {names[0]}" + (f" +{len(names) - 1}" if len(names) > 1 else "")


def _share(need, hybrid) -> int:
    """Lamps bound by the same hybrid materials exclude the same objects:
    they get one collection of the extension's, so that a scene stays under
    Blender's :data:`RECEIVER_COLLECTIONS_MAX` (a node bound to four lamps
    makes one collection, not four).  A lamp with a collection of the
    user's keeps it.  Returns the number of changes."""
    keys = {}
    for mat, _node, lamps in hybrid:
        for lamp in lamps:
            keys.setdefault(lamp, set()).add(mat.name_full)
    groups_of = {}
    for lamp in need:
        coll = lamp.light_linking.receiver_collection
        if coll is None or _ours(coll):
            groups_of.setdefault(frozenset(keys.get(lamp, ())), []).append(lamp)
    changes = 0
    for key in sorted(groups_of, key=sorted):
        lamps = sorted(groups_of[key], key=lambda o: o.name)
        members = set(lamps)
        # a collection of the group's that no lamp outside it uses, the most used first
        held = {}
        for lamp in lamps:
            coll = lamp.light_linking.receiver_collection
            if coll is not None and set(_lamps_of(coll)) <= members:
                held[coll] = held.get(coll, 0) + 1
        if held:
            target = min(held, key=lambda c: (-held[c], c.name))
        else:
            target = bpy.data.collections.new(_collection_name(lamps))
            target[MADE] = True
            target[ADDED] = []
            changes += 1
        for lamp in lamps:
            if lamp.light_linking.receiver_collection != target:
                lamp.light_linking.receiver_collection = target
                changes += 1
        label = _collection_name(lamps)
        if re.sub(r"\.\d{3,}$", "", target.name) != label:  # Blender's .001 on a clash
            target.name = label
    return changes


# the session uids of the materials with a bound hybrid node when the light linking was
# last brought up to date (here, or by the viewport's handler, which compares with it: a
# binding's own update could leave the handler nothing to see, and a hybrid node deleted
# next looked like no change)
SYNCED_HYBRID = [None]


def sync_light_linking(*, handler=None) -> int:
    """Make the light linking match the hybrid nodes: every object using a
    hybrid material excluded from each lamp its node is bound to, lamps
    bound by the same hybrid materials sharing one collection
    (:func:`_share`); entries the extension added that are no longer
    needed removed, a collection it made taken from a lamp that no longer
    needs it (such as a copy of a bound lamp, which Blender gives the
    original's collection) and removed once no lamp uses it.  Returns the
    number of changes.

    ``handler``: None, or the handler that calls it: "render", where
    making or removing a datablock crashes Blender (measured), and
    "update", the viewport's depsgraph update, which evaluates nothing
    (the depsgraphs as Blender keeps them) and makes no datablock either.
    In both only objects are linked and unlinked, and lamps taken from
    collections; the collections are made and shared when a lamp is bound,
    and on save."""
    if handler not in (None, "render", "update"):
        raise ValueError(f"handler={handler!r}; allowed: None, 'render', 'update'")
    in_handler = handler is not None
    changes = 0
    hybrid = hybrid_bindings()
    need, unknown = _exclusions({None: True, "render": "context", "update": False}[handler],
                                hybrid)
    changes += release_stray_lamps(need)
    if not in_handler:
        changes += _share(need, hybrid)
    for lamp, objects in need.items():
        coll = lamp.light_linking.receiver_collection
        if coll is None:
            continue
        added = added_objects(coll)
        members = {member.as_pointer() for member in coll.objects}
        new = [obj for obj in sorted(objects, key=lambda o: o.name)
               if obj.as_pointer() not in members]
        for obj in new:
            coll.objects.link(obj)
        # their entries in one walk: ``collection_objects`` takes no keys and its entries
        # name no object; it walks the same list as ``objects``, in the same order
        if new:
            linked = {obj.as_pointer() for obj in new}
            for entry, member in zip(coll.collection_objects, coll.objects):
                if member.as_pointer() in linked:
                    entry.light_linking.link_state = 'EXCLUDE'
        added += new
        changes += len(new)
        coll[ADDED] = added
    # what is no longer needed: only what the extension added
    for coll in list(bpy.data.collections):
        if ADDED not in coll:
            continue
        lamps = _lamps_of(coll)
        wanted = set(unknown)
        for lamp in lamps:
            wanted |= need.get(lamp, set())
        keep = []
        for obj in added_objects(coll):
            if obj in wanted:
                keep.append(obj)
            else:
                coll.objects.unlink(obj)
                changes += 1
        if keep != list(coll[ADDED]):
            coll[ADDED] = keep
        still_bound = any(lamp in need for lamp in lamps)
        if not keep and coll.get(MADE) and not still_bound and not in_handler:
            for lamp in lamps:
                lamp.light_linking.receiver_collection = None
            if not coll.objects and not coll.children:
                bpy.data.collections.remove(coll)
            changes += 1
    SYNCED_HYBRID[0] = _bound_material_ids(hybrid)
    return changes


def stray_lamps(need=None) -> list:
    """Lamps that use a collection of the extension's (:func:`_ours`) but
    are bound to no hybrid node: a copy of a bound lamp (Shift D, or copy
    and paste), which Blender gives the original's light linking, so that
    the hybrid objects get none of its light.  ``need``: from
    :func:`needed_exclusions`, whose lamps are the bound ones (if None,
    the hybrid nodes' bound lamps are read: no object's materials).
    Sorted by name."""
    if need is None:
        need = _hybrid_lamps()
    return sorted((o for o in bpy.data.objects
                   if o.type == 'LIGHT' and o not in need
                   and _ours(o.light_linking.receiver_collection)), key=lambda o: o.name)


def release_stray_lamps(need=None) -> int:
    """Take the extension's collection from every lamp bound to no hybrid
    node (:func:`stray_lamps`, ``need`` as there; a lamp linked from a
    library is left: it cannot be changed here).  Without ``need`` it reads
    only which lamps the hybrid nodes are bound to, no object's materials:
    cheap enough for the viewport's update after objects were added or
    removed (``ui.on_depsgraph_update_post``).  Returns how many lamps."""
    lamps = [lamp for lamp in stray_lamps(need) if lamp.library is None]  # linked: read-only
    for lamp in lamps:
        lamp.light_linking.receiver_collection = None
    return len(lamps)


def unbound_sharers(need=None) -> list:
    """Lamps bound to no hybrid node that use a collection of the user's to
    which the extension added exclusions (the user gave a bound lamp and
    these one collection): they do not light the hybrid objects either,
    and since the collection is the user's the extension leaves it.
    ``need`` as for :func:`stray_lamps`.  Sorted by name."""
    if need is None:
        need = _hybrid_lamps()
    out = []
    for obj in bpy.data.objects:
        coll = obj.light_linking.receiver_collection if obj.type == 'LIGHT' else None
        if coll is not None and obj not in need and not _ours(coll) and added_objects(coll):
            out.append(obj)
    return sorted(out, key=lambda o: o.name)


def override_keeps_light_linking() -> bool:
    """Whether a library override of a lamp can keep its light linking:
    Blender 5.2 marks ``receiver_collection`` overridable, 4.5 does not
    (measured in 5.2.4 and 4.5.15: the overridden lamp's collection was
    saved in 5.2.4 and gone on reload in 4.5.15)."""
    return bool(bpy.types.ObjectLightLinking.bl_rna.properties["receiver_collection"]
                .is_overridable)


def linked_lamps(node) -> list:
    """``node``'s bound lamps whose hybrid light linking is not saved: a
    lamp linked from a library file, which Blender reads back from its
    library when the file is opened (the linking it was given is then
    gone), and a library override of one where the override cannot keep
    it (:func:`override_keeps_light_linking`)."""
    keeps = override_keeps_light_linking()
    return [lamp for lamp in bound_lights(node) if lamp.library is not None
            or (lamp.override_library is not None and not keeps)]


# Blender's light linking holds at most 63 receiver collections in a scene:
# with 64 lamps each excluding its own object one object was lit by its lamp
# all the same, in Cycles (5.2.4, 4.5.15) and EEVEE, and Blender printed
# "Maximum number of light linking sets (64) exceeded"; with 63 none was.
RECEIVER_COLLECTIONS_MAX = 63


def receiver_collections(scene) -> int:
    """How many distinct light-linking receiver collections the objects of
    ``scene`` (lamps, and emitting meshes) name: the extension's, one per
    lamp bound in hybrid mode, and the user's.  Over
    :data:`RECEIVER_COLLECTIONS_MAX`, Blender ignores some of them."""
    found = set()
    for obj in scene.objects:
        linking = getattr(obj, "light_linking", None)
        coll = linking.receiver_collection if linking is not None else None
        if coll is not None:
            found.add(coll.name_full)
    return len(found)


def needed_exclusions(evaluate=True, hybrid=None) -> dict:
    """Lamp object -> the objects hybrid mode excludes from it (``evaluate``:
    as for :func:`_evaluated_users`; ``hybrid``: :func:`hybrid_bindings`,
    read here if None), for :func:`out_of_sync`, :func:`stray_lamps` and
    :func:`unbound_sharers` to share (the sidebar asks all three)."""
    return _exclusions(evaluate, hybrid)[0]


def out_of_sync(evaluate=True, need=None) -> bool:
    """Whether the light linking differs from what the hybrid nodes need
    (``evaluate``: as for :func:`_evaluated_users`; ``need``: from
    :func:`needed_exclusions`, read here if None)."""
    need = needed_exclusions(evaluate) if need is None else need
    for lamp, objects in need.items():
        coll = lamp.light_linking.receiver_collection
        if coll is None:
            return True
        entries = {member.as_pointer(): entry
                   for entry, member in zip(coll.collection_objects, coll.objects)}
        for obj in objects:
            entry = entries.get(obj.as_pointer())
            if entry is None or entry.light_linking.link_state != 'EXCLUDE':
                return True
    return False
