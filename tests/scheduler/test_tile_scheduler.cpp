// Tests of the tile scheduler on synthetic sample sources: coverage, determinism across thread
// counts, convergence to analytic pixel integrals, NaN handling, cancel/resume, budgets and the
// progress line.
#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

#include "scheduler/tile_scheduler.h"

using namespace tessera;
using namespace tessera::sched;

namespace {

constexpr uint32_t kSeed = 1234;

// Radiance = an analytic function of the film position (x, y) = (px + fx, py + fy), plus
// bookkeeping of which (pixel, index) pairs were evaluated.
class SyntheticSource final : public SampleSource {
  public:
    enum class Kind {
        Gradient,  // R = x / W, G = y / H, B = fx * fy: pixel integrals (px+.5)/W, (py+.5)/H, 1/4
        Edge,      // R = 1 where y < x (film space): coverage of the diagonal half-plane
        Noise,     // R,G,B from the integrator's own sequence dimensions (determinism test)
    };

    SyntheticSource(uint32_t w, uint32_t h, Kind kind) : w_(w), h_(h), kind_(kind) {
        seen_ = std::make_unique<std::atomic<uint64_t>[]>(size_t(w) * h);
        for (size_t i = 0; i < size_t(w) * h; ++i) seen_[i] = 0;
    }
    uint32_t width() const override { return w_; }
    uint32_t height() const override { return h_; }
    std::string describe() const override { return "SyntheticSource"; }

    Sample evaluate(const CameraSample &cs) const override {
        if (cs.index < 64) seen_[size_t(cs.py) * w_ + cs.px].fetch_or(uint64_t(1) << cs.index);
        uint64_t n = evaluations_.fetch_add(1) + 1;
        if (cancel_after_ && n >= cancel_after_) cancel_flag_->store(true);
        Sample s;
        s.rays = 3;
        s.depth = 1.f;
        float x = float(cs.px) + cs.fx, y = float(cs.py) + cs.fy;
        switch (kind_) {
        case Kind::Gradient:
            s.radiance = Rgb(x / float(w_), y / float(h_), cs.fx * cs.fy);
            break;
        case Kind::Edge:
            s.radiance = Rgb(y < x ? 1.f : 0.f);
            break;
        case Kind::Noise: {
            sampling::SobolSampler sampler = TileScheduler::sampler_for(kSeed, cs);
            float a = sampler.get_1d();
            Vec2f b = sampler.get_2d();
            s.radiance = Rgb(a * x, b.x + y, b.y * cs.fx);
            break;
        }
        }
        if (nan_pixel_ && cs.px == 3 && cs.py == 4 && (cs.index & 1u))
            s.radiance.g = std::nanf("");
        // The offset must be the sequence's reserved pixel dimensions of (seed, pixel, index).
        if (check_offsets_) {
            sampling::SobolSampler ref(kSeed);
            ref.start_pixel_sample(cs.px, cs.py, cs.index);
            Vec2f u = ref.get_pixel_2d();
            if (u.x != cs.fx || u.y != cs.fy) offset_mismatch_.fetch_add(1);
        }
        return s;
    }

    uint64_t seen_mask(uint32_t px, uint32_t py) const { return seen_[size_t(py) * w_ + px]; }
    uint64_t evaluations() const { return evaluations_; }

    bool nan_pixel_ = false;
    bool check_offsets_ = false;
    uint64_t cancel_after_ = 0;
    std::atomic<bool> *cancel_flag_ = nullptr;
    mutable std::atomic<uint64_t> offset_mismatch_{0};

  private:
    uint32_t w_, h_;
    Kind kind_;
    std::unique_ptr<std::atomic<uint64_t>[]> seen_;
    mutable std::atomic<uint64_t> evaluations_{0};
};

SchedulerOptions options(uint32_t threads) {
    SchedulerOptions o;
    o.threads = threads;
    o.seed = kSeed;
    o.progress = ProgressReporter::Mode::Never;
    return o;
}

}  // namespace

