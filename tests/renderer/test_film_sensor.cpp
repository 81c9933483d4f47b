// pbrt-v4's sensor exposure (ISO x shutter time / 100) and maxcomponentvalue clamping.
#include <doctest/doctest.h>

#include <cmath>
#include <sstream>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/util/spectra.h"

using namespace tessera;
using namespace tessera::test;

namespace {

/// A camera looking straight at a large area light of radiance (2, 3, 4), direct emission only.
std::string emitter_scene(const std::string &film_extra, const std::string &camera_extra) {
    std::ostringstream os;
    os << "LookAt 0 0 -3  0 0 0  0 1 0\n"
       << "Camera \"perspective\" \"float fov\" [ 20 ] " << camera_extra << "\n"
       << "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ] "
       << film_extra << "\n"
       << "Sampler \"zsobol\" \"integer pixelsamples\" [ 4 ]\nPixelFilter \"box\"\n"
       << "Integrator \"path\" \"integer maxdepth\" [ 0 ]\nWorldBegin\n"
       << "AreaLightSource \"diffuse\" \"rgb L\" [ 2 3 4 ] \"bool twosided\" true\n"
       << "Shape \"trianglemesh\" \"point3 P\" [ -5 -5 0  5 -5 0  5 5 0  -5 5 0 ]\n"
       << "    \"integer indices\" [ 0 1 2  0 2 3 ]\n";
    return os.str();
}

}  // namespace

TEST_CASE("Film iso and the camera's shutter time scale the image as pbrt-v4's sensor does") {
    auto plain = scene_from_string(emitter_scene("", ""));
    CHECK(render_image(*plain).at(1, 1, 2) == test::Approx(4.0));
    // imagingRatio = (shutterclose - shutteropen) * iso / 100 = 0.5 * 600 / 100 = 3.
    auto bright = scene_from_string(emitter_scene("\"float iso\" [ 600 ]",
                                                  "\"float shutteropen\" [ 0.25 ] "
                                                  "\"float shutterclose\" [ 0.75 ]"));
    CHECK(bright->settings.image_scale == test::Approx(3.0));
    sampling::RgbImage img = render_image(*bright);
    CHECK(img.at(1, 1, 0) == test::Approx(6.0));
    CHECK(img.at(2, 2, 2) == test::Approx(12.0));
}

TEST_CASE("Film maxcomponentvalue scales a sample so that its largest component fits") {
    auto sc = scene_from_string(emitter_scene("\"float maxcomponentvalue\" [ 2 ]", ""));
    sampling::RgbImage img = render_image(*sc);
    // (2, 3, 4) * 2/4 = (1, 1.5, 2): the hue is kept.
    CHECK(img.at(1, 1, 0) == test::Approx(1.0));
    CHECK(img.at(1, 1, 1) == test::Approx(1.5));
    CHECK(img.at(1, 1, 2) == test::Approx(2.0));
}

TEST_CASE("--clamp (SceneOverrides::max_component) is the same clamp and wins over the file") {
    SceneOverrides ov;
    ov.max_component = 2.f;
    auto sc = scene_from_string(emitter_scene("\"float maxcomponentvalue\" [ 100 ]", ""), ov);
    CHECK(sc->settings.max_component == 2.f);
    sampling::RgbImage img = render_image(*sc);
    CHECK(img.at(1, 1, 0) == test::Approx(1.0));
    CHECK(img.at(1, 1, 2) == test::Approx(2.0));
    // Off by default; a clamp of 0 or below is rejected with its origin.
    CHECK(std::isinf(scene_from_string(emitter_scene("", ""))->settings.max_component));
    CHECK_THROWS_WITH_AS(scene_from_string(emitter_scene("\"float maxcomponentvalue\" [ 0 ]", "")),
                         doctest::Contains("must be positive"), SceneError);
}

TEST_CASE("Film whitebalance maps the white of illuminant D(T) to the sRGB white (pbrt-v4)") {
    // An emitter of radiance (1, 1, 1) (sRGB white, D65) seen through a film balanced for
    // 9000 K: bluish light counts as white, so D65 white comes out warm (R > G > B).
    auto scene_with = [](const std::string &film) {
        std::string s = emitter_scene(film, "");
        s.replace(s.find("[ 2 3 4 ]"), 9, "[ 1 1 1 ]");
        return scene_from_string(s);
    };
    auto warm = scene_with("\"float whitebalance\" [ 9000 ]");
    REQUIRE(warm->settings.white_balanced);
    sampling::RgbImage img = render_image(*warm);
    const float r = img.at(1, 1, 0), g = img.at(1, 1, 1), b = img.at(1, 1, 2);
    CHECK(r > g);
    CHECK(g > b);
    // The matrix's rows summed (its image of (1, 1, 1)).
    std::array<float, 9> m = white_balance_srgb(daylight_xy(9000.f), kSrgbWhiteXy);
    CHECK(r == test::Approx(m[0] + m[1] + m[2]).epsilon(1e-5));
    CHECK(g == test::Approx(m[3] + m[4] + m[5]).epsilon(1e-5));
    CHECK(b == test::Approx(m[6] + m[7] + m[8]).epsilon(1e-5));
    // 6500 K is D65 to within the CCT rescaling: white stays white (within 0.5%).
    sampling::RgbImage d65 = render_image(*scene_with("\"float whitebalance\" [ 6500 ]"));
    for (int c = 0; c < 3; ++c) CHECK(d65.at(1, 1, c) == test::Approx(1.0).epsilon(0.005));
    // 0 (the default) is off; a negative temperature is an error with the file's line.
    CHECK_FALSE(scene_with("\"float whitebalance\" [ 0 ]")->settings.white_balanced);
    CHECK_THROWS_WITH(scene_with("\"float whitebalance\" [ -5 ]"),
                      doctest::Contains("test.pbrt:3: \"whitebalance\" must be a positive"));
    // With the clamp: pbrt-v4's RGBFilm clamps the sample's largest component first and
    // white-balances when it writes the pixel: (1, 1, 1) -> (0.5, 0.5, 0.5) -> 0.5 (r, g, b).
    sampling::RgbImage clamped = render_image(
        *scene_with("\"float whitebalance\" [ 9000 ] \"float maxcomponentvalue\" [ 0.5 ]"));
    CHECK(clamped.at(1, 1, 0) == test::Approx(0.5 * r).epsilon(1e-5));
    CHECK(clamped.at(1, 1, 2) == test::Approx(0.5 * b).epsilon(1e-5));
}
