// Textures: procedural values at known points, mappings, parameter helpers, and image maps
// (sRGB linearisation, v flip, wrap modes, footprint filtering) on images written here.
#include <doctest/doctest.h>

#include <OpenImageIO/imagebuf.h>

#include <filesystem>
#include <thread>

#include "approx.h"
#include "renderer/shading/texture.h"
#include "test_helpers.h"
#include "texture_test_util.h"

using namespace tessera;
using tessera::test::desc;
using tessera::test::flag;
using tessera::test::num;
using tessera::test::str;
namespace fs = std::filesystem;

namespace {

TextureEvalContext at_uv(float u, float v, float dudx = 0, float dvdy = 0) {
    TextureEvalContext c;
    c.uv = {u, v};
    c.dudx = dudx;
    c.dvdy = dvdy;
    c.n = {0, 0, 1};
    return c;
}
TextureEvalContext at_p(Vec3f p) {
    TextureEvalContext c;
    c.p = p;
    c.n = {0, 0, 1};
    return c;
}

fs::path temp_dir() {
    fs::path d = fs::temp_directory_path() / "tessera_test_texture";
    fs::create_directories(d);
    return d;
}

/// Writes an image of `w` x `h` pixels, `nch` channels, rows top to bottom.
template <typename T>
std::string write_image(const std::string &name, int w, int h, int nch, OIIO::TypeDesc fmt,
                        const std::vector<T> &data) {
    std::string path = (temp_dir() / name).string();
    OIIO::ImageBuf buf(OIIO::ImageSpec(w, h, nch, fmt));
    buf.set_pixels(buf.roi(), OIIO::TypeDescFromC<T>::value(), data.data());
    REQUIRE(buf.write(path));
    return path;
}

// 4 x 2 sRGB PNG: top row (188,0,0) (0,188,0) (0,0,188) (255,255,255);
// bottom row (10,20,30) (64,64,64) (128,128,128) (0,0,0).
std::string test_png() {
    std::vector<uint8_t> px = {188, 0,  0,  0,  188, 0,  0,   0,   188, 255, 255, 255,
                               10,  20, 30, 64, 64,  64, 128, 128, 128, 0,   0,   0};
    return write_image("rgb4x2.png", 4, 2, 3, OIIO::TypeDesc::UINT8, px);
}

float srgb8(int v) {
    return srgb_to_linear(v / 255.f);
}

}  // namespace

TEST_CASE("srgb_to_linear matches the IEC 61966-2-1 curve") {
    CHECK(srgb_to_linear(0.f) == 0.f);
    CHECK(srgb_to_linear(1.f) == test::Approx(1.f));
    CHECK(srgb8(188) == test::Approx(0.50289).epsilon(1e-4));
    CHECK(srgb_to_linear(0.04f) == test::Approx(0.04f / 12.92f));
}

TEST_CASE("constant, scale and mix") {
    std::vector<TextureDesc> d = {
        desc("half", "float", "constant", {num("float", "value", {0.5})}),
        desc("scaled", "float", "scale",
             {str("texture", "tex", "half"), num("float", "scale", {3})}),
        desc("red", "spectrum", "constant", {num("rgb", "value", {0.8, 0.1, 0.2})}),
        desc("redx2", "spectrum", "scale",
             {str("texture", "tex", "red"), num("float", "scale", {2})}),
        desc("mixf", "float", "mix",
             {num("float", "tex1", {0.2}), num("float", "tex2", {0.8}),
              num("float", "amount", {0.25})}),
        desc("mixs", "spectrum", "mix",
             {str("texture", "tex1", "red"), num("rgb", "tex2", {0, 1, 0}),
              str("texture", "amount", "half")}),
        desc("mixdef", "float", "mix", {}),  // defaults: tex1 0, tex2 1, amount 0.5
    };
    TextureSet set(d);
    CHECK_FALSE(set.has_image_maps());
    CHECK(set.size() == d.size());
    TextureEvalContext c = at_uv(0.3f, 0.7f);
    CHECK(set.get_float("half")->evaluate(c) == 0.5f);
    CHECK(set.get_float("scaled")->evaluate(c) == test::Approx(1.5f));
    Rgb r2 = set.get_spectrum("redx2")->evaluate(c);
    CHECK(r2.r == test::Approx(1.6f));
    CHECK(r2.g == test::Approx(0.2f));
    CHECK(r2.b == test::Approx(0.4f));
    CHECK(set.get_float("mixf")->evaluate(c) == test::Approx(0.35f));
    Rgb m = set.get_spectrum("mixs")->evaluate(c);
    CHECK(m.r == test::Approx(0.4f));
    CHECK(m.g == test::Approx(0.55f));
    CHECK(m.b == test::Approx(0.1f));
    CHECK(set.get_float("mixdef")->evaluate(c) == test::Approx(0.5f));
    CHECK(set.get_float("red") == nullptr);  // float and spectrum names are separate
    CHECK(set.get_spectrum("nothing") == nullptr);
}

