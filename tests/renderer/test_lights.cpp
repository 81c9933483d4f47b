// Unit tests of renderer/lights/lights.h and renderer/lights/light_sampler.h: analytic irradiance, pbrt-v4
// parameter semantics (defaults, power normalisation, spot falloff, directions), the equal-area
// map, emission sidedness, and power-proportional light selection.
#include <doctest/doctest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "approx.h"
#include "renderer/lights/light_sampler.h"
#include "renderer/lights/lights.h"
#include "sampling/distribution.h"
#include "test_helpers.h"

using namespace tessera;

namespace {

Param num_param(const std::string &type, const std::string &name, std::vector<double> v) {
    Param p;
    p.type = type;
    p.name = name;
    p.numbers = std::move(v);
    p.loc = {"test.pbrt", 7};
    return p;
}

Param str_param(const std::string &name, const std::string &s) {
    Param p;
    p.type = "string";
    p.name = name;
    p.strings = {s};
    p.loc = {"test.pbrt", 7};
    return p;
}

LightDesc light_desc(const std::string &type, std::vector<Param> params,
                     Transform t = Transform()) {
    LightDesc d;
    d.type = type;
    d.params.params = std::move(params);
    d.loc = {"scene.pbrt", 42};
    d.render_from_light = t;
    return d;
}

bool near(Vec3f a, Vec3f b, float eps = 1e-5f) {
    return length(a - b) <= eps;
}

/// Irradiance at ctx estimated with an n x n stratified grid of light samples.
double mc_irradiance(const Light &light, const LightSampleContext &ctx, int n) {
    double sum = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            Vec2f u{(i + 0.5f) / n, (j + 0.5f) / n};
            auto s = light.sample_li(ctx, u);
            if (!s || s->pdf == 0)
                continue;
            sum += s->L.g * std::max(0.f, dot(ctx.n, s->wi)) / s->pdf;
        }
    return sum / (double(n) * n);
}

}  // namespace

TEST_CASE("point light: irradiance I cos / d^2, from + transform, power") {
    auto light = make_light(light_desc(
        "point", {num_param("rgb", "I", {2, 3, 4}), num_param("point3", "from", {0, 0, 5})},
        Transform::translate({1, 0, 0})));
    REQUIRE(light->type() == LightType::DeltaPosition);
    LightSampleContext ctx{{1, 3, 1}, {0, 0, 1}};
    auto s = light->sample_li(ctx, {0.3f, 0.7f});
    REQUIRE(s);
    CHECK(near(s->p_light, {1, 0, 5}));
    CHECK(s->pdf == 1.f);
    const float d2 = 9.f + 16.f;
    CHECK(near(s->wi, Vec3f(0, -3, 4) / 5.f));
    float cos_t = dot(ctx.n, s->wi);
    CHECK(s->L.r * cos_t == test::Approx(2.f * 0.8f / d2));
    CHECK(s->L.b * cos_t == test::Approx(4.f * 0.8f / d2));
    CHECK(light->pdf_li(ctx, s->wi, s->p_light, {}) == 0.f);
    CHECK(light->phi().g == test::Approx(4.f * kPi * 3.f));

    // "power" normalises the spectrum, keeping the RGB ratios (pbrt-v4), then "scale".
    auto p = make_light(light_desc(
        "point", {num_param("float", "power", {100}), num_param("float", "scale", {2})}));
    CHECK(p->phi().r == test::Approx(200.f));
    CHECK(p->phi().b == test::Approx(200.f));
}

