// The frame scheduler, the plugin registry and parameter parsing, and the `fixed` plugin.
#include <doctest/doctest.h>

#include <atomic>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <tuple>
#include <utility>

#include "approx.h"
#include "sampling/pixel_sampler.h"
#include "scheduler/frame_scheduler.h"
#include "plugin_test_util.h"
#include "synthetic_attribute_source.h"

using namespace tessera;
using namespace tessera::sampling;

namespace {

/// A plugin that records every (stage, tile) call and checks the barrier: no tile of stage s+1
/// runs before all tiles of stage s and end_stage(s).
class RecordingSampler final : public PixelSampler {
  public:
    void begin_frame(const SampleSource &src) override {
        w = src.width();
        h = src.height();
        calls.clear();
        for (int s = 0; s < 3; ++s) calls.emplace_back(size_t(w) * h);
        for (auto &v : calls)
            for (auto &c : v) c.store(0);
        stage_done = -1;
    }
    int stage_count() const override { return 3; }
    void run_tile(int stage, const PixelRect &t, const SampleSource &) override {
        if (stage_done.load() != stage - 1) barrier_violated = true;
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x) calls[size_t(stage)][size_t(y) * w + x]++;
        std::lock_guard<std::mutex> lock(m);
        tiles.insert({stage, t.x0, t.y0});
        ++tile_calls;
        const std::thread::id me = std::this_thread::get_id();
        if (auto it = expected.find(me); it != expected.end()) {
            if (it->second != std::tuple<int, uint32_t, uint32_t>{stage, t.x0, t.y0})
                wrong_prefetch = true;
            expected.erase(it);
        }
        if (auto it = announced.find(me); it != announced.end()) {
            expected[me] = it->second;
            announced.erase(it);
        }
    }
    /// The hint names the tile this thread runs after the one it is about to run (checked in
    /// run_tile).
    void prefetch_tile(int stage, const PixelRect &t) const override {
        std::lock_guard<std::mutex> lock(m);
        announced[std::this_thread::get_id()] = {stage, t.x0, t.y0};
        ++prefetch_calls;
    }
    void end_stage(int stage, const SampleSource &) override { stage_done = stage; }
    void end_frame(FrameResult &r) override { r.reset(w, h); }

    uint32_t w = 0, h = 0;
    std::vector<std::vector<std::atomic<int>>> calls;
    std::atomic<int> stage_done{-1};
    std::atomic<bool> barrier_violated{false};
    mutable std::mutex m;
    std::set<std::tuple<int, uint32_t, uint32_t>> tiles;
    int tile_calls = 0;
    // Per thread: the tile its last prefetch_tile named, and the tile it must run next.
    mutable std::map<std::thread::id, std::tuple<int, uint32_t, uint32_t>> announced, expected;
    mutable int prefetch_calls = 0;
    bool wrong_prefetch = false;
};

}  // namespace

TEST_CASE("frame scheduler: every pixel once per stage, stages separated by barriers") {
    // The larger images make the scheduler hand out runs of 2 to 8 tiles per claim.
    for (uint32_t threads : {1u, 3u, 8u}) {
        for (auto wh : {std::pair{1u, 1u}, {7u, 9u}, {8u, 8u}, {37u, 21u}, {300u, 200u},
                        {1001u, 603u}}) {
            const uint32_t w = wh.first, h = wh.second;  // CAPTURE needs plain variables
            test::SyntheticAttributeSource src(w, h);
            RecordingSampler rec;
            sched::FrameScheduler fs(sched::FrameOptions{threads});
            FrameResult r;
            fs.render(rec, src, r);
            CAPTURE(threads);
            CAPTURE(w);
            CAPTURE(h);
            CHECK_FALSE(rec.barrier_violated.load());
            uint32_t tiles = ((w + 7) / 8) * ((h + 7) / 8);
            CHECK(rec.tile_calls == int(3 * tiles));
            CHECK(rec.tiles.size() == size_t(3 * tiles));
            bool once = true;
            for (auto &v : rec.calls)
                for (auto &c : v) once = once && c.load() == 1;
            CHECK(once);
            // Every tile but each thread's first of a stage was announced by prefetch_tile on
            // the thread that then ran it next.
            CHECK_FALSE(rec.wrong_prefetch);
            CHECK(rec.prefetch_calls >= int(3 * (tiles - std::min(tiles, threads))));
            CHECK(rec.prefetch_calls <= rec.tile_calls);
            CHECK(r.width == w);
            CHECK(r.height == h);
        }
    }
}

