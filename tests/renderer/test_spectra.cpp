// Unit tests of the spectrum -> linear sRGB conversions (renderer/util/spectra.h).
#include <doctest/doctest.h>

#include <vector>

#include "approx.h"
#include "renderer/util/spectra.h"

using namespace tessera;

namespace {

/// CIE D65 at 380..780 nm, 10 nm steps (CIE 15:2004): the sRGB white.
const std::vector<float> kD65 = {
    49.9755f, 54.6482f, 82.7549f, 91.4860f, 93.4318f, 86.6823f, 104.865f, 117.008f, 117.812f,
    114.861f, 115.923f, 108.811f, 109.354f, 107.802f, 104.790f, 107.689f, 104.405f, 104.046f,
    100.000f, 96.3342f, 95.7880f, 88.6856f, 90.0062f, 89.5991f, 87.6987f, 83.2886f, 83.6992f,
    80.0268f, 80.2146f, 82.2778f, 78.2842f, 69.7213f, 71.6091f, 74.3490f, 61.6040f, 69.8856f,
    75.0870f, 63.5927f, 46.4182f, 66.8054f, 63.3828f};

}  // namespace

TEST_CASE("CIE matching-function fit: peaks and equal areas") {
    // ybar peaks at 555 nm with value 1; xbar, ybar and zbar have (nearly) equal integrals.
    CHECK(cie_xyz(555).y == test::Approx(1.0).epsilon(0.01));
    CHECK(cie_xyz(450).z > 1.5f);
    double sx = 0, sy = 0, sz = 0;
    for (int l = 360; l <= 830; ++l) {
        Vec3f c = cie_xyz(float(l));
        sx += c.x, sy += c.y, sz += c.z;
    }
    CHECK(sy == test::Approx(106.857).epsilon(0.01));  // CIE_Y_integral
    CHECK(sx / sy == test::Approx(1.0).epsilon(0.01));
    CHECK(sz / sy == test::Approx(1.0).epsilon(0.01));
}

TEST_CASE("D65 as an illuminant is sRGB white; equal energy is slightly pink") {
    std::vector<float> lambda;
    for (int i = 0; i < 41; ++i) lambda.push_back(380.f + 10.f * i);
    Rgb d65 = sampled_spectrum_rgb(lambda, kD65, true);
    CHECK(d65.r == test::Approx(1).epsilon(0.005));
    CHECK(d65.g == test::Approx(1).epsilon(0.005));
    CHECK(d65.b == test::Approx(1).epsilon(0.005));
    // Illuminant E in linear sRGB at luminance 1 is about (1.205, 0.948, 0.909).
    std::vector<float> l2 = {300, 800}, flat = {3, 3};
    Rgb e = sampled_spectrum_rgb(l2, flat, true);
    CHECK(e.r == test::Approx(1.205).epsilon(0.01));
    CHECK(e.g == test::Approx(0.948).epsilon(0.01));
    CHECK(e.b == test::Approx(0.909).epsilon(0.01));
    CHECK(e.luminance() == test::Approx(1).epsilon(1e-3));
}

TEST_CASE("reflectance spectra: flat is grey, a red step is red") {
    std::vector<float> l = {300, 800}, v = {0.3f, 0.3f};
    Rgb grey = sampled_spectrum_rgb(l, v, false);
    CHECK(grey.r == test::Approx(0.3).epsilon(1e-4));
    CHECK(grey.g == test::Approx(0.3).epsilon(1e-4));
    CHECK(grey.b == test::Approx(0.3).epsilon(1e-4));
    // Zero below 600 nm, one above: a saturated red with no negative components.
    std::vector<float> ls = {300, 599, 600, 800}, vs = {0, 0, 1, 1};
    Rgb red = sampled_spectrum_rgb(ls, vs, false);
    CHECK(red.r > 0.8f);
    CHECK(red.g < 0.05f);
    CHECK(red.b < 0.05f);
    CHECK(red.g >= 0.f);
    CHECK(red.b >= 0.f);
}

