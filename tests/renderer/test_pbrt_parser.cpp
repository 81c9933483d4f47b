// Unit tests of the pbrt-v4 scene reader and of ParamSet lookups.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

#include "approx.h"
#include "gzip_test_util.h"
#include "renderer/input/pbrt_parser.h"
#include "test_helpers.h"

using namespace tessera;

namespace {

SceneDesc parse(const std::string &text) { return parse_pbrt_string(text, "test.pbrt", ""); }

/// The SceneError message of parsing `text`, or "" if it parses.
std::string error_of(const std::string &text, const std::string &dir = "") {
    try {
        parse_pbrt_string(text, "test.pbrt", dir);
    } catch (const SceneError &e) {
        return e.what();
    }
    return {};
}

void check_vec(Vec3f a, Vec3f b, float eps = 1e-5f) {
    CHECK(a.x == test::Approx(b.x).epsilon(eps));
    CHECK(a.y == test::Approx(b.y).epsilon(eps));
    CHECK(a.z == test::Approx(b.z).epsilon(eps));
}

/// A fresh temporary directory for Include tests.
std::filesystem::path temp_dir(const std::string &name) {
    auto p = std::filesystem::temp_directory_path() / ("tessera_parser_" + name);
    std::filesystem::remove_all(p);
    std::filesystem::create_directories(p);
    return p;
}

void write_file(const std::filesystem::path &p, const std::string &text) {
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p) << text;
}

}  // namespace

TEST_CASE("tokenizer: comments, escapes, numbers and bare bools") {
    SceneDesc s = parse(R"(# a comment line
WorldBegin # trailing comment
Shape "sphere" "float radius" 2.5   # single bare value
    "string name" [ "a \"quoted\" \\ name\t" ]
    "integer n" [ +3 -4 ]
    "float f" [ -.5e1 1e-3 ]
    "bool b" true
    "bool c" [ "false" ]
)");
    REQUIRE(s.shapes.size() == 1);
    const ParamSet &p = s.shapes[0].params;
    CHECK(s.shapes[0].type == "sphere");
    CHECK(p.get_float("radius", 0) == 2.5f);
    CHECK(p.get_string("name", "") == "a \"quoted\" \\ name\t");
    CHECK(p.get_ints("n") == std::vector<int>{3, -4});
    CHECK(p.get_floats("f") == std::vector<float>{-5.f, 1e-3f});
    CHECK(p.get_bool("b", false) == true);
    CHECK(p.get_bool("c", true) == false);
    CHECK(s.shapes[0].loc.line == 3);
    CHECK(p.find("name")->loc.line == 4);
}

TEST_CASE("parameter types and aliases") {
    SceneDesc s = parse(R"(WorldBegin
Shape "trianglemesh"
  "point2 uv" [0 0 1 0 1 1]
  "vector2 v2" [1 2]
  "point3 P" [0 0 0 1 0 0 0 1 0]
  "point p1" [1 2 3]
  "vector3 v3" [4 5 6]
  "vector v" [7 8 9]
  "normal N" [0 0 1 0 0 1 0 0 1]
  "normal3 n3" [0 1 0]
  "rgb c" [0.1 0.2 0.3]
  "color old" [0.5 0.5 0.5]
  "blackbody L" [6500]
  "spectrum s" [400 1 700 1]
  "spectrum named" "metal-Au-eta"
  "texture tex" "checks"
)");
    const ParamSet &p = s.shapes[0].params;
    CHECK(p.get_point2s("uv").size() == 3);
    CHECK(p.find("v2")->type == "vector2");
    CHECK(p.get_point3s("P").size() == 3);
    CHECK(p.find("p1")->type == "point3");
    check_vec(p.get_point3("p1", {}), {1, 2, 3});
    check_vec(p.get_vector3("v3", {}), {4, 5, 6});
    CHECK(p.find("v")->type == "vector3");
    CHECK(p.get_normals("N").size() == 3);
    CHECK(p.find("n3")->type == "normal");
    check_vec(p.get_normal("n3", {}), {0, 1, 0});
    Rgb c = *p.get_rgb("c", false, false);
    CHECK(c.r == 0.1f);
    CHECK(c.b == 0.3f);
    CHECK(p.find("old")->type == "rgb");
    CHECK(p.find("L")->numbers == std::vector<double>{6500});
    CHECK(p.find("s")->numbers.size() == 4);
    CHECK(p.find("named")->strings == std::vector<std::string>{"metal-Au-eta"});
    CHECK(p.get_texture("tex") == "checks");
    // A texture-typed parameter is not a constant colour, and vice versa.
    CHECK(!p.get_rgb("tex", false).has_value());
    CHECK(p.get_texture("c").empty());
}

