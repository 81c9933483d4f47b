// Statistical tests of sampling/distribution.h: every sampler against its own pdf/pmf
// (chi-square, fixed seeds, significance 0.01 Bonferroni-corrected over this file's tests),
// normalisation, consistency of returned and queried densities, and the all-zero fallback.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "approx.h"
#include "chi2.h"
#include "sampling/distribution.h"

using namespace tessera;
using namespace tessera::sampling;
using tessera::test::Chi2Rng;

namespace {

constexpr int kNumChi2Tests = 7;  // chi-square tests in this file
constexpr double kAlpha = 0.01 / kNumChi2Tests;

double chi2_p(const std::vector<double> &obs, const std::vector<double> &exp) {
    return tessera::test::chi2_counts_p_value(obs, exp);
}

}  // namespace

TEST_CASE("PiecewiseConstant1D: integral, pdf and continuous sampling match (chi-square)") {
    const std::vector<float> f = {1.f, 0.f, 3.f, 2.f, 0.5f};
    const float lo = -1.f, hi = 3.f;
    PiecewiseConstant1D d(f, lo, hi);
    REQUIRE(d.size() == 5);
    CHECK_FALSE(d.is_uniform_fallback());
    // Integral of |f| over [-1, 3]: cell width 0.8, sum 6.5.
    CHECK(d.integral() == test::Approx(6.5 * 0.8).epsilon(1e-6));
    // pdf = f / integral, integrating to 1.
    double total = 0;
    for (size_t i = 0; i < f.size(); ++i) {
        float x = lo + (float(i) + 0.5f) * 0.8f;
        CHECK(d.pdf(x) == test::Approx(f[i] / 5.2f).epsilon(1e-5));
        total += d.pdf(x) * 0.8;
    }
    CHECK(total == test::Approx(1.0).epsilon(1e-5));
    CHECK(d.pdf(lo - 0.1f) == 0.f);
    CHECK(d.pdf(hi + 0.1f) == 0.f);

    // Four histogram bins per cell; expected counts are exact since the pdf is constant per bin.
    const int n = 200000, per_cell = 4, nbins = 5 * per_cell;
    std::vector<double> obs(nbins, 0.0), exp(nbins, 0.0);
    Chi2Rng rng(11);
    int bad_pdf = 0, bad_offset = 0;
    for (int i = 0; i < n; ++i) {
        float pdf = -1;
        int offset = -1;
        float x = d.sample_continuous(rng.uniform(), &pdf, &offset);
        REQUIRE(x >= lo);
        REQUIRE(x < hi);
        if (std::abs(pdf - d.pdf(x)) > 1e-5f * pdf)
            ++bad_pdf;
        if (offset != std::min(4, int((x - lo) / 0.8f)))
            ++bad_offset;
        int b = std::min(nbins - 1, int((x - lo) / (hi - lo) * nbins));
        obs[size_t(b)] += 1;
    }
    for (int b = 0; b < nbins; ++b)
        exp[size_t(b)] = n * f[size_t(b / per_cell)] / 6.5 / per_cell;
    CHECK(bad_pdf == 0);
    CHECK(bad_offset == 0);
    double p = chi2_p(obs, exp);
    CHECK_MESSAGE(p > kAlpha, "p-value " << p);
}

