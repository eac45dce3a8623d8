# SPDX-License-Identifier: GPL-3.0-or-later
"""Microfacet distributions: the half-angle beta, D, Smith's Lambda and G1.

Slides "Microfacet Distributions" (normalisation), "Microfacet Distribution
Functions" (beta and the four distributions), "Gaussian Rough Surface",
"Self-Shadowing Function", "Self-Consistency Condition".  Errata in
``shared/LECTURE-NOTES.md``; each fix is named next to its formula.

One type per distribution (:class:`Blinn`, :class:`Gaussian`,
:class:`TrowbridgeReitz`, :class:`Beckmann`) exposes ``D``, ``Lambda`` and
``G1`` on local components (x along the tangent, z along the normal), as
pbrt-v4's distribution types do; :func:`distribution` makes one from a name
and a width.  The module-level functions (``D_blinn``, ``Lambda_beckmann``,
...) are the same formulas with explicit widths: the public API that the
OSL library mirrors by name and argument order.

Smith's Lambda of Blinn and Gaussian has no closed form.  Its definition is
the self-consistency integral, :func:`Aminus_quadrature`; the one
approximation used everywhere (here and in the shaders) is its Chebyshev
series :func:`Lambda_chebyshev`, within 1e-6 of the quadrature in G1.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .. import catalogue
from .ranges import within as _within
from .special import SQRT_PI, clenshaw, erfcx_nonnegative, gauss_legendre

PI = math.pi
LN2 = math.log(2.0)


# --------------------------------------------------------------------------
# beta, D(beta) = D(0)/2, and the native widths
# --------------------------------------------------------------------------

# the Gaussian c2 whose beta is pi/2: smaller ones put D's half beyond the hemisphere
GAUSSIAN_C2_MIN = math.sqrt(LN2) / (0.5 * PI)


def blinn_exponent_from_beta(beta):
    """Blinn exponent c with cos^c(beta) = 1/2.

    Erratum: the slide prints c = ln 2 / ln cos(beta), which is negative; the
    defining property D(beta) = D(0)/2 needs c = -ln 2 / ln cos(beta).
    """
    return -LN2 / np.log(np.cos(_within(beta, "beta", 0.0, 0.5 * PI)))


def beta_from_blinn_exponent(c):
    """Inverse of :func:`blinn_exponent_from_beta`: cos(beta) = 2^(-1/c)."""
    return np.arccos(np.exp2(-1.0 / _within(c, "exponent", 0.0)))


def gaussian_c2_from_beta(beta):
    """Gaussian (Torrance-Sparrow) width c2 with exp(-(c2 beta)^2) = 1/2.

    Erratum: the slide prints c2 = sqrt(2)/beta, which gives D(beta) = e^-2;
    the defining property needs c2 = sqrt(ln 2)/beta.
    """
    return math.sqrt(LN2) / _within(beta, "beta", 0.0, 0.5 * PI)


def beta_from_gaussian_c2(c2):
    """Inverse of :func:`gaussian_c2_from_beta`."""
    return math.sqrt(LN2) / _within(c2, "c2", GAUSSIAN_C2_MIN)


TR_ALPHA_BETA_LIMIT = 2.0 ** -0.25
"""A GGX D never falls to half its peak on the hemisphere once alpha reaches this."""


def tr_alpha_from_beta(beta):
    """Trowbridge-Reitz c3 (= GGX alpha) with D(beta) = D(0)/2.

    c3^2 = (cos^2 beta - 1)/(cos^2 beta - sqrt 2); the slide lost the square of
    D, without which this c3 would not satisfy D(beta) = D(0)/2.
    """
    x = np.cos(_within(beta, "beta", 0.0, 0.5 * PI)) ** 2
    return np.sqrt((x - 1.0) / (x - math.sqrt(2.0)))


def beta_from_tr_alpha(alpha):
    """Inverse of :func:`tr_alpha_from_beta`: cos^2 beta = (1 - sqrt2 a^2)/(1 - a^2).

    Raises ValueError for alpha >= 2^(-1/4) ~ 0.8409, where beta is undefined.
    """
    a2 = np.asarray(alpha, dtype=float) ** 2
    if not np.all(a2 < TR_ALPHA_BETA_LIMIT ** 2) or np.any(a2 <= 0.0):  # NaN too
        raise ValueError(
            "beta is undefined for Trowbridge-Reitz alpha outside (0, 2^(-1/4) ~ 0.8409): "
            "D never falls to half its peak; use the native alpha")
    return np.arccos(np.sqrt((1.0 - math.sqrt(2.0) * a2) / (1.0 - a2)))


def beckmann_m_from_beta(beta):
    """Beckmann m with D(beta) = D(0)/2: m = tan(beta)/sqrt(ln 2 - 4 ln cos(beta))."""
    beta = _within(beta, "beta", 0.0, 0.5 * PI)
    return np.tan(beta) / np.sqrt(LN2 - 4.0 * np.log(np.cos(beta)))


def beta_from_beckmann_m(m):
    """Inverse of :func:`beckmann_m_from_beta`, by bisection on x = cos^2(beta).

    f(x) = (1/x - 1)/m^2 - ln 2 + 2 ln x has exactly one root in (0, 1): it
    falls from +inf, and if it rises again (m^2 > 1/2) it ends at -ln 2 < 0.
    """
    m2 = _within(m, "m", 0.0) ** 2
    lo = np.zeros_like(m2)  # f(lo) > 0
    hi = np.minimum(1.0, 1.0 / (2.0 * m2))  # f decreasing on (0, hi], f(hi) < 0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        f = (1.0 / mid - 1.0) / m2 - LN2 + 2.0 * np.log(mid)
        lo = np.where(f > 0.0, mid, lo)
        hi = np.where(f > 0.0, hi, mid)
    return np.arccos(np.sqrt(0.5 * (lo + hi)))


# --------------------------------------------------------------------------
# Distributions, normalised so that  int D(h) cos(theta_h) dw_h = 1.
# Arguments: the half vector's local components; D is 0 below the surface.
# --------------------------------------------------------------------------

GAUSSIAN_NORM_NODES = 64
LOG_D_CUT = math.log(1e-18)  # D/D(0) below this contributes nothing in float64


def gaussian_alpha_cut(c2):
    """Tilt beyond which the Gaussian D is below 1e-18 of its peak (<= pi/2)."""
    return np.minimum(0.5 * PI, math.sqrt(-LOG_D_CUT) / c2)


def blinn_alpha_cut(c):
    """Tilt beyond which the Blinn D is below 1e-18 of its peak (<= pi/2)."""
    return np.arccos(np.exp(LOG_D_CUT / c))


@functools.lru_cache(maxsize=4096)
def _gaussian_norm_scalar(beta: float) -> float:
    return float(_gaussian_norm_vec(np.array([beta]))[0])


def _gaussian_norm_vec(beta):
    c2 = gaussian_c2_from_beta(beta)[..., None]
    cut = gaussian_alpha_cut(c2)
    s, w = gauss_legendre(GAUSSIAN_NORM_NODES)
    a = cut * s
    integral = np.sum(w * cut * np.exp(-(c2 * a) ** 2) * np.sin(a) * np.cos(a), axis=-1)
    return 1.0 / (2.0 * PI * integral)


def gaussian_norm(beta):
    """Normalisation K of the Gaussian D = K exp(-(c2 alpha)^2).

    No closed form (lecture notes): 64-point Gauss-Legendre quadrature of
    2 pi int exp(-(c2 a)^2) cos(a) sin(a) da over [0, cut], where cut is the
    tilt at which D has fallen to 1e-18 of its peak.  Cached per beta.
    """
    beta = np.asarray(beta, dtype=float)
    if beta.ndim == 0:
        return np.float64(_gaussian_norm_scalar(float(beta)))
    uniq, inv = np.unique(beta, return_inverse=True)
    return np.array([_gaussian_norm_scalar(float(b)) for b in uniq])[inv].reshape(beta.shape)


def _tan2(hx, hy, hz):
    return np.divide(hx * hx + hy * hy, np.multiply(hz, hz))  # numpy's inf at hz = 0


def _native(a, name):
    """A native width (GGX alpha, Beckmann m) as a float array: finite and
    above 0, else ValueError naming the range (a negative one would give the
    same lobe as its absolute value, 0 a division by zero)."""
    return _within(a, name, 0.0)


def _upper_only(d, hz):
    """``d`` where the facet normal is above the surface (hz > 0), else 0:
    microfacets face outward, every D is normalised over the upper hemisphere.
    A NaN stays NaN."""
    return np.where(np.asarray(hz) <= 0.0, 0.0, d)  # d is NaN where hz is


def D_blinn(hx, hy, hz, beta):
    """Blinn: D = (c+2)/(2 pi) cos^c(alpha), c = -ln2/ln cos(beta) (slide, erratum fixed).

    cos^c is evaluated as exp(-c/2 ln(1 + tan^2)) so narrow lobes keep precision.
    """
    c = blinn_exponent_from_beta(beta)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = (c + 2.0) / (2.0 * PI) * np.exp(-0.5 * c * np.log1p(_tan2(hx, hy, hz)))
    return _upper_only(d, hz)


def D_gaussian(hx, hy, hz, beta):
    """Gaussian (Torrance-Sparrow): D = K exp(-(c2 alpha)^2), c2 = sqrt(ln2)/beta."""
    alpha = np.arctan2(np.sqrt(hx * hx + hy * hy), hz)
    d = gaussian_norm(beta) * np.exp(-(gaussian_c2_from_beta(beta) * alpha) ** 2)
    return _upper_only(d, hz)


def D_trowbridge_reitz(hx, hy, hz, ax, ay):
    """Trowbridge-Reitz = GGX (Walter 2007, eq. 33; anisotropic form of Heitz 2014)."""
    ax, ay = _native(ax, "ax"), _native(ay, "ay")
    e = (hx / ax) ** 2 + (hy / ay) ** 2 + hz * hz
    with np.errstate(divide="ignore"):
        return _upper_only(1.0 / (PI * ax * ay * e * e), hz)


def D_beckmann(hx, hy, hz, ax, ay):
    """Beckmann: exp(-tan^2/m^2)/(pi m^2 cos^4) (Walter 2007, eq. 25).

    The slide prints 1/(sqrt(pi) m^2 cos^2), which does not integrate to 1
    under int D cos = 1; the normalised form is used.
    """
    ax, ay = _native(ax, "ax"), _native(ay, "ay")
    hz2 = np.multiply(hz, hz)  # an array: numpy's inf at hz = 0, not ZeroDivisionError
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        d = np.exp(-((hx / ax) ** 2 + (hy / ay) ** 2) / hz2) / (PI * ax * ay * hz2 * hz2)
    return _upper_only(d, hz)


# --------------------------------------------------------------------------
# Smith's Lambda (slide: "Self-Shadowing Function"; Walter 2007).
# Arguments: a direction's local components.  A direction on or below the
# surface (wz <= 0, NaN too) has an infinite Lambda: G1 = 0, as the series'.
# --------------------------------------------------------------------------

def Lambda_trowbridge_reitz(wx, wy, wz, ax, ay):
    """Lambda = (-1 + sqrt(1 + alpha^2 tan^2 theta))/2, alpha projected on the
    direction's azimuth (Heitz 2014, eq. 86)."""
    ax, ay = _native(ax, "ax"), _native(ay, "ay")
    with np.errstate(divide="ignore", invalid="ignore"):  # grazing: infinite (G1 = 0)
        a2t2 = ((wx * ax) ** 2 + (wy * ay) ** 2) / (wz * wz)
        lam = 0.5 * (np.sqrt(1.0 + a2t2) - 1.0)
    return np.where(np.asarray(wz) > 0.0, lam, np.inf)


