# SPDX-License-Identifier: GPL-3.0-or-later
"""Fitting mixtures of Cycles closures to the models that have no closure.

For a model variant (say the Gaussian distribution with separable Smith
shadowing) the path-traced output is a non-negative sum of closures
(:mod:`fitting.closures`), whose weights depend on the view angle and the
model's width and whose widths depend on the model's width:

    shade(wi, wo) ~ sum_k w_k(theta_o, width) C_k(wi, wo; alpha_k(width))

(the model's Fresnel factor rides on each microfacet member, so the fit is
made with F = 1).  The light direction is unknown at shading time, so the
fit cannot be exact where the model's ratio to every closure depends on it.

How a variant is fitted (:func:`fit_variant`):

1. Evenly spaced nodes in the width variable (beta, log alpha or
   log(1 + s)); Chebyshev nodes in cos(theta_o) over [cos 89 deg, 1].  The
   shaders interpolate linearly between width nodes and sum the Chebyshev
   series in the view.
2. Width nodes narrow to wide, each starting from its neighbour's solution:
   the members' widths (as log multiples of an equivalent width: Beckmann's
   m or GGX's alpha of the same beta, the native alpha, the
   Ashikhmin-Shirley alpha of the same exponent; self-similar for narrow
   lobes) are chosen by Nelder-Mead to minimise the largest error over the
   view nodes up to 70 deg; for given widths the weights at each view node
   are a linear programme: minimise the largest |mixture - model| over
   light directions up to 70 deg, at the node and half way back to the
   previous node (the interpolated mixture there, so the interval is
   fitted, not only its ends), weights >= 0, directional albedo within
   ALBEDO_TOLERANCE of the model's, plus a small pull toward the previous
   view node's weights (continuity).
3. Nodes still worse than RETRY (or next to an interval that is) are fitted
   again with both intervals, a few sweeps.
4. The interpolated mixtures are measured (:func:`measure`) at the nodes,
   between them and at random widths: largest |mixture - model| over the
   peak with views and lights up to 70 deg and up to 85 deg, and the
   largest albedo difference.  Those numbers go into the data and the docs.

Directions are sampled in half-vector space (dense around the normal, so
narrow lobes are resolved) and reflected about each half vector; albedos are
integrated in half-vector space with the Jacobian 4 (h.wo).

Deterministic: fixed starts, a seeded generator for the test widths.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from addon.core import reference as R
from addon.core import catalogue

from . import closures as C

DEG = math.pi / 180.0
FIT_VIEW = 70.0 * DEG       # the fit's domain: views and lights up to 70 deg
REPORT_VIEW = 85.0 * DEG    # also reported up to 85 deg
COS_VIEW_MIN = math.cos(89.0 * DEG)
ALBEDO_TOLERANCE = 0.008  # at the view nodes: 0.01 is the target between them
MEASURED = ("max_abs_over_peak_70", "max_abs_over_peak_85", "albedo_difference_70",
            "albedo_difference_85", "beyond_70", "bad_weights")
N_VIEW = 8
N_WIDTH = 16         # evenly spaced nodes in the width variable, linear in between
RETRY = 0.015        # nodes worse than this are fitted again with both intervals ...
SWEEPS = 2           # ... at most this many times
QUICK = bool(os.environ.get("RM_FIT_QUICK"))  # development data: 3 nodes, no retries
if QUICK:
    N_WIDTH, SWEEPS = 3, 0
MEMBERS = {
    "diffuse": lambda wi, wo, a: C.diffuse(wi, wo),
    "ggx": lambda wi, wo, a: C.microfacet(wi, wo, a, a, "ggx"),
    "beckmann": lambda wi, wo, a: C.microfacet(wi, wo, a, a, "beckmann"),
    "ashikhmin_shirley": C.ashikhmin_shirley,
}


@dataclass(frozen=True)
class Target:
    """One model variant to fit.  ``width`` names the width parameter
    (``beta``, ``alpha`` or ``exponent``) and ``domain`` its range in the
    fit variable (radians, log alpha, log(1 + s))."""
    key: str
    model: str
    enums: dict
    width: str
    members: tuple
    domain: tuple

    def params(self, value: float) -> dict:
        p = dict(self.enums)
        if self.width == "beta":
            p["beta"] = min(max(value, catalogue.BETA_MIN), catalogue.BETA_MAX)
        elif self.width == "alpha":
            p["alpha"] = min(max(math.exp(value), catalogue.ALPHA_MIN), catalogue.ALPHA_MAX)
        else:
            p["exponent"] = min(max(math.expm1(value), 0.0), 10000.0)
        return p

    @property
    def soft_max(self) -> float:
        """The widest width the closures reach (alpha 1: Cycles clamps its
        closures' alpha there); the domain goes on to the catalogue's limit."""
        if self.width == "alpha":
            return min(0.0, self.domain[1])
        return self.domain[1]

    @property
    def equivalent(self) -> str:
        """How the members' widths are scaled: by Beckmann's m or GGX's alpha
        of the same beta, by the native alpha, or by the Ashikhmin-Shirley
        alpha of the same exponent (2/alpha^2 - 2 = s)."""
        if self.width == "alpha":
            return "alpha"
        if self.width == "exponent":
            return "exponent"
        return "tr_alpha" if self.enums.get("distribution") == "trowbridge_reitz" else "beckmann_m"

    def equivalent_alpha(self, value: float) -> float:
        """The width the members' widths are multiples of."""
        if self.width == "alpha":
            return math.exp(value)
        if self.width == "exponent":
            s = math.expm1(value)
            return math.sqrt(2.0 / (s + 2.0))
        beta = self.params(value)["beta"]
        if self.enums.get("distribution") == "trowbridge_reitz":
            return float(R.tr_alpha_from_beta(beta))
        return float(R.beckmann_m_from_beta(beta))

    def lobe_width(self, value: float) -> float:
        """The angular scale of the model's lobe (radians), for sampling."""
        if self.width == "beta":
            return self.params(value)["beta"]
        if self.width == "alpha":
            return math.atan(math.exp(value))
        s = math.expm1(value)
        return math.acos(2.0 ** (-1.0 / s)) if s > 0.0 else 0.5 * math.pi


def _h_grid(scale, n_t=32, n_p=18):
    """Half vectors: tilts dense up to 5 x the lobe's scale, then to 89 deg;
    azimuths over [0, pi] (the view lies in the x-z plane: symmetric)."""
    edge = min(5.0 * scale, 1.2)
    t = np.concatenate([np.linspace(0.0, edge, n_t), np.linspace(edge, 89.0 * DEG, n_t // 2)[1:]])
    p = np.linspace(0.0, math.pi, n_p)
    T, P = np.meshgrid(t, p, indexing="ij")
    return np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)


def _gl(n, a, b):
    x, w = np.polynomial.legendre.leggauss(n)
    return a + (b - a) * 0.5 * (x + 1.0), 0.5 * (b - a) * w


def _albedo_h(scale):
    """Half vectors and weights of a quadrature of dw_h over the hemisphere,
    split at 6 x the lobe's scale (Gauss-Legendre in the tilt, midpoint in
    the azimuth over [0, pi], doubled)."""
    edge = min(6.0 * scale, 0.5 * math.pi * 0.95)
    t1, w1 = _gl(48, 0.0, edge)
    t2, w2 = _gl(32, edge, 0.5 * math.pi)
    t = np.concatenate([t1, t2])
    wt = np.concatenate([w1, w2]) * np.sin(t)
    n_p = 48
    p = (np.arange(n_p) + 0.5) * math.pi / n_p
    T, P = np.meshgrid(t, p, indexing="ij")
    W = (wt[:, None] * np.full(n_p, 2.0 * math.pi / n_p)[None, :])
    h = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    return h, W.reshape(-1)


@dataclass
class Samples:
    """For one view: light directions (fit set and albedo set), the model's
    values there, its albedo."""
    wo: np.ndarray
    wi: np.ndarray
    fit: np.ndarray      # lights up to 70 deg
    report: np.ndarray   # lights up to 85 deg
    target: np.ndarray
    albedo_wi: np.ndarray
    albedo_w: np.ndarray
    target_albedo: float
    cache: dict = field(default_factory=dict)


def samples(target: Target, value: float, cos_o: float) -> Samples:
    sin_o = math.sqrt(max(1.0 - cos_o * cos_o, 0.0))
    wo = np.array([sin_o, 0.0, cos_o])
    scale = target.lobe_width(value)
    h = _h_grid(scale)
    wi = 2.0 * (h @ wo)[:, None] * h - wo
    keep = wi[:, 2] > math.cos(REPORT_VIEW)
    wi = wi[keep]
    params = target.params(value)
    t = R.shade(target.model, wi, np.broadcast_to(wo, wi.shape), **params)[:, 0]
    ha, wa = _albedo_h(scale)
    wa = wa * 4.0 * np.abs(ha @ wo)
    wia = 2.0 * (ha @ wo)[:, None] * ha - wo
    up = wia[:, 2] > 0.0
    wia, wa = wia[up], wa[up]
    ta = R.shade(target.model, wia, np.broadcast_to(wo, wia.shape), **params)[:, 0]
    return Samples(wo, wi, wi[:, 2] >= math.cos(FIT_VIEW), np.ones(len(wi), bool), t, wia, wa,
                   float(np.sum(ta * wa)))


def _member(name, s: Samples, alpha):
    key = (name, float(alpha))
    if key not in s.cache:
        wo = np.broadcast_to(s.wo, s.wi.shape)
        woa = np.broadcast_to(s.wo, s.albedo_wi.shape)
        v = MEMBERS[name](s.wi, wo, alpha)
        a = float(np.sum(MEMBERS[name](s.albedo_wi, woa, alpha) * s.albedo_w))
        s.cache[key] = (v, a)
        if len(s.cache) > 400:
            s.cache.pop(next(iter(s.cache)))
    return s.cache[key]


ALPHA_MIN, ALPHA_MAX = 1e-3, 1.0  # Cycles clamps the closures' alpha to [1e-4, 1]


def alphas_from_multipliers(c, alpha_eq):
    """The members' widths: alpha_eq exp(c_k), within [ALPHA_MIN, ALPHA_MAX]."""
    return np.clip(alpha_eq * np.exp(np.asarray(c, float)), ALPHA_MIN, ALPHA_MAX)


def _block(s: Samples, members, alphas):
    cols = [_member(m, s, a) for m, a in zip(members, alphas)]
    A = np.nan_to_num(np.stack([c[0] for c in cols], -1))
    return A, np.array([c[1] for c in cols])


def solve_weights(s: Samples, members, alphas, previous=None, pull=1e-3, between=None):
    """The LP of one view node: weights >= 0 minimising the largest error
    over the fit set (relative to the model's peak there), albedo within
    ALBEDO_TOLERANCE, plus ``pull`` x |w - previous|.

    ``between = [(samples, alphas, fixed), ...]``: the same view half way to
    a neighbouring width node, where the shaders interpolate: the mixture
    there, with the weights (fixed + w)/2, counts in the largest error too."""
    from scipy.optimize import linprog

    A, a = _block(s, members, alphas)
    t = s.target
    mask = s.fit
    peak = max(float(t[mask].max()), 1e-30)
    # columns scaled to a peak of 1 (the LP solver's conditioning); unscaled after
    scale = np.maximum(np.abs(A[mask]).max(axis=0) / peak, 1e-12)
    Am, tm = A[mask] / (peak * scale), t[mask] / peak
    for sb, alphas_b, fixed in between or ():
        Ab, _ab = _block(sb, members, alphas_b)
        pb = max(float(sb.target[sb.fit].max()), 1e-30)
        Abm = Ab[sb.fit]
        Am = np.vstack([Am, 0.5 * Abm / (pb * scale)])
        tm = np.concatenate([tm, (sb.target[sb.fit] - 0.5 * Abm @ fixed) / pb])
    a_s = a / scale
    n, k = Am.shape
    prev = np.zeros(k) if previous is None else np.asarray(previous, float) * scale
    # variables: w (k), err, d (k: |w - prev|)
    nv = 2 * k + 1
    c = np.zeros(nv)
    c[k] = 1.0
    c[k + 1:] = pull
    rows, rhs = [], []
    Z = np.zeros((n, k))
    rows.append(np.hstack([Am, -np.ones((n, 1)), Z]))
    rhs.append(tm)
    rows.append(np.hstack([-Am, -np.ones((n, 1)), Z]))
    rhs.append(-tm)
    I = np.eye(k)
    rows.append(np.hstack([I, np.zeros((k, 1)), -I]))
    rhs.append(prev)
    rows.append(np.hstack([-I, np.zeros((k, 1)), -I]))
    rhs.append(-prev)
    rows.append(np.concatenate([a_s, [0.0], np.zeros(k)])[None, :])
    rhs.append([s.target_albedo + ALBEDO_TOLERANCE])
    rows.append(np.concatenate([-a_s, [0.0], np.zeros(k)])[None, :])
    rhs.append([-(s.target_albedo - ALBEDO_TOLERANCE)])
    x = None
    for keep in (len(rows), 4):  # without the albedo band when it cannot be met
        res = linprog(c, A_ub=np.vstack(rows[:keep]),
                      b_ub=np.concatenate([np.ravel(r) for r in rhs[:keep]]),
                      bounds=[(0, None)] * nv, method="highs")
        if res.status == 0 and res.x is not None:
            x = res.x[:k]
            break
    if x is None:  # the solver gave up: non-negative least squares instead
        from scipy.optimize import nnls
        x, _ = nnls(Am, tm)
    w = x / scale
    return w, float(np.max(np.abs(Am @ x - tm)))


def view_nodes(n=N_VIEW):
    """cos(theta_o) at the Chebyshev points of [COS_VIEW_MIN, 1]."""
    u = np.cos(math.pi * (np.arange(n) + 0.5) / n)
    return COS_VIEW_MIN + (1.0 - COS_VIEW_MIN) * 0.5 * (u + 1.0), u


def width_nodes(target: Target, n=N_WIDTH):
    """Evenly spaced nodes over the width variable's domain (beta, log alpha,
    log(1 + s)), ends included: the shaders interpolate linearly between
    them (a polynomial through per-node fits swings wherever two nodes
    settled on different mixtures)."""
    lo, hi = target.domain
    return np.linspace(lo, hi, n)


def fit_width_node(target: Target, value: float, start, views, neighbours=(), effort=30):
    """Member widths (multipliers) and the weights at every view node for one
    width; returns (multipliers, weights (n_view, K), worst error up to 70 deg).

    ``neighbours = [(value, multipliers, weights), ...]``: the neighbouring
    nodes already fitted; the mixture the shaders interpolate half way to
    each counts in the error too, so the intervals are fitted, not only
    their ends.  ``effort``: Nelder-Mead iterations per member width (0:
    the neighbour's widths as they are, only the weights fitted)."""
    from scipy.optimize import minimize

    sets = [samples(target, value, c) for c in views]
    fit_views = [i for i, c in enumerate(views) if c >= math.cos(FIT_VIEW) - 1e-12]
    alpha_eq = target.equivalent_alpha(value)
    mids = []
    for nb in neighbours:
        mid = 0.5 * (nb[0] + value)
        mids.append(([samples(target, mid, c) for c in views], target.equivalent_alpha(mid), nb))

    def solve_all(z, only=None):
        alphas = alphas_from_multipliers(z, alpha_eq)
        mid_alphas = [alphas_from_multipliers(0.5 * (np.asarray(nb[1]) + z), eq)
                      for _sets, eq, nb in mids]
        weights, errs, prev = [], [], None
        for i in range(len(sets) - 1, -1, -1):  # normal view toward grazing: continuity
            if only is not None and i not in only:
                weights.append(None)
                errs.append(0.0)
                continue
            between = [(m[0][i], ma, m[2][2][i]) for m, ma in zip(mids, mid_alphas)]
            w, e = solve_weights(sets[i], target.members, alphas, prev, between=between)
            weights.append(w)
            errs.append(e)
            prev = w
        return weights[::-1], np.array(errs[::-1])

    same = [(i, j) for i in range(len(target.members)) for j in range(i + 1, len(target.members))
            if target.members[i] == target.members[j] != "diffuse"]

    def error(z):
        if np.any(z < Z_MIN) or np.any(z > Z_MAX):
            return 10.0
        # members of one kind keep their order (the narrower first): without
        # it they trade places from one width to the next
        if any(z[i] > z[j] - 0.05 for i, j in same):
            return 10.0
        _w, errs = solve_all(z, set(fit_views))
        return float(np.max(errs[fit_views]))

    anchor = np.asarray(start, float)
    home = default_multipliers(target)

    def objective(z):  # the error, a pull toward the neighbour's widths
        # and toward the defaults (pins the width of a member that is not used)
        return error(z) + SMOOTHING * float(np.mean((z - anchor) ** 2)) \
            + PINNING * float(np.mean((z - home) ** 2))

    if not effort:  # the neighbour's widths; the weights fitted
        best = (objective(np.clip(anchor, Z_MIN + 0.1, Z_MAX - 0.1)),
                np.clip(anchor, Z_MIN + 0.1, Z_MAX - 0.1))
        starts = []
    else:
        starts = [anchor, home] + [anchor + d[:len(anchor)] for d in _KICKS]
        best = None
    for n, z0 in enumerate(starts):
        if n and best[0] < GOOD_ENOUGH:  # further starts only where the first falls short
            break
        z0 = np.clip(z0, Z_MIN + 0.1, Z_MAX - 0.1)
        f0 = objective(z0)
        if f0 < NEGLIGIBLE:  # nothing to gain
            res_fun, res_x = f0, z0
        else:
            res = minimize(objective, z0, method="Nelder-Mead",
                           options=dict(maxiter=effort * len(z0), xatol=2e-3, fatol=2e-5))
            res_fun, res_x = res.fun, res.x
        if best is None or res_fun < best[0]:
            best = (res_fun, res_x)
    weights, errs = solve_all(best[1])
    return best[1], np.array(weights), float(np.max(errs[fit_views]))


Z_MIN, Z_MAX = -4.0, 3.0  # log multipliers of the equivalent width
SMOOTHING = 2e-4
PINNING = 2e-5
GOOD_ENOUGH = 0.012  # a width node whose error is below this is not started again
HOPELESS = 0.06      # two nodes in a row above this: an approximation, not worth retries
NEGLIGIBLE = 1e-3    # nor optimised at all below this
_KICKS = [np.array(v, float) for v in ((0.7, -0.7, 0.7, -0.7), (-0.7, 0.7, -0.7, 0.7))]


def default_multipliers(target: Target):
    """Where each member's width starts (log multiples of the equivalent
    width): the first at it, the next two below and above it."""
    return np.array([0.0, -0.25, 0.3, 0.0][:len(target.members)])


def chebyshev_coefficients(values, axis):
    """DCT of values at the Chebyshev points (cos(pi (k + 1/2)/n)) along ``axis``."""
    values = np.moveaxis(np.asarray(values, float), axis, 0)
    n = values.shape[0]
    u = np.cos(math.pi * (np.arange(n) + 0.5) / n)
    T = np.polynomial.chebyshev.chebvander(u, n - 1)  # (n, n)
    c = (2.0 / n) * np.tensordot(T.T, values, axes=(1, 0))
    c[0] *= 0.5
    return np.moveaxis(c, 0, axis)


@dataclass
class Fit:
    target: Target
    width_values: np.ndarray
    multipliers: np.ndarray          # (n_width, K)
    weights: np.ndarray         # (n_width, n_view, K)
    node_errors: np.ndarray     # (n_width,)
    measured: dict = field(default_factory=dict)

    @property
    def weight_series(self):
        """(n_width, K, n_view): at each width node, each member's weight as
        Chebyshev coefficients in cos(theta_o)."""
        return chebyshev_coefficients(np.transpose(self.weights, (0, 2, 1)), 2)


def fit_variant(target: Target, log=print) -> Fit:
    """Every width node, narrow to wide, each from its neighbour's solution
    and fitted together with the interval back to it; then the nodes whose
    error (or an adjacent interval's) is above RETRY again, with both
    intervals; then measured."""
    views, _u = view_nodes()
    nodes = [float(v) for v in width_nodes(target)]
    fits = []
    effort = 30
    for j, value in enumerate(nodes):
        nb = [] if not j else [(nodes[j - 1], fits[-1][0], fits[-1][1])]
        start = default_multipliers(target) if not j else fits[-1][0]
        fits.append(fit_width_node(target, value, start, views, nb, effort))
        _log_node(target, value, fits[-1], log)
        if j and min(fits[-1][2], fits[-2][2]) > HOPELESS:
            # two nodes in a row far off: the variant's own error (a factor
            # of the light direction no mixture has) dominates as the lobe
            # widens; the widths matter little, only the weights are fitted
            effort = 0
    for _sweep in range(SWEEPS):
        # the error of each node and of the interval ahead of it, as they are now
        node_err = [_node_error(target, nodes[j], fits[j], views) for j in range(len(nodes))]
        gap_err = [_interval_error(target, (nodes[j],) + fits[j][:2],
                                   (nodes[j + 1],) + fits[j + 1][:2], views)
                   for j in range(len(nodes) - 1)] + [0.0]
        worst = [max(node_err[j], gap_err[j], gap_err[j - 1] if j else 0.0)
                 for j in range(len(nodes))]
        # (in a variant that is an approximation, nodes far above the
        # target are not retried; elsewhere every node above RETRY is)
        bad = [j for j in range(len(nodes))
               if RETRY < worst[j] and (effort or worst[j] < HOPELESS)]
        if not bad:
            break
        for j in bad:
            nb = [(nodes[i], fits[i][0], fits[i][1]) for i in (j - 1, j + 1)
                  if 0 <= i < len(nodes)]
            again = fit_width_node(target, nodes[j], fits[j][0], views, nb)
            if again[2] < worst[j]:
                log(f"  again: {worst[j]:.4f} -> {again[2]:.4f}")
                fits[j] = again
                _log_node(target, nodes[j], fits[j], log)
    fit = Fit(target, np.asarray(nodes, float), np.array([f[0] for f in fits]),
              np.array([f[1] for f in fits]), np.array([f[2] for f in fits]))
    fit.measured = measure(fit)
    return fit


def _mixture_error(target, value, alphas_at, views):
    """Largest |mixture - model| over the peak at ``value``, views and lights
    up to 70 deg; ``alphas_at(i) -> (alphas, weights)`` at view node i."""
    worst = 0.0
    for i, c in enumerate(views):
        if c < math.cos(FIT_VIEW) - 1e-12:
            continue
        s = samples(target, float(value), float(c))
        alphas, w = alphas_at(i)
        A, _a = _block(s, target.members, alphas)
        peak = max(float(s.target[s.fit].max()), 1e-30)
        worst = max(worst, float(np.max(np.abs(A[s.fit] @ w - s.target[s.fit]))) / peak)
    return worst


def _node_error(target, value, node, views):
    z, weights = node[0], node[1]
    alphas = alphas_from_multipliers(z, target.equivalent_alpha(value))
    return _mixture_error(target, value, lambda i: (alphas, weights[i]), views)


def _interval_error(target, a, b, views):
    """The error half way between nodes ``a`` and ``b`` (value, multipliers,
    weights), interpolated as the shaders do (at the view nodes)."""
    mid = 0.5 * (a[0] + b[0])
    alphas = alphas_from_multipliers(0.5 * (np.asarray(a[1]) + np.asarray(b[1])),
                                     target.equivalent_alpha(mid))
    return _mixture_error(target, mid, lambda i: (alphas, 0.5 * (a[2][i] + b[2][i])), views)


def _log_node(target, value, node, log):
    z, _w, e = node
    alphas = alphas_from_multipliers(z, target.equivalent_alpha(value))
    log(f"  {target.key} {target.width}={_show(target, value)}: max |d|/peak {e:.4f}, "
        f"alpha {np.round(alphas, 3).tolist()}")


def _show(target, value):
    if target.width == "beta":
        return f"{value / DEG:.2f} deg"
    if target.width == "alpha":
        return f"{math.exp(value):.4g}"
    return f"{math.expm1(value):.4g}"


def hats(x, nodes):
    """Weights of linear interpolation between the (increasing) ``nodes`` at x."""
    nodes = np.asarray(nodes, float)
    x = min(max(x, nodes[0]), nodes[-1])
    out = np.zeros(len(nodes))
    j = int(np.searchsorted(nodes, x, side="right")) - 1
    j = min(max(j, 0), len(nodes) - 2)
    t = (x - nodes[j]) / (nodes[j + 1] - nodes[j])
    out[j], out[j + 1] = 1.0 - t, t
    return out


def evaluate_series(fit: Fit, value: float, cos_o: float):
    """(alphas (K,), weights (K,)) at a width and a view, as the shaders
    compute them: linear between the width nodes, the series in the view."""
    tu = 2.0 * (cos_o - COS_VIEW_MIN) / (1.0 - COS_VIEW_MIN) - 1.0
    hw = hats(value, fit.width_values)
    z = hw @ fit.multipliers
    coeffs = np.tensordot(hw, fit.weight_series, axes=(0, 0))  # (K, n_view)
    w = np.array([np.polynomial.chebyshev.chebval(tu, coeffs[k]) for k in range(len(z))])
    return alphas_from_multipliers(z, fit.target.equivalent_alpha(value)), np.maximum(w, 0.0)


MEASURE_VIEWS_DEG = tuple(range(0, 86, 5))  # every 5 deg: the views measure() checks


def measure(fit: Fit, n_random=6, views_deg=MEASURE_VIEWS_DEG, seed=1) -> dict:
    """The mixture as the shaders compute it, between the nodes: largest
    |mixture - model| over the model's peak (views and lights up to 70 deg,
    and up to 85), largest albedo difference (views up to 70 and up to 85
    deg); NaN weights counted.  Widths: the nodes, a quarter, half and
    three quarters of the way between every two, and random ones.  The ``*_70`` and albedo figures are over the
    closures' range (alpha <= 1: Cycles clamps wider closures); beyond it,
    ``beyond_70``."""
    rng = np.random.default_rng(seed)
    lo, hi = fit.target.domain
    nodes = fit.width_values
    soft = fit.target.soft_max
    # the closures' limit (alpha 1) and half way to it from the last node
    # below it: the widths a midpoint between two nodes across it skips
    inside = nodes[nodes < soft - 1e-12]
    edge = [soft, 0.5 * (inside[-1] + soft)] if soft < hi and len(inside) else []
    between = [nodes[:-1] + t * (nodes[1:] - nodes[:-1]) for t in (0.25, 0.5, 0.75)]
    widths = np.sort(np.concatenate([nodes, *between, rng.uniform(lo, hi, n_random), edge]))
    worst = {"max_abs_over_peak_70": 0.0, "max_abs_over_peak_85": 0.0,
             "albedo_difference_70": 0.0, "albedo_difference_85": 0.0, "beyond_70": 0.0}
    bad = 0
    per_width = []
    for value in widths:
        rows = []
        for deg in views_deg:
            c = math.cos(deg * DEG)
            s = samples(fit.target, float(value), c)
            alphas, w = evaluate_series(fit, float(value), c)
            bad += int(np.sum(~np.isfinite(w)) + np.sum(w < 0.0))
            A, a = _block(s, fit.target.members, alphas)
            rows.append((deg, s, A @ w, abs(float(a @ w) - s.target_albedo)))
        peak70 = max(float(s.target[s.fit].max()) for d, s, _m, _a in rows if d <= 70)
        peak85 = max(float(s.target.max()) for d, s, _m, _a in rows)
        e70 = max(float(np.max(np.abs(m[s.fit] - s.target[s.fit]))) for d, s, m, _a in rows
                  if d <= 70) / peak70
        e85 = max(float(np.max(np.abs(m - s.target))) for d, s, m, _a in rows) / peak85
        da70 = max(a for d, _s, _m, a in rows if d <= 70)
        da85 = max(a for _d, _s, _m, a in rows)
        per_width.append((_show(fit.target, value), e70, e85, da85))
        if value > soft + 1e-12:
            worst["beyond_70"] = max(worst["beyond_70"], e70)
            continue
        for k, v in (("max_abs_over_peak_70", e70), ("max_abs_over_peak_85", e85),
                     ("albedo_difference_70", da70), ("albedo_difference_85", da85)):
            worst[k] = max(worst[k], v)
    return {**worst, "bad_weights": bad, "per_width": per_width}


# --------------------------------------------------------------------------
# What is fitted

BETA = (catalogue.BETA_MIN, catalogue.BETA_MAX)  # beta itself (radians)
LOG_ALPHA = (math.log(catalogue.ALPHA_MIN), math.log(catalogue.ALPHA_MAX))
LOG_EXPONENT = (0.0, math.log1p(10000.0))
MICROFACET = ("ggx", "beckmann", "beckmann", "diffuse")


def targets() -> list:
    out = []
    for dist in ("blinn", "gaussian", "trowbridge_reitz", "beckmann"):
        for sh in ("smith", "smith_correlated", "none", "vgroove", "smith_1967"):
            if sh == "smith_1967" and dist != "beckmann":
                continue
            if sh == "smith_correlated" and dist in ("trowbridge_reitz", "beckmann"):
                continue  # Cycles' own closures: exact (GGX) and near (Beckmann)
            enums = {"distribution": dist, "shadowing": sh, "fresnel": "none"}
            out.append(Target(f"microfacet/{dist}/{sh}/beta", "microfacet", enums, "beta",
                              MICROFACET, BETA))
            if dist in ("trowbridge_reitz", "beckmann"):
                out.append(Target(f"microfacet/{dist}/{sh}/alpha", "microfacet", enums, "alpha",
                                  MICROFACET, LOG_ALPHA))
    # 'energy' is the same lobe times a factor of the exponent: one fit each
    out.append(Target("blinn_phong", "blinn_phong", {"normalization": "none"}, "exponent",
                      ("ashikhmin_shirley", "ggx", "beckmann", "diffuse"), LOG_EXPONENT))
    out.append(Target("phong", "phong", {"normalization": "none"}, "exponent",
                      ("ggx", "beckmann", "beckmann", "diffuse"), LOG_EXPONENT))
    return out


def fitter_hash() -> str:
    """The fitter and the closures' transcriptions, as text."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for rel in ("fitting/mixtures.py", "fitting/closures.py"):
        h.update((root / rel).read_bytes())
    return h.hexdigest()[:16]


def fingerprint(target: Target, n=24, seed=5) -> list:
    """The model's values at fixed directions and widths: what the fit was
    made against (a change of the reference shows up here, not a change of
    its comments)."""
    rng = np.random.default_rng(seed)
    lo, hi = target.domain
    v = rng.normal(size=(2, n, 3))
    v[..., 2] = np.abs(v[..., 2]) + 0.2
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    out = []
    for k, value in enumerate(rng.uniform(lo, hi, 4)):
        sl = slice(k * n // 4, (k + 1) * n // 4)
        out += R.shade(target.model, v[0, sl], v[1, sl], **target.params(float(value)))[:, 0].tolist()
    return [float(f"{x:.12g}") for x in out]


def module_text(fits) -> str:
    """``addon/core/fits/mixtures.py``."""
    from .codegen import array, banner, number

    lines = [banner("fitting/mixtures.py", "python -m tools.fit --mixtures"),
             '"""Fitted mixtures of Cycles closures (see fitting/mixtures.py).\n\n',
             "Per fitted variant: the members (closure names), the width variable\n",
             "(beta, log alpha or log(1 + s)) and its domain, the width the members'\n",
             "widths are multiples of; at evenly spaced nodes of the width variable\n",
             "(linear in between) each member's log multiple, and each member's weight\n",
             "as Chebyshev coefficients in cos theta_o (mapped to\n",
             "2 (c - COS_VIEW_MIN)/(1 - COS_VIEW_MIN) - 1); what the interpolated\n",
             "mixtures measured against the reference between the nodes; and the\n",
             'reference values the fit was made against (its staleness test)."""\n\n',
             f"FITTER = {fitter_hash()!r}\n",
             f"QUICK = {QUICK!r}  # development data (RM_FIT_QUICK): never committed\n",
             f"COS_VIEW_MIN = {number(COS_VIEW_MIN)}\n",
             "FITS = {\n"]
    for fit in fits:
        t = fit.target
        m = fit.measured
        lines.append(f"    {t.key!r}: {{\n")
        lines.append(f"        'members': {tuple(t.members)!r},\n")
        lines.append(f"        'width': {t.width!r},\n")
        lines.append(f"        'equivalent': {t.equivalent!r},\n")
        lines.append(f"        'domain': ({number(t.domain[0])}, {number(t.domain[1])}),\n")
        lines.append(f"        'multipliers': {array(fit.multipliers, indent='            ')},\n")
        lines.append(f"        'weights': {array(fit.weight_series, indent='            ')},\n")
        lines.append("        'measured': {" + ", ".join(
            f"{k!r}: {number(m[k]) if isinstance(m[k], float) else repr(m[k])}"
            for k in MEASURED) + "},\n")
        lines.append(f"        'fingerprint': {array(fingerprint(t), indent='            ')},\n")
        lines.append("    },\n")
    lines.append("}\n")
    return "".join(lines)


def load_fits(keys) -> dict:
    """The committed fits as :class:`Fit` objects (node values recovered
    from the series), for refitting some keys and keeping the others."""
    from addon.core.fits import mixtures as data

    out = {}
    by_key = {t.key: t for t in targets()}
    for key in keys:
        d = data.FITS.get(key)
        if d is None or key not in by_key:
            continue
        t = by_key[key]
        values = width_nodes(t, len(d["multipliers"]))
        views, uv = view_nodes()
        cheb = np.polynomial.chebyshev.chebval
        multipliers = np.array(d["multipliers"])
        ws = np.array(d["weights"])  # (n_width, K, n_view)
        weights = np.array([[[cheb(u, ws[j, k]) for k in range(len(t.members))] for u in uv]
                            for j in range(len(values))])
        fit = Fit(t, values, multipliers, weights, np.zeros(len(values)))
        fit.measured = dict(d["measured"])
        out[key] = fit
    return out
