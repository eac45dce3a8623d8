# SPDX-License-Identifier: GPL-3.0-or-later
"""Re-solving every width node's weight series at once.

:mod:`.polish` re-solves the weight series one width node at a time, each
against its neighbours' series as they are, under a cap that no width of
the node's window err more than it does now.  Where the worst width lies
between two nodes and both have to move together to lower it (Gaussian
with correlated Smith: 0.0264 at beta 83.6 deg, three quarters of the way
from the node at 79.4 deg to the one at 85 deg, its weights swinging
between 0.37 and 1.05 over the view), a node alone cannot lower it without
raising a width it shares with its other neighbour.

:func:`solve` keeps the members' widths and solves for the Chebyshev
coefficients of every node's weights together, in one linear programme:

- only the nodes around the widths that err near the variant's bound
  (0.025 for the Smith variants, 0.2 for Blinn-Phong) or whose albedo is
  near the 0.01 bound (:func:`region`) are solved for, the others kept;
- minimise the largest |mixture - model| over the peak, at every width of
  a dense set (the nodes and every eighth of the way between two), at views
  between the ones :func:`.mixtures.measure` checks
  (:data:`.polish.FIT_VIEWS_DEG`: its views are held out) and lights up to
  70 deg;
- plus SPREAD times the mean of the widths' own errors (a pure minimax
  lets every width rise to the worst one's error), and VIEW_SPREAD times
  the mean of each width's error at each view (else every view of a width
  may rise to its worst view's error: Trowbridge-Reitz with separable
  Smith at beta 25 deg went from 0.004-0.010 at views to 45 deg, 0.029 at
  70, to 0.023-0.028 at all of them);
- no width errs more than it does now by more than RISE, up to 70 deg, or
  GRAZING_RISE up to 85 deg (views every degree from 71 to 89 but the
  measured ones, lights up to 85 deg); widths beyond the closures' reach
  (alpha > 1, Trowbridge-Reitz in alpha) are held to that and count in
  neither the worst case nor the albedo (only in the secondary means);
- the directional albedo within ALBEDO_BAND of the model's at every view
  of the programme, or beyond it at a cost: ALBEDO_WEIGHT per unit of the
  largest excess over all widths, and ALBEDO_WEIGHT / W per unit of each
  width's own excess at views up to 70 deg (with the largest alone, once
  one width was off the others could drift off up to it at no cost:
  Gaussian with separable Smith 0.0124, Trowbridge-Reitz in beta 0.0137);
- the weights non-negative at every node and every view of
  :data:`.polish.POSITIVE_DEG` (the shaders interpolate the nodes'
  weights linearly in the width, so they stay non-negative between).

Where the present series' weights are non-negative, it satisfies every
constraint, so the programme is feasible and its optimum is no worse than
what the fit has at the widths and views it solves at (where they dip
below 0 the programme may fail: :func:`solve` returns ``None``);
:func:`.assemble.finish` measures the result at the held-out views and
ships it only where it measures better.

:func:`.assemble.finish_edge` solves it at :mod:`.bounds`' views (every
1.25 deg, ``views``) and with lights on the domain's edge at 70 deg
(``edge``) beside the fitter's light sets, which reach that edge only
here and there, though the error is often largest on it; and with the
error under a few Fresnel indices held (``fresnel``: rows as
:mod:`.bounds` measures them, each member's values scaled by F, none of
them priced, each width's error under each F kept from rising by more
than RISE).

The programme has up to millions of rows (widths x views x lights); it is
solved by cutting planes over rows generated from per-(width, view)
blocks, the rows that bind being few.  Deterministic (HiGHS's simplex,
a fixed seed): the same fit gives the same series, but the programme is
degenerate, so a fit changed in its last digits (a round trip through the
committed data) can give another series of the same optimum.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from addon.core import reference as R
from addon.core.formulas import library as L

from . import mixtures as M
from .polish import FIT_VIEWS_DEG, GRAZING_DEG, POSITIVE_DEG, SampleCache, _cheb_row, with_series

BETWEEN = tuple(k / 8.0 for k in range(1, 8))  # where between two nodes the error counts
SPREAD = 0.5          # the mean of the widths' own errors, a secondary term ...
VIEW_SPREAD = 0.5     # ... and the mean of their errors view by view
RISE = 0.001          # a width's error up to 70 deg may rise by this (half what
                      # assemble.finish allows, measured at other views) ...
GRAZING_RISE = 0.01   # ... and up to 85 deg by this
NO_RISE = 1e-5        # no rise, up to HiGHS's tolerances (0 exactly can fail as infeasible)
ALBEDO_BAND = 0.009   # the albedo's difference allowed at no cost (0.01: the target) ...
ALBEDO_WEIGHT = 1.0   # ... and what its excess costs
ROUNDS = 60           # cutting-plane rounds at most
ADD_PER_BLOCK = 3     # violated rows added per block and round
INITIAL_PER_BLOCK = 2  # rows per block the first programme starts from
REGION_FRACTION = 0.9  # widths erring more than this fraction of the bound ...
REGION = REGION_FRACTION * 0.025  # ... (0.025, the Smith variants') are worked on ...
ALBEDO_LEVEL = 0.0098  # ... or whose albedo is further off than this (views to 70 deg)


def _widths(fit):
    nodes = fit.width_values
    soft = fit.target.soft_max
    out = {float(v) for v in nodes}
    for a, b in zip(nodes[:-1], nodes[1:]):
        out |= {float(a + t * (b - a)) for t in BETWEEN}
    if soft < nodes[-1]:
        out.add(float(soft))
    return sorted(out)


def at_lights(target, value, wo, alphas, wi):
    """At lights ``wi`` (n x 3) and one view ``wo``: each member's value at
    its width ``alphas`` (n x members, as :func:`.mixtures._block` gives
    them) and the model's (the lights on the domain's edge, which the
    fitter's light sets reach only here and there)."""
    wo = np.broadcast_to(wo, wi.shape)
    A = np.nan_to_num(np.stack([M.MEMBERS[k](wi, wo, a) for k, a in zip(target.members, alphas)],
                               -1))
    return A, R.shade(target.model, wi, wo, **target.params(value))[:, 0]


