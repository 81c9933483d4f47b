// BSDF models; see bsdf.h for the conventions and references.
#include "renderer/bsdf.h"

#include <array>
#include <vector>

#include "sampling/warp.h"

namespace tessera {

namespace {

/// Normalises `v`, or returns nullopt for a zero / non-finite vector.
std::optional<Vec3f> safe_normalize(Vec3f v) {
    float l2 = length_squared(v);
    if (!(l2 > 0.f) || !std::isfinite(l2))
        return std::nullopt;
    return v / std::sqrt(l2);
}

/// `v` normalised, or nullopt for a zero / non-finite vector. Directions from the integrator
/// are already unit (a frame rotation of a unit vector): those within float rounding of unit
/// length are passed through, which saves a square root and a division per direction.
std::optional<Vec3f> unit_direction(Vec3f v) {
    float l2 = length_squared(v);
    if (std::abs(l2 - 1.f) < 1e-6f)
        return v;
    return safe_normalize(v);
}

/// Mirror direction about the local normal (the specular reflection of wo).
Vec3f mirror_z(Vec3f wo) {
    return {-wo.x, -wo.y, wo.z};
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// DiffuseBxdf

Rgb DiffuseBxdf::f(Vec3f wo, Vec3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi))
        return {};
    return reflectance * kInvPi;
}

std::optional<BsdfSample> DiffuseBxdf::sample_f(Vec3f wo, float, Vec2f u, TransportMode) const {
    if (wo.z == 0.f)
        return std::nullopt;
    Vec3f wi = sampling::square_to_cosine_hemisphere(u);
    if (wo.z < 0.f)
        wi.z = -wi.z;
    float pdf = sampling::cosine_hemisphere_pdf(std::abs(wi.z));
    if (!(pdf > 0.f))
        return std::nullopt;
    BsdfSample s;
    s.f = reflectance * kInvPi;
    s.wi = wi;
    s.pdf = pdf;
    s.flags = kBxdfReflection | kBxdfDiffuse;
    return s;
}

float DiffuseBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi))
        return 0.f;
    return sampling::cosine_hemisphere_pdf(std::abs(wi.z));
}

uint8_t DiffuseBxdf::flags() const {
    return reflectance.is_black() ? kBxdfUnset : (kBxdfReflection | kBxdfDiffuse);
}

// ---------------------------------------------------------------------------------------------
// ConductorBxdf

Rgb ConductorBxdf::f(Vec3f wo, Vec3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi) || distrib.effectively_smooth())
        return {};
    float cos_o = std::abs(wo.z), cos_i = std::abs(wi.z);
    if (cos_o == 0.f || cos_i == 0.f)
        return {};
    std::optional<Vec3f> wm = safe_normalize(wi + wo);
    if (!wm)
        return {};
    Rgb fr = fr_complex(absdot(wo, *wm), eta, k);
    return fr * (distrib.d(*wm) * distrib.g(wo, wi) / (4.f * cos_o * cos_i));
}

std::optional<BsdfSample> ConductorBxdf::sample_f(Vec3f wo, float, Vec2f u, TransportMode) const {
    if (wo.z == 0.f)
        return std::nullopt;
    BsdfSample s;
    if (distrib.effectively_smooth()) {
        // Perfect mirror: the delta lobe's weight is the Fresnel reflectance.
        s.wi = mirror_z(wo);
        s.f = fr_complex(std::abs(s.wi.z), eta, k) / std::abs(s.wi.z);
        s.pdf = 1.f;
        s.flags = kBxdfReflection | kBxdfSpecular;
        return s;
    }
    Vec3f wm = distrib.sample_wm(wo, u);
    Vec3f wi = reflect(wo, wm);
    if (!same_hemisphere(wo, wi))
        return std::nullopt;
    float wo_dot_wm = absdot(wo, wm);
    if (wo_dot_wm == 0.f)
        return std::nullopt;
    // Jacobian of the reflection map: dwm/dwi = 1 / (4 |wo . wm|) (PBRT eq. 9.28).
    float pdf = distrib.pdf(wo, wm) / (4.f * wo_dot_wm);
    float cos_o = std::abs(wo.z), cos_i = std::abs(wi.z);
    if (cos_i == 0.f || !(pdf > 0.f))
        return std::nullopt;
    Rgb fr = fr_complex(wo_dot_wm, eta, k);
    s.f = fr * (distrib.d(wm) * distrib.g(wo, wi) / (4.f * cos_o * cos_i));
    s.wi = wi;
    s.pdf = pdf;
    s.flags = kBxdfReflection | kBxdfGlossy;
    return s;
}

float ConductorBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi) || distrib.effectively_smooth())
        return 0.f;
    std::optional<Vec3f> wm = safe_normalize(wo + wi);
    if (!wm)
        return 0.f;
    // Visible normals live in the +z hemisphere; orient the half vector accordingly.
    Vec3f m = face_forward(*wm, Vec3f(0, 0, 1));
    float wo_dot_wm = absdot(wo, m);
    if (wo_dot_wm == 0.f)
        return 0.f;
    return distrib.pdf(wo, m) / (4.f * wo_dot_wm);
}

