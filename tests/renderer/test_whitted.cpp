// Unit tests of the deterministic Whitted integrator (renderer/integrators/whitted_integrator.h): analytic
// direct light (point, spot cone edge, distant, triangle area light), exact shadow bits, a
// mirror's Fresnel-weighted reflection, refraction and total internal reflection in glass, the
// depth limit with exact ray counts, the attribute-vector invariants of the real-time modes
// (shade(first_hit) == radiance; interpolation exact on a plane), packets bit-identical to
// single rays, object ids of instances, mix materials, and determinism.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/shading/microfacet.h"
#include "renderer/integrators/whitted_integrator.h"

using namespace tessera;
using tessera::test::scene_from_string;

namespace {

constexpr float kRelTol = 1e-4f;

CameraSample sample_at(uint32_t px, uint32_t py, float fx = 0.5f, float fy = 0.5f) {
    CameraSample cs;
    cs.px = px;
    cs.py = py;
    cs.fx = fx;
    cs.fy = fy;
    return cs;
}

bool rgb_near(Rgb a, Rgb b, float rel = kRelTol, float abs_tol = 1e-7f) {
    for (int c = 0; c < 3; ++c) {
        float tol = std::max(abs_tol, rel * std::max(std::abs(a[c]), std::abs(b[c])));
        if (!(std::abs(a[c] - b[c]) <= tol))
            return false;
    }
    return true;
}

std::string rgb_str(Rgb c) {
    std::ostringstream s;
    s << "(" << c.r << ", " << c.g << ", " << c.b << ")";
    return s.str();
}

/// A large diffuse floor y = 0 seen from above; `lights` and `extra` are pbrt text.
std::string floor_scene(const std::string &lights, const std::string &extra = "",
                        const std::string &camera =
                            "LookAt 0 5 0  0 0 0  0 0 1\n"
                            "Camera \"perspective\" \"float fov\" [60]\n",
                        int res = 33) {
    return camera + "Film \"rgb\" \"integer xresolution\" [" + std::to_string(res) +
           "] \"integer yresolution\" [" + std::to_string(res) + "]\n" + "WorldBegin\n" + lights +
           "AttributeBegin\n"
           "Material \"diffuse\" \"rgb reflectance\" [0.5 0.4 0.3]\n"
           "Shape \"trianglemesh\" \"point3 P\" [-20 0 -20  20 0 -20  20 0 20  -20 0 20]\n"
           "    \"integer indices\" [0 1 2 0 2 3]\n"
           "AttributeEnd\n" +
           extra;
}

const Rgb kFloorAlbedo{0.5f, 0.4f, 0.3f};

/// Radiance of the diffuse floor at p under a point-like source of intensity I at `light`.
Rgb floor_point_radiance(Vec3f p, Vec3f light, Rgb I) {
    Vec3f d = light - p;
    float r2 = length_squared(d);
    float cos_s = std::max(0.f, d.y / std::sqrt(r2));
    return kFloorAlbedo * kInvPi * I * (cos_s / r2);
}

float smooth_step(float x, float a, float b) {
    float t = clamp((x - a) / (b - a), 0.f, 1.f);
    return t * t * (3.f - 2.f * t);
}

bool same_bits(float a, float b) {
    return std::memcmp(&a, &b, sizeof(float)) == 0;
}
bool same_bits(Rgb a, Rgb b) {
    return same_bits(a.r, b.r) && same_bits(a.g, b.g) && same_bits(a.b, b.b);
}
bool same_bits(Vec3f a, Vec3f b) {
    return same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.z, b.z);
}
bool same_bits(const SurfaceAttributes &a, const SurfaceAttributes &b) {
    return a.object_id == b.object_id && same_bits(a.position, b.position) &&
           same_bits(a.normal, b.normal) && a.shadow_bits == b.shadow_bits &&
           same_bits(a.uv.x, b.uv.x) && same_bits(a.uv.y, b.uv.y) && a.has_texture == b.has_texture;
}
bool same_bits(const Sample &a, const Sample &b) {
    if (!same_bits(a.radiance, b.radiance) || !same_bits(a.albedo, b.albedo) ||
        !same_bits(a.normal, b.normal) || !same_bits(a.depth, b.depth) || a.rays != b.rays ||
        a.first_hit.has_value() != b.first_hit.has_value())
        return false;
    if (!a.first_hit)
        return true;
    const HitAttributes &x = *a.first_hit, &y = *b.first_hit;
    return same_bits(x.primary, y.primary) && same_bits(x.secondary, y.secondary) &&
           same_bits(x.global_color, y.global_color) && same_bits(x.local_color, y.local_color);
}