TEST_CASE("ParamSet lookups: defaults, type and count errors") {
    SceneDesc s = parse(R"(WorldBegin
Shape "sphere" "float radius" [1 2] "string name" "x" "integer k" 4
)");
    const ParamSet &p = s.shapes[0].params;
    CHECK(p.get_float("missing", 7.f) == 7.f);
    CHECK(p.get_float("k", 0.f) == 4.f);  // integer accepted where a float is expected
    CHECK_THROWS_WITH_AS(p.get_float("radius", 0), "test.pbrt:2: parameter \"radius\" expects 1 "
                                                   "value(s) but has 2",
                         SceneError);
    CHECK_THROWS_AS(p.get_int("name", 0), SceneError);
    CHECK_THROWS_AS(p.get_point3("radius", {}), SceneError);
}

TEST_CASE("Transform lists the matrix column by column") {
    SceneDesc s = parse(R"(Transform [ 1 0 0 0  0 1 0 0  0 0 1 0  1 2 3 1 ]
Camera "perspective"
WorldBegin
ConcatTransform [ 2 0 0 0  0 2 0 0  0 0 2 0  0 0 1 1 ]
Shape "sphere"
)");
    const Mat4 &m = s.camera_from_world.matrix();
    CHECK(m.m[0][3] == 1);
    CHECK(m.m[1][3] == 2);
    CHECK(m.m[2][3] == 3);
    CHECK(m.m[3][0] == 0);
    check_vec(s.shapes[0].render_from_object.point({1, 1, 1}), {2, 2, 3});
}

TEST_CASE("Translate, Scale, Rotate and LookAt compose like pbrt (CTM = CTM * T)") {
    SceneDesc s = parse(R"(LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective"
WorldBegin
Translate 1 0 0
Scale 2 2 2
Shape "sphere"
Identity
Rotate 90 0 0 1
Shape "sphere"
)");
    // LookAt gives camera_from_world: the world origin is 5 units in front (+z) of the camera,
    // and pbrt's camera x axis is up x dir = (0,1,0) x (0,0,-1) = (-1,0,0).
    check_vec(s.camera_from_world.point({0, 0, 0}), {0, 0, 5});
    check_vec(s.camera_from_world.point({1, 0, 0}), {-1, 0, 5});
    check_vec(s.camera_from_world.inverse().point({0, 0, 0}), {0, 0, 5});
    REQUIRE(s.shapes.size() == 2);
    check_vec(s.shapes[0].render_from_object.point({1, 0, 0}), {3, 0, 0});
    Vec3f r = s.shapes[1].render_from_object.point({1, 0, 0});
    CHECK(r.x == test::Approx(0).epsilon(1e-6));
    CHECK(r.y == test::Approx(1));
}

TEST_CASE("named coordinate systems, camera and world") {
    SceneDesc s = parse(R"(Translate 0 0 4
CoordinateSystem "mine"
Camera "perspective"
WorldBegin
CoordSysTransform "camera"
Shape "sphere"
CoordSysTransform "mine"
Shape "sphere"
Translate 1 1 1
CoordSysTransform "world"
Shape "sphere"
CoordSysTransform "nonexistent"
Shape "sphere"
)");
    REQUIRE(s.shapes.size() == 4);
    // "camera" = inverse of camera_from_world: maps camera space to world.
    check_vec(s.shapes[0].render_from_object.point({0, 0, 0}), {0, 0, -4});
    check_vec(s.shapes[1].render_from_object.point({0, 0, 0}), {0, 0, 4});
    CHECK(s.shapes[2].render_from_object.is_identity());
    // Unknown name: warning, CTM unchanged.
    CHECK(s.shapes[3].render_from_object.is_identity());
    CHECK(last_warning() ==
          "test.pbrt:12: warning: CoordSysTransform: unknown coordinate system \"nonexistent\"");
}

