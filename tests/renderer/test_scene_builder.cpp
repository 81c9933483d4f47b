// scene_builder.cpp: pbrt-v4 defaults when a directive is absent, command-line overrides,
// SceneFeatures flags, and warnings (not errors) for unsupported shapes and materials.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/util/image_io.h"
#include "renderer/input/scene_desc.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

/// Builds a scene from text under a file name of its own: warn() prints each distinct
/// "file:line: warning: message" once per process, so a unique name keeps counts meaningful.
std::unique_ptr<Scene> build_named(const std::string &text, const std::string &file,
                                   const SceneOverrides &ov = {}) {
    return build_scene(parse_pbrt_string(text, file, ""), ov);
}

/// Angle in degrees between the camera's forward axis and the ray through raster point p.
double ray_angle_deg(const Scene &sc, Vec2f p) {
    CameraRay cr = sc.camera->generate_ray(p, {0.5f, 0.5f});
    Vec3f d = normalize(cr.ray.d);
    double c = std::clamp(double(dot(d, sc.camera->forward())), -1.0, 1.0);
    return std::acos(c) * 180.0 / 3.14159265358979323846;
}

const char *kOneTriangle = R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 -2 ] "rgb I" [ 1 1 1 ]
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
)";

}  // namespace

TEST_CASE("build_scene: pbrt-v4 defaults when Film, Sampler, Integrator, Filter, Camera are absent") {
    std::unique_ptr<Scene> sc = scene_from_string(kOneTriangle);
    REQUIRE(sc);
    CHECK(sc->settings.width == 1280);
    CHECK(sc->settings.height == 720);
    CHECK(sc->settings.spp == 16);
    CHECK(sc->settings.max_depth == 5);
    CHECK(sc->settings.seed == 0u);
    CHECK(sc->settings.output == "pbrt.exr");
    CHECK(sc->filter.kind() == PixelFilter::Kind::Gaussian);
    CHECK(sc->filter.radius().x == test::Approx(1.5f));
    CHECK(sc->filter.radius().y == test::Approx(1.5f));
    // fov 90 spans the shorter (vertical) axis: the ray through the middle of the top edge is
    // 45 degrees off axis; the one through the middle of the left edge is atan(16/9) off.
    CHECK(ray_angle_deg(*sc, {640.f, 0.f}) == test::Approx(45.0).epsilon(1e-4));
    CHECK(ray_angle_deg(*sc, {0.f, 360.f}) ==
          test::Approx(std::atan(1280.0 / 720.0) * 180.0 / 3.14159265358979323846)
              .epsilon(1e-4));
    CHECK(ray_angle_deg(*sc, {640.f, 360.f}) == test::Approx(0.0).epsilon(1e-3));
}

TEST_CASE("build_scene: defaults inside directives that are present but give no parameters") {
    std::unique_ptr<Scene> sc = scene_from_string(R"(
Film "rgb"
Sampler "zsobol"
Integrator "path"
PixelFilter "gaussian"
Camera "perspective"
)" + std::string(kOneTriangle));
    CHECK(sc->settings.width == 1280);
    CHECK(sc->settings.height == 720);
    CHECK(sc->settings.spp == 16);
    CHECK(sc->settings.max_depth == 5);
    CHECK(sc->filter.kind() == PixelFilter::Kind::Gaussian);
    CHECK(sc->filter.radius().x == test::Approx(1.5f));
    CHECK(ray_angle_deg(*sc, {640.f, 0.f}) == test::Approx(45.0).epsilon(1e-4));
}

TEST_CASE("build_scene: scene values are read, and box/triangle filters keep pbrt's radii") {
    std::unique_ptr<Scene> sc = scene_from_string(R"(
Film "rgb" "integer xresolution" [ 64 ] "integer yresolution" [ 32 ] "string filename" "x.exr"
Sampler "zsobol" "integer pixelsamples" [ 8 ] "integer seed" [ 7 ]
Integrator "path" "integer maxdepth" [ 3 ]
PixelFilter "triangle"
Camera "perspective" "float fov" [ 30 ]
)" + std::string(kOneTriangle));
    CHECK(sc->settings.width == 64);
    CHECK(sc->settings.height == 32);
    CHECK(sc->settings.spp == 8);
    CHECK(sc->settings.seed == 7u);
    CHECK(sc->settings.max_depth == 3);
    CHECK(sc->settings.output == "x.exr");
    CHECK(sc->filter.kind() == PixelFilter::Kind::Triangle);
    CHECK(sc->filter.radius().x == test::Approx(2.f));
    CHECK(ray_angle_deg(*sc, {32.f, 0.f}) == test::Approx(15.0).epsilon(1e-4));

    std::unique_ptr<Scene> box = scene_from_string("PixelFilter \"box\"\n" +
                                                   std::string(kOneTriangle));
    CHECK(box->filter.kind() == PixelFilter::Kind::Box);
    CHECK(box->filter.radius().x == test::Approx(0.5f));
}