/// Everything at once: textures, mirror, glass, rough metal, coated diffuse, mix, spheres,
/// disk, every light type (point, spot, distant, triangle, sphere and disk area lights) and an
/// environment, so escaped rays, user geometry and all shading paths appear in one image.
const char *kKitchenSink = R"(
LookAt 0 1 3.9   0 1 0   0 1 0
Camera "perspective" "float fov" [ 45 ]
Film "rgb" "integer xresolution" [ 24 ] "integer yresolution" [ 24 ]
WorldBegin
LightSource "infinite" "rgb L" [ 0.05 0.06 0.08 ]
LightSource "point" "point3 from" [ 0.5 1.6 1.0 ] "rgb I" [ 0.8 0.8 0.7 ]
LightSource "spot" "point3 from" [ -0.6 1.9 0.8 ] "point3 to" [ -0.4 0 0 ] "rgb I" [ 2 1.5 1 ]
    "float coneangle" [ 25 ] "float conedeltaangle" [ 8 ]
LightSource "distant" "point3 from" [ 1 3 2 ] "point3 to" [ 0 0 0 ] "rgb L" [ 0.3 0.3 0.3 ]
Texture "checks" "spectrum" "checkerboard" "float uscale" [ 6 ] "float vscale" [ 6 ]
    "rgb tex1" [ 0.8 0.8 0.8 ] "rgb tex2" [ 0.2 0.3 0.2 ]
MakeNamedMaterial "floor" "string type" [ "diffuse" ] "texture reflectance" "checks"
MakeNamedMaterial "white" "string type" [ "diffuse" ] "rgb reflectance" [ 0.7 0.7 0.7 ]
MakeNamedMaterial "red" "string type" [ "diffuse" ] "rgb reflectance" [ 0.6 0.1 0.1 ]
MakeNamedMaterial "mix" "string type" [ "mix" ] "string materials" [ "white" "red" ]
    "float amount" [ 0.7 ]
NamedMaterial "floor"
Shape "bilinearmesh" "point3 P" [ -1 0 1  1 0 1  -1 0 -1  1 0 -1 ]
    "point2 uv" [ 0 0  1 0  0 1  1 1 ]
NamedMaterial "white"
Shape "bilinearmesh" "point3 P" [ -1 0 -1  1 0 -1  -1 2 -1  1 2 -1 ]
NamedMaterial "mix"
Shape "bilinearmesh" "point3 P" [ 1 0 -1  1 0 1  1 2 -1  1 2 1 ]
AttributeBegin
  Material "conductor" "rgb reflectance" [ 0.9 0.9 0.9 ] "float roughness" [ 0 ]
  Shape "bilinearmesh" "point3 P" [ -1 0 1  -1 0 -1  -1 2 1  -1 2 -1 ]
AttributeEnd
AttributeBegin
  Material "dielectric" "float eta" [ 1.5 ]
  Translate 0.45 0.4 0.3
  Shape "sphere" "float radius" [ 0.4 ]
AttributeEnd
AttributeBegin
  Material "conductor" "float roughness" [ 0.1 ]
  Translate -0.45 0.35 -0.35
  Shape "sphere" "float radius" [ 0.35 ]
AttributeEnd
AttributeBegin
  Material "coateddiffuse" "rgb reflectance" [ 0.2 0.3 0.6 ]
  Translate 0.2 0.01 -0.6
  Rotate -90 1 0 0
  Shape "disk" "float radius" [ 0.3 ]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 8 6 3 ]
  Material "diffuse" "rgb reflectance" [ 0 0 0 ]
  Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
      "point3 P" [ -0.25 1.98 -0.25  0.25 1.98 -0.25  0.25 1.98 0.25  -0.25 1.98 0.25 ]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 3 3 5 ]
  Translate -0.7 1.7 0.2
  Shape "sphere" "float radius" [ 0.08 ]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 4 4 4 ] "bool twosided" true
  Translate 0.7 1.5 -0.5
  Rotate 60 1 0 0
  Shape "disk" "float radius" [ 0.1 ]
AttributeEnd
)";

}  // namespace

TEST_CASE("whitted: diffuse floor under a point light is albedo/pi I cos / r^2") {
    const Vec3f light{1.f, 2.f, 0.5f};
    const Rgb I{3.f, 2.f, 1.f};
    auto scene = scene_from_string(
        floor_scene("LightSource \"point\" \"point3 from\" [1 2 0.5] \"rgb I\" [3 2 1]\n"));
    WhittedIntegrator w(*scene);
    // The centre pixel's centre looks straight down at the origin.
    Sample s = w.evaluate(sample_at(16, 16));
    REQUIRE(s.first_hit);
    Vec3f p = s.first_hit->primary.position;
    CHECK(length(p) < 1e-5f);
    Rgb expected = floor_point_radiance({0, 0, 0}, light, I);
    INFO("got " << rgb_str(s.radiance) << " expected " << rgb_str(expected));
    CHECK(rgb_near(s.radiance, expected));
    CHECK(s.rays == 2);  // primary + one shadow ray
    CHECK(s.first_hit->primary.shadow_bits == 0);
    CHECK(s.first_hit->global_color.is_black());
    // Other pixels: the same formula at their hit point.
    for (uint32_t px : {0u, 5u, 20u, 32u}) {
        Sample t = w.evaluate(sample_at(px, 7, 0.25f, 0.75f));
        REQUIRE(t.first_hit);
        Vec3f q = t.first_hit->primary.position;
        CHECK(std::abs(q.y) < 1e-5f);
        CHECK(rgb_near(t.radiance, floor_point_radiance(q, light, I)));
        CHECK(t.depth == test::Approx(length(q - Vec3f(0, 5, 0))).epsilon(1e-5));
        CHECK(t.albedo.r == test::Approx(0.5f));
    }
}

