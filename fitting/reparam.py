# SPDX-License-Identifier: GPL-3.0-or-later
"""The Smith variants given as alpha, from their siblings given as beta.

Beckmann and Trowbridge-Reitz with separable Smith (and Beckmann with the
1967 bracket, below) are two variants each:
the width as the highlight half-angle beta, or as the native alpha.  At a
beta the model *is* the alpha variant at alpha(beta) (Beckmann's m or GGX's
alpha of the same beta, the fit's equivalent width), so the fits describe
one function twice.  They were made apart, and the alpha ones came out
worse where it counts: their 16 width nodes are spread over log alpha from
0.001 to 4, so thirteen fall within the closures' reach
(alpha <= 1), and the interval from alpha 0.76 to the next node at 1.32
straddles Cycles' alpha limit.  Measured (views and lights up to 70 deg,
over the peak): Beckmann in alpha 0.051 (a single lobe ships: its own fit
measured 0.233), in beta within 0.022 up to beta 62.6 deg (m 0.99);
Trowbridge-Reitz in alpha 0.078, in beta 0.031.

:func:`resampled` puts the beta fit on N_NODES evenly spaced nodes of log
alpha (the data's layout: the shaders interpolate linearly between them,
as they do any fit): at a node, the members' log multiples and their
weights at every view node are the beta fit's, interpolated as the shaders
interpolate them, at the beta whose equivalent width is the node's alpha.
The multiples are of the same equivalent width, so at those nodes the
mixture is the beta fit's.  Below beta's smallest width the beta fit's
first node stands (its members' widths then scale with alpha); the nodes
past the widest beta node within the closures' reach (its equivalent
width <= 1: beyond it the beta fit's members stop widening; Beckmann:
beta 62.6 deg, m 0.99; Trowbridge-Reitz: beta 85 deg, alpha 0.84, where
the beta domain ends) keep the alpha variant's own data, which is the same
function on 61 nodes (its 16 are every fourth).  :func:`derive` then fits
with the fitter's own node fit (:func:`.mixtures.fit_width_node`) the
nodes from there to the first at or beyond alpha 1 (1.004), and the nodes
whose directional albedo is off by more than ALBEDO_REFIT (Beckmann's beta
fit is off by 0.02 at m 0.87).  :func:`finish_derived` puts the alpha
variant's own nodes back where they err less around them
(:func:`.assemble.splice`; at the narrow widths, by 0.0002-0.0004), and
ships the result where, measured as every fit is (:func:`.mixtures.measure`)
and at the widths both measurements hold (:func:`.clamp.window_errors`),
it is better by the rule of :func:`.assemble.finish_halved`: the worst
case lower by WIDTH_SLACK, no width worse by more than WIDTH_SLACK, up to
85 deg no worse by GRAZING_SLACK, the albedo within the target or no
further off by more than ALBEDO_SLACK; then through the choice's last
step like any fit (:func:`.assemble.finish`: the joint re-solve).
Deterministic: the node fit's search starts from fixed points, and the
measurement's widths are seeded.

Also Beckmann with Smith's 1967 bracket (an approximation: its factors
per direction are not any closure's): 0.170 -> 0.126, the albedo 0.141
-> 0.024.  Not the other pairs: tried without shadowing and with the
V-groove (the albedo refit off: their albedo is off everywhere), the
resampled data measured worse (Trowbridge-Reitz 0.472 -> 0.609 and 0.275
-> 0.279; Beckmann 0.267 -> 0.269, and 0.269 either way but worse at 12
widths), their error
being a factor of the light direction no mixture carries, at alpha 1 as
elsewhere.  ``python -m tools.fit --derive``;
``make fit`` runs it last.
"""

from __future__ import annotations

import numpy as np

from . import mixtures as M

SIBLINGS = {  # variant in alpha: its sibling in beta
    "microfacet/beckmann/smith/alpha": "microfacet/beckmann/smith/beta",
    "microfacet/trowbridge_reitz/smith/alpha": "microfacet/trowbridge_reitz/smith/beta",
    "microfacet/beckmann/smith_1967/alpha": "microfacet/beckmann/smith_1967/beta",
}
N_NODES = 61  # nodes over log alpha: 0.14 apart (the beta fits' nodes are 0.1-0.2 apart in log alpha)
ALBEDO_REFIT = 0.01  # a resampled node whose albedo is off by more is fitted again
DERIVED = "resampled in log alpha from the fit in beta"  # what ``how`` says


