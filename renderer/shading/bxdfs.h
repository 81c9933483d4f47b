// The BxDFs of pbrt-v4's basic materials, each in its local shading frame: diffuse,
// diffuse transmission, conductor, dielectric, thin dielectric and hair (their materials and
// parameters: bsdf.h; the layered coats built from them: layered_bxdf.h). Implemented in
// bsdf.cpp and hair.cpp.
//
// Conventions (pbrt-v4, Pharr/Jakob/Humphreys 4th ed., chapter 9):
// - Each Bxdf works in the local shading frame: z is the shading normal, x the dpdu direction
//   (it orients anisotropic roughness). Bsdf wraps a Bxdf with its frame and takes world vectors.
// - wo and wi both point away from the surface; wo is the direction toward the viewer (radiance
//   mode) and wi the direction light arrives from.
// - f() excludes the cosine factor |cos theta_i|; pdf() is per unit solid angle of wi.
// - Delta (specular) lobes are never returned by f()/pdf(); sample_f returns them with
//   f = (Fresnel weight) / |cos theta_i| and pdf = the discrete probability of picking the lobe,
//   so that f |cos| / pdf is the path weight.
// - For transmission through a dielectric in TransportMode::Radiance, f is divided by eta'^2,
//   eta' being the relative IOR along the crossing (radiance is compressed by eta^2 entering a
//   denser medium, PBRT section 9.5.2). BsdfSample::eta returns eta' (1 for reflection).
//
//
// All types are plain values; every method is const, pure and thread-safe.
#pragma once

#include <cstdint>
#include <optional>

#include "renderer/shading/bxdf_types.h"
#include "renderer/shading/microfacet.h"
#include "sampling/vecmath.h"
#include "sampling/warp.h"

namespace tessera {


/// Lambertian reflection f = reflectance / pi in the hemisphere of wo; cosine-weighted sampling.
/// Reflection only: restricted to kReflTransTransmission it samples nothing (pdf 0).
struct DiffuseBxdf {
    Rgb reflectance{0.5f};  ///< hemispherical reflectance in [0, 1] per channel

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode,
                                       BxdfReflTrans lobes = kReflTransAll) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode, BxdfReflTrans lobes = kReflTransAll) const;
    uint8_t flags() const;
};

/// pbrt-v4 "diffusetransmission": Lambertian reflection r / pi on wo's side and Lambertian
/// transmission t / pi on the other (no refraction: eta 1), each sampled cosine-weighted with
/// probability in proportion to the largest channel of r and t (pbrt-v4
/// DiffuseTransmissionBxDF). Thin translucent surfaces: leaves, paper, lampshades.
struct DiffuseTransmissionBxdf {
    Rgb r{0.25f}, t{0.25f};

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode) const;
    uint8_t flags() const;
};

/// Metal: Torrance-Sparrow microfacet reflection (Torrance & Sparrow 1967; Walter et al. 2007)
/// with the GGX distribution and the conductor Fresnel term per RGB channel
/// (f = D(wm) F(wo.wm) G(wo,wi) / (4 cos_o cos_i)); a perfect mirror when effectively smooth.
/// Sampled with visible normals (Heitz 2018). Reflection only, in the hemisphere of wo:
/// restricted to kReflTransTransmission it samples nothing (pdf 0).
struct ConductorBxdf {
    TrowbridgeReitz distrib;
    Rgb eta{1.f};  ///< real part of the IOR relative to the outside medium, per channel
    Rgb k{0.f};    ///< absorption coefficient (imaginary part), per channel

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode,
                                       BxdfReflTrans lobes = kReflTransAll) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode, BxdfReflTrans lobes = kReflTransAll) const;
    uint8_t flags() const;
};

/// pbrt-v4's conversion of an artist "reflectance" to a conductor: with eta = 1,
/// k = 2 sqrt(r) / sqrt(1 - r) gives normal-incidence reflectance r (r clamped to [0, 0.9999]).
Rgb conductor_k_from_reflectance(Rgb r);

