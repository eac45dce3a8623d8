# SPDX-License-Identifier: GPL-3.0-or-later
"""Phong's path-traced mixture on Cycles' native nodes: Toon glossy lobes.

Phong's lobe is round about the mirror direction R of the view; the native
Glossy node's lobes are round about the normal in half-vector space, so the
native mixture of :mod:`fitting.mixtures` errs 0.45 of the peak.  Cycles'
Toon BSDF (Glossy) is a lobe about R: ``size`` and ``smooth`` (each in
[0, 1], times pi/2) make it flat out to the angle a = size pi/2 and fall
linearly to 0 at a + b, b = smooth pi/2; what it renders is

    I(psi) / (2 pi (1 - cos min(a + b, pi/2)))

with psi the angle between the light and R (:func:`glossy_toon`).  It has
no factor cos(theta_i), which Phong's rendered lobe (R.L)^s cos(theta_i)
has; so a mixture of Toon lobes, functions of psi alone, cannot follow
Phong's lobe where cos(theta_i) varies across it (wide lobes, oblique
views), and a diffuse member (cos(theta_i)/pi) takes part of that.

The fit: at evenly spaced nodes of log(1 + s), narrow to wide, three Toon
lobes' sizes and smooths (shared by every view: the lobe's shape in psi
does not depend on the view) are chosen by Nelder-Mead, each node starting
from its narrower neighbour's (the narrowest from the better of two
starts, one of them the lobes that carry most of :func:`floor`'s
mixtures; a node that its neighbour's start leaves more than
SECOND_START_GAP above the floor with the albedo held, from the better of
that and the lobes that carry most of that floor's), to the least
objective of the linear programme below (not its largest error alone,
which gave the albedo away at the wide end: 0.26 at s = 0); for given
lobes, the members' weights, each
a Chebyshev series of degree N_VIEW - 1 in the view variable of
:mod:`fitting.mixtures`, are one linear programme over every view at once
(every 5 deg up to 70: the largest |mixture - model| over the peak, lights
up to 70 deg; up to 85 deg with a smaller weight; directional albedo within
ALBEDO_TOLERANCE, beyond it penalised; weights >= 0 over the whole view
range), at the node and half way back to the node fitted before (the
interpolated mixture there, so the interval is fitted, not only its end).
Between the nodes the lobes' log size and log smooth and the series'
coefficients are linear in log(1 + s), as the shaders have them.  Where
the Glossy mixture of :mod:`fitting.mixtures` measures better by the same
objective (the first run of such widths from the wide end:
:func:`glossy_band`), Cycles renders it instead, and what the data records
is what Cycles renders.

EEVEE renders the Toon BSDF as a diffuse one, so the node group renders
this mixture in Cycles only; EEVEE keeps the Glossy mixture of
:mod:`fitting.mixtures` (the switch: :mod:`addon.core.formulas.models`).

Deterministic: fixed starts, a seeded generator for the measured widths.
Run by ``python -m tools.fit --toon`` (``make fit``).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import linprog, minimize

from . import closures as C
from . import mixtures as M

HALF_PI = 0.5 * math.pi
KEY = "phong"
N_NODES = 16
N_TOON = 3
MEMBERS = ("glossy_toon",) * N_TOON + ("diffuse",)
FIT_VIEWS_DEG = tuple(range(0, 71, 5))
GRAZING_VIEWS_DEG = (75, 80, 85)
ALBEDO_TOLERANCE = M.ALBEDO_TOLERANCE
GRAZING_WEIGHT = 0.1   # the error up to 85 deg, beside the one up to 70 deg
ALBEDO_PENALTY = 2.0   # per unit of albedo beyond ALBEDO_TOLERANCE
SIZE_MIN = 1e-5        # Cycles clamps size to [1e-5, 1]
SMOOTH_MIN = 1e-4      # the fit keeps smooth > 0 (a log in the data)
# a node whose neighbour's start ends this far above floor(s, albedo=True)
# takes the better of it and a start from that floor's lobes
SECOND_START_GAP = 0.02


def glossy_toon(wi, wo, size, smooth):
    """Cycles' Toon BSDF, Glossy, white: I(psi) / (2 pi (1 - cos psi_s)),
    psi the angle between the light and the view's mirror direction, I 1 up
    to a = size pi/2 and linear to 0 at a + b (b = smooth pi/2), psi_s =
    min(a + b, pi/2); 0 unless both directions are above the surface."""
    ci, co = C._cos(wi), C._cos(wo)
    a = min(max(float(size), SIZE_MIN), 1.0) * HALF_PI
    b = min(max(float(smooth), 0.0), 1.0) * HALF_PI
    r = np.stack([-wo[..., 0], -wo[..., 1], wo[..., 2]], -1)
    psi = np.arccos(np.clip(np.sum(r * wi, -1), 0.0, 1.0))
    edge = min(a + b, HALF_PI)
    with np.errstate(divide="ignore", invalid="ignore"):
        ramp = np.where(psi < a, 1.0, np.where(b > 0.0, 1.0 - (psi - a) / b, 0.0))
    value = np.where(psi < edge, ramp, 0.0) / (2.0 * math.pi * (1.0 - math.cos(edge)))
    return np.where((ci > 0) & (co > 0), value, 0.0)


def target() -> M.Target:
    return next(t for t in M.targets() if t.key == KEY)


def view_variable(cos_o: float) -> float:
    return 2.0 * (cos_o - M.COS_VIEW_MIN) / (1.0 - M.COS_VIEW_MIN) - 1.0


@dataclass
class Rows:
    """One width's samples at every measured view (0, 5, ... 85 deg)."""
    value: float
    views: list          # (deg, u, Samples)
    peak70: float
    peak85: float


