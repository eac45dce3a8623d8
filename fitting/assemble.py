# SPDX-License-Identifier: GPL-3.0-or-later
"""What ships for each variant, from the fits of :mod:`.mixtures`.

A fit can be worse than a simpler stand-in somewhere: at a width where the
mixture settled badly, or for a variant whose missing factor depends on the
light (no mixture has it).  So every variant is also given the two single
lobes of its kind at the equivalent width (Ashikhmin-Shirley for
Blinn-Phong, GGX for Trowbridge-Reitz, Beckmann otherwise):

- the *constant* lobe: one weight for every view (1 for a normalised D, the
  peak's for the unnormalised lobes): the stand-in the variant had before
  any fit;
- the *weighted* lobe: at every width and view node the weight that
  minimises the largest error there (the fitter's linear programme with one
  member), interpolated over the view like a fit's weights.

For the Smith-shadowed variants (:func:`re_solved`) the fit is first
*settled* (:mod:`.clamp`): a member that reaches Cycles' alpha limit at
one width node and not at its neighbour is moved to the limit there too,
or off it at the neighbour, and that node's weights solved again, where
the error around the two nodes falls; the settled fit replaces the fit
where it measures no worse (:func:`_no_worse`) and its worst case is lower
by WIDTH_SLACK (otherwise the fit's own re-solve may do better: Gaussian
with correlated Smith settled at 2 nodes, 0.0295 either way, re-solved
0.0259 but worse at beta 85 deg; the fit re-solved ships, 0.0264).  Then
they are also given the fit (settled or not) with its weight series
re-solved as the shaders evaluate it (:mod:`.polish`: the
members' widths kept, the Chebyshev coefficients of the weights solved for
views between the fitter's, width node by width node, no width of a node's
window allowed to err more than it did), where it measures no worse than
the fit at any width (up to 70 deg by at most WIDTH_SLACK, up to 85 deg by
at most GRAZING_SLACK: the cap holds at the views it solves at, and the
measurement is at others), its directional albedo is within the target
or at most ALBEDO_SLACK further off than the fit's, and it lowers the fit's
worst case by at least WIDTH_SLACK (a re-solve that gains nothing there
moved the other widths both ways: Blinn with correlated Smith, 0.0745
either way, measured 0.012 -> 0.015 on make demo's gonio at beta 25 deg).
The better of the fit and that one, if still worse than the target, is
*spliced*: width node by width node, the
weighted lobe's node replaces the fit's where that lowers the largest error
around the node (the node and the intervals either side, at the views the
fitter measures at, between its view nodes too).  The variant ships the
candidate with the smallest measured error; a variant whose shipped data
has no fitted node is "not fitted".  Last (:func:`finish`), a Smith variant
still over the target, or over the albedo target, and Blinn-Phong over its
0.2 (:func:`joint_step`, :func:`bound`), has the weight series of the nodes
around its worst widths solved together (:mod:`.joint`), which
ships under the re-solve's rules (no width worse by more than WIDTH_SLACK
up to 70 deg or GRAZING_SLACK up to 85, the albedo within the target or no
further off by more than ALBEDO_SLACK) where it lowers the worst case by
WIDTH_SLACK or brings the albedo within the target.  Then, for the
variants in the Makefile's HALVE (``python -m tools.fit --finish --halve
--only KEY``; about an hour a variant), a Smith variant still over its
bound (but under HOPELESS: no factor of the light direction dominating)
has its width nodes halved and the members' widths of the nodes around its
worst widths fitted again, their series then re-solved together
(:mod:`.halve`); that ships under the same rules, measured against the
halved fit (:func:`finish_halved`).  Then, for the variants in the
Makefile's MOVE (``python -m tools.fit --move --only KEY``; tried on those
two variants, it ships for Gaussian's), :func:`finish_moved` moves the
members' widths node by node, each move judged by the node's series solved
again (:mod:`.widths`), and where that does not ship by itself solves the
moved fit's series of the nodes around its worst widths together, under
the same rule.  Last, for the variants in the Makefile's EDGE (``python -m
tools.fit --edge --only KEY``), :func:`finish_edge` solves the series of
the nodes around the intervals :mod:`.bounds` measures over the bound
together again, with the lights on the domain's edge.

Reproducible like the fitter (no randomness beyond :func:`.mixtures.measure`'s
seeded widths).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from . import mixtures as M
from . import halve, joint, widths
from .clamp import settle, window_errors
from .polish import SampleCache, polish

VIEWS_DEG = M.MEASURE_VIEWS_DEG
TARGET = 0.025  # the bound (addon.core.formulas.models.FIT_BOUND)
ALBEDO_TARGET = 0.01  # the bound on the directional albedo
ALBEDO_SLACK = 0.002  # a re-solved series may move the albedo this much further off ...
GRAZING_SLACK = 0.1   # ... and the error up to 85 deg this much ...
WIDTH_SLACK = 0.002   # ... and the error up to 70 deg this much, at any width measured


def re_solved(target: M.Target) -> bool:
    """Whether :func:`choose` tries the fit with its weight series re-solved:
    the Smith-shadowed variants, which the 0.025 bound is for (the others'
    error is a factor of the light direction no weight carries)."""
    return target.enums.get("shadowing") in ("smith", "smith_correlated")


BLINN_PHONG_TARGET = 0.2  # the bound for Blinn-Phong


def bound(target: M.Target) -> float:
    """The worst case a variant's joint re-solve aims under: the issue's
    0.025 for the Smith variants, 0.2 for Blinn-Phong."""
    return BLINN_PHONG_TARGET if target.key == "blinn_phong" else TARGET


def joint_step(target: M.Target) -> bool:
    """Whether :func:`finish` runs for the variant: the Smith variants
    (:func:`re_solved`) and Blinn-Phong, the variants the issue gives a
    bound (its albedo 0.18 off before the step, 0.026 after)."""
    return re_solved(target) or target.key == "blinn_phong"


def lobe_member(target: M.Target) -> int:
    """The member the single lobe uses."""
    if target.members[0] == "ashikhmin_shirley" or "trowbridge" in target.key:
        return 0
    return 1


def _lobe_fit(target, weights):
    nodes = M.width_nodes(target)
    fit = M.Fit(target, np.asarray(nodes, float), np.zeros((len(nodes), len(target.members))),
                weights, np.zeros(len(nodes)))
    fit.measured = M.measure(fit)
    return fit


def constant_lobe(target: M.Target) -> M.Fit:
    """One weight for every view: 1 for a normalised D; for (N.H)^s and
    cos^s, which peak at 1, the peak of a lobe D/(4 cos cos) at normal
    incidence, 1/(4 pi alpha^2)."""
    nodes = M.width_nodes(target)
    views, _u = M.view_nodes()
    k = lobe_member(target)
    weights = np.zeros((len(nodes), len(views), len(target.members)))
    if target.model in ("phong", "blinn_phong"):
        weights[:, :, k] = [[4.0 * np.pi * target.equivalent_alpha(float(v)) ** 2]
                            for v in nodes]
    else:
        weights[:, :, k] = 1.0
    return _lobe_fit(target, weights)


def weighted_lobe(target: M.Target) -> M.Fit:
    """The best weight of the single lobe at every width and view node."""
    nodes = M.width_nodes(target)
    views, _u = M.view_nodes()
    k = lobe_member(target)
    weights = np.zeros((len(nodes), len(views), len(target.members)))
    for j, value in enumerate(nodes):
        alpha = [target.equivalent_alpha(float(value))]
        previous = None
        for i in np.argsort(-views):  # from normal incidence out: pulled to the last
            s = M.samples(target, float(value), float(views[i]))
            w, _err = M.solve_weights(s, [target.members[k]], alpha, previous=previous)
            weights[j, i, k] = w[0]
            previous = w
    return _lobe_fit(target, weights)


class _Window:
    """The largest error (views and lights up to 70 deg, over the peak) of a
    fit at a width node and half way to its neighbours; the model's samples
    are computed once per width and view."""

    def __init__(self, target):
        self.target = target
        self.samples = SampleCache(target)

    def error(self, fit, j):
        nodes = fit.width_values
        widths = [nodes[j]] + [0.5 * (nodes[j] + nodes[i]) for i in (j - 1, j + 1)
                               if 0 <= i < len(nodes)]
        widths = [float(v) for v in widths if v <= self.target.soft_max + 1e-12]
        return max(window_errors(fit, widths, self.samples), default=0.0)


def splice(fit: M.Fit, lobe: M.Fit, log=print, what="the weighted lobe", margin=0.0) -> tuple:
    """``(fit, replaced)``: ``fit`` with the nodes where ``lobe``'s node
    lowers the error around it by more than ``margin`` (greedy, narrow to
    wide); ``what`` names ``lobe`` in the log."""
    window = _Window(fit.target)
    multipliers, weights = fit.multipliers.copy(), fit.weights.copy()
    current = M.Fit(fit.target, fit.width_values, multipliers, weights, fit.node_errors.copy())
    replaced = []
    for j in range(len(fit.width_values)):
        before = window.error(current, j)
        trial = M.Fit(fit.target, fit.width_values, multipliers.copy(), weights.copy(),
                      current.node_errors)
        trial.multipliers[j], trial.weights[j] = lobe.multipliers[j], lobe.weights[j]
        after = window.error(trial, j)
        if after < before - margin:
            multipliers, weights = trial.multipliers, trial.weights
            current = M.Fit(fit.target, fit.width_values, multipliers, weights,
                            current.node_errors)
            replaced.append(j)
            log(f"  {fit.target.key}: node {j} {what} ({before:.4f} -> {after:.4f})")
    current.measured = M.measure(current)
    return current, replaced


def _no_worse(new: M.Fit, old: M.Fit, tie=0.0) -> bool:
    """Whether ``new`` measures no worse than ``old`` in its worst case
    (views and lights up to 70 deg; ``tie``: by up to this, for a worst
    width the step left as it was, measured again), up to 85 deg (by
    GRAZING_SLACK) and in the directional albedo (within the target or
    ALBEDO_SLACK)."""
    a, b = old.measured, new.measured
    return (b["max_abs_over_peak_70"] <= a["max_abs_over_peak_70"] + tie
            and _no_worse_beyond(new, old))


def _no_worse_beyond(new: M.Fit, old: M.Fit) -> bool:
    """:func:`_no_worse` but for the worst case up to 70 deg."""
    a, b = old.measured, new.measured
    return (b["max_abs_over_peak_85"] <= a["max_abs_over_peak_85"] + GRAZING_SLACK
            and b["albedo_difference_70"] <= max(ALBEDO_TARGET,
                                                 a["albedo_difference_70"] + ALBEDO_SLACK))


def _worse_widths(new: M.Fit, old: M.Fit, slack=WIDTH_SLACK) -> list:
    """The measured widths where ``new`` errs more than ``old`` by more than
    ``slack`` up to 70 deg or GRAZING_SLACK up to 85 deg (a minimax
    spreads the error: its worst case falls while other widths rise toward
    it), as "width (old -> new, up to 85 deg old -> new)"."""
    return [f"{a[0]} ({a[1]:.4f} -> {b[1]:.4f}, up to 85 deg {a[2]:.4f} -> {b[2]:.4f})"
            for a, b in zip(old.measured["per_width"], new.measured["per_width"])
            if b[1] > a[1] + slack or b[2] > a[2] + GRAZING_SLACK]


def _gain(new: M.Fit, old: M.Fit) -> float:
    """How much lower ``new``'s worst case (up to 70 deg) is than ``old``'s."""
    return old.measured["max_abs_over_peak_70"] - new.measured["max_abs_over_peak_70"]


JOINT = "neighbouring nodes' series re-solved together"  # what finish adds to ``how``


def _rise(new: M.Fit, old: M.Fit) -> float:
    """How much ``new``'s widths rose over ``old``'s up to 70 deg, summed
    over the measured widths (the error a trade spreads)."""
    return sum(max(0.0, b[1] - a[1])
               for a, b in zip(old.measured["per_width"], new.measured["per_width"]))


def finish(fit: M.Fit, how: str, log=print, halving=False) -> tuple:
    """``(fit, how)`` through the choice's last step, the joint re-solve
    (:func:`finish_joint`); with ``halving``, then, for a Smith variant
    still over the bound, the nodes halved (:func:`finish_halved`; ``make
    fit`` runs it for the variants in its HALVE, ``python -m tools.fit
    --finish --halve``)."""
    if JOINT not in how:
        fit, how = finish_joint(fit, how, log)
    return finish_halved(fit, how, log) if halving else (fit, how)


HALVED = "its width nodes halved, the members' widths of those around its worst widths fitted again"
HALVED_ALBEDO_WEIGHT = 10.0  # the albedo's excess in the halved fit's programme, second try
SPLICE_MARGIN = 1e-6  # a halved node put back only where it lowers the error by more (not rounding)


def _tries(new: M.Fit, old: M.Fit, whose: str, log=print) -> list:
    """``[(fit, note), ...]`` a finishing step measures by its rule:
    ``new``, and where some widths measure worse than ``old``'s, ``new``
    with ``old``'s nodes put back where they lower the error around them
    (:func:`splice`); ``whose`` names ``old``'s nodes in the note."""
    tries = [(new, "")]
    if _worse_widths(new, old):
        spliced, kept = splice(new, old, log=log, what=f"{whose} node", margin=SPLICE_MARGIN)
        if kept:
            tries.append((spliced, f" ({whose} nodes kept at {len(kept)} of "
                                   f"{len(new.width_values)})"))
    return tries


