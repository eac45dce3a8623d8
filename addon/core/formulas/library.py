# SPDX-License-Identifier: GPL-3.0-or-later
"""Formulas shared by the models, as expression graphs (:mod:`.expr`).

Names and argument order mirror :mod:`addon.core.reference` (the judge) so
the two read side by side; the arithmetic is arranged for float32 where it
says so (precision notes inline, as in Filament's ``surface_brdf.fs``).
Local components: x along the tangent, y along N x T, z along the normal.
"""

from __future__ import annotations

import math

from ..fits import smith_lambda as _series
from . import expr as E
from .expr import clamp, const, div, exp, fmax, fmin, gt, log, lt, select, sqrt

PI = math.pi
LN2 = math.log(2.0)
SQRT_PI = math.sqrt(math.pi)


# --------------------------------------------------------------------------
# Arithmetic arranged for float32

def log1p(x):
    """log(1 + x) accurate for small x in float32 (Goldberg 1991, theorem 4);
    x >= 0."""
    u = 1.0 + x
    return select(gt(u, 1.0), log(u) * div(x, u - 1.0), x)


def atan2_refined(y, x):
    """atan2 refined by one Newton step on g(a) = x sin a - y cos a (slope
    hypot(x, y) cos(a - a*): the error is squared).  Cycles compiles OSL with
    fast math (atan2 off by 1.5e-5) and the GPU kernels use fast intrinsics;
    the Gaussian D amplifies an angle error about 12-fold."""
    a = E.atan2(y, x)
    r = sqrt(x * x + y * y)
    return a - div(x * E.sin(a) - y * E.cos(a), r)


def acos_refined(c):
    cc = clamp(c, -1.0, 1.0)
    return atan2_refined(sqrt(fmax(1.0 - cc * cc, 0.0)), cc)


def lobe_between(a, b, s):
    """The lobe of the angle between vectors ``a`` and ``b``: max(0, cos)^s
    with cos = a.b/(|a||b|) (0^0 = 0 below the cut-off, as reference._lobe),
    computed from
    tan^2 = |a x b|^2/(a.b)^2 as (1 + tan^2)^(-s/2).  A cosine near 1 holds
    in float32 only to 6e-8, and x^s multiplies that by s (1e-4 at s = 1000);
    the tangent holds to a few ulps of itself, so the error stays at a few
    ulps of the exponent s/2 log(1 + tan^2) however large s is."""
    t = E.cross(a, b)
    return lobe_of_tangent(E.dot(a, b), E.dot(t, t), s)


def lobe_of_tangent(c, sin2, s):
    """max(0, cos)^s from c = r cos and sin2 = (r sin)^2 (any common scale r > 0),
    as (1 + tan^2)^(-s/2): see :func:`lobe_between`."""
    tan2 = fmin(div(sin2, c * c), 1e30)  # finite at c -> 0, where s = 0 gives 1
    return select(gt(c, 0.0), one_plus_to_the(tan2, -0.5 * s), 0.0)


def one_plus_to_the(x, y):
    """(1 + x)^y for x >= 0, accurate where 1 + x rounds: exp(y log1p(x))
    with log1p as in :func:`log1p` (Goldberg), written as one power,
    u^(y x/(u - 1)) with u = 1 + x, instead of a logarithm and an
    exponential (in SVM the logarithm node takes two logarithms).  Where
    1 + x rounds to 1 the division gives 0 (``div``) and the power 1, as
    1^y would."""
    u = 1.0 + x
    return E.pow_(u, y * div(x, u - 1.0))


def erfc(x):
    """Complementary error function for x >= 0 (Press et al., Numerical
    Recipes, 2nd ed., sec. 6.2, ``erfcc``: fractional error below 1.2e-7,
    float32's level), from exp and a polynomial only, so every backend has it
    (Cycles' Math node has no erfc)."""
    z = fmax(x, 0.0)
    t = div(1.0, 1.0 + 0.5 * z)
    coefficients = (-1.26551223, 1.00002368, 0.37409196, 0.09678418, -0.18628806,
                    0.27886807, -1.13520398, 1.48851587, -0.82215223, 0.17087277)
    poly = const(coefficients[-1])
    for c in reversed(coefficients[:-1]):
        poly = c + t * poly
    return t * exp(-z * z + poly)


