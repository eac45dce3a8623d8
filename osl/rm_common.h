// SPDX-License-Identifier: GPL-3.0-or-later
// Reflection Models: functions shared by every shader.
//
// Each function mirrors the one of the same name and argument order in
// addon/reference.py, so the two can be read side by side; conventions and
// slide errata are in shared/LECTURE-NOTES.md.  Directions point away from the
// surface; (x, y, z) components are in the local frame (tangent, N x tangent,
// normal).  Float32: where a formula is rearranged for precision it says so.

#ifndef RM_COMMON_H
#define RM_COMMON_H

#include "rm_generated.h"

#define RM_PI 3.14159265358979323846
#define RM_LN2 0.69314718055994530942
#define RM_SQRT_PI 1.77245385090551602730

// Clamp that also maps NaN to the lower limit: bad input renders like the
// range's limit, never as NaN (Cycles drops a closure with a NaN weight).
// Cycles optimises OSL as if no value were NaN: a comparison such as
// !(x >= lo) may send NaN to either limit (measured: the upper one), so NaN
// is tested with isnan(), which is evaluated as written.
float rm_clamp(float x, float lo, float hi)
{
    if (isnan(x))
        return lo;
    if (x < lo)
        return lo;
    if (x > hi)
        return hi;
    return x;
}

color rm_clamp(color c, float lo, float hi)
{
    return color(rm_clamp(c[0], lo, hi), rm_clamp(c[1], lo, hi), rm_clamp(c[2], lo, hi));
}

// The direction of a vector input, unit length; zero when the input is unset:
// zero, or with a NaN or infinite component (comparisons cannot catch NaN,
// see rm_clamp).  Any finite length works: a vector far from unit length is
// first scaled by exact powers of two (so dot() neither overflows nor
// underflows, and the result is bit-identical to that of the unit vector).
// Straight-line code, no loop: OSL's runtime optimiser folds it away for a
// constant input, and a varying one costs a few comparisons.
#define RM_2_60 1152921504606846976.0           // 2^60
#define RM_2_68 295147905179352825856.0         // 2^68
#define RM_2_80 1208925819614629174706176.0     // 2^80
vector rm_direction(vector v)
{
    if (isnan(v[0]) || isnan(v[1]) || isnan(v[2]) || isinf(v[0]) || isinf(v[1]) || isinf(v[2]))
        return vector(0.0);
    float m = max(max(abs(v[0]), abs(v[1])), abs(v[2]));
    if (m == 0.0)
        return vector(0.0);
    vector u = v;
    if (m > RM_2_60)               // m < 2^128: now in (2^-8, 2^60)
        u *= 1.0 / RM_2_68;
    if (m < 1.0 / RM_2_60) {       // m >= 2^-149 (subnormal): at most two steps
        u *= RM_2_80;              // to [2^-60, 2^20)
        if (m * RM_2_80 < 1.0 / RM_2_60)
            u *= RM_2_80;
    }
    return normalize(u);
}

// A point input: unset (use the default) when a component is NaN or infinite.
int rm_finite(point p)
{
    return !(isnan(p[0]) || isnan(p[1]) || isnan(p[2]) || isinf(p[0]) || isinf(p[1]) ||
             isinf(p[2]));
}

// log(1 + x) accurate for small x in float32 (Goldberg 1991, theorem 4).
float rm_log1p(float x)
{
    float u = 1.0 + x;
    if (u == 1.0)
        return x;
    return log(u) * x / (u - 1.0);
}

// Cycles compiles OSL with fast math: measured relative errors of atan2 1.5e-5,
// acos 2.7e-4, asin 1e-3 (sin, cos, sqrt, log: ~1e-7; exp ~4e-6).  The
// Gaussian D amplifies an angle error about 12-fold, so angles are refined by
// one Newton step on g(a) = x sin(a) - y cos(a), whose slope is
// hypot(x, y) cos(a - a*): the error is squared.
float rm_atan2(float y, float x)
{
    float a = atan2(y, x);
    float r = sqrt(x * x + y * y);
    if (r > 0.0)
        a -= (x * sin(a) - y * cos(a)) / r;
    return a;
}