TEST_CASE("PiecewiseConstant1D: discrete sampling follows the pmf; remapped u is uniform") {
    const std::vector<float> f = {0.f, 4.f, 1.f, 0.f, 2.f, 1.f};
    PiecewiseConstant1D d(f);
    double sum_pmf = 0;
    for (size_t i = 0; i < f.size(); ++i) {
        CHECK(d.pmf(i) == test::Approx(f[i] / 8.0).epsilon(1e-6));
        sum_pmf += d.pmf(i);
    }
    CHECK(sum_pmf == test::Approx(1.0).epsilon(1e-6));

    const int n = 100000, rbins = 20;
    std::vector<double> obs(f.size(), 0.0), exp(f.size(), 0.0);
    std::vector<double> r_obs(rbins, 0.0), r_exp(rbins, 0.0);
    Chi2Rng rng(12);
    for (int i = 0; i < n; ++i) {
        float pmf = -1, ur = -1;
        int k = d.sample_discrete(rng.uniform(), &pmf, &ur);
        REQUIRE(k >= 0);
        REQUIRE(k < int(f.size()));
        CHECK(pmf == d.pmf(size_t(k)));
        REQUIRE(ur >= 0.f);
        REQUIRE(ur < 1.f);
        obs[size_t(k)] += 1;
        if (k == 1)
            r_obs[size_t(std::min(rbins - 1, int(ur * rbins)))] += 1;
    }
    for (size_t i = 0; i < f.size(); ++i)
        exp[i] = n * f[i] / 8.0;
    for (int b = 0; b < rbins; ++b)
        r_exp[size_t(b)] = obs[1] / rbins;
    double p = chi2_p(obs, exp), pr = chi2_p(r_obs, r_exp);
    CHECK_MESSAGE(p > kAlpha, "pmf p-value " << p);
    CHECK_MESSAGE(pr > kAlpha, "remapped-u p-value " << pr);
    // Zero cells are never chosen.
    CHECK(obs[0] == 0);
    CHECK(obs[3] == 0);
}

TEST_CASE("PiecewiseConstant1D: all-zero, empty, NaN and one-cell functions") {
    std::vector<float> zeros(7, 0.f);
    PiecewiseConstant1D z(zeros, 2.f, 4.f);
    CHECK(z.is_uniform_fallback());
    CHECK(z.integral() == 0.f);
    CHECK(z.pdf(3.1f) == test::Approx(0.5f));
    float pdf = 0;
    float x = z.sample_continuous(0.75f, &pdf);
    CHECK(x == test::Approx(3.5f));
    CHECK(pdf == test::Approx(0.5f));
    CHECK(z.pmf(3) == test::Approx(1.f / 7.f));

    PiecewiseConstant1D empty;
    CHECK(empty.size() == 1);
    CHECK(empty.sample_continuous(0.25f, &pdf) == test::Approx(0.25f));
    CHECK(pdf == test::Approx(1.f));

    std::vector<float> with_nan = {std::nanf(""), 1.f};
    PiecewiseConstant1D n(with_nan);
    CHECK(n.pmf(0) == 0.f);
    CHECK(n.pmf(1) == test::Approx(1.f));
    CHECK(n.sample_continuous(0.f) >= 0.5f);

    std::vector<float> one = {5.f};
    PiecewiseConstant1D o(one, 0.f, 2.f);
    CHECK(o.integral() == test::Approx(10.f));
    CHECK(o.sample_continuous(0.5f, &pdf) == test::Approx(1.f));
    CHECK(pdf == test::Approx(0.5f));
    int k = o.sample_discrete(kOneMinusEpsilon);
    CHECK(k == 0);
}

