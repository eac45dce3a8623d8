# SPDX-License-Identifier: GPL-3.0-or-later
"""Series of special functions (Chebyshev and rational), computed in high
precision.

- :func:`erfc_module`: the coefficients of ``addon.core.reference.special``'s
  erfc, computed in 40-digit mpmath (double-precision coefficients from a
  double-precision fit carry ~1e-15 of noise each, which the sums add up).
"""

from __future__ import annotations

import mpmath

from .codegen import array, banner, number

SMALL = 0.5   # below: erf's Maclaurin series
LARGE = 4.0   # above: the series in w = (LARGE / x)^2
RATIONAL_DEGREES = (8, 9)   # erfc(x) exp(x^2) below LARGE: 4e-19 relative, in 40 digits
N_LARGE = 20


def chebyshev_mp(f, a, b, n, dps=40):
    """Coefficients c[j] of sum_j c[j] T_j(u), u = 2 (x - a)/(b - a) - 1,
    interpolating ``f`` (an mpmath function) at the n Chebyshev points, as
    doubles, computed with ``dps`` digits."""
    with mpmath.workdps(dps):
        a, b = mpmath.mpf(a), mpmath.mpf(b)
        half = mpmath.mpf(1) / 2
        angles = [mpmath.pi * (k + half) / n for k in range(n)]
        values = [f(a + (b - a) * (mpmath.cos(t) + 1) / 2) for t in angles]
        coeffs = []
        for j in range(n):
            s = mpmath.fsum(v * mpmath.cos(j * t) for v, t in zip(values, angles))
            coeffs.append(float(s * 2 / n * (half if j == 0 else 1)))
    return coeffs


def rational_mp(f, a, b, m, n, points=120, steps=3, dps=40):
    """Coefficients (ascending powers of x) of P, degree ``m``, and Q,
    degree ``n`` with Q(0) = 1, such that P/Q is ``f`` (an mpmath function)
    on [a, b] to within a small relative error: least squares of
    (P - f Q)/(f Q') at ``points`` Chebyshev points, Q' the last step's Q
    (1 at first), ``steps`` times (Sanathanan and Koerner's iteration; for
    erfc's R it settles at the second step).  As doubles, computed with
    ``dps`` digits."""
    with mpmath.workdps(dps):
        a, b = mpmath.mpf(a), mpmath.mpf(b)
        half = mpmath.mpf(1) / 2
        xs = [a + (b - a) * (mpmath.cos(mpmath.pi * (k + half) / points) + 1) / 2
              for k in range(points)]
        fs = [f(x) for x in xs]
        q_last = [mpmath.mpf(1)] * points
        for _step in range(steps):
            rows, rhs = mpmath.matrix(points, m + 1 + n), mpmath.matrix(points, 1)
            for i, (x, fx) in enumerate(zip(xs, fs)):
                w = 1 / (fx * q_last[i])
                for j in range(m + 1):
                    rows[i, j] = x ** j * w
                for j in range(1, n + 1):
                    rows[i, m + j] = -fx * x ** j * w
                rhs[i] = fx * w
            sol, _residual = mpmath.qr_solve(rows, rhs)
            p = [sol[j] for j in range(m + 1)]
            q = [mpmath.mpf(1)] + [sol[m + j] for j in range(1, n + 1)]
            q_last = [mpmath.fsum(c * x ** j for j, c in enumerate(q)) for x in xs]
        return [float(c) for c in p], [float(c) for c in q]


def _r(x):
    return mpmath.erfc(x) * mpmath.exp(x * x)


def _log_xr(w):
    if w == 0:
        return mpmath.mpf(0)
    x = LARGE / mpmath.sqrt(w)
    return mpmath.log(x * _r(x) * mpmath.sqrt(mpmath.pi))


