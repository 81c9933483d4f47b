// Uniform sampling with the adaptive scheduler (adaptive = false), the checks carried over from
// the retired TileScheduler: exact coverage with the sequence's own film offsets, Morton tile
// order on one thread, 1 vs 4 threads bit-identical (barrier-free and deterministic), convergence
// to analytic pixel integrals, NaN samples dropped and counted, the camera-sample helpers of
// scheduler/camera_sample.h, and the progress-line helpers of scheduler/progress.h.
// Cancel/resume, time budgets and pass targets are covered by test_adaptive_scheduler.cpp.
//
// ThreadSanitizer: these tests carry the "tsan" label (tests/CMakeLists.txt). The sources below
// keep all their bookkeeping in atomics, and the hooks' records are guarded by a mutex.
#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "approx.h"
#include "sampling/film.h"
#include "sampling/sequence.h"
#include "scheduler/adaptive_scheduler.h"
#include "scheduler/camera_sample.h"
#include "scheduler/progress.h"
#include "scheduler/tiles.h"
#include "synthetic_sources.h"

using namespace tessera;
using namespace tessera::sched;

namespace {

constexpr uint32_t kSeed = 1234;

// Radiance = an analytic function of the film position (x, y) = (px + fx, py + fy), or of the
// integrator's own sequence dimensions; records which (pixel, index) pairs it saw and whether
// every film offset equals the sequence's reserved pixel dimensions of (kSeed, pixel, index).
class SequenceSource final : public SampleSource {
  public:
    enum class Kind {
        Gradient,  // R = x / W, G = y / H, B = fx * fy: pixel integrals (px+.5)/W, (py+.5)/H, 1/4
        Edge,      // R = 1 where y < x (film space): coverage of the diagonal half-plane
        Noise,     // R,G,B from the integrator's dimensions (sampler_for): determinism tests
    };

    SequenceSource(uint32_t w, uint32_t h, Kind kind) : w_(w), h_(h), kind_(kind) {
        seen_ = std::make_unique<std::atomic<uint64_t>[]>(size_t(w) * h);
        for (size_t i = 0; i < size_t(w) * h; ++i)
            seen_[i].store(0);
    }
    uint32_t width() const override { return w_; }
    uint32_t height() const override { return h_; }
    std::string describe() const override { return "SequenceSource"; }

    Sample evaluate(const CameraSample &cs) const override {
        if (cs.index < 64)
            seen_[size_t(cs.py) * w_ + cs.px].fetch_or(uint64_t(1) << cs.index,
                                                       std::memory_order_relaxed);
        evaluations_.fetch_add(1, std::memory_order_relaxed);
        Sample s;
        s.rays = 3;
        s.depth = 1.f;
        const float x = float(cs.px) + cs.fx, y = float(cs.py) + cs.fy;
        switch (kind_) {
            case Kind::Gradient:
                s.radiance = Rgb(x / float(w_), y / float(h_), cs.fx * cs.fy);
                break;
            case Kind::Edge:
                s.radiance = Rgb(y < x ? 1.f : 0.f);
                break;
            case Kind::Noise: {
                sampling::SobolSampler sampler = sampler_for(kSeed, cs);
                const float a = sampler.get_1d();
                const Vec2f b = sampler.get_2d();
                s.radiance = Rgb(a * x, b.x + y, b.y * cs.fx);
                break;
            }
        }
        if (nan_odd_ && cs.px == 3 && cs.py == 4 && (cs.index & 1u))
            s.radiance.g = std::nanf("");
        sampling::SobolSampler ref(kSeed);
        ref.start_pixel_sample(cs.px, cs.py, cs.index);
        const Vec2f u = ref.get_pixel_2d();
        if (u.x != cs.fx || u.y != cs.fy)
            offset_mismatch_.fetch_add(1, std::memory_order_relaxed);
        return s;
    }

    /// Bit i set: sample index i (< 64) of pixel (px, py) was evaluated.
    uint64_t seen_mask(uint32_t px, uint32_t py) const { return seen_[size_t(py) * w_ + px]; }
    uint64_t evaluations() const { return evaluations_.load(); }
    uint64_t offset_mismatches() const { return offset_mismatch_.load(); }

    /// Pixel (3, 4) returns a NaN green channel for every odd sample index.
    bool nan_odd_ = false;

