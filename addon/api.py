# SPDX-License-Identifier: GPL-3.0-or-later
"""Scripting API of Reflection Models.

Inside Blender, with the extension enabled (``<repo>`` is the extension
repository, ``user_default`` for one installed from disk)::

    from bl_ext.user_default.reflection_models import api as rm

    rm.enable_osl(bpy.context.scene)      # optional: the OSL shaders (else native nodes)
    mat = bpy.data.materials.new("Brushed")
    node = rm.add_model(mat, "microfacet", distribution="trowbridge_reitz",
                        alpha_x=0.3, alpha_y=0.05, fresnel="conductor",
                        ior=rm.METALS["aluminium"][0], k=rm.METALS["aluminium"][1])
    exact = rm.add_model(bpy.data.materials.new("Exact"), "phong", mode="exact",
                         exponent=50.0)
    rm.bind_light(exact, bpy.data.objects["Sun"])

Models, parameter names, units and ranges are those of
:mod:`addon.reference` (and the catalogue): angles in radians, colours as RGB
triples (a number is grey).  Enum parameters (``distribution``,
``shadowing``, ``fresnel``, ``normalization``) choose the node group variant.
The microfacet width is given one way, as for the reference: ``beta`` (the
half-angle; any distribution), ``alpha`` (native isotropic roughness) or
``alpha_x`` with ``alpha_y`` (native anisotropic roughness; Trowbridge-Reitz
and Beckmann only); the group variant ("width mode") shows only that width's
sockets.

Three modes: ``"path_traced"`` connects the group's BSDF output (Cycles
closures, lit by every light) to the Material Output; ``"exact"`` connects
its Direct output: the analytic value for the lamps given by the node's
Light inputs (one to four), which :func:`bind_light` drives from lamps;
``"hybrid"`` connects both, and takes the bound lamps away from the
material's objects by light linking so that nothing counts twice.

Each group holds the model as OSL shaders and as native nodes, and renders
the OSL shaders where Open Shading Language runs (Cycles on the CPU with OSL
on) and the native nodes everywhere else (GPU devices, EEVEE, OSL off);
``backend="osl"`` or ``"native"`` forces one.  :func:`rendering_backend`
says which one a scene renders; :func:`enable_osl` switches a scene to OSL.
:func:`add_model` never changes the scene.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from . import groups, lighting
from .core import catalogue
from .core.formulas import models as formulas
from .core.validation import validate

MODES = {"path_traced": "BSDF", "exact": "Direct", "hybrid": ("BSDF", "Direct")}
BACKENDS = ("auto", "osl", "native")
METALS = catalogue.METALS
SUPPORTED_LIGHTS = lighting.SUPPORTED_LIGHTS

__all__ = ["add_model", "set_params", "set_mode", "get_mode", "bind_light", "unbind_light",
           "bound_light", "bound_lights", "light_drivers", "sync_light_linking",
           "deferred_light_linking", "enable_osl",
           "osl_status", "rendering_backend", "bsdf_accuracy", "direct_accuracy",
           "ensure_groups", "upgrade_groups", "apply_metal", "use_strand_tangent", "MODES",
           "METALS", "BACKENDS"]


# ---------------------------------------------------------------------------
# Parameters

def _plain(param, value, model_name):
    """A checked value as Blender takes it: a float, or an RGB tuple."""
    arr = np.asarray(value, dtype=float)
    if param.kind == "color":
        if arr.shape in ((), (1,)):
            return (float(arr.reshape(-1)[0]),) * 3
        if arr.shape == (3,):
            return tuple(float(x) for x in arr)
        raise ValueError(f"{param.name} of {model_name!r} must be one RGB colour (3 numbers) "
                         f"or one number, not an array of shape {arr.shape}")
    if arr.shape != ():
        raise ValueError(f"{param.name} of {model_name!r} must be one number, "
                         f"not an array of shape {arr.shape}")
    return float(arr)


def _split(model_name: str, params: dict, width_mode: str | None = None,
           backend: str | None = None, lights: str | None = None):
    """Validate ``params`` (through :func:`addon.core.validation.validate`)
    and split them into ``(base model, enum values, checked values, names
    given)``.  The width mode follows the width given, else ``width_mode``
    (the node's current one), else the default (beta); the backend is
    ``backend`` (default 'auto')."""
    model, values, given = validate(model_name, params)
    enums = {p.name: values[p.name] for p in model.params if p.is_enum}
    backend = groups.BACKEND_PARAM.default if backend is None else backend
    if backend not in groups.BACKEND_PARAM.choices:
        raise ValueError(f"backend={backend!r} is not allowed; backend must be "
                         f"{groups.BACKEND_PARAM.allowed()}")
    enums[groups.BACKEND_PARAM.name] = backend
    enums[groups.LIGHTS_PARAM.name] = groups.LIGHTS_PARAM.default if lights is None else lights
    if "width" in model.rules:
        gave_width = any(n in given for names in groups.WIDTH_SOCKETS.values() for n in names)
        if gave_width or width_mode is None:
            width_mode = groups.WIDTH_FROM_REFERENCE[values["_width"]]
        enums[groups.WIDTH_PARAM.name] = width_mode
    return model, enums, values, given


def _socket_values(model, enums, values, names) -> dict:
    """Blender values of the parameters ``names`` that have a socket in the
    variant ``enums`` (a width of another width mode has none)."""
    have = {p.name for p in groups.socket_params(model.id, enums)}
    out = {}
    for name in names:
        if name in have:
            param = model.param(name)
            value = _plain(param, values[name], model.id)
            out[name] = (*value, 1.0) if param.kind == "color" else value
    return out


def _set_sockets(node, socket_values: dict) -> None:
    for name, value in socket_values.items():
        groups.input_socket(node, name).default_value = value


def _rm_node_info(node):
    info = groups.rm_info(getattr(node, "node_tree", None))
    if info is None:
        raise ValueError(f"{getattr(node, 'name', node)!r} is not a Reflection Models node")
    return info


def add_model(material, model: str, mode: str = "path_traced", *, backend: str = "auto",
              **params):
    """Add the node group of ``model`` to ``material`` and connect it to the
    Material Output's Surface; returns the group node.

    - ``model``: a model or preset name of the catalogue (``lambert``,
      ``phong``, ``blinn_phong``, ``microfacet``, ``kajiya_kay``, ``ward``,
      ``torrance_sparrow``, ``cook_torrance``).
    - ``mode``: ``"path_traced"`` (the BSDF output), ``"exact"`` (the Direct
      output: the bound lamps evaluated analytically) or ``"hybrid"`` (both
      added: the bound lamps exactly, everything else -- sky, other lamps,
      bounces -- path traced, the bound lamps excluded from the material's
      objects by light linking; see :func:`set_mode`).  For exact and
      hybrid the material's emission sampling is set to None, so the
      surface is not sampled as a lamp.
    - ``backend``: ``"auto"`` (the OSL shader where Open Shading Language
      runs, native nodes everywhere else: GPU devices, EEVEE, OSL off),
      ``"osl"`` or ``"native"``.
    - ``params``: as for :func:`addon.reference.shade`: radians, RGB
      triples, enum values choose the group variant; a width for the
      microfacet model as ``beta``, ``alpha`` or ``alpha_x``/``alpha_y``.
      Every socket gets the catalogue default unless given.

    Raises ``ValueError`` for an unknown model, mode, backend, parameter or
    value.
    Does not touch the scene: see :func:`enable_osl`.
    """
    if not isinstance(material, bpy.types.Material):
        raise ValueError(f"add_model needs a material (bpy.types.Material), not "
                         f"{type(material).__name__}")
    _check_mode(mode)
    base, enums, values, _given = _split(model, params, backend=backend)
    socket_values = _socket_values(base, enums, values,
                                   [p.name for p in base.params if not p.is_enum])
    tree = groups.ensure_group(base.id, **enums)

    if material.node_tree is None:
        material.use_nodes = True  # Blender < 5.0; from 5.0 every material has a tree
    ntree = material.node_tree
    output = _material_output(ntree)
    node = ntree.nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    if model in catalogue.PRESETS:
        node.label = catalogue.PRESETS[model].label
    node.location = (output.location.x - 300.0, output.location.y)
    _set_sockets(node, socket_values)
    _wire(node, mode, [material])
    for other in ntree.nodes:
        other.select = other == node
    ntree.nodes.active = node
    return node


def set_params(node, *, backend: str | None = None, **params):
    """Set parameters of an RM group ``node`` (names and units as in
    :func:`add_model`); enum values, a width given another way, or another
    ``backend`` switch the node to another group variant, keeping its links
    and other values.  Returns the node."""
    model_id, variant = _rm_node_info(node)
    current = {k: v for k, v in variant.items()
               if k not in (groups.WIDTH_PARAM.name, groups.BACKEND_PARAM.name,
                            groups.LIGHTS_PARAM.name)}
    base, enums, values, _given = _split(
        model_id, {**current, **params}, variant.get(groups.WIDTH_PARAM.name),
        backend if backend is not None else variant.get(groups.BACKEND_PARAM.name),
        variant.get(groups.LIGHTS_PARAM.name))
    socket_values = _socket_values(base, enums, values,
                                   [n for n in params if not base.param(n).is_enum])
    if enums != groups.resolve_variant(model_id, variant)[1]:
        groups.switch_variant(node, **enums)
    _set_sockets(node, socket_values)
    return node


def _check_mode(mode):
    if mode not in MODES:
        raise ValueError(f"mode={mode!r} is not allowed; mode must be one of "
                         + ", ".join(repr(m) for m in MODES))


HYBRID_TAG = "rm_hybrid_of"


def _group_targets(node) -> list:
    """In a group of the user's, the inputs the node's current mode feeds
    (its BSDF or Direct output, or the hybrid Add Shader); failing those,
    the group's first free Shader output.  Raises ``ValueError`` when there
    is neither."""
    ntree = node.id_data
    sources = [other.outputs[0] for other in ntree.nodes if other.get(HYBRID_TAG) == node.name]
    current = MODES[lighting.node_mode(node)]
    if isinstance(current, str):
        sources.append(groups.output_socket(node, current))
    targets = [link.to_socket for link in ntree.links
               if any(link.from_socket == s for s in sources)
               and link.to_node.get(HYBRID_TAG) != node.name]
    if not targets:
        for out in ntree.nodes:
            if out.bl_idname == "NodeGroupOutput" and out.is_active_output:
                targets = [s for s in out.inputs if s.type == 'SHADER' and not s.is_linked][:1]
    if not targets:
        raise ValueError(f"{node.name!r} is inside node group {ntree.name!r}, where its "
                         "output goes nowhere and the group has no free Shader output: "
                         "link its BSDF or Direct output first")
    return targets


def _wire(node, mode, materials):
    """Connect ``node``'s output for ``mode`` to the Material Output's
    Surface (hybrid: an Add Shader of BSDF and Direct, tagged as ours); in
    a group of the user's, to what its current mode's output fed (see
    :func:`_group_targets`).  ``materials``: those whose emission sampling
    exact and hybrid mode turn off."""
    ntree = node.id_data
    if getattr(ntree, "is_embedded_data", False):
        targets = [_material_output(ntree).inputs["Surface"]]
    else:
        targets = _group_targets(node)
    for other in list(ntree.nodes):
        if other.get(HYBRID_TAG) == node.name:
            ntree.nodes.remove(other)
    if mode == "hybrid":
        add = ntree.nodes.new("ShaderNodeAddShader")
        add[HYBRID_TAG] = node.name
        add.label = "Hybrid: bound lamps exact + path traced"
        add.location = (node.location.x + 200.0, node.location.y + 150.0)
        ntree.links.new(groups.output_socket(node, "BSDF"), add.inputs[0])
        ntree.links.new(groups.output_socket(node, "Direct"), add.inputs[1])
        source = add.outputs[0]
    else:
        source = groups.output_socket(node, MODES[mode])
    for target in targets:
        ntree.links.new(source, target)
    node["rm_mode"] = mode
    if mode != "path_traced":
        for material in materials:
            material.cycles.emission_sampling = 'NONE'


def set_mode(node, mode: str):
    """Switch RM group ``node`` to ``mode`` (``"path_traced"``, ``"exact"``
    or ``"hybrid"``): rewire the Material Output and bring the light linking
    up to date (in hybrid mode every object using the material is excluded
    from the lamps the node is bound to, so that nothing counts twice; an
    object counts as using it through a slot or through the geometry its
    Geometry Nodes make).  A node inside a node group of the user's feeds
    what its output fed before (or the group's first free Shader output);
    every material using the group counts.  Returns the node; raises
    ``ValueError`` for an unknown mode, or for a node in a group where its
    output goes nowhere and the group has no free Shader output."""
    _rm_node_info(node)
    _check_mode(mode)
    _wire(node, mode, groups.materials_of(node))
    lighting.linking_changed()
    return node


def get_mode(node) -> str:
    """The mode of RM group ``node``: ``"path_traced"``, ``"exact"`` or
    ``"hybrid"``."""
    _rm_node_info(node)
    return lighting.node_mode(node)


def apply_metal(node, metal: str):
    """Make a microfacet ``node`` a metal: Fresnel 'conductor' with the
    measured complex index n + ik of ``metal`` (a key of :data:`METALS`;
    sources in ``addon/catalogue.py``).  Returns the node."""
    if metal not in METALS:
        raise ValueError(f"unknown metal {metal!r}; allowed: {', '.join(METALS)}")
    model_id, _variant = _rm_node_info(node)
    if model_id != "microfacet":
        raise ValueError(f"metals apply to microfacet nodes, not {model_id!r}")
    n, k = METALS[metal]
    return set_params(node, fresnel="conductor", ior=n, k=k)


STRAND_TANGENT_LABEL = "Strand Direction (Geometry Tangent)"


def use_strand_tangent(node):
    """Feed the Tangent input of RM group ``node`` from a Geometry node's
    Tangent output: on hair curves the strand's direction
    (``normalize(dPdu)``), which Kajiya-Kay's fibres and the anisotropic
    lobes need there.  The input's default, the UV map's tangent, is 0 on
    curves (measured in Cycles with OSL on and off and in EEVEE), so
    unconnected the fibre falls back to an axis across the strands.  On a
    mesh the Geometry node's Tangent runs about the generated coordinates'
    Z axis (and EEVEE reads one more attribute for it), so the link is
    left to the user rather than made by every group.  Replaces what fed
    the input; calling it again changes nothing.  Returns the Geometry
    node.  Raises ValueError for a node whose variant has no Tangent input
    (only Kajiya-Kay, Ward and the microfacet model's alpha_x/alpha_y
    width have one)."""
    _rm_node_info(node)
    try:
        socket = groups.input_socket(node, "tangent")
    except KeyError:
        raise ValueError(f"{node.name!r} has no Tangent input; the variants with one: "
                         "kajiya_kay, ward, microfacet with alpha_x and alpha_y") from None
    tree = node.id_data
    for link in socket.links:
        source = link.from_node
        if source.bl_idname == "ShaderNodeNewGeometry" and link.from_socket.name == "Tangent":
            return source
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    geometry.label = STRAND_TANGENT_LABEL
    geometry.location = (node.location.x - 220.0, node.location.y - 60.0)
    geometry.parent = node.parent
    tree.links.new(geometry.outputs["Tangent"], socket)
    return geometry


def _material_output(ntree):
    outputs = [n for n in ntree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    for n in outputs:
        if n.is_active_output and n.target in ("ALL", "CYCLES"):
            return n
    for n in outputs:
        if n.target in ("ALL", "CYCLES"):
            return n
    node = ntree.nodes.new("ShaderNodeOutputMaterial")
    node.location = (300.0, 0.0)
    return node


def ensure_groups() -> dict:
    """Build (or reuse) the default variant of every model; returns
    ``{model id: node group}``."""
    return {model_id: groups.ensure_group(model_id) for model_id in catalogue.MODELS}


def upgrade_groups() -> list:
    """Rebuild every local node group of the extension that an older version
    built, or whose native nodes were planned for another Blender's (a file
    made in 4.5 opened in 5.2: no shadow ray in native exact mode), keeping
    the values, links, drivers and keyframes of every node that uses it (the
    sidebar's Upgrade Groups; ``load_post`` logs a warning where a file has
    such groups).  Returns the names of the groups rebuilt."""
    outdated = groups.find_outdated_groups()
    for tree in outdated:
        groups.upgrade_group(tree)
    return [tree.name for tree in outdated]


# ---------------------------------------------------------------------------
# The scene

def _scene(scene, caller):
    """``scene``, or the context scene for None; anything else than a scene
    raises ``ValueError``."""
    if scene is None:
        return bpy.context.scene
    if not isinstance(scene, bpy.types.Scene):
        raise ValueError(f"{caller} takes a scene (bpy.types.Scene) or None (the context "
                         f"scene), not {type(scene).__name__}")
    return scene


def osl_status(scene=None) -> tuple:
    """``(problems, warnings)``: why ``scene`` (default: the context scene)
    cannot run the OSL shaders (empty when it can), and caveats (OptiX: no
    shadow rays)."""
    scene = _scene(scene, "osl_status")
    problems, warnings = [], []
    engine = scene.render.engine
    if engine != 'CYCLES':
        problems.append(f"The render engine is {engine}, not Cycles")
        return problems, warnings
    cycles = scene.cycles
    if not cycles.shading_system:
        problems.append("Open Shading Language is off")
    backend = _compute_device_type()
    if cycles.device == 'GPU' and backend not in (None, 'NONE'):  # 'NONE': Cycles uses the CPU
        if backend == 'OPTIX':
            warnings.append("OptiX runs OSL without trace(): exact mode has no shadows")
        else:
            problems.append(f"The device is GPU ({backend}): OSL runs on the CPU (or "
                            "OptiX) only")
    return problems, warnings


def rendering_backend(scene=None, node=None) -> tuple:
    """``(backend, reason)``: which shaders an 'auto' node renders with in
    ``scene`` (default: the context scene) as it is set now: ``"osl"``
    (Cycles on the CPU, or OptiX, with Open Shading Language on),
    ``"native"`` (every other Cycles set-up and EEVEE), or ``"none"`` (an
    engine that draws no materials, e.g. Workbench).  With an RM group
    ``node``, which render that node, its own ``backend`` choice counted:
    a node forced to the native nodes renders them with OSL on too, and
    one forced to OSL renders nothing ("none") where OSL does not run."""
    scene = _scene(scene, "rendering_backend")
    forced = "auto" if node is None else \
        _rm_node_info(node)[1].get(groups.BACKEND_PARAM.name, "auto")
    engine = scene.render.engine
    if engine != 'CYCLES' and not lighting.is_eevee(scene):
        return "none", f"the {engine} engine does not render shader nodes"
    problems, warnings = osl_status(scene)
    if forced == "native":
        return "native", "the node is set to native nodes"
    if forced == "osl" and problems:
        return "none", "the node is set to OSL, which this scene does not run: " + \
            "; ".join(problems)
    if lighting.is_eevee(scene):
        return "native", "EEVEE runs native nodes"
    if not problems:
        return "osl", "Cycles with Open Shading Language" + \
            (f" ({warnings[0]})" if warnings else "")
    return "native", "; ".join(problems)


def bsdf_accuracy(node, scene=None) -> dict:
    """How the BSDF output of RM group ``node`` matches its model where
    ``scene`` (default: the context scene) renders it, as set now, at the
    node's width and Fresnel indices (Kajiya-Kay: its exponent and colours;
    its variant's worst where one of those inputs is linked).  A dict:

    - ``"backend"``: the shaders that render the node
      (:func:`rendering_backend` of the scene and the node): "osl",
      "native" or "none";
    - ``"status"``: "exact" (a Cycles closure is the model), "near"
      (Cycles' closure, under 1 % off), "fitted" (a fitted mixture within
      0.025 of the peak), "approx" (measured or not, no bound; EEVEE's own
      closures are this) or "none" (nothing renders it);
    - ``"max_abs_over_peak"``: the largest |output - model| over the
      model's peak that the offline fitter measured (views and lights up to
      70 deg; ``docs/verification.md``), or None where none was;
    - ``"note"``: where that figure holds ("at this width", "at this
      exponent and these colours", "at its worst width"), or why there is
      none;
    - ``"detail"``: a sentence on the part of the domain that decides the
      figure, or None (Kajiya-Kay: the figure with the light on the view's
      side across the fibre; on the other its hair closure is 0)."""
    model_id, variant = _rm_node_info(node)
    scene = _scene(scene, "bsdf_accuracy")
    backend, reason = rendering_backend(scene, node)
    if backend == "none":
        return {"backend": "none", "status": "none", "max_abs_over_peak": None, "note": reason,
                "detail": None}
    if lighting.is_eevee(scene):
        return {"backend": backend, "status": "approx", "max_abs_over_peak": None,
                "note": "EEVEE's own closures: not measured by the fitter", "detail": None}
    params = _path_traced_params(node, catalogue.MODELS[model_id])
    enums = {k: v for k, v in variant.items()
             if k not in (groups.BACKEND_PARAM.name, groups.LIGHTS_PARAM.name)}
    status = formulas.path_traced_status(model_id, enums, params, bpy.app.version, backend)
    error, note = formulas.path_traced_error(model_id, enums, params, bpy.app.version, backend)
    detail = formulas.path_traced_detail(model_id, enums, params, bpy.app.version, backend)
    return {"backend": backend, "status": status, "max_abs_over_peak": error, "note": note,
            "detail": detail}


# exact mode's bounds, as the checks hold them (verification/harness/checks.py,
# tests/test_api.py compares): Cycles, OSL or native nodes, float32 against the
# float64 reference (measured <= 1.5e-5); EEVEE, its half-float output
EXACT_MAX_REL_ERROR = 1e-4
EEVEE_EXACT_MAX_ABS_OVER_PEAK = 3e-3


def direct_accuracy(node, scene=None) -> dict:
    """How the Direct output (exact mode) of RM group ``node`` matches its
    model where ``scene`` (default: the context scene) renders it, as set
    now.  A dict:

    - ``"backend"``: :func:`rendering_backend` of the scene and the node;
    - ``"max_rel_error"``: the relative error the checks hold it to in
      Cycles (1e-4: float32), or None; ``"max_abs_over_peak"``: in EEVEE,
      the difference over the model's peak (3e-3: its half-float output),
      or None;
    - ``"shadows"``: "ray" (a ray through the scene: OSL's trace(), the
      Raycast node in Cycles), "screen_space" (EEVEE's Raycast node: only
      what the view sees casts a shadow), "none" (Blender 4.5's native
      nodes, which have no Raycast node; OSL on OptiX, where trace()
      misses), or None where nothing renders the node;
    - ``"notes"``: what else of the bound lamps exact mode does not follow,
      in words (the sidebar's): a lamp's size, a spot's uneven scale, light
      and shadow linking, Kajiya-Kay's ray visibility, EEVEE's light
      factors."""
    _rm_node_info(node)
    scene = _scene(scene, "direct_accuracy")
    backend, reason = rendering_backend(scene, node)
    out = {"backend": backend, "max_rel_error": None, "max_abs_over_peak": None,
           "shadows": None, "notes": []}
    if backend == "none":
        out["notes"].append(reason)
        return out
    from .backends.native import build as native_build
    eevee = lighting.is_eevee(scene)
    if eevee:
        out["max_abs_over_peak"] = EEVEE_EXACT_MAX_ABS_OVER_PEAK
    else:
        out["max_rel_error"] = EXACT_MAX_REL_ERROR
    if backend == "osl":
        out["shadows"] = "none" if osl_status(scene)[1] else "ray"  # OptiX: no trace()
    elif not native_build.has_raycast():
        out["shadows"] = "none"
    else:
        out["shadows"] = "screen_space" if eevee else "ray"
    bound = bound_lights(node)

    def names(lamps):
        return ", ".join(o if isinstance(o, str) else o.name for o in lamps)
    for lamps, text in (
            (lighting.sized_lamps(bound), "taken as a direction or point, size ignored"),
            (lighting.unevenly_scaled_spots(bound), "spot cone taken unscaled (Cycles scales "
                                                    "it with the lamp's uneven scale)"),
            (lighting.shadow_linked_lamps(node), "shadow linking not followed: the shadow "
                                                 "ray sees every object"),
            (lighting.light_linked_lamps(node), "light linking not followed: every object "
                                                "with the material is lit"),
            (lighting.unfollowed_ray_lamps(node), "one ray visibility off: Kajiya-Kay's "
                                                  "diffuse and specular terms share one "
                                                  "light"),
            (lighting.eevee_factor_lamps(node, scene), "EEVEE's Diffuse and Specular light "
                                                       "factors not followed")):
        if lamps:
            out["notes"].append(f"{names(lamps)}: {text}")
    return out


def _path_traced_params(node, model):
    """The widths and Fresnel indices of ``node`` that the BSDF output's
    status depends on (:func:`~.core.formulas.models.path_traced_status`),
    as the shaders take them (clamped to the parameter's limits, NaN to the
    lower), or None where one of them is linked (its value is the link's)."""
    params = {}
    for name in formulas.FORMULAS[model.id].status_params:
        try:
            socket = groups.input_socket(node, name)
        except KeyError:
            continue
        if socket.is_linked:
            return None
        param = model.param(name)

        def clamped(x):
            x = float(x)
            lo = -math.inf if param.minimum is None else param.minimum
            hi = math.inf if param.maximum is None else param.maximum
            return lo if math.isnan(x) else min(max(x, lo), hi)
        value = socket.default_value
        params[name] = clamped(value) if isinstance(value, (int, float)) else \
            tuple(clamped(v) for v in value[:3])
    return params


def _compute_device_type():
    addon = bpy.context.preferences.addons.get("cycles")
    return getattr(getattr(addon, "preferences", None), "compute_device_type", None)


def enable_osl(scene=None):
    """Make ``scene`` (default: the context scene) able to run the shaders:
    Cycles, CPU device, Open Shading Language on.  Returns the scene."""
    scene = _scene(scene, "enable_osl")
    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.shading_system = True
    return scene


# ---------------------------------------------------------------------------
# Lights

def bind_light(node, *lamps) -> None:
    """Drive the Light inputs of RM group ``node`` from ``lamps`` (1 to 4
    SUN, POINT or SPOT lamp objects), so that exact mode (and the exact part
    of hybrid mode) follows them: light k of the node follows lamp k, and
    the result is the sum over the lamps.

    Drivers with simple expressions only (no Python auto-run needed):

    - SUN: Light Direction = the lamp's world +Z axis, from its world-space
      rotation; Point Light = 0; Light Strength = the sun's strength (the
      irradiance, W/m^2).
    - POINT: Light Position = its world-space location; Point Light = 1;
      Light Strength = power / (4 pi), the intensity (W/sr) of Cycles' point
      lamp (with "normalize" off: power * radius^2, or power / pi at
      radius 0).
    - SPOT: as POINT, and Spot = 1, Light Direction = the lamp's world +Z
      axis (its axis reversed), Spot Size and Spot Blend from the lamp: the
      cone as Cycles computes it (for a lamp without scale).
    - Light Color = the lamp colour (times its blackbody colour when "use
      temperature" is on); strength times 2^exposure.

    The node gets the group variant with as many lights as lamps (each
    costs a shadow ray).  In hybrid mode the objects using the material are
    excluded from the lamps by light linking (:func:`set_mode`).  Other lamp
    types, other objects, more than 4 lamps or a lamp given twice raise
    ``ValueError``.  A lamp's soft size and angle are not modelled: exact
    mode treats it as a point or a direction.
    """
    lighting.bind_lights(node, *lamps)


def unbind_light(node) -> None:
    """Remove what :func:`bind_light` added: the drivers on the Light
    inputs, the extra lights, and the light linking of hybrid mode (not
    what a user linked by hand).  The first light's inputs keep the values
    the lamp gave them last (as a removed driver leaves its property): a
    still copy of the lamp, which exact mode goes on rendering."""
    lighting.unbind_lights(node)


def bound_lights(node) -> list:
    """The lamp objects the lights of ``node`` follow, in order."""
    _rm_node_info(node)
    return lighting.bound_lights(node)


def bound_light(node):
    """The first lamp :func:`bind_light` bound ``node`` to, or None."""
    lamps = bound_lights(node)
    return lamps[0] if lamps else None


def light_drivers(node) -> list:
    """The driver F-curves on the Light inputs of ``node``."""
    return lighting.light_drivers(node)


def sync_light_linking() -> int:
    """Bring the light linking of hybrid mode up to date (objects that got
    or lost a hybrid material since); the extension does this on render
    and on save.  Returns the number of changes."""
    return lighting.sync_light_linking()


def deferred_light_linking():
    """A context manager for scripts that bind or switch many nodes: inside
    ``with api.deferred_light_linking():``, :func:`bind_light`,
    :func:`unbind_light` and :func:`set_mode` leave the light linking of
    hybrid mode as it is, and it is brought up to date once when the
    outermost such block ends (by an exception too).  Each update reads
    every hybrid node in the file, so binding n hybrid nodes one by one
    reads n times n: 400 nodes took 9.4 s, and within one block 0.3 s
    (``make bench``).  Inside the block the hybrid objects are not yet
    excluded from the lamps newly bound, so render after it."""
    return lighting.deferred_linking()
