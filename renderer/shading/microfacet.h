// Microfacet distribution and Fresnel helpers for the BSDFs (renderer/shading/bsdf.h).
//
// All directions are in the local shading frame (z = shading normal) and unit length. The
// conventions follow pbrt-v4 (Pharr, Jakob, Humphreys, "Physically Based Rendering", 4th ed.,
// sections 9.3-9.7): `eta` is the relative index of refraction eta_t / eta_i across an interface
// whose +z side is the outside; a direction with z < 0 is inside.
//
// Everything here is header-only (hot path), pure and thread-safe.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "sampling/vecmath.h"

namespace tessera {

/// Mirror of `wo` about the normal `n` (both pointing away from the surface).
inline Vec3f reflect(Vec3f wo, Vec3f n) {
    return -wo + n * (2.f * dot(wo, n));
}

/// Refracts `wi` (pointing away from the surface) through the interface with normal `n` and
/// relative IOR `eta` (inside over outside, with `n` on the outside). When `wi` lies below `n`
/// the interface is seen from inside, so eta becomes 1/eta and n flips. Returns false on total
/// internal reflection; otherwise writes the transmitted direction `wt` (unit, pointing away on
/// the other side) and `etap`, the relative IOR seen along this crossing. Snell's law in vector
/// form (PBRT 4th ed., eq. 9.4 and section 9.3.2).
inline bool refract(Vec3f wi, Vec3f n, float eta, float *etap, Vec3f *wt) {
    float cos_i = dot(n, wi);
    if (cos_i < 0.f) {
        eta = 1.f / eta;
        cos_i = -cos_i;
        n = -n;
    }
    float sin2_i = std::max(0.f, 1.f - cos_i * cos_i);
    float sin2_t = sin2_i / (eta * eta);
    if (sin2_t >= 1.f)
        return false;
    float cos_t = safe_sqrt(1.f - sin2_t);
    *wt = -wi / eta + n * (cos_i / eta - cos_t);
    if (etap)
        *etap = eta;
    return true;
}

/// Unpolarised Fresnel reflectance of a dielectric interface (Fresnel equations, PBRT eq. 9.6).
/// `cos_i` in [-1, 1] is the cosine to the outside normal (negative: arriving from inside);
/// `eta` = eta_inside / eta_outside. Returns a value in [0, 1]; 1 under total internal reflection.
inline float fr_dielectric(float cos_i, float eta) {
    cos_i = clamp(cos_i, -1.f, 1.f);
    if (cos_i < 0.f) {
        eta = 1.f / eta;
        cos_i = -cos_i;
    }
    float sin2_t = (1.f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.f)
        return 1.f;
    float cos_t = safe_sqrt(1.f - sin2_t);
    float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return clamp(0.5f * (r_parl * r_parl + r_perp * r_perp), 0.f, 1.f);
}

/// Fresnel reflectance of a conductor with complex IOR eta + i k (relative to the outside), for
/// `cos_i` in [0, 1] (clamped). The Fresnel equations of fr_dielectric with a complex eta (PBRT
/// 4th ed., section 9.3.6), written out in real arithmetic: with a^2 + b^2 = |eta^2 - sin^2|
/// (complex modulus) and a = Re sqrt(eta^2 - sin^2),
///   Rs = (a^2 + b^2 + cos^2 - 2 a cos) / (a^2 + b^2 + cos^2 + 2 a cos),
///   Rp = Rs (cos^2 (a^2 + b^2) + sin^4 - 2 a cos sin^2) / (... + 2 a cos sin^2),
/// R = (Rs + Rp) / 2. The same values as the complex form (tests/renderer/test_bsdf.cpp checks
/// them against std::complex<double>), without std::complex<float>'s out-of-line division and
/// square root (libgcc's __divsc3, libm's csqrtf), which took 2 % of a Whitted frame with one
/// conductor. Total internal reflection (k = 0, eta < 1) gives a = 0, i.e. 1. Returns a value in
/// [0, 1].
inline float fr_complex(float cos_i, float eta, float k) {
    cos_i = clamp(cos_i, 0.f, 1.f);
    const float cos2 = cos_i * cos_i, sin2 = 1.f - cos2;
    const float eta2 = eta * eta, k2 = k * k;
    const float t0 = eta2 - k2 - sin2;
    const float a2b2 = std::sqrt(t0 * t0 + 4.f * eta2 * k2);
    const float a = std::sqrt(std::max(0.f, 0.5f * (a2b2 + t0)));
    const float t1 = a2b2 + cos2, t2 = 2.f * cos_i * a;
    const float rs = (t1 - t2) / (t1 + t2);
    const float t3 = cos2 * a2b2 + sin2 * sin2, t4 = t2 * sin2;
    const float rp = rs * (t3 - t4) / (t3 + t4);
    const float r = 0.5f * (rs + rp);
    return std::isfinite(r) ? clamp(r, 0.f, 1.f) : 1.f;
}

/// fr_complex per RGB channel.
inline Rgb fr_complex(float cos_i, Rgb eta, Rgb k) {
    return {fr_complex(cos_i, eta.r, k.r), fr_complex(cos_i, eta.g, k.g),
            fr_complex(cos_i, eta.b, k.b)};
}

/// Anisotropic Trowbridge-Reitz (GGX) microfacet distribution (Trowbridge & Reitz 1975; Walter et
/// al. 2007, "Microfacet Models for Refraction through Rough Surfaces"), with Smith's
/// height-correlated masking-shadowing (Heitz 2014, "Understanding the Masking-Shadowing Function
/// in Microfacet-Based BRDFs") and visible-normal sampling (Heitz 2018, "Sampling the GGX
/// Distribution of Visible Normals", JCGT 7(4)). alpha_x scales along the local x (the shading
/// frame's dpdu direction), alpha_y along y. Plain data; all methods are const and thread-safe.
struct TrowbridgeReitz {
    float alpha_x = 0.f, alpha_y = 0.f;

