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

subject to the weights being non-negative at views every 2.5 deg over the
whole range, with the directional albedo within ALBEDO_BAND at every view
(its excess a term of the objective where that cannot be met) and the
error at grazing views (74-89 deg, lights up to 85 deg) a secondary term,
so the series stays sane where the fit's domain ends.  Two sweeps, narrow
to wide, each node against its neighbours' current coefficients.  Nodes
beyond the closures' reach (alpha > 1) are left as they are, but for the
first: it is solved for the widths below alpha 1 it shares with its
neighbour, its own width a secondary term.  A node whose window errs by
less than NEGLIGIBLE is left as it is.

The programme has ~100,000 rows (lights x views x widths); it is solved by
cutting planes (:func:`_cutting_planes`): the rows that bind are few.

Measured: it lowers each variant's worst case (Blinn with correlated Smith
0.075 -> 0.040) but a minimax spreads the error, and 10-15 other widths rise
toward it; :func:`.assemble.choose` ships it only where no width gets
worse, and today that is nowhere.

Deterministic (HiGHS, no randomness).
"""

from __future__ import annotations

import math

import numpy as np

from . import mixtures as M

FIT_VIEWS_DEG = (0.0,) + tuple(2.5 + 5.0 * k for k in range(14)) + (70.0,)
GRAZING_DEG = (74.0, 78.0, 82.0, 86.0, 89.0)
POSITIVE_DEG = tuple(np.arange(0.0, 89.01, 2.5))
GRAZING_WEIGHT = 0.25  # the grazing error's share of the objective
ALBEDO_BAND = 0.009    # the albedo's difference allowed at no cost (0.01: the target) ...
ALBEDO_WEIGHT = 0.5    # ... and what its excess costs
NEGLIGIBLE = 2e-3      # a node whose window errs less than this is left as it is
SWEEPS = 2
INTERVAL = (0.25, 0.5, 0.75)  # where between two width nodes the error counts


def _tu(deg):
    c = math.cos(deg * M.DEG)
    return 2.0 * (c - M.COS_VIEW_MIN) / (1.0 - M.COS_VIEW_MIN) - 1.0


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
        key = (round(float(value), 12), deg)
        if key not in self.cache:
            self.cache[key] = M.samples(self.target, float(value), math.cos(deg * M.DEG))
        return self.cache[key]


def _window(fit, j):
    """``(primary, secondary)``: the widths whose mixture depends on node j
    within the closures' reach (the node, a quarter, half and three quarters
    of the way to each neighbour, and
    where the next node lies beyond alpha 1, alpha 1 and half way to it);
    for the first node beyond alpha 1, the widths below alpha 1 it shares
    with its neighbour, and the node itself as a secondary term."""
    nodes = fit.width_values
    soft = fit.target.soft_max
    if nodes[j] > soft + 1e-12:
        if j and nodes[j - 1] < soft - 1e-12:
            return [soft, 0.5 * float(nodes[j - 1] + soft)], [float(nodes[j])]
        return [], []
    out = [float(nodes[j])]
    for i in (j - 1, j + 1):
        if 0 <= i < len(nodes):
            out += [float(nodes[j] + t * (nodes[i] - nodes[j])) for t in INTERVAL]
    if j + 1 < len(nodes) and nodes[j + 1] > soft + 1e-12 and nodes[j] < soft - 1e-12:
        out += [soft, 0.5 * float(nodes[j] + soft)]
    return sorted({v for v in out if v <= soft + 1e-12}), []


def _solve_node(fit, series, j, get):
    """The coefficients (K, N) of node j minimising the window's error."""
    target = fit.target
    nodes = fit.width_values
    K, N = series.shape[1], series.shape[2]
    nv = K * N + 3  # coefficients (k major), e1 (error), e2 (grazing), e3 (albedo)
    rows, rhs = [], []

    def add(AT, t, hat_j, fixed, scale, err_col):
        """|hat_j AT c + fixed - t| / scale <= e: two rows per sample."""
        B = np.zeros((len(t), nv))
        B[:, :K * N] = hat_j * AT / scale
        E = np.zeros((len(t), nv))
        E[:, err_col] = 1.0
        r = (t - fixed) / scale
        rows.extend([B - E, -B - E])
        rhs.extend([r, -r])

    primary, secondary = _window(fit, j)
    if not primary:
        return None
    for value in primary + secondary:
        main = value in primary
        hw = M.hats(value, nodes)
        hat_j = hw[j]
        others = [i for i in np.nonzero(hw)[0] if i != j]
        z = hw @ fit.multipliers
        alphas = M.alphas_from_multipliers(z, target.equivalent_alpha(value))
        sets = []
        for deg in FIT_VIEWS_DEG + GRAZING_DEG:
            s = get(value, deg)
            A, a = M._block(s, target.members, alphas)
            T = _cheb_row(deg, N)
            AT = (A[:, :, None] * T[None, None, :]).reshape(len(A), K * N)
            aT = (a[:, None] * T[None, :]).reshape(K * N)
            w_fixed = sum(hw[i] * (series[i] @ T) for i in others) if others else np.zeros(K)
            sets.append((deg, s, AT, A @ w_fixed, aT, float(a @ w_fixed)))
        peak70 = max(float(s.target[s.fit].max()) for deg, s, *_ in sets if deg <= 70)
        peak85 = max(float(s.target.max()) for deg, s, *_ in sets)
        for deg, s, AT, fixed, aT, a_fixed in sets:
            if deg <= 70:
                m = s.fit
                add(AT[m], s.target[m], hat_j, fixed[m], peak70, K * N if main else K * N + 1)
            else:
                add(AT, s.target, hat_j, fixed, peak85, K * N + 1)
            if not main:
                continue
            # albedo within the band, or beyond it by e3
            row = np.zeros(nv)
            row[:K * N] = hat_j * aT
            row[K * N + 2] = -1.0
            up = row.copy()
            up[:K * N] *= -1.0
            rows.extend([row[None, :], up[None, :]])
            rhs.extend([[s.target_albedo + ALBEDO_BAND - a_fixed],
                        [-(s.target_albedo - ALBEDO_BAND - a_fixed)]])
    # non-negative weights at every view
    P = np.zeros((len(POSITIVE_DEG) * K, nv))
    for n, deg in enumerate(POSITIVE_DEG):
        T = _cheb_row(deg, N)
        for k in range(K):
            P[n * K + k, k * N:(k + 1) * N] = -T
    c = np.zeros(nv)
    c[K * N:] = 1.0, GRAZING_WEIGHT, ALBEDO_WEIGHT
    bounds = [(None, None)] * (K * N) + [(0, None)] * 3
    A_ub = np.vstack(rows + [P])
    b_ub = np.concatenate([np.ravel(r) for r in rhs] + [np.zeros(len(P))])
    # the current coefficients' error: nothing to gain below NEGLIGIBLE
    x0 = np.concatenate([series[j].ravel(), [0.0, 0.0, 0.0]])
    lhs = A_ub[:, :K * N] @ x0[:K * N] - b_ub
    e1_col, e3_col = A_ub[:, K * N] != 0, A_ub[:, K * N + 2] != 0
    now = float(lhs[e1_col].max(initial=0.0))
    if now < NEGLIGIBLE and lhs[e3_col].max(initial=0.0) <= 0.0:
        return None
    x = _cutting_planes(c, A_ub, b_ub, bounds)
    if x is None:
        return None
    return x[:K * N].reshape(K, N), float(x[K * N])


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
    _views, uv = M.view_nodes(series.shape[2])
    cheb = np.polynomial.chebyshev.chebval
    weights = np.array([[[cheb(u, series[j, k]) for k in range(series.shape[1])] for u in uv]
                        for j in range(len(nodes))])
    out = M.Fit(target, nodes, fit.multipliers.copy(), weights, fit.node_errors.copy())
    out.measured = M.measure(out)
    return out