TEST_CASE("whitted: spot light cone edge follows pbrt's smoothstep falloff") {
    // Spot straight down from (0, 3, 0): full inside 20 degrees, zero beyond 30.
    auto scene = scene_from_string(floor_scene(
        "LightSource \"spot\" \"point3 from\" [0 3 0] \"point3 to\" [0 0 0] \"rgb I\" [5 5 5]\n"
        "    \"float coneangle\" [30] \"float conedeltaangle\" [10]\n"));
    WhittedIntegrator w(*scene);
    const Vec3f apex{0, 3, 0};
    int inside = 0, band = 0, outside = 0;
    for (uint32_t px = 0; px < 33; ++px) {
        for (float fx : {0.1f, 0.6f}) {
            Sample s = w.evaluate(sample_at(px, 16, fx, 0.5f));
            REQUIRE(s.first_hit);
            Vec3f p = s.first_hit->primary.position;
            Vec3f to_p = normalize(p - apex);
            float cos_t = -to_p.y;
            float fall = smooth_step(cos_t, std::cos(radians(30.f)), std::cos(radians(20.f)));
            Rgb expected = floor_point_radiance(p, apex, Rgb(5.f) * fall);
            INFO("px " << px << " cos " << cos_t << " got " << rgb_str(s.radiance) << " expected "
                       << rgb_str(expected));
            CHECK(rgb_near(s.radiance, expected, 1e-3f, 1e-6f));
            if (fall == 1.f)
                ++inside;
            else if (fall == 0.f) {
                ++outside;
                CHECK(s.radiance.is_black());
                CHECK(s.rays == 1);  // no shadow ray outside the cone
            } else {
                ++band;
            }
        }
    }
    CHECK(inside > 0);
    CHECK(band > 0);
    CHECK(outside > 0);
}

TEST_CASE("whitted: distant light gives constant albedo/pi L cos") {
    auto scene = scene_from_string(
        floor_scene("LightSource \"distant\" \"point3 from\" [0 1 1] \"point3 to\" [0 0 0] "
                    "\"rgb L\" [2 2 2]\n"));
    WhittedIntegrator w(*scene);
    Rgb expected = kFloorAlbedo * kInvPi * Rgb(2.f) * (1.f / std::sqrt(2.f));
    for (uint32_t px : {0u, 9u, 16u, 31u})
        for (uint32_t py : {2u, 16u, 30u}) {
            Sample s = w.evaluate(sample_at(px, py));
            INFO("pixel " << px << "," << py << " got " << rgb_str(s.radiance));
            CHECK(rgb_near(s.radiance, expected));
        }
}

namespace {

/// A small one-sided triangle emitter (L = 10, area 0.02) facing down at height 2 above the
/// floor, with `extra` shape parameters. Returns, for three floor pixels, Whitted's radiance
/// next to the point-like-emitter value at its centroid, E = L A cos_l cos_s / d^2; checks that
/// each pixel sees the floor, and that the emitter is shape 0 when `visible`.
std::vector<std::pair<Rgb, Rgb>> small_triangle_light(const std::string &extra, bool visible) {
    auto scene =
        scene_from_string(floor_scene("AttributeBegin\n"
                                      "AreaLightSource \"diffuse\" \"rgb L\" [10 10 10]\n"
                                      "Shape \"trianglemesh\" \"point3 P\" [0 2 0  0.2 2 0  0 2 "
                                      "0.2] \"integer indices\" [0 1 2] " +
                                      extra + "\nAttributeEnd\n"));
    WhittedIntegrator w(*scene);
    const Vec3f c{0.2f / 3, 2.f, 0.2f / 3};
    const float area = 0.02f;
    std::vector<std::pair<Rgb, Rgb>> out;
    for (uint32_t px : {3u, 16u, 27u}) {
        Sample s = w.evaluate(sample_at(px, 10));
        REQUIRE(s.first_hit);
        Vec3f p = s.first_hit->primary.position;
        REQUIRE(std::abs(p.y) < 1e-5f);  // the floor, not the emitter
        if (visible) CHECK(s.first_hit->primary.object_id == 1);  // the emitter is shape 0
        Vec3f d = c - p;
        float d2 = length_squared(d);
        float cos_l = d.y / std::sqrt(d2);  // the emitter faces down: |n_l . wi| = wi.y
        out.push_back({s.radiance,
                       kFloorAlbedo * kInvPi * Rgb(10.f) * (area * cos_l * cos_l / d2)});
    }
    return out;
}

}  // namespace