TEST_CASE("checkerboard 2D: cells, uv mapping, footprint filtering") {
    std::vector<TextureDesc> d = {
        desc("c", "float", "checkerboard", {}),
        desc("c2", "float", "checkerboard",
             {num("float", "uscale", {2}), num("float", "vscale", {4}),
              num("float", "udelta", {0.5})}),
        desc("cs", "spectrum", "checkerboard",
             {num("rgb", "tex1", {1, 0, 0}), num("rgb", "tex2", {0, 0, 1})}),
    };
    TextureSet set(d);
    const FloatTexture *c = set.get_float("c");
    // tex1 (default 1) where floor(s) + floor(t) is even, tex2 (default 0) elsewhere.
    CHECK(c->evaluate(at_uv(0.25f, 0.25f)) == 1.f);
    CHECK(c->evaluate(at_uv(1.25f, 0.25f)) == 0.f);
    CHECK(c->evaluate(at_uv(1.25f, 1.75f)) == 1.f);
    CHECK(c->evaluate(at_uv(-0.25f, 0.25f)) == 0.f);
    CHECK(c->evaluate(at_uv(-0.25f, -0.25f)) == 1.f);
    // s = 2u + 0.5, t = 4v: u = 0.3 -> s = 1.1 (odd), v = 0.1 -> t = 0.4 (even).
    const FloatTexture *c2 = set.get_float("c2");
    CHECK(c2->evaluate(at_uv(0.3f, 0.1f)) == 0.f);
    CHECK(c2->evaluate(at_uv(0.3f, 0.3f)) == 1.f);  // t = 1.2
    CHECK(c2->evaluate(at_uv(0.1f, 0.1f)) == 1.f);  // s = 0.7
    Rgb a = set.get_spectrum("cs")->evaluate(at_uv(0.5f, 0.5f));
    Rgb b = set.get_spectrum("cs")->evaluate(at_uv(1.5f, 0.5f));
    CHECK((a.r == 1.f && a.b == 0.f));
    CHECK((b.r == 0.f && b.b == 1.f));
    // A footprint of many cells averages to 1/2; a tiny one inside a cell is exact.
    CHECK(c->evaluate(at_uv(0.37f, 0.61f, 20.f, 20.f)) == test::Approx(0.5f).epsilon(0.01));
    CHECK(c->evaluate(at_uv(0.5f, 0.5f, 0.01f, 0.01f)) == 1.f);
    // Straddling one edge in s only (t well inside the cell): the tent filter is symmetric,
    // so exactly on the edge the result is 1/2.
    CHECK(c->evaluate(at_uv(1.0f, 0.5f, 0.1f, 0.01f)) == test::Approx(0.5f));
    // Slightly inside cell 0: more than half of the footprint has value 1.
    float near_edge = c->evaluate(at_uv(0.97f, 0.5f, 0.1f, 0.01f));
    CHECK(near_edge > 0.5f);
    CHECK(near_edge < 1.f);
}

