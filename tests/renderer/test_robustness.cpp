// Robustness (docs/ARCHITECTURE.md, "Invariants worth a test each"): odd but legal scenes render finite
// values without crashing, bad values are rejected with file:line, and max depth 0 / 1 give
// exactly emission only / direct light only.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/input/scene_desc.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

/// Small render settings for fast tests.
SceneOverrides small(int res = 16, int spp = 4) {
    SceneOverrides ov;
    ov.width = ov.height = res;
    ov.spp = spp;
    ov.seed = 1;
    return ov;
}

/// Every value is finite and no sample was dropped for NaN/Inf.
void check_finite(const sampling::RgbImage &img, const sched::AdaptiveStats &st) {
    CHECK(st.nan_samples == 0);
    size_t bad = 0;
    for (float v : img.data)
        if (!std::isfinite(v) || v < 0.f) ++bad;
    CHECK_MESSAGE(bad == 0, bad << " non-finite or negative values");
}

/// Renders on 2 threads and checks that no sample was dropped and every value is finite.
sampling::RgbImage render_checked(const Scene &scene) {
    sched::AdaptiveStats st;
    sampling::RgbImage img = render_image(scene, 2, &st);
    check_finite(img, st);
    return img;
}

double image_max(const sampling::RgbImage &img) {
    double m = 0;
    for (float v : img.data) m = std::max(m, double(v));
    return m;
}

/// The SceneError message of parsing + building `text`, "" if none was thrown.
std::string scene_error(const std::string &text) {
    try {
        scene_from_string(text, small());
    } catch (const SceneError &e) {
        return e.what();
    }
    return "";
}

const char *kCamera = R"(
LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" [ 60 ]
PixelFilter "box"
)";

}  // namespace

TEST_CASE("robustness: zero-area triangles render finite values and never emit") {
    std::unique_ptr<Scene> sc = scene_from_string(std::string(kCamera) + R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 0 ] "rgb I" [ 5 5 5 ]
# A collinear triangle and one with a repeated vertex, in the middle of the view.
Shape "trianglemesh" "point3 P" [ -1 0 2  0 0 2  1 0 2  0 1 2 ]
    "integer indices" [ 0 1 2  0 3 3 ]
# An emissive degenerate triangle: no light may be made from it (its pdf would divide by 0).
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 10 10 10 ]
  Shape "trianglemesh" "point3 P" [ -1 -1 2.5  0 -1 2.5  1 -1 2.5 ]
AttributeEnd
Shape "trianglemesh" "point3 P" [ -4 -4 3  4 -4 3  4 4 3  -4 4 3 ]
    "integer indices" [ 0 1 2  0 2 3 ]
)",
                                                  small());
    CHECK(sc->lights.size() == 1);  // the point light only
    sched::AdaptiveStats st;
    sampling::RgbImage img = render_image(*sc, 2, &st);
    check_finite(img, st);
    CHECK(image_mean(img, 0) > 0.0);  // the back wall is lit
}

TEST_CASE("robustness: shading normals of zero length do not produce NaN") {
    std::unique_ptr<Scene> sc = scene_from_string(std::string(kCamera) + R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 0 ] "rgb I" [ 5 5 5 ]
Shape "trianglemesh" "point3 P" [ -4 -4 3  4 -4 3  4 4 3  -4 4 3 ]
    "integer indices" [ 0 1 2  0 2 3 ]
    "normal N" [ 0 0 0  0 0 0  0 0 0  0 0 0 ]
)",
                                                  small());
    sched::AdaptiveStats st;
    sampling::RgbImage img = render_image(*sc, 2, &st);
    check_finite(img, st);
}

