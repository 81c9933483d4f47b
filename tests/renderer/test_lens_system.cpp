// The lens system of pbrt-v4's "realistic" camera (renderer/camera/lens_system.h) against optics
// worked out by hand: the focal length of a thick singlet (lensmaker's equation), where the
// focused rays meet, the exposure of a pupil-limited aperture, and the lens file reader.
#include <doctest/doctest.h>

#include <cmath>

#include "approx.h"
#include "renderer/camera/lens_system.h"
#include "renderer/input/scene_desc.h"
#include "test_helpers.h"

using namespace tessera;

namespace {

// A biconvex singlet (R = +-50 mm, 2 mm thick, n = 1.5, 20 mm across) with the aperture stop
// last, 1 mm behind it: the stop is then the exit pupil. Four values per element: curvature
// radius, thickness, index of refraction behind the interface, aperture diameter (mm).
const std::vector<float> kSinglet = {50, 2, 1.5f, 20, -50, 1, 1, 20, 0, 40, 0, 10};

// The singlet with a 2^14-ray exit-pupil search per film segment (scenes use 2^18): looser
// pupil bounds only mean more blocked samples, and each construction takes 30 ms, not 0.45 s.
LensSystem singlet(float aperture_diameter, float focus_distance, float diagonal = 0.035f,
                   int width = 64, int height = 64, ApertureImage aperture = {},
                   std::vector<std::string> *warnings = nullptr) {
    return LensSystem(kSinglet, aperture_diameter, focus_distance, diagonal, width, height,
                      std::move(aperture), warnings, 14);
}

// Lensmaker's equation for a thick lens: 1/f = (n - 1) (1/R1 - 1/R2 + (n - 1) d / (n R1 R2)).
double singlet_focal_length() {
    const double n = 1.5, r1 = 0.05, r2 = -0.05, d = 0.002;
    return 1.0 / ((n - 1) * (1 / r1 - 1 / r2 + (n - 1) * d / (n * r1 * r2)));
}

// Where a camera-space ray passes closest to the optical axis (the z axis).
double axis_crossing_z(Vec3f o, Vec3f d) {
    double t = -(double(o.x) * d.x + double(o.y) * d.y) / (double(d.x) * d.x + double(d.y) * d.y);
    return o.z + t * d.z;
}

}  // namespace

TEST_CASE("lens system: the thick-lens focal length of a singlet matches the lensmaker's equation") {
    LensSystem lens = singlet(4.f, 2.f);
    const double f = singlet_focal_length();  // 50.34 mm
    CHECK(lens.focal_length() == test::Approx(f).epsilon(0.002).scale(0));
    // Thin-lens estimate of the film distance for an object 2 m away: 1/f = 1/s + 1/s'.
    // The film sits a little beyond f, 1 mm behind the stop plane (rear_z is stop to film).
    const double s_image = 1.0 / (1.0 / f - 1.0 / 2.0);
    CHECK(lens.rear_z() + 0.001 + 0.001 == test::Approx(s_image).epsilon(0.03).scale(0));
}

TEST_CASE("lens system: focusing at infinity puts the film at the back focal point") {
    // The film distance grows toward its limit as the focus distance grows, and stays there
    // for huge values (pbrt's formula cancels to the lens file's own thickness near 1e20).
    double prev = 0;
    for (float focus : {1.f, 10.f, 1e3f, 1e6f, 1e12f, 1e20f, 3e38f}) {
        CAPTURE(focus);
        LensSystem lens = singlet(4.f, focus);
        CHECK(lens.rear_z() < (prev > 0 ? prev + 1e-12 : 1.0));
        prev = lens.rear_z();
    }
    LensSystem far = singlet(4.f, 1e6f), farther = singlet(4.f, 3e38f);
    CHECK(farther.rear_z() == test::Approx(far.rear_z()).epsilon(1e-6).scale(0));
    // A paraxial ray parallel to the axis from the scene lands on the axis at the film.
    // (Equivalently: rays from one film point leave parallel; checked at the centre.)
    Vec3f o, d;
    REQUIRE(farther.generate_ray({32.f, 32.f}, {0.7f, 0.5f}, &o, &d) > 0.f);
    CHECK(std::abs(d.x / d.z) < 1e-4);
    CHECK(std::abs(d.y / d.z) < 1e-4);
}

