# SPDX-License-Identifier: GPL-3.0-or-later
"""Numerical verification of the numpy reference (no bpy).

Each test checks a defining property of the lecture by an independent
quadrature or Monte Carlo estimate, never by comparing the code with itself.
"""

import functools
import math

import numpy as np
import pytest

from addon import catalogue
from addon import reference as R

DEG = math.pi / 180.0
DISTS = catalogue.DISTRIBUTIONS


@functools.lru_cache(maxsize=None)
def _leggauss(n):
    return np.polynomial.legendre.leggauss(n)


def gl(n, a, b):
    x, w = _leggauss(n)
    return 0.5 * (b - a) * x + 0.5 * (b + a), 0.5 * (b - a) * w


def sph(theta, phi=0.0):
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)


def D_of(dist, h, beta):
    """Isotropic D at beta through the public D_* functions."""
    if dist == "blinn":
        return R.D_blinn(h[..., 0], h[..., 1], h[..., 2], beta)
    if dist == "gaussian":
        return R.D_gaussian(h[..., 0], h[..., 1], h[..., 2], beta)
    if dist == "trowbridge_reitz":
        a = R.tr_alpha_from_beta(beta)
        return R.D_trowbridge_reitz(h[..., 0], h[..., 1], h[..., 2], a, a)
    m = R.beckmann_m_from_beta(beta)
    return R.D_beckmann(h[..., 0], h[..., 1], h[..., 2], m, m)


def Lambda_of(dist, w, beta):
    return R.distribution(dist, beta=beta).Lambda(w[..., 0], w[..., 1], w[..., 2])


def projected_area(D, omega, n_alpha=600, n_phi=256, sign=1.0):
    """int max(0, sign omega.m) D(m) dm by 2-D Gauss-Legendre quadrature over
    the facet tilt and azimuth; the azimuth range is cut where omega.m changes
    sign (a geometric fact), so the kink does not spoil the quadrature."""
    theta = math.acos(omega[2])
    phi_w = math.atan2(omega[1], omega[0])
    total = 0.0
    # Split the tilt range at pi/2 - theta, where the sign region starts to change.
    edges = sorted({0.0, max(0.0, 0.5 * math.pi - theta), 0.5 * math.pi})
    for a0, a1 in zip(edges[:-1], edges[1:]):
        if a1 <= a0:
            continue
        alpha, wa = gl(n_alpha, a0, a1)
        A = math.sin(theta) * np.sin(alpha)
        B = math.cos(theta) * np.cos(alpha)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(A > 0, -sign * B / A, -np.inf * sign)
        # sign*(A cos(dphi) + B) > 0  <=>  cos(dphi) > ratio (sign=+1) or < ratio (sign=-1)
        lim = np.arccos(np.clip(ratio, -1.0, 1.0))
        for k in range(alpha.size):
            if sign > 0:
                lo, hi = -lim[k], lim[k]
            else:
                lo, hi = lim[k], 2 * math.pi - lim[k]
            if hi <= lo:
                continue
            phi, wp = gl(n_phi, lo, hi)
            m = sph(alpha[k], phi + phi_w)
            val = sign * (m @ omega)
            total += wa[k] * np.sin(alpha[k]) * np.sum(wp * np.maximum(val, 0.0) * D(m))
    return total


# ---------------------------------------------------------------------------
# Distributions
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("dist", DISTS)
@pytest.mark.parametrize("beta_deg", [1.0, 5.0, 20.0, 45.0, 70.0, 85.0])
def test_every_distribution_integrates_to_one(dist, beta_deg):
    beta = beta_deg * DEG
    # Composite Gauss-Legendre over the tilt, dense near the peak at alpha = 0.
    edges = np.unique(np.r_[np.linspace(0, 4 * beta, 17), np.linspace(4 * beta, math.pi / 2, 17)]
                      .clip(0, math.pi / 2))
    total = 0.0
    for a, b in zip(edges[:-1], edges[1:]):
        alpha, w = gl(64, a, b)
        h = sph(alpha)
        total += 2 * math.pi * np.sum(w * D_of(dist, h, beta) * np.cos(alpha) * np.sin(alpha))
    # Quadrature of a smooth integrand: 1e-7 is far above its error (~1e-12).
    assert total == pytest.approx(1.0, abs=1e-7)


@pytest.mark.parametrize("dist", DISTS)
@pytest.mark.parametrize("beta_deg", [1.0, 10.0, 40.0, 85.0])
def test_D_at_beta_is_half_its_peak(dist, beta_deg):
    beta = beta_deg * DEG
    d0 = D_of(dist, sph(0.0), beta)
    db = D_of(dist, sph(beta), beta)
    assert db / d0 == pytest.approx(0.5, rel=1e-12)


@pytest.mark.parametrize("dist", ["trowbridge_reitz", "beckmann"])
def test_anisotropic_distributions_integrate_to_one(dist):
    ax, ay = 0.15, 0.45
    fn = R.D_trowbridge_reitz if dist == "trowbridge_reitz" else R.D_beckmann
    alpha, wa = gl(800, 0, math.pi / 2)
    phi, wp = gl(200, 0, 2 * math.pi)
    A, P = np.meshgrid(alpha, phi, indexing="ij")
    h = sph(A, P)
    val = fn(h[..., 0], h[..., 1], h[..., 2], ax, ay) * np.cos(A) * np.sin(A)
    total = np.einsum("i,j,ij->", wa, wp, val)
    # 800 x 200 Gauss-Legendre nodes on a smooth integrand: error well below 1e-6.
    assert total == pytest.approx(1.0, abs=1e-6)


def test_beta_conversions_round_trip():
    beta = np.linspace(1, 85, 50) * DEG
    np.testing.assert_allclose(R.beta_from_blinn_exponent(R.blinn_exponent_from_beta(beta)), beta, rtol=1e-12)
    np.testing.assert_allclose(R.beta_from_gaussian_c2(R.gaussian_c2_from_beta(beta)), beta, rtol=1e-12)
    np.testing.assert_allclose(R.beta_from_tr_alpha(R.tr_alpha_from_beta(beta)), beta, rtol=1e-9)
    np.testing.assert_allclose(R.beta_from_beckmann_m(R.beckmann_m_from_beta(beta)), beta, rtol=1e-9)
    # The slide's relation m = 2 sigma / tau does not involve beta; but the
    # errata forms must satisfy D(beta) = D(0)/2 (checked above) and the
    # Blinn exponent must be positive (the printed formula gives a negative one).
    assert np.all(R.blinn_exponent_from_beta(beta) > 0)