def beta_of(target: M.Target, alpha: float) -> float:
    """The beta (radians, within the beta domain) whose equivalent width is
    ``alpha``: bisection (the equivalent width rises with beta)."""
    lo, hi = target.domain
    if alpha <= target.equivalent_alpha(lo):
        return lo
    if alpha >= target.equivalent_alpha(hi):
        return hi
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if target.equivalent_alpha(mid) < alpha else (lo, mid)
    return 0.5 * (lo + hi)


def reach(beta_fit: M.Fit) -> float:
    """The widest node of the beta fit whose equivalent width is within the
    closures' reach (alpha <= 1)."""
    t = beta_fit.target
    inside = [v for v in beta_fit.width_values if t.equivalent_alpha(float(v)) <= M.ALPHA_MAX]
    return float(inside[-1])


def resample(fit: M.Fit, n: int) -> M.Fit:
    """``fit``'s function (its data as the shaders interpolate it) at ``n``
    evenly spaced nodes of its domain: the same function where its nodes
    are among the new ones (16 nodes within 61: every fourth)."""
    values = M.width_nodes(fit.target, n)
    hw = np.array([M.hats(float(x), fit.width_values) for x in values])
    return M.Fit(fit.target, values, hw @ fit.multipliers,
                 np.tensordot(hw, fit.weights, axes=(1, 0)), np.zeros(n))


def _albedo_off(fit: M.Fit, j: int) -> float:
    """The largest directional albedo difference at node j, view nodes up to 70 deg."""
    t = fit.target
    views, _u = M.view_nodes()
    value = float(fit.width_values[j])
    out = 0.0
    for i, c in enumerate(views):
        if c < np.cos(M.FIT_VIEW) - 1e-12:
            continue
        s = M.samples(t, value, float(c))
        _A, a = M._block(s, t.members, M.alphas_from_multipliers(
            fit.multipliers[j], t.equivalent_alpha(value)))
        out = max(out, abs(float(a @ fit.weights[j, i]) - s.target_albedo))
    return out


def resampled(own: M.Fit, beta_fit: M.Fit, n: int = N_NODES) -> M.Fit:
    """``own`` (the alpha variant's data) on ``n`` nodes, those whose alpha
    the beta fit covers within the closures' reach (up to :func:`reach`'s
    equivalent width) given the beta fit's data at the beta of that alpha."""
    t, bt = own.target, beta_fit.target
    assert t.members == bt.members and t.width == "alpha" and bt.width == "beta"
    assert t.model == bt.model and t.enums == bt.enums
    out = resample(own, n)
    cover = bt.equivalent_alpha(reach(beta_fit))
    for j, x in enumerate(out.width_values):
        if np.exp(x) <= cover:
            hw = M.hats(beta_of(bt, float(np.exp(x))), beta_fit.width_values)
            out.multipliers[j] = hw @ beta_fit.multipliers
            out.weights[j] = np.tensordot(hw, beta_fit.weights, axes=(0, 0))
    return out


def derive(own: M.Fit, beta_fit: M.Fit, n: int = N_NODES, log=print) -> M.Fit:
    """The alpha variant's data from its beta sibling's fit (module
    docstring), on ``n`` nodes: :func:`resampled`, then the fitter's node
    fit where the beta fit does not reach or its albedo is off; ``own``,
    the alpha variant's data as it is, stays beyond the closures' limit."""
    t, bt = own.target, beta_fit.target
    out = resampled(own, beta_fit, n)
    values = out.width_values
    cover = bt.equivalent_alpha(reach(beta_fit))
    # the fitter's own node fit (its widths, its weights with the albedo
    # band, the intervals to the neighbours) for the nodes past the beta
    # fit's reach up to the first at or beyond alpha 1, and for those within
    # it whose albedo is off by more than ALBEDO_REFIT
    views, _u = M.view_nodes()
    past = [j for j, x in enumerate(values) if np.exp(x) > cover]
    last = next(j for j, x in enumerate(values) if x >= t.soft_max - 1e-12)
    todo = [j for j, x in enumerate(values) if np.exp(x) <= cover and _albedo_off(out, j)
            > ALBEDO_REFIT] + [j for j in past if j <= last]
    for j in sorted(todo):
        # the neighbours fitted or kept (not those fitted after this one),
        # within the closures' reach (beyond it no mixture is the model)
        nb = [(float(values[i]), out.multipliers[i], out.weights[i]) for i in (j - 1, j + 1)
              if 0 <= i < n and (i < j or i not in todo) and values[i] <= t.soft_max + 1e-12]
        z, w, e = M.fit_width_node(t, float(values[j]), out.multipliers[j - 1 if j in past
                                                                         else j], views, nb)
        out.multipliers[j], out.weights[j], out.node_errors[j] = z, w, e
        log(f"  {t.key}: node {M._show(t, values[j])} fitted: {e:.4f}")
    return out


