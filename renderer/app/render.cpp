#include "renderer/app/render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "renderer/app/checkpoint.h"
#include "renderer/app/mpi_group.h"
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
    o.pattern = scene.settings.sample_pattern;
    o.progress = quiet ? sched::ProgressReporter::Mode::Never : sched::ProgressReporter::Mode::Auto;
    return o;
}

void apply_refinement(sched::AdaptiveOptions &o, const SamplerSpec &sampler,
                      RenderBudget budget) {
    if (!o.adaptive)
        return;
    o.refine_factor = sampler.refine_factor;
    o.refine_spp_ratio = sampler.refine_spp_ratio;
    o.refine_floor_ratio = sampler.refine_floor_ratio;
    o.refine_track = sampler.refine_track;
    o.metric = sampler.metric();
    if (sampler.dammertz) {
        o.refine_target = sampler.refine.value_or(false);
        if (o.refine_target && !sampler.error)
            o.error_target = kDefaultRefineStartTarget;
        return;
    }
    if (sampler.error) {
        o.error_target = *sampler.error;
        o.refine_target = sampler.refine.value_or(false);
        return;
    }
    // No error: the budget decides.
    o.refine_target = sampler.refine.value_or(budget.timed);
    if (o.refine_target) {
        o.error_target = kRelMseRefineStart;
        // The best image in the time: the scene's pixelsamples is no cap, --spp is.
        if (budget.timed && !budget.spp_given)
            o.max_spp = 0;
        return;
    }
    o.error_target = 0;
    // A budget no larger than the uniform first pass leaves nothing to adapt: uniform to it.
    if (o.max_spp > std::max(o.min_spp, 1u)) {
        o.spp_budget = o.max_spp;
        if (o.refine_spp_ratio > 0)
            o.max_spp = uint32_t(std::min(4e9, std::ceil(double(o.max_spp) * o.refine_spp_ratio)));
    }
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
    std::unique_ptr<SampleSource> integrator =
        make_path_tracer(scene, scene.settings.seed, scene.settings.max_depth);
    sched::ProgressiveRun run(*integrator, film, uniform_scheduler_options(scene, threads, quiet));
    return run.advance(time_s, cancel);
}

