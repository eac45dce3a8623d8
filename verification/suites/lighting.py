# SPDX-License-Identifier: GPL-3.0-or-later
"""Checks of exact mode under several lamps and of the hybrid mode.

Every function builds its scene through the public API (``api``), renders,
compares with an expectation from the scene's known geometry and
``addon.reference`` (never from a render, except the hybrid-versus-path-
traced comparison, whose subject is that equality), and returns a
:class:`~verification.harness.checks.Check`.

- :func:`several_lamps`: tiles in exact mode bound to several lamps
  (``verification.scenes.lit``): the sum over the lamps.  Tolerance 1e-4
  relative (float32) plus, per pixel, the change of the expected value
  across the 0.01-pixel filter that Cycles jitters the camera ray in (a
  point lamp's 1/d^2, a spot's cone edge; zero for suns); in EEVEE
  (``eevee=True``) 3e-3 of the peak, its half-float output, plus the same.
- :func:`hybrid_bound_lamp`: a model in hybrid mode under its bound sun
  alone renders the model exactly (the closure, excluded from the sun by
  light linking, adds nothing), with the node in the material, inside a
  node group of the user's, the material given by Geometry Nodes, or the
  tiles rendered as a collection instance.
- :func:`hybrid_lit_scene`: Trowbridge-Reitz with correlated Smith (an
  exact closure) in hybrid mode under a bound sun, an unbound sun, a sky
  and a floor with bounces, against the same material fully path traced:
  per tile, the means differ by at most 4 standard errors.
"""

from __future__ import annotations

import time

import numpy as np

from . import verify
from .. import harness as common
from ..harness.checks import Check, TOLERANCES, tolerance
from ..scenes import gonio, lit

TR = {"distribution": "trowbridge_reitz", "shadowing": "smith_correlated", "beta": 0.4}
LAMP_SETS = {"four": lit.FOUR_LAMPS, "spots": lit.SPOTS}


def _material(name):
    mat, _tree, _out = common.empty_material(name)
    return mat


def compare(img, expected, mask, spread=None, *, eevee=False, scale_of=None):
    """``(largest error, largest error beyond the allowance / allowance)``:
    the error relative to max(|expected|, 1e-3 peak), allowed 1e-4 of that
    plus ``spread``; ``eevee``: the error over the peak, allowed 3e-3 of the
    peak (its half-float output) plus ``spread``.  ``scale_of``: the image
    whose values and peak scale the error, where ``expected`` may be black
    (default: ``expected``)."""
    of = expected if scale_of is None else scale_of
    peak = float(of[mask].max())
    tol = tolerance("eevee_exact" if eevee else "exact_mode")
    scale = peak if eevee else np.maximum(np.abs(of[mask]), 1e-3 * peak)
    err = np.abs(img[mask].astype(np.float64) - expected[mask])
    allowed = tol * scale + (0.0 if spread is None else spread[mask])
    return float((err / scale).max()), float((err / allowed).max())


def _backend(osl, eevee):
    """The backend's name in these checks: "osl", "native" or "eevee"."""
    return "eevee" if eevee else "osl" if osl else "native"


def _use_backend(scene, api, backend, mode=None):
    """Set ``scene`` up for ``backend`` (:func:`.verify.use_backend`, which
    calls the native nodes in Cycles "svm"; ``mode`` "exact": the scene
    holds exact-mode materials alone)."""
    verify.use_backend(scene, {"native": "svm"}.get(backend, backend), api, mode)


def _measure(eevee):
    """How :func:`compare` measured: ``(values key, label, the bound's
    text, tolerance reason)``."""
    if eevee:
        return ("max_abs_over_peak", "|d|/peak", "<= 3e-3 of the peak",
                TOLERANCES["eevee_exact"].reason)
    return "max_rel_error", "rel error", "<= 1e-4 relative", TOLERANCES["exact_mode"].reason


