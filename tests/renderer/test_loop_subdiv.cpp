// Loop subdivision ("loopsubdiv"): counts, smoothness and orientation on known meshes.
#include <doctest/doctest.h>

#include <cmath>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/input/loop_subdiv.h"

using namespace tessera;

namespace {

/// The regular octahedron with outward-facing triangles (every vertex has valence 4).
void octahedron(std::vector<Vec3f> &p, std::vector<uint32_t> &idx) {
    p = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    idx = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
}

}  // namespace

TEST_CASE("loop subdivision of a closed octahedron: counts, a smooth convex limit, orientation") {
    std::vector<Vec3f> p;
    std::vector<uint32_t> idx;
    octahedron(p, idx);
    for (int levels : {0, 1, 3}) {
        SubdividedMesh m = loop_subdivide(p, idx, levels);
        INFO("levels " << levels);
        size_t faces = 8u << (2 * levels);
        CHECK(m.indices.size() == 3 * faces);
        // Euler: V - E + F = 2 for a closed genus-0 mesh, E = 3F/2.
        CHECK(m.p.size() == faces / 2 + 2);
        double rmin = 1e9, rmax = 0;
        for (size_t v = 0; v < m.p.size(); ++v) {
            double r = length(m.p[v]);
            rmin = std::min(rmin, r);
            rmax = std::max(rmax, r);
            CHECK(length(m.n[v]) == test::Approx(1.0).epsilon(1e-5));
            CHECK(dot(m.n[v], m.p[v]) > 0.f);  // outward, like the input triangles
        }
        if (levels > 0) {
            // The limit surface lies inside the control hull and is far rounder than it.
            CHECK(rmax < 1.0);
            CHECK(rmin / rmax > 0.8);
        }
    }
    // Every vertex of the regular octahedron has the same limit position radius by symmetry:
    // the six original vertices move to the same distance from the centre.
    SubdividedMesh m = loop_subdivide(p, idx, 2);
    for (int v = 1; v < 6; ++v) CHECK(length(m.p[size_t(v)]) == test::Approx(length(m.p[0])));
}

TEST_CASE("loop subdivision keeps a flat open patch flat (boundary rules)") {
    std::vector<Vec3f> p = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    std::vector<uint32_t> idx = {0, 1, 2, 0, 2, 3};
    SubdividedMesh m = loop_subdivide(p, idx, 3);
    CHECK(m.indices.size() == 3 * 2 * 64);
    for (size_t v = 0; v < m.p.size(); ++v) {
        CHECK(m.p[v].z == test::Approx(0.0));
        CHECK(m.n[v].z == test::Approx(1.0));
        CHECK(m.p[v].x >= -1e-6f);
        CHECK(m.p[v].x <= 1.f + 1e-6f);
    }
}

TEST_CASE("a loopsubdiv shape renders like a smooth sphere-ish surface") {
    const char *scene = R"(
LookAt 0 0 -4  0 0 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
Sampler "zsobol" "integer pixelsamples" [ 16 ]
Integrator "path" "integer maxdepth" [ 5 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Material "diffuse" "rgb reflectance" [ 1 1 1 ]
Shape "loopsubdiv" "integer levels" [ 2 ]
  "point3 P" [ 1 0 0  -1 0 0  0 1 0  0 -1 0  0 0 1  0 0 -1 ]
  "integer indices" [ 0 2 4  2 1 4  1 3 4  3 0 4  2 0 5  1 2 5  3 1 5  0 3 5 ]
)";
    int before = warning_count();
    auto sc = test::scene_from_string(scene);
    CHECK(warning_count() == before);  // "levels" is used, nothing is ignored
    // A convex white object under a white sky is a white furnace: 1 everywhere.
    CHECK(test::image_mean(test::render_image(*sc), 1) == test::Approx(1.0).epsilon(0.01));
}
