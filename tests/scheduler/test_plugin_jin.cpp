// Tests of the `jin` frame plugin (selective and adaptive supersampling, Jin et al. 2009) on
// synthetic attribute sources: the exact subpixels the pessimistic test activates next to known
// edges (Fig. 4), which attribute picks the threshold (Table 1, section 4.2.2), the weights of
// section 4.1.4, the focus option (section 5), packing per tile, determinism across thread
// counts, and the parameter keys with the paper's defaults.
#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "approx.h"
#include "sampling/pixel_sampler.h"
#include "scheduler/frame_scheduler.h"
#include "scheduler/synthetic_attribute_source.h"

using namespace tessera;
using sampling::FrameResult;
using test::AttrShape;
using test::SyntheticAttributeSource;

namespace {

FrameResult render(const SampleSource &src, const std::string &spec, uint32_t threads = 1) {
    sampling::PluginSpec ps = sampling::parse_plugin_spec(spec);
    auto sampler = ps.info->make(ps.params);
    sched::FrameScheduler scheduler(sched::FrameOptions{threads});
    FrameResult r;
    scheduler.render(*sampler, src, r);
    return r;
}

const std::vector<float> &layer(const FrameResult &r, const std::string &name) {
    for (const auto &l : r.diagnostics)
        if (l.name == name)
            return l.data;
    FAIL("missing layer " << name);
    static const std::vector<float> none;
    return none;
}

float at(const FrameResult &r, const std::string &name, uint32_t x, uint32_t y) {
    return layer(r, name)[size_t(y) * r.width + x];
}

/// Object 1: the half plane x < edge (a vertical edge), in `colour`.
AttrShape left_half(float edge, Rgb colour) {
    AttrShape h;
    h.kind = AttrShape::Kind::HalfPlane;
    h.nx = 1;
    h.ny = 0;
    h.d = edge;
    h.color = colour;
    return h;
}

// The pessimistic rule for a vertical edge between pixel columns e-1 and e: the right subpixels
// (q = 1, 3) of column e-1 and the left ones (q = 0, 2) of column e compare across it.
constexpr int kRight = (1 << 1) | (1 << 3), kLeft = (1 << 0) | (1 << 2);

void check_edge_mask(const FrameResult &r, uint32_t e) {
    for (uint32_t y = 0; y < r.height; ++y)
        for (uint32_t x = 0; x < r.width; ++x) {
            const int expect = x + 1 == e ? kRight : x == e ? kLeft : 0;
            CHECK_MESSAGE(int(at(r, "active_mask", x, y)) == expect, "pixel " << x << "," << y);
            CHECK(at(r, "active_subpixels", x, y) == float(expect ? 2 : 0));
        }
}

void check_colours(const FrameResult &r, const SyntheticAttributeSource &src, float tol) {
    for (uint32_t y = 0; y < r.height; ++y)
        for (uint32_t x = 0; x < r.width; ++x) {
            const Rgb c = r.color[size_t(y) * r.width + x], g = src.ground_truth(x, y);
            for (int l = 0; l < 3; ++l)
                CHECK_MESSAGE(std::fabs(c[l] - g[l]) <= tol, "pixel " << x << "," << y);
        }
}

/// Forwards to a source and records every evaluate_batch call.
class RecordingSource final : public SampleSource {
  public:
    explicit RecordingSource(const SampleSource &inner) : inner_(inner) {}
    uint32_t width() const override { return inner_.width(); }
    uint32_t height() const override { return inner_.height(); }
    bool provides_attributes() const override { return inner_.provides_attributes(); }
    Rgb shade(const HitAttributes &a) const override { return inner_.shade(a); }
    std::string describe() const override { return "recording " + inner_.describe(); }
    Sample evaluate(const CameraSample &cs) const override { return inner_.evaluate(cs); }
    void evaluate_batch(std::span<const CameraSample> cs, std::span<Sample> out) const override {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            batches.emplace_back(cs.begin(), cs.end());
        }
        inner_.evaluate_batch(cs, out);
    }
    mutable std::vector<std::vector<CameraSample>> batches;

  private:
    const SampleSource &inner_;
    mutable std::mutex mutex_;
};