TEST_CASE("checkerboard 2D: textured cells and a planar mapping") {
    // The constant-colour, uv-mapped checkerboard skips the virtual calls; these take the
    // general path: a cell that is itself a texture, and a mapping other than uv.
    std::vector<TextureDesc> d = {
        desc("fine", "float", "checkerboard",
             {num("float", "uscale", {4}), num("float", "vscale", {4})}),
        desc("nested", "float", "checkerboard",
             {str("texture", "tex1", "fine"), num("float", "tex2", {0.25})}),
        desc("pl", "float", "checkerboard",
             {str("string", "mapping", "planar"), num("vector3", "v1", {1, 0, 0}),
              num("vector3", "v2", {0, 1, 0}), num("float", "tex1", {0.75}),
              num("float", "tex2", {0.125})}),
    };
    TextureSet set(d);
    const FloatTexture *n = set.get_float("nested");
    // Cell (0, 0) of the outer board shows "fine": s = 4u, t = 4v.
    CHECK(n->evaluate(at_uv(0.1f, 0.1f)) == 1.f);   // fine cell (0, 0)
    CHECK(n->evaluate(at_uv(0.3f, 0.1f)) == 0.f);   // fine cell (1, 0)
    CHECK(n->evaluate(at_uv(0.3f, 0.3f)) == 1.f);   // fine cell (1, 1)
    CHECK(n->evaluate(at_uv(1.1f, 0.1f)) == 0.25f); // outer cell (1, 0): the constant
    // Planar: s = x, t = y of the point; uv is ignored.
    const FloatTexture *pl = set.get_float("pl");
    TextureEvalContext c = at_p({0.5f, 0.5f, 3.f});
    c.uv = {1.5f, 0.5f};
    CHECK(pl->evaluate(c) == 0.75f);
    CHECK(pl->evaluate(at_p({1.5f, 0.5f, 0.f})) == 0.125f);
    CHECK(pl->evaluate(at_p({1.5f, -0.5f, 0.f})) == 0.75f);
}

TEST_CASE("checkerboard 3D uses the texture transform") {
    std::vector<TextureDesc> d = {
        desc("c3", "float", "checkerboard", {num("integer", "dimension", {3})},
             Transform::translate({1, 0, 0})),
    };
    TextureSet set(d);
    const FloatTexture *c = set.get_float("c3");
    // Texture space is render space shifted by -1 in x.
    CHECK(c->evaluate(at_p({1.5f, 0.5f, 0.5f})) == 1.f);
    CHECK(c->evaluate(at_p({2.5f, 0.5f, 0.5f})) == 0.f);
    CHECK(c->evaluate(at_p({2.5f, 1.5f, 0.5f})) == 1.f);
    CHECK(c->evaluate(at_p({0.5f, 0.5f, 0.5f})) == 0.f);
}

