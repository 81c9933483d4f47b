// Unit tests of the BSDF models: Fresnel and Snell against closed forms, microfacet
// normalisation, reciprocity, sample_f/f/pdf consistency, energy (white furnace) and the edge
// cases that must never produce NaN or Inf.
#include <cmath>
#include <complex>
#include <random>
#include <vector>

#include "approx.h"
#include "bsdf_test_util.h"
#include "chi2.h"
#include "renderer/shading/bsdf.h"
#include "renderer/shading/microfacet.h"
#include "sampling/warp.h"

using namespace tessera;
using tessera::test::Approx;
using tessera::test::dir_from_theta;

namespace {

template <typename B>
Rgb eval_f(const B &b, Vec3f wo, Vec3f wi, TransportMode m = TransportMode::Radiance) {
    return b.f(wo, wi, m);
}

/// Integral over the sphere of a scalar function of direction (adaptive Simpson, tests/chi2.h).
double integrate_sphere(const std::function<double(Vec3f)> &fn) {
    double sum = 0;
    for (double v : test::integrate_pdf_bins(fn, 20, 40, 2, 1e-6))
        sum += v;
    return sum;
}

/// Directional albedo of the non-delta part of a Bxdf, channel c: int f |cos| dwi.
double albedo_quadrature(const Bxdf &b, Vec3f wo, int c = 0) {
    return integrate_sphere([&](Vec3f wi) -> double {
        Rgb f = std::visit([&](const auto &x) { return x.f(wo, wi, TransportMode::Radiance); }, b);
        return f[c] * std::abs(wi.z);
    });
}

/// Monte Carlo directional albedo from sample_f: mean of f |cos| / pdf (all lobes, channel c).
double albedo_mc(const Bxdf &b, Vec3f wo, int n, uint64_t seed, int c = 0,
                 TransportMode mode = TransportMode::Radiance) {
    test::Chi2Rng rng(seed);
    double sum = 0;
    for (int i = 0; i < n; ++i) {
        float uc = rng.uniform();
        Vec2f u = rng.uniform2();
        auto s = std::visit([&](const auto &x) { return x.sample_f(wo, uc, u, mode); }, b);
        if (s)
            sum += s->f[c] * std::abs(s->wi.z) / s->pdf;
    }
    return sum / n;
}

std::vector<Bxdf> rough_models() {
    return {
        DiffuseBxdf{Rgb(0.8f, 0.5f, 0.2f)},
        ConductorBxdf{TrowbridgeReitz(0.3f, 0.3f), Rgb(0.2f, 0.9f, 1.1f), Rgb(3.9f, 2.4f, 2.1f)},
        ConductorBxdf{TrowbridgeReitz(0.05f, 0.6f), Rgb(1.5f), Rgb(3.f)},
        DielectricBxdf{1.5f, TrowbridgeReitz(0.2f, 0.2f)},
        DielectricBxdf{1.f / 1.33f, TrowbridgeReitz(0.5f, 0.1f)},
        DiffuseTransmissionBxdf{Rgb(0.3f, 0.5f, 0.1f), Rgb(0.6f, 0.2f, 0.4f)},
    };
}

/// The layered models (stochastic f and pdf, proportional sample pdf): only the tests that
/// hold for any BSDF run on them here; tests/renderer/test_layered_bxdf*.cpp test the rest.
std::vector<Bxdf> layered_models() {
    auto metal = [](float alpha) {
        return ConductorBxdf{TrowbridgeReitz(alpha, alpha), Rgb(0.15f, 0.4f, 1.2f) / 1.5f,
                             Rgb(3.5f, 2.4f, 1.8f) / 1.5f};
    };
    return {
        CoatedDiffuseBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(0.3f, 0.3f)},
                          DiffuseBxdf{Rgb(0.6f, 0.3f, 0.9f)}, 0.05f, Rgb(0.f), 0.f, 10, 1),
        CoatedDiffuseBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(0.f, 0.f)}, DiffuseBxdf{Rgb(0.6f)},
                          0.01f, Rgb(0.5f), 0.3f, 10, 2),
        CoatedConductorBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(0.2f, 0.2f)}, metal(0.3f), 0.01f,
                            Rgb(0.f), 0.f, 10, 1),
        CoatedConductorBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(0.f, 0.f)}, metal(0.25f), 0.01f,
                            Rgb(0.f), 0.f, 10, 1),
        CoatedConductorBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(0.4f, 0.4f)}, metal(0.f), 0.1f,
                            Rgb(0.8f), -0.5f, 10, 1),
    };
}

}  // namespace