std::vector<CameraSample> extra_samples_of(const RecordingSource &rec, uint32_t x, uint32_t y) {
    std::vector<CameraSample> out;
    for (const auto &b : rec.batches)
        for (const CameraSample &c : b)
            if (c.px == x && c.py == y && c.index > 0)
                out.push_back(c);
    return out;
}

}  // namespace

TEST_CASE("jin: a vertical object edge activates exactly the subpixels beside it") {
    // Object 1 (x < 15.25) against the background: pixel centres 14.5 and 15.5 fall on either
    // side, so columns 14 and 15 disagree on the object id. The colour contrast alone (0.64,
    // 0.45, 0.27) stays under tau_col = 0.6 x (1.36, 1.02, 2.04), so the geometry-selected
    // threshold tau_poid = 0.05 decides.
    SyntheticAttributeSource src(32, 16);
    src.shapes.push_back(left_half(15.25f, Rgb(0.9f, 0.8f, 0.7f)));
    RecordingSource rec(src);
    const FrameResult r = render(rec, "jin");
    check_edge_mask(r, 15);
    for (uint32_t y = 0; y < 16; ++y)
        for (uint32_t x = 0; x < 32; ++x) {
            const bool edge = x == 14 || x == 15;
            CHECK(src.count(x, y) == (edge ? 9u : 1u));  // 1 centre + 2 x 4 extra
            CHECK(at(r, "samples", x, y) == float(edge ? 9 : 1));
            CHECK(r.rays[size_t(y) * 32 + x] == float(edge ? 18 : 2));  // 2 rays per sample
            CHECK(at(r, "test", x, y) == float(edge ? 2 : 0));
            CHECK(at(r, "attributes", x, y) == float(edge ? 1 : 0));  // bit 0: primary id
        }
    CHECK(r.samples == 32 * 16 + 4 * 64);
    CHECK(r.rays_total == 2 * r.samples);
    CHECK(r.active_unit == "subpixels");
    CHECK(r.active_fraction == test::Approx(64.0 / (4 * 32 * 16)));
    // Edge at a quarter-pixel cell boundary: the stratified samples resolve it exactly, so
    // column 15 is 1/4 object and 3/4 background, as (4 - 2)/4 centre + 8 x 1/16 samples gives.
    check_colours(r, src, 1e-5f);

    // The extra samples of an active subpixel lie in its own quadrant, one per quarter cell.
    for (uint32_t x : {14u, 15u}) {
        const auto s = extra_samples_of(rec, x, 3);
        REQUIRE(s.size() == 8);
        std::set<int> cells;
        for (const CameraSample &c : s) {
            CHECK((x == 14 ? c.fx >= 0.5f : c.fx < 0.5f));
            cells.insert(int(c.fx * 4) + 4 * int(c.fy * 4));
        }
        CHECK(cells.size() == 8);
    }

    SUBCASE("tau_poid = 1 turns the object id off: the colour test alone finds nothing") {
        src.reset_counts();
        const FrameResult off = render(src, "jin:tau_poid=1");
        CHECK(src.total_count() == 32 * 16);
        CHECK(off.active_fraction == 0);
    }
    SUBCASE("a strong colour edge with the object id off is found by tau_col (test 1)") {
        src.shapes[0].color = Rgb(0.01f);
        src.shapes[1].color = Rgb(1.f);
        const FrameResult c = render(src, "jin:tau_poid=1");
        check_edge_mask(c, 15);
        CHECK(at(c, "test", 14, 5) == 1);
        CHECK(at(c, "attributes", 14, 5) == 0);
    }
}

TEST_CASE("jin: a flat image activates nothing and costs exactly one sample per pixel") {
    SyntheticAttributeSource src(24, 20);
    src.shapes[0].color_dx = Rgb(0.002f, 0.001f, 0.f);
    src.shapes[0].color_dy = Rgb(0.f, 0.002f, 0.001f);
    const FrameResult r = render(src, "jin");
    for (uint32_t y = 0; y < 20; ++y)
        for (uint32_t x = 0; x < 24; ++x) {
            CHECK(src.count(x, y) == 1);
            CHECK(at(r, "active_subpixels", x, y) == 0);
            CHECK(at(r, "test", x, y) == 0);
        }
    CHECK(r.samples == 24 * 20);
    CHECK(r.active_fraction == 0);
    check_colours(r, src, 1e-5f);  // linear shading: the centre is the pixel mean
}

