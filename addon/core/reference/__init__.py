# SPDX-License-Identifier: GPL-3.0-or-later
"""Numpy reference of every reflection model in the catalogue: the judge.

Public API (scripts and tests depend on it)::

    shade(model, wi, wo, *, normal=(0, 0, 1), tangent=(1, 0, 0), **params) -> (..., 3)
    brdf(model, wi, wo, *, normal=(0, 0, 1), tangent=(1, 0, 0), **params)  -> (..., 3)

``shade`` is the radiance reflected toward ``wo`` under a directional light of
unit irradiance: what a pixel of an orthographic Cycles render under a sun of
strength 1 shows.  For surface models it is ``brdf * max(0, normal . wi)``.
Directions point away from the surface (``wi`` toward the light, ``wo``
toward the eye; ``normal``, ``tangent``), are scaled to unit length (a zero
vector, or one with a NaN or infinite component, has no direction and gives
0) and broadcast over leading axes, as do array-valued parameters.  Colours
are RGB triples (a trailing axis of length 3); a scalar colour, or a trailing
axis of length 1, is grey; any other shape (RGBA, say) raises ``ValueError``.
Angles are radians.

Also public: the microfacet distributions as types (:func:`distribution`,
:class:`Blinn`, :class:`Gaussian`, :class:`TrowbridgeReitz`,
:class:`Beckmann`: D, Lambda, G1, G) and as functions with explicit widths
(``D_*``, ``Lambda_*``), the width conversions, shadowing, Fresnel and a
double-precision ``erf``/``erfc``.  Each raises ``ValueError`` naming its
range for a width or index outside it (beta in (0, pi/2); the exponent, m,
alpha and a dielectric's index above 0; a conductor's n and k at least 0;
NaN and infinities included).  D is 0 for a facet normal below the surface,
Lambda infinite (G1 = 0) for a direction on or below it; Fresnel clamps its
cosine to [0, 1]; V-groove's G stays in [0, 1].

Hand-written from the lecture (``shared/lecture-reflection-models.txt``,
conventions and errata in ``shared/LECTURE-NOTES.md``); never generated from
the formula description that the shaders and node graphs are generated from.
Needs numpy only.

Modules: :mod:`.special` (erf, erfc, quadrature), :mod:`.distributions`,
:mod:`.shadowing`, :mod:`.fresnel`, :mod:`.models` (the BRDFs, shade, brdf).
"""

from .distributions import (  # noqa: F401
    CHEB_BETA, CHEB_NB, CHEB_NX, GAUSSIAN_NORM_NODES, LAMBDA_NODES, LN2, LOG_D_CUT, PI,
    TR_ALPHA_BETA_LIMIT, TYPES, Aminus_quadrature, Beckmann, Blinn, D_beckmann, D_blinn,
    D_gaussian, D_trowbridge_reitz, Distribution, Gaussian, Lambda_beckmann,
    Lambda_chebyshev, Lambda_table, Lambda_trowbridge_reitz, TrowbridgeReitz,
    beckmann_m_from_beta, beta_from_beckmann_m, beta_from_blinn_exponent,
    beta_from_gaussian_c2, beta_from_tr_alpha, blinn_alpha_cut, blinn_exponent_from_beta,
    distribution, gaussian_alpha_cut, gaussian_c2_from_beta, gaussian_norm,
    lambda_chebyshev, tr_alpha_from_beta,
)
from .fresnel import F_conductor, F_dielectric  # noqa: F401
from .models import (  # noqa: F401
    CHUNK, DEFAULT_NORMAL, DEFAULT_TANGENT, brdf, microfacet_distribution, shade,
)
from .shadowing import G_vgroove, S_smith_1967  # noqa: F401
from .special import SQRT_PI, clenshaw, erf, erfc, gauss_legendre  # noqa: F401

__all__ = [
    "shade", "brdf", "erf", "erfc",
    "blinn_exponent_from_beta", "beta_from_blinn_exponent",
    "gaussian_c2_from_beta", "beta_from_gaussian_c2", "gaussian_norm",
    "tr_alpha_from_beta", "beta_from_tr_alpha", "TR_ALPHA_BETA_LIMIT",
    "beckmann_m_from_beta", "beta_from_beckmann_m",
    "D_blinn", "D_gaussian", "D_trowbridge_reitz", "D_beckmann",
    "Lambda_trowbridge_reitz", "Lambda_beckmann", "Lambda_table", "Lambda_chebyshev",
    "Aminus_quadrature", "G_vgroove", "S_smith_1967",
    "F_dielectric", "F_conductor",
    "Distribution", "Blinn", "Gaussian", "TrowbridgeReitz", "Beckmann", "distribution",
]
