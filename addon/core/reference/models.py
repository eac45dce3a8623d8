# SPDX-License-Identifier: GPL-3.0-or-later
"""The reflection models of the lecture as numpy functions: ``shade`` and
``brdf`` (the public API, see the package docstring), one function per model.

Each formula cites its slide; errata are fixed in one line next to the
formula.  The microfacet model composes a distribution type
(:mod:`.distributions`) with a shadowing term and a Fresnel factor.
"""

from __future__ import annotations

import math

import numpy as np

from .distributions import PI, distribution
from .fresnel import F_conductor, F_dielectric
from .shadowing import G_vgroove, S_smith_1967
from ..validation import validate

DEFAULT_NORMAL = (0.0, 0.0, 1.0)
DEFAULT_TANGENT = (1.0, 0.0, 0.0)


def _vec(v, name):
    try:
        arr = np.asarray(v, dtype=float)
    except (TypeError, ValueError):  # a string, a ragged list, complex numbers
        arr = np.zeros(0)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        given = repr(v) if arr.size <= 3 else f"an array of shape {arr.shape}"
        given = given if len(given) <= 80 else given[:77] + "..."  # a long ragged list
        raise ValueError(f"{name} must be a 3-vector or an array of shape (..., 3), not {given}")
    return arr


def _dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _cross_length(a, b):
    """|a x b|."""
    x = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    y = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    z = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return np.sqrt(x * x + y * y + z * z)


def _unit(v):
    """``v`` scaled to unit length; a zero vector, or one with a NaN or
    infinite component, becomes zero (it has no direction: the result is
    0, as the shaders give)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.sqrt(_dot(v, v))
    ok = (inv > 0.0) & (inv < np.inf)  # NaN compares false
    if np.all(ok):
        return v * inv[..., None]
    return np.where(ok[..., None], v, 0.0) * np.where(ok, inv, 0.0)[..., None]


def _frame(normal, tangent):
    """Rows (t, b, n): the tangent projected on the surface, n x t, the normal.

    A tangent along the normal (or zero) falls back to the x axis projected on
    the surface, or the y axis when the normal is near x: the same choice as
    ``rm_begin`` in ``osl/rm_common.h``.
    """
    n = _vec(normal, "normal")
    t = _vec(tangent, "tangent")
    with np.errstate(invalid="ignore"):  # an infinite tangent: NaN, then the fallback
        t = t - _dot(t, n)[..., None] * n
        length = np.sqrt(_dot(t, t))
    bad = ~(length >= 1e-6)  # short, or NaN (a NaN or infinite tangent)
    if np.any(bad):
        axis = np.where((np.abs(n[..., 0]) < 0.9)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        fallback = axis - _dot(axis, n)[..., None] * n
        t = np.where(bad[..., None], fallback, t)
        length = np.sqrt(_dot(t, t))
    t = t / length[..., None]
    b = np.cross(n, t)
    return np.stack(np.broadcast_arrays(t, b, n), axis=-2)


def _local(wi, wo, normal, tangent):
    """Both directions in the local frame, as component tuples (x, y, z)."""
    wi = _vec(wi, "wi")
    wo = _vec(wo, "wo")
    if (np.shape(normal) == (3,) and tuple(normal) == DEFAULT_NORMAL
            and np.shape(tangent) == (3,) and tuple(tangent) == DEFAULT_TANGENT):
        li, lo = wi, wo
    else:
        frame = _frame(normal, tangent)
        if frame.ndim == 2:
            li, lo = wi @ frame.T, wo @ frame.T
        else:
            li = np.einsum("...ij,...j->...i", frame, wi)
            lo = np.einsum("...ij,...j->...i", frame, wo)
    return (li[..., 0], li[..., 1], li[..., 2]), (lo[..., 0], lo[..., 1], lo[..., 2])


# --------------------------------------------------------------------------
# Models.  Each returns (scalar field, colour) pairs summed by _evaluate, or an
# RGB array.  ``v`` is the checked parameter dictionary.
# --------------------------------------------------------------------------

def _upper(ci, co):
    return (ci > 0.0) & (co > 0.0)


def _lobe(x, s):
    """max(0, x)^s with 0^0 = 0 below the cut-off."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(x > 0.0, np.power(np.maximum(x, 1e-300), s), 0.0)


def brdf_lambert(li, lo, wdot, v):
    return np.where(_upper(li[2], lo[2]), 1.0 / PI, 0.0)[..., None] * v["albedo"]


def brdf_phong(li, lo, wdot, v):
    """Slide "Phong Model": ks (E.R(L))^s with E.R(L) = 2(N.L)(N.E) - L.E;
    'energy' multiplies by (s+1)/(2 pi) (slide "Energy normalization")."""
    s = v["exponent"]
    cos_s = 2.0 * li[2] * lo[2] - wdot
    f = _lobe(cos_s, s)
    if v["normalization"] == "energy":
        f = f * ((s + 1.0) / (2.0 * PI))
    return np.where(_upper(li[2], lo[2]), f, 0.0)[..., None] * v["ks"]


