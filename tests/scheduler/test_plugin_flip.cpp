// Tests of the `fliptri` and `flipquad` plugins (sampling/plugins/flip.cpp, Shevtsov et al.):
// pattern positions and sharing (every shared lattice point traced once, mirrored per pixel,
// 1.25 and 2 samples per pixel plus the border), packets of at most 8, no extra samples on a flat
// image, a vertical edge activating exactly the pixels whose pattern straddles it, equal
// weights over pattern + RGSS samples, quality near edges against one sample per pixel, the
// previous frame's threshold, texture averaging, NaN handling, parameters, and 1 vs 3 threads.
#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "approx.h"
#include "sampling/pixel_sampler.h"
#include "scheduler/frame_scheduler.h"
#include "plugin_test_util.h"
#include "synthetic_attribute_source.h"

using namespace tessera;
using sampling::FrameResult;
using sampling::PixelSampler;
using tessera::test::AttrShape;
using tessera::test::SyntheticAttributeSource;

namespace {

constexpr float kBelowOne = 0x1.fffffep-1f;

/// A source whose colour is a function of the film position; records every camera sample and
/// the size of every batch.
class FunctionSource final : public SampleSource {
  public:
    FunctionSource(uint32_t w, uint32_t h, std::function<Rgb(float, float)> f)
        : w_(w), h_(h), f_(std::move(f)) {}
    uint32_t width() const override { return w_; }
    uint32_t height() const override { return h_; }
    std::string describe() const override { return "function source"; }
    Sample evaluate(const CameraSample &cs) const override {
        {
            std::lock_guard<std::mutex> lock(mu_);
            log_.push_back(cs);
        }
        Sample s;
        s.radiance = f_(float(cs.px) + cs.fx, float(cs.py) + cs.fy);
        s.rays = 1;
        return s;
    }
    void evaluate_batch(std::span<const CameraSample> cs, std::span<Sample> out) const override {
        {
            std::lock_guard<std::mutex> lock(mu_);
            batches_.push_back(cs.size());
        }
        for (size_t i = 0; i < cs.size(); ++i)
            out[i] = evaluate(cs[i]);
    }
    std::vector<CameraSample> log() const { return log_; }
    std::vector<size_t> batches() const { return batches_; }
    void clear() {
        log_.clear();
        batches_.clear();
    }

  private:
    uint32_t w_, h_;
    std::function<Rgb(float, float)> f_;
    mutable std::mutex mu_;
    mutable std::vector<CameraSample> log_;
    mutable std::vector<size_t> batches_;
};

std::unique_ptr<PixelSampler> make(const std::string &spec) {
    sampling::PluginSpec s = sampling::parse_plugin_spec(spec);
    REQUIRE(s.info != nullptr);
    REQUIRE(s.info->make);
    return s.info->make(s.params);
}

sched::FrameTiming render(PixelSampler &p, const SampleSource &src, FrameResult &r,
                          uint32_t threads = 2) {
    sched::FrameScheduler fs(sched::FrameOptions{threads});
    return fs.render(p, src, r);
}

const sampling::FrameLayer *layer(const FrameResult &r, const std::string &name) {
    for (const auto &l : r.diagnostics)
        if (l.name == name)
            return &l;
    return nullptr;
}

/// A film position in thirds of a pixel (every pattern point lies on that lattice).
using P3 = std::pair<int64_t, int64_t>;

int64_t to_thirds(uint32_t p, float f) {
    if (f == kBelowOne)
        return 3 * (int64_t(p) + 1);  // clamped right/bottom border point
    const float t = f * 3.f;
    const long r = std::lround(t);
    CHECK(std::fabs(t - float(r)) < 1e-5f);
    return 3 * int64_t(p) + r;
}

/// The pattern of pixel (x, y), written independently of the plugin: the base pattern of a
/// pixel with even x and y, in thirds, mirrored in x for odd x and in y for odd y.
std::vector<P3> expected_pattern(bool quad, uint32_t x, uint32_t y) {
    static const std::vector<P3> tri = {{0, 0}, {3, 1}, {2, 3}};         // corner, right, bottom
    static const std::vector<P3> qd = {{0, 2}, {1, 0}, {3, 1}, {2, 3}};  // left, top, right, bottom
    std::vector<P3> out;
    for (const P3 &b : quad ? qd : tri) {
        const int64_t lx = (x & 1) ? 3 - b.first : b.first;
        const int64_t ly = (y & 1) ? 3 - b.second : b.second;
        out.push_back({3 * int64_t(x) + lx, 3 * int64_t(y) + ly});
    }
    return out;
}

std::set<P3> expected_points(bool quad, uint32_t w, uint32_t h) {
    std::set<P3> s;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x)
            for (const P3 &p : expected_pattern(quad, x, y))
                s.insert(p);
    return s;
}