TEST_CASE("bilerp and the spherical, cylindrical and planar mappings") {
    // With v00 = v01 = 0 and v10 = v11 = 1 a bilerp texture returns s; the swapped one t.
    auto s_of = [](const std::string &name, std::vector<Param> extra, Transform t = {}) {
        std::vector<Param> ps = {num("float", "v00", {0}), num("float", "v01", {0}),
                                 num("float", "v10", {1}), num("float", "v11", {1})};
        ps.insert(ps.end(), extra.begin(), extra.end());
        return desc(name, "float", "bilerp", ps, t);
    };
    auto t_of = [](const std::string &name, std::vector<Param> extra, Transform t = {}) {
        std::vector<Param> ps = {num("float", "v00", {0}), num("float", "v01", {1}),
                                 num("float", "v10", {0}), num("float", "v11", {1})};
        ps.insert(ps.end(), extra.begin(), extra.end());
        return desc(name, "float", "bilerp", ps, t);
    };
    std::vector<TextureDesc> d = {
        s_of("uv_s", {num("float", "uscale", {0.5}), num("float", "udelta", {0.1})}),
        t_of("uv_t", {num("float", "vscale", {2}), num("float", "vdelta", {-0.5})}),
        s_of("sph_s", {str("string", "mapping", "spherical")}),
        t_of("sph_t", {str("string", "mapping", "spherical")}),
        s_of("cyl_s", {str("string", "mapping", "cylindrical")}),
        t_of("cyl_t", {str("string", "mapping", "cylindrical")}, Transform::translate({0, 0, 2})),
        s_of("pl_s",
             {str("string", "mapping", "planar"), num("vector3", "v1", {0, 0, 1}),
              num("vector3", "v2", {1, 0, 0}), num("float", "udelta", {0.25})},
             Transform::translate({1, 0, 0})),
        t_of("pl_t",
             {str("string", "mapping", "planar"), num("vector3", "v1", {0, 0, 1}),
              num("vector3", "v2", {1, 0, 0}), num("float", "vdelta", {0.5})},
             Transform::translate({1, 0, 0})),
        desc("bl_rgb", "spectrum", "bilerp",
             {num("rgb", "v00", {1, 0, 0}), num("rgb", "v11", {0, 0, 1}),
              num("rgb", "v01", {0, 0, 0}), num("rgb", "v10", {0, 0, 0})}),
    };
    TextureSet set(d);
    TextureEvalContext c = at_uv(0.6f, 0.4f);
    CHECK(set.get_float("uv_s")->evaluate(c) == test::Approx(0.4f));  // 0.5 * 0.6 + 0.1
    CHECK(set.get_float("uv_t")->evaluate(c) == test::Approx(0.3f));  // 2 * 0.4 - 0.5
    // Spherical: s = theta / pi, t = phi / 2pi (pbrt-v4).
    CHECK(set.get_float("sph_s")->evaluate(at_p({0, 0, 3})) == test::Approx(0.f));
    CHECK(set.get_float("sph_s")->evaluate(at_p({2, 0, 0})) == test::Approx(0.5f));
    CHECK(set.get_float("sph_s")->evaluate(at_p({0, 0, -1})) == test::Approx(1.f));
    CHECK(set.get_float("sph_t")->evaluate(at_p({0, 1, 0})) == test::Approx(0.25f));
    CHECK(set.get_float("sph_t")->evaluate(at_p({-1, 0, 0.5f})) == test::Approx(0.5f));
    // Cylindrical: s = (pi + atan2(y, x)) / 2pi, t = z in texture space.
    CHECK(set.get_float("cyl_s")->evaluate(at_p({1, 0, 0})) == test::Approx(0.5f));
    CHECK(set.get_float("cyl_s")->evaluate(at_p({0, 1, 0})) == test::Approx(0.75f));
    CHECK(set.get_float("cyl_t")->evaluate(at_p({1, 0, 2.3f})) == test::Approx(0.3f));
    // Planar: s = udelta + dot(p_tex, v1), t = vdelta + dot(p_tex, v2); p_tex = p - (1,0,0).
    CHECK(set.get_float("pl_s")->evaluate(at_p({5, 9, 0.5f})) == test::Approx(0.75f));
    CHECK(set.get_float("pl_t")->evaluate(at_p({1.25f, 9, 0.5f})) == test::Approx(0.75f));
    Rgb q = set.get_spectrum("bl_rgb")->evaluate(at_uv(0.5f, 0.5f));
    CHECK(q.r == test::Approx(0.25f));
    CHECK(q.g == test::Approx(0.f));
    CHECK(q.b == test::Approx(0.25f));
}

TEST_CASE("directionmix follows the normal") {
    std::vector<TextureDesc> d = {
        desc("dm", "float", "directionmix",
             {num("float", "tex1", {1}), num("float", "tex2", {0}),
              num("vector3", "dir", {0, 0, 1})}),
    };
    TextureSet set(d);
    TextureEvalContext c = at_uv(0, 0);
    c.n = {0, 0, -1};
    CHECK(set.get_float("dm")->evaluate(c) == test::Approx(1.f));
    c.n = normalize(Vec3f(1, 0, 1));
    CHECK(set.get_float("dm")->evaluate(c) == test::Approx(std::sqrt(0.5f)));
}

