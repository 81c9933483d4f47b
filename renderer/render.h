// `tessera render`: load a scene, render it on the tile scheduler, write EXR + PNG + stats.
#pragma once

#include <optional>
#include <string>

#include "renderer/color.h"
#include "renderer/scene.h"
#include "sampling/film.h"
#include "scheduler/tile_scheduler.h"

namespace tessera {

/// Everything `tessera render` takes on the command line.
struct RenderOptions {
    std::string scene;
    std::string output;             ///< EXR path ("" : from the scene's Film "filename")
    SceneOverrides overrides;       ///< --spp, --resolution, --seed, --max-depth
    uint32_t threads = 0;           ///< 0: all cores
    double time_s = 0;              ///< 0: no time limit
    std::string stats_path;         ///< --stats FILE.json ("" : none)
    bool half = false;              ///< write half-float EXR colour channels
    bool write_png = true;
    DisplayOptions display;         ///< --ocio-config, --view, --display, --exposure
    bool quiet = false;             ///< no progress bar and no summary
};

/// What a render produced (for the stats JSON and tests).
struct RenderReport {
    sched::RenderStats stats;
    double load_s = 0;
    std::string exr_path, png_path;
    uint32_t width = 0, height = 0, spp = 0;
    size_t film_bytes_per_pixel = 0;
    size_t peak_rss_bytes = 0;
};

/// The EXR and PNG paths for a requested output name: "x.exr" -> (x.exr, x.png); a name with
/// another extension ("cornell-box.png" from a pbrt Film) keeps its stem.
std::pair<std::string, std::string> output_paths(const std::string &requested);

/// Renders `scene` into `film` with the scheduler; `cancel` may stop it early (Ctrl-C).
sched::RenderStats render_scene(const Scene &scene, sampling::Film &film, uint32_t threads,
                                double time_s, bool quiet, const std::atomic<bool> *cancel);

/// Runs the whole `tessera render` command. Throws SceneError on bad input (exit code 2) and
/// std::exception on internal errors (exit code 1).
RenderReport run_render(const RenderOptions &options);

/// Peak resident memory of this process in bytes (Linux getrusage).
size_t peak_rss_bytes();

}  // namespace tessera