def test_trowbridge_reitz_beta_is_undefined_beyond_its_limit():
    assert R.tr_alpha_from_beta(89.999 * DEG) < R.TR_ALPHA_BETA_LIMIT
    with pytest.raises(ValueError, match="undefined"):
        R.beta_from_tr_alpha(0.9)


def test_trowbridge_reitz_with_beta_equals_ggx_with_alpha_c3():
    rng = np.random.default_rng(3)
    wi = sph(rng.uniform(0, 1.4, 500), rng.uniform(0, 6.28, 500))
    wo = sph(rng.uniform(0, 1.4, 500), rng.uniform(0, 6.28, 500))
    for beta in (3 * DEG, 25 * DEG, 70 * DEG):
        a = float(R.tr_alpha_from_beta(beta))
        f_beta = R.brdf("microfacet", wi, wo, distribution="trowbridge_reitz", beta=beta)
        f_alpha = R.brdf("microfacet", wi, wo, distribution="trowbridge_reitz", alpha=a)
        np.testing.assert_allclose(f_beta, f_alpha, rtol=1e-12)
        # ... and GGX written out independently (Walter 2007 eq. 33 and 34).
        h = wi + wo
        h /= np.linalg.norm(h, axis=-1, keepdims=True)
        c = h[:, 2]
        D = a * a / (math.pi * ((a * a - 1) * c * c + 1) ** 2)

        def G1(w):
            t2 = (1 - w[:, 2] ** 2) / w[:, 2] ** 2
            return 2 / (1 + np.sqrt(1 + a * a * t2))
        f = D * G1(wi) * G1(wo) / (4 * wi[:, 2] * wo[:, 2])
        np.testing.assert_allclose(f_beta[:, 0], f, rtol=1e-10)


# ---------------------------------------------------------------------------
# Smith shadowing
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("dist", DISTS)
@pytest.mark.parametrize("beta_deg", [3.0, 20.0, 60.0])
@pytest.mark.parametrize("theta_deg", [0.0, 30.0, 60.0, 75.0, 85.0])
def test_smith_self_consistency(dist, beta_deg, theta_deg):
    """Slide "Self-Consistency Condition": int G1(w) max(0, w.m) D(m) dm = cos(theta)."""
    beta = beta_deg * DEG
    omega = sph(theta_deg * DEG, 0.3)
    aplus = projected_area(lambda m: D_of(dist, m, beta), omega)
    g1 = 1.0 / (1.0 + Lambda_of(dist, omega, beta))
    # 2-D quadrature error and the Lambda table's interpolation (<2e-5): 1e-4.
    assert g1 * aplus == pytest.approx(math.cos(theta_deg * DEG), rel=1e-4, abs=1e-9)


@pytest.mark.parametrize("dist", ["trowbridge_reitz", "beckmann"])
def test_anisotropic_smith_self_consistency(dist):
    ax, ay = 0.12, 0.5
    D = (R.D_trowbridge_reitz if dist == "trowbridge_reitz" else R.D_beckmann)
    L = (R.Lambda_trowbridge_reitz if dist == "trowbridge_reitz" else R.Lambda_beckmann)
    for theta, phi in [(40 * DEG, 0.0), (70 * DEG, 1.0), (80 * DEG, 2.2)]:
        omega = sph(theta, phi)
        aplus = projected_area(lambda m: D(m[..., 0], m[..., 1], m[..., 2], ax, ay), omega, n_phi=400)
        g1 = 1.0 / (1.0 + L(*omega, ax, ay))
        # 2-D quadrature of an anisotropic lobe: 2e-4.
        assert g1 * aplus == pytest.approx(math.cos(theta), rel=2e-4)


def test_beckmann_lambda_is_its_closed_form_to_double_precision():
    """Beckmann's Lambda against its closed form in 40-digit mpmath, a =
    cot(theta)/alpha from 0.01 to 30 (the rational erfc below 4, the series
    above; exp(-a^2) underflows past 27), isotropic and anisotropic:
    1e-12 relative (measured 3.0e-13: exp(-a^2) taken unsplit, its a^2 off
    by 1e-16 a^2), and 1+Lambda, which G1 divides by, to 4e-16."""
    mpmath = pytest.importorskip("mpmath")
    a = np.concatenate([np.linspace(0.01, 8.0, 400), np.linspace(8.0, 30.0, 100)])
    theta = np.arctan(1.0 / a)
    for ax, ay, phi in ((1.0, 1.0, 0.0), (0.3, 0.05, 0.7)):
        w = np.stack([np.sin(theta) * math.cos(phi), np.sin(theta) * math.sin(phi),
                      np.cos(theta)], -1)
        got = R.Lambda_beckmann(w[:, 0], w[:, 1], w[:, 2], ax, ay)
        with mpmath.workdps(40):
            want = []
            for x, y, z in w:
                m = mpmath.sqrt((mpmath.mpf(x) * ax) ** 2 + (mpmath.mpf(y) * ay) ** 2)
                b = mpmath.mpf(z) / m
                want.append(float((mpmath.exp(-b * b) / (b * mpmath.sqrt(mpmath.pi))
                                   - mpmath.erfc(b)) / 2))
        want = np.array(want)
        seen = want > 1e-300
        assert seen.sum() > 100, seen.sum()
        assert np.max(np.abs(got[seen] / want[seen] - 1.0)) < 1e-12
        assert np.max(np.abs(got - want) / (1.0 + want)) < 4e-16


def test_smith_1967_bracket_breaks_self_consistency():
    """The slide's erfc bracket form is not self-consistent (lecture notes: up to ~50 %)."""
    m = 0.5
    worst = 0.0
    for theta in np.linspace(10, 88, 14) * DEG:
        omega = sph(theta)
        aplus = projected_area(lambda h: R.D_beckmann(h[..., 0], h[..., 1], h[..., 2], m, m), omega)
        s = R.S_smith_1967(*omega, m, m)
        worst = max(worst, abs(s * aplus / math.cos(theta) - 1))
    assert 0.1 < worst < 0.6