def Lambda_beckmann(wx, wy, wz, ax, ay):
    """Lambda = (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt pi), a = 1/(m tan theta)
    (Walter 2007, eq. 27; the slide's 2 Lambda with its RMS slope m/sqrt2),
    evaluated as exp(-a^2) (1/(a sqrt pi) - R(a))/2, R(a) = erfc(a) exp(a^2)."""
    ax, ay = _native(ax, "ax"), _native(ay, "ay")
    r = np.sqrt((wx * ax) ** 2 + (wy * ay) ** 2)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a = wz / r
        a = np.where(a > 0.0, a, 0.0)  # the others are left out below
        lam = 1.0 / (a * SQRT_PI)
        lam -= erfcx_nonnegative(a)
        # exp not split as erfc's is: within 3e-13 of 40-digit mpmath up to a = 30 (measured)
        lam *= np.exp(-a * a)
        lam *= 0.5
    return np.where(np.asarray(wz) > 0.0, np.where(r > 0.0, np.maximum(lam, 0.0), 0.0), np.inf)


# Numerical Lambda for distributions without a closed form (Blinn, Gaussian).
#
# Self-consistency slide: Lambda(w) = (1/cos theta) int max(0, -w.m) D(m) dm.
# The azimuthal integral is done analytically: for A = sin(theta) sin(alpha),
# B = cos(theta) cos(alpha),
#   int_0^{2pi} max(0, -A cos(phi) - B) dphi = 2 (sqrt(A^2 - B^2) - B acos(B/A)),
# non-zero only for alpha > pi/2 - theta.  The tilt integral uses
# Gauss-Legendre nodes after alpha = alpha0 + (cut - alpha0) s^2 (3 - 2s): the
# map is flat at both ends, which removes the square-root behaviour at alpha0
# and softens the (pi/2 - alpha)^c end of a wide Blinn lobe.