def finish_halved(fit: M.Fit, how: str, log=print) -> tuple:
    """``(fit, how)``, or, for a Smith variant (:func:`re_solved`) whose
    worst case is over the bound but under HOPELESS (no factor of the
    light direction that no closure has dominating it), the fit with its
    width nodes halved and the members' widths of the nodes around its
    worst widths fitted again (:mod:`.halve`), where that measures no worse
    than the halved fit (the same function, measured at the same widths:
    :func:`_no_worse`, no width worse by more than WIDTH_SLACK up to 70 deg
    or GRAZING_SLACK up to 85) and lowers the worst case by WIDTH_SLACK.

    Where some widths measure worse, the halved fit's own nodes are put
    back where they lower the error around them (:func:`splice`, as the
    weighted single lobe is; Blinn with separable Smith: its refitted nodes
    from beta 45 to 57 deg erred less at the fit's view nodes and more
    between them), and that is measured by the same rule.  Where the
    result fails on the albedo alone (the joint programme traded it for the
    worst case: Gaussian with separable Smith, 0.0095 -> 0.0135), its
    series are solved again with the albedo's excess costing
    HALVED_ALBEDO_WEIGHT."""
    m = fit.measured
    aim = bound(fit.target)
    if HALVED in how or not re_solved(fit.target) \
            or not aim < m["max_abs_over_peak_70"] < M.HOPELESS:
        return fit, how
    for weight in (joint.ALBEDO_WEIGHT, HALVED_ALBEDO_WEIGHT):
        halved, solved = halve.solve(fit, joint.REGION_FRACTION * aim, log=log,
                                     albedo_weight=weight)
        if solved is None:
            return fit, how
        tries = _tries(solved, halved, "the halved fit's", log)
        for out, note in tries:
            worse = _worse_widths(out, halved)
            n = out.measured
            said = (f"{HALVED}{note} (albedo weight {weight:g}): "
                    f"{m['max_abs_over_peak_70']:.4f} -> {n['max_abs_over_peak_70']:.4f}, "
                    f"albedo {m['albedo_difference_70']:.4f} -> {n['albedo_difference_70']:.4f}")
            if better(out, halved):
                log(f"  {fit.target.key}: {said}")
                return out, f"{how}, {HALVED}{note}"
            log(f"  {fit.target.key}: {said}, worse at {len(worse)} widths "
                f"({', '.join(worse[:3])}): not used")
        if not _better_in_shape(out, halved):
            break  # not the albedo alone: a dearer albedo would not make it ship
    return fit, how


