# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender 4.5's Metallic BSDF, its conductor Fresnel and the native nodes'
view factor, measured over the hemisphere: pure numpy, no Blender.

Blender 4.5's Metallic BSDF (physical conductor) takes an approximation of
the conductor Fresnel (:func:`older_fresnel`; rendered by hand in 4.5.15,
it equals this formula to 1e-6 at half-angles 10-70 deg, indices 1.2-2.4
with k = 0, gold's green channel (0.424 + 2.35i) and 1.5 + 0.3i), and the
native nodes carry a dielectric's Fresnel through it too (k = 0).  There
the native BSDF output multiplies the closure's weight by the exact
Fresnel over the approximation at the view
(``addon/backends/native/emit.py``, ``older_fresnel_factor``): exact at the
lobe's mirror direction, approximate away from it.  :func:`table` measures
both over the hemisphere as the fitter does (views every 2.5 deg, lights
every deg and 2 deg of azimuth; the largest difference over the peak, views
and lights to 70 deg, and every direction to 85-88 deg over the same peak),
using the closures' numpy transcriptions that ``tests/test_fitting.py``
checks against renders.  Run: ``python -m fitting.older_conductor``.
"""

from __future__ import annotations

import numpy as np

from addon.core import catalogue
from addon.core import reference as R

from . import closures as C

DOMAIN_DEG = 70.0
MATERIALS = (("glass 1.33", 1.33, 0.0), ("glass 1.5", 1.5, 0.0), ("glass 2.4", 2.4, 0.0),
             ("n 1.5 + 0.3i", 1.5, 0.3),
             *((name, *catalogue.METALS[name]) for name in ("gold", "copper", "aluminium")))
ALPHAS = (0.05, 0.2, 0.5, 1.0)


def older_fresnel(c, eta, k):
    """Blender 4.5's conductor Fresnel: the mean of
    (a c^2 - 2 eta c + 1)/(a c^2 + 2 eta c + 1) and
    (a - 2 eta c + c^2)/(a + 2 eta c + c^2), a = eta^2 + k^2."""
    a, c2, two = eta * eta + k * k, c * c, 2.0 * eta * c
    return 0.5 * ((a * c2 - two + 1.0) / (a * c2 + two + 1.0)
                  + (a - two + c2) / (a + two + c2))


def exact_fresnel(c, eta, k):
    return R.F_dielectric(c, eta) if k == 0.0 else R.F_conductor(c, eta, k)


def view_factor(co, ior, k):
    """One factor for the three channels (the emitter's rule): the channels'
    ratio of exact over approximate Fresnel at the view where they agree,
    else the one nearest 1 on the side where they all lie (1 where they lie
    on both)."""
    ratios = [exact_fresnel(co, n, kk) / older_fresnel(co, n, kk)
              for n, kk in zip(ior, k)]
    low, high = np.minimum.reduce(ratios), np.maximum.reduce(ratios)
    return np.maximum(low, np.minimum(high, 1.0))


def _directions(theta, phi):
    theta, phi = np.radians(theta), np.radians(phi)
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                     np.cos(theta)], -1)


def _hemisphere():
    views = np.arange(0.0, 85.1, 2.5)
    lights, azimuths = np.meshgrid(np.arange(0.0, 88.1, 1.0), np.arange(0.0, 360.0, 2.0),
                                   indexing="ij")
    wi = _directions(lights, azimuths)[None]
    wo = _directions(views, 0.0 * views)[:, None, None, :]
    wi, wo = np.broadcast_arrays(wi, wo)
    h = wi + wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    cos_d = np.clip(np.sum(h * wo, -1), 0.0, 1.0)
    inside = (np.degrees(np.arccos(wo[..., 2])) <= DOMAIN_DEG + 1e-6) & \
        (np.degrees(np.arccos(np.clip(wi[..., 2], -1.0, 1.0))) <= DOMAIN_DEG + 1e-6)
    return wi, wo, cos_d, inside


def table(distribution="beckmann", materials=MATERIALS, alphas=ALPHAS):
    """Rows ``(material, alpha, without, with)``: ``without`` and ``with``
    each ``(in the domain, everywhere)``, the largest difference from the
    model's lobe over its peak in the domain, the worst colour channel."""
    wi, wo, cos_d, inside = _hemisphere()
    co = wo[..., 2]
    rows = []
    for name, ior, k in materials:
        ior, k = np.broadcast_to(ior, 3), np.broadcast_to(k, 3)
        factor = view_factor(co, ior, k)
        for alpha in alphas:
            lobe = C.microfacet(wi, wo, alpha, alpha, distribution)
            worst = np.zeros((2, 2))
            for n, kk in zip(ior, k):
                model = lobe * exact_fresnel(cos_d, n, kk)
                peak = model[inside].max()
                older = lobe * older_fresnel(cos_d, n, kk)
                for i, rendered in enumerate((older, older * factor)):
                    d = np.abs(rendered - model) / peak
                    worst[i] = np.maximum(worst[i], (d[inside].max(), d.max()))
            rows.append((name, alpha, tuple(worst[0]), tuple(worst[1])))
    return rows


def main():
    # 4.5's native GGX lobe of a dielectric is the Principled BSDF's (exact): conductors only
    conductors = tuple(m for m in MATERIALS if np.any(np.asarray(m[2]) > 0.0))
    for distribution, materials in (("beckmann", MATERIALS), ("ggx", conductors)):
        print(f"\n{distribution}: max |difference| / peak, without -> with the view factor "
              f"(views and lights to {DOMAIN_DEG:g} deg; everywhere)")
        for name, alpha, without, with_ in table(distribution, materials):
            print(f"  {name:13s} alpha {alpha:4.2f}: {without[0]:.3f} -> {with_[0]:.3f};  "
                  f"{without[1]:.3f} -> {with_[1]:.3f}")


if __name__ == "__main__":
    main()
