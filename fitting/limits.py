# SPDX-License-Identifier: GPL-3.0-or-later
"""What a mixture of the fitter's members can reach at all, one view at a
time (``python -m fitting.limits``; about 15 minutes on two cores;
``--shipped``: the committed data's error alone at the same widths;
``--capped [KEY]``: Blinn-Phong's or KEY's weights re-solved under its
bound, what that costs in albedo; ``--fresnel``: what the diffuse member's
Fresnel costs the Fresnel variants; ``--kajiya-kay``: an anisotropic GGX
lobe in place of Kajiya-Kay's hair lobe, with the best weight per view).

A fitted mixture (:mod:`.mixtures`) gives its members one width per width
node, the same at every view, and interpolates weights and widths between
nodes: its error is the best those shapes allow plus what sharing the
widths over the view and the interpolation cost.  This measures the first
part alone, where the shipped data misses a target: at one width and one
view, the members' widths are searched on a grid of their log multiples
of the equivalent width (every STEP over GRID; members of one kind kept in
order, as the fitter keeps them), the best REFINE refined by Nelder-Mead,
the weights of each candidate from the fitter's own linear programme
(:func:`.mixtures.solve_weights`: the largest |mixture - model|, lights up
to 70 deg, the directional albedo within its band where it can be).  The
error is in :func:`.mixtures.measure`'s units: over the largest peak of the
model at that width, views 0-70 deg.

With widths and weights free at each view, no mixture of these members
does better there (up to the grid and the refinement: a search, not a
proof).  So where the largest of these per-view optima is over a target,
the target is out of the members' reach; where it is under while the
shipped data is over, what is missing is widths that change with the view,
which the data's layout (one width per node) does not have.

The numbers the docs quote (report/docs.py REMAINS): the separable Smith
variants in beta and Blinn-Phong, at their worst widths, views every 10 deg.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import math

import numpy as np

from . import mixtures as M

GRID = (-2.5, 1.5)  # log multiples of the equivalent width searched
STEP = 0.25
REFINE = 6          # best grid points refined
NO_BAND = 10.0      # an albedo band no mixture reaches: the band off
VIEWS_DEG = tuple(range(0, 71, 10))


@contextlib.contextmanager
def albedo_band(band):
    old = M.ALBEDO_TOLERANCE
    M.ALBEDO_TOLERANCE = band
    try:
        yield
    finally:
        M.ALBEDO_TOLERANCE = old


def peak_70(target: M.Target, value: float) -> float:
    """The model's largest value at this width, views every 5 deg to 70 and
    lights to 70: :func:`.mixtures.measure`'s denominator."""
    return max(float(s.target[s.fit].max()) for s in
               (M.samples(target, value, math.cos(d * M.DEG))
                for d in M.MEASURE_VIEWS_DEG if d <= 70))


def view_optimum(target: M.Target, value: float, view_deg: float, band=M.ALBEDO_TOLERANCE,
                 step=STEP, refine=REFINE, peak=None):
    """``(error, albedo difference, multipliers)``: the best mixture of
    ``target``'s members at one width and one view, widths and weights
    free (module docstring); the error over ``peak`` (default
    :func:`peak_70`)."""
    from scipy.optimize import minimize

    s = M.samples(target, value, math.cos(view_deg * M.DEG))
    peak = peak_70(target, value) if peak is None else peak
    units = float(s.target[s.fit].max()) / peak  # the LP's peak is this view's
    eq = target.equivalent_alpha(value)
    free = [k for k, m in enumerate(target.members) if m != "diffuse"]
    same = [(a, b) for a, b in itertools.combinations(free, 2)
            if target.members[a] == target.members[b]]

    def z_of(y):
        z = np.zeros(len(target.members))
        z[free] = y
        return z

    def solve(y):
        alphas = M.alphas_from_multipliers(z_of(y), eq)
        w, e = M.solve_weights(s, target.members, alphas)
        _A, a = M._block(s, target.members, alphas)
        return e, abs(float(a @ w) - s.target_albedo)

    def error(y):
        if any(y[free.index(a)] > y[free.index(b)] - 0.05 for a, b in same):
            return 10.0
        return solve(y)[0]

    with albedo_band(band):
        grid = np.arange(GRID[0], GRID[1] + 1e-9, step)
        found = sorted((error(np.array(y)), y) for y in itertools.product(grid, repeat=len(free)))
        best_e, best_y = found[0][0], np.array(found[0][1])
        for _e, y in found[:refine]:
            r = minimize(error, np.array(y), method="Nelder-Mead",
                         options=dict(maxiter=400, xatol=1e-3, fatol=1e-6))
            if r.fun < best_e:
                best_e, best_y = float(r.fun), r.x
        e, albedo = solve(best_y)
    return e * units, albedo, z_of(best_y)


