#include "renderer/app/render.h"

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "renderer/app/checkpoint.h"
#include "renderer/util/image_io.h"
#include "renderer/util/json_io.h"
#include "renderer/integrators/integrators.h"
#include "renderer/integrators/path_integrator.h"
#include "renderer/app/realtime.h"
#include "renderer/util/limits.h"
#include "renderer/scene/specialize.h"
#include "sampling/adaptive_error.h"
#include "scheduler/progressive_run.h"

namespace tessera {

namespace fs = std::filesystem;

namespace {

std::atomic<bool> g_cancel{false};

extern "C" void on_signal(int) { g_cancel.store(true); }

/// Installs SIGINT/SIGTERM handlers for the duration of a render: the first signal finishes
/// the tiles in flight, then the image and a checkpoint are written; the handlers are restored
/// afterwards.
class SignalGuard {
  public:
    SignalGuard() {
        g_cancel.store(false);
        old_int_ = std::signal(SIGINT, on_signal);
        old_term_ = std::signal(SIGTERM, on_signal);
    }
    ~SignalGuard() {
        std::signal(SIGINT, old_int_);
        std::signal(SIGTERM, old_term_);
    }

  private:
    void (*old_int_)(int);
    void (*old_term_)(int);
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::pair<std::string, std::string> output_paths(const std::string &requested) {
    fs::path p(requested.empty() ? "pbrt.exr" : requested);
    fs::path stem = p;
    stem.replace_extension();
    return {stem.string() + ".exr", stem.string() + ".png"};
}

sched::AdaptiveOptions scheduler_options(const Scene &scene, const SamplerSpec &sampler,
                                         uint32_t threads, bool quiet) {
    sched::AdaptiveOptions o;
    o.max_spp = uint32_t(scene.settings.spp);
    // MoonRay's uniform start (sampling/progressive_settings.h).
    o.min_spp =
        std::min(o.max_spp, sampler.min_spp.value_or(sampling::kProgressiveDefaults.min_spp));
    o.adaptive = sampler.name == "adaptive";
    o.error_target = o.adaptive ? sampler.error.value_or(kDefaultErrorTarget) : 0.0;
    o.max_pass_spp = sampler.max_pass_spp;
    o.split_factor = sampler.split_factor;
    o.min_extent = sampler.min_extent;
    o.threads = threads;
    o.seed = scene.settings.seed;
    o.progress = quiet ? sched::ProgressReporter::Mode::Never : sched::ProgressReporter::Mode::Auto;
    return o;
}

void apply_refinement(sched::AdaptiveOptions &o, const SamplerSpec &sampler) {
    if (!o.adaptive)
        return;
    o.refine_target = sampler.refine.value_or(false);
    o.refine_factor = sampler.refine_factor;
    o.refine_spp_ratio = sampler.refine_spp_ratio;
    o.refine_floor_ratio = sampler.refine_floor_ratio;
    if (o.refine_target && !sampler.error)
        o.error_target = kDefaultRefineStartTarget;
}

bool keeps_prefix(const SamplerSpec &sampler) {
    return sampler.name == "adaptive" && sampler.prefix_error;
}

sched::AdaptiveOptions uniform_scheduler_options(const Scene &scene, uint32_t threads,
                                                 bool quiet) {
    SamplerSpec uniform;
    uniform.name = "uniform";
    return scheduler_options(scene, uniform, threads, quiet);
}

sched::AdaptiveStats render_scene(const Scene &scene, sampling::Film &film, uint32_t threads,
                                  double time_s, bool quiet, const std::atomic<bool> *cancel) {
    PathIntegrator integrator(scene, scene.settings.seed, scene.settings.max_depth);
    sched::ProgressiveRun run(integrator, film, uniform_scheduler_options(scene, threads, quiet));
    return run.advance(time_s, cancel);
}

RenderReport run_render(const RenderOptions &opt) {
    RenderReport rep;
    auto t0 = std::chrono::steady_clock::now();
    SceneOverrides overrides = opt.overrides;
    overrides.no_specialize |= opt.no_specialize;
    std::unique_ptr<Scene> scene = load_scene(opt.scene, overrides);
    rep.load_s = seconds_since(t0);
    if (!opt.quiet) std::fprintf(stderr, "tessera: %s\n", scene->describe().c_str());

    std::string requested = opt.output.empty() ? scene->settings.output : opt.output;
    auto [exr, png] = output_paths(requested);
    rep.exr_path = exr;
    rep.png_path = opt.write_png ? png : "";
    // Fail before rendering when an output cannot be written (missing or read-only folder, a
    // directory in the way); warn when the disk looks too full for it.
    const uint64_t pixels = uint64_t(scene->settings.width) * uint64_t(scene->settings.height);
    check_output_path(exr, "the image", pixels * 17 * 4);
    if (opt.write_png) check_output_path(png, "the PNG", pixels * 3);
    if (!opt.stats_path.empty()) check_output_path(opt.stats_path, "--stats");
    // Resolve the display transform now: a bad OCIO config must fail before hours of rendering.
    std::optional<DisplayTransform> display;
    if (opt.write_png) {
        try {
            display.emplace(opt.display);
        } catch (const std::exception &e) {
            throw SceneError(std::string("--ocio-config/--display/--view:0: ") + e.what());
        }
    }
    std::string checkpoint = opt.checkpoint;
    if (checkpoint.empty()) {
        fs::path c(exr);
        c.replace_extension(".checkpoint.exr");
        checkpoint = c.string();
    }
    // Ctrl-C writes a checkpoint even without --checkpoint: check its folder too.
    check_output_path(checkpoint, "the checkpoint", pixels * 27 * 4);

    SamplerSpec sampler = opt.sampler;
    if (sampler.is_frame()) {
        if (!opt.resume.empty() || !opt.checkpoint.empty() || opt.checkpoint_every > 0)
            throw SceneError("--sampler:0: " + sampler.name +
                             " renders whole frames; --checkpoint, --checkpoint-every and "
                             "--resume apply to the progressive samplers only");
        SignalGuard guard;
        run_frames(opt, *scene, sampler, exr, opt.write_png ? png : "",
                   display ? &*display : nullptr, &g_cancel, rep);
        return rep;
    }
    // A resumed render keeps exactly the checkpoint's AOVs: one it lacks has no running mean to
    // continue, and starting it from zero would give wrong means.
    sampling::AovSet aovs = scene->settings.aovs;
    if (!opt.resume.empty()) {
        sampling::AovSet stored = checkpoint_aovs(opt.resume);
        if (opt.overrides.aovs && *opt.overrides.aovs != stored)
            throw SceneError("--aov:0: the checkpoint " + opt.resume + " has the AOVs " +
                             stored.describe() + "; a resumed render keeps them (asked for " +
                             opt.overrides.aovs->describe() + ")");
        aovs = stored;
    }
    sampling::Film film(uint32_t(scene->settings.width), uint32_t(scene->settings.height), aovs,
                        keeps_prefix(sampler));
    if (opt.min_spp) sampler.min_spp = *opt.min_spp;
    if (opt.error) sampler.error = *opt.error;
    sched::AdaptiveOptions so = scheduler_options(*scene, sampler, opt.threads, opt.quiet);
    so.deterministic = opt.deterministic;
    so.max_passes = opt.max_passes;
    apply_refinement(so, sampler);
    const double start_error_target = so.error_target;

    CheckpointState cs;
    cs.seed = scene->settings.seed;
    cs.scene = opt.scene;
    cs.settings = sampler.describe() + " spp=" + std::to_string(so.max_spp) +
                  (opt.deterministic ? " deterministic" : "");
    double elapsed_before = 0;
    if (!opt.resume.empty()) {
        CheckpointState prev = read_checkpoint(opt.resume, film);
        if (prev.seed != cs.seed)
            throw SceneError(opt.resume + ":0: checkpoint seed " + std::to_string(prev.seed) +
                             " differs from the render's seed " + std::to_string(cs.seed));
        if (prev.settings != cs.settings)
            warn(FileLoc{opt.resume, 0}, "resuming with other settings: checkpoint \"" +
                                             prev.settings + "\", now \"" + cs.settings + "\"");
        so.start_pass = int64_t(prev.passes);
        rep.passes_total = prev.passes;
        elapsed_before = prev.elapsed_s;
    }

    std::unique_ptr<SampleSource> integrator =
        make_integrator(*scene, opt.integrator.empty() ? "path" : opt.integrator,
                        opt.no_specialize);
    sched::ProgressiveRun run(*integrator, film, so);
    auto t_render = std::chrono::steady_clock::now();
    {
        SignalGuard guard;
        // Render in chunks of --checkpoint-every seconds, checkpointing after each chunk; a
        // chunk resumes at the pass the previous one was in (sched::ProgressiveRun).
        bool out_of_time = false;
        while (true) {
            double remaining = opt.time_s > 0 ? opt.time_s - seconds_since(t_render) : 0.0;
            if (opt.time_s > 0 && remaining <= 0) {
                out_of_time = true;
                break;
            }
            double chunk_s = remaining;
            if (opt.checkpoint_every > 0)
                chunk_s = chunk_s > 0 ? std::min(chunk_s, opt.checkpoint_every)
                                      : opt.checkpoint_every;
            sched::AdaptiveStats s = run.advance(chunk_s, &g_cancel);
            out_of_time = s.out_of_time;
            bool chunk_timeout = s.out_of_time && opt.checkpoint_every > 0 &&
                                 !(opt.time_s > 0 && seconds_since(t_render) >= opt.time_s);
            if (chunk_timeout) {
                cs.passes = uint32_t(run.start_pass());
                cs.elapsed_s = elapsed_before + seconds_since(t_render);
                // A failed periodic checkpoint (disk full for a moment) must not throw away
                // the render: warn, keep rendering, try again at the next one.
                try {
                    write_checkpoint(checkpoint, film, cs);
                } catch (const std::exception &e) {
                    warn(FileLoc{checkpoint, 0}, std::string("checkpoint not written: ") +
                                                     e.what() + "; rendering continues");
                }
                out_of_time = false;
                // A chunk that converged or could not take a sample has nothing left to do.
                if (s.converged || s.samples == 0) break;
                continue;
            }
            break;
        }
        rep.stats = run.total();
        rep.stats.out_of_time = out_of_time;
        if (run.chunks() > 0) rep.passes_total = run.total().passes;
        // The state the last chunk left: the pass to resume from and the (refined) target.
        so = run.options();
    }
    if (rep.stats.cancelled && !opt.quiet)
        std::fprintf(stderr, "tessera: interrupted; writing the partial image and a checkpoint\n");

    auto t_out = std::chrono::steady_clock::now();
    // The per-pixel error estimate (Dammertz) as an AOV beside the sample count.
    sampling::ErrorImage errors;
    sampling::compute_errors(film, sampling::PixelBounds{0, 0, int(film.width()), int(film.height())},
                             so.min_samples_for_error, errors);
    ExrWriteOptions eo;
    eo.half = opt.half;
    cs.passes = so.start_pass >= 0 ? uint32_t(so.start_pass) : rep.passes_total;
    cs.elapsed_s = elapsed_before + seconds_since(t_render);
    try {
        write_film_exr(exr, film, eo, {ImageLayer{"error", {"Y"}, errors.error, true}});
        if (opt.write_png) {
            sampling::RgbImage img(film.width(), film.height(), film.beauty_rgb());
            std::vector<uint8_t> rgb8 = display->to_8bit(img);
            write_rgb8(png, img.width, img.height, rgb8);
        }
    } catch (const std::exception &e) {
        // The image could not be written (disk full?): save the work as a checkpoint if at
        // all possible -- it may live on another disk -- and say how to get the image back.
        std::string saved;
        try {
            write_checkpoint(checkpoint, film, cs);
            saved = "; the render was saved to " + checkpoint + " (continue it with --resume " +
                    checkpoint + ")";
        } catch (const std::exception &c) {
            saved = std::string("; the checkpoint could not be written either: ") + c.what();
        }
        throw OutputError(e.what() + saved);
    }
    if (rep.stats.cancelled || !opt.checkpoint.empty()) {
        write_checkpoint(checkpoint, film, cs);
        rep.checkpoint_path = checkpoint;
    }
    rep.output_s = seconds_since(t_out);
    rep.width = film.width();
    rep.height = film.height();
    rep.max_spp = so.max_spp;
    rep.mean_spp = double(film.total_samples()) / double(uint64_t(film.width()) * film.height());
    rep.film_bytes_per_pixel = film.bytes_per_pixel();
    rep.aovs = film.aovs().names();
    rep.peak_rss_bytes = peak_rss_bytes();

    if (!opt.stats_path.empty()) {
        const auto &s = rep.stats;
        nlohmann::json j;
        j["scene"] = opt.scene;
        j["sampler"] = sampler.describe();
        j["deterministic"] = opt.deterministic;
        j["width"] = rep.width;
        j["height"] = rep.height;
        j["spp"] = rep.max_spp;
        j["min_spp"] = so.min_spp;
        j["mean_spp"] = rep.mean_spp;
        j["samples"] = s.samples;
        j["rays"] = s.rays;
        j["nan_count"] = s.nan_samples;
        j["threads"] = s.threads;
        j["passes"] = rep.passes_total;
        j["catch_up_passes"] = s.catch_up_passes;
        j["pixels_skipped"] = s.pixels_skipped;
        j["tiles_skipped"] = s.tiles_skipped;
        j["lock_wait_fraction"] = s.lock_wait_fraction;
        j["tree_rebuild_ms_max"] = s.tree_rebuild_ms_max;
        j["tree_rebuild_ms_mean"] = s.tree_rebuild_ms_mean;
        j["rebuilds"] = s.rebuilds;
        // Infinity is not JSON: an unknown error estimate is null.
        if (std::isfinite(s.error_estimate))
            j["error_estimate"] = s.error_estimate;
        else
            j["error_estimate"] = nullptr;
        j["error_target"] = start_error_target;
        j["refine_target"] = so.refine_target;
        j["final_error_target"] = so.adaptive ? so.error_target : 0.0;
        j["refinements"] = s.refinements;
        j["converged"] = s.converged;
        j["spp_histogram"] = s.spp_histogram;
        j["wall_s"] = s.wall_s;
        j["time_per_phase"] = {{"load_s", rep.load_s},
                               {"render_thread_s", s.render_s},
                               {"rebuild_thread_s", s.rebuild_s},
                               {"output_s", rep.output_s}};
        j["load_s"] = rep.load_s;
        j["mrays_per_s"] = s.wall_s > 0 ? double(s.rays) / s.wall_s * 1e-6 : 0.0;
        j["samples_per_s"] = s.wall_s > 0 ? double(s.samples) / s.wall_s : 0.0;
        j["cancelled"] = s.cancelled;
        j["out_of_time"] = s.out_of_time;
        j["film_bytes_per_pixel"] = rep.film_bytes_per_pixel;
        j["aovs"] = rep.aovs;
        j["peak_rss_bytes"] = rep.peak_rss_bytes;
        j["features"] = scene->features.describe();
        j["shadow_rays_avoided"] = s.shadow_rays_avoided;
        {
            // The code paths chosen (renderer/scene/specialize.h).
            const uint32_t applicable = applicable_specializations(*scene);
            j["specializations"] = {
                {"applicable", specialization_names(applicable)},
                {"used", specialization_names(used_specializations(applicable, opt.no_specialize))},
                {"forced_general",
                 specialization_names(applicable &
                                      ~used_specializations(applicable, opt.no_specialize))}};
            j["code_path"] = integrator->describe();
        }
        j["version"] = TESSERA_VERSION;
        if (!rep.checkpoint_path.empty()) j["checkpoint"] = rep.checkpoint_path;
        write_json_atomic(opt.stats_path, j);
    }
    if (!opt.quiet) {
        std::fprintf(stderr, "tessera: %s\ntessera: wrote %s%s%s%s%s\n",
                     rep.stats.describe().c_str(), exr.c_str(), opt.write_png ? " and " : "",
                     opt.write_png ? png.c_str() : "", rep.checkpoint_path.empty() ? "" : " and ",
                     rep.checkpoint_path.c_str());
    }
    return rep;
}

}  // namespace tessera
