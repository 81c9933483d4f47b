// OBJ scenes: exact parameters from a tiny OBJ written here, and McGuire's Cornell boxes.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

#include "approx.h"
#include "renderer/input/obj_loader.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() { return test::temp_dir("test_obj_loader"); }

std::string write_text(const std::string &name, const std::string &text) {
    return test::write_text(temp_dir() / name, text);
}

const ShapeDesc *shape_with_material(const SceneDesc &s, const std::string &mat) {
    for (const ShapeDesc &sd : s.shapes)
        if (sd.material == mat) return &sd;
    return nullptr;
}

size_t triangles(const ShapeDesc &sd) {
    return sd.params.get_ints("indices").size() / 3;
}

std::vector<double> numbers(const ParamSet &ps, const std::string &name) {
    const Param *p = ps.find(name);
    return p ? p->numbers : std::vector<double>{};
}

}  // namespace

TEST_CASE("load_obj_scene: tiny OBJ with normals, uvs, a quad, materials and a texture") {
    write_text("tiny.mtl", R"(newmtl red
Kd 0.8 0.1 0.1
Ks 0 0 0
newmtl shiny
Kd 0.2 0.3 0.4
Ks 0.5 0.5 0.5
Ns 98
newmtl lamp
Kd 0 0 0
Ke 4 5 6
newmtl tex
Kd 1 1 1
map_Kd -s 2 3 1 checker.png
)");
    std::string obj = write_text("tiny.obj", R"(mtllib tiny.mtl
v 0 0 0
v 1 0 0
v 0.8 1 0
v 0 1 0
v 0 0 -2
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
o quad
usemtl red
f 1/1/1 2/2/1 3/3/1 4/4/1
usemtl shiny
f -4/1 -3/2 -1/3
o lamp
usemtl lamp
f 1 2 5
usemtl tex
f 1/1 2/2 5/3
)");
    SceneDesc s = load_obj_scene(obj);
    REQUIRE(s.shapes.size() == 4);

    // The quad: 4 shared vertices, split along its shorter diagonal (0-2) into (0 1 2) (0 2 3),
    // with N and uv.
    const ShapeDesc *quad = shape_with_material(s, "red");
    REQUIRE(quad);
    CHECK(quad->type == "trianglemesh");
    CHECK(quad->params.get_ints("indices") == std::vector<int>{0, 1, 2, 0, 2, 3});
    std::vector<Vec3f> P = quad->params.get_point3s("P");
    REQUIRE(P.size() == 4);
    CHECK(P[2].x == 0.8f);
    CHECK(P[2].y == 1.f);
    CHECK(P[3].x == 0.f);
    CHECK(P[3].y == 1.f);
    std::vector<Vec3f> N = quad->params.get_normals("N");
    REQUIRE(N.size() == 4);
    CHECK(N[0].z == 1.f);
    std::vector<Vec2f> uv = quad->params.get_point2s("uv");
    REQUIRE(uv.size() == 4);
    CHECK(uv[2].x == 1.f);
    CHECK(uv[2].y == 1.f);
    CHECK_FALSE(quad->area_light.has_value());

    // Negative indices, no normals on this group: N absent, uv present.
    const ShapeDesc *tri = shape_with_material(s, "shiny");
    REQUIRE(tri);
    CHECK(triangles(*tri) == 1);
    CHECK(tri->params.find("N") == nullptr);
    std::vector<Vec3f> Pt = tri->params.get_point3s("P");
    REQUIRE(Pt.size() == 3);
    CHECK(Pt[0].x == 1.f);   // -4 of 5 vertices is vertex 2
    CHECK(Pt[2].z == -2.f);  // -1 is vertex 5

    // Materials.
    const MaterialDesc &red = s.materials.at("red");
    CHECK(red.type == "diffuse");
    CHECK(numbers(red.params, "reflectance") == std::vector<double>{0.8f, 0.1f, 0.1f});
    const MaterialDesc &shiny = s.materials.at("shiny");
    CHECK(shiny.type == "coateddiffuse");
    CHECK(shiny.params.get_float("roughness", -1) == test::Approx(std::sqrt(2.0 / 100.0)));
    CHECK(shiny.params.get_bool("remaproughness", true) == false);
    const MaterialDesc &tex = s.materials.at("tex");
    CHECK(tex.params.get_texture("reflectance") == "tex:map_Kd");
    REQUIRE(s.textures.size() == 1);
    const TextureDesc &td = s.textures[0];
    CHECK(td.name == "tex:map_Kd");
    CHECK(td.value_type == "spectrum");
    CHECK(td.tex_class == "imagemap");
    CHECK(td.params.get_string("filename", "") == "checker.png");
    CHECK(td.params.get_float("uscale", 1) == 2.f);
    CHECK(td.params.get_float("vscale", 1) == 3.f);
    CHECK(fs::equivalent(td.base_dir, temp_dir()));

    // The emitter gets an area light; with an emitter, no default lights are added.
    const ShapeDesc *lamp = shape_with_material(s, "lamp");
    REQUIRE(lamp);
    REQUIRE(lamp->area_light.has_value());
    CHECK(lamp->area_light_type == "diffuse");
    CHECK(numbers(*lamp->area_light, "L") == std::vector<double>{4, 5, 6});
    CHECK(lamp->area_light->get_bool("twosided", true) == false);
    CHECK(s.lights.empty());

    // Camera, film.
    CHECK(s.camera.present);
    CHECK(s.camera.type == "perspective");
    CHECK(s.camera.params.get_float("fov", 0) == kObjCameraFovDeg);
    CHECK(s.film.params.get_int("xresolution", 0) == 512);
    CHECK(s.film.params.get_int("yresolution", 0) == 512);
}

