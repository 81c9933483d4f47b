// pbrt-v4's LightSource "projection": a slide projector at the light-space origin, throwing an
// RGB image along +z through a perspective frustum.
#include <doctest/doctest.h>

#include <cmath>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/util/image_io.h"
#include "renderer/lights/lights.h"
#include "sampling/warp.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

std::string write_rgb(const std::string &name, int w, int h, const std::vector<float> &px) {
    std::string path = (temp_dir("projection") / name).string();
    write_exr(path, uint32_t(w), uint32_t(h), {ImageLayer{"", {"R", "G", "B"}, px}});
    return path;
}

const ProjectionLight &only_projection(const Scene &sc) {
    REQUIRE(sc.lights.size() == 1);
    auto *p = dynamic_cast<const ProjectionLight *>(sc.lights[0].get());
    REQUIRE(p != nullptr);
    return *p;
}

}  // namespace

TEST_CASE("projection light: the image's top-left lands up-left, as a slide projector's") {
    // Row 0 (the top): red, green; row 1: blue, white.
    std::string quad = write_rgb("quad.exr", 2, 2, {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1});
    auto sc = scene_from_string("WorldBegin\nLightSource \"projection\" \"string filename\" \"" +
                                quad + "\" \"float scale\" 3\n");
    REQUIRE(sc);
    const ProjectionLight &p = only_projection(*sc);
    auto at = [&](Vec3f q) {
        auto s = p.sample_li(LightSampleContext{q, {0, 0, -1}}, {0.5f, 0.5f});
        return s ? s->L : Rgb(0.f);
    };
    // Points at depth 1, a quarter of the way across the 90-degree frustum; d^2 = 1.5.
    const float k = 3.f / 1.5f;
    Rgb tl = at({-0.5f, 0.5f, 1}), tr = at({0.5f, 0.5f, 1});
    Rgb bl = at({-0.5f, -0.5f, 1}), br = at({0.5f, -0.5f, 1});
    CHECK(tl.r == test::Approx(k));
    CHECK(tl.g == 0.f);
    CHECK(tr.g == test::Approx(k));
    CHECK(tr.r == 0.f);
    CHECK(bl.b == test::Approx(k));
    CHECK(bl.r == 0.f);
    CHECK(br.r == test::Approx(k));
    CHECK(br.g == test::Approx(k));
    // Behind the projector and outside the frustum: nothing.
    CHECK(at({0, 0, -1}).is_black());
    CHECK(at({1.5f, 0, 1}).is_black());
    CHECK(at({0, 1.2f, 1}).is_black());
    // The sample points at the light.
    auto s = p.sample_li(LightSampleContext{{0, 0, 2}, {0, 0, -1}}, {0.5f, 0.5f});
    REQUIRE(s);
    CHECK(s->wi.z == test::Approx(-1.f));
    CHECK(s->pdf == 1.f);
}

TEST_CASE("projection light: its power is the intensity integrated over the sphere") {
    // A 64x32 image of varying colours, fov 60: phi() (pbrt's A * mean(rgb cos^3), a midpoint
    // rule per pixel, exact as pixels shrink) against a stratified integral of intensity()
    // over uniformly sampled directions.
    std::vector<float> px;
    for (int i = 0; i < 64 * 32; ++i)
        px.insert(px.end(), {0.1f * float(i % 7 + 1), 0.5f, float((i / 64) % 2)});
    std::string img = write_rgb("wide.exr", 64, 32, px);
    auto sc = scene_from_string("WorldBegin\nLightSource \"projection\" \"string filename\" \"" +
                                img + "\" \"float fov\" 60\n");
    REQUIRE(sc);
    const ProjectionLight &p = only_projection(*sc);
    const int n = 1024;
    double sum[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            Vec3f w = sampling::square_to_uniform_sphere({(i + 0.5f) / n, (j + 0.5f) / n});
            Rgb I = p.intensity(w);
            sum[0] += I.r;
            sum[1] += I.g;
            sum[2] += I.b;
        }
    const double four_pi_over_n = 4 * M_PI / (double(n) * n);
    Rgb phi = p.phi();
    CHECK(sum[0] * four_pi_over_n == test::Approx(phi.r).epsilon(0.01).scale(0));
    CHECK(sum[1] * four_pi_over_n == test::Approx(phi.g).epsilon(0.01).scale(0));
    CHECK(sum[2] * four_pi_over_n == test::Approx(phi.b).epsilon(0.01).scale(0));

    // "power" P scales the light so that its luminous power is P.
    auto powered = scene_from_string("WorldBegin\nLightSource \"projection\" \"string filename\" "
                                     "\"" + img + "\" \"float fov\" 60 \"float power\" 50\n");
    REQUIRE(powered);
    CHECK(only_projection(*powered).phi().luminance() == test::Approx(50.f).epsilon(1e-4).scale(0));
}

TEST_CASE("projection light: no image, or a bad fov, is an error with the file's line") {
    CHECK_THROWS_WITH_AS(scene_from_string("WorldBegin\nLightSource \"projection\"\n"),
                         doctest::Contains("test.pbrt:2: projection light: needs a \"filename\""),
                         SceneError);
    std::string one = write_rgb("one.exr", 1, 1, {1, 1, 1});
    CHECK_THROWS_WITH_AS(
        scene_from_string("WorldBegin\nLightSource \"projection\" \"string filename\" \"" + one +
                          "\" \"float fov\" 180\n"),
        doctest::Contains("test.pbrt:2: projection light: \"fov\""), SceneError);
}