TEST_CASE("Fresnel: dielectric against closed forms") {
    for (float eta : {1.33f, 1.5f, 2.4f}) {
        float r0 = sqr((eta - 1.f) / (eta + 1.f));
        CHECK(fr_dielectric(1.f, eta) == Approx(r0).epsilon(1e-5));
        CHECK(fr_dielectric(-1.f, eta) == Approx(r0).epsilon(1e-5));  // from inside
        CHECK(fr_dielectric(0.f, eta) == Approx(1.f));                // grazing
        // Brewster's angle: the parallel component vanishes; F = r_perp^2 / 2.
        float tb = std::atan(eta);
        float ci = std::cos(tb), ct = std::cos(kPiOver2 - tb);
        float r_perp = (ci - eta * ct) / (ci + eta * ct);
        CHECK(fr_dielectric(ci, eta) == Approx(0.5f * r_perp * r_perp).epsilon(1e-4));
        // Total internal reflection beyond the critical angle from inside.
        float crit = std::asin(1.f / eta);
        CHECK(fr_dielectric(-std::cos(crit + 0.01f), eta) == 1.f);
        CHECK(fr_dielectric(-std::cos(crit - 0.01f), eta) < 1.f);
    }
    CHECK(fr_dielectric(0.5f, 1.f) == Approx(0.f));
}

TEST_CASE("Fresnel: conductor against closed forms") {
    // Normal incidence: ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
    for (auto [n, k] : {std::pair{0.2f, 3.9f}, std::pair{1.5f, 0.f}, std::pair{2.7f, 3.8f}}) {
        float expect = (sqr(n - 1.f) + k * k) / (sqr(n + 1.f) + k * k);
        CHECK(fr_complex(1.f, n, k) == Approx(expect).epsilon(1e-4));
    }
    // k = 0 reduces to the dielectric formula.
    for (float c : {0.1f, 0.5f, 0.9f})
        CHECK(fr_complex(c, 1.5f, 0.f) == Approx(fr_dielectric(c, 1.5f)).epsilon(1e-4));
    CHECK(fr_complex(0.f, 0.2f, 3.9f) == Approx(1.f));
    // Everywhere: the complex Fresnel equations in double precision (fr_complex evaluates them
    // in real arithmetic), across incidence for metals, a dielectric, total internal reflection
    // (k = 0, eta < 1) and near-degenerate pairs.
    auto reference = [](double c, double eta, double k) {
        using C = std::complex<double>;
        const C e(eta, k);
        const C cos_t = std::sqrt(C(1.0) - C(1.0 - c * c) / (e * e));
        const C r_parl = (e * c - cos_t) / (e * c + cos_t);
        const C r_perp = (C(c) - e * cos_t) / (C(c) + e * cos_t);
        return 0.5 * (std::norm(r_parl) + std::norm(r_perp));
    };
    const std::pair<float, float> iors[] = {{0.2f, 3.9f}, {1.1f, 2.6f}, {2.7f, 3.8f},
                                            {1.5f, 0.f},  {0.5f, 0.f},  {1.f, 1e-3f},
                                            {0.05f, 5.f}, {3.f, 0.1f},  {1.f, 0.f}};
    for (const std::pair<float, float> &ior : iors)
        for (int i = 1; i <= 40; ++i) {
            const float eta = ior.first, k = ior.second;
            const float c = float(i) / 40.f;
            CAPTURE(eta);
            CAPTURE(k);
            CAPTURE(c);
            CHECK(std::abs(double(fr_complex(c, eta, k)) - reference(c, eta, k)) <= 2e-6);
        }
    CHECK(fr_complex(0.7f, 1.f, 1e4f) > 0.999f);
    // "reflectance" parameter mapping reproduces r at normal incidence.
    Rgb r(0.9f, 0.5f, 0.05f);
    Rgb k = conductor_k_from_reflectance(r);
    Rgb f0 = fr_complex(1.f, Rgb(1.f), k);
    for (int c = 0; c < 3; ++c)
        CHECK(f0[c] == Approx(r[c]).epsilon(1e-4));
}