TEST_CASE("load_obj_scene: default camera frames the bounding sphere, default lights") {
    // A box from (-1,-2,-3) to (3,2,1): centre (1,0,-1), radius sqrt(4+4+4) = 2*sqrt(3).
    std::string obj = write_text("box.obj", "v -1 -2 -3\nv 3 2 1\nv 3 -2 1\nf 1 2 3\n");
    SceneDesc s = load_obj_scene(obj);
    REQUIRE(s.shapes.size() == 1);
    CHECK(s.shapes[0].material.empty());
    const Transform world_from_camera = s.camera_from_world.inverse();
    Vec3f eye = world_from_camera.point({0, 0, 0});
    float r = 2 * std::sqrt(3.f);
    float d = r / std::sin(radians(kObjCameraFovDeg / 2));
    CHECK(eye.x == test::Approx(1.f));
    CHECK(eye.y == test::Approx(0.f));
    CHECK(eye.z == test::Approx(-1.f + d));
    // Looking along -z, +y up; camera +x maps to world +x (right-handed view, see header).
    Vec3f fwd = world_from_camera.vector({0, 0, 1});
    CHECK(fwd.z == test::Approx(-1.f));
    Vec3f up = world_from_camera.vector({0, 1, 0});
    CHECK(up.y == test::Approx(1.f));
    Vec3f right = world_from_camera.vector({1, 0, 0});
    CHECK(right.x == test::Approx(1.f));
    // The bounding sphere touches the edge of the field of view: the angle between the view
    // axis and the tangent from the eye is half the fov.
    CHECK(std::asin(r / distance(eye, Vec3f(1, 0, -1))) ==
          test::Approx(radians(kObjCameraFovDeg / 2)));
    REQUIRE(s.lights.size() == 2);
    CHECK(s.lights[0].type == "infinite");
    CHECK(s.lights[1].type == "distant");
}

TEST_CASE("load_obj_scene: errors") {
    std::string missing = (temp_dir() / "nope.obj").string();
    CHECK_THROWS_AS(load_obj_scene(missing), SceneError);
    std::string empty = write_text("empty.obj", "# nothing\nv 0 0 0\n");
    CHECK_THROWS_AS(load_obj_scene(empty), SceneError);
}

