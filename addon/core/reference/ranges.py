# SPDX-License-Identifier: GPL-3.0-or-later
"""The one range check of the reference's public terms (widths, indices):
numpy alone would answer a value outside a term's domain silently (NaN, a
mirrored lobe, a width repeating with the period of cos)."""

from __future__ import annotations

import math

import numpy as np

PI = math.pi


def within(x, name, lo, hi=math.inf, *, lo_closed=False):
    """``x`` as a float array whose every element is finite and in (lo, hi),
    or [lo, hi) with ``lo_closed``; else ValueError naming the first value
    outside and the allowed interval."""
    arr = np.asarray(x, dtype=float)
    above = (arr >= lo) if lo_closed else (arr > lo)
    ok = np.isfinite(arr) & above & (arr < hi)
    if not np.all(ok):
        bad = float(arr[~ok].ravel()[0]) if arr.ndim else float(arr)
        upper = "inf" if hi == math.inf else ("pi/2" if hi == 0.5 * PI else f"{hi:.6g}")
        raise ValueError(f"{name}={bad!r} is out of range; {name} must be a finite number in "
                         f"{'[' if lo_closed else '('}{lo:g}, {upper})")
    return arr
