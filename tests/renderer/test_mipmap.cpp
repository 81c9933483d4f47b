// MipMap (renderer/shading/mipmap.h): the pyramid (power-of-two resampling, box levels), and
// the point, bilinear, trilinear and EWA lookups against values computed by hand.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "approx.h"
#include "renderer/shading/mipmap.h"

using namespace tessera;

namespace {

float mean(const std::vector<float> &v) {
    double s = 0;
    for (float x : v) s += x;
    return float(s / double(v.size()));
}

/// A w x h one-channel image from f(x, y).
template <class F>
std::vector<float> image(int w, int h, F f) {
    std::vector<float> px(size_t(w) * size_t(h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) px[size_t(y) * size_t(w) + size_t(x)] = f(x, y);
    return px;
}

float lookup(const MipMap &m, float s, float t, float ds0 = 0, float dt0 = 0, float ds1 = 0,
             float dt1 = 0) {
    float v[MipMap::kMaxChannels];
    m.filter({s, t}, {ds0, dt0}, {ds1, dt1}, v);
    return v[0];
}

}  // namespace

TEST_CASE("mipmap: levels are 2x2 box averages down to 1x1") {
    std::vector<float> px = image(8, 4, [](int x, int y) { return float(x + 10 * y); });
    const float m = mean(px);
    MipMap mm(8, 4, 1, px, MipWrap::Repeat, MipFilter::Bilinear);
    REQUIRE(mm.levels() == 4);
    CHECK(mm.level_width(1) == 4);
    CHECK(mm.level_height(1) == 2);
    CHECK(mm.level_width(3) == 1);
    CHECK(mm.level_height(3) == 1);
    float v;
    mm.texel(1, 0, 0, &v);
    CHECK(v == test::Approx((0 + 1 + 10 + 11) / 4.f));
    mm.texel(3, 0, 0, &v);
    CHECK(v == test::Approx(m));  // every level keeps the mean
    CHECK(mm.bytes() == MipMap::pyramid_bytes(8, 4, 1));
}

TEST_CASE("mipmap: non-power-of-two images are resampled up, preserving constants and the mean") {
    // A constant stays constant through the windowed-sinc resampling (normalised weights).
    MipMap c(5, 3, 3, std::vector<float>(5 * 3 * 3, 0.25f), MipWrap::Clamp, MipFilter::Bilinear);
    CHECK(c.level_width(0) == 8);
    CHECK(c.level_height(0) == 4);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 8; ++x) {
            float v[3];
            c.texel(0, x, y, v);
            CHECK(v[0] == test::Approx(0.25f).epsilon(1e-5));
            CHECK(v[2] == test::Approx(0.25f).epsilon(1e-5));
        }
    // A smooth periodic ramp keeps its mean within the resampling's ripple.
    std::vector<float> px = image(
        100, 60, [](int x, int y) { return 1.f + 0.5f * std::sin(6.2831853f * x / 100.f) * std::cos(6.2831853f * y / 60.f); });
    MipMap r(100, 60, 1, px, MipWrap::Repeat, MipFilter::Trilinear);
    CHECK(r.level_width(0) == 128);
    CHECK(r.level_height(0) == 64);
    CHECK(r.levels() == 8);
    float top;
    r.texel(r.levels() - 1, 0, 0, &top);
    CHECK(top == test::Approx(mean(px)).epsilon(1e-3));
    // Upsampling interpolates: the resampled ramp follows the continuous function.
    float v;
    r.texel(0, 32, 16, &v);
    const float sx = (32 + 0.5f) * 100.f / 128.f - 0.5f, sy = (16 + 0.5f) * 60.f / 64.f - 0.5f;
    CHECK(v == test::Approx(1.f + 0.5f * std::sin(6.2831853f * sx / 100.f) *
                                      std::cos(6.2831853f * sy / 60.f))
                   .epsilon(2e-3));
}