def brdf_blinn_phong(li, lo, wdot, v):
    """ks (N.H)^s, N.H = (N.L + N.E)/|L + E|; 'energy': times (s+8)/(8 pi),
    the usual approximate normalisation (not a bound)."""
    s = v["exponent"]
    # |L + E| from the summed components, not sqrt(2 + 2 L.E): near grazing
    # with L and E almost opposite, 2 + 2 L.E cancels to 0 and N.H overflowed
    hx, hy, hz = li[0] + lo[0], li[1] + lo[1], li[2] + lo[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        ch = hz / np.sqrt(hx * hx + hy * hy + hz * hz)
    f = _lobe(np.minimum(ch, 1.0), s)
    if v["normalization"] == "energy":
        f = f * ((s + 8.0) / (8.0 * PI))
    return np.where(_upper(li[2], lo[2]), f, 0.0)[..., None] * v["ks"]


def microfacet_distribution(v):
    """The :class:`~.distributions.Distribution` of checked microfacet
    parameters ``v``, with the width they were given."""
    how = v["_width"]
    if how == "alpha":
        return distribution(v["distribution"], alpha=v["alpha"])
    if how == "alpha_x":
        return distribution(v["distribution"], alpha_x=v["alpha_x"], alpha_y=v["alpha_y"])
    return distribution(v["distribution"], beta=v["beta"])


def brdf_microfacet(li, lo, wdot, v):
    """Slide "Torrance-Sparrow Model": f = ks F(L.H) G D(H) / (4 (N.L)(N.E))."""
    ci, co = li[2], lo[2]
    hx, hy, hz = li[0] + lo[0], li[1] + lo[1], li[2] + lo[2]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        length = np.sqrt(hx * hx + hy * hy + hz * hz)
        hx, hy, hz = hx / length, hy / length, hz / length
        # L.H = |L + E| / 2 for unit L and E: the dot product itself came out
        # negative by rounding with L and E almost opposite near grazing
        cih = 0.5 * length
        dist = microfacet_distribution(v)
        D = dist.D(hx, hy, hz)
        sh = v["shadowing"]
        if sh == "none":
            G = 1.0
        elif sh in ("smith", "smith_correlated"):
            G = dist.G(li, lo, correlated=sh == "smith_correlated")
        elif sh == "vgroove":
            G = G_vgroove(ci, co, hz, cih)
        else:  # smith_1967 (Beckmann only, checked)
            ax, ay = dist.alpha_x, dist.alpha_y
            G = S_smith_1967(*li, ax, ay) * S_smith_1967(*lo, ax, ay)
        f = G * D / (4.0 * ci * co)
        f = np.where(_upper(ci, co) & (hz > 0.0), f, 0.0)[..., None]
        fr = v["fresnel"]
        if fr == "dielectric":
            f = f * F_dielectric(np.clip(cih, 0.0, 1.0)[..., None], v["ior"])
        elif fr == "conductor":
            f = f * F_conductor(np.clip(cih, 0.0, 1.0)[..., None], v["ior"], v["k"])
    return np.nan_to_num(f * v["ks"], nan=0.0, posinf=0.0)


def brdf_ward(li, lo, wdot, v):
    """Ward 1992, eq. 5: ks exp(-tan^2(h) (cos^2 phi/ax^2 + sin^2 phi/ay^2)) /
    (4 pi ax ay sqrt(cos i cos o))."""
    ci, co = li[2], lo[2]
    ax, ay = v["alpha_x"], v["alpha_y"]
    hx, hy, hz = li[0] + lo[0], li[1] + lo[1], li[2] + lo[2]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # each ratio before squaring, each root apart: hz * hz and ci * co
        # underflowed to 0 at grazing (NaN for a finite value)
        e = (hx / hz / ax) ** 2 + (hy / hz / ay) ** 2
        f = np.exp(-e) / (4.0 * PI * ax * ay * np.sqrt(ci) * np.sqrt(co))
    f = np.where(_upper(ci, co), f, 0.0)
    return f[..., None] * v["ks"]


_BRDFS = {
    "lambert": brdf_lambert,
    "phong": brdf_phong,
    "blinn_phong": brdf_blinn_phong,
    "microfacet": brdf_microfacet,
    "ward": brdf_ward,
}


def shade_kajiya_kay(wi, wo, tangent, v, normal=DEFAULT_NORMAL):
    """Slide "Kay-Kajiya Model": kd sin(theta_L) + ks cos^s(angle to the mirror cone).

    With both directions pointing away from the fibre the cone is T.E = -T.L,
    so the specular term is max(0, sinL sinE - cosL cosE)^s (lecture notes).
    """
    t = _unit(_vec(tangent, "tangent"))
    none = _dot(t, t) == 0.0
    if np.any(none):  # no direction given: the frame's tangent, as the shaders
        t = np.where(none[..., None], _frame(normal, np.zeros(3))[..., 0, :], t)
    wi, wo = _vec(wi, "wi"), _vec(wo, "wo")
    cl, ce = _dot(t, wi), _dot(t, wo)
    # the sines as |T x w|: sqrt(1 - cos^2) loses them near the fibre (10^-16 / sin^2)
    sl, se = _cross_length(t, wi), _cross_length(t, wo)
    spec = _lobe(sl * se - cl * ce, v["exponent"])
    out = sl[..., None] * v["kd"] + spec[..., None] * v["ks"]
    # a zero direction (given as zero, NaN or infinite: _unit) lights nothing
    seen = (_dot(wi, wi) > 0.0) & (_dot(wo, wo) > 0.0)
    return out if np.all(seen) else out * seen[..., None]


CHUNK = 1 << 15  # elements per slice: the temporaries stay in the CPU cache


def _kernel(model, v, wi, wo, normal, tangent, with_cosine):
    # unit directions, per chunk (the temporaries stay in the CPU cache)
    wi, wo, normal = _unit(wi), _unit(wo), _unit(normal)
    if model.kind == "fibre":
        return shade_kajiya_kay(wi, wo, tangent, v, normal)
    li, lo = _local(wi, wo, normal, tangent)
    wdot = _dot(wi, wo) if model.id == "phong" else None
    out = _BRDFS[model.id](li, lo, wdot, v)
    if with_cosine:
        out = out * np.maximum(li[2], 0.0)[..., None]
    return out


def _evaluate(model_name, wi, wo, normal, tangent, params, with_cosine):
    model, v, _given = validate(model_name, params)
    if model.kind == "fibre" and not with_cosine:
        raise ValueError(f"{model_name!r} is a fibre model with no BRDF on a surface; "
                         "use shade(), which gives its reflected radiance")
    wi, wo = _vec(wi, "wi"), _vec(wo, "wo")
    normal, tangent = _vec(normal, "normal"), _vec(tangent, "tangent")
    arrays = {k: a for k, a in v.items() if isinstance(a, np.ndarray)}
    # Leading (broadcast) shape: vectors and colours carry a trailing axis.
    leads = [wi.shape[:-1], wo.shape[:-1], normal.shape[:-1], tangent.shape[:-1]]
    for k, a in arrays.items():
        leads.append(a.shape[:-1] if model.param(k).kind == "color" else a.shape)
    shape = np.broadcast_shapes(*leads)
    size = math.prod(shape)
    if size <= CHUNK:
        out = _kernel(model, v, wi, wo, normal, tangent, with_cosine)
        return np.broadcast_to(out, shape + (3,)).astype(float, copy=False)

    def flat(a, colour=True):
        trail = a.shape[-1:] if colour else ()
        lead = a.shape[:-1] if colour else a.shape
        if lead == ():
            return a, False
        return np.broadcast_to(a, shape + trail).reshape((size,) + trail), True

    flat_vecs = [flat(x) for x in (wi, wo, normal, tangent)]
    flat_params = {k: flat(a, model.param(k).kind == "color") for k, a in arrays.items()}
    out = np.empty((size, 3))
    for start in range(0, size, CHUNK):
        sl = slice(start, start + CHUNK)
        vecs = [x[sl] if per else x for x, per in flat_vecs]
        vc = dict(v)
        for k, (a, per) in flat_params.items():
            vc[k] = a[sl] if per else a
        out[sl] = _kernel(model, vc, *vecs, with_cosine)
    return out.reshape(shape + (3,))


def shade(model, wi, wo, *, normal=DEFAULT_NORMAL, tangent=DEFAULT_TANGENT, **params):
    """Radiance toward ``wo`` under a unit-irradiance directional light from ``wi``.

    Surface models: ``brdf(...) * max(0, normal . wi)``.  Fibre models
    (``kajiya_kay``): the lecture's ``kd sin(theta_L) + ks (cone term)^s`` with
    ``tangent`` the fibre direction; the normal is not used.
    Returns an array of shape ``(..., 3)``.  Raises ``ValueError`` for unknown
    models or parameters and out-of-range values, naming what is allowed.
    """
    return _evaluate(model, wi, wo, normal, tangent, params, with_cosine=True)


def brdf(model, wi, wo, *, normal=DEFAULT_NORMAL, tangent=DEFAULT_TANGENT, **params):
    """The BRDF f_r (1/sr) of a surface model, shape ``(..., 3)``.

    Zero unless both directions are above the surface.  Fibre models have no
    surface BRDF and raise ``ValueError``.
    """
    return _evaluate(model, wi, wo, normal, tangent, params, with_cosine=False)