TEST_CASE("reflect and refract follow the mirror law and Snell's law") {
    Vec3f n(0, 0, 1);
    Vec3f wo = dir_from_theta(40.f);
    Vec3f r = reflect(wo, n);
    CHECK(r.x == Approx(-wo.x));
    CHECK(r.z == Approx(wo.z));
    float etap;
    Vec3f wt;
    REQUIRE(refract(wo, n, 1.5f, &etap, &wt));
    CHECK(etap == 1.5f);
    CHECK(length(wt) == Approx(1.f).epsilon(1e-5));
    CHECK(wt.z < 0.f);
    CHECK(sin_theta(wt) * 1.5f == Approx(sin_theta(wo)).epsilon(1e-5));
    CHECK(dot(cross(wo, n), wt) == Approx(0.f).epsilon(1e-5));  // in the plane of incidence
    // From inside at 60 degrees (beyond the 41.8 degree critical angle): total internal reflection.
    CHECK_FALSE(refract(-dir_from_theta(60.f), n, 1.5f, &etap, &wt));
    REQUIRE(refract(-dir_from_theta(30.f), n, 1.5f, &etap, &wt));
    CHECK(etap == Approx(1.f / 1.5f));
    CHECK(wt.z > 0.f);
}

TEST_CASE("Trowbridge-Reitz: D and visible normals are normalised, G1 is Smith's") {
    for (auto [ax, ay] : {std::pair{0.1f, 0.1f}, std::pair{0.5f, 0.5f}, std::pair{0.2f, 0.7f}}) {
        TrowbridgeReitz d(ax, ay);
        // int D(wm) cos(theta_m) dwm = 1 (projected area of the microsurface).
        CHECK(integrate_sphere([&](Vec3f wm) -> double { return wm.z > 0 ? d.d(wm) * wm.z : 0; }) ==
              Approx(1.0).epsilon(2e-3));
        // int D_w(wm) dwm = 1 for the visible normals of any w.
        for (float th : {0.f, 45.f, 80.f}) {
            Vec3f w = dir_from_theta(th, 10.f);
            CHECK(integrate_sphere([&](Vec3f wm) -> double {
                      return wm.z > 0 ? d.pdf(w, wm) : 0;
                  }) == Approx(1.0).epsilon(3e-3));
        }
    }
    TrowbridgeReitz d(0.5f, 0.5f);
    Vec3f w = dir_from_theta(60.f);
    // Isotropic closed form: Lambda = (sqrt(1 + a^2 tan^2) - 1) / 2.
    float t2 = tan2_theta(w);
    CHECK(d.lambda(w) == Approx(0.5f * (std::sqrt(1.f + 0.25f * t2) - 1.f)).epsilon(1e-5));
    CHECK(d.g1(Vec3f(0, 0, 1)) == Approx(1.f));
    CHECK(d.g(w, w) <= d.g1(w));
    CHECK(TrowbridgeReitz::roughness_to_alpha(0.25f) == Approx(0.5f));
    CHECK(TrowbridgeReitz(5e-4f, 5e-4f).effectively_smooth());
    CHECK_FALSE(TrowbridgeReitz(2e-3f, 5e-4f).effectively_smooth());
    // Sampled normals are unit and on the +z side, for w on either side.
    test::Chi2Rng rng(3);
    for (int i = 0; i < 1000; ++i) {
        Vec3f wm = d.sample_wm(i % 2 ? w : -w, rng.uniform2());
        CHECK(length(wm) == Approx(1.f).epsilon(1e-5));
        CHECK(wm.z > 0.f);
    }
}

