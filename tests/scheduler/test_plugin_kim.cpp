// The `kim` frame plugin (sampling/plugins/kim.cpp): adaptive undersampling after Kim et al.
// Checked on synthetic sources (tests/scheduler/synthetic_attribute_source.h and a table source
// below whose attribute vectors the test sets pixel by pixel):
//  - parameters: the paper's defaults, key parsing, the cross-parameter checks of `make`;
//  - interpolation is exact on a plane: only B pixels are traced (1/4, 1/16, 1/64 of the
//    pixels for block 2, 4, 8), every A pixel is interpolated and the image equals the traced one;
//  - an object edge forces exactly the expected A pixels to be traced (block 2 and 4);
//  - each of the seven similarity checks fails on its own (two references differing in one
//    attribute), in Table 1's order, and a source without attribute vectors traces everything;
//  - T_pos relative to the scene: measured from the B hits, or given as scene-size;
//  - post-correction finds a one-pixel-wide line that the B lattice misses entirely (two and
//    four scan directions), and a missing shadow (pc-shadow);
//  - supersampling: ss=2 traces one sample per pixel on a plane, box-filters to the exact mean;
//  - 1 vs 3 threads give bit-identical frames; sample counts match the source's counters.
//
// ThreadSanitizer: these tests carry the "tsan" label; the sources count with atomics.
#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "approx.h"
#include "sampling/pixel_sampler.h"
#include "scheduler/frame_scheduler.h"
#include "plugin_test_util.h"
#include "synthetic_attribute_source.h"

using tessera::test::check_same_frame;

using namespace tessera;
using namespace tessera::sampling;
using tessera::test::AttrShape;
using tessera::test::ShadowDisc;
using tessera::test::SyntheticAttributeSource;

namespace {

/// Renders one frame of `source` with `kim:<params>` on `threads` threads.
/// `tile` is the scheduler's tile edge (8 by default; 64 puts a small image in one tile).
FrameResult render_kim(const SampleSource &source, const std::string &params, uint32_t threads = 1,
                       uint32_t tile = sched::kTileSize) {
    PluginSpec spec = parse_plugin_spec(params.empty() ? "kim" : "kim:" + params);
    std::unique_ptr<PixelSampler> sampler = spec.info->make(spec.params);
    sched::FrameScheduler scheduler(sched::FrameOptions{threads, tile});
    FrameResult result;
    scheduler.render(*sampler, source, result);
    return result;
}

const FrameLayer &layer(const FrameResult &r, const std::string &name) {
    for (const FrameLayer &l : r.diagnostics)
        if (l.name == name)
            return l;
    FAIL("missing layer " << name);
    return r.diagnostics.front();
}

float at(const FrameResult &r, const std::string &name, uint32_t x, uint32_t y) {
    return layer(r, name).data[size_t(y) * r.width + x];
}

/// The colour of one ray through the pixel centre (what full ray tracing gives).
Rgb traced_centre(const SampleSource &s, uint32_t x, uint32_t y) {
    CameraSample cs;
    cs.px = x;
    cs.py = y;
    return s.evaluate(cs).radiance;
}

float max_diff(Rgb a, Rgb b) {
    return std::max(std::fabs(a.r - b.r), std::max(std::fabs(a.g - b.g), std::fabs(a.b - b.b)));
}

/// A plane with linear shading over the whole film.
std::unique_ptr<SyntheticAttributeSource> flat_plane(uint32_t w, uint32_t h) {
    auto s = std::make_unique<SyntheticAttributeSource>(w, h);
    s->shapes[0].color = Rgb(0.1f, 0.2f, 0.3f);
    s->shapes[0].color_dx = Rgb(0.01f, 0.002f, -0.003f);
    s->shapes[0].color_dy = Rgb(-0.004f, 0.006f, 0.001f);
    return s;
}

bool is_base(uint32_t x, uint32_t y, uint32_t block) {
    return x % block == 0 && y % block == 0;
}

/// A source whose attribute vector the test sets per pixel: evaluate() returns it with
/// radiance = shade(it); shade() = (0.1 x + gcol.r, 0.2 + gcol.g, 0.3 + gcol.b).
class TableSource final : public SampleSource {
  public:
    TableSource(uint32_t w, uint32_t h, bool attributes = true)
        : w_(w), h_(h), attributes_(attributes), table(size_t(w) * h), counts_(size_t(w) * h) {
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                HitAttributes &a = table[size_t(y) * w + x];
                a.primary.object_id = 1;
                a.primary.position = Vec3f(float(x), float(y), 5.f);
                a.primary.normal = Vec3f(0, 0, -1);
            }
    }
    uint32_t width() const override { return w_; }
    uint32_t height() const override { return h_; }
    bool provides_attributes() const override { return attributes_; }
    std::string describe() const override { return "table source"; }
    Rgb shade(const HitAttributes &a) const override {
        return Rgb(0.1f * a.primary.position.x, 0.2f, 0.3f) + a.global_color;
    }
    Sample evaluate(const CameraSample &cs) const override {
        counts_[size_t(cs.py) * w_ + cs.px].fetch_add(1, std::memory_order_relaxed);
        const HitAttributes &a = table[size_t(cs.py) * w_ + cs.px];
        Sample s;
        s.radiance = shade(a);
        s.rays = 1;
        if (attributes_)
            s.first_hit = a;
        return s;
    }
    uint32_t count(uint32_t x, uint32_t y) const {
        return counts_[size_t(y) * w_ + x].load(std::memory_order_relaxed);
    }
    HitAttributes &operator()(uint32_t x, uint32_t y) { return table[size_t(y) * w_ + x]; }

