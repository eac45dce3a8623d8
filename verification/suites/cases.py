# SPDX-License-Identifier: GPL-3.0-or-later
"""The verification cases, generated from the catalogue.

Each :class:`Case` is one material: a model (or preset) of
``addon.catalogue`` with parameters named and measured as in
``addon.reference`` (angles in radians, colours RGB) and a short ``variant``
string for tables ("gaussian/smith", "energy", ...).

The status of its path-traced output (the ``BSDF`` socket, built from
Cycles closures) depends on the backend's closures and comes from the
formula description (``Formula.fidelity``):

- ``"exact"``: the closure is the model itself: Lambert (``diffuse``),
  Phong in OSL (``phong_ramp`` times a constant), microfacet
  Trowbridge-Reitz + ``smith_correlated`` with any Fresnel -- the conductor
  only from Blender 5.2 (4.5's conductor closure uses an older
  approximation, off by up to 8 %).
- ``"near"``: Beckmann + ``smith_correlated``: Cycles' height-correlated
  Smith uses Walter 2007's rational Lambda instead of the erf form
  (measured up to 6e-3 relative).
- ``"fitted"``: a mixture of closures fitted offline (fitting/mixtures.py)
  whose largest error the fitter measured within the bound; checked here
  as the largest difference over the peak.
- ``"approx"``: everything else: the best mixture or lobe; checked against
  the fitter's figure at the case's width and Fresnel where it measured one
  (:meth:`Case.path_traced_error`, what ``api.bsdf_accuracy`` states), else
  the report gives the measured error and claims no tolerance.

Importing this needs no bpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from addon import catalogue
from addon.core import variants
from addon.core.formulas import models as formulas

from ..harness.checks import tolerance

DEG = math.pi / 180.0

EXACT, NEAR, FITTED, APPROX = "exact", "near", "fitted", "approx"

# Path-traced tolerance of each status (None: measured, no claim), from the
# one tolerance table (verification/harness/checks.py).  'fitted' is on the
# largest difference over the peak, the others on the relative error.
PATH_TRACED_TOLERANCE = {EXACT: tolerance("path_traced_exact"), NEAR: tolerance("path_traced_near"),
                         FITTED: tolerance("path_traced_fitted"), APPROX: None}
EXACT_MODE_TOLERANCE = tolerance("exact_mode")

# The metal of the conductor cases.
METAL = "gold"


@dataclass(frozen=True)
class Case:
    """One verification case.  ``fresnel_sweep``: the Fresnel factor is
    constant over a gonio image (every pixel has the same angle L.H), so the
    case is measured at several half-angles theta_d instead of at fixed
    light directions."""
    model: str
    params: dict = field(default_factory=dict)
    variant: str = "default"
    fresnel_sweep: bool = False

    @property
    def id(self) -> str:
        return f"{self.model}[{self.variant}]"

    @property
    def enums(self) -> dict:
        """The structural choices of the case's group (preset values filled in)."""
        structural = {p.name for p in variants.variant_params(self.model)}
        enums = {k: v for k, v in self.params.items() if k in structural}
        if "width_mode" in structural:  # the microfacet model's, not Ward's own alphas
            if "alpha_x" in self.params:
                enums["width_mode"] = "alpha_xy"
            elif "alpha" in self.params:
                enums["width_mode"] = "alpha"
        _model, full = variants.resolve_variant(self.model, enums)
        return {k: v for k, v in full.items() if k != "backend"}

    def path_traced_status(self, blender_version=(5, 2), backend="osl") -> str:
        """``"exact"``, ``"near"``, ``"fitted"`` or ``"approx"`` for this
        Blender version and backend (``"osl"``, or ``"native"`` nodes)."""
        model, _fixed, _defaults = catalogue.resolve(self.model)
        # the widths decide too (Cycles clamps alpha to 1)
        return formulas.path_traced_status(model.id, self.enums, self.params, blender_version,
                                           backend)

    def path_traced_error(self, blender_version=(5, 2), backend="osl") -> tuple:
        """``(error, where)``: the fitter's largest difference over the peak
        for this case's BSDF output (views and lights to 70 deg), or
        ``(None, why)`` (:func:`addon.core.formulas.models.path_traced_error`)."""
        model, _fixed, _defaults = catalogue.resolve(self.model)
        return formulas.path_traced_error(model.id, self.enums, self.params, blender_version,
                                          backend)

    def path_traced_tolerance(self, blender_version=(5, 2), backend="osl"):
        return PATH_TRACED_TOLERANCE[self.path_traced_status(blender_version, backend)]


def _resolved(model):
    m, fixed, defaults = catalogue.resolve(model)
    values = {p.name: p.default for p in m.params}
    values.update(defaults)
    values.update(fixed)
    return values