@pytest.mark.parametrize("dist", ["blinn", "gaussian"])
def test_one_lambda_approximation_for_blinn_and_gaussian(dist):
    """Lambda_table (the earlier tabulated form's name), the types' Lambda and
    Lambda_chebyshev are one and the same series."""
    w = sph(np.linspace(0, 89.8, 50) * DEG)
    beta = 33 * DEG
    lc = R.Lambda_chebyshev(w[:, 0], w[:, 1], w[:, 2], beta, dist)
    assert np.array_equal(R.Lambda_table(w[:, 0], w[:, 1], w[:, 2], beta, dist), lc)
    assert np.array_equal(R.distribution(dist, beta=beta).Lambda(w[:, 0], w[:, 1], w[:, 2]), lc)


@pytest.mark.parametrize("dist", ["blinn", "gaussian"])
def test_lambda_chebyshev_matches_direct_quadrature(dist):
    """The series the shaders evaluate, away from its own interpolation points."""
    rng = np.random.default_rng(11)
    worst = 0.0
    for beta in np.r_[1.0, 85.0, rng.uniform(1, 85, 12)] * DEG:
        theta = np.r_[0.0, np.sort(rng.uniform(0, 89.9, 300))] * DEG
        phi = rng.uniform(0, 2 * np.pi, theta.size)
        w = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
        lc = R.Lambda_chebyshev(w[:, 0], w[:, 1], w[:, 2], beta, dist)
        lq = R.Aminus_quadrature(np.cos(theta), beta, dist, nodes=96) / np.cos(theta)
        worst = max(worst, np.max(np.abs(lc - lq) / (1 + lq)))
    # Relative error of G1 = 1/(1+Lambda); 2e-6 leaves float32 shaders room
    # inside the renders' 1e-4 (1e-6 measured).
    assert worst < 2e-6


@pytest.mark.parametrize("dist", ["blinn", "gaussian"])
def test_lambda_beyond_the_series_range_is_the_quadrature(dist):
    """The series covers the catalogue's beta (1 to 85 deg); the types and
    Lambda_chebyshev take beta in (0, 90 deg), where the series extrapolated
    (Gaussian at 89.9 deg: 0.65 for 0.053 at 30 deg).  Beyond its range they
    are the quadrature; a beta per direction mixes both."""
    theta = np.array([0.0, 30.0, 60.0, 80.0, 89.0]) * DEG
    w = sph(theta)
    betas = np.array([0.05, 0.5, 87.0, 89.0, 89.9]) * DEG
    for beta in betas:
        lq = R.Aminus_quadrature(np.cos(theta), beta, dist, nodes=96) / np.cos(theta)
        got = R.distribution(dist, beta=beta).Lambda(w[:, 0], w[:, 1], w[:, 2])
        # the same quadrature: only the order of the sums may differ
        np.testing.assert_allclose(got, lq, rtol=1e-12, atol=1e-300)
    mixed = np.array([0.5, 20.0, 70.0, 89.0, 89.9]) * DEG
    together = R.Lambda_chebyshev(w[:, 0], w[:, 1], w[:, 2], mixed, dist)
    apart = [R.Lambda_chebyshev(*w[i], mixed[i], dist) for i in range(5)]
    np.testing.assert_allclose(together, np.array(apart, dtype=float), rtol=1e-13)


def test_lambda_chebyshev_broadcasts_beta():
    """A beta per direction (a textured beta) gives what one beta at a time does."""
    betas = np.array([2.0, 20.0, 70.0]) * DEG
    w = sph(np.array([10.0, 50.0, 85.0]) * DEG)
    together = R.Lambda_chebyshev(w[:, 0], w[:, 1], w[:, 2], betas, "gaussian")
    apart = [R.Lambda_chebyshev(w[i, 0], w[i, 1], w[i, 2], betas[i], "gaussian") for i in range(3)]
    assert together == pytest.approx(np.array(apart), rel=1e-13)


@pytest.mark.parametrize("dist", DISTS)
def test_smith_G1_limits(dist):
    beta = 25 * DEG
    theta = np.linspace(0, 89, 200) * DEG
    lam = Lambda_of(dist, sph(theta), beta)
    g1 = 1 / (1 + lam)
    assert np.all(lam >= 0.0)  # back-facing facets never have a negative area
    assert g1[0] == pytest.approx(1.0, abs=1e-12)  # normal incidence
    # monotone in theta: to float64 rounding for the closed forms; for Blinn and
    # Gaussian to the series' accuracy (2e-6 in G1, test below)
    assert np.all(np.diff(g1) <= (2e-6 if dist in ("blinn", "gaussian") else 1e-12))
    assert g1[-1] < 0.9


def test_vgroove_never_exceeds_one():
    rng = np.random.default_rng(5)
    wi = sph(rng.uniform(0, 1.57, 20000), rng.uniform(0, 6.28, 20000))
    wo = sph(rng.uniform(0, 1.57, 20000), rng.uniform(0, 6.28, 20000))
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    g = R.G_vgroove(wi[:, 2], wo[:, 2], h[:, 2], np.sum(wi * h, -1))
    assert np.all(g <= 1.0) and np.all(g >= 0.0) and np.any(g < 0.5)


# ---------------------------------------------------------------------------
# BRDF properties
# ---------------------------------------------------------------------------

def surface_cases():
    cases = [
        ("lambert", {}),
        ("phong", {"exponent": 15.0}),
        ("phong", {"exponent": 15.0, "normalization": "energy"}),
        ("blinn_phong", {"exponent": 30.0, "normalization": "energy"}),
        ("ward", {"alpha_x": 0.3, "alpha_y": 0.1}),
        ("torrance_sparrow", {"beta": 12 * DEG, "fresnel": "conductor", "ior": (1.47, 0.96, 0.62),
                              "k": (7.8, 6.7, 5.5)}),
        ("cook_torrance", {"beta": 12 * DEG}),
    ]
    for dist in DISTS:
        for sh in catalogue.SHADOWINGS:
            if sh == "smith_1967" and dist != "beckmann":
                continue
            cases.append(("microfacet", {"distribution": dist, "shadowing": sh, "beta": 15 * DEG,
                                         "fresnel": "dielectric", "ior": 1.6}))
    cases.append(("microfacet", {"distribution": "trowbridge_reitz", "alpha_x": 0.1, "alpha_y": 0.4}))
    cases.append(("microfacet", {"distribution": "beckmann", "alpha_x": 0.4, "alpha_y": 0.1,
                                 "shadowing": "smith_correlated"}))
    return cases