namespace {

/// Where a progressive or real-time render writes, checked before anything is rendered.
struct RenderOutputs {
    std::string exr, png;  ///< the PNG is written only with RenderOptions::write_png
    std::string checkpoint;
    /// The PNG's display transform (resolved up front: a bad OCIO config must fail before
    /// hours of rendering); empty with --no-png.
    std::optional<DisplayTransform> display;
};

/// The output paths of a render of `scene`: fails before rendering when an output cannot be
/// written (missing or read-only folder, a directory in the way) and warns when the disk looks
/// too full for it.
RenderOutputs prepare_outputs(const RenderOptions &opt, const Scene &scene, RenderReport &rep) {
    RenderOutputs out;
    std::string requested = opt.output.empty() ? scene.settings.output : opt.output;
    std::tie(out.exr, out.png) = output_paths(requested);
    rep.exr_path = out.exr;
    rep.png_path = opt.write_png ? out.png : "";
    const uint64_t pixels = uint64_t(scene.settings.width) * uint64_t(scene.settings.height);
    check_output_path(out.exr, "the image", pixels * 17 * 4);
    if (opt.write_png) check_output_path(out.png, "the PNG", pixels * 3);
    if (!opt.stats_path.empty()) check_output_path(opt.stats_path, "--stats");
    if (opt.write_png) {
        try {
            out.display.emplace(opt.display);
        } catch (const std::exception &e) {
            throw SceneError(std::string("--ocio-config/--display/--view:0: ") + e.what());
        }
    }
    out.checkpoint = opt.checkpoint;
    if (out.checkpoint.empty()) {
        fs::path c(out.exr);
        c.replace_extension(".checkpoint.exr");
        out.checkpoint = c.string();
    }
    // Ctrl-C writes a checkpoint even without --checkpoint: check its folder too.
    check_output_path(out.checkpoint, "the checkpoint", pixels * 27 * 4);
    return out;
}

/// The AOVs of the film: the scene's, or exactly the checkpoint's when resuming (one it lacks
/// has no running mean to continue, and starting it from zero would give wrong means).
sampling::AovSet film_aovs(const RenderOptions &opt, const Scene &scene) {
    if (opt.resume.empty()) return scene.settings.aovs;
    sampling::AovSet stored = checkpoint_aovs(opt.resume);
    if (opt.overrides.aovs && *opt.overrides.aovs != stored)
        throw SceneError("--aov:0: the checkpoint " + opt.resume + " has the AOVs " +
                         stored.describe() + "; a resumed render keeps them (asked for " +
                         opt.overrides.aovs->describe() + ")");
    return stored;
}

/// Whether the progressive render of `opt` adapts at all (an spp budget no larger than the
/// uniform first pass does not): only then does its film need the prefix snapshots.
bool render_adapts(const RenderOptions &opt, const Scene &scene) {
    SamplerSpec s = opt.sampler;
    if (opt.min_spp) s.min_spp = *opt.min_spp;
    if (opt.error) s.error = *opt.error;
    sched::AdaptiveOptions o = scheduler_options(scene, s, opt.threads, true);
    apply_refinement(o, s, RenderBudget{opt.time_s > 0, opt.overrides.spp.has_value()});
    return o.adaptive && (o.error_target > 0 || o.spp_budget > 0);
}

/// A progressive render's state beside the film: the scheduler options it starts with, the
/// checkpoint it writes and what a resumed checkpoint contributed.
struct ProgressiveSetup {
    SamplerSpec sampler;       ///< with --min-spp and --error applied
    sched::AdaptiveOptions so;
    double start_error_target = 0;
    CheckpointState cs;
    double elapsed_before = 0;  ///< render seconds of the resumed checkpoint
};

/// The options of `tessera render`'s progressive render, and the resumed checkpoint read into
/// `film` (its seed must match; other settings only warn).
ProgressiveSetup setup_progressive(const RenderOptions &opt, const Scene &scene,
                                   sampling::Film &film, RenderReport &rep) {
    ProgressiveSetup p;
    p.sampler = opt.sampler;
    if (opt.min_spp) p.sampler.min_spp = *opt.min_spp;
    if (opt.error) p.sampler.error = *opt.error;
    p.so = scheduler_options(scene, p.sampler, opt.threads, opt.quiet);
    p.so.deterministic = opt.deterministic;
    p.so.max_passes = opt.max_passes;
    apply_refinement(p.so, p.sampler, RenderBudget{opt.time_s > 0, opt.overrides.spp.has_value()});
    p.start_error_target = p.so.error_target;

    p.cs.seed = scene.settings.seed;
    p.cs.pattern = sampling::pattern_name(scene.settings.sample_pattern);
    p.cs.scene = opt.scene;
    p.cs.settings = p.sampler.describe() + " spp=" + std::to_string(p.so.max_spp) +
                    (opt.deterministic ? " deterministic" : "");
    if (!opt.resume.empty()) {
        CheckpointState prev = read_checkpoint(opt.resume, film);
        if (prev.seed != p.cs.seed)
            throw SceneError(opt.resume + ":0: checkpoint seed " + std::to_string(prev.seed) +
                             " differs from the render's seed " + std::to_string(p.cs.seed));
        if (prev.pattern != p.cs.pattern)
            throw SceneError(opt.resume + ":0: checkpoint sample pattern \"" + prev.pattern +
                             "\" differs from the render's \"" + p.cs.pattern +
                             "\" (the scene's Sampler type)");
        if (prev.settings != p.cs.settings)
            warn(FileLoc{opt.resume, 0}, "resuming with other settings: checkpoint \"" +
                                             prev.settings + "\", now \"" + p.cs.settings + "\"");
        p.so.start_pass = int64_t(prev.passes);
        rep.passes_total = prev.passes;
        p.elapsed_before = prev.elapsed_s;
    }
    return p;
}

/// Renders in chunks of --checkpoint-every seconds within --time, checkpointing after each
/// chunk (sched::ProgressiveRun carries the pass and the refined target from chunk to chunk).
/// Fills rep.stats and rep.passes_total; leaves in p.so the state the last chunk left.
// Distributed: what rank 0 decides (a choice every rank must make alike; see "Distributed
// rendering" in docs/ARCHITECTURE.md); the flag itself in one process.
bool decided(const RenderOptions &opt, bool flag) {
    return opt.group ? opt.group->decide(flag) : flag;
}

bool is_root(const RenderOptions &opt) { return !opt.group || opt.group->rank() == 0; }

void render_chunks(const RenderOptions &opt, const SampleSource &integrator,
                   sampling::Film &film, const std::string &checkpoint, ProgressiveSetup &p,
                   std::chrono::steady_clock::time_point t_render, RenderReport &rep,
                   sched::FilmGatherer *gather) {
    sched::ProgressiveRun run(integrator, film, p.so);
    SignalGuard guard;
    bool out_of_time = false;
    while (true) {
        double remaining = opt.time_s > 0 ? opt.time_s - seconds_since(t_render) : 0.0;
        if (decided(opt, opt.time_s > 0 && remaining <= 0)) {
            out_of_time = true;
            break;
        }
        double chunk_s = remaining;
        if (opt.checkpoint_every > 0)
            chunk_s = chunk_s > 0 ? std::min(chunk_s, opt.checkpoint_every) : opt.checkpoint_every;
        sched::AdaptiveStats s = run.advance(chunk_s, &g_cancel);
        out_of_time = s.out_of_time;
        const bool chunk_timeout =
            decided(opt, s.out_of_time && opt.checkpoint_every > 0 &&
                             !(opt.time_s > 0 && seconds_since(t_render) >= opt.time_s));
        if (!chunk_timeout) break;
        p.cs.passes = uint32_t(run.start_pass());
        p.cs.elapsed_s = p.elapsed_before + seconds_since(t_render);
        // Distributed: rank 0 holds the whole film only after the gather, and writes it alone.
        if (gather) gather->gather();
        // A failed periodic checkpoint (disk full for a moment) must not throw away the
        // render: warn, keep rendering, try again at the next one.
        if (is_root(opt)) {
            try {
                write_checkpoint(checkpoint, film, p.cs);
            } catch (const std::exception &e) {
                warn(FileLoc{checkpoint, 0}, std::string("checkpoint not written: ") + e.what() +
                                                 "; rendering continues");
            }
        }
        out_of_time = false;
        // A chunk that converged or could not take a sample has nothing left to do.
        if (s.converged || s.samples == 0) break;
    }
    rep.stats = run.total();
    rep.stats.out_of_time = out_of_time;
    if (run.chunks() > 0) rep.passes_total = run.total().passes;
    // The state the last chunk left: the pass to resume from and the (refined) target.
    p.so = run.options();
}

/// Writes the EXR (with `errors`, the per-pixel error estimate, as an AOV beside the sample
/// count), the PNG and the checkpoint (p.cs) when asked for or cancelled. When the image cannot be
/// written (disk full?) the work is saved as a checkpoint if at all possible -- it may live on
/// another disk -- and the OutputError says how to get the image back.
void write_outputs(const RenderOptions &opt, const sampling::Film &film,
                   const sampling::ErrorImage &errors, const RenderOutputs &out,
                   const CheckpointState &cs, RenderReport &rep) {
    ExrWriteOptions eo;
    eo.half = opt.half;
    try {
        write_film_exr(out.exr, film, eo, {ImageLayer{"error", {"Y"}, errors.error, true}});
        if (opt.write_png) {
            sampling::RgbImage img(film.width(), film.height(), film.beauty_rgb());
            std::vector<uint8_t> rgb8 = out.display->to_8bit(img);
            write_rgb8(out.png, img.width, img.height, rgb8);
        }
    } catch (const std::exception &e) {
        std::string saved;
        try {
            write_checkpoint(out.checkpoint, film, cs);
            saved = "; the render was saved to " + out.checkpoint +
                    " (continue it with --resume " + out.checkpoint + ")";
        } catch (const std::exception &c) {
            saved = std::string("; the checkpoint could not be written either: ") + c.what();
        }
        throw OutputError(e.what() + saved);
    }
    if (rep.stats.cancelled || !opt.checkpoint.empty()) {
        write_checkpoint(out.checkpoint, film, cs);
        rep.checkpoint_path = out.checkpoint;
    }
}

/// The --stats JSON of a progressive render (keys documented in the README).
nlohmann::json render_stats_json(const RenderOptions &opt, const Scene &scene,
                                 const ProgressiveSetup &p, const SampleSource &integrator,
                                 const RenderReport &rep) {
    const auto &s = rep.stats;
    const sched::AdaptiveOptions &so = p.so;
    nlohmann::json j;
    j["scene"] = opt.scene;
    j["sampler"] = p.sampler.describe();
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
    j["error_metric"] = so.adaptive ? sampling::metric_name(so.metric) : "none";
    j["error_target"] = p.start_error_target;
    j["spp_budget"] = so.spp_budget;
    j["tree_target"] = s.tree_target;
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
    j["features"] = scene.features.describe();
    j["shadow_rays_avoided"] = s.shadow_rays_avoided;
    {
        // The code paths chosen (renderer/scene/specialize.h).
        const uint32_t applicable = applicable_specializations(scene);
        j["specializations"] = {
            {"applicable", specialization_names(applicable)},
            {"used", specialization_names(used_specializations(applicable, opt.no_specialize))},
            {"forced_general",
             specialization_names(applicable &
                                  ~used_specializations(applicable, opt.no_specialize))}};
        j["code_path"] = integrator.describe();
    }
    j["version"] = TESSERA_VERSION;
    {
        nlohmann::json m;
        m["built_in"] = mpi_built_in();
        m["ranks"] = rep.ranks.empty() ? size_t(1) : rep.ranks.size();
        if (!rep.ranks.empty()) {
            double comm_max = 0, frac = 0, wait = 0;
            nlohmann::json rows = nlohmann::json::array();
            for (const RankRow &r : rep.ranks) {
                rows.push_back({{"rank", r.rank},
                                {"host", r.host},
                                {"samples", r.samples},
                                {"wall_s", r.wall_s},
                                {"render_thread_s", r.render_s},
                                {"comm_s", r.comm_s},
                                {"pass_comm_s", r.pass_comm_s},
                                {"wait_s", r.wait_s}});
                comm_max = std::max(comm_max, r.comm_s);
                // The largest share of a rank's render time spent in the collectives.
                if (r.wall_s > 0) frac = std::max(frac, r.comm_s / r.wall_s);
                if (r.wall_s > 0) wait = std::max(wait, r.wait_s / r.wall_s);
            }
            m["per_rank"] = rows;
            m["wait_fraction_max"] = wait;
            m["comm_s_max"] = comm_max;
            m["comm_fraction_max"] = frac;
        }
        j["mpi"] = m;
    }
    if (!rep.checkpoint_path.empty()) j["checkpoint"] = rep.checkpoint_path;
    return j;
}

// Distributed: every rank's row (samples, times) to rank 0's report.
void gather_rank_rows(const RenderOptions &opt, RenderReport &rep, double wall_s, double comm_s,
                      double wait_s) {
    const nlohmann::json mine = {{"host", opt.host},
                                 {"samples", rep.stats.rank_samples},
                                 {"wall_s", wall_s},
                                 {"render_s", rep.stats.render_s},
                                 {"comm_s", comm_s},
                                 {"pass_comm_s", rep.stats.comm_s},
                                 {"wait_s", wait_s}};
    const std::string text = mine.dump();
    const auto *b = reinterpret_cast<const std::byte *>(text.data());
    std::vector<std::vector<std::byte>> pieces =
        opt.group->gather_to_root(std::span<const std::byte>(b, text.size()));
    for (size_t r = 0; r < pieces.size(); ++r) {
        const nlohmann::json j = nlohmann::json::parse(
            std::string(reinterpret_cast<const char *>(pieces[r].data()), pieces[r].size()));
        RankRow row;
        row.rank = uint32_t(r);
        row.host = j.at("host").get<std::string>();
        row.samples = j.at("samples").get<uint64_t>();
        row.wall_s = j.at("wall_s").get<double>();
        row.render_s = j.at("render_s").get<double>();
        row.comm_s = j.at("comm_s").get<double>();
        row.pass_comm_s = j.at("pass_comm_s").get<double>();
        row.wait_s = j.at("wait_s").get<double>();
        rep.ranks.push_back(row);
    }
}

}  // namespace

