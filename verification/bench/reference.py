# SPDX-License-Identifier: GPL-3.0-or-later
"""Throughput of the numpy reference (a table of ``make bench``).

Throughput of ``addon.reference.shade`` per model on one core, for a batch
of 10^6 direction pairs, against the targets of the issue; and its working
memory: the peak of what numpy allocates during the call beyond the result
itself (``tracemalloc``, which numpy reports to), for that batch and for one
a tenth of its size.  The reference evaluates a large batch slice by slice
(``CHUNK``), so its working memory should not grow with the batch: a row is
"ok" where the larger batch's is within 1 MB of the smaller's.
"""

from __future__ import annotations

import math
import time
import tracemalloc

import numpy as np

DEG = math.pi / 180.0

# (label, model, params, target evaluations per second)
REFERENCE_CASES = [
    ("lambert", "lambert", {}, 5e6),
    ("phong", "phong", {"exponent": 30.0}, 5e6),
    ("phong energy", "phong", {"exponent": 30.0, "normalization": "energy"}, 5e6),
    ("blinn_phong", "blinn_phong", {"exponent": 30.0}, 5e6),
    ("microfacet TR smith", "microfacet",
     {"distribution": "trowbridge_reitz", "beta": 15 * DEG}, 5e6),
    ("microfacet TR correlated aniso", "microfacet",
     {"distribution": "trowbridge_reitz", "alpha_x": 0.1, "alpha_y": 0.3,
      "shadowing": "smith_correlated"}, 5e6),
    ("microfacet beckmann smith", "microfacet", {"distribution": "beckmann", "beta": 15 * DEG}, 5e6),
    ("microfacet beckmann vgroove dielectric", "microfacet",
     {"distribution": "beckmann", "shadowing": "vgroove", "fresnel": "dielectric"}, 5e6),
    ("microfacet TR smith conductor RGB", "microfacet",
     {"distribution": "trowbridge_reitz", "fresnel": "conductor", "ior": (1.47, 0.96, 0.62),
      "k": (7.8, 6.7, 5.5)}, 3e6),
    ("torrance_sparrow conductor RGB", "torrance_sparrow",
     {"fresnel": "conductor", "ior": (1.47, 0.96, 0.62), "k": (7.8, 6.7, 5.5)}, 3e6),
    ("microfacet blinn smith (table)", "microfacet", {"distribution": "blinn", "beta": 15 * DEG}, 1e6),
    ("microfacet gaussian smith (table)", "microfacet",
     {"distribution": "gaussian", "beta": 15 * DEG}, 1e6),
    ("microfacet gaussian correlated (table)", "microfacet",
     {"distribution": "gaussian", "beta": 15 * DEG, "shadowing": "smith_correlated"}, 1e6),
    ("ward", "ward", {}, 5e6),
    ("kajiya_kay", "kajiya_kay", {}, 5e6),
]


def _directions(n, rng):
    def hemi():
        z = rng.uniform(0.0, 1.0, n)
        phi = rng.uniform(0.0, 2 * math.pi, n)
        s = np.sqrt(1 - z * z)
        return np.stack([s * np.cos(phi), s * np.sin(phi), z], -1)
    return hemi(), hemi()


GROWTH_MB = 1.0  # the working memory of a batch ten times larger may exceed the smaller's by this


def working_memory(shade, wi, wo):
    """Bytes numpy allocates at the peak of ``shade(wi, wo)`` beyond its
    result (traced while it runs; the inputs were allocated before)."""
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        out = shade(wi, wo)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return peak - start - out.nbytes


def bench_reference(n=1_000_000, repeats=3):
    from addon import reference

    rng = np.random.default_rng(0)
    wi, wo = _directions(n, rng)
    small = max(n // 10, 1)
    rows = []
    for label, model, params, target in REFERENCE_CASES:
        reference.shade(model, wi[:10], wo[:10], **params)  # warm caches (tables)
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            reference.shade(model, wi, wo, **params)
            best = min(best, time.perf_counter() - t0)
        rate = n / best

        def shade(a, b):
            return reference.shade(model, a, b, **params)
        memory = (working_memory(shade, wi, wo), working_memory(shade, wi[:small], wo[:small]))
        rows.append((label, rate, target, memory))
    print(f"\nReference throughput, batch of {n:,} direction pairs, one core, best of {repeats};"
          f" working memory beyond the result, MB, for {n:,} and {small:,} pairs")
    print(f"{'model':42s} {'M eval/s':>9s} {'target':>7s}  ok {'memory':>7s} {'/10':>6s}  ok")
    for label, rate, target, (big, little) in rows:
        flat = big <= little + GROWTH_MB * 1e6
        fast = "yes" if rate >= target else "NO"
        print(f"{label:42s} {rate / 1e6:9.2f} {target / 1e6:7.1f} {fast:>3s}"
              f" {big / 1e6:7.1f} {little / 1e6:6.1f} {'yes' if flat else 'NO':>3s}")
    return rows