@pytest.mark.parametrize("model,params", surface_cases(), ids=lambda x: str(x)[:60])
def test_every_brdf_is_reciprocal(model, params):
    rng = np.random.default_rng(11)
    n = np.array([0.2, -0.3, 0.93])
    n /= np.linalg.norm(n)
    t = np.array([0.6, 0.8, 0.0])
    wi = sph(rng.uniform(0, 1.5, 2000), rng.uniform(0, 6.28, 2000))
    wo = sph(rng.uniform(0, 1.5, 2000), rng.uniform(0, 6.28, 2000))
    a = R.brdf(model, wi, wo, normal=n, tangent=t, **params)
    b = R.brdf(model, wo, wi, normal=n, tangent=t, **params)
    assert np.all(np.isfinite(a)) and np.any(a > 0)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


def test_phong_reciprocity_identity():
    """Slide "Phong Model": (E.R(L))^s = (L.R(E))^s."""
    rng = np.random.default_rng(2)
    n = np.array([0.0, 0.0, 1.0])
    L = sph(rng.uniform(0, 1.5, 1000), rng.uniform(0, 6.28, 1000))
    E = sph(rng.uniform(0, 1.5, 1000), rng.uniform(0, 6.28, 1000))

    def refl(v):
        return 2 * (v @ n)[:, None] * n - v
    np.testing.assert_allclose(np.sum(E * refl(L), -1), np.sum(L * refl(E), -1), atol=1e-14)
    f = R.brdf("phong", L, E, exponent=7.0)[:, 0]
    np.testing.assert_allclose(f, np.maximum(np.sum(E * refl(L), -1), 0) ** 7, rtol=1e-12)


def albedo(model, theta_o, **params):
    """Directional albedo int f cos(theta_i) dw_i, by quadrature over wi in
    coordinates around the mirror direction (dense where lobes are)."""
    wo = sph(theta_o)
    r = np.array([-wo[0], -wo[1], wo[2]])  # mirror of wo about n = z
    # orthonormal frame around r
    u = np.cross([0.0, 1.0, 0.0], r)
    u /= np.linalg.norm(u)
    v = np.cross(r, u)
    total = 0.0
    edges = np.r_[0, np.geomspace(1e-3, math.pi, 40)]
    phi, wp = gl(256, 0, 2 * math.pi)
    for a, b in zip(edges[:-1], edges[1:]):
        psi, wa = gl(24, a, b)
        P, F = np.meshgrid(psi, phi, indexing="ij")
        wi = (np.sin(P) * np.cos(F))[..., None] * u + (np.sin(P) * np.sin(F))[..., None] * v \
            + np.cos(P)[..., None] * r
        val = R.shade(model, wi, wo, **params)[..., 0] * np.sin(P)
        total += np.einsum("i,j,ij->", wa, wp, val)
    return total


@pytest.mark.parametrize("s", [0.0, 1.0, 10.0, 100.0, 1000.0])
def test_energy_normalised_phong_never_exceeds_one(s):
    alb = [albedo("phong", t * DEG, exponent=s, normalization="energy") for t in (0, 30, 60, 80, 89)]
    # quadrature error of the albedo integral (~1e-4 at the clipping kink).
    assert max(alb) <= 1.0 + 1e-3
    # at normal incidence the lobe sits inside the hemisphere: (s+1)/(s+2)
    assert alb[0] == pytest.approx((s + 1) / (s + 2), rel=2e-3)


@pytest.mark.parametrize("dist", DISTS)
@pytest.mark.parametrize("shadowing", ["smith", "smith_correlated", "vgroove"])
def test_white_furnace_microfacet_albedo_at_most_one(dist, shadowing):
    for beta in (5 * DEG, 30 * DEG, 70 * DEG):
        for t in (0.0, 45.0, 75.0, 88.0):
            a = albedo("microfacet", t * DEG, distribution=dist, shadowing=shadowing, beta=beta)
            # quadrature error ~1e-4; the models lose energy, they never create it.
            assert a <= 1.0 + 1e-3, (beta, t, a)


def test_half_vector_jacobian_by_monte_carlo():
    """Slide "Solid Angle Distributions": dw_h/dw_r = 1/(4 cos theta'_i)."""
    rng = np.random.default_rng(123)
    n = 4_000_000
    wo = sph(50 * DEG, 0.0)
    z = rng.uniform(-1, 1, n)
    phi = rng.uniform(0, 2 * math.pi, n)
    s = np.sqrt(1 - z * z)
    wi = np.stack([s * np.cos(phi), s * np.sin(phi), z], -1)  # uniform on the sphere
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    for h0 in (sph(10 * DEG, 1.0), sph(35 * DEG, 3.0), sph(60 * DEG, 0.2)):
        cap = 4 * DEG
        inside = (h @ h0) > math.cos(cap)
        omega_cap = 2 * math.pi * (1 - math.cos(cap))
        cos_ti = float(h0 @ wo)
        # density of h = density of wi (1/4pi) times dw_i/dw_h = 4 cos(theta'_i)
        expected = n * omega_cap * (1 / (4 * math.pi)) * 4 * cos_ti
        sigma = math.sqrt(expected)
        assert abs(inside.sum() - expected) < 4 * sigma + 0.01 * expected


# ---------------------------------------------------------------------------
# Fresnel
# ---------------------------------------------------------------------------

def test_conductor_fresnel_against_complex_arithmetic():
    c = np.linspace(0.0, 1.0, 101)[:, None]
    for n, k in [(1.47, 7.8), (0.17, 3.15), (1.5, 0.0), (2.9, 3.3)]:
        eta = n + 1j * k
        s2 = 1 - c * c
        ct = np.sqrt(1 - s2 / eta ** 2)
        rs = (c - eta * ct) / (c + eta * ct)
        rp = (eta * c - ct) / (eta * c + ct)
        ref = 0.5 * (abs(rs) ** 2 + abs(rp) ** 2)
        np.testing.assert_allclose(R.F_conductor(c, n, k), ref, rtol=1e-12, atol=1e-14)