TEST_CASE("jin: tau_poid = 0 supersamples object-id boundaries even when colours match") {
    SyntheticAttributeSource src(24, 8);
    src.shapes.push_back(left_half(9.25f, src.shapes[0].color));  // same colour, object 1
    const FrameResult def = render(src, "jin");
    CHECK(def.active_fraction == 0);          // contrast 0 < 0.05 x (1.36, 1.02, 2.04)
    CHECK(at(def, "attributes", 8, 0) == 1);  // but the id disagreement is seen
    src.reset_counts();
    const FrameResult zero = render(src, "jin:tau_poid=0");
    check_edge_mask(zero, 9);
    CHECK(src.count(8, 4) == 9);
    CHECK(src.count(9, 4) == 9);
    CHECK(src.count(10, 4) == 1);
    CHECK(at(zero, "test", 9, 4) == 2);
}

TEST_CASE("jin: a one-pixel object activates the 3x3 pattern of Fig. 4; weights of 4.1.4") {
    // A tiny bright disc at the centre of pixel (10, 8): only that pixel's presample hits it.
    SyntheticAttributeSource src(24, 16);
    AttrShape d;
    d.kind = AttrShape::Kind::Disc;
    d.cx = 10.5f;
    d.cy = 8.5f;
    d.r = 0.02f;
    d.color = Rgb(100.f);
    src.shapes.push_back(d);
    RecordingSource rec(src);
    const FrameResult r = render(rec, "jin");
    // Subpixel q (bit q; q = qx + 2 qy) of (x, y) compares with (x +- 1, y), (x, y +- 1) and the
    // diagonal on its side; it is active when one of them is (10, 8), or when it is (10, 8).
    for (uint32_t y = 0; y < 16; ++y)
        for (uint32_t x = 0; x < 24; ++x) {
            int expect = 0;
            for (int q = 0; q < 4; ++q) {
                const int dx = (q & 1) ? 1 : -1, dy = (q & 2) ? 1 : -1;
                const int nb[4][2] = {{0, 0}, {dx, 0}, {0, dy}, {dx, dy}};
                for (const auto &o : nb)
                    if (int(x) + o[0] == 10 && int(y) + o[1] == 8)
                        expect |= 1 << q;
            }
            CHECK_MESSAGE(int(at(r, "active_mask", x, y)) == expect, "pixel " << x << "," << y);
        }
    CHECK(at(r, "active_mask", 10, 8) == 15);
    CHECK(at(r, "active_mask", 11, 8) == kLeft);
    CHECK(at(r, "active_mask", 10, 7) == 12);  // lower subpixels
    CHECK(at(r, "active_mask", 9, 7) == 8);    // only the lower right one
    CHECK(r.active_fraction == test::Approx(16.0 / (4 * 24 * 16)));
    CHECK(src.count(10, 8) == 17);
    CHECK(src.count(9, 7) == 5);

    // Fully active: the centre colour (100) gets weight (4 - 4)/4 = 0, each of the 16 extra
    // samples 1/16, so the pixel is exactly their mean.
    const auto s = extra_samples_of(rec, 10, 8);
    REQUIRE(s.size() == 16);
    Rgb mean(0.f);
    std::set<int> cells;
    for (const CameraSample &c : s) {
        mean += src.evaluate(c).radiance * (1.f / 16.f);
        cells.insert(int(c.fx * 4) + 4 * int(c.fy * 4));
    }
    CHECK(cells.size() == 16);  // stratified: one sample in each quarter-pixel cell
    const Rgb got = r.color[8 * 24 + 10];
    for (int l = 0; l < 3; ++l)
        CHECK(got[l] == test::Approx(mean[l]).epsilon(1e-6));
    CHECK(got.r < 50.f);  // the centre colour does not leak in
    // A pixel with one active subpixel: 3/4 centre + the subpixel's 4 samples / 16.
    const auto s97 = extra_samples_of(rec, 9, 7);
    REQUIRE(s97.size() == 4);
    Rgb expect97 = src.evaluate(CameraSample{9, 7, 0.5f, 0.5f, 0}).radiance * 0.75f;
    for (const CameraSample &c : s97)
        expect97 += src.evaluate(c).radiance * (1.f / 16.f);
    CHECK(r.color[7 * 24 + 9].g == test::Approx(expect97.g).epsilon(1e-6));
}