TEST_CASE("AttributeBegin/End scope CTM, material, orientation and area light") {
    SceneDesc s = parse(R"(WorldBegin
MakeNamedMaterial "red" "string type" "diffuse" "rgb reflectance" [1 0 0]
AttributeBegin
  NamedMaterial "red"
  Translate 0 1 0
  ReverseOrientation
  AreaLightSource "diffuse" "rgb L" [17 12 4]
  Shape "sphere"
AttributeEnd
Shape "sphere"
AttributeBegin
  Material "conductor" "spectrum eta" "metal-Cu-eta"
  Shape "disk"
AttributeEnd
)");
    REQUIRE(s.shapes.size() == 3);
    const ShapeDesc &a = s.shapes[0], &b = s.shapes[1], &c = s.shapes[2];
    CHECK(a.material == "red");
    CHECK(a.reverse_orientation);
    check_vec(a.render_from_object.point({0, 0, 0}), {0, 1, 0});
    REQUIRE(a.area_light.has_value());
    CHECK(a.area_light_type == "diffuse");
    CHECK(a.area_light_loc.line == 7);
    Rgb L = *a.area_light->get_rgb("L", true);
    CHECK(L.r == 17.f);
    CHECK(L.g == 12.f);
    CHECK(L.b == 4.f);
    CHECK(b.material.empty());
    CHECK(!b.reverse_orientation);
    CHECK(b.render_from_object.is_identity());
    CHECK(!b.area_light.has_value());
    CHECK(c.material == "anonymous#1");
    REQUIRE(s.materials.count("anonymous#1") == 1);
    CHECK(s.materials.at("anonymous#1").type == "conductor");
    CHECK(s.materials.at("red").type == "diffuse");
    CHECK(s.materials.at("red").params.find("type") == nullptr);  // consumed
}

TEST_CASE("TransformBegin/End restore only the CTM") {
    SceneDesc s = parse(R"(WorldBegin
TransformBegin
  Translate 1 0 0
  ReverseOrientation
TransformEnd
Shape "sphere"
)");
    CHECK(s.shapes[0].render_from_object.is_identity());
    CHECK(s.shapes[0].reverse_orientation);
}

TEST_CASE("Attribute sets default parameters per entity kind") {
    SceneDesc s = parse(R"(WorldBegin
AttributeBegin
  Attribute "shape" "float radius" 3 "float zmax" 1
  Attribute "light" "float scale" 2
  Shape "sphere" "float radius" 5
  LightSource "point" "rgb I" [1 1 1]
AttributeEnd
Shape "sphere"
)");
    CHECK(s.shapes[0].params.get_float("radius", 0) == 5.f);  // own value wins
    CHECK(s.shapes[0].params.get_float("zmax", 0) == 1.f);
    CHECK(s.lights[0].params.get_float("scale", 0) == 2.f);
    CHECK(s.shapes[1].params.find("zmax") == nullptr);  // scoped by AttributeEnd
}