  private:
    uint32_t w_, h_;
    Kind kind_;
    std::unique_ptr<std::atomic<uint64_t>[]> seen_;
    mutable std::atomic<uint64_t> evaluations_{0}, offset_mismatch_{0};
};

// Delegates to a SyntheticSource and records, in evaluation order, the pixel of every sample
// with index 0 (with one thread: the order in which pass 0 reaches the pixels).
class FirstSampleRecorder final : public SampleSource {
  public:
    explicit FirstSampleRecorder(const SampleSource &inner) : inner_(inner) {}
    uint32_t width() const override { return inner_.width(); }
    uint32_t height() const override { return inner_.height(); }
    std::string describe() const override { return "FirstSampleRecorder"; }
    Sample evaluate(const CameraSample &cs) const override {
        if (cs.index == 0) {
            std::lock_guard<std::mutex> lock(mutex_);
            order_.emplace_back(cs.px, cs.py);
        }
        return inner_.evaluate(cs);
    }
    std::vector<std::pair<uint32_t, uint32_t>> order() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return order_;
    }

  private:
    const SampleSource &inner_;
    mutable std::mutex mutex_;
    mutable std::vector<std::pair<uint32_t, uint32_t>> order_;
};

// Uniform passes 1, 2, 4, ... up to `spp` samples per pixel.
AdaptiveOptions uniform(uint32_t threads, uint32_t spp, bool deterministic = false) {
    AdaptiveOptions o;
    o.threads = threads;
    o.seed = kSeed;
    o.progress = ProgressReporter::Mode::Never;
    o.adaptive = false;
    o.deterministic = deterministic;
    o.min_spp = 1;
    o.max_spp = spp;
    o.max_pass_spp = 0;
    o.min_extent = 1;  // split down to single pixels (the samplers' default: one tile)
    return o;
}

}  // namespace

TEST_CASE("uniform: every pixel gets exactly spp samples with the sequence's film offsets") {
    for (bool det : {false, true}) {
        CAPTURE(det);
        const uint32_t w = 37, h = 29, spp = 13;
        SequenceSource src(w, h, SequenceSource::Kind::Gradient);
        sampling::Film film(w, h);
        AdaptiveOptions o = uniform(4, spp, det);
        AdaptiveScheduler sched(src, film, o);
        AdaptiveStats st = sched.render();
        CHECK(st.samples == uint64_t(w) * h * spp);
        CHECK(src.evaluations() == uint64_t(w) * h * spp);
        CHECK(st.rays == 3 * st.samples);
        CHECK(st.passes == 5);  // targets 1, 2, 4, 8, 13
        CHECK(!st.cancelled);
        CHECK(!st.out_of_time);
        CHECK(st.nan_samples == 0);
        CHECK(src.offset_mismatches() == 0);
        bool exact = true;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x)
                exact = exact && film.sample_count(x, y) == spp &&
                        src.seen_mask(x, y) == (uint64_t(1) << spp) - 1;
        CHECK(exact);
        bool spp_image = true;
        for (float v : film.spp())
            spp_image = spp_image && v == float(spp);
        CHECK(spp_image);
    }
}

