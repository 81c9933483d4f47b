// BSDF models; see bsdf.h for the conventions and references.
#include "renderer/shading/bsdf.h"

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

std::optional<BsdfSample> DiffuseBxdf::sample_f(Vec3f wo, float, Vec2f u, TransportMode,
                                                BxdfReflTrans lobes) const {
    if (wo.z == 0.f || !(lobes & kReflTransReflection))
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

float DiffuseBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode, BxdfReflTrans lobes) const {
    if (!(lobes & kReflTransReflection) || !same_hemisphere(wo, wi))
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

std::optional<BsdfSample> ConductorBxdf::sample_f(Vec3f wo, float, Vec2f u, TransportMode,
                                                  BxdfReflTrans lobes) const {
    if (wo.z == 0.f || !(lobes & kReflTransReflection))
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
    const float d_wm = distrib.d(wm), lambda_o = distrib.lambda(wo);
    float pdf = distrib.pdf(wo, wm, d_wm, lambda_o) / (4.f * wo_dot_wm);
    float cos_o = std::abs(wo.z), cos_i = std::abs(wi.z);
    if (cos_i == 0.f || !(pdf > 0.f))
        return std::nullopt;
    Rgb fr = fr_complex(wo_dot_wm, eta, k);
    s.f = fr * (d_wm * distrib.g(lambda_o, wi) / (4.f * cos_o * cos_i));
    s.wi = wi;
    s.pdf = pdf;
    s.flags = kBxdfReflection | kBxdfGlossy;
    return s;
}

float ConductorBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode, BxdfReflTrans lobes) const {
    if (!(lobes & kReflTransReflection) || !same_hemisphere(wo, wi) || distrib.effectively_smooth())
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

float DielectricBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode, BxdfReflTrans lobes) const {
    if (eta == 1.f || distrib.effectively_smooth())
        return 0.f;
    Vec3f wm;
    float etap;
    bool refl;
    if (!dielectric_half_vector(wo, wi, eta, &wm, &etap, &refl))
        return 0.f;
    float r = fr_dielectric(dot(wo, wm), eta), t = 1.f - r;
    // A restricted sampler picks the remaining lobe with probability 1 (pbrt-v4).
    if (!(lobes & kReflTransReflection))
        r = 0.f;
    if (!(lobes & kReflTransTransmission))
        t = 0.f;
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

std::optional<BsdfSample> DielectricBxdf::sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode,
                                                   BxdfReflTrans lobes) const {
    if (wo.z == 0.f || !(lobes & kReflTransAll))
        return std::nullopt;
    BsdfSample s;
    if (eta == 1.f || distrib.effectively_smooth()) {
        // Specular interface: choose reflection with probability R (= R / (R + T)); a
        // restricted sampler takes its one lobe with probability 1 (pbrt-v4).
        float r = fr_dielectric(wo.z, eta), t = 1.f - r;
        bool reflect_lobe = uc < r;
        float p_lobe = reflect_lobe ? r : t;
        if (lobes != kReflTransAll) {
            reflect_lobe = lobes == kReflTransReflection;
            if (!((reflect_lobe ? r : t) > 0.f))
                return std::nullopt;
            p_lobe = 1.f;
        }
        if (reflect_lobe) {
            s.wi = mirror_z(wo);
            s.f = Rgb(r / std::abs(s.wi.z));
            s.pdf = p_lobe;
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
        s.pdf = p_lobe;
        s.flags = kBxdfTransmission | kBxdfSpecular;
        s.eta = etap;
        return s;
    }

    // Rough interface: sample a visible microfacet normal, then reflect or refract through it.
    Vec3f wm = distrib.sample_wm(wo, u);
    float r = fr_dielectric(dot(wo, wm), eta), t = 1.f - r;
    // Lobe probabilities: R and T, or 0 for a lobe the restriction leaves out (pbrt-v4).
    const float pr = (lobes & kReflTransReflection) ? r : 0.f;
    const float pt = (lobes & kReflTransTransmission) ? t : 0.f;
    if (!(pr + pt > 0.f))
        return std::nullopt;
    float cos_o = wo.z;
    // D(wm) and Lambda(wo) enter both the density and the value.
    const float d_wm = distrib.d(wm), lambda_o = distrib.lambda(wo);
    if (uc < pr / (pr + pt)) {
        Vec3f wi = reflect(wo, wm);
        if (!same_hemisphere(wo, wi))
            return std::nullopt;
        float pdf = distrib.pdf(wo, wm, d_wm, lambda_o) / (4.f * absdot(wo, wm)) * pr / (pr + pt);
        float fr = d_wm * distrib.g(lambda_o, wi) * r / std::abs(4.f * wi.z * cos_o);
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
    float pdf = distrib.pdf(wo, wm, d_wm, lambda_o) * dwm_dwi * pt / (pr + pt);
    float ft = t * d_wm * distrib.g(lambda_o, wi) *
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
        Rgb operator()(const CoatedDiffuseBxdf &b) const { return b.bottom.reflectance; }
        Rgb operator()(const DiffuseTransmissionBxdf &b) const { return b.r; }
        Rgb operator()(const CoatedConductorBxdf &b) const {
            return fr_complex(1.f, b.bottom.eta, b.bottom.k);
        }
        // The colour a fiber of this absorption shows (exp(-sigma_a) per diameter crossed).
        Rgb operator()(const HairBxdf &b) const {
            return Rgb(std::exp(-b.sigma_a.r), std::exp(-b.sigma_a.g), std::exp(-b.sigma_a.b));
        }
    };
    return std::visit(Visitor{}, bxdf_);
}

}  // namespace tessera
