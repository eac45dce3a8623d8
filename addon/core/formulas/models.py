# SPDX-License-Identifier: GPL-3.0-or-later
"""Each model's evaluation, once, for every backend.

A :class:`Formula` per catalogue model gives

- ``evaluate(v, s, wi)``: the exact radiance per unit irradiance toward the
  viewer (``"value"``, a colour: f_r max(0, N.L) for surface models) for a
  light along ``wi``, and the model's terms (``D``, ``G``, ``Lobe``, ...);
- ``closure(v, s)``: the path-traced BSDF as a weighted sum of the
  renderer's closures.

``v`` (:class:`Values`) holds the parameters, clamped to the catalogue's
limits, and the structural choices (:class:`~.expr.Enum`); ``s``
(:class:`Shading`) the frame and the view direction.  The backends
(``addon.backends.osl``, ``addon.backends.native``) generate code or node
graphs from these graphs; the numpy reference is written separately, from
the lecture, and judges them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import catalogue, variants
from . import expr as E
from . import library as L
from .expr import choose, closure, closure_sum, const, div, fmax, gt, select, vec
from .shading import fibre_tangent, frame, local
from .shading import light as shading_light
from .shading import lights as shading_lights

PI = math.pi


@dataclass(frozen=True)
class Shading:
    """The frame (n, t, b) and the unit view direction ``wo``; ``tf`` the
    fibre direction for fibre models."""
    n: E.Expr
    t: E.Expr
    b: E.Expr
    wo: E.Expr
    tf: E.Expr | None = None
    caps: frozenset = None  # the closures of the backend (ALL_CLOSURES when None)


def shading(model_id: str, enums: dict | None = None, caps=None) -> Shading:
    """The shading frame and view of a model's variant (the tangent only
    where the variant uses one; ``enums`` None: any variant, as for the OSL
    shader that serves them all)."""
    model = catalogue.MODELS[model_id]
    uses = FORMULAS[model_id].uses_tangent(enums)
    n, t, b = frame(uses_tangent=uses)
    # the fibre falls back to the frame's tangent unrotated: fibre_tangent
    # rotates it (the frame's t, rotated already, was turned twice)
    tf = fibre_tangent(n, frame(uses_tangent=uses, rotated=False)[1]) \
        if model.kind == "fibre" else None
    return Shading(n, t, b, E.geometry("I"), tf, caps)


class Values:
    """A model's inputs as expressions: parameters clamped to their limits
    (:meth:`p`) and structural choices (:meth:`enum`).  ``enums`` maps a
    structural parameter to its choice (native: the variant is known) or is
    missing it (OSL: the shader receives the int code)."""

    def __init__(self, model_id: str, enums: dict | None = None, known=True):
        self.model = catalogue.MODELS[model_id]
        self.enums = dict(enums or {})
        self.known = known  # True, False, or the set of names whose choice is known
        self._cache = {}

    def p(self, name: str) -> E.Expr:
        if name not in self._cache:
            self._cache[name] = L.clamped(self.model.param(name))
        return self._cache[name]

    def enum(self, name: str) -> E.Enum:
        param = next((p for p in variants.variant_params(self.model.id) if p.name == name), None)
        if param is None:
            raise KeyError(f"{self.model.id} has no structural parameter {name!r}")
        known = self.known if isinstance(self.known, bool) else name in self.known
        value = self.enums.get(name, param.default) if known else None
        return E.Enum(name, param.choices, value)


def _upper(ci, co):
    return gt(ci, 0.0) * gt(co, 0.0)


# The closures a backend offers (expr.closure names).  Cycles' OSL has them
# all; the native nodes have no Phong lobe (phong_ramp).
ALL_CLOSURES = frozenset({"diffuse", "phong_ramp", "microfacet", "dielectric", "conductor",
                          "hair_reflection", "ashikhmin_shirley"})
# What native nodes offer: no Phong lobe, and dielectric Fresnel only as a
# conductor of extinction 0 (the Metallic BSDF, one closure for a coloured
# IOR); the Toon BSDF's glossy lobe, which EEVEE renders as a diffuse one,
# behind a switch between the engines (expr.engine_switch)
NATIVE_CLOSURES = (ALL_CLOSURES - {"phong_ramp", "dielectric"}) | {"glossy_toon"}


def per_choice(enum, build):
    """``choose`` whose branches are built from the choice's name."""
    return choose(enum, {c: (lambda c=c: build(c)) for c in enum.choices})


def _cos_o(s):
    return fmax(E.dot(s.n, s.wo), 0.0)


class Formula:
    """The description of one model (subclasses per model)."""

    model_id = ""
    # (name, kind) of the terms the exact shader outputs besides Color
    terms: tuple = ()

    def uses_tangent(self, enums: dict | None) -> bool:
        """Whether the variant ``enums`` (None: any variant) needs a tangent."""
        return False

    def evaluate(self, v: Values, s: Shading, wi) -> dict:
        raise NotImplementedError

    def closure(self, v: Values, s: Shading) -> E.Expr:
        """The path-traced BSDF from the closures the backend offers (``s.caps``)."""
        raise NotImplementedError

    def fidelity(self, enums: dict, caps=ALL_CLOSURES, params=None) -> str:
        """How the path-traced output matches the model: 'exact' (a closure is
        the model), 'near' (a closure within a documented difference),
        'fitted' (a fitted mixture whose error is measured and bounded),
        'approx' (the best mixture or lobe, measured, no bound).  ``params``:
        the widths where known (only the microfacet model's matter)."""
        return "approx"

    # the parameters the BSDF output's status and figure depend on, besides
    # the variant (``params`` of :meth:`fidelity`, :meth:`measured_error`)
    status_params: tuple = ("beta", "alpha", "alpha_x", "alpha_y", "ior", "k")

    def measured_error(self, enums: dict, caps=ALL_CLOSURES, params=None) -> tuple:
        """``(error, where)``: the largest |BSDF output - model| over the
        model's peak that the fitter measured for this output (views and
        lights up to 70 deg) and where it holds ("at this width": the
        interval of width nodes around the width in ``params``, with the
        Fresnel's class; "at its worst width": over every width), or
        ``(None, why)`` where none is measured."""
        return None, "not measured by the fitter: a term depends on the light direction"

    def measured_detail(self, params=None):
        """A sentence on the figure of :meth:`measured_error` where part of
        the domain decides it (Kajiya-Kay: the far side of the fibre), or
        None."""
        return None