  private:
    uint32_t w_, h_;
    bool attributes_;
    std::vector<HitAttributes> table;
    mutable std::vector<std::atomic<uint32_t>> counts_;
};

}  // namespace

TEST_CASE("kim: parameters, the paper's defaults and cross-parameter checks") {
    PluginSpec spec = parse_plugin_spec("kim");
    REQUIRE(spec.info != nullptr);
    CHECK(spec.info->kind == PluginKind::Frame);
    CHECK(spec.params.get("t-pos") == test::Approx(0.03));  // Sec. 6
    CHECK(spec.params.get("t-norm") == test::Approx(0.9));
    CHECK(spec.params.get("t-tex") == test::Approx(0.3));
    CHECK(spec.params.get("t-gcol") == test::Approx(0.15));
    CHECK(spec.params.get_int("block") == 2);  // Fig. 2
    CHECK(spec.params.get_int("ss") == 1);
    CHECK(spec.params.get_int("postcorrect") == 4);  // Sec. 5: four scans
    CHECK(spec.params.get_bool("pc-shadow"));
    CHECK(spec.params.get("scene-size") == 0.0);

    spec =
        parse_plugin_spec("kim:block=4,postcorrect=2,t_pos=0.05,scene-size=12.5,pc_shadow=0,ss=2");
    CHECK(spec.params.get_int("block") == 4);
    CHECK(spec.params.get_int("postcorrect") == 2);
    CHECK(spec.params.get("t-pos") == test::Approx(0.05));
    CHECK(spec.params.get("scene_size") == test::Approx(12.5));
    CHECK_FALSE(spec.params.get_bool("pc-shadow"));
    CHECK(spec.params.get_int("ss") == 2);
    CHECK(spec.info->make(spec.params) != nullptr);

    CHECK_THROWS_AS(parse_plugin_spec("kim:t-norm=1.5"), std::invalid_argument);
    CHECK_THROWS_AS(parse_plugin_spec("kim:t-tex=0.6"), std::invalid_argument);
    CHECK_THROWS_AS(parse_plugin_spec("kim:block=16"), std::invalid_argument);
    CHECK_THROWS_AS(parse_plugin_spec("kim:ss=1.5"), std::invalid_argument);
    CHECK_THROWS_AS(parse_plugin_spec("kim:threshold=1"), std::invalid_argument);
    // Inside the ranges but not a valid choice: rejected by make, naming plugin and key.
    for (const char *bad : {"kim:block=3", "kim:ss=3", "kim:postcorrect=1", "kim:postcorrect=3"}) {
        PluginSpec b = parse_plugin_spec(bad);
        std::string msg;
        try {
            b.info->make(b.params);
        } catch (const std::invalid_argument &e) {
            msg = e.what();
        }
        CAPTURE(bad);
        CHECK(msg.find("kim") != std::string::npos);
        const std::string key = std::string(bad).substr(4, std::string(bad).find('=') - 4);
        CHECK(msg.find(key) != std::string::npos);
    }
}

TEST_CASE("kim: interpolation is exact on a plane; only B pixels are traced") {
    for (uint32_t block : {2u, 4u, 8u}) {
        CAPTURE(block);
        auto src = flat_plane(32, 32);
        // References up to 8 pixels apart: a scene of 1000 pixels gives T_pos = 30 pixels.
        FrameResult r = render_kim(*src, "scene-size=1000,block=" + std::to_string(block));
        const uint32_t n_base = (32 / block) * (32 / block);
        CHECK(r.active_fraction == test::Approx(1.0 / double(block * block)).epsilon(1e-12));
        CHECK(r.samples == n_base);
        CHECK(r.shaded == 32 * 32 - n_base);
        CHECK(src->total_count() == n_base);
        CHECK(r.active_unit == "pixels");
        float worst = 0;
        for (uint32_t y = 0; y < 32; ++y)
            for (uint32_t x = 0; x < 32; ++x) {
                const bool b = is_base(x, y, block);
                CHECK(src->count(x, y) == (b ? 1u : 0u));
                CHECK(at(r, "traced", x, y) == (b ? 1.f : 0.f));
                CHECK(at(r, "check", x, y) == 0.f);
                CHECK(r.rays[size_t(y) * 32 + x] == (b ? 2.f : 0.f));
                worst = std::max(worst,
                                 max_diff(r.color[size_t(y) * 32 + x], traced_centre(*src, x, y)));
            }
        CHECK(worst <= 2e-6f);  // float rounding of the interpolated positions only
    }
    // Fig. 2: the class pattern of the 2x2 base block.
    auto src = flat_plane(16, 16);
    FrameResult r = render_kim(*src, "scene-size=1000");
    for (uint32_t y = 0; y < 16; ++y)
        for (uint32_t x = 0; x < 16; ++x) {
            const float expected = y % 2 ? 2.f : (x % 2 ? 1.f : 0.f);
            CHECK(at(r, "class", x, y) == expected);
        }
}