TEST_CASE("robustness: a sphere or disk of radius 0 is rejected with file:line") {
    // The builder rejects non-positive radii (scene_builder.cpp) rather than making a light or
    // a quadric whose area is 0.
    std::string e = scene_error(std::string(kCamera) + R"(WorldBegin
LightSource "point" "point3 from" [ 0 0 0 ] "rgb I" [ 5 5 5 ]
Shape "sphere" "float radius" [ 0 ]
)");
    CHECK_MESSAGE(e.rfind("test.pbrt:7: ", 0) == 0, e);
    CHECK(e.find("radius") != std::string::npos);

    e = scene_error(std::string(kCamera) + R"(WorldBegin
AreaLightSource "diffuse" "rgb L" [ 1 1 1 ]
Shape "sphere" "float radius" [ -2 ]
)");
    CHECK_MESSAGE(e.rfind("test.pbrt:7: ", 0) == 0, e);

    e = scene_error(std::string(kCamera) + R"(WorldBegin
LightSource "point" "point3 from" [ 0 0 0 ] "rgb I" [ 5 5 5 ]
Shape "disk" "float radius" [ 0 ]
)");
    CHECK_MESSAGE(e.rfind("test.pbrt:7: ", 0) == 0, e);
}

TEST_CASE("robustness: lights with zero emission render black without NaN") {
    SUBCASE("area light with L = 0 is no light at all") {
        std::unique_ptr<Scene> sc = scene_from_string(std::string(kCamera) + R"(
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 0 0 0 ]
  Shape "trianglemesh" "point3 P" [ -4 -4 3  4 -4 3  4 4 3  -4 4 3 ]
      "integer indices" [ 0 1 2  0 2 3 ]
AttributeEnd
)",
                                                      small());
        CHECK(sc->lights.empty());
        sampling::RgbImage img = render_checked(*sc);
        CHECK(image_max(img) == 0.0);
    }
    SUBCASE("the only light is a point light with I = 0 (light sampler total power 0)") {
        std::unique_ptr<Scene> sc = scene_from_string(std::string(kCamera) + R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 0 ] "rgb I" [ 0 0 0 ]
Shape "trianglemesh" "point3 P" [ -4 -4 3  4 -4 3  4 4 3  -4 4 3 ]
    "integer indices" [ 0 1 2  0 2 3 ]
)",
                                                      small());
        sampling::RgbImage img = render_checked(*sc);
        CHECK(image_max(img) == 0.0);
    }
    SUBCASE("a zero light next to a real one changes nothing") {
        const std::string body = R"(
Shape "trianglemesh" "point3 P" [ -4 -4 3  4 -4 3  4 4 3  -4 4 3 ]
    "integer indices" [ 0 1 2  0 2 3 ]
LightSource "point" "point3 from" [ 0 0 0 ] "rgb I" [ 2 2 2 ]
)";
        std::unique_ptr<Scene> one = scene_from_string(std::string(kCamera) + "WorldBegin\n" +
                                                           body,
                                                       small());
        std::unique_ptr<Scene> two = scene_from_string(
            std::string(kCamera) + "WorldBegin\n" + body +
                "LightSource \"point\" \"point3 from\" [ 1 1 1 ] \"rgb I\" [ 0 0 0 ]\n",
            small());
        sched::AdaptiveStats st1, st2;
        sampling::RgbImage a = render_image(*one, 2, &st1), b = render_image(*two, 2, &st2);
        check_finite(b, st2);
        // Power-proportional selection never picks the zero light: the same estimate.
        CHECK(image_mean(b, 1) == test::Approx(image_mean(a, 1)).epsilon(1e-5));
    }
}

TEST_CASE("robustness: a scene without lights renders black, with a warning") {
    int before = warning_count();
    // A file name of its own: warn() prints each distinct message once per process.
    std::unique_ptr<Scene> sc = build_scene(parse_pbrt_string(std::string(kCamera) + R"(
WorldBegin
Material "diffuse" "rgb reflectance" [ 0.8 0.8 0.8 ]
Shape "trianglemesh" "point3 P" [ -4 -4 3  4 -4 3  4 4 3  -4 4 3 ]
    "integer indices" [ 0 1 2  0 2 3 ]
Shape "sphere" "float radius" [ 0.5 ]
)",
                                                                      "no_lights.pbrt", ""),
                                                    small());
    CHECK(warning_count() == before + 1);
    CHECK(last_warning().find("no lights") != std::string::npos);
    sched::AdaptiveStats st;
    sampling::RgbImage img = render_image(*sc, 2, &st);
    check_finite(img, st);
    CHECK(image_max(img) == 0.0);
    CHECK(st.samples == 16u * 16u * 4u);
}

