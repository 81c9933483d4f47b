// Unit tests of the film: means, half buffer, AOVs, dropped samples, precision, threads.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "sampling/film.h"

using namespace tessera;
using namespace tessera::sampling;

namespace {

Sample radiance_sample(float r, float g, float b) {
    Sample s;
    s.radiance = Rgb(r, g, b);
    s.depth = kInfinity;  // escaped: no AOV contribution
    return s;
}

Sample hit_sample(Rgb radiance, Rgb albedo, Vec3f normal, float depth) {
    Sample s;
    s.radiance = radiance;
    s.albedo = albedo;
    s.normal = normal;
    s.depth = depth;
    return s;
}

}  // namespace

TEST_CASE("mean and half buffer of a pixel") {
    Film film(3, 2);
    // Samples 0..3 of pixel (2, 1): values 1, 2, 3, 4 in red; odd indices are 1 and 3.
    for (uint32_t i = 0; i < 4; ++i)
        film.add_sample(2, 1, i, radiance_sample(float(i + 1), 10.f * float(i), 0.f));
    PixelStats st = film.pixel_stats(2, 1);
    CHECK(st.taken == 4);
    CHECK(st.accepted == 4);
    CHECK(st.half_accepted == 2);
    CHECK(st.mean[0] == 2.5);
    CHECK(st.mean[1] == 15.0);
    CHECK(st.half_mean[0] == 3.0);  // (2 + 4) / 2
    CHECK(st.half_mean[1] == 20.0);  // (10 + 30) / 2
    CHECK(film.mean(2, 1).r == 2.5f);

    std::vector<float> beauty = film.beauty_rgb(), half = film.half_rgb(), spp = film.spp();
    REQUIRE(beauty.size() == 3 * 6);
    REQUIRE(spp.size() == 6);
    size_t i = (1 * 3 + 2);  // row-major from the top-left
    CHECK(beauty[3 * i + 0] == 2.5f);
    CHECK(beauty[3 * i + 1] == 15.f);
    CHECK(half[3 * i + 0] == 3.f);
    CHECK(spp[i] == 4.f);
    // Untouched pixels stay black with zero samples.
    CHECK(beauty[0] == 0.f);
    CHECK(spp[0] == 0.f);
    CHECK(film.total_samples() == 4);
}

TEST_CASE("AOVs average over hits only") {
    Film film(1, 1);
    film.add_sample(0, 0, 0, hit_sample(Rgb(1.f), Rgb(0.2f, 0.4f, 0.6f), {0, 0, 1}, 2.f));
    film.add_sample(0, 0, 1, radiance_sample(5.f, 5.f, 5.f));  // escaped
    film.add_sample(0, 0, 2, hit_sample(Rgb(1.f), Rgb(0.4f, 0.8f, 0.2f), {0, 1, 0}, 4.f));
    CHECK(film.pixel_stats(0, 0).hits == 2);
    std::vector<float> albedo = film.albedo_rgb(), normal = film.normal_xyz(), depth = film.depth();
    CHECK(albedo[0] == doctest::Approx(0.3f));
    CHECK(albedo[1] == doctest::Approx(0.6f));
    CHECK(albedo[2] == doctest::Approx(0.4f));
    CHECK(normal[0] == 0.f);
    CHECK(normal[1] == doctest::Approx(0.5f));
    CHECK(normal[2] == doctest::Approx(0.5f));
    CHECK(depth[0] == doctest::Approx(3.f));
    // The escaped sample still counts for the beauty: (1 + 5 + 1) / 3.
    CHECK(film.beauty_rgb()[0] == doctest::Approx(7.f / 3.f));

    Film empty(1, 1);
    empty.add_sample(0, 0, 0, radiance_sample(1, 1, 1));
    CHECK(std::isinf(empty.depth()[0]));
    CHECK(empty.albedo_rgb()[0] == 0.f);
}

TEST_CASE("non-finite radiance is dropped, counted and still taken") {
    Film film(2, 1);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    film.add_sample(0, 0, 0, radiance_sample(1.f, 1.f, 1.f));
    film.add_sample(0, 0, 1, radiance_sample(nan, 0.f, 0.f));
    film.add_sample(0, 0, 2, radiance_sample(0.f, kInfinity, 0.f));
    film.add_sample(0, 0, 3, radiance_sample(3.f, 3.f, 3.f));
    film.add_sample(1, 0, 0, radiance_sample(0.f, 0.f, -kInfinity));
    CHECK(film.nan_count() == 3);
    PixelStats st = film.pixel_stats(0, 0);
    CHECK(st.taken == 4);
    CHECK(st.accepted == 2);
    CHECK(st.half_accepted == 1);
    CHECK(st.mean[0] == 2.0);
    CHECK(st.half_mean[0] == 3.0);
    CHECK(film.sample_count(0, 0) == 4);
    CHECK(film.spp()[0] == 4.f);
    // A pixel whose only sample was dropped stays black, with one sample taken.
    CHECK(film.beauty_rgb()[3 + 2] == 0.f);
    CHECK(film.spp()[1] == 1.f);
    for (float v : film.beauty_rgb())
        CHECK(std::isfinite(v));
    film.clear();
    CHECK(film.nan_count() == 0);
    CHECK(film.total_samples() == 0);
}