TEST_CASE("kim: an object edge forces tracing of exactly the A pixels next to it") {
    SUBCASE("vertical edge, block 2: the A1 pixels between B pixels on either side") {
        SyntheticAttributeSource src(32, 32);
        AttrShape half;  // x < 11: pixel columns 0..10
        half.kind = AttrShape::Kind::HalfPlane;
        half.nx = 1, half.ny = 0, half.d = 11;
        half.color = Rgb(0.8f, 0.6f, 0.2f);
        src.shapes.push_back(half);
        FrameResult r = render_kim(src, "scene-size=1000,postcorrect=0");
        for (uint32_t y = 0; y < 32; ++y)
            for (uint32_t x = 0; x < 32; ++x) {
                const bool edge = x == 11 && y % 2 == 0;
                const bool traced = is_base(x, y, 2) || edge;
                CAPTURE(x);
                CAPTURE(y);
                CHECK(src.count(x, y) == (traced ? 1u : 0u));
                CHECK(at(r, "check", x, y) == (edge ? 1.f : 0.f));  // G1
                CHECK(max_diff(r.color[size_t(y) * 32 + x], traced_centre(src, x, y)) <= 2e-6f);
            }
    }
    SUBCASE("horizontal edge, block 2: the whole A2 row between") {
        SyntheticAttributeSource src(32, 32);
        AttrShape half;  // y < 11: pixel rows 0..10
        half.kind = AttrShape::Kind::HalfPlane;
        half.nx = 0, half.ny = 1, half.d = 11;
        half.color = Rgb(0.8f, 0.6f, 0.2f);
        src.shapes.push_back(half);
        FrameResult r = render_kim(src, "scene-size=1000,postcorrect=0");
        for (uint32_t y = 0; y < 32; ++y)
            for (uint32_t x = 0; x < 32; ++x) {
                const bool traced = is_base(x, y, 2) || y == 11;
                CHECK(src.count(x, y) == (traced ? 1u : 0u));
                CHECK(at(r, "check", x, y) == (y == 11 ? 1.f : 0.f));
                CHECK(at(r, "class", x, y) == (y % 2 ? 2.f : (x % 2 ? 1.f : 0.f)));
            }
        CHECK(r.active_fraction == test::Approx((16.0 * 16 + 32) / (32.0 * 32)));
        // Post-correction then revisits the traced row: its interpolated neighbours of a
        // different object (the A1 pixels of row 10) are re-traced, without a change.
        src.reset_counts();
        r = render_kim(src, "scene-size=1000,postcorrect=4");
        for (uint32_t x = 0; x < 32; ++x) {
            CHECK(at(r, "postcorrected", x, 10) == (x % 2 ? 1.f : 0.f));
            CHECK(at(r, "postcorrected", x, 12) == 0.f);  // same object as row 11
            CHECK(src.count(x, 10) == 1);
        }
        CHECK(r.active_fraction == test::Approx((16.0 * 16 + 32 + 16) / (32.0 * 32)));
    }
    SUBCASE("vertical edge, block 4: the midpoint levels recurse") {
        SyntheticAttributeSource src(32, 32);
        AttrShape half;
        half.kind = AttrShape::Kind::HalfPlane;
        half.nx = 1, half.ny = 0, half.d = 11;
        src.shapes.push_back(half);
        FrameResult r = render_kim(src, "scene-size=1000,block=4,postcorrect=0");
        // B at x = 8 (inside) and 12 (outside): level 2 traces x = 10 in rows y = 0 (mod 4);
        // level 1 traces x = 11 (between 10 inside and 12 outside) in the even rows.
        for (uint32_t y = 0; y < 32; ++y)
            for (uint32_t x = 0; x < 32; ++x) {
                const bool traced =
                    is_base(x, y, 4) || (x == 10 && y % 4 == 0) || (x == 11 && y % 2 == 0);
                CAPTURE(x);
                CAPTURE(y);
                CHECK(src.count(x, y) == (traced ? 1u : 0u));
                CHECK(max_diff(r.color[size_t(y) * 32 + x], traced_centre(src, x, y)) <= 2e-6f);
            }
    }
}