class Lambert(Formula):
    model_id = "lambert"
    terms = (("cos_theta_i", "f"), ("cos_theta_o", "f"))

    def evaluate(self, v, s, wi):
        ci, co = E.dot(s.n, wi), E.dot(s.n, s.wo)
        # the colour times a masked float (one product per channel, not two);
        # max(0, cos theta_i) and the view's test: the upper hemisphere
        value = v.p("albedo") * select(gt(co, 0.0), fmax(ci, 0.0) * (1.0 / PI), 0.0)
        return {"value": value, "cos_theta_i": ci, "cos_theta_o": co}

    def closure(self, v, s):
        # Exact: diffuse() is Lambert.
        return closure("diffuse", v.p("albedo"), s.n)

    def fidelity(self, enums, caps=ALL_CLOSURES, params=None):
        return "exact"

    def measured_error(self, enums, caps=ALL_CLOSURES, params=None):
        return None, CLOSURE_IS_MODEL


class Phong(Formula):
    """Slides "Phong Model", "Energy normalization": ks (E.R(L))^s, 'energy'
    times (s+1)/(2 pi)."""
    model_id = "phong"
    terms = (("Lobe", "f"), ("cos_theta_s", "f"), ("cos_theta_i", "f"), ("cos_theta_o", "f"))

    def _norm(self, v, s_exp):
        return choose(v.enum("normalization"),
                      {"energy": lambda: (s_exp + 1.0) * (1.0 / (2.0 * PI)), "none": const(1.0)})

    def evaluate(self, v, s, wi):
        se = v.p("exponent")
        ci, co = E.dot(s.n, wi), E.dot(s.n, s.wo)
        m = E.reflect(wi, s.n)  # -R(L): one Vector Math node
        cs = -E.dot(m, s.wo)  # E.R(L)
        t = E.cross(m, s.wo)  # |R(L) x E| = sin
        lobe = L.lobe_of_tangent(cs, E.dot(t, t), se)
        value = v.p("ks") * select(gt(co, 0.0), self._norm(v, se) * lobe * fmax(ci, 0.0), 0.0)
        return {"value": value, "Lobe": lobe, "cos_theta_s": cs, "cos_theta_i": ci,
                "cos_theta_o": co}

    def closure(self, v, s):
        se = v.p("exponent")
        if "phong_ramp" in (s.caps or ALL_CLOSURES):
            # Exact: phong_ramp() is (s+2)/(2 pi) cos^s (Lafortune's normalisation);
            # a constant weight gives the lecture's form or the (s+1)/(2 pi) one.
            weight = v.p("ks") * (self._norm(v, se) * div(2.0 * PI, se + 2.0))
            return closure("phong_ramp", weight, s.n, se)
        # Fitted: no Phong lobe in the backend (native nodes); a mixture fitted
        # to the lecture's form, times the normalisation: of Toon lobes (round
        # about the mirror direction) in Cycles, of Glossy lobes in EEVEE,
        # which renders the Toon BSDF as a diffuse one.
        x, weight = E.log(1.0 + se), v.p("ks") * self._norm(v, se)
        lobes = _fitted_lobes("phong", x, s, weight)
        if "glossy_toon" not in (s.caps or ALL_CLOSURES):
            return lobes
        from . import mixtures

        def toon(name, w, size, smooth):
            if name == "diffuse":
                return closure("diffuse", E.scaled(weight, w), s.n)
            return closure("glossy_toon", E.scaled(weight, w), s.n, size, smooth)
        # where the Glossy mixture measured better (the widest lobes), Cycles
        # renders it too
        return E.engine_switch(mixtures.toon_mixture(x, _cos_o(s), toon), lobes,
                               mixtures.toon_glossy_band(x))

    def fidelity(self, enums, caps=ALL_CLOSURES, params=None):
        return "exact" if "phong_ramp" in caps else fit_status("phong")

    def measured_error(self, enums, caps=ALL_CLOSURES, params=None):
        if "phong_ramp" in caps:
            return None, CLOSURE_IS_MODEL
        from . import mixtures
        # the Toon mixture, which Cycles' native nodes render (EEVEE renders
        # the Glossy one, with EEVEE's own closures)
        return mixtures.toon_measured()["max_abs_over_peak_70"], AT_WORST_WIDTH


class BlinnPhong(Formula):
    """Slide "Reflection Geometry": ks (N.H)^s, 'energy' times (s+8)/(8 pi)."""
    model_id = "blinn_phong"
    terms = (("Lobe", "f"), ("cos_theta_h", "f"), ("cos_theta_i", "f"), ("cos_theta_o", "f"))

    def _norm(self, v, s_exp):
        return choose(v.enum("normalization"),
                      {"energy": lambda: (s_exp + 8.0) * (1.0 / (8.0 * PI)), "none": const(1.0)})

    def evaluate(self, v, s, wi):
        se = v.p("exponent")
        ci, co = E.dot(s.n, wi), E.dot(s.n, s.wo)
        h = wi + s.wo
        hl = E.length(h)
        ch = select(gt(hl, 0.0), div(E.dot(s.n, h), hl), 0.0)
        lobe = L.lobe_between(s.n, h, se)
        value = v.p("ks") * select(gt(co, 0.0), self._norm(v, se) * lobe * fmax(ci, 0.0), 0.0)
        return {"value": value, "Lobe": lobe, "cos_theta_h": ch, "cos_theta_i": ci,
                "cos_theta_o": co}

    def closure(self, v, s):
        # Fitted: Cycles has no Blinn-Phong lobe; the fitted mixture (an
        # Ashikhmin-Shirley lobe, whose (N.H)^n is Blinn's, with GGX, Beckmann
        # and diffuse members) of the lecture's form, times the normalisation.
        se = v.p("exponent")
        return _fitted_lobes("blinn_phong", E.log(1.0 + se), s, v.p("ks") * self._norm(v, se))

    def fidelity(self, enums, caps=ALL_CLOSURES, params=None):
        return fit_status("blinn_phong")

    def measured_error(self, enums, caps=ALL_CLOSURES, params=None):
        return fit_error("blinn_phong"), AT_WORST_WIDTH


