// Phase functions: the angular scattering distribution of a participating medium, per unit
// solid angle. Used by the layered BSDF's medium between its interfaces (renderer/
// layered_bxdf.h) and written so that a volumetric path tracer can use it as it is.
//
// Conventions (pbrt-v4, PBRT 4th ed., section 11.3): both directions point away from the
// scattering point; wo is the direction the path came from (toward the viewer) and wi the one
// it continues along. Forward scattering therefore means wi close to -wo, and the angle the
// Henyey-Greenstein lobe is written in is that between wo and wi, cos_theta = dot(wo, wi).
// Header-only, pure and thread-safe.
#pragma once

#include <optional>

#include "sampling/vecmath.h"

namespace tessera {

/// The Henyey-Greenstein phase function (Henyey and Greenstein 1941, "Diffuse radiation in the
/// Galaxy") in pbrt-v4's form: p = (1 - g^2) / (4 pi (1 + g^2 + 2 g cos_theta)^(3/2)), with
/// cos_theta = dot(wo, wi) of two directions pointing away (so g > 0 scatters forward, toward
/// wi = -wo). g in (-1, 1): 0 is isotropic. Units: 1/sr; it integrates to 1 over the sphere.
inline float henyey_greenstein(float cos_theta, float g) {
    const float denom = 1.f + g * g + 2.f * g * cos_theta;
    return kInv4Pi * (1.f - g * g) / (denom * safe_sqrt(denom));
}

/// What HgPhaseFunction::sample_p returns: the phase function's value p, the sampled direction
/// wi (unit, pointing away) and its solid-angle density (equal to p: exact importance sampling).
struct PhaseFunctionSample {
    float p = 0.f;
    Vec3f wi;
    float pdf = 0.f;
};

/// pbrt-v4's HGPhaseFunction: Henyey-Greenstein with asymmetry g. Plain value, thread-safe.
struct HgPhaseFunction {
    float g = 0.f;

    /// Value for the pair (both unit, pointing away). Units: 1/sr.
    float p(Vec3f wo, Vec3f wi) const { return henyey_greenstein(dot(wo, wi), g); }
    /// Density with which sample_p returns wi (equal to p where |g| < 0.99).
    float pdf(Vec3f wo, Vec3f wi) const { return p(wo, wi); }

    /// Samples wi from u in [0,1)^2 by inverting the lobe's cumulative distribution in
    /// cos_theta (PBRT 4th ed., section 11.3.1). As pbrt-v4 does, g is clamped to
    /// [-0.99, 0.99] here, where the inversion is still numerically stable; the returned p and
    /// pdf are those of the clamped g. wo must be unit length.
    std::optional<PhaseFunctionSample> sample_p(Vec3f wo, Vec2f u) const {
        const float gc = clamp(g, -0.99f, 0.99f);
        float cos_theta;
        if (std::abs(gc) < 1e-3f) {
            cos_theta = 1.f - 2.f * u.x;
        } else {
            const float s = (1.f - gc * gc) / (1.f + gc - 2.f * gc * u.x);
            cos_theta = -(1.f + gc * gc - s * s) / (2.f * gc);
        }
        cos_theta = clamp(cos_theta, -1.f, 1.f);
        const float sin_theta = safe_sqrt(1.f - cos_theta * cos_theta);
        const Frame frame = Frame::from_z(wo);
        PhaseFunctionSample s;
        s.wi = frame.to_world(spherical_direction(sin_theta, cos_theta, 2.f * kPi * u.y));
        s.pdf = henyey_greenstein(cos_theta, gc);
        s.p = s.pdf;
        if (!(s.pdf > 0.f) || !std::isfinite(s.pdf))
            return std::nullopt;
        return s;
    }
};

}  // namespace tessera
