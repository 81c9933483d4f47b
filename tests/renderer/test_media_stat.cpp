// Participating media against analytic answers (renderer/media/medium.h, renderer/integrators/
// volpath_integrator.h): Beer-Lambert through an absorbing slab, white furnaces of albedo-1
// media, delta and ratio tracking against the analytic and the quadrature transmittance, the
// majorant bound, chromatic media with a channel of zero extinction. Fixed seeds; each
// tolerance is checked to stand above the estimate's own noise, so that the tests can fail.
#include <doctest/doctest.h>

#include <cmath>
#include <sstream>

#include "render_test_util.h"
#include "renderer/integrators/volpath_integrator.h"
#include "renderer/media/medium.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;

namespace {

/// A closed box [lo, hi] as a triangle mesh with outward normals (pbrt-v4 orientation).
std::string box_mesh(Vec3f lo, Vec3f hi) {
    std::ostringstream os;
    os << "Shape \"trianglemesh\" \"point3 P\" [ ";
    const float x[2] = {lo.x, hi.x}, y[2] = {lo.y, hi.y}, z[2] = {lo.z, hi.z};
    for (int k = 0; k < 8; ++k) os << x[k & 1] << ' ' << y[(k >> 1) & 1] << ' ' << z[k >> 2] << ' ';
    // Vertex k = (x[k&1], y[k>>1&1], z[k>>2]); each face counter-clockwise seen from outside.
    os << "] \"integer indices\" [ 0 2 3 0 3 1  4 5 7 4 7 6  0 1 5 0 5 4  2 6 7 2 7 3 "
          " 0 4 6 0 6 2  1 3 7 1 7 5 ]\n";
    return os.str();
}

const char *kHeader =
    "LookAt 0 0 -5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 30 ]\n"
    "Film \"rgb\" \"integer xresolution\" [ 8 ] \"integer yresolution\" [ 8 ]\n"
    "Integrator \"volpath\" \"integer maxdepth\" [ 1000 ]\nWorldBegin\n"
    "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n";

/// Mean and standard error of the radiance along `ray` over n samples, the hero channel
/// cycling (each channel the hero for a third of the samples, as the uniform choice averages).
struct Estimate {
    Rgb mean, stderr_;
};
Estimate estimate(const VolPathIntegrator &integ, const Ray &ray, int medium, int n) {
    double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i) {
        Rgb L = integ.radiance(ray, medium, i % 3, uint32_t(i % 61), uint32_t(i / 61 % 53),
                               uint32_t(i));
        for (int c = 0; c < 3; ++c) {
            s[c] += L[c];
            s2[c] += double(L[c]) * L[c];
        }
    }
    Estimate e;
    for (int c = 0; c < 3; ++c) {
        double m = s[c] / n;
        e.mean[c] = float(m);
        e.stderr_[c] = float(std::sqrt(std::max(0.0, s2[c] / n - m * m) / n));
    }
    return e;
}

}  // namespace

TEST_CASE("Beer-Lambert: an absorbing slab transmits exp(-sigma_a d) per channel within 0.5%") {
    // A slab 1.5 thick (z in [0, 1.5]) of chromatic absorption, wide enough to be infinite for
    // the axial ray; the uniform environment behind it is the only light.
    const Rgb sigma_a(0.4f, 1.0f, 1.6f);
    std::ostringstream os;
    os << kHeader << "MakeNamedMedium \"ink\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [ "
       << sigma_a.r << ' ' << sigma_a.g << ' ' << sigma_a.b << " ] \"rgb sigma_s\" [ 0 0 0 ]\n"
       << "AttributeBegin\nMediumInterface \"ink\" \"\"\nMaterial \"interface\"\n"
       << box_mesh({-1000, -1000, 0}, {1000, 1000, 1.5f}) << "AttributeEnd\n";
    auto scene = scene_from_string(os.str());
    REQUIRE(scene->features.media);
    VolPathIntegrator integ(*scene, 3, 1000);
    Estimate e = estimate(integ, Ray{{0, 0, -3}, {0, 0, 1}, kInfinity}, -1, 2000000);
    for (int c = 0; c < 3; ++c) {
        const double expected = std::exp(-1.5 * sigma_a[c]);
        CAPTURE(c);
        CAPTURE(e.mean[c]);
        CAPTURE(expected);
        CHECK(4 * e.stderr_[c] < 0.005 * expected);  // the check below can fail
        CHECK(std::abs(e.mean[c] - expected) < 0.005 * expected);
    }
}