/// The RGSS extra positions of pixel (x, y) (n x n rotated grid, mirrored like the pattern).
std::vector<std::pair<float, float>> expected_extra(uint32_t n, uint32_t x, uint32_t y) {
    std::vector<std::pair<float, float>> out;
    const float inv = 1.f / float(n * n);
    for (uint32_t a = 0; a < n; ++a)
        for (uint32_t b = 0; b < n; ++b) {
            float fx = (float(a * n + b) + 0.5f) * inv;
            float fy = (float(b * n + (n - 1 - a)) + 0.5f) * inv;
            if (x & 1)
                fx = 1.f - fx;
            if (y & 1)
                fy = 1.f - fy;
            out.push_back({fx, fy});
        }
    return out;
}

uint64_t tri_count(uint64_t w, uint64_t h) {
    // Vertical edge sites on odd lines, horizontal ones on odd rows, corners on even points.
    return (w + 1) / 2 * h + w * ((h + 1) / 2) + (w / 2 + 1) * (h / 2 + 1);
}
uint64_t quad_count(uint64_t w, uint64_t h) {
    return 2 * w * h + w + h;
}

void check_identical(const FrameResult &a, const FrameResult &b) { test::check_same_frame(a, b); }

/// A scene with every kind of feature: linear shading, a disc, a slanted half-plane, a thin
/// line, a checker-textured disc, a shadow and a reflecting shape.
SyntheticAttributeSource busy_scene(uint32_t w, uint32_t h) {
    SyntheticAttributeSource src(w, h);
    src.shapes[0].color_dx = Rgb(0.004f, 0.002f, 0.f);
    src.shapes[0].color_dy = Rgb(0.f, 0.003f, 0.005f);
    AttrShape disc;
    disc.kind = AttrShape::Kind::Disc;
    disc.cx = 14.3f;
    disc.cy = 12.6f;
    disc.r = 8.7f;
    disc.color = Rgb(0.9f, 0.2f, 0.1f);
    src.shapes.push_back(disc);
    AttrShape half;
    half.kind = AttrShape::Kind::HalfPlane;
    half.nx = 0.8f;
    half.ny = 0.6f;
    half.d = 12.f;
    half.color = Rgb(0.1f, 0.8f, 0.3f);
    src.shapes.push_back(half);
    AttrShape line;
    line.kind = AttrShape::Kind::Line;
    line.nx = 0.28f;
    line.ny = -0.96f;
    line.d = -20.f;
    line.width = 0.4f;
    line.color = Rgb(1.f, 1.f, 1.f);
    src.shapes.push_back(line);
    AttrShape tex;
    tex.kind = AttrShape::Kind::Disc;
    tex.cx = 32.f;
    tex.cy = 26.f;
    tex.r = 7.f;
    tex.color = Rgb(0.8f, 0.8f, 0.6f);
    tex.texture_scale = 1.7f;
    tex.reflects = 1;
    tex.reflection = Rgb(0.05f, 0.05f, 0.1f);
    src.shapes.push_back(tex);
    src.shadows.push_back({30.f, 8.f, 5.f});
    return src;
}

}  // namespace

