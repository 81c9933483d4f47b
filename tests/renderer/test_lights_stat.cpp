// Chi-square tests of the lights' sample_li directions against their pdf_li (tests/chi2.h
// sphere binning; the pdf of an area light at direction w is pdf_li at the point where the ray
// along w first meets the light), and agreement of pdf_li with the pdf sample_li returns.
// Fixed seeds; significance 0.01 Bonferroni-corrected over this file's tests.
#include <doctest/doctest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "approx.h"
#include "chi2.h"
#include "renderer/lights/lights.h"

using namespace tessera;
using tessera::test::Chi2Options;

namespace {

constexpr int kNumChi2Tests = 11;

Chi2Options options(uint64_t seed) {
    Chi2Options o;
    o.num_tests = kNumChi2Tests;
    o.seed = seed;
    o.sample_count = 200000;
    o.theta_bins = 40;
    o.phi_bins = 80;
    return o;
}

/// Where a ray from o along unit w first hits the light's surface, with the surface normal.
struct Hit {
    Vec3f p, n;
};
using Intersector = std::function<std::optional<Hit>(Vec3f o, Vec3f w)>;

std::optional<Hit> hit_triangle(Vec3f o, Vec3f w, Vec3f p0, Vec3f p1, Vec3f p2) {
    // Moller-Trumbore, in double to keep the bin integrals clean near the edges.
    Vec3f e1 = p1 - p0, e2 = p2 - p0;
    Vec3f pv = cross(w, e2);
    double det = dot(e1, pv);
    if (std::abs(det) < 1e-12)
        return std::nullopt;
    Vec3f tv = o - p0;
    double b1 = dot(tv, pv) / det;
    if (b1 < 0 || b1 > 1)
        return std::nullopt;
    Vec3f qv = cross(tv, e1);
    double b2 = dot(w, qv) / det;
    if (b2 < 0 || b1 + b2 > 1)
        return std::nullopt;
    double t = dot(e2, qv) / det;
    if (t <= 0)
        return std::nullopt;
    return Hit{o + w * float(t), normalize(cross(e1, e2))};
}

std::optional<Hit> hit_sphere(Vec3f o, Vec3f w, Vec3f c, float r) {
    Vec3f oc = o - c;
    double b = dot(oc, w), cc = double(dot(oc, oc)) - double(r) * r;
    double disc = b * b - cc;
    if (disc < 0)
        return std::nullopt;
    double s = std::sqrt(disc);
    double t = -b - s;
    if (t <= 0)
        t = -b + s;
    if (t <= 0)
        return std::nullopt;
    Vec3f p = o + w * float(t);
    return Hit{p, normalize(p - c)};
}

std::optional<Hit> hit_disk(Vec3f o, Vec3f w, Vec3f c, Vec3f n, float r) {
    double denom = dot(w, n);
    if (std::abs(denom) < 1e-12)
        return std::nullopt;
    double t = dot(c - o, n) / denom;
    if (t <= 0)
        return std::nullopt;
    Vec3f p = o + w * float(t);
    if (length_squared(p - c) > r * r)
        return std::nullopt;
    return Hit{p, n};
}

/// First hit of a ray with a QuadricAreaLight's shape (in object space through `xf`), with its
/// emitting normal.
std::optional<Hit> hit_quadric(Vec3f o_w, Vec3f w_w, const Transform &xf,
                               const QuadricAreaLight::Shape &q) {
    Vec3f o = xf.inverse_point(o_w), d = xf.inverse_point(o_w + w_w) - o;
    auto phi_ok = [&](double x, double y) {
        double phi = std::atan2(y, x);
        if (phi < 0) phi += 2 * M_PI;
        return phi <= q.phi_max;
    };
    double best = -1;
    Vec3f n_obj;
    if (q.kind == QuadricAreaLight::Kind::Disk) {
        if (d.z != 0) {
            double t = (q.height - o.z) / d.z;
            double x = o.x + t * d.x, y = o.y + t * d.y, r2 = x * x + y * y;
            if (t > 0 && r2 <= double(q.radius) * q.radius &&
                r2 >= double(q.inner_radius) * q.inner_radius && phi_ok(x, y)) {
                best = t;
                n_obj = {0, 0, 1};
            }
        }
    } else {
        const bool sphere = q.kind == QuadricAreaLight::Kind::Sphere;
        double a = d.x * d.x + d.y * d.y + (sphere ? d.z * d.z : 0.0);
        double b = 2 * (d.x * o.x + d.y * o.y + (sphere ? d.z * o.z : 0.0));
        double c = o.x * o.x + o.y * o.y + (sphere ? o.z * o.z : 0.0) - double(q.radius) * q.radius;
        double disc = b * b - 4 * a * c;
        if (a > 0 && disc >= 0) {
            double sq = std::sqrt(disc);
            for (double t : {(-b - sq) / (2 * a), (-b + sq) / (2 * a)}) {
                double x = o.x + t * d.x, y = o.y + t * d.y, z = o.z + t * d.z;
                if (t > 0 && z >= q.zmin && z <= q.zmax && phi_ok(x, y)) {
                    best = t;
                    n_obj = sphere ? Vec3f(float(x), float(y), float(z)) : Vec3f(float(x), float(y), 0);
                    break;
                }
            }
        }
    }
    if (best < 0)
        return std::nullopt;
    Vec3f p_obj = o + d * float(best);
    if (q.flip_normal)
        n_obj = -n_obj;
    return Hit{xf.point(p_obj), normalize(xf.normal(n_obj))};
}

/// Runs the chi-square test of `light` seen from ctx, then checks that pdf_li at every sampled
/// direction reproduces the sample's pdf and that the sample lies on the surface.
void check_light(const std::string &name, const Light &light, const LightSampleContext &ctx,
                 const Intersector &intersect, uint64_t seed, Chi2Options opt) {
    auto sampler = [&](Vec2f u, float) -> std::optional<Vec3f> {
        auto s = light.sample_li(ctx, u);
        if (!s)
            return std::nullopt;
        return s->wi;
    };
    auto pdf = [&](Vec3f w) -> double {
        if (!intersect)
            return light.pdf_li(ctx, w, {}, {});
        auto h = intersect(ctx.p, w);
        if (!h)
            return 0.0;
        return light.pdf_li(ctx, w, h->p, h->n);
    };
    opt.seed = seed;
    auto r = tessera::test::chi2_sphere(name, sampler, pdf, opt);
    CHECK_MESSAGE(r.passed, r.message);
    CHECK_MESSAGE(r.pdf_integral == test::Approx(1.0).epsilon(5e-3), r.message);

    tessera::test::Chi2Rng rng(seed + 1000);
    int mismatched = 0, off_surface = 0;
    for (int i = 0; i < 2000; ++i) {
        auto s = light.sample_li(ctx, rng.uniform2());
        if (!s)
            continue;
        float q = light.pdf_li(ctx, s->wi, s->p_light, s->n_light);
        if (!(std::abs(q - s->pdf) <= 1e-3f * s->pdf))
            ++mismatched;
        if (intersect) {
            auto h = intersect(ctx.p, s->wi);
            if (!h || length(h->p - s->p_light) > 1e-3f * (1.f + length(s->p_light)))
                ++off_surface;
        }
    }
    CHECK_MESSAGE(mismatched == 0, name << ": pdf_li disagrees with sample_li's pdf");
    CHECK_MESSAGE(off_surface == 0, name << ": sampled points are not where the ray hits");
}

/// A 2:1 or square RGB image with a smooth gradient and one bright spot, written as EXR.
std::string write_env(const std::string &file, int w, int h) {
    std::vector<float> px(size_t(w * h * 3));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float base = 0.2f + 0.6f * float(x) / float(w) + 0.3f * float(y) / float(h);
            bool spot = std::abs(x - w / 3) <= 1 && std::abs(y - h / 4) <= 1;
            float v = spot ? 30.f : base;
            px[size_t((y * w + x) * 3 + 0)] = v;
            px[size_t((y * w + x) * 3 + 1)] = v * 0.8f;
            px[size_t((y * w + x) * 3 + 2)] = (x + y) % 5 == 0 ? 0.f : v * 0.5f;
        }
    std::string path = tessera::test::output_dir() + "/" + file;
    auto out = OIIO::ImageOutput::create(path);
    REQUIRE(out);
    OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::FLOAT);
    REQUIRE(out->open(path, spec));
    REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
    out->close();
    return path;
}

