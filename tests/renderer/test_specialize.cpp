// Specialised code paths (renderer/scene/specialize.h): which ones a scene gets, and that
// each gives exactly the image of the general path while skipping work.
#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>

#include "render_test_util.h"
#include "renderer/integrators/path_integrator.h"
#include "renderer/scene/specialize.h"
#include "scheduler/adaptive_scheduler.h"
#include "scheduler/camera_sample.h"

using namespace tessera;
using namespace tessera::test;

namespace {

struct Rendered {
    std::vector<float> rgb;
    sched::AdaptiveStats stats;
};

/// Uniform render of `scene` with the path tracer, the specialisations in `disabled` forced
/// onto the general path.
Rendered render_with(const Scene &scene, uint32_t disabled) {
    PathIntegrator integrator(scene, scene.settings.seed, scene.settings.max_depth,
                              DirectStrategy::Mis, disabled);
    CHECK((integrator.specializations() & disabled) == 0);
    sampling::Film film(uint32_t(scene.settings.width), uint32_t(scene.settings.height));
    SamplerSpec uniform;
    uniform.name = "uniform";
    sched::AdaptiveOptions o = scheduler_options(scene, uniform, 2, true);
    sched::AdaptiveScheduler scheduler(integrator, film, o);
    Rendered r;
    r.stats = scheduler.render();
    r.rgb = film.beauty_rgb();
    return r;
}

std::unique_ptr<Scene> example(const std::string &rel, uint32_t no_specialize = 0, int size = 24,
                               int spp = 4) {
    SceneOverrides ov;
    ov.no_specialize = no_specialize;
    ov.width = size;
    ov.height = size;
    ov.spp = spp;
    return load_scene(std::string(TESSERA_SOURCE_DIR) + "/examples/" + rel, ov);
}

/// Equal up to a last-bit difference in a hit (relative 1e-5): what a sample traced through
/// Embree's packet kernels may differ by from one traced through its single-ray kernel.
bool near_equal(float a, float e) { return a == e || std::abs(a - e) <= 1e-5f * (1.f + std::abs(e)); }

/// Bit-identical float images (NaN never expected).
bool identical(const std::vector<float> &a, const std::vector<float> &b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i)
        if (a[i] != b[i]) return false;
    return true;
}

/// How evaluate_batch and evaluate (trace_impl) compared, sample by sample.
struct PacketComparison {
    size_t compared = 0, lit = 0, bounced = 0, exact = 0;
};

/// Each batch through evaluate_batch, each sample checked against evaluate(): values, AOVs and
/// ray counts.
PacketComparison compare_batches(const PathIntegrator &integrator,
                                 const std::vector<std::vector<CameraSample>> &batches) {
    PacketComparison c;
    for (const auto &batch : batches) {
        std::vector<Sample> out(batch.size());
        integrator.evaluate_batch(batch, out);
        for (size_t i = 0; i < batch.size(); ++i) {
            const Sample one = integrator.evaluate(batch[i]);
            const Sample &b = out[i];
            CAPTURE(batch[i].px);
            CAPTURE(batch[i].py);
            CAPTURE(batch[i].index);
            // Embree's packet and single-ray kernels may round a hit differently on another
            // CPU; a lane mix-up or a wrong dimension differs by far more.
            for (int k = 0; k < 3; ++k) {
                CHECK(near_equal(b.radiance[k], one.radiance[k]));
                CHECK(near_equal(b.albedo[k], one.albedo[k]));
                CHECK(near_equal(b.normal[k], one.normal[k]));
            }
            CHECK(near_equal(b.depth, one.depth));
            CHECK(b.rays == one.rays);
            CHECK(b.shadow_rays_avoided == one.shadow_rays_avoided);
            ++c.compared;
            c.exact += b.radiance[0] == one.radiance[0] && b.radiance[1] == one.radiance[1] &&
                       b.radiance[2] == one.radiance[2] && b.depth == one.depth;
            c.lit += one.radiance.max_value() > 0.f;
            c.bounced += one.rays > 3;
        }
    }
    return c;
}

