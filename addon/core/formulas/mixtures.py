# SPDX-License-Identifier: GPL-3.0-or-later
"""Fitted closure mixtures as expression graphs.

A fitted variant (``addon/core/fits/mixtures.py``, made offline by
``fitting/mixtures.py``) renders as

    sum_k w_k(cos theta_o, x) C_k(alpha_k(x)),

x the width variable (beta in radians, log alpha, or log(1 + s) for an
exponent s).  At evenly spaced nodes of x the data holds each member's
width as the log of a multiple of an equivalent width (Beckmann's m or
GGX's alpha of the same beta, the native alpha, the Ashikhmin-Shirley alpha
of the same exponent) and each member's weight as Chebyshev coefficients in
cos theta_o; between the nodes both are linear in x (``table``: an OSL
array, a Float Curve node).  The shaders sum each series as a polynomial
in powers of the view variable (:func:`power_coefficients`: the same
function, one Multiply Add node a degree by Horner's rule), three members'
at a time in one vector.  Where x is a constant, everything but the
series in cos theta_o folds to constants.
"""

from __future__ import annotations

import math

from ..fits import mixtures as _data
from ..fits import toon as _toon
from . import expr as E
from .expr import clamp, closure_sum, div, exp, fmax, sqrt, table
from .library import beckmann_m_from_beta, tr_alpha_from_beta
from .models import FIT_BOUND

FITS = _data.FITS
# variants with no fitted width: a single lobe of their kind stands in
NOT_FITTED = frozenset(getattr(_data, "NOT_FITTED", ()))
SHIPPED = dict(getattr(_data, "SHIPPED", {}))  # what each variant's data is, in words
ALPHA_MIN, ALPHA_MAX = 1e-3, 1.0  # the fitter's limits (Cycles clamps alpha to [0, 1])


def has(key: str) -> bool:
    return key in FITS


def measured(key: str) -> dict:
    return dict(FITS[key]["measured"])


def toon_measured() -> dict:
    """What Phong's Toon mixture (Cycles' native nodes) measured: the keys
    of :func:`measured`."""
    return dict(_toon.MEASURED)


def shipped(key: str) -> str:
    """What the variant's data is: "fitted", "fitted; the weighted single
    lobe at 4 of 16 widths", "single lobe, weighted by view; the fit
    measured 0.3", ... (fitting/assemble.py)."""
    if key in SHIPPED:
        return SHIPPED[key]
    return "single lobe" if key in NOT_FITTED else "fitted"


def members_text(key: str) -> str:
    """The variant's closures, in words, as the docs and the report list
    them: the members of a fit (and what replaced some of its widths), or
    the single lobe that ships instead."""
    if key in NOT_FITTED:
        return shipped(key)
    members = ", ".join(FITS[key]["members"])
    how = shipped(key)
    return members if how == "fitted" else f"{members} ({how})"


def worst_text(key: str) -> str:
    """The fitter's worst case up to 70 deg as the docs and the report show
    it: three decimals, or four where three would read as the bound a
    fitted variant is within (FIT_BOUND: 0.02495 is "0.0249", not "0.025")."""
    v = measured(key)["max_abs_over_peak_70"]
    return f"{v:.4f}" if f"{v:.3f}" == f"{FIT_BOUND:.3f}" else f"{v:.3f}"


def fresnel_class(fresnel: str, params: dict):
    """The class ``fitting/bounds.py`` measured a Fresnel choice in, from
    its indices (``params``' "ior" and "k", colours or scalars, the
    catalogue's defaults where absent): "none"; "dielectric" (a real index
    in its range in every channel); "conductor" (k at least its minimum in
    every channel); None where it measured no such Fresnel."""
    from .. import catalogue
    from ..fits import bounds as _bounds
    if fresnel in (None, "none"):
        return "none"
    model = catalogue.MODELS["microfacet"]

    def channels(name):
        value = params.get(name, model.param(name).default)
        if isinstance(value, (int, float)):
            return (float(value),) * 3
        return tuple(float(v) for v in value)
    if fresnel == "dielectric":
        lo, hi = _bounds.DIELECTRIC_RANGE
        return "dielectric" if all(lo <= n <= hi for n in channels("ior")) else None
    if fresnel == "conductor":
        return "conductor" if all(k >= _bounds.CONDUCTOR_K_MIN for k in channels("k")) else None
    raise ValueError(f"fresnel must be one of {catalogue.FRESNELS}, not {fresnel!r}")