def with_edge(target, value, s, A, alphas, edge):
    """The lights of the sample set ``s`` up to 70 deg and the lights
    ``edge`` on the domain's edge: their directions, the members' values
    (``A``: at ``s``' lights, as :func:`.mixtures._block` gives them) and
    the model's."""
    A_edge, t_edge = at_lights(target, value, s.wo, alphas, edge)
    return (np.concatenate([s.wi[s.fit], edge]), np.concatenate([A[s.fit], A_edge]),
            np.concatenate([s.target[s.fit], t_edge]))


class _FresnelRows(NamedTuple):
    """Under one Fresnel, at one view: the lifted rows, the model less the
    fixed nodes' part, and the model's peak there."""
    lifted: np.ndarray
    target: np.ndarray
    peak: float


class _View(NamedTuple):
    """One view of one width, as :class:`_Blocks` builds its rows: the
    lifted matrices (the mixture's values at the sample set's lights, and
    up to 70 deg with the edge's), the albedo row, each target less the
    fixed nodes' part, the model's peak up to 70 deg, and per Fresnel its
    lifted rows, target and peak."""
    deg: float
    s: object
    lifted: np.ndarray
    lifted70: np.ndarray
    albedo_row: np.ndarray
    target: np.ndarray
    target70: np.ndarray
    peak70: float
    albedo: float
    with_fresnel: list