uint8_t ConductorBxdf::flags() const {
    return kBxdfReflection | (distrib.effectively_smooth() ? kBxdfSpecular : kBxdfGlossy);
}

Rgb conductor_k_from_reflectance(Rgb r) {
    Rgb k;
    for (int c = 0; c < 3; ++c) {
        float rc = clamp(r[c], 0.f, 0.9999f);
        k[c] = 2.f * std::sqrt(rc) / std::sqrt(1.f - rc);
    }
    return k;
}

// ---------------------------------------------------------------------------------------------
// DielectricBxdf

uint8_t DielectricBxdf::flags() const {
    uint8_t f = eta == 1.f ? kBxdfTransmission : (kBxdfReflection | kBxdfTransmission);
    return f | ((eta == 1.f || distrib.effectively_smooth()) ? kBxdfSpecular : kBxdfGlossy);
}

namespace {

/// Generalized half vector of a dielectric pair (Walter et al. 2007, eq. 16): for reflection
/// wo + wi, for transmission etap wi + wo, oriented to +z. Returns false for degenerate
/// configurations or a half vector that is back-facing to either direction. Writes etap.
bool dielectric_half_vector(Vec3f wo, Vec3f wi, float eta, Vec3f *wm, float *etap,
                            bool *is_reflection) {
    float cos_o = wo.z, cos_i = wi.z;
    if (cos_o == 0.f || cos_i == 0.f)
        return false;
    bool refl = cos_o * cos_i > 0.f;
    float ep = 1.f;
    if (!refl)
        ep = cos_o > 0.f ? eta : 1.f / eta;
    std::optional<Vec3f> m = safe_normalize(wi * ep + wo);
    if (!m)
        return false;
    Vec3f n = face_forward(*m, Vec3f(0, 0, 1));
    // Microfacets that face away from wo or wi cannot connect them.
    if (dot(n, wi) * cos_i < 0.f || dot(n, wo) * cos_o < 0.f)
        return false;
    *wm = n;
    *etap = ep;
    *is_reflection = refl;
    return true;
}

}  // namespace

Rgb DielectricBxdf::f(Vec3f wo, Vec3f wi, TransportMode mode) const {
    if (eta == 1.f || distrib.effectively_smooth())
        return {};
    Vec3f wm;
    float etap;
    bool refl;
    if (!dielectric_half_vector(wo, wi, eta, &wm, &etap, &refl))
        return {};
    float fr = fr_dielectric(dot(wo, wm), eta);
    float cos_o = wo.z, cos_i = wi.z;
    if (refl) {
        return Rgb(distrib.d(wm) * distrib.g(wo, wi) * fr / std::abs(4.f * cos_i * cos_o));
    }
    // Transmission (Walter et al. 2007, eq. 21), with the generalized half-vector Jacobian.
    float denom = sqr(dot(wi, wm) + dot(wo, wm) / etap) * cos_i * cos_o;
    if (denom == 0.f)
        return {};
    float ft = distrib.d(wm) * (1.f - fr) * distrib.g(wo, wi) *
               std::abs(dot(wi, wm) * dot(wo, wm) / denom);
    if (mode == TransportMode::Radiance)
        ft /= sqr(etap);
    return std::isfinite(ft) ? Rgb(ft) : Rgb();
}

float DielectricBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode) const {
    if (eta == 1.f || distrib.effectively_smooth())
        return 0.f;
    Vec3f wm;
    float etap;
    bool refl;
    if (!dielectric_half_vector(wo, wi, eta, &wm, &etap, &refl))
        return 0.f;
    float r = fr_dielectric(dot(wo, wm), eta), t = 1.f - r;
    if (!(r + t > 0.f))
        return 0.f;
    float pdf;
    if (refl) {
        pdf = distrib.pdf(wo, wm) / (4.f * absdot(wo, wm)) * r / (r + t);
    } else {
        // Jacobian dwm/dwi of the refraction half vector (Walter et al. 2007, eq. 17).
        float denom = sqr(dot(wi, wm) + dot(wo, wm) / etap);
        if (denom == 0.f)
            return 0.f;
        float dwm_dwi = absdot(wi, wm) / denom;
        pdf = distrib.pdf(wo, wm) * dwm_dwi * t / (r + t);
    }
    return std::isfinite(pdf) ? pdf : 0.f;
}