TEST_CASE("white furnace: a sphere of albedo-1 medium under a uniform sky stays at 1") {
    // Scattering only, optical radius 2: rays through the sphere scatter many times; with
    // nothing absorbed every ray must still bring back exactly the sky's radiance 1.
    for (float g : {-0.7f, 0.f, 0.9f}) {
        CAPTURE(g);
        std::ostringstream os;
        os << kHeader << "MakeNamedMedium \"m\" \"string type\" \"homogeneous\" "
           << "\"rgb sigma_a\" [ 0 0 0 ] \"rgb sigma_s\" [ 2 2 2 ] \"float g\" [ " << g << " ]\n"
           << "AttributeBegin\nMediumInterface \"m\" \"\"\nMaterial \"interface\"\n"
           << "Shape \"sphere\" \"float radius\" [ 1 ]\nAttributeEnd\n";
        auto scene = scene_from_string(os.str());
        VolPathIntegrator integ(*scene, 5, 1000);
        // Through the centre and off-centre.
        for (float y : {0.f, 0.6f}) {
            Estimate e = estimate(integ, Ray{{0, y, -3}, {0, 0, 1}, kInfinity}, -1, 60000);
            for (int c = 0; c < 3; ++c) {
                CAPTURE(y);
                CAPTURE(e.mean[c]);
                CHECK(4 * e.stderr_[c] < 0.01);
                CHECK(std::abs(e.mean[c] - 1.f) < 0.01f);
            }
        }
    }
}

TEST_CASE("chromatic furnace: a channel with zero extinction stays unbiased and finite") {
    // sigma_s (1.5, 0, 4): green sees no medium at all, blue a dense one; the spectral MIS must
    // give 1 in every channel with no NaN or infinity, whichever channel is the hero.
    std::ostringstream os;
    os << kHeader << "MakeNamedMedium \"m\" \"string type\" \"homogeneous\" "
       << "\"rgb sigma_a\" [ 0 0 0 ] \"rgb sigma_s\" [ 1.5 0 4 ] \"float g\" [ 0.3 ]\n"
       << "AttributeBegin\nMediumInterface \"m\" \"\"\nMaterial \"interface\"\n"
       << "Shape \"sphere\" \"float radius\" [ 1 ]\nAttributeEnd\n";
    auto scene = scene_from_string(os.str());
    VolPathIntegrator integ(*scene, 9, 1000);
    for (int hero = 0; hero < 3; ++hero) {
        for (int i = 0; i < 3000; ++i) {
            Rgb L = integ.radiance(Ray{{0, 0.3f, -3}, {0, 0, 1}, kInfinity}, -1, hero, 1, 2,
                                   uint32_t(i));
            REQUIRE(L.is_finite());
        }
    }
    Estimate e = estimate(integ, Ray{{0, 0.3f, -3}, {0, 0, 1}, kInfinity}, -1, 400000);
    for (int c = 0; c < 3; ++c) {
        CAPTURE(c);
        CAPTURE(e.mean[c]);
        CHECK(4 * e.stderr_[c] < 0.01);
        CHECK(std::abs(e.mean[c] - 1.f) < 0.01f);
    }
}

