# SPDX-License-Identifier: GPL-3.0-or-later
"""Re-solving a fit's weights as the shaders evaluate them.

The fitter (:mod:`.mixtures`) solves the weights at each view node, one
node at a time, and the shaders sum the Chebyshev series through those
values: between the view nodes the weights are what the series makes of
them, and a weight that jumps from one node to the next swings the series
in between.  Its measurement (:func:`.mixtures.measure`) found part of the
error of the Smith variants there and between width nodes.

:func:`polish` keeps the members' widths of a fit and solves, width node by
width node, for the series coefficients themselves: one linear programme
per node whose unknowns are the K x N_VIEW coefficients, minimising the
largest |mixture - model| over the peak

- at views between the ones :func:`.mixtures.measure` checks (0, 2.5, 7.5,
  ..., 67.5, 70 deg: the measured views are held out, but for the ends)
  and lights up to 70 deg,
- at the node and a quarter, half and three quarters of the way to each
  neighbour (with the neighbour's coefficients as they are, interpolated
  as the shaders do);

under a cap: **no width of the window may err more than it does now**, up
to 70 deg and up to 85 deg (views every degree from 71 to 89 but the
measured 75, 80 and 85, lights up to 85 deg).  An unconstrained minimax
lowered each variant's worst case but spread the error, 10-15 other widths
rising toward it (make demo's gonio at beta 25 deg: Trowbridge-Reitz with
Smith 0.012 -> 0.031); the cap keeps what the fit has and takes only what
is free.  Secondary terms: the mean of the widths' own errors, the
grazing error, the directional albedo beyond ALBEDO_BAND.  The weights
are kept non-negative as the shaders interpolate them, at every view the
programme fits at (so its error is the shaders' there; they clamp a
negative weight to 0) and every 2.5 deg.  Where a fit's weights dip below
0 now, weights >= 0 may not reach every width's present error: that node
is left as it is, as is a node whose window errs by less than NEGLIGIBLE.
Two sweeps, narrow to wide, each node against its neighbours' current
coefficients.  Nodes beyond the closures' reach (alpha > 1) are left as
they are, but for the first: it is solved for the widths below alpha 1 it
shares with its neighbour, its own width and those toward the next node
capped too.

The programme has ~100,000 rows (lights x views x widths); it is solved by
cutting planes (:func:`_cutting_planes`): the rows that bind are few.
:func:`.assemble.choose` tries it for the Smith-shadowed variants and ships
it where, measured, no width is worse than the fit's and the worst case
falls.

Deterministic (HiGHS, no randomness).
"""

from __future__ import annotations

import math

import numpy as np

from . import mixtures as M

FIT_VIEWS_DEG = (0.0,) + tuple(2.5 + 5.0 * k for k in range(14)) + (70.0,)
# every degree past 70 but the measured views (75, 80, 85): a series swings
# between views a few degrees apart there
GRAZING_DEG = tuple(float(d) for d in range(71, 90) if d % 5)
# weights >= 0 every 2.5 deg and at every view the programme fits at (the
# shaders clamp a negative weight to 0: the programme's error is theirs there)
POSITIVE_DEG = tuple(sorted(set(np.arange(0.0, 89.01, 2.5))
                          | set(FIT_VIEWS_DEG) | set(GRAZING_DEG)))
GRAZING_WEIGHT = 0.25  # the grazing error's share of the objective
ALBEDO_BAND = 0.009    # the albedo's difference allowed at no cost (0.01: the target) ...
ALBEDO_WEIGHT = 0.5    # ... and what its excess costs
NEGLIGIBLE = 2e-3      # a node whose window errs less than this is left as it is
SWEEPS = 2
INTERVAL = (0.25, 0.5, 0.75)  # where between two width nodes the error counts
SPREAD = 0.5          # the mean of the widths' own errors, a secondary term
CAP_TOLERANCE = 1e-5  # a width's error may exceed its current one by this (the LP's tolerance)
OVER_CAP = 100.0      # what a width's error beyond its current one costs