/// Glass-like interface with relative IOR eta (inside / outside; the +z side is outside):
/// Fresnel-weighted reflection and refraction, perfectly specular when the distribution is
/// effectively smooth, else the rough GGX model of Walter et al. 2007 with the generalized
/// half vector, visible-normal sampling and a reflect/refract choice with probability R / (R+T)
/// (PBRT 4th ed., section 9.7). eta == 1 means no interface: pure specular pass-through.
/// `lobes` restricts sampling to reflection or transmission (pbrt-v4's BxDFReflTransFlags):
/// the lobe left is then chosen with probability 1 instead of R / (R + T) or T / (R + T), for
/// the smooth and the rough interface alike, and pdf() is that of the restricted sampler.
/// Unrestricted calls (kReflTransAll) compute exactly what they always did.
struct DielectricBxdf {
    float eta = 1.5f;
    TrowbridgeReitz distrib;

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode,
                                       BxdfReflTrans lobes = kReflTransAll) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode, BxdfReflTrans lobes = kReflTransAll) const;
    uint8_t flags() const;
};

/// pbrt-v4 "thindielectric": a thin slab with parallel faces (a window pane). Light either
/// reflects specularly with R' = R + T^2 R / (1 - R^2), summing the inter-reflections inside
/// the slab, or passes straight through (wi = -wo, no refraction, no radiance scaling) with
/// T' = 1 - R' (pbrt-v4 ThinDielectricBxDF). Purely specular.
struct ThinDielectricBxdf {
    float eta = 1.5f;

    Rgb f(Vec3f, Vec3f, TransportMode) const { return Rgb(0.f); }
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    float pdf(Vec3f, Vec3f, TransportMode) const { return 0.f; }
    uint8_t flags() const;
};

/// pbrt-v4 "hair": the scattering model of Chiang, Bitterli, Tappan and Burley 2016 ("A
/// Practical and Controllable Hair and Fur Model for Production Path Tracing"), as pbrt-v4's
/// HairBxDF implements it (PBRT 4th ed., section 9.9), with RGB absorption instead of spectral.
///
/// Local frame: x runs along the fiber (the curve's dpdu), z is the shading normal. A direction
/// w has longitudinal angle theta with sin theta = w.x and azimuth phi = atan2(w.z, w.y).
/// f = sum over p = 0, 1, 2 (R, TT, TRT) of Mp(theta_i, theta_o rotated by the scale tilt
/// -2 alpha, alpha, 4 alpha) Ap(p) Np(phi, p), plus the remaining orders Mp Ap(3) / (2 pi);
/// f includes pbrt's division by |cos theta_i| to the shading normal, so f |wi.z| is the
/// fiber's scattering function. h in [-1, 1] is where the ray met the fiber's width, sigma_a the
/// absorption per unit fiber diameter, beta_m and beta_n the longitudinal and azimuthal
/// roughness in [0, 1], alpha the scale tilt in degrees, eta the fiber's IOR. Sampling picks a
/// lobe in proportion to the channel mean of Ap and samples Mp and the trimmed logistic Np
/// exactly; pdf() is the matching mixture. Flags: glossy reflection, as in pbrt-v4 (the lobes
/// scatter to the whole sphere). Compact (nine floats): the per-lobe constants are derived on
/// use.
struct HairBxdf {
    float h = 0.f;
    float eta = 1.55f;
    Rgb sigma_a{0.f};
    float v0 = 0.f;  ///< longitudinal variance of the R lobe (TT: v0 / 4, TRT and rest: 4 v0)
    float s = 0.f;   ///< azimuthal logistic scale
    float sin_alpha = 0.f, cos_alpha = 1.f;  ///< of the scale tilt

    HairBxdf() : HairBxdf(0.f, 1.55f, Rgb(0.f), 0.3f, 0.3f, 2.f) {}
    /// pbrt-v4 HairBxDF(h, eta, sigma_a, beta_m, beta_n, alpha): h is clamped to [-1, 1] and
    /// the roughnesses to [0, 1].
    HairBxdf(float h, float eta, Rgb sigma_a, float beta_m, float beta_n, float alpha_degrees);

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode) const;
    uint8_t flags() const { return kBxdfReflection | kBxdfGlossy; }

    /// pbrt-v4 SigmaAFromConcentration: absorption of eumelanin and pheomelanin concentrations.
    static Rgb sigma_a_from_concentration(float eumelanin, float pheomelanin);
    /// pbrt-v4 SigmaAFromReflectance: the absorption that gives roughly colour c (in [0, 1])
    /// after multiple scattering in a fiber of azimuthal roughness beta_n.
    static Rgb sigma_a_from_reflectance(Rgb c, float beta_n);
};

}  // namespace tessera