TEST_CASE("whitted: triangle area light as a point-like emitter at its centroid") {
    for (const auto &r : small_triangle_light("", true)) {
        const Rgb &got = r.first, &expected = r.second;  // (clang: no bindings in INFO)
        INFO("got " << rgb_str(got) << " expected " << rgb_str(expected));
        CHECK(rgb_near(got, expected, 1e-4f));
    }
}

TEST_CASE("whitted: an invisible (alpha 0) emitter lights as its light sample says") {
    // pbrt-v4 makes the emitter sample-only; Whitted reaches it through sample_li at u = (0.5,
    // 0.5) and must divide the radiance by that sample's solid-angle pdf: for this small, far
    // triangle that is close to the centroid formula of the visible case.
    for (const auto &r : small_triangle_light("\"float alpha\" 0", false)) {
        const Rgb &got = r.first, &expected = r.second;
        INFO("got " << rgb_str(got) << " expected " << rgb_str(expected));
        CHECK(got.g == test::Approx(expected.g).epsilon(0.05));
    }
}

TEST_CASE("whitted: shadow bits are set exactly behind occluders") {
    // Light 0: point light at (0, 4, 0); light 1: distant light from straight above. A square
    // [-0.5, 0.5]^2 at y = 2 shadows |x|,|z| < 1 from light 0 and < 0.5 from light 1.
    std::string lights =
        "LightSource \"point\" \"point3 from\" [0 4 0] \"rgb I\" [4 4 4]\n"
        "LightSource \"distant\" \"point3 from\" [0 1 0] \"point3 to\" [0 0 0] \"rgb L\" [1 1 1]\n";
    std::string occluder =
        "AttributeBegin\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.2 0.2 0.2]\n"
        "Shape \"trianglemesh\" \"point3 P\" [-0.5 2 -0.5  0.5 2 -0.5  0.5 2 0.5  -0.5 2 0.5]\n"
        "    \"integer indices\" [0 1 2 0 2 3]\n"
        "AttributeEnd\n";
    // Seen from the side so that the occluder hides little of its shadow.
    std::string camera = "LookAt 0 4 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [50]\n";
    auto scene = scene_from_string(floor_scene(lights, occluder, camera, 48));
    WhittedIntegrator w(*scene);
    int in0 = 0, in1 = 0, lit = 0, checked = 0;
    for (uint32_t py = 0; py < 48; ++py)
        for (uint32_t px = 0; px < 48; ++px) {
            Sample s = w.evaluate(sample_at(px, py));
            REQUIRE(s.first_hit);
            const SurfaceAttributes &a = s.first_hit->primary;
            if (a.object_id != 0) {
                // The occluder's top is lit by both lights.
                if (a.object_id == 1 && a.normal.y > 0.5f)
                    CHECK(a.shadow_bits == 0);
                continue;
            }
            float x = std::abs(a.position.x), z = std::abs(a.position.z);
            auto near_edge = [](float v, float e) { return std::abs(v - e) < 2e-3f; };
            if (near_edge(x, 1.f) || near_edge(z, 1.f) || near_edge(x, 0.5f) || near_edge(z, 0.5f))
                continue;
            uint32_t expected = 0;
            if (x < 1.f && z < 1.f)
                expected |= 1u, ++in0;
            if (x < 0.5f && z < 0.5f)
                expected |= 2u, ++in1;
            if (!expected)
                ++lit;
            ++checked;
            INFO("pixel " << px << "," << py << " p = (" << a.position.x << ", " << a.position.z
                          << ")");
            CHECK(a.shadow_bits == expected);
            // Radiance: the unblocked lights only.
            Rgb e(0.f);
            if (!(expected & 1u))
                e += floor_point_radiance(a.position, {0, 4, 0}, Rgb(4.f));
            if (!(expected & 2u))
                e += kFloorAlbedo * kInvPi;
            CHECK(rgb_near(s.radiance, e));
        }
    CHECK(in0 > 20);
    CHECK(in1 > 5);
    CHECK(lit > 100);
    CHECK(checked > 500);
}

TEST_CASE("whitted: a mirror reflects the wall it sees, weighted by the conductor Fresnel") {
    // Mirror floor (object 0), diffuse wall at z = -3 (object 1) lit by a point light.
    const char *text = R"(
LookAt 0 1 4  0 0 0  0 1 0
Camera "perspective" "float fov" [30]
Film "rgb" "integer xresolution" [21] "integer yresolution" [21]
WorldBegin
LightSource "point" "point3 from" [0 2 2] "rgb I" [6 6 6]
AttributeBegin
  Material "conductor" "rgb reflectance" [0.9 0.8 0.7] "float roughness" [0]
  Shape "trianglemesh" "point3 P" [-30 0 -30  30 0 -30  30 0 30  -30 0 30]
      "integer indices" [0 1 2 0 2 3]
AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.6 0.5 0.4]
  Shape "trianglemesh" "point3 P" [-30 -1 -3  30 -1 -3  30 30 -3  -30 30 -3]
      "integer indices" [0 1 2 0 2 3]