TEST_CASE("uniform: one thread visits the tiles in Morton order, pass after pass") {
    const uint32_t w = 27, h = 19, spp = 4;  // passes 1, 2, 4
    const std::vector<Tile> morton = make_morton_tiles(w, h);
    for (bool det : {false, true}) {
        CAPTURE(det);
        test::SyntheticSource inner(w, h, test::gradient_noise_params());
        FirstSampleRecorder src(inner);
        sampling::Film film(w, h);
        AdaptiveOptions o = uniform(1, spp, det);
        std::mutex mutex;
        std::vector<std::pair<uint32_t, uint32_t>> hooked;   // (pass, tile order) per tile_hook
        std::vector<std::pair<uint32_t, uint32_t>> visited;  // (pass, tile order) per visit_hook
        bool bounds_ok = true, first_pass_took_one = true;
        o.tile_hook = [&](const Tile &t, uint32_t pass) {
            std::lock_guard<std::mutex> lock(mutex);
            hooked.emplace_back(pass, t.order);
            bounds_ok = bounds_ok && t.order < morton.size() && t.x0 == morton[t.order].x0 &&
                        t.y0 == morton[t.order].y0 && t.x1 == morton[t.order].x1 &&
                        t.y1 == morton[t.order].y1;
        };
        o.visit_hook = [&](const TileVisit &v) {
            std::lock_guard<std::mutex> lock(mutex);
            visited.emplace_back(v.pass, v.tile->order);
            if (v.pass == 0)
                for (uint32_t i = 0; i < v.tile->pixel_count(); ++i)
                    first_pass_took_one =
                        first_pass_took_one && v.count_before[i] == 0 && v.count_after[i] == 1;
        };
        AdaptiveScheduler sched(src, film, o);
        REQUIRE(sched.thread_count() == 1);
        REQUIRE(sched.tiles().size() == morton.size());
        AdaptiveStats st = sched.render();
        CHECK(st.passes == 3);

        std::vector<std::pair<uint32_t, uint32_t>> expected;
        for (uint32_t pass = 0; pass < 3; ++pass)
            for (const Tile &t : morton)
                expected.emplace_back(pass, t.order);
        CHECK(bounds_ok);
        CHECK(hooked == expected);
        CHECK(visited == expected);
        // Pass 0 takes each pixel's first sample tile by tile in Morton order, row-major inside.
        std::vector<std::pair<uint32_t, uint32_t>> pixels;
        for (const Tile &t : morton)
            for (uint32_t y = t.y0; y < t.y1; ++y)
                for (uint32_t x = t.x0; x < t.x1; ++x)
                    pixels.emplace_back(x, y);
        CHECK(src.order() == pixels);
        CHECK(first_pass_took_one);
        bool exact = true;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x)
                exact = exact && inner.indices_exact(x, y, spp);
        CHECK(exact);
    }
}

TEST_CASE("uniform: 1 thread and 4 threads give bit-identical films") {
    // No tree is involved, so the barrier-free mode must be bit-identical too.
    const uint32_t w = 45, h = 19, spp = 21;
    for (bool det : {false, true}) {
        CAPTURE(det);
        std::vector<float> beauty[2], half[2], spp_image[2];
        int k = 0;
        for (uint32_t threads : {1u, 4u}) {
            SequenceSource src(w, h, SequenceSource::Kind::Noise);
            sampling::Film film(w, h);
            AdaptiveScheduler sched(src, film, uniform(threads, spp, det));
            CHECK(sched.thread_count() == threads);
            AdaptiveStats st = sched.render();
            CHECK(st.samples == uint64_t(w) * h * spp);
            beauty[k] = film.beauty_rgb();
            half[k] = film.half_rgb();
            spp_image[k] = film.spp();
            ++k;
        }
        REQUIRE(beauty[0].size() == beauty[1].size());
        REQUIRE(half[0].size() == half[1].size());
        CHECK(std::memcmp(beauty[0].data(), beauty[1].data(), beauty[0].size() * sizeof(float)) ==
              0);
        CHECK(std::memcmp(half[0].data(), half[1].data(), half[0].size() * sizeof(float)) == 0);
        CHECK(spp_image[0] == spp_image[1]);
    }
}

TEST_CASE("uniform: the mean converges to the analytic pixel integral") {
    const uint32_t w = 20, h = 12, spp = 256;
    SequenceSource src(w, h, SequenceSource::Kind::Gradient);
    sampling::Film film(w, h);
    AdaptiveScheduler(src, film, uniform(0, spp)).render();
    double worst_r = 0, worst_g = 0, worst_b = 0;
    for (uint32_t y = 0; y < h; ++y) {
        for (uint32_t x = 0; x < w; ++x) {
            Rgb m = film.mean(x, y);
            worst_r = std::max(worst_r, std::abs(m.r - (x + 0.5) / w));
            worst_g = std::max(worst_g, std::abs(m.g - (y + 0.5) / h));
            worst_b = std::max(worst_b, std::abs(m.b - 0.25));
        }
    }
    // 256 points of a (0,8,2)-net: each 1D projection is stratified in 256 intervals, so a
    // linear function errs by at most 1/(2 * 256) of its range over the pixel.
    CHECK(worst_r < 1.0 / (2 * 256) / w + 1e-6);
    CHECK(worst_g < 1.0 / (2 * 256) / h + 1e-6);
    // fx * fy over a 16x16 grid of strata: error well below 1%.
    CHECK(worst_b < 0.01);

    SequenceSource edge(8, 8, SequenceSource::Kind::Edge);
    sampling::Film edge_film(8, 8);
    AdaptiveScheduler(edge, edge_film, uniform(2, spp)).render();
    for (uint32_t y = 0; y < 8; ++y) {
        for (uint32_t x = 0; x < 8; ++x) {
            double coverage = x > y ? 1.0 : (x == y ? 0.5 : 0.0);
            CAPTURE(x);
            CAPTURE(y);
            CHECK(std::abs(edge_film.mean(x, y).r - coverage) < 0.03);
        }
    }
}