def _cells_around(x, grid) -> list:
    """The intervals j of ``grid`` (ascending nodes) that hold ``x``,
    clamped to the grid: one, or two at a node."""
    x = min(max(x, grid[0]), grid[-1])
    return [j for j in range(len(grid) - 1) if grid[j] - 1e-12 <= x <= grid[j + 1] + 1e-12]


def interval_bound(key: str, value: float, fresnel_class: str):
    """The largest error over the peak that ``fitting/bounds.py`` measured
    around the width ``value`` (beta in radians, or alpha: the parameter's
    own value) for a Fresnel class ("none", "dielectric", "conductor"):
    the bound of the interval between width nodes that holds it, the larger
    of the two at a node; None where not measured (beyond the closures'
    range, or no such data)."""
    from ..fits import bounds as _bounds
    entry = _bounds.BOUNDS.get(key)
    if entry is None:
        return None
    x = float(value) if entry["width"] == "beta" else math.log(max(float(value), 1e-30))
    nodes, values = entry["nodes"], entry[fresnel_class]
    found = [values[j] for j in _cells_around(x, nodes)]
    if not found or any(v is None for v in found):
        return None
    return max(found)


def ward_figure(alpha_x=None, alpha_y=None):
    """The largest |BSDF output - model| over the peak that
    ``fitting/ward.py`` measured for Ward's model (views and lights up to
    70 deg) in the cell of widths around (``alpha_x``, ``alpha_y``), the
    larger of the cells at a node, clamped to the sockets' range; with no
    widths, the largest of every cell."""
    from ..fits import ward as _ward
    if alpha_x is None or alpha_y is None:
        return max(max(row) for row in _ward.FIGURES)
    nodes = _ward.NODES

    def around(alpha):
        return _cells_around(math.log(max(float(alpha), 1e-30)), nodes)
    return max(_ward.FIGURES[a][b] for a in around(alpha_x) for b in around(alpha_y))


def kajiya_kay_figure(exponent=None, kd=None, ks=None, same_side=False):
    """The largest |BSDF output - model| over the peak that
    ``fitting/kajiya_kay.py`` measured for Kajiya-Kay's model (views and
    lights up to 70 deg; ``same_side``: the lights on the view's side
    across the fibre) in the cell around the exponent and each colour
    channel's ratio kd / (kd + ks), the largest over the channels (a channel
    with kd = ks = 0 renders 0, as the model); with no values, the largest
    of every cell."""
    from ..fits import kajiya_kay as _kk
    table = _kk.SAME_SIDE if same_side else _kk.FIGURES
    if exponent is None or kd is None or ks is None:
        return max(max(row) for row in table)
    nodes, ratios = _kk.NODES, _kk.RATIOS

    around = _cells_around

    def channels(c):
        return (float(c),) * 3 if isinstance(c, (int, float)) else tuple(float(v) for v in c)
    rows = around(math.log1p(max(float(exponent), 0.0)), nodes)
    out = 0.0
    for d, k in zip(channels(kd), channels(ks)):
        if d + k > 0.0:
            out = max(out, max(table[j][r] for j in rows
                               for r in around(d / (d + k), ratios)))
    return out


def worst_interval(key: str, fresnel_class: str):
    """The largest :func:`interval_bound` of the variant (its intervals
    within the closures' range), or None where not measured."""
    from ..fits import bounds as _bounds
    entry = _bounds.BOUNDS.get(key)
    values = [v for v in entry[fresnel_class] if v is not None] if entry else []
    return max(values) if values else None


def fitted_ranges(key: str, fresnel_class: str) -> list:
    """The widths where :func:`interval_bound` is within FIT_BOUND, as
    ``[(lo, hi), ...]`` in the parameter's own value (beta in radians,
    alpha), neighbouring intervals merged; [] where none is."""
    from ..fits import bounds as _bounds
    entry = _bounds.BOUNDS.get(key)
    if entry is None:
        return []
    nodes, values = entry["nodes"], entry[fresnel_class]
    own = (lambda x: x) if entry["width"] == "beta" else math.exp
    out = []
    for j, v in enumerate(values):
        if v is None or v > FIT_BOUND:
            continue
        if out and out[-1][1] == own(nodes[j]):
            out[-1] = (out[-1][0], own(nodes[j + 1]))
        else:
            out.append((own(nodes[j]), own(nodes[j + 1])))
    return out


