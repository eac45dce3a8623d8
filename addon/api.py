# SPDX-License-Identifier: GPL-3.0-or-later
"""Scripting API of Reflection Models.

Inside Blender, with the extension enabled (``<repo>`` is the extension
repository, ``user_default`` for one installed from disk)::

    from bl_ext.user_default.reflection_models import api as rm

    rm.enable_osl(bpy.context.scene)      # Cycles, CPU, Open Shading Language on
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

Two modes: ``"path_traced"`` connects the group's BSDF output (a Cycles
closure, lit by every light) to the Material Output; ``"exact"`` connects its
Direct output: the analytic value for one light, given by the node's Light
inputs, which :func:`bind_light` drives from a lamp.

The shaders are OSL Script nodes: the scene must render with Cycles, on the
CPU (OptiX runs OSL but without shadow rays), with Open Shading Language on.
:func:`add_model` never changes the scene; call :func:`enable_osl` (or use the
"Enable OSL" button of the Shader Editor sidebar).
"""

from __future__ import annotations

import bpy
import numpy as np

from . import groups
from .core import catalogue
from .core.validation import validate

MODES = {"path_traced": "BSDF", "exact": "Direct"}
METALS = catalogue.METALS
SUPPORTED_LIGHTS = ("SUN", "POINT")
LIGHT_SOCKETS = tuple(p.name for p in catalogue.LIGHT_INPUTS)

__all__ = ["add_model", "set_params", "bind_light", "unbind_light", "bound_light",
           "light_drivers", "enable_osl", "osl_status", "ensure_groups", "apply_metal",
           "MODES", "METALS"]


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


def _split(model_name: str, params: dict, width_mode: str | None = None):
    """Validate ``params`` (through :func:`addon.reference._check`) and split
    them into ``(base model, enum values, checked values, names given)``.
    The width mode follows the width given, else ``width_mode`` (the node's
    current one), else the default (beta)."""
    model, values, given = validate(model_name, params)
    enums = {p.name: values[p.name] for p in model.params if p.is_enum}
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


def add_model(material, model: str, mode: str = "path_traced", **params):
    """Add the node group of ``model`` to ``material`` and connect it to the
    Material Output's Surface; returns the group node.

    - ``model``: a model or preset name of the catalogue (``lambert``,
      ``phong``, ``blinn_phong``, ``microfacet``, ``kajiya_kay``, ``ward``,
      ``torrance_sparrow``, ``cook_torrance``).
    - ``mode``: ``"path_traced"`` (the BSDF output) or ``"exact"`` (the Direct
      output; the material's emission sampling is set to None, so the
      surface is not sampled as a lamp).
    - ``params``: as for :func:`addon.reference.shade`: radians, RGB
      triples, enum values choose the group variant; a width for the
      microfacet model as ``beta``, ``alpha`` or ``alpha_x``/``alpha_y``.
      Every socket gets the catalogue default unless given.

    Raises ``ValueError`` for an unknown model, mode, parameter or value.
    Does not touch the scene: see :func:`enable_osl`.
    """
    if mode not in MODES:
        raise ValueError(f"mode={mode!r} is not allowed; mode must be one of "
                         + ", ".join(repr(m) for m in MODES))
    base, enums, values, _given = _split(model, params)
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
    ntree.links.new(groups.output_socket(node, MODES[mode]), output.inputs["Surface"])
    if mode == "exact":
        material.cycles.emission_sampling = 'NONE'
    for other in ntree.nodes:
        other.select = other == node
    ntree.nodes.active = node
    return node


def set_params(node, **params):
    """Set parameters of an RM group ``node`` (names and units as in
    :func:`add_model`); enum values, or a width given another way, switch the
    node to another group variant, keeping its links and other values.
    Returns the node."""
    model_id, variant = _rm_node_info(node)
    current = {k: v for k, v in variant.items() if k != groups.WIDTH_PARAM.name}
    base, enums, values, _given = _split(model_id, {**current, **params},
                                        variant.get(groups.WIDTH_PARAM.name))
    socket_values = _socket_values(base, enums, values,
                                   [n for n in params if not base.param(n).is_enum])
    if enums != variant:
        groups.switch_variant(node, **enums)
    _set_sockets(node, socket_values)
    return node


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


# ---------------------------------------------------------------------------
# The scene

def osl_status(scene) -> tuple:
    """``(problems, warnings)``: why ``scene`` cannot run the OSL shaders
    (empty when it can), and caveats (OptiX: no shadow rays)."""
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


def _compute_device_type():
    addon = bpy.context.preferences.addons.get("cycles")
    return getattr(getattr(addon, "preferences", None), "compute_device_type", None)


def enable_osl(scene=None):
    """Make ``scene`` (default: the context scene) able to run the shaders:
    Cycles, CPU device, Open Shading Language on.  Returns the scene."""
    scene = scene or bpy.context.scene
    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.shading_system = True
    return scene