def fit_status(key):
    """The variant's status at any width, without Fresnel: "fitted" where
    the shipped data (a fitted mixture or a weighted single lobe:
    fitting/assemble.py) measured within FIT_BOUND by the fitter's measure
    and, where ``fitting/bounds.py`` measured it (views four times as
    dense), in every interval of its width nodes, else "approx"."""
    return "fitted" if fit_error(key) <= FIT_BOUND else "approx"


def fit_error(key):
    """The variant's largest error over the peak at its worst width, without
    Fresnel: the larger of the fitter's measure and, where
    ``fitting/bounds.py`` measured it, its worst interval of width nodes
    (what :func:`fit_status` compares with FIT_BOUND)."""
    from . import mixtures
    worst = mixtures.worst_interval(key, "none")
    measured = mixtures.measured(key)["max_abs_over_peak_70"]
    return measured if worst is None else max(measured, worst)


# where a :meth:`Formula.measured_error` holds, and why there is none
AT_THIS_WIDTH = "at this width"
AT_THESE_SETTINGS = "at this exponent and these colours"  # Kajiya-Kay's cell
AT_WORST_WIDTH = "at its worst width"
CLOSURE_IS_MODEL = "a Cycles closure is the model"


def fit_status_at(key, value, fresnel, params):
    """"fitted" where the interval of width nodes around ``value`` measured
    within FIT_BOUND (``fitting/bounds.py``: without Fresnel, or with the
    worst index of the class of the model's Fresnel), else "approx"."""
    from . import mixtures
    cls = mixtures.fresnel_class(fresnel, params)
    if cls is None:
        return "approx"
    bound = mixtures.interval_bound(key, value, cls)
    return "fitted" if bound is not None and bound <= FIT_BOUND else "approx"


# A fitted mixture is "fitted" (bounded) when its measured largest error over
# the hemisphere (views and lights to 70 deg) is at most this fraction of the
# peak; else "approx" (measured, no bound).
FIT_BOUND = 0.025


def _fitted_lobes(key, x, s, weight, member=None):
    """A fitted mixture whose members are plain lobes (no Fresnel)."""
    from . import mixtures

    def plain(name, w, alpha):
        if name == "diffuse":
            return closure("diffuse", E.scaled(weight, w), s.n)
        if name == "ashikhmin_shirley":
            return closure("ashikhmin_shirley", E.scaled(weight, w), s.n, s.t, alpha, alpha)
        return closure("microfacet", E.scaled(weight, w), s.n, s.t, alpha, alpha,
                       distribution=name)
    return mixtures.mixture(key, x, _cos_o(s), member or plain)


def native_width_beyond_closures(distribution, enums, params) -> bool:
    """Whether a Trowbridge-Reitz or Beckmann width is wider than Cycles'
    closures reach (alpha 1): alpha, alpha x or y over 1 as given, or in
    beta Beckmann's m (Trowbridge-Reitz's alpha of beta stays under 0.85)."""
    mode = enums.get("width_mode") or ("alpha_xy" if "alpha_x" in params else
                                       "alpha" if "alpha" in params else "beta")
    if mode == "alpha":
        return float(params.get("alpha", 0.0)) > 1.0
    if mode == "alpha_xy":
        return max(float(params.get("alpha_x", 0.0)), float(params.get("alpha_y", 0.0))) > 1.0
    if distribution != "beckmann" or "beta" not in params:
        return False
    # the shaders' own m of beta, folded to a constant
    m = L.beckmann_m_from_beta(E.const(min(float(params["beta"]), catalogue.BETA_MAX)))
    if not m.is_const:
        raise TypeError(f"beckmann_m_from_beta did not fold at beta {params['beta']!r}")
    return m.data > 1.0