def fitted_ranges_text(key: str, fresnel_class: str) -> str:
    """:func:`fitted_ranges` in words: "every width", "none", or the ranges
    (beta in whole degrees, alpha to two digits)."""
    from ..fits import bounds as _bounds
    entry = _bounds.BOUNDS[key]
    ranges = fitted_ranges(key, fresnel_class)
    if not ranges:
        return "none"
    measured = [v for v in entry[fresnel_class] if v is not None]
    if len(measured) == len(entry[fresnel_class]) and all(v <= FIT_BOUND for v in measured):
        return "every width"
    if entry["width"] == "beta":
        return ", ".join(f"β {math.degrees(a):.0f}–{math.degrees(b):.0f}°" for a, b in ranges)
    return ", ".join(f"α {a:.2g}–{b:.2g}" for a, b in ranges)


def fitted_widths_rows() -> tuple:
    """The tables of where each microfacet mixture is fitted (the README's,
    the model page's, the report's): ``([(key, [without Fresnel,
    dielectric, conductor]), ...], [keys fitted nowhere])``, in words."""
    from ..fits import bounds as _bounds
    rows, nowhere = [], []
    for key in FITS:
        if key not in _bounds.BOUNDS:
            continue
        cells = [fitted_ranges_text(key, c) for c in ("none", "dielectric", "conductor")]
        if all(c == "none" for c in cells):
            nowhere.append(key)
        else:
            rows.append((key, cells))
    return rows, nowhere


def width_variable(width: str, value):
    """The fit's width variable of a width parameter's value: beta itself,
    log alpha, log(1 + s)."""
    if width == "beta":
        return E.wrap(value)
    if width == "alpha":
        return E.log(value)
    return E.log(1.0 + value)


def equivalent_alpha(equivalent: str, x):
    """The width the members' widths are multiples of, from the (clamped)
    width variable."""
    if equivalent == "beckmann_m":
        return beckmann_m_from_beta(x)
    if equivalent == "tr_alpha":
        return tr_alpha_from_beta(x)
    if equivalent == "alpha":
        return exp(x)
    if equivalent == "exponent":  # 2/alpha^2 - 2 = s, and exp(x) = 1 + s
        return sqrt(div(2.0, exp(x) + 1.0))
    raise ValueError(f"unknown equivalent width {equivalent!r}")


def view_variable(cos_o):
    c0 = _data.COS_VIEW_MIN
    # 2 (c - c0)/(1 - c0) - 1 as one product and sum (one Multiply Add node)
    return clamp(cos_o * (2.0 / (1.0 - c0)) + (-(1.0 + c0) / (1.0 - c0)), -1.0, 1.0)


def members(key: str, x, cos_o):
    """``[(closure name, weight, alpha)]`` of the fitted variant ``key`` at
    width variable ``x`` and view cosine ``cos_o``."""
    d = FITS[key]
    lo, hi = d["domain"]
    xc = clamp(E.wrap(x), lo, hi)
    t = (xc - lo) * (1.0 / (hi - lo))
    tu = view_variable(cos_o)
    eq = equivalent_alpha(d["equivalent"], xc)
    mult, weights = d["multipliers"], d["weights"]  # (n, K), (n, K, n_view)
    w = _weights(weights, len(d["members"]), t, tu)
    out = []
    for k, name in enumerate(d["members"]):
        z = table([row[k] for row in mult], t)
        alpha = clamp(eq * exp(z), ALPHA_MIN, ALPHA_MAX)
        out.append((name, w[k], alpha))
    return out


def _weights(weights, K, t, tu):
    """The K members' weights at the table variable ``t`` and the view
    variable ``tu``: ``weights`` (n, K, n_view) are each node's Chebyshev
    series."""
    # each node's series as a polynomial in the view variable: a_j = sum_m
    # P[j][m] c_m, and the tables are linear in their values, so a table of
    # the a_j is that sum of the c_m's tables
    power = power_coefficients(len(weights[0][0]))

    def coefficient(k, j):
        # math.fsum: correctly rounded, so the shaders' constants are the same
        # on every Python (sum() of floats compensates only from 3.12)
        return table([math.fsum(p * c for p, c in zip(power[j], row[k])) for row in weights], t)

    # Horner's rule, one product and sum (one Multiply Add node) a degree
    # (Clenshaw's recurrence for the Chebyshev series takes two), three
    # members at a time as one vector (a last one or two alone)
    w = []
    for k0 in range(0, K, 3):
        group = range(k0, min(k0 + 3, K))
        if len(group) < 3:
            w += [fmax(horner([coefficient(k, j) for j in range(len(power))], tu), 0.0)
                  for k in group]
            continue
        series = fmax(horner([E.pack(*(coefficient(k, j) for k in group))
                              for j in range(len(power))], tu), 0.0)
        w += [series[i] for i in range(3)]
    return w