AttributeEnd
)";
    auto scene = scene_from_string(text);
    WhittedIntegrator w(*scene);
    const Rgb k = conductor_k_from_reflectance(Rgb(0.9f, 0.8f, 0.7f));
    int mirrored = 0;
    for (uint32_t py = 10; py < 21; py += 2)
        for (uint32_t px = 0; px < 21; px += 4) {
            Sample s = w.evaluate(sample_at(px, py));
            REQUIRE(s.first_hit);
            const HitAttributes &h = *s.first_hit;
            if (h.primary.object_id != 0)
                continue;
            ++mirrored;
            CHECK(h.secondary.object_id == 1);
            CHECK(scene->geometry->object_material(1) ==
                  scene->geometry->object_material(h.secondary.object_id));
            CHECK(h.local_color.is_black());  // a smooth mirror has no diffuse part
            // Fresnel at the mirror for the camera ray.
            Vec3f wo = normalize(Vec3f(0, 1, 4) - h.primary.position);
            float cos_o = dot(wo, Vec3f(0, 1, 0));
            Rgb F = fr_complex(cos_o, Rgb(1.f), k);
            // The wall's radiance at the reflected hit (diffuse: the same seen directly).
            Vec3f q = h.secondary.position;
            CHECK(std::abs(q.z + 3.f) < 1e-4f);
            Vec3f d = Vec3f(0, 2, 2) - q;
            float r2 = length_squared(d);
            Rgb wall = Rgb(0.6f, 0.5f, 0.4f) * kInvPi * Rgb(6.f) * (d.z / std::sqrt(r2) / r2);
            INFO("got " << rgb_str(h.global_color) << " expected " << rgb_str(F * wall));
            CHECK(rgb_near(h.global_color, F * wall, 2e-4f));
            CHECK(rgb_near(s.radiance, h.global_color, 1e-6f));
            // Rays: primary, reflection, the wall's shadow ray.
            CHECK(s.rays == 3);
        }
    CHECK(mirrored > 10);
}

TEST_CASE("whitted: glass sphere refracts to the backdrop; TIR inside glass reflects fully") {
    SUBCASE("refraction at normal incidence") {
        // Camera on the axis of a glass ball (object 0) in front of a diffuse wall (object 1)
        // lit by a distant light whose shadow of the ball falls elsewhere.
        const char *text = R"(
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" [30]
Film "rgb" "integer xresolution" [9] "integer yresolution" [9]
WorldBegin
LightSource "distant" "point3 from" [1 1 1] "point3 to" [0 0 0] "rgb L" [3 3 3]
AttributeBegin
  Material "dielectric" "float eta" [1.5]
  Shape "sphere" "float radius" [1]
AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
  Shape "trianglemesh" "point3 P" [-30 -30 -3  30 -30 -3  30 30 -3  -30 30 -3]
      "integer indices" [0 1 2 0 2 3]
AttributeEnd
)";
        auto scene = scene_from_string(text);
        WhittedIntegrator w(*scene);
        Sample s = w.evaluate(sample_at(4, 4));
        REQUIRE(s.first_hit);
        const HitAttributes &h = *s.first_hit;
        CHECK(h.primary.object_id == 0);
        // The refraction (T = 0.96) is stronger than the reflection (R = 0.04).
        CHECK(h.secondary.object_id == 0);
        CHECK(length(h.secondary.position - Vec3f(0, 0, -1)) < 1e-3f);
        const float R = 0.04f;
        float wall = 0.5f * kInvPi * 3.f / std::sqrt(3.f);
        // In and out at normal incidence: (1-R)/1.5^2 * (1-R)*1.5^2, plus one internal round
        // trip (R^2) within depth 5 (enter 1, exit 2; back 2, front 3, back 4 -> wall).
        float expected = wall * sqr(1.f - R) * (1.f + R * R);
        INFO("got " << rgb_str(s.radiance) << " expected " << expected);
        CHECK(rgb_near(s.radiance, Rgb(expected), 1e-3f));
        CHECK(rgb_near(h.global_color, s.radiance, 1e-6f));
        CHECK(h.local_color.is_black());
        // Outside the ball the camera sees the wall directly.
        Sample wall_px = w.evaluate(sample_at(0, 0, 0.f, 0.f));
        REQUIRE(wall_px.first_hit);
        CHECK(wall_px.first_hit->primary.object_id == 1);
        CHECK(wall_px.first_hit->secondary.object_id == -1);
    }
    SUBCASE("total internal reflection") {
        // The camera sits inside a big glass ball and looks at its wall at 64 degrees from the
        // normal (beyond the critical angle of 41.8): everything reflects, nothing refracts.
        const char *text = R"(
LookAt 0 9 0  1 9 0  0 1 0
Camera "perspective" "float fov" [20]
Film "rgb" "integer xresolution" [5] "integer yresolution" [5]
WorldBegin
LightSource "point" "point3 from" [2 5 0] "rgb I" [3 3 3]
AttributeBegin
  Material "dielectric" "float eta" [1.5]
  Shape "sphere" "float radius" [10]
AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.7 0.7 0.7]
  Translate 7.46 5.08 0
  Shape "sphere" "float radius" [0.6]
