// BSDFs: the scattering models behind pbrt-v4's "diffuse", "diffusetransmission", "conductor",
// "dielectric", "thindielectric", "coateddiffuse", "coatedconductor" and "hair" materials, in
// RGB.
//
// The conventions of every Bxdf: bxdfs.h.
//
// pbrt-v4 material parameters and defaults (checked in pbrt-v4 src/pbrt/materials.{h,cpp}) and
// how they map here; the material layer does the texture lookups and the mapping:
//   "diffuse":      "spectrum reflectance" 0.5                 -> DiffuseBxdf{reflectance}
//   "conductor":    "spectrum eta" metal-Cu-eta, "spectrum k" metal-Cu-k, or instead
//                   "spectrum reflectance" r (then eta = 1, k = conductor_k_from_reflectance(r));
//                   "float roughness" 0, "uroughness"/"vroughness" (default: roughness),
//                   "bool remaproughness" true (alpha = roughness_to_alpha(roughness))
//                                                              -> ConductorBxdf
//   "dielectric":   "float eta" 1.5 (or a spectrum; RGB here uses one value),
//                   "float roughness" 0, "uroughness"/"vroughness", "bool remaproughness" true
//                                                              -> DielectricBxdf
//   "coateddiffuse":"spectrum reflectance" 0.5, "float roughness" 0, "uroughness"/"vroughness",
//                   "float thickness" 0.01, "float eta" 1.5 (0 means 1), "spectrum albedo" 0,
//                   "float g" 0 (clamped to [-1, 1]), "integer maxdepth" 10,
//                   "integer nsamples" 1, "bool remaproughness" true
//                                     -> CoatedDiffuseBxdf (LayeredBxdf: dielectric over diffuse)
//   "coatedconductor": "float interface.eta" 1.5 (0 means 1), "interface.roughness" 0,
//                   "interface.uroughness"/"interface.vroughness"; "spectrum conductor.eta"
//                   metal-Cu-eta and "conductor.k" metal-Cu-k, or "spectrum reflectance" r
//                   (eta 1, k as for "conductor"), both divided by the interface's eta;
//                   "conductor.roughness" 0, "conductor.uroughness"/"conductor.vroughness";
//                   "float thickness" 0.01, "spectrum albedo" 0, "float g" 0, "integer
//                   maxdepth" 10, "integer nsamples" 1, "bool remaproughness" true
//                                  -> CoatedConductorBxdf (LayeredBxdf: dielectric over metal)
// Both coated materials are pbrt-v4's stochastic layered BSDF (renderer/shading/layered_bxdf.h): f()
// and pdf() are Monte Carlo estimates, deterministic for given directions, and sample_f's pdf
// is only proportional to the density (BsdfSample::pdf_is_proportional).
// Roughness is remapped with alpha = sqrt(roughness) when remaproughness is true, else used as
// alpha directly. Alphas below 1e-3 give the specular (delta) code paths.
//
// All types are plain values; every method is const, pure and thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <variant>

#include "renderer/shading/bxdfs.h"
#include "renderer/shading/layered_bxdf.h"
#include "sampling/vecmath.h"
#include "sampling/warp.h"

namespace tessera {

/// pbrt-v4 "coateddiffuse" (CoatedDiffuseBxDF): a dielectric coat (DielectricBxdf, its IOR and
/// GGX roughness) over a Lambertian base (DiffuseBxdf), a slab of medium between them,
/// evaluated by pbrt-v4's random walk (LayeredBxdf, renderer/shading/layered_bxdf.h). Two-sided.
using CoatedDiffuseBxdf = LayeredBxdf<DielectricBxdf, DiffuseBxdf, true>;
/// pbrt-v4 "coatedconductor" (CoatedConductorBxDF): a dielectric coat over a conductor whose
/// eta and k are relative to the coat (the material divides them by the coat's IOR), likewise.
using CoatedConductorBxdf = LayeredBxdf<DielectricBxdf, ConductorBxdf, true>;
extern template struct LayeredBxdf<DielectricBxdf, DiffuseBxdf, true>;
extern template struct LayeredBxdf<DielectricBxdf, ConductorBxdf, true>;

/// A Lambertian BSDF with its shading frame, in world space: what Bsdf does for a DiffuseBxdf,
/// without the variant. Equal to the generic DiffuseBxdf code (which normalises the local
/// directions) up to rounding: only the sign of cos theta matters for f and for wo. A black
/// reflectance scatters nothing (DiffuseBxdf::flags() is then kBxdfUnset). Plain value.
struct LambertianBsdf {
    Frame shading;  ///< z: the shading normal
    Rgb reflectance;