def chebyshev(coefficients, t):
    """sum_k c_k T_k(t) by Clenshaw's recurrence (coefficients: numbers or
    expressions; vectors evaluate three series at once)."""
    coefficients = [E.wrap(c) for c in coefficients]
    if len(coefficients) == 1:
        return coefficients[0]
    b1 = coefficients[-1]
    b2 = E.packed(0.0, 0.0, 0.0) if b1.kind == "v" else const(0.0)
    t2 = 2.0 * t
    for c in coefficients[-2:0:-1]:
        b1, b2 = c + t2 * b1 - b2, b1
    return coefficients[0] + t * b1 - b2


# --------------------------------------------------------------------------
# beta and the native widths (slide "Microfacet Distribution Functions")

SMALL_BETA = 0.15  # radians (8.6 deg): below it tan(beta) and -2 ln cos(beta) from series


def tan_beta(beta):
    """tan(beta), below SMALL_BETA from its series (the first dropped term is
    1382 b^11/155925: 1e-10 of it).  A narrow lobe's width turned into an
    exponent (Blinn's c, over 3000 at beta 1.2 deg; Beckmann's 1/m^2)
    multiplies any relative error of it by the whole exponent, up to ~30 in
    a lobe's visible tail; computed with tan and log in OSL (Cycles compiles
    it with fast math) the result erred 2.75e-4 (Blinn) and 1.06e-4
    (Beckmann) at beta 1.2 deg, against 3.6e-5 and 4.7e-5 in SVM from the
    same expressions (which of the two functions is not isolated); from the
    series both backends measure under 5e-5.  Where beta is a constant
    socket SVM folds all of it away."""
    b2 = beta * beta
    series = beta * (1.0 + b2 * (1.0 / 3.0 + b2 * (2.0 / 15.0 + b2 * (17.0 / 315.0
                                                                   + b2 * (62.0 / 2835.0)))))
    return select(lt(beta, SMALL_BETA), series, E.tan(beta))


def minus_2_log_cos(beta):
    """-2 ln cos(beta) = log1p(tan^2 beta); below SMALL_BETA from its series
    b^2 + b^4/6 + 2 b^6/45 + 17 b^8/1260 (1.1e-9 of it at SMALL_BETA), for
    the reason given in :func:`tan_beta`."""
    b2 = beta * beta
    series = b2 * (1.0 + b2 * (1.0 / 6.0 + b2 * (2.0 / 45.0 + b2 * (17.0 / 1260.0))))
    t = E.tan(beta)
    return select(lt(beta, SMALL_BETA), series, log1p(t * t))


def blinn_exponent_from_beta(beta):
    """Erratum: -ln2 / ln cos(beta); as 2 ln2 / (-2 ln cos beta) for float32."""
    return div(2.0 * LN2, minus_2_log_cos(beta))


def gaussian_c2_from_beta(beta):
    """Erratum: sqrt(ln 2)/beta, not sqrt(2)/beta."""
    return div(math.sqrt(LN2), beta)


def tr_alpha_from_beta(beta):
    """c3^2 = (cos^2 - 1)/(cos^2 - sqrt2) = sin^2 / (sqrt2 - cos^2): no cancellation."""
    s, c = E.sin(beta), E.cos(beta)
    return sqrt(div(s * s, math.sqrt(2.0) - c * c))


def beckmann_m_from_beta(beta):
    """m = tan(beta) / sqrt(ln 2 - 4 ln cos beta), with -4 ln cos = 2 log1p(tan^2)."""
    return div(tan_beta(beta), sqrt(LN2 + 2.0 * minus_2_log_cos(beta)))


def _beta_series_variable(beta):
    return 2.0 * (beta - _series.BETA_MIN) / (_series.BETA_MAX - _series.BETA_MIN) - 1.0


def gaussian_norm(beta):
    """Normalisation K of the Gaussian D: no closed form; the Chebyshev
    series of the reference's quadrature (K = c2^2/pi exp(series), within
    5e-9 relative: addon/core/fits/smith_lambda.py)."""
    c2 = gaussian_c2_from_beta(beta)
    return c2 * c2 * (1.0 / PI) * exp(chebyshev(_series.GAUSSIAN_NORM, _beta_series_variable(beta)))


# --------------------------------------------------------------------------
# Distributions, normalised: int D cos(theta_h) dw_h = 1

def tan2(hx, hy, hz):
    return div(hx * hx + hy * hy, hz * hz)


