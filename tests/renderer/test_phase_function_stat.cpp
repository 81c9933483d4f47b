// The Henyey-Greenstein phase function (renderer/shading/phase_function.h): chi-square tests of its
// sampling against its density (tests/chi2.h; fixed seeds, significance 0.01 Bonferroni-
// corrected over the file's chi-square tests), normalisation, pbrt-v4's sign convention and
// the clamping of g in sampling.
#include <cmath>

#include "approx.h"
#include "chi2.h"
#include "renderer/shading/phase_function.h"
#include "sampling/warp.h"

using namespace tessera;
using tessera::test::Approx;

namespace {

constexpr float kGs[] = {0.f, 0.3f, -0.6f, 0.9f, -0.95f};
constexpr int kChi2Tests = 2 * int(sizeof(kGs) / sizeof(kGs[0]));

}  // namespace

TEST_CASE("Henyey-Greenstein: the closed form, pbrt-v4's sign and normalisation") {
    // Isotropic for g = 0; (1 - g^2) / (4 pi (1 + g^2 + 2 g cos)^1.5) otherwise.
    CHECK(henyey_greenstein(0.3f, 0.f) == Approx(kInv4Pi).epsilon(1e-6));
    const float g = 0.4f, c = -0.2f;
    CHECK(henyey_greenstein(c, g) ==
          Approx((1 - g * g) / (4 * kPi * std::pow(1 + g * g + 2 * g * c, 1.5f))).epsilon(1e-5));
    // Both directions point away: forward scattering (g > 0) favours wi = -wo.
    HgPhaseFunction forward{0.7f};
    const Vec3f wo = normalize(Vec3f(0.3f, -0.2f, 0.9f));
    CHECK(forward.p(wo, -wo) > 10.f * forward.p(wo, wo));
    CHECK(HgPhaseFunction{-0.7f}.p(wo, wo) == Approx(forward.p(wo, -wo)).epsilon(1e-5));
    CHECK(forward.pdf(wo, -wo) == forward.p(wo, -wo));
    // int p dw = 1 over the sphere, for every g (adaptive quadrature, tests/chi2.h).
    for (float gg : {0.f, 0.3f, -0.6f, 0.9f, 0.99f}) {
        HgPhaseFunction hg{gg};
        const double integral = test::integrate_pdf_sphere(
            [&](Vec3f wi) -> double { return hg.p(Vec3f(0, 0, 1), wi); }, 60, 60, 1e-8);
        INFO("g " << gg);
        CHECK(integral == Approx(1.0).epsilon(gg > 0.95f ? 2e-3 : 2e-4));
    }
}

TEST_CASE("Henyey-Greenstein: the mean cosine is -g, samples are unit with p == pdf") {
    for (float g : kGs) {
        HgPhaseFunction hg{g};
        const Vec3f wo = normalize(Vec3f(-0.5f, 0.4f, 0.2f));
        test::Chi2Rng rng(17);
        double sum = 0;
        int bad = 0;
        const int n = 200000;
        for (int i = 0; i < n; ++i) {
            auto s = hg.sample_p(wo, rng.uniform2());
            if (!s || !(std::abs(length(s->wi) - 1.f) < 1e-5f) || s->p != s->pdf ||
                !(std::abs(s->pdf - hg.pdf(wo, s->wi)) <= 2e-3f * s->pdf)) {
                ++bad;
                continue;
            }
            sum += dot(wo, s->wi);
        }
        // The asymmetry g is the mean cosine of the scattering angle, here between -wo and wi.
        // Standard error <= 1 / sqrt(3 n) = 1.3e-3: 4 sigma.
        INFO("g " << g);
        CHECK(bad == 0);
        CHECK(std::abs(sum / n + g) < 5e-3);
    }
}

TEST_CASE("chi2: Henyey-Greenstein sampling against its density") {
    uint64_t seed = 4200;
    for (float g : kGs) {
        for (Vec3f wo : {Vec3f(0, 0, 1), normalize(Vec3f(0.6f, -0.3f, -0.7f))}) {
            HgPhaseFunction hg{g};
            auto sampler = [&](Vec2f u, float) -> std::optional<Vec3f> {
                auto s = hg.sample_p(wo, u);
                if (!s)
                    return std::nullopt;
                return s->wi;
            };
            auto pdf = [&](Vec3f wi) -> double { return hg.pdf(wo, wi); };
            test::Chi2Options opt;
            opt.seed = ++seed;
            opt.num_tests = kChi2Tests;
            opt.sample_count = 200000;
            char name[64];
            std::snprintf(name, sizeof name, "hg_g%g_z%g", double(g), double(wo.z));
            test::Chi2Result r = test::chi2_sphere(name, sampler, pdf, opt);
            INFO(r.message);
            CHECK(r.passed);
            CHECK(r.pdf_integral == Approx(1.0).epsilon(2e-3));
            MESSAGE(r.message);
        }
    }
}

TEST_CASE("Henyey-Greenstein: sampling clamps g to [-0.99, 0.99], as pbrt-v4 does") {
    // Beyond 0.99 the inversion is unstable; the sample then follows g = 0.99 and reports that
    // lobe's density, while p() and pdf() keep the unclamped g.
    const Vec3f wo(0, 0, 1);
    test::Chi2Rng rng(5);
    for (float g : {0.999f, -1.f, 1.f}) {
        HgPhaseFunction hg{g};
        HgPhaseFunction clamped{g > 0.f ? 0.99f : -0.99f};
        for (int i = 0; i < 1000; ++i) {
            auto s = hg.sample_p(wo, rng.uniform2());
            REQUIRE(s);
            CHECK(std::isfinite(s->pdf));
            CHECK(s->pdf == Approx(clamped.pdf(wo, s->wi)).epsilon(2e-3));
        }
    }
}