class _Blocks:
    """The programme's error rows, block by block: per (width, view) the
    matrix of the mixture at its lights as a linear map of the free nodes'
    coefficients (the other nodes' part moved to the right-hand side),
    scaled by the width's peak."""

    def __init__(self, fit, series, get, free, views=FIT_VIEWS_DEG, edge=None, fresnel=()):
        target = fit.target
        nodes = fit.width_values
        self.K, self.N = series.shape[1], series.shape[2]
        K, N = self.K, self.N
        self.widths = [v for v in _widths(fit) if any(M.hats(v, nodes)[j] > 0 for j in free)]
        self.used = used = sorted(free)
        col0 = {j: n * K * N for n, j in enumerate(used)}
        self.n_coef = len(used) * K * N
        W = len(self.widths)
        # beyond the closures' reach (alpha 1) a width is only kept from
        # getting worse: it counts in neither the worst case nor the albedo
        self.inside = [v <= target.soft_max + 1e-12 for v in self.widths]
        # columns: coefficients, e70 per width, e85 per width, T, albedo
        # excess (the largest), albedo excess per width (views to 70 deg),
        # the error per width of each Fresnel of ``fresnel`` (views to 70
        # deg), then one error per block (a width at a view, or with a
        # Fresnel), each at most its width's
        self.E70 = self.n_coef
        self.E85 = self.n_coef + W
        self.T = self.n_coef + 2 * W
        self.ALB = self.T + 1
        self.ALBW = self.ALB + 1
        self.EF = self.ALBW + W
        self.n_fresnel = len(fresnel)
        self.BLOCK = self.EF + self.n_fresnel * W
        diffuse = list(target.members).index("diffuse") if fresnel else None
        fresnel_blocks = []  # as blocks, their error columns set below
        self.blocks = []   # (cols, matrix (L, cols) scaled, target less the fixed part,
                           #  its error column, its width's error column)
        self.albedo = []   # (width, view, cols, row, target albedo less the fixed part)
        for w_i, value in enumerate(self.widths):
            hw = M.hats(value, nodes)
            js = [int(j) for j in np.nonzero(hw)[0] if j in col0]
            rest = [int(j) for j in np.nonzero(hw)[0] if j not in col0]
            cols = np.concatenate([np.arange(col0[j], col0[j] + K * N) for j in js])
            alphas = M.alphas_from_multipliers(hw @ fit.multipliers,
                                               target.equivalent_alpha(value))
            sets = []
            for deg in tuple(views) + GRAZING_DEG:
                s = get(value, deg)
                A, a = M._block(s, target.members, alphas)
                wi70, A70, t70 = s.wi[s.fit], A[s.fit], s.target[s.fit]
                if edge is not None and deg <= 70:  # the lights on the domain's edge too
                    wi70, A70, t70 = with_edge(target, value, s, A, alphas, edge)
                T = _cheb_row(deg, N)

                def lifted(B):
                    return np.concatenate([hw[j] * (B[:, :, None] * T[None, None, :])
                                           .reshape(len(B), K * N) for j in js], axis=1)

                aT = np.concatenate([hw[j] * (a[:, None] * T[None, :]).reshape(K * N) for j in js])
                w_fixed = sum((hw[j] * (series[j] @ T) for j in rest), np.zeros(K))
                with_fresnel = []  # per Fresnel, its rows
                if deg <= 70:
                    for F in fresnel:
                        Fm, S = _fresnel_scales(F, wi70, s.wo, deg, K, diffuse)
                        with_fresnel.append(_FresnelRows(lifted(A70 * S),
                                                         Fm * t70 - (A70 * S) @ w_fixed,
                                                         float(np.max(Fm * t70))))
                sets.append(_View(deg, s, lifted(A), lifted(A70), aT, s.target - A @ w_fixed,
                                  t70 - A70 @ w_fixed, float(t70.max()),
                                  s.target_albedo - float(a @ w_fixed), with_fresnel))
            near = [v for v in sets if v.deg <= 70]
            peak70 = max(v.peak70 for v in near)
            peak85 = max(float(v.s.target.max()) for v in sets)
            peaks = [max(v.with_fresnel[f].peak for v in near) for f in range(self.n_fresnel)]
            for v in sets:
                if v.deg <= 70:
                    self.blocks.append((cols, v.lifted70 / peak70, v.target70 / peak70,
                                        self.BLOCK + len(self.blocks), self.E70 + w_i))
                self.blocks.append((cols, v.lifted / peak85, v.target / peak85,
                                    self.BLOCK + len(self.blocks), self.E85 + w_i))
                for f, rows in enumerate(v.with_fresnel):
                    fresnel_blocks.append((cols, rows.lifted / peaks[f], rows.target / peaks[f],
                                           self.EF + f * W + w_i))
                if self.inside[w_i]:
                    self.albedo.append((w_i, v.deg, cols, v.albedo_row, v.albedo))
        first = self.BLOCK + len(self.blocks)
        self.fresnel_blocks = [(cols, Mx, t, first + b, e)
                               for b, (cols, Mx, t, e) in enumerate(fresnel_blocks)]
        self.nv = first + len(self.fresnel_blocks)

    def x_of(self, series):
        x = np.zeros(self.nv)
        for n, j in enumerate(self.used):
            x[n * self.K * self.N:(n + 1) * self.K * self.N] = series[j].ravel()
        return x

    def errors(self, x):
        """Each width's error up to 70 and up to 85 deg at ``x``'s
        coefficients, and its largest albedo difference at views up to 70
        deg (what the 0.01 target is measured at)."""
        W = len(self.widths)
        out = np.zeros(2 * W)
        for cols, Mx, t, _b, e in self.blocks:
            r = float(np.max(np.abs(Mx @ x[cols] - t)))
            out[e - self.E70] = max(out[e - self.E70], r)
        albedo = np.zeros(W)
        for w, deg, cols, aT, ta in self.albedo:
            if deg <= 70:
                albedo[w] = max(albedo[w], abs(float(aT @ x[cols]) - ta))
        return out[:W], out[W:], albedo

    def fresnel_errors(self, x):
        """Per Fresnel of the programme (rows) each width's error at views
        up to 70 deg, over the peak of the model with that Fresnel."""
        W = len(self.widths)
        out = np.zeros((self.n_fresnel, W))
        for cols, Mx, t, _b, e in self.fresnel_blocks:
            f, w = divmod(e - self.EF, W)
            out[f, w] = max(out[f, w], float(np.max(np.abs(Mx @ x[cols] - t))))
        return out


