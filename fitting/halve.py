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
weights at the view nodes again, node by node against both neighbours as
they are, the nodes that were there first and then the new ones, narrow
to wide: Nelder-Mead on the widths (from the node's own, its narrower
neighbour's, and its own kicked as the fitter kicks a start), minimising
the largest error of the node and its two intervals at the view nodes up
to 70 deg, plus PRICE times its error up to 85 deg beyond what it was
plus GRAZING; the weights from the fitter's linear programme, at the
view nodes beyond 70 deg against every light up to 85 deg
(:func:`_node_weights`).  The result replaces the node where its error up
to 70 deg falls and its error up to 85 deg rises by at most GRAZING.
Only the nodes around the widths that err more than ``level`` are fitted
(:func:`.joint.region`).

Why the views beyond 70 deg are in it: a first trial with the fitter's
own node fit (:func:`.mixtures.fit_width_node`, which solves the weights
beyond 70 deg against lights up to 70 deg only, and counts views up to 70
deg) lowered the error up to 70 deg at every node of Blinn's and
Gaussian's worst range (Blinn at beta 79.4 deg: 0.036 -> 0.023), but
raised it beyond 70 deg by up to 0.11 of the peak (Blinn at beta 45.8
deg, 0.129 -> 0.243), more than the ship rule's 0.1; held to GRAZING, no
node changed.  With the weights beyond 70 deg solved against the lights
there, Blinn's node at 79.4 deg measured 0.036 -> 0.028 up to 70 deg
while its error up to 85 deg fell, 0.088 -> 0.075.

The weight series are then re-solved together (:mod:`.joint`), and
:func:`.assemble.finish_halved` ships the result under the joint step's
rules, measured against the halved fit (the same function as the fit,
measured at the same widths), with the halved fit's own nodes put back
where the result errs more around them.  Deterministic like the fitter:
fixed starts, no random numbers.  Each stage's result is kept in
CACHE_DIR (``build/fits``, set by tools.fit), so a run resumes: the
series re-solve on 31 nodes takes half an hour to an hour a variant on
two cores.

Run to the end for Blinn and Gaussian with separable Smith (``make fit``
runs it for the variants in its HALVE): Blinn 0.0329 -> 0.0263 (shipped),
Gaussian 0.0348 -> 0.0318 with its albedo 0.0095 -> 0.0135 (not shipped).
Node by node the refit lowered every node's error at the view nodes, but
measured at every 5 deg of view the whole erred more before the series
re-solve (Blinn 0.0329 -> 0.0356): the weights are fitted at the view
nodes, and the series between them is not what was fitted
(docs/verification.md).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from . import joint
from . import mixtures as M
from . import polish

SWEEPS = 1
GRAZING = 0.03  # a node's error up to 85 deg may rise this much ...
PRICE = 10.0    # ... and what a rise beyond that costs in the node fit's objective
ITERATIONS = 30  # Nelder-Mead iterations per member width (the fitter's effort)


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


def _mixture_errors(target, value, z, w, views, get):
    """(views and lights up to 70 deg, views and lights up to 85 deg): the
    largest |mixture - model| over the peak at ``value``, members' widths
    ``z``, weights ``w`` (n_view, K) at the view nodes ``views``."""
    alphas = M.alphas_from_multipliers(z, target.equivalent_alpha(value))
    e70 = e85 = 0.0
    for i, c in enumerate(views):
        if c < math.cos(M.REPORT_VIEW) - 1e-12:
            continue
        s = get.at_cos(value, c)
        A, _a = M._block(s, target.members, alphas)
        d = np.abs(A @ w[i] - s.target)
        e85 = max(e85, float(d.max()) / max(float(s.target.max()), 1e-30))
        if c >= math.cos(M.FIT_VIEW) - 1e-12:
            e70 = max(e70, float(d[s.fit].max()) / max(float(s.target[s.fit].max()), 1e-30))
    return e70, e85


def _local_error(fit: M.Fit, j: int, z, w, views, get=None) -> tuple:
    """(up to 70 deg, up to 85 deg): the largest error of node j (holding
    ``z``, ``w``) and of the intervals half way to its neighbours (widths and
    weights interpolated as the shaders do), at the view nodes (``get``:
    the node's :class:`.polish.SampleCache`, made here if not given)."""
    t, nodes = fit.target, fit.width_values
    get = get or polish.SampleCache(t)
    e70, e85 = _mixture_errors(t, float(nodes[j]), z, w, views, get)
    for i in (j - 1, j + 1):
        if 0 <= i < len(nodes):
            a, b = _mixture_errors(t, 0.5 * float(nodes[i] + nodes[j]),
                                   0.5 * (np.asarray(z) + fit.multipliers[i]),
                                   0.5 * (np.asarray(w) + fit.weights[i]), views, get)
            e70, e85 = max(e70, a), max(e85, b)
    return e70, e85


def _node_weights(target, value, z, views, get=None):
    """The weights (n_view, K) at every view node for the members' widths
    ``z``: the fitter's linear programme (:func:`.mixtures.solve_weights`),
    with the continuity pull from one view node to the next, at views up
    to 70 deg against the lights up to 70 deg, and beyond 70 deg against
    every light up to 85 deg (the fitter's own node fit solves those
    against lights up to 70 deg only, which is what raised the error
    beyond 70 deg)."""
    get = get or polish.SampleCache(target)
    alphas = M.alphas_from_multipliers(z, target.equivalent_alpha(value))
    out, prev = [None] * len(views), None
    for i in range(len(views) - 1, -1, -1):  # as the fitter goes, with its pull
        s = get.at_cos(value, views[i])
        if views[i] < math.cos(M.FIT_VIEW) - 1e-12:
            s = dataclasses.replace(s, fit=np.ones(len(s.wi), bool), cache=s.cache)
        out[i], _e = M.solve_weights(s, target.members, alphas, prev)
        prev = out[i]
    return np.array(out)


def _fit_node(fit: M.Fit, j: int, z0, b85, views, get):
    """Nelder-Mead on node j's members' widths from ``z0``: the largest
    error of the node and its intervals up to 70 deg, plus PRICE times its
    error up to 85 deg beyond ``b85`` + GRAZING; the weights by
    :func:`_node_weights`.  Returns (e70, e85, widths, weights)."""
    from scipy.optimize import minimize
    t = fit.target
    value = float(fit.width_values[j])
    same = [(a, b) for a in range(len(t.members)) for b in range(a + 1, len(t.members))
            if t.members[a] == t.members[b] != "diffuse"]

    def objective(z):
        if np.any(z < M.Z_MIN) or np.any(z > M.Z_MAX) or any(z[a] > z[b] - 0.05 for a, b in same):
            return 10.0  # the fitter's box, and members of one kind keep their order
        e70, e85 = _local_error(fit, j, z, _node_weights(t, value, z, views, get), views, get)
        return e70 + PRICE * max(0.0, e85 - b85 - GRAZING)

    z0 = np.clip(np.asarray(z0, float), M.Z_MIN + 0.1, M.Z_MAX - 0.1)
    res = minimize(objective, z0, method="Nelder-Mead",
                   options=dict(maxiter=ITERATIONS * len(z0), xatol=2e-3, fatol=2e-5))
    w = _node_weights(t, value, res.x, views, get)
    return (*_local_error(fit, j, res.x, w, views, get), res.x, w)


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
            # the model's samples at the node's widths and views, made once
            # for its whole search (the members' values kept in them too)
            get = polish.SampleCache(out.target)
            b70, b85 = _local_error(out, j, out.multipliers[j], out.weights[j], views, get)
            # its own widths, its narrower neighbour's, and its own kicked
            # as the fitter kicks a start (the search is local)
            own = out.multipliers[j]
            starts = [own] + ([out.multipliers[j - 1]] if j else []) \
                + [own + d[:len(own)] for d in M._KICKS]
            best = (b70, b85, None, None)
            for z0 in starts:
                e70, e85, z, w = _fit_node(out, j, z0, b85, views, get)
                if e70 < best[0] and e85 <= b85 + GRAZING:
                    best = (e70, e85, z, w)
            if best[2] is not None:
                out.multipliers[j], out.weights[j], out.node_errors[j] = best[2], best[3], best[0]
            log(f"  {fit.target.key}: sweep {sweep}, node {j} ({M._show(fit.target, nodes[j])}): "
                f"{b70:.4f} -> {best[0]:.4f} (up to 85 deg {b85:.4f} -> {best[1]:.4f})")
    out.measured = M.measure(out)
    return out


CACHE_DIR = None  # tools.fit sets build/fits: each result kept, so a run resumes


VERSION = 2  # of what the stages compute: a kept result is used only by the same version


def _cached(fit: M.Fit, level: float, stage: str):
    """Where a stage's result for ``fit`` is kept: named by the fit's
    numbers, ``level``, the stage and VERSION (raise it when a stage's
    computation changes)."""
    import hashlib
    from pathlib import Path
    h = hashlib.sha256()
    for a in (fit.width_values, fit.multipliers, fit.weights):
        h.update(np.ascontiguousarray(a, float).tobytes())
    h.update(repr((fit.target.key, level, stage, VERSION)).encode())
    name = f"halve-{stage}-{fit.target.key.replace('/', '-')}-{h.hexdigest()[:16]}.pickle"
    return Path(CACHE_DIR) / name


def _kept(fit: M.Fit, level: float, stage: str, make, log=print):
    """``make()``, kept in CACHE_DIR (where that is set) under the name of
    ``fit``, ``level`` and ``stage``, so a run resumes after each stage."""
    import pickle
    if CACHE_DIR is None:
        return make()
    path = _cached(fit, level, stage)
    if path.exists():
        log(f"  {fit.target.key}: {stage} from {path.name}")
        return pickle.loads(path.read_bytes())
    out = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(out))
    return out


