// Stress tests of the adaptive scheduler on synthetic sources: every image size from 1x1 to 4K,
// 1 to 64 threads (oversubscribed on purpose), barrier-free, deterministic and uniform modes,
// random per-tile delays. Each run checks the invariants of docs/ARCHITECTURE.md ("Invariants
// worth a test each"): exact per-pixel coverage (film counts == evaluations the source received, indices
// 0..n-1 once each), no (pass, tile) visited twice, inactive pixels take no samples, region-tree
// leaves partition their grown quadrant, the image stays finite.
//
// ThreadSanitizer: the TSan job builds this file with -DTESSERA_TSAN=ON (ctest -L tsan). The
// scheduler is data-race-free by design: film pixels are written by their tile's owner only
// (the same tile's next pass waits for it), the trees are read under reader locks and swapped
// under the writer lock, and rebuilds read an atomic per-pixel error snapshot, never the film.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "approx.h"
#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"
#include "synthetic_sources.h"

using namespace tessera;
using namespace tessera::sched;
using tessera::test::SyntheticParams;
using tessera::test::SyntheticSource;
using tessera::test::VisitRecorder;

namespace {

constexpr uint32_t kSeed = 4242;

AdaptiveOptions base_options(uint32_t threads) {
    AdaptiveOptions o;
    o.threads = threads;
    o.seed = kSeed;
    o.progress = ProgressReporter::Mode::Never;
    o.min_spp = 4;
    o.max_spp = 64;
    o.max_pass_spp = 16;
    o.error_target = 0.002;
    o.min_extent = 1;  // split down to single pixels (the samplers' default: one tile)
    return o;
}

struct RunResult {
    AdaptiveStats stats;
    std::vector<float> beauty, spp;
    uint64_t reopened = 0;
    std::vector<uint8_t> reopened_mask;
};

// Renders `sp` at w x h with `o` and checks every invariant; returns the film's images.
RunResult run_checked(uint32_t w, uint32_t h, const SyntheticParams &sp, AdaptiveOptions o,
                      uint64_t delay_seed, bool check_trees = false) {
    SyntheticSource src(w, h, sp);
    sampling::Film film(w, h);
    const size_t tiles = size_t((w + 7) / 8) * ((h + 7) / 8);
    VisitRecorder rec(w, h, tiles, delay_seed);
    rec.install(o, check_trees);
    AdaptiveScheduler sched(src, film, o);
    rec.set_scheduler(&sched);
    RunResult r;
    r.stats = sched.render();
    const AdaptiveStats &st = r.stats;

    CHECK(!st.cancelled);
    CHECK(!st.out_of_time);
    CHECK(rec.double_visits.load() == 0);
    CHECK(rec.inactive_sampled.load() == 0);
    CHECK(rec.active_short.load() == 0);
    CHECK(rec.overshoot.load() == 0);
    CHECK(rec.mask_mismatch.load() == 0);
    CHECK(rec.visits.load() == st.tiles_rendered + st.tiles_skipped);

    // Coverage: the film's count is exactly what the source evaluated, indices 0..n-1.
    bool exact = true, capped = true, uniform_ok = true;
    uint64_t film_total = 0;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            uint32_t n = film.sample_count(x, y);
            film_total += n;
            exact = exact && src.indices_exact(x, y, n);
            capped = capped && (o.max_spp == 0 || n <= o.max_spp);
            uniform_ok = uniform_ok && (sched.adaptive() || n == o.max_spp);
        }
    CHECK(exact);
    CHECK(capped);
    CHECK(uniform_ok);
    CHECK(film_total == st.samples);
    CHECK(src.total() == st.samples);
    CHECK(st.rays == 2 * st.samples);
    for (int q = 0; q < 4; ++q)
        CHECK(test::leaves_partition(sched.tree(q)));