TEST_CASE("material parameter helpers") {
    std::vector<TextureDesc> d = {
        desc("bright", "spectrum", "constant", {num("rgb", "value", {1.5, 0.5, -0.0})}),
        desc("rough", "float", "constant", {num("float", "value", {0.3})}),
    };
    TextureSet set(d);
    ParamSet ps;
    ps.params = {str("texture", "reflectance", "bright"), num("rgb", "Kd", {0.2, 0.4, 0.6}),
                 str("texture", "roughness", "rough"),    num("float", "eta", {1.33}),
                 str("texture", "missing", "nope"),       str("texture", "wrongkind", "rough")};
    TextureEvalContext c = at_uv(0.5f, 0.5f);
    // Reflectance from a texture is clamped to [0,1]; the unbounded lookup is not.
    Rgb clamped = set.spectrum_param(ps, "reflectance", std::nullopt, false)->evaluate(c);
    CHECK(clamped.r == 1.f);
    CHECK(clamped.g == 0.5f);
    Rgb raw = set.spectrum_param(ps, "reflectance", std::nullopt, true)->evaluate(c);
    CHECK(raw.r == 1.5f);
    // The clamping wrapper is made once per texture.
    CHECK(set.spectrum_param(ps, "reflectance", std::nullopt, false) ==
          set.spectrum_param(ps, "reflectance", std::nullopt, false));
    Rgb kd = set.spectrum_param(ps, "Kd", Rgb(0.5f), false)->evaluate(c);
    CHECK(kd.b == test::Approx(0.6f));
    CHECK(set.spectrum_param(ps, "absent", std::nullopt, false) == nullptr);
    Rgb def = set.spectrum_param(ps, "absent", Rgb(0.25f), false)->evaluate(c);
    CHECK(def.g == 0.25f);
    CHECK(set.float_param(ps, "roughness", 0.f) == set.get_float("rough"));
    CHECK(set.float_param(ps, "eta", 1.5f)->evaluate(c) == test::Approx(1.33f));
    CHECK(set.float_param(ps, "absent", 1.5f)->evaluate(c) == 1.5f);
    CHECK_THROWS_AS(set.float_param(ps, "missing", 0.f), SceneError);
    CHECK_THROWS_AS(set.spectrum_param(ps, "wrongkind", std::nullopt, true), SceneError);
}

TEST_CASE("bad texture declarations") {
    CHECK_THROWS_AS(TextureSet({desc("x", "float", "nosuchclass", {})}), SceneError);
    CHECK_THROWS_AS(TextureSet({desc("x", "vector", "constant", {})}), SceneError);
    CHECK_THROWS_AS(TextureSet({desc("x", "float", "scale", {str("texture", "tex", "later")}),
                                desc("later", "float", "constant", {})}),
                    SceneError);
    CHECK_THROWS_AS(
        TextureSet({desc("x", "float", "constant", {}), desc("x", "float", "constant", {})}),
        SceneError);
    CHECK_THROWS_AS(TextureSet({desc("x", "spectrum", "imagemap",
                                     {str("string", "filename", "/no/such/image.png")})}),
                    SceneError);
    // Unsupported classes warn and become a constant 0.5.
    int before = warning_count();
    TextureSet set({desc("faces", "float", "ptex", {str("string", "filename", "x.ptx")})});
    CHECK(warning_count() == before + 1);
    CHECK(set.get_float("faces")->evaluate(at_uv(0.1f, 0.2f)) == 0.5f);
}