LightDesc env_desc(const std::string &path) {
    LightDesc d;
    d.type = "infinite";
    Param p;
    p.type = "string";
    p.name = "filename";
    p.strings = {path};
    d.params.params = {p};
    d.loc = {"env.pbrt", 1};
    // An arbitrary rotation, to check that sampling and pdf agree on the transform.
    d.render_from_light = Transform::rotate(-70, normalize(Vec3f(1, 0.4f, 0.2f)));
    return d;
}

}  // namespace

TEST_CASE("triangle light: sample_li matches pdf_li (chi-square)") {
    Vec3f p0{-1, -1, 2}, p1{1.5f, -0.5f, 2}, p2{0, 1.2f, 2.5f};
    Vec3f n = normalize(cross(p1 - p0, p2 - p0));
    if (n.z > 0)
        n = -n;  // emit toward the receiver below
    TriangleLight light(p0, p1, p2, n, Rgb(1.f), false);
    check_light(
        "triangle_light", light, {{0.1f, 0.2f, 0}, {0, 0, 1}},
        [&](Vec3f o, Vec3f w) { return hit_triangle(o, w, p0, p1, p2); }, 31, options(31));
}

TEST_CASE("sphere light seen from outside: cone sampling (chi-square)") {
    Vec3f c{0.5f, 0.3f, 3};
    SphereLight light(c, 1.2f, Rgb(1.f));
    check_light(
        "sphere_outside", light, {{0, 0, 0}, {0, 0, 1}},
        [&](Vec3f o, Vec3f w) { return hit_sphere(o, w, c, 1.2f); }, 32, options(32));
    // A small, distant sphere takes the small-angle (Taylor) branch.
    Vec3f c2{0.2f, -0.1f, 30};
    SphereLight tiny(c2, 0.5f, Rgb(1.f));
    Chi2Options o = options(33);
    o.theta_bins = 400;  // theta_max ~ 1 degree
    o.phi_bins = 40;
    check_light(
        "sphere_small_angle", tiny, {{0, 0, 0}, {}},
        [&](Vec3f org, Vec3f w) { return hit_sphere(org, w, c2, 0.5f); }, 33, o);
}