TEST_CASE("reciprocity of the reflection lobes") {
    test::Chi2Rng rng(11);
    for (const Bxdf &b : rough_models()) {
        for (int i = 0; i < 200; ++i) {
            Vec3f wo = sampling::square_to_uniform_hemisphere(rng.uniform2());
            Vec3f wi = sampling::square_to_uniform_hemisphere(rng.uniform2());
            Rgb a = std::visit([&](const auto &x) { return eval_f(x, wo, wi); }, b);
            Rgb c = std::visit([&](const auto &x) { return eval_f(x, wi, wo); }, b);
            for (int ch = 0; ch < 3; ++ch) {
                CHECK(a[ch] == Approx(c[ch]).epsilon(1e-4));
            }
        }
    }
}

TEST_CASE("dielectric transmission: adjoint and generalized reciprocity") {
    // f_importance(wi, wo) = f_radiance(wo, wi) (PBRT section 9.5.2) and
    // f(wo, wi) / n(wo)^2 = f(wi, wo) / n(wi)^2 (Veach 1997, eq. 5.14).
    const float eta = 1.5f;
    DielectricBxdf b{eta, TrowbridgeReitz(0.3f, 0.3f)};
    test::Chi2Rng rng(12);
    int tested = 0;
    for (int i = 0; i < 500; ++i) {
        Vec3f wo = sampling::square_to_uniform_sphere(rng.uniform2());
        Vec3f wi = sampling::square_to_uniform_sphere(rng.uniform2());
        if (same_hemisphere(wo, wi))
            continue;
        float f_rad = b.f(wo, wi, TransportMode::Radiance).r;
        float f_imp_rev = b.f(wi, wo, TransportMode::Importance).r;
        float f_rad_rev = b.f(wi, wo, TransportMode::Radiance).r;
        if (f_rad < 1e-4f)
            continue;
        ++tested;
        CHECK(f_imp_rev == Approx(f_rad).epsilon(1e-3));
        float n_o = wo.z > 0 ? 1.f : eta, n_i = wi.z > 0 ? 1.f : eta;
        CHECK(f_rad / (n_o * n_o) == Approx(f_rad_rev / (n_i * n_i)).epsilon(1e-3));
    }
    CHECK(tested > 30);
}

TEST_CASE("sample_f agrees with f and pdf, and f |cos| / pdf is the sample weight") {
    test::Chi2Rng rng(21);
    for (const Bxdf &b : rough_models()) {
        for (float th : {5.f, 45.f, 80.f}) {
            for (Vec3f wo : {dir_from_theta(th), -dir_from_theta(th, 200.f)}) {
                int ok = 0;
                for (int i = 0; i < 300; ++i) {
                    float uc = rng.uniform();
                    Vec2f u = rng.uniform2();
                    auto s = std::visit(
                        [&](const auto &x) {
                            return x.sample_f(wo, uc, u, TransportMode::Radiance);
                        },
                        b);
                    if (!s)
                        continue;
                    CHECK(length(s->wi) == Approx(1.f).epsilon(1e-4));
                    CHECK(s->pdf > 0.f);
                    if (s->is_specular())
                        continue;
                    ++ok;
                    Rgb f = std::visit([&](const auto &x) { return eval_f(x, wo, s->wi); }, b);
                    float pdf = std::visit(
                        [&](const auto &x) { return x.pdf(wo, s->wi, TransportMode::Radiance); },
                        b);
                    CHECK(pdf == Approx(s->pdf).epsilon(2e-3));
                    for (int ch = 0; ch < 3; ++ch)
                        CHECK(f[ch] == Approx(s->f[ch]).epsilon(2e-3));
                    if (s->is_transmission()) {
                        // Refraction has eta != 1; diffuse transmission does not refract.
                        if (std::holds_alternative<DiffuseTransmissionBxdf>(b))
                            CHECK(s->eta == 1.f);
                        else
                            CHECK(s->eta != 1.f);
                        CHECK_FALSE(same_hemisphere(wo, s->wi));
                    } else {
                        CHECK(same_hemisphere(wo, s->wi));
                    }
                }
                CHECK(ok > 0);
            }
        }
    }
}

TEST_CASE("white furnace: diffuse with reflectance 1 has albedo 1") {
    DiffuseBxdf b{Rgb(1.f)};
    for (float th : {0.f, 45.f, 85.f}) {
        Vec3f wo = dir_from_theta(th);
        CHECK(albedo_mc(b, wo, 20000, 5) == Approx(1.0).epsilon(5e-3));
        CHECK(albedo_quadrature(b, wo) == Approx(1.0).epsilon(5e-3));
    }
}

