// pbrt-v4 "hair" material: its parameters (which absorption wins, defaults, clamps, warnings)
// and renders of hair curves whose outcome is known (a white furnace, melanin's colour order).
#include <doctest/doctest.h>

#include <cmath>
#include <sstream>
#include <string>
#include <variant>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/shading/material.h"
#include "renderer/integrators/path_integrator.h"
#include "renderer/integrators/whitted_integrator.h"

using namespace tessera;

namespace {

/// An orthographic view of [-1, 1]^2 filled by one flat curve 4 units wide, under a uniform
/// white sky, with `material` on the curve.
std::string furnace_scene(const std::string &material, int res = 16, int spp = 64) {
    std::ostringstream os;
    os << "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"orthographic\"\n"
       << "Film \"rgb\" \"integer xresolution\" [ " << res << " ] \"integer yresolution\" [ " << res
       << " ]\nSampler \"zsobol\" \"integer pixelsamples\" [ " << spp << " ]\n"
       << "PixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" [ 64 ]\nWorldBegin\n"
       << "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
       << material << "\n"
       << "Shape \"curve\" \"point3 P\" [ -3 0 0  -1 0 0  1 0 0  3 0 0 ] \"float width\" 4 "
          "\"string type\" \"flat\"\n";
    return os.str();
}

/// The HairBxdf the scene's only material builds where the curve is hit at v = 0.75.
HairBxdf hair_at(const Scene &scene) {
    SurfaceInteraction si;
    si.p = {0, 0, 0};
    si.n = si.ns = {0, 0, 1};
    si.dpdu = {2, 0, 0};
    si.dpdv = {0, 1, 0};
    si.uv = {0.5f, 0.75f};
    si.wo = {0, 0, 1};
    TextureEvalContext tc;
    tc.p = si.p;
    tc.n = si.n;
    tc.uv = si.uv;
    REQUIRE(scene.materials.size() >= 1);
    std::optional<Bsdf> b = scene.materials.back()->get_bsdf(si, tc);
    REQUIRE(b);
    REQUIRE(std::holds_alternative<HairBxdf>(b->bxdf()));
    // pbrt-v4's frame: x along dpdu (the fiber), z the shading normal.
    CHECK(b->frame().x.x == test::Approx(1.0).epsilon(1e-6));
    CHECK(b->frame().z.z == test::Approx(1.0).epsilon(1e-6));
    return std::get<HairBxdf>(b->bxdf());
}

}  // namespace

TEST_CASE("hair material: the absorption comes from sigma_a, else a colour, else melanin") {
    auto build = [](const std::string &material) {
        return test::scene_from_string(furnace_scene(material));
    };
    SUBCASE("without any: brown hair, eumelanin 1.3, and pbrt-v4's defaults") {
        int before = warning_count();
        HairBxdf h = hair_at(*build("Material \"hair\""));
        CHECK(warning_count() == before);
        Rgb s = HairBxdf::sigma_a_from_concentration(1.3f, 0.f);
        CHECK(h.sigma_a.r == s.r);
        CHECK(h.sigma_a.b == s.b);
        CHECK(h.eta == 1.55f);
        CHECK(h.h == test::Approx(0.5).epsilon(1e-6));  // -1 + 2 v at v = 0.75
        HairBxdf ref(0.5f, 1.55f, s, 0.3f, 0.3f, 2.f);
        CHECK(h.v0 == ref.v0);
        CHECK(h.s == ref.s);
        CHECK(h.sin_alpha == ref.sin_alpha);
    }
    SUBCASE("sigma_a wins over a colour and melanin, each ignored with a warning") {
        int before = warning_count();
        HairBxdf h =
            hair_at(*build("Material \"hair\" \"rgb sigma_a\" [ 0.1 0.2 0.3 ] "
                           "\"rgb reflectance\" [ 0.5 0.5 0.5 ] \"float eumelanin\" 2"));
        CHECK(warning_count() == before + 2);
        CHECK(last_warning().find("\"eumelanin\" ignored since \"sigma_a\" was given") !=
              std::string::npos);
        CHECK(h.sigma_a.g == test::Approx(0.2).epsilon(1e-6));
    }
    SUBCASE("a colour: pbrt-v4's \"reflectance\", or its older name \"color\"") {
        for (const char *name : {"reflectance", "color"}) {
            CAPTURE(name);
            HairBxdf h = hair_at(*build(std::string("Material \"hair\" \"rgb ") + name +
                                        "\" [ 0.8 0.4 0.1 ] \"float beta_n\" 0.5"));
            Rgb s = HairBxdf::sigma_a_from_reflectance(Rgb(0.8f, 0.4f, 0.1f), 0.5f);
            CHECK(h.sigma_a.r == test::Approx(s.r).epsilon(1e-6));
            CHECK(h.sigma_a.b == test::Approx(s.b).epsilon(1e-6));
            CHECK(h.sigma_a.r < h.sigma_a.g);
            CHECK(h.sigma_a.g < h.sigma_a.b);
        }
    }
    SUBCASE("bump mapping is ignored with a warning, as pbrt-v4 has none for hair") {
        int before = warning_count();
        auto sc = build(
            "Texture \"bumps\" \"float\" \"checkerboard\"\n"
            "Material \"hair\" \"texture displacement\" \"bumps\"");
        CHECK(warning_count() == before + 1);
        CHECK(last_warning().find("not supported on hair") != std::string::npos);
        hair_at(*sc);  // the frame is the fiber's own
    }
    SUBCASE("melanin concentrations; roughness clamped to [0.01, 1]") {
        HairBxdf h =
            hair_at(*build("Material \"hair\" \"float pheomelanin\" 2 "
                           "\"float beta_m\" 3 \"float beta_n\" 0"));
        Rgb s = HairBxdf::sigma_a_from_concentration(0.f, 2.f);
        CHECK(h.sigma_a.r == test::Approx(s.r).epsilon(1e-6));
        HairBxdf ref(0.5f, 1.55f, s, 1.f, 0.01f, 2.f);
        CHECK(h.v0 == ref.v0);
        CHECK(h.s == ref.s);
    }
}