float rm_acos(float c)
{
    float cc = clamp(c, -1.0, 1.0);
    return rm_atan2(sqrt(max(1.0 - cc * cc, 0.0)), cc);
}

// max(0, x)^s with 0^0 = 0 below the cut-off (as reference._lobe).
float rm_lobe(float x, float s)
{
    return (x > 0.0) ? pow(x, s) : 0.0;
}

// ---------------------------------------------------------------------------
// Beta (D(beta) = D(0)/2) and native parameters.  Slide: "Microfacet
// Distribution Functions".
// ---------------------------------------------------------------------------

// Erratum: -ln2 / ln cos(beta); written as 2 ln2 / log1p(tan^2 beta) for float32.
float blinn_exponent_from_beta(float beta)
{
    float t = tan(beta);
    return 2.0 * RM_LN2 / rm_log1p(t * t);
}

// Erratum: sqrt(ln 2)/beta, not sqrt(2)/beta.
float gaussian_c2_from_beta(float beta)
{
    return sqrt(RM_LN2) / beta;
}

// c3^2 = (cos^2 - 1)/(cos^2 - sqrt2) = sin^2 / (sqrt2 - cos^2): no cancellation.
float tr_alpha_from_beta(float beta)
{
    float s = sin(beta);
    float c = cos(beta);
    return sqrt(s * s / (M_SQRT2 - c * c));
}

// m = tan(beta) / sqrt(ln 2 - 4 ln cos beta), with -4 ln cos = 2 log1p(tan^2).
float beckmann_m_from_beta(float beta)
{
    float t = tan(beta);
    return t / sqrt(RM_LN2 + 2.0 * rm_log1p(t * t));
}

float gaussian_alpha_cut(float c2)
{
    return min(0.5 * RM_PI, sqrt(-RM_LOG_D_CUT) / c2);
}

float blinn_alpha_cut(float c)
{
    return rm_acos(exp(RM_LOG_D_CUT / c));
}

// One term of gaussian_norm's quadrature: the node s of [0, 1] maps to the
// tilt a = cut s.
float rm_gaussian_norm_term(float s, float cut, float c2)
{
    float a = cut * s;
    float e = c2 * a;
    return exp(-e * e) * sin(a) * cos(a);
}

// Normalisation of the Gaussian D: no closed form; the reference's 64-point
// Gauss-Legendre rule over [0, cut], written out term by term
// (RM_GL_NORM_SUM) so that OSL folds it to one constant when beta is one.
float gaussian_norm(float beta)
{
    float c2 = gaussian_c2_from_beta(beta);
    float cut = gaussian_alpha_cut(c2);
    float sum = RM_GL_NORM_SUM(rm_gaussian_norm_term, cut, c2);
    return 1.0 / (2.0 * RM_PI * cut * sum);
}

// ---------------------------------------------------------------------------
// Distributions, normalised: int D cos(theta_h) dw_h = 1.
// ---------------------------------------------------------------------------

float rm_tan2(float hx, float hy, float hz)
{
    return (hx * hx + hy * hy) / (hz * hz);
}

float D_blinn(float hx, float hy, float hz, float beta)
{
    float c = blinn_exponent_from_beta(beta);
    return (c + 2.0) / (2.0 * RM_PI) * exp(-0.5 * c * rm_log1p(rm_tan2(hx, hy, hz)));
}

float D_gaussian(float hx, float hy, float hz, float beta)
{
    float alpha = rm_atan2(sqrt(hx * hx + hy * hy), hz);
    float e = gaussian_c2_from_beta(beta) * alpha;
    return gaussian_norm(beta) * exp(-e * e);
}

float D_trowbridge_reitz(float hx, float hy, float hz, float ax, float ay)
{
    float e = (hx / ax) * (hx / ax) + (hy / ay) * (hy / ay) + hz * hz;
    return 1.0 / (RM_PI * ax * ay * e * e);
}

float D_beckmann(float hx, float hy, float hz, float ax, float ay)
{
    float hz2 = hz * hz;
    float e = ((hx / ax) * (hx / ax) + (hy / ay) * (hy / ay)) / hz2;
    return exp(-e) / (RM_PI * ax * ay * hz2 * hz2);
}