    r.beauty = film.beauty_rgb();
    r.spp = film.spp();
    bool finite = true;
    for (float v : r.beauty)
        finite = finite && std::isfinite(v);
    CHECK(finite);
    r.reopened = rec.reopened_pixels();
    r.reopened_mask.resize(size_t(w) * h);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x)
            r.reopened_mask[size_t(y) * w + x] = rec.reopened(x, y);
    return r;
}

}  // namespace

TEST_CASE("stress: image sizes x thread counts x modes keep every invariant") {
    const uint32_t sizes[][2] = {{1, 1}, {1, 1000}, {1000, 1}, {7, 9}, {8, 8}, {9, 9}, {70, 45}};
    const uint32_t threads[] = {1, 2, 3, 8, 64};
    const SyntheticParams sources[] = {test::edge_params(), test::gradient_noise_params(),
                                       test::firefly_params(0.01f)};
    uint64_t run = 0, skipped_pixels = 0;
    for (auto &sz : sizes)
        for (uint32_t t : threads)
            for (int mode = 0; mode < 3; ++mode) {
                ++run;
                AdaptiveOptions o = base_options(t);
                o.deterministic = mode == 1;
                o.adaptive = mode != 2;
                const SyntheticParams &sp = sources[run % 3];
                CAPTURE(sz[0]);
                CAPTURE(sz[1]);
                CAPTURE(t);
                CAPTURE(mode);
                RunResult r = run_checked(sz[0], sz[1], sp, o, /*delay_seed=*/run,
                                          /*check_trees=*/o.deterministic);
                skipped_pixels += r.stats.pixels_skipped;
            }
    // The adaptive runs did skip work somewhere.
    CHECK(skipped_pixels > 0);
}

TEST_CASE("stress: the schedule never ends with an open region below max_spp (catch-up passes)") {
    // The last rebuild may cut a tree anew and open a region whose pixels took their last
    // samples passes ago; barrier-free, a tile may also skip its last passes on a stale tree.
    // Either way the render used to end there, unconverged with pixels below max_spp (these
    // thin images did so every time). Now it runs passes at the last target while an open
    // region holds such a pixel: at the end, every pixel of every open leaf inside its
    // quadrant is at max_spp, and every invariant of run_checked holds over the extra passes
    // (no tile visited twice in a pass, no pixel past max_spp, sample indices exact).
    const uint32_t sizes[][2] = {{1, 1000}, {1000, 1}, {70, 45}};
    uint32_t catch_up = 0, runs = 0;
    for (auto &sz : sizes)
        for (bool det : {true, false})
            for (uint32_t t : {1u, 3u})
                for (int src = 0; src < 3; ++src) {
                    AdaptiveOptions o = base_options(t);
                    o.deterministic = det;
                    const SyntheticParams sp = src == 0   ? test::edge_params()
                                               : src == 1 ? test::gradient_noise_params()
                                                          : test::firefly_params(0.01f);
                    CAPTURE(sz[0]);
                    CAPTURE(sz[1]);
                    CAPTURE(det);
                    CAPTURE(t);
                    CAPTURE(src);
                    SyntheticSource source(sz[0], sz[1], sp);
                    sampling::Film film(sz[0], sz[1]);
                    AdaptiveScheduler sched(source, film, o);
                    const AdaptiveStats st = sched.render();
                    ++runs;
                    catch_up += st.catch_up_passes;
                    CHECK(st.catch_up_passes <= 4);
                    uint32_t below = 0;
                    std::vector<sampling::PixelBounds> rects;
                    for (int q = 0; q < 4 && !st.converged; ++q) {
                        const sampling::PixelBounds qr = sched.quadrant_rect(q);
                        if (qr.empty()) continue;
                        sched.tree(q).active_rects(qr, rects);
                        for (const sampling::PixelBounds &r : rects)
                            for (int y = std::max(r.y0, qr.y0); y < std::min(r.y1, qr.y1); ++y)
                                for (int x = std::max(r.x0, qr.x0); x < std::min(r.x1, qr.x1);
                                     ++x)
                                    below += film.sample_count(uint32_t(x), uint32_t(y)) <
                                             o.max_spp;
                    }
                    CHECK(below == 0);
                    if (st.catch_up_passes > 0)  // the extra passes keep every invariant
                        run_checked(sz[0], sz[1], sp, o, /*delay_seed=*/runs, det);
                }
    MESSAGE(catch_up << " catch-up passes in " << runs << " renders");
    CHECK(catch_up > 0);
}