    const Frame &frame() const { return shading; }
    bool has_non_specular() const { return !reflectance.is_black(); }
    Rgb albedo_hint() const { return reflectance; }
    Rgb f_pdf(Vec3f wo_world, Vec3f wi_world, float *pdf_out) const {
        *pdf_out = pdf(wo_world, wi_world);
        return f(wo_world, wi_world);
    }
    /// `uc` is unused (one lobe); the signature matches Bsdf::sample_f.
    std::optional<BsdfSample> sample_f(Vec3f wo_world, float /*uc*/, Vec2f u) const {
        return sample_f(wo_world, u);
    }

    Rgb f(Vec3f wo_world, Vec3f wi_world) const {
        float co = dot(wo_world, shading.z), ci = dot(wi_world, shading.z);
        if (!(co * ci > 0.f)) return {};
        Rgb r = reflectance * kInvPi;
        return r.is_finite() ? r : Rgb();
    }
    float pdf(Vec3f wo_world, Vec3f wi_world) const {
        float co = dot(wo_world, shading.z), ci = dot(wi_world, shading.z);
        if (!(co * ci > 0.f)) return 0.f;
        float l2 = length_squared(wi_world);
        if (!(std::abs(l2 - 1.f) < 1e-6f)) ci /= std::sqrt(l2);
        float p = sampling::cosine_hemisphere_pdf(std::abs(ci));
        return std::isfinite(p) ? p : 0.f;
    }
    std::optional<BsdfSample> sample_f(Vec3f wo_world, Vec2f u) const {
        float co = dot(wo_world, shading.z);
        if (co == 0.f || std::isnan(co) || reflectance.is_black()) return std::nullopt;
        Vec3f wi = sampling::square_to_cosine_hemisphere(u);
        if (co < 0.f) wi.z = -wi.z;
        float pdf = sampling::cosine_hemisphere_pdf(std::abs(wi.z));
        Rgb f = reflectance * kInvPi;
        if (!(pdf > 0.f) || f.is_black() || !f.is_finite() || !std::isfinite(pdf))
            return std::nullopt;
        BsdfSample s;
        s.f = f;
        s.wi = shading.to_world(wi);
        s.pdf = pdf;
        s.flags = kBxdfReflection | kBxdfDiffuse;
        return s;
    }
};

using Bxdf =
    std::variant<DiffuseBxdf, ConductorBxdf, DielectricBxdf, ThinDielectricBxdf, CoatedDiffuseBxdf,
                 CoatedConductorBxdf, HairBxdf, DiffuseTransmissionBxdf>;

/// A Bxdf with its shading frame; takes and returns world-space unit directions. Directions
/// passed in are normalised here. A direction exactly in the tangent plane (wo.z == 0 locally)
/// scatters nothing. Plain value, thread-safe.
class Bsdf {
  public:
    Bsdf() : flags_(compute_flags(bxdf_)) {}
    Bsdf(const Frame &shading_frame, Bxdf bxdf)
        : frame_(shading_frame), bxdf_(bxdf), flags_(compute_flags(bxdf_)) {}