def test_conductor_fresnel_without_extinction_is_the_dielectric_one_to_grazing():
    """k = 0 is a dielectric: F_conductor equals F_dielectric down to c = 1e-12
    (1 - c^2 lost c^2 there: an index of 1 reflected everything below
    c = 1e-8), and an index of 1 reflects nothing, at c = 0 too (was 0/0)."""
    c = np.r_[0.0, 10.0 ** np.linspace(-12, 0, 49)]
    for n in (1.0, 1.0001, 1.5, 3.0):
        np.testing.assert_allclose(R.F_conductor(c[1:], n, 0.0), R.F_dielectric(c[1:], n),
                                   rtol=1e-9, atol=1e-15)
    assert np.all(R.F_conductor(c, 1.0, 0.0) == 0.0)


def test_dielectric_fresnel_properties():
    for n in (1.33, 1.5, 2.4):
        assert R.F_dielectric(1.0, n) == pytest.approx(((n - 1) / (n + 1)) ** 2, rel=1e-12)
        assert R.F_dielectric(1e-9, n) == pytest.approx(1.0, abs=1e-6)
        c = np.linspace(0.01, 1, 50)
        np.testing.assert_allclose(R.F_dielectric(c, n), R.F_conductor(c, n, 0.0), rtol=1e-12)
    assert R.F_dielectric(0.5, 1 / 1.5) == 1.0  # total internal reflection


# ---------------------------------------------------------------------------
# Kajiya-Kay, Ward, API behaviour
# ---------------------------------------------------------------------------

def test_kajiya_kay_highlight_lies_on_the_mirror_cone():
    t = np.array([1.0, 0.0, 0.0])
    wi = sph(60 * DEG, 0.3)
    cone = -float(t @ wi)  # T.E must equal -T.L
    th = np.linspace(0.01, math.pi - 0.01, 2001)
    wo = np.stack([np.cos(th), np.sin(th) * 0.6, np.sin(th) * 0.8], -1)
    spec = R.shade("kajiya_kay", wi, wo, tangent=t, kd=0.0, ks=1.0, exponent=200.0)[:, 0]
    best = wo[np.argmax(spec)]
    assert float(best @ t) == pytest.approx(cone, abs=2e-3)  # sampling step of th
    on_cone = np.array([cone, 0.6 * math.sqrt(1 - cone ** 2), 0.8 * math.sqrt(1 - cone ** 2)])
    peak = R.shade("kajiya_kay", wi, on_cone, tangent=t, kd=0.0, ks=1.0, exponent=200.0)[0]
    assert peak == pytest.approx(1.0, abs=1e-12)
    diffuse = R.shade("kajiya_kay", wi, wo, tangent=t, kd=1.0, ks=0.0)[:, 0]
    np.testing.assert_allclose(diffuse, math.sqrt(1 - cone ** 2))


@pytest.mark.parametrize("eps", [1e-3, 1e-6, 1e-9, 1e-150])
def test_kajiya_kay_keeps_its_sines_with_the_light_along_the_fibre(eps):
    """The light eps rad from the fibre, the view across it: the diffuse
    term is kd sin(eps), and the cone term sin(eps) (T.E = 0), so ks sin^2
    at exponent 2, to float64 rounding (1e-12 relative; sqrt(1 - cos^2)
    lost the sine: 5e-5 relative at 1e-6, and 0 from 1e-8 on)."""
    t = np.array([1.0, 0.0, 0.0])
    wi = np.array([math.cos(eps), 0.0, math.sin(eps)])
    wo = np.array([0.0, 0.6, 0.8])
    diffuse = R.shade("kajiya_kay", wi, wo, tangent=t, kd=1.0, ks=0.0)[0]
    assert diffuse == pytest.approx(math.sin(eps), rel=1e-12, abs=0.0)
    spec = R.shade("kajiya_kay", wi, wo, tangent=t, kd=0.0, ks=1.0, exponent=2.0)[0]
    assert spec == pytest.approx(math.sin(eps) ** 2, rel=1e-12, abs=0.0)


def test_ward_matches_its_formula():
    wi, wo = sph(30 * DEG, 0.4), sph(45 * DEG, 2.0)
    ax, ay = 0.2, 0.05
    h = wi + wo
    h /= np.linalg.norm(h)
    tan2 = (h[0] ** 2 + h[1] ** 2) / h[2] ** 2
    cos2p = h[0] ** 2 / (h[0] ** 2 + h[1] ** 2)
    f = math.exp(-tan2 * (cos2p / ax ** 2 + (1 - cos2p) / ay ** 2)) / (
        4 * math.pi * ax * ay * math.sqrt(wi[2] * wo[2]))
    assert R.brdf("ward", wi, wo, alpha_x=ax, alpha_y=ay)[0] == pytest.approx(f, rel=1e-12)


def test_shade_is_brdf_times_cosine_and_broadcasts():
    rng = np.random.default_rng(9)
    wi = sph(rng.uniform(0, 1.5, (4, 5)), rng.uniform(0, 6, (4, 5)))
    wo = sph(0.3, 0.1)
    s = R.shade("phong", wi, wo, exponent=np.full((4, 5), 9.0), ks=(1.0, 0.5, 0.25))
    f = R.brdf("phong", wi, wo, exponent=9.0, ks=(1.0, 0.5, 0.25))
    assert s.shape == (4, 5, 3)
    np.testing.assert_allclose(s, f * np.maximum(wi[..., 2:], 0))
    np.testing.assert_allclose(s[..., 1], 0.5 * s[..., 0])


def test_rotated_frame_gives_the_same_pixel():
    rng = np.random.default_rng(4)
    wi = sph(0.5, 0.2)
    wo = sph(0.8, 2.5)
    # a random rotation
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    params = dict(distribution="beckmann", alpha_x=0.1, alpha_y=0.3, fresnel="dielectric")
    a = R.shade("microfacet", wi, wo, **params)
    b = R.shade("microfacet", q @ wi, q @ wo, normal=q @ [0, 0, 1.0], tangent=q @ [1.0, 0, 0], **params)
    np.testing.assert_allclose(a, b, rtol=1e-10)


