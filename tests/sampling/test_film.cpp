// Unit tests of the film: means, half buffer, AOVs (only the requested ones), dropped samples,
// precision, threads.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "approx.h"
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
    Film film(1, 1, AovSet::all());
    film.add_sample(0, 0, 0, hit_sample(Rgb(1.f), Rgb(0.2f, 0.4f, 0.6f), {0, 0, 1}, 2.f));
    film.add_sample(0, 0, 1, radiance_sample(5.f, 5.f, 5.f));  // escaped
    film.add_sample(0, 0, 2, hit_sample(Rgb(1.f), Rgb(0.4f, 0.8f, 0.2f), {0, 1, 0}, 4.f));
    CHECK(film.pixel_stats(0, 0).hits == 2);
    std::vector<float> albedo = film.albedo_rgb(), normal = film.normal_xyz(), depth = film.depth();
    CHECK(albedo[0] == test::Approx(0.3f));
    CHECK(albedo[1] == test::Approx(0.6f));
    CHECK(albedo[2] == test::Approx(0.4f));
    CHECK(normal[0] == 0.f);
    CHECK(normal[1] == test::Approx(0.5f));
    CHECK(normal[2] == test::Approx(0.5f));
    CHECK(depth[0] == test::Approx(3.f));
    // The escaped sample still counts for the beauty: (1 + 5 + 1) / 3.
    CHECK(film.beauty_rgb()[0] == test::Approx(7.f / 3.f));

    Film empty(1, 1, AovSet::all());
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
    Film film(1, 1, AovSet::all());
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
    // Two double RGB sums and four counters; with all AOVs also seven floats.
    CHECK(Film::bytes_per_pixel_for({}) == 2 * 24 + 4 * 4);
    CHECK(Film::bytes_per_pixel_for(AovSet::all()) == 2 * 24 + 4 * 4 + 7 * 4);
    CHECK(Film::bytes_per_pixel_for(AovSet::all()) <= 96);
    CHECK(Film(4, 4).bytes_per_pixel() == Film::bytes_per_pixel_for({}));
    CHECK(Film(4, 4, AovSet::all()).bytes_per_pixel() == Film::bytes_per_pixel_for(AovSet::all()));
    CHECK(Film(4, 4).describe().find("4x4") != std::string::npos);
}

namespace {

/// A deterministic mix of hits, misses and a NaN for every pixel of a w x h film.
void fill(Film &film, uint32_t spp) {
    for (uint32_t y = 0; y < film.height(); ++y)
        for (uint32_t x = 0; x < film.width(); ++x)
            for (uint32_t i = 0; i < spp; ++i) {
                float v = 0.1f * float(x + 2 * y) + 0.37f * float(i % 5);
                if (i % 11 == 10)
                    film.add_sample(x, y, i, radiance_sample(NAN, 0, 0));
                else if (i % 3 == 0)
                    film.add_sample(x, y, i, radiance_sample(v, 2 * v, 0.5f));
                else
                    film.add_sample(x, y, i,
                                    hit_sample(Rgb(v, v, 1.f), Rgb(0.1f * float(i % 4), 0.5f, v),
                                               {0, float(i % 2), 1}, 1.f + v));
            }
}

}  // namespace