def rows(value: float) -> Rows:
    t = target()
    views = []
    for deg in FIT_VIEWS_DEG + GRAZING_VIEWS_DEG:
        c = math.cos(math.radians(deg))
        views.append((deg, view_variable(c), M.samples(t, value, c)))
    peak70 = max(float(s.target[s.fit].max()) for d, _u, s in views if d <= 70)
    peak85 = max(float(s.target.max()) for _d, _u, s in views)
    return Rows(value, views, peak70, peak85)


def _columns(s: M.Samples, lobes):
    """(values (n, K), albedos (K,)) of the members at one view."""
    wo = np.broadcast_to(s.wo, s.wi.shape)
    woa = np.broadcast_to(s.wo, s.albedo_wi.shape)
    cols, alb = [], []
    for size, smooth in lobes:
        cols.append(glossy_toon(s.wi, wo, size, smooth))
        alb.append(float(np.sum(glossy_toon(s.albedo_wi, woa, size, smooth) * s.albedo_w)))
    cols.append(C.diffuse(s.wi, wo))
    alb.append(float(np.sum(C.diffuse(s.albedo_wi, woa) * s.albedo_w)))
    return np.stack(cols, -1), np.array(alb)


def _cheb(u, n=M.N_VIEW):
    return np.polynomial.chebyshev.chebvander(np.atleast_1d(u), n - 1)[0]


def _view_rows(r: Rows, lobes, n, scale=1.0, fixed=None):
    """The LP's rows of one width: |mixture - model| <= e peak at every
    sample, the albedo within its band (beyond it, the excess), where the
    weights are ``scale`` times the series' coefficients (variables) plus
    the weights ``fixed`` gives at each view (or none)."""
    out_rows, out_rhs = [], []
    for deg, u, s in r.views:
        A, alb = _columns(s, lobes)
        T = _cheb(u)
        # the mixture at each sample is sum_k sum_m c_km T_m(u) A_jk
        B = scale * np.einsum("jk,m->jkm", A, T).reshape(len(A), n)
        a_row = scale * np.einsum("k,m->km", alb, T).reshape(1, n)
        t, ta = s.target, s.target_albedo
        if fixed is not None:
            w = fixed(u)
            t, ta = t - A @ w, ta - float(alb @ w)
        keep = s.fit if deg <= 70 else s.report
        Bk, tk = B[keep], t[keep]
        peak = r.peak70 if deg <= 70 else r.peak85
        e_col = np.zeros((len(tk), 3))
        e_col[:, 0 if deg <= 70 else 1] = -peak
        out_rows += [np.c_[Bk, e_col], np.c_[-Bk, e_col]]
        out_rhs += [tk, -tk]
        out_rows += [np.c_[a_row, [[0.0, 0.0, -1.0]]], np.c_[-a_row, [[0.0, 0.0, -1.0]]]]
        out_rhs += [[ta + ALBEDO_TOLERANCE], [-ta + ALBEDO_TOLERANCE]]
    return out_rows, out_rhs


