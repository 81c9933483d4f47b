// Unit tests of the adaptive scheduler: pass targets, lock striping, quadrant split, uniform
// mode, early convergence on a flat image, more samples where the noise is, time budget,
// cancel + resume (each pixel continues its own sequence), progress line.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <set>
#include <thread>
#include <vector>

#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"
#include "scheduler/striped_locks.h"
#include "synthetic_sources.h"

using namespace tessera;
using namespace tessera::sched;
using tessera::test::SyntheticParams;
using tessera::test::SyntheticSource;

namespace {

AdaptiveOptions quiet(uint32_t threads) {
    AdaptiveOptions o;
    o.threads = threads;
    o.seed = 99;
    o.progress = ProgressReporter::Mode::Never;
    o.min_extent = 1;  // split down to single pixels (the samplers' default: one tile)
    return o;
}

bool all_counts(const sampling::Film &film, uint32_t n) {
    for (uint32_t y = 0; y < film.height(); ++y)
        for (uint32_t x = 0; x < film.width(); ++x)
            if (film.sample_count(x, y) != n)
                return false;
    return true;
}

}  // namespace

TEST_CASE("pass targets: uniform start, growing passes, capped per pass and in total") {
    AdaptiveOptions o;  // 16 .. 1024, 64 per pass
    std::vector<uint32_t> t = AdaptiveScheduler::pass_targets(o);
    REQUIRE(t.size() == 18);
    CHECK(t[0] == 16);
    CHECK(t[1] == 32);
    CHECK(t[2] == 64);
    CHECK(t[3] == 128);
    CHECK(t[4] == 192);
    CHECK(t.back() == 1024);
    CHECK(AdaptiveScheduler::pass_count(o) == 18);

    o.min_spp = 1;
    o.max_spp = 10;
    o.max_pass_spp = 4;
    CHECK(AdaptiveScheduler::pass_targets(o) == std::vector<uint32_t>{1, 2, 4, 8, 10});
    o.max_pass_spp = 0;
    o.max_spp = 100;
    CHECK(AdaptiveScheduler::pass_targets(o) == std::vector<uint32_t>{1, 2, 4, 8, 16, 32, 64, 100});
    o.min_spp = 50;  // more than the cap: one pass
    o.max_spp = 20;
    CHECK(AdaptiveScheduler::pass_targets(o) == std::vector<uint32_t>{20});
    o.min_spp = 0;  // treated as 1
    o.max_spp = 1;
    CHECK(AdaptiveScheduler::pass_targets(o) == std::vector<uint32_t>{1});

    // Unlimited: the closed form agrees with stepping, and saturates at 2^32 - 1.
    o.min_spp = 3;
    o.max_spp = 0;
    o.max_pass_spp = 64;
    uint64_t prev = 0;
    for (uint64_t p = 0; p < 200; ++p) {
        uint64_t cur = AdaptiveScheduler::pass_target(o, p);
        CHECK(cur > prev);
        if (p > 0)
            CHECK(cur - prev == std::min<uint64_t>(prev, 64));
        prev = cur;
    }
    CHECK(AdaptiveScheduler::pass_target(o, uint64_t(1) << 40) == 0xffffffffu);
    uint64_t n = AdaptiveScheduler::pass_count(o);
    CHECK(AdaptiveScheduler::pass_target(o, n - 1) == 0xffffffffu);
    CHECK(AdaptiveScheduler::pass_target(o, n - 2) < 0xffffffffu);
}