namespace {

/// Transmittance along `ray` (unit d) to t_max by delta tracking (1 or 0 per walk) and by
/// ratio tracking (the product of null-collision probabilities), in channel 0.
void tracking_estimates(const Medium &m, const Ray &ray, float t_max, int n, double *delta,
                        double *ratio) {
    double sd = 0, sr = 0;
    for (int i = 0; i < n; ++i) {
        Pcg32 rng(uint64_t(i), 77);
        float u = rng.uniform();
        bool absorbed = false;
        sample_t_maj(m, ray, t_max, u, rng, 0,
                     [&](Vec3f, const MediumProperties &mp, Rgb sigma_maj, Rgb) {
                         const float st = mp.sigma_a[0] + mp.sigma_s[0];
                         if (rng.uniform() < st / sigma_maj[0]) {
                             absorbed = true;
                             return false;
                         }
                         return true;
                     });
        sd += absorbed ? 0 : 1;
        Pcg32 rng2(uint64_t(i), 78);
        double T = 1;
        sample_t_maj(m, ray, t_max, rng2.uniform(), rng2, 0,
                     [&](Vec3f, const MediumProperties &mp, Rgb sigma_maj, Rgb) {
                         T *= 1.0 - (mp.sigma_a[0] + mp.sigma_s[0]) / sigma_maj[0];
                         return true;
                     });
        sr += T;
    }
    *delta = sd / n;
    *ratio = sr / n;
}

/// exp(-integral of sigma_t) along the ray by the midpoint rule.
double quadrature_transmittance(const Medium &m, const Ray &ray, float t_max, int steps) {
    double tau = 0, dt = double(t_max) / steps;
    for (int k = 0; k < steps; ++k) {
        MediumProperties mp = m.sample_point(ray.o + ray.d * float((k + 0.5) * dt));
        tau += (mp.sigma_a[0] + mp.sigma_s[0]) * dt;
    }
    return std::exp(-tau);
}

MediumDesc grid_desc() {
    // A 6x5x4 density grid with a dense corner and an empty half, in a rotated, scaled box.
    MediumDesc d;
    d.name = "grid";
    d.type = "uniformgrid";
    d.loc = FileLoc{"test.pbrt", 1};
    std::vector<double> density;
    for (int z = 0; z < 4; ++z)
        for (int y = 0; y < 5; ++y)
            for (int x = 0; x < 6; ++x) density.push_back(x < 3 ? 0.0 : 0.5 * (x - 2) * (1 + y));
    d.params.params.push_back(Param::numeric("float", "density", density, d.loc));
    d.params.params.push_back(Param::numeric("integer", "nx", {6}, d.loc));
    d.params.params.push_back(Param::numeric("integer", "ny", {5}, d.loc));
    d.params.params.push_back(Param::numeric("integer", "nz", {4}, d.loc));
    d.params.params.push_back(Param::numeric("rgb", "sigma_a", {0.1, 0.1, 0.1}, d.loc));
    d.params.params.push_back(Param::numeric("rgb", "sigma_s", {0.3, 0.3, 0.3}, d.loc));
    d.params.params.push_back(Param::numeric("point3", "p0", {-1, -1, -1}, d.loc));
    d.params.params.push_back(Param::numeric("point3", "p1", {1, 1.5, 1}, d.loc));
    d.render_from_medium = Transform::rotate(30, {0, 1, 0}) * Transform::scale(1.5, 1, 1);
    return d;
}

}  // namespace

TEST_CASE("delta and ratio tracking agree with each other and the analytic transmittance") {
    SUBCASE("homogeneous: exp(-sigma_t d)") {
        MediumDesc d;
        d.name = "h";
        d.type = "homogeneous";
        d.loc = FileLoc{"test.pbrt", 1};
        d.params.params.push_back(Param::numeric("rgb", "sigma_a", {0.2, 0.2, 0.2}, d.loc));
        d.params.params.push_back(Param::numeric("rgb", "sigma_s", {0.5, 0.5, 0.5}, d.loc));
        auto m = make_medium(d);
        REQUIRE(m);
        const float t = 2.f;
        double delta, ratio;
        tracking_estimates(*m, Ray{{0, 0, 0}, {0, 0, 1}, kInfinity}, t, 200000, &delta, &ratio);
        const double expected = std::exp(-0.7 * t);  // 0.2466
        CHECK(delta == doctest::Approx(expected).epsilon(0.01));
        // With the majorant equal to sigma_t ratio tracking is delta tracking's expectation.
        CHECK(ratio == doctest::Approx(expected).epsilon(0.01));
    }
    SUBCASE("uniformgrid: both against the quadrature of sample_point, several rays") {
        auto m = make_medium(grid_desc());
        REQUIRE(m);
        const Ray rays[] = {Ray{{-4, 0.1f, 0.2f}, normalize(Vec3f(1, 0.05f, -0.1f)), kInfinity},
                            Ray{{0.3f, -3, -0.2f}, normalize(Vec3f(0.1f, 1, 0.15f)), kInfinity},
                            Ray{{2, 2, 2}, normalize(Vec3f(-1, -1, -1)), kInfinity}};
        for (const Ray &r : rays) {
            const float t_max = 8.f;
            const double q = quadrature_transmittance(*m, r, t_max, 20000);
            double delta, ratio;
            tracking_estimates(*m, r, t_max, 100000, &delta, &ratio);
            CAPTURE(q);
            CHECK(q < 0.95);  // the ray crosses the dense part
            CHECK(q > 0.02);
            CHECK(delta == doctest::Approx(q).epsilon(0.02));
            CHECK(ratio == doctest::Approx(q).epsilon(0.02));
        }
    }
}