TEST_CASE("a film without AOVs is smaller and has the same beauty as one with all") {
    Film none(5, 3), all(5, 3, AovSet::all());
    CHECK(none.aovs().empty());
    CHECK(none.bytes_per_pixel() < all.bytes_per_pixel());
    CHECK(none.bytes_per_pixel() == 64);
    CHECK(all.bytes_per_pixel() == 92);
    fill(none, 37);
    fill(all, 37);
    // Bit-identical beauty, half buffer, counts and dropped samples.
    CHECK(none.beauty_rgb() == all.beauty_rgb());
    CHECK(none.half_rgb() == all.half_rgb());
    CHECK(none.spp() == all.spp());
    CHECK(none.nan_count() == all.nan_count());
    CHECK(none.total_samples() == all.total_samples());
    for (uint32_t y = 0; y < 3; ++y)
        for (uint32_t x = 0; x < 5; ++x) {
            PixelStats a = none.pixel_stats(x, y), b = all.pixel_stats(x, y);
            CHECK(a.mean == b.mean);
            CHECK(a.half_mean == b.half_mean);
            CHECK(a.taken == b.taken);
            CHECK(a.accepted == b.accepted);
            CHECK(a.half_accepted == b.half_accepted);
            CHECK(a.hits == 0);  // no AOV means kept: hits are not counted
            CHECK(b.hits > 0);
        }
    // The resolves of AOVs that were not asked for are empty (documented in film.h).
    CHECK(none.albedo_rgb().empty());
    CHECK(none.normal_xyz().empty());
    CHECK(none.depth().empty());
    CHECK(none.raw_aovs().albedo.empty());
    CHECK(none.raw_aovs().normal.empty());
    CHECK(none.raw_aovs().depth.empty());
}

TEST_CASE("a film with only depth allocates only depth, with the means of an all-AOV film") {
    Film depth(4, 2, AovSet{Aov::Depth}), all(4, 2, AovSet::all());
    CHECK(depth.bytes_per_pixel() == 64 + 4);
    CHECK(depth.raw_aovs().albedo.empty());
    CHECK(depth.raw_aovs().normal.empty());
    CHECK(depth.raw_aovs().depth.size() == 8);
    fill(depth, 23);
    fill(all, 23);
    CHECK(depth.albedo_rgb().empty());
    CHECK(depth.normal_xyz().empty());
    REQUIRE(depth.depth().size() == 8);
    CHECK(depth.depth() == all.depth());
    CHECK(depth.beauty_rgb() == all.beauty_rgb());
    depth.clear();
    CHECK(depth.raw_aovs().depth.size() == 8);
    CHECK(depth.raw_aovs().depth[3] == 0.f);
}

TEST_CASE("restore checks the AOV arrays against the film's set") {
    Film film(2, 2, AovSet{Aov::Albedo});
    std::vector<Film::PixelData> px(4);
    Film::AovData ok;
    ok.albedo.assign(4, Film::Float3{0.5f, 0.25f, 0.125f});
    px[1].taken = px[1].accepted = px[1].hits = 1;
    film.restore(px, ok, 3);
    CHECK(film.albedo_rgb()[3 + 1] == 0.25f);
    CHECK(film.nan_count() == 3);
    Film::AovData extra = ok;
    extra.depth.assign(4, 1.f);  // the film keeps no depth
    CHECK_THROWS_AS(film.restore(px, extra, 0), std::invalid_argument);
    CHECK_THROWS_AS(film.restore(px, Film::AovData{}, 0), std::invalid_argument);
}

TEST_CASE("AovSet: parse, names, describe") {
    CHECK(AovSet::parse("none").empty());
    CHECK(AovSet::parse("all") == AovSet::all());
    CHECK(AovSet::parse("depth,albedo") == AovSet{Aov::Albedo, Aov::Depth});
    CHECK(AovSet::parse("normal,normal") == AovSet{Aov::Normal});
    CHECK(AovSet::parse("depth,albedo").names() == std::vector<std::string>{"albedo", "depth"});
    CHECK(AovSet::all().describe() == "albedo,normal,depth");
    CHECK(AovSet{}.describe() == "none");
    CHECK(AovSet::parse(AovSet{Aov::Normal, Aov::Depth}.describe()) ==
          AovSet{Aov::Normal, Aov::Depth});
    for (const char *bad : {"bogus", "", "albedo,", "albedo,all", "Depth", "albedo;normal"}) {
        CAPTURE(bad);
        CHECK_THROWS_AS(AovSet::parse(bad), std::invalid_argument);
    }
}
