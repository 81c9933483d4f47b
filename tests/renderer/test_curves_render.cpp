// pbrt-v4 "curve" shapes: intersection against hand-computed hits, and renders whose coverage
// and shading have closed forms (orthographic views of straight curves).
#include <doctest/doctest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/scene/geometry.h"

using namespace tessera;

namespace {

/// An orthographic camera looking down -z at the square [-1, 1]^2 of the plane z = 0, a box
/// filter, direct lighting only, and `world` after WorldBegin.
std::string ortho_scene(const std::string &world, int res = 64, int spp = 16) {
    std::ostringstream os;
    os << "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"orthographic\"\n"
       << "Film \"rgb\" \"integer xresolution\" [ " << res << " ] \"integer yresolution\" [ "
       << res << " ]\nSampler \"zsobol\" \"integer pixelsamples\" [ " << spp << " ]\n"
       << "PixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
       << world;
    return os.str();
}

/// A black curve in front of a white sky: the image mean is the uncovered fraction.
double uncovered(const std::string &curve) {
    auto scene = test::scene_from_string(ortho_scene(
        "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
        "Material \"diffuse\" \"rgb reflectance\" [ 0 0 0 ]\n" + curve));
    return test::image_mean(test::render_image(*scene, 1), 1);
}

}  // namespace

TEST_CASE("curve: a ray hits a flat curve where its width says, with pbrt-v4's v and normal") {
    // A straight cubic Bezier along x (evenly spaced control points: u is linear in x), 0.5
    // wide, in the plane z = 0; as given, mirrored in x, reversed, or both.
    const std::string curve =
        "Shape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] \"float width\" 0.5\n";
    for (int variant = 0; variant < 4; ++variant) {
        const bool reverse = variant & 1, mirror = variant & 2;
        CAPTURE(reverse);
        CAPTURE(mirror);
        auto scene = test::scene_from_string(
            ortho_scene(std::string(reverse ? "ReverseOrientation\n" : "") +
                        (mirror ? "Scale -1 1 1\n" : "") + curve));
        const Geometry &g = *scene->geometry;
        auto hit = g.intersect(Ray{{0.1f, 0.05f, 5.f}, {0.f, 0.f, -1.f}, kInfinity});
        REQUIRE(hit);
        CHECK(hit->t == test::Approx(5.0).epsilon(1e-5));
        CHECK(hit->p.x == test::Approx(0.1).epsilon(1e-5));
        CHECK(hit->p.y == test::Approx(0.05).epsilon(1e-5));
        CHECK(std::abs(hit->p.z) < 1e-5f);
        // u along the segment (object x = -0.1 when mirrored); v across the width in object
        // space: 0.5 + 0.05 / 0.5 on the side of cross(ray direction, dpdu) = cross(-z, +x) =
        // -y, so below 0.5, mirrored or not.
        CHECK(hit->uv.x == test::Approx(((mirror ? -0.1 : 0.1) + 3.0) / 6.0).epsilon(1e-3));
        CHECK(hit->uv.y == test::Approx(0.4).epsilon(1e-3));
        // pbrt-v4's flat-curve normal cross(dpdu, dpdv) points along the object-space ray,
        // flipped by ReverseOrientation xor a handedness swap.
        CHECK(hit->n.z == test::Approx(reverse != mirror ? 1.0 : -1.0).epsilon(1e-6));
        CHECK(hit->ns.z == hit->n.z);
        CHECK(hit->dpdu.x == test::Approx(mirror ? -6.0 : 6.0).epsilon(1e-4));
        CHECK(hit->dpdv.y == test::Approx(-0.5).epsilon(1e-4));
        // The error bound is the width at the hit (pbrt-v4): spawned rays clear the ribbon.
        CHECK(hit->p_error.x == test::Approx(0.5).epsilon(1e-6));
        CHECK(g.object_material(hit->object_id) == hit->material);
        // Outside the width, and beyond the end of the curve: misses.
        CHECK_FALSE(g.intersect(Ray{{0.1f, 0.26f, 5.f}, {0.f, 0.f, -1.f}, kInfinity}));
        CHECK_FALSE(g.intersect(Ray{{3.1f, 0.f, 5.f}, {0.f, 0.f, -1.f}, kInfinity}));
        CHECK(g.occluded(Ray{{0.f, 0.2f, 5.f}, {0.f, 0.f, -1.f}, 10.f}));
        CHECK_FALSE(g.occluded(Ray{{0.f, 0.2f, 5.f}, {0.f, 0.f, -1.f}, 4.9f}));
    }
}