TEST_CASE("10^6 samples of 0.1 keep the mean exact to 1e-6") {
    Film film(1, 1);
    Sample s = hit_sample(Rgb(0.1f, 0.1f, 0.1f), Rgb(0.1f), {0, 0, 1}, 0.1f);
    const uint32_t n = 1000000;
    for (uint32_t i = 0; i < n; ++i)
        film.add_sample(0, 0, i, s);
    const double exact = double(0.1f);  // the float value every sample carries
    PixelStats st = film.pixel_stats(0, 0);
    CHECK(std::abs(st.mean[0] - exact) / exact < 1e-6);
    CHECK(std::abs(st.half_mean[2] - exact) / exact < 1e-6);
    CHECK(std::abs(film.beauty_rgb()[1] - 0.1f) / 0.1f < 1e-6);
    CHECK(std::abs(film.albedo_rgb()[0] - 0.1f) / 0.1f < 1e-5);
    CHECK(std::abs(film.depth()[0] - 0.1f) / 0.1f < 1e-5);
    CHECK(film.spp()[0] == 1e6f);
    // A float accumulator would be off by far more than that: check the test can tell.
    float naive = 0.f;
    for (uint32_t i = 0; i < n; ++i)
        naive += 0.1f;
    CHECK(std::abs(naive / float(n) - 0.1f) / 0.1f > 1e-3);
}

TEST_CASE("2^20 samples of a constant average to the constant within 1e-6, at any magnitude") {
    // Double sums: the mean of 2^20 equal floats is exact (the sum of n equal values needs
    // only log2(n) more bits than one), for tiny, ordinary and huge radiance alike.
    const uint32_t n = 1u << 20;
    for (float level : {1e-20f, 1e-4f, 0.1f, 0.7f, 3.3e3f, 1e6f, 3e30f}) {
        CAPTURE(level);
        Film film(2, 1);
        Sample s = hit_sample(Rgb(level, level, level), Rgb(0.5f), {0, 0, 1}, 1.f);
        for (uint32_t i = 0; i < n; ++i) film.add_sample(1, 0, i, s);
        PixelStats st = film.pixel_stats(1, 0);
        CHECK(st.accepted == n);
        CHECK(st.half_accepted == n / 2);
        for (int c = 0; c < 3; ++c) {
            CHECK(std::abs(st.mean[size_t(c)] - double(level)) <= 1e-6 * double(level));
            CHECK(std::abs(st.half_mean[size_t(c)] - double(level)) <= 1e-6 * double(level));
        }
        CHECK(std::abs(film.beauty_rgb()[3] - level) <= 1e-6f * level);
        CHECK(film.nan_count() == 0);
    }
}

TEST_CASE("concurrent writers to different pixels") {
    const uint32_t w = 16, h = 16, spp = 200;
    Film film(w, h);
    std::vector<std::thread> threads;
    for (uint32_t t = 0; t < 4; ++t) {
        threads.emplace_back([&film, t] {
            // Thread t owns rows t, t+4, ...; every 7th sample is NaN.
            for (uint32_t y = t; y < h; y += 4)
                for (uint32_t x = 0; x < w; ++x)
                    for (uint32_t i = 0; i < spp; ++i)
                        film.add_sample(x, y, i,
                                        i % 7 == 0 ? radiance_sample(NAN, 0, 0)
                                                   : radiance_sample(float(x + y), 1, 2));
        });
    }
    for (auto &th : threads)
        th.join();
    const uint32_t dropped_per_pixel = (spp + 6) / 7;
    CHECK(film.nan_count() == uint64_t(w) * h * dropped_per_pixel);
    CHECK(film.total_samples() == uint64_t(w) * h * spp);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x)
            CHECK(film.mean(x, y).r == float(x + y));
}

TEST_CASE("memory per pixel") {
    // Two double RGB sums, three float AOVs, four counters.
    CHECK(Film::bytes_per_pixel() >= 2 * 24 + 7 * 4 + 4 * 4);
    CHECK(Film::bytes_per_pixel() <= 96);
    CHECK(Film(4, 4).describe().find("4x4") != std::string::npos);
}