TEST_CASE("load_obj_scene: CornellBox-Original (quads, negative indices, Ke light)") {
    TESSERA_REQUIRE_SHARED(shared);
    SceneDesc s = load_obj_scene(shared + "/scenes/mcguire-cornellbox-obj/CornellBox-Original.obj");
    CHECK(s.materials.size() == 8);
    size_t total = 0;
    for (const ShapeDesc &sd : s.shapes) total += triangles(sd);
    CHECK(total == 36);  // 5 walls + light (1 quad each) + 2 boxes (6 quads each)
    for (const char *m : {"floor", "ceiling", "backWall", "rightWall", "leftWall", "light"}) {
        CAPTURE(m);
        const ShapeDesc *sd = shape_with_material(s, m);
        REQUIRE(sd);
        CHECK(triangles(*sd) == 2);
    }
    size_t short_box = 0, tall_box = 0;
    for (const ShapeDesc &sd : s.shapes) {
        if (sd.material == "shortBox") short_box += triangles(sd);
        if (sd.material == "tallBox") tall_box += triangles(sd);
    }
    CHECK(short_box == 12);
    CHECK(tall_box == 12);
    const MaterialDesc &left = s.materials.at("leftWall");
    CHECK(left.type == "diffuse");
    std::vector<double> kd = numbers(left.params, "reflectance");
    REQUIRE(kd.size() == 3);
    CHECK(kd[0] == test::Approx(0.63));
    CHECK(kd[1] == test::Approx(0.065));
    CHECK(kd[2] == test::Approx(0.05));
    int emitters = 0;
    for (const ShapeDesc &sd : s.shapes)
        if (sd.area_light) {
            ++emitters;
            CHECK(sd.material == "light");
            CHECK(numbers(*sd.area_light, "L") == std::vector<double>{17, 12, 4});
            // The light quad at y = 1.98 emits downwards: (p1 - p0) x (p2 - p0) has -y.
            std::vector<Vec3f> P = sd.params.get_point3s("P");
            std::vector<int> idx = sd.params.get_ints("indices");
            Vec3f n = cross(P[idx[1]] - P[idx[0]], P[idx[2]] - P[idx[0]]);
            CHECK(n.y < 0);
        }
    CHECK(emitters == 1);
    CHECK(s.lights.empty());
    // Light vertex exactly as in the file.
    std::vector<Vec3f> P = shape_with_material(s, "light")->params.get_point3s("P");
    CHECK(P[0].x == -0.24f);
    CHECK(P[0].y == 1.98f);
    CHECK(P[0].z == 0.16f);
}

TEST_CASE("load_obj_scene: CornellBox-Sphere (mirror and glass)") {
    TESSERA_REQUIRE_SHARED(shared);
    SceneDesc s = load_obj_scene(shared + "/scenes/mcguire-cornellbox-obj/CornellBox-Sphere.obj");
    const MaterialDesc &mirror = s.materials.at("leftSphere");
    CHECK(mirror.type == "conductor");
    std::vector<double> r = numbers(mirror.params, "reflectance");
    REQUIRE(r.size() == 3);
    CHECK(r[0] == test::Approx(0.95));
    CHECK(mirror.params.get_float("roughness", -1) == 0.f);
    const MaterialDesc &glass = s.materials.at("rightSphere");
    CHECK(glass.type == "dielectric");
    CHECK(glass.params.get_float("eta", 0) == test::Approx(2.5f));
    const ShapeDesc *sphere = shape_with_material(s, "leftSphere");
    REQUIRE(sphere);
    CHECK(triangles(*sphere) > 100);
    const ShapeDesc *light = shape_with_material(s, "light");
    REQUIRE(light);
    REQUIRE(light->area_light.has_value());
    CHECK(numbers(*light->area_light, "L") == std::vector<double>{10, 10, 10});
}