/// The packet kernel against the scalar path (compare_batches): batches of one pixel's 37
/// samples (lanes refilled as paths end), rows of different pixels, and batches of 2 and 3.
PacketComparison compare_packet_to_scalar(const Scene &scene, DirectStrategy strategy) {
    PathIntegrator packet(scene, 11, scene.settings.max_depth, strategy);
    REQUIRE((packet.specializations() & kSpecPacket) != 0);
    const uint32_t w = packet.width(), h = packet.height();
    const sampling::SamplePattern pattern = scene.settings.sample_pattern;
    auto camera_sample = [&](uint32_t seed, uint32_t x, uint32_t y, uint32_t i) {
        return sched::camera_sample(seed, x, y, i, pattern);
    };
    std::vector<std::vector<CameraSample>> batches;
    for (uint32_t y = 0; y < h; y += 3)
        for (uint32_t x = 0; x < w; x += 3) {
            std::vector<CameraSample> one_pixel;
            for (uint32_t i = 0; i < 37; ++i)
                one_pixel.push_back(camera_sample(5, x, y, i));
            batches.push_back(one_pixel);
        }
    for (uint32_t y = 0; y < h; ++y) {
        std::vector<CameraSample> row;
        for (uint32_t x = 0; x < w; ++x)
            row.push_back(camera_sample(5, x, y, x % 5));
        batches.push_back(row);
    }
    batches.push_back({camera_sample(5, 3, 4, 0), camera_sample(5, 3, 4, 1)});
    batches.push_back({camera_sample(5, 9, 2, 7), camera_sample(5, 1, 1, 2),
                       camera_sample(5, 15, 11, 3)});
    return compare_batches(packet, batches);
}

}  // namespace

TEST_CASE("--no-specialize names parse, and bad ones are errors naming the valid ones") {
    CHECK(parse_specializations("all") == kSpecAll);
    CHECK(parse_specializations("lambertian") == kSpecLambertian);
    CHECK(parse_specializations("cull,differentials") == (kSpecCull | kSpecDifferentials));
    CHECK(specialization_names(kSpecLambertian | kSpecCull) == "lambertian,cull");
    CHECK(specialization_names(0) == "none");
    try {
        parse_specializations("lambertian,bogus");
        FAIL("no exception");
    } catch (const std::invalid_argument &e) {
        std::string m = e.what();
        CHECK(m.find("\"bogus\"") != std::string::npos);
        CHECK(m.find("differentials") != std::string::npos);
    }
    CHECK_THROWS_AS(parse_specializations(""), std::invalid_argument);
}

TEST_CASE("a scene gets exactly the specialisations whose property it has") {
    // Diffuse-only, untextured, one area light: all three.
    CHECK(applicable_specializations(*example("specialize/diffuse-box.pbrt")) ==
          (kSpecAll & ~kSpecAttributes));
    // A checkerboard floor, glass and copper: only culling.
    CHECK(applicable_specializations(*example("cornell-box/scene.pbrt")) ==
          (kSpecCull | kSpecAlpha));
    const std::string head = tiny_lit_scene_header(4, 4);
    const std::string quad = "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ]"
                             " \"integer indices\" [ 0 1 2  0 2 3 ]\n";
    // A textured diffuse material: neither differentials nor lambertian.
    auto textured = scene_from_string(
        head + "Texture \"c\" \"spectrum\" \"checkerboard\"\nMaterial \"diffuse\" \"texture "
               "reflectance\" \"c\"\n" + quad);
    CHECK(applicable_specializations(*textured) == (kSpecCull | kSpecAlpha));
    // A constant diffuse with a bump map: textured (no differentials skipping), not lambertian.
    auto bumped = scene_from_string(
        head + "Texture \"b\" \"float\" \"checkerboard\"\nMaterial \"diffuse\" \"texture "
               "displacement\" \"b\"\n" + quad);
    CHECK(applicable_specializations(*bumped) == (kSpecCull | kSpecAlpha));
    // A smooth conductor: untextured, not lambertian.
    auto metal = scene_from_string(head + "Material \"conductor\"\n" + quad);
    CHECK(applicable_specializations(*metal) == (kSpecCull | kSpecDifferentials | kSpecAlpha));
    // No light: nothing to cull.
    auto dark = scene_from_string(
        "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\"\nFilm \"rgb\" \"integer "
        "xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\nWorldBegin\n" + quad);
    CHECK(applicable_specializations(*dark) ==
          (kSpecLambertian | kSpecDifferentials | kSpecAlpha | kSpecPacket));
    // Only an alpha-tested mesh (and no light): no opaque mesh to spare the filter.
    auto cutout = scene_from_string(
        "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\"\nFilm \"rgb\" \"integer "
        "xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\nWorldBegin\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ]"
        " \"integer indices\" [ 0 1 2  0 2 3 ] \"float alpha\" [ 0.5 ]\n");
    CHECK(applicable_specializations(*cutout) == (kSpecLambertian | kSpecDifferentials));
}