TEST_CASE("spot light: smoothstep falloff between the cone edges, pbrt-v4 defaults") {
    // Defaults: coneangle 30, conedeltaangle 5, from (0,0,0), to (0,0,1), I = 1.
    auto spot = make_light(light_desc("spot", {num_param("float", "scale", {3})}));
    auto at_angle = [&](float deg) {
        float t = radians(deg);
        LightSampleContext ctx{Vec3f(std::sin(t), 0, std::cos(t)) * 2.f, {}};
        auto s = spot->sample_li(ctx, {0.5f, 0.5f});
        return s ? s->L.r * 4.f : 0.f;  // undo 1/d^2
    };
    // The tag the Whitted integrator's direct calls rely on.
    CHECK(spot->shape() == LightShape::Spot);
    CHECK(make_light(light_desc("point", {}))->shape() == LightShape::Point);
    CHECK(make_light(light_desc("distant", {}))->shape() == LightShape::Other);
    CHECK(at_angle(0.f) == test::Approx(3.f));
    CHECK(at_angle(24.9f) == test::Approx(3.f));
    CHECK(at_angle(30.1f) == 0.f);
    CHECK(at_angle(90.f) == 0.f);
    // Inside the falloff band: smoothstep of cos theta between cos 30 and cos 25.
    float c = std::cos(radians(27.5f)), c0 = std::cos(radians(30.f)), c1 = std::cos(radians(25.f));
    float t = (c - c0) / (c1 - c0);
    CHECK(at_angle(27.5f) == test::Approx(3.f * t * t * (3 - 2 * t)).epsilon(1e-4));
    float mid = at_angle(27.5f);
    CHECK(mid > 0.f);
    CHECK(mid < 3.f);

    // Power: phi equals the requested power; the axis follows from -> to and the transform.
    auto aimed = make_light(
        light_desc("spot",
                   {num_param("float", "power", {50}), num_param("point3", "from", {0, 0, 0}),
                    num_param("point3", "to", {1, 0, 0}), num_param("float", "coneangle", {20})},
                   Transform::translate({0, 2, 0})));
    CHECK(aimed->phi().g == test::Approx(50.f).epsilon(1e-4));
    auto on_axis = aimed->sample_li({{5, 2, 0}, {}}, {});
    REQUIRE(on_axis);
    CHECK(near(on_axis->p_light, {0, 2, 0}));
    CHECK(near(on_axis->wi, {-1, 0, 0}));
    CHECK_FALSE(aimed->sample_li({{-5, 2, 0}, {}}, {}));  // behind the spot
}

TEST_CASE("spot light: the falloff cosine is the light-space one, similarity or sheared transform") {
    // pbrt-v4: I(w) = I smoothstep(cos_theta(normalize(light_from_render(-wi)))). A rotated,
    // uniformly scaled light takes the render-space shortcut; a non-uniformly scaled one must
    // not: with scale (1, 3, 1) the render-space cosine to the axis is visibly different.
    const float c0 = std::cos(radians(40.f)), c1 = std::cos(radians(25.f));
    auto reference = [&](const Transform &render_from_light, Vec3f p) {
        Vec3f apex = render_from_light.point({0, 0, 0});
        Vec3f wi = normalize(apex - p);
        Vec3f w_light = normalize(render_from_light.inverse().vector(-wi));
        float t = clamp((cos_theta(w_light) - c0) / (c1 - c0), 0.f, 1.f);
        return 2.f * t * t * (3 - 2 * t) / length_squared(apex - p);
    };
    const Transform similarity = Transform::translate({1, -2, 0.5f}) *
                            Transform::rotate(37.0, {1, 2, 3}) * Transform::scale(2, 2, 2);
    const Transform sheared = Transform::scale(1, 3, 1);
    int in_band = 0, differs = 0;
    for (const Transform *tr : {&similarity, &sheared}) {
        auto spot = make_light(light_desc(
            "spot", {num_param("float", "scale", {2}), num_param("float", "coneangle", {40}),
                     num_param("float", "conedeltaangle", {15})},
            *tr));
        for (int k = 0; k < 64; ++k) {
            // Points around the axis at 0..45 degrees, all around it.
            float th = radians(45.f * float(k % 16) / 15.f), ph = 0.7f * float(k);
            Vec3f p_light = Vec3f(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph),
                                  std::cos(th)) * 3.f;
            Vec3f p = tr->point(p_light);
            float want = reference(*tr, p);
            auto s = spot->sample_li({p, {}}, {0.5f, 0.5f});
            float got = s ? s->L.r : 0.f;
            CHECK(got == test::Approx(want).epsilon(1e-4).scale(1e-6));
            const Vec3f apex = tr->point({0, 0, 0});
            const float d2 = length_squared(p - apex);
            if (tr == &sheared && want > 0.f && want < 2.f / d2) {
                ++in_band;
                // The render-space cosine would give another value here.
                Vec3f axis = normalize(tr->vector({0, 0, 1}));
                float t = clamp((dot(axis, normalize(p - apex)) - c0) / (c1 - c0), 0.f, 1.f);
                differs += std::abs(t * t * (3 - 2 * t) - want * d2 / 2.f) > 1e-2f;
            }
        }
    }
    CHECK(in_band > 4);
    CHECK(differs > 2);
}