def compare(new: M.Fit, old: M.Fit) -> list:
    """The widths within the closures' reach where ``new`` errs more than
    ``old`` by more than WIDTH_SLACK (views and lights up to 70 deg),
    measured at the widths either measurement holds, as "width (old ->
    new)"."""
    from .assemble import WIDTH_SLACK
    from .clamp import window_errors
    from .polish import SampleCache

    t = new.target
    widths = sorted({float(v) for f in (new, old) for v in _measured_widths(f)
                     if v <= t.soft_max + 1e-12})
    get = SampleCache(t)
    a, b = window_errors(old, widths, get), window_errors(new, widths, get)
    return [f"{M._show(t, v)} ({x:.4f} -> {y:.4f})" for v, x, y in zip(widths, a, b)
            if y > x + WIDTH_SLACK]


def _measured_widths(fit: M.Fit) -> list:
    """The widths :func:`.mixtures.measure` measures ``fit`` at but the random
    ones: the nodes, a quarter, half and three quarters of the way between
    every two, the closures' limit and half way to it from the last node
    below it (measure's own rule, which is in the fitter's hash: a change
    there would refit everything)."""
    nodes = fit.width_values
    between = [nodes[:-1] + s * (nodes[1:] - nodes[:-1]) for s in (0.25, 0.5, 0.75)]
    soft = fit.target.soft_max
    inside = nodes[nodes < soft - 1e-12]
    edge = [soft, 0.5 * (inside[-1] + soft)] if soft < nodes[-1] and len(inside) else []
    return list(np.concatenate([nodes, *between, edge]))


def finish_derived(fit: M.Fit, how: str, beta_fit: M.Fit, log=print) -> tuple:
    """``(fit, how)``, or the data derived from ``beta_fit`` (:func:`derive`)
    where it ships under the module docstring's rule."""
    from .assemble import SPLICE_MARGIN, better, finish, joint_step, splice

    key = fit.target.key
    new = derive(fit, beta_fit, log=log)
    # where the alpha fit's own node errs less around it, it stays
    new, kept = splice(new, resample(fit, len(new.width_values)), log=log,
                       what="the alpha fit's own node", margin=SPLICE_MARGIN)
    a, b = fit.measured, new.measured
    worse = compare(new, fit)
    said = (f"{key}: {DERIVED} ({beta_fit.target.key}): "
            f"{a['max_abs_over_peak_70']:.4f} -> {b['max_abs_over_peak_70']:.4f}, "
            f"up to 85 deg {a['max_abs_over_peak_85']:.4f} -> {b['max_abs_over_peak_85']:.4f}, "
            f"albedo {a['albedo_difference_70']:.4f} -> {b['albedo_difference_70']:.4f}")
    if not (better(new, fit, worse) and b["bad_weights"] == 0):
        log(f"  {said}; worse at {len(worse)} widths ({', '.join(worse[:3])}): not used")
        return fit, how
    log(f"  {said}: ships")
    own = f", its own nodes kept at {len(kept)}" if kept else ""
    how = f"fitted, {DERIVED} ({len(new.width_values)} nodes{own})"
    # then the choice's last step, as for any fit it runs for (the joint re-solve)
    return finish(new, how, log=log) if joint_step(fit.target) else (new, how)
