// Statistical tests of the Owen-scrambled Sobol sequence: uniformity (chi-square across pixels)
// and stratification (elementary intervals within one pixel).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "approx.h"
#include "sampling/sequence.h"
#include "chi2.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::sampling;

namespace {

// Chi-square p-value of observed counts against a uniform expectation (every bin expects
// total / bins >= 5 here, so no pooling is needed).
double chi2_uniform_p(const std::vector<double> &counts, double total) {
    double expected = total / double(counts.size());
    double chi2 = 0;
    for (double c : counts) chi2 += (c - expected) * (c - expected) / expected;
    return tessera::test::chi2_p_value(chi2, int(counts.size()) - 1);
}

void dump_histogram(const std::string &name, const std::vector<double> &counts) {
    std::ofstream f(tessera::test::output_dir() + "/" + name + ".txt");
    for (double c : counts) f << c << "\n";
}

// Significance 0.01, Bonferroni-corrected for the chi-square tests in this file.
constexpr int kChiSquareTests = 4;
constexpr double kAlpha = 0.01 / kChiSquareTests;

// Checks every elementary interval of volume 2^-m (all shapes 2^a x 2^(m-a)) holds exactly one
// of the 2^m points.
bool is_02_net(const std::vector<Vec2f> &pts, int m) {
    for (int a = 0; a <= m; ++a) {
        int nx = 1 << a, ny = 1 << (m - a);
        std::vector<int> cell(size_t(1) << m, 0);
        for (Vec2f p : pts) {
            int ix = int(p.x * nx), iy = int(p.y * ny);
            if (++cell[size_t(iy) * nx + ix] > 1) return false;
        }
    }
    return true;
}

}  // namespace

TEST_CASE("chi-square p-value sanity") {
    // 2 degrees of freedom: P(X >= x) = exp(-x/2); 99 degrees: the 99% quantile is 134.642.
    CHECK(tessera::test::chi2_p_value(3.0, 2) == test::Approx(std::exp(-1.5)).epsilon(1e-10));
    CHECK(tessera::test::chi2_p_value(134.642, 99) == test::Approx(0.01).epsilon(1e-3));
}

TEST_CASE("1D values are uniform across pixels (chi-square)") {
    // Sample 0 and sample 5 of 20000 pixels: independent scrambles, so plain uniform draws.
    const int bins = 100;
    for (uint32_t index : {0u, 5u}) {
        std::vector<double> counts(bins, 0.0);
        SobolSampler s(11);
        uint32_t n = 0;
        for (uint32_t py = 0; py < 100; ++py) {
            for (uint32_t px = 0; px < 200; ++px, ++n) {
                s.start_pixel_sample(px, py, index);
                (void)s.get_2d();
                counts[size_t(s.get_1d() * bins)] += 1;
            }
        }
        double p = chi2_uniform_p(counts, n);
        if (p < kAlpha) dump_histogram("sequence_1d_index" + std::to_string(index), counts);
        CHECK(p > kAlpha);
    }
}

TEST_CASE("2D values are uniform across pixels (chi-square)") {
    const int side = 16;
    // The reserved pixel pair, and a mixed pair: pixel x against the first 1D dimension.
    std::vector<std::function<Vec2f(SobolSampler &)>> pairs = {
        [](SobolSampler &s) { return s.get_pixel_2d(); },
        [](SobolSampler &s) { return Vec2f(s.get_pixel_2d().x, s.get_1d()); },
    };
    int which = 0;
    for (auto &pair : pairs) {
        std::vector<double> counts(side * side, 0.0);
        SobolSampler s(99);
        uint32_t n = 0;
        for (uint32_t py = 0; py < 160; ++py) {
            for (uint32_t px = 0; px < 160; ++px, ++n) {
                s.start_pixel_sample(px, py, 3);
                Vec2f u = pair(s);
                counts[size_t(u.y * side) * side + size_t(u.x * side)] += 1;
            }
        }
        double p = chi2_uniform_p(counts, n);
        if (p < kAlpha) dump_histogram("sequence_2d_pair" + std::to_string(which), counts);
        CHECK(p > kAlpha);
        ++which;
    }
}

TEST_CASE("power-of-two prefixes are (0,m,2)-nets in every pair") {
    for (uint32_t seed : {0u, 42u}) {
        for (uint32_t pixel : {0u, 17u}) {
            for (int m = 0; m <= 10; ++m) {
                uint32_t n = 1u << m;
                // Block 0 = the prefix, block 1 = a pixel resuming at sample 2^m.
                for (uint32_t block = 0; block < 2; ++block) {
                    std::vector<Vec2f> p01, p23, p45;
                    std::vector<float> d6;
                    SobolSampler s(seed);
                    for (uint32_t i = block * n; i < (block + 1) * n; ++i) {
                        s.start_pixel_sample(pixel, 3 * pixel + 1, i);
                        p01.push_back(s.get_pixel_2d());
                        p23.push_back(s.get_2d());
                        p45.push_back(s.get_2d());
                        d6.push_back(s.get_1d());
                    }
                    INFO("seed " << seed << " pixel " << pixel << " m " << m << " block "
                                 << block);
                    CHECK(is_02_net(p01, m));
                    CHECK(is_02_net(p23, m));
                    CHECK(is_02_net(p45, m));
                    // 1D: every interval [k/n, (k+1)/n) holds one value.
                    std::vector<int> strata(n, 0);
                    bool ok = true;
                    for (float v : d6) ok = ok && ++strata[size_t(v * float(n))] == 1;
                    CHECK(ok);
                }
            }
        }
    }
}