LAMBDA_NODES = 32


def _D_of_alpha(alpha, beta, distribution):
    if distribution == "blinn":
        c = blinn_exponent_from_beta(beta)
        return (c + 2.0) / (2.0 * PI) * np.cos(alpha) ** c
    c2 = gaussian_c2_from_beta(beta)
    return gaussian_norm(beta) * np.exp(-(c2 * alpha) ** 2)


def _alpha_cut(beta, distribution):
    if distribution == "blinn":
        return blinn_alpha_cut(blinn_exponent_from_beta(beta))
    return gaussian_alpha_cut(gaussian_c2_from_beta(beta))


def Aminus_quadrature(cos_theta, beta, distribution, nodes=LAMBDA_NODES):
    """Projected area of the back-facing facets, A-(theta) = cos(theta) Lambda(theta):
    the definition of Smith's Lambda for 'blinn' and 'gaussian'.

    ``beta`` must be a scalar; ``cos_theta`` may be an array (clamped to
    [0, 1]); ``nodes`` is the number of Gauss-Legendre nodes.  Raises
    ValueError naming what is allowed otherwise.
    """
    if distribution not in ("blinn", "gaussian"):
        raise ValueError(f"distribution={distribution!r}; the quadrature is for 'blinn' and "
                         "'gaussian' (the others have closed forms)")
    if isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)) or nodes < 1:
        raise ValueError(f"nodes={nodes!r} is not allowed; nodes must be a positive integer")
    if np.ndim(beta) != 0:
        raise ValueError(f"beta must be a scalar here, not an array of shape {np.shape(beta)}")
    _within(beta, "beta", 0.0, 0.5 * PI)
    cos_theta = np.clip(np.asarray(cos_theta, dtype=float), 0.0, 1.0)
    theta = np.arccos(cos_theta)[..., None]
    alpha0 = 0.5 * PI - theta
    cut = _alpha_cut(beta, distribution)
    span = np.maximum(cut - alpha0, 0.0)
    s, w = gauss_legendre(nodes)
    alpha = alpha0 + span * (s * s * (3.0 - 2.0 * s))
    jac = 6.0 * span * s * (1.0 - s)
    # A^2 - B^2 = -cos(theta + alpha) cos(theta - alpha), exact near alpha0.
    diff = np.maximum(-np.cos(theta + alpha) * np.cos(theta - alpha), 0.0)
    root = np.sqrt(diff)
    B = np.cos(theta) * np.cos(alpha)
    inner = 2.0 * (root - B * np.arctan2(root, B))
    integrand = _D_of_alpha(alpha, beta, distribution) * np.sin(alpha) * inner * jac
    return np.sum(w * integrand, axis=-1)