TEST_CASE("grid majorants bound sigma_t everywhere along every segment") {
    auto m = make_medium(grid_desc());
    REQUIRE(m);
    Pcg32 rng(1, 2);
    int segments = 0, below = 0;
    for (int k = 0; k < 2000; ++k) {
        Vec3f o{rng.uniform() * 8 - 4, rng.uniform() * 8 - 4, rng.uniform() * 8 - 4};
        Vec3f target{rng.uniform() * 2 - 1, rng.uniform() * 2 - 1, rng.uniform() * 2 - 1};
        Ray r{o, normalize(target - o), kInfinity};
        MajorantIterator it = m->sample_ray(r, 20.f);
        MajorantSegment seg;
        float prev_end = -1;
        while (it.next(&seg)) {
            ++segments;
            CHECK(seg.t0 <= seg.t1);
            if (prev_end >= 0) CHECK(seg.t0 == doctest::Approx(prev_end).epsilon(1e-5));
            prev_end = seg.t1;
            for (int j = 0; j < 8; ++j) {
                float t = seg.t0 + (seg.t1 - seg.t0) * (j + 0.5f) / 8.f;
                MediumProperties mp = m->sample_point(r.o + r.d * t);
                float st = mp.sigma_a[0] + mp.sigma_s[0];
                if (st < seg.sigma_maj[0] * (1 + 1e-4f) + 1e-6f) ++below;
                else FAIL_CHECK("sigma_t " << st << " above the majorant " << seg.sigma_maj[0]);
            }
        }
    }
    CHECK(segments > 2000);
    CHECK(below == segments * 8);
}

TEST_CASE("media presets and parameter errors are pbrt-v4's") {
    Rgb a, s;
    REQUIRE(medium_preset("Wholemilk", &a, &s));
    CHECK(a.b == doctest::Approx(0.014f));
    CHECK(s.r == doctest::Approx(2.55f));
    CHECK_FALSE(medium_preset("Milk Shake", &a, &s));
    auto bad = [](const std::string &medium) {
        std::string text = std::string(kHeader) + medium;
        CHECK_THROWS_AS(scene_from_string(text), SceneError);
    };
    bad("MakeNamedMedium \"g\" \"string type\" \"uniformgrid\" \"integer nx\" 2 "
        "\"float density\" [ 1 ]\n");
    bad("MakeNamedMedium \"g\" \"string type\" \"homogeneous\" \"float g\" [ 1.5 ]\n");
    bad("MakeNamedMedium \"g\" \"string type\" \"rgbgrid\" \"float g\" [ 0 ]\n");
    bad("MakeNamedMedium \"g\" \"string type\" \"uniformgrid\" \"float density\" [ -1 ]\n");
}

TEST_CASE("nanovdb media are left out (no reader in this build); cloud media are built") {
    auto scene = scene_from_string(std::string(kHeader) +
                                   "MakeNamedMedium \"v\" \"string type\" \"nanovdb\" "
                                   "\"string filename\" \"smoke.nvdb\"\n"
                                   "MakeNamedMedium \"c\" \"string type\" \"cloud\"\n"
                                   "MediumInterface \"v\" \"c\"\nShape \"sphere\"\n");
    REQUIRE(scene->media.size() == 1);
    CHECK(scene->media[0]->name == "c");
    // The cloud's density is in [0, 1] and its majorant sigma_a + sigma_s (1 + 1) bounds it.
    const Medium &c = *scene->media[0];
    Pcg32 rng(3, 4);
    for (int i = 0; i < 1000; ++i) {
        Vec3f p{rng.uniform(), rng.uniform(), rng.uniform()};
        MediumProperties mp = c.sample_point(p);
        CHECK(mp.sigma_a[0] >= 0.f);
        CHECK(mp.sigma_a[0] + mp.sigma_s[0] <= 2.f);
    }
}

TEST_CASE("a scene without media keeps the surface path tracer; path ignores media") {
    auto plain = scene_from_string(std::string(kHeader) + "Shape \"sphere\"\n");
    CHECK_FALSE(plain->features.media);
    CHECK(plain->media.empty());
    std::string with_path = kHeader;
    with_path.replace(with_path.find("\"volpath\""), 9, "\"path\"");
    with_path += "MakeNamedMedium \"m\" \"string type\" \"homogeneous\"\n"
                 "MediumInterface \"m\" \"\"\nShape \"sphere\"\n";
    auto ignored = scene_from_string(with_path);
    CHECK_FALSE(ignored->features.media);
}