TEST_CASE("lens system: rays from the film centre meet on the axis at the focus distance") {
    // A 0.5 mm stop keeps the rays paraxial: the singlet's spherical aberration grows with
    // the ray height squared and is magnified s^2 / f^2 in object space (through a 2 mm stop
    // the marginal rays focused at 2 m cross the axis 2.3% short; through 0.5 mm, ~0.2%).
    for (float focus : {0.3f, 0.5f, 1.f, 2.f}) {
        CAPTURE(focus);
        LensSystem lens = singlet(0.5f, focus);
        int traced = 0;
        double z_min = 1e30, z_max = -1e30;
        for (int i = 0; i < 8; ++i)
            for (int j = 0; j < 8; ++j) {
                Vec3f o, d;
                float w = lens.generate_ray({32.f, 32.f}, {(i + 0.5f) / 8, (j + 0.5f) / 8}, &o, &d);
                if (w == 0.f) continue;
                // Rays along the axis itself (the pupil centre) have no crossing to measure.
                if (double(d.x) * d.x + double(d.y) * d.y < 1e-12) continue;
                ++traced;
                double z = axis_crossing_z(o, d);
                z_min = std::min(z_min, z);
                z_max = std::max(z_max, z);
            }
        REQUIRE(traced > 20);
        CHECK(z_min == test::Approx(focus).epsilon(0.01).scale(0));
        CHECK(z_max == test::Approx(focus).epsilon(0.01).scale(0));
    }
}

TEST_CASE("lens system: the centre pixel's mean weight is the stop's projected solid angle") {
    // With the stop as exit pupil at distance z from the film, pbrt's weight cos^4 / (pdf z^2)
    // integrates over the pupil to pi R^2 / (z^2 + R^2) at the film centre.
    for (float diameter : {2.f, 6.f, 10.f}) {
        CAPTURE(diameter);
        LensSystem lens = singlet(diameter, 3.f);
        const double z = lens.rear_z(), r = diameter / 2000.0;
        const double expected = M_PI * r * r / (z * z + r * r);
        const int n = 256;
        double sum = 0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                Vec3f o, d;
                sum += lens.generate_ray({32.f, 32.f}, {(i + 0.5f) / n, (j + 0.5f) / n}, &o, &d);
            }
        CHECK(sum / (n * n) == test::Approx(expected).epsilon(0.01).scale(0));
    }
}

TEST_CASE("lens system: the image is inverted onto the film; raster up-left looks up-left") {
    LensSystem lens = singlet(4.f, 5.f, 0.035f, 64, 48);
    Vec3f o, d;
    REQUIRE(lens.generate_ray({8.f, 6.f}, {0.5f, 0.5f}, &o, &d) > 0.f);
    CHECK(d.x < 0.f);  // camera +x is the image's right
    CHECK(d.y > 0.f);  // camera +y is up
    CHECK(d.z > 0.f);
    REQUIRE(lens.generate_ray({56.f, 42.f}, {0.5f, 0.5f}, &o, &d) > 0.f);
    CHECK(d.x > 0.f);
    CHECK(d.y < 0.f);
    // The film's aspect follows the resolution, its diagonal is the given one.
    Vec2f e = lens.film_extent();
    CHECK(e.x / e.y == test::Approx(64.0 / 48.0));
    CHECK(std::hypot(e.x, e.y) == test::Approx(0.035).epsilon(1e-5).scale(0));
}

TEST_CASE("lens system: an aperture wider than the stop is clamped with a warning") {
    std::vector<std::string> warnings;
    LensSystem lens = singlet(30.f, 3.f, 0.035f, 64, 64, {}, &warnings);
    REQUIRE(warnings.size() == 1);
    CHECK(warnings[0].find("clamped") != std::string::npos);
    CHECK(lens.elements().back().aperture_radius == test::Approx(0.005).epsilon(1e-5).scale(0));
}

TEST_CASE("lens system: a focus distance inside the focal length cannot be focused") {
    CHECK_THROWS_WITH_AS(singlet(4.f, 0.03f),
                         doctest::Contains("too close"), std::runtime_error);
    // A stop too small for any ray: no light passes.
    std::vector<float> shut = kSinglet;
    shut[11] = 0.f;
    CHECK_THROWS_AS(LensSystem(shut, 4.f, 3.f, 0.035f, 64, 64), std::runtime_error);
    // More elements than any lens has: refused before the exit-pupil search.
    std::vector<float> many;
    for (int i = 0; i < 65; ++i) many.insert(many.end(), {100, 1, 1, 20});
    CHECK_THROWS_WITH_AS(LensSystem(many, 4.f, 3.f, 0.035f, 64, 64),
                         doctest::Contains("at most 64"), std::runtime_error);
}

