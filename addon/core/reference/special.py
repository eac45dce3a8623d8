# SPDX-License-Identifier: GPL-3.0-or-later
"""Special functions of the reference, in double precision (numpy only).

``erfc`` and ``erf`` are accurate to about 1e-15 relative over the whole
real line where erfc is a normal float (tests/test_reference.py checks them
against the standard library's ``math.erfc`` at 20 000 points):

- erfc, ``|x| < 4``: exp(-x^2) R(x) with R(x) = erfc(x) exp(x^2) a ratio of
  polynomials in x of degrees 8 and 9 (4e-19 relative in 40 digits; every
  coefficient positive, so Horner's rule cancels nothing);
- erfc, ``|x| >= 4``: R(x) = exp(S(w)) / (x sqrt(pi)), S a Chebyshev series
  in w = 16 / x^2 (R tends to 1/(x sqrt pi));
- erf, ``|x| < 0.5``: its Maclaurin series (20 terms; the last one is below
  1e-20); elsewhere 1 - erfc.

The coefficients were computed in 40-digit arithmetic (mpmath) by
``fitting/series.py`` and are committed in ``addon/core/fits/erfc.py``.
Until the fifty-fourth session erfc took a 32-term Chebyshev series for
0.5 <= |x| < 4 and erf's series below: three times the operations where
most of a Beckmann lobe's Smith Lambda falls (``make bench``).
exp(-x^2) is evaluated as exp(-xh^2) exp(-(x - xh)(x + xh)) with xh = x
rounded to 1/4096, whose square is exact: a naive x*x would lose x^2 ulps.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..fits import erfc as _erfc_fit

SQRT_PI = math.sqrt(math.pi)
_TWO_OVER_SQRT_PI = 2.0 / SQRT_PI
_SERIES_TERMS = 20


def clenshaw(t, coeffs):
    """sum_k coeffs[k] T_k(t) (Chebyshev polynomials of the first kind) over
    the first axis of ``coeffs``; ``t`` broadcasts against the other axes.
    The recurrence b = (c + 2 t b1) - b2 runs in place, in that order of
    operations (the same bits as written out, without a new array a step)."""
    coeffs = np.asarray(coeffs, dtype=float)
    t = np.asarray(t, dtype=float)
    shape = np.broadcast_shapes(t.shape, coeffs.shape[1:])
    b1, b2, step = np.zeros(shape), np.zeros(shape), np.empty(shape)
    two_t = 2.0 * t
    for c in coeffs[:0:-1]:
        np.multiply(two_t, b1, out=step)
        step += c
        np.subtract(step, b2, out=b2)
        b1, b2 = b2, b1
    return coeffs[0] + t * b1 - b2


def _exp_minus_square(z):
    """exp(-z^2) for z >= 0, to double precision (z split at a 1/4096 grid);
    0 from z = 40 on (exp(-1600) underflows), where the split would give
    0 times an overflow."""
    zc = np.minimum(z, 40.0)
    zh = np.round(zc * 4096.0) / 4096.0
    return np.where(z < 40.0, np.exp(-zh * zh) * np.exp(-(zc - zh) * (zc + zh)), 0.0)


def _maclaurin(s):
    """sum_n (-1)^n s^(2n+1) / (n! (2n+1)) to _SERIES_TERMS terms (erf's
    series without its factor 2/sqrt(pi)), in place: the same operations
    in the same order as acc += p/(2n+1); p = -p s^2/(n+1)."""
    s2 = s * s
    acc = np.zeros_like(s)
    p = s.copy()
    term = np.empty_like(s)
    for n in range(_SERIES_TERMS):
        np.divide(p, 2 * n + 1, out=term)
        acc += term
        np.negative(p, out=p)
        p *= s2
        p /= n + 1
    return acc


def _horner(coeffs, x):
    """sum_k coeffs[k] x^k by Horner's rule, in place on one new array."""
    acc = np.full_like(x, coeffs[-1])
    for c in coeffs[-2::-1]:
        acc *= x
        acc += c
    return acc


def erfcx_nonnegative(z):
    """The scaled complementary error function R(z) = erfc(z) exp(z^2) for
    z >= 0, inf included (R = 0 there), not NaN: the rational below LARGE,
    exp(S(w)) / (z sqrt pi) from LARGE on.  erfc is R times exp(-z^2), and
    Beckmann's Smith Lambda takes R itself (one exp(-z^2) for both terms)."""
    below = np.minimum(z, _erfc_fit.LARGE)
    r = _horner(_erfc_fit.R_NUMERATOR, below)
    r /= _horner(_erfc_fit.R_DENOMINATOR, below)
    large = z >= _erfc_fit.LARGE
    if large.any():
        s = z[large]
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            w = np.where(np.isfinite(s), (_erfc_fit.LARGE / s) ** 2, 0.0)
            big = np.exp(clenshaw(2.0 * w - 1.0, _erfc_fit.LOG_XR_LARGE)) / (s * SQRT_PI)
            r[large] = np.where(np.isfinite(s), big, 0.0)
    return r


def _erfc_nonnegative(z):
    """erfc(z) for z >= 0 (inf included; no NaN)."""
    r = erfcx_nonnegative(z)
    r *= _exp_minus_square(z)
    return r


def erfc(x):
    """Complementary error function, vectorised, about 1e-15 relative."""
    x = np.asarray(x, dtype=float)
    scalar = x.ndim == 0
    x = np.atleast_1d(x)
    nan = np.isnan(x)
    any_nan = bool(nan.any())
    z = np.where(nan, 0.0, np.abs(x)) if any_nan else np.abs(x)
    r = _erfc_nonnegative(z)
    negative = x < 0.0
    if negative.any():
        r = np.where(negative, 2.0 - r, r)
    if any_nan:
        r = np.where(nan, np.nan, r)
    return r[0] if scalar else r


def erf(x):
    """Error function, vectorised: the series near 0, 1 - erfc elsewhere."""
    x = np.asarray(x, dtype=float)
    scalar = x.ndim == 0
    x = np.atleast_1d(x)
    z = np.abs(x)
    small = z < _erfc_fit.SMALL
    out = np.empty_like(x)
    out[small] = _TWO_OVER_SQRT_PI * _maclaurin(z[small])
    out[~small] = 1.0 - _erfc_nonnegative(np.where(np.isnan(z[~small]), 0.0, z[~small]))
    out = np.where(x < 0.0, -out, out)
    out = np.where(np.isnan(x), np.nan, out)
    return out[0] if scalar else out


@functools.lru_cache(maxsize=None)
def gauss_legendre(n):
    """Gauss-Legendre nodes and weights on [0, 1] (cached: numpy solves an
    n x n eigenproblem)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w