std::optional<BsdfSample> DielectricBxdf::sample_f(Vec3f wo, float uc, Vec2f u,
                                                   TransportMode mode) const {
    if (wo.z == 0.f)
        return std::nullopt;
    BsdfSample s;
    if (eta == 1.f || distrib.effectively_smooth()) {
        // Specular interface: choose reflection with probability R (= R / (R + T)).
        float r = fr_dielectric(wo.z, eta), t = 1.f - r;
        if (uc < r) {
            s.wi = mirror_z(wo);
            s.f = Rgb(r / std::abs(s.wi.z));
            s.pdf = r;
            s.flags = kBxdfReflection | kBxdfSpecular;
            return s;
        }
        float etap;
        Vec3f wi;
        if (!refract(wo, Vec3f(0, 0, 1), eta, &etap, &wi) || wi.z == 0.f)
            return std::nullopt;
        float ft = t / std::abs(wi.z);
        if (mode == TransportMode::Radiance)
            ft /= sqr(etap);
        s.f = Rgb(ft);
        s.wi = wi;
        s.pdf = t;
        s.flags = kBxdfTransmission | kBxdfSpecular;
        s.eta = etap;
        return s;
    }

    // Rough interface: sample a visible microfacet normal, then reflect or refract through it.
    Vec3f wm = distrib.sample_wm(wo, u);
    float r = fr_dielectric(dot(wo, wm), eta), t = 1.f - r;
    float cos_o = wo.z;
    if (uc < r / (r + t)) {
        Vec3f wi = reflect(wo, wm);
        if (!same_hemisphere(wo, wi))
            return std::nullopt;
        float pdf = distrib.pdf(wo, wm) / (4.f * absdot(wo, wm)) * r / (r + t);
        float fr = distrib.d(wm) * distrib.g(wo, wi) * r / std::abs(4.f * wi.z * cos_o);
        if (!(pdf > 0.f) || !std::isfinite(fr) || !std::isfinite(pdf))
            return std::nullopt;
        s.f = Rgb(fr);
        s.wi = wi;
        s.pdf = pdf;
        s.flags = kBxdfReflection | kBxdfGlossy;
        return s;
    }
    float etap;
    Vec3f wi;
    if (!refract(wo, wm, eta, &etap, &wi))
        return std::nullopt;  // total internal reflection
    if (same_hemisphere(wo, wi) || wi.z == 0.f)
        return std::nullopt;
    float denom = sqr(dot(wi, wm) + dot(wo, wm) / etap);
    if (denom == 0.f)
        return std::nullopt;
    float dwm_dwi = absdot(wi, wm) / denom;
    float pdf = distrib.pdf(wo, wm) * dwm_dwi * t / (r + t);
    float ft = t * distrib.d(wm) * distrib.g(wo, wi) *
               std::abs(dot(wi, wm) * dot(wo, wm) / (wi.z * cos_o * denom));
    if (mode == TransportMode::Radiance)
        ft /= sqr(etap);
    if (!(pdf > 0.f) || !std::isfinite(ft) || !std::isfinite(pdf))
        return std::nullopt;
    s.f = Rgb(ft);
    s.wi = wi;
    s.pdf = pdf;
    s.flags = kBxdfTransmission | kBxdfGlossy;
    s.eta = etap;
    return s;
}

// ---------------------------------------------------------------------------------------------
// CoatedDiffuseBxdf

float fresnel_diffuse_reflectance(float eta) {
    // Table over eta in [1, 4] (step 0.0125), Simpson's rule in mu with 256 intervals per entry.
    constexpr int kEntries = 241;
    constexpr float kMax = 4.f;
    auto integrate = [](float e) {
        constexpr int n = 256;
        double sum = 0;
        for (int i = 0; i <= n; ++i) {
            double mu = static_cast<double>(i) / n;
            double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
            sum += w * mu * fr_dielectric(static_cast<float>(mu), e);
        }
        return static_cast<float>(2.0 * sum / (3.0 * n));
    };
    static const std::array<float, kEntries> table = [&] {
        std::array<float, kEntries> t{};
        for (int i = 0; i < kEntries; ++i)
            t[i] = integrate(1.f + (kMax - 1.f) * i / (kEntries - 1));
        return t;
    }();
    if (!(eta > 1.f))
        return 0.f;
    if (eta >= kMax)
        return integrate(eta);
    float x = (eta - 1.f) / (kMax - 1.f) * (kEntries - 1);
    int i = std::min(static_cast<int>(x), kEntries - 2);
    float t = x - i;
    return (1.f - t) * table[i] + t * table[i + 1];
}

CoatedDiffuseBxdf::CoatedDiffuseBxdf(Rgb reflectance_, float eta_, TrowbridgeReitz distrib_,
                                     float thickness_, Rgb albedo_, float g_)
    : reflectance(reflectance_),
      eta(eta_),
      distrib(distrib_),
      thickness(std::max(0.f, thickness_)),
      albedo(albedo_),
      g(g_) {
    // A coat "less dense" than the outside is unphysical for a coating; use its reciprocal.
    if (!(eta > 0.f) || !std::isfinite(eta))
        eta = 1.f;
    if (eta < 1.f)
        eta = 1.f / eta;
    float fdr_ext = fresnel_diffuse_reflectance(eta);
    fdr_int = 1.f - (1.f - fdr_ext) / (eta * eta);
}

uint8_t CoatedDiffuseBxdf::flags() const {
    uint8_t f = kBxdfReflection | kBxdfDiffuse;
    if (eta != 1.f)
        f |= distrib.effectively_smooth() ? kBxdfSpecular : kBxdfGlossy;
    return f;
}