TEST_CASE("aperture images: pbrt's built-in shapes pass as much light as the round stop") {
    for (const char *name : {"gaussian", "square", "pentagon", "star"}) {
        CAPTURE(name);
        ApertureImage img = ApertureImage::builtin(name);
        REQUIRE(!img.empty());
        const int n = 512;
        double sum = 0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) sum += img.bilerp((i + 0.5) / n, (j + 0.5) / n);
        CHECK(sum / (n * n) == test::Approx(M_PI / 4).epsilon(0.01).scale(0));
        CHECK(img.bilerp(0.01, 0.01) == 0.f);  // the corners are closed
        CHECK(img.bilerp(1.5, 0.5) == 0.f);    // black outside
    }
    CHECK(ApertureImage::builtin("hexagon").empty());
    // pbrt rasterises the pentagon with its point at +y, then flips the image: the point ends
    // at small v (lens-space -y), the flat edge at v = 0.82.
    ApertureImage p = ApertureImage::builtin("pentagon");
    CHECK(p.bilerp(0.5, 0.15) > 0.f);
    CHECK(p.bilerp(0.2, 0.15) == 0.f);
    CHECK(p.bilerp(0.5, 0.80) > 0.f);
    CHECK(p.bilerp(0.5, 0.85) == 0.f);
}

TEST_CASE("lens files: numbers, comments, and errors with the file's line") {
    auto dir = test::temp_dir("lens_files", true);
    auto path = test::write_text(dir / "ok.dat",
                                 "# radius sep n aperture\n29.475 3.76 1.67 25.2  # front\n"
                                 "0\t4.5\t0\t17.1\n\n-39.73 5 1 20\n");
    std::vector<float> v = read_lens_file(path);
    REQUIRE(v.size() == 12);
    CHECK(v[0] == test::Approx(29.475));
    CHECK(v[7] == test::Approx(17.1));
    CHECK(v[11] == test::Approx(20));

    // Text that is not a number is skipped with a warning, as pbrt-v4's ReadFloatFile does
    // (an uncommented header line still loads).
    auto header = test::write_text(dir / "header.dat",
                                   "radius thickness n aperture\n50 2 1.5 20\n-50 1 1 20\n");
    v = read_lens_file(header);
    CHECK(v.size() == 8);
    CHECK(last_warning().find("header.dat:1: warning: lens file: unexpected text \"radius") !=
          std::string::npos);
    auto bad = test::write_text(dir / "bad.dat", "1 2 3 4\n5 six 7 8\n");
    CHECK_THROWS_WITH_AS(read_lens_file(bad), doctest::Contains("bad.dat:2: lens file: 7 values"),
                         SceneError);
    // A number pbrt's reader would take apart, or one out of range, is an error on its line.
    auto dashed = test::write_text(dir / "dashed.dat", "1 2 3 4\n5 6-7 8 9\n");
    CHECK_THROWS_WITH_AS(read_lens_file(dashed),
                         doctest::Contains("dashed.dat:2: lens file: \"6-7\" is not a finite"),
                         SceneError);
    auto huge = test::write_text(dir / "huge.dat", "1 2 3 1e999\n");
    CHECK_THROWS_WITH_AS(read_lens_file(huge), doctest::Contains("huge.dat:1:"), SceneError);
    auto odd = test::write_text(dir / "odd.dat", "1 2 3 4\n5 6\n");
    CHECK_THROWS_WITH_AS(read_lens_file(odd), doctest::Contains("not a multiple of four"),
                         SceneError);
    auto empty = test::write_text(dir / "empty.dat", "# nothing here\n");
    CHECK_THROWS_WITH_AS(read_lens_file(empty), doctest::Contains("no values"), SceneError);
    CHECK_THROWS_WITH_AS(read_lens_file((dir / "missing.dat").string()),
                         doctest::Contains("not found"), SceneError);
    CHECK_THROWS_WITH_AS(read_lens_file(dir.string()), doctest::Contains("not a regular file"),
                         SceneError);
}

TEST_CASE("lens system: an aperture image passes the round stop's light at every film angle") {
    // pbrt-v4 normalises aperture images to the round stop's transmission. Its exit-pupil
    // bounds, found on the film's x axis and rotated, would cut off a square stop's corners
    // at 45 degrees; Tessera bounds the circle around the image instead (lens_system.cpp).
    LensSystem round = singlet(6.f, 5.f, 0.02f, 16, 16);
    for (const char *name : {"square", "pentagon", "gaussian"}) {
        CAPTURE(name);
        LensSystem shaped = singlet(6.f, 5.f, 0.02f, 16, 16, ApertureImage::builtin(name));
        for (Vec2f film : {Vec2f{8.f, 8.f}, Vec2f{12.f, 8.f}, Vec2f{12.f, 12.f}, Vec2f{3.f, 13.f}}) {
            CAPTURE(film.x);
            CAPTURE(film.y);
            const int n = 384;
            double a = 0, b = 0;
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    Vec3f o, d;
                    Vec2f u{(i + 0.5f) / n, (j + 0.5f) / n};
                    a += round.generate_ray(film, u, &o, &d);
                    b += shaped.generate_ray(film, u, &o, &d);
                }
            CHECK(b == test::Approx(a).epsilon(0.01).scale(0));
        }
    }
}