# The series: g(beta, x) = a Lambda with a = cot(theta)/m(beta) (m: Beckmann's m
# at the same beta, which makes g nearly independent of beta and smooth) and
# x = (2/pi) atan(a) in [0, 1], a two-dimensional Chebyshev series, CHEB_NB
# terms along beta over the catalogue's range and CHEB_NX along x,
# interpolating the quadrature (96 nodes) at the Chebyshev points.  Measured
# max |dLambda|/(1 + Lambda) against the quadrature below 1e-6 for beta in
# [1, 85] deg (tests/test_reference.py).  The shaders evaluate the same
# series (its coefficients: addon/core/fits/smith_lambda.py).
CHEB_NB = 28
CHEB_NX = 20
CHEB_BETA = (catalogue.BETA_MIN, catalogue.BETA_MAX)


def _cheb_points(n):
    """Chebyshev points t_k = cos(pi (k + 1/2) / n) and T_j(t_k) as (n, n)."""
    t = np.cos(PI * (np.arange(n) + 0.5) / n)
    return t, np.polynomial.chebyshev.chebvander(t, n - 1)


@functools.lru_cache(maxsize=None)
def lambda_chebyshev(distribution):
    """The (CHEB_NB, CHEB_NX) coefficients c[j, i] of
    g(beta, x) = sum c[j, i] T_j(tb) T_i(2x - 1), with
    tb = 2 (beta - CHEB_BETA[0]) / (CHEB_BETA[1] - CHEB_BETA[0]) - 1 and x as
    above, for 'blinn' or 'gaussian'.  Computed in about 0.3 s (discrete
    cosine transform of the quadrature at the Chebyshev points).
    """
    if distribution not in ("blinn", "gaussian"):
        raise ValueError(f"distribution={distribution!r}; the series exists for 'blinn' "
                         "and 'gaussian' (the others have closed forms)")
    tb, vb = _cheb_points(CHEB_NB)
    tx, vx = _cheb_points(CHEB_NX)
    betas = CHEB_BETA[0] + (CHEB_BETA[1] - CHEB_BETA[0]) * 0.5 * (tb + 1.0)
    a = np.tan(0.25 * PI * (tx + 1.0))  # x = (tx + 1)/2 lies strictly inside (0, 1)
    values = np.empty((CHEB_NB, CHEB_NX))
    for j, beta in enumerate(betas):
        m = float(beckmann_m_from_beta(beta))
        am = a * m
        aminus = Aminus_quadrature(am / np.sqrt(1.0 + am * am), beta, distribution, nodes=96)
        values[j] = aminus * np.sqrt(1.0 + am * am) / m
    coeffs = (2.0 / CHEB_NB) * (2.0 / CHEB_NX) * (vb.T @ values @ vx)
    coeffs[0, :] *= 0.5
    coeffs[:, 0] *= 0.5
    coeffs.setflags(write=False)
    return coeffs


