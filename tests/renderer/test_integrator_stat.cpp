// Light transport against analytic answers: furnaces, MIS consistency, determinism, scale
// invariance. Small images, fixed seeds; tolerances are several standard errors wide.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <sstream>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/integrators/path_integrator.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

/// Camera looking at the origin from +z with a narrow field of view.
std::string header(int res, int spp, int depth) {
    std::ostringstream os;
    os << "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 30 ]\n"
       << "Film \"rgb\" \"integer xresolution\" [ " << res << " ] \"integer yresolution\" [ "
       << res << " ]\nSampler \"zsobol\" \"integer pixelsamples\" [ " << spp << " ]\n"
       << "PixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" [ " << depth
       << " ]\nWorldBegin\n";
    return os.str();
}

/// Max relative deviation of any pixel channel from `expected`.
double max_rel_dev(const sampling::RgbImage &img, double expected) {
    double worst = 0;
    for (float v : img.data) worst = std::max(worst, std::abs(v - expected) / expected);
    return worst;
}

}  // namespace

TEST_CASE("white furnace: albedo-1 diffuse objects under a uniform environment stay at 1") {
    // A convex sphere and, in front of it, a disk: with unit albedo and unit environment
    // radiance every path carries exactly 1 (MIS between environment and BSDF sampling).
    std::string s = header(16, 64, 100) +
                    "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
                    "Material \"diffuse\" \"rgb reflectance\" [ 1 1 1 ]\n"
                    "Shape \"sphere\" \"float radius\" [ 0.8 ]\n"
                    "AttributeBegin\nTranslate 0.3 0.2 1.2\nRotate 30 1 0 0\n"
                    "Shape \"disk\" \"float radius\" [ 0.4 ]\nAttributeEnd\n";
    auto scene = scene_from_string(s);
    sampling::RgbImage img = render_image(*scene);
    for (int c = 0; c < 3; ++c) CHECK(image_mean(img, c) == test::Approx(1.0).epsilon(0.005));
    // Russian roulette makes single pixels noisy but unbiased; the mean is the contract, and
    // no pixel may deviate wildly.
    CHECK(max_rel_dev(img, 1.0) < 0.25);
}

TEST_CASE("white furnace: a smooth glass sphere conserves energy") {
    std::string s = header(16, 64, 200) +
                    "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
                    "Material \"dielectric\" \"float eta\" [ 1.5 ]\n"
                    "Shape \"sphere\" \"float radius\" [ 1 ]\n";
    auto scene = scene_from_string(s);
    sampling::RgbImage img = render_image(*scene);
    for (int c = 0; c < 3; ++c) CHECK(image_mean(img, c) == test::Approx(1.0).epsilon(0.005));
}

TEST_CASE("sphere furnace: albedo a and emission e inside a closed sphere give e / (1 - a)") {
    // The camera sits inside a two-sided emitting diffuse sphere: L = e + a L.
    for (float a : {0.3f, 0.5f, 0.8f}) {
        std::ostringstream os;
        os << "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" [ 60 ]\n"
           << "Film \"rgb\" \"integer xresolution\" [ 12 ] \"integer yresolution\" [ 12 ]\n"
           << "Sampler \"zsobol\" \"integer pixelsamples\" [ 128 ]\nPixelFilter \"box\"\n"
           << "Integrator \"path\" \"integer maxdepth\" [ 1000 ]\nWorldBegin\n"
           << "AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ] \"bool twosided\" true\n"
           << "Material \"diffuse\" \"rgb reflectance\" [ " << a << " " << a << " " << a
           << " ]\nShape \"sphere\" \"float radius\" [ 3 ]\n";
        auto scene = scene_from_string(os.str());
        sampling::RgbImage img = render_image(*scene);
        double expected = 1.0 / (1.0 - a);
        INFO("albedo " << a);
        for (int c = 0; c < 3; ++c)
            CHECK(image_mean(img, c) == test::Approx(expected).epsilon(0.01));
    }
}