    TrowbridgeReitz() = default;
    /// Alphas are clamped to >= 1e-4 when the lobe is rough enough to be evaluated, so that the
    /// density stays finite; use effectively_smooth() to choose the specular code path.
    TrowbridgeReitz(float ax, float ay) : alpha_x(ax), alpha_y(ay) {
        if (!effectively_smooth()) {
            alpha_x = std::max(alpha_x, 1e-4f);
            alpha_y = std::max(alpha_y, 1e-4f);
        }
    }

    /// pbrt-v4's roughness remapping ("remaproughness" true): alpha = sqrt(roughness).
    static float roughness_to_alpha(float roughness) { return std::sqrt(std::max(0.f, roughness)); }

    /// True below alpha 1e-3 on both axes: the lobe is treated as a perfect specular one.
    bool effectively_smooth() const { return std::max(alpha_x, alpha_y) < 1e-3f; }

    /// Microfacet normal density D(wm) per unit projected area (PBRT eq. 9.16, anisotropic).
    /// Units: 1/sr. Zero for wm below the horizon.
    /// For a unit wm, cos^4 theta (1 + tan^2 theta (cos^2 phi / ax^2 + sin^2 phi / ay^2))^2 =
    /// (z^2 + x^2 / ax^2 + y^2 / ay^2)^2: the same density without the angles' square roots
    /// and divisions.
    float d(Vec3f wm) const {
        const float z2 = wm.z * wm.z;
        if (!(z2 > 0.f))
            return 0.f;
        const float q = z2 + sqr(wm.x / alpha_x) + sqr(wm.y / alpha_y);
        return 1.f / (kPi * alpha_x * alpha_y * sqr(q));
    }