TEST_CASE("stress: 1920x1080 and 4096x2160 with few samples") {
    {
        AdaptiveOptions o = base_options(8);
        o.min_spp = 2;
        o.max_spp = 4;
        o.min_samples_for_error = 2;
        // Low enough that the edge stays open after the first pass (at 0.0005 every quadrant
        // could converge at once, and a barrier-free render then may stop before any tile of
        // the second pass is visited: nothing skipped).
        o.error_target = 0.00002;
        RunResult r = run_checked(1920, 1080, test::edge_params(), o, 11);
        MESSAGE("1920x1080, 8 threads: " << r.stats.describe());
        CHECK(r.stats.pixels_skipped > 0);
    }
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
    // A 4K film is 850 MB before the sanitizer's shadow memory: 1080p covers the same code.
    MESSAGE("4096x2160 skipped under a sanitizer");
#else
    {
        AdaptiveOptions o = base_options(64);
        o.min_spp = 1;
        o.max_spp = 2;
        o.min_samples_for_error = 2;
        o.error_target = 0.001;
        RunResult r = run_checked(4096, 2160, test::gradient_noise_params(0.1f), o, 12);
        MESSAGE("4096x2160, 64 threads: " << r.stats.describe());
    }
#endif
}

TEST_CASE("stress: deterministic mode gives a bit-identical film for 1, 3 and 8 threads") {
    SyntheticParams sp = test::gradient_noise_params(0.3f);
    sp.noise_rect = {10, 5, 40, 30};
    std::vector<float> beauty, spp;
    for (uint32_t t : {1u, 3u, 8u}) {
        AdaptiveOptions o = base_options(t);
        o.deterministic = true;
        o.max_spp = 256;
        o.error_target = 0.0005;
        RunResult r = run_checked(61, 43, sp, o, 100 + t, /*check_trees=*/true);
        CAPTURE(t);
        CHECK(r.stats.pixels_skipped > 0);
        if (beauty.empty()) {
            beauty = r.beauty;
            spp = r.spp;
        } else {
            CHECK(std::memcmp(beauty.data(), r.beauty.data(), beauty.size() * 4) == 0);
            CHECK(std::memcmp(spp.data(), r.spp.data(), spp.size() * 4) == 0);
        }
    }
    // Uniform barrier-free passes are bit-identical too (no trees involved).
    std::vector<float> uniform;
    for (uint32_t t : {1u, 8u}) {
        AdaptiveOptions o = base_options(t);
        o.adaptive = false;
        RunResult r = run_checked(61, 43, sp, o, 200 + t);
        if (uniform.empty())
            uniform = r.beauty;
        else
            CHECK(std::memcmp(uniform.data(), r.beauty.data(), uniform.size() * 4) == 0);
    }
}

TEST_CASE("stress: a NaN pixel is counted and the image stays finite") {
    for (bool det : {false, true}) {
        const uint32_t w = 20, h = 20;
        SyntheticSource src(w, h, test::nan_params(3, 4));
        sampling::Film film(w, h);
        AdaptiveOptions o = base_options(3);
        o.deterministic = det;
        AdaptiveScheduler sched(src, film, o);
        AdaptiveStats st = sched.render();
        CHECK(st.nan_samples == film.sample_count(3, 4));
        CHECK(st.nan_samples == src.count(3, 4));
        CHECK(st.nan_samples >= o.min_spp);
        for (float v : film.beauty_rgb())
            REQUIRE(std::isfinite(v));
    }
}

