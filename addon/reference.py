# SPDX-License-Identifier: GPL-3.0-or-later
"""Numpy reference of every reflection model in the catalogue.

Public API (scripts and tests depend on it)::

    shade(model, wi, wo, *, normal=(0, 0, 1), tangent=(1, 0, 0), **params) -> (..., 3)
    brdf(model, wi, wo, *, normal=(0, 0, 1), tangent=(1, 0, 0), **params)  -> (..., 3)

``shade`` is the radiance reflected toward ``wo`` under a directional light of
unit irradiance: what a pixel of an orthographic Cycles render under a sun of
strength 1 shows.  For surface models it is ``brdf * max(0, normal . wi)``.
Directions are unit vectors pointing away from the surface (``wi`` toward the
light, ``wo`` toward the eye) and broadcast over leading axes, as do
array-valued parameters.  Colours are RGB triples (a trailing axis of length 3);
a scalar colour is grey.  Angles are radians.

Conventions and slide errata: ``shared/LECTURE-NOTES.md``.  Function names
mirror the OSL header ``osl/rm_common.h`` (same names, same argument order).
Needs numpy only.
"""

from __future__ import annotations

import functools
import math
import os

import numpy as np

from . import catalogue

PI = math.pi
LN2 = math.log(2.0)
SQRT_PI = math.sqrt(PI)

__all__ = [
    "shade", "brdf", "erf", "erfc",
    "blinn_exponent_from_beta", "beta_from_blinn_exponent",
    "gaussian_c2_from_beta", "beta_from_gaussian_c2", "gaussian_norm",
    "tr_alpha_from_beta", "beta_from_tr_alpha", "TR_ALPHA_BETA_LIMIT",
    "beckmann_m_from_beta", "beta_from_beckmann_m",
    "D_blinn", "D_gaussian", "D_trowbridge_reitz", "D_beckmann",
    "Lambda_trowbridge_reitz", "Lambda_beckmann", "Lambda_table", "Lambda_chebyshev",
    "Aminus_quadrature", "G_vgroove", "S_smith_1967",
    "F_dielectric", "F_conductor",
]


# --------------------------------------------------------------------------
# Special functions
# --------------------------------------------------------------------------

def erfc(x):
    """Complementary error function, vectorised.

    Chebyshev fit of Press et al., Numerical Recipes (2nd ed.) sec. 6.2,
    ``erfcc``: fractional error below 1.2e-7 everywhere, which keeps the
    relative accuracy of erfc itself in the tail (unlike 1 - erf).
    """
    x = np.asarray(x, dtype=float)
    z = np.abs(x)
    t = 1.0 / (1.0 + 0.5 * z)
    poly = (-1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (
        -0.18628806 + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (
            -0.82215223 + t * 0.17087277)))))))))
    r = t * np.exp(-z * z + poly)
    return np.where(x >= 0.0, r, 2.0 - r)


def erf(x):
    """Error function, vectorised (1 - erfc)."""
    return 1.0 - erfc(x)


# --------------------------------------------------------------------------
# Beta (the highlight half-angle, D(beta) = D(0)/2) and native parameters.
# Slide: "Microfacet Distribution Functions".
# --------------------------------------------------------------------------

def blinn_exponent_from_beta(beta):
    """Blinn exponent c with cos^c(beta) = 1/2.

    Erratum: the slide prints c = ln 2 / ln cos(beta), which is negative; the
    defining property D(beta) = D(0)/2 needs c = -ln 2 / ln cos(beta).
    """
    return -LN2 / np.log(np.cos(beta))


def beta_from_blinn_exponent(c):
    """Inverse of :func:`blinn_exponent_from_beta`: cos(beta) = 2^(-1/c)."""
    return np.arccos(np.exp2(-1.0 / np.asarray(c, dtype=float)))


def gaussian_c2_from_beta(beta):
    """Gaussian (Torrance-Sparrow) width c2 with exp(-(c2 beta)^2) = 1/2.

    Erratum: the slide prints c2 = sqrt(2)/beta, which gives D(beta) = e^-2;
    the defining property needs c2 = sqrt(ln 2)/beta.
    """
    return math.sqrt(LN2) / np.asarray(beta, dtype=float)


def beta_from_gaussian_c2(c2):
    """Inverse of :func:`gaussian_c2_from_beta`."""
    return math.sqrt(LN2) / np.asarray(c2, dtype=float)


TR_ALPHA_BETA_LIMIT = 2.0 ** -0.25
"""A GGX D never falls to half its peak on the hemisphere once alpha reaches this."""