def _tu(deg):
    c = math.cos(deg * M.DEG)
    return min(max(2.0 * (c - M.COS_VIEW_MIN) / (1.0 - M.COS_VIEW_MIN) - 1.0, -1.0), 1.0)


def _cheb_row(deg, n):
    """T_0..T_{n-1} at the view ``deg`` (the shaders' mapping of cos theta_o)."""
    return np.polynomial.chebyshev.chebvander(np.array([_tu(deg)]), n - 1)[0]


class SampleCache:
    """The model's samples per (width, view), made once (also
    :class:`.assemble._Window`'s)."""

    def __init__(self, target):
        self.target = target
        self.cache = {}

    def __call__(self, value, deg):
        return self._kept((round(float(value), 12), deg), value, math.cos(deg * M.DEG))

    def at_cos(self, value, cos_o):
        """The samples at the view whose cosine is ``cos_o`` (the view nodes
        are cosines: made from it as given, not from an angle)."""
        return self._kept((round(float(value), 12), "cos", float(cos_o)), value, cos_o)

    def _kept(self, key, value, cos_o):
        if key not in self.cache:
            self.cache[key] = M.samples(self.target, float(value), float(cos_o))
        return self.cache[key]


def _window(fit, j):
    """``(primary, secondary)``: the widths whose mixture depends on node j
    within the closures' reach (the node, a quarter, half and three quarters
    of the way to each neighbour, and
    where the next node lies beyond alpha 1, alpha 1 and half way to it);
    for the first node beyond alpha 1, the widths below alpha 1 it shares
    with its neighbour, and as secondary widths the node itself and a
    quarter, half and three quarters of the way to the next."""
    nodes = fit.width_values
    soft = fit.target.soft_max
    if nodes[j] > soft + 1e-12:
        if j and nodes[j - 1] < soft - 1e-12:
            beyond = [float(nodes[j])]
            if j + 1 < len(nodes):
                beyond += [float(nodes[j] + t * (nodes[j + 1] - nodes[j])) for t in INTERVAL]
            return [soft, 0.5 * float(nodes[j - 1] + soft)], beyond
        return [], []
    out = [float(nodes[j])]
    for i in (j - 1, j + 1):
        if 0 <= i < len(nodes):
            out += [float(nodes[j] + t * (nodes[i] - nodes[j])) for t in INTERVAL]
    if j + 1 < len(nodes) and nodes[j + 1] > soft + 1e-12 and nodes[j] < soft - 1e-12:
        out += [soft, 0.5 * float(nodes[j] + soft)]
    return sorted({v for v in out if v <= soft + 1e-12}), []