def solve(r: Rows, lobes, back=None):
    """The weight series (K, N_VIEW) for the lobes ``[(size, smooth)] *
    N_TOON`` at one width, and the LP's largest error up to 70 deg over the
    peak.  ``back``: ``(rows, lobes, series)`` half way to the previous
    node, where the shaders interpolate (its lobes, and half of its series
    plus half of this one's): that width is fitted too.  Variables: the
    series' coefficients, e70, e85, the albedo excess.  Returns (series,
    e70, the programme's objective: e70 + GRAZING_WEIGHT e85 +
    ALBEDO_PENALTY excess), the errors infinite where it has no solution."""
    K, D = len(MEMBERS), M.N_VIEW
    n = K * D
    ub_rows, ub_rhs = _view_rows(r, lobes, n)
    if back is not None:
        r_mid, lobes_mid, series_prev = back
        fixed = (lambda u: 0.5 * np.polynomial.chebyshev.chebval(u, series_prev.T))
        more_rows, more_rhs = _view_rows(r_mid, lobes_mid, n, 0.5, fixed)
        ub_rows += more_rows
        ub_rhs += more_rhs
    # weights >= 0 over the whole view range (the shaders clamp at 0 anyway)
    grid = np.concatenate([np.linspace(-1.0, 1.0, 41), [u for _d, u, _s in r.views]])
    V = np.polynomial.chebyshev.chebvander(grid, D - 1)
    for k in range(K):
        block = np.zeros((len(grid), n + 3))
        block[:, k * D:(k + 1) * D] = -V
        ub_rows.append(block)
        ub_rhs.append(np.zeros(len(grid)))
    c = np.r_[np.zeros(n), 1.0, GRAZING_WEIGHT, ALBEDO_PENALTY]
    res = linprog(c, A_ub=np.vstack(ub_rows), b_ub=np.concatenate([np.ravel(x) for x in ub_rhs]),
                  bounds=[(None, None)] * n + [(0, None)] * 3, method="highs")
    if not res.success:
        return None, math.inf, math.inf
    return res.x[:n].reshape(K, D), float(res.x[n]), float(res.fun)


def _lobes(z):
    """``[(size, smooth)]`` of the optimiser's variables (log size, log smooth)."""
    z = np.asarray(z, float).reshape(N_TOON, 2)
    return [(min(max(math.exp(a), SIZE_MIN), 1.0), min(max(math.exp(b), SMOOTH_MIN), 1.0))
            for a, b in z]


def fit_node(r: Rows, start, effort=40, previous=None):
    """Nelder-Mead over the lobes' log size and log smooth from ``start``,
    to the least objective of :func:`solve`; ``previous``: ``(rows half
    way back, its lobes' variables, its series)`` of the node fitted
    before, the interval between fitted too.  Returns (variables, series,
    e70, objective)."""
    best = {}

    def back(z):
        if previous is None:
            return None
        r_mid, z_prev, series_prev = previous
        return r_mid, _lobes(0.5 * (np.asarray(z_prev) + z)), series_prev

    def cost(z):
        key = tuple(np.round(z, 9))
        if key not in best:
            best[key] = solve(r, _lobes(z), back(z))[2]
        return best[key]

    z0 = np.asarray(start, float)
    res = minimize(cost, z0, method="Nelder-Mead",
                   options=dict(maxfev=effort * len(z0), xatol=1e-3, fatol=1e-5,
                                initial_simplex=z0 + np.vstack([np.zeros(len(z0)),
                                                                0.3 * np.eye(len(z0))])))
    z = np.asarray(res.x, float)
    series, err, objective = solve(r, _lobes(z), back(z))
    return z, series, err, objective


def start_for(value: float):
    """The narrowest node's start: lobes at 0.5, 1 and 2 of Phong's half
    width at half maximum, smooth as wide as the lobe."""
    s = math.expm1(value)
    half = math.acos(2.0 ** (-1.0 / s)) if s > 0 else HALF_PI
    f = half / HALF_PI
    return np.log(np.array([[f * m, f * m] for m in (0.5, 1.0, 2.0)]).clip(SIZE_MIN, 1.0)).ravel()