TEST_CASE("kim: each similarity check of Table 1 fails on its own") {
    // Pixels 0 and 2 are B, pixel 1 the A1 pixel between them. scene-size 100: T_pos = 3.
    auto run = [](const std::function<void(HitAttributes &, HitAttributes &)> &edit) {
        TableSource src(3, 1);
        HitAttributes &a = src(0, 0), &b = src(2, 0);
        a.primary.has_texture = b.primary.has_texture = true;
        a.primary.uv = Vec2f(0.5f, 0.5f);
        b.primary.uv = Vec2f(0.55f, 0.45f);
        a.global_color = Rgb(0.1f);
        b.global_color = Rgb(0.1f);
        edit(a, b);
        FrameResult r = render_kim(src, "scene-size=100,postcorrect=0");
        const float check = at(r, "check", 1, 0);
        CHECK(src.count(1, 0) == (check == 0.f ? 0u : 1u));
        CHECK(at(r, "traced", 1, 0) == (check == 0.f ? 0.f : 1.f));
        if (check == 0.f) {  // interpolated: shade() of the midpoint vector
            const float gcol = 0.5f * (src(0, 0).global_color.r + src(2, 0).global_color.r);
            CHECK(r.color[1].r == test::Approx(0.1f * 1.f + gcol));
            CHECK(r.shaded == 1);
        }
        return int(check);
    };
    const Vec3f n_left = normalize(Vec3f(-0.2f, 0, -1)), n_right = normalize(Vec3f(0.2f, 0, -1));
    CHECK(run([](HitAttributes &, HitAttributes &) {}) == 0);
    CHECK(run([](HitAttributes &, HitAttributes &b) { b.primary.object_id = 2; }) == 1);
    // G2: 4.1 apart > 3. (G4 would fail as well; the first failure is reported.)
    CHECK(run([](HitAttributes &, HitAttributes &b) { b.primary.position.z = 8.5f; }) == 2);
    CHECK(run([](HitAttributes &, HitAttributes &b) {
              b.primary.normal = normalize(Vec3f(0.6f, 0, -0.8f));  // dot 0.8 < 0.9
          }) == 3);
    // G4: a step between two parallel surfaces: each hit lies on opposite sides of the other's
    // tangent plane.
    CHECK(run([](HitAttributes &, HitAttributes &b) { b.primary.position.z = 5.5f; }) == 4);
    // G4 with curved normals: convex (normals spread outwards) and concave pass; the same
    // positions with both normals tilted one way (an inflection) fail.
    CHECK(run([&](HitAttributes &a, HitAttributes &b) {
              a.primary.normal = n_left;
              b.primary.normal = n_right;
          }) == 0);
    CHECK(run([&](HitAttributes &a, HitAttributes &b) {
              a.primary.normal = n_right;
              b.primary.normal = n_left;
          }) == 0);
    CHECK(run([&](HitAttributes &a, HitAttributes &b) {
              a.primary.normal = n_left;
              b.primary.normal = n_left;
          }) == 4);
    // TX (Table 1): fails when the references straddle a repeated texture's seam in s or t;
    // both near the same side of it is fine; only one textured fails.
    CHECK(run([](HitAttributes &a, HitAttributes &b) {
              a.primary.uv.x = 0.95f;
              b.primary.uv.x = 1.05f;  // fractional 0.05: across the seam
          }) == 5);
    CHECK(run([](HitAttributes &a, HitAttributes &b) {
              a.primary.uv.y = 2.1f;  // repeated texture: fractional parts 0.1 and 0.8
              b.primary.uv.y = 1.8f;
          }) == 5);
    CHECK(run([](HitAttributes &a, HitAttributes &b) {
              a.primary.uv.x = 0.9f;  // both near the seam, on the same side
              b.primary.uv.x = 0.95f;
          }) == 0);
    CHECK(run([](HitAttributes &a, HitAttributes &b) {
              a.primary.uv.x = 0.25f;  // below T_tex but the other is not above 1 - T_tex
              b.primary.uv.x = 0.65f;
          }) == 0);
    CHECK(run([](HitAttributes &, HitAttributes &b) { b.primary.has_texture = false; }) == 5);
    CHECK(run([](HitAttributes &, HitAttributes &b) { b.primary.shadow_bits = 2; }) == 6);
    CHECK(run([](HitAttributes &, HitAttributes &b) { b.global_color = Rgb(0.3f, 0.1f, 0.1f); }) ==
          7);  // |difference| 0.2 > 0.15
    CHECK(run([](HitAttributes &, HitAttributes &b) { b.global_color = Rgb(0.2f, 0.1f, 0.1f); }) ==
          0);  // 0.1 <= 0.15
    // Thresholds are parameters.
    {
        TableSource src(3, 1);
        src(2, 0).primary.normal = normalize(Vec3f(0.6f, 0, -0.8f));
        CHECK(at(render_kim(src, "scene-size=100,t-norm=0.7"), "check", 1, 0) == 0.f);
        CHECK(at(render_kim(src, "scene-size=100,t-norm=0.9"), "check", 1, 0) == 3.f);
    }
    // A source without attribute vectors: nothing can be checked, every pixel is traced.
    {
        TableSource src(8, 8, false);
        FrameResult r = render_kim(src, "");
        CHECK(r.active_fraction == 1.0);
        CHECK(r.shaded == 0);
        CHECK(at(r, "check", 1, 0) == 8.f);
        CHECK(at(r, "check", 0, 0) == 0.f);  // B
    }
}

