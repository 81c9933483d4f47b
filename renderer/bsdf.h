// BSDFs: the scattering models behind pbrt-v4's "diffuse", "diffusetransmission", "conductor",
// "dielectric", "thindielectric", "coateddiffuse", "coatedconductor" and "hair" materials, in
// RGB.
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
//                   "float thickness" 0.01, "float eta" 1.5, "spectrum albedo" 0, "float g" 0,
//                   "integer maxdepth" 10, "integer nsamples" 1, "bool twosided" true,
//                   "bool remaproughness" true               -> CoatedDiffuseBxdf
//                   (maxdepth, nsamples and g only affect pbrt's stochastic evaluation; the
//                   closed-form model below has no use for them.)
// Roughness is remapped with alpha = sqrt(roughness) when remaproughness is true, else used as
// alpha directly. Alphas below 1e-3 give the specular (delta) code paths.
//
// All types are plain values; every method is const, pure and thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <variant>

#include "renderer/microfacet.h"
#include "sampling/vecmath.h"
#include "sampling/warp.h"

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

/// What a path carries: radiance (camera paths) or importance (light paths). Only dielectric
/// transmission differs (the 1/eta^2 radiance scaling applies in Radiance mode only).
enum class TransportMode { Radiance, Importance };

/// Result of sampling a Bsdf. `f` excludes the cosine; `pdf` is per solid angle (or the discrete
/// lobe probability for specular samples); `eta` is the relative IOR of a transmission, else 1.
struct BsdfSample {
    Rgb f;
    Vec3f wi;
    float pdf = 0.f;
    uint8_t flags = kBxdfUnset;
    float eta = 1.f;
    bool pdf_is_proportional = false;  ///< always false here (kept for pbrt-v4 parity)

    bool is_specular() const { return flags & kBxdfSpecular; }
    bool is_transmission() const { return flags & kBxdfTransmission; }
    bool is_reflection() const { return flags & kBxdfReflection; }
};

/// Lambertian reflection f = reflectance / pi in the hemisphere of wo; cosine-weighted sampling.
struct DiffuseBxdf {
    Rgb reflectance{0.5f};  ///< hemispherical reflectance in [0, 1] per channel

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode) const;
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
/// Sampled with visible normals (Heitz 2018). Reflection only, in the hemisphere of wo.
struct ConductorBxdf {
    TrowbridgeReitz distrib;
    Rgb eta{1.f};  ///< real part of the IOR relative to the outside medium, per channel
    Rgb k{0.f};    ///< absorption coefficient (imaginary part), per channel

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode) const;
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
struct DielectricBxdf {
    float eta = 1.5f;
    TrowbridgeReitz distrib;

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode) const;
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

/// pbrt-v4 "coateddiffuse": a dielectric coat (IOR eta, GGX roughness) over a Lambertian base
/// with an absorbing layer of the given thickness in between.
///
/// NOTE: pbrt-v4 evaluates this stochastically (LayeredBxDF random walk, Guo et al. 2018,
/// "Position-Free Monte Carlo Simulation for Arbitrary Layered BSDFs"). Here it is the
/// deterministic closed-form layered model of Weidlich & Wilkie 2007 ("Arbitrarily Layered
/// Micro-Facet Surfaces") and Kelemen & Szirmay-Kalos 2001, as in Mitsuba's "plastic":
///   f = f_coat(wo, wi) + f_base(wo, wi), with
///   f_coat = the GGX dielectric reflection lobe of the coat (a delta lobe of weight F(cos_o)
///            when smooth),
///   f_base = rho T(wo) T(wi) A(wo) A(wi) / (pi eta^2 (1 - rho Fdr_int a^2)),
/// where T(w) = 1 - F(cos w) is the Fresnel transmittance of the (macro) interface, Fdr_int the
/// coat's internal diffuse (cosine-averaged) Fresnel reflectance, 1 - Fdr_int = (1 - Fdr_ext) /
/// eta^2, and the factor 1/(1 - rho Fdr_int a^2) sums the light bouncing between base and coat.
/// Absorption: pbrt's layer has unit extinction per unit thickness; here the absorbing part
/// sigma_a = 1 - albedo attenuates the refracted ray A(w) = exp(-sigma_a thickness / cos_t(w))
/// and each internal diffuse round trip by a^2, a = exp(-2 sigma_a thickness); the scattering
/// part (albedo, g) is treated as forward scattering that neither absorbs nor redirects.
/// The model conserves energy (the base term's albedo is at most T(wo)) and is reciprocal.
/// It is two-sided like pbrt's (wo below the surface mirrors both directions); no transmission.
/// Sampling: the coat lobe (visible normals, or the delta) with probability p_coat from the
/// estimated Fresnel weight against the base's weight, else the cosine-weighted hemisphere;
/// pdf() is the matching mixture density.
/// Differences from pbrt-v4: no multiple scattering inside a rough coat, the base seen through a
/// rough coat is not blurred by it, and the medium scattering (albedo, g) is approximated.
struct CoatedDiffuseBxdf {
    Rgb reflectance{0.5f};  ///< base diffuse reflectance
    float eta = 1.5f;       ///< coat IOR relative to the outside (values < 1 are inverted)
    TrowbridgeReitz distrib;
    float thickness = 0.01f;  ///< layer thickness in units of the layer's mean free path
    Rgb albedo{0.f};          ///< single-scattering albedo of the layer medium
    float g = 0.f;            ///< Henyey-Greenstein asymmetry (unused, see above)
    float fdr_int = 0.f;      ///< internal diffuse Fresnel reflectance (set by the constructor)