TEST_CASE("every specialisation renders the general path's image bit for bit") {
    // Each example scene, specialised against each specialisation forced off and against the
    // general path: identical beauty, identical sample counts.
    for (const char *rel : {"specialize/diffuse-box.pbrt", "cornell-box/scene.pbrt",
                            "environment/scene.pbrt", "glossy-glass/scene.pbrt"}) {
        CAPTURE(rel);
        // The packet kernel traces every ray as an Embree packet, whose rounding may differ
        // from the single-ray kernel's in the last bit on some CPUs: it has its own tests
        // below; here it is off on both sides.
        auto scene = example(rel);
        const uint32_t applicable = applicable_specializations(*scene);
        Rendered spec = render_with(*scene, kSpecPacket);
        for (uint32_t disabled : {uint32_t(kSpecAll), uint32_t(kSpecDifferentials),
                                  uint32_t(kSpecLambertian), uint32_t(kSpecCull),
                                  uint32_t(kSpecAlpha)}) {
            CAPTURE(disabled);
            // The alpha specialisation is chosen where the scene is built.
            auto general_scene = example(rel, disabled);
            Rendered general = render_with(*general_scene, disabled | kSpecPacket);
            CHECK(general.stats.samples == spec.stats.samples);
            CHECK(identical(general.rgb, spec.rgb));
            if (disabled & applicable & kSpecCull) {
                // The general path traces the shadow rays culling avoids (those with a light
                // sample to aim at) and no others.
                CHECK(general.stats.rays > spec.stats.rays);
                CHECK(general.stats.rays - spec.stats.rays ==
                      spec.stats.shadow_rays_avoided - general.stats.shadow_rays_avoided);
            } else {
                CHECK(general.stats.rays == spec.stats.rays);
            }
        }
    }
}

TEST_CASE("a light behind every shading point costs no shadow ray") {
    // A point light below a floor seen from above: every light sample has a zero BSDF value
    // (the light is under the surface), so no shadow ray is traced and the image is black.
    auto scene = scene_from_string(
        "LookAt 0 3 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" [ 30 ]\n"
        "Film \"rgb\" \"integer xresolution\" [ 8 ] \"integer yresolution\" [ 8 ]\n"
        "Sampler \"zsobol\" \"integer pixelsamples\" [ 4 ]\n"
        "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
        "LightSource \"point\" \"point3 from\" [ 0 -1 0 ] \"rgb I\" [ 10 10 10 ]\n"
        "Material \"diffuse\"\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -9 0 -9  9 0 -9  9 0 9  -9 0 9 ]"
        " \"integer indices\" [ 0 1 2  0 2 3 ]\n");
    Rendered spec = render_with(*scene, 0);
    Rendered general = render_with(*scene, kSpecCull);
    const uint64_t samples = 8 * 8 * 4;
    REQUIRE(spec.stats.samples == samples);
    // Specialised: one camera ray and one (BSDF-sampled, escaping) continuation per sample at
    // most; every light sample avoided.
    CHECK(spec.stats.shadow_rays_avoided == samples);
    CHECK(general.stats.shadow_rays_avoided == 0);
    CHECK(general.stats.rays == spec.stats.rays + samples);
    CHECK(identical(general.rgb, spec.rgb));
    for (float v : spec.rgb) CHECK(v == 0.f);
}