def _solve_node(fit, series, j, get, start=8, views=FIT_VIEWS_DEG, limits=None,
                grazing=GRAZING_DEG):
    """``(coefficients (K, N), the window's error, its widths' errors now)``:
    the coefficients of node j minimising the window's error at ``views``
    (and ``grazing`` beyond 70 deg), no width of the window erring more than it does now
    (or than ``limits``: per width of :func:`_window`, its error up to 70
    and up to 85 deg); ``None`` where the node is left as it is.  The
    cutting planes start from every ``start``-th row
    (:func:`_cutting_planes`)."""
    target = fit.target
    nodes = fit.width_values
    K, N = series.shape[1], series.shape[2]
    primary, secondary = _window(fit, j)
    if not primary:
        return None
    widths = primary + secondary
    KN = len(widths)
    # coefficients (k major); e1 (the window's error), e2 (grazing and the
    # secondary widths), e3 (albedo); per width its error up to 70 deg and
    # up to 85 deg
    E1, E2, E3 = K * N, K * N + 1, K * N + 2
    nv = K * N + 3 + 2 * KN
    rows, rhs, owner = [], [], []
    caps = []  # per width, its error up to 70 and up to 85 deg as the shaders compute it now
    positive = []

    def add(AT, t, hat_j, fixed, scale, err_col):
        """|hat_j AT c + fixed - t| / scale <= e: two rows per sample."""
        B = np.zeros((len(t), nv))
        B[:, :K * N] = hat_j * AT / scale
        E = np.zeros((len(t), nv))
        E[:, err_col] = 1.0
        r = (t - fixed) / scale
        rows.extend([B - E, -B - E])
        rhs.extend([r, -r])
        owner.extend([np.full(len(t), err_col)] * 2)

    for n, value in enumerate(widths):
        main = value in primary
        c70, c85 = K * N + 3 + 2 * n, K * N + 4 + 2 * n
        hw = M.hats(value, nodes)
        hat_j = hw[j]
        others = [i for i in np.nonzero(hw)[0] if i != j]
        z = hw @ fit.multipliers
        alphas = M.alphas_from_multipliers(z, target.equivalent_alpha(value))
        sets = []
        for deg in tuple(views) + tuple(grazing):
            s = get(value, deg)
            A, a = M._block(s, target.members, alphas)
            T = _cheb_row(deg, N)
            AT = (A[:, :, None] * T[None, None, :]).reshape(len(A), K * N)
            aT = (a[:, None] * T[None, :]).reshape(K * N)
            w_fixed = sum(hw[i] * (series[i] @ T) for i in others) if others else np.zeros(K)
            now = A @ np.maximum(hat_j * (series[j] @ T) + w_fixed, 0.0)  # clamped, as shaded
            # the weights as the shaders interpolate them >= 0 here
            G = np.zeros((K, nv))
            for k in range(K):
                G[k, k * N:(k + 1) * N] = -hat_j * T
            positive.append((G, w_fixed))
            sets.append((deg, s, AT, A @ w_fixed, aT, float(a @ w_fixed), np.abs(now - s.target)))
        peak70 = max(float(s.target[s.fit].max()) for deg, s, *_ in sets if deg <= 70)
        peak85 = max(float(s.target.max()) for deg, s, *_ in sets)
        caps += [max(float(d[s.fit].max()) for deg, s, *_r, d in sets if deg <= 70) / peak70,
                 max(float(d.max()) for deg, s, *_r, d in sets) / peak85]
        for deg, s, AT, fixed, aT, a_fixed, _now in sets:
            if deg <= 70:
                m = s.fit
                add(AT[m], s.target[m], hat_j, fixed[m], peak70, c70)
                add(AT, s.target, hat_j, fixed, peak85, c85)  # and lights up to 85 deg
            else:
                add(AT, s.target, hat_j, fixed, peak85, c85)
            if not main:
                continue
            # albedo within the band, or beyond it by e3
            row = np.zeros(nv)
            row[:K * N] = hat_j * aT
            row[E3] = -1.0
            up = row.copy()
            up[:K * N] *= -1.0
            rows.extend([row[None, :], up[None, :]])
            rhs.extend([[s.target_albedo + ALBEDO_BAND - a_fixed],
                        [-(s.target_albedo - ALBEDO_BAND - a_fixed)]])
            owner.extend([np.array([E3])] * 2)
    # the window's error is the largest of its primary widths'; the grazing
    # error is at least each width's up to 85 deg and each secondary width's
    for n, value in enumerate(widths):
        for col, top in ((K * N + 3 + 2 * n, E1 if value in primary else E2),
                         (K * N + 4 + 2 * n, E2)):
            row = np.zeros((1, nv))
            row[0, col], row[0, top] = 1.0, -1.0
            rows.append(row)
            rhs.append([0.0])
            owner.append(np.array([-1]))
    # non-negative weights at every view
    P = np.zeros((len(POSITIVE_DEG) * K, nv))
    for n, deg in enumerate(POSITIVE_DEG):
        T = _cheb_row(deg, N)
        for k in range(K):
            P[n * K + k, k * N:(k + 1) * N] = -T
    rows += [P] + [G for G, _f in positive]
    rhs += [np.zeros(len(P))] + [f for _G, f in positive]
    A_ub = np.vstack(rows)
    b_ub = np.concatenate([np.ravel(r) for r in rhs])
    owner = np.concatenate(owner + [np.full(len(b_ub) - sum(map(len, owner)), -1)])
    # each width's error now caps it: no width gets worse
    x0 = np.concatenate([series[j].ravel(), np.zeros(3 + 2 * KN)])
    lhs = A_ub[:, :K * N] @ x0[:K * N] - b_ub
    if max(caps[0:2 * len(primary):2]) < NEGLIGIBLE and lhs[owner == E3].max(initial=0.0) <= 0.0:
        return None
    now, caps = caps, (caps if limits is None else list(limits))
    # a width may exceed its cap only by an excess that costs OVER_CAP each
    # (where the shaders clamp a weight now, weights >= 0 may not reach the
    # error it has); a solution with any excess is not taken
    nc = len(caps)
    A_ub = np.hstack([A_ub, np.zeros((len(A_ub), nc))])
    C = np.hstack([np.zeros((nc, K * N + 3)), np.eye(nc), -np.eye(nc)])
    A_ub = np.vstack([A_ub, C])
    b_ub = np.concatenate([b_ub, np.asarray(caps) + CAP_TOLERANCE])
    c = np.zeros(nv + nc)
    c[E1:E3 + 1] = 1.0, GRAZING_WEIGHT, ALBEDO_WEIGHT
    c[K * N + 3:nv:2] = SPREAD / KN  # every width's own error, a secondary term
    c[K * N + 4:nv:2] = SPREAD * GRAZING_WEIGHT / KN
    c[nv:] = OVER_CAP
    bounds = [(None, None)] * (K * N) + [(0, None)] * (3 + 2 * KN + nc)
    x = _cutting_planes(c, A_ub, b_ub, bounds, start=start)
    if x is None or x[nv:].max() > CAP_TOLERANCE:  # a width would get worse: left as it is
        return None
    return x[:K * N].reshape(K, N), float(x[E1]), now


