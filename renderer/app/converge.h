// `tessera converge`: error against time of several progressive samplers on one scene, for the
// same wall-time budget (docs/ARCHITECTURE.md, "Outputs people use").
//
// Each sampler renders a fresh film for --time seconds. At N log-spaced times (first snapshot
// --first-snapshot, default time / 32; sampling/convergence_curve.h) the render stops, the
// film's mean image and sample counts are copied, and the render resumes where it stopped: a
// later AdaptiveScheduler::render() continues every pixel's own sample sequence at the pass the
// previous chunk was in (as --checkpoint-every does). The reported time is the sum of the
// chunks' wall times, from before each scheduler is built until its render() returns, so it
// includes each restart's set-up (a few milliseconds: error snapshot and trees rebuilt from the
// film) but not the snapshot copies, the metrics or any file output; the copies' cost is
// measured and reported per snapshot (snapshot_cost_s). A sampler that stops by itself
// (converged, or reached --spp) ends its curve there. The samplers run interleaved, each with its
// own film: snapshot k of every sampler, then snapshot k + 1, so that a machine that slows down
// for a while (other processes) costs every sampler alike.
//
// Metrics per snapshot against the reference (sampling/image_metrics.h): MSE, relMSE, RMSE,
// PSNR (peak 1) and MAE per channel and in total, plus mean spp, samples, rays, passes and
// coverage (the fraction of pixels with at least one sample: below 1 the first pass was still
// running, and such snapshots stay out of fits and crossing times).
//
// Outputs in DIR: convergence.csv and convergence.json (one row per sampler and snapshot; the
// JSON also has the version, scene hash, hardware threads, settings, per-sampler log-log fits
// and the headline table), images/ (reference PNG; per sampler its final EXR with spp layer,
// display PNG and a samples-per-pixel PFM for heat maps), and report.html from
// scripts/convergence_report.py unless --no-report. Everything is written at the end, each file
// atomically; bad input (scene, reference, options) is found before anything is written.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "renderer/util/color.h"
#include "renderer/app/render.h"
#include "renderer/scene/scene.h"
#include "sampling/convergence_curve.h"
#include "sampling/image_metrics.h"

namespace tessera {

/// Everything `tessera converge` takes on the command line.
struct ConvergeOptions {
    std::string scene;
    std::string output_dir;             ///< -o DIR (created if missing)
    std::vector<std::string> samplers;  ///< --sampler specs (default: uniform, adaptive)
    double time_s = 0;                  ///< --time: budget per sampler, seconds (> 0)
    uint32_t snapshots = 8;             ///< --snapshots N (>= 1)
    double first_snapshot_s = 0;        ///< --first-snapshot (0: time_s / 32)
    SceneOverrides overrides;           ///< --resolution, --max-depth, --seed, --spp (a cap)
    uint32_t threads = 0;               ///< --threads (0: all cores)
    std::string reference;              ///< --reference REF.exr ("" : render and cache one)
    uint32_t reference_spp = 4096;      ///< --reference-spp
    std::string cache_dir;              ///< --cache-dir ("" : default_cache_dir())
    /// --metric of the headline: mse|relmse|relmse-robust|rmse|mae (relmse-robust: relMSE
    /// without the 0.1% largest per-pixel errors, sampling/image_metrics.h)
    std::string metric = "relmse-robust";
    std::vector<double> target_errors;  ///< --target-error (default: from the curves)
    bool report = true;                 ///< false: --no-report
    std::string report_script;          ///< --report-script ("" : find_report_script())
    DisplayOptions display;             ///< PNGs: --ocio-config, --display, --view, --exposure
    bool quiet = false;                 ///< -q: no progress lines (the headline still prints)
};

/// One snapshot of one sampler's render.
struct ConvergenceRow {
    size_t sampler = 0;          ///< index into ConvergeResult::samplers
    uint32_t snapshot = 0;       ///< 0-based
    double target_time_s = 0;    ///< scheduled time
    double time_s = 0;           ///< render time reached (snapshots excluded)
    double snapshot_cost_s = 0;  ///< time to copy the film's images at this snapshot
    double mean_spp = 0;
    uint64_t samples = 0, rays = 0;
    uint32_t passes = 0;   ///< passes every tile completed
    double coverage = 0;   ///< fraction of pixels with at least one sample
    bool stopped = false;  ///< the sampler stopped by itself (converged or --spp reached)
    sampling::ImageComparison metrics;
};

/// One sampler's summary.
struct ConvergenceSampler {
    std::string spec;         ///< as given, e.g. "adaptive:error=0.002"
    std::string description;  ///< SamplerSpec::describe()
    std::string slug;         ///< file name stem: "<index>-<spec with safe characters>"
    /// Log-log fits of error against time (rows with coverage 1): mse, relmse, robust relmse,
    /// rmse, mae.
    sampling::LogLogFit fit_mse, fit_rel_mse, fit_rel_mse_robust, fit_rmse, fit_mae;
    /// Time to reach each headline level (ConvergeResult::levels).
    std::vector<sampling::Crossing> crossings;
    double final_time_s = 0;
};

/// What `tessera converge` measured (written to convergence.{csv,json}).
struct ConvergeResult {
    std::vector<ConvergenceSampler> samplers;
    std::vector<ConvergenceRow> rows;
    std::vector<double> snapshot_times;  ///< the schedule
    std::vector<double> levels;          ///< headline error levels of `metric`, descending
    std::string metric;                  ///< headline metric key
    std::string scene_hash;
    uint32_t width = 0, height = 0, threads = 0, hardware_threads = 0;
    std::string reference_path;
    bool reference_cached = false, reference_rendered = false;
    double reference_noise_mse = -1, reference_noise_rel_mse = -1;  ///< < 0: unknown
    std::string report_path;  ///< "" when no report was written
};

/// Headline metric value of a row ("mse", "relmse", "rmse", "mae"; total over channels).
/// Throws std::invalid_argument for another key.
double headline_value(const sampling::ImageComparison &m, const std::string &metric);

/// The headline levels when none are given: the largest final error over the samplers (the
/// level every sampler reaches) and 2x and 4x that, descending. Rows with coverage < 1 are
/// ignored; empty when no sampler has a usable row.
std::vector<double> default_levels(const ConvergeResult &result);

/// The headline table: time to reach each level per sampler and the speed-up against the
/// first sampler at the lowest level. Lines end in '\n'.
std::string format_headline(const ConvergeResult &result);

/// CSV text of the rows (header line first; one line per row).
std::string convergence_csv(const ConvergeResult &result);

/// Where scripts/convergence_report.py is: $TESSERA_REPORT_SCRIPT, then beside the executable
/// (<exe>/../share/tessera/, <exe>/../scripts/, <exe>/scripts/), then the source tree the
/// executable was built from. "" when none exists.
std::string find_report_script();

/// Runs the whole command. Throws SceneError on bad input (exit code 2), std::exception on
/// internal errors (exit code 1). Prints the headline table to stdout.
ConvergeResult run_converge(const ConvergeOptions &options);

}  // namespace tessera