TEST_CASE("a spot light never costs a shadow ray outside its cone") {
    // A narrow spot aimed at the floor's centre: points outside the cone get no shadow ray;
    // the number avoided is the number of light samples outside the cone (all but the spot's
    // disc), and the image equals the general path's.
    auto scene = scene_from_string(
        "LookAt 0 5 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" [ 60 ]\n"
        "Film \"rgb\" \"integer xresolution\" [ 16 ] \"integer yresolution\" [ 16 ]\n"
        "Sampler \"zsobol\" \"integer pixelsamples\" [ 4 ]\n"
        "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nWorldBegin\n"
        "LightSource \"spot\" \"point3 from\" [ 0 2 0 ] \"point3 to\" [ 0 0 0 ]"
        " \"float coneangle\" [ 10 ] \"float conedeltaangle\" [ 2 ] \"rgb I\" [ 10 10 10 ]\n"
        "Material \"diffuse\"\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -9 0 -9  9 0 -9  9 0 9  -9 0 9 ]"
        " \"integer indices\" [ 0 1 2  0 2 3 ]\n");
    Rendered spec = render_with(*scene, 0);
    Rendered general = render_with(*scene, kSpecCull);
    CHECK(identical(general.rgb, spec.rgb));
    // Most of the floor lies outside a 10-degree cone seen from 2 units up. The spot's light
    // sample itself carries nothing there, so even the general path has no ray to trace.
    CHECK(spec.stats.shadow_rays_avoided > spec.stats.samples / 2);
    CHECK(spec.stats.shadow_rays_avoided < spec.stats.samples);
    CHECK(general.stats.shadow_rays_avoided == spec.stats.shadow_rays_avoided);
    CHECK(general.stats.rays == spec.stats.rays);
    // Rays = camera rays + BSDF continuations + shadow rays: the lit disc's samples.
    CHECK(spec.stats.rays - spec.stats.samples * 2 ==
          spec.stats.samples - spec.stats.shadow_rays_avoided);
}

TEST_CASE("the path tracer's camera-ray packets give every sample its own value") {
    // evaluate_batch traces up to 8 camera rays as one Embree packet and continues each path
    // alone; every sample must come out as evaluate() gives it. Batches of 13 (a packet and a
    // remainder of 5), of 1, and rows of different pixels (rays that diverge, some escaping
    // the scene), on scenes with textures (ray differentials), glass and an environment.
    for (const char *rel : {"cornell-box/scene.pbrt", "glossy-glass/scene.pbrt",
                            "environment/scene.pbrt", "textured/scene.pbrt"}) {
        CAPTURE(rel);
        auto scene = example(rel);
        PathIntegrator integrator(*scene, 7, scene->settings.max_depth);
        const uint32_t w = uint32_t(scene->settings.width), h = uint32_t(scene->settings.height);
        std::vector<std::vector<CameraSample>> batches;
        for (uint32_t y = 0; y < h; y += 5)
            for (uint32_t x = 0; x < w; x += 7) {
                std::vector<CameraSample> one_pixel;
                for (uint32_t i = 0; i < 13; ++i)
                    one_pixel.push_back(sched::camera_sample(3, x, y, i));
                batches.push_back(one_pixel);
            }
        for (uint32_t y = 0; y < h; y += 3) {
            std::vector<CameraSample> row;
            for (uint32_t x = 0; x < w; ++x) row.push_back(sched::camera_sample(3, x, y, x % 4));
            batches.push_back(row);
        }
        batches.push_back({sched::camera_sample(3, w / 2, h / 2, 5)});
        const PacketComparison c = compare_batches(integrator, batches);
        CHECK(c.compared > 200);
        CHECK(c.lit > c.compared / 4);  // the comparison is not between black samples
    }
}

