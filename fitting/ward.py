# SPDX-License-Identifier: GPL-3.0-or-later
"""How far Ward's BSDF output is from Ward's model, cell by cell of its
widths (``python -m tools.fit --ward``, a step of ``make fit``).

Ward's path-traced output is no fit: Cycles' anisotropic Beckmann closure
(Walter's rational Lambda, ``fitting/closures.py``) with Ward's (alpha_x,
alpha_y), weighted by the view alone, cos theta_o (1 + 2 Lambda(theta_o))
(``addon/core/formulas/models.py``, ``Ward.closure``): what remains of
Ward / closure depends on the light (sqrt(cos theta_i / cos theta_o) and
the closure's shadowing), which no weight can carry.  Here that remainder
is measured, as ``fitting/bounds.py`` measures the mixtures: the largest
|output - model| over the model's peak with views and lights up to 70 deg.

The widths: alpha_x and alpha_y on NODES (in log alpha over the sockets'
range [0.001, 1], closer toward 1); a cell's figure is the largest
measured at its corners, its edges' midpoints and its centre (nine
points, midpoints in log alpha).  Ward is symmetric in the swap of alpha_x
and alpha_y with a quarter turn of the view's azimuth, and the views'
azimuths (0 to 90 deg) go both ways, so only alpha_x <= alpha_y is
measured.  At each width: views every VIEW_STEP_DEG in
elevation (0 to 70) and VIEW_AZIMUTH_STEP_DEG in azimuth; lights on a grid
of the domain (every degree of elevation to 70, every two of azimuth) and
the mirror images of half vectors spread over four lobe widths either side
of the normal in each direction (the lobe's own scale: narrow lobes fall
between the grid's lights).  The model's peak is its value at any mirror
direction, 1/(4 pi alpha_x alpha_y) (the reference's formula at L = R(E)).

Deterministic.  Its output, ``addon/core/fits/ward.py``, names what it was
computed from (:func:`fitter_hash`).
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np

from . import closures as CL

LOG_MIN, LOG_MAX = math.log(0.001), math.log(1.0)  # the sockets' range
# log alpha: every quarter decade from 0.001 to 0.32, then every tenth of
# alpha to 1, where the difference grows fastest (0.23 of the peak at alpha
# 0.3, 0.33 at 0.5, 0.71 at 0.8, 1.43 at 1)
NODES = tuple([LOG_MIN + (LOG_MAX - LOG_MIN) * j / 12 for j in range(11)]
              + [math.log(a / 10.0) for a in range(4, 11)])
DOMAIN_DEG = 70.0
VIEW_STEP_DEG = 2.5
VIEW_AZIMUTH_STEP_DEG = 7.5
LOBE_SPAN = 4.0  # half vectors out to this many widths (tan theta_h / alpha)
LOBE_SAMPLES = 61


def _dirs(theta, phi):
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)],
                    -1)


def views():
    t = np.radians(np.arange(0.0, DOMAIN_DEG + 1e-9, VIEW_STEP_DEG))
    p = np.radians(np.arange(0.0, 90.0 + 1e-9, VIEW_AZIMUTH_STEP_DEG))
    T, P = np.meshgrid(t, p, indexing="ij")
    return _dirs(T, P).reshape(-1, 3)


def _grid_lights():
    t = np.radians(np.linspace(0.0, DOMAIN_DEG, 71))
    p = np.radians(np.linspace(0.0, 360.0, 181))
    T, P = np.meshgrid(t, p, indexing="ij")
    return _dirs(T, P).reshape(-1, 3)


def model(wi, wo, ax, ay):
    """Ward's f_r cos theta_i (the reference's brdf_ward for ks = 1)."""
    h = wi + wo
    ci, co = wi[..., 2], wo[..., 2]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e = (h[..., 0] / h[..., 2] / ax) ** 2 + (h[..., 1] / h[..., 2] / ay) ** 2
        f = np.exp(-e) / (4.0 * math.pi * ax * ay * np.sqrt(ci) * np.sqrt(co))
    return np.where((ci > 0) & (co > 0), f * ci, 0.0)


def output(wi, wo, ax, ay):
    """What Ward's BSDF output renders (Ward.closure): the Beckmann closure
    at widths clamped to 1, weighted by cos theta_o (1 + 2 Lambda(theta_o))."""
    ax, ay = min(ax, 1.0), min(ay, 1.0)
    co = np.maximum(wo[..., 2], 0.0)
    weight = co * (1.0 + 2.0 * CL.lambda_beckmann_rational(wo, ax, ay))
    return weight * CL.microfacet(wi, wo, ax, ay, "beckmann")


def measure(ax: float, ay: float) -> float:
    """The largest |output - model| over the model's peak at (ax, ay)."""
    grid = _grid_lights()
    u = np.linspace(-LOBE_SPAN, LOBE_SPAN, LOBE_SAMPLES)
    X, Y = np.meshgrid(u * ax, u * ay, indexing="ij")
    h = np.stack([X, Y, np.ones_like(X)], -1).reshape(-1, 3)
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    edge = math.cos(math.radians(DOMAIN_DEG))
    worst = 0.0
    for wo in views():
        wi = 2.0 * (h @ wo)[:, None] * h - wo
        wi = np.concatenate([grid, wi[wi[:, 2] >= edge - 1e-12]])
        d = np.abs(output(wi, wo[None], ax, ay) - model(wi, wo[None], ax, ay))
        worst = max(worst, float(np.max(d)))
    return worst * 4.0 * math.pi * ax * ay