TEST_CASE("registry: both plugins, the paper's defaults, parameter checks") {
    for (const char *name : {"fliptri", "flipquad"}) {
        const sampling::PluginInfo *info = sampling::find_plugin(name);
        REQUIRE(info != nullptr);
        CHECK(info->kind == sampling::PluginKind::Frame);
        CHECK(bool(info->make));
        sampling::PluginSpec spec = sampling::parse_plugin_spec(name);
        CHECK(spec.params.get_int("extra") == (std::string(name) == "fliptri" ? 4 : 16));
        CHECK(spec.params.get("prev_threshold") == 0);
        CHECK(spec.params.get("threshold_scale") == 1);
        CHECK(spec.params.get("per_channel") == 0);
        CHECK(spec.params.get("texture_average") == 0);
        CHECK(spec.params.get("share_weights") == 0);  // the paper's equal weights
        CHECK_THROWS_AS(sampling::parse_plugin_spec(std::string(name) + ":share_weights=2"),
                        std::invalid_argument);
        // '-' and '_' are the same in keys.
        CHECK(sampling::parse_plugin_spec(std::string(name) + ":threshold-scale=2")
                  .params.get("threshold_scale") == 2);
        CHECK_THROWS_AS(sampling::parse_plugin_spec(std::string(name) + ":spp=4"),
                        std::invalid_argument);
        CHECK_THROWS_AS(sampling::parse_plugin_spec(std::string(name) + ":extra=65"),
                        std::invalid_argument);
        // extra must be a square (rotated n x n grid): checked by make, naming plugin and key.
        sampling::PluginSpec bad = sampling::parse_plugin_spec(std::string(name) + ":extra=5");
        try {
            (void)bad.info->make(bad.params);
            FAIL("extra=5 accepted");
        } catch (const std::invalid_argument &e) {
            const std::string msg = e.what();
            CHECK(msg.find(name) != std::string::npos);
            CHECK(msg.find("extra") != std::string::npos);
        }
        for (int ok : {0, 1, 9, 64})
            CHECK(make(std::string(name) + ":extra=" + std::to_string(ok)));
    }
}

TEST_CASE("pattern: positions, sharing (each lattice point traced once), mirroring, packets") {
    for (bool quad : {false, true}) {
        for (const std::pair<uint32_t, uint32_t> &size :
             {std::pair<uint32_t, uint32_t>{16, 16}, {13, 10}, {9, 11}, {1, 1}}) {
            const uint32_t w = size.first, h = size.second;
            CAPTURE(quad);
            CAPTURE(w);
            CAPTURE(h);
            FunctionSource src(w, h, [](float, float) { return Rgb(0.5f); });
            auto p = make(quad ? "flipquad" : "fliptri");
            FrameResult r;
            sched::FrameTiming t = render(*p, src, r);
            CHECK(t.stage_names.size() == 3);
            const std::vector<CameraSample> log = src.log();
            std::set<P3> traced;
            std::set<std::pair<P3, uint32_t>> owner_index;  // (pixel, index) unique
            for (const CameraSample &cs : log) {
                REQUIRE(cs.px < w);
                REQUIRE(cs.py < h);
                CHECK(cs.fx >= 0.f);
                CHECK(cs.fx < 1.f);
                CHECK(cs.fy >= 0.f);
                CHECK(cs.fy < 1.f);
                // Clamped border points only in the last column / row.
                if (cs.fx == kBelowOne)
                    CHECK(cs.px == w - 1);
                if (cs.fy == kBelowOne)
                    CHECK(cs.py == h - 1);
                CHECK(traced.insert({to_thirds(cs.px, cs.fx), to_thirds(cs.py, cs.fy)}).second);
                CHECK(owner_index.insert({{cs.px, cs.py}, cs.index}).second);
            }
            const std::set<P3> expected = expected_points(quad, w, h);
            CHECK(traced == expected);
            CHECK(log.size() == expected.size());
            CHECK(log.size() == (quad ? quad_count(w, h) : tri_count(w, h)));
            CHECK(r.samples == log.size());
            CHECK(r.rays_total == log.size());  // 1 ray per sample
            CHECK(r.active_fraction == 0.0);
            for (size_t b : src.batches())
                CHECK(b <= 8);
            // Rays per pixel: shared samples split over their users; the total is conserved.
            double rays = 0;
            for (float v : r.rays)
                rays += v;
            CHECK(rays == test::Approx(double(r.rays_total)).epsilon(1e-6));
            if (w == 16) {
                // Interior pixels: exactly the nominal 1.25 / 2 rays.
                CHECK(r.rays[5 * w + 6] == test::Approx(quad ? 2.0 : 1.25));
                CHECK(double(log.size()) ==
                      (quad ? 2.0 * w * h + w + h : 1.25 * w * h + w / 2 + h / 2 + 1));
                // Packets are full except at the end of a tile's streams.
                size_t full = 0;
                for (size_t b : src.batches())
                    full += b == 8 ? 1 : 0;
                CHECK(full * 8 >= log.size() * 3 / 4);
            }
        }
    }
    // Explicit mirroring within one 2x2 block (film coordinates in thirds).
    const std::vector<P3> q00 = expected_pattern(true, 0, 0), q10 = expected_pattern(true, 1, 0);
    // (0,0)'s right sample is the flipped pixel (1,0)'s mirrored "right" one, on its left edge.
    CHECK(q00[2] == q10[2]);
    CHECK(q10[2] == P3{3, 1});  // (1, 1/3)
    CHECK(q10[0] == P3{6, 2});  // the mirrored "left" sample on (1,0)'s right edge
    CHECK(q10[1] == P3{5, 0});  // top of the flipped pixel at x = 1 + 2/3
    const std::vector<P3> t00 = expected_pattern(false, 0, 0), t11 = expected_pattern(false, 1, 1);
    CHECK(t11[0] == P3{6, 6});  // FLIPTRI corners on even lattice points
    CHECK(t00[1] == P3{3, 1});
}