Rgb CoatedDiffuseBxdf::base(Vec3f wo, Vec3f wi) const {
    // Both in the upper hemisphere here.
    float t_o = 1.f - fr_dielectric(wo.z, eta), t_i = 1.f - fr_dielectric(wi.z, eta);
    Rgb attenuation(1.f), loop(1.f);
    if (thickness > 0.f) {
        // Cosines of the refracted directions inside the coat (Snell's law).
        float ct_o = safe_sqrt(1.f - (1.f - wo.z * wo.z) / (eta * eta));
        float ct_i = safe_sqrt(1.f - (1.f - wi.z * wi.z) / (eta * eta));
        float path = thickness * (1.f / std::max(ct_o, 1e-4f) + 1.f / std::max(ct_i, 1e-4f));
        for (int c = 0; c < 3; ++c) {
            float sigma_a = 1.f - clamp(albedo[c], 0.f, 1.f);
            attenuation[c] = std::exp(-sigma_a * path);
            loop[c] = std::exp(-4.f * sigma_a * thickness);  // a^2, a = exp(-2 sigma_a d)
        }
    }
    Rgb out;
    for (int c = 0; c < 3; ++c) {
        float rho = clamp(reflectance[c], 0.f, 1.f);
        float denom = 1.f - rho * fdr_int * loop[c];
        out[c] = denom > 0.f ? rho * attenuation[c] / denom : 0.f;
    }
    return out * (t_o * t_i * kInvPi / (eta * eta));
}

Rgb CoatedDiffuseBxdf::coat_f(Vec3f wo, Vec3f wi) const {
    if (eta == 1.f || distrib.effectively_smooth())
        return {};
    std::optional<Vec3f> wm = safe_normalize(wo + wi);
    if (!wm)
        return {};
    float fr = fr_dielectric(dot(wo, *wm), eta);
    return Rgb(distrib.d(*wm) * distrib.g(wo, wi) * fr / (4.f * wo.z * wi.z));
}

float CoatedDiffuseBxdf::coat_pdf(Vec3f wo, Vec3f wi) const {
    if (eta == 1.f || distrib.effectively_smooth())
        return 0.f;
    std::optional<Vec3f> wm = safe_normalize(wo + wi);
    if (!wm)
        return 0.f;
    float wo_dot_wm = dot(wo, *wm);
    if (!(wo_dot_wm > 0.f))
        return 0.f;
    return distrib.pdf(wo, *wm) / (4.f * wo_dot_wm);
}

float CoatedDiffuseBxdf::coat_probability(Vec3f wo) const {
    if (eta == 1.f)
        return 0.f;
    float fr = fr_dielectric(std::abs(wo.z), eta);
    // Estimated energy of the base term: its albedo is ~ T(wo) * rho_eff (see bsdf.h).
    float rho = clamp(reflectance.average(), 0.f, 1.f);
    float base = (1.f - fr) * rho * (1.f - fdr_int) / std::max(1e-6f, 1.f - rho * fdr_int);
    if (!(base > 0.f))
        return 1.f;
    return clamp(fr / (fr + base), 0.1f, 0.9f);
}

Rgb CoatedDiffuseBxdf::f(Vec3f wo, Vec3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi))
        return {};
    // Two-sided: evaluate with both directions mirrored into the upper hemisphere.
    if (wo.z < 0.f) {
        wo = -wo;
        wi = -wi;
    }
    Rgb r = base(wo, wi) + coat_f(wo, wi);
    return r.is_finite() ? r : Rgb();
}

float CoatedDiffuseBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi))
        return 0.f;
    if (wo.z < 0.f) {
        wo = -wo;
        wi = -wi;
    }
    float pc = coat_probability(wo);
    float p = (1.f - pc) * sampling::cosine_hemisphere_pdf(wi.z) + pc * coat_pdf(wo, wi);
    return std::isfinite(p) ? p : 0.f;
}

std::optional<BsdfSample> CoatedDiffuseBxdf::sample_f(Vec3f wo, float uc, Vec2f u,
                                                      TransportMode mode) const {
    if (wo.z == 0.f)
        return std::nullopt;
    bool flipped = wo.z < 0.f;
    if (flipped)
        wo = -wo;
    float pc = coat_probability(wo);
    BsdfSample s;
    if (uc < pc && distrib.effectively_smooth()) {
        // Delta reflection off a smooth coat, chosen with discrete probability pc.
        float fr = fr_dielectric(wo.z, eta);
        s.wi = mirror_z(wo);
        s.f = Rgb(fr / s.wi.z);
        s.pdf = pc;
        s.flags = kBxdfReflection | kBxdfSpecular;
    } else {
        Vec3f wi;
        if (uc < pc) {
            wi = reflect(wo, distrib.sample_wm(wo, u));
            if (!(wi.z > 0.f))
                return std::nullopt;
            s.flags = kBxdfReflection | kBxdfGlossy;
        } else {
            wi = sampling::square_to_cosine_hemisphere(u);
            if (!(wi.z > 0.f))
                return std::nullopt;
            s.flags = kBxdfReflection | kBxdfDiffuse;
        }
        s.wi = wi;
        s.f = f(wo, wi, mode);
        s.pdf = pdf(wo, wi, mode);
        if (!(s.pdf > 0.f) || s.f.is_black())
            return std::nullopt;
    }
    if (flipped)
        s.wi = -s.wi;
    return s;
}

// ---------------------------------------------------------------------------------------------
// DiffuseTransmissionBxdf

