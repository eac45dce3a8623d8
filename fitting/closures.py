# SPDX-License-Identifier: GPL-3.0-or-later
"""Numpy transcriptions of the Cycles closures the mixtures are made of.

Each function returns what a closure contributes to a pixel under a
directional light of unit irradiance: f_r(wi, wo) max(0, N.wi) (the
quantity ``addon.reference.shade`` returns), for local directions (x along
the tangent, z along the normal) ``wi`` toward the light and ``wo`` toward
the viewer, arrays of shape (..., 3).  Read from Cycles' kernel
(``kernel/closure/bsdf_microfacet.h``, ``bsdf_ashikhmin_shirley.h``,
``bsdf_phong_ramp.h``), not copied; ``tests/test_fitting.py`` checks every
one against Cycles renders of the closure (OSL and the native node) to 1e-3.

In Cycles' own naming the view is ``wi`` and the light ``wo``: here the
lecture's convention is kept.
"""

from __future__ import annotations

import numpy as np

PI = np.pi


def _cos(w):
    return w[..., 2]


def _half(wi, wo):
    h = wi + wo
    return h / np.maximum(np.linalg.norm(h, axis=-1, keepdims=True), 1e-30)


def lambda_ggx(w, ax, ay):
    """Heitz 2014, eq. 72 (Cycles: GGX)."""
    t2 = ((w[..., 0] * ax) ** 2 + (w[..., 1] * ay) ** 2) / np.maximum(w[..., 2] ** 2, 1e-30)
    return 0.5 * (np.sqrt(1.0 + t2) - 1.0)


def lambda_beckmann_rational(w, ax, ay):
    """Cycles' Beckmann Lambda: Walter 2007's rational approximation (below
    Heitz 2014, eq. 69), 0 where a = 1/(alpha tan theta) >= 1.6."""
    t2 = ((w[..., 0] * ax) ** 2 + (w[..., 1] * ay) ** 2) / np.maximum(w[..., 2] ** 2, 1e-30)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = 1.0 / np.sqrt(t2)
        lam = ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)
    return np.where(t2 < 0.39, 0.0, lam)


def D_ggx(h, ax, ay):
    x, y = h[..., 0] / ax, h[..., 1] / ay
    e = x * x + y * y + h[..., 2] ** 2
    return 1.0 / (PI * ax * ay * e * e)


def D_beckmann(h, ax, ay):
    z2 = h[..., 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        d = np.exp(-((h[..., 0] / ax) ** 2 + (h[..., 1] / ay) ** 2) / z2) / (PI * ax * ay * z2 * z2)
    return np.where(z2 > 0, d, 0.0)


def microfacet(wi, wo, ax, ay=None, distribution="ggx"):
    """``microfacet(distribution, N, T, ax, ay, 0, 0)`` (OSL) = the Glossy
    BSDF (native): D G2 / (4 cos_o) with the height-correlated
    G2 = 1/(1 + Lambda_i + Lambda_o); alpha clamped to [1e-4, 1]."""
    ay = ax if ay is None else ay
    ax = np.clip(ax, 1e-4, 1.0)
    ay = np.clip(ay, 1e-4, 1.0)
    h = _half(wi, wo)
    if distribution == "ggx":
        D, lam = D_ggx(h, ax, ay), lambda_ggx
    elif distribution == "beckmann":
        D, lam = D_beckmann(h, ax, ay), lambda_beckmann_rational
    else:
        raise ValueError(distribution)
    ci, co = _cos(wi), _cos(wo)
    G = 1.0 / (1.0 + lam(wi, ax, ay) + lam(wo, ax, ay))
    with np.errstate(divide="ignore", invalid="ignore"):
        v = D * G / (4.0 * co)
    return np.where((ci > 0) & (co > 0), v, 0.0)


def ashikhmin_shirley(wi, wo, alpha):
    """``microfacet("ashikhmin_shirley", ...)`` / Glossy 'Ashikhmin-Shirley'
    (isotropic): (n+1)/(8 pi) (N.H)^n cos_i / ((H.V) max(cos_i, cos_o)),
    n = 2/alpha^2 - 2, alpha clamped to [1e-4, 1]."""
    alpha = np.clip(alpha, 1e-4, 1.0)
    n = 2.0 / (alpha * alpha) - 2.0
    ci, co = _cos(wi), _cos(wo)
    h = _half(wi, wo)
    hv = np.maximum(np.abs(np.sum(h * wo, -1)), 1e-6)
    hn = np.maximum(h[..., 2], 1e-6)
    pump = 1.0 / np.maximum(1e-6, hv * np.maximum(np.maximum(co, 1e-6), np.maximum(ci, 1e-6)))
    v = np.maximum(ci, 1e-6) * (n + 1.0) / (8.0 * PI) * hn ** n * pump
    return np.where((ci >= 0) & (co >= 0), v, 0.0)


def phong_ramp(wi, wo, exponent):
    """``phong_ramp`` with a white ramp: (n+2)/(2 pi) max(0, R(V).L)^n cos_i."""
    ci, co = _cos(wi), _cos(wo)
    r = np.stack([-wo[..., 0], -wo[..., 1], wo[..., 2]], -1)  # reflect the view about N
    c = np.sum(r * wi, -1)
    with np.errstate(invalid="ignore"):
        v = ci * (exponent + 2.0) / (2.0 * PI) * np.where(c > 0, np.maximum(c, 0.0) ** exponent, 0.0)
    return np.where((ci > 0) & (co > 0), v, 0.0)


def diffuse(wi, wo):
    """Lambert: cos_i / pi."""
    return np.where((_cos(wi) > 0) & (_cos(wo) > 0), _cos(wi) / PI, 0.0)


CLOSURES = {"ggx": lambda wi, wo, a: microfacet(wi, wo, a, a, "ggx"),
            "beckmann": lambda wi, wo, a: microfacet(wi, wo, a, a, "beckmann"),
            "ashikhmin_shirley": ashikhmin_shirley}