def _cutting_planes(c, A_ub, b_ub, bounds, start=8, add=400, rounds=40):
    """The LP ``min c x, A_ub x <= b_ub`` by its rows that bind: every
    ``start``-th row first, then the ``add`` most violated rows each round,
    until none is violated (the same optimum as the whole LP, solved on a
    small part of its rows); ``None`` if HiGHS fails."""
    from scipy.optimize import linprog

    active = np.zeros(len(b_ub), bool)
    active[::start] = True
    for _round in range(rounds):
        res = linprog(c, A_ub=A_ub[active], b_ub=b_ub[active], bounds=bounds, method="highs")
        if res.status != 0:
            return None
        excess = A_ub @ res.x - b_ub
        excess[active] = 0.0
        if excess.max() <= 1e-9:
            return res.x
        worst = np.argsort(-excess)[:add]
        active[worst[excess[worst] > 1e-9]] = True
    res = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs")
    return res.x if res.status == 0 else None


def polish(fit: M.Fit, log=print) -> M.Fit:
    """``fit`` with its weight series re-solved (module docstring); the
    members' widths unchanged; measured."""
    target = fit.target
    get = SampleCache(target)
    series = fit.weight_series.copy()  # (n_width, K, N)
    nodes = fit.width_values
    for sweep in range(SWEEPS):
        for j in range(len(nodes)):
            out = _solve_node(fit, series, j, get)
            if out is not None:
                series[j] = out[0]
                if sweep == SWEEPS - 1:
                    log(f"  {target.key} node {j}: {out[1]:.4f}")
    out = with_series(fit, series)
    out.measured = M.measure(out)
    return out


def with_series(fit: M.Fit, series) -> M.Fit:
    """``fit`` with the weight series ``series`` (n_width, K, N): its weights
    at the view nodes, as :class:`.mixtures.Fit` holds them."""
    _views, uv = M.view_nodes(series.shape[2])
    cheb = np.polynomial.chebyshev.chebval
    weights = np.array([[[cheb(u, series[j, k]) for k in range(series.shape[1])] for u in uv]
                        for j in range(len(fit.width_values))])
    return M.Fit(fit.target, fit.width_values, fit.multipliers.copy(), weights,
                 fit.node_errors.copy())
