// pbrt-v4's procedural noise (renderer/util/noise.h) and the noise textures built on it: values at
// fixed points, computed by hand-following pbrt-v4's float operations (a float32 emulation of
// its source, independent of this code), and the properties the values must have whatever
// their digits: zeros on the lattice, the period 256, the band limit of the footprint.
#include <doctest/doctest.h>

#include <cmath>

#include "approx.h"
#include "renderer/util/noise.h"
#include "renderer/shading/texture.h"
#include "texture_test_util.h"

using namespace tessera;

TEST_CASE("noise: pbrt-v4's values, zeros on the lattice, period 256") {
    CHECK(perlin_noise(0.5f, 0.5f, 0.5f) == -0.125f);
    CHECK(perlin_noise(0.25f, 0.75f, 0.1f) == test::Approx(-0.0632028878).epsilon(1e-5));
    CHECK(perlin_noise(1.3f, -2.7f, 3.9f) == test::Approx(0.0620817542).epsilon(1e-5));
    CHECK(perlin_noise(-0.6f, 0.2f, -1.45f) == test::Approx(0.295568317).epsilon(1e-5));
    CHECK(perlin_noise(10.1f, 20.2f, 30.3f) == test::Approx(-0.424981177).epsilon(1e-5));
    CHECK(perlin_noise(123.456f, -78.9f, 0.001f) == test::Approx(0.0904424712).epsilon(1e-4));
    // The two-argument form is at z = 0.5.
    CHECK(perlin_noise(0.3f, 0.6f) == perlin_noise(0.3f, 0.6f, 0.5f));
    for (int i = -3; i < 4; ++i) {
        CHECK(perlin_noise(float(i), float(2 * i), float(-i)) == 0.f);
        // (0.375 keeps the offset in the cell exact after adding 256.)
        CHECK(perlin_noise(0.375f + float(i), 1.625f, 2.5f) ==
              perlin_noise(0.375f + float(i) + 256.f, 1.625f, 2.5f));
    }
    // Bounded, and continuous across cell faces.
    float worst = 0.f;
    for (int i = 0; i < 1000; ++i) {
        float x = 0.0137f * float(i) - 3.f;
        worst = std::max(worst, std::abs(perlin_noise(x, 0.3f * x, 1.7f)));
    }
    CHECK(worst < 1.f);
    // Coordinates beyond float's range give 0, not undefined behaviour; huge finite ones wrap.
    CHECK(perlin_noise(INFINITY, 0.f, 0.f) == 0.f);
    CHECK(perlin_noise(NAN, 0.f, 0.f) == 0.f);
    CHECK(std::isfinite(perlin_noise(3e30f, -2e20f, 1e9f)));
    CHECK(fbm(Vec3f(0.1f, 0.2f, 0.3f), Vec3f(NAN, 0.f, 0.f), Vec3f(0.f, 0.f, 0.f), 0.5f, 8) == 0.f);
    CHECK(std::abs(perlin_noise(0.9999f, 0.4f, 0.6f) - perlin_noise(1.0001f, 0.4f, 0.6f)) < 1e-3f);
}

TEST_CASE("noise: fBm and turbulence, full band and band-limited by the footprint") {
    const Vec3f zero(0.f, 0.f, 0.f), dx(0.01f, 0.f, 0.f);
    struct Case {
        Vec3f p;
        double fbm_full, turb_full, fbm_limited, turb_limited;
    };
    const Case cases[] = {
        {{0.25f, 0.75f, 0.1f}, 0.225766793, 0.362411022, 0.225091159, 0.369271666},
        {{1.3f, -2.7f, 3.9f}, 0.0132555589, 0.16333504, 0.0123343552, 0.169455841},
        {{-0.6f, 0.2f, -1.45f}, 0.273971885, 0.348633379, 0.281661242, 0.351435125},
    };
    for (const Case &c : cases) {
        CAPTURE(c.p.x);
        CHECK(fbm(c.p, zero, zero, 0.5f, 8) == test::Approx(c.fbm_full).epsilon(1e-4));
        CHECK(turbulence(c.p, zero, zero, 0.5f, 8) == test::Approx(c.turb_full).epsilon(1e-5));
        CHECK(fbm(c.p, dx, zero, 0.5f, 8) == test::Approx(c.fbm_limited).epsilon(1e-4));
        CHECK(turbulence(c.p, dx, zero, 0.5f, 8) == test::Approx(c.turb_limited).epsilon(1e-5));
    }
    // A footprint of a whole cell or more leaves no octave: fBm fades to 0, turbulence to the
    // average 0.2 per octave. pbrt-v4 adds the faded partial octave's 0.2 and then 0.2 for each
    // of the eight clamped octaves, the first at the same weight 1: 0.2 + 0.2 (1 - 0.5^8) / 0.5.
    const Vec3f big(2.f, 0.f, 0.f), p(0.3f, 0.7f, 0.2f);
    CHECK(fbm(p, big, big, 0.5f, 8) == 0.f);
    CHECK(turbulence(p, big, big, 0.5f, 8) ==
          test::Approx(0.2 + 0.2 * (1 - std::pow(0.5, 8)) / 0.5).epsilon(1e-6));
}