    /// BSDF value (no cosine) for the pair; 0 for delta lobes. Units: 1/sr.
    Rgb f(Vec3f wo_world, Vec3f wi_world, TransportMode mode = TransportMode::Radiance) const {
        if (const DiffuseBxdf *d = std::get_if<DiffuseBxdf>(&bxdf_))
            return diffuse_f(*d, wo_world, wi_world);
        return f_general(wo_world, wi_world, mode);
    }
    /// f() and pdf() of the same pair in one call (one dispatch, one frame transform).
    Rgb f_pdf(Vec3f wo_world, Vec3f wi_world, float *pdf_out,
              TransportMode mode = TransportMode::Radiance) const {
        if (const DiffuseBxdf *d = std::get_if<DiffuseBxdf>(&bxdf_)) {
            *pdf_out = diffuse_pdf(wo_world, wi_world);
            return diffuse_f(*d, wo_world, wi_world);
        }
        return f_pdf_general(wo_world, wi_world, pdf_out, mode);
    }
    /// Samples wi (world space in the result) from canonical uc in [0,1) (lobe choice) and u in
    /// [0,1)^2 (direction). nullopt when no direction is produced (TIR in a rough interface,
    /// a microfacet reflection below the horizon, wo in the tangent plane, zero f or pdf).
    std::optional<BsdfSample> sample_f(Vec3f wo_world, float uc, Vec2f u,
                                       TransportMode mode = TransportMode::Radiance) const {
        if (const DiffuseBxdf *d = std::get_if<DiffuseBxdf>(&bxdf_))
            return diffuse_sample_f(*d, wo_world, u);
        return sample_f_general(wo_world, uc, u, mode);
    }
    /// Solid-angle density with which sample_f returns wi_world (non-delta part only).
    float pdf(Vec3f wo_world, Vec3f wi_world, TransportMode mode = TransportMode::Radiance) const {
        if (std::holds_alternative<DiffuseBxdf>(bxdf_))
            return diffuse_pdf(wo_world, wi_world);
        return pdf_general(wo_world, wi_world, mode);
    }
    /// Union of the lobes' BxdfFlags.
    uint8_t flags() const { return flags_; }
    /// Colour for an albedo AOV: diffuse/base reflectance, the normal-incidence Fresnel
    /// reflectance of a conductor, 1 for a dielectric.
    Rgb albedo_hint() const;
    /// True when some lobe is diffuse or glossy (light sampling / MIS is worthwhile).
    bool has_non_specular() const { return flags_ & (kBxdfDiffuse | kBxdfGlossy); }

    const Frame &frame() const { return frame_; }
    const Bxdf &bxdf() const { return bxdf_; }
    Vec3f to_local(Vec3f w) const { return frame_.to_local(w); }
    Vec3f to_world(Vec3f w) const { return frame_.to_world(w); }

  private:
    static uint8_t compute_flags(const Bxdf &b);
    Rgb f_general(Vec3f wo_world, Vec3f wi_world, TransportMode mode) const;
    Rgb f_pdf_general(Vec3f wo_world, Vec3f wi_world, float *pdf_out, TransportMode mode) const;
    std::optional<BsdfSample> sample_f_general(Vec3f wo_world, float uc, Vec2f u,
                                               TransportMode mode) const;
    float pdf_general(Vec3f wo_world, Vec3f wi_world, TransportMode mode) const;

    // Lambertian fast paths (LambertianBsdf, shared with the path tracer's Lambertian-only
    // specialisation so that both give bit-identical images).
    Rgb diffuse_f(const DiffuseBxdf &d, Vec3f wo_world, Vec3f wi_world) const {
        return LambertianBsdf{frame_, d.reflectance}.f(wo_world, wi_world);
    }
    float diffuse_pdf(Vec3f wo_world, Vec3f wi_world) const {
        return LambertianBsdf{frame_, Rgb()}.pdf(wo_world, wi_world);
    }
    std::optional<BsdfSample> diffuse_sample_f(const DiffuseBxdf &d, Vec3f wo_world,
                                               Vec2f u) const {
        return LambertianBsdf{frame_, d.reflectance}.sample_f(wo_world, u);
    }

    Frame frame_;
    Bxdf bxdf_;
    uint8_t flags_ = kBxdfUnset;
};

}  // namespace tessera