Rgb DiffuseTransmissionBxdf::f(Vec3f wo, Vec3f wi, TransportMode) const {
    return same_hemisphere(wo, wi) ? r * kInvPi : t * kInvPi;
}

uint8_t DiffuseTransmissionBxdf::flags() const {
    uint8_t f = kBxdfUnset;
    if (!r.is_black())
        f |= kBxdfReflection | kBxdfDiffuse;
    if (!t.is_black())
        f |= kBxdfTransmission | kBxdfDiffuse;
    return f;
}

float DiffuseTransmissionBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode) const {
    float pr = r.max_value(), pt = t.max_value();
    if (!(pr + pt > 0.f))
        return 0.f;
    float lobe = same_hemisphere(wo, wi) ? pr : pt;
    return sampling::cosine_hemisphere_pdf(std::abs(wi.z)) * lobe / (pr + pt);
}

std::optional<BsdfSample> DiffuseTransmissionBxdf::sample_f(Vec3f wo, float uc, Vec2f u,
                                                            TransportMode) const {
    float pr = r.max_value(), pt = t.max_value();
    if (!(pr + pt > 0.f) || wo.z == 0.f)
        return std::nullopt;
    BsdfSample s;
    s.wi = sampling::square_to_cosine_hemisphere(u);
    const bool reflect_lobe = uc < pr / (pr + pt);
    // Reflection on wo's side, transmission on the other.
    if ((wo.z < 0.f) == reflect_lobe)
        s.wi.z = -s.wi.z;
    s.f = (reflect_lobe ? r : t) * kInvPi;
    s.pdf =
        sampling::cosine_hemisphere_pdf(std::abs(s.wi.z)) * (reflect_lobe ? pr : pt) / (pr + pt);
    s.flags = reflect_lobe ? (kBxdfReflection | kBxdfDiffuse) : (kBxdfTransmission | kBxdfDiffuse);
    s.eta = 1.f;
    return s;
}

// ---------------------------------------------------------------------------------------------
// CoatedConductorBxdf

namespace {

/// wo (upper hemisphere) refracted into a coat of IOR eta, pointing away from the base.
Vec3f into_coat(Vec3f w, float eta) {
    if (eta == 1.f)
        return w;
    return {w.x / eta, w.y / eta, safe_sqrt(1.f - (1.f - w.z * w.z) / (eta * eta))};
}

/// The fraction of the light a GGX mirror of roughness alpha sends up from direction cos_in
/// (inside a coat of IOR eta) that crosses the coat: 1 - the internal Fresnel reflectance, 0
/// beyond the critical angle, averaged over the lobe's visible-normal samples weighted by
/// their masking G1. A table over alpha in [0, 1], cos_in in [0, 1] and eta in [1, 3], filled
/// on first use (1.4 M lobe samples, tens of milliseconds) and interpolated.
class CoatEscapeTable {
  public:
    static const CoatEscapeTable &get() {
        static const CoatEscapeTable table;
        return table;
    }
    /// The escape fraction; below the first roughness step it blends toward the exact smooth
    /// value 1 - F_int(cos_in) (a step near the critical angle that no grid resolves).
    float lookup(float alpha, float cos_in, float eta) const {
        float a = clamp(alpha, 0.f, 1.f) * (kAlpha - 1), c = clamp(cos_in, 0.f, 1.f) * (kCos - 1);
        float e = clamp((eta - 1.f) * 0.5f, 0.f, 1.f) * (kEta - 1);
        int ia = std::min(int(a), kAlpha - 2), ic = std::min(int(c), kCos - 2),
            ie = std::min(int(e), kEta - 2);
        float fa = a - float(ia), fc = c - float(ic), fe = e - float(ie);
        auto row = [&](int r) {
            float out = 0.f;
            for (int dc = 0; dc < 2; ++dc)
                for (int de = 0; de < 2; ++de)
                    out += (dc ? fc : 1.f - fc) * (de ? fe : 1.f - fe) *
                           v_[index(r, ic + dc, ie + de)];
            return out;
        };
        float lo = ia == 0 ? 1.f - fr_dielectric(cos_in, 1.f / eta) : row(ia);
        return (1.f - fa) * lo + fa * row(ia + 1);
    }