TEST_CASE("distant light: arrives from from - to; illuminance; p_light beyond the scene") {
    auto sun = make_light(light_desc(
        "distant", {num_param("rgb", "L", {1, 2, 3}), num_param("point3", "from", {0, 0, 0}),
                    num_param("point3", "to", {0, 0, 1})}));
    REQUIRE(sun->type() == LightType::DeltaDirection);
    sun->preprocess({0, 0, 0}, 10.f);
    auto s = sun->sample_li({{1, 1, 1}, {0, 0, -1}}, {});
    REQUIRE(s);
    CHECK(near(s->wi, {0, 0, -1}));  // light travels +z, so it comes from -z
    CHECK(s->L.b == test::Approx(3.f));
    CHECK(near(s->p_light, {1, 1, -19}));
    CHECK(sun->phi().r == test::Approx(kPi * 100.f));

    auto lux = make_light(light_desc("distant", {num_param("float", "illuminance", {7})}));
    auto s2 = lux->sample_li({{0, 0, 0}, {}}, {});
    REQUIRE(s2);
    CHECK(s2->L.g == test::Approx(7.f));
}

TEST_CASE("sphere light: Monte Carlo irradiance matches pi L (r/d)^2") {
    // A normal-facing receiver at distance d from the centre of a Lambertian sphere of radius r
    // receives E = pi L (r/d)^2 (the sphere's form factor).
    const float L = 3.f, r = 0.5f, d = 4.f;
    SphereLight light({0, 0, d}, r, Rgb(L));
    LightSampleContext ctx{{0, 0, 0}, {0, 0, 1}};
    double e = mc_irradiance(light, ctx, 128);
    CHECK(e == test::Approx(kPi * L * (r / d) * (r / d)).epsilon(2e-3));
    // Large, close sphere (no small-angle branch): d = 1.5 r.
    SphereLight big({0, 0, 0.9f}, 0.6f, Rgb(L));
    e = mc_irradiance(big, ctx, 256);
    CHECK(e == test::Approx(kPi * L * (0.6 / 0.9) * (0.6 / 0.9)).epsilon(2e-3));
    CHECK(light.phi().r == test::Approx(L * kPi * 4.f * kPi * r * r));
}

TEST_CASE("disk light: on-axis irradiance pi L r^2 / (r^2 + d^2)") {
    const float L = 2.f, r = 1.f, d = 1.5f;
    DiskLight disk({0, 0, d}, {0, 0, -1}, r, Rgb(L));
    LightSampleContext ctx{{0, 0, 0}, {0, 0, 1}};
    double e = mc_irradiance(disk, ctx, 256);
    CHECK(e == test::Approx(kPi * L * r * r / (r * r + d * d)).epsilon(3e-3));
    // The receiver behind a one-sided disk gets nothing.
    CHECK(mc_irradiance(disk, {{0, 0, 3}, {0, 0, -1}}, 8) == 0.0);
}