def solve(fit: M.Fit, level: float, log=print, albedo_weight=joint.ALBEDO_WEIGHT):
    """:func:`solve_uncached`, kept in CACHE_DIR where that is set (the
    refit stage on its own too)."""
    stage = ("solved" if albedo_weight == joint.ALBEDO_WEIGHT
             else f"solved-albedo{albedo_weight:g}")
    return _kept(fit, level, stage, lambda: solve_uncached(fit, level, log, albedo_weight), log)


def solve_uncached(fit: M.Fit, level: float, log=print, albedo_weight=joint.ALBEDO_WEIGHT):
    """``(halved, refitted)``: the fit halved (:func:`halve`, measured) and
    that with the nodes around its widths erring more than ``level``
    fitted again (:func:`refit`) and their weight series re-solved together
    (:func:`.joint.solve`, no width's error up to 70 deg rising by more
    than its RISE, the albedo's excess costing ``albedo_weight``);
    ``refitted`` is ``None`` where there is nothing to fit."""
    halved = halve(fit)
    halved.measured = M.measure(halved)
    free = joint.region(halved, level=level)
    if not free:
        return halved, None
    log(f"  {fit.target.key}: nodes halved, widths fitted again at {sorted(free)}")
    refitted = _kept(fit, level, "refit", lambda: refit(halved, free, log=log), log)
    solved = joint.solve(refitted, log=log, rise=joint.RISE, level=level,
                         albedo_weight=albedo_weight)
    return halved, (solved if solved is not None else refitted)