TEST_CASE("PiecewiseConstant2D: pdf integrates to 1 and matches sampling (chi-square)") {
    const int nu = 8, nv = 6;
    std::vector<float> f(size_t(nu * nv));
    Chi2Rng gen(5);
    for (int v = 0; v < nv; ++v)
        for (int u = 0; u < nu; ++u) {
            float val = 0.1f + 3.f * gen.uniform();
            if (v == 2)
                val = 0.f;  // an empty row
            if (u == 5)
                val = 0.f;  // an empty column
            if (u == 1 && v == 4)
                val = 40.f;  // a bright spot
            f[size_t(v * nu + u)] = val;
        }
    PiecewiseConstant2D d(f, nu, nv);
    CHECK(d.nu() == nu);
    CHECK(d.nv() == nv);
    double sum_f = 0;
    for (float x : f)
        sum_f += x;
    CHECK(d.integral() == test::Approx(sum_f / (nu * nv)).epsilon(1e-5));

    double total = 0;
    for (int v = 0; v < nv; ++v)
        for (int u = 0; u < nu; ++u) {
            Vec2f p{(u + 0.5f) / nu, (v + 0.5f) / nv};
            float expect = float(f[size_t(v * nu + u)] / (sum_f / (nu * nv)));
            CHECK(d.pdf(p) == test::Approx(expect).epsilon(1e-4));
            total += d.pdf(p) / (nu * nv);
        }
    CHECK(total == test::Approx(1.0).epsilon(1e-5));

    // Histogram on a grid twice as fine as the cells: expected counts are exact.
    const int n = 300000, bu = 2 * nu, bv = 2 * nv;
    std::vector<double> obs(size_t(bu * bv), 0.0), exp(size_t(bu * bv), 0.0);
    Chi2Rng rng(13);
    int bad_pdf = 0;
    for (int i = 0; i < n; ++i) {
        float pdf = 0;
        Vec2f p = d.sample(rng.uniform2(), &pdf);
        REQUIRE(p.x >= 0.f);
        REQUIRE(p.x < 1.f);
        REQUIRE(p.y >= 0.f);
        REQUIRE(p.y < 1.f);
        if (std::abs(pdf - d.pdf(p)) > 1e-4f * pdf)
            ++bad_pdf;
        int x = std::min(bu - 1, int(p.x * bu)), y = std::min(bv - 1, int(p.y * bv));
        obs[size_t(y * bu + x)] += 1;
    }
    for (int y = 0; y < bv; ++y)
        for (int x = 0; x < bu; ++x)
            exp[size_t(y * bu + x)] = n * f[size_t((y / 2) * nu + x / 2)] / sum_f / 4.0;
    CHECK(bad_pdf == 0);
    double p = chi2_p(obs, exp);
    CHECK_MESSAGE(p > kAlpha, "p-value " << p);
}

TEST_CASE("PiecewiseConstant2D: all-zero and 1x1 grids are uniform") {
    std::vector<float> zeros(12, 0.f);
    PiecewiseConstant2D z(zeros, 4, 3);
    CHECK(z.integral() == 0.f);
    float pdf = 0;
    Vec2f p = z.sample({0.3f, 0.8f}, &pdf);
    CHECK(pdf == test::Approx(1.f));
    CHECK(p.x == test::Approx(0.3f));
    CHECK(p.y == test::Approx(0.8f));
    CHECK(z.pdf({0.9f, 0.1f}) == test::Approx(1.f));

    std::vector<float> one = {2.5f};
    PiecewiseConstant2D o(one, 1, 1);
    CHECK(o.integral() == test::Approx(2.5f));
    p = o.sample({0.6f, 0.2f}, &pdf);
    CHECK(pdf == test::Approx(1.f));
    CHECK(p.x == test::Approx(0.6f));
    CHECK(p.y == test::Approx(0.2f));

    // Uniform fallback passes a chi-square test too.
    const int n = 40000, b = 8;
    std::vector<double> obs(b * b, 0.0), exp(b * b, double(n) / (b * b));
    Chi2Rng rng(14);
    for (int i = 0; i < n; ++i) {
        Vec2f q = z.sample(rng.uniform2());
        obs[size_t(std::min(b - 1, int(q.y * b)) * b + std::min(b - 1, int(q.x * b)))] += 1;
    }
    double pv = chi2_p(obs, exp);
    CHECK_MESSAGE(pv > kAlpha, "p-value " << pv);
}