def test_presets_are_the_named_microfacet_models():
    wi, wo = sph(0.4, 0.0), sph(0.6, 3.0)
    a = R.shade("torrance_sparrow", wi, wo, beta=0.2, ior=1.7)
    b = R.shade("microfacet", wi, wo, distribution="gaussian", shadowing="vgroove",
                fresnel="dielectric", beta=0.2, ior=1.7)
    np.testing.assert_allclose(a, b)
    with pytest.raises(ValueError, match="fixed"):
        R.shade("cook_torrance", wi, wo, distribution="gaussian")


@pytest.mark.parametrize("model,params", [
    ("phong", {"exponent": 30.0}), ("microfacet", {"distribution": "trowbridge_reitz",
                                                   "alpha": 0.3, "fresnel": "conductor",
                                                   "ior": 0.2, "k": 3.0}),
    ("ward", {"alpha_x": 0.2, "alpha_y": 0.5}), ("kajiya_kay", {}),
])
def test_directions_of_any_length_are_directions(model, params):
    """wi, wo, the normal and the tangent are scaled to unit length (as the
    shaders do); a zero, NaN or infinite vector has no direction and gives
    0, never NaN."""
    rng = np.random.default_rng(7)
    wi, wo = sph(0.5, 0.3), sph(0.7, 2.5)
    n = np.array([0.1, -0.2, 1.0]) / np.linalg.norm([0.1, -0.2, 1.0])
    t = np.array([1.0, 0.3, 0.0])
    unit = R.shade(model, wi, wo, normal=n, tangent=t / np.linalg.norm(t), **params)
    assert np.all(unit > 0)
    for _ in range(5):
        a, b, c, d = rng.uniform(1e-3, 1e3, 4)
        scaled = R.shade(model, a * wi, b * wo, normal=c * n, tangent=d * t, **params)
        np.testing.assert_allclose(scaled, unit, rtol=1e-12)  # float64 rounding of a rescale
    for bad in (np.zeros(3), np.array([np.nan, 0.0, 1.0]), np.array([np.inf, 0.0, 1.0])):
        for kw in ({"wi": bad, "wo": wo}, {"wi": wi, "wo": bad}):
            out = R.shade(model, kw["wi"], kw["wo"], normal=n, tangent=t, **params)
            assert np.all(out == 0.0), (bad, out)
    # a tangent with no direction: the frame's, the x axis on the surface (as
    # the shaders' frame without a UV map)
    x = np.array([1.0, 0.0, 0.0])
    default = R.shade(model, wi, wo, normal=n, tangent=x - np.dot(x, n) * n, **params)
    for bad in (np.zeros(3), np.array([np.nan, 0.0, 1.0]), np.array([np.inf, 0.0, 0.0])):
        out = R.shade(model, wi, wo, normal=n, tangent=bad, **params)
        np.testing.assert_allclose(out, default, rtol=1e-12)


