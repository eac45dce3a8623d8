# SPDX-License-Identifier: GPL-3.0-or-later
"""The one record of a verification result, and the one tolerance table.

Every check of the project (gonio cases, oracle, furnace, lecture figures,
anisotropy scenes) is a :class:`Check`; its tolerance comes from
:data:`TOLERANCES`, where each number has its one-line reason.  The report
draws checks; tests assert on their ``values``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Tolerance:
    value: float
    reason: str


TOLERANCES = {
    # exact mode and the closures that are the model
    "exact_mode": Tolerance(1e-4, "float32 shader arithmetic (Cycles' fast math, angles refined) "
                                  "against the float64 reference; measured <= 1.5e-5"),
    "path_traced_exact": Tolerance(1e-3, "a closure that is the model: float32 only (measured "
                                         "<= 8e-6)"),
    "path_traced_near": Tolerance(1e-2, "Cycles' Beckmann uses Walter 2007's rational Lambda, not "
                                        "the erf form (<= 6e-3 at alpha 0.6-1)"),
    "path_traced_fitted": Tolerance(0.025, "a fitted mixture: the fitter's bound on the largest "
                                           "difference over the peak (views and lights to 70 deg)"),
    # the value is the case's own: Case.path_traced_error
    "path_traced_measured": Tolerance(float("nan"), "an approximate mixture or lobe: the "
                                      "fitter's measured largest difference over the peak at "
                                      "this width and Fresnel (views and lights to 70 deg), the "
                                      "figure api.bsdf_accuracy and the sidebar state"),
    "eevee_exact": Tolerance(3e-3, "EEVEE's half-float output (11-bit mantissa: 4.9e-4 per "
                                   "value) and its float shader arithmetic, over the peak"),
    "eevee_false_shadow": Tolerance(0.01, "EEVEE's Raycast node traces in screen space: a shadow "
                                          "ray passing behind a visible surface counts as a hit "
                                          "(measured: 1 of 634 gonio pixels); the fraction of "
                                          "lit pixels it blackens"),
    "oracle_ggx": Tolerance(1e-4, "both are float32 evaluations of the same formula"),
    "oracle_beckmann": Tolerance(1e-2, "Cycles' Beckmann uses Walter 2007's rational Lambda"),
    "furnace_sigmas": Tolerance(4.0, "Monte Carlo margin in standard errors of a bin's mean, from "
                                     "the spread of its pixels (over-estimates the noise)"),
    # lecture figures (numpy)
    "phong_half_width_deg": Tolerance(0.02, "the lobe sampled every 0.01 deg, interpolated "
                                            "linearly"),
    "reciprocity": Tolerance(1e-12, "(E.R(L))^s and (L.R(E))^s: float64 rounding of a power <= 1"),
    "albedo_bound": Tolerance(1e-9, "quadrature weights sum to 1, integrand <= 1: rounding only"),
    "albedo_limit": Tolerance(0.01, "at s = 1000 the lobe (2.1 deg) changes cos theta_i by < 1e-3"),
    "half_maximum": Tolerance(1e-9, "closed-form width conversions: rounding only"),
    "self_consistency": Tolerance(2e-4, "quadrature (~1e-7) and the Lambda series (<= 1e-6 in G1)"),
    "bracket_deviation": Tolerance(0.2, "the 1967 bracket is 1 - erfc(1/(m tan theta))/2: 0.516 "
                                        "at m = 0.6, 89 deg (a lower bound)"),
    "render_vs_reference_peak": Tolerance(1e-3, "exact mode (float32) against numpy, relative to "
                                                "the peak"),
    "vgroove_near": Tolerance(0.02, "V-groove and Smith are both ~1 near normal for m = 0.3"),
    "vgroove_grazing": Tolerance(0.2, "V-groove ignores the roughness, Smith does not (a lower "
                                      "bound)"),
    # anisotropy scenes
    "streak_angle_deg": Tolerance(2.0, "moment fit of the streak on the pixel grid (0.05 deg on "
                                       "the reference image)"),
    "terms_sum": Tolerance(1e-5, "Diffuse + Specular = Color / strength: one float32 multiply"),
    "hair_band": Tolerance(0.05, "3 pixels: the waves tilt T and the strands' shadows (measured "
                                 "0.6 px)"),
}


def tolerance(name: str) -> float:
    return TOLERANCES[name].value


@dataclass
class Check:
    """One verification result.

    - ``passed``: True, False, or None when nothing is claimed (a measured
      approximation);
    - ``measured``/``expected``: one line each, for people;
    - ``values``: the numbers (tests assert on these);
    - ``images``: arrays or file paths the report shows (never asserted on).
    """
    name: str
    passed: bool | None
    measured: str = ""
    expected: str = ""
    detail: str = ""
    group: str = ""
    tolerance: str = ""
    values: dict = field(default_factory=dict)
    images: dict = field(default_factory=dict)
    seconds: float = math.nan

    @property
    def verdict(self) -> str:
        return {True: "pass", False: "FAIL", None: "measured"}[self.passed]

    def summary(self) -> dict:
        """The record without images, for JSON."""
        return {"name": self.name, "pass": self.passed, "measured": self.measured,
                "expected": self.expected, "detail": self.detail, "group": self.group,
                "tolerance": self.tolerance, "values": _jsonable(self.values),
                "seconds": self.seconds}


def _jsonable(value):
    import numpy as np

    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist() if value.size <= 64 else f"array{value.shape}"
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    return value