TEST_CASE("jin: a shadow-only edge is caught by the shadow count threshold") {
    // One object; a huge shadow disc whose boundary is nearly vertical near x = 15.25. Shadow
    // factor 0.25 gives a contrast of 0.6 < tau_col x (1.36, 1.02, 2.04) = (0.816, 0.612, 1.22).
    SyntheticAttributeSource src(32, 16);
    src.shadows.push_back({15.25f - 1000.f, 8.f, 1000.f});
    const FrameResult r = render(src, "jin");
    check_edge_mask(r, 15);
    CHECK(at(r, "test", 15, 2) == 2);
    CHECK(at(r, "attributes", 15, 2) == 4);  // bit 2: primary shadow count
    const FrameResult off = render(src, "jin:tau_psc=1");
    CHECK(off.active_fraction == 0);
}

TEST_CASE("jin: surface normals differ when their dot product is below normal_dot") {
    // Two objects of one colour; object ids are turned off so only the normal can pick a
    // threshold, and tau_psn = 0 makes any normal disagreement active.
    SyntheticAttributeSource src(24, 8);
    src.shapes.push_back(left_half(9.25f, src.shapes[0].color));
    src.shapes[1].normal = Vec3f(0.f, 1.f, 0.f);  // 90 degrees from the background's (0, 0, -1)
    const std::string spec = "jin:tau_poid=1,tau_psn=0";
    const FrameResult r = render(src, spec);
    check_edge_mask(r, 9);
    CHECK(at(r, "attributes", 9, 0) == 2);                             // bit 1: primary normal
    src.shapes[1].normal = Vec3f(0.f, 0.3f, -std::sqrt(1.f - 0.09f));  // dot = 0.954
    CHECK(render(src, spec).active_fraction == 0);                     // 0.954 >= 0.9
    check_edge_mask(render(src, spec + ",normal_dot=0.96"), 9);
}

TEST_CASE("jin: secondary object ids and texture existence pick their thresholds") {
    SUBCASE("secondary object id") {
        SyntheticAttributeSource src(24, 8);
        src.shapes[0].reflects = 6;
        src.shapes[0].reflection = Rgb(0.1f);
        AttrShape h = left_half(9.25f, src.shapes[0].color);
        h.reflects = 5;
        h.reflection = Rgb(0.1f);
        src.shapes.push_back(h);
        const FrameResult def = render(src, "jin:tau_poid=1");
        CHECK(def.active_fraction == 0);
        CHECK(at(def, "attributes", 9, 3) == 16);  // bit 4: secondary id
        const FrameResult r = render(src, "jin:tau_poid=1,tau_soid=0");
        check_edge_mask(r, 9);
        CHECK(r.rays[3 * 24 + 9] == float(3 * 9));  // primary + shadow + reflection rays
    }
    SUBCASE("texture existence is set on every textured pixel, regardless of neighbours") {
        SyntheticAttributeSource src(16, 16);
        src.shapes[0].texture_scale = 2;
        const FrameResult all = render(src, "jin:tau_col=1,tau_pte=0");
        CHECK(all.active_fraction == 1);
        CHECK(src.count(7, 7) == 17);
        CHECK(at(all, "attributes", 0, 0) == 8);  // bit 3: primary texture
        src.reset_counts();
        const FrameResult off = render(src, "jin:tau_col=1,tau_pte=1");
        CHECK(off.active_fraction == 0);
        CHECK(src.total_count() == 16 * 16);
    }
}