TEST_CASE("robustness: NaN and infinite numbers are rejected by the parser with file:line") {
    const std::string head = std::string(kCamera) + "WorldBegin\n";  // 5 lines
    struct Case {
        const char *line, *what;
    } cases[] = {
        {"Shape \"sphere\" \"float radius\" [ nan ]", "nan"},
        {"Shape \"sphere\" \"float radius\" [ NaN ]", "NaN"},
        {"Shape \"sphere\" \"float radius\" [ inf ]", "inf"},
        {"Shape \"sphere\" \"float radius\" [ -inf ]", "-inf"},
        {"Shape \"sphere\" \"float radius\" [ 1e999 ]", "1e999"},
        {"LightSource \"point\" \"rgb I\" [ 1 nan 1 ]", "nan"},
        {"Translate 0 nan 0", "nan"},
        {"Scale 1 1 inf", "inf"},
    };
    for (const Case &c : cases) {
        CAPTURE(c.line);
        std::string e;
        try {
            parse_pbrt_string(head + "\n" + c.line + "\n", "nan.pbrt", "");
        } catch (const SceneError &ex) {
            e = ex.what();
        }
        CHECK_MESSAGE(e.rfind("nan.pbrt:7: ", 0) == 0, "error: \"" << e << "\"");
        CHECK(e.find(c.what) != std::string::npos);
    }
    // On a continuation line the error names the line of the bad value.
    std::string e;
    try {
        parse_pbrt_string(head + "Shape \"trianglemesh\"\n  \"point3 P\" [ 0 0 1  1 0 1\n"
                                 "  0 nan 1 ]\n",
                          "nan.pbrt", "");
    } catch (const SceneError &ex) {
        e = ex.what();
    }
    CHECK_MESSAGE(e.rfind("nan.pbrt:8: ", 0) == 0, "error: \"" << e << "\"");
}

namespace {

/// A small lit scene whose world is scaled by `s` (camera included): a floor, a back wall, a
/// sphere and a quad area light (radiance is scale invariant, so the picture must not change).
std::string scaled_scene(double s, double offset = 0) {
    auto num = [](double v) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.9g", v);
        return std::string(buf);
    };
    auto n = [&](double v) { return num(v * s); };
    auto p = [&](double x, double y, double z) {
        return num(x * s + offset) + " " + num(y * s) + " " + num(z * s);
    };
    return "LookAt " + p(0, 0.5, -3) + "  " + p(0, 0, 0) + "  0 1 0\n" +
           "Camera \"perspective\" \"float fov\" [ 50 ]\nPixelFilter \"box\"\nWorldBegin\n"
           "AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 6 6 6 ] \"bool twosided\" true\n"
           "  Shape \"trianglemesh\" \"point3 P\" [ " +
           p(-0.5, 1.5, -0.5) + "  " + p(-0.5, 1.5, 0.5) + "  " + p(0.5, 1.5, 0.5) + "  " +
           p(0.5, 1.5, -0.5) + " ] \"integer indices\" [ 0 1 2  0 2 3 ]\nAttributeEnd\n" +
           "Material \"diffuse\" \"rgb reflectance\" [ 0.6 0.6 0.6 ]\n"
           "Shape \"trianglemesh\" \"point3 P\" [ " +
           p(-3, -1, -3) + "  " + p(3, -1, -3) + "  " + p(3, -1, 3) + "  " + p(-3, -1, 3) +
           " ] \"integer indices\" [ 0 1 2  0 2 3 ]\n"
           "Shape \"trianglemesh\" \"point3 P\" [ " +
           p(-3, -1, 2) + "  " + p(3, -1, 2) + "  " + p(3, 3, 2) + "  " + p(-3, 3, 2) +
           " ] \"integer indices\" [ 0 1 2  0 2 3 ]\n"
           "AttributeBegin\n  Translate " + p(0.3, -0.4, 0.5) + "\n  Shape \"sphere\" \"float radius\" [ " +
           n(0.6) + " ]\nAttributeEnd\n";
}

}  // namespace

