// pbrt-v4 "hair" material: its parameters (which absorption wins, defaults, clamps, warnings)
// and renders of hair curves whose outcome is known (a white furnace, melanin's colour order).
#include <doctest/doctest.h>

#include <cmath>
#include <sstream>
#include <string>
#include <variant>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/material.h"

using namespace tessera;

namespace {

/// An orthographic view of [-1, 1]^2 filled by one flat curve 4 units wide, under a uniform
/// white sky, with `material` on the curve.
std::string furnace_scene(const std::string &material, int res = 16, int spp = 64) {
    std::ostringstream os;
    os << "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"orthographic\"\n"
       << "Film \"rgb\" \"integer xresolution\" [ " << res << " ] \"integer yresolution\" [ "
       << res << " ]\nSampler \"zsobol\" \"integer pixelsamples\" [ " << spp << " ]\n"
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
    si.dpdu = {1, 0, 0};
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
        HairBxdf h = hair_at(*build("Material \"hair\" \"rgb sigma_a\" [ 0.1 0.2 0.3 ] "
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
    SUBCASE("melanin concentrations; roughness clamped to [0.01, 1]") {
        HairBxdf h = hair_at(*build("Material \"hair\" \"float pheomelanin\" 2 "
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
    for (float v : img.data) spread = std::max(spread, std::abs(double(v) - 1.0));
    CHECK(spread > 1e-3);
    MESSAGE("white furnace: " << test::image_mean(img, 0) << " " << test::image_mean(img, 1)
                              << " " << test::image_mean(img, 2) << ", max |pixel - 1| "
                              << spread);
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