TEST_CASE("jin: focus restricts geometry attributes to the chosen objects") {
    // Object 1: x < 8.25; object 2: x > 24.25; the background between. Low colour contrast, so
    // only the geometry-selected threshold (tau_poid) finds the edges.
    SyntheticAttributeSource src(32, 8);
    const Rgb c(0.25f, 0.3f, 0.4f);
    src.shapes.push_back(left_half(8.25f, c));
    AttrShape right = left_half(-24.25f, c);
    right.nx = -1;
    src.shapes.push_back(right);
    auto mask_row = [](const FrameResult &r) {
        std::vector<int> m;
        for (uint32_t x = 0; x < r.width; ++x)
            m.push_back(int(at(r, "active_mask", x, 4)));
        return m;
    };
    std::vector<int> both(32, 0), only2(32, 0), only1(32, 0), tau0(32, 0);
    both[7] = only1[7] = kRight;
    both[8] = only1[8] = kLeft;
    both[23] = only2[23] = kRight;
    both[24] = only2[24] = kLeft;
    CHECK(mask_row(render(src, "jin")) == both);
    CHECK(mask_row(render(src, "jin:focus=2")) == only2);
    CHECK(mask_row(render(src, "jin:focus=1")) == only1);
    CHECK(mask_row(render(src, "jin:focus=1,focus_count=2")) == both);
    CHECK(at(render(src, "jin:focus=2"), "attributes", 8, 4) == 0);

    // focus_tau = 0 with the object id off: every subpixel whose pixel or one of its three
    // neighbours hit object 2 is supersampled (column 23's right half sees column 24).
    for (uint32_t x = 24; x < 32; ++x)
        tau0[x] = 15;
    tau0[23] = kRight;
    const FrameResult f = render(src, "jin:focus=2,focus_tau=0,tau_poid=1");
    CHECK(mask_row(f) == tau0);
    CHECK(at(f, "test", 28, 4) == 3);
    CHECK(at(f, "test", 10, 4) == 0);
}

TEST_CASE("jin: bilinear filtering of inactive subpixels (section 6 option)") {
    SyntheticAttributeSource src(16, 16);
    src.shapes[0].texture_scale = 3;
    const FrameResult r = render(src, "jin:tau_col=1,tau_pte=1,bilinear=1");
    REQUIRE(r.active_fraction == 0);
    auto centre = [&](int x, int y) {
        return src.shade(src.attributes_at(float(x) + 0.5f, float(y) + 0.5f));
    };
    const int x = 6, y = 9;
    const Rgb expect =
        centre(x, y) * (9.f / 16.f) +
        (centre(x - 1, y) + centre(x + 1, y) + centre(x, y - 1) + centre(x, y + 1)) * (3.f / 32.f) +
        (centre(x - 1, y - 1) + centre(x + 1, y - 1) + centre(x - 1, y + 1) +
         centre(x + 1, y + 1)) *
            (1.f / 64.f);
    CHECK(r.color[size_t(y) * 16 + x].r == test::Approx(expect.r).epsilon(1e-6));
    // On linear shading it is exact inside the image.
    SyntheticAttributeSource ramp(16, 16);
    ramp.shapes[0].color_dx = Rgb(0.01f, 0.f, 0.005f);
    ramp.shapes[0].color_dy = Rgb(0.f, 0.01f, 0.005f);
    const FrameResult lr = render(ramp, "jin:bilinear=1");
    for (uint32_t py = 1; py < 15; ++py)
        for (uint32_t px = 1; px < 15; ++px)
            CHECK(lr.color[py * 16 + px].g == test::Approx(ramp.ground_truth(px, py).g));
}