TEST_CASE("curve: degenerate ends and normals give finite hits; alpha 0 hides a curve") {
    // A tip of width 0: hits near it have a finite v and a positive error bound.
    auto tip = test::scene_from_string(ortho_scene(
        "Shape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] \"float width0\" 0.5 "
        "\"float width1\" 0\n"));
    for (float x : {2.9f, 2.99f, 2.999f}) {
        CAPTURE(x);
        auto hit = tip->geometry->intersect(Ray{{x, 0.f, 5.f}, {0.f, 0.f, -1.f}, kInfinity});
        REQUIRE(hit);
        CHECK(std::isfinite(hit->uv.y));
        CHECK(hit->uv.y >= 0.f);
        CHECK(hit->uv.y <= 1.f);
        CHECK(hit->p_error.x > 0.f);
        CHECK(std::isfinite(hit->n.z));
    }
    // Opposite normals at a ribbon's ends (pbrt-v4's slerp divides by zero there): the ribbon
    // turns half a revolution about its tangent; every hit is finite, and so is the image.
    auto twist = test::scene_from_string(ortho_scene(
        "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
        "Shape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] \"float width\" 0.5 "
        "\"string type\" \"ribbon\" \"normal N\" [ 0 0 1  0 0 -1 ]\n"));
    auto hit = twist->geometry->intersect(Ray{{-2.9f, 0.f, 5.f}, {0.f, 0.f, -1.f}, kInfinity});
    REQUIRE(hit);
    CHECK(std::isfinite(hit->n.x + hit->n.y + hit->n.z));
    CHECK(std::isfinite(hit->uv.y));
    sampling::Film film(uint32_t(twist->settings.width), uint32_t(twist->settings.height));
    render_scene(*twist, film, 1, 0.0, true, nullptr);
    CHECK(film.nan_count() == 0);
    sampling::RgbImage img(film.width(), film.height(), film.beauty_rgb());
    double lo = 1, hi = 0;
    for (float v : img.data) {
        lo = std::min(lo, double(v));
        hi = std::max(hi, double(v));
    }
    CHECK(lo >= 0.0);
    CHECK(hi <= 1.0 + 1e-5);
    CHECK(lo < 0.5);  // the ribbon is seen where it faces the view
    // Constant alpha 0: invisible, as in pbrt-v4.
    CHECK(uncovered("Shape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] "
                    "\"float width\" 0.5 \"float alpha\" 0\n") == 1.0);
}