TEST_CASE("conductors: a mirror with huge k reflects everything, rough ones lose little") {
    ConductorBxdf mirror{TrowbridgeReitz(0.f, 0.f), Rgb(1.f), Rgb(1e4f)};
    for (float th : {0.f, 30.f, 60.f, 89.f}) {
        Vec3f wo = dir_from_theta(th);
        auto s = mirror.sample_f(wo, 0.5f, {0.3f, 0.7f}, TransportMode::Radiance);
        REQUIRE(s);
        CHECK(s->is_specular());
        CHECK(s->wi.x == Approx(-wo.x));
        CHECK(s->wi.z == Approx(wo.z));
        CHECK(s->f.r * std::abs(s->wi.z) / s->pdf == Approx(1.0).epsilon(1e-3));
        CHECK(mirror.f(wo, s->wi, TransportMode::Radiance).is_black());
        CHECK(mirror.pdf(wo, s->wi, TransportMode::Radiance) == 0.f);
    }
    // Rough perfect mirror, alpha 0.1: energy lost only to masking and below-horizon reflections.
    ConductorBxdf rough{TrowbridgeReitz(0.1f, 0.1f), Rgb(1.f), Rgb(1e4f)};
    for (float th : {0.f, 45.f, 70.f}) {
        Vec3f wo = dir_from_theta(th);
        double a_mc = albedo_mc(rough, wo, 20000, 6);
        double a_q = albedo_quadrature(rough, wo);
        CHECK(a_mc <= 1.0);
        CHECK(a_mc > 0.9);
        CHECK(a_q <= 1.0 + 1e-3);
        CHECK(a_q == Approx(a_mc).epsilon(1e-2));
    }
}

TEST_CASE("smooth dielectric: Fresnel split with R + T = 1 and the eta^2 radiance factor") {
    for (float eta : {1.5f, 1.f / 1.5f, 1.33f}) {
        DielectricBxdf b{eta, TrowbridgeReitz(0.f, 0.f)};
        CHECK(b.flags() == (kBxdfReflection | kBxdfTransmission | kBxdfSpecular));
        for (float th : {0.f, 30.f, 60.f, 85.f}) {
            Vec3f wo = dir_from_theta(th);
            float r = fr_dielectric(wo.z, eta);
            // uc below R picks reflection, above it transmission.
            auto sr = b.sample_f(wo, 0.5f * r, {0.5f, 0.5f}, TransportMode::Radiance);
            double reflected = 0, transmitted = 0;
            if (r > 0.f) {
                REQUIRE(sr);
                CHECK(sr->is_reflection());
                CHECK(sr->pdf == Approx(r));
                reflected = sr->pdf * sr->f.r * std::abs(sr->wi.z) / sr->pdf;
            }
            auto st = b.sample_f(wo, r + 0.5f * (1.f - r), {0.5f, 0.5f}, TransportMode::Radiance);
            if (r < 1.f) {
                REQUIRE(st);
                CHECK(st->is_transmission());
                CHECK(st->pdf == Approx(1.f - r).epsilon(1e-5));
                float w = st->f.r * std::abs(st->wi.z) / st->pdf;
                // Radiance is divided by eta'^2 across the interface.
                CHECK(w == Approx(1.f / sqr(st->eta)).epsilon(1e-4));
                CHECK(st->eta == Approx(eta));
                CHECK(sin_theta(st->wi) * st->eta == Approx(sin_theta(wo)).epsilon(1e-4));
                transmitted = st->pdf * w * sqr(st->eta);
                auto si =
                    b.sample_f(wo, r + 0.5f * (1.f - r), {0.5f, 0.5f}, TransportMode::Importance);
                REQUIRE(si);
                CHECK(si->f.r * std::abs(si->wi.z) / si->pdf == Approx(1.f).epsilon(1e-4));
            }
            CHECK(reflected + transmitted == Approx(1.0).epsilon(1e-5));
        }
    }
    // Total internal reflection from inside beyond the critical angle: always reflected.
    DielectricBxdf glass{1.5f, TrowbridgeReitz(0.f, 0.f)};
    Vec3f wo = -dir_from_theta(60.f);
    for (float uc : {0.f, 0.5f, kOneMinusEpsilon}) {
        auto s = glass.sample_f(wo, uc, {0.1f, 0.2f}, TransportMode::Radiance);
        REQUIRE(s);
        CHECK(s->is_reflection());
        CHECK(s->f.r * std::abs(s->wi.z) / s->pdf == Approx(1.f));
    }
}