TEST_CASE("AliasTable: frequencies follow the weights (chi-square); remapped u is uniform") {
    const std::vector<float> w = {0.f, 1.f, 2.f, 3.f, 0.5f, 0.f, 10.f};
    AliasTable t(w);
    REQUIRE(t.size() == w.size());
    double sum_w = 16.5, sum_pmf = 0;
    for (size_t i = 0; i < w.size(); ++i) {
        CHECK(t.pmf(i) == test::Approx(w[i] / sum_w).epsilon(1e-6));
        sum_pmf += t.pmf(i);
    }
    CHECK(sum_pmf == test::Approx(1.0).epsilon(1e-6));

    const int n = 200000, rbins = 16;
    std::vector<double> obs(w.size(), 0.0), exp(w.size(), 0.0);
    std::vector<double> r_obs(rbins, 0.0), r_exp(rbins, double(n) / rbins);
    Chi2Rng rng(15);
    for (int i = 0; i < n; ++i) {
        float pmf = 0, ur = -1;
        int k = t.sample(rng.uniform(), &pmf, &ur);
        REQUIRE(k >= 0);
        REQUIRE(k < int(w.size()));
        REQUIRE(pmf == t.pmf(size_t(k)));
        REQUIRE(ur >= 0.f);
        REQUIRE(ur < 1.f);
        obs[size_t(k)] += 1;
        r_obs[size_t(std::min(rbins - 1, int(ur * rbins)))] += 1;
    }
    for (size_t i = 0; i < w.size(); ++i)
        exp[i] = n * w[i] / sum_w;
    double p = chi2_p(obs, exp), pr = chi2_p(r_obs, r_exp);
    CHECK_MESSAGE(p > kAlpha, "p-value " << p);
    CHECK_MESSAGE(pr > kAlpha, "remapped-u p-value " << pr);
    CHECK(obs[0] == 0);
    CHECK(obs[5] == 0);
}

TEST_CASE("AliasTable: all-zero weights, one entry, empty table") {
    std::vector<float> zeros(4, 0.f);
    AliasTable z(zeros);
    for (size_t i = 0; i < 4; ++i)
        CHECK(z.pmf(i) == test::Approx(0.25f));
    std::vector<int> hits(4, 0);
    for (int i = 0; i < 400; ++i)
        ++hits[size_t(z.sample((i + 0.5f) / 400.f))];
    for (int h : hits)
        CHECK(h == 100);  // stratified u: exactly a quarter each

    std::vector<float> one = {3.f};
    AliasTable o(one);
    float pmf = 0, ur = 0;
    CHECK(o.sample(0.7f, &pmf, &ur) == 0);
    CHECK(pmf == 1.f);
    CHECK(ur == test::Approx(0.7f));

    AliasTable e;
    CHECK(e.size() == 0);
    CHECK(e.sample(0.5f) == -1);
}

TEST_CASE("PiecewiseConstant1D: the cell search is std::upper_bound's, ties and ends included") {
    // Cells of zero value make runs of equal CDF entries, which inversion must pass over (the
    // last cell whose CDF entry is <= u); u exactly at an entry and one ulp either side.
    Chi2Rng rng(17);
    for (int n : {1, 2, 3, 5, 8, 31, 64, 100, 513}) {
        for (int variant = 0; variant < 5; ++variant) {
            std::vector<float> f(static_cast<size_t>(n));
            for (float &v : f) v = rng.uniform() < 0.3f * float(variant) ? 0.f : rng.uniform();
            // Variant 4: one cell 1e6 times the rest, so that most CDF entries crowd into the
            // first and last guide buckets.
            if (variant == 4) {
                for (float &v : f) v = 1e-6f * rng.uniform();
                f[size_t(n) / 2] = 1.f;
            }
            PiecewiseConstant1D d(f);
            const std::vector<float> &cdf = d.cdf();
            REQUIRE(cdf.size() == size_t(n) + 1);
            std::vector<float> us;
            for (float c : cdf) {
                us.push_back(c);
                us.push_back(std::nextafter(c, 2.f));
                us.push_back(std::nextafter(c, -1.f));
            }
            for (int k = 0; k < 200; ++k) us.push_back(rng.uniform());
            // The guide table's bucket edges (about n / 4 buckets) and one ulp either side.
            for (int g = 1; g <= n; ++g)
                for (int j = 0; j <= g; ++j) {
                    const float c = float(j) / float(g);
                    us.push_back(c);
                    us.push_back(std::nextafter(c, 2.f));
                    us.push_back(std::nextafter(c, -1.f));
                }
            for (float u : us) {
                if (!(u >= 0.f && u < 1.f))
                    continue;
                const int expect = std::clamp(
                    int(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()) - 1, 0, n - 1);
                int offset = -1;
                d.sample_continuous(u, nullptr, &offset);
                CAPTURE(n);
                CAPTURE(u);
                CHECK(offset == expect);
                CHECK(d.sample_discrete(u) == expect);
            }
        }
    }
}