TEST_CASE("blackbody: luminance 1, 6500 K near white, warm and cool ends") {
    Rgb w = blackbody_rgb(6500);
    CHECK(w.luminance() == test::Approx(1).epsilon(0.002));
    CHECK(w.r == test::Approx(1).epsilon(0.06));
    CHECK(w.g == test::Approx(1).epsilon(0.06));
    CHECK(w.b == test::Approx(1).epsilon(0.06));
    Rgb warm = blackbody_rgb(2856);  // illuminant A: orange
    CHECK(warm.r > 1.5f * warm.g);
    CHECK(warm.g > 2.f * warm.b);
    Rgb cool = blackbody_rgb(10000);
    CHECK(cool.b > cool.g);
    CHECK(cool.g > cool.r);
    CHECK(blackbody_rgb(1000).b >= 0.f);  // out of gamut: clamped
    // Planck's law at the peak of a 5000 K body (Wien: 579.6 nm), W/(m^2 sr m).
    // 2hc^2 / lambda^5 / (exp(hc / (lambda k T)) - 1) = 1.8185e15 / 142.0 by hand.
    CHECK(planck(579.6, 5000) == test::Approx(1.2806e13).epsilon(0.005));
    CHECK(planck(579.6, 5000) > planck(560, 5000));
    CHECK(planck(579.6, 5000) > planck(600, 5000));
}

TEST_CASE("band average of a piecewise-linear spectrum") {
    std::vector<float> l = {400, 700}, v = {0, 3};  // value = (lambda - 400) / 100
    Rgb a = band_average_rgb(l, v);
    CHECK(a.r == test::Approx(2.5).epsilon(1e-4));
    CHECK(a.g == test::Approx(1.5).epsilon(1e-4));
    CHECK(a.b == test::Approx(0.5).epsilon(1e-4));
}

TEST_CASE("named metals: plausible optical constants") {
    Rgb eta, k;
    REQUIRE(named_metal("Au", &eta, &k));
    CHECK(k.r > k.b);      // gold absorbs (reflects) red more strongly than blue
    CHECK(eta.b > eta.r);  // and is yellow: low eta in the red
    // Normal-incidence Fresnel reflectance ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
    auto r0 = [](float n, float kk) {
        return ((n - 1) * (n - 1) + kk * kk) / ((n + 1) * (n + 1) + kk * kk);
    };
    REQUIRE(named_metal("Ag", &eta, &k));
    CHECK(r0(eta.r, k.r) > 0.9f);
    CHECK(r0(eta.g, k.g) > 0.9f);
    CHECK(r0(eta.b, k.b) > 0.85f);
    REQUIRE(named_metal("Cu", &eta, &k));
    CHECK(r0(eta.r, k.r) > r0(eta.b, k.b) + 0.2f);  // copper is red
    REQUIRE(named_metal("Al", &eta, &k));
    CHECK(r0(eta.g, k.g) > 0.85f);
    CHECK(named_metal("CuZn", &eta, &k));
    CHECK(!named_metal("Unobtainium", &eta, &k));
    // The named-spectrum form gives the same table entries.
    REQUIRE(named_metal("Au", &eta, &k));
    CHECK(named_spectrum_rgb("metal-Au-eta")->b == eta.b);
    CHECK(named_spectrum_rgb("metal-Au-k")->r == k.r);
    CHECK(named_spectrum_rgb("metal-TiO2-k").has_value());
    CHECK(!named_spectrum_rgb("metal-Au-x").has_value());
}