TEST_CASE("dielectric with eta 1 is a pure pass-through") {
    for (float alpha : {0.f, 0.3f}) {
        DielectricBxdf b{1.f, TrowbridgeReitz(alpha, alpha)};
        CHECK(b.flags() == (kBxdfTransmission | kBxdfSpecular));
        Vec3f wo = dir_from_theta(50.f);
        for (float uc : {0.f, 0.7f, kOneMinusEpsilon}) {
            auto s = b.sample_f(wo, uc, {0.4f, 0.9f}, TransportMode::Radiance);
            REQUIRE(s);
            CHECK(s->is_transmission());
            CHECK(s->wi.x == Approx(-wo.x));
            CHECK(s->wi.z == Approx(-wo.z));
            CHECK(s->f.r * std::abs(s->wi.z) / s->pdf == Approx(1.f));
            CHECK(s->eta == Approx(1.f));
        }
        CHECK(b.f(wo, -wo, TransportMode::Radiance).is_black());
        CHECK(b.pdf(wo, -wo, TransportMode::Radiance) == 0.f);
    }
}

TEST_CASE("rough dielectric: energy of reflection + transmission") {
    // With the eta'^2 factor undone (Importance mode), the single-scattering energy is <= 1
    // and close to 1 for moderate roughness.
    for (float eta : {1.5f, 1.f / 1.5f}) {
        DielectricBxdf b{eta, TrowbridgeReitz(0.2f, 0.2f)};
        double a = albedo_mc(b, dir_from_theta(30.f), 40000, 8, 0, TransportMode::Importance);
        CHECK(a <= 1.0 + 1e-3);
        CHECK(a > 0.9);
    }
}

TEST_CASE("Bsdf wrapper: world frame, flags and albedo hint") {
    Frame frame = Frame::from_z(normalize(Vec3f(0.2f, 0.9f, -0.3f)));
    Bsdf diffuse(frame, DiffuseBxdf{Rgb(0.4f, 0.5f, 0.6f)});
    Vec3f wo = frame.to_world(dir_from_theta(30.f));
    Vec3f wi = frame.to_world(dir_from_theta(60.f, 250.f));
    CHECK(diffuse.f(wo, wi).g == Approx(0.5f * kInvPi));
    CHECK(diffuse.f(wo, -wi).is_black());
    CHECK(diffuse.pdf(wo, wi) == Approx(0.5f * kInvPi));  // cos 60 / pi
    auto s = diffuse.sample_f(wo, 0.3f, {0.2f, 0.8f});
    REQUIRE(s);
    CHECK(dot(s->wi, frame.z) > 0.f);
    CHECK(diffuse.flags() == (kBxdfReflection | kBxdfDiffuse));
    CHECK(diffuse.has_non_specular());
    CHECK(diffuse.albedo_hint().b == Approx(0.6f));
    // Unnormalised inputs are accepted.
    CHECK(diffuse.f(wo * 3.f, wi * 0.5f).g == Approx(0.5f * kInvPi));

    Bsdf glass(frame, DielectricBxdf{1.5f, TrowbridgeReitz(0.f, 0.f)});
    CHECK_FALSE(glass.has_non_specular());
    CHECK(glass.albedo_hint().r == 1.f);
    Bsdf metal(frame, ConductorBxdf{TrowbridgeReitz(0.2f, 0.2f), Rgb(1.f), Rgb(1e4f)});
    CHECK(metal.flags() == (kBxdfReflection | kBxdfGlossy));
    CHECK(metal.albedo_hint().r == Approx(1.f).epsilon(1e-3));
    Bsdf coated(frame, CoatedDiffuseBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(0.f, 0.f)},
                                         DiffuseBxdf{Rgb(0.3f)}, 0.01f, Rgb(0.f), 0.f, 10, 1));
    CHECK(coated.flags() == (kBxdfReflection | kBxdfDiffuse | kBxdfSpecular));
    CHECK(coated.has_non_specular());
    CHECK(coated.albedo_hint().g == Approx(0.3f));
    // A direction in the tangent plane scatters nothing.
    Bsdf flat(Frame{}, DiffuseBxdf{Rgb(0.5f)});
    Vec3f tangent(0.6f, 0.8f, 0.f), up = dir_from_theta(20.f);
    CHECK(flat.f(tangent, up).is_black());
    CHECK_FALSE(flat.sample_f(tangent, 0.5f, {0.5f, 0.5f}));
    CHECK(flat.pdf(tangent, up) == 0.f);
}