def Lambda_chebyshev(wx, wy, wz, beta, distribution):
    """Smith Lambda of the Blinn or Gaussian distribution from the Chebyshev
    series of :func:`lambda_chebyshev`.  ``beta`` broadcasts."""
    coeffs = lambda_chebyshev(distribution)
    wx, wy, wz, beta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (wx, wy, wz, beta)))
    r = np.sqrt(wx * wx + wy * wy)
    m = beckmann_m_from_beta(beta)
    x = np.arctan2(wz, r * m) * (2.0 / PI)
    if beta.ndim == 0 or np.all(beta == beta.flat[0]):  # one beta: sum its part once
        b0 = float(beta.flat[0]) if beta.ndim else float(beta)
        tb = 2.0 * (b0 - CHEB_BETA[0]) / (CHEB_BETA[1] - CHEB_BETA[0]) - 1.0
        cx = clenshaw(tb, coeffs)  # (NX,)
        cx = cx.reshape(cx.shape + (1,) * x.ndim)
    else:
        tb = 2.0 * (beta - CHEB_BETA[0]) / (CHEB_BETA[1] - CHEB_BETA[0]) - 1.0
        cx = clenshaw(tb[None, ...], coeffs.reshape(coeffs.shape + (1,) * tb.ndim))
    g = clenshaw(2.0 * np.clip(x, 0.0, 1.0) - 1.0, cx)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.maximum(g * (r * m) / wz, 0.0)  # the series wiggles by ~1e-10 near 0
    lam = np.where(wz > 0.0, lam, np.inf)
    outside = (beta < CHEB_BETA[0]) | (beta > CHEB_BETA[1])
    if np.any(outside):
        # Beyond the catalogue's range the series extrapolates (6 % off at
        # beta 88 deg, ten times at 89.9): the quadrature it interpolates.
        norm = np.sqrt(wx * wx + wy * wy + wz * wz)
        for b in np.unique(beta[outside]):
            sel = outside & (beta == b) & (wz > 0.0)
            c = wz[sel] / norm[sel]
            lam[sel] = Aminus_quadrature(c, float(b), distribution, nodes=96) / c
    return lam


def Lambda_table(wx, wy, wz, beta, distribution):
    """The same as :func:`Lambda_chebyshev` (kept for scripts written against
    the earlier tabulated form, which the series replaced)."""
    return Lambda_chebyshev(wx, wy, wz, beta, distribution)


# --------------------------------------------------------------------------
# The types
# --------------------------------------------------------------------------