class Microfacet(Formula):
    """Slides "Torrance-Sparrow Model", "Microfacet Distribution Functions",
    "Self-Shadowing Function", "Self-Shadowing: V-Groove Model":
    f = ks F(L.H) G D(H) / (4 (N.L)(N.E))."""
    model_id = "microfacet"
    terms = (("D", "f"), ("G", "f"), ("F", "v"), ("cos_theta_i", "f"), ("cos_theta_o", "f"),
             ("cos_theta_h", "f"), ("cos_theta_d", "f"))

    def uses_tangent(self, enums):
        return enums is None or enums.get("width_mode") == "alpha_xy"

    def widths(self, v):
        """(ax, ay): the native widths; from beta, Trowbridge-Reitz gets its
        c3 and every other distribution Beckmann's m of the same beta (Blinn
        and Gaussian use it for their Lambda series and their closure)."""
        dist, mode = v.enum("distribution"), v.enum("width_mode")
        beta = v.p("beta")

        def from_beta():
            a = choose(dist, {"trowbridge_reitz": lambda: L.tr_alpha_from_beta(beta),
                              "*": lambda: L.beckmann_m_from_beta(beta)})
            return a, a

        def native(kind):
            return choose(dist, {"trowbridge_reitz": kind, "beckmann": kind,
                                 "*": lambda: from_beta()[0]})

        ax = choose(mode, {"beta": lambda: from_beta()[0],
                           "alpha": lambda: native(lambda: v.p("alpha")),
                           "alpha_xy": lambda: native(lambda: v.p("alpha_x"))})
        ay = choose(mode, {"beta": lambda: from_beta()[1],
                           "alpha": lambda: native(lambda: v.p("alpha")),
                           "alpha_xy": lambda: native(lambda: v.p("alpha_y"))})
        return ax, ay

    def evaluate(self, v, s, wi):
        dist, sh, fr = v.enum("distribution"), v.enum("shadowing"), v.enum("fresnel")
        beta = v.p("beta")
        ax, ay = self.widths(v)

        def framed():
            """Components in the frame (t, b, n): anisotropic widths."""
            li, lo = local(wi, s.t, s.b, s.n), local(s.wo, s.t, s.b, s.n)
            hv = vec(li[0] + lo[0], li[1] + lo[1], li[2] + lo[2])
            length = E.length(hv)
            inv = div(1.0, length)
            h = (hv[0] * inv, hv[1] * inv, hv[2] * inv)
            return li, lo, h, 0.5 * length

        def isotropic():
            """(length across n, 0, along n): with one width, D and Lambda
            see only those, and no tangent is computed.  The length across
            is that of w - n (n.w), accurate to float32 near the normal
            (sqrt(1 - (n.w)^2) is not)."""
            ci, co = E.dot(wi, s.n), E.dot(s.wo, s.n)
            li = (E.length(wi - s.n * ci), const(0.0), ci)
            lo = (E.length(s.wo - s.n * co), const(0.0), co)
            hv, hz = wi + s.wo, ci + co
            length = E.length(hv)
            inv = div(1.0, length)
            h = (E.length(hv - s.n * hz) * inv, const(0.0), hz * inv)
            return li, lo, h, 0.5 * length

        # cos theta_d = L.H = |L + E| / 2 for unit L and E, never below 0: the
        # dot product came out negative in float32 with L and E almost
        # opposite near grazing (a backlit silhouette), and V-groove's G with it
        forms = {}

        def flat(form):
            """A form's ten values (li, lo, h, cos theta_d), built once."""
            if form not in forms:
                li, lo, h, cd = form()
                forms[form] = (*li, *lo, *h, cd)
            return forms[form]

        # each value by the width mode (every mode but alpha_xy has one width)
        values = [choose(v.enum("width_mode"), {"alpha_xy": lambda k=k: flat(framed)[k],
                                               "*": lambda k=k: flat(isotropic)[k]})
                  for k in range(10)]
        li, lo, h, cd = tuple(values[0:3]), tuple(values[3:6]), tuple(values[6:9]), values[9]
        ci, co = li[2], lo[2]
        ch = h[2]

        D = choose(dist, {
            "blinn": lambda: L.D_blinn(*h, beta),
            "gaussian": lambda: L.D_gaussian(*h, beta),
            "trowbridge_reitz": lambda: L.D_trowbridge_reitz(*h, ax, ay),
            "beckmann": lambda: L.D_beckmann(*h, ax, ay)})

        def lam(w):
            return choose(dist, {
                "trowbridge_reitz": lambda: L.Lambda_trowbridge_reitz(*w, ax, ay),
                "beckmann": lambda: L.Lambda_beckmann(*w, ax, ay),
                "blinn": lambda: self._series(w, "blinn", beta),
                "gaussian": lambda: self._series(w, "gaussian", beta)})

        def smith(correlated):
            lam_i, lam_o = lam(li), lam(lo)
            if correlated:
                return div(1.0, 1.0 + lam_i + lam_o)
            return div(1.0, (1.0 + lam_i) * (1.0 + lam_o))

        G = choose(sh, {
            "none": const(1.0),
            "smith": lambda: smith(False),
            "smith_correlated": lambda: smith(True),
            "vgroove": lambda: L.G_vgroove(ci, co, ch, cd),
            # the bracket form is defined for Beckmann only; elsewhere Smith
            "smith_1967": lambda: choose(dist, {
                "beckmann": lambda: L.S_smith_1967(*li, ax, ay) * L.S_smith_1967(*lo, ax, ay),
                "*": lambda: smith(False)})})

        c = E.clamp(cd, 0.0, 1.0)
        F = choose(fr, {
            "none": lambda: vec(1.0, 1.0, 1.0),
            "dielectric": lambda: L.per_channel(L.F_dielectric, c, v.p("ior")),
            "conductor": lambda: L.per_channel(L.F_conductor, c, v.p("ior"), v.p("k"))})

        ok = _upper(ci, co) * gt(ch, 0.0)
        zero = vec(0.0, 0.0, 0.0)
        value = (v.p("ks") * F) * select(ok, G * D * div(1.0, 4.0 * co), 0.0)
        return {"value": value, "D": select(ok, D, 0.0), "G": select(ok, G, 0.0),
                "F": select(ok, F, zero), "cos_theta_i": ci, "cos_theta_o": co,
                "cos_theta_h": ch, "cos_theta_d": cd}

    @staticmethod
    def _series(w, distribution, beta):
        coefficients = L.lambda_chebyshev_coefficients(distribution, beta)
        return L.Lambda_chebyshev_x(*w, L.beckmann_m_from_beta(beta), coefficients)

    def closure(self, v, s):
        # Exact: Trowbridge-Reitz + smith_correlated is Cycles' GGX closure
        # (any Fresnel in 5.2; none or dielectric in 4.5).  Near: Beckmann +
        # smith_correlated, Cycles' Beckmann closure (Walter's rational Lambda,
        # < 1 %).  Everything else: a mixture fitted offline
        # (fitting/mixtures.py) over the view angle and the width, with the
        # model's Fresnel on each microfacet member (exact at the half vector)
        # and F(cos theta_o) on the diffuse one.
        dist, sh, mode = v.enum("distribution"), v.enum("shadowing"), v.enum("width_mode")
        ks = v.p("ks")
        cos_o = _cos_o(s)

        def lobe(name, weight, ax, ay):
            return self._fresnel_lobe(v, s, name, weight, ax, ay)

        def exact(name):
            ax, ay = self.widths(v)
            return lobe(name, ks, ax, ay)

        def fitted(d, shadowing):
            if shadowing == "smith_1967" and d != "beckmann":
                shadowing = "smith"  # the bracket form is defined for Beckmann only
            if d in ("blinn", "gaussian"):
                return self._fitted(v, s, f"microfacet/{d}/{shadowing}/beta", v.p("beta"),
                                    None, cos_o)

            def native(aniso):
                key = f"microfacet/{d}/{shadowing}/alpha"
                if not aniso:
                    return self._fitted(v, s, key, E.log(v.p("alpha")), None, cos_o)
                ax, ay = v.p("alpha_x"), v.p("alpha_y")
                return self._fitted(v, s, key, 0.5 * (E.log(ax) + E.log(ay)),
                                    (E.sqrt(div(ax, ay)), E.sqrt(div(ay, ax))), cos_o)
            return choose(mode, {
                "beta": lambda: self._fitted(v, s, f"microfacet/{d}/{shadowing}/beta",
                                             v.p("beta"), None, cos_o),
                "alpha": lambda: native(False), "alpha_xy": lambda: native(True)})

        def for_distribution(d):
            def for_shadowing(shadowing):
                if shadowing == "smith_correlated" and d == "trowbridge_reitz":
                    return exact("ggx")
                if shadowing == "smith_correlated" and d == "beckmann":
                    return exact("beckmann")
                return fitted(d, shadowing)
            return per_choice(sh, for_shadowing)
        return per_choice(dist, for_distribution)

    def _fresnel_lobe(self, v, s, name, weight, ax, ay):
        """One microfacet closure carrying the model's Fresnel (exact at the
        facet normal: Cycles evaluates F at the half vector)."""
        fr = v.enum("fresnel")
        return choose(fr, {
            "none": lambda: closure("microfacet", weight, s.n, s.t, ax, ay, distribution=name),
            "conductor": lambda: closure("conductor", weight, s.n, s.t, ax, ay, v.p("ior"),
                                         v.p("k"), distribution=name),
            "dielectric": lambda: self._dielectric(weight, s, ax, ay, v.p("ior"), name)
            if "dielectric" in (s.caps or ALL_CLOSURES) else
            # without dielectric_bsdf: a conductor of extinction 0 is the same Fresnel
            closure("conductor", weight, s.n, s.t, ax, ay, v.p("ior"), vec(0.0, 0.0, 0.0),
                    distribution=name)})

    @staticmethod
    def _dielectric(weight, s, ax, ay, ior, name):
        """dielectric_bsdf takes one real index: with a different index per
        channel, one closure per channel."""
        one = closure("dielectric", weight, s.n, s.t, ax, ay, ior[0], distribution=name)
        per = closure_sum(*(closure("dielectric", weight * vec(*(1.0 if j == i else 0.0
                                                                 for j in range(3))),
                                    s.n, s.t, ax, ay, ior[i], distribution=name)
                            for i in range(3)))
        same = E.ge(ior[0], ior[1]) * E.ge(ior[1], ior[0]) * E.ge(ior[1], ior[2]) \
            * E.ge(ior[2], ior[1])
        return select(same, one, per)

    def _fitted(self, v, s, key, x, aniso, cos_o):
        from . import mixtures

        ks = v.p("ks")
        fr = v.enum("fresnel")

        def member(name, w, alpha):
            if name == "diffuse":
                # the members' Fresnel is at the half vector, which a diffuse
                # lobe has not: F at L.H averaged over the lights it reflects
                c = L.mean_light_half_cosine(E.clamp(cos_o, 0.0, 1.0))
                F = choose(fr, {
                    "none": lambda: vec(1.0, 1.0, 1.0),
                    "dielectric": lambda: L.per_channel(L.F_dielectric, c, v.p("ior")),
                    "conductor": lambda: L.per_channel(L.F_conductor, c, v.p("ior"), v.p("k"))})
                return closure("diffuse", E.scaled(ks * F, w), s.n)
            ax, ay = (alpha, alpha) if aniso is None else (alpha * aniso[0], alpha * aniso[1])
            return self._fresnel_lobe(v, s, name, E.scaled(ks, w), ax, ay)
        return mixtures.mixture(key, x, cos_o, member)

    def fidelity(self, enums, caps=ALL_CLOSURES, params=None):
        """As :meth:`Formula.fidelity`; with ``params`` (the widths), a
        closure that is the model ("exact", "near") only within Cycles'
        range: it clamps alpha to 1, so a wider native width (alpha, alpha x
        or y over 1; Beckmann's m of beta over 1, from beta 63 deg) renders
        the clamped lobe: "approx".  So is a fitted mixture given in alpha
        beyond alpha 1 (its bound holds where the closures reach; the fitter
        measures the rest apart, 'beyond alpha 1')."""
        kind, key, native = self._path_traced(enums, params)
        if kind in ("exact", "near"):
            return kind
        if kind != "fit":
            return "approx"
        fresnel = enums.get("fresnel", "none")
        if params is None:
            # the width unknown (a linked socket): the variant's worst width,
            # measured for F = 1 only
            return fit_status(key) if fresnel == "none" else "approx"
        return fit_status_at(key, self._width_value(native, params), fresnel, params)

    def measured_error(self, enums, caps=ALL_CLOSURES, params=None):
        kind, key, native = self._path_traced(enums, params)
        if kind in ("exact", "near"):
            return None, CLOSURE_IS_MODEL if kind == "exact" else \
                "Cycles' Beckmann closure, its Lambda rational (under 1 % off)"
        if kind == "beyond":
            return None, "wider than Cycles' closures reach (alpha 1): not measured"
        if kind == "anisotropic":
            return None, "not measured by the fitter: its fits are for one width"
        from . import mixtures
        fresnel = enums.get("fresnel", "none")
        if params is None:
            if fresnel == "none":
                return fit_error(key), AT_WORST_WIDTH
            return None, "not measured with its width or indices linked"
        cls = mixtures.fresnel_class(fresnel, params)
        if cls is None:
            return None, "not measured at these Fresnel indices"
        bound = mixtures.interval_bound(key, self._width_value(native, params), cls)
        if bound is None:
            return None, "wider than Cycles' closures reach (alpha 1): not measured"
        return bound, AT_THIS_WIDTH

    def _path_traced(self, enums, params):
        """``(kind, key, native)``: what the BSDF output is for the variant
        ``enums`` at the widths ``params`` (None: not known): "exact" or
        "near" (a closure), "beyond" (a native width wider than Cycles'
        closures reach), "anisotropic" (widths alpha x and y) or "fit" (the
        fitted data ``key``); ``native``: the width is alpha, not beta."""
        dist, sh = enums.get("distribution"), enums.get("shadowing")
        if sh == "smith_correlated" and dist in ("trowbridge_reitz", "beckmann"):
            if params is not None and native_width_beyond_closures(dist, enums, params):
                return "beyond", None, True
            return ("exact" if dist == "trowbridge_reitz" else "near"), None, True
        if sh == "smith_1967" and dist != "beckmann":
            sh = "smith"
        mode = enums.get("width_mode", "beta")
        native = dist in ("trowbridge_reitz", "beckmann") and mode != "beta"
        key = f"microfacet/{dist}/{sh}/{'alpha' if native else 'beta'}"
        if mode == "alpha_xy":
            return "anisotropic", key, native
        if native and params is not None and native_width_beyond_closures(dist, enums, params):
            return "beyond", key, native
        return "fit", key, native

    @staticmethod
    def _width_value(native, params):
        """The width a status is looked up at: alpha (native) or beta, the
        catalogue's default where not given."""
        name = "alpha" if native else "beta"
        default = catalogue.MODELS["microfacet"].param(name).default
        return float(params.get(name, default))