@dataclass
class Fit:
    values: np.ndarray        # (n,) the nodes in log(1 + s)
    lobes: np.ndarray         # (n, N_TOON, 2) log size, log smooth
    series: np.ndarray        # (n, K, N_VIEW)
    node_errors: np.ndarray   # (n,)
    measured: dict = field(default_factory=dict)
    band: tuple = None        # (lo, hi) in log(1 + s): the Glossy mixture there
    glossy: str = None        # glossy_digest() of what band and measured were made against
    floors: tuple = None      # ((floor(s), floor(s, albedo=True)), ...) at each node
    at_nodes: tuple = None    # ((s, Toon e70, Glossy e70, floors), ...) at each node


def fit(log=print, jobs=1) -> Fit:
    """Narrow to wide, each node by Nelder-Mead from its narrower
    neighbour's lobes (scaled by the change of the half width), so that the
    lobes interpolated between the nodes stay near both; the narrowest from
    two starts, :func:`start_for` and :func:`floor_start`, the one of
    lesser objective kept (``jobs``: processes for a node's two starts).
    A node whose neighbour's start ends more than SECOND_START_GAP above
    the floor with the albedo held also takes the start of that floor's
    lobes (:func:`floor_start` with ``albedo``), if its objective is less.
    (Every node from the free floor's start, the better kept by the
    largest error, was tried: where that start won, the lobes jumped
    between the nodes and the widths between them erred up to 0.70;
    docs/verification.md.)"""
    from concurrent.futures import ProcessPoolExecutor

    lo, hi = target().domain
    values = np.linspace(lo, hi, N_NODES)
    n = len(values)
    lobes = np.zeros((n, N_TOON, 2))
    series = np.zeros((n, len(MEMBERS), M.N_VIEW))
    errors = np.zeros(n)
    floors = tuple((floor(s), floor(s, albedo=True))
                   for v in values for s in [math.expm1(float(v))])
    z = start_for(values[-1])
    previous = None
    with ProcessPoolExecutor(max(1, min(jobs, 2))) as pool:
        for i in range(n - 1, -1, -1):
            r = rows(float(values[i]))
            if i < n - 1:  # the neighbour's lobes, scaled by the change of the half width
                previous = (rows(0.5 * float(values[i] + values[i + 1])), z, series[i + 1])
                z = z + (start_for(values[i]) - start_for(values[i + 1]))
            starts = {"neighbour" if i < n - 1 else "half width": z}
            if i == n - 1:
                starts["floor"] = floor_start(float(values[i]))
            else:  # run beside the neighbour's; taken only past the gap
                starts["albedo floor"] = floor_start(float(values[i]), albedo=True)
            runs = {k: pool.submit(fit_node, r, z0, previous=previous) for k, z0 in starts.items()}
            done = {k: f.result() for k, f in runs.items()}
            first = next(iter(done))
            near = i < n - 1 and done[first][2] <= floors[i][1] + SECOND_START_GAP
            eligible = [first] if near else list(done)
            kept = min(eligible, key=lambda k: done[k][3])  # the first start's on a tie
            z, s, e, objective = done[kept]
            lobes[i], series[i], errors[i] = z.reshape(N_TOON, 2), s, e
            log(f"phong toon: node {i} s = {math.expm1(values[i]):.4g}: {e:.4f} "
                f"(objective {objective:.4f}) from the {kept}'s start ("
                f"{', '.join(f'{k} {v[2]:.4f} ({v[3]:.4f})' for k, v in done.items())}) "
                f"lobes {[(round(a, 5), round(b, 5)) for a, b in _lobes(z)]}")
    f = Fit(values, lobes, series, errors, floors=floors)
    return against_glossy(f, log)


def against_glossy(f: Fit, log=print) -> Fit:
    """``f`` with its band and measure made against the committed Glossy
    mixture (which the nodes' fit does not use: a change to the Glossy
    data alone asks for these again, not for the fit)."""
    f.band = glossy_band(f, log)
    f.measured = measure(f, f.band)
    toon, glossy = toon_mixture(f), glossy_mixture()
    f.at_nodes = tuple((s, width_measure(v, toon)[0], width_measure(v, glossy)[0], *fl)
                       for v, fl in zip(f.values, f.floors) for s in [math.expm1(float(v))])
    f.glossy = glossy_digest()
    return f


def evaluate(f: Fit, value: float, cos_o: float):
    """(lobes [(size, smooth)], weights (K,)) as the shaders compute them."""
    hw = M.hats(value, f.values)
    z = np.tensordot(hw, f.lobes, axes=(0, 0))
    coeffs = np.tensordot(hw, f.series, axes=(0, 0))
    w = np.polynomial.chebyshev.chebval(view_variable(cos_o), coeffs.T)
    return _lobes(z.ravel()), np.maximum(w, 0.0)