TEST_CASE("options, lights, textures and unsupported features") {
    SceneDesc s = parse(R"(Film "rgb" "integer xresolution" 320
Sampler "halton" "integer pixelsamples" 16
Integrator "volpath" "integer maxdepth" 7
PixelFilter "gaussian"
Accelerator "bvh"
ColorSpace "aces2065-1"
Option "bool disablepixeljitter" true
MakeNamedMedium "fog" "string type" "homogeneous"
TransformTimes 0 1
WorldBegin
MediumInterface "fog" ""
Translate 0 2 0
Texture "checks" "spectrum" "checkerboard" "float uscale" 4
Texture "checks" "float" "constant" "float value" 0.5
LightSource "distant" "blackbody L" 5000
ActiveTransform EndTime
Translate 100 0 0
ActiveTransform StartTime
Shape "sphere"
)");
    CHECK(s.film.present);
    CHECK(s.film.type == "rgb");
    CHECK(s.film.params.get_int("xresolution", 0) == 320);
    CHECK(s.sampler.type == "halton");
    CHECK(s.integrator.params.get_int("maxdepth", 0) == 7);
    CHECK(s.filter.type == "gaussian");
    CHECK(s.accelerator.type == "bvh");
    CHECK(!s.camera.present);
    REQUIRE(s.textures.size() == 2);
    CHECK(s.textures[0].value_type == "spectrum");
    CHECK(s.textures[0].tex_class == "checkerboard");
    check_vec(s.textures[0].render_from_texture.point({0, 0, 0}), {0, 2, 0});
    CHECK(s.textures[1].value_type == "float");
    REQUIRE(s.lights.size() == 1);
    CHECK(s.lights[0].type == "distant");
    // The EndTime translation is ignored.
    check_vec(s.shapes[0].render_from_object.point({0, 0, 0}), {0, 2, 0});
}

TEST_CASE("media: MakeNamedMedium, MediumInterface scopes, the camera's medium") {
    SceneDesc s = parse(R"(MediumInterface "" "air"
LookAt 0 0 -3  0 0 0  0 1 0
Camera "perspective"
WorldBegin
Translate 0 1 0
MakeNamedMedium "air" "string type" "homogeneous" "rgb sigma_s" [ 0.1 0.1 0.1 ]
AttributeBegin
  MediumInterface "ink"
  Shape "sphere"
  MediumInterface "ink" "air"
  Shape "sphere"
AttributeEnd
Shape "sphere"
MakeNamedMedium "ink" "string type" "uniformgrid" "float density" [ 1 ]
)");
    CHECK(s.camera_medium == "air");
    REQUIRE(s.media.size() == 2);
    const MediumDesc &air = s.media.at("air");
    CHECK(air.type == "homogeneous");
    check_vec(air.render_from_medium.point({0, 0, 0}), {0, 1, 0});  // the CTM at its declaration
    CHECK(air.params.find("type")->used);  // consumed, as MakeNamedMaterial's
    REQUIRE(s.shapes.size() == 3);
    CHECK(s.shapes[0].medium_inside == "ink");  // one name: both sides
    CHECK(s.shapes[0].medium_outside == "ink");
    CHECK(s.shapes[1].medium_inside == "ink");
    CHECK(s.shapes[1].medium_outside == "air");
    // AttributeEnd restores the interface current before (the camera's, "" "air").
    CHECK(s.shapes[2].medium_inside.empty());
    CHECK(s.shapes[2].medium_outside == "air");
    CHECK_THROWS_WITH_AS(parse("WorldBegin\nMediumInterface \"nope\" \"\"\nShape \"sphere\"\n"),
                         "test.pbrt:3: medium \"nope\" is not defined", SceneError);
    CHECK_THROWS_WITH_AS(
        parse("MakeNamedMedium \"a\" \"string type\" \"homogeneous\"\n"
              "MakeNamedMedium \"a\" \"string type\" \"homogeneous\"\n"),
        "test.pbrt:2: named medium \"a\" redefined (first at test.pbrt:1)", SceneError);
}

TEST_CASE("ObjectBegin/ObjectInstance") {
    SceneDesc s = parse(R"(WorldBegin
AttributeBegin
  Translate 0 0 1
  ObjectBegin "thing"
    Translate 1 0 0
    Shape "sphere"
    AreaLightSource "diffuse" "rgb L" [1 1 1]
    Shape "disk"
  ObjectEnd
AttributeEnd
Shape "sphere"
Translate 0 5 0
ObjectInstance "thing"
)");
    CHECK(s.shapes.size() == 1);  // only the shape outside the object
    REQUIRE(s.objects.count("thing") == 1);
    const ObjectDesc &o = s.objects.at("thing");
    REQUIRE(o.shapes.size() == 2);
    CHECK(o.loc.line == 4);
    // render_from_object is the CTM at the shape inside the block.
    check_vec(o.shapes[0].render_from_object.point({0, 0, 0}), {1, 0, 1});
    CHECK(!o.shapes[1].area_light.has_value());  // area lights dropped in instances (pbrt-v4)
    REQUIRE(s.instances.size() == 1);
    CHECK(s.instances[0].object == "thing");
    check_vec(s.instances[0].render_from_instance.point({0, 0, 0}), {0, 5, 0});
    // ObjectBegin scopes the graphics state: the later Shape is not translated.
    CHECK(s.shapes[0].render_from_object.is_identity());
}

