# SPDX-License-Identifier: GPL-3.0-or-later
"""Node-group variants, without Blender.

One node group per model and per combination of its structural parameters
(the catalogue's enums, the microfacet width mode): its name, the
parameters that are sockets, which inputs it shows, the labels of its
outputs.  The Blender layer (:mod:`addon.groups`) builds groups from this.
"""

from __future__ import annotations

from . import catalogue
from .validation import validate

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
# validation's name for the width it was given -> our width mode
WIDTH_FROM_REFERENCE = {"beta": "beta", "alpha": "alpha", "alpha_x": "alpha_xy"}

BACKENDS = ("auto", "osl", "native")
BACKEND_PARAM = catalogue.Param(
    "backend", "Backend", "enum", "auto",
    "Which shaders render: 'auto' the OSL shader where Open Shading Language runs (Cycles "
    "on the CPU with OSL on) and native nodes everywhere else (GPU devices, EEVEE, OSL "
    "off); 'osl' only the OSL shader; 'native' only native nodes",
    choices=BACKENDS)
LIGHT_COUNTS = tuple(str(k) for k in range(1, catalogue.MAX_LIGHTS + 1))
LIGHTS_PARAM = catalogue.Param(
    "lights", "Lights", "enum", "1",
    f"How many lamps exact mode follows (1 to {catalogue.MAX_LIGHTS}); each has its Light "
    "inputs, set by Bind Light", choices=LIGHT_COUNTS)
# Parameters of a group that are not the catalogue's (validated here).
GROUP_PARAMS = (WIDTH_PARAM, LIGHTS_PARAM, BACKEND_PARAM)

CHOICE_LABELS = {  # in menus
    "none": "None", "energy": "Energy",
    "blinn": "Blinn", "gaussian": "Gaussian", "trowbridge_reitz": "Trowbridge-Reitz (GGX)",
    "beckmann": "Beckmann",
    "smith": "Smith", "smith_correlated": "Smith Height-Correlated", "vgroove": "V-Groove",
    "smith_1967": "Smith 1967",
    "dielectric": "Dielectric", "conductor": "Conductor",
    "beta": "Half-Angle", "alpha": "Roughness (alpha)",
    "alpha_xy": "Anisotropic Roughness (alpha x, y)",
    "auto": "Automatic", "osl": "OSL", "native": "Native Nodes",
    **{k: f"{k} Lights" for k in LIGHT_COUNTS[1:]},
}
NAME_LABELS = {  # in group names: Blender 4.5 cuts ID names at 63 characters
    "native": "Native",
    "trowbridge_reitz": "GGX", "smith_correlated": "Smith Corr.",
    "alpha": "Alpha", "alpha_xy": "Alpha XY",
}
MAX_NAME = 63
# only where a name is too long
SHORT_LABELS = {"dielectric": "Diel.", "conductor": "Cond.", "smith_correlated": "Smith C.",
                "smith_1967": "S. 1967", "alpha_xy": "A. XY", "trowbridge_reitz": "GGX",
                "native": "Nat.", **{k: f"{k} L." for k in LIGHT_COUNTS[1:]}}

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


# ---------------------------------------------------------------------------
# Variants (pure: no Blender data is read or written)

def variant_params(model_id: str) -> tuple:
    """The structural parameters of a model (or a preset's base model): its
    enum params, :data:`WIDTH_PARAM` for models with a width rule, and
    :data:`LIGHTS_PARAM` and :data:`BACKEND_PARAM`."""
    model, _fixed, _defaults = catalogue.resolve(model_id)
    params = tuple(p for p in model.params if p.is_enum)
    if "width" in model.rules:
        params += (WIDTH_PARAM,)
    return params + (LIGHTS_PARAM, BACKEND_PARAM)


def resolve_variant(model_id: str, enums: dict | None = None) -> tuple:
    """``(model, variant)`` for a model or preset name and enum values.

    ``variant`` holds every structural parameter of the model (defaults and a
    preset's fixed values filled in), in :func:`variant_params` order.
    Validation is :func:`..validation.validate`'s: unknown names, values and
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
    check = {k: v for k, v in enums.items()
             if k not in (WIDTH_PARAM.name, BACKEND_PARAM.name, LIGHTS_PARAM.name)}
    lights = str(enums.get(LIGHTS_PARAM.name, LIGHTS_PARAM.default))
    if lights not in LIGHT_COUNTS:
        raise ValueError(f"lights={enums.get(LIGHTS_PARAM.name)!r} is not allowed; lights must be "
                         f"{LIGHTS_PARAM.allowed()}")
    backend = enums.get(BACKEND_PARAM.name, BACKEND_PARAM.default)
    if backend not in BACKENDS:
        raise ValueError(f"backend={backend!r} is not allowed; backend must be "
                         f"{BACKEND_PARAM.allowed()}")
    width = None
    if "width" in model.rules:
        width = enums.get(WIDTH_PARAM.name, WIDTH_PARAM.default)
        if width not in WIDTH_MODES:
            raise ValueError(f"width_mode={width!r} is not allowed; width_mode must be "
                             f"{WIDTH_PARAM.allowed()}")
        if width != "beta":  # let the reference check the distribution allows it
            check.update({n: model.param(n).default for n in WIDTH_SOCKETS[width]})
    _model, values, _given = validate(model_id, check)
    variant = {p.name: values[p.name] for p in model.params if p.is_enum}
    if width is not None:
        variant[WIDTH_PARAM.name] = width
    variant[LIGHTS_PARAM.name] = lights
    variant[BACKEND_PARAM.name] = backend
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
    shown = [v for k, v in variant.items()
             if not (k in (WIDTH_PARAM.name, BACKEND_PARAM.name, LIGHTS_PARAM.name)
                     and v in (WIDTH_PARAM.default, BACKEND_PARAM.default, LIGHTS_PARAM.default))]
    for short in ({}, SHORT_LABELS):
        parts = [short.get(v) or NAME_LABELS.get(v) or choice_label(v) for v in shown]
        name = GROUP_PREFIX + model.label + (f" ({', '.join(parts)})" if parts else "")
        if len(name) <= MAX_NAME:
            break
    return name


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
    model, variant = resolve_variant(model_id, enums)
    count = int(variant.get(LIGHTS_PARAM.name, LIGHTS_PARAM.default))
    lights = tuple(p for k in range(1, count + 1) for p in catalogue.light_inputs(k))
    return socket_params(model_id, enums) + lights + geometry


def output_label(name: str) -> str:
    """Socket label of a shader output: ``cos_theta_i`` -> ``Cos Theta I``;
    names without underscores that are not all lower case stay (BSDF, D)."""
    if "_" not in name and not name.islower():
        return name
    return " ".join(w[:1].upper() + w[1:] for w in name.split("_") if w)