TEST_CASE("build_scene: SceneOverrides win over the scene file") {
    const std::string text = R"(
Film "rgb" "integer xresolution" [ 64 ] "integer yresolution" [ 32 ]
Sampler "zsobol" "integer pixelsamples" [ 8 ] "integer seed" [ 7 ]
Integrator "path" "integer maxdepth" [ 3 ]
)" + std::string(kOneTriangle);
    SceneOverrides ov;
    ov.width = 20;
    ov.height = 10;
    ov.spp = 3;
    ov.seed = 99;
    ov.max_depth = 0;
    std::unique_ptr<Scene> sc = scene_from_string(text, ov);
    CHECK(sc->settings.width == 20);
    CHECK(sc->settings.height == 10);
    CHECK(sc->settings.spp == 3);
    CHECK(sc->settings.seed == 99u);
    CHECK(sc->settings.max_depth == 0);
    // The camera is built for the overridden film: the top-edge ray still spans fov/2 = 45.
    CHECK(ray_angle_deg(*sc, {10.f, 0.f}) == test::Approx(45.0).epsilon(1e-4));

    // Unset fields keep the file's values.
    SceneOverrides only_spp;
    only_spp.spp = 5;
    std::unique_ptr<Scene> sc2 = scene_from_string(text, only_spp);
    CHECK(sc2->settings.width == 64);
    CHECK(sc2->settings.height == 32);
    CHECK(sc2->settings.spp == 5);
    CHECK(sc2->settings.seed == 7u);
    CHECK(sc2->settings.max_depth == 3);
}

TEST_CASE("build_scene: a non-positive resolution or sample count is an error") {
    SceneOverrides ov;
    ov.width = 0;
    CHECK_THROWS_AS(scene_from_string(kOneTriangle, ov), SceneError);
    CHECK_THROWS_AS(scene_from_string("Sampler \"zsobol\" \"integer pixelsamples\" [ 0 ]\n" +
                                      std::string(kOneTriangle)),
                    SceneError);
}

TEST_CASE("SceneFeatures: a plain scene has no optional features") {
    std::unique_ptr<Scene> sc = scene_from_string(kOneTriangle);
    const SceneFeatures &f = sc->features;
    CHECK_FALSE(f.textures);
    CHECK_FALSE(f.image_textures);
    CHECK_FALSE(sc->textures->has_image_maps());
    CHECK_FALSE(f.specular);
    CHECK_FALSE(f.transmission);
    CHECK_FALSE(f.emissive_shapes);
    CHECK_FALSE(f.environment);
    CHECK_FALSE(f.environment_map);
    CHECK(f.delta_lights);
    CHECK_FALSE(f.instances);
    CHECK_FALSE(f.quadrics);
    CHECK(sc->infinite_lights.empty());
    CHECK(sc->lights.size() == 1);
}

TEST_CASE("SceneFeatures: each feature is detected") {
    SUBCASE("procedural texture: textures, but no texture system") {
        std::unique_ptr<Scene> sc = scene_from_string(R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 -2 ] "rgb I" [ 1 1 1 ]
Texture "checks" "spectrum" "checkerboard" "rgb tex1" [ 1 0 0 ] "rgb tex2" [ 0 0 1 ]
Material "diffuse" "texture reflectance" "checks"
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
)");
        CHECK(sc->features.textures);
        CHECK_FALSE(sc->features.image_textures);
        CHECK_FALSE(sc->textures->has_image_maps());
    }
    SUBCASE("image texture: texture system") {
        std::string path = output_dir() + "/scene_builder_tex.png";
        write_rgb8(path, 2, 2, std::vector<uint8_t>(12, 128));
        std::unique_ptr<Scene> sc = scene_from_string(R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 -2 ] "rgb I" [ 1 1 1 ]
Texture "img" "spectrum" "imagemap" "string filename" ")" + path + R"("
Material "diffuse" "texture reflectance" "img"
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
)");
        CHECK(sc->features.textures);
        CHECK(sc->features.image_textures);
        CHECK(sc->textures->has_image_maps());
    }
    SUBCASE("constant infinite light: environment without a map") {
        std::unique_ptr<Scene> sc = scene_from_string(R"(
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Shape "sphere"
)");
        CHECK(sc->features.environment);
        CHECK_FALSE(sc->features.environment_map);
        CHECK_FALSE(sc->features.delta_lights);
        CHECK(sc->features.quadrics);
        CHECK(sc->infinite_lights.size() == 1);
    }
    SUBCASE("image infinite light: environment map") {
        std::string path = output_dir() + "/scene_builder_env.exr";
        write_exr(path, 4, 4, {{"", {"R", "G", "B"}, std::vector<float>(48, 0.5f), false}});
        std::unique_ptr<Scene> sc = scene_from_string(R"(
WorldBegin
LightSource "infinite" "string filename" ")" + path + R"("
Shape "sphere"
)");
        CHECK(sc->features.environment);
        CHECK(sc->features.environment_map);
        CHECK(sc->infinite_lights.size() == 1);
    }
    SUBCASE("specular, transmission, area lights, instances") {
        std::unique_ptr<Scene> sc = scene_from_string(R"(
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 1 1 1 ]
  Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
AttributeEnd
ObjectBegin "glassball"
  Material "dielectric"
  Shape "sphere" "float radius" 0.5
ObjectEnd
ObjectInstance "glassball"
)");
        CHECK(sc->features.specular);
        CHECK(sc->features.transmission);
        CHECK(sc->features.emissive_shapes);
        CHECK(sc->features.instances);
        CHECK(sc->features.quadrics);
        CHECK_FALSE(sc->features.delta_lights);
        CHECK(sc->geometry->instance_count() == 1);
        CHECK(sc->features.describe().find("instances") != std::string::npos);
    }
}