TEST_CASE("stress: a late firefly reopens completed regions of its quadrant") {
    // 64x64: flat 0.5, except a noisy block in quadrant 0 that stays open (the target is far
    // below what max_spp reaches there). Pixel (20, 10) in the block returns a 1e12 firefly at
    // samples 41, 57, 73, ...: its quadrant's root error then exceeds split_factor * target, the
    // root stays one open leaf, and the flat pixels of quadrant 0 that completed after the
    // first pass are sampled again. Without the firefly, flat pixels away from the block never
    // reopen: those of the tiles that do not touch it (x < 8; the trees know the error per
    // 8x8 tile, and a tile an open region touches is sampled whole).
    const uint32_t w = 64, h = 64;
    SyntheticParams sp;
    sp.base = SyntheticParams::Base::Flat;
    sp.noise = 0.3f;
    sp.noise_rect = {16, 0, 32, 32};
    SyntheticParams late = sp;
    late.late_x = 20;
    late.late_y = 10;
    late.late_after = 41;
    for (bool det : {true, false}) {
        CAPTURE(det);
        AdaptiveOptions o = base_options(4);
        o.deterministic = det;
        o.min_spp = 16;
        o.max_spp = 256;
        o.max_pass_spp = 64;
        o.error_target = 0.0002;
        RunResult calm = run_checked(w, h, sp, o, 31, det);
        RunResult fire = run_checked(w, h, late, o, 32, det);
        // Flat pixels of quadrant 0 away from the noisy block.
        uint64_t calm_reopened = 0, fire_reopened = 0;
        double calm_spp = 0, fire_spp = 0;
        for (uint32_t y = 0; y < 32; ++y)
            for (uint32_t x = 0; x < 8; ++x) {
                size_t i = size_t(y) * w + x;
                calm_reopened += calm.reopened_mask[i];
                fire_reopened += fire.reopened_mask[i];
                calm_spp += calm.spp[i];
                fire_spp += fire.spp[i];
            }
        MESSAGE("late firefly (" << std::string(det ? "deterministic" : "barrier-free")
                                 << "): flat pixels "
                                 << "reopened " << fire_reopened
                                 << "/256 (without: " << calm_reopened << "), mean spp "
                                 << fire_spp / 256 << " (without: " << calm_spp / 256 << ")");
        if (det) {
            CHECK(calm_reopened == 0);
            CHECK(calm_spp == test::Approx(16.0 * 256));
        }
        // Barrier-free, a busy machine may rebuild the quadrant's tree only after the firefly is
        // already in the film, so the flat pixels never close before it and cannot "reopen";
        // they still get more samples than without the firefly.
        if (det) CHECK(fire_reopened > 0);
        CHECK(fire_spp > calm_spp);
        // The noisy block got more samples than the flat rest either way.
        CHECK(calm.spp[size_t(10) * w + 24] > calm.spp[size_t(10) * w + 4]);
    }
}

TEST_CASE("stress: lock wait and rebuild times (barrier-free, oversubscribed)") {
    for (uint32_t t : {2u, 8u, 64u}) {
        AdaptiveOptions o = base_options(t);
        o.min_spp = 4;
        o.max_spp = 128;
        o.max_pass_spp = 32;
        o.error_target = 0.0005;
        SyntheticParams sp = test::gradient_noise_params(0.2f);
        sp.noise_rect = {0, 0, 200, 120};
        RunResult r = run_checked(320, 240, sp, o, 40 + t);
        const AdaptiveStats &st = r.stats;
        MESSAGE(t << " threads: lock wait " << st.lock_wait_fraction * 100 << "% of thread time ("
                  << st.lock_wait_s * 1e3 << " ms), tile wait " << st.tile_wait_s * 1e3 << " ms, "
                  << st.rebuilds << " rebuilds, mean " << st.tree_rebuild_ms_mean << " ms, max "
                  << st.tree_rebuild_ms_max << " ms; " << st.describe());
        CHECK(st.rebuilds >= 4);
        CHECK(st.lock_wait_fraction >= 0);
        CHECK(st.lock_wait_fraction < 0.5);
    }
}