namespace {

/// Stage 0 by tiles, stage 1 as `jobs` jobs that are not tiles, stage 2 as none.
class JobsSampler final : public PixelSampler {
  public:
    explicit JobsSampler(uint32_t jobs) : jobs_(jobs), seen(jobs) {}
    void begin_frame(const SampleSource &) override {}
    int stage_count() const override { return 3; }
    uint32_t stage_jobs(int stage) const override {
        return stage == 0 ? kTileJobs : stage == 1 ? jobs_ : 0;
    }
    void run_tile(int stage, const PixelRect &t, const SampleSource &) override {
        if (stage_done.load() != stage - 1) barrier_violated = true;
        if (stage == 0) {
            ++tiles;
        } else if (stage == 1 && t.count == jobs_ && t.index < jobs_ && t.x1 == t.x0 &&
                   t.y1 == t.y0) {
            seen[t.index]++;
        } else {
            bad_call = true;
        }
    }
    void end_stage(int stage, const SampleSource &) override {
        stage_done = stage;
        ++ends;
    }
    void end_frame(FrameResult &r) override { r.reset(1, 1); }

    uint32_t jobs_;
    std::vector<std::atomic<int>> seen;
    std::atomic<int> tiles{0}, ends{0}, stage_done{-1};
    std::atomic<bool> bad_call{false}, barrier_violated{false};
};

}  // namespace

TEST_CASE("frame scheduler: a stage of jobs that are not tiles, and a stage of none") {
    for (uint32_t threads : {1u, 3u})
        for (uint32_t jobs : {1u, 5u, 1000u}) {
            CAPTURE(threads);
            CAPTURE(jobs);
            test::SyntheticAttributeSource src(37, 21);  // 5 x 3 tiles
            JobsSampler s(jobs);
            sched::FrameScheduler fs(sched::FrameOptions{threads});
            FrameResult r;
            fs.render(s, src, r);
            CHECK(s.tiles.load() == 15);
            bool once = true;
            for (auto &c : s.seen) once = once && c.load() == 1;
            CHECK(once);
            CHECK_FALSE(s.bad_call.load());  // stage 2 (no jobs) never runs, others well formed
            CHECK_FALSE(s.barrier_violated.load());
            CHECK(s.ends.load() == 3);
        }
}

TEST_CASE("plugin registry: names, kinds, parameter parsing and errors") {
    CHECK(find_plugin("uniform")->kind == PluginKind::Progressive);
    CHECK(find_plugin("adaptive")->kind == PluginKind::Progressive);
    CHECK(find_plugin("fixed")->kind == PluginKind::Frame);
    CHECK(find_plugin("nope") == nullptr);

    PluginSpec s = parse_plugin_spec("fixed:spp=9");
    CHECK(s.info->name == "fixed");
    CHECK(s.params.get_int("spp") == 9);
    CHECK(s.params.is_set("spp"));
    CHECK_FALSE(s.params.is_set("seed"));
    CHECK(s.describe() == "fixed:spp=9,seed=0,jitter=1");

    PluginSpec a = parse_plugin_spec("adaptive:min_spp=8,error=0.002");  // '_' == '-'
    CHECK(a.params.get("min-spp") == 8);
    CHECK(a.params.get("error") == test::Approx(0.002));
    CHECK(a.params.get("split-factor") == 256);  // default filled in

    auto msg = [](const char *text) { return test::spec_error(text); };
    CHECK(msg("bogus").find("unknown sampler \"bogus\"") != std::string::npos);
    CHECK(msg("fixed:tau=1").find("sampler fixed: unknown key \"tau\"") != std::string::npos);
    CHECK(msg("fixed:spp=0").find("outside [1, 256]") != std::string::npos);
    CHECK(msg("fixed:spp=2.5").find("whole number") != std::string::npos);
    CHECK(msg("fixed:spp=abc").find("not a number") != std::string::npos);
    CHECK(msg("fixed:spp").find("expected key=value") != std::string::npos);
    CHECK(msg("fixed:spp=4,spp=9").find("given twice") != std::string::npos);

    std::string list = format_plugin_list();
    for (const PluginInfo &p : plugin_registry()) {
        CHECK(list.find(p.name) != std::string::npos);
        for (const PluginParamSpec &k : p.params) CHECK(list.find(k.key + "=") != std::string::npos);
    }
}

TEST_CASE("fixed: K samples per pixel, jittered grid for square K, colour = sample mean") {
    test::SyntheticAttributeSource src(24, 16);
    test::AttrShape disc;
    disc.kind = test::AttrShape::Kind::Disc;
    disc.cx = 11.3f;
    disc.cy = 7.6f;
    disc.r = 5.2f;
    disc.color = Rgb(0.9f, 0.8f, 0.1f);
    src.shapes.push_back(disc);

    for (int spp : {1, 4, 9, 16, 6}) {
        CAPTURE(spp);
        auto plugin = find_plugin("fixed")->make(parse_plugin_spec("fixed:spp=" + std::to_string(spp)).params);
        src.reset_counts();
        FrameResult r;
        sched::FrameScheduler(sched::FrameOptions{3}).render(*plugin, src, r);
        CHECK(r.samples == uint64_t(spp) * 24 * 16);
        CHECK(src.total_count() == r.samples);
        bool counts_ok = true;
        for (uint32_t y = 0; y < 16; ++y)
            for (uint32_t x = 0; x < 24; ++x) counts_ok = counts_ok && src.count(x, y) == uint32_t(spp);
        CHECK(counts_ok);
        CHECK(r.rays_total == uint64_t(spp) * 24 * 16 * 2);
        // Away from the disc's edge every sample has the same colour up to the linear shading.
        Rgb bg = r.color[0];
        Rgb gt = src.ground_truth(0, 0);
        CHECK(bg.r == test::Approx(gt.r).epsilon(1e-4));
        // Error against the exact pixel mean shrinks with K (stratification).
        double err = 0;
        for (uint32_t y = 0; y < 16; ++y)
            for (uint32_t x = 0; x < 24; ++x) {
                Rgb d = r.color[y * 24 + x] - src.ground_truth(x, y);
                err += double(d.r) * d.r + double(d.g) * d.g + double(d.b) * d.b;
            }
        err /= 24 * 16;
        if (spp == 16) CHECK(err < 2e-4);
        if (spp == 1) CHECK(err > 1e-3);
    }
}