TEST_CASE("the packet kernel gives every sample the scalar path's value") {
    // Every feature the packet kernel handles, in one meshes-only Lambertian scene: an area
    // light (one-sided quad), an invisible (alpha 0, sample-only: delta to MIS) triangle
    // emitter, a point light, a distant light and a uniform environment (all
    // four light kinds: points, directions, escapes); shading normals and uvs on the floor; a
    // ReverseOrientation wall; a black material (no light sample, no continuation). Batches of
    // one pixel's 37 samples (lanes refilled
    // as paths end), rows of different pixels, and batches of 2 and 3, for each direct-lighting
    // strategy: evaluate_batch (the packet kernel) against evaluate (trace_impl), sample by
    // sample.
    const std::string scene_text =
        "LookAt 0 1.2 -3.4  0 0.8 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 50 ]\n"
        "Film \"rgb\" \"integer xresolution\" [ 16 ] \"integer yresolution\" [ 12 ]\n"
        "Sampler \"zsobol\" \"integer pixelsamples\" [ 8 ]\n"
        "Integrator \"path\" \"integer maxdepth\" [ 6 ]\nWorldBegin\n"
        "LightSource \"point\" \"point3 from\" [ 0.5 1.5 -0.5 ] \"rgb I\" [ 1 0.8 0.6 ]\n"
        "LightSource \"distant\" \"point3 from\" [ 1 3 -2 ] \"point3 to\" [ 0 0 0 ]"
        " \"rgb L\" [ 0.4 0.4 0.5 ]\n"
        "LightSource \"infinite\" \"rgb L\" [ 0.1 0.15 0.2 ]\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 4 4 4 ]\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -0.3 1.9 -0.3  0.3 1.9 -0.3  0.3 1.9 0.3  -0.3 1.9 "
        "0.3 ]"
        " \"integer indices\" [ 0 2 1  0 3 2 ]\nAttributeEnd\n"
        "Material \"diffuse\" \"rgb reflectance\" [ 0.7 0.6 0.5 ]\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -2 0 -2  2 0 -2  2 0 2  -2 0 2 ]"
        " \"normal N\" [ 0.1 1 0  -0.1 1 0  0 1 0.1  0 1 -0.1 ]"
        " \"point2 uv\" [ 0 0  3 0  3 2  0 2 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n"
        "AttributeBegin\nReverseOrientation\nMaterial \"diffuse\" \"rgb reflectance\" [ 0.2 0.5 "
        "0.8 ]\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -2 0 1.5  2 0 1.5  2 2 1.5  -2 2 1.5 ]"
        " \"integer indices\" [ 0 1 2  0 2 3 ]\nAttributeEnd\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 3 2 1 ]\n"
        "Shape \"trianglemesh\" \"point3 P\" [ 1 1.5 0.5  1.5 1.5 0.5  1.5 1.5 1 ]"
        " \"integer indices\" [ 0 2 1 ] \"float alpha\" [ 0 ]\nAttributeEnd\n"
        "AttributeBegin\nMaterial \"diffuse\" \"rgb reflectance\" [ 0 0 0 ]\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -1.8 0 -1  -1.8 0 1  -1.8 1.5 1  -1.8 1.5 -1 ]"
        " \"integer indices\" [ 0 1 2  0 2 3 ]\nAttributeEnd\n"
        "";
    auto scene = scene_from_string(scene_text);
    REQUIRE((applicable_specializations(*scene) & kSpecPacket) != 0);
    REQUIRE(scene->settings.sample_pattern == sampling::SamplePattern::Padded);
    for (DirectStrategy strategy :
         {DirectStrategy::Mis, DirectStrategy::LightOnly, DirectStrategy::BsdfOnly}) {
        CAPTURE(int(strategy));
        const PacketComparison c = compare_packet_to_scalar(*scene, strategy);
        CHECK(c.compared > 600);
        CHECK(c.lit > c.compared / 2);  // not a comparison of black samples
        CHECK(c.bounced >= 10);         // and of paths that go on past their second vertex
        CHECK(c.exact > c.compared * 9 / 10);
    }

    // Sampler "sobol": the lanes draw SamplePattern::Sobol's values (gathered matrix columns
    // of each lane's own dimension).
    const std::string zsobol = "Sampler \"zsobol\"";
    std::string sobol_text = scene_text;
    REQUIRE(sobol_text.find(zsobol) != std::string::npos);
    sobol_text.replace(sobol_text.find(zsobol), zsobol.size(), "Sampler \"sobol\"");
    auto sobol_scene = scene_from_string(sobol_text);
    REQUIRE(sobol_scene->settings.sample_pattern == sampling::SamplePattern::Sobol);
    for (DirectStrategy strategy : {DirectStrategy::Mis, DirectStrategy::BsdfOnly}) {
        CAPTURE(int(strategy));
        const PacketComparison c = compare_packet_to_scalar(*sobol_scene, strategy);
        CHECK(c.compared > 600);
        CHECK(c.lit > c.compared / 2);
        CHECK(c.bounced >= 5);
        CHECK(c.exact > c.compared * 9 / 10);
    }

    // The camera rays: generated 8 at a time for a pinhole camera (each pixel filter's
    // importance sampling, lane-parallel), by camera_ray per sample for the other cameras.
    const std::string camera = "Camera \"perspective\" \"float fov\" [ 50 ]\n";
    REQUIRE(scene_text.find(camera) != std::string::npos);
    for (const std::string &variant :
         {"PixelFilter \"box\"\n" + camera,
          "PixelFilter \"box\" \"float xradius\" 0.8 \"float yradius\" 1.3\n" + camera,
          "PixelFilter \"triangle\"\n" + camera,
          "PixelFilter \"gaussian\" \"float sigma\" 0.7 \"float xradius\" 2.5\n" + camera,
          std::string("Camera \"perspective\" \"float fov\" [ 50 ] \"float lensradius\" 0.1"
                      " \"float focaldistance\" 3\n"),
          std::string("Camera \"orthographic\"\n")}) {
        CAPTURE(variant);
        std::string text = scene_text;
        text.replace(text.find(camera), camera.size(), variant);
        auto s = scene_from_string(text);
        const PacketComparison c = compare_packet_to_scalar(*s, DirectStrategy::Mis);
        CHECK(c.compared > 600);
        CHECK(c.lit > c.compared / 2);
        CHECK(c.exact > c.compared * 9 / 10);
    }
}