MOVED = ("the members' widths of the nodes around its worst widths moved, "
         "each node's series solved again")


def finish_moved(fit: M.Fit, how: str, log=print, sweeps=widths.SWEEPS) -> tuple:
    """``(fit, how)``, or, for a Smith variant (:func:`re_solved`) still
    over the bound but under HOPELESS, the fit with the members' widths of
    the nodes around its worst widths moved, each move judged by the node's
    series solved again (:mod:`.widths`), where that ships by
    :func:`_moved_ships` (the halving step's rule, measured at the same
    widths, or a result brought within the bound with no width worse);
    where some widths measure worse, with the fit's own nodes put back
    where they lower the error around them (:func:`splice`), by the same
    rule; where that fails, the moved fit's series of the nodes around its
    worst widths solved together (:func:`_moved_and_solved`), each measured
    the same two ways; where that fails too, the search again with no
    width of a node's window allowed to rise up to 70 deg (as
    :func:`finish_joint` solves again with NO_RISE).  The search sweeps
    ``sweeps`` times (``make fit``'s MOVE: widths.SWEEPS; its MOVE_ONCE:
    one), each over the nodes around the widths still erring more than the
    level (:func:`.joint.region`).  Measured: Blinn with separable Smith,
    one sweep solved together 0.0249 (two sweeps measured 0.0264 before
    solving, and each of its solves takes two hours); Gaussian's one sweep
    solved together 0.0326, but 0.0369 at held-out widths and views, where
    two sweeps' (shipped, 0.0327) measure 0.0355 (docs/verification.md).
    Run once: a fit whose ``how`` says it was is left as it is (a second
    round, one sweep on what the first shipped, measured better and was
    not: it let the error at the views with the lower peak grow,
    docs/verification.md)."""
    m = fit.measured
    aim = bound(fit.target)
    if MOVED in how or not re_solved(fit.target) \
            or not aim < m["max_abs_over_peak_70"] < M.HOPELESS:
        return fit, how
    level = joint.REGION_FRACTION * aim
    for rise in (joint.RISE, joint.NO_RISE):
        stage = f"moved{widths.VERSION}" + ("" if rise == joint.RISE else f"-rise{rise:g}")
        moved = fit
        for _sweep in range(sweeps):  # each over the nodes around the widths still over
            free = joint.region(moved, level=level)
            moved = halve._kept(moved, level, stage,
                                functools.partial(widths.move, moved, free, log=log, rise=rise),
                                log)
        for made, what in _moved_and_solved(moved, level, stage, log):
            for out, note in _tries(made, fit, "its own", log):
                n = out.measured
                said = (f"{MOVED}{what}{note} (a width may rise by {rise:g}): "
                        f"{m['max_abs_over_peak_70']:.4f} -> {n['max_abs_over_peak_70']:.4f}, "
                        f"albedo {m['albedo_difference_70']:.4f} -> "
                        f"{n['albedo_difference_70']:.4f}")
                if _moved_ships(out, fit):
                    log(f"  {fit.target.key}: {said}")
                    return out, f"{how}, {MOVED}{what}{note}"
                worse = _worse_widths(out, fit)
                log(f"  {fit.target.key}: {said}, worse at {len(worse)} widths "
                    f"({', '.join(worse[:3])}): not used")
        if not _worse_widths(moved, fit) and _gain(moved, fit) < WIDTH_SLACK:
            break  # nothing rose: the search with less room would not gain more
    return fit, how