def _glossy():
    """The committed Glossy mixture of Phong (:mod:`fitting.mixtures`)."""
    return M.load_fits([KEY])[KEY]


def glossy_digest() -> str:
    """A digest of the committed Glossy mixture of Phong (its widths and
    weights), which the band and the measure were made against."""
    from addon.core.fits import mixtures as data
    d = data.FITS[KEY]
    h = hashlib.sha256()
    for name in ("multipliers", "weights"):
        h.update(np.ascontiguousarray(d[name], dtype=float).tobytes())
    return h.hexdigest()[:16]


def width_measure(value: float, mixture) -> tuple:
    """(e70, e85, albedo 70, albedo 85) of a mixture at one width, as
    :func:`fitting.mixtures.measure` has them: ``mixture(value, s) ->
    (values at s.wi, albedo)`` at each view every 5 deg; also the count of
    non-finite weights."""
    r = rows(float(value))
    e70 = e85 = da70 = da85 = 0.0
    bad = 0
    for deg, _u, s in r.views:
        m, alb, nonfinite = mixture(float(value), s)
        bad += nonfinite
        da = abs(alb - s.target_albedo)
        e85 = max(e85, float(np.max(np.abs(m - s.target))) / r.peak85)
        da85 = max(da85, da)
        if deg <= 70:
            e70 = max(e70, float(np.max(np.abs(m[s.fit] - s.target[s.fit]))) / r.peak70)
            da70 = max(da70, da)
    return e70, e85, da70, da85, bad


def toon_mixture(f: Fit):
    def mixture(value, s):
        lobes, w = evaluate(f, value, float(s.wo[2]))
        A, alb = _columns(s, lobes)
        return A @ w, float(alb @ w), int(np.sum(~np.isfinite(w)))
    return mixture


def glossy_mixture(g=None):
    g = g or _glossy()

    def mixture(value, s):
        alphas, w = M.evaluate_series(g, value, float(s.wo[2]))
        A, a = M._block(s, g.target.members, alphas)
        return A @ w, float(a @ w), int(np.sum(~np.isfinite(w)))
    return mixture


BAND_STEPS = 8  # the band's ends are on a grid of an eighth of a node interval


def score(measured: tuple) -> float:
    """What the fit minimises (the objective of :func:`solve`) as one
    width's :func:`width_measure` has it: e70 + GRAZING_WEIGHT e85 +
    ALBEDO_PENALTY (the albedo's excess over ALBEDO_TOLERANCE); its e85
    is over every view and sample, the programme's over the views beyond
    70 deg."""
    e70, e85, _da70, da85 = measured[:4]
    return e70 + GRAZING_WEIGHT * e85 + ALBEDO_PENALTY * max(0.0, da85 - ALBEDO_TOLERANCE)


def glossy_band(f: Fit, log=print):
    """``(lo, hi)`` in log(1 + s): the first run of widths from the wide end
    (s = 0) where the Glossy mixture measures better than the Toon one by
    :func:`score`, the fit's own objective (on a grid of an eighth of a
    node interval, views every 5 deg); Cycles renders the Glossy mixture
    there too.  None where there is none."""
    step = (f.values[1] - f.values[0]) / BAND_STEPS
    grid = f.values[0] + step * np.arange(int(round((f.values[-1] - f.values[0]) / step)) + 1)
    toon, glossy = toon_mixture(f), glossy_mixture()
    better = []
    for x in grid:
        better.append(score(width_measure(x, glossy)) < score(width_measure(x, toon)))
        if len(better) > 2 and not any(better[-3:]) and any(better):
            break  # past the run
    if not any(better):
        return None
    first = better.index(True)
    last = first
    while last + 1 < len(better) and better[last + 1]:
        last += 1
    # the switch lies half way between a grid point of one and one of the other
    lo = float(grid[first] - 0.5 * step) if first > 0 else float(grid[0])
    hi = float(grid[last] + 0.5 * step)
    log(f"phong toon: the Glossy mixture measures better for s in "
        f"[{math.expm1(lo):.4g}, {math.expm1(hi):.4g})")
    return lo, hi


def in_band(value: float, band) -> bool:
    return band is not None and band[0] <= value < band[1]