AttributeEnd
)";
        auto scene = scene_from_string(text);
        WhittedIntegrator w(*scene);
        Sample s = w.evaluate(sample_at(2, 2));
        REQUIRE(s.first_hit);
        const HitAttributes &h = *s.first_hit;
        CHECK(h.primary.object_id == 0);
        CHECK(h.secondary.object_id == 1);
        // primary + the one reflection (no refraction ray) + the small ball's shadow ray
        CHECK(s.rays == 3);
        Vec3f q = h.secondary.position;
        Vec3f d = Vec3f(2, 5, 0) - q;
        float r2 = length_squared(d);
        Vec3f n = normalize(q - Vec3f(7.46f, 5.08f, 0));
        Rgb ball = Rgb(0.7f) * kInvPi * Rgb(3.f) * (std::max(0.f, dot(n, d)) / std::sqrt(r2) / r2);
        REQUIRE(ball.max_value() > 0.f);
        // R = 1 exactly under TIR.
        CHECK(rgb_near(h.global_color, ball, 1e-4f));
    }
}

TEST_CASE("whitted: max_depth bounds the specular recursion (rays counted)") {
    // Two parallel mirrors facing each other; the centre ray bounces between them.
    const char *text = R"(
LookAt 0 0 1  0 0 0  0 1 0
Camera "perspective" "float fov" [30]
Film "rgb" "integer xresolution" [5] "integer yresolution" [5]
WorldBegin
LightSource "point" "point3 from" [0 0.5 1] "rgb I" [1 1 1]
Material "conductor" "rgb reflectance" [0.9 0.9 0.9]
Shape "trianglemesh" "point3 P" [-100 -100 0  100 -100 0  100 100 0  -100 100 0]
    "integer indices" [0 1 2 0 2 3]
Shape "trianglemesh" "point3 P" [-100 -100 2  100 -100 2  100 100 2  -100 100 2]
    "integer indices" [0 2 1 0 3 2]
)";
    auto scene = scene_from_string(text);
    for (int depth : {0, 1, 2, 5, 9}) {
        WhittedOptions o;
        o.max_depth = depth;
        WhittedIntegrator w(*scene, o);
        Sample s = w.evaluate(sample_at(2, 2));
        INFO("max_depth " << depth);
        CHECK(s.rays == uint32_t(1 + depth));
        REQUIRE(s.first_hit);
        CHECK(s.first_hit->primary.object_id == 0);
        if (depth > 0)
            CHECK(s.first_hit->secondary.object_id == 1);
        else
            CHECK(s.first_hit->secondary.object_id == -1);
    }
}

TEST_CASE("whitted: shade(first_hit) reproduces evaluate's radiance at every pixel") {
    auto scene = scene_from_string(kKitchenSink);
    WhittedIntegrator w(*scene);
    CHECK(w.provides_attributes());
    int hits = 0, misses = 0, textured = 0, shadowed = 0, specular = 0;
    for (uint32_t py = 0; py < 24; ++py)
        for (uint32_t px = 0; px < 24; ++px)
            for (float f : {0.5f, 0.13f}) {
                Sample s = w.evaluate(sample_at(px, py, f, 1.f - f));
                REQUIRE(s.first_hit);
                const HitAttributes &h = *s.first_hit;
                if (h.primary.hit()) {
                    ++hits;
                    CHECK(std::abs(length(h.primary.normal) - 1.f) < 1e-5f);
                } else {
                    ++misses;
                    CHECK(std::abs(length(h.primary.position) - 1.f) < 1e-5f);
                }
                textured += h.primary.has_texture;
                shadowed += h.primary.shadow_bits != 0;
                specular += h.secondary.object_id >= 0;
                Rgb sum = h.local_color + h.global_color;
                CHECK(same_bits(sum, s.radiance));
                Rgb r = w.shade(h);
                INFO("pixel " << px << "," << py << " object " << h.primary.object_id
                              << " radiance " << rgb_str(s.radiance) << " shade " << rgb_str(r));
                CHECK(rgb_near(r, s.radiance, 1e-5f, 1e-7f));
            }
    CHECK(hits > 500);
    CHECK(misses > 0);
    CHECK(textured > 50);
    CHECK(shadowed > 20);
    CHECK(specular > 100);
}