TEST_CASE("counts with the synthetic attribute source; a flat image gets no extra samples") {
    for (bool quad : {false, true}) {
        CAPTURE(quad);
        const uint32_t w = 40, h = 24;
        SyntheticAttributeSource src(w, h);  // flat background colour
        for (const char *opts : {"", ":threshold_scale=0", ":per_channel=1"}) {
            CAPTURE(opts);
            src.reset_counts();
            auto p = make(std::string(quad ? "flipquad" : "fliptri") + opts);
            FrameResult r;
            render(*p, src, r);
            const uint64_t n = quad ? quad_count(w, h) : tri_count(w, h);
            CHECK(src.total_count() == n);
            CHECK(r.samples == n);
            CHECK(r.rays_total == 2 * n);  // primary + shadow ray per sample
            CHECK(r.active_fraction == 0.0);
            CHECK(r.active_unit == "pixels");
            CHECK(r.shaded == 0);
            CHECK(r.nan_samples == 0);
            const sampling::FrameLayer *active = layer(r, "active");
            const sampling::FrameLayer *gradient = layer(r, "gradient");
            REQUIRE(active);
            REQUIRE(gradient);
            for (size_t i = 0; i < size_t(w) * h; ++i) {
                CHECK(active->data[i] == 0.f);
                CHECK(gradient->data[i] == 0.f);
                // Equal weights: a constant image resolves to the constant.
                CHECK(r.color[i].r == test::Approx(0.2f).epsilon(1e-6));
                CHECK(r.color[i].g == test::Approx(0.3f).epsilon(1e-6));
                CHECK(r.color[i].b == test::Approx(0.4f).epsilon(1e-6));
            }
        }
    }
}