TEST_CASE("imagemap: sRGB linearisation, v flip, wrap modes, scale and invert") {
    // The in-memory pyramid and, with no budget for one, OpenImageIO's TextureSystem (each
    // subcase runs the whole test).
    size_t budget = TextureSet::kMaxSetPyramidBytes;
    SUBCASE("in-memory pyramid") {}
    SUBCASE("OpenImageIO") { budget = 0; }
    CAPTURE(budget);
    std::string png = test_png();
    std::vector<TextureDesc> d = {
        desc("img", "spectrum", "imagemap", {str("string", "filename", png)}),
        desc("imgf", "float", "imagemap", {str("string", "filename", png)}),
        desc("black", "spectrum", "imagemap",
             {str("string", "filename", png), str("string", "wrap", "black")}),
        desc("clamp", "spectrum", "imagemap",
             {str("string", "filename", png), str("string", "wrap", "clamp")}),
        desc("lin", "spectrum", "imagemap",
             {str("string", "filename", png), str("string", "encoding", "linear")}),
        desc("gamma", "spectrum", "imagemap",
             {str("string", "filename", png), str("string", "encoding", "gamma 2.2")}),
        desc("inv", "spectrum", "imagemap",
             {str("string", "filename", png), flag("invert", true), num("float", "scale", {0.5})}),
        desc("point", "float", "imagemap",
             {str("string", "filename", png), str("string", "filter", "point")}),
    };
    TextureSet set(d, budget);
    CHECK(set.has_image_maps());
    CHECK(set.uses_texture_system() == (budget == 0));
    CHECK((set.pyramid_bytes() > 0) == (budget > 0));
    const SpectrumTexture *img = set.get_spectrum("img");
    // Texel centres: s = (i + 0.5) / 4; top row at v = 0.75 (pbrt looks up (s, 1 - v)).
    Rgb tl = img->evaluate(at_uv(0.125f, 0.75f));
    CHECK(tl.r == test::Approx(srgb8(188)).epsilon(1e-3));
    CHECK(tl.g == test::Approx(0.f));
    CHECK(tl.b == test::Approx(0.f));
    Rgb tr = img->evaluate(at_uv(0.875f, 0.75f));
    CHECK(tr.g == test::Approx(1.f).epsilon(1e-3));
    Rgb bl = img->evaluate(at_uv(0.125f, 0.25f));
    CHECK(bl.r == test::Approx(srgb8(10)).epsilon(2e-3));
    CHECK(bl.g == test::Approx(srgb8(20)).epsilon(2e-3));
    CHECK(bl.b == test::Approx(srgb8(30)).epsilon(2e-3));
    Rgb b3 = img->evaluate(at_uv(0.625f, 0.25f));
    CHECK(b3.g == test::Approx(srgb8(128)).epsilon(1e-3));
    // Half way between two texel centres, bilinear filtering averages the *linear* values.
    Rgb mid = img->evaluate(at_uv(0.25f, 0.75f));
    CHECK(mid.r == test::Approx(0.5f * srgb8(188)).epsilon(2e-3));
    CHECK(mid.g == test::Approx(0.5f * srgb8(188)).epsilon(2e-3));
    // Float image maps of an RGB image read the average of the linear channels (pbrt-v4's
    // MIPMap::Bilerp<Float>); the top-left texel is (188, 0, 0).
    CHECK(set.get_float("imgf")->evaluate(at_uv(0.125f, 0.75f)) ==
          test::Approx(srgb8(188) / 3).epsilon(1e-3));
    // The "point" (and "ewa") filter reads channel 0 instead (pbrt-v4's MIPMap::Texel<Float>).
    CHECK(set.get_float("point")->evaluate(at_uv(0.2f, 0.6f)) ==
          test::Approx(srgb8(188)).epsilon(1e-3));
    // Wrap modes one texel width beyond s = 1.
    Rgb rep = img->evaluate(at_uv(1.125f, 0.75f));
    CHECK(rep.r == test::Approx(srgb8(188)).epsilon(1e-3));
    Rgb blk = set.get_spectrum("black")->evaluate(at_uv(1.125f, 0.75f));
    CHECK(blk.r == 0.f);
    CHECK(blk.g == 0.f);
    Rgb clp = set.get_spectrum("clamp")->evaluate(at_uv(1.125f, 0.75f));
    CHECK(clp.r == test::Approx(1.f).epsilon(1e-3));  // the white edge texel
    CHECK(clp.b == test::Approx(1.f).epsilon(1e-3));
    // Encodings.
    CHECK(set.get_spectrum("lin")->evaluate(at_uv(0.125f, 0.75f)).r ==
          test::Approx(188.f / 255.f).epsilon(1e-3));
    CHECK(set.get_spectrum("gamma")->evaluate(at_uv(0.125f, 0.75f)).r ==
          test::Approx(std::pow(188.f / 255.f, 2.2f)).epsilon(1e-3));
    // invert: max(0, 1 - scale * value).
    Rgb inv = set.get_spectrum("inv")->evaluate(at_uv(0.125f, 0.75f));
    CHECK(inv.r == test::Approx(1.f - 0.5f * srgb8(188)).epsilon(1e-3));
    CHECK(inv.g == test::Approx(1.f));
}

TEST_CASE("imagemap: float EXR stays linear and unclamped, relative file names") {
    std::vector<float> px = {0.25f, 2.5f, 0.f,  1.f, 0.125f, 4.f,   // top row
                             0.5f,  0.5f, 0.5f, 8.f, 0.f,    0.f};  // bottom row
    std::string exr = write_image("hdr2x2.exr", 2, 2, 3, OIIO::TypeDesc::FLOAT, px);
    TextureDesc t = desc("hdr", "spectrum", "imagemap", {str("string", "filename", "hdr2x2.exr")});
    t.base_dir = temp_dir().string();
    TextureSet set({t});
    const SpectrumTexture *hdr = set.get_spectrum("hdr");
    Rgb a = hdr->evaluate(at_uv(0.25f, 0.75f));
    CHECK(a.r == test::Approx(0.25f));
    CHECK(a.g == test::Approx(2.5f));
    Rgb b = hdr->evaluate(at_uv(0.75f, 0.25f));
    CHECK(b.r == test::Approx(8.f));
    ParamSet ps;
    ps.params = {str("texture", "reflectance", "hdr")};
    CHECK(set.spectrum_param(ps, "reflectance", std::nullopt, false)
              ->evaluate(at_uv(0.25f, 0.75f))
              .g == 1.f);
}