def several_lamps(api, lamps: str, model: str, params: dict, *, osl: bool, resolution=48,
                  eevee=False):
    """``eevee``: rendered by EEVEE (native nodes, ``osl`` ignored) and held
    to its tolerance, 3e-3 of the peak (half-float output) plus the same
    per-pixel spread."""
    t0 = time.perf_counter()
    bpy = common.import_bpy()
    lamp_set = LAMP_SETS[lamps]
    backend = _backend(osl, eevee)
    name = f"lit_{lamps}_{model}_{backend}"
    mat = _material(name)
    node = api.add_model(mat, model, mode="exact", **params)
    s = lit.build_lit_scene(mat, lamp_set, resolution=resolution, name=name)
    _use_backend(s.scene, api, backend, "exact")
    try:
        api.bind_light(node, *s.lamp_objects)
        bound = [o.name for o in api.bound_lights(node)]
        lights = node.node_tree["rm_variant"]["lights"]
        img = s.render()
    finally:
        bpy.data.scenes.remove(s.scene)
        bpy.data.materials.remove(mat)
    expected = s.reference(model, **params)
    spread = s.footprint_spread(model, **params)
    worst, ratio = compare(img, expected, s.mask, spread, eevee=eevee)
    cones = [lit.spot_cone(w[s.mask] @ lit.normalize(l.direction), l.size, l.blend)
             for w, l in zip(s.wi, s.lamps) if l.kind == "SPOT"]
    key, label, within, reason = _measure(eevee)
    values = {"model": model, "lamps": lamps, "backend": backend, key: worst,
              "allowance_used": ratio, "n_pixels": int(s.mask.sum()),
              "bound": bound, "lights": lights, "lamp_names": [o for o in bound],
              "cone_edge_pixels": int(sum(np.sum((c > 0.01) & (c < 0.99)) for c in cones)),
              "outside_cone_pixels": int(sum(np.sum(c == 0.0) for c in cones))}
    return Check(name=f"{model} exact, {len(lamp_set)} lamps ({lamps}), "
                      f"{values['backend']}",
                 passed=ratio <= 1.0,
                 measured=f"max {label} {worst:.2e} ({ratio:.2f} of the allowance)",
                 expected=within + " + the change across the pixel filter", group="lamps",
                 tolerance=reason, values=values, seconds=time.perf_counter() - t0)


PLACEMENTS = ("material", "group", "geometry_nodes", "instance")


def _into_user_group(api, mat, node):
    """Move ``node`` into a shader group of the user's (its BSDF to the
    group's Shader output), the group node to the material's Surface; the
    mode set again through the API, inside the group.  Returns the node in
    the group."""
    bpy = common.import_bpy()
    tree = mat.node_tree
    group = bpy.data.node_groups.new(mat.name + " user group", "ShaderNodeTree")
    group.interface.new_socket("Shader", in_out='OUTPUT', socket_type='NodeSocketShader')
    out = group.nodes.new("NodeGroupOutput")
    inner = group.nodes.new("ShaderNodeGroup")
    inner.node_tree = node.node_tree
    inner.label = node.label
    for src, dst in zip(node.inputs, inner.inputs):
        if hasattr(src, "default_value"):
            dst.default_value = src.default_value
    group.links.new(inner.outputs["BSDF"], out.inputs[0])
    mode = api.get_mode(node)
    api.set_mode(node, "path_traced")  # drops the material's hybrid Add Shader
    tree.nodes.remove(node)
    holder = tree.nodes.new("ShaderNodeGroup")
    holder.node_tree = group
    surface = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    tree.links.new(holder.outputs[0], surface.inputs["Surface"])
    api.set_mode(inner, mode)
    return inner


def geometry_nodes_tree(name):
    """A new Geometry Nodes tree with one Geometry input and output:
    ``(tree, its Group Input node, its Group Output node)``."""
    bpy = common.import_bpy()
    tree = bpy.data.node_groups.new(name, "GeometryNodeTree")
    for side in ("INPUT", "OUTPUT"):
        tree.interface.new_socket("Geometry", in_out=side, socket_type='NodeSocketGeometry')
    return tree, tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")


