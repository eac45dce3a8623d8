# SPDX-License-Identifier: GPL-3.0-or-later
"""The catalogue: the one list of models, their parameters, units, ranges,
defaults and tooltips.

Everything else is driven from here: the numpy reference validates its
arguments against it (:mod:`.validation`), the node groups take their
sockets from it (:mod:`.variants`), the shaders their limits, the README
table, the model pages and the parametrised tests iterate over it.  Adding a
model means one entry here plus its formulas in :mod:`.reference` (the
judge) and :mod:`.formulas` (what renders).

Pure Python: importing it needs neither numpy nor bpy.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

DEG = math.pi / 180.0


@dataclass(frozen=True)
class Param:
    """One parameter of a model.

    ``kind`` is one of ``float`` (a scalar), ``angle`` (radians in Python,
    shown in degrees in Blender), ``color`` (an RGB triple; a scalar is
    broadcast), ``factor`` (a scalar in [0, 1] shown as a slider) or ``enum``
    (a string from ``choices``; structural: it selects the node-group
    variant rather than being a socket).
    ``minimum``/``maximum`` are hard limits: the reference raises
    ``ValueError`` beyond them, the shaders clamp to them.
    """

    name: str
    label: str
    kind: str
    default: object
    description: str
    minimum: float | None = None
    maximum: float | None = None
    soft_min: float | None = None
    soft_max: float | None = None
    unit: str = ""
    choices: tuple = ()
    panel: str = ""

    @property
    def is_enum(self) -> bool:
        return self.kind == "enum"

    def allowed(self) -> str:
        """Human-readable description of the allowed values."""
        if self.is_enum:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        lo = "-inf" if self.minimum is None else _fmt(self.minimum, self.kind)
        hi = "inf" if self.maximum is None else _fmt(self.maximum, self.kind)
        what = "an RGB colour or scalar" if self.kind == "color" else "a number"
        unit = f" {self.unit}" if self.unit and self.kind != "angle" else ""  # angles say rad/deg
        return f"{what} in [{lo}, {hi}]{unit}"


def _fmt(value: float, kind: str) -> str:
    if kind == "angle":
        return f"{value:.6g} rad ({value / DEG:.6g} deg)"
    return f"{value:.6g}"


@dataclass(frozen=True)
class Model:
    """One reflection model of the lecture."""

    id: str
    label: str
    description: str
    slide: str
    params: tuple
    kind: str = "surface"  # "surface" (uses the normal) or "fibre" (uses the tangent)
    shader: str = ""  # file in osl/
    rules: tuple = ()  # extra validation rules, see validation.validate
    # Its faces: the reference function (addon/core/reference/models.py) that
    # judges it, and the papers it comes from.
    reference: str = ""
    citation: str = ""

    def param(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)

    @property
    def param_names(self) -> tuple:
        return tuple(p.name for p in self.params)


@dataclass(frozen=True)
class Preset:
    """A named model of the literature, built on a generic model with some
    structural parameters fixed."""

    id: str
    label: str
    description: str
    base: str
    fixed: dict = field(default_factory=dict)
    defaults: dict = field(default_factory=dict)


# --- shared parameter definitions --------------------------------------------------

def _ks(default=(1.0, 1.0, 1.0), label="Specular", what="specular reflectance factor"):
    return Param("ks", label, "color", default, f"Colour factor: the {what}",
                 minimum=0.0, maximum=1.0, panel="Surface")


def _exponent(default=20.0, what="the highlight; 0 is the widest, large is a mirror"):
    return Param("exponent", "Exponent", "float", default,
                 f"Exponent s of the cosine lobe: sharpness of {what}",
                 minimum=0.0, maximum=10000.0, soft_min=0.0, soft_max=1000.0,
                 panel="Surface")


def _normalization(energy_text):
    return Param("normalization", "Normalization", "enum", "none",
                 "'none': the lecture's form; 'energy': " + energy_text,
                 choices=("none", "energy"))


BETA_MIN = 1.0 * DEG
BETA_MAX = 85.0 * DEG
ALPHA_MIN = 1e-3
ALPHA_MAX = 4.0

DISTRIBUTIONS = ("blinn", "gaussian", "trowbridge_reitz", "beckmann")
SHADOWINGS = ("none", "smith", "smith_correlated", "vgroove", "smith_1967")
FRESNELS = ("none", "dielectric", "conductor")

MODELS: dict[str, Model] = {}


def _add(model: Model) -> None:
    MODELS[model.id] = model


_add(Model(
    id="lambert",
    label="Lambert",
    description="Ideal diffuse reflection: f = albedo / pi",
    slide="Last lecture: ideal diffuse",
    shader="rm_lambert.osl",
    reference="brdf_lambert",
    citation='Lambert 1760, Photometria; the previous lecture (ideal diffuse)',
    params=(
        Param("albedo", "Albedo", "color", (0.8, 0.8, 0.8),
              "Diffuse reflectance: the fraction of the light reflected",
              minimum=0.0, maximum=1.0, panel="Surface"),
    ),
))

_add(Model(
    id="phong",
    label="Phong",
    description="Phong's cosine lobe around the mirror direction: ks (E.R(L))^s",
    slide="Phong Model; Energy normalization",
    shader="rm_phong.osl",
    reference="brdf_phong",
    citation='Phong 1975, "Illumination for computer generated pictures"; energy bound: the lecture\'s slide; Lafortune & Willems 1994 for (s+2)/(2 pi)',
    params=(
        _exponent(),
        _ks(),
        _normalization("times (s+1)/(2 pi), the lecture's bound: never reflects more "
                       "than it receives"),
    ),
))

_add(Model(
    id="blinn_phong",
    label="Blinn-Phong",
    description="Blinn's half-vector form of Phong: ks (N.H)^s",
    slide="Reflection Geometry (cos theta_s' = H.N)",
    shader="rm_blinn_phong.osl",
    reference="brdf_blinn_phong",
    citation='Blinn 1977, "Models of light reflection for computer synthesized pictures"',
    params=(
        _exponent(),
        _ks(),
        _normalization("times (s+8)/(8 pi), the usual approximate normalisation "
                       "(an approximation, not a bound)"),
    ),
))

_add(Model(
    id="microfacet",
    label="Microfacet",
    description=("Torrance-Sparrow microfacet BRDF ks F G D / (4 cos i cos o) with a "
                 "choice of distribution D, shadowing G and Fresnel F"),
    slide="Torrance-Sparrow Model; Microfacet Distribution Functions; Self-Shadowing",
    shader="rm_microfacet.osl",
    reference="brdf_microfacet",
    citation='Torrance & Sparrow 1967; Beckmann & Spizzichino 1963; Trowbridge & Reitz 1975; Smith 1967; Walter et al. 2007, "Microfacet models for refraction through rough surfaces"; Heitz 2014, "Understanding the masking-shadowing function"',
    params=(
        Param("distribution", "Distribution", "enum", "beckmann",
              "Microfacet distribution D", choices=DISTRIBUTIONS),
        Param("shadowing", "Shadowing", "enum", "smith",
              "Self-shadowing G: 'smith' separable G1 G1 (the lecture's S S), "
              "'smith_correlated' 1/(1+Li+Lo) as in Cycles, 'vgroove' Torrance-Sparrow's "
              "V-grooves, 'smith_1967' the slide's erfc bracket form (Beckmann only; "
              "breaks self-consistency by up to ~50%), 'none'",
              choices=SHADOWINGS),
        Param("fresnel", "Fresnel", "enum", "none",
              "Fresnel factor F: 'dielectric' (real index), 'conductor' (complex "
              "index n + ik per colour channel), 'none' (F = 1)",
              choices=FRESNELS),
        Param("beta", "Half-Angle", "angle", 10.0 * DEG,
              "Highlight half-angle beta: the facet tilt at which D falls to half its "
              "peak; the same meaning for every distribution",
              minimum=BETA_MIN, maximum=BETA_MAX, unit="rad", panel="Roughness"),
        Param("alpha", "Roughness", "float", 0.2,
              "Native roughness instead of beta: GGX alpha (Trowbridge-Reitz) or "
              "Beckmann m (RMS slope times sqrt 2)",
              minimum=ALPHA_MIN, maximum=ALPHA_MAX, soft_max=1.0, panel="Roughness"),
        Param("alpha_x", "Roughness X", "float", 0.2,
              "Anisotropic native roughness along the tangent",
              minimum=ALPHA_MIN, maximum=ALPHA_MAX, soft_max=1.0, panel="Roughness"),
        Param("alpha_y", "Roughness Y", "float", 0.2,
              "Anisotropic native roughness across the tangent",
              minimum=ALPHA_MIN, maximum=ALPHA_MAX, soft_max=1.0, panel="Roughness"),
        Param("ior", "IOR", "color", (1.5, 1.5, 1.5),
              "Index of refraction n (real part; per channel for metals)",
              minimum=0.01, maximum=10.0, soft_min=1.0, soft_max=4.0, panel="Fresnel"),
        Param("k", "Extinction", "color", (0.0, 0.0, 0.0),
              "Extinction coefficient k (imaginary part of the index, per channel); "
              "used by the conductor Fresnel",
              minimum=0.0, maximum=20.0, soft_max=10.0, panel="Fresnel"),
        _ks(),
    ),
    rules=("width", "smith_1967_beckmann"),
))

_add(Model(
    id="kajiya_kay",
    label="Kajiya-Kay Hair",
    description=("Kajiya-Kay fibre model: kd sin(theta_L) + ks cos^s of the angle to "
                 "the mirror cone T.E = -T.L"),
    slide="Kay-Kajiya Model",
    kind="fibre",
    shader="rm_kajiya_kay.osl",
    reference="shade_kajiya_kay",
    citation='Kajiya & Kay 1989, "Rendering fur with three dimensional textures"',
    params=(
        Param("kd", "Diffuse", "color", (0.25, 0.12, 0.05),
              "Diffuse colour: weight of the sin(theta_L) term",
              minimum=0.0, maximum=1.0, panel="Surface"),
        _ks((0.5, 0.5, 0.5)),
        _exponent(40.0, "the highlight around the mirror cone"),
    ),
))

_add(Model(
    id="ward",
    label="Ward Anisotropic",
    description="Ward's anisotropic Gaussian lobe (Ward 1992)",
    slide="Anisotropic Reflection Model",
    shader="rm_ward.osl",
    reference="brdf_ward",
    citation='Ward 1992, "Measuring and modeling anisotropic reflection", eq. 5',
    params=(
        Param("alpha_x", "Roughness X", "float", 0.3,
              "RMS slope along the tangent", minimum=ALPHA_MIN, maximum=1.0,
              panel="Roughness"),
        Param("alpha_y", "Roughness Y", "float", 0.08,
              "RMS slope across the tangent", minimum=ALPHA_MIN, maximum=1.0,
              panel="Roughness"),
        _ks(),
    ),
))


PRESETS: dict[str, Preset] = {
    "torrance_sparrow": Preset(
        "torrance_sparrow", "Torrance-Sparrow 1967",
        "The original Torrance-Sparrow model: Gaussian D, V-groove G, Fresnel F",
        base="microfacet",
        fixed={"distribution": "gaussian", "shadowing": "vgroove"},
        defaults={"fresnel": "dielectric"}),
    "cook_torrance": Preset(
        "cook_torrance", "Cook-Torrance",
        "Cook-Torrance: Beckmann D, V-groove G, Fresnel F",
        base="microfacet",
        fixed={"distribution": "beckmann", "shadowing": "vgroove"},
        defaults={"fresnel": "dielectric"}),
}


def names() -> tuple:
    """Every model and preset name accepted by the reference."""
    return tuple(MODELS) + tuple(PRESETS)


def resolve(name: str) -> tuple:
    """Return ``(model, fixed, defaults)`` for a model or preset name.

    Raises ``ValueError`` naming the allowed names for anything else.
    """
    if name in MODELS:
        return MODELS[name], {}, {}
    if name in PRESETS:
        p = PRESETS[name]
        return MODELS[p.base], dict(p.fixed), dict(p.defaults)
    raise ValueError(f"unknown model {name!r}; allowed: {', '.join(names())}")


# Metals: complex index n + ik at the RGB primaries' dominant wavelengths
# (approx. 650, 550, 450 nm), rounded to 3 digits.  Sources: Rakic 1995 (Al),
# Johnson & Christy 1972 (Au, Ag, Cu), Johnson & Christy 1974 (Cr), read off
# their published tables; a three-wavelength sample, not a spectral fit.
METALS = {
    "aluminium": ((1.47, 0.96, 0.62), (7.79, 6.69, 5.47)),
    "gold": ((0.166, 0.424, 1.38), (3.15, 2.35, 1.91)),
    "silver": ((0.141, 0.124, 0.135), (4.14, 3.34, 2.50)),
    "copper": ((0.214, 1.06, 1.19), (3.67, 2.59, 2.41)),
    "chromium": ((3.11, 3.18, 2.39), (3.31, 3.33, 3.17)),
}


# --- inputs every node group has besides its model's parameters ---------------------
# Exact mode evaluates the model for one light given by these inputs; "Bind
# Light" drives them from a lamp.  Names are the OSL parameter names.

LIGHT_INPUTS = (
    Param("point_light", "Point Light", "factor", 0.0,
          "Exact mode: 0 is a sun (uses Light Direction), 1 a point or spot light (uses Light "
          "Position); set by Bind Light", minimum=0.0, maximum=1.0, panel="Light"),
    Param("light_direction", "Light Direction", "direction", (0.0, 0.0, 1.0),
          "Exact mode: world-space direction toward a sun, or a spot's axis reversed (the "
          "lamp's +Z); normalised in the shader", panel="Light"),
    Param("light_position", "Light Position", "position", (0.0, 0.0, 5.0),
          "Exact mode, point or spot light: world-space position of the light", panel="Light"),
    Param("light_strength", "Light Strength", "float", 1.0,
          "Exact mode: sun irradiance (W/m^2) or point/spot intensity (W/sr)",
          minimum=0.0, maximum=1e6, soft_max=10.0, panel="Light"),
    Param("light_color", "Light Color", "color", (1.0, 1.0, 1.0),
          "Exact mode: colour of the light", minimum=0.0, maximum=1e6, panel="Light"),
    Param("shadows", "Shadows", "factor", 1.0,
          "Exact mode: 1 casts a shadow ray toward the light, 0 ignores occluders (a bound "
          "lamp sets it from its Cast Shadow)",
          minimum=0.0, maximum=1.0, panel="Light"),
    Param("spot", "Spot", "factor", 0.0,
          "Exact mode, point light: 1 makes it a spot (cone of Spot Size around the reversed "
          "Light Direction, edge softened by Spot Blend, as Cycles computes it)",
          minimum=0.0, maximum=1.0, panel="Light"),
    Param("spot_size", "Spot Size", "angle", 45.0 * DEG,
          "Exact mode, spot: the cone's full angle", minimum=1.0 * DEG, maximum=180.0 * DEG,
          unit="rad", panel="Light"),
    Param("spot_blend", "Spot Blend", "factor", 0.15,
          "Exact mode, spot: the softness of the cone's edge", minimum=0.0, maximum=1.0,
          panel="Light"),
)

# Exact mode follows up to MAX_LIGHTS lamps; light k > 1 has the inputs of
# LIGHT_INPUTS named <name>_<k> in the panel "Light <k>".
MAX_LIGHTS = 4


def light_inputs(k: int) -> tuple:
    """The Light inputs of light ``k`` (1-based)."""
    if k == 1:
        return LIGHT_INPUTS
    if not 1 <= k <= MAX_LIGHTS:
        raise ValueError(f"light {k}: exact mode follows 1 to {MAX_LIGHTS} lights")
    return tuple(dataclasses.replace(p, name=f"{p.name}_{k}", label=f"{p.label} {k}",
                                     panel=f"Light {k}") for p in LIGHT_INPUTS)


GEOMETRY_INPUTS = (
    Param("shading_normal", "Normal", "normal", (0.0, 0.0, 0.0),
          "Shading normal; unconnected (zero) uses the surface normal", panel="Geometry"),
    Param("tangent", "Tangent", "normal", (0.0, 0.0, 0.0),
          "Tangent (fibre or brush direction); unconnected (zero) uses the UV tangent, "
          "which is zero on hair curves: there link Geometry > Tangent",
          panel="Geometry"),
    Param("tangent_rotation", "Tangent Rotation", "angle", 0.0,
          "Rotation of the tangent about the normal", minimum=-6.283185307179586,
          maximum=6.283185307179586, panel="Geometry"),
)

# Outputs of every model shader besides its terms: BSDF (path traced), Direct
# (the exact value as an emission closure) and Color (the exact value).
MAIN_OUTPUTS = ("BSDF", "Direct", "Color")
