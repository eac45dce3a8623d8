# SPDX-License-Identifier: GPL-3.0-or-later
"""Image input and output, all through OpenImageIO (Blender's bundled copy,
which Cycles' ``oslquery`` needs: see :mod:`.session`).

Images are numpy arrays ``(H, W, C)`` with **row 0 at the top** of the
picture (the order OpenImageIO reads an EXR written by Blender).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np


def _oiio():
    from . import session
    session.use_bundled_site_packages()  # the bundled OpenImageIO must win over pip's
    import OpenImageIO
    return OpenImageIO


def srgb_encode(linear):
    """Linear [0, 1] -> sRGB-encoded [0, 1] (IEC 61966-2-1), clipped."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def write_png(path, rgb, *, srgb=True):
    """Write ``rgb`` ``(H, W, 3)`` (row 0 = top; linear if ``srgb``, else
    already display-encoded in [0, 1]) as an 8-bit PNG."""
    oiio = _oiio()

    img = np.asarray(rgb, dtype=np.float64)[..., :3]
    if srgb:
        img = srgb_encode(img)
    data = np.ascontiguousarray(np.clip(np.round(img * 255.0), 0, 255).astype(np.uint8))
    h, w = data.shape[:2]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = oiio.ImageOutput.create(str(path))
    if out is None:
        raise OSError(f"cannot create {path}: {oiio.geterror()}")
    spec = oiio.ImageSpec(w, h, 3, "uint8")
    spec.attribute("png:compressionLevel", 9)
    if not out.open(str(path), spec):
        raise OSError(f"cannot open {path}: {out.geterror()}")
    ok = out.write_image(data)
    out.close()
    if not ok:
        raise OSError(f"cannot write {path}")
    return path


def read_exr(path, channels=3):
    """Read the first ``channels`` channels of an image as float32
    ``(H, W, channels)``, row 0 = top of the picture."""
    oiio = _oiio()
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(f"cannot open {path}: {oiio.geterror()}")
    try:
        spec = inp.spec()
        data = inp.read_image(0, 0, 0, min(channels, spec.nchannels), "float")
    finally:
        inp.close()
    if data is None:
        raise OSError(f"cannot read {path}")
    data = np.asarray(data, dtype=np.float32).reshape(spec.height, spec.width, -1)
    return data


def temp_path(suffix=".exr", prefix="render_"):
    """A fresh file name under the process's temporary folder."""
    fd, path = tempfile.mkstemp(suffix=suffix, prefix=prefix)
    os.close(fd)
    os.remove(path)
    return path