TEST_CASE("build_scene: an unknown shape type is an error naming its line, as in pbrt-v4") {
    // pbrt-v3's "hyperboloid" is not a pbrt-v4 shape: pbrt-v4 stops on it.
    CHECK_THROWS_WITH(build_named(R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 -2 ] "rgb I" [ 1 1 1 ]
Shape "hyperboloid" "point3 p1" [ 0 0 0 ] "point3 p2" [ 1 1 1 ]
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
)",
                                  "unknown_shape.pbrt"),
                      doctest::Contains("unknown_shape.pbrt:4: unknown shape type \"hyperboloid\""));
}

TEST_CASE("build_scene: curves warn where pbrt-v4 does (unknown type, stray normals, lights)") {
    struct Case {
        const char *shape, *expected;
    };
    const Case cases[] = {
        {R"(Shape "curve" "point3 P" [ 0 0 0  1 0 0  2 0 0  3 0 0 ] "string type" "tube")",
         "curve_warning.pbrt:4: warning: curve: unknown type \"tube\"; using \"cylinder\""},
        {R"(Shape "curve" "point3 P" [ 0 0 0  1 0 0  2 0 0  3 0 0 ] "normal N" [ 0 0 1  0 0 1 ])",
         "curve_warning.pbrt:4: warning: curve: normals \"N\" are only used by \"ribbon\""},
        {"AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
         "Shape \"curve\" \"point3 P\" [ 0 0 0  1 0 0  2 0 0  3 0 0 ]",
         "curve_warning.pbrt:4: warning: area lights on curves are not supported"},
    };
    for (const Case &c : cases) {
        CAPTURE(c.shape);
        const int before = warning_count();
        std::unique_ptr<Scene> sc = build_named(std::string(R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 -2 ] "rgb I" [ 1 1 1 ]
)") + c.shape + "\n",
                                                "curve_warning.pbrt");
        REQUIRE(sc);
        CHECK(warning_count() == before + 1);
        CHECK(last_warning().find(c.expected) == 0);
        CHECK(sc->features.curves);
        CHECK(sc->lights.size() == 1);
    }
}

TEST_CASE("build_scene: an unknown material type is an error naming its line") {
    CHECK_THROWS_WITH(build_named(R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 -2 ] "rgb I" [ 1 1 1 ]
Material "frobnium" "float shininess" [ 3 ]
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
)",
                                  "unknown_material.pbrt"),
                      doctest::Contains("unknown_material.pbrt:4: unknown material type \"frobnium\""));
}

TEST_CASE("build_scene: a pbrt-v4 material Tessera lacks warns and the scene still builds") {
    int before = warning_count();
    std::unique_ptr<Scene> sc = build_named(R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 -2 ] "rgb I" [ 1 1 1 ]
Material "measured" "string filename" [ "no-such.bsdf" ]
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
)",
                                            "unsupported_material.pbrt");
    REQUIRE(sc);
    CHECK(warning_count() > before);
    CHECK(sc->geometry->triangle_count() == 1);
    CHECK(sc->materials.size() >= 1);
    // It renders (with the fallback material) to finite values.
    SceneOverrides ov;
    ov.width = ov.height = 8;
    ov.spp = 1;
    std::unique_ptr<Scene> small = build_named(R"(
WorldBegin
LightSource "point" "point3 from" [ 0 0 -2 ] "rgb I" [ 1 1 1 ]
Material "subsurface"
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
)",
                                               "unsupported_material_small.pbrt", ov);
    sched::AdaptiveStats st;
    sampling::RgbImage img = render_image(*small, 1, &st);
    CHECK(st.nan_samples == 0);
    for (float v : img.data) CHECK(std::isfinite(v));
}

