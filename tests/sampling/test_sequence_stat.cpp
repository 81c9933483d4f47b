// Statistical tests of the Owen-scrambled Sobol sequence: uniformity (chi-square across pixels)
// and stratification (elementary intervals within one pixel).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "sampling/sequence.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::sampling;

namespace {

// Regularised upper incomplete gamma Q(a, x) (series for x < a + 1, Lentz continued fraction
// otherwise; Press et al., Numerical Recipes, 6.2), for chi-square p-values.
double gamma_q(double a, double x) {
    if (x <= 0) return 1.0;
    double gln = std::lgamma(a);
    if (x < a + 1) {
        double sum = 1.0 / a, del = sum, ap = a;
        for (int n = 0; n < 10000; ++n) {
            ap += 1;
            del *= x / ap;
            sum += del;
            if (std::abs(del) < std::abs(sum) * 1e-15) break;
        }
        return 1.0 - sum * std::exp(-x + a * std::log(x) - gln);
    }
    double b = x + 1 - a, c = 1e300, d = 1 / b, h = d;
    for (int i = 1; i < 10000; ++i) {
        double an = -i * (i - a);
        b += 2;
        d = an * d + b;
        if (std::abs(d) < 1e-300) d = 1e-300;
        c = b + an / c;
        if (std::abs(c) < 1e-300) c = 1e-300;
        d = 1 / d;
        double del = d * c;
        h *= del;
        if (std::abs(del - 1) < 1e-15) break;
    }
    return std::exp(-x + a * std::log(x) - gln) * h;
}

// Chi-square p-value of observed counts against a uniform expectation (every bin expects
// total / bins >= 5 here, so no pooling is needed).
double chi2_uniform_p(const std::vector<double> &counts, double total) {
    double expected = total / double(counts.size());
    double chi2 = 0;
    for (double c : counts) chi2 += (c - expected) * (c - expected) / expected;
    return gamma_q(0.5 * double(counts.size() - 1), 0.5 * chi2);
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

TEST_CASE("gamma_q sanity") {
    // Chi-square with 2 degrees of freedom: Q(1, x/2) = exp(-x/2).
    CHECK(gamma_q(1.0, 1.5) == doctest::Approx(std::exp(-1.5)).epsilon(1e-10));
    CHECK(gamma_q(1.0, 0.2) == doctest::Approx(std::exp(-0.2)).epsilon(1e-10));
    // Chi-square 99% quantile for 99 degrees of freedom is 134.642.
    CHECK(gamma_q(49.5, 134.642 / 2) == doctest::Approx(0.01).epsilon(1e-3));
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