TEST_CASE("fixed: square K puts one sample in each cell of the N x N grid") {
    // A source that records the film offsets of pixel (0, 0).
    struct OffsetSource final : public SampleSource {
        uint32_t width() const override { return 2; }
        uint32_t height() const override { return 2; }
        std::string describe() const override { return "offsets"; }
        Sample evaluate(const CameraSample &cs) const override {
            if (cs.px == 0 && cs.py == 0) {
                std::lock_guard<std::mutex> l(m);
                cells.insert(int(cs.fx * 3) + 3 * int(cs.fy * 3));
                CHECK(cs.fx >= 0.f);
                CHECK(cs.fx < 1.f);
            }
            return Sample{};
        }
        mutable std::mutex m;
        mutable std::set<int> cells;
    } src;
    auto plugin = find_plugin("fixed")->make(parse_plugin_spec("fixed:spp=9").params);
    FrameResult r;
    sched::FrameScheduler(sched::FrameOptions{1}).render(*plugin, src, r);
    CHECK(src.cells.size() == 9);
}

TEST_CASE("fixed: jitter=0 samples the cell centres exactly") {
    // Every offset seen, per pixel; spp=1 must be the pixel centre, spp=4 the quarter centres.
    struct CentreSource final : public SampleSource {
        uint32_t width() const override { return 3; }
        uint32_t height() const override { return 2; }
        std::string describe() const override { return "centres"; }
        Sample evaluate(const CameraSample &cs) const override {
            std::lock_guard<std::mutex> l(m);
            offsets.insert({cs.fx, cs.fy});
            return Sample{};
        }
        mutable std::mutex m;
        mutable std::set<std::pair<float, float>> offsets;
    };
    // (No structured bindings: clang 14 cannot capture them in CAPTURE's lambda.)
    using Case = std::pair<const char *, std::set<std::pair<float, float>>>;
    for (const Case &c :
         {Case{"fixed:spp=1,jitter=0", {{0.5f, 0.5f}}},
          Case{"fixed:spp=4,jitter=0",
               {{0.25f, 0.25f}, {0.75f, 0.25f}, {0.25f, 0.75f}, {0.75f, 0.75f}}}}) {
        const std::string spec = c.first;
        const std::set<std::pair<float, float>> &expected = c.second;
        CAPTURE(spec);
        CentreSource src;
        auto plugin = find_plugin("fixed")->make(parse_plugin_spec(spec).params);
        FrameResult r;
        sched::FrameScheduler(sched::FrameOptions{2}).render(*plugin, src, r);
        CHECK(src.offsets == expected);
    }
    // The default jitters: the offsets of spp=1 are not all the centre.
    CentreSource src;
    auto plugin = find_plugin("fixed")->make(parse_plugin_spec("fixed:spp=1").params);
    FrameResult r;
    sched::FrameScheduler(sched::FrameOptions{2}).render(*plugin, src, r);
    CHECK(src.offsets.size() > 1);
}

TEST_CASE("fixed: frames are identical for 1 and 3 threads") {
    test::SyntheticAttributeSource src(40, 24);
    test::AttrShape edge;
    edge.kind = test::AttrShape::Kind::HalfPlane;
    edge.nx = 0.8f;
    edge.ny = 0.6f;
    edge.d = 20;
    edge.color = Rgb(1, 1, 1);
    src.shapes.push_back(edge);
    auto p1 = find_plugin("fixed")->make(parse_plugin_spec("fixed:spp=5").params);
    auto p3 = find_plugin("fixed")->make(parse_plugin_spec("fixed:spp=5").params);
    FrameResult a, b;
    sched::FrameScheduler(sched::FrameOptions{1}).render(*p1, src, a);
    sched::FrameScheduler(sched::FrameOptions{3}).render(*p3, src, b);
    bool same = true;
    for (size_t i = 0; i < a.color.size(); ++i)
        same = same && a.color[i].r == b.color[i].r && a.color[i].g == b.color[i].g &&
               a.color[i].b == b.color[i].b && a.rays[i] == b.rays[i];
    CHECK(same);
}