TEST_CASE("triangle light: one-sided and two-sided emission") {
    Vec3f p0{0, 0, 1}, p1{1, 0, 1}, p2{0, 1, 1};
    TriangleLight one(p0, p1, p2, {0, 0, -1}, Rgb(5.f), false);
    TriangleLight two(p0, p1, p2, {0, 0, -1}, Rgb(5.f), true);
    CHECK(one.area() == test::Approx(0.5f));
    CHECK(one.L(p0, {0, 0, -1}, {}, {0, 0, -1}).r == 5.f);
    CHECK(one.L(p0, {0, 0, -1}, {}, {0, 0, 1}).r == 0.f);
    CHECK(two.L(p0, {0, 0, -1}, {}, {0, 0, 1}).r == 5.f);
    CHECK(one.phi().r == test::Approx(5.f * kPi * 0.5f));
    CHECK(two.phi().r == test::Approx(2.f * 5.f * kPi * 0.5f));

    LightSampleContext below{{0.2f, 0.2f, 0}, {0, 0, 1}}, above{{0.2f, 0.2f, 2}, {0, 0, -1}};
    auto s = one.sample_li(below, {0.3f, 0.6f});
    REQUIRE(s);
    CHECK(s->L.r == 5.f);
    CHECK(s->p_light.z == test::Approx(1.f));
    // Solid-angle pdf = d^2 / (cos * area).
    float d2 = length_squared(s->p_light - below.p);
    CHECK(s->pdf == test::Approx(d2 / (std::abs(s->wi.z) * 0.5f)));
    CHECK(one.pdf_li(below, s->wi, s->p_light, s->n_light) == test::Approx(s->pdf));
    CHECK_FALSE(one.sample_li(above, {0.3f, 0.6f}));
    auto s2 = two.sample_li(above, {0.3f, 0.6f});
    REQUIRE(s2);
    CHECK(s2->L.r == 5.f);
    CHECK(s2->n_light.z == test::Approx(1.f));  // the side facing the receiver
}

TEST_CASE("sphere light: reverse orientation emits inward") {
    SphereLight outward({0, 0, 0}, 2.f, Rgb(1.f));
    SphereLight inward({0, 0, 0}, 2.f, Rgb(1.f), true);
    LightSampleContext inside{{0.3f, 0, 0}, {}};
    CHECK_FALSE(outward.sample_li(inside, {0.2f, 0.4f}));
    auto s = inward.sample_li(inside, {0.2f, 0.4f});
    REQUIRE(s);
    CHECK(length(s->p_light) == test::Approx(2.f));
    // Inside a uniformly emitting sphere the irradiance on any plane is pi L.
    CHECK(mc_irradiance(inward, {{0.3f, 0.5f, -0.2f}, normalize(Vec3f(1, 2, 3))}, 256) ==
          test::Approx(kPi).epsilon(5e-3));
}

TEST_CASE("equal-area octahedral map: round trips and landmarks") {
    using sampling::equal_area_sphere_to_square;
    using sampling::equal_area_square_to_sphere;
    CHECK(near(equal_area_square_to_sphere({0.5f, 0.5f}), {0, 0, 1}));
    CHECK(near(equal_area_square_to_sphere({1.f, 0.5f}), {1, 0, 0}));
    CHECK(near(equal_area_square_to_sphere({0.5f, 1.f}), {0, 1, 0}));
    CHECK(near(equal_area_square_to_sphere({0.f, 0.f}), {0, 0, -1}));
    int bad = 0;
    const int n = 97;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            Vec2f u{(i + 0.5f) / n, (j + 0.5f) / n};
            Vec3f w = equal_area_square_to_sphere(u);
            if (std::abs(length(w) - 1.f) > 1e-5f)
                ++bad;
            Vec2f back = equal_area_sphere_to_square(w);
            if (std::abs(back.x - u.x) > 1e-5f || std::abs(back.y - u.y) > 1e-5f)
                ++bad;
            Vec3f again = equal_area_square_to_sphere(back);
            if (!near(again, w, 1e-5f))
                ++bad;
        }
    CHECK(bad == 0);
}