TEST_CASE("Include resolves relative to the main file, then to the including file") {
    auto dir = temp_dir("include");
    write_file(dir / "main.pbrt", "WorldBegin\nInclude \"sub/a.pbrt\"\nShape \"sphere\"\n");
    write_file(dir / "sub" / "a.pbrt", "Translate 1 0 0\nImport \"b.pbrt\"\n");
    write_file(dir / "sub" / "b.pbrt", "\n\nShape \"disk\" \"spectrum s\" \"s.spd\"\n");
    write_file(dir / "sub" / "s.spd", "# lambda value\n400 0.5\n700 0.5\n");
    SceneDesc s = parse_pbrt_file((dir / "main.pbrt").string());
    REQUIRE(s.shapes.size() == 2);
    CHECK(s.main_file == (dir / "main.pbrt").string());
    CHECK(s.shapes[0].type == "disk");
    CHECK(s.shapes[0].loc.file == (dir / "sub" / "b.pbrt").string());
    CHECK(s.shapes[0].loc.line == 3);
    // pbrt-v4: entity file names resolve against the main file's directory.
    CHECK(s.shapes[0].base_dir == dir.string());
    CHECK(s.shapes[0].params.find("s")->numbers == std::vector<double>{400, 0.5, 700, 0.5});
    // Include is textual: the graphics state carries over.
    check_vec(s.shapes[1].render_from_object.point({0, 0, 0}), {1, 0, 0});
    CHECK(s.shapes[1].base_dir == dir.string());

    // Import (pbrt-v4) brings back what it declares but not its graphics state, and is allowed
    // in the world block only.
    write_file(dir / "imp.pbrt", "Translate 0 2 0\nMaterial \"conductor\"\nShape \"sphere\"\n"
                                 "MakeNamedMaterial \"m\" \"string type\" \"diffuse\"\n");
    write_file(dir / "main_imp.pbrt", "WorldBegin\nImport \"imp.pbrt\"\nShape \"disk\"\n"
                                      "NamedMaterial \"m\"\nShape \"disk\"\n");
    SceneDesc im = parse_pbrt_file((dir / "main_imp.pbrt").string());
    REQUIRE(im.shapes.size() == 3);
    check_vec(im.shapes[0].render_from_object.point({0, 0, 0}), {0, 2, 0});
    CHECK(im.shapes[1].render_from_object.is_identity());
    CHECK(im.shapes[1].material != im.shapes[0].material);
    CHECK(im.materials.count("m") == 1);
    // ActiveTransform is graphics state too: an imported "ActiveTransform EndTime" must not
    // make the parent drop its later transforms.
    write_file(dir / "imp_active.pbrt", "ActiveTransform EndTime\n");
    write_file(dir / "main_imp_active.pbrt",
               "WorldBegin\nImport \"imp_active.pbrt\"\nTranslate 0 0 3\nShape \"disk\"\n");
    SceneDesc ia = parse_pbrt_file((dir / "main_imp_active.pbrt").string());
    REQUIRE(ia.shapes.size() == 1);
    check_vec(ia.shapes[0].render_from_object.point({0, 0, 0}), {0, 0, 3});
    write_file(dir / "main_imp_early.pbrt", "Import \"imp.pbrt\"\nWorldBegin\n");
    CHECK_THROWS_WITH(parse_pbrt_file((dir / "main_imp_early.pbrt").string()),
                      doctest::Contains("main_imp_early.pbrt:1: Import is only allowed after "
                                        "WorldBegin"));

    // Errors inside an included file name that file and line.
    write_file(dir / "sub" / "bad.pbrt", "\nFoo\n");
    write_file(dir / "main2.pbrt", "WorldBegin\nInclude \"sub/bad.pbrt\"\n");
    try {
        parse_pbrt_file((dir / "main2.pbrt").string());
        FAIL("expected a SceneError");
    } catch (const SceneError &e) {
        CHECK(std::string(e.what()) == (dir / "sub" / "bad.pbrt").string() +
                                           ":2: unknown directive 'Foo'");
    }
    std::filesystem::remove_all(dir);
}

