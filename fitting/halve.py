# SPDX-License-Identifier: GPL-3.0-or-later
"""Halving the width nodes' spacing, and fitting the members' widths again.

The shaders interpolate a fit linearly between its width nodes, the
members' widths (log multiples) as well as their weights, so two
neighbouring nodes whose members settled on different widths make a
poor mixture half way between them, and the fitter
(:func:`.mixtures.fit_width_node`) holds each node to the interval on
either side as well as to itself.  Measured on Blinn with separable Smith
(0.033 before this step): at the node at beta 79.4 deg, the best widths
for that node alone err 0.015 at the view nodes up to 70 deg; with its
neighbours as they are, 0.027.  The intervals, not the members, hold
the separable Smith variants over the bound there.

:func:`halve` puts a node half way between every two, with the widths and
weights the shaders interpolate there now: the same function, on twice
as many nodes.  :func:`refit` then fits the members' widths and the
weights at the view nodes again (:func:`.mixtures.fit_width_node`,
against both neighbours as they are), node by node, the nodes that were
there first and then the new ones, narrow to wide; each
node starts from its own widths and from its narrower neighbour's, and
the result replaces it where the largest error of the node and its two
intervals (at the view nodes up to 70 deg) falls.  Only the nodes around
the widths that err more than ``level`` are fitted (:func:`.joint.region`).

The weight series are then re-solved together (:mod:`.joint`), and
:func:`.assemble.finish` ships the result under the joint step's rules,
measured against the halved fit (the same function as the fit, measured
at the same widths).  Deterministic like the fitter: fixed starts, no
random numbers.
"""

from __future__ import annotations

import numpy as np

from . import joint
from . import mixtures as M

SWEEPS = 1


def halve(fit: M.Fit) -> M.Fit:
    """``fit`` on 2 n - 1 evenly spaced width nodes: the old ones and one
    half way between every two, holding the interpolated widths and
    weights there (the shaders' function unchanged)."""
    lo, hi = fit.target.domain
    n = len(fit.width_values)
    nodes = np.linspace(lo, hi, 2 * n - 1)
    z = np.empty((2 * n - 1,) + fit.multipliers.shape[1:])
    w = np.empty((2 * n - 1,) + fit.weights.shape[1:])
    z[::2], w[::2] = fit.multipliers, fit.weights
    z[1::2] = 0.5 * (fit.multipliers[:-1] + fit.multipliers[1:])
    w[1::2] = 0.5 * (fit.weights[:-1] + fit.weights[1:])
    errors = np.repeat(fit.node_errors, 2)[:2 * n - 1]
    return M.Fit(fit.target, nodes, z, w, errors)


def _local_error(fit: M.Fit, j: int, z, w, views) -> float:
    """The largest error of node j (holding ``z``, ``w``) and of the
    intervals to its neighbours, at the view nodes up to 70 deg."""
    t, nodes = fit.target, fit.width_values
    e = M._node_error(t, nodes[j], (z, w), views)
    for i in (j - 1, j + 1):
        if 0 <= i < len(nodes):
            e = max(e, M._interval_error(t, (nodes[j], z, w),
                                         (nodes[i], fit.multipliers[i], fit.weights[i]), views))
    return e


def refit(fit: M.Fit, free, log=print) -> M.Fit:
    """``fit`` with the members' widths and weights of the nodes ``free``
    fitted again (module docstring); measured."""
    views, _u = M.view_nodes()
    out = M.Fit(fit.target, fit.width_values, fit.multipliers.copy(), fit.weights.copy(),
                fit.node_errors.copy())
    nodes = out.width_values
    # the nodes the fit had first (even), then the new ones (odd)
    order = sorted(free, key=lambda j: (j % 2, j))
    for sweep in range(SWEEPS):
        for j in order:
            before = _local_error(out, j, out.multipliers[j], out.weights[j], views)
            nb = [(float(nodes[i]), out.multipliers[i], out.weights[i])
                  for i in (j - 1, j + 1) if 0 <= i < len(nodes)]
            starts = [out.multipliers[j]] + ([out.multipliers[j - 1]] if j else [])
            best = None
            for z0 in starts:
                z, w, _e = M.fit_width_node(out.target, float(nodes[j]), z0, views, nb)
                e = _local_error(out, j, z, w, views)
                if best is None or e < best[0]:
                    best = (e, z, w)
            if best[0] < before:
                out.multipliers[j], out.weights[j], out.node_errors[j] = best[1], best[2], best[0]
            log(f"  {fit.target.key}: sweep {sweep}, node {j} ({M._show(fit.target, nodes[j])}): "
                f"{before:.4f} -> {min(before, best[0]):.4f}")
    out.measured = M.measure(out)
    return out


def solve(fit: M.Fit, level: float, log=print):
    """``(halved, refitted)``: the fit halved (:func:`halve`, measured) and
    that with the nodes around its widths erring more than ``level``
    fitted again (:func:`refit`) and their weight series re-solved together
    (:func:`.joint.solve`, no width's error up to 70 deg rising by more
    than its RISE); ``refitted`` is ``None`` where there is nothing to fit."""
    halved = halve(fit)
    halved.measured = M.measure(halved)
    free = joint.region(halved, level=level)
    if not free:
        return halved, None
    log(f"  {fit.target.key}: nodes halved, widths fitted again at {sorted(free)}")
    refitted = refit(halved, free, log=log)
    solved = joint.solve(refitted, log=log, rise=joint.RISE, level=level)
    return halved, (solved if solved is not None else refitted)