class Distribution:
    """A normalised microfacet distribution with a fixed width.

    ``D(hx, hy, hz)``: the density of facet normals (int D cos = 1);
    ``Lambda(wx, wy, wz)``: Smith's Lambda for a direction; ``G1``: Smith's
    masking 1/(1 + Lambda); ``G(wi, wo, correlated)``: separable
    G1(wi) G1(wo) (the lecture's S(theta_i) S(theta_r)) or height-correlated
    1/(1 + Lambda_i + Lambda_o) (Cycles').  Local components: x along the
    tangent, z along the normal.
    """

    name = ""
    isotropic = True

    def D(self, hx, hy, hz):
        raise NotImplementedError

    def Lambda(self, wx, wy, wz):
        raise NotImplementedError

    def G1(self, wx, wy, wz):
        return 1.0 / (1.0 + self.Lambda(wx, wy, wz))

    def G(self, wi, wo, correlated=False):
        li, lo = self.Lambda(*wi), self.Lambda(*wo)
        if correlated:
            return 1.0 / (1.0 + li + lo)
        return 1.0 / ((1.0 + li) * (1.0 + lo))

    def __repr__(self):
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in vars(self).items())})"


class Blinn(Distribution):
    """D = (c+2)/(2 pi) cos^c(alpha) at half-angle ``beta``; numerical Lambda."""
    name = "blinn"

    def __init__(self, beta):
        self.beta = _within(beta, "beta", 0.0, 0.5 * PI)

    @property
    def exponent(self):
        return blinn_exponent_from_beta(self.beta)

    def D(self, hx, hy, hz):
        return D_blinn(hx, hy, hz, self.beta)

    def Lambda(self, wx, wy, wz):
        return Lambda_chebyshev(wx, wy, wz, self.beta, self.name)


class Gaussian(Blinn):
    """Torrance-Sparrow's D = K exp(-(c2 alpha)^2) at half-angle ``beta``."""
    name = "gaussian"

    @property
    def c2(self):
        return gaussian_c2_from_beta(self.beta)

    def D(self, hx, hy, hz):
        return D_gaussian(hx, hy, hz, self.beta)


class TrowbridgeReitz(Distribution):
    """GGX with widths ``alpha_x`` (along the tangent) and ``alpha_y``."""
    name = "trowbridge_reitz"

    def __init__(self, alpha_x, alpha_y=None):
        self.alpha_x = _native(alpha_x, "alpha_x")
        self.alpha_y = self.alpha_x if alpha_y is None else _native(alpha_y, "alpha_y")
        self.isotropic = alpha_y is None

    @classmethod
    def from_beta(cls, beta):
        return cls(tr_alpha_from_beta(beta))

    def D(self, hx, hy, hz):
        return D_trowbridge_reitz(hx, hy, hz, self.alpha_x, self.alpha_y)

    def Lambda(self, wx, wy, wz):
        return Lambda_trowbridge_reitz(wx, wy, wz, self.alpha_x, self.alpha_y)


class Beckmann(TrowbridgeReitz):
    """Beckmann with RMS-slope widths ``alpha_x``, ``alpha_y`` (m = 2 sigma / tau)."""
    name = "beckmann"

    @classmethod
    def from_beta(cls, beta):
        return cls(beckmann_m_from_beta(beta))

    def D(self, hx, hy, hz):
        return D_beckmann(hx, hy, hz, self.alpha_x, self.alpha_y)

    def Lambda(self, wx, wy, wz):
        return Lambda_beckmann(wx, wy, wz, self.alpha_x, self.alpha_y)


TYPES = {cls.name: cls for cls in (Blinn, Gaussian, TrowbridgeReitz, Beckmann)}


def distribution(name, *, beta=None, alpha=None, alpha_x=None, alpha_y=None) -> Distribution:
    """The distribution ``name`` with one width: ``beta`` (any distribution),
    ``alpha`` or ``alpha_x`` with ``alpha_y`` (Trowbridge-Reitz and Beckmann).
    Raises ValueError naming what is allowed."""
    if name not in TYPES:
        raise ValueError(f"unknown distribution {name!r}; allowed: {', '.join(TYPES)}")
    cls = TYPES[name]
    given = [k for k, v in (("beta", beta), ("alpha", alpha), ("alpha_x", alpha_x),
                            ("alpha_y", alpha_y)) if v is not None]
    if given == ["beta"]:
        return cls(beta) if cls in (Blinn, Gaussian) else cls.from_beta(beta)
    if cls in (Blinn, Gaussian):
        raise ValueError(f"{name!r} takes beta only (got {', '.join(given) or 'no width'})")
    if given == ["alpha"]:
        return cls(_native(alpha, "alpha"))
    if given == ["alpha_x", "alpha_y"]:
        return cls(alpha_x, alpha_y)
    raise ValueError(f"give one width for {name!r}: beta, alpha, or alpha_x with alpha_y "
                     f"(got {', '.join(given) or 'none'})")