class Ward(Formula):
    """Ward (1992) anisotropic: ks exp(-tan^2(h)(cos^2 phi/ax^2 + sin^2 phi/ay^2))
    / (4 pi ax ay sqrt(cos i cos o)).  Slide "Anisotropic Reflection Model"."""
    model_id = "ward"
    terms = (("Lobe", "f"), ("cos_theta_i", "f"), ("cos_theta_o", "f"))

    def uses_tangent(self, enums):
        return True

    def evaluate(self, v, s, wi):
        ax, ay = v.p("alpha_x"), v.p("alpha_y")
        li, lo = local(wi, s.t, s.b, s.n), local(s.wo, s.t, s.b, s.n)
        ci, co = li[2], lo[2]
        h = (li[0] + lo[0], li[1] + lo[1], li[2] + lo[2])
        x, y = div(h[0], ax), div(h[1], ay)
        e = div(x * x + y * y, h[2] * h[2])
        ok = _upper(ci, co)
        lobe = select(ok, div(E.exp(-e), 4.0 * PI * ax * ay * E.sqrt(ci * co)), 0.0)
        value = v.p("ks") * (lobe * ci)  # the lobe is 0 where not ok
        return {"value": value, "Lobe": lobe, "cos_theta_i": ci, "cos_theta_o": co}

    def fidelity(self, enums, caps=ALL_CLOSURES, params=None):
        """"fitted" where ``fitting/ward.py`` measured the weighted lobe
        within FIT_BOUND in the cell of widths around ``params`` (narrow
        lobes, whose lights stay near the mirror direction, where the light
        part Ward's normalisation leaves is about 1), else "approx"."""
        figure, _where = self.measured_error(enums, caps, params)
        return "fitted" if figure <= FIT_BOUND else "approx"

    def measured_error(self, enums, caps=ALL_CLOSURES, params=None):
        from . import mixtures
        if params is None:
            return mixtures.ward_figure(), AT_WORST_WIDTH
        default = catalogue.MODELS["ward"]
        return mixtures.ward_figure(params.get("alpha_x", default.param("alpha_x").default),
                                    params.get("alpha_y", default.param("alpha_y").default)), \
            AT_THIS_WIDTH

    def closure(self, v, s):
        # APPROXIMATION: ward() is declared but renders black in Cycles.  The
        # anisotropic Beckmann closure with the same (ax, ay) and a weight of
        # the view: Ward / closure = cos^4(theta_h) sqrt(ci co) / G2, which at
        # the mirror (ci = co, theta_h = 0) is co (1 + 2 Lambda(co)), Lambda
        # the closure's (Walter's rational form, Cycles').  What remains
        # depends on the light direction.
        ax, ay = E.fmin(v.p("alpha_x"), 1.0), E.fmin(v.p("alpha_y"), 1.0)
        lo = local(s.wo, s.t, s.b, s.n)
        co = fmax(lo[2], 0.0)
        weight = co * (1.0 + 2.0 * L.Lambda_beckmann_rational(*lo, ax, ay))
        return closure("microfacet", v.p("ks") * weight, s.n, s.t, ax, ay,
                       distribution="beckmann")