// ---------------------------------------------------------------------------
// Smith Lambda.  Slide: "Self-Shadowing Function".
// ---------------------------------------------------------------------------

float Lambda_trowbridge_reitz(float wx, float wy, float wz, float ax, float ay)
{
    float a2t2 = ((wx * ax) * (wx * ax) + (wy * ay) * (wy * ay)) / (wz * wz);
    return 0.5 * (sqrt(1.0 + a2t2) - 1.0);
}

float Lambda_beckmann(float wx, float wy, float wz, float ax, float ay)
{
    float r = sqrt((wx * ax) * (wx * ax) + (wy * ay) * (wy * ay));
    if (r <= 0.0)
        return 0.0;
    float a = wz / r;
    return max(0.5 * (exp(-a * a) / (a * RM_SQRT_PI) - erfc(a)), 0.0);
}

float S_smith_1967(float wx, float wy, float wz, float ax, float ay)
{
    float r = sqrt((wx * ax) * (wx * ax) + (wy * ay) * (wy * ay));
    float bracket = (r > 0.0) ? 1.0 - 0.5 * erfc(wz / r) : 1.0;
    return bracket / (1.0 + Lambda_beckmann(wx, wy, wz, ax, ay));
}

// Lambda of Blinn or Gaussian: no closed form; the Chebyshev series of the
// reference's quadrature (rm_generated.h, from reference.lambda_chebyshev),
// in x = (2/pi) atan(a), a = cot(theta)/m with m Beckmann's m of the same
// beta: Lambda = g(beta, x) / a.  k holds the series' coefficients in x for
// this beta (rm_lambda_chebyshev_coeffs), m = beckmann_m_from_beta(beta).
float rm_lambda_chebyshev_x(float wx, float wy, float wz, float m, rm_cheb_x k)
{
    if (wz <= 0.0)
        return 1e30;
    float rm = sqrt(wx * wx + wy * wy) * m;
    if (rm <= 0.0)
        return 0.0;  // normal incidence: no back-facing facets
    float x = rm_atan2(wz, rm) * (2.0 / RM_PI);
    return rm_lambda_chebyshev_g(k, 2.0 * clamp(x, 0.0, 1.0) - 1.0) * rm / wz;
}

// The same for one direction; beta must lie in the catalogue's range.
float Lambda_chebyshev(float wx, float wy, float wz, float beta, int distribution)
{
    rm_cheb_x k;
    rm_lambda_chebyshev_coeffs(distribution, beta, k);
    return rm_lambda_chebyshev_x(wx, wy, wz, beckmann_m_from_beta(beta), k);
}

// V-groove: min(1, 2(N.H)(N.E)/(E.H), 2(N.H)(N.L)/(L.H)); E.H = L.H.
float G_vgroove(float ci, float co, float ch, float cih)
{
    return min(1.0, 2.0 * ch * min(ci, co) / cih);
}

// ---------------------------------------------------------------------------
// Fresnel (exact, unpolarised).
// ---------------------------------------------------------------------------

float F_dielectric(float c, float ior)
{
    float g2 = ior * ior - 1.0 + c * c;
    if (g2 <= 0.0)
        return 1.0;  // total internal reflection
    float g = sqrt(g2);
    float a = (g - c) / (g + c);
    float b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * a * a * (1.0 + b * b);
}

float F_conductor(float c, float n, float k)
{
    float c2 = c * c;
    float s2 = 1.0 - c2;
    float t0 = n * n - k * k - s2;
    float ab2 = sqrt(t0 * t0 + 4.0 * n * n * k * k);
    float a = sqrt(max(0.5 * (ab2 + t0), 0.0));
    float two_ac = 2.0 * a * c;
    float rs = (ab2 - two_ac + c2) / (ab2 + two_ac + c2);
    float pu = c2 * ab2 + s2 * s2;
    float pv = two_ac * s2;
    float rp = rs * (pu - pv) / (pu + pv);
    return 0.5 * (rs + rp);
}