TEST_CASE("jin: active subpixels are packed per tile before the extra sampling") {
    SyntheticAttributeSource src(40, 24);
    for (int k = 0; k < 5; ++k) {
        AttrShape d;
        d.kind = AttrShape::Kind::Disc;
        d.cx = 5.f + 7.3f * float(k);
        d.cy = 4.f + 3.9f * float(k);
        d.r = 2.5f + float(k);
        d.color = Rgb(0.9f, 0.2f * float(k), 0.5f);
        src.shapes.push_back(d);
    }
    RecordingSource rec(src);
    const FrameResult r = render(rec, "jin", 1);
    uint64_t extra = 0, presample = 0;
    // Batches in call order (one thread): a tile's presample batch, later its extra batches.
    int last_tile = -1;
    std::vector<size_t> tile_sizes;
    auto check_tile = [&] {
        for (size_t k = 0; k + 1 < tile_sizes.size(); ++k)
            CHECK(tile_sizes[k] == 64);
        tile_sizes.clear();
    };
    for (const auto &b : rec.batches) {
        REQUIRE(!b.empty());
        const int tile = int(b[0].px / 8) + 100 * int(b[0].py / 8);
        for (const CameraSample &c : b)
            CHECK(int(c.px / 8) + 100 * int(c.py / 8) == tile);
        if (b[0].index == 0) {
            presample += b.size();
            for (const CameraSample &c : b)
                CHECK((c.index == 0 && c.fx == 0.5f && c.fy == 0.5f));
            continue;
        }
        if (tile != last_tile)
            check_tile();
        last_tile = tile;
        tile_sizes.push_back(b.size());
        REQUIRE(b.size() % 4 == 0);
        // Only active subpixels, in pixel order, four stratified samples each.
        for (size_t k = 0; k < b.size(); k += 4) {
            const uint32_t q = (b[k].index - 1) / 4;
            CHECK((int(at(r, "active_mask", b[k].px, b[k].py)) & (1 << q)) != 0);
            for (uint32_t s = 0; s < 4; ++s) {
                CHECK(b[k + s].px == b[k].px);
                CHECK(b[k + s].index == 1 + 4 * q + s);
            }
            if (k > 0) {
                const auto key = [](const CameraSample &c) {
                    return (uint64_t(c.py) * 40 + c.px) * 32 + c.index;
                };
                CHECK(key(b[k - 4]) < key(b[k]));
            }
        }
        extra += b.size();
    }
    check_tile();
    CHECK(presample == 40 * 24);
    double active = 0;
    for (float v : layer(r, "active_subpixels"))
        active += v;
    CHECK(active > 20);
    CHECK(extra == uint64_t(4 * active));
    CHECK(r.samples == presample + extra);
}

TEST_CASE("jin: frames are bit-identical for 1 and 3 threads") {
    // Image size not a multiple of the tile: edge tiles of every shape. Textures, thin lines,
    // shadows, reflections and linear shading together.
    SyntheticAttributeSource src(45, 30);
    src.shapes[0].color_dx = Rgb(0.01f, 0.f, 0.f);
    AttrShape d;
    d.kind = AttrShape::Kind::Disc;
    d.cx = 14;
    d.cy = 12;
    d.r = 9;
    d.texture_scale = 2.5f;
    d.color = Rgb(0.8f, 0.6f, 0.2f);
    src.shapes.push_back(d);
    AttrShape line;
    line.kind = AttrShape::Kind::Line;
    line.nx = 0.6f;
    line.ny = 0.8f;
    line.d = 30;
    line.width = 0.4f;
    line.color = Rgb(0.1f, 0.9f, 0.1f);
    src.shapes.push_back(line);
    AttrShape mirror = left_half(-32.f, Rgb(0.1f));
    mirror.nx = -1;
    mirror.reflects = 1;
    mirror.reflection = Rgb(0.3f, 0.3f, 0.5f);
    mirror.normal = Vec3f(0, 1, 0);
    src.shapes.push_back(mirror);
    src.shadows.push_back({30, 8, 5});
    for (const char *spec : {"jin", "jin:focus=1,focus_tau=0.2,bilinear=1,seed=7"}) {
        CAPTURE(spec);
        const FrameResult a = render(src, spec, 1), b = render(src, spec, 3);
        REQUIRE(a.color.size() == b.color.size());
        CHECK(std::memcmp(a.color.data(), b.color.data(), a.color.size() * sizeof(Rgb)) == 0);
        CHECK(a.rays == b.rays);
        REQUIRE(a.diagnostics.size() == b.diagnostics.size());
        for (size_t k = 0; k < a.diagnostics.size(); ++k)
            CHECK(a.diagnostics[k].data == b.diagnostics[k].data);
        CHECK(a.samples == b.samples);
        CHECK(a.rays_total == b.rays_total);
        CHECK(a.active_fraction > 0);
        CHECK(a.active_fraction < 0.5);
    }
    // The same plugin object renders the same frame twice.
    sampling::PluginSpec ps = sampling::parse_plugin_spec("jin");
    auto sampler = ps.info->make(ps.params);
    sched::FrameScheduler scheduler(sched::FrameOptions{2});
    FrameResult f1, f2;
    scheduler.render(*sampler, src, f1);
    scheduler.render(*sampler, src, f2);
    CHECK(std::memcmp(f1.color.data(), f2.color.data(), f1.color.size() * sizeof(Rgb)) == 0);
}

