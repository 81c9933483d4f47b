// "What a scene does not need costs nothing" (docs/ARCHITECTURE.md) for the real-time modes:
// the Whitted integrator collects only the attribute groups the frame plugin reads
// (PixelSampler::attributes_used) and the scene can have, and traces no shadow ray toward a
// light that cannot contribute.
//  - every plugin's frames are bit-identical with the reduced and the full (general path,
//    WhittedOptions::specialize = false) collection, on the example scenes;
//  - a point behind a one-sided area light or outside a spot cone costs no shadow ray;
//  - the real-time stats JSON reports shadow_rays, shadow_rays_avoided, attributes_collected.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "renderer/scene/specialize.h"
#include "render_test_util.h"
#include "renderer/app/realtime.h"
#include "renderer/integrators/whitted_integrator.h"
#include "sampling/pixel_sampler.h"
#include "scheduler/frame_scheduler.h"
#include "scheduler/plugin_test_util.h"

using namespace tessera;
using tessera::test::scene_from_string;

namespace {

/// Example scenes of the real-time modes, at 40 x 40 (fast, yet with edges, mirrors, textures).
std::vector<std::string> example_scenes() {
    const std::string root = std::string(TESSERA_SOURCE_DIR) + "/examples/";
    return {root + "realtime/cornell-mirror.pbrt", root + "realtime/thin-shadows.pbrt",
            root + "cornell-box/scene.pbrt", root + "textured/scene.pbrt"};
}

/// Plugin specs: every plugin, plus the options that change what jin and flip read.
const char *const kSpecs[] = {
    "fixed:spp=1",
    "fixed:spp=4",
    "jin",
    "jin:focus=1",
    "jin:tau_soid=1,tau_ssn=1,tau_ssc=1,tau_ste=1,tau_pte=1",
    "kim",
    "kim:ss=2,block=4",
    "fliptri",
    "flipquad",
    "fliptri:texture_average=1",
    "suffern",
};

/// Renders `frames` frames of `spec` with the Whitted integrator (specialised or not); returns
/// the last frame and the attribute groups collected.
sampling::FrameResult render_frames(const Scene &scene, const std::string &spec, bool specialize,
                                    uint32_t *collected, int frames = 2) {
    sampling::PluginSpec ps = sampling::parse_plugin_spec(spec);
    std::unique_ptr<sampling::PixelSampler> plugin = ps.info->make(ps.params);
    WhittedOptions wo;
    wo.max_depth = scene.settings.max_depth;
    wo.attributes = plugin->attributes_used();
    wo.specialize = specialize;
    WhittedIntegrator source(scene, wo);
    *collected = source.collected_attributes();
    sched::FrameOptions fo;
    fo.threads = 2;
    sched::FrameScheduler scheduler(fo);
    sampling::FrameResult r;
    for (int k = 0; k < frames; ++k)
        scheduler.render(*plugin, source, r);
    return r;
}

CameraSample pixel_centre(uint32_t px, uint32_t py) {
    CameraSample cs;
    cs.px = px;
    cs.py = py;
    return cs;
}

}  // namespace

TEST_CASE(
    "whitted attributes: every plugin's frames are identical with reduced and full "
    "collection") {
    SceneOverrides ov;
    ov.width = 40;
    ov.height = 40;
    int reduced = 0;
    for (const std::string &path : example_scenes()) {
        std::unique_ptr<Scene> scene = load_scene(path, ov);
        for (const char *spec : kSpecs) {
            INFO(path << " --sampler " << spec);
            uint32_t got = 0, all = 0;
            sampling::FrameResult a = render_frames(*scene, spec, true, &got);
            sampling::FrameResult b = render_frames(*scene, spec, false, &all);
            CHECK(all == kAttrAll);
            CHECK((got & ~all) == 0u);
            reduced += got != all;
            tessera::test::check_same_frame(a, b);
            CHECK(a.shadow_rays == b.shadow_rays);
            CHECK(a.shadow_rays_avoided == b.shadow_rays_avoided);
            CHECK(a.shadow_rays > 0);
            if (!scene->features.specular)
                CHECK((got & kAttrSecondary) == 0u);
            if (!scene->features.textures)
                CHECK((got & kAttrTexture) == 0u);
        }
    }
    CHECK(reduced > 20);  // the test compares something
}

TEST_CASE("whitted attributes: plugins declare what they read") {
    auto used = [](const std::string &spec) {
        sampling::PluginSpec ps = sampling::parse_plugin_spec(spec);
        return ps.info->make(ps.params)->attributes_used();
    };
    CHECK(used("fixed") == kAttrNone);
    CHECK(used("suffern") == kAttrNone);
    CHECK(used("fliptri") == kAttrNone);
    CHECK(used("fliptri:texture_average=1") == kAttrAll);
    CHECK(used("kim") == (kAttrPrimary | kAttrTexture));
    CHECK(used("jin") == kAttrAll);
    CHECK(used("jin:tau_soid=1,tau_ssn=1,tau_ssc=1,tau_ste=1") == (kAttrPrimary | kAttrTexture));
    CHECK(used("jin:tau_soid=1,tau_ssn=1,tau_ssc=1,tau_ste=1,tau_pte=1") == kAttrPrimary);
    CHECK(used("jin:tau_soid=1,tau_ssn=1,tau_ssc=1,tau_ste=1,focus=3") ==
          (kAttrPrimary | kAttrTexture | kAttrSecondary));
    CHECK(describe_attributes(kAttrNone) == "none");
    CHECK(describe_attributes(kAttrAll) == "primary+texture+secondary");
}

