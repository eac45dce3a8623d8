// SPDX-License-Identifier: GPL-3.0-or-later
// Reflection Models: the operations of the formula graphs, for OSL.
//
// The shaders rm_<model>.osl and rm_<model>_bsdf.osl are generated from the
// formula description (addon/core/formulas) by addon/backends/osl/generate.py;
// this header gives the graphs' operations the semantics every backend shares
// (those of Cycles' SVM Math node, see addon/core/formulas/expr.py):
// division by zero gives 0, the square root and the logarithm of a value out
// of their domain give 0, inputs are clamped with NaN going to the lower
// limit.  Cycles optimises OSL as if no value were NaN: a comparison such as
// !(x >= lo) may send NaN either way, so NaN is tested with isnan(), which
// is evaluated as written.

#ifndef RM_LIBRARY_H
#define RM_LIBRARY_H

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

// Linear interpolation between values at evenly spaced knots over [0, 1]
float rm_table(float v[], float t)
{
    int last = arraylength(v) - 1;
    float u = clamp(t, 0.0, 1.0) * last;
    int j = min((int)floor(u), last - 1);
    float f = u - j;
    return v[j] + f * (v[j + 1] - v[j]);
}

float rm_finite(float x)
{
    return (isnan(x) || isinf(x)) ? 0.0 : 1.0;
}

float rm_div(float a, float b)
{
    return (b != 0.0) ? a / b : 0.0;
}

vector rm_div(vector a, vector b)
{
    return vector(rm_div(a[0], b[0]), rm_div(a[1], b[1]), rm_div(a[2], b[2]));
}

float rm_sqrt(float x)
{
    return (x > 0.0) ? sqrt(x) : 0.0;
}

float rm_log(float x)
{
    return (x > 0.0) ? log(x) : 0.0;
}

// Cycles' safe_powf: x^0 = 1 (0^0 too), 0^y = 0, a negative x with a
// non-integer y gives 0.
float rm_pow(float x, float y)
{
    if (y == 0.0)
        return 1.0;
    if (x == 0.0)
        return 0.0;
    if (x < 0.0 && y != floor(y))
        return 0.0;
    return pow(x, y);
}

vector rm_normalize(vector v)
{
    float l = length(v);
    return (l != 0.0) ? v / l : vector(0.0);
}

// In Cycles OSL, I points toward the viewer (the OSL specification says
// the opposite).
vector rm_view()
{
    return normalize(I);
}

// Cycles' phong_ramp with a white ramp: (s+2)/(2 pi) cos^s(R.L) (N.L).
closure color rm_phong_ramp(vector n, float exponent)
{
    color ramp[8] = {color(1.0), color(1.0), color(1.0), color(1.0),
                     color(1.0), color(1.0), color(1.0), color(1.0)};
    return phong_ramp(n, exponent, ramp);
}

#endif  // RM_LIBRARY_H