TEST_CASE("kim: a non-finite sample is dropped and never interpolated") {
    // Pixel 2 (B) returns NaN: its colour is dropped and counted; the A1 pixels next to it
    // (pixel 1 between 0 and 2, pixel 3 extrapolated from 0 and 2) fail GC and are traced.
    TableSource src(4, 1);
    src(2, 0).global_color = Rgb(std::nanf(""), 0.f, 0.f);
    FrameResult r = render_kim(src, "scene-size=100,postcorrect=0");
    CHECK(r.nan_samples == 1);
    CHECK(r.color[2].r == 0.f);
    CHECK(at(r, "check", 1, 0) == 7.f);
    CHECK(at(r, "check", 3, 0) == 7.f);
    for (uint32_t x : {0u, 1u, 3u}) {
        CHECK(std::isfinite(r.color[x].r));
        CHECK(r.color[x].r == test::Approx(0.1f * float(x)));
    }
}

TEST_CASE("kim: an interpolation between escaped references, one non-finite, is dropped") {
    // Every pixel escapes (no surface: OID -1), so the checks on position and normal do not
    // apply and A pixels take the linear interpolation of their references' colours. B pixel 2
    // returns NaN (through its position, which escaped pixels do not compare): pixel 1 (between
    // 0 and 2) and pixel 3 (extrapolated from 0 and 2) are interpolated from it, so they are
    // non-finite too: dropped (colour 0) and counted, like the NaN sample itself. (Its stored
    // colour is 0; interpolating that, or clamping the NaN to 0, would darken them silently.)
    TableSource src(4, 1);
    for (uint32_t x = 0; x < 4; ++x) src(x, 0).primary.object_id = -1;
    src(2, 0).primary.position.x = std::nanf("");
    FrameResult r = render_kim(src, "scene-size=100,postcorrect=0");
    CHECK(at(r, "traced", 1, 0) == 0.f);  // interpolated, not traced
    CHECK(at(r, "traced", 3, 0) == 0.f);
    CHECK(r.nan_samples == 3);
    for (uint32_t x : {1u, 2u, 3u}) {
        CAPTURE(x);
        CHECK(r.color[x].r == 0.f);
        CHECK(r.color[x].g == 0.f);
    }
    CHECK(r.color[0].g == test::Approx(0.2f));
}

TEST_CASE("kim: T_pos is relative to the scene's longest side") {
    // The B hits of a 32-pixel plane span 30 units: T_pos = 0.9 < 2 (the reference distance),
    // so G2 fails everywhere; at 128 pixels T_pos = 3.78 and every A pixel is interpolated.
    auto small = flat_plane(32, 32);
    FrameResult r = render_kim(*small, "");
    CHECK(r.active_fraction == 1.0);
    CHECK(at(r, "check", 1, 0) == 2.f);
    CHECK(at(r, "check", 5, 7) == 2.f);
    auto large = flat_plane(128, 128);
    r = render_kim(*large, "");
    CHECK(r.active_fraction == 0.25);
    // The same 32-pixel plane with the scene size given.
    r = render_kim(*small, "scene-size=200");
    CHECK(r.active_fraction == 0.25);
    r = render_kim(*small, "scene-size=200,t-pos=0.005");  // 1 < 2
    CHECK(r.active_fraction == 1.0);
}