TEST_CASE("striped locks: 8-neighbours never share a stripe; a sweep waits for readers") {
    CHECK(round_stripe_count(0) == 8);
    CHECK(round_stripe_count(9) == 16);
    CHECK(round_stripe_count(64) == 64);
    for (uint32_t p : {8u, 16u, 64u, 256u}) {
        bool distinct = true;
        for (uint32_t y = 1; y < 40; ++y)
            for (uint32_t x = 1; x < 40; ++x)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx)
                        if ((dx || dy) && stripe_index(x, y, p) == stripe_index(x + dx, y + dy, p))
                            distinct = false;
        CAPTURE(p);
        CHECK(distinct);
    }
    StripedRwLocks locks(64);
    CHECK(locks.size() == 64);
    CHECK(locks.lock_shared(3) == 0.0);
    CHECK(locks.lock_shared(3) == 0.0);  // readers share
    locks.unlock_shared(3);
    locks.unlock_shared(3);
    CHECK(locks.sweep() == 0.0);
    // A sweep waits for a reader that holds a stripe.
    std::atomic<bool> swept{false};
    CHECK(locks.lock_shared(5) == 0.0);
    std::thread writer([&] {
        locks.sweep();
        swept = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    CHECK(!swept.load());
    locks.unlock_shared(5);
    writer.join();
    CHECK(swept.load());
}

TEST_CASE("quadrants split at tile boundaries; every tile in exactly one quadrant") {
    for (auto wh : {std::pair{1u, 1u}, {17u, 9u}, {24u, 40u}, {1u, 100u}, {100u, 3u}}) {
        // Plain variables: clang 14 cannot capture structured bindings in CAPTURE's lambda.
        const uint32_t w = wh.first, h = wh.second;
        SyntheticSource src(w, h);
        sampling::Film film(w, h);
        AdaptiveScheduler sched(src, film, quiet(1));
        CAPTURE(w);
        CAPTURE(h);
        // Quadrant rectangles partition the image.
        long long area = 0;
        for (int q = 0; q < 4; ++q) {
            sampling::PixelBounds r = sched.quadrant_rect(q);
            area += r.empty() ? 0 : r.area();
            if (!r.empty())
                CHECK(r.x0 % 8 == 0);
            if (!r.empty())
                CHECK(r.y0 % 8 == 0);
        }
        CHECK(area == (long long)w * h);
        for (size_t t = 0; t < sched.tiles().size(); ++t) {
            const Tile &tile = sched.tiles()[t];
            sampling::PixelBounds r = sched.quadrant_rect(int(sched.tile_quadrant(t)));
            CHECK(int(tile.x0) >= r.x0);
            CHECK(int(tile.x1) <= r.x1);
            CHECK(int(tile.y0) >= r.y0);
            CHECK(int(tile.y1) <= r.y1);
        }
        CHECK(!sched.describe().empty());
    }
}

TEST_CASE("uniform mode: exactly max_spp everywhere (adaptive off, or target 0)") {
    for (int variant = 0; variant < 2; ++variant) {
        const uint32_t w = 29, h = 21;
        SyntheticSource src(w, h, test::gradient_noise_params());
        sampling::Film film(w, h);
        AdaptiveOptions o = quiet(3);
        o.min_spp = 2;
        o.max_spp = 37;
        o.max_pass_spp = 8;
        if (variant == 0)
            o.adaptive = false, o.error_target = 0.01;
        AdaptiveScheduler sched(src, film, o);
        CHECK(!sched.adaptive());
        AdaptiveStats st = sched.render();
        CHECK(all_counts(film, 37));
        CHECK(st.samples == uint64_t(w) * h * 37);
        CHECK(st.passes == AdaptiveScheduler::pass_count(o));
        CHECK(st.pixels_skipped == 0);
        CHECK(st.rebuilds == 0);
        CHECK(!st.converged);
        bool exact = true;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x)
                exact = exact && src.indices_exact(x, y, 37);
        CHECK(exact);
        // Histogram: every pixel in the bucket [32, 64).
        REQUIRE(st.spp_histogram.size() == 7);
        CHECK(st.spp_histogram[6] == uint64_t(w) * h);
    }
}

TEST_CASE("adaptive: a nearly flat image converges early with fewer samples than max") {
    for (bool det : {false, true}) {
        const uint32_t w = 48, h = 40;
        SyntheticSource src(w, h, test::gradient_noise_params(0.002f));
        sampling::Film film(w, h);
        AdaptiveOptions o = quiet(2);
        o.deterministic = det;
        o.error_target = 0.001;
        AdaptiveScheduler sched(src, film, o);
        AdaptiveStats st = sched.render();
        CAPTURE(det);
        CHECK(st.converged);
        CHECK(st.samples < uint64_t(w) * h * o.max_spp / 4);
        CHECK(st.error_estimate < 0.01);
        for (int q = 0; q < 4; ++q)
            CHECK(sched.tree(q).complete());
        CHECK(st.rebuilds >= 4);
        MESSAGE("flat image: " << st.describe());
    }
}

TEST_CASE("adaptive: the noisy region gets more samples than the flat rest") {
    const uint32_t w = 64, h = 48;
    SyntheticParams sp;
    sp.base = SyntheticParams::Base::Flat;
    sp.noise = 0.3f;
    sp.noise_rect = {40, 8, 56, 24};
    SyntheticSource src(w, h, sp);
    sampling::Film film(w, h);
    AdaptiveOptions o = quiet(4);
    o.max_spp = 256;
    o.error_target = 0.0005;
    // Barrier-free mode may read stale trees, so how far the flat rest gets depends on timing
    // on a loaded machine; the barrier mode makes the outcome exact.
    o.deterministic = true;
    AdaptiveScheduler sched(src, film, o);
    AdaptiveStats st = sched.render();
    double in = 0, out = 0;
    uint64_t n_in = 0, n_out = 0;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            bool inside = x >= 40 && x < 56 && y >= 8 && y < 24;
            (inside ? in : out) += film.sample_count(x, y);
            ++(inside ? n_in : n_out);
        }
    in /= double(n_in);
    out /= double(n_out);
    MESSAGE("noisy region " << in << " spp, flat rest " << out << " spp; " << st.describe());
    CHECK(in > 4 * out);
    CHECK(st.pixels_skipped > 0);
    CHECK(st.tiles_skipped > 0);
}