def _moved_ships(new: M.Fit, old: M.Fit) -> bool:
    """The rule :func:`finish_moved` ships ``new`` in place of ``old`` by:
    :func:`better` (no worse by :func:`_no_worse`, no width worse by
    :func:`_worse_widths`, the worst case lower by WIDTH_SLACK), with the
    gain waived where ``new`` is brought within the variant's bound from
    over it (:func:`bound`), however small the gain: the issue's
    bound met is the measure the WIDTH_SLACK gain stands in for (Blinn
    with separable Smith: 0.0263 -> 0.0249, no width worse)."""
    reached = new.measured["max_abs_over_peak_70"] <= bound(new.target) \
        < old.measured["max_abs_over_peak_70"]
    return (_no_worse(new, old) and not _worse_widths(new, old)
            and (reached or _gain(new, old) >= WIDTH_SLACK))


def _moved_and_solved(moved: M.Fit, level: float, stage: str, log=print):
    """``(fit, what)`` pairs :func:`finish_moved` measures, in order: the
    moved fit, then (each computed only if the one before did not ship) its
    weight series of the nodes around its worst widths solved together
    (:func:`.joint.solve`), no width allowed to rise (NO_RISE), then one
    allowed to rise by RISE: what the first ships trades no width for
    another, and a solve on Blinn's takes two hours on one core
    (Gaussian's, a quarter of an hour).  The moves solve one node's
    series with its neighbours held; the joint programme solves them
    together, and brings down the widths the moves left highest (Gaussian
    with separable Smith: its two-sweep moved fit 0.0304 with beta 73.8
    deg worse than shipped by 0.0020; solved together and its own nodes
    put back at 3 of 16, 0.0327 with no width worse)."""
    yield moved, ""
    for rise in (joint.NO_RISE, joint.RISE):
        solved = halve._kept(moved, level, f"{stage}-joint{rise:g}",
                             functools.partial(joint.solve, moved, log=log, rise=rise,
                                               level=level), log)
        if solved is not None:
            yield solved, f", {JOINT} (rise {rise:g})"