// The Cornell box version of this test, with a PSNR bound, is in test_numerical_stress_render.cpp.
TEST_CASE("robustness: scenes scaled by 1e-4, 1e-2, 1e2 and 1e5 render the same picture") {
    SceneOverrides ov = small(24, 16);
    sched::AdaptiveStats st;
    sampling::RgbImage ref = render_image(*scene_from_string(scaled_scene(1.0), ov), 2, &st);
    check_finite(ref, st);
    double ref_mean = image_mean(ref, 1);
    REQUIRE(ref_mean > 0.01);
    for (double s : {1e-4, 1e-2, 1e2, 1e5}) {
        CAPTURE(s);
        sampling::RgbImage img = render_image(*scene_from_string(scaled_scene(s), ov), 2, &st);
        check_finite(img, st);
        // Same seed, same paths: only ray-offset epsilons differ, so the means agree closely.
        CHECK(image_mean(img, 1) == test::Approx(ref_mean).epsilon(0.005));
        sampling::ImageComparison c = sampling::compare_images(img, ref, 1.0);
        CHECK(c.mse.total < 1e-3 * ref_mean * ref_mean);
    }
}

TEST_CASE("robustness: huge and tiny coordinates render finite values") {
    SceneOverrides ov = small(16, 4);
    for (double s : {1e-7, 1e8}) {
        CAPTURE(s);
        sched::AdaptiveStats st;
        sampling::RgbImage img = render_image(*scene_from_string(scaled_scene(s), ov), 2, &st);
        check_finite(img, st);
    }
    // Far from the origin (float spacing 0.5 at 1e7): imprecise, but never NaN.
    sched::AdaptiveStats st;
    sampling::RgbImage img =
        render_image(*scene_from_string(scaled_scene(10.0, 1e7), ov), 2, &st);
    check_finite(img, st);
}

TEST_CASE("robustness: a camera inside closed geometry") {
    SUBCASE("inside a closed box with the light outside: no light leaks in") {
        std::unique_ptr<Scene> sc = scene_from_string(std::string(kCamera) + R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 5 ] "rgb I" [ 50 50 50 ]
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 5 5 5 ] "bool twosided" true
  Shape "trianglemesh" "point3 P" [ -1 -1 6  1 -1 6  1 1 6  -1 1 6 ]
      "integer indices" [ 0 1 2  0 2 3 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.9 0.9 0.9 ]
Shape "trianglemesh"
    "point3 P" [ -1 -1 -1  1 -1 -1  1 1 -1  -1 1 -1  -1 -1 1  1 -1 1  1 1 1  -1 1 1 ]
    "integer indices" [ 0 2 1  0 3 2   4 5 6  4 6 7   0 1 5  0 5 4
                        3 7 6  3 6 2   0 4 7  0 7 3   1 2 6  1 6 5 ]
)",
                                                      small(16, 8));
        sampling::RgbImage img = render_checked(*sc);
        CHECK(image_max(img) == 0.0);
    }
    SUBCASE("inside a sphere with a light inside: lit, finite") {
        std::unique_ptr<Scene> sc = scene_from_string(std::string(kCamera) + R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0.5 0 ] "rgb I" [ 1 1 1 ]
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "sphere" "float radius" [ 2 ]
)",
                                                      small(16, 8));
        sampling::RgbImage img = render_checked(*sc);
        CHECK(image_mean(img, 0) > 0.0);
    }
    SUBCASE("inside a sphere, light outside: black") {
        std::unique_ptr<Scene> sc = scene_from_string(std::string(kCamera) + R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 5 ] "rgb I" [ 50 50 50 ]
Material "diffuse" "rgb reflectance" [ 0.9 0.9 0.9 ]
Shape "sphere" "float radius" [ 2 ]
)",
                                                      small(16, 8));
        sampling::RgbImage img = render_checked(*sc);
        CHECK(image_max(img) == 0.0);
    }
}