def points():
    """The widths measured: (i, j) on the half-step grid of NODES (2 i is a
    node), i <= j (alpha_x <= alpha_y)."""
    n = 2 * (len(NODES) - 1) + 1
    return [(i, j) for i in range(n) for j in range(i, n)]


def _width(i):
    """alpha at point i of the half-step grid: NODES i/2, or between two."""
    return math.exp(0.5 * (NODES[i // 2] + NODES[(i + 1) // 2]))


def measure_point(point):
    i, j = point
    return measure(_width(i), _width(j))


def cells(measured: dict) -> list:
    """``figure[a][b]``: the cell between NODES a, a + 1 (alpha_x) and b,
    b + 1 (alpha_y): the largest of its nine points (``measured`` by
    :func:`points`, swapped where alpha_x > alpha_y), rounded up to 1e-5."""
    m = len(NODES) - 1

    def at(i, j):
        return measured[(min(i, j), max(i, j))]
    return [[math.ceil(1e5 * max(at(2 * a + p, 2 * b + q) for p in range(3) for q in range(3)))
             / 1e5 for b in range(m)] for a in range(m)]


def fitter_hash() -> str:
    """This module and the closures it transcribes."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for rel in ("fitting/ward.py", "fitting/closures.py"):
        h.update((root / rel).read_bytes())
    return h.hexdigest()[:16]


def module_text(measured: dict) -> str:
    figures = cells(measured)
    lines = [
        "# SPDX-License-Identifier: GPL-3.0-or-later\n",
        "# GENERATED by fitting/ward.py (python -m tools.fit --ward): do not edit.\n",
        '"""Per cell of Ward\'s widths (alpha_x, alpha_y), the largest |BSDF output -\n',
        "model| over the model's peak (views and lights up to 70 deg) that\n",
        'fitting/ward.py measured.  See fitting/ward.py."""\n',
        "\n",
        f"FITTER = {fitter_hash()!r}\n",
        f"NODES = {tuple(NODES)!r}  # log alpha\n",
        "FIGURES = (  # FIGURES[a][b]: alpha_x between NODES a, a + 1; alpha_y b, b + 1\n",
    ]
    lines += [f"    {tuple(row)!r},\n" for row in figures]
    lines.append(")\n")
    return "".join(lines)