EDGE = "the series of the nodes around its intervals over the bound re-solved together " \
       "with the lights on the domain's edge"  # what finish_edge adds to ``how``
EDGE_PASSES = 3  # finish_edge's passes at most, each while the one before kept a window
TIE = 1e-9  # the fitter's worst case the same up to this: its width, away from the nodes
            # solved for, measured again differs in the last digits (0.0327, 1e-15 up)


def _width_of(target, label: str) -> tuple:
    """The width one of :func:`.mixtures.measure`'s ``per_width`` labels
    names (``mixtures._show`` the other way), and how far the label's
    rounding can put it from the width measured."""
    text = label.split()[0]
    if target.width == "beta":
        return math.radians(float(text)), math.radians(0.01)  # shown to 0.01 deg
    # four significant digits of exp(width) or expm1(width): 5e-4 of it
    return (math.log(float(text)) if target.width == "alpha" else math.log1p(float(text))), 1e-3


def _unseen_rises(new: M.Fit, old: M.Fit, none: list) -> list:
    """The widths :func:`.mixtures.measure` measures within the closures'
    range where ``new`` errs more than ``old``'s worst case (up to 70 deg,
    by more than TIE) and more than the bounds without Fresnel (``none``,
    one per interval between the width nodes, None where not measured) of
    every interval the width lies in: where the fitter's coarser measure
    finds an error that the finer one, which the status follows, does
    not; as "width (error, the intervals' bound)"."""
    worst = old.measured["max_abs_over_peak_70"] + TIE
    nodes = [float(x) for x in new.width_values]
    soft = new.target.soft_max
    out = []
    for label, e70, *_rest in new.measured["per_width"]:
        if e70 <= worst:
            continue
        x, near = _width_of(new.target, label)
        if x > soft + near:
            continue  # beyond the closures' range: not in the worst case
        seen = [b for j, b in enumerate(none)
                if b is not None and nodes[j] - near <= x <= nodes[j + 1] + near]
        if not seen or max(seen) < e70:
            out.append(f"{label} ({e70:.4f}, {max(seen, default=float('nan')):.4f})")
    return out