TEST_CASE("robustness: maxdepth 0 shows emission only, exactly") {
    // An area light fills the right half of the view (x > 0), a diffuse wall lit by a point
    // light the left half. Box filter: every sample stays in its pixel.
    std::unique_ptr<Scene> sc = scene_from_string(std::string(kCamera) + R"(
Integrator "path" "integer maxdepth" [ 0 ]
WorldBegin
LightSource "point" "point3 from" [ -1 0 1 ] "rgb I" [ 5 5 5 ]
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 2 3 4 ] "bool twosided" true
  Shape "trianglemesh" "point3 P" [ 0 -10 2  10 -10 2  10 10 2  0 10 2 ]
      "integer indices" [ 0 1 2  0 2 3 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.8 0.8 0.8 ]
Shape "trianglemesh" "point3 P" [ -10 -10 3  0 -10 3  0 10 3  -10 10 3 ]
    "integer indices" [ 0 1 2  0 2 3 ]
)",
                                                  small(16, 4));
    REQUIRE(sc->settings.max_depth == 0);
    sched::AdaptiveStats st;
    sampling::RgbImage img = render_image(*sc, 2, &st);
    check_finite(img, st);
    const float L[3] = {2.f, 3.f, 4.f};
    int light_px = 0, dark_px = 0;
    for (uint32_t y = 0; y < img.height; ++y)
        for (uint32_t x = 0; x < img.width; ++x) {
            if (x == 7 || x == 8) continue;  // the pixels on the seam at x = 0
            bool right = x > 8;
            for (int c = 0; c < 3; ++c) {
                CAPTURE(x);
                CAPTURE(y);
                if (right)
                    CHECK(img.at(x, y, c) == test::Approx(L[c]).epsilon(1e-6));
                else
                    CHECK(img.at(x, y, c) == 0.f);
            }
            (right ? light_px : dark_px)++;
        }
    CHECK(light_px == 7 * 16);
    CHECK(dark_px == 7 * 16);
}

TEST_CASE("robustness: maxdepth 1 is direct light only") {
    // A spot light (cone 15 degrees) points straight down at the floor; the back wall is
    // outside its cone, so it receives only light bounced off the floor. The top half of the
    // image sees only the back wall: exactly 0 at maxdepth 1, > 0 at maxdepth 2.
    auto make = [](int depth) {
        return scene_from_string(std::string(R"(
LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" [ 40 ]
PixelFilter "box"
Integrator "path" "integer maxdepth" [ )") + std::to_string(depth) + R"( ]
WorldBegin
LightSource "spot" "point3 from" [ 0 2 2.5 ] "point3 to" [ 0 -1 2.5 ] "rgb I" [ 20 20 20 ]
    "float coneangle" [ 15 ] "float conedeltaangle" [ 0 ]
Material "diffuse" "rgb reflectance" [ 0.8 0.8 0.8 ]
Shape "trianglemesh" "point3 P" [ -5 -1 -1  5 -1 -1  5 -1 4  -5 -1 4 ]
    "integer indices" [ 0 1 2  0 2 3 ]
Shape "trianglemesh" "point3 P" [ -5 -1 4  5 -1 4  5 5 4  -5 5 4 ]
    "integer indices" [ 0 1 2  0 2 3 ]
)",
                                 small(16, 16));
    };
    auto top_half_max = [](const sampling::RgbImage &img) {
        double m = 0;
        for (uint32_t y = 0; y < img.height / 2; ++y)
            for (uint32_t x = 0; x < img.width; ++x)
                for (int c = 0; c < 3; ++c) m = std::max(m, double(img.at(x, y, c)));
        return m;
    };
    sched::AdaptiveStats st;
    sampling::RgbImage d1 = render_image(*make(1), 2, &st);
    check_finite(d1, st);
    CHECK(top_half_max(d1) == 0.0);
    CHECK(image_max(d1) > 0.0);  // the lit floor, seen at the bottom
    sampling::RgbImage d2 = render_image(*make(2), 2, &st);
    check_finite(d2, st);
    CHECK(top_half_max(d2) > 0.0);
    CHECK(image_mean(d2, 1) > image_mean(d1, 1));
    // And maxdepth 0 sees no emitter at all here.
    sampling::RgbImage d0 = render_image(*make(0), 2, &st);
    CHECK(image_max(d0) == 0.0);
}
