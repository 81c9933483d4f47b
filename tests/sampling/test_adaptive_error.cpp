// Unit tests of the Dammertz et al. 2010 error metrics: pixel error, region error with
// fractional coverage and the r factor, error images computed from a film.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "approx.h"
#include "sampling/adaptive_error.h"

using namespace tessera;
using namespace tessera::sampling;

namespace {

constexpr float kInfF = std::numeric_limits<float>::infinity();

PixelStats stats(std::array<double, 3> mean, std::array<double, 3> half, uint32_t accepted,
                 uint32_t half_accepted) {
    PixelStats s;
    s.mean = mean;
    s.half_mean = half;
    s.taken = s.accepted = accepted;
    s.half_accepted = half_accepted;
    return s;
}

ErrorImage uniform_image(int w, int h, float e) {
    ErrorImage img;
    img.width = w;
    img.height = h;
    img.error.assign(size_t(w) * size_t(h), e);
    return img;
}

Sample radiance_sample(float r, float g, float b) {
    Sample s;
    s.radiance = Rgb(r, g, b);
    s.depth = kInfinity;
    return s;
}

}  // namespace

TEST_CASE("pixel error against hand-computed values") {
    // I = (0.5, 0.25, 0.25), A = (0.7, 0.25, 0.05): |dI| sums to 0.4, sqrt(sum I) = 1.
    CHECK(pixel_error(stats({0.5, 0.25, 0.25}, {0.7, 0.25, 0.05}, 8, 4), 2) ==
          test::Approx(0.4).epsilon(1e-6));
    // I = (2, 1, 1), A = (1, 1, 1): 1 / sqrt(4) = 0.5.
    CHECK(pixel_error(stats({2, 1, 1}, {1, 1, 1}, 4, 2), 4) == test::Approx(0.5));
    // Equal means: no error.
    CHECK(pixel_error(stats({3, 2, 1}, {3, 2, 1}, 16, 8), 2) == 0.f);
    // Scaling the radiance by k scales the error by sqrt(k).
    float e1 = pixel_error(stats({0.3, 0.2, 0.1}, {0.4, 0.1, 0.1}, 8, 4), 2);
    float e4 = pixel_error(stats({1.2, 0.8, 0.4}, {1.6, 0.4, 0.4}, 8, 4), 2);
    CHECK(e4 == test::Approx(2.0 * e1).epsilon(1e-6));
}

TEST_CASE("pixel error is infinite without an estimate") {
    const std::array<double, 3> m{1, 1, 1}, a{1.5, 1, 1};
    CHECK(pixel_error(stats(m, a, 3, 1), 4) == kInfF);  // fewer than min_samples
    CHECK(pixel_error(stats(m, a, 4, 2), 4) < kInfF);   // exactly min_samples
    CHECK(pixel_error(stats(m, a, 1, 0), 0) == kInfF);  // one sample is never enough
    CHECK(pixel_error(stats(m, a, 8, 0), 2) == kInfF);  // empty half buffer
    CHECK(pixel_error(stats(m, m, 8, 8), 2) == kInfF);  // no even-index sample
    CHECK(pixel_error(PixelStats{}, 0) == kInfF);       // untouched pixel
}

TEST_CASE("black and signed pixels") {
    // All samples black: 0, not NaN.
    CHECK(pixel_error(stats({0, 0, 0}, {0, 0, 0}, 8, 4), 2) == 0.f);
    // Signed radiance whose mean cancels: denominator from the pixel's own magnitude,
    // sqrt(max(0, |1| + |-1|)) -> 2 / sqrt(2).
    float e = pixel_error(stats({0, 0, 0}, {1, -1, 0}, 8, 4), 2);
    CHECK(std::isfinite(e));
    CHECK(e == test::Approx(std::sqrt(2.0)));
    // ... and it scales as sqrt(k) too.
    CHECK(pixel_error(stats({0, 0, 0}, {4, -4, 0}, 8, 4), 2) == test::Approx(2.0 * e));
}