class KajiyaKay(Formula):
    """Slide "Kay-Kajiya Model": kd sin(theta_L) + ks max(0, sinL sinE - cosL cosE)^s;
    with L and E pointing away from the fibre the mirror cone is T.E = -T.L."""
    model_id = "kajiya_kay"
    terms = (("Diffuse", "v"), ("Specular", "v"), ("cos_theta_l", "f"), ("cos_theta_e", "f"))

    def uses_tangent(self, enums):
        return True

    def evaluate(self, v, s, wi):
        cl, ce = E.dot(s.tf, wi), E.dot(s.tf, s.wo)
        # sines as |T x w|: sqrt(1 - cos^2) in float32 errs 6e-8 / sin^2
        # relative near the fibre (1e-3 at 0.3 deg), the cross product 6e-8 / sin
        sl = E.length(E.cross(s.tf, wi))
        se = E.length(E.cross(s.tf, s.wo))
        diffuse = v.p("kd") * sl
        # cos and sin of the angle to the cone: sl se - cl ce and sl ce + cl se
        sn = sl * ce + cl * se
        specular = v.p("ks") * L.lobe_of_tangent(sl * se - cl * ce, sn * sn, v.p("exponent"))
        return {"value": diffuse + specular, "Diffuse": diffuse, "Specular": specular,
                "cos_theta_l": cl, "cos_theta_e": ce}

    status_params = ("exponent", "kd", "ks")

    def fidelity(self, enums, caps=ALL_CLOSURES, params=None):
        figure, _where = self.measured_error(enums, caps, params)
        return "fitted" if figure <= FIT_BOUND else "approx"

    def _figure(self, params, same_side=False):
        """``fitting/kajiya_kay.py``'s figure in the cell of the exponent and
        the colours' ratio in ``params`` (their defaults where absent), or
        the worst cell's where ``params`` is None."""
        from . import mixtures
        if params is None:
            return mixtures.kajiya_kay_figure(same_side=same_side)
        model = catalogue.MODELS["kajiya_kay"]
        get = {n: params.get(n, model.param(n).default) for n in self.status_params}
        return mixtures.kajiya_kay_figure(get["exponent"], get["kd"], get["ks"],
                                          same_side=same_side)

    def measured_error(self, enums, caps=ALL_CLOSURES, params=None):
        """The figure over every light (the tangent in the surface)."""
        return self._figure(params), AT_WORST_WIDTH if params is None else AT_THESE_SETTINGS

    def measured_detail(self, params=None):
        """The figure with the light on the view's side across the fibre
        (the hair closure is 0 on the other, where the model's cone lights
        the fibre up to its peak and the GGX lobe alone lights it)."""
        return (f"{self._figure(params, same_side=True):.2g} with the light on the view's "
                "side of the fibre (on the other only the GGX lobe lights the cone)")

    # The hair lobe's shape (fitting/kajiya_kay.py): its latitudinal roughness
    # this times sqrt(2 / (s + 2)) (a Cauchy lobe in the half angle is as wide
    # at half its peak as cos^s at about 0.42), the azimuthal one 1
    # (cos(phi / 2), from 1 to 0.71 over the 90 deg it reaches, where the
    # model's cone is flat).  Chosen on a grid (0.3-1.0 by 7) at s 1, 5, 20,
    # 100, 1000 and 10,000, for the smallest largest difference where the
    # closure is not 0: 0.38 at every s.
    HAIR_LATITUDE_SCALE = 0.38
    # The anisotropic GGX lobe about the same fibre, which lights the cone
    # where the hair lobe is 0 (the light across the fibre from the view):
    # its roughness along the fibre this times sqrt(2 / (s + 2)), 1 across
    # it (GGX's distribution then depends on H.T alone: its ridge is the
    # mirror cone at every azimuth).  The two lobes' peaks, over the model's
    # (HAIR_PEAK_SCALE of the hair lobe's on the view's mirror cone;
    # GGX_PEAK_SCALE of the GGX lobe's D G2 / (4 co) on it, taking
    # Lambda(wi) = 0), chosen on grids (0.6-1.12 and 0-0.6; the GGX
    # roughness 0.5, 0.7 and 1) at s 1, 5, 40, 1000 and 10,000 on every
    # third view of the measure, then with the whole measure at s 15, 40,
    # 300 and 3,000, for the smallest largest difference over every light
    # with the view's side no worse than with the hair lobe alone (1.12, 0):
    # 0.87 of the peak over every light from s = 0.8 (1.0 before); the
    # view's side lower in 143 of fits/kajiya_kay.py's 160 cells, up to
    # 0.0018 higher in 17.
    HAIR_PEAK_SCALE = 0.95
    GGX_WIDTH_SCALE = 0.7
    GGX_PEAK_SCALE = 0.25
    # The diffuse closure's kd cos theta_i against the model's kd sin theta_L
    # (no view in either): over lights to 70 deg the largest |w cos theta_i -
    # sin theta_L| is w - 1 (the light at the normal) or 1 - w cos 70 deg
    # (grazing across the fibre), equal at this w: 0.490 of the peak (0.658
    # at w = 1).  Under a uniform sky the model's term sums to pi^2 / 2 and
    # Lambert's to pi, a ratio of 1.57.
    DIFFUSE_SCALE = 2.0 / (1.0 + math.cos(math.radians(70.0)))

    def closure(self, v, s):
        # APPROXIMATION: no Kajiya-Kay closure; Lambert times DIFFUSE_SCALE
        # for the diffuse part plus Cycles' own hair_reflection lobe around
        # the same fibre, its
        # weight of the view making its peak the model's times
        # HAIR_PEAK_SCALE: the lobe, phi_pdf theta_pdf in Cycles'
        # bsdf_hair.h, peaks on the mirror cone (t = 0, phi = 0) at
        # 1 / (8 r1 r2 (a - b) cos theta_r), a - b the normalisation over the
        # latitudes from the view's theta_r (the light's cos theta_i is
        # cos theta_r there).  It is 0 where the light and the view lie on
        # opposite sides across the fibre (phi over 90 deg), where the
        # model's cone is not: an anisotropic GGX lobe about the fibre,
        # weighted by the view too, lights the cone there (and adds to the
        # hair lobe on the view's side).
        width = E.sqrt(div(2.0, v.p("exponent") + 2.0))  # the model's lobe's, in latitude
        r1 = E.clamp(self.HAIR_LATITUDE_SCALE * width, 0.001, 1.0)
        ce = E.dot(s.tf, s.wo)
        se = E.length(E.cross(s.tf, s.wo))
        theta_r = E.atan2(ce, se)
        # a - b = atan(x1) - atan(x2), x1 = (pi/2 + theta_r) / (2 r1) > 0 >
        # x2 = (theta_r - pi/2) / (2 r1), is in (0, pi): one atan2 of
        # (x1 - x2, 1 + x1 x2), both times 4 r1^2 (what Cycles folds, r1's
        # terms, is most of it)
        spread = E.atan2(2.0 * PI * r1, 4.0 * r1 * r1 - 0.25 * PI * PI + theta_r * theta_r)
        peak = 8.0 * self.HAIR_PEAK_SCALE * r1 * spread * se
        hair = closure("hair_reflection", v.p("ks") * peak, s.n, r1, 1.0, s.tf, 0.0)
        # the GGX lobe (ax along the fibre, 1 across) is D G2 / (4 co) with
        # D = 1 / (pi ax) on the cone; its weight GGX_PEAK_SCALE 4 pi ax co
        # (1 + Lambda(wo)), where co (1 + Lambda) = (co + sqrt(co^2 + ax^2
        # ce^2 + (B.wo)^2)) / 2 and co^2 + ce^2 + (B.wo)^2 = 1: no division
        ax = E.clamp(self.GGX_WIDTH_SCALE * width, 0.001, 1.0)
        co = fmax(E.dot(s.n, s.wo), 0.0)
        grazing = E.sqrt(fmax(1.0 - (1.0 - ax * ax) * ce * ce, 0.0))
        lobe = closure("microfacet", v.p("ks") * (2.0 * PI * self.GGX_PEAK_SCALE * ax)
                       * (co + grazing), s.n, s.tf, ax, 1.0, distribution="ggx")
        lobes = closure_sum(hair, lobe)
        if "glossy_toon" in (s.caps or ALL_CLOSURES):  # native nodes: EEVEE too
            # EEVEE renders the hair closure as a diffuse one of its colour,
            # where the weight of the view (about 2 at the default exponent,
            # 6.6 at s = 1) would only brighten a diffuse lobe (the GGX lobe
            # was not tried there): the plain hair lobe of ks, as before the
            # weights
            lobes = E.engine_switch(lobes, closure("hair_reflection", v.p("ks"), s.n, r1, 1.0,
                                                   s.tf, 0.0))
        return closure_sum(closure("diffuse", v.p("kd") * (PI * self.DIFFUSE_SCALE), s.n),
                           lobes)


