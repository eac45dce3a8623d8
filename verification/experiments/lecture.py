# SPDX-License-Identifier: GPL-3.0-or-later
"""The lecture's experiments, computed: pure numpy, no Blender, no drawing.

Each function reproduces one figure or claim of the lecture from
:mod:`addon.reference` and returns its numbers (curves as arrays, the
quantities a check judges).  Judging is :mod:`verification.suites.lecture`;
drawing is :mod:`report.lecture`.  ``fast=True`` lowers quadrature sizes for
the test suite.

Conventions (``shared/LECTURE-NOTES.md``): directions point away from the
surface, ``wi`` toward the light, ``wo`` toward the eye, N = +z.  "In the plane
of incidence" means the x-z plane, the light on the -x side and a signed
reflection angle ``theta_r`` positive on the mirror (+x) side.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from addon import catalogue
from addon import reference as R

DEG = math.pi / 180.0


def in_plane(theta):
    """Unit directions in the x-z plane at signed angle ``theta`` from +z (toward +x)."""
    theta = np.asarray(theta, float)
    return np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)


def light(theta_i):
    """Direction toward a light at incidence ``theta_i`` on the -x side."""
    return in_plane(-theta_i)


# --------------------------------------------------------------------------
# 1. Phong: from mirror to diffuse (slides "Phong Model", "Reciprocity")
# --------------------------------------------------------------------------

PHONG_EXPONENTS = (1, 5, 20, 100, 1000)
PHONG_THETA_I = 30.0 * DEG


def phong_lobes(fast=False):
    """The lobe (E.R(L))^s in the plane of incidence for each exponent, its
    half-maximum half-width against acos(2^(-1/s)), and reciprocity on
    random direction pairs."""
    wi = light(PHONG_THETA_I)
    step = 0.002 if not fast else 0.01
    tr = np.arange(-90.0, 90.0 + step / 2, step) * DEG
    wo = in_plane(tr)
    curves, widths, expected = {}, [], []
    for s in PHONG_EXPONENTS:
        f = R.brdf("phong", wi, wo, exponent=float(s))[:, 0]
        curves[s] = f
        # half-maximum angle on the normal's side of the mirror direction
        k0 = int(np.argmax(f))
        below = np.nonzero(f[:k0] < 0.5 * f[k0])[0]
        k = below[-1]  # f[k] < half <= f[k+1]: linear interpolation
        t = (0.5 * f[k0] - f[k]) / (f[k + 1] - f[k])
        half = tr[k] + t * (tr[k + 1] - tr[k])
        widths.append(float((tr[k0] - half) / DEG))
        expected.append(math.acos(2.0 ** (-1.0 / s)) / DEG)

    rng = np.random.default_rng(11)
    v = rng.normal(size=(2, 4000, 3))
    v[..., 2] = np.abs(v[..., 2])
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    L, E = v
    N = np.array([0.0, 0.0, 1.0])

    def refl(w):
        return 2.0 * (w @ N)[:, None] * N - w

    recip = 0.0
    for s in PHONG_EXPONENTS:
        a = np.maximum(np.sum(E * refl(L), -1), 0.0) ** s
        b = np.maximum(np.sum(L * refl(E), -1), 0.0) ** s
        fa = R.brdf("phong", L, E, exponent=float(s))[:, 0]
        fb = R.brdf("phong", E, L, exponent=float(s))[:, 0]
        recip = max(recip, float(np.max(np.abs(a - b))), float(np.max(np.abs(fa - fb))),
                    float(np.max(np.abs(fa - a))))
    return {"theta_r": tr, "curves": curves, "step_deg": step, "half_widths_deg": widths,
            "expected_deg": expected,
            "width_error_deg": max(abs(a - b) for a, b in zip(widths, expected)),
            "reciprocity_error": recip}


# --------------------------------------------------------------------------
# 2. Energy normalisation (slide "Energy normalization")
# --------------------------------------------------------------------------

ALBEDO_EXPONENTS = (0.5, 1, 2, 5, 10, 20, 50, 100, 200, 500, 1000)
ALBEDO_VIEWS_DEG = (0, 30, 60, 80)


def phong_albedo(s, theta_o, normalization, n=256):
    """Directional albedo rho(theta_o) = int f cos(theta_i) dw_i of Phong, by quadrature.

    Lobe coordinates around R(E): u the angle to R(E), phi its azimuth.  With
    v = cos(u)^(s+1), dw = dv dphi / ((s+1) cos(u)^s), so the lobe is sampled
    evenly however narrow it is (midpoint rule, n x n nodes).
    """
    wo = in_plane(theta_o)
    rE = np.array([-math.sin(theta_o), 0.0, math.cos(theta_o)])
    t1 = np.array([math.cos(theta_o), 0.0, math.sin(theta_o)])
    t2 = np.array([0.0, 1.0, 0.0])
    v = (np.arange(n) + 0.5) / n
    phi = (np.arange(n) + 0.5) / n * 2.0 * math.pi
    cu = v ** (1.0 / (s + 1.0))
    su = np.sqrt(np.maximum(1.0 - cu * cu, 0.0))
    wi = (cu[:, None, None] * rE + su[:, None, None] * (np.cos(phi)[None, :, None] * t1
                                                        + np.sin(phi)[None, :, None] * t2))
    weight = (1.0 / n) * (2.0 * math.pi / n) / ((s + 1.0) * cu ** s)
    f = R.shade("phong", wi, wo, exponent=float(s), normalization=normalization)[..., 0]
    return float(np.sum(f * weight[:, None]))


def energy(fast=False):
    """Phong's directional albedo over exponents and view angles, normalised
    and not, against the slide's bound 2 pi/(s+1)."""
    n = 96 if fast else 256
    exps = ALBEDO_EXPONENTS
    rho = {(nm, t): np.array([phong_albedo(s, t * DEG, nm, n) for s in exps])
           for nm in ("none", "energy") for t in ALBEDO_VIEWS_DEG}
    return {
        "exponents": np.array(exps, dtype=float), "views_deg": ALBEDO_VIEWS_DEG, "rho": rho,
        "nodes": n,
        "normalised_max": max(float(v.max()) for (nm, _), v in rho.items() if nm == "energy"),
        "bound_ratio_max": max(float(np.max(rho[("none", t)] * (np.array(exps) + 1)
                                            / (2 * math.pi))) for t in ALBEDO_VIEWS_DEG),
        "limit_error": max(abs(rho[("energy", t)][-1] - math.cos(t * DEG))
                           for t in ALBEDO_VIEWS_DEG),
    }


