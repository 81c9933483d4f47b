#include "renderer/app/realtime.h"
#include "renderer/integrators/integrators.h"
#include "renderer/util/limits.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>

#include "renderer/util/image_io.h"
#include "renderer/util/json_io.h"
#include "renderer/scene/specialize.h"
#include "renderer/integrators/whitted_integrator.h"
#include "scheduler/frame_scheduler.h"

namespace tessera {

Transform orbit_world_from_camera(const Transform &world_from_camera, Vec3f center,
                                  double degrees) {
    const Vec3f eye = world_from_camera.point({0, 0, 0});
    const Vec3f fwd = normalize(world_from_camera.vector({0, 0, 1}));
    const Vec3f up = normalize(world_from_camera.vector({0, 1, 0}));
    const Vec3f pivot = eye + fwd * std::max(0.f, dot(center - eye, fwd));
    const Transform orbit = Transform::translate(pivot) * Transform::rotate(degrees, up) *
                            Transform::translate(-pivot);
    return orbit * world_from_camera;
}

namespace {

double percentile(std::vector<double> v, double q) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    double pos = q * double(v.size() - 1);
    size_t i = size_t(pos);
    double f = pos - double(i);
    return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

// The sample source of the real-time modes and what it collects. The Whitted integrator
// collects only the attributes the plugin reads and the scene can have (scene/specialize.h),
// unless --no-specialize asks for the general path.
struct FrameSource {
    std::unique_ptr<SampleSource> source;
    std::string attributes_collected = "n/a";
};

FrameSource make_frame_source(const RenderOptions &opt, Scene &scene,
                              const std::string &integrator_name,
                              const sampling::PixelSampler &plugin) {
    FrameSource out;
    if (integrator_name == "whitted") {
        WhittedOptions wo;
        wo.max_depth = scene.settings.max_depth;
        wo.seed = scene.settings.seed;
        wo.attributes = plugin.attributes_used();
        wo.specialize = !(opt.no_specialize & kSpecAttributes);
        wo.lambertian = !(opt.no_specialize & kSpecLambertian);
        auto whitted = std::make_unique<WhittedIntegrator>(scene, wo);
        out.attributes_collected = describe_attributes(whitted->collected_attributes());
        out.source = std::move(whitted);
    } else {
        out.source = make_integrator(scene, integrator_name);
    }
    return out;
}

// What the frame loop leaves: the last frame, its timing, and totals over all frames.
struct FrameRun {
    sampling::FrameResult result;
    sched::FrameTiming timing;
    uint32_t done = 0;
    uint64_t shadow_rays = 0, shadow_rays_avoided = 0;  // over all frames
    // Per stage name, the times of the frames without diagnostics (all but the last one; the
    // last one alone when there is only one): the profile of the frames that frame_ms_median
    // sums. By name: a plugin may run other stages in its first frame (fliptri's
    // prev_threshold).
    std::map<std::string, std::vector<double>> stage_ms;
};

// Renders opt.frames frames (orbiting the camera by opt.orbit_deg over them), until a cancel.
void render_frame_loop(const RenderOptions &opt, Scene &scene, sampling::PixelSampler &plugin,
                       const SampleSource &source, sched::FrameScheduler &scheduler,
                       const std::atomic<bool> *cancel, RenderReport &rep, FrameRun &run) {
    const Transform home = scene.camera->world_from_camera();
    const Vec3f center = (scene.geometry->bounds_min() + scene.geometry->bounds_max()) * 0.5f;
    const uint32_t frames = std::max(1u, opt.frames);
    for (uint32_t k = 0; k < frames; ++k) {
        if (cancel && cancel->load()) break;
        if (opt.orbit_deg != 0)
            scene.camera->set_world_from_camera(
                orbit_world_from_camera(home, center, opt.orbit_deg * double(k) / frames));
        // Only the last frame is written out: the others skip their diagnostic layers.
        plugin.set_diagnostics(k + 1 == frames);
        run.timing = scheduler.render(plugin, source, run.result, cancel);
        if (run.timing.cancelled) break;
        rep.frame_ms.push_back(run.timing.total_ms);
        if (k + 1 < frames || run.stage_ms.empty())
            for (size_t i = 0; i < run.timing.stage_ms.size(); ++i)
                run.stage_ms[run.timing.stage_names[i]].push_back(run.timing.stage_ms[i]);
        run.shadow_rays += run.result.shadow_rays;
        run.shadow_rays_avoided += run.result.shadow_rays_avoided;
        ++run.done;
        if (!opt.quiet)
            std::fprintf(stderr, "\rtessera: frame %u/%u  %.1f ms  %.2f rays/px", k + 1, frames,
                         run.timing.total_ms,
                         double(run.result.rays_total) /
                             double(run.result.width * run.result.height));
    }
    if (!opt.quiet) std::fprintf(stderr, "\n");
}

// Writes the last frame: the EXR (beauty, rays per pixel, the plugin's diagnostic layers) and
// the display PNG.
void write_frame_images(const RenderOptions &opt, const sampling::FrameResult &result,
                        const std::string &exr, const std::string &png,
                        const DisplayTransform *display) {
    const uint32_t w = result.width, h = result.height;
    std::vector<ImageLayer> layers;
    ImageLayer beauty{"", {"R", "G", "B"}, {}, false};
    beauty.data.resize(size_t(w) * h * 3);
    for (size_t i = 0; i < size_t(w) * h; ++i) {
        beauty.data[3 * i] = result.color[i].r;
        beauty.data[3 * i + 1] = result.color[i].g;
        beauty.data[3 * i + 2] = result.color[i].b;
    }
    layers.push_back(beauty);
    layers.push_back(ImageLayer{"rays", {"Y"}, result.rays, true});
    for (const sampling::FrameLayer &l : result.diagnostics)
        layers.push_back(ImageLayer{l.name, {"Y"}, l.data, true});
    ExrWriteOptions eo;
    eo.half = opt.half;
    write_exr(exr, w, h, layers, eo);
    if (display) {
        sampling::RgbImage img(w, h, beauty.data);
        write_rgb8(png, w, h, display->to_8bit(img));
    }
}

// The report's image, rate and total fields from the last frame and the frame times.
void fill_frame_report(const sampling::FrameResult &result, uint32_t threads, RenderReport &rep) {
    const double pixels = double(result.width) * result.height;
    rep.width = result.width;
    rep.height = result.height;
    rep.rays_per_pixel = double(result.rays_total) / pixels;
    rep.active_fraction = result.active_fraction;
    rep.mean_spp = double(result.samples) / pixels;
    rep.stats.samples = result.samples;
    rep.stats.rays = result.rays_total;
    rep.stats.nan_samples = result.nan_samples;
    rep.stats.threads = threads;
    rep.peak_rss_bytes = peak_rss_bytes();
    double total_ms = 0;
    for (double ms : rep.frame_ms) total_ms += ms;
    rep.stats.wall_s = total_ms * 1e-3;
}

// The stats JSON of the real-time modes (--stats).
nlohmann::json frames_stats_json(const RenderOptions &opt, const Scene &scene,
                                 const SamplerSpec &sampler, const std::string &integrator_name,
                                 const std::string &attributes_collected, uint32_t threads,
                                 const FrameRun &run, const RenderReport &rep) {
    const sampling::FrameResult &result = run.result;
    const double pixels = double(result.width) * result.height;
    nlohmann::json j;
    j["scene"] = opt.scene;
    j["sampler"] = sampler.describe();
    j["integrator"] = integrator_name;
    j["width"] = result.width;
    j["height"] = result.height;
    j["frames"] = run.done;
    j["orbit_deg"] = opt.orbit_deg;
    j["threads"] = threads;
    j["frame_ms"] = rep.frame_ms;
    j["frame_ms_median"] = percentile(rep.frame_ms, 0.5);
    j["frame_ms_p95"] = percentile(rep.frame_ms, 0.95);
    j["frame_ms_min"] = *std::min_element(rep.frame_ms.begin(), rep.frame_ms.end());
    j["rays_per_pixel"] = rep.rays_per_pixel;
    j["samples_per_pixel"] = rep.mean_spp;
    j["shaded_per_pixel"] = double(result.shaded) / pixels;
    j["active_fraction"] = result.active_fraction;
    j["active_unit"] = result.active_unit;
    j["samples"] = result.samples;
    j["rays"] = result.rays_total;
    // Totals over all frames (`rays` above is the last frame's).
    j["shadow_rays"] = run.shadow_rays;
    j["shadow_rays_avoided"] = run.shadow_rays_avoided;
    j["attributes_collected"] = attributes_collected;
    j["specialize"] = !(opt.no_specialize & kSpecAttributes);
    j["nan_count"] = result.nan_samples;
    nlohmann::json stages = nlohmann::json::array();
    for (size_t i = 0; i < run.timing.stage_ms.size(); ++i)
        stages.push_back({{"name", run.timing.stage_names[i]}, {"ms", run.timing.stage_ms[i]}});
    j["stages_last_frame"] = stages;
    nlohmann::json medians = nlohmann::json::array();
    for (const std::string &name : run.timing.stage_names) {
        const auto it = run.stage_ms.find(name);
        if (it != run.stage_ms.end())
            medians.push_back({{"name", name}, {"ms", percentile(it->second, 0.5)}});
    }
    j["stages_ms_median"] = medians;
    std::vector<std::string> layer_names;
    for (const auto &l : result.diagnostics) layer_names.push_back(l.name);
    j["diagnostic_layers"] = layer_names;
    j["load_s"] = rep.load_s;
    j["cancelled"] = rep.stats.cancelled;
    j["peak_rss_bytes"] = rep.peak_rss_bytes;
    j["features"] = scene.features.describe();
    j["version"] = TESSERA_VERSION;
    return j;
}

}  // namespace

void run_frames(const RenderOptions &opt, Scene &scene, const SamplerSpec &sampler,
                const std::string &exr, const std::string &png, const DisplayTransform *display,
                const std::atomic<bool> *cancel, RenderReport &rep) {
    const std::string integrator_name = opt.integrator.empty() ? "whitted" : opt.integrator;
    std::unique_ptr<sampling::PixelSampler> plugin;
    try {
        plugin = sampler.plugin.info->make(sampler.plugin.params);
    } catch (const std::invalid_argument &e) {
        throw SceneError(std::string("--sampler:0: ") + e.what());
    }
    const FrameSource src = make_frame_source(opt, scene, integrator_name, *plugin);
    sched::FrameOptions fo;
    fo.threads = opt.threads;
    sched::FrameScheduler scheduler(fo);

    const uint32_t frames = std::max(1u, opt.frames);
    FrameRun run;
    render_frame_loop(opt, scene, *plugin, *src.source, scheduler, cancel, rep, run);
    const uint32_t done = run.done;
    if (done == 0) {
        // Interrupted before the first frame finished: nothing consistent to write.
        rep.stats.cancelled = true;
        if (!opt.quiet) std::fprintf(stderr, "tessera: interrupted before the first frame\n");
        return;
    }
    rep.stats.cancelled = cancel && cancel->load();
    if (done < frames && !opt.quiet)
        std::fprintf(stderr, "tessera: interrupted after %u of %u frames: writing frame %u without "
                             "its diagnostic layers (only the last frame computes them)\n",
                     done, frames, done);

    auto t_out = std::chrono::steady_clock::now();
    write_frame_images(opt, run.result, exr, png, display);
    rep.output_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_out).count();
    fill_frame_report(run.result, scheduler.threads(), rep);
    if (!opt.stats_path.empty())
        write_json_atomic(opt.stats_path,
                          frames_stats_json(opt, scene, sampler, integrator_name,
                                            src.attributes_collected, scheduler.threads(), run,
                                            rep));
    if (!opt.quiet)
        std::fprintf(stderr,
                     "tessera: %u frame(s), median %.1f ms, p95 %.1f ms, %.2f rays/px, %.1f%% %s "
                     "active\ntessera: wrote %s%s%s\n",
                     done, percentile(rep.frame_ms, 0.5), percentile(rep.frame_ms, 0.95),
                     rep.rays_per_pixel, 100.0 * run.result.active_fraction,
                     run.result.active_unit.c_str(), exr.c_str(), display ? " and " : "",
                     display ? png.c_str() : "");
}

}  // namespace tessera