def finish_edge(fit: M.Fit, how: str, log=print) -> tuple:
    """``(fit, how)``, or the fit with the weight series of the nodes around
    the intervals that :func:`.bounds.intervals` measures over the bound
    without Fresnel solved together (:func:`.joint.solve`) at that
    measure's views (every 1.25 deg) and with the lights on the domain's
    edge (:func:`.bounds.edge_lights`) beside the fitter's light sets: the
    steps before it saw views 5 deg apart and the light sets alone, which
    reach the edge only here and there, where the error is often largest.
    One interval at a time, the one nearest the bound first, each from the
    series the ones before it left (the intervals' nodes at once: Gaussian
    with separable Smith's twelve took 20 minutes for two of the
    programme's rounds; one interval's four 2-5 minutes in all):
    interval j lies between nodes j and j + 1; those and one more on
    either side are solved for, every width allowed to rise by RISE at the
    programme's rows (where that was not kept, the same with no rise,
    NO_RISE, measured the same to four digits on Blinn with separable
    Smith's first interval: not tried), and so is its error under the
    Fresnel index of each class that errs most at the window's intervals
    (:func:`.bounds.worst_settings`), held there to RISE and to the bound
    from within it (without it, windows were refused because a dielectric
    interval rose: Blinn with separable Smith at beta 46-49 deg, 0.0324 ->
    0.0351; held, 0.0324 -> 0.0317 and 0.0271 -> 0.0257 without Fresnel,
    which the fitter's worst case rising 0.0249 -> 0.0257 refused until
    the rule below let it rise where the bounds see it).  A
    window is kept where
    :func:`.bounds.intervals` (its edge lights at whole degrees of azimuth,
    the programme's half-way between), at the intervals its nodes reach,
    finds its interval without Fresnel lower, no interval of any Fresnel
    class risen from the fit's own by more than WIDTH_SLACK or gone over
    the bound from within it, and :func:`.mixtures.measure` finds it no
    worse up to 85 deg and in the albedo (:func:`_no_worse_beyond`) and no
    width over the fit's worst case up to 70 deg that the bounds after the
    window put lower (:func:`_unseen_rises`: the fitter's worst case may
    rise only where the bounds, which the status follows, see the rise;
    the rule that it may not rise at all refused windows that brought
    their intervals within the bound: Blinn with separable Smith at beta
    51-54 deg, 0.0281 -> 0.0230, the fitter's worst 0.0249 -> 0.0255 at
    the node at 57 deg, which the bounds put at 0.0255 and 0.0291 on
    either side).  Width by width, the
    interval's rule stands in for :func:`_worse_widths`: :mod:`.bounds`
    measures each interval at more views than the fitter's measure, and on
    the edge, and it is what the status follows (Gaussian with separable
    Smith, its interval at beta 29-35 deg: 0.0257 -> 0.0221, while the
    fitter's light set saw beta 36-44 deg rise by up to 0.0047, to 0.0278,
    where the bounds measured 0.0271-0.0299 before and 0.0278-0.0299
    after).  Then, while a pass kept a window and up to EDGE_PASSES
    passes, the same again from what it left, each pass's rules measured
    from its own start, so a Fresnel class's interval may rise by
    WIDTH_SLACK a pass (Blinn with separable Smith: the second pass kept
    the window at beta 77-79 deg that the first had refused, and with it
    every interval came within the bound without Fresnel; the dielectric
    interval at 79-82 deg rose 0.0029 over the two passes, 0.1685 ->
    0.1715, approx there, where one pass alone refused that rise).
    ``make fit`` runs it for the variants in its EDGE, after the moves."""
    if EDGE in how or not re_solved(fit.target):
        return fit, how
    current = fit
    for _ in range(EDGE_PASSES):
        passed = _edge_pass(current, log)
        if passed is current:
            break
        current = passed
    if current is fit:
        return fit, how
    return current, f"{how}, {EDGE}"