FORMULAS = {f.model_id: f for f in (Lambert(), Phong(), BlinnPhong(), Microfacet(), Ward(),
                                    KajiyaKay())}


def path_traced_status(model_id: str, enums: dict, params=None, blender_version=(5, 2),
                       backend: str = "osl") -> str:
    """How the BSDF output matches the model: ``"exact"``, ``"near"``,
    ``"fitted"`` or ``"approx"``, for a variant (``enums``), its widths
    (``params``, where known: a width wider than Cycles' closures reach is
    approx), a Blender version and a backend (``"osl"``, or ``"native"``
    nodes)."""
    caps = ALL_CLOSURES if backend == "osl" else NATIVE_CLOSURES
    status = FORMULAS[model_id].fidelity(enums, caps, params=params)
    # 4.5's conductor closure is an older approximation; the native nodes
    # also carry a dielectric's Fresnel through it (k = 0), but for a GGX
    # lobe (the Principled BSDF's specular layer, one per channel where the
    # index differs by channel, its weight's colour a coat's tint:
    # backends/native/emit.py), which the exact closure of Trowbridge-Reitz
    # with correlated Smith is
    through_conductor = enums.get("fresnel") == "conductor" or (
        backend == "native" and enums.get("fresnel") == "dielectric"
        and (enums.get("distribution"), enums.get("shadowing"))
        != ("trowbridge_reitz", "smith_correlated"))
    if through_conductor and tuple(blender_version[:2]) < (5, 2) and \
            status in ("exact", "near", "fitted"):
        return "approx"
    return status


