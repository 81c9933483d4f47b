// Object instancing: geometry placed with ObjectBegin/ObjectInstance renders the same image as
// the same geometry written out with the instance transforms applied explicitly (pbrt-v4:
// world transform = renderFromInstance * renderFromObject). Transforms include rotations and
// non-uniform scales; the objects hold triangle meshes and spheres.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/util/image_io.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

constexpr int kRes = 48;
constexpr int kSpp = 32;

/// Camera, a floor and a quad area light: the parts both variants share.
const char *kStage = R"(
LookAt 0 3 -7  0 0.5 0  0 1 0
Camera "perspective" "float fov" [ 45 ]
Sampler "zsobol" "integer pixelsamples" [ 8 ]
Integrator "path" "integer maxdepth" [ 3 ]
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 8 8 8 ] "bool twosided" true
  Shape "trianglemesh" "point3 P" [ -1 4 -1  -1 4 1  1 4 1  1 4 -1 ]
      "integer indices" [ 0 1 2  0 2 3 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -6 0 -6  6 0 -6  6 0 6  -6 0 6 ]
    "integer indices" [ 0 1 2  0 2 3 ]
)";

/// A unit box standing on y = 0, in object space.
const char *kBox = R"(
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 0.7 0.3 0.2 ]
  Shape "trianglemesh"
      "point3 P" [ -0.5 0 -0.5  0.5 0 -0.5  0.5 1 -0.5  -0.5 1 -0.5
                   -0.5 0 0.5   0.5 0 0.5   0.5 1 0.5   -0.5 1 0.5 ]
      "integer indices" [ 0 2 1  0 3 2   4 5 6  4 6 7   0 1 5  0 5 4
                          3 7 6  3 6 2   0 4 7  0 7 3   1 2 6  1 6 5 ]
AttributeEnd
)";

/// A sphere resting on the box, with its own transform inside the object. (Glossy metal, not a
/// coated material: the layered BSDF seeds its estimates with the bits of the directions, so
/// the instance transform's rounding would give independent estimates all over the sphere,
/// which the per-pixel check below reads as a mismatch.)
const char *kSphere = R"(
AttributeBegin
  Translate 0 1.4 0
  Material "conductor" "rgb reflectance" [ 0.2 0.4 0.8 ] "float roughness" [ 0.1 ]
  Shape "sphere" "float radius" [ 0.4 ]
AttributeEnd
)";

/// Instance transforms: a rotation plus a non-uniform scale, and a rotation about a tilted axis.
const std::vector<std::string> kPlacements = {
    "Translate -1.3 0 0.4\n  Rotate 30 0 1 0\n  Scale 1 1.6 0.6\n",
    "Translate 1.4 0.2 -0.3\n  Rotate -50 0.3 1 0.2\n  Scale 0.8 0.8 1.3\n",
};

std::string instanced(const std::string &body) {
    std::string s = kStage;
    s += "ObjectBegin \"thing\"\n" + body + "ObjectEnd\n";
    for (const std::string &xf : kPlacements)
        s += "AttributeBegin\n  " + xf + "  ObjectInstance \"thing\"\nAttributeEnd\n";
    return s;
}

std::string explicit_copies(const std::string &body) {
    std::string s = kStage;
    for (const std::string &xf : kPlacements) s += "AttributeBegin\n  " + xf + body + "AttributeEnd\n";
    return s;
}

SceneOverrides overrides() {
    SceneOverrides ov;
    ov.width = ov.height = kRes;
    ov.spp = kSpp;
    ov.seed = 3;
    return ov;
}

/// Renders both variants and checks that they agree: mean within 0.5% per channel and a
/// per-pixel MSE that is small against the image's mean square. Writes both images on failure.
void check_same_image(const std::string &body, const char *tag) {
    std::unique_ptr<Scene> inst = scene_from_string(instanced(body), overrides());
    std::unique_ptr<Scene> flat = scene_from_string(explicit_copies(body), overrides());
    CHECK(inst->features.instances);
    CHECK_FALSE(flat->features.instances);
    CHECK(inst->geometry->instance_count() == kPlacements.size());
    CHECK(flat->geometry->instance_count() == 0);

    sched::AdaptiveStats si, sf;
    sampling::RgbImage a = render_image(*inst, 0, &si);
    sampling::RgbImage b = render_image(*flat, 0, &sf);
    CHECK(si.nan_samples == 0);
    CHECK(sf.nan_samples == 0);

    bool ok = true;
    double mean_sq = 0;
    for (float v : b.data) mean_sq += double(v) * v;
    mean_sq /= double(b.data.size());
    for (int c = 0; c < 3; ++c) {
        double ma = image_mean(a, c), mb = image_mean(b, c);
        CAPTURE(c);
        REQUIRE(mb > 0.01);
        CHECK(ma == test::Approx(mb).epsilon(0.005));
        ok = ok && std::abs(ma - mb) <= 0.005 * mb;
    }
    sampling::ImageComparison cmp = sampling::compare_images(a, b, 1.0);
    // Identical geometry and seed: the images differ only where floating-point differences of
    // the instance transform send a path elsewhere.
    CHECK(cmp.mse.total < 1e-3 * mean_sq);
    ok = ok && cmp.mse.total < 1e-3 * mean_sq;
    if (!ok) {
        std::string dir = output_dir();
        write_exr(dir + "/instancing_" + tag + "_instanced.exr", a.width, a.height,
                  {{"", {"R", "G", "B"}, a.data, false}});
        write_exr(dir + "/instancing_" + tag + "_explicit.exr", b.width, b.height,
                  {{"", {"R", "G", "B"}, b.data, false}});
        MESSAGE("wrote the two images to " << dir);
    }
}

}  // namespace

TEST_CASE("instancing: rotated, non-uniformly scaled mesh instances == explicit copies") {
    check_same_image(kBox, "box");
}

TEST_CASE("instancing: instances holding a mesh and a sphere == explicit copies") {
    check_same_image(std::string(kBox) + kSphere, "box_sphere");
}

TEST_CASE("instancing: one object instanced many times stays consistent") {
    // Eight instances of a sphere-only object in a ring: the instanced and explicit images
    // agree as well, and the object's prototype is built once.
    std::string body = R"(
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 0.3 0.8 0.3 ]
  Scale 1 0.5 1
  Shape "sphere" "float radius" [ 0.35 ]
AttributeEnd
)";
    std::string inst = kStage, flat = kStage;
    inst += "ObjectBegin \"ball\"\n" + body + "ObjectEnd\n";
    for (int i = 0; i < 8; ++i) {
        std::string xf = "Rotate " + std::to_string(45 * i) + " 0 1 0\n  Translate 2 0.3 0\n";
        inst += "AttributeBegin\n  " + xf + "  ObjectInstance \"ball\"\nAttributeEnd\n";
        flat += "AttributeBegin\n  " + xf + body + "AttributeEnd\n";
    }
    std::unique_ptr<Scene> a_sc = scene_from_string(inst, overrides());
    std::unique_ptr<Scene> b_sc = scene_from_string(flat, overrides());
    CHECK(a_sc->geometry->instance_count() == 8);
    sched::AdaptiveStats st;
    sampling::RgbImage a = render_image(*a_sc, 0, &st);
    CHECK(st.nan_samples == 0);
    sampling::RgbImage b = render_image(*b_sc, 0, &st);
    for (int c = 0; c < 3; ++c) {
        REQUIRE(image_mean(b, c) > 0.01);
        CHECK(image_mean(a, c) == test::Approx(image_mean(b, c)).epsilon(0.005));
    }
}