TEST_CASE("curve: coverage of straight curves in every basis and degree is their width") {
    // The view is 2 units tall: a horizontal curve of width w wider than the view covers w / 2
    // of it. Control points are evenly spaced along x, so the parameter is linear in x.
    struct Case {
        const char *name, *shape;
        double covered;
    };
    const Case cases[] = {
        {"cubic Bezier", "\"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] \"float width\" 0.5", 0.25},
        {"two cubic Bezier segments",
         "\"point3 P\" [ -3 0 0  -2 0 0  -1 0 0  0 0 0  1 0 0  2 0 0  3 0 0 ] \"float width\" 0.6",
         0.3},
        {"quadratic Bezier", "\"point3 P\" [ -4 0 0  -2 0 0  0 0 0  2 0 0  4 0 0 ] "
                             "\"integer degree\" 2 \"float width\" 0.5", 0.25},
        // Uniform B-splines: the cubic spans (q0 + 4 q1 + q2) / 6 = -3 .. 3, the quadratic
        // (q0 + q1) / 2 = -4 .. 4.
        {"cubic B-spline", "\"point3 P\" [ -5 0 0  -3 0 0  -1 0 0  1 0 0  3 0 0  5 0 0 ] "
                           "\"string basis\" \"bspline\" \"float width\" 0.4", 0.2},
        {"quadratic B-spline", "\"point3 P\" [ -5 0 0  -3 0 0  -1 0 0  1 0 0  3 0 0  5 0 0 ] "
                               "\"string basis\" \"bspline\" \"integer degree\" 2 "
                               "\"float width\" 0.4", 0.2},
        // width0 -> width1 linearly over the whole curve: 0.6 at x = -1, 0.4 at x = 1.
        {"tapered", "\"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] \"float width0\" 0.8 "
                    "\"float width1\" 0.2", 0.25},
        {"cylinder type", "\"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] \"float width\" 0.5 "
                          "\"string type\" \"cylinder\"", 0.25},
    };
    for (const Case &c : cases) {
        CAPTURE(c.name);
        CHECK(uncovered(std::string("Shape \"curve\" ") + c.shape + "\n") ==
              test::Approx(1.0 - c.covered).epsilon(0.005));
    }
    // A bent curve inside the view covers its width times its length (its curvature radius,
    // above 0.2, is many widths): the tessellation follows the curve.
    {
        const Vec3f b[4] = {{-0.8f, -0.5f, 0.f}, {-0.3f, 0.8f, 0.f}, {0.3f, -0.8f, 0.f},
                            {0.8f, 0.5f, 0.f}};
        double len = 0;
        Vec3f prev = b[0];
        for (int i = 1; i <= 20000; ++i) {
            float u = float(i) / 20000.f, v = 1 - u;
            Vec3f p = b[0] * (v * v * v) + b[1] * (3 * u * v * v) + b[2] * (3 * u * u * v) +
                      b[3] * (u * u * u);
            len += double(length(p - prev));
            prev = p;
        }
        const double w = 0.02;
        const double covered = 1.0 - uncovered("Shape \"curve\" \"point3 P\" [ -0.8 -0.5 0  "
                                               "-0.3 0.8 0  0.3 -0.8 0  0.8 0.5 0 ] "
                                               "\"float width\" 0.02\n");
        CHECK(covered == test::Approx(w * len / 4.0).epsilon(0.01));
    }
    // The width is in object space: a curve scaled by 2 is twice as wide.
    CHECK(uncovered("Scale 2 2 2\nShape \"curve\" \"point3 P\" [ -1.5 0 0  -0.5 0 0  0.5 0 0  "
                    "1.5 0 0 ] \"float width\" 0.25\n") ==
          test::Approx(0.75).epsilon(0.005));
    // Instanced curves cover the same.
    CHECK(uncovered("ObjectBegin \"c\"\nShape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  "
                    "3 0 0 ] \"float width\" 0.5\nObjectEnd\nAttributeBegin\nTranslate 0 0.3 0\n"
                    "ObjectInstance \"c\"\nAttributeEnd\n") ==
          test::Approx(0.75).epsilon(0.005));
}

TEST_CASE("curve: ribbons follow their normals; cylinders bend the normal across the width") {
    // A ribbon's plane holds the tangent (x) and cross(N, x): N = (0, sin a, cos a) tilts it by
    // a from the view, so it covers w cos(a) / 2 of the 2-unit view.
    const double a = 60.0 * kPi / 180.0;
    std::ostringstream n;
    n << "0 " << std::sin(a) << " " << std::cos(a);
    const std::string ribbon = "Shape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] "
                               "\"float width\" 0.8 \"string type\" \"ribbon\" \"normal N\" [ ";
    CHECK(uncovered(ribbon + "0 0 1  0 0 1 ]\n") == test::Approx(0.6).epsilon(0.005));
    CHECK(uncovered(ribbon + n.str() + "  " + n.str() + " ]\n") ==
          test::Approx(1.0 - 0.8 * std::cos(a) / 2).epsilon(0.005));
    // "N" on a flat curve is ignored (pbrt-v4 warns and discards it).
    CHECK(uncovered("Shape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] "
                    "\"float width\" 0.8 \"normal N\" [ 0 1 0  0 1 0 ]\n") ==
          test::Approx(0.6).epsilon(0.005));

    // White curves lit head-on by a distant light (irradiance E = 3), direct light only. A
    // flat curve faces the light: radiance E / pi. A "cylinder" curve's normal turns from -90
    // to 90 degrees across the width, so its mean radiance is (2 / pi) E / pi.
    auto lit = [](const char *type) {
        auto scene = test::scene_from_string(ortho_scene(
            "LightSource \"distant\" \"point3 from\" [ 0 0 5 ] \"point3 to\" [ 0 0 0 ] "
            "\"rgb L\" [ 3 3 3 ]\nMaterial \"diffuse\" \"rgb reflectance\" [ 1 1 1 ]\n"
            "Shape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] \"float width\" 1 "
            "\"string type\" \"" + std::string(type) + "\"\n", 64, 64));
        return test::image_mean(test::render_image(*scene, 1), 0);
    };
    const double flat = lit("flat"), cylinder = lit("cylinder");
    CHECK(flat == test::Approx(0.5 * 3.0 / kPi).epsilon(0.005));
    CHECK(cylinder / flat == test::Approx(2.0 / kPi).epsilon(0.01));
}