namespace {

TextureEvalContext at_point(Vec3f p) {
    TextureEvalContext c;
    c.p = p;
    return c;
}

}  // namespace

TEST_CASE("noise textures: fbm, wrinkled, windy and marble in the Texture statement's space") {
    // Texture space is the object space of the Texture statement: scaled by 2 here, so the
    // texture at render point 2 p is the noise at p.
    Transform scale2 = Transform::scale(2.f, 2.f, 2.f);
    std::vector<TextureDesc> descs = {
        test::desc("f", "float", "fbm", {test::num("integer", "octaves", {8})}),
        test::desc("w", "float", "wrinkled", {test::num("float", "roughness", {0.5})}),
        test::desc("wind", "float", "windy"),
        test::desc("m", "spectrum", "marble"),
    };
    descs[0].render_from_texture = scale2;
    TextureSet set(descs);
    const Vec3f p(0.25f, 0.75f, 0.1f);
    CHECK(set.get_float("f")->evaluate(at_point(p * 2.f)) ==
          test::Approx(0.225766793).epsilon(1e-4));
    CHECK(set.get_float("w")->evaluate(at_point(p)) == test::Approx(0.362411022).epsilon(1e-5));
    CHECK(set.get_float("wind")->evaluate(at_point(p)) == test::Approx(0.0129190646).epsilon(1e-3));
    CHECK(set.get_float("wind")->evaluate(at_point({1.3f, -2.7f, 3.9f})) ==
          test::Approx(0.00748719322).epsilon(1e-3));
    Rgb m = set.get_spectrum("m")->evaluate(at_point(p));
    CHECK(m.r == test::Approx(0.840448976).epsilon(1e-4));
    CHECK(m.b == test::Approx(0.879003406).epsilon(1e-4));
    Rgb m2 = set.get_spectrum("m")->evaluate(at_point({-0.6f, 0.2f, -1.45f}));
    CHECK(m2.g == test::Approx(0.870283246).epsilon(1e-4));
    // The footprint goes through the texture transform too: a render-space dpdx of 0.02 is 0.01
    // in texture space, which leaves 5.64 octaves.
    TextureEvalContext c = at_point(p * 2.f);
    c.dpdx = Vec3f(0.02f, 0.f, 0.f);
    CHECK(set.get_float("f")->evaluate(c) == test::Approx(0.225091159).epsilon(1e-4));
    // pbrt-v4 has no spectrum fbm and no float marble.
    CHECK_THROWS_AS(TextureSet({test::desc("x", "spectrum", "fbm")}), SceneError);
    CHECK_THROWS_AS(TextureSet({test::desc("x", "float", "marble")}), SceneError);
    CHECK_THROWS_AS(
        TextureSet({test::desc("x", "float", "fbm", {test::num("integer", "octaves", {-1})})}),
        SceneError);
}