TEST_CASE("stress: 1x1 at 2^20 spp and 65536x4: exact means and valid float splits") {
    SUBCASE("one pixel, 2^20 samples of a constant: the mean is the constant to 1e-6") {
        for (float level : {0.1f, 3.7e-4f, 12345.678f}) {
            CAPTURE(level);
            SyntheticParams p;
            p.base = SyntheticParams::Base::Flat;
            p.level = level;
            SyntheticSource src(1, 1, p);
            sampling::Film film(1, 1);
            AdaptiveOptions o = base_options(2);
            o.max_spp = 1u << 20;
            o.max_pass_spp = 1u << 18;
            // A constant has no error: the adaptive mode would stop at min_spp. Uniform mode
            // takes every sample.
            o.adaptive = false;
            AdaptiveScheduler sched(src, film, o);
            AdaptiveStats st = sched.render();
            CHECK(film.sample_count(0, 0) == (1u << 20));
            CHECK(st.samples == (1u << 20));
            sampling::PixelStats ps = film.pixel_stats(0, 0);
            for (int c = 0; c < 3; ++c) {
                CHECK(std::abs(ps.mean[size_t(c)] - double(level)) <= 1e-6 * double(level));
                CHECK(std::abs(ps.half_mean[size_t(c)] - double(level)) <= 1e-6 * double(level));
            }
            for (int q = 0; q < 4; ++q) CHECK(test::leaves_partition(sched.tree(q)));
        }
    }
    SUBCASE("one noisy pixel to 2^20 spp: the error estimate keeps shrinking, trees stay valid") {
        SyntheticSource src(1, 1, test::gradient_noise_params(0.2f));
        sampling::Film film(1, 1);
        AdaptiveOptions o = base_options(2);
        o.max_spp = 1u << 20;
        o.max_pass_spp = 1u << 18;
        o.error_target = 1e-12;
        AdaptiveScheduler sched(src, film, o);
        AdaptiveStats st = sched.render();
        CHECK(film.sample_count(0, 0) == (1u << 20));
        CHECK(std::isfinite(st.error_estimate));
        CHECK(st.error_estimate < 1e-3);
        for (int q = 0; q < 4; ++q) CHECK(test::leaves_partition(sched.tree(q)));
    }
    SUBCASE("65536x4: four 32768x2 quadrants with splits along a 32768-pixel axis") {
        // The error lives in a few narrow columns: splits must land at fractional positions
        // tens of thousands of pixels from the origin and still partition exactly.
        SyntheticParams p;
        p.base = SyntheticParams::Base::Flat;
        p.noise = 0.3f;
        p.noise_rect = {40000, 0, 40100, 4};
        SyntheticSource src(65536, 4, p);
        sampling::Film film(65536, 4);
        AdaptiveOptions o = base_options(2);
        o.min_spp = 4;
        o.max_spp = 32;
        o.max_pass_spp = 8;
        // Low enough that the 100-pixel noisy strip keeps its quadrant's error above target
        // (diluted over 65536 pixels) until the tree localises it.
        o.error_target = 1e-5;
        AdaptiveScheduler sched(src, film, o);
        AdaptiveStats st = sched.render();
        CHECK(st.samples >= uint64_t(65536) * 4 * o.min_spp);
        size_t nodes = 0;
        for (int q = 0; q < 4; ++q) {
            const sampling::RegionTree &t = sched.tree(q);
            CHECK(test::leaves_partition(t));
            nodes += t.nodes().size();
            for (const auto &n : t.nodes()) {
                CHECK(std::isfinite(n.bounds.x0));
                CHECK(std::isfinite(n.bounds.x1));
                CHECK(n.bounds.x1 > n.bounds.x0);
                CHECK(n.bounds.y1 > n.bounds.y0);
            }
        }
        CHECK(nodes > 4);  // something split
        // The noisy columns got more samples than the flat rest, even in their own quadrant.
        CHECK(film.sample_count(40050, 1) > film.sample_count(100, 1));
        CHECK(film.sample_count(40050, 1) > film.sample_count(60000, 1));
        for (float v : film.beauty_rgb()) REQUIRE(std::isfinite(v));
    }
}