  private:
    static constexpr int kAlpha = 17, kCos = 65, kEta = 9, kSqrtN = 12;
    static int index(int a, int c, int e) { return (a * kCos + c) * kEta + e; }
    CoatEscapeTable() : v_(size_t(kAlpha * kCos * kEta)) {
        for (int ia = 0; ia < kAlpha; ++ia)
            for (int ic = 0; ic < kCos; ++ic)
                for (int ie = 0; ie < kEta; ++ie) {
                    float alpha = std::max(float(ia) / (kAlpha - 1), 1e-3f);
                    float cos_in = std::max(float(ic) / (kCos - 1), 1e-3f);
                    float eta = 1.f + 2.f * float(ie) / (kEta - 1);
                    TrowbridgeReitz d(alpha, alpha);
                    Vec3f w{safe_sqrt(1.f - cos_in * cos_in), 0.f, cos_in};
                    double sum = 0, weight = 0;
                    for (int i = 0; i < kSqrtN; ++i)
                        for (int j = 0; j < kSqrtN; ++j) {
                            Vec2f u{(i + 0.5f) / kSqrtN, (j + 0.5f) / kSqrtN};
                            Vec3f wi = reflect(w, d.sample_wm(w, u));
                            if (!(wi.z > 0.f))
                                continue;
                            double g = d.g1(wi);
                            weight += g;
                            // Leaving the coat from inside: relative IOR 1 / eta.
                            sum += g * (1.0 - fr_dielectric(wi.z, 1.f / eta));
                        }
                    v_[size_t(index(ia, ic, ie))] = weight > 0 ? float(sum / weight) : 0.f;
                }
    }
    std::vector<float> v_;
};

/// A direction inside the coat (upper hemisphere) refracted out; nullopt under total internal
/// reflection.
std::optional<Vec3f> out_of_coat(Vec3f w, float eta) {
    float sin2 = (1.f - w.z * w.z) * eta * eta;
    if (!(sin2 < 1.f))
        return std::nullopt;
    return Vec3f(w.x * eta, w.y * eta, std::sqrt(1.f - sin2));
}

}  // namespace

uint8_t CoatedConductorBxdf::flags() const {
    uint8_t f = kBxdfReflection;
    if (eta != 1.f)
        f |= coat.effectively_smooth() ? kBxdfSpecular : kBxdfGlossy;
    f |= base.distrib.effectively_smooth() ? kBxdfSpecular : kBxdfGlossy;
    return f;
}

float CoatedConductorBxdf::coat_probability(Vec3f wo) const {
    if (eta == 1.f)
        return 0.f;
    float fr = fr_dielectric(wo.z, eta);
    Vec3f wo_in = into_coat(wo, eta);
    float fb = fr_complex(wo_in.z, base.eta, base.k).average();
    float a = std::exp(-2.f * absorb.average() / std::max(wo_in.z, 1e-4f));
    float b = (1.f - fr) * (1.f - fr) * fb * a;
    if (!(b > 0.f))
        return 1.f;
    return clamp(fr / (fr + b), 0.05f, 0.95f);
}

namespace {

/// What f, pdf and sample_f share for a pair in the upper hemisphere: the refracted directions
/// and the weight T(wo) T(wi) A / eta^2 of the base's BRDF, times the light that comes back
/// after bouncing between base and coat.
struct CoatPath {
    Vec3f wo_in, wi_in;
    Rgb weight;
};

/// 1 / (1 - r): the base's light from direction w_in that the coat sends back down (internal
/// reflection and total internal reflection of the lobe, 1 - the escape fraction) returns to
/// the base, is reflected with F_b and leaves the same way, round after round.
Rgb bounce_gain(const CoatedConductorBxdf &b, Vec3f w_in) {
    float trapped = 0.f;
    if (b.eta != 1.f) {
        float alpha = std::sqrt(b.base.distrib.alpha_x * b.base.distrib.alpha_y);
        trapped = clamp(1.f - CoatEscapeTable::get().lookup(alpha, w_in.z, b.eta), 0.f, 1.f);
    }
    Rgb fb = fr_complex(w_in.z, b.base.eta, b.base.k);
    Rgb g;
    for (int ch = 0; ch < 3; ++ch) {
        float pass = std::exp(-2.f * b.absorb[ch] / std::max(w_in.z, 1e-4f));
        g[ch] = 1.f / std::max(1e-3f, 1.f - trapped * fb[ch] * pass);
    }
    return g;
}

CoatPath coat_path(const CoatedConductorBxdf &b, Vec3f wo, Vec3f wi) {
    CoatPath c;
    c.wo_in = into_coat(wo, b.eta);
    c.wi_in = into_coat(wi, b.eta);
    // (No coat: no Fresnel, also at grazing angles where fr_dielectric(cos, 1) rounds to 1.)
    float fo = b.eta == 1.f ? 0.f : fr_dielectric(wo.z, b.eta);
    float fi = b.eta == 1.f ? 0.f : fr_dielectric(wi.z, b.eta);
    float co = std::max(c.wo_in.z, 1e-4f), ci = std::max(c.wi_in.z, 1e-4f);
    // From wo's side only: what wo's light loses to the coat comes back in the base's lobe.
    // (An average with wi's gain would be reciprocal but overshoots energy by a few percent:
    // grazing wi trap more. Nothing in Tessera traces from the lights, so f need not be.)
    Rgb gain = bounce_gain(b, c.wo_in);
    for (int ch = 0; ch < 3; ++ch) {
        float a = std::exp(-b.absorb[ch] * (1.f / co + 1.f / ci));
        c.weight[ch] = (1.f - fo) * (1.f - fi) * a * gain[ch] / (b.eta * b.eta);
    }
    return c;
}

/// The coat's own rough reflection lobe (none when smooth or absent).
Rgb coat_lobe_f(const CoatedConductorBxdf &b, Vec3f wo, Vec3f wi) {
    if (b.eta == 1.f || b.coat.effectively_smooth())
        return {};
    std::optional<Vec3f> wm = safe_normalize(wo + wi);
    if (!wm)
        return {};
    float fr = fr_dielectric(dot(wo, *wm), b.eta);
    return Rgb(b.coat.d(*wm) * b.coat.g(wo, wi) * fr / (4.f * wo.z * wi.z));
}

float coat_lobe_pdf(const CoatedConductorBxdf &b, Vec3f wo, Vec3f wi) {
    if (b.eta == 1.f || b.coat.effectively_smooth())
        return 0.f;
    std::optional<Vec3f> wm = safe_normalize(wo + wi);
    if (!wm)
        return 0.f;
    float wo_dot_wm = dot(wo, *wm);
    if (!(wo_dot_wm > 0.f))
        return 0.f;
    return b.coat.pdf(wo, *wm) / (4.f * wo_dot_wm);
}

/// Density of wi (outside) when the base's lobe is sampled inside the coat and refracted out:
/// the inside density times dw_in / dw = cos wi / (eta^2 cos wi_in).
float base_lobe_pdf(const CoatedConductorBxdf &b, const CoatPath &c, Vec3f wi) {
    if (b.base.distrib.effectively_smooth())
        return 0.f;
    float p = b.base.pdf(c.wo_in, c.wi_in, TransportMode::Radiance);
    return p * wi.z / (b.eta * b.eta * std::max(c.wi_in.z, 1e-6f));
}

}  // namespace