def D_blinn(hx, hy, hz, beta):
    c = blinn_exponent_from_beta(beta)
    return (c + 2.0) * (1.0 / (2.0 * PI)) * one_plus_to_the(tan2(hx, hy, hz), -0.5 * c)


def D_gaussian(hx, hy, hz, beta):
    alpha = atan2_refined(sqrt(hx * hx + hy * hy), hz)
    e = gaussian_c2_from_beta(beta) * alpha
    return gaussian_norm(beta) * exp(-e * e)


def D_trowbridge_reitz(hx, hy, hz, ax, ay):
    x, y = div(hx, ax), div(hy, ay)
    e = x * x + y * y + hz * hz
    return div(1.0, PI * ax * ay * e * e)


def D_beckmann(hx, hy, hz, ax, ay):
    x, y = div(hx, ax), div(hy, ay)
    hz2 = hz * hz
    return div(exp(-div(x * x + y * y, hz2)), PI * ax * ay * hz2 * hz2)


# --------------------------------------------------------------------------
# Smith's Lambda (slide "Self-Shadowing Function")

def Lambda_trowbridge_reitz(wx, wy, wz, ax, ay):
    x, y = wx * ax, wy * ay
    return 0.5 * (sqrt(1.0 + div(x * x + y * y, wz * wz)) - 1.0)


def Lambda_beckmann(wx, wy, wz, ax, ay):
    """(erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt pi), a = 1/(m tan theta); 0 at
    normal incidence (r = 0: a is set to 0 and both terms cancel below)."""
    x, y = wx * ax, wy * ay
    r = sqrt(x * x + y * y)
    a = div(wz, r)
    lam = 0.5 * (div(exp(-a * a), a * SQRT_PI) - erfc(a))
    return select(gt(r, 0.0), fmax(lam, 0.0), 0.0)


def S_smith_1967(wx, wy, wz, ax, ay):
    """The slide's bracket form: [1 - erfc(a)/2] / (1 + Lambda)."""
    x, y = wx * ax, wy * ay
    r = sqrt(x * x + y * y)
    bracket = select(gt(r, 0.0), 1.0 - 0.5 * erfc(div(wz, r)), 1.0)
    return div(bracket, 1.0 + Lambda_beckmann(wx, wy, wz, ax, ay))


def lambda_chebyshev_coefficients(distribution: str, beta):
    """The coefficients in x of the series for this beta (the beta part of
    the two-dimensional series, summed once per shading point, three
    coefficients per vector operation; folded to constants wherever beta is
    constant)."""
    table = _series.LAMBDA[distribution]
    tb = _beta_series_variable(beta)
    out = []
    for first in range(0, _series.NX, 3):  # three columns per vector series
        columns = list(range(first, min(first + 3, _series.NX)))
        series = chebyshev([E.packed(*([row[i] for i in columns] + [0.0] * (3 - len(columns))))
                            for row in table], tb)
        out.extend(series[k] for k in range(len(columns)))
    return out


def Lambda_chebyshev_x(wx, wy, wz, m, coefficients):
    """Smith Lambda of Blinn or Gaussian from the series: Lambda = g(x)/a,
    a = cot(theta)/m, x = (2/pi) atan(a); 0 at normal incidence."""
    rm = sqrt(wx * wx + wy * wy) * m
    x = atan2_refined(wz, rm) * (2.0 / PI)
    g = chebyshev(coefficients, 2.0 * clamp(x, 0.0, 1.0) - 1.0)
    return select(gt(rm, 0.0), fmax(g * div(rm, wz), 0.0), 0.0)


# --------------------------------------------------------------------------
# Shadowing and Fresnel

def G_vgroove(ci, co, ch, cih):
    """min(1, 2(N.H)(N.E)/(E.H), 2(N.H)(N.L)/(L.H)); E.H = L.H."""
    return fmin(1.0, div(2.0 * ch * fmin(ci, co), cih))


def F_dielectric(c, ior):
    """Exact unpolarised Fresnel of a real index (Cook & Torrance 1982);
    total internal reflection gives 1."""
    g2 = ior * ior - 1.0 + c * c
    g = sqrt(fmax(g2, 0.0))
    a = div(g - c, g + c)
    b = div(c * (g + c) - 1.0, c * (g - c) + 1.0)
    return select(gt(g2, 0.0), 0.5 * a * a * (1.0 + b * b), 1.0)