RenderReport run_render(const RenderOptions &opt) {
    RenderReport rep;
    auto t0 = std::chrono::steady_clock::now();
    SceneOverrides overrides = opt.overrides;
    overrides.no_specialize |= opt.no_specialize;
    std::unique_ptr<Scene> scene = load_scene(opt.scene, overrides);
    rep.load_s = seconds_since(t0);
    const bool root = is_root(opt);
    if (!opt.quiet && root) std::fprintf(stderr, "tessera: %s\n", scene->describe().c_str());
    // Distributed: rank 0 alone writes (and checks) the outputs.
    RenderOutputs out = root ? prepare_outputs(opt, *scene, rep) : RenderOutputs{};

    if (opt.sampler.is_frame()) {
        if (opt.group)
            throw SceneError("--sampler:0: " + opt.sampler.name +
                             " renders whole frames in one process; run it without mpirun");
        if (!opt.resume.empty() || !opt.checkpoint.empty() || opt.checkpoint_every > 0)
            throw SceneError("--sampler:0: " + opt.sampler.name +
                             " renders whole frames; --checkpoint, --checkpoint-every and "
                             "--resume apply to the progressive samplers only");
        SignalGuard guard;
        run_frames(opt, *scene, opt.sampler, out.exr, opt.write_png ? out.png : "",
                   out.display ? &*out.display : nullptr, &g_cancel, rep);
        return rep;
    }
    sampling::Film film(uint32_t(scene->settings.width), uint32_t(scene->settings.height),
                        film_aovs(opt, *scene),
                        keeps_prefix(opt.sampler) && render_adapts(opt, *scene));
    ProgressiveSetup p = setup_progressive(opt, *scene, film, rep);
    p.so.group = opt.group;
    if (!root) p.so.progress = sched::ProgressReporter::Mode::Never;
    // Made before any sample: the film's NaN count now is the base every rank shares.
    std::optional<sched::FilmGatherer> gather;
    if (opt.group) gather.emplace(*opt.group, film);

    std::unique_ptr<SampleSource> integrator =
        make_integrator(*scene, opt.integrator.empty() ? "path" : opt.integrator,
                        opt.no_specialize);
    // Every rank starts its clock at the same moment (the time budget is measured on each).
    if (opt.group) opt.group->barrier();
    const double comm_before = opt.group ? opt.group->comm_seconds() : 0.0;
    const double wait_before = opt.group ? opt.group->wait_seconds() : 0.0;
    auto t_render = std::chrono::steady_clock::now();
    render_chunks(opt, *integrator, film, out.checkpoint, p, t_render, rep,
                  gather ? &*gather : nullptr);
    if (opt.group) {
        gather->gather();
        gather_rank_rows(opt, rep, seconds_since(t_render),
                         opt.group->comm_seconds() - comm_before,
                         opt.group->wait_seconds() - wait_before);
        if (!root) return rep;
    }
    if (rep.stats.cancelled && !opt.quiet)
        std::fprintf(stderr, "tessera: interrupted; writing the partial image and a checkpoint\n");

    auto t_out = std::chrono::steady_clock::now();
    // The per-pixel error estimate (Dammertz) as an AOV beside the sample count.
    sampling::ErrorImage errors;
    const sampling::PixelBounds whole{0, 0, int(film.width()), int(film.height())};
    sampling::compute_errors(film, whole, p.so.min_samples_for_error, errors,
                             p.so.adaptive ? p.so.metric : sampling::ErrorMetric::Dammertz);
    p.cs.passes = p.so.start_pass >= 0 ? uint32_t(p.so.start_pass) : rep.passes_total;
    p.cs.elapsed_s = p.elapsed_before + seconds_since(t_render);
    write_outputs(opt, film, errors, out, p.cs, rep);
    rep.output_s = seconds_since(t_out);
    rep.width = film.width();
    rep.height = film.height();
    rep.max_spp = p.so.max_spp;
    rep.mean_spp = double(film.total_samples()) / double(uint64_t(film.width()) * film.height());
    rep.film_bytes_per_pixel = film.bytes_per_pixel();
    rep.aovs = film.aovs().names();
    rep.peak_rss_bytes = peak_rss_bytes();

    if (!opt.stats_path.empty())
        write_json_atomic(opt.stats_path, render_stats_json(opt, *scene, p, *integrator, rep));
    if (!opt.quiet) {
        std::fprintf(stderr, "tessera: %s\ntessera: wrote %s%s%s%s%s\n",
                     rep.stats.describe().c_str(), out.exr.c_str(), opt.write_png ? " and " : "",
                     opt.write_png ? out.png.c_str() : "",
                     rep.checkpoint_path.empty() ? "" : " and ", rep.checkpoint_path.c_str());
        if (!rep.ranks.empty()) {
            double frac = 0, wait = 0;
            std::string per;
            for (const RankRow &r : rep.ranks) {
                if (r.wall_s > 0) frac = std::max(frac, r.comm_s / r.wall_s);
                if (r.wall_s > 0) wait = std::max(wait, r.wait_s / r.wall_s);
                per += (per.empty() ? "" : ", ") + std::to_string(r.samples);
            }
            std::fprintf(stderr,
                         "tessera: %zu MPI ranks (samples per rank: %s); communication at most "
                         "%.2f%% of a rank's render time, waiting for slower ranks at most "
                         "%.2f%%\n",
                         rep.ranks.size(), per.c_str(), 100.0 * frac, 100.0 * wait);
        }
    }
    return rep;
}

}  // namespace tessera
