// Numerical stress tests (issue "Hardening"): the same picture at any scale, no shadow acne or
// light leaks on grazing, coplanar, thin, sliver and far-from-origin geometry, and extreme
// radiance ratios, each measured against an analytic answer or the unscaled/unshifted scene.
//
// Most scenes here are lit by one distant (delta) light and rendered at maxdepth 1 with a box
// filter: every camera sample that hits the diffuse plane then has exactly the radiance
// rho / pi * L * cos(theta_light), whatever the random numbers, so a single dark or bright pixel
// is acne or a leak, not noise.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "approx.h"
#include "render_test_util.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

SceneOverrides settings(int w, int h, int spp) {
    SceneOverrides ov;
    ov.width = w;
    ov.height = h;
    ov.spp = spp;
    ov.seed = 7;
    return ov;
}

std::string num(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

std::string vec(double x, double y, double z) { return num(x) + " " + num(y) + " " + num(z); }

/// A quad in the plane y = `y` spanning [x0, x1] x [z0, z1], facing +y.
std::string quad_y(double y, double x0, double x1, double z0, double z1) {
    return "Shape \"trianglemesh\" \"point3 P\" [ " + vec(x0, y, z0) + "  " + vec(x1, y, z0) +
           "  " + vec(x1, y, z1) + "  " + vec(x0, y, z1) +
           " ] \"integer indices\" [ 0 2 1  0 3 2 ]\n";
}

/// Camera, box filter, maxdepth 1 and a distant light of radiance 1 arriving at `elevation_deg`
/// above the y = 0 plane (from +x); WorldBegin included. Grey diffuse material rho = 0.5.
std::string lit_plane_head(Vec3f eye, Vec3f look, double fov, double elevation_deg,
                           Vec3f up = {0, 1, 0}) {
    double e = elevation_deg * kPi / 180.0;
    return "LookAt " + vec(eye.x, eye.y, eye.z) + "  " + vec(look.x, look.y, look.z) + "  " +
           vec(up.x, up.y, up.z) + "\nCamera \"perspective\" \"float fov\" [ " + num(fov) +
           " ]\nPixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" [ 1 ]\n"
           "WorldBegin\nLightSource \"distant\" \"point3 from\" [ " +
           vec(std::cos(e), std::sin(e), 0) + " ] \"point3 to\" [ 0 0 0 ] \"rgb L\" [ 1 1 1 ]\n"
           "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]\n";
}

/// Radiance of the plane under the lit_plane_head light: rho / pi * L * sin(elevation).
double lit_plane_value(double elevation_deg) {
    return 0.5 / kPi * std::sin(elevation_deg * kPi / 180.0);
}

struct PixelCounts {
    size_t exact = 0, black = 0, other = 0;
    double worst = 0;  ///< largest relative deviation among the "other" pixels
};

/// Classifies every pixel (green channel) as the analytic value (relative 1e-4), black, or
/// anything else (acne, a leak, a seam).
PixelCounts classify(const sampling::RgbImage &img, double value) {
    PixelCounts c;
    for (size_t i = 0; i < img.pixel_count(); ++i) {
        double v = img.data[3 * i + 1];
        if (std::abs(v - value) <= 1e-4 * value) {
            ++c.exact;
        } else if (v == 0.0) {
            ++c.black;
        } else {
            ++c.other;
            c.worst = std::max(c.worst, std::abs(v - value) / value);
        }
    }
    return c;
}

sampling::RgbImage render_checked(const std::string &text, const SceneOverrides &ov,
                                  sched::AdaptiveStats *stats_out = nullptr) {
    std::unique_ptr<Scene> sc = scene_from_string(text, ov);
    sched::AdaptiveStats st;
    sampling::RgbImage img = render_image(*sc, 2, &st);
    CHECK(st.nan_samples == 0);
    for (float v : img.data) REQUIRE(std::isfinite(v));
    if (stats_out) *stats_out = st;
    return img;
}

std::string read_file(const std::string &path) {
    std::ifstream in(path);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

/// The Cornell box example with the whole world (camera and lights included) scaled by s: the
/// camera transform gets Scale(1/s) after its LookAt, the world Scale(s) after WorldBegin.
std::string scaled_cornell(double s) {
    std::string text = read_file(std::string(TESSERA_SOURCE_DIR) + "/examples/cornell-box/scene.pbrt");
    REQUIRE(!text.empty());
    size_t look = text.find("LookAt");
    size_t eol = text.find('\n', look);
    text.insert(eol + 1, "Scale " + vec(1 / s, 1 / s, 1 / s) + "\n");
    size_t world = text.find("WorldBegin");
    eol = text.find('\n', world);
    text.insert(eol + 1, "Scale " + vec(s, s, s) + "\n");
    return text;
}

}  // namespace

TEST_CASE("stress: the Cornell box scaled by 1e-4 .. 1e5 renders the same picture (PSNR >= 40 dB)") {
    // Same seed and samples: the paths are the same up to the scale, so only the ray-offset
    // arithmetic differs. The glass and copper spheres make many of the paths specular chains,
    // where a different offset would send a path elsewhere.
    const SceneOverrides ov = settings(64, 64, 16);
    sampling::RgbImage ref = render_checked(scaled_cornell(1.0), ov);
    REQUIRE(image_mean(ref, 1) > 0.05);
    for (double s : {1e-4, 1e-2, 1e2, 1e5}) {
        CAPTURE(s);
        sampling::RgbImage img = render_checked(scaled_cornell(s), ov);
        sampling::ImageComparison c = sampling::compare_images(img, ref, 1.0);
        MESSAGE("scale " << s << ": PSNR " << c.psnr.total << " dB, mean " << image_mean(img, 1)
                         << " vs " << image_mean(ref, 1));
        CHECK(c.psnr.total >= 40.0);
        CHECK(image_mean(img, 1) == test::Approx(image_mean(ref, 1)).epsilon(0.002));
    }
}

TEST_CASE("stress: grazing light and grazing view on a plane: no shadow acne") {
    SUBCASE("light 0.5 degrees above the plane, camera at 45 degrees") {
        for (double elevation : {0.5, 0.05}) {
            CAPTURE(elevation);
            std::string text = lit_plane_head({0, 2, -2}, {0, 0, 0}, 40, elevation) +
                               quad_y(0, -100, 100, -100, 100);
            PixelCounts c = classify(render_checked(text, settings(48, 48, 4)),
                                     lit_plane_value(elevation));
            CHECK(c.exact == 48u * 48u);
            CHECK_MESSAGE(c.other + c.black == 0, c.black << " black and " << c.other
                                                          << " wrong pixels (worst " << c.worst
                                                          << ")");
        }
    }
    SUBCASE("camera 1 unit above a plane 10^4 across, looking at the horizon") {
        // Rows below the horizon hit the plane at grazing angles down to ~0.006 degrees; every
        // pixel (1 sample) is either the plane's exact value or black sky.
        std::string text = lit_plane_head({0, 1, 0}, {0, 1, 1000}, 20, 90) +
                           quad_y(0, -1e4, 1e4, -1e4, 1e4);
        PixelCounts c = classify(render_checked(text, settings(64, 64, 1)),
                                 lit_plane_value(90));
        CHECK(c.other == 0);
        CHECK(c.exact > 64u * 20u);
        CHECK(c.black > 64u * 20u);
    }
}

TEST_CASE("stress: coplanar and nearly coplanar triangles: no acne") {
    // Two quads in the same plane (coincident triangles) and a third 1e-5 above part of them,
    // all the same material: every pixel sees a lit plane, whichever quad it hits. A shadow ray
    // leaving one quad must not hit its coplanar twin or the sheet just above.
    for (double gap : {0.0, 1e-5, 1e-3}) {
        CAPTURE(gap);
        std::string text = lit_plane_head({0, 2, -2}, {0, 0, 0}, 40, 60) +
                           quad_y(0, -10, 10, -10, 10) + quad_y(0, -10, 10, -10, 10) +
                           quad_y(gap, -10, 0.3, -10, 10);
        PixelCounts c = classify(render_checked(text, settings(48, 48, 4)), lit_plane_value(60));
        CHECK_MESSAGE(c.exact == 48u * 48u, c.black << " black and " << c.other
                                                   << " wrong pixels (worst " << c.worst << ")");
    }
}

TEST_CASE("stress: thin sheets: no light leaks through, no acne on top") {
    // A closed slab 1e-4 thick under a light from straight above: its top is exactly lit, its
    // bottom (seen from below) exactly black at any path depth.
    auto slab = [](double t) {
        const std::string pts = "[ -5 0 -5  5 0 -5  5 0 5  -5 0 5  -5 T -5  5 T -5  5 T 5  -5 T 5 ]";
        std::string p = pts;
        for (size_t i; (i = p.find('T')) != std::string::npos;) p.replace(i, 1, num(t));
        return "Shape \"trianglemesh\" \"point3 P\" " + p +
               " \"integer indices\" [ 0 1 2  0 2 3  4 6 5  4 7 6  0 5 1  0 4 5  1 6 2  1 5 6"
               "  2 7 3  2 6 7  3 4 0  3 7 4 ]\n";
    };
    for (double t : {1e-4, 1e-6}) {
        CAPTURE(t);
        std::string top = lit_plane_head({0, 2, -2}, {0, 0, 0}, 40, 90) + slab(t);
        PixelCounts c = classify(render_checked(top, settings(32, 32, 4)), lit_plane_value(90));
        CHECK(c.exact == 32u * 32u);
        // From below, with paths long enough to bounce around the slab's edges.
        std::string below = lit_plane_head({0, -2, -2}, {0, 0, 0}, 40, 90);
        below.replace(below.find("\"integer maxdepth\" [ 1 ]"), 24, "\"integer maxdepth\" [ 8 ]");
        below += slab(t);
        sampling::RgbImage img = render_checked(below, settings(32, 32, 8));
        double mx = 0;
        for (float v : img.data) mx = std::max(mx, double(v));
        CHECK_MESSAGE(mx == 0.0, "light leaked through a slab " << t << " thick: max " << mx);
    }
}

TEST_CASE("stress: long thin triangles tile a plane without cracks") {
    // A 20 x 20 plane cut into 400 slivers 1000 units long and 0.05 wide (aspect 2e4), and
    // nothing behind it: a ray slipping between two slivers would see black, as would a shadow
    // ray stopped by a neighbouring sliver.
    std::string mesh = "Shape \"trianglemesh\" \"point3 P\" [";
    std::string idx = " ] \"integer indices\" [";
    const int n = 400;
    for (int i = 0; i <= n; ++i) {
        double x = -10 + 20.0 * i / n;
        mesh += ' ';
        mesh += vec(x, 0, -500);
        mesh += "  ";
        mesh += vec(x, 0, 500);
    }
    for (int i = 0; i < n; ++i) {
        const int a = 2 * i, b = 2 * i + 1, c = 2 * i + 2, d = 2 * i + 3;
        for (int v : {a, b, d, a, d, c}) {
            idx += ' ';
            idx += std::to_string(v);
        }
    }
    std::string text = lit_plane_head({0, 3, -3}, {0, 0, 0}, 40, 75) + mesh + idx + " ]\n";
    PixelCounts c = classify(render_checked(text, settings(48, 48, 4)), lit_plane_value(75));
    CHECK_MESSAGE(c.exact == 48u * 48u, c.black << " black and " << c.other
                                               << " wrong pixels (worst " << c.worst << ")");
}

TEST_CASE("stress: geometry 1e6 units from the origin renders like the unshifted scene") {
    // Float spacing at 1e6 is 0.0625: the camera and vertices move by up to that, which the
    // analytic value does not depend on; shadow acne would (offsets must scale with the
    // coordinates, not with the scene size).
    const double value = lit_plane_value(30);
    double mean0 = 0;
    size_t bad0 = 0;
    for (double shift : {0.0, 1e6}) {
        CAPTURE(shift);
        std::string text =
            lit_plane_head({float(shift), float(shift + 40), float(shift - 40)},
                           {float(shift), float(shift), float(shift)}, 40, 30) +
            quad_y(shift, shift - 500, shift + 500, shift - 500, shift + 500) +
            // A box standing on the plane: its shadow and its lit faces near the floor are where
            // acne and leaks at the contact edge would show.
            "AttributeBegin\n  Translate " + vec(shift, shift, shift) +
            "\n  Shape \"trianglemesh\" \"point3 P\" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5  -5 10 -5  "
            "5 10 -5  5 10 5  -5 10 5 ] \"integer indices\" [ 4 6 5  4 7 6  0 5 1  0 4 5  1 6 2 "
            " 1 5 6  2 7 3  2 6 7  3 4 0  3 7 4 ]\nAttributeEnd\n";
        std::unique_ptr<Scene> sc = scene_from_string(text, settings(48, 48, 4));
        sched::AdaptiveStats st;
        sampling::RgbImage img = render_image(*sc, 2, &st);
        CHECK(st.nan_samples == 0);
        // Every pixel is the lit floor, the shadowed floor (black), the lit box top
        // (= the floor's value: both face +y) or a box side: lit sides face -x/+x/-z/+z.
        size_t bad = 0;
        const double side = 0.5 / kPi * std::cos(30 * kPi / 180);  // the +x face
        for (size_t i = 0; i < img.pixel_count(); ++i) {
            double v = img.data[3 * i + 1];
            bool ok = std::abs(v - value) <= 1e-4 * value || v == 0.0 ||
                      std::abs(v - side) <= 1e-4 * side;
            // Pixels on an edge mix two of those values.
            bad += ok ? 0 : 1;
        }
        MESSAGE("shift " << shift << ": " << bad << " pixels on edges or wrong");
        CHECK(bad < img.pixel_count() / 10);
        if (shift == 0.0) {
            mean0 = image_mean(img, 1);
            bad0 = bad;
        } else {
            // The edges move by the float spacing (0.0625 of 10 units); acne would add many.
            CHECK(bad <= bad0 + img.pixel_count() / 100);
            CHECK(image_mean(img, 1) == test::Approx(mean0).epsilon(0.01));
        }
    }
}

TEST_CASE("stress: a tiny light 1e6 times brighter than the sky") {
    // Constant sky L = 1 and a sphere light of radius 1e-3 and radiance 1e6 (intensity
    // L * pi r^2 = pi) 0.1 above a diffuse plane (rho 0.5), out of the camera's view.
    // Direct light only: Lo(x) = rho * (1 + h / d^3) at distance d from the light, h = 0.1.
    std::string text = "LookAt 0 1 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" [ 30 ]\n"
                       "PixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" [ 1 ]\n"
                       "WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
                       "AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 1e6 1e6 1e6 ]\n"
                       "  Translate 0.5 0.1 0\n  Shape \"sphere\" \"float radius\" [ 0.001 ]\n"
                       "AttributeEnd\nMaterial \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]\n" +
                       quad_y(0, -100, 100, -100, 100);
    const int res = 32;
    std::unique_ptr<Scene> sc = scene_from_string(text, settings(res, res, 64));
    sched::AdaptiveStats st;
    sampling::RgbImage img = render_image(*sc, 2, &st);
    CHECK(st.nan_samples == 0);
    // The analytic image: average Lo over 8x8 positions in each pixel (box filter).
    double err_sum = 0, worst = 0, ref_sum = 0;
    for (int y = 0; y < res; ++y)
        for (int x = 0; x < res; ++x) {
            double expect = 0;
            for (int j = 0; j < 8; ++j)
                for (int i = 0; i < 8; ++i) {
                    Ray r = sc->camera->generate_ray({x + (i + 0.5f) / 8, y + (j + 0.5f) / 8},
                                                     {0.5f, 0.5f}, false)
                                .ray;
                    REQUIRE(r.d.y < 0);
                    double t = -r.o.y / r.d.y;
                    double px = r.o.x + t * r.d.x, pz = r.o.z + t * r.d.z;
                    double d2 = (px - 0.5) * (px - 0.5) + 0.01 + pz * pz;
                    expect += 0.5 * (1 + 0.1 / (d2 * std::sqrt(d2))) / 64;
                }
            double v = img.at(uint32_t(x), uint32_t(y), 1);
            err_sum += std::abs(v - expect);
            ref_sum += expect;
            worst = std::max(worst, std::abs(v - expect) / expect);
        }
    MESSAGE("relative mean abs error " << err_sum / ref_sum << ", worst pixel " << worst);
    CHECK(err_sum / ref_sum < 0.02);
    CHECK(worst < 0.1);
}

namespace {

/// A sky, a point light and a floor; `objects` adds shapes. 32x32, maxdepth 8.
std::string material_scene(const std::string &objects) {
    return "LookAt 0 1.5 -5  0 0.5 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 45 ]\n"
           "Integrator \"path\" \"integer maxdepth\" [ 8 ]\nWorldBegin\n"
           "LightSource \"infinite\" \"rgb L\" [ 0.3 0.3 0.3 ]\n"
           "LightSource \"point\" \"point3 from\" [ 1 3 -1 ] \"rgb I\" [ 10 10 10 ]\n"
           "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]\n" +
           quad_y(0, -10, 10, -10, 10) + objects;
}

/// A sphere of radius 0.4 at (x, 0.5, z) with the given material line.
std::string sphere_at(double x, double z, const std::string &material) {
    return "AttributeBegin\n  " + material + "\n  Translate " + vec(x, 0.5, z) +
           "\n  Shape \"sphere\" \"float radius\" [ 0.4 ]\nAttributeEnd\n";
}

}  // namespace

TEST_CASE("stress: degenerate materials render finite values, never NaN") {
    const char *materials[] = {
        "Material \"diffuse\" \"rgb reflectance\" [ 0 0 0 ]",
        "Material \"conductor\" \"float roughness\" [ 0 ]",
        "Material \"conductor\" \"float roughness\" [ 1 ]",
        "Material \"conductor\" \"float uroughness\" [ 0 ] \"float vroughness\" [ 1 ]",
        "Material \"conductor\" \"rgb reflectance\" [ 0 0 0 ] \"float roughness\" [ 0.3 ]",
        "Material \"conductor\" \"float roughness\" [ 1e-8 ] \"bool remaproughness\" false",
        "Material \"dielectric\" \"float eta\" [ 1 ]",
        "Material \"dielectric\" \"float eta\" [ 1 ] \"float roughness\" [ 0.5 ]",
        "Material \"dielectric\" \"float eta\" [ 1.5 ] \"float roughness\" [ 1 ]",
        "Material \"dielectric\" \"float eta\" [ 1.0001 ] \"float roughness\" [ 1e-7 ]",
        "Material \"dielectric\" \"float eta\" [ 100 ]",
        "Material \"dielectric\" \"float eta\" [ 0.01 ]",
        "Material \"coateddiffuse\" \"float roughness\" [ 0 ]",
        "Material \"coateddiffuse\" \"float roughness\" [ 1 ] \"rgb reflectance\" [ 0 0 0 ]",
        "Material \"coateddiffuse\" \"float roughness\" [ 0.2 ] \"rgb reflectance\" [ 1 1 1 ]",
    };
    for (const char *m : materials) {
        CAPTURE(m);
        std::string objects;
        // The same material on a sphere, on a quad seen edge-on and on a quad facing the camera.
        objects += sphere_at(0, 0, m);
        objects += "AttributeBegin\n  " + std::string(m) + "\n" + quad_y(1.2, -0.5, 0.5, -0.5, 0.5) +
                   "AttributeEnd\n";
        sched::AdaptiveStats st;
        sampling::RgbImage img = render_checked(material_scene(objects), settings(24, 24, 8), &st);
        CHECK(st.samples == 24u * 24u * 8u);
    }
}

TEST_CASE("stress: a glass sphere of IOR 1 is invisible") {
    // eta = 1: no refraction and no Fresnel reflection (pbrt-v4 treats it as index-matched),
    // so the picture equals the one without the sphere, up to noise.
    sampling::RgbImage with = render_checked(
        material_scene(sphere_at(0, 0, "Material \"dielectric\" \"float eta\" [ 1 ]")),
        settings(32, 32, 64));
    sampling::RgbImage without = render_checked(material_scene(""), settings(32, 32, 64));
    for (int c = 0; c < 3; ++c)
        CHECK(image_mean(with, c) == test::Approx(image_mean(without, c)).epsilon(0.02));
    // Pixel by pixel too (noise of 64 spp with a point light and a sky: a few percent).
    sampling::ImageComparison cmp = sampling::compare_images(with, without, 1.0);
    CHECK(cmp.psnr.total > 30.0);
}

TEST_CASE("stress: degenerate lights render or are rejected with file:line") {
    SUBCASE("zero-power lights and a zero scale: black contributions, no NaN") {
        std::string objects =
            "LightSource \"point\" \"point3 from\" [ 0 2 0 ] \"rgb I\" [ 0 0 0 ]\n"
            "LightSource \"spot\" \"point3 from\" [ 0 2 0 ] \"point3 to\" [ 0 0 0 ] "
            "\"rgb I\" [ 5 5 5 ] \"float scale\" [ 0 ]\n"
            "AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 0 0 0 ]\n" +
            sphere_at(1, 0, "") + "AttributeEnd\n";
        render_checked(material_scene(objects), settings(16, 16, 8));
    }
    SUBCASE("a tiny but positive light radius renders") {
        std::string objects = "AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 1e20 1e20 1e20 ]\n"
                              "  Translate 0 1 0\n  Shape \"sphere\" \"float radius\" [ 1e-9 ]\n"
                              "AttributeEnd\n";
        render_checked(material_scene(objects), settings(16, 16, 8));
    }
    SUBCASE("a light of radius 0 is rejected") {
        std::string objects = "AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
                              "  Shape \"disk\" \"float radius\" [ 0 ]\nAttributeEnd\n";
        CHECK_THROWS_WITH_AS(scene_from_string(material_scene(objects), settings(8, 8, 1)),
                             doctest::Contains("radius must be positive"), SceneError);
    }
}