def path_traced_error(model_id: str, enums: dict, params=None, blender_version=(5, 2),
                      backend: str = "osl") -> tuple:
    """``(error, where)`` for the BSDF output as :func:`path_traced_status`
    takes it: the fitter's largest |output - model| over the model's peak
    (views and lights up to 70 deg) and where it holds, or ``(None, why)``
    (:meth:`Formula.measured_error`)."""
    caps = ALL_CLOSURES if backend == "osl" else NATIVE_CLOSURES
    if path_traced_status(model_id, enums, params, blender_version, backend) == "approx" \
            and FORMULAS[model_id].fidelity(enums, caps, params=params) != "approx":
        return None, "Blender 4.5's conductor closure: an older Fresnel, not measured"
    return FORMULAS[model_id].measured_error(enums, caps, params=params)


def path_traced_detail(model_id: str, enums: dict, params=None, blender_version=(5, 2),
                       backend: str = "osl"):
    """A sentence on where :func:`path_traced_error`'s figure is reached
    (:meth:`Formula.measured_detail`), or None (no figure, or nothing to
    add)."""
    if path_traced_error(model_id, enums, params, blender_version, backend)[0] is None:
        return None
    return FORMULAS[model_id].measured_detail(params)


def exact(model_id: str, v: Values, s: Shading, lights=None) -> dict:
    """The exact outputs: Color = the sum over the lights of E times the
    value, the terms for light 1.  ``lights``: a list of
    :class:`~.shading.Light`, or None for the variant's Light inputs (the
    structural ``lights`` count; where it is not known, as in the OSL
    shader, a choice between the sums)."""
    formula = FORMULAS[model_id]
    if lights is None:
        enum = v.enum("lights")
        if enum.value is not None:  # known: only its lights
            lights = shading_lights(int(enum.value))
        else:  # every light, gated by the count (OSL folds the gates and the rays)
            lights = [shading_light(k, active=choose(enum, {
                c: const(1.0 if int(c) >= k else 0.0) for c in enum.choices}))
                for k in range(1, max(int(c) for c in enum.choices) + 1)]
    color = vec(0.0, 0.0, 0.0)
    first = None
    for light in lights:
        ev = formula.evaluate(v, s, light.wi)
        color = color + light.E * ev["value"]
        if first is None:
            first = ev
    result = {"Color": color}
    result.update({name: first[name] for name, _kind in formula.terms})
    return result
