# SPDX-License-Identifier: GPL-3.0-or-later
"""The shading frame and the light of exact mode, as expression graphs.

What every model sees (:class:`Shading`): the frame (n, t, b), the view
direction wo and, per light, the direction wi and the irradiance E, with
the inputs sanitised by the catalogue's rules (a vector input that is zero
or not finite is unset; numbers are clamped to their declared limits, NaN
to the lower one).  The backends provide the geometry (``geometry("N")``,
``"I"``, ``"P"``, ``"uv_tangent"``) and the shadow ray (:func:`expr.occluded`).
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import catalogue
from . import expr as E
from .library import clamped, is_zero, unit_or_zero
from .expr import cross, dot, fmax, geometry, gt, input_, normalize, select, sqrt, vec

COMMON = {p.name: p for p in catalogue.LIGHT_INPUTS + catalogue.GEOMETRY_INPUTS}


def _vinput(name):
    return input_(name, "v")


def default_direction(v):
    """The group's UV tangent: finite, unit or zero (no UV map); not a user's
    input, so it skips :func:`unit_or_zero`'s checks."""
    return select(gt(dot(v, v), 0.0), normalize(v), vec(0.0, 0.0, 0.0))


def frame(*, uses_tangent=True, rotated=True):
    """(n, t, b): the shading normal (the Normal input when set, else the
    surface normal), the tangent projected on the surface and rotated about
    n by Tangent Rotation (``rotated``), b = n x t.  Without a tangent any
    perpendicular."""
    n_in = unit_or_zero(_vinput("shading_normal"))
    n = select(is_zero(n_in), geometry("N"), n_in)
    axis = select(E.lt(E.fabs(n[0]), 0.9), vec(1.0, 0.0, 0.0), vec(0.0, 1.0, 0.0))
    fallback = normalize(axis - n * dot(axis, n))
    if not uses_tangent:
        t = fallback
        return n, t, cross(n, t)
    tt = unit_or_zero(_vinput("tangent"))
    tt = select(is_zero(tt), default_direction(geometry("uv_tangent")), tt)
    tt = tt - n * dot(tt, n)
    tt = select(E.lt(dot(tt, tt), 1e-12), fallback, normalize(tt))
    if not rotated:
        return n, tt, cross(n, tt)
    r = clamped(COMMON["tangent_rotation"])
    turned = tt * E.cos(r) + cross(n, tt) * E.sin(r)
    t = select(gt(E.fabs(r), 0.0), turned, tt)  # a branch on a constant folds away
    return n, t, cross(n, t)


def fibre_tangent(n, t):
    """Kajiya-Kay's fibre direction: the Tangent input as given (not projected
    on a surface), else the UV tangent, else ``t`` (the frame's tangent
    before its rotation: rotated here, once); rotated about n (Rodrigues),
    keeping the fibre's tilt out of the surface."""
    tf = unit_or_zero(_vinput("tangent"))
    tf = select(is_zero(tf), default_direction(geometry("uv_tangent")), tf)
    tf = select(is_zero(tf), t, tf)
    r = clamped(COMMON["tangent_rotation"])
    c, s = E.cos(r), E.sin(r)
    rotated = tf * c + cross(n, tf) * s + n * ((1.0 - c) * dot(n, tf))
    return select(gt(E.fabs(r), 0.0), rotated, tf)


def local(w, t, b, n):
    """Components of ``w`` in the frame: (along t, along b, along n)."""
    return dot(w, t), dot(w, b), dot(w, n)


@dataclass(frozen=True)
class Light:
    """One light of exact mode at the shading point: unit direction ``wi``
    toward it and irradiance ``E`` (a colour; zero in shadow)."""
    wi: E.Expr
    E: E.Expr


def light(k: int = 1, active=None) -> Light:
    """Light ``k`` of the Light inputs (light 1: ``light_strength``, ...;
    light k > 1: ``light_strength_<k>``, ...): a sun along Light Direction,
    or a point at Light Position, or a spot (a point whose cone is Spot
    Size around the reversed Light Direction, its edge smoothed as Cycles
    does: smoothstep((cos - cos(size/2)) / ((1 - cos(size/2)) blend))), of
    strength Light Strength and colour Light Color, shadowed by a ray toward
    it unless Shadows is 0.  ``active`` (0 or 1, None: 1) switches the
    light, its shadow ray included, off."""
    suffix = "" if k == 1 else f"_{k}"

    def param(name):
        return clamped(COMMON[name], input_(name + suffix, "v" if COMMON[name].kind == "color"
                                            else "f"))
    P = geometry("P")
    strength = param("light_strength")
    point = E.ge(param("point_light"), 0.5)
    lp_in = _vinput("light_position" + suffix)
    lp_ok = E.finite(lp_in[0]) * E.finite(lp_in[1]) * E.finite(lp_in[2])
    big = 3.4028234663852886e38
    lp_safe = vec(*(E.clamp_input(lp_in[i], -big, big) for i in range(3)))
    lp = select(lp_ok, lp_safe, vec(0.0, 0.0, 5.0))
    d = lp - P
    d2 = fmax(dot(d, d), 1e-12)
    dist = sqrt(d2)
    axis = unit_or_zero(_vinput("light_direction" + suffix))
    axis = select(is_zero(axis), vec(0.0, 0.0, 1.0), axis)
    wi = select(point, d * E.div(1.0, dist), axis)
    # the spot's cone (Cycles' spot_light_attenuation for an unscaled lamp)
    cos_half = E.cos(0.5 * param("spot_size"))
    width = (1.0 - cos_half) * param("spot_blend")
    x = dot(wi, axis)
    f = select(gt(width, 0.0), E.clamp((x - cos_half) * E.div(1.0, width), 0.0, 1.0),
               gt(x, cos_half))
    cone = f * f * (3.0 - 2.0 * f)
    spot = point * E.ge(param("spot"), 0.5)
    strength = select(point, E.div(strength, d2) * select(spot, cone, 1.0), strength)
    maxdist = select(point, dist, 1e30)
    shadows = param("shadows")
    enabled = gt(shadows, 0.0) if active is None else gt(shadows, 0.0) * active
    visible = 1.0 - shadows * E.occluded(P, wi, maxdist, enabled)
    if active is not None:
        strength = strength * active
    return Light(wi, param("light_color") * (strength * visible))


def lights(count: int) -> list:
    """Lights 1 to ``count``."""
    return [light(k) for k in range(1, count + 1)]
