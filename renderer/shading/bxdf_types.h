// The plain types every BxDF shares (renderer/shading/bsdf.h, renderer/shading/layered_bxdf.h): lobe flags,
// the reflection/transmission restriction of sampling, the transport mode and the sample
// record. Conventions as in pbrt-v4 (PBRT 4th ed., section 9.1); see bsdf.h.
#pragma once

#include <cstdint>

#include "sampling/vecmath.h"

namespace tessera {

/// Kinds of lobe; a Bxdf's flags() is a union of these bits.
enum BxdfFlags : uint8_t {
    kBxdfUnset = 0,
    kBxdfReflection = 1,
    kBxdfTransmission = 2,
    kBxdfDiffuse = 4,
    kBxdfGlossy = 8,
    kBxdfSpecular = 16,
};

/// Which half of a BxDF sample_f() may return and pdf() accounts for (pbrt-v4's
/// BxDFReflTransFlags): the layered BSDF's random walk asks an interface for its transmission
/// only when entering or leaving the layers and for its reflection only inside them. With a
/// restriction the remaining lobe is chosen with probability 1 (its pdf is not scaled by the
/// Fresnel split). kReflTransAll is what every caller outside the walk uses.
enum BxdfReflTrans : uint8_t {
    kReflTransReflection = 1,
    kReflTransTransmission = 2,
    kReflTransAll = kReflTransReflection | kReflTransTransmission,
};

/// True for a lobe set that has a perfectly specular lobe (pbrt-v4 IsSpecular).
inline bool is_specular_flags(uint8_t f) {
    return f & kBxdfSpecular;
}
/// True for a lobe set that has a diffuse or glossy lobe (pbrt-v4 IsNonSpecular).
inline bool is_non_specular_flags(uint8_t f) {
    return f & (kBxdfDiffuse | kBxdfGlossy);
}

/// What a path carries: radiance (camera paths) or importance (light paths). Only dielectric
/// transmission differs (the 1/eta^2 radiance scaling applies in Radiance mode only).
enum class TransportMode { Radiance, Importance };

/// The other mode (pbrt-v4's !mode): the adjoint direction, used by the layered BSDF for the
/// path it traces from wi, the light's side.
inline TransportMode flip(TransportMode m) {
    return m == TransportMode::Radiance ? TransportMode::Importance : TransportMode::Radiance;
}

/// Result of sampling a Bsdf. `f` excludes the cosine; `pdf` is per solid angle (or the discrete
/// lobe probability for specular samples); `eta` is the relative IOR of a transmission, else 1.
struct BsdfSample {
    Rgb f;
    Vec3f wi;
    float pdf = 0.f;
    uint8_t flags = kBxdfUnset;
    float eta = 1.f;
    /// True when `pdf` is only proportional to the density of wi (pbrt-v4's pdfIsProportional):
    /// f |cos| / pdf is still the sample's weight, but MIS must ask pdf() for the density. The
    /// layered BSDFs (coateddiffuse, coatedconductor) set it; every other BxDF's pdf is exact.
    bool pdf_is_proportional = false;

    bool is_specular() const { return flags & kBxdfSpecular; }
    bool is_transmission() const { return flags & kBxdfTransmission; }
    bool is_reflection() const { return flags & kBxdfReflection; }
};

}  // namespace tessera