TEST_CASE("mipmap: bilinear and point lookups on level 0, wrap modes") {
    // 4 x 2: row 0 = 0 1 2 3, row 1 = 10 11 12 13.
    std::vector<float> px = image(4, 2, [](int x, int y) { return float(x + 10 * y); });
    MipMap rep(4, 2, 1, px, MipWrap::Repeat, MipFilter::Bilinear);
    MipMap blk(4, 2, 1, px, MipWrap::Black, MipFilter::Bilinear);
    MipMap clp(4, 2, 1, px, MipWrap::Clamp, MipFilter::Bilinear);
    MipMap pt(4, 2, 1, px, MipWrap::Repeat, MipFilter::Point);
    // Texel centres at ((i + 0.5) / 4, (j + 0.5) / 2).
    CHECK(lookup(rep, 0.375f, 0.25f) == test::Approx(1.f));
    CHECK(lookup(rep, 0.375f, 0.75f) == test::Approx(11.f));
    // Half way between centres, and a quarter.
    CHECK(lookup(rep, 0.5f, 0.25f) == test::Approx(1.5f));
    CHECK(lookup(rep, 0.5f, 0.5f) == test::Approx((1 + 2 + 11 + 12) / 4.f));
    CHECK(lookup(rep, 0.4375f, 0.25f) == test::Approx(1.25f));
    // At the left edge (s = 0): repeat blends texel 3 and 0, black blends 0 and 0, clamp
    // repeats texel 0.
    CHECK(lookup(rep, 0.f, 0.25f) == test::Approx(1.5f));
    CHECK(lookup(blk, 0.f, 0.25f) == test::Approx(0.f));
    CHECK(lookup(clp, 0.f, 0.25f) == test::Approx(0.f));
    CHECK(lookup(blk, 1.f, 0.25f) == test::Approx(1.5f));  // (3 + 0) / 2
    CHECK(lookup(clp, 1.f, 0.25f) == test::Approx(3.f));
    CHECK(lookup(rep, 1.375f, 0.25f) == test::Approx(1.f));
    // Point: the nearest texel.
    CHECK(lookup(pt, 0.3f, 0.2f) == 1.f);
    CHECK(lookup(pt, 0.9f, 0.9f) == 13.f);
    CHECK(lookup(pt, -0.1f, 0.2f) == 3.f);
    // Non-finite coordinates give a finite value.
    CHECK(std::isfinite(lookup(rep, std::nanf(""), 0.5f)));
}

TEST_CASE("mipmap: the footprint width selects the level; trilinear blends two") {
    // 16 x 16 checkerboard of single texels: level 0 alternates 0 / 1, level 1 and up are 1/2.
    std::vector<float> px = image(16, 16, [](int x, int y) { return float((x + y) & 1); });
    MipMap bl(16, 16, 1, px, MipWrap::Repeat, MipFilter::Bilinear);
    MipMap tri(16, 16, 1, px, MipWrap::Repeat, MipFilter::Trilinear);
    const float s = 2.5f / 16, t = 3.5f / 16;  // the centre of texel (2, 3): value 1
    // A tiny footprint: level 0.
    CHECK(lookup(bl, s, t, 1e-4f, 0, 0, 1e-4f) == test::Approx(1.f));
    CHECK(lookup(tri, s, t, 1e-4f, 0, 0, 1e-4f) == test::Approx(1.f));
    // width = 2 * max |d| = 1/8 -> level = 4 + log2(1/8) = 1: level 1 is 1/2 everywhere.
    CHECK(lookup(bl, s, t, 1.f / 16, 0, 0, 1.f / 16) == test::Approx(0.5f));
    // Between levels 0 and 1 (width 3/32: level 0.58) trilinear keeps level 0 (pbrt-v4);
    // between 1 and 2 it blends (both 1/2 here).
    CHECK(lookup(tri, s, t, 3.f / 64, 0, 0, 3.f / 64) == test::Approx(1.f));
    CHECK(lookup(tri, s, t, 3.f / 32, 0, 0, 3.f / 32) == test::Approx(0.5f));
    // A blend of two different levels: a ramp whose level 1 differs from level 2 at a point.
    std::vector<float> ramp = image(16, 16, [](int x, int) { return float(x * x); });
    MipMap tr(16, 16, 1, ramp, MipWrap::Clamp, MipFilter::Trilinear);
    float b1, b2;
    tr.bilerp(1, {0.3f, 0.5f}, &b1);
    tr.bilerp(2, {0.3f, 0.5f}, &b2);
    REQUIRE(b1 != test::Approx(b2));
    // width 2^(l - 4) at l = 1.25.
    const float d = 0.5f * std::exp2(1.25f - 4.f);
    CHECK(lookup(tr, 0.3f, 0.5f, d, 0, 0, d) == test::Approx(0.75f * b1 + 0.25f * b2).epsilon(1e-4));
    // Wider than the image: the 1x1 level, the mean.
    CHECK(lookup(bl, s, t, 2.f, 0, 0, 2.f) == test::Approx(mean(px)));
}

