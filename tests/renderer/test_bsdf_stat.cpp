// Chi-square tests of every BSDF sampling routine against its pdf (tests/chi2.h), plus the
// normalisation of each non-delta pdf. Fixed seeds; significance 0.01 Bonferroni-corrected over
// all the chi-square tests of this file.
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "approx.h"
#include "bsdf_test_util.h"
#include "chi2.h"
#include "renderer/shading/bsdf.h"
#include "sampling/warp.h"

using namespace tessera;
using tessera::test::dir_from_theta;

namespace {

struct Case {
    std::string family;  // which TEST_CASE runs it
    std::string name;    // output file name
    Bxdf bxdf;
    Vec3f wo;
};

std::string fmt(float v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

std::vector<Case> all_cases() {
    std::vector<Case> cases;
    for (float th : {0.f, 60.f, 89.f}) {
        cases.push_back(
            {"diffuse", "diffuse_" + fmt(th), DiffuseBxdf{Rgb(0.7f)}, dir_from_theta(th)});
    }
    cases.push_back({"diffuse", "diffuse_below", DiffuseBxdf{Rgb(0.7f)}, -dir_from_theta(40.f)});

    Rgb cu_eta(0.2f, 0.92f, 1.1f), cu_k(3.9f, 2.45f, 2.14f);
    for (float a : {0.05f, 0.3f, 0.8f}) {
        for (float th : {0.f, 45.f, 80.f}) {
            cases.push_back({"conductor", "conductor_a" + fmt(a) + "_t" + fmt(th),
                             ConductorBxdf{TrowbridgeReitz(a, a), cu_eta, cu_k},
                             dir_from_theta(th)});
        }
    }
    cases.push_back({"conductor", "conductor_aniso1",
                     ConductorBxdf{TrowbridgeReitz(0.1f, 0.5f), cu_eta, cu_k},
                     dir_from_theta(50.f, 20.f)});
    cases.push_back({"conductor", "conductor_aniso2",
                     ConductorBxdf{TrowbridgeReitz(0.6f, 0.15f), cu_eta, cu_k},
                     dir_from_theta(70.f, 110.f)});
    cases.push_back({"conductor", "conductor_below",
                     ConductorBxdf{TrowbridgeReitz(0.3f, 0.3f), cu_eta, cu_k},
                     -dir_from_theta(30.f)});

    for (float eta : {1.5f, 1.f / 1.5f}) {
        for (float a : {0.1f, 0.5f}) {
            for (float th : {10.f, 60.f, 85.f}) {
                cases.push_back({"dielectric",
                                 "dielectric_eta" + fmt(eta) + "_a" + fmt(a) + "_t" + fmt(th),
                                 DielectricBxdf{eta, TrowbridgeReitz(a, a)}, dir_from_theta(th)});
            }
        }
    }
    // Seen from inside (wo below the surface), and anisotropic.
    cases.push_back({"dielectric", "dielectric_inside",
                     DielectricBxdf{1.5f, TrowbridgeReitz(0.3f, 0.3f)}, -dir_from_theta(35.f)});
    cases.push_back({"dielectric", "dielectric_aniso",
                     DielectricBxdf{1.33f, TrowbridgeReitz(0.05f, 0.4f)}, dir_from_theta(40.f)});

    for (float th : {0.f, 60.f}) {
        cases.push_back({"diffusetransmission", "diffusetransmission_t" + fmt(th),
                         DiffuseTransmissionBxdf{Rgb(0.3f, 0.5f, 0.1f), Rgb(0.6f, 0.2f, 0.4f)},
                         dir_from_theta(th)});
    }
    cases.push_back({"diffusetransmission", "diffusetransmission_below",
                     DiffuseTransmissionBxdf{Rgb(0.7f), Rgb(0.2f)}, -dir_from_theta(30.f)});
    return cases;
}

void run_family(const std::string &family) {
    std::vector<Case> cases = all_cases();
    uint64_t seed = 1234;
    int ran = 0;
    for (const Case &c : cases) {
        ++seed;
        if (c.family != family)
            continue;
        ++ran;
        test::Chi2Options opt;
        opt.num_tests = static_cast<int>(cases.size());
        opt.seed = seed;
        const Bxdf &bxdf = c.bxdf;
        Vec3f wo = c.wo;
        // Delta samples are left out (nullopt): the test then checks their probability through
        // the rejected-samples bin, whose expected count is N * (1 - integral of the pdf).
        auto sampler = [&](Vec2f u, float uc) -> std::optional<Vec3f> {
            auto s = std::visit(
                [&](const auto &b) { return b.sample_f(wo, uc, u, TransportMode::Radiance); },
                bxdf);
            if (!s || s->is_specular())
                return std::nullopt;
            return s->wi;
        };
        auto pdf = [&](Vec3f wi) -> double {
            return std::visit([&](const auto &b) { return b.pdf(wo, wi, TransportMode::Radiance); },
                              bxdf);
        };
        test::Chi2Result r = test::chi2_sphere(c.name, sampler, pdf, opt);
        INFO(r.message);
        CHECK(r.passed);
        // A normalised pdf integrates to <= 1 (less where samples can fail or be delta).
        CHECK(r.pdf_integral <= 1.0 + 1e-3);
        MESSAGE(r.message);
    }
    CHECK(ran > 0);
}

}  // namespace

TEST_CASE("chi2 helper: p-values of the chi-square distribution") {
    // Reference values: P(X >= x) for chi-square(k).
    CHECK(test::chi2_p_value(3.841459, 1) == test::Approx(0.05).epsilon(1e-5));
    CHECK(test::chi2_p_value(6.634897, 1) == test::Approx(0.01).epsilon(1e-5));
    CHECK(test::chi2_p_value(2.0, 2) == test::Approx(std::exp(-1.0)).epsilon(1e-9));
    CHECK(test::chi2_p_value(124.342, 100) == test::Approx(0.05).epsilon(1e-3));
    CHECK(test::chi2_p_value(1000.0, 1000) == test::Approx(0.4940).epsilon(2e-3));
}

TEST_CASE("chi2 helper: rejects a sampler that does not match its pdf") {
    // Cosine-weighted samples tested against a uniform-hemisphere pdf must fail.
    auto sampler = [](Vec2f u, float) -> std::optional<Vec3f> {
        return sampling::square_to_cosine_hemisphere(u);
    };
    auto pdf = [](Vec3f w) -> double { return w.z > 0 ? kInv2Pi : 0.0; };
    test::Chi2Options opt;
    opt.sample_count = 100000;
    test::Chi2Result r = test::chi2_sphere("selftest_mismatch", sampler, pdf, opt);
    CHECK_FALSE(r.passed);
    CHECK(r.pdf_integral == test::Approx(1.0).epsilon(1e-4));
}

TEST_CASE("chi2: diffuse") {
    run_family("diffuse");
}
TEST_CASE("chi2: conductor (isotropic and anisotropic GGX)") {
    run_family("conductor");
}
TEST_CASE("chi2: diffuse transmission (reflection on wo's side, transmission on the other)") {
    run_family("diffusetransmission");
}
TEST_CASE("chi2: rough dielectric (reflection + transmission)") {
    run_family("dielectric");
}
TEST_CASE("chi2: rough dielectric restricted to reflection or to transmission") {
    // pbrt-v4's BxDFReflTransFlags, as the layered BSDF's random walk uses them: the lobe left
    // is sampled with probability 1, and pdf() with the same restriction is its density.
    struct Restricted {
        const char *name;
        float eta, alpha, theta;
        BxdfReflTrans lobes;
    };
    const Restricted cases[] = {
        {"dielectric_refl_outside", 1.5f, 0.3f, 40.f, kReflTransReflection},
        {"dielectric_trans_outside", 1.5f, 0.3f, 40.f, kReflTransTransmission},
        {"dielectric_refl_inside", 1.5f, 0.2f, 150.f, kReflTransReflection},
        {"dielectric_trans_inside", 1.5f, 0.2f, 150.f, kReflTransTransmission},
        {"dielectric_trans_grazing", 1.f / 1.3f, 0.5f, 80.f, kReflTransTransmission},
    };
    uint64_t seed = 777;
    for (const Restricted &c : cases) {
        DielectricBxdf b{c.eta, TrowbridgeReitz(c.alpha, c.alpha)};
        Vec3f wo = dir_from_theta(c.theta);
        int wrong_lobe = 0;
        auto sampler = [&](Vec2f u, float uc) -> std::optional<Vec3f> {
            auto s = b.sample_f(wo, uc, u, TransportMode::Radiance, c.lobes);
            if (!s)
                return std::nullopt;
            // Only the lobe asked for.
            if (same_hemisphere(wo, s->wi) != (c.lobes == kReflTransReflection))
                ++wrong_lobe;
            return s->wi;
        };
        auto pdf = [&](Vec3f wi) -> double {
            return b.pdf(wo, wi, TransportMode::Radiance, c.lobes);
        };
        test::Chi2Options opt;
        opt.seed = ++seed;
        opt.sample_count = 200000;
        opt.num_tests = static_cast<int>(all_cases().size()) + 6;
        test::Chi2Result r = test::chi2_sphere(c.name, sampler, pdf, opt);
        INFO(r.message);
        CHECK(r.passed);
        CHECK(r.pdf_integral <= 1.0 + 1e-3);
        CHECK(wrong_lobe == 0);
        MESSAGE(r.message);
    }
}

TEST_CASE("chi2: Bsdf world-space wrapper with a rotated anisotropic frame") {
    Frame frame = Frame::from_xz(normalize(Vec3f(1, 2, 0.5f)), normalize(Vec3f(0.3f, -0.4f, 0.8f)));
    Bsdf bsdf(frame, ConductorBxdf{TrowbridgeReitz(0.4f, 0.1f), Rgb(1.5f), Rgb(3.f)});
    Vec3f wo = frame.to_world(dir_from_theta(55.f, 70.f));
    auto sampler = [&](Vec2f u, float uc) -> std::optional<Vec3f> {
        auto s = bsdf.sample_f(wo, uc, u);
        if (!s)
            return std::nullopt;
        return s->wi;
    };
    auto pdf = [&](Vec3f wi) -> double { return bsdf.pdf(wo, wi); };
    test::Chi2Options opt;
    opt.seed = 99;
    opt.num_tests = static_cast<int>(all_cases().size()) + 1;
    test::Chi2Result r = test::chi2_sphere("bsdf_world", sampler, pdf, opt);
    INFO(r.message);
    CHECK(r.passed);
}

TEST_CASE("pdf normalisation of the non-delta lobes") {
    // Where no sample can fail, the pdf integrates to 1.
    auto integral = [](const Bxdf &b, Vec3f wo) {
        return test::integrate_pdf_sphere([&](Vec3f wi) -> double {
            return std::visit([&](const auto &x) { return x.pdf(wo, wi, TransportMode::Radiance); },
                              b);
        });
    };
    CHECK(integral(DiffuseBxdf{Rgb(1.f)}, dir_from_theta(30.f)) ==
          test::Approx(1.0).epsilon(1e-4));
    // At normal incidence the visible normals are D(wm) cos(theta_m), and a reflection leaves
    // the hemisphere exactly when tan^2(theta_m) > 1, which has probability a^2 / (1 + a^2).
    CHECK(integral(ConductorBxdf{TrowbridgeReitz(0.2f, 0.2f), Rgb(1.f), Rgb(5.f)},
                   dir_from_theta(0.f)) == test::Approx(1.0 / (1.0 + 0.04)).epsilon(1e-4));
    // Rough dielectric: reflection + transmission together make 1 (no TIR from outside), less
    // the sampled reflections that leave below the surface and the refractions that leave
    // above it, which have no pdf: 0.9908 here.
    const double rough = integral(DielectricBxdf{1.5f, TrowbridgeReitz(0.3f, 0.3f)},
                                  dir_from_theta(20.f));
    CHECK(rough > 0.98);
    CHECK(rough < 1.0 + 1e-3);
    // Restricted to one lobe, each half integrates to 1 on its own, less what leaves on the
    // wrong side: the reflection exactly as much as a conductor of the same roughness loses.
    const DielectricBxdf glass{1.5f, TrowbridgeReitz(0.3f, 0.3f)};
    const Vec3f wo20 = dir_from_theta(20.f);
    const double refl = test::integrate_pdf_sphere([&](Vec3f wi) -> double {
        return glass.pdf(wo20, wi, TransportMode::Radiance, kReflTransReflection);
    });
    CHECK(refl == test::Approx(integral(ConductorBxdf{TrowbridgeReitz(0.3f, 0.3f), Rgb(1.f),
                                                      Rgb(5.f)},
                                        wo20))
                      .epsilon(1e-4));
    const double trans = test::integrate_pdf_sphere([&](Vec3f wi) -> double {
        return glass.pdf(wo20, wi, TransportMode::Radiance, kReflTransTransmission);
    });
    CHECK(trans > 0.97);
    CHECK(trans < 1.0 + 1e-3);
}
