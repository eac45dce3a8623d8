# SPDX-License-Identifier: GPL-3.0-or-later
"""Comparing a render with an expectation (numpy only)."""

from __future__ import annotations

import math

import numpy as np


def compare(rendered, expected, mask, *, floor=None, floor_fraction=1e-3, scale=1.0):
    """Compare a render with an expectation on the pixels of ``mask``.

    The relative error of a pixel channel is ``|r - e| / max(|e|, floor)``.
    The floor keeps dark pixels (e.g. where N.wi <= 0 or far outside a
    highlight, e ~ 0) from dominating: by default it is ``floor_fraction``
    times the largest ``|e|`` over the mask (1e-3 of the peak), so below the
    floor an absolute error of ``floor_fraction * peak`` counts as 100 %.
    Where the expectation is 0 on every pixel (a black colour, a Fresnel
    factor of 0) it has no peak: ``scale``, a radiance the scene would show
    (e.g. a white Lambertian surface's brightest), stands for it.

    Returns a dict with ``max_rel_error``, ``rms_rel_error``,
    ``max_abs_error``, ``floor``, ``n_pixels`` (masked pixels), ``peak``
    (largest |e|), ``scale`` (``peak``, or ``scale`` where it is 0),
    ``worst`` ((row, column, channel) of the largest relative
    error) and the rendered and expected values there.
    """
    r = np.asarray(rendered, dtype=np.float64)[..., :3]
    e = np.asarray(expected, dtype=np.float64)
    if e.ndim == r.ndim - 1:
        e = e[..., None]
    e = np.broadcast_to(e, r.shape)
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        raise ValueError("compare: empty mask")
    rm, em = r[mask], e[mask]
    peak = float(np.max(np.abs(em)))
    if not scale > 0:
        raise ValueError(f"compare: scale must be positive, not {scale!r}")
    if floor is None:
        floor = floor_fraction * (peak if peak > 0 else scale)
    abs_err = np.abs(rm - em)
    rel = abs_err / np.maximum(np.abs(em), floor)
    k = np.unravel_index(int(np.argmax(rel)), rel.shape)
    rows, cols = np.nonzero(mask)
    return {
        "max_rel_error": float(rel.max()),
        "rms_rel_error": float(np.sqrt(np.mean(rel ** 2))),
        "max_abs_error": float(abs_err.max()),
        "floor": float(floor),
        "peak": peak,
        "scale": peak if peak > 0 else float(scale),
        "n_pixels": int(mask.sum()),
        "worst": (int(rows[k[0]]), int(cols[k[0]]), int(k[1])),
        "rendered_at_worst": float(rm[k]),
        "expected_at_worst": float(em[k]),
    }


def rel_error_map(rendered, expected, mask, floor):
    """Per-pixel relative error (max over channels) as in :func:`compare`; 0
    outside ``mask``."""
    r = np.asarray(rendered, dtype=np.float64)[..., :3]
    e = np.asarray(expected, dtype=np.float64)
    rel = np.abs(r - e) / np.maximum(np.abs(e), floor)
    out = rel.max(axis=-1)
    return np.where(mask, out, 0.0)


def aggregate(per_render):
    """Max and RMS of the relative error over several comparisons (each a
    dict with ``max_rel_error``, ``rms_rel_error``, ``n_pixels``); returns
    ``(max, rms, pixels)``."""
    mx = max(p["max_rel_error"] for p in per_render)
    n = sum(p["n_pixels"] for p in per_render)
    ms = sum(p["rms_rel_error"] ** 2 * p["n_pixels"] for p in per_render) / max(n, 1)
    return mx, math.sqrt(ms), n
