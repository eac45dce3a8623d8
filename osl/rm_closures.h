// SPDX-License-Identifier: GPL-3.0-or-later
// Reflection Models: the path-traced closure of each model.
//
// Used by the model shaders (their BSDF output) and by the closure-only
// shaders rm_<model>_bsdf.osl, which the node groups wire to their BSDF
// output: a path-traced material then compiles only the closure, not the
// exact evaluation and its shadow ray.  Each function clamps its inputs.
// Which closures are the model exactly and which are approximations is said
// in each function's comment and measured in docs/verification.md.

#ifndef RM_CLOSURES_H
#define RM_CLOSURES_H

#include "rm_common.h"

// Exact: diffuse() is Lambert.
closure color lambert_bsdf(vector n, color albedo)
{
    return rm_clamp(albedo, RM_LAMBERT_ALBEDO_MIN, RM_LAMBERT_ALBEDO_MAX) * diffuse(n);
}

// Exact: phong_ramp() is (s+2)/(2 pi) cos^s (Lafortune's normalisation); a
// constant weight gives the lecture's form or the (s+1)/(2 pi) one.
closure color phong_bsdf(vector n, float exponent, color ks, int normalization)
{
    float s = rm_clamp(exponent, RM_PHONG_EXPONENT_MIN, RM_PHONG_EXPONENT_MAX);
    color k = rm_clamp(ks, RM_PHONG_KS_MIN, RM_PHONG_KS_MAX);
    float norm = (normalization == RM_NORMALIZATION_ENERGY) ? (s + 1.0) / (2.0 * RM_PI) : 1.0;
    color ramp[8] = {color(1.0), color(1.0), color(1.0), color(1.0),
                     color(1.0), color(1.0), color(1.0), color(1.0)};
    return (k * (norm * 2.0 * RM_PI / (s + 2.0))) * phong_ramp(n, s, ramp);
}

// APPROXIMATION: Cycles has no Blinn lobe.  GGX at the same half-angle beta
// (cos^s beta = 1/2), weighted to agree at normal incidence.
closure color blinn_phong_bsdf(vector n, vector t, float exponent, color ks, int normalization)
{
    float s = rm_clamp(exponent, RM_BLINN_PHONG_EXPONENT_MIN, RM_BLINN_PHONG_EXPONENT_MAX);
    color k = rm_clamp(ks, RM_BLINN_PHONG_KS_MIN, RM_BLINN_PHONG_KS_MAX);
    float norm = (normalization == RM_NORMALIZATION_ENERGY) ? (s + 8.0) / (8.0 * RM_PI) : 1.0;
    // beta with cos^s(beta) = 1/2, kept inside the microfacet range.
    float beta = (s > 0.0) ? rm_acos(exp(-RM_LN2 / s)) : RM_MICROFACET_BETA_MAX;
    beta = clamp(beta, RM_MICROFACET_BETA_MIN, RM_MICROFACET_BETA_MAX);
    float a = tr_alpha_from_beta(beta);
    // GGX at N = L = E: D(0) G / 4 = 1 / (4 pi a^2); Blinn-Phong there: norm.
    return (k * (norm * 4.0 * RM_PI * a * a)) * microfacet("ggx", n, t, a, a, 0.0, 0);
}

// APPROXIMATION: ward() is declared but renders black in Cycles; the
// anisotropic Beckmann microfacet with the same (ax, ay) stands in.
closure color ward_bsdf(vector n, vector t, float alpha_x, float alpha_y, color ks)
{
    float ax = rm_clamp(alpha_x, RM_WARD_ALPHA_X_MIN, RM_WARD_ALPHA_X_MAX);
    float ay = rm_clamp(alpha_y, RM_WARD_ALPHA_Y_MIN, RM_WARD_ALPHA_Y_MAX);
    color k = rm_clamp(ks, RM_WARD_KS_MIN, RM_WARD_KS_MAX);
    return k * microfacet("beckmann", n, t, min(ax, 1.0), min(ay, 1.0), 0.0, 0);
}

// APPROXIMATION: no Kajiya-Kay closure; Lambert for the diffuse part plus
// Cycles' own hair_reflection lobe around the same fibre direction tf.
closure color kajiya_kay_bsdf(vector n, vector tf, color kd, color ks, float exponent)
{
    color d = rm_clamp(kd, RM_KAJIYA_KAY_KD_MIN, RM_KAJIYA_KAY_KD_MAX);
    color k = rm_clamp(ks, RM_KAJIYA_KAY_KS_MIN, RM_KAJIYA_KAY_KS_MAX);
    float s = rm_clamp(exponent, RM_KAJIYA_KAY_EXPONENT_MIN, RM_KAJIYA_KAY_EXPONENT_MAX);
    float rough = clamp(sqrt(2.0 / (s + 2.0)), 0.001, 1.0);
    return (d * RM_PI) * diffuse(n) + k * hair_reflection(n, rough, rough, tf, 0.0);
}

// Cycles' microfacet closures use height-correlated Smith and clamp alpha to
// [0, 1].  Exact: Trowbridge-Reitz + smith_correlated (any Fresnel in 5.2;
// dielectric or none in 4.5).  Beckmann + smith_correlated differs by
// Walter's rational Lambda (< 1 %).  Everything else (Blinn and Gaussian as
// Beckmann at the same beta; separable Smith, V-groove, 1967 bracket, no
// shadowing; alpha > 1) is an APPROXIMATION.
closure color microfacet_bsdf(vector n, vector t, int distribution, int fresnel,
                              int width_mode, float beta, float alpha, float alpha_x,
                              float alpha_y, color ior, color k, color ks)
{
    float ax, ay;
    rm_microfacet_widths(distribution, width_mode, beta, alpha, alpha_x, alpha_y, ax, ay);
    color kk = rm_clamp(ks, RM_MICROFACET_KS_MIN, RM_MICROFACET_KS_MAX);
    color eta = rm_clamp(ior, RM_MICROFACET_IOR_MIN, RM_MICROFACET_IOR_MAX);
    color kap = rm_clamp(k, RM_MICROFACET_K_MIN, RM_MICROFACET_K_MAX);
    string dist = rm_closure_distribution(distribution);
    if (fresnel == RM_FRESNEL_CONDUCTOR)
        return kk * conductor_bsdf(n, t, ax, ay, eta, kap, dist);
    if (fresnel == RM_FRESNEL_DIELECTRIC) {
        if (eta[0] == eta[1] && eta[1] == eta[2])
            return kk * dielectric_bsdf(n, t, color(1.0), color(0.0), ax, ay, eta[0], dist);
        // a different index per channel: one closure per channel
        return (kk * color(1, 0, 0)) * dielectric_bsdf(n, t, color(1.0), color(0.0), ax, ay, eta[0], dist)
             + (kk * color(0, 1, 0)) * dielectric_bsdf(n, t, color(1.0), color(0.0), ax, ay, eta[1], dist)
             + (kk * color(0, 0, 1)) * dielectric_bsdf(n, t, color(1.0), color(0.0), ax, ay, eta[2], dist);
    }
    return kk * microfacet(dist, n, t, ax, ay, 0.0, 0);
}

#endif  // RM_CLOSURES_H
