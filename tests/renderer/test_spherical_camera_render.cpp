// pbrt-v4's "spherical" camera: which direction each part of the image looks in, for both
// mappings, checked against six coloured emitting walls around the camera.
#include <doctest/doctest.h>

#include "approx.h"
#include "render_test_util.h"

using namespace tessera;
using namespace tessera::test;

namespace {

// The camera at the origin with the identity transform (camera space = world space), inside a
// cube of six two-sided emitting walls: +x red, -x green, +y blue, -y yellow, +z magenta,
// -z cyan. Emission only (maxdepth 0).
std::string cube_scene(const std::string &camera, int w, int h) {
    std::string s = camera + "\nFilm \"rgb\" \"integer xresolution\" [ " + std::to_string(w) +
                    " ] \"integer yresolution\" [ " + std::to_string(h) +
                    " ]\nSampler \"zsobol\" \"integer pixelsamples\" [ 4 ]\nPixelFilter \"box\"\n"
                    "Integrator \"path\" \"integer maxdepth\" [ 0 ]\nWorldBegin\n";
    struct Wall {
        const char *L;
        const char *P;
    };
    const Wall walls[] = {
        {"1 0 0", "1 -1 -1  1 1 -1  1 1 1  1 -1 1"},
        {"0 1 0", "-1 -1 -1  -1 1 -1  -1 1 1  -1 -1 1"},
        {"0 0 1", "-1 1 -1  1 1 -1  1 1 1  -1 1 1"},
        {"1 1 0", "-1 -1 -1  1 -1 -1  1 -1 1  -1 -1 1"},
        {"1 0 1", "-1 -1 1  1 -1 1  1 1 1  -1 1 1"},
        {"0 1 1", "-1 -1 -1  1 -1 -1  1 1 -1  -1 1 -1"},
    };
    for (const Wall &wall : walls)
        s += std::string("AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ ") + wall.L +
             " ] \"bool twosided\" true\nShape \"trianglemesh\" \"point3 P\" [ " + wall.P +
             " ] \"integer indices\" [ 0 1 2  0 2 3 ]\nAttributeEnd\n";
    return s;
}

void check_rgb(const sampling::RgbImage &img, int x, int y, Rgb expect) {
    CAPTURE(x);
    CAPTURE(y);
    CHECK(img.at(x, y, 0) == test::Approx(expect.r));
    CHECK(img.at(x, y, 1) == test::Approx(expect.g));
    CHECK(img.at(x, y, 2) == test::Approx(expect.b));
}

}  // namespace

TEST_CASE("spherical camera, equirectangular: u = phi / 2 pi around camera +y, v = theta") {
    auto sc = scene_from_string(
        cube_scene("Camera \"spherical\" \"string mapping\" \"equirectangular\"", 64, 32));
    REQUIRE(sc);
    sampling::RgbImage img = render_image(*sc);
    // Middle row (theta = 90 degrees): phi = 0 looks along +x, 90 along +z, 180 along -x,
    // 270 along -z.
    check_rgb(img, 1, 16, {1, 0, 0});
    check_rgb(img, 16, 16, {1, 0, 1});
    check_rgb(img, 32, 16, {0, 1, 0});
    check_rgb(img, 48, 16, {0, 1, 1});
    check_rgb(img, 62, 16, {1, 0, 0});
    // Top row: +y; bottom row: -y.
    check_rgb(img, 10, 0, {0, 0, 1});
    check_rgb(img, 40, 31, {1, 1, 0});
}

TEST_CASE("spherical camera, equal-area (the default): centre +y, corners -y") {
    auto sc = scene_from_string(cube_scene("Camera \"spherical\"", 32, 32));
    REQUIRE(sc);
    sampling::RgbImage img = render_image(*sc);
    check_rgb(img, 16, 16, {0, 0, 1});
    check_rgb(img, 0, 0, {1, 1, 0});
    check_rgb(img, 31, 31, {1, 1, 0});
    // Every direction is seen exactly once: the six walls each cover a sixth of the solid
    // angle, but a cube's faces subtend equal solid angles, so each colour covers 1/6 of an
    // equal-area image. Mean of R = (red + yellow + magenta) / 6 = 0.5, likewise G and B.
    for (int c = 0; c < 3; ++c) CHECK(image_mean(img, c) == test::Approx(0.5).epsilon(0.02));
}

TEST_CASE("spherical camera: an unknown mapping is an error with the file's line") {
    CHECK_THROWS_WITH(scene_from_string(cube_scene(
                          "Camera \"spherical\" \"string mapping\" \"fisheye\"", 8, 8)),
                      doctest::Contains("test.pbrt:1: spherical camera: unknown \"mapping\""));
}
