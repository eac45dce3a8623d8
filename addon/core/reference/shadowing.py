# SPDX-License-Identifier: GPL-3.0-or-later
"""Self-shadowing functions that are not a distribution's Smith G1.

Slides "Self-Shadowing Function" (the 1967 bracket form) and
"Self-Shadowing: V-Groove Model".
"""

from __future__ import annotations

import numpy as np

from .distributions import Lambda_beckmann
from .special import erfc


def G_vgroove(ci, co, ch, cih):
    """V-groove G = min(1, 2(N.H)(N.E)/(E.H), 2(N.H)(N.L)/(L.H))
    (slide: "Self-Shadowing: V-Groove Model"); E.H = L.H for the half vector.

    Arguments are cosines: N.L, N.E, N.H, L.H; negative ones count as 0.  G
    is in [0, 1]: 0 where a cosine of the numerator is 0, 1 where L.H is 0 and
    the numerator is not (the limit); a NaN gives NaN."""
    num = 2.0 * np.maximum(ch, 0.0) * np.maximum(np.minimum(ci, co), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.minimum(1.0, num / np.maximum(cih, 0.0))
    return np.where(num > 0.0, g, 0.0 * num)  # NaN stays NaN


def S_smith_1967(wx, wy, wz, ax, ay):
    """The slide's S(theta) = [1 - erfc(mu/(sqrt2 rms))/2] / (1 + Lambda).

    With rms = m/sqrt2 the argument is a = 1/(m tan theta).  The bracket is the
    chance that the point's own facet faces the ray; inside a microfacet BRDF
    it breaks the self-consistency condition (by up to ~50 %).
    """
    r = np.sqrt((wx * ax) ** 2 + (wy * ay) ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(r > 0.0, wz / r, np.inf)
    bracket = 1.0 - 0.5 * erfc(a)
    return bracket / (1.0 + Lambda_beckmann(wx, wy, wz, ax, ay))