TEST_CASE("whitted: shade() of Lambertian materials is bit-identical without get_bsdf") {
    // The kitchen sink mixes constant diffuse, textured diffuse, metal and glass: the fast path
    // covers the first two, and every shade() must equal the general path's bit for bit,
    // including on interpolated (averaged) attribute vectors.
    auto scene = scene_from_string(kKitchenSink);
    WhittedOptions general;
    general.lambertian = false;
    WhittedIntegrator fast(*scene), slow(*scene, general);
    int checked = 0, lambert_hits = 0, textured_lambert_hits = 0;
    for (uint32_t py = 0; py < 24; ++py)
        for (uint32_t px = 0; px < 24; ++px) {
            Sample a = fast.evaluate(sample_at(px, py, 0.5f, 0.5f));
            Sample b = fast.evaluate(sample_at(px, py, 0.1f, 0.8f));
            REQUIRE(a.first_hit);
            REQUIRE(b.first_hit);
            HitAttributes mid = *a.first_hit;
            if (a.first_hit->primary.object_id == b.first_hit->primary.object_id) {
                const SurfaceAttributes &p = a.first_hit->primary, &q = b.first_hit->primary;
                mid.primary.position = (p.position + q.position) * 0.5f;
                mid.primary.normal = normalize(p.normal + q.normal);
                mid.primary.uv = (p.uv + q.uv) * 0.5f;
            }
            for (const HitAttributes *h : {&*a.first_hit, &*b.first_hit, &mid}) {
                CHECK(same_bits(fast.shade(*h), slow.shade(*h)));
                ++checked;
                const int32_t m = h->primary.hit()
                                      ? scene->geometry->object_material(h->primary.object_id)
                                      : -1;
                if (m < 0) continue;
                const Material &mat = *scene->materials[size_t(m)];
                if (mat.constant_lambertian()) ++lambert_hits;
                TextureEvalContext tc;
                tc.p = h->primary.position;
                tc.uv = h->primary.uv;
                tc.n = h->primary.normal;
                if (!mat.constant_lambertian() && mat.lambertian_at(tc)) ++textured_lambert_hits;
            }
        }
    CHECK(checked == 3 * 24 * 24);
    // The fast path really ran, on constant and on textured diffuse materials.
    CHECK(lambert_hits > 300);
    CHECK(textured_lambert_hits > 50);
}

TEST_CASE("whitted: shading the average of two neighbours on a plane equals the midpoint") {
    // Orthographic view of a flat floor with a reflectance linear in u, under a distant light:
    // hit points, uv and radiance are affine in the film position.
    const char *text = R"(
LookAt 0 5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-2 2 -2 2]
Film "rgb" "integer xresolution" [16] "integer yresolution" [16]
WorldBegin
LightSource "distant" "point3 from" [0.3 1 0.2] "point3 to" [0 0 0] "rgb L" [2 2 2]
Texture "ramp" "spectrum" "bilerp" "rgb v00" [0.1 0.2 0.3] "rgb v10" [0.9 0.6 0.3]
    "rgb v01" [0.1 0.2 0.3] "rgb v11" [0.9 0.6 0.3]
Material "diffuse" "texture reflectance" "ramp"
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5]
    "point2 uv" [0 0  1 0  1 1  0 1] "integer indices" [0 1 2 0 2 3]
)";
    auto scene = scene_from_string(text);
    WhittedIntegrator w(*scene);
    for (uint32_t py : {3u, 8u, 12u})
        for (uint32_t px : {1u, 6u, 13u}) {
            Sample a = w.evaluate(sample_at(px, py));
            Sample b = w.evaluate(sample_at(px + 2, py + 1));
            Sample mid = w.evaluate(sample_at(px + 1, py, 0.5f, 1.0f));
            REQUIRE(a.first_hit);
            REQUIRE(b.first_hit);
            REQUIRE(mid.first_hit);
            const SurfaceAttributes &pa = a.first_hit->primary, &pb = b.first_hit->primary;
            REQUIRE(pa.object_id == pb.object_id);
            CHECK(pa.has_texture);
            HitAttributes avg = *a.first_hit;
            avg.primary.position = (pa.position + pb.position) * 0.5f;
            avg.primary.normal = (pa.normal + pb.normal) * 0.5f;
            avg.primary.uv = (pa.uv + pb.uv) * 0.5f;
            avg.global_color = (a.first_hit->global_color + b.first_hit->global_color) * 0.5f;
            CHECK(pa.uv.x != test::Approx(pb.uv.x));  // the colour really varies
            Rgb r = w.shade(avg);
            INFO("shade " << rgb_str(r) << " midpoint " << rgb_str(mid.radiance));
            CHECK(rgb_near(r, mid.radiance, 1e-5f));
            CHECK(length(avg.primary.position - mid.first_hit->primary.position) < 1e-5f);
        }
}

TEST_CASE("whitted: evaluate_batch is bit-identical to evaluate (packets of 8, 5, 3, 1)") {
    auto scene = scene_from_string(kKitchenSink);
    WhittedIntegrator w(*scene);
    // Rows across the glass sphere (user geometry) and its silhouette, plus sky misses.
    std::vector<CameraSample> all;
    for (uint32_t py = 0; py < 24; ++py)
        for (uint32_t px = 0; px < 24; ++px)
            all.push_back(sample_at(px, py, 0.3f, 0.7f));
    for (size_t n : {size_t(8), size_t(5), size_t(3), size_t(1), all.size()}) {
        for (size_t start = 0; start + n <= all.size(); start += std::max<size_t>(n, 37)) {
            std::span<const CameraSample> batch(all.data() + start, n);
            std::vector<Sample> out(n);
            w.evaluate_batch(batch, out);
            for (size_t i = 0; i < n; ++i) {
                Sample single = w.evaluate(batch[i]);
                INFO("batch " << n << " start " << start << " lane " << i);
                CHECK(same_bits(out[i], single));
            }
        }
    }
    // The batch covered sphere hits and misses.
    int sphere = 0, miss = 0;
    std::vector<Sample> out(all.size());
    w.evaluate_batch(all, out);
    for (const Sample &s : out) {
        miss += !s.first_hit->primary.hit();
        sphere += s.first_hit->primary.object_id == 4;  // the glass sphere (5th shape)
    }
    CHECK(miss > 0);
    CHECK(sphere > 0);
}

