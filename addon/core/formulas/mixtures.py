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
array, a Float Curve node).  Where x is a constant, everything but the
series in cos theta_o folds to constants.
"""

from __future__ import annotations

from ..fits import mixtures as _data
from . import expr as E
from .expr import clamp, closure_sum, div, exp, fmax, sqrt, table
from .library import beckmann_m_from_beta, chebyshev, tr_alpha_from_beta

FITS = _data.FITS
# variants with no fitted width: a single lobe of their kind stands in
NOT_FITTED = frozenset(getattr(_data, "NOT_FITTED", ()))
SHIPPED = dict(getattr(_data, "SHIPPED", {}))  # what each variant's data is, in words
ALPHA_MIN, ALPHA_MAX = 1e-3, 1.0  # the fitter's limits (Cycles clamps alpha to [0, 1])


def has(key: str) -> bool:
    return key in FITS


def measured(key: str) -> dict:
    return dict(FITS[key]["measured"])


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
    return clamp(2.0 * (cos_o - c0) * (1.0 / (1.0 - c0)) - 1.0, -1.0, 1.0)


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
    out = []
    for k, name in enumerate(d["members"]):
        z = table([row[k] for row in mult], t)
        alpha = clamp(eq * exp(z), ALPHA_MIN, ALPHA_MAX)
        coefficients = [table([row[k][m] for row in weights], t)
                        for m in range(len(weights[0][k]))]
        out.append((name, fmax(chebyshev(coefficients, tu), 0.0), alpha))
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
           "mixture", "nodes", "shipped", "width_variable"]