TEST_CASE("mipmap: EWA is a normalised average over the footprint ellipse") {
    // A constant image: every footprint returns the constant.
    MipMap c(32, 32, 3, std::vector<float>(32 * 32 * 3, 0.7f), MipWrap::Repeat, MipFilter::Ewa);
    for (float d : {1e-4f, 0.01f, 0.05f, 0.3f}) {
        float v[3];
        c.filter({0.31f, 0.77f}, {d, 0.2f * d}, {-0.3f * d, 0.5f * d}, v);
        CHECK(v[0] == test::Approx(0.7f).epsilon(1e-5));
        CHECK(v[1] == test::Approx(0.7f).epsilon(1e-5));
    }
    // Stripes along t (value = x & 1): a footprint long along t and a texel wide in s keeps
    // the stripe's value near its centre; one long along s averages the stripes to 1/2.
    std::vector<float> px = image(64, 64, [](int x, int) { return float((x / 4) & 1); });
    MipMap e(64, 64, 1, px, MipWrap::Repeat, MipFilter::Ewa, 8.f);
    const float s = (4 * 5 + 2.f) / 64, t = 0.5f;  // in stripe 5 (value 1)
    CHECK(lookup(e, s, t, 0.5f / 64, 0, 0, 4.f / 64) == test::Approx(1.f).epsilon(0.02));
    CHECK(lookup(e, s, t, 16.f / 64, 0, 0, 0.5f / 64) == test::Approx(0.5f).epsilon(0.05));
    // A degenerate footprint (one derivative zero) falls back to bilinear on level 0.
    float bl;
    e.bilerp(0, {s, t}, &bl);
    CHECK(lookup(e, s, t, 0.1f, 0, 0, 0) == test::Approx(bl));
    // Far wider than the image: the mean.
    CHECK(lookup(e, s, t, 8.f, 0, 0, 8.f) == test::Approx(mean(px)).epsilon(1e-4));
}

TEST_CASE("mipmap: pyramid sizes and bad input") {
    CHECK(MipMap::pyramid_bytes(1, 1, 3) == 12);
    CHECK(MipMap::pyramid_bytes(4, 4, 1) == (16 + 4 + 1) * 4);
    CHECK(MipMap::pyramid_bytes(3, 1, 1) == (4 + 2 + 1) * 4);  // resampled to 4 x 1 first
    CHECK_THROWS(MipMap(2, 2, 1, std::vector<float>(3), MipWrap::Repeat, MipFilter::Bilinear));
    CHECK_THROWS(MipMap(0, 2, 1, {}, MipWrap::Repeat, MipFilter::Bilinear));
    CHECK_THROWS(MipMap(1, 1, 5, std::vector<float>(5), MipWrap::Repeat, MipFilter::Bilinear));
}