def measure(f: Fit, band=None, n_random=6, seed=1) -> dict:
    """As :func:`fitting.mixtures.measure`: at the nodes, a quarter, half and
    three quarters between every two, random widths, and both sides of the
    band's ends; views every 5 deg.  In ``band`` the Glossy mixture's
    numbers (what Cycles renders there)."""
    rng = np.random.default_rng(seed)
    lo, hi = f.values[0], f.values[-1]
    nodes = f.values
    between = [nodes[:-1] + t * (nodes[1:] - nodes[:-1]) for t in (0.25, 0.5, 0.75)]
    ends = [e + d for e in (band or ()) for d in (-1e-9, 0.0)]
    widths = np.sort(np.concatenate([nodes, *between, rng.uniform(lo, hi, n_random),
                                     np.clip(ends, lo, hi)]))
    keys = ("max_abs_over_peak_70", "max_abs_over_peak_85", "albedo_difference_70",
            "albedo_difference_85")
    worst = dict.fromkeys(keys, 0.0)
    bad = 0
    per_width = []
    toon, glossy = toon_mixture(f), (glossy_mixture() if band else None)
    for value in widths:
        e70, e85, da70, da85, nonfinite = width_measure(
            value, glossy if in_band(float(value), band) else toon)
        bad += nonfinite
        per_width.append((float(value), e70, e85, da85))
        for k, v in zip(keys, (e70, e85, da70, da85)):
            worst[k] = max(worst[k], v)
    return {**worst, "beyond_70": 0.0, "bad_weights": bad, "per_width": per_width}


def fitter_hash() -> str:
    """This fitter, the closures' transcriptions and the samples it uses."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for rel in ("fitting/toon.py", "fitting/mixtures.py", "fitting/closures.py"):
        h.update((root / rel).read_bytes())
    return h.hexdigest()[:16]


def fingerprint() -> list:
    """The reference values the fit was made against (those of
    :func:`fitting.mixtures.fingerprint` for Phong)."""
    return M.fingerprint(target())


def module_text(f: Fit) -> str:
    """``addon/core/fits/toon.py``."""
    from .codegen import array, banner, number

    m = f.measured
    keys = ("max_abs_over_peak_70", "max_abs_over_peak_85", "albedo_difference_70",
            "albedo_difference_85", "bad_weights")
    lines = [banner("fitting/toon.py", "python -m tools.fit --toon"),
             '"""Phong\'s path-traced mixture of Toon glossy lobes and a diffuse\n',
             "member, for Cycles' native nodes (see fitting/toon.py).\n\n",
             "At evenly spaced nodes of log(1 + s) (linear in between): each Toon\n",
             "lobe's log size and log smooth (the node's inputs), and each member's\n",
             "weight as Chebyshev coefficients in the view variable of\n",
             "addon/core/fits/mixtures.py; what the interpolated mixture measured\n",
             "against the reference between the nodes; and the reference values the\n",
             'fit was made against (its staleness test)."""\n\n',
             f"FITTER = {fitter_hash()!r}\n",
             "# the Glossy mixture of Phong the band and MEASURED were made against\n",
             f"GLOSSY = {f.glossy!r}\n",
             f"MEMBERS = {MEMBERS!r}\n",
             f"DOMAIN = ({number(f.values[0])}, {number(f.values[-1])})\n",
             f"LOBES = {array(f.lobes, indent='    ')}\n",
             f"WEIGHTS = {array(f.series, indent='    ')}\n",
             "# log(1 + s) from, to: where the Glossy mixture measured better (Cycles\n",
             "# renders it there too); None: nowhere\n",
             "GLOSSY_BAND = "
             + (f"({number(f.band[0])}, {number(f.band[1])})" if f.band else "None") + "\n",
             "MEASURED = {" + ", ".join(
                 f"{k!r}: {number(m[k]) if isinstance(m[k], float) else repr(m[k])}"
                 for k in keys) + "}\n",
             "# at each node: (s, max |d|/peak up to 70 deg of the Toon mixture, of\n",
             "# the Glossy mixture, floor(s), floor(s, albedo=True))\n",
             f"AT_NODES = {array(f.at_nodes, indent='    ')}\n",
             f"FINGERPRINT = {array(fingerprint(), indent='    ')}\n"]
    return "".join(lines)


