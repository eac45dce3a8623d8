# SPDX-License-Identifier: GPL-3.0-or-later
"""Directions and camera bases (numpy only).

Conventions: directions are unit 3-vectors in world space; ``view_dir``
points from the scene toward the camera (= wo of every pixel of an
orthographic camera), ``light_dir`` toward the sun (= wi).
"""

from __future__ import annotations

import numpy as np


def normalize(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def camera_basis(direction, up_hint=None):
    """Right-handed orthonormal basis ``(right, up, direction)`` as the columns
    of a 3x3 array, with ``direction`` normalised.

    Used for the camera (``direction`` = toward the camera, the camera looks
    along ``-direction``) and the sun (``direction`` = toward the sun).
    ``up`` is the projection of ``up_hint`` (default world +Y, or +Z when the
    direction is close to Y) on the plane perpendicular to ``direction``.
    With ``direction = (0,0,1)`` and the default hint the basis is identity.
    """
    w = normalize(direction)
    if up_hint is None:
        up_hint = (0.0, 1.0, 0.0) if abs(w[1]) < 0.9 else (0.0, 0.0, 1.0)
    up_hint = np.asarray(up_hint, dtype=np.float64)
    right = normalize(np.cross(up_hint, w))
    up = np.cross(w, right)
    return np.stack([right, up, w], axis=1)