TEST_CASE("noise textures: dots, with pbrt-v4's inside and outside") {
    TextureSet set(
        {test::desc("d", "float", "dots",
                    {test::num("float", "inside", {0.25}), test::num("float", "outside", {0.75})}),
         test::desc("plain", "spectrum", "dots")});
    auto at_st = [](float s, float t) {
        TextureEvalContext c;
        c.uv = {s, t};
        return c;
    };
    // Cells with a dot at st: (0.1, 2.05), (5, 5), (2, 3); none at (0, 0), (1, 0), (3.02, -1.1),
    // (-2, 7), (4, 1). pbrt-v4 shows "outside" in the dots and "inside" elsewhere.
    for (Vec2f st : {Vec2f(0.1f, 2.05f), Vec2f(5.f, 5.f), Vec2f(2.f, 3.f)})
        CHECK(set.get_float("d")->evaluate(at_st(st.x, st.y)) == 0.75f);
    for (Vec2f st :
         {Vec2f(0.f, 0.f), Vec2f(1.f, 0.f), Vec2f(3.02f, -1.1f), Vec2f(-2.f, 7.f), Vec2f(4.f, 1.f)})
        CHECK(set.get_float("d")->evaluate(at_st(st.x, st.y)) == 0.25f);
    // Defaults: 0 in the dots, 1 elsewhere; about a fifth of the plane is dots (half the cells
    // hold one, of area pi 0.35^2 each).
    int in_dots = 0, n = 0;
    for (int i = 0; i < 200; ++i)
        for (int j = 0; j < 200; ++j, ++n)
            in_dots += set.get_spectrum("plain")->evaluate(at_st(0.05f * i, 0.05f * j)).g == 0.f;
    CHECK(double(in_dots) / n > 0.1);
    CHECK(double(in_dots) / n < 0.3);
}

TEST_CASE("noise textures: parameters are read (octaves, scale, variation, the dots mapping)") {
    TextureSet set(
        {test::desc("f2", "float", "fbm", {test::num("integer", "octaves", {2})}),
         test::desc("w3", "float", "wrinkled", {test::num("float", "roughness", {0.3})}),
         test::desc("flat", "spectrum", "marble",
                    {test::num("float", "variation", {0.0}), test::num("float", "scale", {2.0})}),
         test::desc("d1", "float", "dots"),
         test::desc("d2", "float", "dots", {test::num("float", "uscale", {2.0})})});
    const Vec3f p(0.25f, 0.75f, 0.1f), zero(0.f, 0.f, 0.f);
    CHECK(set.get_float("f2")->evaluate(at_point(p)) == fbm(p, zero, zero, 0.5f, 2));
    CHECK(set.get_float("f2")->evaluate(at_point(p)) != fbm(p, zero, zero, 0.5f, 8));
    CHECK(set.get_float("w3")->evaluate(at_point(p)) == turbulence(p, zero, zero, 0.3f, 8));
    // Without variation, marble is sin(scale y) through the colour spline, whose segment ends
    // are pbrt-v4's colours times 1.5: sin -1, 0, 1 give colours 0, 3 and 8.
    auto marble_at_y = [&](float y) {
        return set.get_spectrum("flat")->evaluate(at_point({0.3f, y, 0.2f}));
    };
    Rgb top = marble_at_y(0.25f * kPi), mid = marble_at_y(0.f), bottom = marble_at_y(-0.25f * kPi);
    CHECK(top.r == test::Approx(1.5 * 0.58).epsilon(1e-5));
    CHECK(top.b == test::Approx(1.5 * 0.60).epsilon(1e-5));
    CHECK(mid.g == test::Approx(1.5 * 0.50).epsilon(1e-5));
    CHECK(bottom.r == test::Approx(1.5 * 0.58).epsilon(1e-4));
    CHECK(bottom.b == test::Approx(1.5 * 0.60).epsilon(1e-4));
    // uscale 2 at u is the plain dots at 2u.
    auto at_st = [](float s, float t) {
        TextureEvalContext c;
        c.uv = {s, t};
        return c;
    };
    int differ = 0;
    for (int i = 0; i < 400; ++i) {
        float u = 0.0371f * float(i), v = 0.0173f * float(i);
        CHECK(set.get_float("d2")->evaluate(at_st(u, v)) ==
              set.get_float("d1")->evaluate(at_st(2.f * u, v)));
        differ += set.get_float("d2")->evaluate(at_st(u, v)) !=
                  set.get_float("d1")->evaluate(at_st(u, v));
    }
    CHECK(differ > 0);
    // No dot beyond int's range, and no undefined conversion on the way.
    CHECK(set.get_float("d1")->evaluate(at_st(3e9f, 1.f)) == 1.f);
    CHECK(set.get_float("d1")->evaluate(at_st(NAN, 1.f)) == 1.f);
}