def load() -> Fit:
    """The committed data as a :class:`Fit` (its measured numbers included)."""
    from addon.core.fits import toon as data
    values = np.linspace(data.DOMAIN[0], data.DOMAIN[1], len(data.LOBES))
    return Fit(values, np.array(data.LOBES, float), np.array(data.WEIGHTS, float),
               np.zeros(len(values)), dict(data.MEASURED), data.GLOSSY_BAND, data.GLOSSY,
               tuple(tuple(row[3:]) for row in data.AT_NODES),
               tuple(tuple(row) for row in data.AT_NODES))


def _dictionary(value: float) -> list:
    """240 Toon lobes ``(size, smooth)``: 40 sizes from 2 % of Phong's lobe
    width at ``value`` to pi/2, smooth 0 to 4 times the size."""
    width = target().lobe_width(value)
    return [(a / HALF_PI, min(a * f, HALF_PI) / HALF_PI)
            for a in np.geomspace(max(width * 0.02, SIZE_MIN * HALF_PI), HALF_PI, 40)
            for f in (0.0, 0.25, 0.5, 1.0, 2.0, 4.0)]


def _free_views(value: float, albedo: bool = False):
    """At each view up to 70 deg, the minimax linear programme over
    :func:`_dictionary` and the diffuse lobe, lights up to 70 deg, in units
    of the largest peak over the views; ``albedo``: the directional albedo
    held within ALBEDO_TOLERANCE of the model's too.  Yields (weights (K,),
    each member's largest value (K,), the error)."""
    r = rows(value)
    lobes = _dictionary(value)
    for deg, _u, s in r.views:
        if deg > 70:
            continue
        A, alb = _columns(s, lobes)
        A, t = A[s.fit], s.target[s.fit] / r.peak70
        n = A.shape[1]
        ub = [np.c_[A, -np.ones(len(t))], np.c_[-A, -np.ones(len(t))]]
        rhs = [t, -t]
        if albedo:  # in units of the peak, as the samples
            a, ta = np.r_[alb, 0.0] / r.peak70, s.target_albedo / r.peak70
            tol = ALBEDO_TOLERANCE / r.peak70
            ub += [a[None], -a[None]]
            rhs += [[ta + tol], [tol - ta]]
        res = linprog(np.r_[np.zeros(n), 1.0], A_ub=np.vstack(ub), b_ub=np.concatenate(rhs),
                      bounds=[(0, None)] * (n + 1), method="highs")
        if not res.success:
            yield np.zeros(n), A.max(axis=0), math.inf
        else:
            yield res.x[:n], A.max(axis=0), float(res.x[n])


def floor(exponent: float, albedo: bool = False) -> float:
    """How close Toon lobes and a diffuse one can come to Phong's lobe at
    ``exponent`` with everything free at every view: the largest error over
    the views of :func:`_free_views` (``albedo``: with the directional
    albedo held too).  Up to the dictionary's steps, no mixture of these
    closures, with weights and lobes that depend on the view, does
    better; it may use more than N_TOON lobes at a view."""
    return max(e for _w, _peak, e in _free_views(math.log1p(exponent), albedo))


def floor_start(value: float, albedo: bool = False):
    """A node's second start: the N_TOON lobes of :func:`_dictionary` that
    carry the most of :func:`floor`'s mixtures (weight times the lobe's
    largest value, summed over the views; ``albedo``: of the floor with the
    albedo held too)."""
    lobes = _dictionary(value)
    carried = np.zeros(len(lobes))
    for w, peak, _e in _free_views(value, albedo):
        carried += (w * peak)[:len(lobes)]
    top = np.argsort(-carried, kind="stable")[:N_TOON]
    return np.log(np.array([lobes[k] for k in top]).clip([SIZE_MIN, SMOOTH_MIN], 1.0)).ravel()


if __name__ == "__main__":
    import sys
    if sys.argv[1:2] != ["--floor"]:
        raise SystemExit("usage: python -m fitting.toon --floor [EXPONENT ...]  "
                         "(the fit itself: python -m tools.fit --toon)")
    for s_exp in [float(x) for x in sys.argv[2:]] or [1.0, 10.0, 100.0, 1000.0]:
        print(f"s = {s_exp:g}: Toon lobes and a diffuse one, free at every view: "
              f"{floor(s_exp):.3f} of the peak; with the albedo within "
              f"{ALBEDO_TOLERANCE:g} too: {floor(s_exp, albedo=True):.3f}", flush=True)