def fresnel_cosines(wi, wo, cos_view):
    """Where a mixture's Fresnel is taken, as :mod:`.bounds` measures it:
    L.H for each light ``wi`` (n x 3; the model's and every microfacet
    member's, each at its own half vector, the same one) and, for the
    diffuse member, which has none, the mean L.H of the lights the view
    reflects (:func:`addon.core.formulas.library.mean_light_half_cosine`)."""
    h = wi + wo
    h = h / np.linalg.norm(h, axis=1, keepdims=True)
    return np.clip(np.sum(wi * h, 1), 0.0, 1.0), L.mean_light_half_cosine(cos_view)


def _fresnel_scales(F, wi, wo, deg, K, diffuse):
    """What the Fresnel ``F`` scales the model by, per light, and each
    member's value, per light (rows) and member (columns; ``diffuse`` the
    diffuse member's), at :func:`fresnel_cosines`."""
    cd, cbar = fresnel_cosines(wi, wo, math.cos(math.radians(deg)))
    model = F(cd)
    S = np.repeat(model[:, None], K, axis=1)
    S[:, diffuse] = F(np.array(cbar))
    return model, S


def _add_rows(h, rows, upper):
    """Rows ``rows @ x <= upper`` (a scipy sparse matrix) into HiGHS."""
    import highspy

    rows = rows.tocsr()
    n = rows.shape[0]
    h.addRows(n, np.full(n, -highspy.kHighsInf), np.asarray(upper, float), rows.nnz,
              rows.indptr[:-1].astype(np.int32), rows.indices.astype(np.int32),
              rows.data.astype(float))


def region(fit: M.Fit, level=REGION, get=None):
    """The nodes worth solving for: those of every width (of the
    programme's set) that errs more than ``level`` now, or whose albedo is
    further off than ALBEDO_LEVEL, and one more on either side."""
    get = get or SampleCache(fit.target)
    everything = _Blocks(fit, fit.weight_series, get, range(len(fit.width_values)))
    e70, _e85, albedo = everything.errors(everything.x_of(fit.weight_series))
    nodes = fit.width_values
    free = set()
    for v, inside, e, a in zip(everything.widths, everything.inside, e70, albedo):
        if inside and (e > level or a > ALBEDO_LEVEL):
            for j in np.nonzero(M.hats(v, nodes))[0]:
                free |= {int(i) for i in (j - 1, j, j + 1) if 0 <= i < len(nodes)}
    return free