# --------------------------------------------------------------------------
# 3. The four distributions at equal beta (slide "Microfacet Distribution Functions")
# --------------------------------------------------------------------------

DISTRIBUTION_BETA = 15.0 * DEG


def D_ratio(distribution, alpha, beta):
    """D(alpha)/D(0) of a reference distribution at half-angle ``beta``."""
    alpha = np.asarray(alpha, float)
    d = R.distribution(distribution, beta=beta)
    h = (np.sin(alpha), np.zeros_like(alpha), np.cos(alpha))
    return d.D(*h) / d.D(0.0, 0.0, 1.0)


def distributions():
    beta = DISTRIBUTION_BETA
    a = np.linspace(0.0, 60.0, 601) * DEG
    ratios = {d: D_ratio(d, a, beta) for d in catalogue.DISTRIBUTIONS}
    at_beta = {d: float(D_ratio(d, beta, beta)) for d in catalogue.DISTRIBUTIONS}
    at_3beta = {d: float(D_ratio(d, 3 * beta, beta)) for d in catalogue.DISTRIBUTIONS}
    return {"alpha": a, "beta": beta, "ratios": ratios, "at_beta": at_beta,
            "at_3beta": at_3beta, "tail_order": sorted(at_3beta, key=at_3beta.get, reverse=True),
            "half_error": max(abs(v - 0.5) for v in at_beta.values())}


# --------------------------------------------------------------------------
# 4. Smith shadowing and the self-consistency condition
# --------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _leggauss(n):
    return np.polynomial.legendre.leggauss(n)  # an n x n eigenproblem: cache it


def _gl(n, a, b):
    x, w = _leggauss(n)
    return a + (b - a) * 0.5 * (x + 1.0), 0.5 * (b - a) * w


