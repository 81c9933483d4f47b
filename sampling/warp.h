// Warps from the unit square to common domains, with their densities.
//
// Each warp maps a canonical sample u in [0,1)^2 to a point on its domain; the matching `*_pdf`
// gives the density with respect to that domain's measure (area or solid angle).
// Every warp has a chi-square test in tests/sampling/test_warp_stat.cpp.
#pragma once

#include "sampling/vecmath.h"

namespace tessera::sampling {

/// sin and cos of x for |x| <= pi/4 (Taylor polynomials to x^9 and x^8: error below 3e-8,
/// under half a float ulp of 1). The concentric map only needs this range, and libm's sincosf
/// with its range reduction showed up at ~2% of a render profile.
inline Vec2f sincos_quarter_pi(float x) {
    float x2 = x * x;
    float s =
        x * (1.f + x2 * (-1.f / 6 + x2 * (1.f / 120 + x2 * (-1.f / 5040 + x2 * (1.f / 362880)))));
    float c = 1.f + x2 * (-0.5f + x2 * (1.f / 24 + x2 * (-1.f / 720 + x2 * (1.f / 40320))));
    return {s, c};
}

/// Concentric map of the square onto the unit disk (Shirley & Chiu 1997). Density 1/pi.
inline Vec2f square_to_disk_concentric(Vec2f u) {
    float ox = 2.f * u.x - 1.f, oy = 2.f * u.y - 1.f;
    if (ox == 0.f && oy == 0.f)
        return {0.f, 0.f};
    if (std::abs(ox) > std::abs(oy)) {
        // theta = pi/4 (oy / ox) in [-pi/4, pi/4].
        Vec2f sc = sincos_quarter_pi(kPiOver4 * (oy / ox));
        return {ox * sc.y, ox * sc.x};
    }
    // theta = pi/2 - a with a = pi/4 (ox / oy): cos(theta) = sin(a), sin(theta) = cos(a).
    Vec2f sc = sincos_quarter_pi(kPiOver4 * (ox / oy));
    return {oy * sc.x, oy * sc.y};
}

/// Cosine-weighted hemisphere around +z (Malley's method). Density cos(theta)/pi per steradian.
inline Vec3f square_to_cosine_hemisphere(Vec2f u) {
    Vec2f d = square_to_disk_concentric(u);
    float z = safe_sqrt(1.f - d.x * d.x - d.y * d.y);
    return {d.x, d.y, z};
}
inline float cosine_hemisphere_pdf(float cos_theta_) { return cos_theta_ * kInvPi; }

/// Uniform direction on the unit sphere. Density 1/(4 pi).
inline Vec3f square_to_uniform_sphere(Vec2f u) {
    float z = 1.f - 2.f * u.x;
    float r = safe_sqrt(1.f - z * z);
    float phi = 2.f * kPi * u.y;
    return {r * std::cos(phi), r * std::sin(phi), z};
}
inline constexpr float uniform_sphere_pdf() { return kInv4Pi; }

/// Uniform direction on the +z hemisphere. Density 1/(2 pi).
inline Vec3f square_to_uniform_hemisphere(Vec2f u) {
    float z = u.x;
    float r = safe_sqrt(1.f - z * z);
    float phi = 2.f * kPi * u.y;
    return {r * std::cos(phi), r * std::sin(phi), z};
}
inline constexpr float uniform_hemisphere_pdf() { return kInv2Pi; }

/// Uniform direction in the cone around +z with cos(half-angle) = cos_max. Density 1/(2 pi (1-cos_max)).
inline Vec3f square_to_uniform_cone(Vec2f u, float cos_max) {
    float cos_t = (1.f - u.x) + u.x * cos_max;
    float sin_t = safe_sqrt(1.f - cos_t * cos_t);
    float phi = u.y * 2.f * kPi;
    return spherical_direction(sin_t, cos_t, phi);
}
inline float uniform_cone_pdf(float cos_max) { return 1.f / (2.f * kPi * (1.f - cos_max)); }

/// Uniform barycentrics (b0, b1) on a triangle (Heitz 2019 low-distortion map); b2 = 1-b0-b1.
inline Vec2f square_to_uniform_triangle(Vec2f u) {
    float b0, b1;
    if (u.x < u.y) {
        b0 = u.x / 2.f;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.f;
        b0 = u.x - b1;
    }
    return {b0, b1};
}

/// Samples a tent (triangle) filter of radius r: density (r - |x|)/r^2 on [-r, r].
inline float sample_tent(float u, float r) {
    if (u < 0.5f) {
        float v = u * 2.f;  // in [0,1)
        return -r + r * std::sqrt(v);
    }
    float v = (u - 0.5f) * 2.f;
    return r - r * std::sqrt(1.f - v);
}

}  // namespace tessera::sampling
