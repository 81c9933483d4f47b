// pbrt-v4's "cylinder" shape: exact hits against the analytic surface, pbrt's defaults and
// parameterisation, clipping by zmin/zmax/phimax, transforms, and a render whose mean is known.
#include <doctest/doctest.h>

#include <cmath>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/scene/geometry.h"

using namespace tessera;

namespace {

std::unique_ptr<Scene> cylinder_scene(const std::string &shape, const std::string &xf = "") {
    return test::scene_from_string("WorldBegin\nLightSource \"point\" \"point3 from\" [0 0 10]\n" +
                                   xf + "\nShape \"cylinder\" " + shape + "\n");
}

std::optional<SurfaceInteraction> hit(const Scene &sc, Vec3f o, Vec3f d) {
    return sc.geometry->intersect(Ray{o, normalize(d), kInfinity});
}

}  // namespace

TEST_CASE("cylinder: pbrt-v4 defaults (radius 1, z in [-1, 1]), outward normal, uv, dpdu/dpdv") {
    auto sc = cylinder_scene("");
    REQUIRE(sc);
    CHECK(sc->features.quadrics);
    // From +x toward the axis at z = 0.5: hits x = 1.
    auto h = hit(*sc, {5, 0, 0.5f}, {-1, 0, 0});
    REQUIRE(h);
    CHECK(h->t == test::Approx(4.f).epsilon(1e-6));
    CHECK(h->p.x == test::Approx(1.f).epsilon(1e-6));
    CHECK(h->p.z == test::Approx(0.5f).epsilon(1e-6));
    CHECK(h->n.x == test::Approx(1.f));  // away from the axis
    CHECK(h->n.y == test::Approx(0.f));
    CHECK(h->n.z == test::Approx(0.f));
    CHECK(h->uv.x == test::Approx(0.f).epsilon(1e-6));  // phi = 0
    CHECK(h->uv.y == test::Approx(0.75f));              // (0.5 - -1) / 2
    // dpdu = phimax * (-y, x, 0), dpdv = (0, 0, zmax - zmin).
    CHECK(h->dpdu.y == test::Approx(2 * kPi));
    CHECK(h->dpdv.z == test::Approx(2.f));
    // The error bound keeps a spawned ray off the surface on both sides.
    Ray out = h->spawn_ray({1, 0, 0});
    CHECK(out.o.x > 1.f);
    CHECK_FALSE(sc->geometry->intersect(out));
    Ray in = h->spawn_ray({-1, 0, 0});
    CHECK(in.o.x < 1.f);
    auto far = sc->geometry->intersect(in);
    REQUIRE(far);
    CHECK(far->p.x == test::Approx(-1.f).epsilon(1e-6));
    CHECK(far->n.x == test::Approx(-1.f));  // still away from the axis, seen from inside

    // At phi = 90 degrees: u = 0.25.
    auto h90 = hit(*sc, {0, 3, -0.25f}, {0, -1, 0});
    REQUIRE(h90);
    CHECK(h90->uv.x == test::Approx(0.25f));
    CHECK(h90->uv.y == test::Approx(0.375f));
    CHECK(h90->n.y == test::Approx(1.f));
}

TEST_CASE("cylinder: open ends, z range, phimax and rays along the axis") {
    auto sc = cylinder_scene("\"float radius\" [ 0.5 ] \"float zmin\" [ 0 ] \"float zmax\" [ 2 ] "
                             "\"float phimax\" [ 180 ]");
    REQUIRE(sc);
    // Above and below the z range: miss.
    CHECK_FALSE(hit(*sc, {5, 0.1f, 2.5f}, {-1, 0, 0}));
    CHECK_FALSE(hit(*sc, {5, 0.1f, -0.1f}, {-1, 0, 0}));
    // Along the axis through the open ends: miss (no caps), also exactly on the axis.
    CHECK_FALSE(hit(*sc, {0, 0.2f, -5}, {0, 0, 1}));
    CHECK_FALSE(hit(*sc, {0, 0, -5}, {0, 0, 1}));
    // phimax 180: the y > 0 half only. From -y toward +y the ray passes the missing half and
    // hits the inside of the kept half at y = +0.5.
    auto h = hit(*sc, {0.1f, -5, 1}, {0, 1, 0});
    REQUIRE(h);
    CHECK(h->p.y == test::Approx(std::sqrt(0.25f - 0.01f)).epsilon(1e-5));
    CHECK(h->n.y > 0.9f);
    // Slanted through the open top: hits the inside wall.
    auto in = hit(*sc, {0, 0.1f, 3}, {0, 0.2f, -1});
    REQUIRE(in);
    CHECK(in->p.y == test::Approx(0.5f).epsilon(1e-5));
    CHECK(in->p.z == test::Approx(3.f - 0.4f / 0.2f).epsilon(1e-5));
}