@functools.lru_cache(maxsize=None)
def _committed(key):
    return M.load_fits([key])[key]


def shipped_error(key: str, value: float, view_deg: float, peak=None) -> float:
    """The committed mixture's error at one width and view, in the same units."""
    fit = _committed(key)
    t = fit.target
    c = math.cos(view_deg * M.DEG)
    s = M.samples(t, value, c)
    alphas, w = M.evaluate_series(fit, value, c)
    A, _a = M._block(s, t.members, alphas)
    peak = peak_70(t, value) if peak is None else peak
    return float(np.max(np.abs(A[s.fit] @ w - s.target[s.fit]))) / peak


CASES = (("microfacet/gaussian/smith/beta", (51.4, 79.4)),
         ("microfacet/blinn/smith/beta", (51.4, 69.6)),
         ("microfacet/trowbridge_reitz/smith/beta", (29.0, 34.6)),
         ("blinn_phong", (5.31, 10.66)))


def _value(key, shown):
    return math.log1p(shown) if key == "blinn_phong" else shown * M.DEG


def _job(job):
    key, shown, view, band = job
    t = _committed(key).target
    value = _value(key, shown)
    peak = peak_70(t, value)
    e, albedo, _z = view_optimum(t, value, view, band, peak=peak)
    return job, e, albedo, shipped_error(key, value, view, peak=peak)


def main(jobs=2):
    from concurrent.futures import ProcessPoolExecutor

    work = [(k, w, v, M.ALBEDO_TOLERANCE) for k, ws in CASES for w in ws for v in VIEWS_DEG]
    # without the albedo band, where the band is what stands in the way
    work += [(k, w, v, NO_BAND) for k, ws in CASES for w in ws for v in VIEWS_DEG
             if k in ("microfacet/trowbridge_reitz/smith/beta", "blinn_phong")]
    with ProcessPoolExecutor(jobs) as pool:
        done = list(pool.map(_job, work))
    print("The best mixture of the fitter's members with widths and weights free at each "
          "view\n(max |mixture - model| over the model's peak, views 0-70 deg, lights to 70; "
          f"views {VIEWS_DEG[0]}-{VIEWS_DEG[-1]} every {VIEWS_DEG[1] - VIEWS_DEG[0]} deg)\n")
    print(f"{'variant':40s} {'width':>6s} {'albedo band':>11s} {'per-view best':>13s} "
          f"{'at view':>7s} {'its albedo':>10s} {'shipped there':>13s} {'shipped max':>11s}")
    rows = {}
    for (key, shown, view, band), e, albedo, shipped in done:
        rows.setdefault((key, shown, band), []).append((e, view, albedo, shipped))
    for (key, shown, band), r in rows.items():
        e, view, albedo, _s = max(r)
        shipped_there = next(s for ee, vv, _a, s in r if vv == view)
        print(f"{key:40s} {shown:6g} {_band(band):>11s} {e:13.4f} {view:7.0f} {albedo:10.4f} "
              f"{shipped_there:13.4f} {max(s for *_x, s in r):11.4f}")
    return 0


def shipped():
    """The committed mixtures' error alone at the CASES' widths, views every
    10 deg (seconds: the search is skipped): the table's last column after
    a change to the data."""
    print(f"{'variant':40s} {'width':>6s} {'shipped max':>11s} {'at view':>7s}")
    for key, widths in CASES:
        t = _committed(key).target
        for shown in widths:
            value = _value(key, shown)
            peak = peak_70(t, value)
            e, view = max((shipped_error(key, value, v, peak=peak), v) for v in VIEWS_DEG)
            print(f"{key:40s} {shown:6g} {e:11.4f} {view:7.0f}")
    return 0


CAPPED = (0.99, 0.98)  # fractions of the bound the capped re-solve is held to


