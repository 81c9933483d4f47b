// Chi-square tests of every warp in sampling/warp.h (and the equal-area sphere map of
// sampling/distribution.h) against its stated density. Directions use tests/chi2.h's sphere
// binning; planar warps use local binnings whose expected counts are exact. Fixed seeds,
// significance 0.01 Bonferroni-corrected over the tests of this file.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "approx.h"
#include "chi2.h"
#include "sampling/distribution.h"
#include "sampling/warp.h"

using namespace tessera;
using namespace tessera::sampling;
using tessera::test::Chi2Options;
using tessera::test::Chi2Rng;

namespace {

constexpr int kNumChi2Tests = 9;
constexpr double kAlpha = 0.01 / kNumChi2Tests;

Chi2Options options(uint64_t seed) {
    Chi2Options o;
    o.num_tests = kNumChi2Tests;
    o.seed = seed;
    o.sample_count = 200000;
    return o;
}

double chi2_p(const std::vector<double> &obs, const std::vector<double> &exp) {
    return tessera::test::chi2_counts_p_value(obs, exp);
}

}  // namespace

TEST_CASE("warp: cosine-weighted hemisphere") {
    auto r = tessera::test::chi2_sphere(
        "cosine_hemisphere",
        [](Vec2f u, float) -> std::optional<Vec3f> { return square_to_cosine_hemisphere(u); },
        [](Vec3f w) { return w.z > 0 ? double(cosine_hemisphere_pdf(w.z)) : 0.0; }, options(21));
    CHECK_MESSAGE(r.passed, r.message);
    CHECK(r.pdf_integral == test::Approx(1.0).epsilon(2e-3));
}

TEST_CASE("warp: uniform sphere and hemisphere") {
    auto s = tessera::test::chi2_sphere(
        "uniform_sphere",
        [](Vec2f u, float) -> std::optional<Vec3f> { return square_to_uniform_sphere(u); },
        [](Vec3f) { return double(uniform_sphere_pdf()); }, options(22));
    CHECK_MESSAGE(s.passed, s.message);
    auto h = tessera::test::chi2_sphere(
        "uniform_hemisphere",
        [](Vec2f u, float) -> std::optional<Vec3f> { return square_to_uniform_hemisphere(u); },
        [](Vec3f w) { return w.z > 0 ? double(uniform_hemisphere_pdf()) : 0.0; }, options(23));
    CHECK_MESSAGE(h.passed, h.message);
}

TEST_CASE("warp: uniform cone, wide and narrow") {
    for (float cos_max : {0.3f, 0.985f}) {
        Chi2Options o = options(cos_max < 0.5f ? 24 : 25);
        if (cos_max > 0.9f)
            o.theta_bins = 180;  // 1-degree rows: the cone spans ~10 of them
        auto r = tessera::test::chi2_sphere(
            cos_max < 0.5f ? "cone_wide" : "cone_narrow",
            [&](Vec2f u, float) -> std::optional<Vec3f> {
                return square_to_uniform_cone(u, cos_max);
            },
            [&](Vec3f w) { return w.z >= cos_max ? double(uniform_cone_pdf(cos_max)) : 0.0; }, o);
        CHECK_MESSAGE(r.passed, r.message);
        CHECK(r.pdf_integral == test::Approx(1.0).epsilon(5e-3));
    }
}

TEST_CASE("warp: equal-area octahedral square-to-sphere map is uniform") {
    auto r = tessera::test::chi2_sphere(
        "equal_area_sphere",
        [](Vec2f u, float) -> std::optional<Vec3f> { return equal_area_square_to_sphere(u); },
        [](Vec3f) { return double(kInv4Pi); }, options(26));
    CHECK_MESSAGE(r.passed, r.message);
}

TEST_CASE("warp: concentric disk is uniform by area") {
    // Bins equal in r^2 and phi have equal area, so each expects n / bins samples.
    const int n = 200000, nr = 10, nphi = 24;
    std::vector<double> obs(nr * nphi, 0.0), exp(nr * nphi, double(n) / (nr * nphi));
    Chi2Rng rng(27);
    for (int i = 0; i < n; ++i) {
        Vec2f d = square_to_disk_concentric(rng.uniform2());
        float r2 = d.x * d.x + d.y * d.y;
        REQUIRE(r2 <= 1.f + 1e-6f);
        float phi = std::atan2(d.y, d.x);
        if (phi < 0)
            phi += 2 * kPi;
        int ir = std::min(nr - 1, int(r2 * nr));
        int ip = std::min(nphi - 1, int(phi / (2 * kPi) * nphi));
        obs[size_t(ir * nphi + ip)] += 1;
    }
    double p = chi2_p(obs, exp);
    CHECK_MESSAGE(p > kAlpha, "p-value " << p);
}

TEST_CASE("warp: uniform triangle barycentrics") {
    // (b0, b1) must be uniform on the triangle b0, b1 >= 0, b0 + b1 <= 1 (density 2). On an
    // n x n grid, cells below the diagonal hold area 1/n^2, cells on it 1/(2 n^2).
    const int n = 200000, g = 12;
    std::vector<double> obs(g * g, 0.0), exp(g * g, 0.0);
    for (int i = 0; i < g; ++i)
        for (int j = 0; j < g; ++j) {
            double area = i + j < g - 1 ? 1.0 / (g * g) : (i + j == g - 1 ? 0.5 / (g * g) : 0.0);
            exp[size_t(i * g + j)] = n * 2.0 * area;
        }
    Chi2Rng rng(28);
    for (int k = 0; k < n; ++k) {
        Vec2f b = square_to_uniform_triangle(rng.uniform2());
        REQUIRE(b.x >= 0.f);
        REQUIRE(b.y >= 0.f);
        REQUIRE(b.x + b.y <= 1.f + 1e-6f);
        int i = std::min(g - 1, int(b.x * g)), j = std::min(g - 1, int(b.y * g));
        obs[size_t(i * g + j)] += 1;
    }
    double p = chi2_p(obs, exp);
    CHECK_MESSAGE(p > kAlpha, "p-value " << p);
}

TEST_CASE("warp: tent filter sampling") {
    // Density (r - |x|) / r^2 on [-r, r]; CDF F(x) = (x+r)^2/(2r^2) for x < 0, else
    // 1 - (r-x)^2/(2r^2).
    const float r = 1.5f;
    const int n = 200000, nb = 30;
    auto cdf = [&](double x) {
        return x < 0 ? (x + r) * (x + r) / (2.0 * r * r) : 1.0 - (r - x) * (r - x) / (2.0 * r * r);
    };
    std::vector<double> obs(nb, 0.0), exp(nb, 0.0);
    for (int b = 0; b < nb; ++b) {
        double x0 = -r + 2.0 * r * b / nb, x1 = -r + 2.0 * r * (b + 1) / nb;
        exp[size_t(b)] = n * (cdf(x1) - cdf(x0));
    }
    Chi2Rng rng(29);
    for (int k = 0; k < n; ++k) {
        float x = sample_tent(rng.uniform(), r);
        REQUIRE(x >= -r);
        REQUIRE(x <= r);
        obs[size_t(std::min(nb - 1, int((x + r) / (2 * r) * nb)))] += 1;
    }
    double p = chi2_p(obs, exp);
    CHECK_MESSAGE(p > kAlpha, "p-value " << p);
}