color F_dielectric(float c, color ior)
{
    return color(F_dielectric(c, ior[0]), F_dielectric(c, ior[1]), F_dielectric(c, ior[2]));
}

color F_conductor(float c, color n, color k)
{
    return color(F_conductor(c, n[0], k[0]), F_conductor(c, n[1], k[1]),
                 F_conductor(c, n[2], k[2]));
}

// ---------------------------------------------------------------------------
// Shading frame and light, shared by every model shader.
// ---------------------------------------------------------------------------

// Inputs every model shader has besides its parameters (names = catalogue
// LIGHT_INPUTS and GEOMETRY_INPUTS; default_tangent comes from the group's
// Tangent node).  Defaults are constants so unconnected sockets pass values.
#define RM_GEOMETRY_PARAMS                                                    \
    normal shading_normal = normal(0.0),                                      \
    vector tangent = vector(0.0),                                             \
    float tangent_rotation = 0.0,                                             \
    vector default_tangent = vector(0.0)

#define RM_GEOMETRY_ARGS shading_normal, tangent, tangent_rotation, default_tangent

#define RM_LIGHT_GEOMETRY_PARAMS                                              \
    float point_light = 0.0,                                                  \
    vector light_direction = vector(0.0, 0.0, 1.0),                           \
    point light_position = point(0.0, 0.0, 5.0),                              \
    float light_strength = 1.0,                                               \
    color light_color = color(1.0),                                           \
    float shadows = 1.0,                                                      \
    RM_GEOMETRY_PARAMS

#define RM_LIGHT_GEOMETRY_ARGS                                                \
    point_light, light_direction, light_position, light_strength, light_color, \
    shadows, RM_GEOMETRY_ARGS

// The local frame: the normal n, the tangent t (projected on the surface and
// rotated about n) and b = n x t.
// The shading normal: the input when set, else the surface normal N.
vector rm_normal(normal shading_normal)
{
    vector n = rm_direction(shading_normal);
    return (dot(n, n) == 0.0) ? N : n;
}

// The default tangent: what the node group links to default_tangent, Cycles'
// UV tangent, finite and unit or zero (no UV map).  Not a user's input, so it
// skips rm_direction's checks (measured: 0.9 % of a path-traced Ward render).
vector rm_default_direction(vector v)
{
    return (dot(v, v) > 0.0) ? normalize(v) : vector(0.0);
}

void rm_frame(normal shading_normal, vector tangent, float tangent_rotation,
              vector default_tangent, output vector n, output vector t, output vector b)
{
    n = rm_normal(shading_normal);

    vector tt = rm_direction(tangent);
    if (dot(tt, tt) == 0.0)
        tt = rm_default_direction(default_tangent);
    tt = tt - dot(tt, n) * n;
    if (dot(tt, tt) < 1e-12) {  // no tangent, or along the normal: any perpendicular
        vector axis = (abs(n[0]) < 0.9) ? vector(1.0, 0.0, 0.0) : vector(0.0, 1.0, 0.0);
        tt = axis - dot(axis, n) * n;
    }
    tt = normalize(tt);
    float r = rm_clamp(tangent_rotation, RM_COMMON_TANGENT_ROTATION_MIN,
                       RM_COMMON_TANGENT_ROTATION_MAX);
    t = tt;
    if (r != 0.0)  // a branch on a constant folds away; 0 * x does not
        t = cos(r) * tt + sin(r) * cross(n, tt);
    b = cross(n, t);
}