def projected_facet_area(theta, D_of_alpha, cut, n=200):
    """int max(0, w.h) D(h) dw_h over facet normals, for w at angle ``theta``.

    The azimuth is integrated in closed form: with A = sin theta sin alpha and
    B = cos theta cos alpha, int_0^2pi max(0, A cos phi + B) dphi is 2 pi B for
    B >= A and 2 (B acos(-B/A) + sqrt(A^2 - B^2)) otherwise.  The tilt
    integral is Gauss-Legendre, split where B = A (alpha = pi/2 - theta).
    Kept independent of the reference's own Lambda quadrature on purpose.
    """
    a0 = 0.5 * math.pi - theta
    pieces = [(0.0, min(a0, cut))] + ([(a0, cut)] if a0 < cut else [])
    total = 0.0
    for lo, hi in pieces:
        if hi <= lo:
            continue
        al, w = _gl(n, lo, hi)
        A = math.sin(theta) * np.sin(al)
        B = math.cos(theta) * np.cos(al)
        with np.errstate(divide="ignore", invalid="ignore"):
            part = 2.0 * (B * np.arccos(np.clip(-B / np.where(A > 0, A, 1.0), -1.0, 1.0))
                          + np.sqrt(np.maximum(A * A - B * B, 0.0)))
        inner = np.where(B >= A, 2.0 * math.pi * B, part)
        total += float(np.sum(w * D_of_alpha(al) * np.sin(al) * inner))
    return total


def distribution_case(distribution, width):
    """(D(alpha), Lambda(theta), tilt cut-off) of a self-consistency case:
    ``width`` is beta for Blinn and Gaussian, the native alpha otherwise."""
    if distribution in ("blinn", "gaussian"):
        d = R.distribution(distribution, beta=width)
    else:
        d = R.distribution(distribution, alpha=width)
    cut = math.atan(width * math.sqrt(-math.log(1e-18))) if distribution == "beckmann" \
        else 0.5 * math.pi
    return ((lambda al: d.D(np.sin(al), 0.0, np.cos(al))),
            (lambda th: float(d.Lambda(math.sin(th), 0.0, math.cos(th)))), cut)


SC_THETAS_DEG = (0, 30, 60, 75, 85, 89)
SMITH_MS = (0.1, 0.3, 0.6, 1.0)
SC_CASES = (
    ("Beckmann m=0.3, Smith", "beckmann", 0.3, "smith"),
    ("Beckmann m=0.6, Smith", "beckmann", 0.6, "smith"),
    ("Trowbridge-Reitz a=0.3, Smith", "trowbridge_reitz", 0.3, "smith"),
    ("Gaussian beta=15, Smith (series)", "gaussian", 15.0 * DEG, "smith"),
    ("Blinn beta=15, Smith (series)", "blinn", 15.0 * DEG, "smith"),
    ("Beckmann m=0.3, 1967 bracket", "beckmann", 0.3, "1967"),
    ("Beckmann m=0.6, 1967 bracket", "beckmann", 0.6, "1967"),
)


def smith(fast=False):
    """S(theta) of Beckmann surfaces (Smith and the slide's 1967 form) and
    the self-consistency ratio int G1 max(0, w.m) D dm / cos(theta) per case."""
    n = 120 if fast else 300
    th = np.linspace(0, 89.9, 400) * DEG
    w = (np.sin(th), np.zeros_like(th), np.cos(th))
    S = {m: (1.0 / (1.0 + R.Lambda_beckmann(*w, m, m)), R.S_smith_1967(*w, m, m))
         for m in SMITH_MS}
    table, smith_err, dev1967 = [], 0.0, 0.0
    for label, dist, width, kind in SC_CASES:
        D, Lam, cut = distribution_case(dist, width)
        ratios = []
        for t in SC_THETAS_DEG:
            theta = t * DEG
            area = projected_facet_area(theta, D, cut, n)
            if kind == "smith":
                G1 = 1.0 / (1.0 + Lam(theta))
            else:
                G1 = float(R.S_smith_1967(math.sin(theta), 0.0, math.cos(theta), width, width))
            ratio = G1 * area / math.cos(theta)
            ratios.append(ratio)
            if kind == "smith":
                smith_err = max(smith_err, abs(ratio - 1.0))
            else:
                dev1967 = max(dev1967, abs(ratio - 1.0))
        table.append((label, ratios))
    return {"theta": th, "S": S, "table": table, "thetas_deg": SC_THETAS_DEG, "nodes": n,
            "smith_error": smith_err, "bracket_deviation": dev1967}