TEST_CASE("edge cases never produce NaN or Inf") {
    std::vector<Bxdf> models = rough_models();
    for (const Bxdf &b : layered_models())
        models.push_back(b);
    for (float a : {0.f, 1e-4f, 9e-4f, 1.1e-3f, 1.f}) {
        models.push_back(ConductorBxdf{TrowbridgeReitz(a, a), Rgb(0.2f), Rgb(3.f)});
        models.push_back(DielectricBxdf{1.5f, TrowbridgeReitz(a, a)});
        models.push_back(DielectricBxdf{1.f / 1.5f, TrowbridgeReitz(a, 0.3f)});
        models.push_back(DielectricBxdf{1.f, TrowbridgeReitz(a, a)});
        models.push_back(CoatedDiffuseBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(a, a)},
                                           DiffuseBxdf{Rgb(1.f)}, 1.f, Rgb(0.f), 0.f, 10, 1));
        models.push_back(
            CoatedConductorBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(a, 0.2f)},
                                ConductorBxdf{TrowbridgeReitz(a, a), Rgb(0.2f), Rgb(3.f)}, 1e-3f,
                                Rgb(0.9f), 0.9f, 10, 1));
    }
    models.push_back(ConductorBxdf{TrowbridgeReitz(0.f, 0.5f), Rgb(0.2f), Rgb(3.f)});
    // A coat less dense than the outside (pbrt-v4 keeps eta < 1), a zero thickness.
    models.push_back(CoatedDiffuseBxdf(DielectricBxdf{0.5f, TrowbridgeReitz(0.f, 0.f)},
                                       DiffuseBxdf{Rgb(0.5f)}, 0.f, Rgb(0.f), 0.f, 10, 1));
    std::vector<Vec3f> dirs = {Vec3f(0, 0, 1),         Vec3f(0, 0, -1),
                               Vec3f(1, 0, 0),         Vec3f(0, 1, 0),
                               dir_from_theta(89.99f), -dir_from_theta(89.99f),
                               Vec3f(1e-7f, 0, 1),     normalize(Vec3f(1, 1, 1e-6f)),
                               dir_from_theta(45.f)};
    std::vector<float> us = {0.f, 0.5f, kOneMinusEpsilon};
    int samples = 0;
    for (const Bxdf &b : models) {
        Bsdf bsdf(Frame{}, b);
        for (Vec3f wo : dirs) {
            for (Vec3f wi : dirs) {
                Rgb f = bsdf.f(wo, wi);
                float p = bsdf.pdf(wo, wi);
                Rgb fl = std::visit([&](const auto &x) { return eval_f(x, wo, wi); }, b);
                CHECK(f.is_finite());
                CHECK(fl.is_finite());
                CHECK(std::isfinite(p));
                CHECK(p >= 0.f);
                CHECK(f.r >= 0.f);
            }
            for (float uc : us) {
                for (float ux : us) {
                    for (float uy : us) {
                        auto s = bsdf.sample_f(wo, uc, {ux, uy});
                        if (!s)
                            continue;
                        ++samples;
                        CHECK(s->f.is_finite());
                        CHECK(std::isfinite(s->pdf));
                        CHECK(s->pdf > 0.f);
                        CHECK(std::isfinite(s->eta));
                        CHECK(length(s->wi) == Approx(1.f).epsilon(1e-3));
                    }
                }
            }
        }
    }
    CHECK(samples > 100);
}