def solve(fit: M.Fit, free=None, log=print, rise=RISE, level=REGION, cap=None,
          albedo_weight=ALBEDO_WEIGHT, views=FIT_VIEWS_DEG, edge=None, fresnel=(), bound=None,
          get=None, measure=True):
    """``fit`` with the weight series of the nodes ``free`` (default:
    :func:`region`) solved together (module docstring), measured; ``None``
    where the programme fails or there is nothing to solve.  ``rise``: how
    much a width's error up to 70 deg may rise (RISE); ``level``: the
    error above which a width's nodes are free, with ``free`` not given;
    ``cap``: a bound on the worst case (every width's error up to 70 deg
    at most this), which the albedo terms then pay for; ``albedo_weight``:
    what a unit of the albedo's excess costs (ALBEDO_WEIGHT); ``fresnel``:
    Fresnel functions F(cos) under each of which, as :mod:`.bounds`
    measures it, no width's error at views up to 70 deg may rise by more
    than ``rise``, nor past ``bound`` from within it (the model's Fresnel
    rescales the members' errors light by light, and the diffuse member's
    by one F per view: a series solved without it let the error with a
    dielectric rise, Blinn with separable Smith at beta 46-49 deg 0.0324
    -> 0.0351).  ``get``: a :class:`.polish.SampleCache` of the fit's
    target to take the model's samples from (a new one if not given);
    ``measure=False`` leaves the result unmeasured (``measured`` empty:
    :func:`.mixtures.measure` samples the whole width range, most of the
    time of a solve of one node), for a caller that reads only the series."""
    import highspy
    import scipy.sparse as sp

    target = fit.target
    series = fit.weight_series.copy()
    if get is not None and get.target is not target:
        raise ValueError("get: a SampleCache of the fit's own target")
    get = get or SampleCache(target)
    free = region(fit, level=level, get=get) if free is None else set(free)
    if not free:
        return None
    log(f"  {target.key}: joint re-solve of nodes {sorted(free)}")
    B = _Blocks(fit, series, get, free, views, edge, fresnel)
    K, N, nv = B.K, B.N, B.nv
    W = len(B.widths)
    x0 = B.x_of(series)
    cur70, cur85, _albedo = B.errors(x0)
    curF = B.fresnel_errors(x0)
    capF = curF + rise
    if bound is not None:
        capF = np.where(curF <= bound, np.minimum(capF, bound), capF)

    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("random_seed", 0)
    inf = highspy.kHighsInf
    every = B.blocks + B.fresnel_blocks
    nb = len(every)
    nF = B.n_fresnel * W
    lower = np.concatenate([np.full(B.n_coef, -inf), np.zeros(3 * W + 2 + nF + nb)])
    upper = np.concatenate([np.full(B.n_coef, inf), cur70 + rise, cur85 + GRAZING_RISE,
                            [inf if cap is None else cap, inf], np.full(W, inf), capF.ravel(),
                            np.full(nb, inf)])
    h.addVars(nv, lower, upper)
    c = np.zeros(nv)
    c[B.T] = 1.0
    c[B.E70:B.E70 + W] = SPREAD / W
    c[B.E85:B.E85 + W] = 0.1 * SPREAD / W
    c[B.ALB] = albedo_weight
    c[B.ALBW:B.ALBW + W] = albedo_weight / W
    up_to_70 = np.array([e < B.E85 for *_r, e in B.blocks])
    for b, near in enumerate(up_to_70):  # the Fresnel blocks cost nothing: held, not priced
        c[B.BLOCK + b] = VIEW_SPREAD * (1.0 if near else 0.1) / max(1, int(np.sum(up_to_70 == near)))
    h.changeColsCost(nv, np.arange(nv, dtype=np.int32), c)

    # fixed rows: positivity at every used node and view; the albedo band;
    # each width's error at most T.  Built sparse (dense rows of every column
    # took 5.6 GB for Blinn with separable Smith's sixteen nodes), the same
    # matrix as from dense rows: zeros dropped, columns in order.
    fixed_cols, fixed_vals, fixed_rhs = [], [], []

    def fixed(cols, vals, rhs):
        fixed_cols.append(np.asarray(cols))
        fixed_vals.append(np.asarray(vals, float))
        fixed_rhs.append(rhs)

    for n, _j in enumerate(B.used):
        for deg in POSITIVE_DEG:
            T = _cheb_row(deg, N)
            for k in range(K):
                start = n * K * N + k * N
                fixed(np.arange(start, start + N), -T, 0.0)
    for w, deg, cols, aT, ta in B.albedo:
        for sign in (1.0, -1.0):
            for excess in ((B.ALB, B.ALBW + w) if deg <= 70 else (B.ALB,)):
                fixed(np.append(cols, excess), np.append(sign * aT, -1.0),
                      sign * ta + ALBEDO_BAND)
    for w in np.nonzero(B.inside)[0]:
        fixed([B.E70 + w, B.T], [1.0, -1.0], 0.0)
    rows_of = np.repeat(np.arange(len(fixed_cols)), [len(c) for c in fixed_cols])
    vals = np.concatenate(fixed_vals)
    keep = vals != 0.0
    fixed_matrix = sp.csr_matrix((vals[keep], (rows_of[keep], np.concatenate(fixed_cols)[keep])),
                                 shape=(len(fixed_cols), nv))
    fixed_matrix.sort_indices()
    # a block's error is at most its width's: one sparse row per block (dense
    # rows of every column would take nb x nv floats)
    nb_rows = np.repeat(np.arange(nb), 2)
    nb_cols = np.array([c for *_r, b, e in every for c in (b, e)])
    links = sp.csr_matrix((np.tile([1.0, -1.0], nb), (nb_rows, nb_cols)), shape=(nb, nv))
    _add_rows(h, sp.vstack([fixed_matrix, links]), fixed_rhs + [0.0] * nb)

    active = [set() for _ in every]  # per block: (light, sign of the residual)

    def add_violated(x, per_block):
        mats, rhs = [], []
        for b, (cols, Mx, t, e, _w) in enumerate(every):
            r = Mx @ x[cols] - t
            v = np.abs(r) - x[e]
            new = [(int(i), bool(r[i] > 0)) for i in np.argsort(-v)[:per_block]
                   if v[i] > 1e-7 and (int(i), bool(r[i] > 0)) not in active[b]]
            if not new:
                continue
            active[b].update(new)
            idx = np.array([i for i, _p in new])
            sign = np.array([1.0 if p else -1.0 for _i, p in new])
            rows = np.zeros((len(new), nv))
            rows[:, cols] = sign[:, None] * Mx[idx]
            rows[:, e] = -1.0
            mats.append(sp.csr_matrix(rows))
            rhs.append(sign * t[idx])
        if mats:
            _add_rows(h, sp.vstack(mats), np.concatenate(rhs))
        return sum(m.shape[0] for m in mats)

    x = x0.copy()
    x[B.E70:B.E70 + W] = 0.0
    x[B.E85:B.E85 + W] = 0.0
    x[B.BLOCK:] = 0.0
    add_violated(x, INITIAL_PER_BLOCK)
    for rnd in range(ROUNDS):
        h.run()
        if h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
            log(f"  {target.key}: joint programme failed ({h.getModelStatus()})")
            return None
        x = np.array(h.getSolution().col_value)
        added = add_violated(x, ADD_PER_BLOCK)
        log(f"  {target.key}: joint round {rnd}: worst {x[B.T]:.4f}, {added} rows added")
        if not added:
            break
    else:
        log(f"  {target.key}: joint programme did not converge in {ROUNDS} rounds")
        return None
    out_series = series.copy()
    for n, j in enumerate(B.used):
        out_series[j] = x[n * K * N:(n + 1) * K * N].reshape(K, N)
    out = with_series(fit, out_series)
    out.measured = M.measure(out) if measure else {}
    out.programme_worst = float(x[B.T])  # the programme's own optimum, at its widths and views
    return out