# --------------------------------------------------------------------------
# 5. Torrance-Sparrow experiments (slide "Torrance-Sparrow Experiments")
# --------------------------------------------------------------------------

# Fig. 9 of Torrance & Sparrow (1967): P(alpha) ~ exp(-c^2 alpha^2), c = 0.05 per
# degree, so D falls to half at beta = sqrt(ln 2)/c = 16.65 deg; lambda = 0.5 um.
TS_BETA = math.sqrt(math.log(2.0)) / 0.05 * DEG
TS_MATERIALS = {
    "aluminium": dict(fresnel="conductor", ior=catalogue.METALS["aluminium"][0][1],
                      k=catalogue.METALS["aluminium"][1][1]),
    "magnesium oxide": dict(fresnel="dielectric", ior=1.74),
}
TS_INCIDENCES_DEG = (10, 20, 30, 40, 50, 60, 70, 75, 80)


def torrance_sparrow_brdf(material, theta_i, theta_r):
    """f_r of the preset for a material, in the plane of incidence (green channel)."""
    return R.brdf("torrance_sparrow", light(theta_i), in_plane(theta_r), beta=TS_BETA,
                  **TS_MATERIALS[material])[..., 1]


def torrance_sparrow_peaks(material, theta_i_deg, step_deg=0.01):
    """Peak positions (deg) of f_r and of f_r cos(theta_r) in the plane of incidence."""
    tr = np.linspace(0.0, 89.99, int(round(89.99 / step_deg)) + 1) * DEG
    f = torrance_sparrow_brdf(material, theta_i_deg * DEG, tr)
    return float(tr[np.argmax(f)] / DEG), float(tr[np.argmax(f * np.cos(tr))] / DEG)


def torrance_sparrow(fast=False):
    """f_r cos(theta_r) curves for every incidence and material, scaled to
    the value at the mirror, and the peak positions."""
    step = 0.05 if fast else 0.01
    tr = np.arange(-89.9, 89.95, 0.1) * DEG
    curves, peaks = {}, {}
    for name in TS_MATERIALS:
        for ti in TS_INCIDENCES_DEG:
            y = torrance_sparrow_brdf(name, ti * DEG, tr) * np.cos(tr)
            ymir = float(torrance_sparrow_brdf(name, ti * DEG, ti * DEG) * math.cos(ti * DEG))
            curves[(name, ti)] = y / ymir
            peaks[(name, ti)] = torrance_sparrow_peaks(name, ti, step)
    return {"theta_r": tr, "curves": curves, "peaks_deg": peaks, "step_deg": step,
            "beta": TS_BETA}


def torrance_sparrow_expected(theta_r, theta_i):
    """f_r cos(theta_r) of each material at the given angles (radians)."""
    return {name: torrance_sparrow_brdf(name, theta_i, theta_r) * np.cos(theta_r)
            for name in TS_MATERIALS}


# --------------------------------------------------------------------------
# 6. V-groove vs Smith shadowing
# --------------------------------------------------------------------------

VG_M = 0.3


def vgroove_smith_curves(theta_i, theta_o):
    """G of the V-groove model and separable Smith (Beckmann m = VG_M), in the plane."""
    L = light(theta_i)
    E = in_plane(theta_o)
    H = L + E
    H /= np.linalg.norm(H, axis=-1, keepdims=True)
    G_v = R.G_vgroove(L[..., 2], E[..., 2], H[..., 2], np.sum(L * H, -1))
    d = R.Beckmann(VG_M)
    G_s = d.G((L[..., 0], L[..., 1], L[..., 2]), (E[..., 0], E[..., 1], E[..., 2]))
    return G_v, G_s


def vgroove_smith():
    to = np.linspace(-89.5, 89.5, 359) * DEG
    curves = {ti: vgroove_smith_curves(ti * DEG, to) for ti in (30, 70)}
    G_v, G_s = curves[30]
    near = float(np.max(np.abs(G_v - G_s)[np.abs(to) <= 30 * DEG]))
    far = float(np.max(np.abs(G_v - G_s)[to >= 80 * DEG]))
    return {"theta_o": to, "curves": curves, "m": VG_M, "near_difference": near,
            "grazing_difference": far}


