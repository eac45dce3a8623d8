# SPDX-License-Identifier: GPL-3.0-or-later
"""The verification cases, generated from the catalogue.

Each :class:`Case` is one material: a model (or preset) of
``addon.catalogue`` with parameters named and measured as in
``addon.reference`` (angles in radians, colours RGB), a short ``variant``
string for tables ("gaussian/smith", "energy", ...) and the status of its
path-traced output (the ``BSDF`` socket, built from Cycles closures):

- ``"exact"``: the closure is the model itself: Lambert (``diffuse``),
  Phong in both normalisations (``phong_ramp`` times a constant),
  microfacet Trowbridge-Reitz + ``smith_correlated`` with any Fresnel
  (``microfacet("ggx")``, ``dielectric_bsdf``, ``conductor_bsdf``) -- the
  conductor only from Blender 5.2 (4.5's ``conductor_bsdf`` uses an older
  approximation, off by up to 8 %).
- ``"near"``: Beckmann + ``smith_correlated``: Cycles' height-correlated
  Smith uses Walter 2007's rational Lambda instead of the erf form
  (measured up to 6e-3 relative).
- ``"approx"``: everything else (Blinn-Phong, Blinn and Gaussian D,
  separable Smith, V-groove, the 1967 bracket, no shadowing, Ward,
  Kajiya-Kay): the closure is a stand-in; the report gives the measured
  error and claims no tolerance.

Importing this needs no bpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from addon import catalogue

from ..harness.checks import tolerance

DEG = math.pi / 180.0

EXACT, NEAR, APPROX = "exact", "near", "approx"

# Path-traced tolerance of each status (None: measured, no claim), from the
# one tolerance table (verification/harness/checks.py).
PATH_TRACED_TOLERANCE = {EXACT: tolerance("path_traced_exact"), NEAR: tolerance("path_traced_near"),
                         APPROX: None}
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
    status: dict = field(default_factory=dict)  # blender (major, minor) -> status; key None = any
    fresnel_sweep: bool = False

    @property
    def id(self) -> str:
        return f"{self.model}[{self.variant}]"

    def path_traced_status(self, blender_version=(5, 2)) -> str:
        """``"exact"``, ``"near"`` or ``"approx"`` for this Blender version."""
        for key, value in self.status.items():
            if key is not None and tuple(blender_version[:2]) < key:
                return value
        return self.status[None]

    def path_traced_tolerance(self, blender_version=(5, 2)):
        return PATH_TRACED_TOLERANCE[self.path_traced_status(blender_version)]


def microfacet_status(distribution, shadowing, fresnel="none"):
    """Path-traced status of a microfacet variant.  A dict: ``{None: status}``
    or, for the conductor, ``{(5, 2): status before 5.2, None: from 5.2}``."""
    if shadowing != "smith_correlated" or distribution not in ("trowbridge_reitz", "beckmann"):
        return {None: APPROX}
    base = EXACT if distribution == "trowbridge_reitz" else NEAR
    if fresnel == "conductor":
        return {(5, 2): APPROX, None: base}
    return {None: base}


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
            status = microfacet_status(v["distribution"], v["shadowing"], v["fresnel"])
            variant = f"default {v['distribution']}/{v['shadowing']}"
        elif mid in ("lambert", "phong"):
            status, variant = {None: EXACT}, "default"
        else:
            status, variant = {None: APPROX}, "default"
        cases.append(Case(mid, {}, variant, status))
    # Phong's and Blinn-Phong's other normalisation
    cases.append(Case("phong", {"normalization": "energy"}, "energy", {None: EXACT}))
    cases.append(Case("blinn_phong", {"normalization": "energy"}, "energy", {None: APPROX}))
    # microfacet: every distribution x shadowing (the 1967 bracket: Beckmann only)
    beta = 25.0 * DEG  # wide enough that shadowing and its variants matter
    for dist in catalogue.DISTRIBUTIONS:
        for sh in catalogue.SHADOWINGS:
            if sh == "smith_1967" and dist != "beckmann":
                continue
            cases.append(Case("microfacet", {"distribution": dist, "shadowing": sh, "beta": beta},
                              f"{dist}/{sh}", microfacet_status(dist, sh)))
    # Fresnel, on the exact TR + correlated base (theta_d sweep)
    n, k = catalogue.METALS[METAL]
    tr = {"distribution": "trowbridge_reitz", "shadowing": "smith_correlated", "alpha": 0.3}
    cases.append(Case("microfacet", dict(tr, fresnel="dielectric", ior=1.5),
                      "trowbridge_reitz/smith_correlated/dielectric 1.5",
                      microfacet_status("trowbridge_reitz", "smith_correlated", "dielectric"),
                      fresnel_sweep=True))
    cases.append(Case("microfacet", dict(tr, fresnel="conductor", ior=n, k=k),
                      f"trowbridge_reitz/smith_correlated/conductor {METAL}",
                      microfacet_status("trowbridge_reitz", "smith_correlated", "conductor"),
                      fresnel_sweep=True))
    cases.append(Case("microfacet", {"distribution": "beckmann", "shadowing": "smith",
                                     "fresnel": "conductor", "ior": n, "k": k, "beta": beta},
                      f"beckmann/smith/conductor {METAL}", {None: APPROX}, fresnel_sweep=True))
    # anisotropic native widths
    for dist in ("trowbridge_reitz", "beckmann"):
        cases.append(Case("microfacet", {"distribution": dist, "shadowing": "smith_correlated",
                                         "alpha_x": 0.15, "alpha_y": 0.45},
                          f"{dist}/smith_correlated/aniso 0.15x0.45",
                          microfacet_status(dist, "smith_correlated")))
    # presets (their default Fresnel is dielectric: sweep theta_d)
    for pid in catalogue.PRESETS:
        cases.append(Case(pid, {}, "preset", {None: APPROX}, fresnel_sweep=True))
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
