// What `tessera render` takes (RenderOptions, with its sampler choice SamplerSpec) and what it
// reports (RenderReport): shared by the progressive render (render.h), the real-time loop
// (realtime.h), `tessera converge` and the tests.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "renderer/util/color.h"
#include "renderer/scene/scene.h"
#include "sampling/pixel_sampler.h"
#include "sampling/progressive_settings.h"
#include "scheduler/adaptive_scheduler.h"

namespace tessera {

/// Default region error target of the adaptive sampler with dammertz=1 (Dammertz e_b; see
/// sampling/region_tree.h and sampling/progressive_settings.h).
inline constexpr double kDefaultErrorTarget = sampling::kProgressiveDefaults.error;

/// Starting image relMSE of a refining relMSE-metric render (a time budget and no error): loose
/// enough that only the worst regions are above its per-pixel threshold after the first pass
/// (sched::AdaptiveScheduler, "Error metrics"); each refinement lowers it by refine_factor.
inline constexpr double kRelMseRefineStart = sampling::kProgressiveDefaults.relmse_refine_start;

/// Starting region error target of a refining adaptive render with no explicit error (a time
/// budget and no `--error` / `error=`; see sched::AdaptiveOptions::refine_target and
/// sampling/progressive_settings.h).
inline constexpr double kDefaultRefineStartTarget =
    sampling::kProgressiveDefaults.refine_start_error;

/// A sampler selection: any registered plugin (sampling/pixel_sampler.h; `tessera samplers`
/// lists them), e.g. `uniform`, `adaptive[:error=E,min-spp=N,...]` (progressive, run by the
/// adaptive scheduler) or `jin:tau_col=0.6` (a real-time frame plugin). For the progressive
/// samplers the fields below hold the parsed values; their defaults are the registry's
/// (sampling/progressive_settings.h).
struct SamplerSpec {
    std::string name = "adaptive";
    /// The parsed plugin and all its parameters (defaults filled in). Empty info: "adaptive"
    /// with defaults (a default-constructed spec).
    sampling::PluginSpec plugin;
    /// True for real-time frame plugins (fixed, jin, kim, fliptri, flipquad, suffern).
    bool is_frame() const {
        return plugin.info && plugin.info->kind == sampling::PluginKind::Frame;
    }
    std::optional<double> error;
    std::optional<uint32_t> min_spp;
    uint32_t max_pass_spp = sampling::kProgressiveDefaults.max_pass_spp;
    double split_factor = sampling::kProgressiveDefaults.split_factor;
    /// Narrowest region a split may create, pixels (ProgressiveSettings::min_extent).
    double min_extent = sampling::kProgressiveDefaults.min_extent;
    /// adaptive:refine=0|1; unset: off (opt-in, see apply_refinement: it helps some scenes
    /// and hurts others).
    std::optional<bool> refine;
    // adaptive:refine-factor, refine-spp-ratio, refine-floor-ratio, refine-track.
    double refine_factor = sampling::kProgressiveDefaults.refine_factor;
    double refine_spp_ratio = sampling::kProgressiveDefaults.refine_spp_ratio;
    double refine_floor_ratio = sampling::kProgressiveDefaults.refine_floor_ratio;
    /// adaptive:refine-track (ProgressiveSettings::refine_track).
    double refine_track = sampling::kProgressiveDefaults.refine_track;
    /// adaptive:prefix-error=1: pixel errors compare the mean with the mean of the pixel's
    /// first 2^k samples instead of the half buffer (sampling/adaptive_error.h); the film then
    /// keeps prefix snapshots (keeps_prefix). Unset: on with the relMSE metric, and with
    /// dammertz=1 exactly when refining (refine=1).
    bool prefix_error = true;
    /// adaptive:dammertz=1: MoonRay's rule, the error target is Dammertz's area-weighted region
    /// error (sched::AdaptiveOptions::metric = Dammertz, error default kDefaultErrorTarget,
    /// refinement opt-in). Default (0): the target is the image relMSE and the budget decides
    /// (apply_refinement).
    bool dammertz = false;
    /// The error metric the spec selects (Dammertz or RelMse).
    sampling::ErrorMetric metric() const {
        return dammertz ? sampling::ErrorMetric::Dammertz : sampling::ErrorMetric::RelMse;
    }
    /// One line, e.g. "adaptive:error=0.002,min-spp=16".
    std::string describe() const;
};

/// Parses "NAME[:key=value,...]" against the plugin registry. Throws SceneError
/// ("--sampler:0: sampler NAME: ...") naming the sampler and the key for an unknown sampler or
/// key, or a bad value.
SamplerSpec parse_sampler_spec(const std::string &text);

/// Everything `tessera render` takes on the command line.
struct RenderOptions {
    std::string scene;
    std::string output;             ///< EXR path ("" : from the scene's Film "filename")
    /// --spp (the maximum), --resolution, --seed, --max-depth, --clamp, --aov
    SceneOverrides overrides;
    SamplerSpec sampler;            ///< --sampler
    std::optional<uint32_t> min_spp;   ///< --min-spp (wins over the sampler spec's)
    std::optional<double> error;       ///< --error (wins over the sampler spec's)
    bool deterministic = false;     ///< --deterministic: barriers between passes
    uint32_t max_passes = 0;        ///< --max-passes (0: none)
    uint32_t threads = 0;           ///< 0: all cores
    double time_s = 0;              ///< 0: no time limit
    std::string checkpoint;         ///< --checkpoint FILE ("" : only on Ctrl-C, beside the EXR)
    double checkpoint_every = 0;    ///< --checkpoint-every SECONDS (0: at the end only)
    std::string resume;             ///< --resume FILE
    std::string stats_path;         ///< --stats FILE.json ("" : none)
    bool half = false;              ///< write half-float EXR colour channels
    bool write_png = true;
    DisplayOptions display;         ///< --ocio-config, --view, --display, --exposure
    bool quiet = false;             ///< no progress bar and no summary
    /// --integrator: "path" or "whitted"; "" = path for progressive samplers, whitted for the
    /// real-time frame plugins (they compare neighbours, so noise must not look like an edge).
    std::string integrator;
    uint32_t frames = 1;            ///< --frames: frames to render with a frame plugin
    double orbit_deg = 0;           ///< --orbit: camera orbit over all frames, degrees
    /// --no-specialize[=NAME,...]: Specialization bits (renderer/scene/specialize.h) forced onto the
    /// general code path (benchmarks of what each specialisation saves).
    uint32_t no_specialize = 0;
    /// Distributed render (main.cpp sets it under mpirun with several ranks): this process is
    /// one rank of the group; rank 0 writes the outputs. Null: one process renders everything.
    sched::RankGroup *group = nullptr;
    std::string host;  ///< this rank's host name (the stats' per-rank rows)
};

/// One rank of a distributed render, in rank 0's stats.
struct RankRow {
    uint32_t rank = 0;
    std::string host;
    uint64_t samples = 0;    ///< samples this rank took
    double wall_s = 0;       ///< wall time of its render (all chunks)
    double render_s = 0;     ///< thread-seconds in its tiles
    double comm_s = 0;       ///< wall seconds in the collectives' communication
    /// Wall seconds waiting for slower ranks before the exchanges (RankGroup::arrive: load
    /// imbalance at pass ends and before the film's gathers), not in comm_s.
    double wait_s = 0;
    /// Of comm_s, the seconds in the scheduler's per-pass exchanges (the rest: the film's
    /// gathers to rank 0 for checkpoints and the image, and the chunk decisions).
    double pass_comm_s = 0;
};

/// What a render produced (for the stats JSON and tests).
struct RenderReport {
    sched::AdaptiveStats stats;     ///< totals over all render() calls of this run
    uint32_t passes_total = 0;      ///< absolute passes completed (resumed ones included)
    double load_s = 0, output_s = 0;
    std::string exr_path, png_path, checkpoint_path;
    uint32_t width = 0, height = 0, max_spp = 0;
    double mean_spp = 0;
    size_t film_bytes_per_pixel = 0;  ///< Film::bytes_per_pixel() of the render's film
    std::vector<std::string> aovs;    ///< names of the AOVs the film kept, canonical order
    size_t peak_rss_bytes = 0;
    std::vector<RankRow> ranks;     ///< distributed: every rank (rank 0 only), else empty
    // Frame plugins (real-time loop):
    std::vector<double> frame_ms;   ///< wall time of every frame
    double rays_per_pixel = 0;      ///< last frame: rays traced / pixels
    double active_fraction = 0;     ///< last frame: fraction of (sub)pixels found active
};

}  // namespace tessera