# --------------------------------------------------------------------------
# 7. The sun's glitter path on a rough sea (Minnaert; slides "Reflection of
#    the Sun from the Sea", "Reflection Angles")
# --------------------------------------------------------------------------
#
# Geometry.  A facet reflects the sun (direction L, elevation e) toward the eye
# when its normal is H = normalize(L + E), E the direction from the sea point
# to the eye.  Its tilt is alpha = angle(H, z).
# - Along the vertical through the sun's image (the slide's gamma = 2 alpha):
#   a sea point seen at depression delta has E at elevation delta on the eye's
#   side and L at elevation e on the other, so H leans by (delta - e)/2 and
#   gamma = delta - e = 2 alpha.  With tilts up to alpha_max the path runs
#   from depression e - 2 alpha_max to e + 2 alpha_max.
# - Across (the slide's tan psi = tan alpha cos theta): the slide's light sits
#   at the eye's height h at a finite distance, so a point b off the axis
#   shifts both L and E sideways by b/r.  The sun is at infinity: only E
#   shifts, and on the row of the sun's image (E.y = L.y) the sideways lean
#   gives tan alpha = sin psi / (cos theta + sqrt(cos^2 theta - sin^2 psi)),
#   theta = 90 deg - e the incidence there; solved for psi:
#       sin psi = sin(2 alpha) cos theta      (~ 2 tan alpha cos theta),
#   twice the slide's value, which is the same construction with the light
#   sharing the sideways offset.  The path is long and narrow: its
#   length-to-width ratio is about 1/cos theta = 1/sin e.
# - alpha_max: the tilt at which the Beckmann D falls to half its peak, i.e.
#   beta by construction; the render is thresholded at half its peak.

GLITTER = dict(sun_elevation_deg=15.0, beta_deg=5.0, eye_height=2.0, vfov_deg=28.0)


def glitter_geometry(sun_elevation, alpha_max):
    """Minnaert's predicted extent of the glitter path, in radians.

    Returns (near, far, half_width): depressions of the path's ends below the
    horizon (near = e + 2 alpha_max, far = e - 2 alpha_max, clipped at the
    horizon) and the angular half-width psi on the sun image's row.
    """
    e = sun_elevation
    return (e + 2 * alpha_max, max(e - 2 * alpha_max, 0.0),
            math.asin(math.sin(2 * alpha_max) * math.sin(e)))


def glitter_boundary(sun_elevation, alpha_max, n=3600):
    """The exact outline of the set {tilt <= alpha_max} in view angles: for facet
    normals on the cone of tilt alpha_max, the reflected sun directions, as
    (depression in the vertical plane, lateral angle psi) arrays (radians)."""
    L = np.array([0.0, math.cos(sun_elevation), math.sin(sun_elevation)])
    phi = np.linspace(0, 2 * math.pi, n, endpoint=False)
    Hn = np.stack([math.sin(alpha_max) * np.cos(phi), math.sin(alpha_max) * np.sin(phi),
                   np.full_like(phi, math.cos(alpha_max))], -1)
    E = 2.0 * (Hn @ L)[:, None] * Hn - L  # toward the eye, from the sea point
    d = -E  # view ray from the eye toward the sea
    return np.arctan2(-d[:, 2], d[:, 1]), np.arcsin(d[:, 0])


def exact_dep_at_widest(dep, lat):
    """Depression (radians) at which the outline from :func:`glitter_boundary` is widest."""
    return float(dep[int(np.argmax(np.abs(lat)))])


def camera_rays(res, vfov, depression):
    """Unit view rays (H, W, 3) of a perspective camera at the origin looking
    along +y tilted down by ``depression``; sensor fit horizontal, pixel
    centres; also the camera's (right, up, back) basis and its lens (mm)."""
    W, Hh = res
    sensor = 36.0
    half_h = math.tan(0.5 * vfov)  # vertical half-extent at unit focal length
    lens = sensor * Hh / W / (2.0 * half_h)  # mm: vertical extent = sensor * H/W
    look = np.array([0.0, math.cos(depression), -math.sin(depression)])
    back = -look
    right = np.array([1.0, 0.0, 0.0])
    up = np.cross(back, right)
    i = np.arange(W) + 0.5 - W / 2
    j = Hh / 2 - (np.arange(Hh) + 0.5)
    px = sensor / W
    x = i[None, :] * px
    y = j[:, None] * px
    d = x[..., None] * right + y[..., None] * up - lens * back
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return d, np.stack([right, up, back], axis=1), lens


