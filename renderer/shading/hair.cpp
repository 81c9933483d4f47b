// HairBxdf: pbrt-v4's hair scattering model (Chiang et al. 2016; PBRT 4th ed., section 9.9),
// in RGB. See bsdf.h for the conventions.
#include <array>
#include <cmath>

#include "renderer/shading/bxdfs.h"

namespace tessera {

namespace {

constexpr int kPMax = 3;  // lobes R, TT, TRT, then the sum of all higher orders

/// Modified Bessel function of the first kind, order 0, from its power series
/// sum_i (x^2 / 4)^i / (i!)^2 summed until the terms stop mattering. pbrt-v4 keeps ten terms,
/// which is 0.3% low at x = 10, 0.9% at 11 and 2% at 12 (narrow lobes): its Mp, and so its
/// pdf, then integrates to less than 1 (0.997 for beta_m 0.3) and no longer matches the exactly
/// sampled density.
double bessel_i0(double x) {
    const double q = 0.25 * x * x;
    double term = 1.0, sum = 1.0;
    for (int i = 1; i < 100 && term > 1e-9 * sum; ++i) {
        term *= q / (double(i) * double(i));
        sum += term;
    }
    return sum;
}

/// log(I0(x)); past x = 12 (where I0 overflows for narrow lobes) the asymptotic expansion
/// e^x / sqrt(2 pi x) (1 + 1/(8x) + 9/(128x^2) + 75/(1024x^3)), relative error below 1e-5.
/// pbrt-v4 writes x + (-ln 2 pi + ln(1/x) + 1/(8x)) / 2, which halves the 1/(8x) term: 0.6% low
/// at x = 12.
double log_bessel_i0(double x) {
    if (x > 12.0)
        return x - 0.5 * std::log(2.0 * M_PI * x) +
               std::log1p(1.0 / (8.0 * x) + 9.0 / (128.0 * x * x) + 75.0 / (1024.0 * x * x * x));
    return std::log(bessel_i0(x));
}

/// Longitudinal scattering Mp (d'Eon et al. 2011), in log space for small variances (there
/// csch(1/v) is 2 e^(-1/v) to float precision).
float mp(float cos_i, float cos_o, float sin_i, float sin_o, float v) {
    float m;
    if (v <= 0.1f) {
        // The exponent sums terms of size 1/v (7e4 for beta_m 0.01) that nearly cancel: all of
        // it in double.
        const double vd = v, a = double(cos_i) * cos_o / vd, b = double(sin_i) * sin_o / vd;
        m = float(std::exp(log_bessel_i0(a) - b - 1.0 / vd + M_LN2 + std::log(1.0 / (2.0 * vd))));
    } else {
        float a = cos_i * cos_o / v, b = sin_i * sin_o / v;
        m = std::exp(-b) * float(bessel_i0(a)) / (std::sinh(1.f / v) * 2.f * v);
    }
    return std::isfinite(m) ? m : 0.f;
}

/// Attenuation of each lobe: Fresnel at the fiber's entry and exit, absorption per crossing.
std::array<Rgb, kPMax + 1> ap(float cos_theta_o, float eta, float h, Rgb t) {
    std::array<Rgb, kPMax + 1> a;
    float cos_gamma_o = safe_sqrt(1.f - h * h);
    float f = fr_dielectric(cos_theta_o * cos_gamma_o, eta);
    a[0] = Rgb(f);
    a[1] = t * sqr(1.f - f);
    for (int p = 2; p < kPMax; ++p)
        a[size_t(p)] = a[size_t(p - 1)] * t * f;
    // The geometric series of every higher order.
    Rgb denom = Rgb(1.f) - t * f;
    auto div = [](float n, float d) { return d != 0.f ? n / d : 0.f; };
    Rgb num = a[kPMax - 1] * t * f;
    a[kPMax] = Rgb(div(num.r, denom.r), div(num.g, denom.g), div(num.b, denom.b));
    return a;
}

/// Azimuth of the exit direction of lobe p, relative to the entry.
float phi_p(int p, float gamma_o, float gamma_t) {
    return 2.f * float(p) * gamma_t - 2.f * gamma_o + float(p) * kPi;
}

float logistic(float x, float s) {
    x = std::abs(x);
    float e = std::exp(-x / s);
    return e / (s * sqr(1.f + e));
}

float logistic_cdf(float x, float s) {
    return 1.f / (1.f + std::exp(-x / s));
}

float trimmed_logistic(float x, float s, float a, float b) {
    return logistic(x, s) / (logistic_cdf(b, s) - logistic_cdf(a, s));
}

/// Samples the logistic of scale s restricted to [a, b] by inverting its CDF.
float sample_trimmed_logistic(float u, float s, float a, float b) {
    float ca = logistic_cdf(a, s), cb = logistic_cdf(b, s);
    float up = (1.f - u) * ca + u * cb;
    float x = -s * std::log(1.f / up - 1.f);
    return clamp(x, a, b);
}

/// Azimuthal scattering Np of lobe p at relative azimuth phi.
float np(float phi, int p, float s, float gamma_o, float gamma_t) {
    float dphi = phi - phi_p(p, gamma_o, gamma_t);
    while (dphi > kPi)
        dphi -= 2.f * kPi;
    while (dphi < -kPi)
        dphi += 2.f * kPi;
    return trimmed_logistic(dphi, s, -kPi, kPi);
}

/// What f, sample_f and pdf share for one wo.
struct FiberGeometry {
    float sin_o, cos_o, phi_o;
    float gamma_o, gamma_t;
    Rgb t;  // transmittance of one crossing of the fiber
    // sin/cos of theta_o rotated for lobes R, TT, TRT (the scale tilt), cos made non-negative.
    std::array<float, kPMax> sin_po, cos_po;
};

FiberGeometry fiber_geometry(const HairBxdf &b, Vec3f wo) {
    FiberGeometry g;
    g.sin_o = wo.x;
    g.cos_o = safe_sqrt(1.f - sqr(g.sin_o));
    g.phi_o = std::atan2(wo.z, wo.y);
    g.gamma_o = safe_asin(b.h);
    // The refracted ray: the modified IOR of the fiber's cross-section (Bravais).
    float sin_t = g.sin_o / b.eta, cos_t = safe_sqrt(1.f - sqr(sin_t));
    float etap = safe_sqrt(sqr(b.eta) - sqr(g.sin_o)) / g.cos_o;
    float sin_gamma_t = b.h / etap, cos_gamma_t = safe_sqrt(1.f - sqr(sin_gamma_t));
    g.gamma_t = safe_asin(sin_gamma_t);
    float len = 2.f * cos_gamma_t / cos_t;
    g.t = Rgb(std::exp(-b.sigma_a.r * len), std::exp(-b.sigma_a.g * len),
              std::exp(-b.sigma_a.b * len));
    // sin/cos of alpha, 2 alpha, 4 alpha.
    float s2[3], c2[3];
    s2[0] = b.sin_alpha;
    c2[0] = b.cos_alpha;
    for (int i = 1; i < 3; ++i) {
        s2[i] = 2.f * c2[i - 1] * s2[i - 1];
        c2[i] = sqr(c2[i - 1]) - sqr(s2[i - 1]);
    }
    // R: theta_o - 2 alpha; TT: theta_o + alpha; TRT: theta_o + 4 alpha.
    g.sin_po[0] = g.sin_o * c2[1] - g.cos_o * s2[1];
    g.cos_po[0] = std::abs(g.cos_o * c2[1] + g.sin_o * s2[1]);
    g.sin_po[1] = g.sin_o * c2[0] + g.cos_o * s2[0];
    g.cos_po[1] = std::abs(g.cos_o * c2[0] - g.sin_o * s2[0]);
    g.sin_po[2] = g.sin_o * c2[2] + g.cos_o * s2[2];
    g.cos_po[2] = std::abs(g.cos_o * c2[2] - g.sin_o * s2[2]);
    return g;
}

/// Longitudinal variance of lobe p.
float variance(const HairBxdf &b, int p) {
    return p == 0 ? b.v0 : (p == 1 ? 0.25f * b.v0 : 4.f * b.v0);
}

/// Probability of sampling each lobe: its Ap, averaged over the channels, normalised.
std::array<float, kPMax + 1> lobe_pdf(const HairBxdf &b, const FiberGeometry &g) {
    std::array<Rgb, kPMax + 1> a = ap(g.cos_o, b.eta, b.h, g.t);
    std::array<float, kPMax + 1> w;
    float sum = 0.f;
    for (int i = 0; i <= kPMax; ++i)
        sum += (w[size_t(i)] = a[size_t(i)].average());
    for (float &x : w)
        x = sum > 0.f ? x / sum : 0.f;
    return w;
}

/// The mixture density of wi (solid angle), given the lobe probabilities.
float mixture_pdf(const HairBxdf &b, const FiberGeometry &g, const std::array<float, kPMax + 1> &w,
                  float sin_i, float cos_i, float dphi) {
    float pdf = 0.f;
    for (int p = 0; p < kPMax; ++p)
        pdf += mp(cos_i, g.cos_po[size_t(p)], sin_i, g.sin_po[size_t(p)], variance(b, p)) *
               w[size_t(p)] * np(dphi, p, b.s, g.gamma_o, g.gamma_t);
    pdf += mp(cos_i, g.cos_o, sin_i, g.sin_o, variance(b, kPMax)) * w[kPMax] * kInv2Pi;
    return pdf;
}

}  // namespace

HairBxdf::HairBxdf(float h_, float eta_, Rgb sigma_a_, float beta_m, float beta_n,
                   float alpha_degrees)
    : h(clamp(h_, -1.f, 1.f)), eta(eta_), sigma_a(sigma_a_) {
    float bm = clamp(beta_m, 0.f, 1.f), bn = clamp(beta_n, 0.f, 1.f);
    v0 = sqr(0.726f * bm + 0.812f * sqr(bm) + 3.7f * std::pow(bm, 20.f));
    constexpr float kSqrtPiOver8 = 0.626657069f;
    s = kSqrtPiOver8 * (0.265f * bn + 1.194f * sqr(bn) + 5.372f * std::pow(bn, 22.f));
    sin_alpha = std::sin(radians(alpha_degrees));
    cos_alpha = safe_sqrt(1.f - sqr(sin_alpha));
}

Rgb HairBxdf::f(Vec3f wo, Vec3f wi, TransportMode) const {
    FiberGeometry g = fiber_geometry(*this, wo);
    float sin_i = wi.x, cos_i = safe_sqrt(1.f - sqr(sin_i));
    float phi = std::atan2(wi.z, wi.y) - g.phi_o;
    std::array<Rgb, kPMax + 1> a = ap(g.cos_o, eta, h, g.t);
    Rgb sum(0.f);
    for (int p = 0; p < kPMax; ++p)
        sum += a[size_t(p)] *
               (mp(cos_i, g.cos_po[size_t(p)], sin_i, g.sin_po[size_t(p)], variance(*this, p)) *
                np(phi, p, s, g.gamma_o, g.gamma_t));
    sum += a[kPMax] * (mp(cos_i, g.cos_o, sin_i, g.sin_o, variance(*this, kPMax)) * kInv2Pi);
    if (std::abs(wi.z) > 0.f)
        sum /= std::abs(wi.z);
    return sum;
}

std::optional<BsdfSample> HairBxdf::sample_f(Vec3f wo, float uc, Vec2f u, TransportMode) const {
    FiberGeometry g = fiber_geometry(*this, wo);
    std::array<float, kPMax + 1> w = lobe_pdf(*this, g);
    // Choose a lobe with uc, then reuse what is left of uc for the azimuth.
    int p = 0;
    while (p < kPMax && uc >= w[size_t(p)]) {
        uc -= w[size_t(p)];
        ++p;
    }
    if (!(w[size_t(p)] > 0.f))
        return std::nullopt;
    uc = std::min(uc / w[size_t(p)], kOneMinusEpsilon);

    float sin_po = p < kPMax ? g.sin_po[size_t(p)] : g.sin_o;
    float cos_po = p < kPMax ? g.cos_po[size_t(p)] : g.cos_o;
    // Mp: theta_i about the lobe's tilted theta_o (d'Eon et al. 2013).
    float v = variance(*this, p);
    float cos_theta = 1.f + v * std::log(std::max(u.x, 1e-5f) + (1.f - u.x) * std::exp(-2.f / v));
    float sin_theta = safe_sqrt(1.f - sqr(cos_theta));
    float cos_phi = std::cos(2.f * kPi * u.y);
    float sin_i = -cos_theta * sin_po + sin_theta * cos_phi * cos_po;
    float cos_i = safe_sqrt(1.f - sqr(sin_i));
    // Np: the azimuth about the lobe's exit azimuth.
    float dphi = p < kPMax
                     ? phi_p(p, g.gamma_o, g.gamma_t) + sample_trimmed_logistic(uc, s, -kPi, kPi)
                     : 2.f * kPi * uc;
    float phi_i = g.phi_o + dphi;

    BsdfSample bs;
    bs.wi = {sin_i, cos_i * std::cos(phi_i), cos_i * std::sin(phi_i)};
    bs.pdf = mixture_pdf(*this, g, w, sin_i, cos_i, dphi);
    bs.f = f(wo, bs.wi, TransportMode::Radiance);
    bs.flags = flags();
    return bs;
}

float HairBxdf::pdf(Vec3f wo, Vec3f wi, TransportMode) const {
    FiberGeometry g = fiber_geometry(*this, wo);
    float sin_i = wi.x, cos_i = safe_sqrt(1.f - sqr(sin_i));
    float phi = std::atan2(wi.z, wi.y) - g.phi_o;
    return mixture_pdf(*this, g, lobe_pdf(*this, g), sin_i, cos_i, phi);
}

Rgb HairBxdf::sigma_a_from_concentration(float eumelanin, float pheomelanin) {
    const Rgb eu(0.419f, 0.697f, 1.37f), pheo(0.187f, 0.4f, 1.05f);
    return eu * eumelanin + pheo * pheomelanin;
}

Rgb HairBxdf::sigma_a_from_reflectance(Rgb c, float beta_n) {
    float bn = beta_n;
    float denom = 5.969f - 0.215f * bn + 2.532f * sqr(bn) - 10.73f * std::pow(bn, 3.f) +
                  5.574f * std::pow(bn, 4.f) + 0.245f * std::pow(bn, 5.f);
    auto one = [&](float x) { return sqr(std::log(x) / denom); };
    return Rgb(one(c.r), one(c.g), one(c.b));
}

}  // namespace tessera