def erfc_module() -> str:
    numerator, denominator = rational_mp(_r, 0, LARGE, *RATIONAL_DEGREES)
    large = chebyshev_mp(_log_xr, 0, 1, N_LARGE)
    return "".join([
        banner("fitting/series.py"),
        '"""Coefficients of erfc (see addon/core/reference/special.py): R(x) =\n',
        "erfc(x) exp(x^2) on [0, LARGE] as R_NUMERATOR(x) / R_DENOMINATOR(x), polynomials\n",
        "in x by ascending powers, and the Chebyshev series of log(x R(x) sqrt(pi)) for\n",
        "x >= LARGE in 2 w - 1, w = (LARGE / x)^2.  Below SMALL erf takes its own\n",
        "series.\"\"\"\n\n",
        f"SMALL = {number(SMALL)}\n",
        f"LARGE = {number(LARGE)}\n",
        f"R_NUMERATOR = {array(numerator)}\n",
        f"R_DENOMINATOR = {array(denominator)}\n",
        f"LOG_XR_LARGE = {array(large)}\n",
    ])


# --------------------------------------------------------------------------
# Series the shaders and node graphs evaluate, from the reference's quadratures

GAUSSIAN_NORM_TERMS = 32


def gaussian_norm_coefficients():
    """Chebyshev coefficients of log(K(beta) pi / c2(beta)^2) over the
    catalogue's beta range, K the reference's Gaussian normalisation (its
    quadrature) and c2 = sqrt(ln 2)/beta: K -> c2^2/pi for a narrow lobe, so
    the logarithm stays small.  32 terms: within 5e-9 of the quadrature's
    logarithm (the tilt cut-off reaching pi/2 near beta = 11.6 deg makes the
    function only once differentiable there, which slows the convergence)."""
    import math

    import numpy as np

    from addon.core.reference import distributions as D

    lo, hi = D.CHEB_BETA
    n = GAUSSIAN_NORM_TERMS
    u = np.cos(np.pi * (np.arange(n) + 0.5) / n)
    beta = lo + (hi - lo) * (u + 1.0) / 2.0
    values = np.log(D.gaussian_norm(beta) * math.pi / D.gaussian_c2_from_beta(beta) ** 2)
    t = np.polynomial.chebyshev.chebvander(u, n - 1)
    c = (2.0 / n) * (t.T @ values)
    c[0] *= 0.5
    return (lo, hi), c


def smith_lambda_module() -> str:
    """``addon/core/fits/smith_lambda.py``: the Chebyshev series of Smith's
    Lambda for Blinn and Gaussian (the reference's :func:`lambda_chebyshev`)
    and of the Gaussian normalisation, for the shaders and node graphs."""
    from addon.core.reference import distributions as D

    (lo, hi), norm = gaussian_norm_coefficients()
    parts = [
        banner("fitting/series.py"),
        '"""Series evaluated by the shaders and node graphs (addon/core/formulas):\n\n',
        "- LAMBDA[distribution][j][i]: g(beta, x) = a Lambda = sum c[j][i] T_j(tb) T_i(2x - 1)\n",
        "  for 'blinn' and 'gaussian' (addon.core.reference.lambda_chebyshev);\n",
        "- GAUSSIAN_NORM[j]: log(K pi / c2^2) = sum c[j] T_j(tb), K the Gaussian D's\n",
        "  normalisation (the reference's quadrature), c2 = sqrt(ln 2)/beta;\n\n",
        'tb = 2 (beta - BETA_MIN)/(BETA_MAX - BETA_MIN) - 1."""\n\n',
        f"BETA_MIN = {number(lo)}\n",
        f"BETA_MAX = {number(hi)}\n",
        f"NB = {D.CHEB_NB}\n",
        f"NX = {D.CHEB_NX}\n",
        "LAMBDA = {\n",
    ]
    for dist in ("blinn", "gaussian"):
        parts.append(f'    "{dist}": {array(D.lambda_chebyshev(dist), indent="        ")},\n')
    parts.append("}\n")
    parts.append(f"GAUSSIAN_NORM = {array(norm)}\n")
    return "".join(parts)
