// pbrt-v4's invisible emitters: an area light on a shape with constant "float alpha" 0 is never
// hit by a ray and lights the scene by light sampling alone, with full weight (pbrt-v4 makes it
// a DeltaPosition light: no MIS). The floor it lights must get the same light as from the
// visible emitter, and the camera must not see it.
#include <doctest/doctest.h>

#include "approx.h"
#include "render_test_util.h"

using namespace tessera;

namespace {

// A diffuse floor seen from a low camera; `emitter` is above and outside the view.
std::string floor_scene(const std::string &emitter) {
    return R"(
LookAt 0 0.3 -2  0 0 0  0 1 0
Camera "perspective" "float fov" [ 30 ]
Film "rgb" "integer xresolution" [ 32 ] "integer yresolution" [ 32 ]
Sampler "zsobol" "integer pixelsamples" [ 64 ]
Integrator "path" "integer maxdepth" [ 1 ]
WorldBegin
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -10 0 -10  10 0 -10  10 0 10  -10 0 10 ]
    "integer indices" [ 0 1 2  0 2 3 ]
AttributeBegin
)" + emitter + "\nAttributeEnd\n";
}

double mean_luminance(const std::string &text) {
    auto sc = test::scene_from_string(text);
    REQUIRE(sc);
    sampling::RgbImage img = test::render_image(*sc);
    return 0.2126 * test::image_mean(img, 0) + 0.7152 * test::image_mean(img, 1) +
           0.0722 * test::image_mean(img, 2);
}

// A 4x4 quad light at y = 1 facing down: large and close, so BSDF sampling carries most of the
// light a visible emitter gives the floor (MIS weights far from 1).
const char *kQuad = R"(AreaLightSource "diffuse" "rgb L" [ 2 2 2 ]
Shape "trianglemesh" "point3 P" [ -2 1 -2  2 1 -2  2 1 2  -2 1 2 ]
    "integer indices" [ 0 1 2  0 2 3 ] )";

const char *kSphere = R"(AreaLightSource "diffuse" "rgb L" [ 3 3 3 ]
Translate 0 1.2 0.5
Shape "sphere" "float radius" [ 0.6 ] )";

}  // namespace

TEST_CASE("render: a triangle emitter with alpha 0 lights the floor as the visible one does") {
    double visible = mean_luminance(floor_scene(kQuad));
    double invisible = mean_luminance(floor_scene(std::string(kQuad) + "\"float alpha\" [ 0 ]"));
    INFO("visible " << visible << ", invisible " << invisible);
    CHECK(visible > 0.05);
    CHECK(invisible == test::Approx(visible).epsilon(0.03));
}

TEST_CASE("render: a sphere emitter with alpha 0 lights the floor as the visible one does") {
    double visible = mean_luminance(floor_scene(kSphere));
    double invisible = mean_luminance(floor_scene(std::string(kSphere) + "\"float alpha\" [ 0 ]"));
    INFO("visible " << visible << ", invisible " << invisible);
    CHECK(visible > 0.05);
    CHECK(invisible == test::Approx(visible).epsilon(0.03));
}

TEST_CASE("render: the camera does not see an emitter with alpha 0, and it casts no shadow") {
    // Looking straight at the emitters: visible ones fill the view, invisible ones leave it black.
    const std::string head = R"(
LookAt 0 0 -3  0 0 0  0 1 0
Camera "perspective" "float fov" [ 20 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
Sampler "zsobol" "integer pixelsamples" [ 4 ]
WorldBegin
)";
    const std::string quad = R"(AreaLightSource "diffuse" "rgb L" [ 2 2 2 ] "bool twosided" true
Shape "trianglemesh" "point3 P" [ -2 -2 0  2 -2 0  2 2 0  -2 2 0 ] "integer indices" [ 0 1 2  0 2 3 ] )";
    const std::string sphere = R"(AreaLightSource "diffuse" "rgb L" [ 3 3 3 ]
Shape "sphere" "float radius" [ 2 ] )";
    CHECK(mean_luminance(head + quad) == test::Approx(2.0).epsilon(1e-3));
    CHECK(mean_luminance(head + quad + "\"float alpha\" [ 0 ]") == 0.0);
    CHECK(mean_luminance(head + sphere) == test::Approx(3.0).epsilon(1e-3));
    CHECK(mean_luminance(head + sphere + "\"float alpha\" [ 0 ]") == 0.0);
}