@pytest.mark.parametrize("call,match", [
    (lambda w: R.shade("glossy", w, w), "allowed: lambert"),
    (lambda w: R.shade("phong", w, w, shininess=3), "allowed: exponent"),
    (lambda w: R.shade("phong", w, w, exponent=-1), r"\[0, 10000\]"),
    (lambda w: R.shade("phong", w, w, exponent=float("nan")), "exponent must be"),
    (lambda w: R.shade("phong", w, w, ks=None), r"ks=None is not allowed; ks must be an RGB"),
    # numpy would read a string as its number and True as 1: not numbers here
    (lambda w: R.shade("phong", w, w, exponent="20"), r"exponent='20' is not allowed"),
    (lambda w: R.shade("phong", w, w, exponent=True), r"exponent=True is not allowed"),
    (lambda w: R.shade("phong", w, w, ks=("1", "1", "1")), r"ks=.* is not allowed; ks must be"),
    # RGBA, or an axis of greys: the colour's axis would be a guess (read as greys before)
    (lambda w: R.shade("phong", w, w, ks=(1.0, 0.5, 0.25, 1.0)), r"ks has shape \(4,\); .*RGB"),
    (lambda w: R.shade("lambert", w, w, albedo=np.full((5, 2), 0.5)), r"albedo has shape \(5, 2\)"),
    (lambda w: R.shade("microfacet", w, w, distribution="ggx"), "'trowbridge_reitz'"),
    (lambda w: R.shade("microfacet", w, w, beta=0.0), "beta must be"),
    (lambda w: R.shade("microfacet", w, w, beta=0.3, alpha=0.2), "one width"),
    (lambda w: R.shade("microfacet", w, w, distribution="blinn", alpha=0.2), "takes beta"),
    (lambda w: R.shade("microfacet", w, w, distribution="gaussian", shadowing="smith_1967"), "beckmann"),
    (lambda w: R.shade("microfacet", w, w, fresnel="conductor", k=-1), "k must be"),
    (lambda w: R.shade("microfacet", w, w, fresnel="dielectric", ior=0.0), "ior must be"),
    (lambda w: R.brdf("kajiya_kay", w, w), "fibre model"),
    # directions that are no vectors: numpy gave its own message (a string, a ragged list)
    # or a TypeError (complex numbers)
    (lambda w: R.shade("lambert", "up", w), r"wi must be a 3-vector .*, not 'up'"),
    (lambda w: R.shade("lambert", w, None), r"wo must be a 3-vector .*, not None"),
    (lambda w: R.shade("phong", w, w, normal=[[0, 1], [1]]), r"normal must be a 3-vector"),
    (lambda w: R.shade("ward", w, w, tangent=np.zeros((9, 2))), r"not an array of shape \(9, 2\)"),
    (lambda w: R.shade("lambert", [1j, 0, 1], w), r"wi must be a 3-vector"),
    (lambda w: R.shade("microfacet", w, w, distribution="beckmann", alpha_x=0.2), "together"),
    # the width conversions: numpy gave NaN, or past pi a width repeating with cos
    (lambda w: R.blinn_exponent_from_beta(2.0), r"beta=2.0 is out of range.*\(0, pi/2\)"),
    (lambda w: R.gaussian_c2_from_beta(-0.1), r"beta=-0.1 is out of range"),
    (lambda w: R.tr_alpha_from_beta(np.array([0.3, 10.0])), r"beta=10.0 is out of range"),
    (lambda w: R.beckmann_m_from_beta(float("nan")), r"beta=nan is out of range"),
    (lambda w: R.beta_from_blinn_exponent(0.0), r"exponent=0.0 is out of range.*\(0, inf\)"),
    (lambda w: R.beta_from_gaussian_c2(0.5), r"c2=0.5 is out of range; c2 must be .*\(0.53"),
    (lambda w: R.beta_from_beckmann_m(float("inf")), r"m=inf is out of range"),
    (lambda w: R.beta_from_tr_alpha(float("nan")), "undefined"),
    (lambda w: R.D_blinn(0.0, 0.0, 1.0, 1.6), r"beta=1.6 is out of range"),
    # the native widths: a negative one gave its absolute value's lobe, 0 a
    # ZeroDivisionError, NaN a NaN
    (lambda w: R.D_trowbridge_reitz(0.0, 0.0, 1.0, -0.3, 0.3),
     r"ax=-0.3 is out of range.*\(0, inf"),
    (lambda w: R.D_beckmann(0.0, 0.0, 1.0, 0.3, 0.0), r"ay=0.0 is out of range"),
    (lambda w: R.Lambda_trowbridge_reitz(0.5, 0.0, 0.8, float("nan"), 0.3), r"ax=nan is out"),
    (lambda w: R.Lambda_beckmann(0.5, 0.0, 0.8, 0.3, float("inf")), r"ay=inf is out"),
    (lambda w: R.S_smith_1967(0.5, 0.0, 0.8, -1.0, 0.3), r"ax=-1.0 is out of range"),
    (lambda w: R.distribution("trowbridge_reitz", alpha=0.0), r"alpha=0.0 is out of range"),
    (lambda w: R.distribution("beckmann", alpha_x=0.2, alpha_y=-0.2), r"alpha_y=-0.2 is out"),
    (lambda w: R.distribution("gaussian", beta=-1.0), r"beta=-1.0 is out of range"),
    (lambda w: R.Blinn(2.0), r"beta=2.0 is out of range"),
    (lambda w: R.TrowbridgeReitz([0.2, float("nan")]), r"alpha_x=nan is out of range"),
    # the Fresnel indices: a negative one passed as its absolute value, NaN gave 1
    (lambda w: R.F_dielectric(0.5, -1.5), r"ior=-1.5 is out of range; ior must be .* \(0, inf\)"),
    (lambda w: R.F_dielectric(0.5, float("nan")), r"ior=nan is out of range"),
    (lambda w: R.F_dielectric(0.5, float("inf")), r"ior=inf is out of range"),
    (lambda w: R.F_conductor(0.5, -0.2, 3.0), r"n=-0.2 is out of range; n must be .* \[0, inf\)"),
    (lambda w: R.F_conductor(0.5, (0.2, 0.3, 0.4), (3.0, -1.0, 2.0)), r"k=-1.0 is out of range"),
    # the quadrature took any other name for the Gaussian, numpy's messages otherwise
    (lambda w: R.Aminus_quadrature(0.5, 0.3, "beckmann"), r"'beckmann'; the quadrature is for"),
    (lambda w: R.Aminus_quadrature(0.5, 0.3, "blinn", nodes=2.5), r"nodes=2.5 is not allowed"),
    (lambda w: R.Aminus_quadrature(0.5, [0.3, 0.4], "blinn"), r"beta must be a scalar"),
    (lambda w: R.Aminus_quadrature(0.5, 1.6, "blinn"), r"beta=1.6 is out of range"),
])
def test_bad_input_raises_value_error_naming_what_is_allowed(call, match):
    w = np.array([0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match=match):
        call(w)


def test_the_terms_keep_their_ranges_outside_their_domain():
    """Facet normals below the surface have no density; a cosine past [0, 1]
    gives Fresnel's end value (it gave 280 at c = -0.5); V-groove's G stays
    in [0, 1] (it gave -4.5 for a negative L.H) and NaN stays NaN."""
    below = (0.1, 0.0, -0.99)
    for d in (R.Blinn(0.3), R.Gaussian(0.3), R.TrowbridgeReitz(0.3), R.Beckmann(0.3)):
        assert d.D(*below) == 0.0 and d.D(0.3, 0.0, 0.0) == 0.0, d
        assert d.D(0.1, 0.0, 0.99) > 0.0 and np.isnan(d.D(0.1, 0.0, np.nan)), d
    c = np.array([-0.5, 0.0, 1.0, 1.5, np.nan])
    for f in (lambda c: R.F_dielectric(c, 1.5), lambda c: R.F_conductor(c, 0.2, 3.0)):
        got = f(c)
        np.testing.assert_array_equal(got[:2], [1.0, 1.0])
        np.testing.assert_array_equal(got[3], got[2])
        assert np.isnan(got[4])
    assert R.F_dielectric(np.nan, 1.5) != 1.0  # NaN, not total internal reflection
    # a direction on or below the surface is masked (G1 = 0) by every Lambda;
    # GGX's gave the mirrored direction's and Beckmann's 0 (G1 = 1)
    for w in ((0.6, 0.0, -0.8), (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)):
        for d in (R.Blinn(0.3), R.Gaussian(0.3), R.TrowbridgeReitz(0.3), R.Beckmann(0.3)):
            assert d.G1(*w) == 0.0, (d, w)
        assert R.S_smith_1967(*w, 0.3, 0.3) == 0.0, w
    g = R.G_vgroove(np.array([0.5, -0.5, 0.5, 0.5, 0.5]), 0.5, 0.9,
                    np.array([-0.2, 0.5, 0.0, np.nan, 0.95]))
    np.testing.assert_array_equal(g[:3], [1.0, 0.0, 1.0])
    assert np.isnan(g[3]) and 0.0 < g[4] < 1.0


def test_a_colour_is_grey_as_a_scalar_or_a_last_axis_of_one():
    """A scalar colour and a last axis of length 1 are grey; an axis of
    length 3 is RGB, per leading index (what the error above names)."""
    wi = np.array([[0.3, 0.0, 1.0], [0.0, 0.5, 1.0]])
    wo = np.array([0.0, 0.0, 1.0])
    grey = R.shade("lambert", wi, wo, albedo=0.5)
    per_row = R.shade("lambert", wi, wo, albedo=np.array([[0.5], [0.25]]))
    np.testing.assert_array_equal(per_row[0], grey[0])
    np.testing.assert_array_equal(per_row[1], grey[1] * 0.5)
    rgb = R.shade("lambert", wi, wo, albedo=(0.5, 0.25, 0.125))
    np.testing.assert_array_equal(rgb[:, 0], grey[:, 0])
    np.testing.assert_array_equal(rgb[:, 2], grey[:, 2] / 4)


def test_erfc_accuracy():
    x = np.linspace(-4, 6, 1001)
    ref = np.array([math.erfc(v) for v in x])
    np.testing.assert_allclose(R.erfc(x), ref, rtol=1.2e-7)


def test_erfc_is_finite_and_zero_far_out():
    """Beyond x ~ 27 erfc underflows to 0; the split of exp(-x^2) used to
    give 0 times an overflow (NaN) at some x from ~3e6 on, which a narrow
    Beckmann lobe's Lambda reaches near the normal (a = 1/(m tan theta))."""
    x = np.logspace(1.5, 300, 2000)
    assert np.all(R.erfc(x) == 0.0)
    assert R.erfc(np.inf) == 0.0 and R.erfc(-np.inf) == 2.0
    assert R.erfc(27.0) == pytest.approx(math.erfc(27.0), rel=1e-6, abs=0.0)


@pytest.mark.parametrize("shadowing", ["smith", "smith_correlated", "smith_1967"])
def test_a_narrow_beckmann_lobe_is_continuous_at_the_normal(shadowing):
    """Lights ever closer to the normal (sin theta from 1e-4 to 1e-12) under a
    narrow Beckmann lobe (alpha 0.006, seen 1.25 deg off the normal): the
    value converges to the one at the normal, never 0 (it was, where
    Lambda's erfc gave NaN: at some of these lights, a = 1/(m tan theta)
    from ~3e6 on)."""
    wo = np.array([[math.sin(math.radians(1.25)), 0.0, math.cos(math.radians(1.25))]])
    at_normal = R.shade("microfacet", np.array([[0.0, 0.0, 1.0]]), wo, distribution="beckmann",
                        shadowing=shadowing, alpha=0.0062)[0, 0]
    assert at_normal > 50.0
    x = np.logspace(-12.0, -4.0, 400)
    wi = np.stack([x, np.zeros_like(x), np.sqrt(1.0 - x * x)], -1)
    values = R.shade("microfacet", wi, np.broadcast_to(wo, wi.shape), distribution="beckmann",
                     shadowing=shadowing, alpha=0.0062)[:, 0]
    assert values == pytest.approx(np.full_like(x, at_normal), rel=0.05)


def test_no_nan_for_degenerate_directions():
    w = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.6, 0.0, 0.8]])
    for model, params in surface_cases():
        out = R.shade(model, w[:, None, :], w[None, :, :], **params)
        assert np.all(np.isfinite(out)), model