def material_by_geometry_nodes(obj, mat):
    """``obj``'s slots emptied; a Geometry Nodes modifier's Set Material
    node gives its geometry ``mat``."""
    obj.data.materials.clear()
    tree, given, out = geometry_nodes_tree(mat.name + " set material")
    setter = tree.nodes.new("GeometryNodeSetMaterial")
    setter.inputs["Material"].default_value = mat
    tree.links.new(given.outputs[0], setter.inputs["Geometry"])
    tree.links.new(setter.outputs["Geometry"], out.inputs[0])
    obj.modifiers.new("RM set material", 'NODES').node_group = tree
    return tree


def _instanced(scene, obj):
    """``obj`` replaced in ``scene`` by a collection instance of a new
    object of its mesh (an Empty at the origin: the same geometry, rendered
    as an instance); the new object is in no view layer, as in a file that
    keeps its instanced objects out of the scene.  Cycles applies the
    instanced object's own exclusion where the instancer has none, EEVEE
    does not (measured, 5.2: with only the object excluded, Cycles renders
    the model within 1.03e-6 relative, EEVEE lights the tiles twice, 0.69
    (Cook-Torrance) and 1.0 (Lambert) of the peak off).  The extension
    excludes the instancer and not the new object, which is in no scene
    (it renders only as the instance), so the render tells in both
    engines whether the instancer is excluded, as does the check's
    ``excluded``.  Returns the Empty, the collection and the new object."""
    bpy = common.import_bpy()
    source = bpy.data.collections.new(obj.name + " source")
    copy = bpy.data.objects.new(obj.name + " instanced", obj.data)
    copy.matrix_world = obj.matrix_world
    copy.visible_diffuse, copy.visible_glossy = obj.visible_diffuse, obj.visible_glossy
    source.objects.link(copy)
    for coll in list(obj.users_collection):
        coll.objects.unlink(obj)
    empty = bpy.data.objects.new(obj.name + " instancer", None)
    empty.instance_type = 'COLLECTION'
    empty.instance_collection = source
    empty.visible_diffuse, empty.visible_glossy = obj.visible_diffuse, obj.visible_glossy
    scene.collection.objects.link(empty)
    return empty, source, copy


def remove_binding(api, node, scene, material, made=()):
    """Unbind ``node`` (the light linking its binding added goes), then
    remove ``scene``, ``material`` and the data ``made`` (None skipped)."""
    bpy = common.import_bpy()
    api.unbind_light(node)
    bpy.data.scenes.remove(scene)
    bpy.data.materials.remove(material)
    made = [data for data in made if data is not None]
    if made:
        bpy.data.batch_remove(made)


def hybrid_bound_lamp(api, model: str, *, osl: bool, resolution=48, eevee=False,
                      placement="material"):
    """The tiles are hidden from diffuse and glossy rays: Cycles traces a
    BSDF ray even without bounces to collect emission, and the neighbours'
    Direct output is an emission (their reflection of the sun: right in a
    lit scene, not this check's subject).  ``eevee``: rendered by EEVEE
    (native nodes, ``osl`` ignored), which honours the light linking too,
    held to 3e-3 of the peak (half-float output).  ``placement``: the
    node in the material ("material"), inside a node group of the user's
    there ("group"), the material given to the tiles by a Geometry Nodes
    modifier instead of a slot ("geometry_nodes"), or the tiles rendered as
    a collection instance ("instance"): the light linking finds the tiles,
    or their instancer, in each case."""
    if placement not in PLACEMENTS:
        raise ValueError(f"placement={placement!r}; allowed: {', '.join(PLACEMENTS)}")
    t0 = time.perf_counter()
    common.import_bpy()  # Blender prepared before the scene is built
    light = gonio.normalize((0.35, 0.25, 0.90))
    backend = _backend(osl, eevee)
    where = "" if placement == "material" else f"_{placement}"
    name = f"hybrid_{model}_{backend}{where}"
    mat = _material(name)
    node = api.add_model(mat, model, mode="hybrid")
    g = gonio.build_gonio_scene(mat, light_dir=light, resolution=resolution,
                                osl=backend == "osl", name=name)
    _use_backend(g.scene, api, backend)
    g.tiles_object.visible_diffuse = g.tiles_object.visible_glossy = False
    made, receiver = [], g.tiles_object
    try:
        if placement == "group":
            node = _into_user_group(api, mat, node)
            made.append(node.id_data)
        elif placement == "geometry_nodes":
            made.append(material_by_geometry_nodes(g.tiles_object, mat))
        elif placement == "instance":
            receiver, source, copy = _instanced(g.scene, g.tiles_object)
            made += [receiver, source, copy]
        api.bind_light(node, g.sun)
        coll = g.sun.light_linking.receiver_collection
        excluded = coll is not None and any(
            o == receiver and e.light_linking.link_state == 'EXCLUDE'
            for e, o in zip(coll.collection_objects, coll.objects))
        img = g.render()
    finally:
        remove_binding(api, node, g.scene, mat, made)
    expected = g.reference(model)
    worst, ratio = compare(img, expected, g.mask, eevee=eevee)
    key, label, within, reason = _measure(eevee)
    values = {"model": model, "backend": backend, "placement": placement, key: worst,
              "excluded": excluded, "n_lit": int(g.lit.sum()),
              "peak": float(expected[g.lit].max()) if g.lit.any() else 0.0}
    where = {"material": "", "group": " (inside a user's group)",
             "geometry_nodes": " (material by Geometry Nodes)",
             "instance": " (a collection instance)"}[placement]
    return Check(name=f"{model} hybrid under its bound sun{where}, {backend}",
                 passed=ratio <= 1.0 and excluded,
                 measured=f"max {label} {worst:.2e}",
                 expected=within + ": the bound lamp exactly, no closure response to it",
                 group="hybrid", tolerance=reason, values=values,
                 seconds=time.perf_counter() - t0)


