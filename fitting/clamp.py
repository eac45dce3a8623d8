# SPDX-License-Identifier: GPL-3.0-or-later
"""Member widths that cross Cycles' clamp inside an interval.

The shaders interpolate each member's log multiple linearly between two
width nodes and multiply it by the equivalent width there; Cycles then
clamps the closure's alpha to [ALPHA_MIN, ALPHA_MAX].  Where a member sits
at the clamp at one node and below it at the next (the lobe widening
toward beta 85 deg, whose equivalent Beckmann m is 3.5), the interpolated
width reaches the clamp a few tenths of a degree past the narrower node,
while the weights there are still that node's, fitted for the narrower
member: Blinn with correlated Smith erred 0.026 at beta 79.4 deg and 0.095
at 80.0 deg, where its GGX member had gone from alpha 0.954 to 1 (a GGX
lobe's backscatter changes 12 % between them).  The fitter's intervals are
sampled half way, past the crossing, so it did not see it.

:func:`settle` takes every pair of neighbouring nodes a member crosses the
limit between and tries both ways of not crossing it: the member moved to
the limit at the node below it too (the width its neighbour has), or moved
off the limit at the neighbour (to the node's alpha); each time the moved
node's weights are solved again (:func:`.mixtures.fit_width_node` with the
members' widths held, the intervals to both neighbours fitted).  The
better of the two is kept where it lowers the largest error measured over
the widths the two nodes shape (each node, a quarter, half and three
quarters of the way to its neighbours, as :func:`.mixtures.measure` checks
them, and alpha 1 where the next node lies beyond it) by MIN_GAIN.  Where
the better of the two still errs more than SEARCH_ABOVE there, the moved
node's other microfacet members' widths are searched too (Nelder-Mead,
SEARCH_ITERATIONS, the moved members held, the weights solved for each),
for the largest error over those widths.  Widths outside the two nodes'
intervals are unchanged by construction.  Measured on the fits (the
figure over every width, views and lights up to 70 deg): Blinn with
correlated Smith 0.0745 -> 0.036, Blinn with Smith 0.053 -> 0.037,
Gaussian with Smith 0.054 -> 0.041 (its Beckmann member off the limit at
beta 85 deg: 0.070 between the nodes without the search, 0.041 with it),
Trowbridge-Reitz with Smith in alpha 0.119 -> 0.093 (its re-solve, 0.070,
is not used: the albedo rose to 0.043).

Deterministic (the fitter's linear programmes, no randomness).
"""

from __future__ import annotations

import math

import numpy as np

from . import mixtures as M
from .polish import SampleCache

MARGIN = 0.02    # a moved member's log multiple lies this far past the clamp
MIN_GAIN = 1e-3  # a change is kept where it lowers the error around it by this
SEARCH_ABOVE = 0.025   # a change still above this (the bound) ...
SEARCH_ITERATIONS = 40  # ... has the node's other member widths searched this long


def _alphas(fit, j):
    return M.alphas_from_multipliers(fit.multipliers[j],
                                     fit.target.equivalent_alpha(float(fit.width_values[j])))


def crossings(fit: M.Fit) -> dict:
    """``{(j, i): {member: ...}}``: the members below (above) the upper
    (lower) clamp at node j and at it at its neighbour i, both within the
    closures' reach; per member ``(log multiple at the clamp at j, log
    multiple at i giving node j's alpha)``."""
    t = fit.target
    nodes = fit.width_values
    out = {}
    for j in range(len(nodes)):
        if nodes[j] > t.soft_max + 1e-12:
            continue
        here = _alphas(fit, j)
        eq = t.equivalent_alpha(float(nodes[j]))
        for i in (j - 1, j + 1):
            if not 0 <= i < len(nodes) or nodes[i] > t.soft_max + 1e-12:
                continue
            there = _alphas(fit, i)
            eq_i = t.equivalent_alpha(float(nodes[i]))
            for k, member in enumerate(t.members):
                if member == "diffuse":
                    continue
                if there[k] >= M.ALPHA_MAX and here[k] < M.ALPHA_MAX:
                    z = math.log(M.ALPHA_MAX / eq) + MARGIN
                elif there[k] <= M.ALPHA_MIN and here[k] > M.ALPHA_MIN:
                    z = math.log(M.ALPHA_MIN / eq) - MARGIN
                else:
                    continue
                out.setdefault((j, i), {})[k] = (z, math.log(here[k] / eq_i))
    return out


def _interval_widths(fit, j):
    """Node j and a quarter, half and three quarters of the way to each
    neighbour, within the closures' reach (as :func:`.mixtures.measure`'s
    figures up to 70 deg are)."""
    nodes = fit.width_values
    soft = fit.target.soft_max
    out = [float(nodes[j])]
    for i in (j - 1, j + 1):
        if 0 <= i < len(nodes):
            out += [float(nodes[j] + t * (nodes[i] - nodes[j])) for t in (0.25, 0.5, 0.75)]
            if nodes[i] > soft + 1e-12 >= nodes[j]:  # alpha 1 and half way to it, as measured
                out += [soft, 0.5 * float(nodes[j] + soft)]
    return [v for v in out if v <= soft + 1e-12]