def test_grazing_directions_almost_opposite_stay_finite_and_non_negative():
    """Near grazing with L and E almost opposite, sqrt(2 + 2 L.E) cancelled to
    0 (Blinn-Phong's N.H overflowed to inf), L.H came out negative by rounding
    (V-groove's G, and the pixel, went negative: -1.2e8) and Ward's hz * hz
    and ci * co underflowed (NaN).  The half vector there is the normal."""
    rng = np.random.default_rng(12)
    phi = rng.uniform(0.0, 2 * math.pi, 400)
    zi = 10.0 ** rng.uniform(-14, -2, 400)
    zo = zi * 10.0 ** rng.uniform(-3, 3, 400)
    wi = np.stack([np.cos(phi), np.sin(phi), zi], -1)
    wo = np.stack([-np.cos(phi), -np.sin(phi), zo], -1)
    for model, params in surface_cases():
        for f in (R.shade, R.brdf):
            out = f(model, wi, wo, **params)
            assert np.all(np.isfinite(out)) and np.all(out >= 0.0), (f.__name__, model, params)


@pytest.mark.parametrize("z", [1e-3, 1e-9, 1e-200])
def test_symmetric_grazing_pair_has_the_normal_as_half_vector(z):
    """L = (s, 0, z), E = (-s, 0, z): H = N and L.H = N.L = z, so Blinn-Phong's
    f is ks, V-groove's G is 1 (shade D(N) / (4 z)) and Ward's shade is
    ks / (4 pi ax ay): values from the geometry, not from the code."""
    s = math.sqrt(1.0 - z * z)
    wi, wo = np.array([s, 0.0, z]), np.array([-s, 0.0, z])
    assert R.brdf("blinn_phong", wi, wo, exponent=200.0, ks=0.7)[0] == pytest.approx(0.7)
    ax, ay = 0.3, 0.1
    ward = R.shade("ward", wi, wo, alpha_x=ax, alpha_y=ay)[0]
    assert ward == pytest.approx(1.0 / (4 * math.pi * ax * ay), rel=1e-12)
    if z > 1e-100:  # D(N) / (4 z) overflows nothing down to here
        beta = 20 * DEG
        vg = R.shade("microfacet", wi, wo, distribution="gaussian", shadowing="vgroove",
                     beta=beta)[0]
        d_n = R.Gaussian(beta=beta).D(0.0, 0.0, 1.0)
        assert vg == pytest.approx(d_n / (4 * z), rel=1e-9)


def test_tangent_along_the_normal_falls_back_like_the_shader():
    """Isotropic models ignore the tangent, so a tangent parallel to a per-pixel
    normal must not fail; the fallback matches osl/rm_common.h (x axis, or y
    when the normal is near x)."""
    n = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    wi = np.array([[0.8, 0.6, 0.0], [0.0, 0.6, 0.8]])
    wo = np.array([[0.8, -0.6, 0.0], [0.0, -0.6, 0.8]])
    iso = R.shade("microfacet", wi, wo, normal=n, tangent=(1.0, 0.0, 0.0), distribution="beckmann")
    np.testing.assert_allclose(iso[0], iso[1], rtol=1e-12)  # same geometry, rotated
    aniso = dict(distribution="beckmann", alpha_x=0.1, alpha_y=0.4)
    a = R.shade("microfacet", wi[:1], wo[:1], normal=n[:1], tangent=(1.0, 0.0, 0.0), **aniso)
    b = R.shade("microfacet", wi[:1], wo[:1], normal=n[:1], tangent=(0.0, 1.0, 0.0), **aniso)
    np.testing.assert_allclose(a, b, rtol=1e-12)