# ---------------------------------------------------------------------------
# Lights

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


def _prop(light_data, path):
    def fill(var):
        var.type = 'SINGLE_PROP'
        target = var.targets[0]
        target.id_type = 'LIGHT'
        target.id = light_data
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


# The sun shines along its local -Z: the direction toward it is the world
# +Z axis, the third column of R = Rz Ry Rx (XYZ Euler).
SUN_DIRECTION = (
    "cos(rz) * sin(ry) * cos(rx) + sin(rz) * sin(rx)",
    "sin(rz) * sin(ry) * cos(rx) - cos(rz) * sin(rx)",
    "cos(ry) * cos(rx)",
)
# A sun's strength is the irradiance (W/m^2).  Radiant intensity (W/sr) of a
# point lamp of power P, measured against a Diffuse BSDF in Cycles
# (tests/test_api.py): P / (4 pi) with "normalize" on (the default); with it
# off, P r^2 for a radius r > 0 and P / pi for r = 0.
SUN_STRENGTH = "e * pow(2, x)"
POINT_STRENGTH = "e * pow(2, x) * (1 / (4 * pi) if n else (r * r if r > 0 else 1 / pi))"
LIGHT_COLOR = "c * (t if u else 1)"


def unbind_light(node) -> None:
    """Remove the drivers :func:`bind_light` put on the Light inputs."""
    _rm_node_info(node)
    for name in LIGHT_SOCKETS:
        socket = groups.input_socket(node, name)
        size = len(socket.default_value) if hasattr(socket.default_value, "__len__") else 0
        if size:
            for i in range(size):
                socket.driver_remove("default_value", i)
        else:
            socket.driver_remove("default_value")


def bind_light(node, light_object) -> None:
    """Drive the Light inputs of RM group ``node`` from ``light_object``
    (a SUN or POINT lamp) so that exact mode follows the lamp.

    Drivers with simple expressions only (no Python auto-run needed):

    - SUN: Light Direction = the lamp's world +Z axis, from its world-space
      rotation; Point Light = 0; Light Strength = the sun's strength (the
      irradiance, W/m^2).
    - POINT: Light Position = its world-space location; Point Light = 1;
      Light Strength = power / (4 pi), the intensity (W/sr) of Cycles' point
      lamp (with "normalize" off: power * radius^2, or power / pi at
      radius 0).
    - Light Color = the lamp colour (times its blackbody colour when "use
      temperature" is on); strength times 2^exposure.

    Other lamp types raise ``ValueError``.  The lamp's soft size and angle
    are not modelled: exact mode treats it as a point or a direction.
    """
    _rm_node_info(node)
    if getattr(light_object, "type", None) != 'LIGHT':
        raise ValueError(f"{getattr(light_object, 'name', light_object)!r} is not a light object")
    light = light_object.data
    if light.type not in SUPPORTED_LIGHTS:
        raise ValueError(f"{light_object.name!r} is a {light.type} light; allowed: "
                         + ", ".join(SUPPORTED_LIGHTS))
    unbind_light(node)
    sun = light.type == 'SUN'
    groups.input_socket(node, "point_light").default_value = 0.0 if sun else 1.0
    if sun:
        socket = groups.input_socket(node, "light_direction")
        rot = {v: _transform(light_object, f"ROT_{v[1].upper()}") for v in ("rx", "ry", "rz")}
        for i, expr in enumerate(SUN_DIRECTION):
            _drive(socket, i, expr, rot)
    else:
        socket = groups.input_socket(node, "light_position")
        for i, axis in enumerate("xyz"):
            _drive(socket, i, axis, {axis: _transform(light_object, f"LOC_{axis.upper()}")})
    strength = {"e": _prop(light, "energy"), "x": _prop(light, "exposure")}
    if not sun:
        strength.update(n=_prop(light, "normalize"), r=_prop(light, "shadow_soft_size"))
    _drive(groups.input_socket(node, "light_strength"), -1,
           SUN_STRENGTH if sun else POINT_STRENGTH, strength)
    color = groups.input_socket(node, "light_color")
    for i in range(3):
        _drive(color, i, LIGHT_COLOR,
               {"c": _prop(light, f"color[{i}]"), "t": _prop(light, f"temperature_color[{i}]"),
                "u": _prop(light, "use_temperature")})


def bound_light(node):
    """The lamp object :func:`bind_light` bound ``node`` to, or None."""
    for fcurve in light_drivers(node):
        for var in fcurve.driver.variables:
            if var.type == 'TRANSFORMS' and var.targets[0].id is not None:
                return var.targets[0].id
    return None


def light_drivers(node) -> list:
    """The driver F-curves on the Light inputs of ``node``."""
    anim = node.id_data.animation_data
    if anim is None:
        return []
    paths = set()
    for name in LIGHT_SOCKETS:
        paths.add(groups.input_socket(node, name).path_from_id("default_value"))
    return [fc for fc in anim.drivers if fc.data_path in paths]

