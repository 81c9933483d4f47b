// The prefix error estimate (sampling/adaptive_error.h, films built with keep_prefix): the film
// keeps the means of the first 2^k samples, pixel_error weights |I - prefix| to the half
// buffer's scale, and on Tessera's Owen-scrambled Sobol samples it tracks the true error of a
// smooth pixel where the half buffer (the odd-index samples, not a net) overstates it by orders
// of magnitude, while on independent noise both agree.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "approx.h"
#include "sampling/adaptive_error.h"
#include "sampling/film.h"
#include "sampling/sequence.h"

using namespace tessera;
using namespace tessera::sampling;

namespace {

constexpr float kInfF = std::numeric_limits<float>::infinity();

Sample grey(float v) {
    Sample s;
    s.radiance = Rgb(v);
    s.depth = kInfinity;
    return s;
}

/// Independent uniform numbers in [0,1) from (pixel, index): white noise, no QMC structure.
float white(uint32_t px, uint32_t index) {
    uint32_t h = mix_bits_32(mix_bits_32(px * 0x9e3779b9u + 17u) ^ (index * 0x85ebca6bu));
    return float(h >> 8) * 0x1p-24f;
}

}  // namespace

TEST_CASE("prefix snapshots: the film keeps the mean of the first 2^(k-1) samples") {
    Film plain(1, 1);
    CHECK_FALSE(plain.keeps_prefix());
    CHECK_FALSE(plain.pixel_stats(0, 0).has_prefix);
    Film film(1, 1, {}, true);
    CHECK(film.keeps_prefix());
    CHECK(film.bytes_per_pixel() == plain.bytes_per_pixel() + sizeof(Film::PrefixData));
    // Sample i has radiance i, except index 5, which is NaN (taken, not accepted).
    std::vector<double> values;
    for (uint32_t i = 0; i < 40; ++i) {
        Sample s = grey(float(i));
        if (i == 5) s.radiance = Rgb(std::nanf(""), 0.f, 0.f);
        film.add_sample(0, 0, i, s);
        const uint32_t taken = i + 1;
        uint32_t p = 1;  // largest power of two <= taken
        while (p * 2 <= taken) p *= 2;
        double sum = 0;
        uint32_t accepted = 0;
        for (uint32_t j = 0; j < p / 2; ++j)
            if (j != 5) {
                sum += j;
                ++accepted;
            }
        const PixelStats st = film.pixel_stats(0, 0);
        CAPTURE(taken);
        REQUIRE(st.has_prefix);
        CHECK(st.prefix_accepted == accepted);
        CHECK(st.prefix_mean[0] == test::Approx(accepted ? sum / accepted : 0.0));
    }
    film.clear();
    CHECK(film.pixel_stats(0, 0).prefix_accepted == 0);
}

TEST_CASE("prefix error: hand-computed values, the sqrt(m / (n - m)) weight, no estimate") {
    PixelStats st;
    st.has_prefix = true;
    st.mean = {2, 1, 1};
    st.prefix_mean = {1, 1, 1};
    st.taken = st.accepted = 8;
    st.prefix_accepted = 4;  // m = n/2: weight 1; |dI| = 1, sqrt(sum I) = 2
    CHECK(pixel_error(st, 4) == test::Approx(0.5));
    st.taken = st.accepted = 12;  // m = n/3: weight sqrt(4/8)
    CHECK(pixel_error(st, 4) == test::Approx(0.5 * std::sqrt(0.5)));
    // The half buffer is not consulted (empty here, which alone would mean no estimate).
    CHECK(st.half_accepted == 0);
    st.prefix_accepted = 0;  // nothing accepted in the prefix
    CHECK(pixel_error(st, 4) == kInfF);
    st.prefix_accepted = 12;  // nothing after it
    CHECK(pixel_error(st, 4) == kInfF);
    st.prefix_accepted = 4;
    CHECK(pixel_error(st, 16) == kInfF);  // fewer than min_samples
}

TEST_CASE("prefix error tracks the true error of Sobol samples; the half buffer overstates it") {
    // 64 pixels of a smooth integrand of one Sobol pair, f(u) = 0.5 + 0.3 u.x u.y + 0.2 u.y
    // (exact mean 0.675), n = 1024 samples each. The true error of the mean is tiny (an
    // Owen-scrambled (0,10,2)-net); the mean of the odd-index samples converges as 1/sqrt(n).
    constexpr uint32_t kPixels = 64, kN = 1024;
    constexpr double kExact = 0.5 + 0.3 * 0.25 + 0.2 * 0.5;
    Film half(kPixels, 1), prefix(kPixels, 1, {}, true);
    SobolSampler sampler(3);
    for (uint32_t px = 0; px < kPixels; ++px)
        for (uint32_t i = 0; i < kN; ++i) {
            sampler.start_pixel_sample(px, 0, i);
            const Vec2f u = sampler.get_2d();
            const Sample s = grey(0.5f + 0.3f * u.x * u.y + 0.2f * u.y);
            half.add_sample(px, 0, i, s);
            prefix.add_sample(px, 0, i, s);
        }
    double e_true = 0, e_half = 0, e_prefix = 0;
    for (uint32_t px = 0; px < kPixels; ++px) {
        const PixelStats st = prefix.pixel_stats(px, 0);
        // The same units as pixel_error: sum over channels of |I - exact| / sqrt(sum I).
        e_true += 3 * std::abs(st.mean[0] - kExact) / std::sqrt(3 * st.mean[0]);
        e_half += pixel_error(half.pixel_stats(px, 0), 4);
        e_prefix += pixel_error(st, 4);
    }
    CAPTURE(e_true / kPixels);
    CAPTURE(e_half / kPixels);
    CAPTURE(e_prefix / kPixels);
    CHECK(e_half > 100 * e_true);
    // The prefix (512 samples) is about 2^1.5 less accurate than the full mean on a smooth
    // integrand, so the estimate reads a few times high, never far low.
    CHECK(e_prefix > 0.5 * e_true);
    CHECK(e_prefix < 8 * e_true);
}

TEST_CASE("prefix error and half buffer agree on independent noise, at any count") {
    // White noise: both estimates have the spread sigma / sqrt(n) (the prefix one through its
    // weight), so their means over many pixels agree, with m = n/2 and with m = n/3.
    constexpr uint32_t kPixels = 400;
    for (uint32_t n : {1024u, 1536u}) {
        CAPTURE(n);
        Film half(kPixels, 1), prefix(kPixels, 1, {}, true);
        for (uint32_t px = 0; px < kPixels; ++px)
            for (uint32_t i = 0; i < n; ++i) {
                const Sample s = grey(0.2f + white(px, i));
                half.add_sample(px, 0, i, s);
                prefix.add_sample(px, 0, i, s);
            }
        double e_half = 0, e_prefix = 0;
        for (uint32_t px = 0; px < kPixels; ++px) {
            e_half += pixel_error(half.pixel_stats(px, 0), 4);
            e_prefix += pixel_error(prefix.pixel_stats(px, 0), 4);
        }
        // 400 folded normals: each mean within about 4% (1 sd); 15% is over 3 sd of the ratio.
        CHECK(e_prefix / e_half == test::Approx(1.0).epsilon(0.15));
    }
}