TEST_CASE("a vertical edge activates exactly the pixels whose pattern straddles it") {
    const uint32_t w = 24, h = 18;
    for (bool quad : {false, true})
        for (float d : {10.5f, 11.f, 11.2f, 11.8f, 12.f, 12.5f}) {
            CAPTURE(quad);
            CAPTURE(d);
            SyntheticAttributeSource src(w, h);
            AttrShape half;
            half.kind = AttrShape::Kind::HalfPlane;
            half.nx = 1;
            half.ny = 0;
            half.d = d;  // x < d
            half.color = Rgb(0.9f, 0.8f, 0.7f);
            src.shapes.push_back(half);
            auto p = make(quad ? "flipquad" : "fliptri");
            FrameResult r;
            render(*p, src, r);
            const sampling::FrameLayer *active = layer(r, "active");
            const sampling::FrameLayer *gradient = layer(r, "gradient");
            REQUIRE(active);
            REQUIRE(gradient);
            uint32_t n_active = 0;
            for (uint32_t y = 0; y < h; ++y)
                for (uint32_t x = 0; x < w; ++x) {
                    bool in = false, out = false;
                    for (const P3 &q : expected_pattern(quad, x, y))
                        (float(q.first) / 3.f < d ? in : out) = true;
                    const bool straddles = in && out;
                    const size_t i = size_t(y) * w + x;
                    CHECK(active->data[i] == (straddles ? 1.f : 0.f));
                    CHECK((gradient->data[i] > 1.f) == straddles);
                    n_active += straddles ? 1 : 0;
                    // Rays per pixel: the pattern share plus 2 rays per extra sample.
                    const double base = (quad ? 2.0 : 1.25) * 2.0;
                    if (x > 0 && y > 0 && x + 1 < w && y + 1 < h)
                        CHECK(r.rays[i] ==
                              test::Approx(base + (straddles ? 2.0 * (quad ? 16 : 4) : 0)));
                }
            CHECK(n_active == h);  // one column
            const uint64_t pattern = quad ? quad_count(w, h) : tri_count(w, h);
            CHECK(src.total_count() == pattern + uint64_t(n_active) * (quad ? 16 : 4));
            CHECK(r.samples == src.total_count());
            CHECK(r.active_fraction == test::Approx(double(n_active) / (w * h)));
        }
}