    CoatedDiffuseBxdf() : CoatedDiffuseBxdf(Rgb(0.5f), 1.5f, TrowbridgeReitz(0.f, 0.f)) {}
    CoatedDiffuseBxdf(Rgb reflectance, float eta, TrowbridgeReitz distrib, float thickness = 0.01f,
                      Rgb albedo = Rgb(0.f), float g = 0.f);

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode) const;
    uint8_t flags() const;

    /// Probability of sampling the coat lobe for outgoing direction wo (local, wo.z > 0).
    float coat_probability(Vec3f wo) const;

  private:
    Rgb base(Vec3f wo, Vec3f wi) const;
    Rgb coat_f(Vec3f wo, Vec3f wi) const;
    float coat_pdf(Vec3f wo, Vec3f wi) const;
};

/// pbrt-v4 "coatedconductor": a dielectric coat (IOR eta, GGX roughness `coat`) over a conductor
/// (`base`, its complex IOR relative to the coat: pbrt-v4 divides the conductor's eta and k by
/// the coat's), with an absorbing layer between them.
///
/// NOTE: pbrt-v4 evaluates this stochastically (LayeredBxDF). Here it is closed-form, like
/// CoatedDiffuseBxdf:
///   f = f_coat(wo, wi) + T(wo) T(wi) A f_base(wo', wi') / (eta^2 (1 - rho))
/// where wo', wi' are wo, wi refracted into the coat (Snell's law, tangential components / eta),
/// T = 1 - F the coat's Fresnel transmittance, A = exp(-absorb (1/cos wo' + 1/cos wi')) the
/// layer's absorption (absorb = thickness (1 - albedo), as for coateddiffuse), f_base the
/// conductor's Torrance-Sparrow BRDF inside the coat, and 1 / (1 - rho) the light bounced
/// between base and coat: rho = F_b(wo') A_pass(wo') (1 - E), E the fraction of the base's lobe
/// from wo' that crosses the coat (1 - internal Fresnel, 0 under total internal reflection;
/// tabulated over roughness, angle and eta). With both layers smooth this is exact (one mirror
/// lobe of weight F + T^2 F_b A / (1 - F F_b A)); with rough layers the returning light is
/// assumed to leave in the base's lobe, which conserves energy (within the lobe's own masking
/// loss) but is not reciprocal (rho is wo's), and the coat's roughness does not blur the base.
/// Two-sided like pbrt-v4's, no transmission.
/// Sampling: the coat's lobe (or its mirror) with probability p_coat from the Fresnel weights,
/// else the base's visible normals inside the coat, refracted out (a direction that cannot
/// leave the coat fails).
struct CoatedConductorBxdf {
    float eta = 1.5f;      ///< coat IOR (values < 1 are inverted; 1: no coat)
    TrowbridgeReitz coat;  ///< the coat's roughness
    ConductorBxdf base;    ///< the metal, eta and k relative to the coat
    Rgb absorb{0.01f};     ///< thickness (1 - albedo) per channel

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode) const;
    uint8_t flags() const;
    /// Probability of sampling the coat for wo (local, wo.z > 0).
    float coat_probability(Vec3f wo) const;
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

/// Cosine-weighted hemispherical average of the dielectric Fresnel reflectance seen from the
/// outside, Fdr_ext(eta) = 2 int_0^1 F(mu, eta) mu dmu, for eta >= 1 (tabulated once; thread-safe).
float fresnel_diffuse_reflectance(float eta);

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