TEST_CASE("sphere light seen from inside: area sampling (chi-square)") {
    Vec3f c{0, 0, 0};
    SphereLight light(c, 2.f, Rgb(1.f), /*reverse_orientation=*/true);
    check_light(
        "sphere_inside", light, {{0.5f, -0.3f, 0.8f}, {}},
        [&](Vec3f o, Vec3f w) { return hit_sphere(o, w, c, 2.f); }, 34, options(34));
}

TEST_CASE("disk light: area sampling (chi-square)") {
    Vec3f c{0, 0, 2}, n = normalize(Vec3f(0.3f, 0, -1));
    DiskLight light(c, n, 1.5f, Rgb(1.f));
    check_light(
        "disk_light", light, {{0.3f, 0, 0}, {0, 0, 1}},
        [&](Vec3f o, Vec3f w) { return hit_disk(o, w, c, n, 1.5f); }, 35, options(35));
}

TEST_CASE("cylinder, partial sphere and annulus lights: area sampling (chi-square)") {
    // Rotated, moved and uniformly scaled, so that sampling and pdf agree on the transform.
    const Transform xf = Transform::translate({0.3f, -0.2f, 0.5f}) *
                         Transform::rotate(35, normalize(Vec3f(1, 0.5f, 0.2f))) *
                         Transform::scale(1.5f, 1.5f, 1.5f);
    // Seen from inside, emitting inward: every direction meets the surface at most once.
    QuadricAreaLight::Shape cyl;
    cyl.kind = QuadricAreaLight::Kind::Cylinder;
    cyl.radius = 0.8f;
    cyl.zmin = -0.6f;
    cyl.zmax = 1.1f;
    cyl.phi_max = radians(300);
    cyl.flip_normal = true;
    QuadricAreaLight cyl_light(cyl, xf, Rgb(1.f));
    const Vec3f inside = xf.point({0.1f, -0.2f, 0.2f});
    check_light(
        "cylinder_light", cyl_light, {inside, {}},
        [&](Vec3f o, Vec3f w) { return hit_quadric(o, w, xf, cyl); }, 40, options(40));

    QuadricAreaLight::Shape sph;
    sph.kind = QuadricAreaLight::Kind::Sphere;
    sph.radius = 1.f;
    sph.zmin = -0.5f;
    sph.zmax = 0.9f;
    sph.phi_max = radians(250);
    sph.flip_normal = true;
    QuadricAreaLight sph_light(sph, xf, Rgb(1.f));
    check_light(
        "partial_sphere_light", sph_light, {inside, {}},
        [&](Vec3f o, Vec3f w) { return hit_quadric(o, w, xf, sph); }, 41, options(41));

    // An annulus sector seen from above its emitting side.
    QuadricAreaLight::Shape disk;
    disk.kind = QuadricAreaLight::Kind::Disk;
    disk.radius = 1.2f;
    disk.inner_radius = 0.4f;
    disk.height = 0.3f;
    disk.phi_max = radians(200);
    QuadricAreaLight disk_light(disk, xf, Rgb(1.f));
    check_light(
        "annulus_light", disk_light, {xf.point({0.2f, 0.1f, 1.5f}), {}},
        [&](Vec3f o, Vec3f w) { return hit_quadric(o, w, xf, disk); }, 42, options(42));
    // Areas: 1.5^2 times phi_max r (zmax - zmin), and phi_max / 2 (ro^2 - ri^2).
    CHECK(cyl_light.area() == test::Approx(2.25 * radians(300) * 0.8 * 1.7).epsilon(1e-5));
    CHECK(sph_light.area() == test::Approx(2.25 * radians(250) * 1.0 * 1.4).epsilon(1e-5));
    CHECK(disk_light.area() ==
          test::Approx(2.25 * 0.5 * radians(200) * (1.44 - 0.16)).epsilon(1e-5));
}

