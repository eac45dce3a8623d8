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
intervals (at the view nodes up to 70 deg) falls and its error up to 85
deg rises by at most GRAZING (the fitter sees views up to 70 deg only:
without this limit the widths that lowered the error up to 70 deg raised
it up to 85 deg by up to 0.11 of the peak, Blinn with separable Smith at
beta 45.8 deg, 0.129 -> 0.243).  Only the nodes around
the widths that err more than ``level`` are fitted (:func:`.joint.region`).

The weight series are then re-solved together (:mod:`.joint`), and
:func:`.assemble.finish_halved` ships the result under the joint step's
rules, measured against the halved fit (the same function as the fit,
measured at the same widths).  Deterministic like the fitter: fixed
starts, no random numbers.

Not a step of ``make fit`` yet (``python -m tools.fit --finish --halve``
applies it to the committed data).  Measured: unlimited up to 85 deg, the
refitted nodes of Blinn and Gaussian with separable Smith erred less up to
70 deg at every node of their worst range (Blinn at beta 79.4 deg: 0.036
-> 0.023, at 85 deg 0.030 -> 0.025; Gaussian at 85 deg 0.040 -> 0.021),
but the widths that did so raised the error at views beyond 70 deg by up
to 0.11 of the peak (Blinn at beta 45.8 deg, 0.129 -> 0.243), beyond the
0.1 the ship rule allows; with GRAZING 0.03 no node of either changed.
"""

from __future__ import annotations

import math

import numpy as np

from . import joint
from . import mixtures as M

SWEEPS = 1
GRAZING = 0.03  # a node's error up to 85 deg may rise this much (the fitter sees views to 70)


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


def _mixture_errors(target, value, z, w, views):
    """(views and lights up to 70 deg, views and lights up to 85 deg): the
    largest |mixture - model| over the peak at ``value``, members' widths
    ``z``, weights ``w`` (n_view, K) at the view nodes ``views``."""
    alphas = M.alphas_from_multipliers(z, target.equivalent_alpha(value))
    e70 = e85 = 0.0
    for i, c in enumerate(views):
        if c < math.cos(M.REPORT_VIEW) - 1e-12:
            continue
        s = M.samples(target, float(value), float(c))
        A, _a = M._block(s, target.members, alphas)
        d = np.abs(A @ w[i] - s.target)
        e85 = max(e85, float(d.max()) / max(float(s.target.max()), 1e-30))
        if c >= math.cos(M.FIT_VIEW) - 1e-12:
            e70 = max(e70, float(d[s.fit].max()) / max(float(s.target[s.fit].max()), 1e-30))
    return e70, e85


def _local_error(fit: M.Fit, j: int, z, w, views) -> tuple:
    """(up to 70 deg, up to 85 deg): the largest error of node j (holding
    ``z``, ``w``) and of the intervals half way to its neighbours (widths and
    weights interpolated as the shaders do), at the view nodes."""
    t, nodes = fit.target, fit.width_values
    e70, e85 = _mixture_errors(t, float(nodes[j]), z, w, views)
    for i in (j - 1, j + 1):
        if 0 <= i < len(nodes):
            a, b = _mixture_errors(t, 0.5 * float(nodes[i] + nodes[j]),
                                   0.5 * (np.asarray(z) + fit.multipliers[i]),
                                   0.5 * (np.asarray(w) + fit.weights[i]), views)
            e70, e85 = max(e70, a), max(e85, b)
    return e70, e85


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
            b70, b85 = _local_error(out, j, out.multipliers[j], out.weights[j], views)
            nb = [(float(nodes[i]), out.multipliers[i], out.weights[i])
                  for i in (j - 1, j + 1) if 0 <= i < len(nodes)]
            starts = [out.multipliers[j]] + ([out.multipliers[j - 1]] if j else [])
            best = (b70, b85, None, None)
            for z0 in starts:
                z, w, _e = M.fit_width_node(out.target, float(nodes[j]), z0, views, nb)
                e70, e85 = _local_error(out, j, z, w, views)
                if e70 < best[0] and e85 <= b85 + GRAZING:
                    best = (e70, e85, z, w)
            if best[2] is not None:
                out.multipliers[j], out.weights[j], out.node_errors[j] = best[2], best[3], best[0]
            log(f"  {fit.target.key}: sweep {sweep}, node {j} ({M._show(fit.target, nodes[j])}): "
                f"{b70:.4f} -> {best[0]:.4f} (up to 85 deg {b85:.4f} -> {best[1]:.4f})")
    out.measured = M.measure(out)
    return out


CACHE_DIR = None  # tools.fit sets build/fits: each result kept, so a run resumes


def _cached(fit: M.Fit, level: float):
    """Where :func:`solve`'s result for ``fit`` is kept: named by the fit's
    numbers, ``level`` and the fitting code's text."""
    import hashlib
    from pathlib import Path
    h = hashlib.sha256()
    for a in (fit.width_values, fit.multipliers, fit.weights):
        h.update(np.ascontiguousarray(a, float).tobytes())
    h.update(repr((fit.target.key, level)).encode())
    for path in sorted(Path(__file__).resolve().parent.glob("*.py")):
        h.update(path.read_bytes())
    return Path(CACHE_DIR) / f"halve-{fit.target.key.replace('/', '-')}-{h.hexdigest()[:16]}.pickle"


def solve(fit: M.Fit, level: float, log=print):
    """:func:`solve_uncached`, kept in CACHE_DIR where that is set."""
    import pickle
    if CACHE_DIR is None:
        return solve_uncached(fit, level, log)
    path = _cached(fit, level)
    if path.exists():
        log(f"  {fit.target.key}: halved and fitted again: from {path.name}")
        return pickle.loads(path.read_bytes())
    out = solve_uncached(fit, level, log)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(out))
    return out


def solve_uncached(fit: M.Fit, level: float, log=print):
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