namespace {

/// A closed box with a large light: every direct-lighting strategy converges in a few hundred
/// samples per pixel, so their means can be compared tightly.
const char *kMisBox = R"(
LookAt 0 1 3.5  0 1 0  0 1 0
Camera "perspective" "float fov" [ 45 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
Sampler "zsobol" "integer pixelsamples" [ 256 ]
PixelFilter "box"
Integrator "path" "integer maxdepth" [ 3 ]
WorldBegin
Material "diffuse" "rgb reflectance" [ 0.6 0.5 0.4 ]
Shape "bilinearmesh" "point3 P" [ -1 0 1  1 0 1  -1 0 -1  1 0 -1 ]
Shape "bilinearmesh" "point3 P" [ -1 2 -1  1 2 -1  -1 2 1  1 2 1 ]
Shape "bilinearmesh" "point3 P" [ -1 0 -1  1 0 -1  -1 2 -1  1 2 -1 ]
Shape "bilinearmesh" "point3 P" [ -1 0 1  -1 0 -1  -1 2 1  -1 2 -1 ]
Shape "bilinearmesh" "point3 P" [ 1 0 -1  1 0 1  1 2 -1  1 2 1 ]
Material "conductor" "float roughness" [ 0.3 ]
AttributeBegin
Translate 0.3 0.4 0
Shape "sphere" "float radius" [ 0.4 ]
AttributeEnd
AttributeBegin
AreaLightSource "diffuse" "rgb L" [ 2 2 2 ]
Material "diffuse" "rgb reflectance" [ 0 0 0 ]
Shape "trianglemesh" "point3 P" [ -0.7 1.99 -0.7  0.7 1.99 -0.7  0.7 1.99 0.7  -0.7 1.99 0.7 ]
    "integer indices" [ 0 1 2  0 2 3 ]
AttributeEnd
AttributeBegin
Translate -0.5 1.2 -0.3
AreaLightSource "diffuse" "rgb L" [ 1 1.5 2 ]
Shape "sphere" "float radius" [ 0.15 ]
AttributeEnd
)";

sampling::RgbImage render_with(const Scene &scene, DirectStrategy strategy) {
    return render_with_strategy(scene, strategy, 7);
}

}  // namespace

TEST_CASE("MIS consistency: light-only, BSDF-only and MIS estimates agree") {
    auto scene = scene_from_string(kMisBox);
    sampling::RgbImage mis = render_with(*scene, DirectStrategy::Mis);
    sampling::RgbImage light = render_with(*scene, DirectStrategy::LightOnly);
    sampling::RgbImage bsdf = render_with(*scene, DirectStrategy::BsdfOnly);
    for (int c = 0; c < 3; ++c) {
        double m = image_mean(mis, c), l = image_mean(light, c), b = image_mean(bsdf, c);
        INFO("channel " << c << ": MIS " << m << ", light " << l << ", BSDF " << b);
        CHECK(m > 0.05);
        CHECK(l == test::Approx(m).epsilon(0.02));
        CHECK(b == test::Approx(m).epsilon(0.03));
    }
    // Quadrant means agree too (catches errors that cancel over the whole image).
    for (int q = 0; q < 4; ++q) {
        double sm = 0, sl = 0;
        for (uint32_t y = 0; y < 8; ++y)
            for (uint32_t x = 0; x < 8; ++x) {
                uint32_t px = x + (q % 2) * 8, py = y + (q / 2) * 8;
                sm += mis.at(px, py, 1);
                sl += light.at(px, py, 1);
            }
        CHECK(sl == test::Approx(sm).epsilon(0.04));
    }
}

TEST_CASE("determinism: the same seed gives bit-identical images for 1 and 4 threads") {
    auto scene = scene_from_string(kMisBox, SceneOverrides{{}, {}, 16, {}, 3u});
    sampling::RgbImage a = render_image(*scene, 1);
    sampling::RgbImage b = render_image(*scene, 4);
    REQUIRE(a.data.size() == b.data.size());
    CHECK(std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)) == 0);
    // A different seed gives a different image.
    auto scene2 = scene_from_string(kMisBox, SceneOverrides{{}, {}, 16, {}, 4u});
    sampling::RgbImage c = render_image(*scene2, 2);
    CHECK(std::memcmp(a.data.data(), c.data.data(), a.data.size() * sizeof(float)) != 0);
}

TEST_CASE("scale invariance: the scene scaled by 1e-4 and 1e5 renders the same picture") {
    // Robust ray origins must not depend on a scene-scale epsilon. The whole world, camera
    // included, is scaled; the floor lies exactly on y = 0 (a zero per-axis error bound).
    auto make = [](double k) {
        std::string s = kMisBox;
        std::ostringstream look, world;
        look << "LookAt 0 " << k << " " << 3.5 * k << "  0 " << k << " 0  0 1 0";
        world << "WorldBegin\nScale " << k << " " << k << " " << k;
        s.replace(s.find("LookAt 0 1 3.5  0 1 0  0 1 0"), 28, look.str());
        s.replace(s.find("WorldBegin"), 10, world.str());
        return s;
    };
    auto ref_scene = scene_from_string(make(1.0), SceneOverrides{{}, {}, 64, {}, {}});
    sampling::RgbImage ref = render_image(*ref_scene);
    for (double k : {1e-4, 1e5}) {
        auto sc = scene_from_string(make(k), SceneOverrides{{}, {}, 64, {}, {}});
        sampling::RgbImage img = render_image(*sc);
        INFO("scale " << k);
        for (int c = 0; c < 3; ++c)
            CHECK(image_mean(img, c) == test::Approx(image_mean(ref, c)).epsilon(0.01));
        // Same sample sequence and the same geometry up to rounding: pixels agree closely.
        double mse = sampling::mse(img, ref).total;
        CHECK(mse < 1e-3);
    }
}