TEST_CASE("bad files give file:line messages") {
    CHECK(error_of("WorldBegin\n\nShape \"sphere\n") == "test.pbrt:3: unterminated string");
    CHECK(error_of("WorldBegin\nFrobnicate 1 2\n") ==
          "test.pbrt:2: unknown directive 'Frobnicate'");
    CHECK(error_of("WorldBegin\nShape \"trianglemesh\"\n  \"point3 P\" [0 0 0 1 0]\n") ==
          "test.pbrt:3: parameter \"point3 P\" expects a multiple of 3 values, found 5");
    CHECK(error_of("WorldBegin\nShape \"sphere\" \"quaternion q\" [1]\n") ==
          "test.pbrt:2: unknown parameter type \"quaternion\"");
    CHECK(error_of("WorldBegin\nAttributeBegin\nAttributeEnd\nAttributeEnd\n") ==
          "test.pbrt:4: unmatched AttributeEnd (no AttributeBegin)");
    CHECK(error_of("WorldBegin\nInclude \"does-not-exist.pbrt\"\n") ==
          "test.pbrt:2: cannot open Include file \"does-not-exist.pbrt\": not found");
    CHECK(error_of("Shape \"sphere\"\n") == "test.pbrt:1: Shape is only allowed after WorldBegin");
    CHECK(error_of("WorldBegin\nCamera \"perspective\"\n") ==
          "test.pbrt:2: Camera is not allowed after WorldBegin");
    CHECK(error_of("WorldBegin\nShape \"sphere\" \"float radius\" [ \"one\" ]\n") ==
          "test.pbrt:2: parameter \"float radius\" expects numbers, found \"one\"");
    CHECK(error_of("WorldBegin\nShape \"sphere\" \"integer n\" [ 1.5 ]\n") ==
          "test.pbrt:2: parameter \"integer n\" has a non-integer value 1.5");
    CHECK(error_of("Translate 1 nan 2\n") ==
          "test.pbrt:1: Translate expects a number, found 'nan'");
    CHECK(error_of("WorldBegin\nWorldBegin\n") == "test.pbrt:2: WorldBegin given twice");
    CHECK(error_of("ActiveTransform Sometimes\n") ==
          "test.pbrt:1: ActiveTransform expects StartTime, EndTime or All, found 'Sometimes'");
    CHECK(error_of("WorldBegin\nMakeNamedMaterial \"m\" \"string type\" \"diffuse\"\n"
                   "MakeNamedMaterial \"m\" \"string type\" \"conductor\"\n") ==
          "test.pbrt:3: named material \"m\" redefined (first at test.pbrt:2)");
    CHECK(error_of("WorldBegin\nTexture \"t\" \"float\" \"constant\"\n"
                   "Texture \"t\" \"float\" \"scale\"\n") ==
          "test.pbrt:3: float texture \"t\" redefined (first at test.pbrt:2)");
    CHECK(error_of("WorldBegin\nTexture \"t\" \"rgb\" \"constant\"\n") ==
          "test.pbrt:2: texture \"t\": unknown type \"rgb\" (expected float or spectrum)");
    CHECK(error_of("Translate 1 2\nWorldBegin\n") ==
          "test.pbrt:2: Translate expects a number, found 'WorldBegin'");
    CHECK(error_of("WorldBegin\nNamedMaterial \"nope\"\nShape \"sphere\"\n") ==
          "test.pbrt:3: named material \"nope\" is not defined");
    CHECK(error_of("WorldBegin\nObjectInstance \"ghost\"\n") ==
          "test.pbrt:2: object \"ghost\" is not defined");
    CHECK(error_of("WorldBegin\nAttributeBegin\nTransformEnd\n") ==
          "test.pbrt:3: TransformEnd does not match the open AttributeBegin at test.pbrt:2");
    CHECK(error_of("WorldBegin\nMakeNamedMaterial \"m\" \"rgb reflectance\" [1 1 1]\n") ==
          "test.pbrt:2: MakeNamedMaterial \"m\": no \"string type\" parameter");
    CHECK(error_of("WorldBegin\nShape \"sphere\" \"float radius\"\n") ==
          "test.pbrt:2: unexpected end of file: no value for parameter \"radius\"");
    CHECK(error_of("WorldBegin\nShape \"sphere\" \"bool b\" maybe\n") ==
          "test.pbrt:2: parameter \"bool b\" expects true or false, found maybe");
    CHECK(error_of("WorldBegin\nAttribute \"camera\" \"float x\" 1\n") ==
          "test.pbrt:2: Attribute: unknown target \"camera\" (expected shape, light, material, "
          "medium or texture)");
}