TEST_CASE("jin: a cancelled frame reports no stale pixels of the previous frame") {
    SyntheticAttributeSource src(24, 16);
    src.shapes.push_back(left_half(9.25f, Rgb(1.f)));
    sampling::PluginSpec ps = sampling::parse_plugin_spec("jin");
    auto sampler = ps.info->make(ps.params);
    sched::FrameScheduler scheduler(sched::FrameOptions{2});
    FrameResult r;
    scheduler.render(*sampler, src, r);
    CHECK(r.samples > 24 * 16);
    const std::atomic<bool> cancel{true};
    CHECK(scheduler.render(*sampler, src, r, &cancel).cancelled);
    CHECK(r.samples == 0);
    CHECK(r.rays_total == 0);
    CHECK(r.active_fraction == 0);
    CHECK(r.color[3].g == 0);
    scheduler.render(*sampler, src, r);  // and the next frame is whole again
    check_colours(r, src, 1e-5f);
}

TEST_CASE("jin: parameters, the paper's defaults, and stage names") {
    const sampling::PluginSpec def = sampling::parse_plugin_spec("jin");
    REQUIRE(def.info != nullptr);
    CHECK(def.info->kind == sampling::PluginKind::Frame);
    // Table 2: tau_alpha = tau_col = tau_pte = tau_ste = 0.6; caption: tau_poid = tau_soid =
    // 0.05, tau_psn = tau_ssn = 0.06, tau_psc = tau_ssc = 0.06.
    CHECK(def.params.get("tau_col") == 0.6);
    CHECK(def.params.get("tau_pte") == 0.6);
    CHECK(def.params.get("tau_ste") == 0.6);
    CHECK(def.params.get("tau_poid") == 0.05);
    CHECK(def.params.get("tau_soid") == 0.05);
    CHECK(def.params.get("tau_psn") == 0.06);
    CHECK(def.params.get("tau_ssn") == 0.06);
    CHECK(def.params.get("tau_psc") == 0.06);
    CHECK(def.params.get("tau_ssc") == 0.06);
    CHECK(def.params.get("normal_dot") == 0.9);
    CHECK(def.params.get("focus") == -1);
    CHECK(def.params.get("focus_tau") == 1);
    CHECK(def.params.get("bilinear") == 0);

    const sampling::PluginSpec s = sampling::parse_plugin_spec("jin:tau-poid=0,tau_col=0.3");
    CHECK(s.params.get("tau_poid") == 0);
    CHECK(s.params.get("tau_col") == 0.3);
    CHECK_THROWS_AS(sampling::parse_plugin_spec("jin:tau_col=1.5"), std::invalid_argument);
    CHECK_THROWS_AS(sampling::parse_plugin_spec("jin:tau_oid=0.1"), std::invalid_argument);
    CHECK_THROWS_AS(sampling::parse_plugin_spec("jin:focus=1.5"), std::invalid_argument);

    auto make_error = [](const std::string &spec) -> std::string {
        const sampling::PluginSpec p = sampling::parse_plugin_spec(spec);
        try {
            p.info->make(p.params);
        } catch (const std::invalid_argument &e) {
            return e.what();
        }
        return "";
    };
    for (const char *key : {"focus_tau", "focus_count"}) {
        const std::string e = make_error(std::string("jin:") + key + "=1");
        CHECK(e.find("jin") != std::string::npos);
        CHECK(e.find(key) != std::string::npos);
    }
    CHECK(make_error("jin:focus=2147483647,focus_count=2").find("focus_count") !=
          std::string::npos);
    CHECK(make_error("jin:focus=3,focus_tau=0.2,focus_count=2") == "");

    auto sampler = def.info->make(def.params);
    CHECK(sampler->stage_count() == 3);
    CHECK(sampler->stage_name(0) == "presample");
    CHECK(sampler->stage_name(1) == "test");
    CHECK(sampler->stage_name(2) == "supersample");
}
