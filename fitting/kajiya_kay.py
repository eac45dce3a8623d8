# SPDX-License-Identifier: GPL-3.0-or-later
"""How far Kajiya-Kay's BSDF output is from the model, cell by cell of its
exponent and its colours' ratio (``python -m tools.fit --kajiya-kay``, a
step of ``make fit``).

Kajiya-Kay's path-traced output is no fit (``KajiyaKay.closure`` in
``addon/core/formulas/models.py``, whose constants this module takes): a
diffuse closure of weight kd pi DIFFUSE_SCALE (kd DIFFUSE_SCALE cos
theta_i where the model has kd sin theta_L), Cycles' hair reflection
closure around the same fibre, its latitudinal roughness
HAIR_LATITUDE_SCALE sqrt(2 / (s + 2)), its azimuthal one 1, its weight
ks times a weight of the view that sets its peak on the mirror cone to
HAIR_PEAK_SCALE (:func:`hair_reflection`, read from Cycles'
``kernel/closure/bsdf_hair.h``, not copied; :func:`peak_weight`), and
Cycles' anisotropic GGX closure about the fibre, its roughness
GGX_WIDTH_SCALE sqrt(2 / (s + 2)) along it and 1 across it, weighted ks
GGX_PEAK_SCALE 4 pi ax co (1 + Lambda(wo)) (:func:`ggx_width`,
:func:`ggx_weight`; all checked against renders in
``tests/test_fitting.py``).  Here what that leaves is measured, as
``fitting/bounds.py`` measures the mixtures: the largest |output - model|
over the model's peak with views and lights up to 70 deg, the fibre's
tangent in the surface (the UV tangent, or it turned by Tangent
Rotation).  The hair closure is 0 where the light and the view lie on
opposite sides across the fibre (their azimuths about it more than 90 deg
apart), where the model's cone is not; there the GGX lobe alone lights
the cone, to about 0.52 GGX_PEAK_SCALE of the peak.

Per colour channel the difference is kd (DIFFUSE_SCALE cos theta_i - sin
theta_L) + ks (weighted hair + weighted GGX - lobe) and the model's peak
kd + ks (sin theta_L = 1 on the mirror cone), so over the peak it depends
on the exponent and on rho = kd / (kd + ks) alone, and for one set of
directions it is the largest of |rho d + (1 - rho) e|, convex in rho:
over an interval of rho its largest is at an end.
So a cell's figure is the larger of its two ratios' at the exponent
interval's two nodes and its midpoint (in log(1 + s)).

Directions, in the frame of the normal (z) and the fibre (x): views every
VIEW_STEP_DEG in elevation (0 to 70) and VIEW_AZIMUTH_STEP_DEG in azimuth
(0 to 180: both terms are even in y); lights on a grid of the domain (every
degree of elevation, every two of azimuth) and, for the lobe's own scale,
around the view's mirror cone (T.L = -T.E): latitudes within four lobe
widths of it, 181 azimuths about the fibre.

Deterministic.  Its output, ``addon/core/fits/kajiya_kay.py``, names what
it was computed from (:func:`fitter_hash`).
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np

from addon.core.formulas.models import KajiyaKay

from . import closures as C
from . import ward as W

X_MAX = math.log1p(10000.0)  # log(1 + s) over the socket's range [0, 10000]
NODES = tuple(X_MAX * j / 16 for j in range(17))
RATIOS = tuple(j / 10 for j in range(11))  # rho = kd / (kd + ks)
# the views' and the grid lights' sampling, and the domain, are Ward's
DOMAIN_DEG, VIEW_STEP_DEG, VIEW_AZIMUTH_STEP_DEG = W.DOMAIN_DEG, W.VIEW_STEP_DEG, \
    W.VIEW_AZIMUTH_STEP_DEG
CONE_SPAN = 4.0  # lobe widths either side of the mirror cone
CONE_SAMPLES = 41
_dirs, _grid_lights = W._dirs, W._grid_lights


def views():
    """Ward's views with their azimuths to 180 deg (Ward's lobe is even in
    both axes, these terms in y only)."""
    t = np.radians(np.arange(0.0, DOMAIN_DEG + 1e-9, VIEW_STEP_DEG))
    p = np.radians(np.arange(0.0, 180.0 + 1e-9, VIEW_AZIMUTH_STEP_DEG))
    T, P = np.meshgrid(t, p, indexing="ij")
    return _dirs(T, P).reshape(-1, 3)


HAIR_LATITUDE_SCALE = KajiyaKay.HAIR_LATITUDE_SCALE
HAIR_PEAK_SCALE = KajiyaKay.HAIR_PEAK_SCALE
GGX_WIDTH_SCALE = KajiyaKay.GGX_WIDTH_SCALE
GGX_PEAK_SCALE = KajiyaKay.GGX_PEAK_SCALE
DIFFUSE_SCALE = KajiyaKay.DIFFUSE_SCALE


def lobe_width(s):
    """The model's lobe's width in latitude, sqrt(2 / (s + 2)) rad (cos^s
    falls to about 1/e that far from the cone); the cone's lights are
    sampled on its scale."""
    return math.sqrt(2.0 / (s + 2.0))


def roughness(s):
    """The hair closure's latitudinal roughness for exponent s, as the
    shaders (the azimuthal one is 1)."""
    return min(max(HAIR_LATITUDE_SCALE * lobe_width(s), 0.001), 1.0)


def peak_weight(wo, r1):
    """The hair closure's weight of the view (times ks), as the shaders:
    HAIR_PEAK_SCALE 8 r1 (a - b) cos theta_r, which makes the closure's peak
    (azimuthal roughness 1) HAIR_PEAK_SCALE on the view's mirror cone."""
    th_r = np.arcsin(np.clip(wo[..., 0], -1.0, 1.0))
    spread = np.arctan((math.pi / 2 + th_r) * 0.5 / r1) - \
        np.arctan((th_r - math.pi / 2) * 0.5 / r1)
    return HAIR_PEAK_SCALE * 8.0 * r1 * spread * np.cos(th_r)