TEST_CASE("unused parameters are reported with file:line") {
    SceneDesc s =
        parse("WorldBegin\nShape \"sphere\"\n  \"float radius\" 1\n  \"float bogus\" 2\n");
    const ParamSet &p = s.shapes[0].params;
    CHECK(p.get_float("radius", 0) == 1.f);
    int before = warning_count();
    p.report_unused("Shape \"sphere\"");
    CHECK(warning_count() == before + 1);
    CHECK(last_warning() ==
          "test.pbrt:4: warning: Shape \"sphere\": parameter \"float bogus\" is not used");
    // Deduplicated: the same warning again prints nothing.
    p.report_unused("Shape \"sphere\"");
    CHECK(warning_count() == before + 1);
}

TEST_CASE("get_rgb converts every spectrum parameter form") {
    SceneDesc s = parse(R"(WorldBegin
LightSource "point"
  "rgb a" [2 1 0.5]
  "float f" 0.25
  "blackbody bb" 6500
  "spectrum flat" [300 0.5 800 0.5]
  "spectrum au" "metal-Au-k"
  "spectrum glass" "glass-BK7"
  "rgb big" [2 0.5 0.5]
)");
    const ParamSet &p = s.lights[0].params;
    Rgb a = *p.get_rgb("a", true);
    CHECK(a.r == 2.f);
    CHECK(a.b == 0.5f);
    CHECK(p.get_rgb("f", false)->g == 0.25f);
    Rgb bb = *p.get_rgb("bb", true);
    CHECK(bb.luminance() == test::Approx(1).epsilon(0.01));
    Rgb flat = *p.get_rgb("flat", false, false);
    CHECK(flat.r == test::Approx(0.5).epsilon(1e-3));
    CHECK(flat.g == test::Approx(0.5).epsilon(1e-3));
    CHECK(flat.b == test::Approx(0.5).epsilon(1e-3));
    Rgb au = *p.get_rgb("au", false);
    CHECK(au.r > au.b);
    CHECK(p.get_rgb("glass", false)->g == test::Approx(1.5185).epsilon(1e-3));
    // A reflectance is clamped to [0, 1].
    CHECK(p.get_rgb("big", false, false)->r == 1.f);
    CHECK(!p.get_rgb("absent", true).has_value());
}

TEST_CASE("Bitterli's Cornell box (shared scene)") {
    TESSERA_REQUIRE_SHARED(shared);
    SceneDesc s =
        parse_pbrt_file(shared + "/scenes/bitterli-cornell-box/pbrt-v4/scene-v4.pbrt");
    // Eye at (0, 1, 6.8) looking toward -z.
    Transform world_from_camera = s.camera_from_world.inverse();
    check_vec(world_from_camera.point({0, 0, 0}), {0, 1, 6.8f});
    Vec3f forward = world_from_camera.vector({0, 0, 1});
    check_vec(forward, {0, 0, -1});
    CHECK(s.camera.type == "perspective");
    CHECK(s.camera.params.get_float("fov", 0) == 19.5f);
    CHECK(s.film.params.get_int("xresolution", 0) == 1024);
    CHECK(s.film.params.get_int("yresolution", 0) == 1024);
    CHECK(s.integrator.type == "path");
    CHECK(s.integrator.params.get_int("maxdepth", 0) == 65);
    CHECK(s.sampler.params.get_int("pixelsamples", 0) == 64);
    CHECK(s.filter.type == "triangle");
    CHECK(s.materials.size() == 8);
    CHECK(s.shapes.size() == 8);
    int emissive = 0;
    for (const ShapeDesc &sh : s.shapes) {
        CHECK(sh.type == "trianglemesh");
        CHECK(s.materials.count(sh.material) == 1);
        if (!sh.area_light) continue;
        ++emissive;
        CHECK(sh.area_light_type == "diffuse");
        Rgb L = *sh.area_light->get_rgb("L", true);
        CHECK(L.r == 17.f);
        CHECK(L.g == 12.f);
        CHECK(L.b == 4.f);
        CHECK(sh.material == "Light");
    }
    CHECK(emissive == 1);
}