def _edge_pass(fit: M.Fit, log) -> M.Fit:
    """One pass of :func:`finish_edge` over the intervals over the bound:
    the fit its kept windows left, or ``fit`` itself where none was kept."""
    from . import bounds
    aim = bound(fit.target)
    picked = {}  # each interval's worst Fresnel indices, for ``current``
    before = bounds.intervals(fit, picked=picked)
    over = [j for j, e in enumerate(before["none"]) if e is not None and e > aim]
    n = len(fit.width_values)
    now, current = {cls: list(v) for cls, v in before.items()}, fit
    tried = set()
    while True:
        left = [j for j in over if j not in tried and now["none"][j] > aim]
        if not left:
            break
        j = min(left, key=lambda i: now["none"][i])
        tried.add(j)
        free = {i for i in range(j - 1, j + 3) if 0 <= i < n}
        reach = set(range(max(0, min(free) - 1), min(n - 1, max(free) + 1)))
        solved = joint.solve(current, free=free, log=log, views=bounds.VIEWS_DEG,
                             edge=bounds.edge_lights(offset=0.5), bound=aim,
                             fresnel=bounds.worst_settings(current, reach, picked))
        if solved is None:
            continue
        picked_after = {}
        after = bounds.intervals(solved, only=reach, picked=picked_after)
        rose = [(cls, k, round(before[cls][k], 5), round(after[cls][k], 5))
                for cls in bounds.CLASSES for k in sorted(reach)
                if before[cls][k] is not None
                and (after[cls][k] > before[cls][k] + WIDTH_SLACK
                     or before[cls][k] <= aim < after[cls][k])]
        old, new = now["none"][j], after["none"][j]
        said = (f"{EDGE}, interval {j}: without Fresnel {old:.4f} -> {new:.4f}, measured "
                f"{fit.measured['max_abs_over_peak_70']:.4f} -> "
                f"{solved.measured['max_abs_over_peak_70']:.4f}")
        unseen = _unseen_rises(solved, fit, [after["none"][k] if k in reach else e
                                             for k, e in enumerate(now["none"])])
        if new < old and not rose and not unseen and _no_worse_beyond(solved, fit):
            log(f"  {fit.target.key}: {said}")
            current = solved
            picked.update(picked_after)
            for cls in bounds.CLASSES:
                for k in reach:
                    now[cls][k] = after[cls][k]
        else:
            log(f"  {fit.target.key}: {said}, risen {rose[:3]}, over the bounds "
                f"{unseen[:3]}: not used")
    return current


def left_as_they_were(chosen: dict, committed: dict, shipped: dict) -> list:
    """The variants a finishing step left as they were: ``chosen[key] =
    (fit, how)`` with the committed fit's node values (``committed``, as
    :func:`.mixtures.load_fits` gives them) and the committed words
    (``shipped``).  Their committed text is kept
    (:func:`.codegen.keep_entries`); the words alone would not do (a step
    run again on changed data can ship new data in the same words)."""
    def same(a, b):
        return (a.multipliers.shape == b.multipliers.shape and a.weights.shape == b.weights.shape
                and np.array_equal(a.multipliers, b.multipliers)
                and np.array_equal(a.weights, b.weights))
    return [k for k, (fit, how) in chosen.items()
            if k in committed and how == shipped[k] and same(fit, committed[k])]


def better(new: M.Fit, old: M.Fit, worse=None) -> bool:
    """The rule :func:`finish_halved` (and :func:`.reparam.finish_derived`)
    ships ``new`` in place of ``old`` by: :func:`_better_in_shape` and
    :func:`_no_worse` (the albedo too).  ``worse``: the widths where
    ``new`` errs more, where the two are not measured at the same widths
    (default :func:`_worse_widths`)."""
    return _better_in_shape(new, old, worse) and _no_worse(new, old)


def _better_in_shape(new: M.Fit, old: M.Fit, worse=None) -> bool:
    """Everything :func:`finish_halved` asks of ``new`` against ``old`` but
    the albedo: the worst case lower by WIDTH_SLACK, no width worse
    (``worse``, default :func:`_worse_widths`), up to 85 deg no worse by
    GRAZING_SLACK."""
    worse = _worse_widths(new, old) if worse is None else worse
    return (_gain(new, old) >= WIDTH_SLACK and not worse
            and new.measured["max_abs_over_peak_85"]
            <= old.measured["max_abs_over_peak_85"] + GRAZING_SLACK)


