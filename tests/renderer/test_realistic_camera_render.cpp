// pbrt-v4's Camera "realistic" end to end: a scene's lens file, the exposure its rays carry,
// the image's orientation, and the errors a scene gets for a lens that cannot work.
#include <doctest/doctest.h>

#include <cmath>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/util/image_io.h"
#include "renderer/camera/lens_system.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

// A biconvex singlet with the aperture stop last (the stop is the exit pupil); see
// test_lens_system.cpp.
const char *kSinglet = "# singlet\n50 2 1.5 20\n-50 1 1 20\n0 40 0 10\n";

std::string lens_file() {
    return write_text(temp_dir("realistic_camera") / "singlet.dat", kSinglet);
}

std::string camera_and_film(const std::string &lens, int res, int spp,
                            const std::string &extra = "") {
    return "Camera \"realistic\" \"string lensfile\" \"" + lens +
           "\" \"float aperturediameter\" 6 \"float focusdistance\" 5 " + extra +
           "\nFilm \"rgb\" \"integer xresolution\" " + std::to_string(res) +
           " \"integer yresolution\" " + std::to_string(res) +
           " \"float diagonal\" 20\nSampler \"zsobol\" \"integer pixelsamples\" " +
           std::to_string(spp) + "\nPixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" 1\n";
}

}  // namespace

TEST_CASE("realistic camera: a uniform sky exposes the centre by the stop's solid angle") {
    auto sc = scene_from_string(camera_and_film(lens_file(), 16, 256) +
                                "WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n");
    REQUIRE(sc);
    const LensSystem *lens = sc->camera->lens_system();
    REQUIRE(lens != nullptr);
    sampling::RgbImage img = render_image(*sc);
    // pbrt's weight cos^4 / (pdf z^2) integrates to pi R^2 / (z^2 + R^2) over a stop of radius
    // R at distance z from the film centre (every ray through the stop sees L = 1).
    const double z = lens->rear_z(), r = 0.003;
    const double expected = M_PI * r * r / (z * z + r * r);
    // The central 4x4 pixels (within 2 pixels, 1.8 mm, of the film centre, where cos^4 and
    // the pupil's shape change the exposure by under 0.2%), averaged against per-pixel noise.
    for (int c = 0; c < 3; ++c) {
        CAPTURE(c);
        double mean = 0;
        for (int y = 6; y <= 9; ++y)
            for (int x = 6; x <= 9; ++x) mean += img.at(x, y, c) / 16.0;
        CHECK(mean == test::Approx(expected).epsilon(0.01).scale(0));
    }
    // The corners are darker (cos^4 and the pupil's foreshortening), never brighter.
    CHECK(img.at(0, 0, 0) < 0.95 * img.at(7, 7, 0));
    CHECK(img.at(0, 0, 0) > 0.f);
}

TEST_CASE("realistic camera: the lens inverts the image and the film inverts it back") {
    // An emitter in the camera's upper-left quadrant (camera +x right, +y up), in focus 5 m
    // away, lights only the image's top-left quadrant.
    auto sc = scene_from_string(
        camera_and_film(lens_file(), 16, 16) +
        "WorldBegin\nAttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -20 0 5  0 0 5  0 20 5  -20 20 5 ]\n"
        "  \"integer indices\" [ 0 1 2  0 2 3 ]\nAttributeEnd\n");
    REQUIRE(sc);
    sampling::RgbImage img = render_image(*sc);
    CHECK(img.at(3, 3, 0) > 0.f);
    CHECK(img.at(12, 3, 0) == 0.f);
    CHECK(img.at(3, 12, 0) == 0.f);
    CHECK(img.at(12, 12, 0) == 0.f);
}

TEST_CASE("realistic camera: the lens file resolves against the scene file's folder") {
    auto dir = temp_dir("realistic_camera_relative", true);
    write_text(dir / "lenses" / "singlet.dat", kSinglet);
    auto scene = write_text(dir / "scene.pbrt",
                            camera_and_film("lenses/singlet.dat", 8, 4) +
                                "WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n");
    auto sc = load_scene(scene, {});
    REQUIRE(sc);
    CHECK(sc->camera->lens_system() != nullptr);
    CHECK(sc->camera->uses_lens_sample());
}

TEST_CASE("realistic camera: a lens that cannot work is an error naming the Camera line") {
    const std::string sky = "WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n";
    // No lens file.
    CHECK_THROWS_WITH_AS(scene_from_string("Camera \"realistic\"\n" + sky),
                         doctest::Contains("test.pbrt:1: Camera \"realistic\" needs a"),
                         SceneError);
    // A lens file that is not there.
    CHECK_THROWS_WITH_AS(
        scene_from_string(camera_and_film("/nonexistent/lens.dat", 8, 4) + sky),
        doctest::Contains("/nonexistent/lens.dat:0: cannot read the lens file: not found"),
        SceneError);
    // Focused closer than its focal length.
    CHECK_THROWS_WITH_AS(
        scene_from_string("Camera \"realistic\" \"string lensfile\" \"" + lens_file() +
                          "\" \"float focusdistance\" 0.02\n" + sky),
        doctest::Contains("test.pbrt:1: Camera \"realistic\": \"focusdistance\""), SceneError);
    // An aperture image that is not there, and one that is black.
    CHECK_THROWS_WITH_AS(
        scene_from_string(camera_and_film(lens_file(), 8, 4,
                                          "\"string aperture\" \"/nonexistent/bokeh.exr\"") +
                          sky),
        doctest::Contains("test.pbrt:1: cannot read image \"/nonexistent/bokeh.exr\""),
        SceneError);
    auto black = (temp_dir("realistic_camera") / "black.exr").string();
    write_exr(black, 4, 4, {ImageLayer{"", {"R", "G", "B"}, std::vector<float>(48, 0.f)}});
    CHECK_THROWS_WITH_AS(
        scene_from_string(camera_and_film(lens_file(), 8, 4,
                                          "\"string aperture\" \"" + black + "\"") + sky),
        doctest::Contains("passes no light"), SceneError);
}

TEST_CASE("realistic camera: an aperture image shapes the stop and keeps its exposure") {
    // A 16x16 EXR, open (1) in a centred 8x8 square: pbrt normalises every aperture image to
    // pass as much light as the round stop, so the sky's centre exposure stays pi R^2/(z^2+R^2)
    // (to within the cos^4 falloff across the slightly larger square).
    std::vector<float> px(16 * 16 * 3, 0.f);
    for (int y = 4; y < 12; ++y)
        for (int x = 4; x < 12; ++x)
            for (int c = 0; c < 3; ++c) px[size_t((y * 16 + x) * 3 + c)] = 1.f;
    auto square = (temp_dir("realistic_camera") / "square.exr").string();
    write_exr(square, 16, 16, {ImageLayer{"", {"R", "G", "B"}, px}});
    for (const std::string &aperture : {square, std::string("square")}) {
        CAPTURE(aperture);
        auto sc = scene_from_string(
            camera_and_film(lens_file(), 16, 256, "\"string aperture\" \"" + aperture + "\"") +
            "WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n");
        REQUIRE(sc);
        sampling::RgbImage img = render_image(*sc);
        const double z = sc->camera->lens_system()->rear_z(), r = 0.003;
        const double expected = M_PI * r * r / (z * z + r * r);
        double mean = 0;
        for (int y = 6; y <= 9; ++y)
            for (int x = 6; x <= 9; ++x) mean += img.at(x, y, 1) / 16.0;
        CHECK(mean == test::Approx(expected).epsilon(0.015).scale(0));
    }
}
