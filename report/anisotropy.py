# SPDX-License-Identifier: GPL-3.0-or-later
"""The anisotropy and hair section of the report: the checks' renders as
PNGs (only draws and writes)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from verification import harness

BACKGROUND = np.array([0.55, 0.6, 0.65])  # display value behind the hair demo


def write_image(path, img, scale=None, background=None):
    """A linear float image as an 8-bit sRGB PNG; ``scale`` divides
    (default: the 99.5th percentile); pure-black pixels become
    ``background`` (display value) when given."""
    img = np.asarray(img, dtype=np.float64)[..., :3]
    if scale is None:
        v = img[img.max(-1) > 0]
        scale = float(np.percentile(v, 99.5)) if v.size else 1.0
    x = harness.srgb_encode(img / max(scale, 1e-30))
    if background is not None:
        x[img.max(-1) <= 0] = background
    return str(harness.write_png(path, x, srgb=False))


def write_images(checks, out_dir):
    """Write every check's images to ``out_dir``; returns ``[(check,
    [paths])]`` with each image written once."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written, rows = {}, []
    for c in checks:
        paths = []
        for name, (img, scale) in c.images.items():
            if name not in written:
                bg = BACKGROUND if name.startswith("hair_") and scale is not None else None
                written[name] = write_image(out_dir / f"{name}.png", img, scale, bg)
            paths.append(written[name])
        rows.append((c, paths))
    return rows