TEST_CASE("region error: r factor, whole image against half image") {
    ErrorImage img = uniform_image(10, 10, 0.1f);
    const double area = 100;
    // Whole image: r = 1, the mean pixel error.
    CHECK(region_error(img, {0, 0, 10, 10}, area) == test::Approx(0.1));
    // Half the image: r = sqrt(1/2).
    CHECK(region_error(img, {0, 0, 5, 10}, area) == test::Approx(0.1 * std::sqrt(0.5)));
    // A float rectangle of area 12.5 px: r = sqrt(0.125), mean still 0.1.
    CHECK(region_error(img, {1.25, 2.5, 3.75, 7.5}, area) ==
          test::Approx(0.1 * std::sqrt(0.125)));
    // Clipped to the image; empty regions have no error.
    CHECK(region_error(img, {-5, 0, 10, 10}, area) == test::Approx(0.1));
    CHECK(region_error(img, {3, 3, 3, 8}, area) == 0.0);
}

TEST_CASE("region error: fractional coverage") {
    ErrorImage img = uniform_image(8, 8, 0.f);
    img.error[3 * 8 + 2] = 1.f;  // pixel (2, 3)
    const double area = 64;
    // [2.5, 4.25) x [3, 4) covers half of pixel (2, 3): sum 0.5 over N = 1.75 px.
    CHECK(region_error(img, {2.5, 3, 4.25, 4}, area) ==
          test::Approx(0.5 / std::sqrt(1.75 * area)));
    // A quarter of it in both axes: coverage 0.5 * 0.25.
    CHECK(region_error(img, {2.5, 3.75, 3.0, 5.0}, area) ==
          test::Approx(0.125 / std::sqrt(0.5 * 1.25 * area)));
    // Ending exactly at the pixel's boundary covers none of it.
    CHECK(region_error(img, {0, 0, 2, 8}, area) == 0.0);

    // An unknown pixel makes the region infinite only where it is covered.
    img.error[5 * 8 + 5] = kInfF;
    CHECK(region_error(img, {3, 0, 5, 8}, area) == 0.0);
    CHECK(region_error(img, {3, 0, 5.01, 8}, area) == std::numeric_limits<double>::infinity());
}

TEST_CASE("compute_errors on a film with synthetic samples") {
    Film film(4, 3);
    // Pixel (1, 1): red 1, 3, 1, 3 -> I = 2, A (odd samples) = 3: error 1 / sqrt(2).
    for (uint32_t i = 0; i < 4; ++i)
        film.add_sample(1, 1, i, radiance_sample(i & 1 ? 3.f : 1.f, 0.f, 0.f));
    // Pixel (2, 1): constant grey -> 0.
    for (uint32_t i = 0; i < 4; ++i)
        film.add_sample(2, 1, i, radiance_sample(0.5f, 0.5f, 0.5f));
    // Pixel (0, 0): only 1 sample -> unknown.
    film.add_sample(0, 0, 0, radiance_sample(1.f, 1.f, 1.f));

    ErrorImage out;
    compute_errors(film, {0, 0, 3, 2}, 2, out);
    REQUIRE(out.width == 4);
    REQUIRE(out.height == 3);
    REQUIRE(out.error.size() == 12);
    CHECK(out.at(1, 1) == test::Approx(1.0 / std::sqrt(2.0)));
    CHECK(out.at(1, 1) == pixel_error(film.pixel_stats(1, 1), 2));
    CHECK(out.at(2, 1) == 0.f);
    CHECK(out.at(0, 0) == kInfF);
    CHECK(out.at(3, 1) == kInfF);  // outside the region: untouched (+inf on allocation)

    // min_samples above the count: unknown.
    compute_errors(film, {0, 0, 4, 3}, 8, out);
    CHECK(out.at(1, 1) == kInfF);

    // Reuse: no reallocation, only the region is rewritten; regions are clipped to the film.
    const float *data = out.error.data();
    out.error[2 * 4 + 3] = 7.f;
    compute_errors(film, {-2, -2, 3, 2}, 2, out);
    CHECK(out.error.data() == data);
    CHECK(out.at(3, 2) == 7.f);
    CHECK(out.at(1, 1) == test::Approx(1.0 / std::sqrt(2.0)));
}