TEST_CASE("image infinite light: +z is the centre of an equal-area map; transform rotates") {
    // 9x9 map, dark except the centre pixel (light-space +z) and the left-edge middle (-x).
    const int res = 9;
    std::vector<float> px(size_t(res * res * 3), 0.1f);
    auto set = [&](int x, int y, float v) {
        for (int c = 0; c < 3; ++c)
            px[size_t((y * res + x) * 3 + c)] = v;
    };
    set(4, 4, 50.f);
    set(0, 4, 7.f);
    std::string path = tessera::test::output_dir() + "/lights_unit_env.exr";
    {
        auto out = OIIO::ImageOutput::create(path);
        REQUIRE(out);
        OIIO::ImageSpec spec(res, res, 3, OIIO::TypeDesc::FLOAT);
        REQUIRE(out->open(path, spec));
        REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
        out->close();
    }
    // Rotate -90 degrees about x: light-space +z becomes world +y (the usual y-up setup).
    auto light = make_light(
        light_desc("infinite", {str_param("filename", path)}, Transform::rotate(-90, {1, 0, 0})));
    REQUIRE(light->type() == LightType::Infinite);
    CHECK(light->Le({0, 1, 0}).r == test::Approx(50.f));
    CHECK(light->Le({-1, 0, 0}).r == test::Approx(7.f));
    CHECK(light->Le({0, -1, 0}).r == test::Approx(0.1f));
    // Most light samples go to the bright pixel (50 of the map's total weight ~62.
    int toward_up = 0;
    for (int i = 0; i < 100; ++i) {
        auto s = light->sample_li({{0, 0, 0}, {}}, {(i % 10 + 0.5f) / 10, (i / 10 + 0.5f) / 10});
        REQUIRE(s);
        if (s->wi.y > 0.9f)
            ++toward_up;
    }
    CHECK(toward_up > 70);

    // "scale" multiplies; "illuminance" rescales.
    auto scaled = make_light(
        light_desc("infinite", {str_param("filename", path), num_param("float", "scale", {2})}));
    CHECK(scaled->Le({0, 0, 1}).r == test::Approx(100.f));
}

TEST_CASE("uniform infinite light: L, default, illuminance, phi from the scene radius") {
    auto sky = make_light(light_desc("infinite", {num_param("rgb", "L", {0.5, 1, 2})}));
    CHECK(sky->Le({0.3f, 0.1f, -0.9f}).b == test::Approx(2.f));
    sky->preprocess({0, 0, 0}, 10.f);
    CHECK(sky->phi().g == test::Approx(4.f * kPi * kPi * 100.f));
    auto s = sky->sample_li({{0, 0, 0}, {0, 0, 1}}, {0.2f, 0.9f});
    REQUIRE(s);
    CHECK(s->pdf == test::Approx(kInv4Pi));
    CHECK(length(s->p_light) == test::Approx(20.f));
    auto def = make_light(light_desc("infinite", {}));
    CHECK(def->Le({0, 0, 1}).r == test::Approx(1.f));
    // Illuminance E on an upward patch from a uniform sky of radiance L is pi L.
    auto lux = make_light(light_desc("infinite", {num_param("float", "illuminance", {10})}));
    CHECK(lux->Le({0, 0, 1}).r == test::Approx(10.f / kPi));
}

TEST_CASE("make_light: unsupported and unknown types, conflicting parameters") {
    auto message = [](const LightDesc &d) -> std::string {
        try {
            make_light(d);
        } catch (const SceneError &e) {
            return e.what();
        }
        return "";
    };
    // A goniometric light without a map emits nothing (pbrt-v4 warns): no light, no error.
    CHECK(make_light(light_desc("goniometric", {})) == nullptr);
    std::string p = message(light_desc("projection", {}));
    CHECK(p.find("scene.pbrt:42") == 0);
    CHECK(p.find("needs a \"filename\"") != std::string::npos);
    CHECK(message(light_desc("laser", {})).find("scene.pbrt:42") == 0);
    CHECK(message(light_desc("infinite",
                             {num_param("rgb", "L", {1, 1, 1}), str_param("filename", "x.exr")}))
              .find("scene.pbrt:42") == 0);
    CHECK(message(light_desc("infinite", {str_param("filename", "/nonexistent/sky.exr")}))
              .find("scene.pbrt:42") == 0);
}

