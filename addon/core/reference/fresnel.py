# SPDX-License-Identifier: GPL-3.0-or-later
"""Fresnel reflectance, exact and unpolarised (slide "Torrance-Sparrow
Experiments": aluminium needs a complex index, magnesium oxide a real one)."""

from __future__ import annotations

import numpy as np

from .ranges import within


def _cosine(c):
    """The cosine clamped to [0, 1] (NaN stays NaN): past normal incidence and
    below the surface the reflectance is that of the nearest end."""
    return np.clip(np.asarray(c, dtype=float), 0.0, 1.0)


def F_dielectric(c, ior):
    """Exact unpolarised Fresnel reflectance of a dielectric of real index ``ior``
    (Cook & Torrance 1982, eq. in appendix); total internal reflection gives 1.

    ``c`` is the cosine of the angle of incidence, clamped to [0, 1]; ``ior``
    must be finite and above 0 (ValueError otherwise)."""
    c, ior = _cosine(c), within(ior, "ior", 0.0)
    g2 = ior * ior - 1.0 + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (g - c) / (g + c)
        b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return np.where(g2 > 0.0, 0.5 * a * a * (1.0 + b * b), np.where(g2 <= 0.0, 1.0, np.nan))


def F_conductor(c, n, k):
    """Exact unpolarised Fresnel reflectance for a complex index n + ik
    (Born & Wolf; real-arithmetic form with a^2 + b^2 = |eta^2 - sin^2|).

    ``c`` is the cosine of the angle of incidence, clamped to [0, 1]; ``n``
    and ``k`` must be finite and at least 0 (ValueError otherwise)."""
    c = _cosine(c)
    n, k = within(n, "n", 0.0, lo_closed=True), within(k, "k", 0.0, lo_closed=True)
    c2 = c * c
    s2 = 1.0 - c2
    t0 = (n * n - k * k - 1.0) + c2  # n^2 - k^2 - sin^2: 1 - c2 lost c2 near grazing
    ab2 = np.sqrt(t0 * t0 + 4.0 * n * n * k * k)
    a = np.sqrt(np.maximum(0.5 * (ab2 + t0), 0.0))
    two_ac = 2.0 * a * c
    den = ab2 + two_ac + c2
    # den is 0 only at grazing for n = 1, k = 0 (no interface): 0 there, the
    # limit along c (it was 0 / 0, NaN)
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = np.where(den > 0.0, (ab2 - two_ac + c2) / den, 0.0)
    u = c2 * ab2 + s2 * s2
    v = two_ac * s2
    rp = rs * (u - v) / (u + v)
    return 0.5 * (rs + rp)
