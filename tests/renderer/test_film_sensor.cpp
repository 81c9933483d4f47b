// pbrt-v4's sensor exposure (ISO x shutter time / 100) and maxcomponentvalue clamping.
#include <doctest/doctest.h>

#include <cmath>
#include <sstream>

#include "render_test_util.h"

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
    CHECK(render_image(*plain).at(1, 1, 2) == doctest::Approx(4.0));
    // imagingRatio = (shutterclose - shutteropen) * iso / 100 = 0.5 * 600 / 100 = 3.
    auto bright = scene_from_string(emitter_scene("\"float iso\" [ 600 ]",
                                                  "\"float shutteropen\" [ 0.25 ] "
                                                  "\"float shutterclose\" [ 0.75 ]"));
    CHECK(bright->settings.image_scale == doctest::Approx(3.0));
    sampling::RgbImage img = render_image(*bright);
    CHECK(img.at(1, 1, 0) == doctest::Approx(6.0));
    CHECK(img.at(2, 2, 2) == doctest::Approx(12.0));
}

TEST_CASE("Film maxcomponentvalue scales a sample so that its largest component fits") {
    auto sc = scene_from_string(emitter_scene("\"float maxcomponentvalue\" [ 2 ]", ""));
    sampling::RgbImage img = render_image(*sc);
    // (2, 3, 4) * 2/4 = (1, 1.5, 2): the hue is kept.
    CHECK(img.at(1, 1, 0) == doctest::Approx(1.0));
    CHECK(img.at(1, 1, 1) == doctest::Approx(1.5));
    CHECK(img.at(1, 1, 2) == doctest::Approx(2.0));
}

TEST_CASE("--clamp (SceneOverrides::max_component) is the same clamp and wins over the file") {
    SceneOverrides ov;
    ov.max_component = 2.f;
    auto sc = scene_from_string(emitter_scene("\"float maxcomponentvalue\" [ 100 ]", ""), ov);
    CHECK(sc->settings.max_component == 2.f);
    sampling::RgbImage img = render_image(*sc);
    CHECK(img.at(1, 1, 0) == doctest::Approx(1.0));
    CHECK(img.at(1, 1, 2) == doctest::Approx(2.0));
    // Off by default; a clamp of 0 or below is rejected with its origin.
    CHECK(std::isinf(scene_from_string(emitter_scene("", ""))->settings.max_component));
    CHECK_THROWS_WITH_AS(scene_from_string(emitter_scene("\"float maxcomponentvalue\" [ 0 ]", "")),
                         doctest::Contains("must be positive"), SceneError);
}
