// Cameras: pbrt-v4's orthographic projection and the perspective field of view.
#include <doctest/doctest.h>

#include <sstream>

#include "approx.h"
#include "render_test_util.h"

using namespace tessera;
using namespace tessera::test;

namespace {

/// A 1x1 emitting square (L = 1) at distance `z` in front of the camera.
std::string square_scene(const std::string &camera, float z) {
    std::ostringstream os;
    os << "LookAt 0 0 0  0 0 1  0 1 0\n" << camera << "\n"
       << "Film \"rgb\" \"integer xresolution\" [ 32 ] \"integer yresolution\" [ 32 ]\n"
       << "Sampler \"zsobol\" \"integer pixelsamples\" [ 16 ]\nPixelFilter \"box\"\n"
       << "Integrator \"path\" \"integer maxdepth\" [ 0 ]\nWorldBegin\n"
       << "AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ] \"bool twosided\" true\n"
       << "Shape \"trianglemesh\" \"point3 P\" [ -0.5 -0.5 " << z << "  0.5 -0.5 " << z
       << "  0.5 0.5 " << z << "  -0.5 0.5 " << z << " ] \"integer indices\" [ 0 1 2  0 2 3 ]\n";
    return os.str();
}

double coverage(const std::string &camera, float z) {
    auto sc = scene_from_string(square_scene(camera, z));
    return image_mean(render_image(*sc), 0);
}

}  // namespace

TEST_CASE("orthographic: the screen window maps to world units, whatever the distance") {
    // Screen window [-1, 1]^2 is 2x2 world units: the unit square covers a quarter of it.
    const std::string ortho = "Camera \"orthographic\"";
    CHECK(coverage(ortho, 2.f) == test::Approx(0.25).epsilon(0.01));
    CHECK(coverage(ortho, 20.f) == test::Approx(0.25).epsilon(0.01));
    // screenwindow scales the view.
    CHECK(coverage("Camera \"orthographic\" \"float screenwindow\" [ -0.5 0.5 -0.5 0.5 ]", 5.f) ==
          test::Approx(1.0).epsilon(0.01));
}

TEST_CASE("perspective: fov spans the shorter axis; the square shrinks with distance") {
    // fov 90: at distance z the view is 2z wide, so the square covers (1 / 2z)^2.
    const std::string persp = "Camera \"perspective\" \"float fov\" [ 90 ]";
    CHECK(coverage(persp, 1.f) == test::Approx(0.25).epsilon(0.02));
    CHECK(coverage(persp, 2.f) == test::Approx(0.0625).epsilon(0.03));
}
