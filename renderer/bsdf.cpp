// BSDF models; see bsdf.h for the conventions and references.
#include "renderer/bsdf.h"

#include <array>

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
        // The colour a fiber of this absorption shows (exp(-sigma_a) per diameter crossed).
        Rgb operator()(const HairBxdf &b) const {
            return Rgb(std::exp(-b.sigma_a.r), std::exp(-b.sigma_a.g), std::exp(-b.sigma_a.b));
        }
    };
    return std::visit(Visitor{}, bxdf_);
}

}  // namespace tessera