def capped(key="blinn_phong"):
    """The committed variant's weight series re-solved with its worst case
    held under its bound (:func:`.joint.solve` with ``cap``; minutes): what
    the bound costs in directional albedo, where the shipped data trades
    the other way (the data does not change)."""
    from . import assemble, joint
    fit = _committed(key)
    fit.measured = M.measure(fit)
    aim = assemble.bound(fit.target)
    m = fit.measured
    print(f"{key}: shipped {m['max_abs_over_peak_70']:.4f}, albedo "
          f"{m['albedo_difference_70']:.4f}")
    for fraction in CAPPED:
        solved = joint.solve(fit, log=lambda _msg: None, rise=joint.RISE,
                             level=joint.REGION_FRACTION * aim, cap=fraction * aim)
        if solved is None:
            print(f"held under {fraction * aim:.4f}: no solution")
            continue
        n = solved.measured
        print(f"held under {fraction * aim:.4f}: {n['max_abs_over_peak_70']:.4f}, albedo "
              f"{n['albedo_difference_70']:.4f} (up to 85 deg {n['max_abs_over_peak_85']:.4f})")
    return 0


FRESNEL_KEYS = ("microfacet/blinn/smith/beta", "microfacet/gaussian/smith/beta",
                "microfacet/gaussian/smith_correlated/beta",
                "microfacet/trowbridge_reitz/smith/beta")
LOBE_ALPHAS = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0)


def fresnel(keys=FRESNEL_KEYS):
    """What the diffuse member's Fresnel costs (``--fresnel``; about a
    minute): at each width node (up to the closures' range), the worst
    index of each Fresnel class as the mixture carries it (the diffuse
    member at F of the mean L.H, as :mod:`.bounds` measures it) and as it
    would be if the diffuse member carried F(L.H) light by light, as the
    microfacet members do; then how closely the lobes that can carry F(L.H)
    stand in for the diffuse one (:func:`lambert_by_lobes`)."""
    from . import bounds as B
    print("Largest |mixture - model| over the peak, views and lights to 70 deg, at each width "
          "node:\nwithout Fresnel; with the worst index of each class, the diffuse member's "
          "F at the mean L.H (shipped) and at each light's L.H (no closure does that)\n")
    print(f"{'variant':42s} {'width':>7s} {'none':>6s} {'dielectric':>17s} {'conductor':>17s}")
    for key in keys:
        fit = _committed(key)
        for x in fit.width_values:
            if x > fit.target.soft_max + 1e-12:
                break
            rows = B.rows_at(fit, float(x))
            e = {(cls, exact): B.class_error(rows, cls, exact)
                 for cls in ("dielectric", "conductor") for exact in (False, True)}
            shown = (f"{math.degrees(x):5.1f}deg" if fit.target.width == "beta"
                     else f"{math.exp(x):7.4f}")
            print(f"{key:42s} {shown:>7s} {B.class_error(rows, 'none'):6.3f} "
                  f"{e['dielectric', False]:8.3f} {e['dielectric', True]:8.3f} "
                  f"{e['conductor', False]:8.3f} {e['conductor', True]:8.3f}")
    print("\nLambert's lobe by GGX and Beckmann lobes (alpha 0.5-1, weights free at each view): "
          "largest |difference| over its peak, lights to 70 deg")
    for deg, err in lambert_by_lobes():
        print(f"view {deg:3d} deg: {err:.3f}")
    return 0


def lambert_by_lobes(views=VIEWS_DEG, alphas=LOBE_ALPHAS):
    """``[(view, error)]``: the best non-negative mixture of Cycles' GGX and
    Beckmann lobes (:mod:`.closures`, the members that carry F(L.H)) for
    Lambert's cos(theta_i)/pi at one view, minimax over lights to 70 deg
    every 2.5 deg of elevation and 7.5 of azimuth, over Lambert's peak."""
    from scipy.optimize import linprog

    from . import closures as CL
    theta, phi = np.meshgrid(np.radians(np.arange(0.0, 70.01, 2.5)),
                             np.radians(np.arange(0.0, 360.0, 7.5)))
    wi = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                   np.cos(theta)], -1).reshape(-1, 3)
    out = []
    for deg in views:
        t = math.radians(deg)
        wo = np.broadcast_to(np.array([math.sin(t), 0.0, math.cos(t)]), wi.shape)
        target = CL.diffuse(wi, wo)
        A = np.stack([CL.microfacet(wi, wo, a, a, d) for d in ("ggx", "beckmann")
                      for a in alphas], 1)
        n, k = A.shape
        # minimise e with |A w - target| <= e * peak, w >= 0
        slack = -target.max() * np.ones((n, 1))
        res = linprog(np.r_[np.zeros(k), 1.0],
                      A_ub=np.vstack([np.hstack([A, slack]), np.hstack([-A, slack])]),
                      b_ub=np.r_[target, -target], bounds=[(0, None)] * (k + 1), method="highs")
        out.append((deg, float(res.x[-1])))
    return out