def path_extent(mask, rays):
    """(near, far, half_width) in radians of a bright-pixel mask, from its rays:
    the largest and smallest depression (in the vertical plane) and the largest
    |lateral angle|; pixel rays are centres, so extents are +-half a pixel."""
    d = rays[mask]
    dep = np.arctan2(-d[:, 2], d[:, 1])
    lat = np.arcsin(np.abs(d[:, 0]))
    return float(dep.max()), float(dep.min()), float(lat.max())


def glitter_D_factor(rays):
    """Per-pixel factor turning the sea's radiance into D: 4 cos(theta_o) / G.

    The sea is flat and the sun's direction known, so cos(theta_o) (the
    ray's depression sine) and Smith's G = 1/((1 + Lambda(L))(1 + Lambda(E)))
    follow from the pixel's ray alone.  Without this the 1/(4 cos theta_o) of
    the BRDF makes the far end (grazing view) brighter and G (about 0.95 at
    theta_o = 85 deg) dims it, moving the half-peak outline by ~0.3 deg.
    """
    e = GLITTER["sun_elevation_deg"] * DEG
    m = float(R.beckmann_m_from_beta(GLITTER["beta_deg"] * DEG))
    wo = -rays
    lam_o = R.Lambda_beckmann(wo[..., 0], wo[..., 1], np.maximum(wo[..., 2], 1e-9), m, m)
    lam_i = float(R.Lambda_beckmann(0.0, math.cos(e), math.sin(e), m, m))
    return 4.0 * np.maximum(wo[..., 2], 1e-9) * (1.0 + lam_i) * (1.0 + lam_o)


def bright(value, rays, peak, threshold=0.5):
    """Pixels whose D (value times :func:`glitter_D_factor`) is at least
    ``threshold`` of ``peak`` (the reference's peak D)."""
    d = value * glitter_D_factor(rays)
    return d >= threshold * peak, d


def glitter_reference(rays):
    """Expected image (H, W) from addon.reference: the Beckmann sea under the sun."""
    e = GLITTER["sun_elevation_deg"] * DEG
    L = np.array([0.0, math.cos(e), math.sin(e)])
    down = rays[..., 2] < 0
    wo = -rays
    val = R.shade("microfacet", L, wo, distribution="beckmann", shadowing="smith",
                  beta=GLITTER["beta_deg"] * DEG)[..., 0]
    return np.where(down, val, 0.0)


def glitter_analysis(image, rays, res):
    """Everything the glitter check judges, from a rendered image (or the
    reference image) of :func:`camera_rays` ``rays``."""
    e = GLITTER["sun_elevation_deg"] * DEG
    beta = GLITTER["beta_deg"] * DEG
    ref = glitter_reference(rays)
    peak = float(np.max(ref * glitter_D_factor(rays)))
    m_r, _ = bright(image, rays, peak)
    m_e, _ = bright(ref, rays, peak)
    dep_b, lat_b = glitter_boundary(e, beta)
    vfov = GLITTER["vfov_deg"]
    # angular pixel pitch at the image centre (largest there for a pinhole camera)
    pitch = max(vfov / res[1],
                2 * math.degrees(math.atan(math.tan(0.5 * vfov * DEG) * res[0] / res[1])) / res[0])
    return {
        "mask": m_r, "reference": ref,
        "render_deg": [v / DEG for v in path_extent(m_r, rays)],
        "reference_deg": [v / DEG for v in path_extent(m_e, rays)],
        "geometry_deg": [float(dep_b.max()) / DEG, float(dep_b.min()) / DEG,
                         float(np.abs(lat_b).max()) / DEG],
        "closed_form_half_width_deg": glitter_geometry(e, beta)[2] / DEG,
        "slide_half_width_deg": math.atan(math.tan(beta) * math.sin(e)) / DEG,
        "widest_depression_deg": math.degrees(exact_dep_at_widest(dep_b, lat_b)),
        "pixel_pitch_deg": pitch,
        "image_max_rel_difference": float(np.max(np.abs(image - ref)) / max(float(ref.max()),
                                                                           1e-12)),
        "beckmann_m": float(R.beckmann_m_from_beta(beta)),
    }