TEST_CASE("whitted: object ids distinguish instances; mix picks the larger weight") {
    const char *text = R"(
LookAt 0 0 6  0 0 0  0 1 0
Camera "perspective" "float fov" [40]
Film "rgb" "integer xresolution" [32] "integer yresolution" [16]
WorldBegin
LightSource "distant" "point3 from" [0 0 1] "point3 to" [0 0 0] "rgb L" [1 1 1]
MakeNamedMaterial "a" "string type" [ "diffuse" ] "rgb reflectance" [ 0.8 0 0 ]
MakeNamedMaterial "b" "string type" [ "diffuse" ] "rgb reflectance" [ 0 0.8 0 ]
MakeNamedMaterial "mostly_a" "string type" [ "mix" ] "string materials" [ "a" "b" ]
    "float amount" [ 0.3 ]
MakeNamedMaterial "mostly_b" "string type" [ "mix" ] "string materials" [ "a" "b" ]
    "float amount" [ 0.7 ]
ObjectBegin "ball"
  NamedMaterial "mostly_a"
  Shape "sphere" "float radius" [0.8]
  NamedMaterial "mostly_b"
  Translate 0 -1.2 0
  Shape "sphere" "float radius" [0.3]
ObjectEnd
AttributeBegin
  Translate -1.5 0.3 0
  ObjectInstance "ball"
AttributeEnd
AttributeBegin
  Translate 1.5 0.3 0
  ObjectInstance "ball"
AttributeEnd
)";
    auto scene = scene_from_string(text);
    WhittedIntegrator w(*scene);
    CHECK(scene->geometry->object_count() == 4);
    // Centres of the two big balls: left and right of the image.
    Sample left = w.evaluate(sample_at(8, 7)), right = w.evaluate(sample_at(23, 7));
    REQUIRE(left.first_hit);
    REQUIRE(right.first_hit);
    int32_t l = left.first_hit->primary.object_id, r = right.first_hit->primary.object_id;
    CHECK(l >= 0);
    CHECK(r >= 0);
    CHECK(l != r);
    CHECK(scene->geometry->object_material(l) == scene->geometry->object_material(r));
    // amount 0.3 -> "a" (red) everywhere on the ball.
    CHECK(left.radiance.r > 0.1f);
    CHECK(left.radiance.g == 0.f);
    CHECK(rgb_near(w.shade(*left.first_hit), left.radiance, 1e-5f));
    // The small balls below (amount 0.7 -> "b", green) have their own ids.
    int32_t small_ids[2] = {-1, -1};
    for (uint32_t px = 0; px < 32; ++px)
        for (uint32_t py = 9; py < 16; ++py) {
            Sample s = w.evaluate(sample_at(px, py));
            int32_t id = s.first_hit->primary.object_id;
            if (id < 0 || id == l || id == r)
                continue;
            CHECK(s.radiance.r == 0.f);
            CHECK(s.radiance.g > 0.f);
            small_ids[px < 16 ? 0 : 1] = id;
        }
    CHECK(small_ids[0] >= 0);
    CHECK(small_ids[1] >= 0);
    CHECK(small_ids[0] != small_ids[1]);
    CHECK(small_ids[0] != l);
}

TEST_CASE("whitted: deterministic, and attributes can be turned off") {
    auto scene = scene_from_string(kKitchenSink);
    WhittedIntegrator w(*scene);
    WhittedOptions o;
    o.attributes = false;
    WhittedIntegrator plain(*scene, o);
    CHECK_FALSE(plain.provides_attributes());
    CHECK(w.describe().find("Whitted") != std::string::npos);
    for (uint32_t i = 0; i < 24; ++i) {
        CameraSample cs = sample_at(i, 23 - i, 0.21f, 0.87f);
        cs.index = i;
        Sample a = w.evaluate(cs), b = w.evaluate(cs);
        CHECK(same_bits(a, b));
        cs.index = 1000 + i;  // the sample index plays no role
        CHECK(same_bits(a, w.evaluate(cs)));
        Sample c = plain.evaluate(cs);
        CHECK_FALSE(c.first_hit);
        CHECK(same_bits(c.radiance, a.radiance));
        CHECK(c.rays == a.rays);
    }
    std::unique_ptr<SampleSource> f = make_whitted_integrator(*scene, WhittedOptions{});
    CHECK(f->provides_attributes());
    CHECK(f->width() == 24);
}