TEST_CASE("time budget stops an unlimited render") {
    const uint32_t w = 32, h = 32;
    SyntheticSource src(w, h, test::gradient_noise_params());
    sampling::Film film(w, h);
    AdaptiveOptions o = quiet(2);
    o.max_spp = 0;
    o.time_s = 0.15;
    o.adaptive = false;
    AdaptiveScheduler sched(src, film, o);
    AdaptiveStats st = sched.render();
    CHECK(st.out_of_time);
    CHECK(!st.cancelled);
    CHECK(st.wall_s < 2.0);
    CHECK(st.samples > 0);
    // Without any budget an unlimited render is refused.
    o.time_s = 0;
    CHECK_THROWS_AS(AdaptiveScheduler(src, film, o), std::invalid_argument);
}

TEST_CASE("cancel stops; a second render() resumes each pixel's own sequence") {
    const uint32_t w = 40, h = 30;
    // Uniform: the resumed film is bit-identical to a straight render.
    {
        SyntheticSource straight_src(w, h, test::gradient_noise_params());
        sampling::Film straight(w, h);
        AdaptiveOptions o = quiet(3);
        o.adaptive = false;
        o.max_spp = 64;
        AdaptiveScheduler(straight_src, straight, o).render();

        SyntheticSource src(w, h, test::gradient_noise_params());
        sampling::Film film(w, h);
        std::atomic<bool> cancel{false};
        src.cancel_after(10000, &cancel);
        AdaptiveScheduler sched(src, film, o);
        AdaptiveStats a = sched.render(&cancel);
        CHECK(a.cancelled);
        CHECK(a.samples < uint64_t(w) * h * 64);
        CHECK(film.total_samples() == a.samples);
        src.cancel_after(0, nullptr);
        AdaptiveStats b = sched.render();
        CHECK(!b.cancelled);
        CHECK(a.samples + b.samples == uint64_t(w) * h * 64);
        std::vector<float> x = straight.beauty_rgb(), y = film.beauty_rgb();
        CHECK(std::memcmp(x.data(), y.data(), x.size() * 4) == 0);
    }
    // Adaptive, both modes: indices stay 0..n-1 once each across the two calls.
    for (bool det : {false, true}) {
        SyntheticParams sp = test::gradient_noise_params(0.3f);
        sp.noise_rect = {0, 0, 20, 30};
        SyntheticSource src(w, h, sp);
        sampling::Film film(w, h);
        AdaptiveOptions o = quiet(3);
        o.deterministic = det;
        o.max_spp = 128;
        o.error_target = 0.0005;
        std::atomic<bool> cancel{false};
        src.cancel_after(40000, &cancel);
        AdaptiveScheduler sched(src, film, o);
        AdaptiveStats a = sched.render(&cancel);
        CAPTURE(det);
        CHECK(a.cancelled);
        src.cancel_after(0, nullptr);
        AdaptiveStats b = sched.render();
        CHECK(!b.cancelled);
        CHECK(a.samples + b.samples == film.total_samples());
        bool exact = true;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x)
                exact = exact && src.indices_exact(x, y, film.sample_count(x, y));
        CHECK(exact);
        // A third call rebuilds the trees from the film. In deterministic mode they equal those
        // of the last pass, whose active pixels all reached the target: nothing to do. (The
        // barrier-free mode may find regions opened by samples taken after its last rebuild.)
        AdaptiveStats c = sched.render();
        if (det)
            CHECK(c.samples == 0);
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x)
                exact = exact && src.indices_exact(x, y, film.sample_count(x, y));
        CHECK(exact);
    }
}

TEST_CASE("progress line shows passes, spp, error, rays/s and ETA") {
    AdaptiveProgressState st;
    st.passes = 5;
    st.mean_spp = 37.25;
    st.error = 0.0123;
    st.error_target = 0.01;
    st.rays_per_s = 12.3e6;
    st.eta_s = 42;
    st.fraction = 0.5;
    std::string line = format_adaptive_progress_line(st, 10);
    CHECK(line == "[#####.....] passes 5  spp 37.2  err 0.0123/0.01  12.3 Mrays/s  ETA 0:42");
    st.error = std::numeric_limits<double>::infinity();
    st.eta_s = -1;
    CHECK(format_adaptive_progress_line(st, 10).find("err n/a/0.01") != std::string::npos);
    CHECK(format_adaptive_progress_line(st, 10).find("ETA --:--") != std::string::npos);
}