TEST_CASE("weights: an active pixel is the equal-weight mean of its pattern and RGSS samples; "
          "share_weights=1 weighs pattern samples by their pixel share") {
    const uint32_t w = 20, h = 12;
    auto f = [](float x, float y) {
        const float base = 0.1f + 0.01f * x + 0.02f * y;
        return x < 9.4f ? Rgb(base) : Rgb(base + 0.6f, base + 0.3f, base);
    };
    for (int variant = 0; variant < 4; ++variant)
        for (uint32_t n : {1u, 2u, 3u}) {
            const bool share = variant >= 2, quad = variant % 2 == 1;
            CAPTURE(share);
            CAPTURE(quad);
            CAPTURE(n);
            FunctionSource src(w, h, f);
            auto p = make(std::string(quad ? "flipquad" : "fliptri") +
                          ":extra=" + std::to_string(n * n) + (share ? ",share_weights=1" : ""));
            FrameResult r;
            render(*p, src, r);
            const sampling::FrameLayer *active = layer(r, "active");
            REQUIRE(active);
            std::map<std::pair<uint32_t, uint32_t>, std::vector<std::pair<float, float>>> extra;
            for (const CameraSample &cs : src.log())
                if (cs.index >= 16)
                    extra[{cs.px, cs.py}].push_back({cs.fx, cs.fy});
            uint32_t checked = 0;
            for (uint32_t y = 0; y < h; ++y)
                for (uint32_t x = 0; x < w; ++x) {
                    const size_t i = size_t(y) * w + x;
                    const bool act = active->data[i] == 1.f;
                    CHECK(act == (x == 9));  // the column that holds the edge
                    // The extra samples are the mirrored rotated grid, N-rooks.
                    std::vector<std::pair<float, float>> want =
                        act ? expected_extra(n, x, y) : std::vector<std::pair<float, float>>{};
                    std::vector<std::pair<float, float>> got = extra[{x, y}];
                    std::sort(want.begin(), want.end());
                    std::sort(got.begin(), got.end());
                    CHECK(got == want);
                    if (act) {
                        std::set<long> xs, ys;
                        for (auto [fx, fy] : got) {
                            xs.insert(std::lround(fx * float(n * n) - 0.5f));
                            ys.insert(std::lround(fy * float(n * n) - 0.5f));
                        }
                        CHECK(xs.size() == n * n);
                        CHECK(ys.size() == n * n);
                    }
                    // Expected colour: the mean of every sample, equal weights; with share_weights
                    // in an active pixel, a pattern sample weighs 1 / (pixels that use it): it
                    // is shared across a pixel edge it lies on, unless that is the image border.
                    Rgb sum(0.f);
                    float count = 0;
                    for (const P3 &q : expected_pattern(quad, x, y)) {
                        // The point as the plugin hands it to the source (border clamped).
                        auto coord = [](int64_t t3, uint32_t size) {
                            if (t3 >= 3 * int64_t(size))
                                return float(size - 1) + kBelowOne;
                            const int64_t pix = t3 / 3, rem = t3 % 3;
                            return float(pix) + (rem == 0 ? 0.f : rem == 1 ? 1.f / 3.f : 2.f / 3.f);
                        };
                        auto users = [](int64_t t3, uint32_t size) {
                            return t3 % 3 == 0 && t3 > 0 && t3 < 3 * int64_t(size) ? 2.f : 1.f;
                        };
                        const float weight =
                            share && act ? 1.f / (users(q.first, w) * users(q.second, h)) : 1.f;
                        sum += f(coord(q.first, w), coord(q.second, h)) * weight;
                        count += weight;
                    }
                    for (auto [fx, fy] : want) {
                        sum += f(float(x) + fx, float(y) + fy);
                        count += 1.f;
                    }
                    const Rgb e = sum / count;
                    CHECK(r.color[i].r == test::Approx(e.r).epsilon(1e-5));
                    CHECK(r.color[i].g == test::Approx(e.g).epsilon(1e-5));
                    CHECK(r.color[i].b == test::Approx(e.b).epsilon(1e-5));
                    ++checked;
                }
            CHECK(checked == w * h);
        }
}

TEST_CASE("quality near edges: better than one sample per pixel against the ground truth") {
    const uint32_t w = 48, h = 40;
    SyntheticAttributeSource src = busy_scene(w, h);
    // Edge pixels: where the exact pixel mean differs from the pixel-centre colour.
    std::vector<Rgb> truth(size_t(w) * h), centre(size_t(w) * h);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            truth[size_t(y) * w + x] = src.ground_truth(x, y);
            centre[size_t(y) * w + x] =
                src.shade(src.attributes_at(float(x) + 0.5f, float(y) + 0.5f));
        }
    auto error = [&](const std::vector<Rgb> &img) {
        double e = 0;
        int n = 0;
        for (size_t i = 0; i < img.size(); ++i) {
            const Rgb d0 = truth[i] - centre[i];
            if (std::fabs(d0.r) + std::fabs(d0.g) + std::fabs(d0.b) < 1e-3f &&
                src.ground_truth(uint32_t(i % w), uint32_t(i / w), 4).r == truth[i].r)
                continue;  // smooth pixel
            const Rgb d = img[i] - truth[i];
            e += std::fabs(d.r) + std::fabs(d.g) + std::fabs(d.b);
            ++n;
        }
        return e / std::max(n, 1);
    };
    FrameResult one;
    auto fixed1 = make("fixed:spp=1");
    render(*fixed1, src, one);
    const double e_centre = error(centre), e_one = error(one.color);
    for (int spp : {4, 8, 16}) {
        FrameResult rf;
        auto fk = make("fixed:spp=" + std::to_string(spp));
        render(*fk, src, rf);
        MESSAGE("fixed:spp=" << spp << ": edge error " << error(rf.color));
    }
    for (std::string spec : {"fliptri", "flipquad"}) {
        CAPTURE(spec);
        FrameResult r;
        auto p = make(spec);
        render(*p, src, r);
        const double e = error(r.color);
        MESSAGE(spec << ": edge error " << e << " vs centre " << e_centre << ", fixed:spp=1 "
                     << e_one << ", rays/pixel " << double(r.samples) / (w * h) << ", active "
                     << r.active_fraction);
        CHECK(e < 0.6 * e_centre);
        CHECK(e < 0.6 * e_one);
        CHECK(r.active_fraction > 0.05);
        CHECK(r.active_fraction < 0.6);
    }
}