TEST_CASE("kim: post-correction recovers a one-pixel-wide line the B lattice misses") {
    const Rgb line_color(0.9f, 0.1f, 0.1f);
    auto scene = [&](bool seed_above) {
        auto src = std::make_unique<SyntheticAttributeSource>(32, 32);
        AttrShape line;  // column 11 only: B pixels are at even x, so none ever hits it
        line.kind = AttrShape::Kind::Line;
        line.nx = 1, line.ny = 0, line.d = 11.5f, line.width = 1;
        line.color = line_color;
        src->shapes.push_back(line);
        AttrShape half;  // covers the line above row 8 (or below row 24); its edge seeds
        half.kind = AttrShape::Kind::HalfPlane;
        half.nx = 0;
        half.ny = seed_above ? 1.f : -1.f;
        half.d = seed_above ? 8.f : -24.f;
        half.color = Rgb(0.1f, 0.8f, 0.1f);
        src->shapes.push_back(half);
        return src;
    };
    SUBCASE("line below a traced edge: found by the top-to-bottom scan") {
        auto src = scene(true);
        // Rows >= 8 of column 11 show the line; without post-correction they are background.
        FrameResult off = render_kim(*src, "scene-size=1000,postcorrect=0");
        for (uint32_t y = 8; y < 32; ++y) {
            CHECK(max_diff(off.color[size_t(y) * 32 + 11], traced_centre(*src, 10, y)) <= 1e-5f);
            CHECK(at(off, "traced", 11, y) == 0.f);
        }
        for (int dirs : {2, 4}) {
            CAPTURE(dirs);
            src->reset_counts();
            FrameResult on =
                render_kim(*src, "scene-size=1000,postcorrect=" + std::to_string(dirs));
            for (uint32_t y = 8; y < 32; ++y) {
                CAPTURE(y);
                CHECK(max_diff(on.color[size_t(y) * 32 + 11], line_color) == 0.f);
                CHECK(at(on, "postcorrected", 11, y) == 2.f);
                CHECK(src->count(11, y) == 1);
            }
            // The A1 pixels below the seed row are examined (different OID) but unchanged.
            CHECK(at(on, "postcorrected", 13, 8) == 1.f);
            CHECK(at(on, "postcorrected", 12, 9) == 0.f);
            CHECK(on.samples == src->total_count());
            CHECK(on.samples > off.samples);
        }
    }
    SUBCASE("line above a traced edge: only the four-direction scan goes up") {
        auto src = scene(false);
        FrameResult two = render_kim(*src, "scene-size=1000,postcorrect=2");
        FrameResult four = render_kim(*src, "scene-size=1000,postcorrect=4");
        // Row 23 is traced (its references differ): that pixel is the seed on the line.
        CHECK(at(two, "traced", 11, 23) == 1.f);
        for (uint32_t y = 0; y < 23; ++y) {
            CAPTURE(y);
            CHECK(max_diff(two.color[size_t(y) * 32 + 11], line_color) > 0.1f);
            CHECK(max_diff(four.color[size_t(y) * 32 + 11], line_color) == 0.f);
            CHECK(at(four, "postcorrected", 11, y) == 2.f);
        }
    }
    SUBCASE("horizontal line right of a traced disc border: the left-to-right scan") {
        SyntheticAttributeSource src(32, 32);
        AttrShape line;  // row 11 only: A2 pixels, interpolated from rows 10 and 12
        line.kind = AttrShape::Kind::Line;
        line.nx = 0, line.ny = 1, line.d = 11.5f, line.width = 1;
        line.color = line_color;
        src.shapes.push_back(line);
        AttrShape disc;  // its lower border crosses row 11 near x = 3..5 and traces A2 there
        disc.kind = AttrShape::Kind::Disc;
        disc.cx = 0, disc.cy = 0, disc.r = 11.9f;
        disc.color = Rgb(0.1f, 0.8f, 0.1f);
        src.shapes.push_back(disc);
        FrameResult off = render_kim(src, "scene-size=1000,postcorrect=0");
        FrameResult on = render_kim(src, "scene-size=1000,postcorrect=2");
        for (uint32_t x = 6; x < 32; ++x) {
            CAPTURE(x);
            CHECK(max_diff(off.color[11 * 32 + x], line_color) > 0.1f);
            CHECK(max_diff(on.color[11 * 32 + x], line_color) == 0.f);
        }
    }
    SUBCASE("an isolated line with no traced adaptive pixel next to it stays missing") {
        // Sec. 4 starts from ray-traced adaptive pixels; nothing marks this line.
        SyntheticAttributeSource src(32, 32);
        AttrShape line;
        line.kind = AttrShape::Kind::Line;
        line.nx = 1, line.ny = 0, line.d = 11.5f, line.width = 1;
        line.color = line_color;
        src.shapes.push_back(line);
        FrameResult r = render_kim(src, "scene-size=1000");
        CHECK(r.active_fraction == 0.25);
    }
}