Rgb CoatedConductorBxdf::f(Vec3f wo, Vec3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi))
        return {};
    if (wo.z < 0.f) {
        wo = -wo;
        wi = -wi;
    }
    Rgb r = coat_lobe_f(*this, wo, wi);
    if (!base.distrib.effectively_smooth()) {
        CoatPath c = coat_path(*this, wo, wi);
        r += c.weight * base.f(c.wo_in, c.wi_in, TransportMode::Radiance);
    }
    return r.is_finite() ? r : Rgb();
}

float CoatedConductorBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode) const {
    if (!same_hemisphere(wo, wi))
        return 0.f;
    if (wo.z < 0.f) {
        wo = -wo;
        wi = -wi;
    }
    float pc = coat_probability(wo);
    float p = pc * coat_lobe_pdf(*this, wo, wi);
    if (pc < 1.f)
        p += (1.f - pc) * base_lobe_pdf(*this, coat_path(*this, wo, wi), wi);
    return std::isfinite(p) ? p : 0.f;
}

std::optional<BsdfSample> CoatedConductorBxdf::sample_f(Vec3f wo, float uc, Vec2f u,
                                                        TransportMode mode) const {
    if (wo.z == 0.f)
        return std::nullopt;
    const bool flipped = wo.z < 0.f;
    if (flipped)
        wo = -wo;
    const bool coat_smooth = eta == 1.f || coat.effectively_smooth();
    const bool base_smooth = base.distrib.effectively_smooth();
    const float pc = coat_probability(wo);
    BsdfSample s;
    if (coat_smooth && base_smooth) {
        // One mirror lobe: the coat's reflection plus everything that came back from the base.
        Vec3f wi = mirror_z(wo);
        CoatPath c = coat_path(*this, wo, wi);
        Rgb w = Rgb(eta == 1.f ? 0.f : fr_dielectric(wo.z, eta)) +
                c.weight * (eta * eta) * fr_complex(c.wo_in.z, base.eta, base.k);
        s.wi = wi;
        s.f = w / wi.z;
        s.pdf = 1.f;
        s.flags = kBxdfReflection | kBxdfSpecular;
    } else if (uc < pc && coat_smooth) {
        s.wi = mirror_z(wo);
        s.f = Rgb(fr_dielectric(wo.z, eta) / s.wi.z);
        s.pdf = pc;
        s.flags = kBxdfReflection | kBxdfSpecular;
    } else if (uc >= pc && base_smooth) {
        // The base's mirror seen through the coat: mirror_z(wo) inside maps to mirror_z(wo)
        // outside, and the eta^2 of the solid-angle change cancels the one in the weight.
        s.wi = mirror_z(wo);
        CoatPath c = coat_path(*this, wo, s.wi);
        s.f = c.weight * (eta * eta) * fr_complex(c.wo_in.z, base.eta, base.k) / s.wi.z;
        s.pdf = 1.f - pc;
        s.flags = kBxdfReflection | kBxdfSpecular;
    } else {
        Vec3f wi;
        if (uc < pc) {
            wi = reflect(wo, coat.sample_wm(wo, u));
            s.flags = kBxdfReflection | kBxdfGlossy;
        } else {
            Vec3f wo_in = into_coat(wo, eta);
            Vec3f wi_in = reflect(wo_in, base.distrib.sample_wm(wo_in, u));
            if (!(wi_in.z > 0.f))
                return std::nullopt;
            std::optional<Vec3f> out = out_of_coat(wi_in, eta);
            if (!out)
                return std::nullopt;
            wi = *out;
            s.flags = kBxdfReflection | kBxdfGlossy;
        }
        if (!(wi.z > 0.f))
            return std::nullopt;
        s.wi = wi;
        s.f = f(wo, wi, mode);
        s.pdf = pdf(wo, wi, mode);
        if (!(s.pdf > 0.f) || s.f.is_black())
            return std::nullopt;
    }
    if (flipped)
        s.wi = -s.wi;
    return s;
}