// The local frame (t, b, n), the view (wo) and light (wi) directions, and the light's
// irradiance E (colour; zero in shadow) at P.
void rm_begin(float point_light, vector light_direction, point light_position,
              float light_strength, color light_color, float shadows,
              normal shading_normal, vector tangent, float tangent_rotation,
              vector default_tangent,
              output vector n, output vector t, output vector b, output vector wo,
              output vector wi, output color E)
{
    rm_frame(shading_normal, tangent, tangent_rotation, default_tangent, n, t, b);
    wo = normalize(I);  // In Cycles OSL, I points toward the viewer.

    float strength = rm_clamp(light_strength, RM_COMMON_LIGHT_STRENGTH_MIN,
                              RM_COMMON_LIGHT_STRENGTH_MAX);
    float maxdist = 1e30;
    if (rm_clamp(point_light, 0.0, 1.0) >= 0.5) {
        point lp = rm_finite(light_position) ? light_position : point(0.0, 0.0, 5.0);
        vector d = lp - P;
        float d2 = max(dot(d, d), 1e-12);
        maxdist = sqrt(d2);
        wi = d / maxdist;
        strength /= d2;
    }
    else {
        wi = rm_direction(light_direction);
        if (dot(wi, wi) == 0.0)
            wi = vector(0.0, 0.0, 1.0);
    }
    float visible = 1.0;
    float sh = rm_clamp(shadows, RM_COMMON_SHADOWS_MIN, RM_COMMON_SHADOWS_MAX);
    if (sh > 0.0 && trace(P, wi, "mindist", 1e-5, "maxdist", maxdist))
        visible = 1.0 - sh;
    E = strength * visible * rm_clamp(light_color, RM_COMMON_LIGHT_COLOR_MIN,
                                      RM_COMMON_LIGHT_COLOR_MAX);
}

vector rm_local(vector w, vector t, vector b, vector n)
{
    return vector(dot(w, t), dot(w, b), dot(w, n));
}

// The fibre direction of Kajiya-Kay: the tangent as given (not projected on a
// surface), else the default tangent, else the frame's t; rotated about n
// (Rodrigues), keeping the fibre's tilt out of the surface.
vector rm_fibre_tangent(vector tangent, vector default_tangent, float tangent_rotation,
                        vector n, vector t)
{
    vector tf = rm_direction(tangent);
    if (dot(tf, tf) == 0.0)
        tf = rm_default_direction(default_tangent);
    if (dot(tf, tf) == 0.0)
        tf = t;
    float r = rm_clamp(tangent_rotation, RM_COMMON_TANGENT_ROTATION_MIN,
                       RM_COMMON_TANGENT_ROTATION_MAX);
    if (r == 0.0)
        return tf;
    return cos(r) * tf + sin(r) * cross(n, tf) + (1.0 - cos(r)) * dot(n, tf) * n;
}

// Native widths (ax, ay) of the microfacet shader from its width inputs:
// converted from beta when width_mode is RM_WIDTH_BETA (Blinn and Gaussian
// get the Beckmann m of the same beta: the closure's stand-in).
void rm_microfacet_widths(int distribution, int width_mode, float beta, float alpha,
                          float alpha_x, float alpha_y, output float ax, output float ay)
{
    int native = (distribution == RM_DISTRIBUTION_TROWBRIDGE_REITZ ||
                  distribution == RM_DISTRIBUTION_BECKMANN);
    float bt = rm_clamp(beta, RM_MICROFACET_BETA_MIN, RM_MICROFACET_BETA_MAX);
    if (native && width_mode == RM_WIDTH_ALPHA) {
        ax = rm_clamp(alpha, RM_MICROFACET_ALPHA_MIN, RM_MICROFACET_ALPHA_MAX);
        ay = ax;
    }
    else if (native && width_mode == RM_WIDTH_ALPHA_XY) {
        ax = rm_clamp(alpha_x, RM_MICROFACET_ALPHA_X_MIN, RM_MICROFACET_ALPHA_X_MAX);
        ay = rm_clamp(alpha_y, RM_MICROFACET_ALPHA_Y_MIN, RM_MICROFACET_ALPHA_Y_MAX);
    }
    else if (distribution == RM_DISTRIBUTION_TROWBRIDGE_REITZ) {
        ax = tr_alpha_from_beta(bt);
        ay = ax;
    }
    else {
        ax = beckmann_m_from_beta(bt);
        ay = ax;
    }
}

// Cycles' closure distribution names: only these two exist; any other string
// silently renders GGX, so the shaders never build one from user input.
string rm_closure_distribution(int distribution)
{
    return (distribution == RM_DISTRIBUTION_TROWBRIDGE_REITZ) ? "ggx" : "beckmann";
}

#endif  // RM_COMMON_H