TEST_CASE("image error and error summary") {
    Film film(2, 2);
    CHECK(image_error(film, 2) == std::numeric_limits<double>::infinity());
    for (uint32_t y = 0; y < 2; ++y)
        for (uint32_t x = 0; x < 2; ++x)
            for (uint32_t i = 0; i < 4; ++i)
                film.add_sample(x, y, i, radiance_sample(i & 1 ? 3.f : 1.f, 0.f, 0.f));
    // Every pixel has error 1 / sqrt(2); r = 1: the mean.
    CHECK(image_error(film, 2) == test::Approx(1.0 / std::sqrt(2.0)));
    ErrorImage out;
    compute_errors(film, {0, 0, 2, 2}, 2, out);
    CHECK(image_error(film, 2) == test::Approx(region_error(out, {0, 0, 2, 2}, 4.0)));

    out.error[0] = kInfF;
    ErrorSummary s = summarize_errors(out);
    CHECK(s.pixels == 4);
    CHECK(s.unknown_pixels == 1);
    CHECK(s.mean_finite == test::Approx(1.0 / std::sqrt(2.0)));
}

TEST_CASE("pixel relMSE estimate: hand-computed values, +inf exactly where pixel_error is") {
    // I = (0.5, 0.25, 0.25), A = (0.7, 0.25, 0.05), half buffer (k = 1):
    // (0.04 / 0.26 + 0 + 0.04 / 0.0725) / 3.
    const PixelStats st = stats({0.5, 0.25, 0.25}, {0.7, 0.25, 0.05}, 8, 4);
    CHECK(pixel_rel_mse(st, 2) ==
          test::Approx((0.04 / 0.26 + 0.04 / (0.0625 + 0.01)) / 3).epsilon(1e-6));
    CHECK(pixel_rel_mse(stats({3, 2, 1}, {3, 2, 1}, 16, 8), 2) == 0.f);
    CHECK(pixel_rel_mse(stats({1, 1, 1}, {1.5, 1, 1}, 3, 1), 4) == kInfF);  // too few
    CHECK(pixel_rel_mse(stats({1, 1, 1}, {1.5, 1, 1}, 8, 0), 2) == kInfF);  // empty half
    CHECK(pixel_rel_mse(stats({1, 1, 1}, {1.5, 1, 1}, 8, 8), 2) == kInfF);  // no even sample
    CHECK(std::string(metric_name(ErrorMetric::RelMse)) == "relmse");
    CHECK(std::string(metric_name(ErrorMetric::Dammertz)) == "dammertz");
}

TEST_CASE("pixel relMSE estimate is unbiased for the relMSE of independent samples") {
    // 4000 pixels of n i.i.d. samples, mean 0.5 (R), 2 (G), 0.05 (B), uniform noise of
    // amplitude s: Var(I_c) = s^2 / (3 n). Over the pixels, the mean estimate must match
    // (1/3) sum_c Var(I_c) / (mu_c^2 + 0.01) (the estimate divides by I_c^2, not mu_c^2: a
    // second-order effect, 1-2% here), for both the half buffer and the prefix.
    constexpr uint32_t kPixels = 4000;
    const float mu[3] = {0.5f, 2.f, 0.05f};
    for (bool prefix : {false, true})
        for (uint32_t n : {16u, 48u, 128u}) {
            CAPTURE(prefix);
            CAPTURE(n);
            Film film(kPixels, 1, {}, prefix);
            std::mt19937 rng(17 + n);
            std::uniform_real_distribution<float> u(-1.f, 1.f);
            constexpr float s = 0.04f;
            for (uint32_t p = 0; p < kPixels; ++p)
                for (uint32_t i = 0; i < n; ++i)
                    film.add_sample(p, 0, i,
                                    radiance_sample(mu[0] + s * u(rng), mu[1] + s * u(rng),
                                                    mu[2] + s * u(rng)));
            double est = 0;
            for (uint32_t p = 0; p < kPixels; ++p)
                est += pixel_rel_mse(film.pixel_stats(p, 0), 2);
            est /= kPixels;
            double expected = 0;
            for (float m : mu)
                expected += (s * s / (3.0 * n)) / (double(m) * m + 0.01);
            expected /= 3;
            CHECK(est == test::Approx(expected).epsilon(0.06));
        }
}