    /// Smith's auxiliary function Lambda(w) (PBRT eq. 9.22), with alpha^2 tan^2 theta =
    /// (x^2 ax^2 + y^2 ay^2) / z^2 for a unit w; 0 on the horizon, as pbrt-v4 returns there.
    float lambda(Vec3f w) const {
        const float z2 = w.z * w.z;
        const float a2t2 = (sqr(w.x * alpha_x) + sqr(w.y * alpha_y)) / z2;
        if (!(a2t2 < std::numeric_limits<float>::infinity()))
            return 0.f;
        return 0.5f * (std::sqrt(1.f + a2t2) - 1.f);
    }

    /// Smith masking G1(w) = 1 / (1 + Lambda(w)), in [0, 1].
    float g1(Vec3f w) const { return 1.f / (1.f + lambda(w)); }

    /// Height-correlated masking-shadowing G(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)).
    float g(Vec3f wo, Vec3f wi) const { return g(lambda(wo), wi); }

    /// Distribution of normals visible from w: D_w(wm) = G1(w) / |cos w| * D(wm) * <w . wm>
    /// (Heitz 2014, eq. 38; PBRT eq. 9.23), with w mirrored to the +z side when it lies below (the
    /// sampler's symmetric convention) and <.> clamping back-facing normals to zero, so that it
    /// integrates to 1 over the +z hemisphere. Units: 1/sr over wm.
    float d(Vec3f w, Vec3f wm) const { return pdf(w, wm, d(wm), lambda(w)); }

    /// Density (1/sr over wm) with which sample_wm(w, u) returns wm.
    float pdf(Vec3f w, Vec3f wm) const { return d(w, wm); }

    /// d(w, wm) (which calls it) and g(w, wi) from D(wm) and Lambda(w) already at hand: a
    /// sampler that evaluates the density of its microfacet normal and then the BSDF value
    /// computes each once. 1 / (1 + Lambda(w)) is g1(w).
    float pdf(Vec3f w, Vec3f wm, float d_wm, float lambda_w) const {
        float c = abs_cos_theta(w);
        if (c == 0.f)
            return 0.f;
        float w_dot_wm = w.z < 0.f ? -dot(w, wm) : dot(w, wm);
        if (!(w_dot_wm > 0.f))
            return 0.f;
        return 1.f / (1.f + lambda_w) / c * d_wm * w_dot_wm;
    }
    float g(float lambda_wo, Vec3f wi) const { return 1.f / (1.f + lambda_wo + lambda(wi)); }

    /// Samples a visible microfacet normal for direction `w` (either hemisphere; the result
    /// lies in the +z hemisphere). Heitz 2018: stretch w to the alpha = 1 configuration, sample
    /// the projected visible hemisphere as a disk warped toward its visible part, unstretch.
    Vec3f sample_wm(Vec3f w, Vec2f u) const {
        Vec3f wh = normalize(Vec3f(alpha_x * w.x, alpha_y * w.y, w.z));
        if (wh.z < 0.f)
            wh = -wh;
        Vec3f t1 = wh.z < 0.99999f ? normalize(cross(Vec3f(0, 0, 1), wh)) : Vec3f(1, 0, 0);
        Vec3f t2 = cross(wh, t1);
        // Uniform point on the unit disk (polar map; the continuous parametrisation keeps the
        // warp below monotone).
        float r = std::sqrt(u.x), phi = 2.f * kPi * u.y;
        float px = r * std::cos(phi), py = r * std::sin(phi);
        // Warp the lower half-disk so only the visible part of the hemisphere is covered.
        float h = std::sqrt(std::max(0.f, 1.f - px * px));
        float s = 0.5f * (1.f + wh.z);
        py = (1.f - s) * h + s * py;
        float pz = safe_sqrt(1.f - px * px - py * py);
        Vec3f nh = t1 * px + t2 * py + wh * pz;
        return normalize(Vec3f(alpha_x * nh.x, alpha_y * nh.y, std::max(1e-6f, nh.z)));
    }
};

}  // namespace tessera
