// pbrt-v4's LightSource "goniometric": a point light whose intensity over directions is an
// equal-area image, with pbrt-v4's y/z swap (the map's pole is the light's +y).
#include <doctest/doctest.h>

#include <cmath>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/util/image_io.h"
#include "renderer/lights/lights.h"
#include "sampling/distribution.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

// A res x res RGB EXR whose value at each pixel centre is f(direction of the centre in the
// map's own frame).
template <class F>
std::string write_map(const std::string &name, int res, F f) {
    std::vector<float> px(size_t(res) * size_t(res) * 3);
    for (int y = 0; y < res; ++y)
        for (int x = 0; x < res; ++x) {
            Vec3f d = sampling::equal_area_square_to_sphere(
                {(float(x) + 0.5f) / float(res), (float(y) + 0.5f) / float(res)});
            float v = f(d);
            for (int c = 0; c < 3; ++c) px[(size_t(y) * size_t(res) + size_t(x)) * 3 + size_t(c)] = v;
        }
    std::string path = (temp_dir("goniometric") / name).string();
    write_exr(path, uint32_t(res), uint32_t(res), {ImageLayer{"", {"R", "G", "B"}, px}});
    return path;
}

const GoniometricLight &only_goniometric(const Scene &sc) {
    REQUIRE(sc.lights.size() == 1);
    auto *g = dynamic_cast<const GoniometricLight *>(sc.lights[0].get());
    REQUIRE(g != nullptr);
    return *g;
}

}  // namespace

TEST_CASE("goniometric light: the map's pole is the light's +y (pbrt-v4's y/z swap)") {
    // Bright where the map's z > 0: after the swap, every direction with light-space y > 0.
    std::string up = write_map("up.exr", 64, [](Vec3f d) { return d.z > 0.f ? 1.f : 0.f; });
    auto sc = scene_from_string("WorldBegin\nLightSource \"goniometric\" \"string filename\" \"" +
                                up + "\" \"rgb I\" [ 2 2 2 ]\n");
    REQUIRE(sc);
    const GoniometricLight &g = only_goniometric(*sc);
    CHECK(g.intensity({0, 1, 0}).g == test::Approx(2.f));
    CHECK(g.intensity({0.7f, 0.3f, -0.6f}).g == test::Approx(2.f));
    CHECK(g.intensity({0, -1, 0}).g == 0.f);
    CHECK(g.intensity({0.5f, -0.2f, 0.8f}).g == 0.f);
    // Power 4 pi I times the lit share of the map's pixels (half the sphere, less the pixels
    // centred exactly on the equator).
    int lit_pixels = 0;
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x)
            lit_pixels += sampling::equal_area_square_to_sphere({(x + 0.5f) / 64, (y + 0.5f) / 64}).z > 0;
    CHECK(lit_pixels > 1900);
    CHECK(lit_pixels < 2048);
    CHECK(g.phi().g == test::Approx(4 * M_PI * 2 * lit_pixels / 4096.0).epsilon(1e-5).scale(0));
    CHECK(g.image_mean() == test::Approx(lit_pixels / 4096.0).epsilon(1e-6).scale(0));

    // Rotated so that the light's +y points along render +z: a point at z = +2 is lit with
    // I / d^2, one at z = -2 is not.
    auto rot = scene_from_string(
        "WorldBegin\nAttributeBegin\nRotate 90 1 0 0\nLightSource \"goniometric\" "
        "\"string filename\" \"" + up + "\" \"rgb I\" [ 2 2 2 ]\nAttributeEnd\n");
    REQUIRE(rot);
    const GoniometricLight &r = only_goniometric(*rot);
    auto lit = r.sample_li(LightSampleContext{{0, 0, 2}, {0, 0, -1}}, {0.5f, 0.5f});
    REQUIRE(lit);
    CHECK(lit->L.g == test::Approx(2.f / 4.f));
    CHECK(lit->wi.z == test::Approx(-1.f));
    CHECK(lit->pdf == 1.f);
    // Nothing toward z < 0: no sample, as for a spot light outside its cone.
    CHECK(!r.sample_li(LightSampleContext{{0, 0, -2}, {0, 0, 1}}, {0.5f, 0.5f}));
}

TEST_CASE("goniometric light: a constant map is the point light of the same I and power") {
    std::string flat = write_map("flat.exr", 8, [](Vec3f) { return 1.f; });
    const std::string floor =
        "LookAt 0 3 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n"
        "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
        "Sampler \"zsobol\" \"integer pixelsamples\" 4\nWorldBegin\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ]\n"
        "  \"integer indices\" [ 0 1 2  0 2 3 ]\n";
    for (const std::string params : {"\"rgb I\" [ 3 2 1 ]", "\"float power\" 40"}) {
        CAPTURE(params);
        auto point = scene_from_string(floor + "LightSource \"point\" \"point3 from\" [ 0 1 0 ] " +
                                       params + "\n");
        auto gonio = scene_from_string(floor + "Translate 0 1 0\nLightSource \"goniometric\" "
                                               "\"string filename\" \"" + flat + "\" " + params +
                                       "\n");
        REQUIRE(point);
        REQUIRE(gonio);
        sampling::RgbImage a = render_image(*point), b = render_image(*gonio);
        for (int c = 0; c < 3; ++c) {
            CAPTURE(c);
            CHECK(image_mean(a, c) > 0.0);
            CHECK(image_mean(b, c) == test::Approx(image_mean(a, c)).epsilon(1e-5).scale(0));
        }
    }
}

TEST_CASE("goniometric light: bad maps are errors with the file's line") {
    auto dir = temp_dir("goniometric");
    std::string wide = (dir / "wide.exr").string();
    write_exr(wide, 4, 2, {ImageLayer{"", {"R", "G", "B"}, std::vector<float>(24, 1.f)}});
    CHECK_THROWS_WITH_AS(
        scene_from_string("WorldBegin\nLightSource \"goniometric\" \"string filename\" \"" + wide +
                          "\"\n"),
        doctest::Contains(("test.pbrt:2: goniometric light: \"" + wide + "\" is 4x2").c_str()),
        SceneError);
    CHECK_THROWS_WITH_AS(
        scene_from_string("WorldBegin\nLightSource \"goniometric\" \"string filename\" "
                          "\"/nonexistent/map.exr\"\n"),
        doctest::Contains("test.pbrt:2: cannot read image"), SceneError);
    // No map: pbrt-v4 warns and the light emits nothing (the point light is the only one).
    auto sc = scene_from_string("WorldBegin\nLightSource \"goniometric\"\n"
                                "LightSource \"point\" \"rgb I\" [ 1 1 1 ]\n");
    REQUIRE(sc);
    REQUIRE(sc->lights.size() == 1);
    CHECK(dynamic_cast<const GoniometricLight *>(sc->lights[0].get()) == nullptr);
    CHECK(last_warning().find("goniometric light: no \"filename\"") != std::string::npos);
}
