// Cameras: pbrt-v4's orthographic projection and the perspective field of view.
#include <doctest/doctest.h>

#include <cstdint>
#include <sstream>
#include <vector>

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

TEST_CASE("pixel filters: weighted samples estimate the normalised filter int f g / int f") {
    // g is a smooth test function of the offset; the reference integral is a midpoint rule on
    // a fine grid of PixelFilter::evaluate (the analytic filter), the estimate the mean of
    // w g(p) over 512^2 stratified samples (so both the sampled positions and the signed
    // weights of the mitchell and sinc filters are checked).
    auto g = [](Vec2f p) { return 1.0 + 0.3 * p.x + p.x * p.x + 0.5 * p.y * p.y + std::cos(p.y); };
    const PixelFilter filters[] = {
        PixelFilter(PixelFilter::Kind::Box, {0.5f, 0.5f}),
        PixelFilter(PixelFilter::Kind::Triangle, {2.f, 1.5f}),
        PixelFilter(PixelFilter::Kind::Gaussian, {1.5f, 1.5f}, 0.5f),
        PixelFilter::mitchell({2.f, 2.f}, 1.f / 3.f, 1.f / 3.f),
        PixelFilter::mitchell({1.5f, 2.5f}, 0.f, 0.5f),
        PixelFilter::lanczos({4.f, 4.f}, 3.f),
    };
    for (const PixelFilter &f : filters) {
        CAPTURE(f.describe());
        const Vec2f r = f.radius();
        const int n = 2000;
        double sf = 0, sfg = 0;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                Vec2f p{-r.x + (i + 0.5f) * 2 * r.x / n, -r.y + (j + 0.5f) * 2 * r.y / n};
                double v = f.evaluate(p);
                sf += v;
                sfg += v * g(p);
            }
        const double expected = sfg / sf;
        // Latin hypercube: each axis stratified in 2^20 strata (the y strata permuted), so
        // that every cell of the filter's tables gets its share of samples.
        const uint32_t m = 1u << 20;
        std::vector<uint32_t> perm(m);
        for (uint32_t i = 0; i < m; ++i) perm[i] = i;
        uint64_t state = 0x9e3779b97f4a7c15ull;
        for (uint32_t i = m - 1; i > 0; --i) {
            state = state * 6364136223846793005ull + 1442695040888963407ull;
            std::swap(perm[i], perm[uint32_t((state >> 33) % (i + 1))]);
        }
        double sum = 0, sum_w = 0;
        int negative = 0, outside = 0;
        for (uint32_t i = 0; i < m; ++i) {
            float w = 0;
            Vec2f p = f.sample({(i + 0.5f) / m, (perm[i] + 0.5f) / m}, &w);
            outside += std::abs(p.x) > r.x || std::abs(p.y) > r.y;
            sum += w * g(p);
            sum_w += w;
            negative += w < 0;
        }
        CHECK(outside == 0);
        CHECK(sum / m == test::Approx(expected).epsilon(2e-3).scale(0));
        CHECK(sum_w / m == test::Approx(1.0).epsilon(2e-3).scale(0));
        CHECK(f.has_negative_lobes() == (negative > 0));
    }
}