TEST_CASE("uniform infinite light (chi-square)") {
    UniformInfiniteLight light(Rgb(1.f));
    check_light("uniform_infinite", light, {{1, 2, 3}, {0, 0, 1}}, nullptr, 36, options(36));
}

TEST_CASE("image infinite light, square equal-area and 2:1 lat-long (chi-square)") {
    for (int equirect = 0; equirect < 2; ++equirect) {
        std::string path = equirect ? write_env("lights_stat_latlong.exr", 24, 12)
                                    : write_env("lights_stat_equal_area.exr", 16, 16);
        auto light = make_light(env_desc(path));
        REQUIRE(light);
        // Pixel borders cut the sphere bins everywhere; a looser integration tolerance keeps
        // the adaptive quadrature fast while its error stays far below the counts' noise.
        Chi2Options o = options(37 + uint64_t(equirect));
        o.integration_tol = 2e-6;
        check_light(equirect ? "image_latlong" : "image_equal_area", *light, {{0, 0, 0}, {0, 0, 1}},
                    nullptr, 37 + uint64_t(equirect), o);
        // The sample's radiance is what Le returns for the same direction (nearest pixel);
        // only directions within rounding of a pixel border may differ.
        tessera::test::Chi2Rng rng(99);
        int differ = 0;
        for (int i = 0; i < 2000; ++i) {
            auto s = light->sample_li({{0, 0, 0}, {}}, rng.uniform2());
            REQUIRE(s);
            Rgb le = light->Le(s->wi);
            if (std::abs(le.r - s->L.r) > 1e-4f * (1.f + s->L.r))
                ++differ;
        }
        CHECK(differ <= 5);
    }
}

TEST_CASE("negative control: the chi-square test rejects a plausible but wrong pdf") {
    // Cone-sampled sphere directions tested against the area-sampling density (d^2 / cos over
    // the visible cap's area): right support, wrong shape. The test must notice.
    Vec3f c{0.5f, 0.3f, 3};
    const float r = 1.2f;
    SphereLight light(c, r, Rgb(1.f));
    LightSampleContext ctx{{0, 0, 0}, {}};
    auto sampler = [&](Vec2f u, float) -> std::optional<Vec3f> {
        auto s = light.sample_li(ctx, u);
        if (!s)
            return std::nullopt;
        return s->wi;
    };
    // Visible cap area: 2 pi r^2 (1 - r / |c - p|).
    const float cap = 2.f * kPi * r * r * (1.f - r / length(c));
    auto wrong_pdf = [&](Vec3f w) -> double {
        auto h = hit_sphere(ctx.p, w, c, r);
        if (!h)
            return 0.0;
        return length_squared(h->p) / (absdot(h->n, w) * cap);
    };
    auto res = tessera::test::chi2_sphere("negative_control", sampler, wrong_pdf, options(40));
    CHECK_MESSAGE(!res.passed, res.message);
}