TEST_CASE("build_scene: a scene without lights warns that it will be black") {
    int before = warning_count();
    std::unique_ptr<Scene> sc = build_named(R"(
WorldBegin
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  0 1 1 ]
)",
                                            "no_lights_builder.pbrt");
    CHECK(warning_count() == before + 1);
    CHECK(last_warning().find("no lights") != std::string::npos);
    CHECK(sc->lights.empty());
    CHECK(sc->light_sampler == nullptr);
}

TEST_CASE("build_scene: Film \"gbuffer\" keeps the geometric AOVs, \"rgb\" none, --aov wins") {
    auto film = [](const std::string &type) {
        return "Film \"" + type + "\" \"integer xresolution\" [ 8 ] \"integer yresolution\" [ 8 ]" +
               std::string(kOneTriangle);
    };
    // pbrt-v4 semantics: "rgb" writes RGB only, "gbuffer" albedo, normal and depth.
    int before = warning_count();
    CHECK(build_named(film("rgb"), "film_rgb.pbrt")->settings.aovs.empty());
    CHECK(build_named(film("gbuffer"), "film_gbuffer.pbrt")->settings.aovs ==
          sampling::AovSet::all());
    CHECK(warning_count() == before);  // neither warns
    // No Film directive: pbrt-v4's default "rgb".
    CHECK(build_named(kOneTriangle, "film_default.pbrt")->settings.aovs.empty());
    // Other film types still render as "rgb", with a warning.
    CHECK(build_named(film("spectral"), "film_spectral.pbrt")->settings.aovs.empty());
    CHECK(warning_count() == before + 1);
    CHECK(last_warning().find("film_spectral.pbrt:1: warning: Film \"spectral\" is rendered as "
                              "an \"rgb\" film") == 0);
    // --aov overrides the Film type either way.
    SceneOverrides ov;
    ov.aovs = sampling::AovSet{sampling::Aov::Depth};
    CHECK(build_named(film("gbuffer"), "film_gbuffer_ov.pbrt", ov)->settings.aovs == *ov.aovs);
    ov.aovs = sampling::AovSet::all();
    CHECK(build_named(film("rgb"), "film_rgb_ov.pbrt", ov)->settings.aovs == *ov.aovs);
}

TEST_CASE("build_scene: area-light \"power\" is per pbrt-v4 shape: per triangle, per quad patch") {
    // Total emitted power (one-sided: pi * L * area per light) of a scene's lights.
    auto total_power = [](const Scene &sc) {
        double sum = 0;
        for (const auto &l : sc.lights) sum += l->phi().luminance();
        return sum;
    };
    const std::string head = "WorldBegin\nAreaLightSource \"diffuse\" \"float power\" [ 10 ]\n";
    // A 2x1 bilinear patch: one pbrt shape, 10 W in all (it was 10 W per triangle: 20 W).
    auto patch = test::scene_from_string(
        head + "Shape \"bilinearmesh\" \"point3 P\" [ 0 0 0  2 0 0  0 1 0  2 1 0 ]\n");
    REQUIRE(patch->lights.size() == 2);
    CHECK(total_power(*patch) == test::Approx(10.0).epsilon(1e-4));
    // Two patches of different sizes: 10 W each, 20 W in all.
    auto two = test::scene_from_string(
        head + "Shape \"bilinearmesh\" \"point3 P\" [ 0 0 0  2 0 0  0 1 0  2 1 0  "
               "0 0 5  1 0 5  0 1 5  1 1 5 ] \"integer indices\" [ 0 1 2 3  4 5 6 7 ]\n");
    CHECK(total_power(*two) == test::Approx(20.0).epsilon(1e-4));
    // The same rectangle as a trianglemesh is two pbrt shapes (Triangle): 10 W each.
    auto tris = test::scene_from_string(
        head + "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  2 0 0  2 1 0  0 1 0 ] "
               "\"integer indices\" [ 0 1 2  0 2 3 ]\n");
    CHECK(total_power(*tris) == test::Approx(20.0).epsilon(1e-4));
    // A PLY quad is a bilinear patch in pbrt-v4 as well; its triangles are per triangle.
    auto dir = test::temp_dir("scene_builder_ply_power");
    test::write_text(dir / "quad_tri.ply",
                     "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                     "end_header\n0 0 0\n3 0 0\n3 1 0\n0 1 0\n5 5 0\n4 0 1 2 3\n3 1 4 2\n");
    auto ply = test::scene_from_string(head + "Shape \"plymesh\" \"string filename\" \"" +
                                       (dir / "quad_tri.ply").string() + "\"\n");
    REQUIRE(ply->lights.size() == 3);
    CHECK(total_power(*ply) == test::Approx(20.0).epsilon(1e-4));
}