def _lambert_gonio(api, name, mode, *, osl, eevee, resolution):
    """``(backend, material, node, gonio scene)``: a Lambert node in
    ``mode`` on the gonio's tiles under the sun, set up for the backend
    (named ``name`` and the backend)."""
    backend = _backend(osl, eevee)
    name = f"{name}_{backend}"
    mat = _material(name)
    node = api.add_model(mat, "lambert", mode=mode)
    g = gonio.build_gonio_scene(mat, light_dir=gonio.normalize((0.35, 0.25, 0.90)),
                                resolution=resolution, osl=backend == "osl", name=name)
    _use_backend(g.scene, api, backend)
    return backend, mat, node, g


def hybrid_copied_lamp(api, *, osl: bool, resolution=48, eevee=False):
    """A copy of the bound sun (Blender gives it the original's light
    linking), then the node bound to both.  Lambert, whose closure is the
    model: unbound, the copy lights the tiles through the BSDF output;
    bound, each sun renders the model and neither adds its closure's
    response.  Both renders are 2 x the reference (1e-4 relative; EEVEE
    3e-3 of the peak, half float); a copy that kept the original's
    collection renders 1 x, a sun that did not exclude the tiles 3 x.  The
    light linking is brought up to date as the render handler does it
    (``sync_light_linking``), so that the check does not depend on
    handlers being registered."""
    t0 = time.perf_counter()
    backend, mat, node, g = _lambert_gonio(api, "hybrid_copy", "hybrid", osl=osl, eevee=eevee,
                                           resolution=resolution)
    g.tiles_object.visible_diffuse = g.tiles_object.visible_glossy = False
    expected = 2.0 * g.reference("lambert")
    worst, ratio, collections, copy = 0.0, 0.0, set(), None
    try:
        api.bind_light(node, g.sun)
        copy = g.sun.copy()
        g.scene.collection.objects.link(copy)
        for bind_both in (False, True):
            if bind_both:
                api.bind_light(node, g.sun, copy)
            api.sync_light_linking()
            collections = {lamp.light_linking.receiver_collection for lamp in (g.sun, copy)}
            w, r = compare(g.render(), expected, g.mask, eevee=eevee)
            worst, ratio = max(worst, w), max(ratio, r)
        shared = len(collections) == 1 and None not in collections
    finally:
        remove_binding(api, node, g.scene, mat, [copy])
    key, label, within, reason = _measure(eevee)
    values = {"backend": backend, key: worst, "shared": shared, "n_lit": int(g.lit.sum())}
    return Check(name=f"a copy of the bound sun, unbound then bound too, {backend}",
                 passed=ratio <= 1.0 and shared,
                 measured=f"max {label} {worst:.2e}; bound to both: "
                 + ("one shared collection" if shared else "not one collection"),
                 expected=within + " of twice the model (the copy's closure, then its exact "
                 "evaluation)", group="hybrid", tolerance=reason, values=values,
                 seconds=time.perf_counter() - t0)