def ggx_width(s):
    """The GGX lobe's roughness along the fibre for exponent s, as the
    shaders (1 across it)."""
    return min(max(GGX_WIDTH_SCALE * lobe_width(s), 0.001), 1.0)


def ggx_weight(wo, ax):
    """The GGX lobe's weight of the view (times ks): GGX_PEAK_SCALE 4 pi ax
    co (1 + Lambda(wo)), which makes its D G2 / (4 co) on the mirror cone
    GGX_PEAK_SCALE where Lambda(wi) is 0 (D = 1 / (pi ax) there)."""
    co = np.maximum(wo[..., 2], 0.0)
    return GGX_PEAK_SCALE * 4.0 * math.pi * ax * co * (1.0 + C.lambda_ggx(wo, ax, 1.0))


def hair_reflection(wi, wo, r1, r2=1.0):
    """Cycles' hair reflection closure (offset 0; roughnesses ``r1`` in
    latitude, ``r2`` in azimuth) for the light ``wi`` and the view ``wo``
    about the fibre x: a Cauchy lobe in the half angle of the two latitudes
    times cos(phi / (2 r2)) in the azimuth between them about the fibre, 0
    where that azimuth passes 90 deg or the light runs along the fibre."""
    vz, lz = np.clip(wo[..., 0], -1.0, 1.0), np.clip(wi[..., 0], -1.0, 1.0)

    def across(w):
        y = w.copy()
        y[..., 0] = 0.0
        return y / np.maximum(np.linalg.norm(y, axis=-1, keepdims=True), 1e-30)
    th_r, th_i = np.arcsin(vz), np.arcsin(lz)
    c = np.sum(across(wo) * across(wi), -1)
    phi = np.minimum(np.arccos(np.clip(c, -1.0, 1.0)) / r2, math.pi)
    a = np.arctan((math.pi / 2 + th_r) * 0.5 / r1)
    b = np.arctan((-math.pi / 2 + th_r) * 0.5 / r1)
    t = (th_i + th_r) * 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.cos(phi * 0.5) * 0.25 / r2 * r1 / (2.0 * (t * t + r1 * r1) * (a - b)
                                                   * np.cos(th_i))
    return np.where((math.pi / 2 - np.abs(th_i) < 0.001) | (c < 0.0), 0.0, v)


def terms(wi, wo, s):
    """(d, e): the diffuse and specular terms' differences, output - model,
    for kd = 1 and ks = 1 (the model's lobe max(0, sinL sinE - cosL cosE)^s
    as the reference writes it)."""
    sl = np.hypot(wi[..., 1], wi[..., 2])
    d = DIFFUSE_SCALE * np.maximum(wi[..., 2], 0.0) - sl
    r1, ax = roughness(s), ggx_width(s)
    e = peak_weight(wo, r1) * hair_reflection(wi, wo, r1) + \
        ggx_weight(wo, ax) * C.microfacet(wi, wo, ax, 1.0, "ggx") - lobe(wi, wo, s)
    return d, e