TEST_CASE("hair material: a white furnace stays white; melanin absorbs red least") {
    // Non-absorbing hair under a uniform white sky reflects all of it (pbrt-v4's furnace bound
    // for the BSDF is 5%), through every bounce of the path tracer with MIS against the sky.
    auto white = test::scene_from_string(
        furnace_scene("Material \"hair\" \"rgb sigma_a\" [ 0 0 0 ] \"float beta_m\" 0.3"));
    sampling::RgbImage img = test::render_image(*white, 0);
    // The hair covers the view (an image of exactly 1 would also be an empty view): pixels
    // vary around 1.
    double spread = 0;
    for (float v : img.data)
        spread = std::max(spread, std::abs(double(v) - 1.0));
    CHECK(spread > 1e-3);
    MESSAGE("white furnace: " << test::image_mean(img, 0) << " " << test::image_mean(img, 1) << " "
                              << test::image_mean(img, 2) << ", max |pixel - 1| " << spread);
    for (int c = 0; c < 3; ++c) {
        double m = test::image_mean(img, c);
        CAPTURE(c);
        CHECK(m > 0.95);
        CHECK(m < 1.05);
    }
    // Brown hair: eumelanin absorbs blue most (sigma_a 0.419, 0.697, 1.37 per unit).
    auto brown = test::scene_from_string(furnace_scene("Material \"hair\""));
    sampling::RgbImage b = test::render_image(*brown, 0);
    double r = test::image_mean(b, 0), g = test::image_mean(b, 1), bl = test::image_mean(b, 2);
    CHECK(r < 0.9);
    CHECK(r > g);
    CHECK(g > bl);
    CHECK(bl > 0.0);
    MESSAGE("brown hair: " << r << " " << g << " " << bl);
}

TEST_CASE("hair material: backlit hair transmits the light (TT) in both integrators") {
    // A distant light behind the curve shines toward the camera: only TT and TRT reach it, on
    // the far side of the shading normal. The Whitted integrator's reflection-only culling must
    // not drop them; both integrators evaluate the same f for a delta light (direct light only).
    std::string scene_text = furnace_scene("Material \"hair\" \"rgb sigma_a\" [ 0.2 0.2 0.2 ]");
    scene_text.replace(scene_text.find("LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]"),
                       std::string("LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]").size(),
                       "LightSource \"distant\" \"point3 from\" [ 0.3 0.2 -5 ] "
                       "\"point3 to\" [ 0 0 0 ] \"rgb L\" [ 3 3 3 ]");
    scene_text.replace(scene_text.find("\"integer maxdepth\" [ 64 ]"),
                       std::string("\"integer maxdepth\" [ 64 ]").size(),
                       "\"integer maxdepth\" [ 1 ]");
    auto scene = test::scene_from_string(scene_text);
    WhittedIntegrator w(*scene);
    PathIntegrator path(*scene, 1, 1, DirectStrategy::LightOnly);
    double sum_w = 0, sum_p = 0;
    int n = 0;
    for (uint32_t y = 2; y < 14; y += 3)
        for (uint32_t x = 2; x < 14; x += 3) {
            CameraSample cs;
            cs.px = x;
            cs.py = y;
            cs.fx = cs.fy = 0.5f;
            sum_w += w.evaluate(cs).radiance.g;
            sum_p += path.evaluate(cs).radiance.g;
            ++n;
        }
    CHECK(sum_p / n > 0.05);
    CHECK(sum_w / n == test::Approx(sum_p / n).epsilon(0.02));
}