TEST_CASE("imagemap: a large footprint averages a checkerboard image, from many threads") {
    // 64 x 64 sRGB PNG of 8 x 8-pixel black and white squares.
    std::vector<uint8_t> px(64 * 64);
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) px[y * 64 + x] = ((x / 8 + y / 8) & 1) ? 255 : 0;
    std::string png = write_image("checker64.png", 64, 64, 1, OIIO::TypeDesc::UINT8, px);
    size_t budget = TextureSet::kMaxSetPyramidBytes;
    SUBCASE("in-memory pyramid") {}
    SUBCASE("OpenImageIO") { budget = 0; }
    CAPTURE(budget);
    for (const char *filter : {"bilinear", "trilinear", "ewa"}) {
        CAPTURE(filter);
        TextureSet set({desc("chk", "spectrum", "imagemap",
                             {str("string", "filename", png), str("string", "filter", filter)})},
                       budget);
        const SpectrumTexture *t = set.get_spectrum("chk");
        // Inside a square with a tiny footprint: exactly black or white (grey image -> rgb).
        Rgb white = t->evaluate(at_uv(12.f / 64, 1 - 4.f / 64, 1e-4f, 1e-4f));
        CHECK(white.r == test::Approx(1.f).epsilon(1e-3));
        CHECK(white.b == test::Approx(1.f).epsilon(1e-3));
        CHECK(t->evaluate(at_uv(4.f / 64, 1 - 4.f / 64, 1e-4f, 1e-4f)).g == test::Approx(0.f));
        // Footprint of the whole image: the mean, 1/2 (in linear units).
        Rgb avg = t->evaluate(at_uv(0.5f, 0.5f, 1.f, 1.f));
        CHECK(avg.r == test::Approx(0.5f).epsilon(0.02));
        // Many threads at once give the same values as one.
        std::vector<float> out(8 * 200);
        std::vector<std::thread> threads;
        for (int k = 0; k < 8; ++k)
            threads.emplace_back([&, k] {
                for (int i = 0; i < 200; ++i)
                    out[k * 200 + i] = t->evaluate(at_uv(i / 200.f, 0.3f, 0.002f, 0.002f)).r;
            });
        for (auto &th : threads) th.join();
        for (int i = 0; i < 200; ++i) {
            float ref = t->evaluate(at_uv(i / 200.f, 0.3f, 0.002f, 0.002f)).r;
            for (int k = 0; k < 8; ++k) CHECK(out[k * 200 + i] == ref);
        }
    }
}