TEST_CASE("pass targets double and end exactly at spp") {
    CHECK(TileScheduler::pass_targets(0).empty());
    CHECK(TileScheduler::pass_targets(1) == std::vector<uint32_t>{1});
    CHECK(TileScheduler::pass_targets(10) == std::vector<uint32_t>{1, 2, 4, 8, 10});
    CHECK(TileScheduler::pass_targets(16) == std::vector<uint32_t>{1, 2, 4, 8, 16});
    CHECK(TileScheduler::pass_targets(300, 64) ==
          std::vector<uint32_t>{1, 2, 4, 8, 16, 32, 64, 128, 192, 256, 300});
}

TEST_CASE("every pixel gets exactly spp samples, indices 0..spp-1 once each") {
    const uint32_t w = 37, h = 29, spp = 13;
    SyntheticSource src(w, h, SyntheticSource::Kind::Gradient);
    src.check_offsets_ = true;
    sampling::Film film(w, h);
    TileScheduler sched(src, film, options(4));
    RenderStats st = sched.render({spp, 0});
    CHECK(st.samples == uint64_t(w) * h * spp);
    CHECK(src.evaluations() == uint64_t(w) * h * spp);
    CHECK(st.rays == 3 * st.samples);
    CHECK(st.passes == 5);
    CHECK(!st.cancelled);
    CHECK(!st.out_of_time);
    CHECK(src.offset_mismatch_ == 0);
    bool exact = true;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x)
            exact = exact && film.sample_count(x, y) == spp &&
                    src.seen_mask(x, y) == (uint64_t(1) << spp) - 1;
    CHECK(exact);
    for (float v : film.spp()) CHECK(v == float(spp));
}

TEST_CASE("one thread visits the tiles in Morton order") {
    // Records the pixel of every first sample; with one thread that is the tile order.
    class Recorder final : public SampleSource {
      public:
        uint32_t width() const override { return 27; }
        uint32_t height() const override { return 19; }
        std::string describe() const override { return "Recorder"; }
        Sample evaluate(const CameraSample &cs) const override {
            if (cs.index == 0) order.emplace_back(cs.px, cs.py);
            return Sample{};
        }
        mutable std::vector<std::pair<uint32_t, uint32_t>> order;
    } rec;
    sampling::Film film(27, 19);
    TileScheduler sched(rec, film, options(1));
    sched.render({1, 0});
    std::vector<std::pair<uint32_t, uint32_t>> expected;
    for (const Tile &t : make_morton_tiles(27, 19))
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x) expected.emplace_back(x, y);
    CHECK(rec.order == expected);
}

TEST_CASE("1 thread and 4 threads give bit-identical films") {
    const uint32_t w = 45, h = 19, spp = 21;
    std::vector<float> beauty[2], half[2];
    int k = 0;
    for (uint32_t threads : {1u, 4u}) {
        SyntheticSource src(w, h, SyntheticSource::Kind::Noise);
        sampling::Film film(w, h);
        TileScheduler sched(src, film, options(threads));
        CHECK(sched.thread_count() == threads);
        sched.render({spp, 0});
        beauty[k] = film.beauty_rgb();
        half[k] = film.half_rgb();
        ++k;
    }
    REQUIRE(beauty[0].size() == beauty[1].size());
    CHECK(std::memcmp(beauty[0].data(), beauty[1].data(), beauty[0].size() * sizeof(float)) == 0);
    CHECK(std::memcmp(half[0].data(), half[1].data(), half[0].size() * sizeof(float)) == 0);
}

TEST_CASE("the mean converges to the analytic pixel integral") {
    const uint32_t w = 20, h = 12, spp = 256;
    SyntheticSource src(w, h, SyntheticSource::Kind::Gradient);
    sampling::Film film(w, h);
    TileScheduler(src, film, options(0)).render({spp, 0});
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

    SyntheticSource edge(8, 8, SyntheticSource::Kind::Edge);
    sampling::Film edge_film(8, 8);
    TileScheduler(edge, edge_film, options(2)).render({spp, 0});
    for (uint32_t y = 0; y < 8; ++y) {
        for (uint32_t x = 0; x < 8; ++x) {
            double coverage = x > y ? 1.0 : (x == y ? 0.5 : 0.0);
            CHECK(std::abs(edge_film.mean(x, y).r - coverage) < 0.03);
        }
    }
}