def finish_joint(fit: M.Fit, how: str, log=print) -> tuple:
    """``(fit, how)``, or the fit with the weight series of the nodes around
    its worst widths solved together (:mod:`.joint`) where that measures no
    worse (:func:`_no_worse`, and no width worse than WIDTH_SLACK up to 70
    deg or GRAZING_SLACK up to 85) and lowers the worst case by WIDTH_SLACK
    or brings the directional albedo within the target (WIDTH_SLACK in
    proportion to the variant's :func:`bound`: 0.002 of 0.025, 0.016 of
    Blinn-Phong's 0.2); where the programme's
    widths were allowed to rise by RISE and some measured width rose by more
    than WIDTH_SLACK, solved again with no rise allowed (NO_RISE).

    One trade is accepted in place of the rule against a width rising (the
    trade): a result that brings the directional albedo within the target
    from beyond it *and* lowers the worst case, the issue's two measures
    both better, ships though some widths rose (never above the new worst
    case, which is lower than the old); of two such, the one whose widths
    rose least in sum.  Each risen width is logged."""
    m = fit.measured
    aim = bound(fit.target)
    slack = WIDTH_SLACK * aim / TARGET  # in proportion to the bound (0.016 for Blinn-Phong)
    if m["max_abs_over_peak_70"] <= aim and m["albedo_difference_70"] <= ALBEDO_TARGET:
        return fit, how
    trades = []
    for rise in (joint.RISE, joint.NO_RISE):
        solved = joint.solve(fit, log=lambda _msg: None, rise=rise,
                             level=joint.REGION_FRACTION * aim)
        if solved is None:
            break
        worse = _worse_widths(solved, fit, slack)
        n = solved.measured
        albedo_in = n["albedo_difference_70"] <= ALBEDO_TARGET < m["albedo_difference_70"]
        gain = _gain(solved, fit)
        said = (f"{JOINT} (rise {rise}): {m['max_abs_over_peak_70']:.4f} -> "
                f"{n['max_abs_over_peak_70']:.4f} (the programme's optimum "
                f"{solved.programme_worst:.4f}), albedo {m['albedo_difference_70']:.4f} -> "
                f"{n['albedo_difference_70']:.4f}")
        if _no_worse(solved, fit) and not worse and (gain >= slack or albedo_in):
            log(f"  {fit.target.key}: {said}")
            return solved, f"{how}, {JOINT}"
        if _no_worse(solved, fit) and albedo_in and gain > 0.0:
            trades.append((_rise(solved, fit), rise, solved, worse, said))
            log(f"  {fit.target.key}: {said}, worse at {len(worse)} widths "
                f"({', '.join(worse)}): a trade for the albedo")
            continue
        log(f"  {fit.target.key}: {said}, worse at {len(worse)} widths "
            f"({', '.join(worse[:3])}): not used")
    if trades:
        _spread, rise, solved, worse, said = min(trades, key=lambda t: t[0])
        log(f"  {fit.target.key}: ships the trade of rise {rise}: {said}")
        n = len(worse)
        return solved, (f"{how}, {JOINT}, the albedo brought within {ALBEDO_TARGET} for a "
                        f"rise at {n} width{'s' if n != 1 else ''}")
    return fit, how


def choose(target: M.Target, fit, log=print) -> tuple:
    """``(shipped Fit, how)`` for one variant: the candidate of smallest
    measured error (views and lights up to 70 deg); ``how`` says what it is."""
    candidates = [(constant_lobe(target), "single lobe"),
                  (weighted_lobe(target), "single lobe, weighted by view")]
    if fit is not None:
        fit.measured = M.measure(fit)  # as measured now (the fit may be older than measure)
        fit_how = "fitted"
        if re_solved(target):
            settled, moved = settle(fit, log)
            if moved and _no_worse(settled, fit) and _gain(settled, fit) >= WIDTH_SLACK:
                fit = settled
                fit_how = (f"fitted, a member moved to Cycles' alpha limit at {len(moved)} of "
                           f"{len(fit.width_values)} widths")
            polished = polish(fit, log=lambda _msg: None)
            worse = _worse_widths(polished, fit)
            gain = _gain(polished, fit)
            if _no_worse(polished, fit) and not worse and gain >= WIDTH_SLACK:
                candidates.append((polished, f"{fit_how}, its weight series re-solved"))
            else:  # closer in shape, further in albedo or at grazing views: not shipped
                log(f"  {target.key}: re-solved series "
                    f"{polished.measured['max_abs_over_peak_70']:.4f} (the fit's worst case "
                    f"lower by {gain:.4f}), albedo "
                    f"{polished.measured['albedo_difference_70']:.4f}, up to 85 deg "
                    f"{polished.measured['max_abs_over_peak_85']:.4f}, worse than the fit at "
                    f"{len(worse)} widths ({', '.join(worse[:3])}): not used")
        candidates.insert(2, (fit, fit_how))
        base, base_how = min(candidates[2:], key=lambda c: c[0].measured["max_abs_over_peak_70"])
        if base.measured["max_abs_over_peak_70"] > TARGET:
            spliced, replaced = splice(base, candidates[1][0], log)
            if replaced:
                n = len(fit.width_values)
                candidates.append((spliced, f"{base_how}; the weighted single lobe at "
                                            f"{len(replaced)} of {n} widths"))
    for c, how in candidates:
        log(f"  {target.key}: {how}: {c.measured['max_abs_over_peak_70']:.4f}")
    best, how = min(candidates, key=lambda c: c[0].measured["max_abs_over_peak_70"])
    if joint_step(target) and not how.startswith("single lobe"):
        best, how = finish(best, how, log)
    if how.startswith("single lobe"):
        how += ("; no fit has run" if fit is None else
                f"; the fit measured {fit.measured['max_abs_over_peak_70']:.3g}")
    return best, how