def window_errors(fit, widths, get):
    """The largest error over the peak (views and lights up to 70 deg, the
    views :func:`.mixtures.measure` checks) at each width; ``get``: the
    model's samples (a :class:`.polish.SampleCache`)."""
    t = fit.target
    out = []
    for value in widths:
        rows = []
        for deg in M.MEASURE_VIEWS_DEG:
            if deg > 70:
                continue
            s = get(value, deg)
            alphas, w = M.evaluate_series(fit, value, math.cos(deg * M.DEG))
            A, _a = M._block(s, t.members, alphas)
            rows.append((s, A @ w))
        peak = max(float(s.target[s.fit].max()) for s, _m in rows)
        out.append(max(float(np.max(np.abs(m[s.fit] - s.target[s.fit]))) for s, m in rows)
                   / peak)
    return out


def _refit(fit, j, changes, views):
    """``fit`` with node j's members ``changes`` ({member: log multiple})
    and its weights solved again (the members' widths held)."""
    t = fit.target
    nodes = fit.width_values
    z = fit.multipliers[j].copy()
    for k, zk in changes.items():
        z[k] = min(max(zk, M.Z_MIN + 0.1), M.Z_MAX - 0.1)  # the fitter's search box
    nb = [(float(nodes[i]), fit.multipliers[i], fit.weights[i])
          for i in (j - 1, j + 1) if 0 <= i < len(nodes)]
    z_new, w_new, _err = M.fit_width_node(t, float(nodes[j]), z, views, nb, effort=0)
    out = M.Fit(t, nodes, fit.multipliers.copy(), fit.weights.copy(), fit.node_errors.copy())
    out.multipliers[j], out.weights[j] = z_new, w_new
    return out


def _search(fit, j, held, widths, views, get):
    """``fit`` with node j's members ``held`` ({member: log multiple}) and
    the widths of its other microfacet members chosen by Nelder-Mead, each
    with the node's weights solved again, for the smallest largest error
    at ``widths``."""
    from scipy.optimize import minimize

    t = fit.target
    free = [k for k, m in enumerate(t.members) if m != "diffuse" and k not in held]

    def trial(x):
        return _refit(fit, j, {**held, **dict(zip(free, x))}, views)

    def objective(x):
        return max(window_errors(trial(x), widths, get))

    res = minimize(objective, fit.multipliers[j][free], method="Nelder-Mead",
                   options=dict(maxiter=SEARCH_ITERATIONS, xatol=2e-3, fatol=2e-5))
    return trial(res.x)


def settle(fit: M.Fit, log=print, only=None, measure=True) -> tuple:
    """``(fit, moved)``: ``fit`` where, for every pair of neighbouring
    nodes a member crosses the clamp between, the better of moving it to
    the clamp at the other node too and moving it off the clamp at the
    neighbour (to the other node's alpha), each with that node's weights
    solved again, where it lowers the largest error around the two nodes
    by MIN_GAIN; ``moved`` lists the nodes changed.  Measured
    (``measure=False``: ``measured`` left empty, for a caller that reads
    only the weights).  ``only``: these pairs ``(j, i)`` of
    :func:`crossings` alone."""
    t = fit.target
    views, _u = M.view_nodes()
    current = M.Fit(t, fit.width_values, fit.multipliers.copy(), fit.weights.copy(),
                    fit.node_errors.copy())
    moved = []
    get = SampleCache(t)
    for (j, i), members in sorted(crossings(fit).items()):
        if only is not None and (j, i) not in only:
            continue
        if j in moved or i in moved:
            continue  # a node already changed: its crossings are not these
        widths = sorted(set(_interval_widths(current, j) + _interval_widths(current, i)))
        before = max(window_errors(current, widths, get))
        trials = [(j, _refit(current, j, {k: v[0] for k, v in members.items()}, views)),
                  (i, _refit(current, i, {k: v[1] for k, v in members.items()}, views))]
        errs = [max(window_errors(trial, widths, get)) for _n, trial in trials]
        best = int(np.argmin(errs))
        if errs[best] > SEARCH_ABOVE:  # the other members' widths searched too
            n, held = trials[best][0], ({k: v[0] for k, v in members.items()} if best == 0
                                        else {k: v[1] for k, v in members.items()})
            trials.append((n, _search(trials[best][1], n, held, widths, views, get)))
            errs.append(max(window_errors(trials[-1][1], widths, get)))
            log(f"  {t.key}: nodes {j}, {i}: node {n}'s other members searched: "
                f"{errs[best]:.4f} -> {errs[-1]:.4f}")
            best = int(np.argmin(errs))
        kept = errs[best] <= before - MIN_GAIN
        log(f"  {t.key}: nodes {j}, {i} ({M._show(t, float(current.width_values[j]))}), "
            f"members {sorted(members)}: {before:.4f}; to the clamp at {j} {errs[0]:.4f}, "
            f"off it at {i} {errs[1]:.4f}; " + (f"node {trials[best][0]} kept" if kept
                                                else "not kept"))
        if kept:
            current = trials[best][1]
            moved.append(trials[best][0])
    if not measure:
        current.measured = {}
    elif moved:
        current.measured = M.measure(current)
    else:
        current.measured = dict(fit.measured or M.measure(fit))
    return current, sorted(moved)