TEST_CASE("NaN samples are dropped and counted") {
    const uint32_t w = 9, h = 9, spp = 16;
    SyntheticSource src(w, h, SyntheticSource::Kind::Gradient);
    src.nan_pixel_ = true;
    sampling::Film film(w, h);
    RenderStats st = TileScheduler(src, film, options(2)).render({spp, 0});
    CHECK(st.nan_samples == spp / 2);
    CHECK(film.nan_count() == spp / 2);
    CHECK(film.sample_count(3, 4) == spp);
    sampling::PixelStats ps = film.pixel_stats(3, 4);
    CHECK(ps.accepted == spp / 2);
    CHECK(ps.half_accepted == 0);
    CHECK(std::isfinite(film.mean(3, 4).g));
    CHECK(film.mean(3, 4).r == doctest::Approx((3 + 0.5) / w).epsilon(0.02));
}

TEST_CASE("cancel stops between tiles; resuming equals a straight render") {
    const uint32_t w = 40, h = 24, spp = 8;
    std::atomic<bool> cancel{false};
    SyntheticSource src(w, h, SyntheticSource::Kind::Noise);
    src.cancel_after_ = 2000;  // in pass 3 (targets 1, 2, 4, 8; 960 pixels)
    src.cancel_flag_ = &cancel;
    sampling::Film film(w, h);
    TileScheduler sched(src, film, options(3));
    RenderStats st = sched.render({spp, 0}, &cancel);
    CHECK(st.cancelled);
    CHECK(st.samples < uint64_t(w) * h * spp);
    CHECK(st.samples >= 2000);
    CHECK(st.passes == 2);

    // Resume on the same film.
    cancel = false;
    src.cancel_after_ = 0;
    RenderStats rest = sched.render({spp, 0}, &cancel);
    CHECK(!rest.cancelled);
    CHECK(st.samples + rest.samples == uint64_t(w) * h * spp);

    SyntheticSource src2(w, h, SyntheticSource::Kind::Noise);
    sampling::Film straight(w, h);
    TileScheduler(src2, straight, options(1)).render({spp, 0});
    std::vector<float> a = film.beauty_rgb(), b = straight.beauty_rgb();
    CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
    std::vector<float> ha = film.half_rgb(), hb = straight.half_rgb();
    CHECK(std::memcmp(ha.data(), hb.data(), ha.size() * sizeof(float)) == 0);
}

TEST_CASE("a time budget stops the render") {
    SyntheticSource src(16, 16, SyntheticSource::Kind::Gradient);
    sampling::Film film(16, 16);
    RenderStats st = TileScheduler(src, film, options(2)).render({0, 0.05});
    CHECK(st.out_of_time);
    CHECK(st.samples > 0);
    CHECK(st.wall_s >= 0.05);
    CHECK(st.wall_s < 1.0);
    CHECK_THROWS(TileScheduler(src, film, options(1)).render({0, 0}));
    sampling::Film wrong(8, 16);
    CHECK_THROWS(TileScheduler(src, wrong, options(1)));
}

TEST_CASE("camera samples and the integrator's sampler") {
    CameraSample cs = TileScheduler::camera_sample(5, 10, 20, 7);
    sampling::SobolSampler s(5);
    s.start_pixel_sample(10, 20, 7);
    Vec2f u = s.get_pixel_2d();
    CHECK(cs.fx == u.x);
    CHECK(cs.fy == u.y);
    CHECK(cs.index == 7);
    sampling::SobolSampler t = TileScheduler::sampler_for(5, cs);
    CHECK(t.dimension() == sampling::kFirstFreeDimension);
    CHECK(t.get_1d() == s.get_1d());
}

TEST_CASE("progress line formatting") {
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
    CHECK(estimate_eta_s(st) == doctest::Approx(30.0));
    std::string line = format_progress_line(st, 8);
    CHECK(line == "[##......] pass 3/7  spp 4/64  12.3 Mrays/s  ETA 0:30");
    st.time_budget_s = 15;  // 5 s left caps the estimate
    CHECK(estimate_eta_s(st) == doctest::Approx(5.0));
    ProgressReporter quiet(ProgressReporter::Mode::Never);
    CHECK(!quiet.enabled());
    quiet.begin(2, 4, 100, 0);
    quiet.add_work(50, 10);
    CHECK(quiet.state().fraction == doctest::Approx(0.5));
}