TEST_CASE("uniform: NaN samples are dropped and counted") {
    const uint32_t w = 9, h = 9, spp = 16;
    SequenceSource src(w, h, SequenceSource::Kind::Gradient);
    src.nan_odd_ = true;
    sampling::Film film(w, h);
    AdaptiveStats st = AdaptiveScheduler(src, film, uniform(2, spp)).render();
    CHECK(st.nan_samples == spp / 2);
    CHECK(film.nan_count() == spp / 2);
    CHECK(film.sample_count(3, 4) == spp);  // dropped samples still count as taken
    sampling::PixelStats ps = film.pixel_stats(3, 4);
    CHECK(ps.accepted == spp / 2);
    CHECK(ps.half_accepted == 0);  // every odd index was the NaN
    CHECK(std::isfinite(film.mean(3, 4).g));
    CHECK(film.mean(3, 4).r == test::Approx((3 + 0.5) / w).epsilon(0.02));
    CHECK(film.pixel_stats(4, 4).accepted == spp);
}

TEST_CASE("a film of another size than the source is refused") {
    SequenceSource src(16, 16, SequenceSource::Kind::Gradient);
    sampling::Film wrong(8, 16);
    CHECK_THROWS_AS(AdaptiveScheduler(src, wrong, uniform(1, 4)), std::invalid_argument);
}

TEST_CASE("camera samples and the integrator's sampler") {
    CameraSample cs = camera_sample(5, 10, 20, 7);
    sampling::SobolSampler s(5);
    s.start_pixel_sample(10, 20, 7);
    Vec2f u = s.get_pixel_2d();
    CHECK(cs.px == 10);
    CHECK(cs.py == 20);
    CHECK(cs.fx == u.x);
    CHECK(cs.fy == u.y);
    CHECK(cs.index == 7);
    CHECK(cs.fx >= 0.f);
    CHECK(cs.fx < 1.f);
    CHECK(cs.fy >= 0.f);
    CHECK(cs.fy < 1.f);
    sampling::SobolSampler t = sampler_for(5, cs);
    CHECK(t.dimension() == sampling::kFirstFreeDimension);
    CHECK(t.seed() == 5);
    CHECK(t.sample_index() == 7);
    CHECK(t.get_1d() == s.get_1d());
    CHECK(t.get_2d().x == s.get_2d().x);
    // Pure: the same arguments give the same sample; another index or seed another offset.
    CameraSample again = camera_sample(5, 10, 20, 7);
    CHECK(again.fx == cs.fx);
    CHECK(again.fy == cs.fy);
    CameraSample other = camera_sample(5, 10, 20, 8);
    CHECK((other.fx != cs.fx || other.fy != cs.fy));
    CameraSample reseeded = camera_sample(6, 10, 20, 7);
    CHECK((reseeded.fx != cs.fx || reseeded.fy != cs.fy));
}

TEST_CASE("progress line formatting (scheduler/progress.h)") {
    CHECK(format_duration(75) == "1:15");
    CHECK(format_duration(3725) == "1:02:05");
    CHECK(format_duration(-1) == "--:--");
    ProgressState st;
    st.pass = 3;
    st.passes = 7;
    st.spp_done = 4;
    st.spp_total = 64;
    st.fraction = 0.25;
    st.elapsed_s = 10;
    st.rays_per_s = 12.34e6;
    CHECK(estimate_eta_s(st) == test::Approx(30.0));
    std::string line = format_progress_line(st, 8);
    CHECK(line == "[##......] pass 3/7  spp 4/64  12.3 Mrays/s  ETA 0:30");
    st.time_budget_s = 15;  // 5 s left caps the estimate
    CHECK(estimate_eta_s(st) == test::Approx(5.0));
    ProgressReporter quiet(ProgressReporter::Mode::Never);
    CHECK(!quiet.enabled());
    quiet.begin(2, 4, 100, 0);
    quiet.add_work(50, 10);
    CHECK(quiet.state().fraction == test::Approx(0.5));
}