def tr_alpha_from_beta(beta):
    """Trowbridge-Reitz c3 (= GGX alpha) with D(beta) = D(0)/2.

    c3^2 = (cos^2 beta - 1)/(cos^2 beta - sqrt 2); the slide lost the square of
    D, without which this c3 would not satisfy D(beta) = D(0)/2.
    """
    x = np.cos(beta) ** 2
    return np.sqrt((x - 1.0) / (x - math.sqrt(2.0)))


def beta_from_tr_alpha(alpha):
    """Inverse of :func:`tr_alpha_from_beta`: cos^2 beta = (1 - sqrt2 a^2)/(1 - a^2).

    Raises ValueError for alpha >= 2^(-1/4) ~ 0.8409, where beta is undefined.
    """
    a2 = np.asarray(alpha, dtype=float) ** 2
    if np.any(a2 >= TR_ALPHA_BETA_LIMIT ** 2) or np.any(a2 <= 0.0):
        raise ValueError(
            "beta is undefined for Trowbridge-Reitz alpha outside (0, 2^(-1/4) ~ 0.8409): "
            "D never falls to half its peak; use the native alpha")
    return np.arccos(np.sqrt((1.0 - math.sqrt(2.0) * a2) / (1.0 - a2)))


def beckmann_m_from_beta(beta):
    """Beckmann m with D(beta) = D(0)/2: m = tan(beta)/sqrt(ln 2 - 4 ln cos(beta))."""
    beta = np.asarray(beta, dtype=float)
    return np.tan(beta) / np.sqrt(LN2 - 4.0 * np.log(np.cos(beta)))


def beta_from_beckmann_m(m):
    """Inverse of :func:`beckmann_m_from_beta`, by bisection on x = cos^2(beta).

    f(x) = (1/x - 1)/m^2 - ln 2 + 2 ln x has exactly one root in (0, 1): it
    falls from +inf, and if it rises again (m^2 > 1/2) it ends at -ln 2 < 0.
    """
    m2 = np.asarray(m, dtype=float) ** 2
    lo = np.zeros_like(m2)  # f(lo) > 0
    hi = np.minimum(1.0, 1.0 / (2.0 * m2))  # f decreasing on (0, hi], f(hi) < 0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        f = (1.0 / mid - 1.0) / m2 - LN2 + 2.0 * np.log(mid)
        lo = np.where(f > 0.0, mid, lo)
        hi = np.where(f > 0.0, hi, mid)
    return np.arccos(np.sqrt(0.5 * (lo + hi)))


# --------------------------------------------------------------------------
# Microfacet distributions, normalised so that  int D(h) cos(theta_h) dw_h = 1
# (slide: "Microfacet Distributions", Normalization).  Arguments: the half
# vector's local components (hx along the tangent, hz along the normal).
# --------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _gl_nodes(n):
    """Gauss-Legendre nodes and weights on [0, 1] (cached: leggauss solves an
    n x n eigenproblem)."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


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
    s, w = _gl_nodes(GAUSSIAN_NORM_NODES)
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
    return (hx * hx + hy * hy) / (hz * hz)


def D_blinn(hx, hy, hz, beta):
    """Blinn: D = (c+2)/(2 pi) cos^c(alpha), c = -ln2/ln cos(beta) (slide, erratum fixed).

    cos^c is evaluated as exp(-c/2 ln(1 + tan^2)) so narrow lobes keep precision.
    """
    c = blinn_exponent_from_beta(beta)
    return (c + 2.0) / (2.0 * PI) * np.exp(-0.5 * c * np.log1p(_tan2(hx, hy, hz)))


def D_gaussian(hx, hy, hz, beta):
    """Gaussian (Torrance-Sparrow): D = K exp(-(c2 alpha)^2), c2 = sqrt(ln2)/beta."""
    alpha = np.arctan2(np.sqrt(hx * hx + hy * hy), hz)
    return gaussian_norm(beta) * np.exp(-(gaussian_c2_from_beta(beta) * alpha) ** 2)


def D_trowbridge_reitz(hx, hy, hz, ax, ay):
    """Trowbridge-Reitz = GGX (Walter 2007, eq. 33; anisotropic form of Heitz 2014)."""
    e = (hx / ax) ** 2 + (hy / ay) ** 2 + hz * hz
    return 1.0 / (PI * ax * ay * e * e)


def D_beckmann(hx, hy, hz, ax, ay):
    """Beckmann: exp(-tan^2/m^2)/(pi m^2 cos^4) (Walter 2007, eq. 25).

    The slide prints 1/(sqrt(pi) m^2 cos^2), which does not integrate to 1
    under int D cos = 1; the normalised form is used.
    """
    hz2 = hz * hz
    return np.exp(-((hx / ax) ** 2 + (hy / ay) ** 2) / hz2) / (PI * ax * ay * hz2 * hz2)


# --------------------------------------------------------------------------
# Smith's Lambda (slide: "Self-Shadowing Function"; Walter 2007).
# Arguments: a direction's local components.
# --------------------------------------------------------------------------

def Lambda_trowbridge_reitz(wx, wy, wz, ax, ay):
    """Lambda = (-1 + sqrt(1 + alpha^2 tan^2 theta))/2, alpha projected on the
    direction's azimuth (Heitz 2014, eq. 86)."""
    a2t2 = ((wx * ax) ** 2 + (wy * ay) ** 2) / (wz * wz)
    return 0.5 * (np.sqrt(1.0 + a2t2) - 1.0)