def toon_members(x, cos_o):
    """``[(closure name, weight, size, smooth)]`` of Phong's Toon mixture
    (``addon/core/fits/toon.py``, made by ``fitting/toon.py``) at width
    variable ``x`` = log(1 + s) and view cosine ``cos_o``: the Toon lobes'
    log size and log smooth and the weights' series linear between the
    nodes, the series summed by Horner's rule as in :func:`members`."""
    lo, hi = _toon.DOMAIN
    t = (clamp(E.wrap(x), lo, hi) - lo) * (1.0 / (hi - lo))
    w = _weights(_toon.WEIGHTS, len(_toon.MEMBERS), t, view_variable(cos_o))
    out = []
    for k, name in enumerate(_toon.MEMBERS):
        if name == "diffuse":
            out.append((name, w[k], None, None))
            continue
        size = clamp(exp(table([row[k][0] for row in _toon.LOBES], t)), TOON_SIZE_MIN, 1.0)
        smooth = clamp(exp(table([row[k][1] for row in _toon.LOBES], t)), 0.0, 1.0)
        out.append((name, w[k], size, smooth))
    return out


TOON_SIZE_MIN = 1e-5  # Cycles clamps the Toon BSDF's size to [1e-5, 1]


def toon_glossy_band(x):
    """1 where Cycles renders Phong's Glossy mixture too (where it measured
    better than the Toon one: ``GLOSSY_BAND`` of the data, in log(1 + s)),
    else 0; a constant where ``x`` is one."""
    band = _toon.GLOSSY_BAND
    if band is None:
        return E.const(0.0)
    x = E.wrap(x)
    return E.lt(x, band[1]) * E.ge(x, band[0])


def toon_at_nodes() -> tuple:
    """((s, the Toon mixture's max |d|/peak up to 70 deg, the Glossy
    mixture's, the floor with the lobes free at every view, the floor with
    the albedo held too), ...) at each of the Toon data's nodes
    (fitting/toon.py)."""
    return tuple(tuple(row) for row in _toon.AT_NODES)


def toon_band_text():
    """The exponents where Cycles renders Phong's Glossy mixture too, as the
    docs and the report write them ("LO-HI", two decimals each), or None."""
    band = _toon.GLOSSY_BAND
    return None if band is None else f"{math.expm1(band[0]):.2f}-{math.expm1(band[1]):.2f}"


def toon_band_words() -> str:
    """Where the Toon mixture's row of a table points to the Glossy
    mixture's row above it ("the row above for s LO-HI"), or ""."""
    band = toon_band_text()
    return "" if band is None else f"the row above for s {band}"


def toon_mixture(x, cos_o, member):
    """Phong's Toon mixture: ``member(name, weight, size, smooth)`` builds
    each member's closure."""
    return closure_sum(*(member(*m) for m in toon_members(x, cos_o)))


def power_coefficients(n: int) -> list:
    """``P`` with sum_m c_m T_m(u) = sum_j (sum_m P[j][m] c_m) u^j, the
    Chebyshev polynomials T_0 ... T_{n-1} in powers of u (T_{m+1} =
    2 u T_m - T_{m-1}).  The powers' coefficients of the committed fits'
    degree-7 series sum to at most 75 times the series' own, so in float32
    the sum errs by under 1e-5 of the series' size (tests/test_fits.py):
    far under the fits' 0.025."""
    T = [[1.0], [0.0, 1.0]][:n]
    while len(T) < n:
        a, b = T[-1], T[-2]
        T.append([(2.0 * a[j - 1] if j else 0.0) - (b[j] if j < len(b) else 0.0)
                  for j in range(len(a) + 1)])
    return [[T[m][j] if j < len(T[m]) else 0.0 for m in range(n)] for j in range(n)]


def horner(coefficients, u):
    """sum_j a_j u^j (coefficients: numbers or expressions, floats or
    vectors)."""
    out = E.wrap(coefficients[-1])
    for a in coefficients[-2::-1]:
        out = a + out * u
    return out


def mixture(key: str, x, cos_o, member):
    """The closure sum: ``member(name, weight, alpha)`` builds each member's
    closure (the model adds its colour, Fresnel and frame)."""
    return closure_sum(*(member(name, w, a) for name, w, a in members(key, x, cos_o)))


def nodes(key: str) -> list:
    """The width nodes of ``key`` (evenly spaced over its domain)."""
    d = FITS[key]
    lo, hi = d["domain"]
    n = len(d["multipliers"])
    return [lo + (hi - lo) * i / (n - 1) for i in range(n)]


__all__ = ["FITS", "NOT_FITTED", "SHIPPED", "has", "measured", "members", "members_text",
           "mixture", "nodes", "shipped", "toon_measured", "toon_members", "toon_mixture",
           "width_variable"]