def lobe(wi, wo, s):
    """The model's specular lobe for ks = 1, max(0, sinL sinE - cosL cosE)^s
    as the reference writes it (at s = 0 too: 1 within 90 deg of the cone,
    0 beyond, the reference's 0^0 = 0 below the cut-off)."""
    cl, ce = wi[..., 0], wo[..., 0]
    sl = np.hypot(wi[..., 1], wi[..., 2])
    se = np.hypot(wo[..., 1], wo[..., 2])
    c = np.maximum(sl * se - cl * ce, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(c > 0.0, c ** s, 0.0)


def same_side(wi, wo):
    """Whether the light and the view lie on one side across the fibre x
    (their directions across it less than 90 deg apart): where the hair
    closure is not 0.  A light on the boundary itself (90 deg apart, where
    rounding decides whether the closure is 0) is on neither side: the
    closure's limit from this side is cos(45 deg) of its peak, not 0."""
    return wi[..., 1] * wo[..., 1] + wi[..., 2] * wo[..., 2] > 1e-9


def lights(wo, s):
    """The lights measured for the view ``wo`` at exponent ``s``: the grid of
    the domain and, on the lobe's own scale, those about the view's mirror
    cone (within CONE_SPAN lobe widths of its latitude, 181 azimuths about
    the fibre) inside the domain."""
    width = lobe_width(s)
    edge = math.cos(math.radians(DOMAIN_DEG))
    psi = np.radians(np.linspace(0.0, 360.0, 181))
    lat = -math.asin(max(-1.0, min(1.0, wo[0])))  # the mirror cone's latitude
    lats = np.clip(lat + np.linspace(-CONE_SPAN, CONE_SPAN, CONE_SAMPLES) * width,
                   -math.pi / 2, math.pi / 2)
    L, P = np.meshgrid(lats, psi, indexing="ij")
    cone = np.stack([np.sin(L), np.cos(L) * np.cos(P), np.cos(L) * np.sin(P)],
                    -1).reshape(-1, 3)
    return np.concatenate([_grid_lights(), cone[cone[:, 2] >= edge - 1e-12]])


def measure(s: float) -> tuple:
    """``(everywhere, same side)``: the largest |rho d + (1 - rho) e| (over
    the peak, which is 1) at exponent ``s`` for each of RATIOS, over every
    light and over the lights on the view's side across the fibre
    (:func:`same_side`)."""
    rho = np.array(RATIOS)[:, None]
    worst, near = np.zeros(len(RATIOS)), np.zeros(len(RATIOS))
    for wo in views():
        wi = lights(wo, s)
        d, e = terms(wi, wo[None], s)
        err = np.abs(rho * d + (1.0 - rho) * e)
        worst = np.maximum(worst, np.max(err, axis=1))
        near = np.maximum(near, np.max(np.where(same_side(wi, wo[None]), err, 0.0), axis=1))
    return tuple(float(w) for w in worst), tuple(float(w) for w in near)


def points():
    """The exponents measured: NODES and the midpoints between them (in
    log(1 + s))."""
    return [math.expm1(0.5 * (NODES[i // 2] + NODES[(i + 1) // 2]))
            for i in range(2 * (len(NODES) - 1) + 1)]


def cells(measured: list, part: int = 0) -> list:
    """``figure[j][k]``: exponents between NODES j, j + 1 and ratios between
    RATIOS k, k + 1: the largest of the two ratios at the interval's three
    points (``measured``: :func:`measure` at :func:`points`; ``part`` 0
    everywhere, 1 on the view's side), rounded up to 1e-5."""
    return [[math.ceil(1e5 * max(measured[2 * j + p][part][k + q] for p in range(3)
                                 for q in range(2))) / 1e5
             for k in range(len(RATIOS) - 1)] for j in range(len(NODES) - 1)]


def fitter_hash() -> str:
    """This module, Ward's, whose sampling it takes, the closures'
    transcription and the shaders' constants of the three closures."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for rel in ("fitting/kajiya_kay.py", "fitting/ward.py", "fitting/closures.py"):
        h.update((root / rel).read_bytes())
    h.update(repr((HAIR_LATITUDE_SCALE, HAIR_PEAK_SCALE, GGX_WIDTH_SCALE, GGX_PEAK_SCALE,
                   DIFFUSE_SCALE)).encode())
    return h.hexdigest()[:16]


def module_text(measured: list) -> str:
    lines = [
        "# SPDX-License-Identifier: GPL-3.0-or-later\n",
        "# GENERATED by fitting/kajiya_kay.py (python -m tools.fit --kajiya-kay): do not edit.\n",
        '"""Per cell of Kajiya-Kay\'s exponent (log(1 + s)) and colour ratio kd / (kd +\n',
        "ks), the largest |BSDF output - model| over the model's peak (views and\n",
        'lights up to 70 deg) that fitting/kajiya_kay.py measured; SAME_SIDE: over\n',
        "the lights on the view's side across the fibre only (the hair closure is 0\n",
        'on the other)."""\n',
        "\n",
        f"FITTER = {fitter_hash()!r}\n",
        f"NODES = {tuple(NODES)!r}  # log(1 + s)\n",
        f"RATIOS = {tuple(RATIOS)!r}\n",
        "FIGURES = (  # FIGURES[j][k]: NODES j, j + 1; RATIOS k, k + 1\n",
    ]
    lines += [f"    {tuple(row)!r},\n" for row in cells(measured, 0)]
    lines.append(")\n")
    lines.append("SAME_SIDE = (\n")
    lines += [f"    {tuple(row)!r},\n" for row in cells(measured, 1)]
    lines.append(")\n")
    return "".join(lines)