TEST_CASE("cylinder: transforms, zmin > zmax swapped, ReverseOrientation flips the normal") {
    // Rotated so that its axis is world x, moved to y = 2; zmin/zmax given reversed.
    auto sc = cylinder_scene("\"float radius\" [ 0.25 ] \"float zmin\" [ 1 ] \"float zmax\" [ -1 ]",
                             "Translate 0 2 0\nRotate 90 0 1 0");
    REQUIRE(sc);
    auto h = hit(*sc, {0.5f, 2, 5}, {0, 0, -1});
    REQUIRE(h);
    CHECK(h->p.z == test::Approx(0.25f).epsilon(1e-5));
    CHECK(h->n.z == test::Approx(1.f).epsilon(1e-5));
    CHECK_FALSE(hit(*sc, {1.5f, 2, 5}, {0, 0, -1}));  // beyond the (swapped) z range

    auto rev = cylinder_scene("", "ReverseOrientation");
    REQUIRE(rev);
    auto hr = hit(*rev, {5, 0, 0}, {-1, 0, 0});
    REQUIRE(hr);
    CHECK(hr->n.x == test::Approx(-1.f));
}

TEST_CASE("cylinder: a diffuse cylinder under a uniform sky renders albedo x sky where it is seen") {
    // Orthographic camera looking down -z at a cylinder lying along x: it covers the band
    // |y| < r over x in [zmin, zmax]. A convex outer surface sees the whole sky: radiance = a * L.
    const float a = 0.5f;
    auto sc = test::scene_from_string(R"(
LookAt 0 0 5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [ -1 1 -1 1 ]
Film "rgb" "integer xresolution" [ 64 ] "integer yresolution" [ 64 ]
Sampler "sobol" "integer pixelsamples" [ 16 ]
Integrator "path" "integer maxdepth" [ 5 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Rotate 90 0 1 0
Shape "cylinder" "float radius" [ 0.4 ] "float zmin" [ -0.5 ] "float zmax" [ 0.5 ]
)");
    REQUIRE(sc);
    sampling::RgbImage img = test::render_image(*sc);
    // Coverage of the [-1,1]^2 screen: (2 * 0.4) * 1.0 / 4 = 0.2; the rest is the sky (1).
    const double coverage = 0.2;
    const double expect = 1.0 - (1.0 - a) * coverage;
    for (int c = 0; c < 3; ++c)
        CHECK(test::image_mean(img, c) == test::Approx(expect).epsilon(0.01));
    // The centre pixel is on the cylinder, a corner on the sky.
    const size_t centre = (32 * 64 + 32) * 3, corner = 0;
    CHECK(img.data[centre] == test::Approx(a).epsilon(0.05));
    CHECK(img.data[corner] == test::Approx(1.f).epsilon(1e-4));
}

TEST_CASE("cylinder emitter (and a partial sphere): light, BSDF and MIS estimates agree") {
    // A diffuse floor lit by an emissive open cylinder standing on it and by a hemisphere
    // (partial sphere) above: both use QuadricAreaLight (uniform area sampling). The camera
    // sees the floor and the emitters.
    auto sc = test::scene_from_string(R"(
LookAt 0 3 -4  0 0.5 0  0 1 0
Camera "perspective" "float fov" [ 50 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
Sampler "zsobol" "integer pixelsamples" [ 256 ]
Integrator "path" "integer maxdepth" [ 1 ]
WorldBegin
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ] "integer indices" [ 0 1 2  0 2 3 ]
AttributeBegin
AreaLightSource "diffuse" "rgb L" [ 2 1.5 1 ]
Rotate -90 1 0 0
Shape "cylinder" "float radius" [ 0.3 ] "float zmin" [ 0 ] "float zmax" [ 1.2 ]
AttributeEnd
AttributeBegin
AreaLightSource "diffuse" "rgb L" [ 0.5 1 2 ]
Translate 1.5 1.5 1
Shape "sphere" "float radius" [ 0.4 ] "float zmin" [ 0 ]
AttributeEnd
)");
    REQUIRE(sc);
    sampling::RgbImage mis = test::render_with_strategy(*sc, DirectStrategy::Mis, 5);
    sampling::RgbImage light = test::render_with_strategy(*sc, DirectStrategy::LightOnly, 5);
    sampling::RgbImage bsdf = test::render_with_strategy(*sc, DirectStrategy::BsdfOnly, 5);
    for (int c = 0; c < 3; ++c) {
        double m = test::image_mean(mis, c), l = test::image_mean(light, c),
               b = test::image_mean(bsdf, c);
        INFO("channel " << c << ": MIS " << m << ", light " << l << ", BSDF " << b);
        CHECK(m > 0.02);
        CHECK(l == test::Approx(m).epsilon(0.03));
        CHECK(b == test::Approx(m).epsilon(0.03));
    }
}
