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
    (slide: "Self-Shadowing: V-Groove Model"); E.H = L.H for the half vector."""
    return np.minimum(1.0, 2.0 * ch * np.minimum(ci, co) / cih)


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
