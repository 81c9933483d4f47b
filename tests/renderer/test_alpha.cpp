// pbrt's "alpha" cut-outs: ignored hits where alpha is 0, stochastic where it is fractional,
// for camera rays and shadow rays alike.
#include <doctest/doctest.h>

#include <sstream>

#include "approx.h"
#include "render_test_util.h"

using namespace tessera;
using namespace tessera::test;

namespace {

/// An emitter (L = 1) at z = 2 seen through a black quad at z = 0 with the given alpha.
std::string scene(const std::string &alpha_param, const std::string &textures = "") {
    std::ostringstream os;
    os << "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 30 ]\n"
       << "Film \"rgb\" \"integer xresolution\" [ 16 ] \"integer yresolution\" [ 16 ]\n"
       << "Sampler \"zsobol\" \"integer pixelsamples\" [ 64 ]\nPixelFilter \"box\"\n"
       << "Integrator \"path\" \"integer maxdepth\" [ 0 ]\nWorldBegin\n"
       << textures
       << "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ] \"bool twosided\" true\n"
       << "Shape \"trianglemesh\" \"point3 P\" [ -9 -9 2  9 -9 2  9 9 2  -9 9 2 ]\n"
       << "  \"integer indices\" [ 0 1 2  0 2 3 ]\nAttributeEnd\n"
       << "Material \"diffuse\" \"rgb reflectance\" [ 0 0 0 ]\n"
       << "Shape \"trianglemesh\" \"point3 P\" [ -9 -9 0  9 -9 0  9 9 0  -9 9 0 ]\n"
       << "  \"point2 uv\" [ 0 0  1 0  1 1  0 1 ] \"integer indices\" [ 0 1 2  0 2 3 ] "
       << alpha_param << "\n";
    return os.str();
}

double mean_green(const std::string &text) {
    auto sc = scene_from_string(text);
    return image_mean(render_image(*sc), 1);
}

}  // namespace

TEST_CASE("alpha 1 is opaque, alpha 0 is invisible") {
    CHECK(mean_green(scene("")) == test::Approx(0.0));
    CHECK(mean_green(scene("\"float alpha\" [ 1 ]")) == test::Approx(0.0));
    CHECK(mean_green(scene("\"float alpha\" [ 0 ]")) == test::Approx(1.0));
}

TEST_CASE("fractional alpha keeps a hit with probability alpha") {
    // 16x16 pixels x 64 samples: the fraction passing is 0.7 within a few standard errors.
    CHECK(mean_green(scene("\"float alpha\" [ 0.3 ]")) == test::Approx(0.7).epsilon(0.03));
}

TEST_CASE("an alpha texture cuts out where it is 0") {
    std::string tex = "Texture \"mask\" \"float\" \"checkerboard\" \"float uscale\" [ 4 ] "
                      "\"float vscale\" [ 4 ] \"float tex1\" [ 1 ] \"float tex2\" [ 0 ]\n";
    double g = mean_green(scene("\"texture alpha\" \"mask\"", tex));
    // Half the checker cells are holes; the visible part of the quad is symmetric about the
    // cell pattern up to the pixel grid.
    CHECK(g == test::Approx(0.5).epsilon(0.1));
}

TEST_CASE("shadow rays pass through cut-outs") {
    // A point light behind the camera lights a wall in front of it; a quad between the light
    // and the camera (behind the camera, so camera rays never meet it) casts the shadow.
    auto make = [](const std::string &blocker) {
        return "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 20 ]\n"
               "Film \"rgb\" \"integer xresolution\" [ 8 ] \"integer yresolution\" [ 8 ]\n"
               "Sampler \"zsobol\" \"integer pixelsamples\" [ 4 ]\nPixelFilter \"box\"\n"
               "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
               "LightSource \"point\" \"rgb I\" [ 16 16 16 ] \"point3 from\" [ 0 0 -4 ]\n"
               "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]\n"
               "Shape \"trianglemesh\" \"point3 P\" [ -9 -9 1  9 -9 1  9 9 1  -9 9 1 ]\n"
               "  \"integer indices\" [ 0 1 2  0 2 3 ]\n" + blocker;
    };
    const std::string quad = "Shape \"trianglemesh\" \"point3 P\" [ -9 -9 -3.5  9 -9 -3.5  "
                             "9 9 -3.5  -9 9 -3.5 ] \"integer indices\" [ 0 1 2  0 2 3 ] ";
    double open = mean_green(make(""));
    CHECK(open > 0.05);
    CHECK(mean_green(make(quad + "\n")) == test::Approx(0.0));
    CHECK(mean_green(make(quad + "\"float alpha\" [ 0 ]\n")) == test::Approx(open));
}