TEST_CASE("make_area_emission: defaults, scale, power per shape, twosided") {
    ParamSet none;
    AreaEmission e = make_area_emission(none, {"a.pbrt", 3}, 2.f);
    CHECK(e.L.r == 1.f);
    CHECK(e.L.b == 1.f);
    CHECK_FALSE(e.twosided);

    ParamSet ps;
    ps.params = {num_param("rgb", "L", {17, 12, 4}), num_param("float", "scale", {0.5})};
    e = make_area_emission(ps, {"a.pbrt", 3}, 2.f);
    CHECK(e.L.r == test::Approx(8.5f));
    CHECK(e.L.b == test::Approx(2.f));

    // power: phi = L * pi * area * (twosided ? 2 : 1) equals the requested power.
    ParamSet pw;
    Param ts;
    ts.type = "bool";
    ts.name = "twosided";
    ts.bools = {1};
    ts.strings = {"true"};
    pw.params = {num_param("float", "power", {10}), ts};
    e = make_area_emission(pw, {"a.pbrt", 3}, 2.f);
    CHECK(e.twosided);
    CHECK(e.L.g * kPi * 2.f * 2.f == test::Approx(10.f));

    ParamSet img;
    img.params = {str_param("filename", "emit.png")};
    int before = warning_count();
    e = make_area_emission(img, {"a.pbrt", 4}, 1.f);
    CHECK(warning_count() > before);
    CHECK(e.L.r == 1.f);
}

TEST_CASE("PowerLightSampler: pmf proportional to power, sums to 1, O(1) lookup") {
    PointLight point({0, 0, 0}, Rgb(1.f));                   // phi = 4 pi
    SphereLight sphere({0, 0, 5}, 1.f, Rgb(2.f, 2.f, 2.f));  // phi = 2 * pi * 4 pi
    TriangleLight tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, Rgb(0.f, 4.f, 0.f), true);
    UniformInfiniteLight sky(Rgb(0.01f));
    sky.preprocess({0, 0, 0}, 3.f);
    std::vector<const Light *> lights = {&point, &sphere, &tri, &sky};
    PowerLightSampler sampler(lights);
    REQUIRE(sampler.size() == 4);

    // Local lights only: purely by power.
    std::vector<const Light *> local = {&point, &sphere, &tri};
    PowerLightSampler local_sampler(local);
    double sum_local = 0;
    for (const Light *l : local) sum_local += l->phi().luminance();
    for (const Light *l : local)
        CHECK(local_sampler.pmf(l) ==
              test::Approx(l->phi().luminance() / sum_local).epsilon(1e-5));

    // With a sky too: the sky (the infinite-extent group) gets 1/2, the local lights share
    // the other half by power.
    double total = 0;
    CHECK(sampler.pmf(&sky) == test::Approx(0.5).epsilon(1e-6));
    for (const Light *l : local)
        CHECK(sampler.pmf(l) ==
              test::Approx(0.5 * l->phi().luminance() / sum_local).epsilon(1e-5));
    for (const Light *l : lights) total += sampler.pmf(l);
    CHECK(total == test::Approx(1.0).epsilon(1e-6));
    PointLight stranger({1, 1, 1}, Rgb(1.f));
    CHECK(sampler.pmf(&stranger) == 0.f);

    // Stratified u: the alias table returns each light within a few samples of pmf * n.
    const int n = 10000;
    std::vector<int> count(4, 0);
    for (int i = 0; i < n; ++i) {
        auto s = sampler.sample((i + 0.5f) / n);
        REQUIRE(s);
        CHECK(s->pmf == sampler.pmf(s->light));
        for (size_t k = 0; k < 4; ++k)
            if (s->light == lights[k])
                ++count[k];
    }
    for (size_t k = 0; k < 4; ++k)
        CHECK(std::abs(count[k] - sampler.pmf(lights[k]) * n) <= 9.0);

    // All-zero power: uniform. No lights: nothing.
    PointLight dark1({0, 0, 0}, Rgb(0.f)), dark2({1, 0, 0}, Rgb(0.f));
    std::vector<const Light *> dark = {&dark1, &dark2};
    PowerLightSampler uniform(dark);
    CHECK(uniform.pmf(&dark1) == test::Approx(0.5f));
    CHECK(uniform.pmf(&dark2) == test::Approx(0.5f));
    PowerLightSampler empty(std::span<const Light *const>{});
    CHECK_FALSE(empty.sample(0.5f));
}