TEST_CASE("kim: post-correction recovers a missing shadow through the shadow bits") {
    SyntheticAttributeSource src(32, 32);
    src.shapes[0].color = Rgb(0.6f, 0.5f, 0.4f);
    AttrShape half;  // rows 0..7: its edge traces row 7, the seeds
    half.kind = AttrShape::Kind::HalfPlane;
    half.nx = 0, half.ny = 1, half.d = 8;
    half.color = Rgb(0.1f, 0.8f, 0.1f);
    src.shapes.push_back(half);
    for (uint32_t y = 8; y < 32; ++y)  // a thin shadow over column 11 only
        src.shadows.push_back(ShadowDisc{11.5f, float(y) + 0.5f, 0.6f});
    const Rgb lit = traced_centre(src, 10, 20), dark = traced_centre(src, 11, 20);
    REQUIRE(max_diff(lit, dark) > 0.1f);
    FrameResult off = render_kim(src, "scene-size=1000,postcorrect=0");
    FrameResult ids = render_kim(src, "scene-size=1000,postcorrect=2,pc-shadow=0");
    FrameResult on = render_kim(src, "scene-size=1000,postcorrect=2");
    for (uint32_t y = 8; y < 32; ++y) {
        CAPTURE(y);
        const Rgb truth = traced_centre(src, 11, y);
        CHECK(max_diff(off.color[size_t(y) * 32 + 11], truth) > 0.1f);
        CHECK(max_diff(on.color[size_t(y) * 32 + 11], truth) <= 1e-6f);
        CHECK(at(on, "postcorrected", 11, y) == 2.f);
        // Without the shadow bits only row 8 is re-traced (its OID differs from the seed's),
        // and nothing propagates from it.
        if (y == 8) {
            CHECK(max_diff(ids.color[size_t(y) * 32 + 11], truth) <= 1e-6f);
            CHECK(at(ids, "postcorrected", 11, y) == 1.f);
        } else {
            CHECK(max_diff(ids.color[size_t(y) * 32 + 11], truth) > 0.1f);
        }
    }
}

TEST_CASE("kim: supersampling runs the undersampling on the ss x ss lattice") {
    auto src = flat_plane(24, 16);
    FrameResult r = render_kim(*src, "scene-size=1000,ss=2");
    CHECK(r.active_unit == "subpixels");
    CHECK(r.active_fraction == 0.25);
    CHECK(r.samples == 24 * 16);
    CHECK(r.shaded == 3 * 24 * 16);
    float worst = 0;
    for (uint32_t y = 0; y < 16; ++y)
        for (uint32_t x = 0; x < 24; ++x) {
            CHECK(src->count(x, y) == 1);  // the B sample at the pixel's top-left
            CHECK(at(r, "traced", x, y) == 0.25f);
            // Linear shading: the box filter of the 4 samples is the exact pixel mean.
            worst = std::max(worst, max_diff(r.color[size_t(y) * 24 + x], src->ground_truth(x, y)));
        }
    CHECK(worst <= 2e-6f);

    // ss=4: 16 samples per pixel, one traced on a plane.
    src->reset_counts();
    r = render_kim(*src, "scene-size=1000,ss=4,block=4");
    CHECK(r.samples == 24 * 16);
    CHECK(r.active_fraction == test::Approx(1.0 / 16));
    CHECK(src->count(5, 5) == 1);

    // An edge on the lattice: counts per pixel equal the traced samples of the layer.
    SyntheticAttributeSource edge(24, 16);
    AttrShape disc;
    disc.kind = AttrShape::Kind::Disc;
    disc.cx = 11.3f, disc.cy = 7.9f, disc.r = 5.2f;
    disc.color = Rgb(0.9f, 0.9f, 0.2f);
    edge.shapes.push_back(disc);
    r = render_kim(edge, "scene-size=1000,ss=2");
    uint64_t total = 0;
    for (uint32_t y = 0; y < 16; ++y)
        for (uint32_t x = 0; x < 24; ++x) {
            CHECK(edge.count(x, y) == uint32_t(std::lround(at(r, "traced", x, y) * 4)));
            CHECK(r.rays[size_t(y) * 24 + x] == float(2 * edge.count(x, y)));
            total += edge.count(x, y);
        }
    CHECK(total == r.samples);
    CHECK(r.rays_total == 2 * total);
}


TEST_CASE("kim: post-correction across block borders equals one serial scan per line") {
    // pc-lines=1 scans every image line in one job, serially along it (the paper's threads):
    // the reference. By default each 8x8-pixel block with a seed scans its own segments and the
    // chains that cross block borders continue in the -cross stages; the frame must be the same,
    // for any tile size and thread count.
    for (const char *params : {"scene-size=300", "scene-size=300,block=4,ss=2",
                               "scene-size=300,postcorrect=2,pc-shadow=0"}) {
        CAPTURE(params);
        auto src = test::busy_attribute_scene();
        FrameResult serial = render_kim(*src, std::string(params) + ",pc-lines=1", 1);
        check_same_frame(serial, render_kim(*src, params, 3, 8));
        check_same_frame(serial, render_kim(*src, params, 2, 64));
        check_same_frame(serial, render_kim(*src, std::string(params) + ",pc-lines=1", 3, 8));
    }
    // The line scenes of the post-correction test, whose chains cross three block borders; and
    // two lines close together, so that one image line holds several crossings and walks.
    for (float gap : {0.f, 5.f}) {
        CAPTURE(gap);
        SyntheticAttributeSource src(32, 32);
        AttrShape line;
        line.kind = AttrShape::Kind::Line;
        line.nx = 1, line.ny = 0, line.d = 11.5f, line.width = 1;
        src.shapes.push_back(line);
        if (gap > 0) {
            AttrShape other = line;
            other.nx = 0.8f, other.ny = 0.6f, other.d = 11.5f + gap;
            src.shapes.push_back(other);
        }
        AttrShape half;
        half.kind = AttrShape::Kind::HalfPlane;
        half.nx = 0, half.ny = -1, half.d = -24;
        src.shapes.push_back(half);
        check_same_frame(render_kim(src, "scene-size=1000,pc-lines=1", 1),
                         render_kim(src, "scene-size=1000", 2, 8));
    }
}