TEST_CASE("the packet kernel renders the scalar path's image") {
    // Through the scheduler (a pixel's 48 samples in one batch, lanes refilled): the packet
    // kernel's image and statistics against the same scene with the kernel forced off. Bit for
    // bit where Embree's packet and single-ray kernels round alike (they do on the machines
    // this was written on); the check allows a last-bit difference in a hit on other CPUs.
    auto scene = example("specialize/diffuse-box.pbrt", 0, 24, 48);
    REQUIRE((applicable_specializations(*scene) & kSpecPacket) != 0);
    Rendered packet = render_with(*scene, 0);
    Rendered scalar = render_with(*scene, kSpecPacket);
    CHECK(packet.stats.samples == scalar.stats.samples);
    CHECK(packet.stats.samples == 24u * 24u * 48u);
    REQUIRE(packet.rgb.size() == scalar.rgb.size());
    size_t n_close = 0;
    double sum_p = 0, sum_s = 0;
    for (size_t i = 0; i < packet.rgb.size(); ++i) {
        const float a = packet.rgb[i], e = scalar.rgb[i];
        n_close += near_equal(a, e);
        sum_p += a;
        sum_s += e;
    }
    CHECK(n_close >= packet.rgb.size() * 99 / 100);
    CHECK(sum_s > 0);
    CHECK(std::abs(sum_p - sum_s) <= 1e-4 * sum_s);
    // Rays and avoided shadow rays: the same paths (a hit rounded differently could change
    // a path's length, very rarely).
    CHECK(std::abs(double(packet.stats.rays) - double(scalar.stats.rays)) <=
          1e-4 * double(scalar.stats.rays));
}