KK_EXPONENTS = (1.0, 5.0, 40.0, 200.0, 1000.0, 10000.0)
KK_MULTIPLES = (0.7, 0.85, 1.0, 1.15, 1.3)


def minimax_weight(f, target):
    """``(w, e)``: the weight w >= 0 that makes e = max |w f - target|
    smallest (a ternary search: the largest is convex in w; beyond
    2 max target / max f it only grows)."""
    lo, hi = 0.0, 2.0 * float(np.max(target)) / max(float(np.max(f)), 1e-300)
    for _ in range(80):
        a, b = lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0
        if np.max(np.abs(a * f - target)) <= np.max(np.abs(b * f - target)):
            hi = b
        else:
            lo = a
    w = 0.5 * (lo + hi)
    return w, float(np.max(np.abs(w * f - target)))


def kajiya_kay_anisotropic(s, multiple, views=None):
    """``(everywhere, same side)`` for Kajiya-Kay's lobe (ks = 1) drawn by
    Cycles' anisotropic GGX closure instead of the hair one: its roughness
    along the fibre ``multiple`` times the model's lobe width sqrt(2 / (s +
    2)) (capped at 1), across it 1, where GGX's distribution depends on the
    half vector's component along the fibre alone, so the lobe's ridge is
    the model's mirror cone (H perpendicular to T) at every azimuth and has
    no far-side cut; its weight the best for each view (:func:`minimax_weight`
    over every light).  ``fitting/kajiya_kay.py``'s views (or ``views``),
    lights and sides; the largest |w lobe - model| over the model's peak."""
    from . import closures as C
    from . import kajiya_kay as K
    ax = min(multiple * K.lobe_width(s), 1.0)
    worst = near = 0.0
    for wo in K.views() if views is None else views:
        wi = K.lights(wo, s)
        f = C.microfacet(wi, wo[None], ax, 1.0, "ggx")
        target = K.lobe(wi, wo[None], s)
        w, e = minimax_weight(f, target)
        worst = max(worst, e)
        near = max(near, float(np.max(np.where(K.same_side(wi, wo[None]),
                                                np.abs(w * f - target), 0.0))))
    return worst, near


def kajiya_kay(exponents=KK_EXPONENTS, multiples=KK_MULTIPLES):
    """``--kajiya-kay`` (about 10 minutes): :func:`kajiya_kay_anisotropic`
    at each exponent and roughness multiple, beside the shipped hair lobe's
    figures there (ks only: ``fitting/kajiya_kay.py``'s measure at rho =
    0)."""
    from . import kajiya_kay as K
    print("Kajiya-Kay's lobe (ks only) as an anisotropic GGX lobe with the best weight per "
          "view,\nagainst the shipped hair lobe (max |output - model| over the peak, views "
          "and lights to 70 deg)\n")
    print(f"{'s':>7s} {'multiple':>8s} {'everywhere':>10s} {'view side':>9s}   "
          f"{'hair: everywhere':>16s} {'view side':>9s}")
    for s in exponents:
        everywhere, near = K.measure(s)
        for m in multiples:
            a, b = kajiya_kay_anisotropic(s, m)
            print(f"{s:7g} {m:8.2f} {a:10.3f} {b:9.3f}   {everywhere[0]:16.3f} "
                  f"{near[0]:9.3f}", flush=True)
    return 0


def _band(band):
    return "none" if band >= NO_BAND else f"{band:g}"


if __name__ == "__main__":
    import sys
    if sys.argv[1:2] == ["--capped"]:
        raise SystemExit(capped(*sys.argv[2:3]))
    if sys.argv[1:] == ["--fresnel"]:
        raise SystemExit(fresnel())
    if sys.argv[1:] == ["--kajiya-kay"]:
        raise SystemExit(kajiya_kay())
    raise SystemExit(shipped() if sys.argv[1:] == ["--shipped"] else main())