TEST_CASE("Include inside an included file resolves against the main file's directory first") {
    // The layout of pbrt-v4-scenes' sanmiguel: geometry/geom.pbrt includes "geometry/part.pbrt".
    auto dir = temp_dir("include_main_first");
    write_file(dir / "main.pbrt", "WorldBegin\nInclude \"geometry/geom.pbrt\"\n");
    write_file(dir / "geometry" / "geom.pbrt", "Include \"geometry/part.pbrt\"\n");
    write_file(dir / "geometry" / "part.pbrt", "Shape \"sphere\"\n");
    SceneDesc s = parse_pbrt_file((dir / "main.pbrt").string());
    REQUIRE(s.shapes.size() == 1);
    CHECK(s.shapes[0].loc.file == (dir / "geometry" / "part.pbrt").string());
    CHECK(s.shapes[0].base_dir == dir.string());
}

TEST_CASE("gzip-compressed scene files and includes are decompressed (pbrt-v4)") {
    auto dir = temp_dir("gzip_scene");
    // An Include and an Import of ".pbrt.gz" files, from a main file that is itself ".gz".
    test::write_gzip(dir / "geometry" / "part.pbrt.gz",
                     "Shape \"sphere\" \"float radius\" [ 2.5 ]\n");
    test::write_gzip(dir / "more.pbrt.gz", "Shape \"disk\"\n");
    const std::string main_text = "Film \"rgb\" \"integer xresolution\" [ 32 ]\nWorldBegin\n"
                                  "Include \"geometry/part.pbrt.gz\"\nImport \"more.pbrt.gz\"\n";
    std::string main_gz = test::write_gzip(dir / "main.pbrt.gz", main_text);
    SceneDesc s = parse_pbrt_file(main_gz);
    REQUIRE(s.shapes.size() == 2);
    CHECK(s.shapes[0].type == "sphere");
    CHECK(s.shapes[0].params.get_float("radius", 1.f) == 2.5f);
    CHECK(s.shapes[0].loc.file == (dir / "geometry" / "part.pbrt.gz").string());
    CHECK(s.shapes[0].loc.line == 1);
    CHECK(s.shapes[1].type == "disk");
    CHECK(s.film.params.get_int("xresolution", 0) == 32);
    // The same text uncompressed parses to the same shapes and film.
    write_file(dir / "plain.pbrt", main_text);
    SceneDesc p = parse_pbrt_file((dir / "plain.pbrt").string());
    CHECK(p.shapes.size() == 2);
    CHECK(p.film.params.get_int("xresolution", 0) == 32);

    // A truncated compressed include is an error at the Include line, not a shorter scene.
    std::string whole = test::write_gzip(dir / "whole.gz", std::string(20000, '#') + "\n");
    std::ifstream in(whole, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    write_file(dir / "cut.pbrt.gz", bytes.substr(0, bytes.size() / 2));
    write_file(dir / "cut_main.pbrt", "WorldBegin\nInclude \"cut.pbrt.gz\"\n");
    CHECK_THROWS_WITH(parse_pbrt_file((dir / "cut_main.pbrt").string()),
                      doctest::Contains("cut_main.pbrt:2: cannot open Include file \"cut.pbrt.gz\": "
                                        "is not valid gzip data (truncated"));
}