// ---------------------------------------------------------------------------------------------
// Bsdf

Rgb Bsdf::f_general(Vec3f wo_world, Vec3f wi_world, TransportMode mode) const {
    Vec3f wo = frame_.to_local(wo_world), wi = frame_.to_local(wi_world);
    std::optional<Vec3f> o = unit_direction(wo), i = unit_direction(wi);
    if (!o || !i || o->z == 0.f)
        return {};
    Rgb r = std::visit([&](const auto &b) { return b.f(*o, *i, mode); }, bxdf_);
    return r.is_finite() ? r : Rgb();
}

Rgb Bsdf::f_pdf_general(Vec3f wo_world, Vec3f wi_world, float *pdf_out,
                        TransportMode mode) const {
    *pdf_out = 0.f;
    Vec3f wo = frame_.to_local(wo_world), wi = frame_.to_local(wi_world);
    std::optional<Vec3f> o = unit_direction(wo), i = unit_direction(wi);
    if (!o || !i || o->z == 0.f)
        return {};
    float p = 0.f;
    Rgb r = std::visit(
        [&](const auto &b) {
            p = b.pdf(*o, *i, mode);
            return b.f(*o, *i, mode);
        },
        bxdf_);
    *pdf_out = std::isfinite(p) ? p : 0.f;
    return r.is_finite() ? r : Rgb();
}

std::optional<BsdfSample> Bsdf::sample_f_general(Vec3f wo_world, float uc, Vec2f u,
                                                 TransportMode mode) const {
    std::optional<Vec3f> wo = unit_direction(frame_.to_local(wo_world));
    if (!wo || wo->z == 0.f || flags_ == kBxdfUnset)
        return std::nullopt;
    std::optional<BsdfSample> s =
        std::visit([&](const auto &b) { return b.sample_f(*wo, uc, u, mode); }, bxdf_);
    if (!s || !(s->pdf > 0.f) || s->f.is_black() || s->wi.z == 0.f || !s->f.is_finite() ||
        !std::isfinite(s->pdf))
        return std::nullopt;
    s->wi = frame_.to_world(s->wi);
    return s;
}

float Bsdf::pdf_general(Vec3f wo_world, Vec3f wi_world, TransportMode mode) const {
    std::optional<Vec3f> o = unit_direction(frame_.to_local(wo_world));
    std::optional<Vec3f> i = unit_direction(frame_.to_local(wi_world));
    if (!o || !i || o->z == 0.f)
        return 0.f;
    float p = std::visit([&](const auto &b) { return b.pdf(*o, *i, mode); }, bxdf_);
    return std::isfinite(p) ? p : 0.f;
}

uint8_t Bsdf::compute_flags(const Bxdf &b) {
    return std::visit([](const auto &x) { return x.flags(); }, b);
}

std::optional<BsdfSample> ThinDielectricBxdf::sample_f(Vec3f wo, float uc, Vec2f,
                                                       TransportMode) const {
    float cos_o = std::abs(wo.z);
    if (cos_o == 0.f) return std::nullopt;
    float R = fr_dielectric(cos_o, eta), T = 1.f - R;
    // Sum the geometric series of reflections inside the slab.
    if (R < 1.f) {
        R += T * T * R / (1.f - R * R);
        T = 1.f - R;
    }
    BsdfSample s;
    if (uc < R / (R + T)) {
        s.wi = {-wo.x, -wo.y, wo.z};
        s.f = Rgb(R / cos_o);
        s.pdf = R / (R + T);
        s.flags = kBxdfReflection | kBxdfSpecular;
    } else {
        s.wi = -wo;
        s.f = Rgb(T / cos_o);
        s.pdf = T / (R + T);
        s.flags = kBxdfTransmission | kBxdfSpecular;
        s.eta = 1.f;
    }
    return s;
}

uint8_t ThinDielectricBxdf::flags() const {
    return kBxdfReflection | kBxdfTransmission | kBxdfSpecular;
}

Rgb Bsdf::albedo_hint() const {
    struct Visitor {
        Rgb operator()(const DiffuseBxdf &b) const { return b.reflectance; }
        Rgb operator()(const ConductorBxdf &b) const { return fr_complex(1.f, b.eta, b.k); }
        Rgb operator()(const DielectricBxdf &) const { return Rgb(1.f); }
        Rgb operator()(const ThinDielectricBxdf &) const { return Rgb(1.f); }
        Rgb operator()(const CoatedDiffuseBxdf &b) const { return b.reflectance; }
        Rgb operator()(const DiffuseTransmissionBxdf &b) const { return b.r; }
        Rgb operator()(const CoatedConductorBxdf &b) const {
            return fr_complex(1.f, b.base.eta, b.base.k);
        }
        // The colour a fiber of this absorption shows (exp(-sigma_a) per diameter crossed).
        Rgb operator()(const HairBxdf &b) const {
            return Rgb(std::exp(-b.sigma_a.r), std::exp(-b.sigma_a.g), std::exp(-b.sigma_a.b));
        }
    };
    return std::visit(Visitor{}, bxdf_);
}

}  // namespace tessera
