# SPDX-License-Identifier: GPL-3.0-or-later
"""How far Kajiya-Kay's BSDF output is from the model, cell by cell of its
exponent and its colours' ratio (``python -m tools.fit --kajiya-kay``, a
step of ``make fit``).

Kajiya-Kay's path-traced output is no fit (``Kajiya-Kay.closure`` in
``addon/core/formulas/models.py``): a diffuse closure of weight kd pi
(kd cos theta_i where the model has kd sin theta_L) and Cycles' hair
reflection closure of weight ks around the same fibre, its roughness
sqrt(2 / (s + 2)) (:func:`hair_reflection`, read from Cycles'
``kernel/closure/bsdf_hair.h``, not copied; checked against renders in
``tests/test_fitting.py``).  Here what that leaves is measured, as
``fitting/bounds.py`` measures the mixtures: the largest |output - model|
over the model's peak with views and lights up to 70 deg, the fibre's
tangent in the surface (the UV tangent, or it turned by Tangent Rotation).

Per colour channel the difference is kd (cos theta_i - sin theta_L) + ks
(hair - lobe) and the model's peak kd + ks (sin theta_L = 1 on the mirror
cone), so over the peak it depends on the exponent and on rho = kd / (kd +
ks) alone, and for one set of directions it is the largest of |rho d + (1 -
rho) e|, convex in rho: over an interval of rho its largest is at an end.
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


def roughness(s):
    """The hair closure's roughness (both) for exponent s, as the shaders."""
    return min(max(math.sqrt(2.0 / (s + 2.0)), 0.001), 1.0)


def hair_reflection(wi, wo, r):
    """Cycles' hair reflection closure (offset 0, both roughnesses ``r``)
    for the light ``wi`` and the view ``wo`` about the fibre x: a Cauchy
    lobe in the half angle of the two latitudes times cos(phi / (2 r)) in
    the azimuth between them about the fibre, 0 where that azimuth passes
    90 deg or the light runs along the fibre."""
    vz, lz = np.clip(wo[..., 0], -1.0, 1.0), np.clip(wi[..., 0], -1.0, 1.0)

    def across(w):
        y = w.copy()
        y[..., 0] = 0.0
        return y / np.maximum(np.linalg.norm(y, axis=-1, keepdims=True), 1e-30)
    th_r, th_i = np.arcsin(vz), np.arcsin(lz)
    c = np.sum(across(wo) * across(wi), -1)
    phi = np.minimum(np.arccos(np.clip(c, -1.0, 1.0)) / r, math.pi)
    a = np.arctan((math.pi / 2 + th_r) * 0.5 / r)
    b = np.arctan((-math.pi / 2 + th_r) * 0.5 / r)
    t = (th_i + th_r) * 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.cos(phi * 0.5) * 0.25 / r * r / (2.0 * (t * t + r * r) * (a - b) * np.cos(th_i))
    return np.where((math.pi / 2 - np.abs(th_i) < 0.001) | (c < 0.0), 0.0, v)


def terms(wi, wo, s):
    """(d, e): the diffuse and specular terms' differences, output - model,
    for kd = 1 and ks = 1 (the model's lobe max(0, sinL sinE - cosL cosE)^s
    as the reference writes it)."""
    cl, ce = wi[..., 0], wo[..., 0]
    sl = np.hypot(wi[..., 1], wi[..., 2])
    se = np.hypot(wo[..., 1], wo[..., 2])
    c = np.maximum(sl * se - cl * ce, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        lobe = np.where(c > 0.0, c ** s, 0.0) if s > 0 else np.ones_like(c)
    d = np.maximum(wi[..., 2], 0.0) - sl
    e = hair_reflection(wi, wo, roughness(s)) - lobe
    return d, e


def measure(s: float) -> tuple:
    """The largest |rho d + (1 - rho) e| (over the peak, which is 1) at
    exponent ``s``, for each of RATIOS."""
    grid = _grid_lights()
    width = math.sqrt(2.0 / (s + 2.0))
    edge = math.cos(math.radians(DOMAIN_DEG))
    rho = np.array(RATIOS)[:, None]
    worst = np.zeros(len(RATIOS))
    psi = np.radians(np.linspace(0.0, 360.0, 181))
    for wo in views():
        lat = -math.asin(max(-1.0, min(1.0, wo[0])))  # the mirror cone's latitude
        lats = np.clip(lat + np.linspace(-CONE_SPAN, CONE_SPAN, CONE_SAMPLES) * width,
                       -math.pi / 2, math.pi / 2)
        L, P = np.meshgrid(lats, psi, indexing="ij")
        cone = np.stack([np.sin(L), np.cos(L) * np.cos(P), np.cos(L) * np.sin(P)],
                        -1).reshape(-1, 3)
        wi = np.concatenate([grid, cone[cone[:, 2] >= edge - 1e-12]])
        d, e = terms(wi, wo[None], s)
        worst = np.maximum(worst, np.max(np.abs(rho * d + (1.0 - rho) * e), axis=1))
    return tuple(float(w) for w in worst)


def points():
    """The exponents measured: NODES and the midpoints between them (in
    log(1 + s))."""
    return [math.expm1(0.5 * (NODES[i // 2] + NODES[(i + 1) // 2]))
            for i in range(2 * (len(NODES) - 1) + 1)]


def cells(measured: list) -> list:
    """``figure[j][k]``: exponents between NODES j, j + 1 and ratios between
    RATIOS k, k + 1: the largest of the two ratios at the interval's three
    points (``measured``: :func:`measure` at :func:`points`), rounded up to
    1e-5."""
    return [[math.ceil(1e5 * max(measured[2 * j + p][k + q] for p in range(3)
                                 for q in range(2))) / 1e5
             for k in range(len(RATIOS) - 1)] for j in range(len(NODES) - 1)]


def fitter_hash() -> str:
    """This module and Ward's, whose sampling it takes."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for rel in ("fitting/kajiya_kay.py", "fitting/ward.py"):
        h.update((root / rel).read_bytes())
    return h.hexdigest()[:16]


def module_text(measured: list) -> str:
    figures = cells(measured)
    lines = [
        "# SPDX-License-Identifier: GPL-3.0-or-later\n",
        "# GENERATED by fitting/kajiya_kay.py (python -m tools.fit --kajiya-kay): do not edit.\n",
        '"""Per cell of Kajiya-Kay\'s exponent (log(1 + s)) and colour ratio kd / (kd +\n',
        "ks), the largest |BSDF output - model| over the model's peak (views and\n",
        'lights up to 70 deg) that fitting/kajiya_kay.py measured."""\n',
        "\n",
        f"FITTER = {fitter_hash()!r}\n",
        f"NODES = {tuple(NODES)!r}  # log(1 + s)\n",
        f"RATIOS = {tuple(RATIOS)!r}\n",
        "FIGURES = (  # FIGURES[j][k]: NODES j, j + 1; RATIOS k, k + 1\n",
    ]
    lines += [f"    {tuple(row)!r},\n" for row in figures]
    lines.append(")\n")
    return "".join(lines)