# (setting, whether the engine renders the sun in it): the sun in two sibling collections
LAMP_SWITCHES = (("as bound", True), ("a disabled in renders", True),
                 ("a and b disabled in renders", False),
                 ("a excluded from the view layer, b disabled", False),
                 ("a excluded from the view layer", True),
                 ("Glossy ray visibility off", True), ("Diffuse ray visibility off", False))


def _switch_lamp(g, a, b, setting):
    """Put the sun of ``g`` (in collections ``a`` and ``b``) in ``setting``
    (one of :data:`LAMP_SWITCHES`), the other switches back on."""
    layer = g.scene.view_layers[0]
    a.hide_render = "a disabled" in setting or "a and b disabled" in setting
    b.hide_render = "b disabled" in setting or "a and b disabled" in setting
    layer.layer_collection.children[a.name].exclude = "a excluded" in setting
    g.sun.visible_glossy = setting != "Glossy ray visibility off"
    g.sun.visible_diffuse = setting != "Diffuse ray visibility off"


def lamp_switches(api, *, osl: bool, resolution=48, eevee=False):
    """Exact mode's strength follows what decides whether the engine lights
    a surface with the bound lamp: the Disable in Renders of the
    collections it is in and their exclusion from the view layer, over
    every way down to it (a lamp in two collections renders while either
    does), and its ray visibility for the model's kind.  Lambert, whose
    closure is the model, under the sun in two sibling collections, in
    each setting of :data:`LAMP_SWITCHES`: whether the engine lights the
    tiles is read from the path-traced render, and must be as expected;
    the exact render must be the model where it does and black where not
    (1e-4 relative to the model; EEVEE 3e-3 of its peak, half float)."""
    t0 = time.perf_counter()
    bpy = common.import_bpy()
    backend, mat, node, g = _lambert_gonio(api, "lamp_switches", "exact", osl=osl, eevee=eevee,
                                           resolution=resolution)
    a, b = (bpy.data.collections.new(f"{g.scene.name} {k}") for k in "ab")
    for coll in (a, b):
        g.scene.collection.children.link(coll)
    lit.move_to_collection(g.sun, a)
    b.objects.link(g.sun)
    reference = g.reference("lambert")
    worst, ratio, wrong = 0.0, 0.0, []
    try:
        api.bind_light(node, g.sun)
        g.scene.view_layers[0].update()  # the layer collections, built lazily
        renders = {}
        for mode in ("path_traced", "exact"):  # one shader compilation each in EEVEE
            api.set_mode(node, mode)
            for setting, _lights in LAMP_SWITCHES:
                _switch_lamp(g, a, b, setting)
                renders[mode, setting] = g.render()
        for setting, lights in LAMP_SWITCHES:
            traced, exact = renders["path_traced", setting], renders["exact", setting]
            engine_lights = bool(traced[g.lit].min() > 0)
            if engine_lights != lights or (not lights and traced[g.mask].any()):
                wrong.append(setting)
            w, r = compare(exact, reference * float(engine_lights), g.mask, eevee=eevee,
                           scale_of=reference)
            worst, ratio = max(worst, w), max(ratio, r)
    finally:
        remove_binding(api, node, g.scene, mat, [a, b])
    key, label, within, reason = _measure(eevee)
    values = {"backend": backend, key: worst, "settings": len(LAMP_SWITCHES),
              "not_as_expected": wrong, "n_lit": int(g.lit.sum())}
    return Check(name=f"exact mode follows the lamp's collections, view layer and ray "
                 f"visibility, {backend}",
                 passed=ratio <= 1.0 and not wrong,
                 measured=f"max {label} {worst:.2e} over {len(LAMP_SWITCHES)} settings"
                 + (f"; the engine not as expected in: {', '.join(wrong)}" if wrong else ""),
                 expected=within + " of the model where the engine lights the tiles with "
                 "the sun, black where it does not", group="hybrid", tolerance=reason,
                 values=values, seconds=time.perf_counter() - t0)


