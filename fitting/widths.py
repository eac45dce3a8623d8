# SPDX-License-Identifier: GPL-3.0-or-later
"""Moving the members' widths node by node, each move judged by the node's
weight series solved again.

The fitter chooses a node's members' widths with the weights solved at the
view nodes (:func:`.mixtures.fit_width_node`), and so does the halving
step's node fit (:mod:`.halve`); the series re-solves that follow
(:mod:`.polish`, :mod:`.joint`) keep the widths.  Measured on Blinn with
separable Smith (the shipped 31 nodes, its worst node at beta 57 deg, the
node and its intervals): the shipped series errs 0.0263 there, and
weights solved at the view nodes make a poorer series between them for
any widths near the shipped ones, so a width search with those weights
finds nothing (Nelder-Mead from the shipped widths, its error counted at
the views between the view nodes too: 0.0290).  With the node's series
solved for each trial (:func:`.polish._solve_node`: the node's
coefficients minimising its window's error, its neighbours as they are),
one member's width moved by exp(0.1) takes the same window from 0.0254
to 0.0230.

:func:`move` does that search over the nodes it is given (narrow to
wide): from the node's widths, each member with a width (not the diffuse
one) moved by +-STEPS[0] in its log multiple (members of one kind kept
in order, within the fitter's box), the best move taken where it lowers
the node's window's error by more than GAIN, until no move does; then the
same with STEPS[1].  Every trial holds each width of the window to its
error before the node moved plus ``rise`` up to 70 deg (the joint
re-solve's RISE by default) and GRAZING_RISE up to 85 deg.  The node keeps
its widths and the series of the last move.  The programme is solved at
VIEWS_DEG and GRAZING_DEG (why not at the series re-solves' views: there).
Deterministic (HiGHS, fixed steps).  About four seconds a programme (the
cutting planes started from every START-th row; every 8th, :mod:`.polish`'s
default, takes 26 s to the same optimum), a minute or two a node.

:func:`.assemble.finish_moved` runs it (SWEEPS sweeps, or as many as
it is given, each over the nodes around the widths still over the level)
and ships the result where it measures better by the halving step's rule
or comes within the bound with no width worse
(:func:`.assemble._moved_ships`); where it does not, the moved fit with
those nodes' series solved together (:mod:`.joint`), by the same rule.
"""

from __future__ import annotations

import math

import numpy as np

from . import mixtures as M
from . import polish
from .joint import GRAZING_RISE, RISE
from .polish import SampleCache

STEPS = (0.1, 0.05)  # log-multiple moves tried, coarse then fine
SWEEPS = 2           # assemble.finish_moved's default sweeps, each over the nodes erring most
GAIN = 1e-4          # a move is taken where the node's window errs less by more than this
START = 64           # the cutting planes start from every START-th row
# the views the node's programme fits at: every 2.5 deg, half way between
# neighbours of the measured views (0, 5, ..., 70 deg; those held out), and
# the ends.  At the series re-solves' views, 5 deg apart (polish.FIT_VIEWS_DEG),
# a node's series solved alone swings between them: Gaussian with separable
# Smith, its node at beta 45.8 deg, widths as shipped: 0.0249 at those views,
# 0.0262 at the measured ones and 0.0304 at these; solved at these, 0.0249 at
# all three sets
VIEWS_DEG = (0.0,) + tuple(1.25 + 2.5 * k for k in range(28)) + (70.0,)
# and beyond 70 deg every degree to 85 but the measured 75 and 80: the
# series re-solves' views there go on to 89 deg, where the error is larger,
# and a width's cap, its largest error over every view, then let its error
# at the measured views up to 85 deg rise to that (Gaussian with separable
# Smith, the node at beta 34.6 deg: 0.146 -> 0.252)
GRAZING_DEG = tuple(float(d) for d in range(71, 86) if d not in (75, 80))
VERSION = 4          # of what move computes: a kept result (build/fits) is used only by the same


def _window(fit: M.Fit, multipliers, series, j, z, get, limits=None):
    """``(error, coefficients, errors now)``: node j's series solved with
    its members' widths ``z`` (the other nodes' widths ``multipliers``,
    series ``series``), no width of its window erring more than
    ``limits`` (default: than it does now), its window's largest error up
    to 70 deg, and each window width's error (up to 70 and 85 deg) before
    the solve; ``(inf, None, None)`` where the programme has no solution
    within the limits."""
    trial = M.Fit(fit.target, fit.width_values, multipliers.copy(), fit.weights,
                  fit.node_errors)
    trial.multipliers[j] = z
    out = polish._solve_node(trial, series, j, get, start=START, views=VIEWS_DEG, limits=limits,
                              grazing=GRAZING_DEG)
    return (math.inf, None, None) if out is None else (out[1], out[0], out[2])


def _moves(target: M.Target, z, step):
    """The widths one move from ``z``: each member with a width (not the
    diffuse one) up and down by ``step``, within the fitter's box, members
    of one kind in order."""
    members = target.members
    same = [(a, b) for a in range(len(members)) for b in range(a + 1, len(members))
            if members[a] == members[b] != "diffuse"]
    out = []
    for k, kind in enumerate(members):
        if kind == "diffuse":
            continue
        for sign in (-1.0, 1.0):
            t = np.array(z, float)
            t[k] += sign * step
            if M.Z_MIN < t[k] < M.Z_MAX and all(t[a] <= t[b] - 0.05 for a, b in same):
                out.append(t)
    return out


def move(fit: M.Fit, free, log=print, rise=RISE) -> M.Fit:
    """``fit`` with the members' widths of the nodes ``free`` moved and
    their series solved again (module docstring), no width of a node's
    window rising by more than ``rise`` up to 70 deg (GRAZING_RISE up to
    85) over its error before the node moved; measured."""
    target = fit.target
    get = SampleCache(target)
    series = fit.weight_series.copy()
    multipliers = fit.multipliers.copy()
    for j in sorted(free):
        if fit.width_values[j] > target.soft_max + 1e-12:
            continue  # beyond the closures' reach: nothing a width can change
        z = multipliers[j].copy()
        err, coef, now = _window(fit, multipliers, series, j, z, get)
        if coef is None:
            log(f"  {target.key}: node {j} ({M._show(target, fit.width_values[j])}): "
                "no solution at its own widths, left as it is")
            continue
        first = err
        # no width of the window rises over its error before the node moved
        # by more than ``rise`` up to 70 deg, GRAZING_RISE up to 85
        limits = [e + (rise if k % 2 == 0 else GRAZING_RISE) for k, e in enumerate(now)]
        for step in STEPS:
            while True:
                tried = [(*_window(fit, multipliers, series, j, t, get, limits)[:2], t)
                         for t in _moves(target, z, step)]
                if not tried:
                    break
                e, c, t = min(tried, key=lambda r: r[0])
                if not e < err - GAIN:
                    break
                err, coef, z = e, c, t
        multipliers[j], series[j] = z, coef
        log(f"  {target.key}: node {j} ({M._show(target, fit.width_values[j])}): "
            f"{first:.4f} -> {err:.4f}, widths moved by {np.round(z - fit.multipliers[j], 3)}")
    out = polish.with_series(M.Fit(target, fit.width_values, multipliers, fit.weights,
                                   fit.node_errors.copy()), series)
    out.measured = M.measure(out)
    return out