TEST_CASE("whitted attributes: no shadow ray behind a one-sided area light or outside a cone") {
    // A floor lit by a one-sided quad light facing down at y = 1 (over x in [-0.25, 0.25]) and
    // a spot with a 20-degree cone aimed at x = 2. Above the light's plane a second floor at
    // y = 1.5 (facing up) sees only the back of the area light; outside the spot cone the
    // spot is skipped. The camera looks straight down.
    const char *text = R"(
LookAt 0 6 0   0 0 0   0 0 -1
Camera "orthographic" "float screenwindow" [ -4 4 -4 4 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
WorldBegin
LightSource "spot" "point3 from" [ 2 3 0 ] "point3 to" [ 2 0 0 ] "rgb I" [ 4 4 4 ]
    "float coneangle" [ 20 ] "float conedeltaangle" [ 5 ]
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 4 4 4 ]
  Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
      "point3 P" [ -0.25 1 -0.25  0.25 1 -0.25  0.25 1 0.25  -0.25 1 0.25 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
    "point3 P" [ -4 0 -4  -4 0 4  4 0 4  4 0 -4 ]
Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
    "point3 P" [ -4 1.5 -4  -4 1.5 -1  -1 1.5 -1  -1 1.5 -4 ]
)";
    auto scene = scene_from_string(text);
    WhittedIntegrator w(*scene);
    // The spot, then one light per triangle of the quad.
    const uint32_t lights = uint32_t(scene->lights.size());
    REQUIRE(lights == 3u);
    uint32_t behind = 0, outside = 0, both_traced = 0;
    for (uint32_t py = 0; py < 16; ++py)
        for (uint32_t px = 0; px < 16; ++px) {
            Sample s = w.evaluate(pixel_centre(px, py));
            REQUIRE(s.first_hit);
            const SurfaceAttributes &a = s.first_hit->primary;
            if (!a.hit() || a.object_id == 0)
                continue;  // the light itself
            INFO("pixel " << px << "," << py << " at " << a.position.x << "," << a.position.y << ","
                          << a.position.z << " rays " << s.rays);
            // Traced + avoided covers every light; every ray is the primary or a shadow ray.
            CHECK(s.shadow_rays + s.shadow_rays_avoided == lights);
            CHECK(s.rays == 1u + s.shadow_rays);
            const Vec3f p = a.position;
            const float dx = p.x - 2.f;
            const float cos_spot = 3.f / std::sqrt(dx * dx + p.z * p.z + 9.f);
            const bool in_cone = p.y < 0.5f && cos_spot > std::cos(radians(20.f)) - 1e-4f;
            if (p.y > 1.2f) {
                // The upper floor: above the one-sided light (its back, and below the surface)
                // and outside the spot's cone (which misses x < -1): no shadow ray at all.
                ++behind;
                CHECK(s.shadow_rays == 0u);
                CHECK(s.rays == 1u);
                CHECK(a.shadow_bits == 0u);
            } else if (!in_cone) {
                ++outside;
                CHECK(s.shadow_rays == lights - 1);  // the area light's triangles only
                CHECK(s.rays == lights);
            } else {
                ++both_traced;
            }
        }
    CHECK(behind > 0);
    CHECK(outside > 0);
    CHECK(both_traced > 0);
}

TEST_CASE("whitted attributes: the real-time stats report shadow rays and attributes") {
    namespace fs = std::filesystem;
    const fs::path out = fs::path(TESSERA_TEST_OUTPUT_DIR) / "whitted_attributes";
    fs::create_directories(out);
    for (bool specialize : {true, false}) {
        RenderOptions opt;
        opt.scene = std::string(TESSERA_SOURCE_DIR) + "/examples/cornell-box/scene.pbrt";
        opt.overrides.width = 32;
        opt.overrides.height = 32;
        opt.frames = 2;
        opt.threads = 1;
        opt.quiet = true;
        opt.write_png = false;
        opt.no_specialize = specialize ? 0u : uint32_t(kSpecAll);
        opt.stats_path = (out / (specialize ? "stats.json" : "stats_general.json")).string();
        std::unique_ptr<Scene> scene = load_scene(opt.scene, opt.overrides);
        SamplerSpec sampler;
        sampler.name = "fixed";
        sampler.plugin = sampling::parse_plugin_spec("fixed:spp=1");
        RenderReport rep;
        run_frames(opt, *scene, sampler, (out / "frame.exr").string(), "", nullptr, nullptr, rep);
        std::ifstream f(opt.stats_path);
        REQUIRE(f);
        nlohmann::json j = nlohmann::json::parse(f);
        INFO(j.dump());
        REQUIRE(j.contains("shadow_rays"));
        REQUIRE(j.contains("shadow_rays_avoided"));
        REQUIRE(j.contains("attributes_collected"));
        // The Cornell box's light is on the ceiling: the ceiling and the light's own surround
        // are behind it, so shadow rays are avoided.
        CHECK(j["shadow_rays_avoided"].get<uint64_t>() > 0);
        CHECK(j["shadow_rays"].get<uint64_t>() > 0);
        CHECK(j["attributes_collected"].get<std::string>() ==
              (specialize ? "none" : "primary+texture+secondary"));
    }
}