TEST_CASE("prev_threshold: the previous frame's average is the threshold, in two stages") {
    const uint32_t w = 32, h = 24;
    // Frame A: a high-contrast checker everywhere (a high average gradient).
    SyntheticAttributeSource a(w, h);
    a.shapes[0].color = Rgb(0.9f);
    a.shapes[0].texture_scale = 1.3f;
    // Frame B: one weak vertical edge on a flat background.
    SyntheticAttributeSource b(w, h);
    b.shapes[0].color = Rgb(0.5f);
    AttrShape half;
    half.kind = AttrShape::Kind::HalfPlane;
    half.d = 10.5f;
    half.color = Rgb(0.56f);
    b.shapes.push_back(half);
    for (const char *name : {"fliptri", "flipquad"}) {
        CAPTURE(name);
        auto ref = make(name);  // three-pass, this frame's threshold
        FrameResult rb;
        CHECK(render(*ref, b, rb).stage_names.size() == 3);
        const sampling::FrameLayer *rb_active = layer(rb, "active");
        REQUIRE(rb_active);
        CHECK(rb.active_fraction == test::Approx(1.0 / w));  // column 10

        auto p = make(std::string(name) + ":prev_threshold=1");
        FrameResult r1, r2, r3;
        sched::FrameTiming t1 = render(*p, a, r1);
        CHECK(t1.stage_names.size() == 3);  // no previous frame yet
        CHECK(r1.active_fraction > 0.05);
        sched::FrameTiming t2 = render(*p, b, r2);
        CHECK(t2.stage_names.size() == 2);
        CHECK(t2.stage_names[1] == "gradient+supersample");
        // A's threshold is far above B's weak edge: nothing is supersampled.
        CHECK(r2.active_fraction == 0.0);
        const sampling::FrameLayer *g2 = layer(r2, "gradient");
        REQUIRE(g2);
        float gmax = 0;
        for (float v : g2->data)
            gmax = std::max(gmax, v);
        CHECK(gmax > 0.f);
        CHECK(gmax < 1.f);
        // Frame 3 on B uses B's own average (from frame 2): the three-pass result exactly.
        sched::FrameTiming t3 = render(*p, b, r3);
        CHECK(t3.stage_names.size() == 2);
        check_identical(r3, rb);
    }
}

TEST_CASE("texture_average: texture detail alone triggers nothing, object edges still do") {
    const uint32_t w = 40, h = 32;
    SyntheticAttributeSource src(w, h);
    src.shapes[0].color = Rgb(0.8f);
    src.shapes[0].texture_scale = 1.5f;
    AttrShape disc;
    disc.kind = AttrShape::Kind::Disc;
    disc.cx = 20.3f;
    disc.cy = 15.8f;
    disc.r = 8.4f;
    disc.color = Rgb(0.f);
    src.shapes.push_back(disc);
    for (bool quad : {false, true}) {
        CAPTURE(quad);
        auto plain = make(quad ? "flipquad" : "fliptri");
        auto avg = make(std::string(quad ? "flipquad" : "fliptri") + ":texture_average=1");
        FrameResult rp, ra;
        render(*plain, src, rp);
        render(*avg, src, ra);
        const sampling::FrameLayer *act = layer(ra, "active");
        REQUIRE(act);
        uint32_t n = 0;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                bool in = false, out = false;
                for (const P3 &q : expected_pattern(quad, x, y)) {
                    float px = float(q.first) / 3.f, py = float(q.second) / 3.f;
                    px = std::min(px, float(w - 1) + kBelowOne);
                    py = std::min(py, float(h - 1) + kBelowOne);
                    (src.attributes_at(px, py).primary.object_id == 1 ? in : out) = true;
                }
                CHECK(act->data[size_t(y) * w + x] == ((in && out) ? 1.f : 0.f));
                n += (in && out) ? 1 : 0;
            }
        CHECK(ra.active_fraction == test::Approx(double(n) / (w * h)));
        // Without averaging the checker squares' edges are supersampled too.
        CHECK(rp.active_fraction > 2 * ra.active_fraction);
    }
}