def _lit_scene(api, mode, samples, resolution, osl=True):
    """Tiles (TR + correlated Smith) over a white floor, a bound sun, an
    unbound sun, a sky of strength 0.5, 4 bounces; OSL on or off."""
    bpy = common.import_bpy()
    name = f"rm_hybrid_scene_{mode}"
    mat = _material(name)
    node = api.add_model(mat, "microfacet", mode=mode, **TR)
    g = gonio.build_gonio_scene(mat, light_dir=(0.35, 0.25, 0.90), resolution=resolution,
                                osl=osl, name=name)
    scene = g.scene
    common.configure_cycles(scene, samples=samples, max_bounces=4, osl=osl, seed=7)
    common.set_world_background(scene, 0.5, (0.6, 0.75, 1.0))
    other = lit.add_lamp(scene, lit.Lamp("SUN", direction=(-0.5, 0.3, 0.81), strength=0.7,
                                         color=(1.0, 0.85, 0.7)), name + "_sun2")
    floor_mat = _material(name + "_floor")
    tree = floor_mat.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(diffuse.outputs[0], out.inputs["Surface"])
    mesh = bpy.data.meshes.new(name + "_floor")
    mesh.from_pydata([(-8, -8, -1.5), (8, -8, -1.5), (8, 8, -1.5), (-8, 8, -1.5)], [],
                     [(0, 1, 2, 3)])
    mesh.materials.append(floor_mat)
    scene.collection.objects.link(bpy.data.objects.new(name + "_floor", mesh))
    api.bind_light(node, g.sun)
    unbound_linked = other.light_linking.receiver_collection is not None
    return g, node, (mat, floor_mat), unbound_linked


def hybrid_lit_scene(api, *, samples=64, resolution=48, osl=True):
    """The Monte Carlo bound: per tile, the means of the two renders differ
    by at most 4 standard errors (from the spread of each tile's pixels,
    which also holds the tile's small geometric variation: an overestimate
    of the noise) plus 1e-4 of the mean (float32)."""
    t0 = time.perf_counter()
    bpy = common.import_bpy()
    images = {}
    for mode in ("hybrid", "path_traced"):
        g, node, mats, unbound_linked = _lit_scene(api, mode, samples, resolution, osl)
        try:
            images[mode] = g.render().astype(np.float64)
        finally:
            api.unbind_light(node)
            bpy.data.scenes.remove(g.scene)
            for m in mats:
                bpy.data.materials.remove(m)
    h, p = images["hybrid"], images["path_traced"]
    finite = bool(np.isfinite(h).all() and np.isfinite(p).all())
    worst, tiles = 0.0, 0
    for k in range(len(g.tiles)):
        m = g.inside & (g.tile_index == k)
        n = int(m.sum())
        if n < 10:  # too few pixels inside the tile to estimate its noise
            continue
        tiles += 1
        mh, mp = h[m].mean(0), p[m].mean(0)
        se = np.sqrt(h[m].var(0, ddof=1) / n + p[m].var(0, ddof=1) / n)
        bound = 4.0 * se + 1e-4 * np.abs(mp)
        worst = max(worst, float(np.max(np.abs(mh - mp) / np.maximum(bound, 1e-12))))
    values = {"worst_over_bound": worst, "tiles": tiles, "samples": samples, "finite": finite,
              "unbound_linked": unbound_linked, "mean": float(h[g.inside].mean()),
              "backend": "osl" if osl else "native"}
    return Check(name="hybrid vs fully path traced, TR + correlated Smith, lit scene"
                      + ("" if osl else ", native"),
                 passed=finite and worst <= 1.0 and not unbound_linked,
                 measured=f"largest tile difference {worst:.2f} of its bound ({tiles} tiles, "
                 f"{samples} spp)",
                 expected="per tile: |mean difference| <= 4 standard errors + 1e-4",
                 group="hybrid", tolerance="Monte Carlo noise of both renders",
                 values=values, seconds=time.perf_counter() - t0)