def F_conductor(c, n, k):
    """Exact unpolarised Fresnel of a complex index n + ik (Born & Wolf)."""
    c2 = c * c
    s2 = 1.0 - c2
    t0 = (n * n - k * k - 1.0) + c2  # n^2 - k^2 - sin^2: 1 - c2 loses c2 near grazing
    ab2 = sqrt(t0 * t0 + 4.0 * n * n * k * k)
    a = sqrt(fmax(0.5 * (ab2 + t0), 0.0))
    two_ac = 2.0 * a * c
    rs = div(ab2 - two_ac + c2, ab2 + two_ac + c2)
    pu = c2 * ab2 + s2 * s2
    pv = two_ac * s2
    rp = rs * div(pu - pv, pu + pv)
    return 0.5 * (rs + rp)


# The Lambertian-weighted mean of L.H over the lights at a view (H the half
# vector): (1/pi) int sqrt((1 + L.V)/2) cos(theta_i) dw_i, as a quadratic in
# cos(theta_o), within 4e-4 of the integral (a least-squares fit; the test
# integrates it again).
MEAN_LIGHT_HALF_COSINE = (0.6794, 0.2620, -0.0313)


def mean_light_half_cosine(co):
    """L.H averaged over the lights a diffuse lobe reflects, at the view
    cos theta_o (:data:`MEAN_LIGHT_HALF_COSINE`): 0.679 at grazing, 0.910
    at the normal.  Where a lobe has no half vector of its own (the fitted
    mixtures' diffuse member), the model's Fresnel is taken there."""
    c0, c1, c2 = MEAN_LIGHT_HALF_COSINE
    return c0 + co * (c1 + c2 * co)


def per_channel(f, *colours_and_floats):
    """Apply a float formula to each channel of colour arguments (floats are
    shared): a colour."""
    def arg(a, i):
        a = E.wrap(a)
        return a[i] if a.kind == "v" else a
    return E.vec(*(f(*(arg(a, i) for a in colours_and_floats)) for i in range(3)))


# --------------------------------------------------------------------------
# Inputs: clamping to the catalogue's limits

def clamped(param, value=None):
    """The parameter's input clamped to its catalogue limits (NaN to the
    lower limit): bad input renders like the range's limit."""
    value = E.input_(param.name, "v" if param.kind == "color" else "f") if value is None else value
    if param.minimum is None:
        return value
    return E.clamp_input(value, param.minimum, param.maximum)


def unit_or_zero(v):
    """The direction of a vector input: unit length, or zero when it is
    unset (zero, or with a NaN or infinite component).  Any finite length
    works: a vector far from unit length is first scaled by exact powers of
    two, so the result is bit-identical to that of the unit vector."""
    big = 3.4028234663852886e38
    ok = E.finite(v[0]) * E.finite(v[1]) * E.finite(v[2])
    comps = [E.clamp_input(v[i], -big, big) * ok for i in range(3)]
    m = fmax(fmax(E.fabs(comps[0]), E.fabs(comps[1])), E.fabs(comps[2]))
    # one factor, so no compiler can fold two scalings into an infinite one
    # (Mesa's did, for the zero vector: 0 * (2^80 2^80) is NaN)
    large = select(gt(m, 2.0 ** 60), 2.0 ** -68, 1.0)  # m < 2^128: now < 2^60
    tiny = select(lt(m, 2.0 ** -100), 2.0 ** 126, 2.0 ** 80)  # m >= 2^-149 (subnormal)
    return E.normalize(E.vscale(E.vec(*comps), select(lt(m, 2.0 ** -60), tiny, large)))


def is_zero(v):
    """1 where the vector is exactly zero."""
    return 1.0 - gt(E.dot(v, v), 0.0)


def Lambda_beckmann_rational(wx, wy, wz, ax, ay):
    """Cycles' Beckmann Lambda (the closure's, not the model's): Walter
    2007's rational approximation below Heitz 2014, eq. 69; 0 where
    a = 1/(alpha tan theta) >= 1.6."""
    x, y = wx * ax, wy * ay
    t2 = div(x * x + y * y, wz * wz)
    a = div(1.0, sqrt(t2))
    lam = div((0.396 * a - 1.259) * a + 1.0, (2.181 * a + 3.535) * a)
    return select(lt(t2, 0.39), 0.0, lam)