def build_cases():
    """Every case, in report order."""
    cases = []
    # every model at its defaults
    for mid in catalogue.MODELS:
        if mid == "microfacet":
            v = _resolved(mid)
            variant = f"default {v['distribution']}/{v['shadowing']}"
        else:
            variant = "default"
        cases.append(Case(mid, {}, variant))
    # Phong's and Blinn-Phong's other normalisation
    cases.append(Case("phong", {"normalization": "energy"}, "energy"))
    cases.append(Case("blinn_phong", {"normalization": "energy"}, "energy"))
    # microfacet: every distribution x shadowing (the 1967 bracket: Beckmann only)
    beta = 25.0 * DEG  # wide enough that shadowing and its variants matter
    for dist in catalogue.DISTRIBUTIONS:
        for sh in catalogue.SHADOWINGS:
            if sh == "smith_1967" and dist != "beckmann":
                continue
            cases.append(Case("microfacet", {"distribution": dist, "shadowing": sh, "beta": beta},
                              f"{dist}/{sh}"))
    # Fresnel, on the exact TR + correlated base (theta_d sweep)
    n, k = catalogue.METALS[METAL]
    tr = {"distribution": "trowbridge_reitz", "shadowing": "smith_correlated", "alpha": 0.3}
    cases.append(Case("microfacet", dict(tr, fresnel="dielectric", ior=1.5),
                      "trowbridge_reitz/smith_correlated/dielectric 1.5", fresnel_sweep=True))
    cases.append(Case("microfacet", dict(tr, fresnel="conductor", ior=n, k=k),
                      f"trowbridge_reitz/smith_correlated/conductor {METAL}", fresnel_sweep=True))
    cases.append(Case("microfacet", {"distribution": "beckmann", "shadowing": "smith",
                                     "fresnel": "conductor", "ior": n, "k": k, "beta": beta},
                      f"beckmann/smith/conductor {METAL}", fresnel_sweep=True))
    # anisotropic native widths
    for dist in ("trowbridge_reitz", "beckmann"):
        cases.append(Case("microfacet", {"distribution": dist, "shadowing": "smith_correlated",
                                         "alpha_x": 0.15, "alpha_y": 0.45},
                          f"{dist}/smith_correlated/aniso 0.15x0.45"))
    # presets (their default Fresnel is dielectric: sweep theta_d)
    for pid in catalogue.PRESETS:
        cases.append(Case(pid, {}, "preset", fresnel_sweep=True))
    ids = [c.id for c in cases]
    assert len(ids) == len(set(ids)), "duplicate case ids"
    return cases


CASES = build_cases()


def by_id(case_id):
    for c in CASES:
        if c.id == case_id:
            return c
    raise KeyError(case_id)


# Light directions (toward the sun, the camera looks down -z from +z).
# Two directions per case: a moderate sun and a low one from another side;
# Fresnel cases use the half-angle sweep instead.
LIGHT_DIRS = ((0.35, 0.25, 0.90), (-0.75, 0.30, 0.59))
THETA_D_SWEEP = (15.0, 50.0, 75.0)


def random_cases(n_microfacet=14, n_other=3, seed=2026):
    """Seeded random parameters over each model's whole range, its ends
    included (every distribution, shadowing, Fresnel and width mode of the
    microfacet model), except where float32 directions alone exceed the
    tolerance (widths below 0.03 in alpha; docs/verification.md, narrow
    lobes) or the gonio's pixels see only a tail below float32's smallest
    numbers (exponents over 1000, beta under 2 deg).  The tests' cases
    (tests/test_verification.py, tests/test_native.py)."""
    import random
    rng = random.Random(seed)
    out = []
    for model_id, model in catalogue.MODELS.items():
        for i in range(n_microfacet if model_id == "microfacet" else n_other):
            p = {q.name: rng.choice(q.choices) for q in model.params if q.is_enum}
            if p.get("shadowing") == "smith_1967":
                p["distribution"] = "beckmann"
            for q in model.params:
                if q.is_enum or q.name in ("beta", "alpha", "alpha_x", "alpha_y", "exponent"):
                    continue
                hi = q.soft_max if q.soft_max is not None else q.maximum
                r = rng.random()
                x = q.minimum if r < 0.15 else hi if r < 0.3 else rng.uniform(q.minimum, hi)
                if q.kind == "color":
                    x = max(x, 0.05) if q.name in ("ks", "kd", "albedo") else x
                    x = tuple(min(max(x * f, q.minimum), q.maximum)
                              for f in (1.0, rng.uniform(0.3, 1.0), rng.uniform(0.3, 1.0)))
                p[q.name] = x
            if "exponent" in model.param_names:
                p["exponent"] = rng.choice([0.0, rng.uniform(0.0, 50.0), rng.uniform(50.0, 1000.0),
                                            1000.0])
            if model_id == "ward":
                p["alpha_x"], p["alpha_y"] = rng.uniform(0.03, 1.0), rng.uniform(0.03, 1.0)
            if model_id == "microfacet":
                widths = ["beta"] if p["distribution"] in ("blinn", "gaussian") else \
                    ["beta", "alpha", "alpha_xy"]
                w = rng.choice(widths)
                if w == "beta":
                    p["beta"] = rng.choice([2.0, rng.uniform(2.0, 20.0), rng.uniform(20.0, 85.0),
                                            85.0]) * math.pi / 180.0
                elif w == "alpha":
                    p["alpha"] = rng.choice([0.03, rng.uniform(0.03, 1.0), rng.uniform(1.0, 4.0),
                                             4.0])
                else:
                    p["alpha_x"], p["alpha_y"] = rng.uniform(0.03, 1.0), rng.uniform(0.03, 1.0)
            out.append(Case(model_id, p, f"random {i}"))
    return out