TEST_CASE("float image maps of colour images: RGB average, or alpha when it is not all 1") {
    // pbrt-v4's MIPMap lookups of Float: 3 channels -> average; RGBA with alpha < 1 -> alpha.
    namespace fs = std::filesystem;
    fs::path dir = fs::temp_directory_path() / "tessera_texture_float_channels";
    fs::create_directories(dir);
    auto write = [&](const std::string &name, int nch, const std::vector<float> &px) {
        OIIO::ImageSpec spec(2, 2, nch, OIIO::TypeDesc::FLOAT);
        auto out = OIIO::ImageOutput::create((dir / name).string());
        REQUIRE(out);
        REQUIRE(out->open((dir / name).string(), spec));
        REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
        out->close();
    };
    std::vector<float> rgb, rgba;
    for (int i = 0; i < 4; ++i) {
        rgb.insert(rgb.end(), {0.2f, 0.4f, 0.9f});
        rgba.insert(rgba.end(), {0.2f, 0.4f, 0.9f, 0.25f});
    }
    write("rgb.exr", 3, rgb);
    write("rgba.exr", 4, rgba);
    auto float_map = [&](std::string name, const std::string &file) {
        TextureDesc d;
        d.name = std::move(name);
        d.value_type = "float";
        d.tex_class = "imagemap";
        Param f;
        f.type = "string";
        f.name = "filename";
        f.strings = {(dir / file).string()};
        d.params.params.push_back(f);
        return d;
    };
    std::vector<TextureDesc> descs = {float_map("c", "rgb.exr"), float_map("a", "rgba.exr")};
    TextureSet set(descs);
    TextureEvalContext ctx;
    ctx.uv = {0.5f, 0.5f};
    CHECK(set.get_float("c")->evaluate(ctx) == test::Approx(0.5f).epsilon(1e-3));
    CHECK(set.get_float("a")->evaluate(ctx) == test::Approx(0.25f).epsilon(1e-3));

    // An 8-bit RGBA PNG: its alpha is decoded with the image's encoding (sRGB by default) like
    // the colour channels, as pbrt-v4's Image::GetChannel does; "linear" leaves it as stored.
    {
        const std::string png = (dir / "rgba8.png").string();
        OIIO::ImageSpec spec(2, 2, 4, OIIO::TypeDesc::UINT8);
        auto out = OIIO::ImageOutput::create(png);
        REQUIRE(out);
        REQUIRE(out->open(png, spec));
        // Four pixels of (200, 100, 50, 128); filled by index (g++ 12 misreports an
        // insert of an initializer list of bytes with -Wstringop-overflow).
        std::vector<uint8_t> px(16);
        const uint8_t texel[4] = {200, 100, 50, 128};
        for (size_t i = 0; i < px.size(); ++i) px[i] = texel[i % 4];
        REQUIRE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
        out->close();
        TextureDesc srgb = float_map("a8", "rgba8.png");
        TextureDesc lin = float_map("a8lin", "rgba8.png");
        Param e;
        e.type = "string";
        e.name = "encoding";
        e.strings = {"linear"};
        lin.params.params.push_back(e);
        TextureSet set8(std::vector<TextureDesc>{srgb, lin});
        CHECK(set8.get_float("a8")->evaluate(ctx) ==
              test::Approx(srgb_to_linear(128.f / 255.f)).epsilon(2e-3));
        CHECK(set8.get_float("a8lin")->evaluate(ctx) ==
              test::Approx(128.f / 255.f).epsilon(2e-3));
    }
    fs::remove_all(dir);
}

TEST_CASE("imagemap: formats pbrt-v4 reads with stb_image are sRGB and lose their alpha") {
    // A 2x2 RGBA TGA of (200, 100, 50, 128). pbrt-v4 reads TGA/JPEG/BMP/... through stb_image:
    // always sRGB whatever "encoding" says, and only R, G, B of a 4-channel image.
    std::vector<uint8_t> px(16);
    const uint8_t texel[4] = {200, 100, 50, 128};
    for (size_t i = 0; i < px.size(); ++i) px[i] = texel[i % 4];
    // Written as stored: OIIO would otherwise take the buffer as premultiplied and divide by
    // the alpha on writing a TGA.
    std::string tga = (temp_dir() / "rgba2x2.tga").string();
    {
        OIIO::ImageSpec spec(2, 2, 4, OIIO::TypeDesc::UINT8);
        spec.attribute("oiio:UnassociatedAlpha", 1);
        OIIO::ImageBuf buf(spec);
        buf.set_pixels(buf.roi(), OIIO::TypeDesc::UINT8, px.data());
        REQUIRE(buf.write(tga));
    }
    const float avg = (srgb8(200) + srgb8(100) + srgb8(50)) / 3;
    int before = warning_count();
    std::vector<TextureDesc> d = {
        desc("f", "float", "imagemap", {str("string", "filename", tga)}),
        desc("lin", "spectrum", "imagemap",
             {str("string", "filename", tga), str("string", "encoding", "linear")}),
    };
    TextureSet set(d);
    // The float map reads the RGB average, not the alpha (a PNG would give its alpha).
    CHECK(set.get_float("f")->evaluate(at_uv(0.5f, 0.5f)) == test::Approx(avg).epsilon(2e-3));
    // "linear" is ignored with a warning: the texels are decoded as sRGB.
    Rgb c = set.get_spectrum("lin")->evaluate(at_uv(0.5f, 0.5f));
    CHECK(c.r == test::Approx(srgb8(200)).epsilon(2e-3));
    CHECK(c.b == test::Approx(srgb8(50)).epsilon(2e-3));
    CHECK(warning_count() == before + 1);
    CHECK(last_warning().find("pbrt-v4 reads this image format as sRGB") != std::string::npos);
}