def Lambda_beckmann(wx, wy, wz, ax, ay):
    """Lambda = (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt pi), a = 1/(m tan theta)
    (Walter 2007, eq. 27; the slide's 2 Lambda with its RMS slope m/sqrt2)."""
    r = np.sqrt((wx * ax) ** 2 + (wy * ay) ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = wz / r
        lam = 0.5 * (np.exp(-a * a) / (a * SQRT_PI) - erfc(a))
    return np.where(r > 0.0, np.maximum(lam, 0.0), 0.0)


def S_smith_1967(wx, wy, wz, ax, ay):
    """The slide's S(theta) = [1 - erfc(mu/(sqrt2 rms))/2] / (1 + Lambda).

    With rms = m/sqrt2 the argument is a = 1/(m tan theta).  The bracket is the
    chance that the point's own facet faces the ray; inside a microfacet BRDF
    it breaks the self-consistency condition (by up to ~50 %).
    """
    r = np.sqrt((wx * ax) ** 2 + (wy * ay) ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(r > 0.0, wz / r, np.inf)
    bracket = 1.0 - 0.5 * erfc(a)
    return bracket / (1.0 + Lambda_beckmann(wx, wy, wz, ax, ay))


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
    """Projected area of the back-facing facets, A-(theta) = cos(theta) Lambda(theta).

    ``beta`` must be a scalar; ``cos_theta`` may be an array.
    """
    cos_theta = np.clip(np.asarray(cos_theta, dtype=float), 0.0, 1.0)
    theta = np.arccos(cos_theta)[..., None]
    alpha0 = 0.5 * PI - theta
    cut = _alpha_cut(beta, distribution)
    span = np.maximum(cut - alpha0, 0.0)
    s, w = _gl_nodes(nodes)
    alpha = alpha0 + span * (s * s * (3.0 - 2.0 * s))
    jac = 6.0 * span * s * (1.0 - s)
    # A^2 - B^2 = -cos(theta + alpha) cos(theta - alpha), exact near alpha0.
    diff = np.maximum(-np.cos(theta + alpha) * np.cos(theta - alpha), 0.0)
    root = np.sqrt(diff)
    B = np.cos(theta) * np.cos(alpha)
    inner = 2.0 * (root - B * np.arctan2(root, B))
    integrand = _D_of_alpha(alpha, beta, distribution) * np.sin(alpha) * inner * jac
    return np.sum(w * integrand, axis=-1)


# The cached table g(beta, x) = a Lambda, with a = cot(theta)/m(beta) and
# x = (2/pi) atan(a) in [0, 1]; m(beta) is Beckmann's m at the same beta, which
# makes g nearly independent of beta and smooth in x (g -> A-(90 deg)/m at
# grazing, -> 0 at normal incidence).  Catmull-Rom along beta, linear along x:
# measured max |dLambda|/(1 + Lambda) below 2e-5 for beta in [1, 85] deg
# (tests/test_reference.py checks it against direct quadrature).
TABLE_BETA = np.linspace(0.5, 89.5, 179) * (PI / 180.0)
TABLE_X = np.linspace(0.0, 1.0, 1025)
TABLE_VERSION = 1


def _build_table(distribution):
    table = np.empty((TABLE_BETA.size, TABLE_X.size))
    a = np.tan(0.5 * PI * TABLE_X)
    for i, beta in enumerate(TABLE_BETA):
        m = float(beckmann_m_from_beta(beta))
        am = a * m
        cos_theta = am / np.sqrt(1.0 + am * am)  # cot(theta) = a m
        cos_theta[-1] = 1.0
        aminus = Aminus_quadrature(cos_theta, beta, distribution)
        # g = a Lambda = a A-/cos(theta) = A- sqrt(1 + (a m)^2)/m
        g = aminus * np.sqrt(1.0 + am * am) / m
        g[-1] = 0.0  # normal incidence: no back-facing facets
        table[i] = g
    return table


def _cache_dir():
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(root, "reflection_models")


@functools.lru_cache(maxsize=None)
def lambda_table(distribution):
    """The (beta, x) table of g = a Lambda for 'blinn' or 'gaussian'.

    Built once (about a second) and cached in memory and in
    ``~/.cache/reflection_models`` (``$XDG_CACHE_HOME`` is honoured).
    """
    path = os.path.join(_cache_dir(), f"lambda_{distribution}_v{TABLE_VERSION}.npy")
    try:
        table = np.load(path)
        if table.shape == (TABLE_BETA.size, TABLE_X.size):
            return table
    except (OSError, ValueError):
        pass
    table = _build_table(distribution)
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        tmp = f"{path}.{os.getpid()}.tmp.npy"
        np.save(tmp, table)
        os.replace(tmp, path)
    except OSError:
        pass  # a read-only cache only costs a rebuild next time
    return table


def Lambda_table(wx, wy, wz, beta, distribution):
    """Smith Lambda of the Blinn or Gaussian distribution, from the cached table."""
    table = lambda_table(distribution)
    r = np.sqrt(wx * wx + wy * wy)
    m = beckmann_m_from_beta(beta)
    x = np.arctan2(wz, r * m) * (2.0 / PI)  # (2/pi) atan(a), a = cot(theta)/m
    nb, nx = TABLE_BETA.size, TABLE_X.size
    fb = (beta - TABLE_BETA[0]) * ((nb - 1) / (TABLE_BETA[-1] - TABLE_BETA[0]))
    fx = np.clip(x, 0.0, 1.0) * (nx - 1)
    ib = np.clip(np.floor(fb).astype(np.intp), 1, nb - 3)
    ix = np.clip(np.floor(fx).astype(np.intp), 0, nx - 2)
    t = fb - ib
    tx = fx - ix
    flat = table.ravel()
    # Catmull-Rom weights along beta (rows ib-1 .. ib+2), linear along x.
    t2 = t * t
    t3 = t2 * t
    weights = (0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
               0.5 * (-3.0 * t3 + 4.0 * t2 + t), 0.5 * (t3 - t2))
    g = 0.0
    for j, wj in enumerate(weights):
        base = (ib + (j - 1)) * nx + ix
        row = flat[base]
        g = g + wj * (row + tx * (flat[base + 1] - row))
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = g * (r * m) / wz  # Lambda = g / a
    return np.where(wz > 0.0, lam, np.inf)


# The shaders' form of the same quadrature: g(beta, x) as a two-dimensional
# Chebyshev series, CHEB_NB terms along beta over the catalogue's range and
# CHEB_NX along x, interpolating the quadrature (96 nodes) at the Chebyshev
# points.  A shader evaluates it with a few hundred multiply-adds and no
# transcendental besides one atan2, instead of 2 x 32 quadrature nodes of
# about ten each; written out term by term (tools/gen_osl.py), its beta part
# folds to CHEB_NX constants when beta is constant.  Measured max
# |dLambda|/(1 + Lambda) against the quadrature below 1e-6 for beta in
# [1, 85] deg (tests/test_reference.py).
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
    in :func:`Lambda_table`, for 'blinn' or 'gaussian'.  Computed in about 0.3 s
    (discrete cosine transform of the values at the Chebyshev points).
    """
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


def _clenshaw(t, coeffs):
    """sum_k coeffs[k] T_k(t) over the first axis of ``coeffs`` (t broadcasts
    against the remaining axes); the recurrence the shaders write out."""
    b1 = np.zeros(np.broadcast_shapes(np.shape(t), coeffs.shape[1:]))
    b2 = np.zeros_like(b1)
    for c in coeffs[:0:-1]:
        b1, b2 = c + 2.0 * t * b1 - b2, b1
    return coeffs[0] + t * b1 - b2


def Lambda_chebyshev(wx, wy, wz, beta, distribution):
    """Smith Lambda of the Blinn or Gaussian distribution from the Chebyshev
    series of :func:`lambda_chebyshev`: what the shaders evaluate."""
    coeffs = lambda_chebyshev(distribution)
    wx, wy, wz, beta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (wx, wy, wz, beta)))
    r = np.sqrt(wx * wx + wy * wy)
    m = beckmann_m_from_beta(beta)
    x = np.arctan2(wz, r * m) * (2.0 / PI)
    tb = 2.0 * (beta - CHEB_BETA[0]) / (CHEB_BETA[1] - CHEB_BETA[0]) - 1.0
    cx = _clenshaw(tb[None, ...], coeffs.reshape(coeffs.shape + (1,) * tb.ndim))  # (NX, ...)
    g = _clenshaw(2.0 * np.clip(x, 0.0, 1.0) - 1.0, cx)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = g * (r * m) / wz
    return np.where(wz > 0.0, lam, np.inf)


# --------------------------------------------------------------------------
# Shadowing and Fresnel
# --------------------------------------------------------------------------

def G_vgroove(ci, co, ch, cih):
    """V-groove G = min(1, 2(N.H)(N.E)/(E.H), 2(N.H)(N.L)/(L.H))
    (slide: "Self-Shadowing: V-Groove Model"); E.H = L.H for the half vector."""
    return np.minimum(1.0, 2.0 * ch * np.minimum(ci, co) / cih)


def F_dielectric(c, ior):
    """Exact unpolarised Fresnel reflectance of a dielectric of real index ``ior``
    (Cook & Torrance 1982, eq. in appendix); total internal reflection gives 1."""
    g2 = ior * ior - 1.0 + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return np.where(g2 > 0.0, 0.5 * a * a * (1.0 + b * b), 1.0)


def F_conductor(c, n, k):
    """Exact unpolarised Fresnel reflectance for a complex index n + ik
    (Born & Wolf; real-arithmetic form with a^2 + b^2 = |eta^2 - sin^2|)."""
    c2 = c * c
    s2 = 1.0 - c2
    t0 = n * n - k * k - s2
    ab2 = np.sqrt(t0 * t0 + 4.0 * n * n * k * k)
    a = np.sqrt(np.maximum(0.5 * (ab2 + t0), 0.0))
    two_ac = 2.0 * a * c
    rs = (ab2 - two_ac + c2) / (ab2 + two_ac + c2)
    u = c2 * ab2 + s2 * s2
    v = two_ac * s2
    rp = rs * (u - v) / (u + v)
    return 0.5 * (rs + rp)


# --------------------------------------------------------------------------
# Argument handling
# --------------------------------------------------------------------------

DEFAULT_NORMAL = (0.0, 0.0, 1.0)
DEFAULT_TANGENT = (1.0, 0.0, 0.0)


def _as_param(p, value):
    """Check one parameter value against the catalogue; return an array
    (colours get a trailing axis of length 3 or 1)."""
    if p.is_enum:
        if not isinstance(value, str) or value not in p.choices:
            raise ValueError(f"{p.name}={value!r} is not allowed; {p.name} must be {p.allowed()}")
        return value
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{p.name}={value!r} is not allowed; {p.name} must be {p.allowed()}") from None
    if np.isnan(arr).any() or (p.minimum is not None and (arr < p.minimum).any()) or (
            p.maximum is not None and (arr > p.maximum).any()):
        bad = arr if arr.ndim == 0 else arr[np.isnan(arr) | (arr < (p.minimum if p.minimum is not None else -np.inf))
                                            | (arr > (p.maximum if p.maximum is not None else np.inf))].ravel()[0]
        raise ValueError(f"{p.name}={float(bad)!r} is out of range; {p.name} must be {p.allowed()}")
    if p.kind == "color":
        if arr.ndim == 0 or arr.shape[-1] != 3:
            arr = arr[..., None]
    return arr


def _check(model_name, params):
    """Resolve a model or preset and validate ``params``.

    Returns ``(model, values, given)``: every parameter's checked value
    (defaults filled in) and the set of names the caller gave.
    """
    model, fixed, preset_defaults = catalogue.resolve(model_name)
    allowed = [n for n in model.param_names if n not in fixed]
    for key in params:
        if key in fixed:
            raise ValueError(f"{key} is fixed to {fixed[key]!r} by the preset {model_name!r}; "
                             f"allowed parameters: {', '.join(allowed)}")
        if key not in model.param_names:
            raise ValueError(f"unknown parameter {key!r} for model {model_name!r}; "
                             f"allowed: {', '.join(allowed)}")
    given = set(params)
    merged = {p.name: p.default for p in model.params}
    merged.update(preset_defaults)
    merged.update(fixed)
    merged.update(params)
    values = {p.name: _as_param(p, merged[p.name]) for p in model.params}
    if "width" in model.rules:
        _check_width(model_name, values, given)
    if "smith_1967_beckmann" in model.rules and values["shadowing"] == "smith_1967" \
            and values["distribution"] != "beckmann":
        raise ValueError("shadowing='smith_1967' (the slide's erfc bracket form) is defined for "
                         "distribution='beckmann' only; allowed shadowing for "
                         f"{values['distribution']!r}: none, smith, smith_correlated, vgroove")
    return model, values, given


def _check_width(model_name, values, given):
    widths = [g for g in (("beta",), ("alpha",), ("alpha_x", "alpha_y")) if any(n in given for n in g)]
    if len(widths) > 1:
        raise ValueError(f"give one width for {model_name!r}: beta, alpha, or alpha_x with alpha_y "
                         f"(got {', '.join(sorted(n for g in widths for n in g))})")
    native = widths and widths[0][0] != "beta"
    if native and values["distribution"] not in ("trowbridge_reitz", "beckmann"):
        raise ValueError(f"alpha/alpha_x/alpha_y are native widths of 'trowbridge_reitz' and "
                         f"'beckmann' only; distribution {values['distribution']!r} takes beta")
    if widths and widths[0] == ("alpha_x", "alpha_y") and not {"alpha_x", "alpha_y"} <= given:
        raise ValueError("give alpha_x and alpha_y together (anisotropic width)")
    values["_width"] = widths[0][0] if widths else "beta"


def _vec(v, name):
    arr = np.asarray(v, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"{name} must be a 3-vector or an array of shape (..., 3)")
    return arr


def _dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _frame(normal, tangent):
    """Rows (t, b, n): the tangent projected on the surface, n x t, the normal.

    A tangent along the normal (or zero) falls back to the x axis projected on
    the surface, or the y axis when the normal is near x: the same choice as
    ``rm_begin`` in ``osl/rm_common.h``.
    """
    n = _vec(normal, "normal")
    t = _vec(tangent, "tangent")
    t = t - _dot(t, n)[..., None] * n
    length = np.sqrt(_dot(t, t))
    bad = length < 1e-6
    if np.any(bad):
        axis = np.where((np.abs(n[..., 0]) < 0.9)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        fallback = axis - _dot(axis, n)[..., None] * n
        t = np.where(bad[..., None], fallback, t)
        length = np.sqrt(_dot(t, t))
    t = t / length[..., None]
    b = np.cross(n, t)
    return np.stack(np.broadcast_arrays(t, b, n), axis=-2)


def _local(wi, wo, normal, tangent):
    """Both directions in the local frame, as component tuples (x, y, z)."""
    wi = _vec(wi, "wi")
    wo = _vec(wo, "wo")
    if (np.shape(normal) == (3,) and tuple(normal) == DEFAULT_NORMAL
            and np.shape(tangent) == (3,) and tuple(tangent) == DEFAULT_TANGENT):
        li, lo = wi, wo
    else:
        frame = _frame(normal, tangent)
        if frame.ndim == 2:
            li, lo = wi @ frame.T, wo @ frame.T
        else:
            li = np.einsum("...ij,...j->...i", frame, wi)
            lo = np.einsum("...ij,...j->...i", frame, wo)
    return (li[..., 0], li[..., 1], li[..., 2]), (lo[..., 0], lo[..., 1], lo[..., 2])


# --------------------------------------------------------------------------
# Models.  Each returns (scalar field, colour) pairs summed by _evaluate, or an
# RGB array.  ``v`` is the checked parameter dictionary.
# --------------------------------------------------------------------------

def _upper(ci, co):
    return (ci > 0.0) & (co > 0.0)


def _lobe(x, s):
    """max(0, x)^s with 0^0 = 0 below the cut-off."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(x > 0.0, np.power(np.maximum(x, 1e-300), s), 0.0)


def _brdf_lambert(li, lo, wdot, v):
    return np.where(_upper(li[2], lo[2]), 1.0 / PI, 0.0)[..., None] * v["albedo"]


def _brdf_phong(li, lo, wdot, v):
    """Slide "Phong Model": ks (E.R(L))^s with E.R(L) = 2(N.L)(N.E) - L.E;
    'energy' multiplies by (s+1)/(2 pi) (slide "Energy normalization")."""
    s = v["exponent"]
    cos_s = 2.0 * li[2] * lo[2] - wdot
    f = _lobe(cos_s, s)
    if v["normalization"] == "energy":
        f = f * ((s + 1.0) / (2.0 * PI))
    return np.where(_upper(li[2], lo[2]), f, 0.0)[..., None] * v["ks"]


def _brdf_blinn_phong(li, lo, wdot, v):
    """ks (N.H)^s, N.H = (N.L + N.E)/|L + E|; 'energy': times (s+8)/(8 pi),
    the usual approximate normalisation (not a bound)."""
    s = v["exponent"]
    with np.errstate(divide="ignore", invalid="ignore"):
        ch = (li[2] + lo[2]) / np.sqrt(np.maximum(2.0 + 2.0 * wdot, 1e-300))
    f = _lobe(ch, s)
    if v["normalization"] == "energy":
        f = f * ((s + 8.0) / (8.0 * PI))
    return np.where(_upper(li[2], lo[2]), f, 0.0)[..., None] * v["ks"]


def _widths(v):
    """(ax, ay) native widths for Trowbridge-Reitz / Beckmann, or beta."""
    dist = v["distribution"]
    how = v["_width"]
    if how == "alpha":
        return v["alpha"], v["alpha"]
    if how == "alpha_x":
        return v["alpha_x"], v["alpha_y"]
    beta = v["beta"]
    a = tr_alpha_from_beta(beta) if dist == "trowbridge_reitz" else beckmann_m_from_beta(beta)
    return a, a


def _brdf_microfacet(li, lo, wdot, v):
    """Slide "Torrance-Sparrow Model": f = ks F(L.H) G D(H) / (4 (N.L)(N.E))."""
    ci, co = li[2], lo[2]
    hx, hy, hz = li[0] + lo[0], li[1] + lo[1], li[2] + lo[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.sqrt(hx * hx + hy * hy + hz * hz)
        hx, hy, hz = hx * inv, hy * inv, hz * inv
        cih = li[0] * hx + li[1] * hy + li[2] * hz
        dist = v["distribution"]
        if dist in ("trowbridge_reitz", "beckmann"):
            ax, ay = _widths(v)
            Dfun = D_trowbridge_reitz if dist == "trowbridge_reitz" else D_beckmann
            Lfun = Lambda_trowbridge_reitz if dist == "trowbridge_reitz" else Lambda_beckmann
            D = Dfun(hx, hy, hz, ax, ay)
            lam = (lambda w: Lfun(w[0], w[1], w[2], ax, ay))
        else:
            beta = v["beta"]
            D = (D_blinn if dist == "blinn" else D_gaussian)(hx, hy, hz, beta)
            lam = (lambda w: Lambda_table(w[0], w[1], w[2], beta, dist))
        sh = v["shadowing"]
        if sh == "none":
            G = 1.0
        elif sh == "smith":
            G = 1.0 / ((1.0 + lam(li)) * (1.0 + lam(lo)))
        elif sh == "smith_correlated":
            G = 1.0 / (1.0 + lam(li) + lam(lo))
        elif sh == "vgroove":
            G = G_vgroove(ci, co, hz, cih)
        else:  # smith_1967 (Beckmann only, checked)
            G = S_smith_1967(*li, ax, ay) * S_smith_1967(*lo, ax, ay)
        f = G * D / (4.0 * ci * co)
        f = np.where(_upper(ci, co) & (hz > 0.0), f, 0.0)[..., None]
        fr = v["fresnel"]
        if fr == "dielectric":
            f = f * F_dielectric(np.clip(cih, 0.0, 1.0)[..., None], v["ior"])
        elif fr == "conductor":
            f = f * F_conductor(np.clip(cih, 0.0, 1.0)[..., None], v["ior"], v["k"])
    return np.nan_to_num(f * v["ks"], nan=0.0, posinf=0.0)


def _brdf_ward(li, lo, wdot, v):
    """Ward 1992, eq. 5: ks exp(-tan^2(h) (cos^2 phi/ax^2 + sin^2 phi/ay^2)) /
    (4 pi ax ay sqrt(cos i cos o))."""
    ci, co = li[2], lo[2]
    ax, ay = v["alpha_x"], v["alpha_y"]
    hx, hy, hz = li[0] + lo[0], li[1] + lo[1], li[2] + lo[2]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e = ((hx / ax) ** 2 + (hy / ay) ** 2) / (hz * hz)
        f = np.exp(-e) / (4.0 * PI * ax * ay * np.sqrt(ci * co))
    f = np.where(_upper(ci, co), f, 0.0)
    return f[..., None] * v["ks"]


_BRDFS = {
    "lambert": _brdf_lambert,
    "phong": _brdf_phong,
    "blinn_phong": _brdf_blinn_phong,
    "microfacet": _brdf_microfacet,
    "ward": _brdf_ward,
}


def _shade_kajiya_kay(wi, wo, tangent, v):
    """Slide "Kay-Kajiya Model": kd sin(theta_L) + ks cos^s(angle to the mirror cone).

    With both directions pointing away from the fibre the cone is T.E = -T.L,
    so the specular term is max(0, sinL sinE - cosL cosE)^s (lecture notes).
    """
    t = _vec(tangent, "tangent")
    t = t / np.sqrt(_dot(t, t))[..., None]
    cl = _dot(t, _vec(wi, "wi"))
    ce = _dot(t, _vec(wo, "wo"))
    sl = np.sqrt(np.maximum(1.0 - cl * cl, 0.0))
    se = np.sqrt(np.maximum(1.0 - ce * ce, 0.0))
    spec = _lobe(sl * se - cl * ce, v["exponent"])
    return sl[..., None] * v["kd"] + spec[..., None] * v["ks"]


CHUNK = 1 << 15  # elements per slice: the temporaries stay in the CPU cache


def _kernel(model, v, wi, wo, normal, tangent, with_cosine):
    if model.kind == "fibre":
        return _shade_kajiya_kay(wi, wo, tangent, v)
    li, lo = _local(wi, wo, normal, tangent)
    wdot = _dot(wi, wo) if model.id in ("phong", "blinn_phong") else None
    out = _BRDFS[model.id](li, lo, wdot, v)
    if with_cosine:
        out = out * np.maximum(li[2], 0.0)[..., None]
    return out


def _evaluate(model_name, wi, wo, normal, tangent, params, with_cosine):
    model, v, _given = _check(model_name, params)
    if model.kind == "fibre" and not with_cosine:
        raise ValueError(f"{model_name!r} is a fibre model with no BRDF on a surface; "
                         "use shade(), which gives its reflected radiance")
    wi, wo = _vec(wi, "wi"), _vec(wo, "wo")
    normal, tangent = _vec(normal, "normal"), _vec(tangent, "tangent")
    arrays = {k: a for k, a in v.items() if isinstance(a, np.ndarray)}
    # Leading (broadcast) shape: vectors and colours carry a trailing axis.
    leads = [wi.shape[:-1], wo.shape[:-1], normal.shape[:-1], tangent.shape[:-1]]
    for k, a in arrays.items():
        leads.append(a.shape[:-1] if model.param(k).kind == "color" else a.shape)
    shape = np.broadcast_shapes(*leads)
    size = math.prod(shape)
    if size <= CHUNK:
        out = _kernel(model, v, wi, wo, normal, tangent, with_cosine)
        return np.broadcast_to(out, shape + (3,)).astype(float, copy=False)

    def flat(a, colour=True):
        trail = a.shape[-1:] if colour else ()
        lead = a.shape[:-1] if colour else a.shape
        if lead == ():
            return a, False
        return np.broadcast_to(a, shape + trail).reshape((size,) + trail), True

    flat_vecs = [flat(x) for x in (wi, wo, normal, tangent)]
    flat_params = {k: flat(a, model.param(k).kind == "color") for k, a in arrays.items()}
    out = np.empty((size, 3))
    for start in range(0, size, CHUNK):
        sl = slice(start, start + CHUNK)
        vecs = [x[sl] if per else x for x, per in flat_vecs]
        vc = dict(v)
        for k, (a, per) in flat_params.items():
            vc[k] = a[sl] if per else a
        out[sl] = _kernel(model, vc, *vecs, with_cosine)
    return out.reshape(shape + (3,))


def shade(model, wi, wo, *, normal=DEFAULT_NORMAL, tangent=DEFAULT_TANGENT, **params):
    """Radiance toward ``wo`` under a unit-irradiance directional light from ``wi``.

    Surface models: ``brdf(...) * max(0, normal . wi)``.  Fibre models
    (``kajiya_kay``): the lecture's ``kd sin(theta_L) + ks (cone term)^s`` with
    ``tangent`` the fibre direction; the normal is not used.
    Returns an array of shape ``(..., 3)``.  Raises ``ValueError`` for unknown
    models or parameters and out-of-range values, naming what is allowed.
    """
    return _evaluate(model, wi, wo, normal, tangent, params, with_cosine=True)


def brdf(model, wi, wo, *, normal=DEFAULT_NORMAL, tangent=DEFAULT_TANGENT, **params):
    """The BRDF f_r (1/sr) of a surface model, shape ``(..., 3)``.

    Zero unless both directions are above the surface.  Fibre models have no
    surface BRDF and raise ``ValueError``.
    """
    return _evaluate(model, wi, wo, normal, tangent, params, with_cosine=False)