TEST_CASE("named glasses, illuminants and unsupported names") {
    CHECK(named_spectrum_rgb("glass-BK7")->g == test::Approx(1.5185).epsilon(1e-4));
    CHECK(named_spectrum_rgb("glass-F11")->g == named_spectrum_rgb("glass-SF11")->g);
    CHECK(named_spectrum_rgb("glass-LASF9")->r > named_spectrum_rgb("glass-FK51A")->r);
    CHECK(!named_spectrum_note("glass-BK7").empty());
    Rgb d65 = *named_spectrum_rgb("stdillum-D65");
    CHECK(d65.r == 1.f);
    CHECK(d65.b == 1.f);
    CHECK(named_spectrum_note("stdillum-D65").empty());
    Rgb a = *named_spectrum_rgb("stdillum-A");
    CHECK(a.luminance() == test::Approx(1).epsilon(0.002));
    CHECK(a.r > a.b);
    Rgb a_refl = *named_spectrum_rgb("stdillum-A", false);
    CHECK(a_refl.max_value() == test::Approx(1));
    CHECK(!named_spectrum_note("stdillum-F11").empty());
    CHECK(!named_spectrum_rgb("canon_eos_100d_r").has_value());
    CHECK(!named_spectrum_rgb("no-such-spectrum").has_value());
}

TEST_CASE("daylight_xy: pbrt-v4's D(T) white points") {
    // D65 and D50 (CIE 15:2004: (0.31272, 0.32903), (0.34567, 0.35850)) at their nominal
    // temperatures, which pbrt-v4 rescales by 1.4388 / 1.4380 as the CIE does.
    Vec2f d65 = daylight_xy(6500.f), d50 = daylight_xy(5000.f);
    CHECK(d65.x == test::Approx(0.31272).epsilon(1e-3));
    CHECK(d65.y == test::Approx(0.32903).epsilon(1e-3));
    CHECK(d50.x == test::Approx(0.34567).epsilon(1e-3));
    CHECK(d50.y == test::Approx(0.35850).epsilon(1e-3));
    // Above 7000 K the second branch: D75 (0.29902, 0.31485).
    Vec2f d75 = daylight_xy(7500.f);
    CHECK(d75.x == test::Approx(0.29902).epsilon(1e-3));
    CHECK(d75.y == test::Approx(0.31485).epsilon(1e-3));
    // Below 4000 K a blackbody: the Planckian locus at 3000 K is (0.4369, 0.4041).
    Vec2f bb = daylight_xy(3000.f / (1.4388f / 1.4380f));
    CHECK(bb.x == test::Approx(0.4369).epsilon(5e-3));
    CHECK(bb.y == test::Approx(0.4041).epsilon(5e-3));
}

TEST_CASE("white_balance_srgb: identity for equal whites, maps the source white to the target") {
    std::array<float, 9> id = white_balance_srgb(kSrgbWhiteXy, kSrgbWhiteXy);
    for (int i = 0; i < 9; ++i)
        CHECK(id[size_t(i)] == test::Approx(i % 4 == 0 ? 1.f : 0.f).epsilon(1e-6));
    // The sRGB colour of the D50 white (Y = 1) goes to the sRGB colour of D65 at Y = 1: (1, 1, 1).
    Vec2f d50{0.34567f, 0.35850f};
    Rgb src = xyz_to_linear_srgb({d50.x / d50.y, 1.f, (1.f - d50.x - d50.y) / d50.y});
    std::array<float, 9> m = white_balance_srgb(d50, kSrgbWhiteXy);
    Rgb out{m[0] * src.r + m[1] * src.g + m[2] * src.b, m[3] * src.r + m[4] * src.g + m[5] * src.b,
            m[6] * src.r + m[7] * src.g + m[8] * src.b};
    CHECK(out.r == test::Approx(1.0).epsilon(2e-3));
    CHECK(out.g == test::Approx(1.0).epsilon(2e-3));
    CHECK(out.b == test::Approx(1.0).epsilon(2e-3));
    // Bradford keeps luminance of the white: Y of out equals Y of src (= 1).
    CHECK(0.2126f * out.r + 0.7152f * out.g + 0.0722f * out.b == test::Approx(1.0).epsilon(2e-3));
}