TEST_CASE("kim: frames are bit-identical for 1 and 3 threads") {
    for (const char *params :
         {"scene-size=300", "scene-size=300,block=4", "scene-size=300,ss=2,postcorrect=2",
          "block=8,ss=4,scene-size=900", ""}) {
        CAPTURE(params);
        auto src = test::busy_attribute_scene();
        FrameResult a = render_kim(*src, params, 1);
        std::vector<uint32_t> counts_a;
        for (uint32_t y = 0; y < 38; ++y)
            for (uint32_t x = 0; x < 45; ++x)
                counts_a.push_back(src->count(x, y));
        src->reset_counts();
        FrameResult b = render_kim(*src, params, 3);
        check_same_frame(a, b);
        for (uint32_t y = 0; y < 38; ++y)
            for (uint32_t x = 0; x < 45; ++x)
                CHECK(src->count(x, y) == counts_a[y * 45 + x]);
        CHECK(b.samples == src->total_count());
    }
}

TEST_CASE("kim: close to full ray tracing on a busy scene, with far fewer rays") {
    // The synthetic shading is linear inside each shape, so every correctly interpolated
    // pixel is exact; the remaining error is missing thin objects, which post-correction
    // recovers where a traced adaptive pixel touches them.
    auto src = test::busy_attribute_scene();
    auto psnr = [&](const FrameResult &r) {
        double se = 0;
        for (uint32_t y = 0; y < 38; ++y)
            for (uint32_t x = 0; x < 45; ++x) {
                const Rgb d = r.color[size_t(y) * 45 + x] - traced_centre(*src, x, y);
                se += (d.r * d.r + d.g * d.g + d.b * d.b) / 3.0;
            }
        const double mse = se / (45.0 * 38.0);
        return mse > 0 ? 10 * std::log10(1.0 / mse) : 200.0;
    };
    FrameResult off = render_kim(*src, "scene-size=300,postcorrect=0");
    FrameResult on = render_kim(*src, "scene-size=300");
    MESSAGE("kim busy scene vs full ray tracing: PSNR "
            << psnr(off) << " dB without, " << psnr(on)
            << " dB with post-correction; traced fraction " << off.active_fraction << " / "
            << on.active_fraction);
    CHECK(psnr(off) < 40);
    CHECK(psnr(on) >= 60);
    CHECK(on.active_fraction < 0.6);
    CHECK(on.active_fraction > off.active_fraction);
    CHECK(on.samples + on.shaded >= 45u * 38u);
}

TEST_CASE("kim: a frame after other frames equals the first frame of a fresh plugin") {
    // The plugin keeps its lattice, its per-block seed flags and (unzeroed) output buffers from
    // frame to frame: nothing of an earlier frame may leak into a later one. Frames 1 and 2
    // see different scenes (a plain plane, then the busy scene); frame 3 the busy scene again.
    for (const char *params : {"scene-size=300", "scene-size=300,block=4,ss=2"}) {
        CAPTURE(params);
        auto busy = test::busy_attribute_scene();
        SyntheticAttributeSource plain(45, 38);
        plain.shapes[0].color = Rgb(0.9f, 0.1f, 0.4f);
        PluginSpec spec = parse_plugin_spec(std::string("kim:") + params);
        std::unique_ptr<PixelSampler> sampler = spec.info->make(spec.params);
        sched::FrameScheduler scheduler(sched::FrameOptions{2, sched::kTileSize});
        FrameResult r;
        scheduler.render(*sampler, plain, r);
        scheduler.render(*sampler, *busy, r);
        const FrameResult fresh = render_kim(*busy, params, 1);
        check_same_frame(fresh, r);
        scheduler.render(*sampler, *busy, r);
        check_same_frame(fresh, r);
        // The busy scene does post-correct: the seed flags of frame 2 were used.
        float corrected = 0;
        for (float v : layer(r, "postcorrected").data) corrected = std::max(corrected, v);
        CHECK(corrected == 2.f);
    }
}