TEST_CASE("non-finite samples are dropped and counted") {
    const uint32_t w = 16, h = 16;
    // A NaN exactly at one pattern point: FLIPQUAD pixel (4, 4)'s left sample (4, 4 + 2/3).
    FunctionSource src(w, h, [](float x, float y) {
        if (x == 4.f && y == 4.f + 2.f / 3.f)
            return Rgb(std::nanf(""));
        return Rgb(0.25f);
    });
    auto p = make("flipquad");
    FrameResult r;
    render(*p, src, r);
    CHECK(r.nan_samples == 1);
    CHECK(r.active_fraction == 0.0);
    for (const Rgb &c : r.color) {
        CHECK(c.is_finite());
        CHECK(c.r == test::Approx(0.25f));
    }
}

TEST_CASE("frames are bit-identical for 1 and 3 threads") {
    const uint32_t w = 45, h = 37;  // partial tiles and odd borders
    SyntheticAttributeSource src = busy_scene(w, h);
    for (const char *spec : {"fliptri", "flipquad", "fliptri:per_channel=1,texture_average=1",
                             "flipquad:extra=9,threshold_scale=0.5", "fliptri:prev_threshold=1"}) {
        CAPTURE(spec);
        auto p1 = make(spec), p3 = make(spec);
        for (int frame = 0; frame < 2; ++frame) {
            FrameResult r1, r3;
            render(*p1, src, r1, 1);
            render(*p3, src, r3, 3);
            check_identical(r1, r3);
            CHECK(r1.active_fraction > 0.0);
        }
    }
}

TEST_CASE("any tile size gives the same frame; each shared point still traced once") {
    const uint32_t w = 29, h = 22;
    SyntheticAttributeSource src = busy_scene(w, h);
    for (const char *spec : {"fliptri", "flipquad"}) {
        CAPTURE(spec);
        FrameResult ref;
        auto p = make(spec);
        src.reset_counts();
        render(*p, src, ref);
        const uint64_t traced = src.total_count();
        CHECK(ref.samples == traced);
        for (uint32_t tile : {1u, 3u, 5u, 16u, 64u}) {
            CAPTURE(tile);
            auto q = make(spec);
            FrameResult r;
            src.reset_counts();
            sched::FrameScheduler fs(sched::FrameOptions{3, tile});
            fs.render(*q, src, r);
            CHECK(src.total_count() == traced);
            check_identical(r, ref);
        }
    }
}

TEST_CASE("a cancelled frame leaves zeros, counts only what ran, and resets prev_threshold") {
    const uint32_t w = 24, h = 16;
    SyntheticAttributeSource src = busy_scene(w, h);
    auto p = make("fliptri:prev_threshold=1");
    sched::FrameScheduler fs(sched::FrameOptions{2});
    FrameResult r1, r2, r3;
    CHECK(fs.render(*p, src, r1).stage_names.size() == 3);
    std::atomic<bool> cancel{true};
    sched::FrameTiming t2 = fs.render(*p, src, r2, &cancel);
    CHECK(t2.cancelled);
    CHECK(t2.stage_names.size() == 2);
    CHECK(r2.samples == 0);
    CHECK(r2.rays_total == 0);
    CHECK(r2.active_fraction == 0.0);
    for (const Rgb &c : r2.color)
        CHECK(c.is_black());
    // The cancelled frame's average is incomplete: the next frame runs the three passes.
    CHECK(fs.render(*p, src, r3).stage_names.size() == 3);
    check_identical(r3, r1);
}
