// The `tessera` command line: render, samplers, diff, converge.
//
// Exit codes: 0 success, 2 bad input (with "file:line: message"), 1 internal error.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <regex>

#include "renderer/app/converge.h"
#include "renderer/app/diff.h"
#include "renderer/app/mpi_group.h"
#include "renderer/util/error.h"
#include "renderer/util/image_io.h"
#include "renderer/app/render.h"
#include "renderer/scene/specialize.h"

namespace {

/// Parses "WxH" into width and height; false if malformed.
bool parse_resolution(const std::string &s, int *w, int *h) {
    std::smatch m;
    static const std::regex re(R"(^\s*(\d+)\s*[xX]\s*(\d+)\s*$)");
    if (!std::regex_match(s, m, re)) return false;
    // More digits than an int holds: std::stoi would throw out_of_range.
    if (m[1].length() > 9 || m[2].length() > 9) return false;
    *w = std::stoi(m[1]);
    *h = std::stoi(m[2]);
    return *w > 0 && *h > 0;
}

/// `tessera converge` and the command-line values that need conversion afterwards.
struct ConvergeCli {
    tessera::ConvergeOptions options;
    std::string resolution;
    int spp = 0, max_depth = -1;
    long long seed = -1;
    CLI::App *command = nullptr;
};

void add_converge_command(CLI::App &app, ConvergeCli &c) {
    tessera::ConvergeOptions &o = c.options;
    c.command = app.add_subcommand(
        "converge", "Error against time of several samplers for the same time budget");
    CLI::App *cmd = c.command;
    cmd->add_option("scene", o.scene, "Scene file")->required();
    cmd->add_option("-o,--output", o.output_dir, "Output folder (created if missing)")->required();
    // Vector options: one value per occurrence (repeat the flag), so that a positional
    // argument after them is not swallowed.
    cmd->add_option("--sampler", o.samplers,
                    "Sampler to run, repeatable: uniform | adaptive[:error=E,min-spp=N,...] "
                    "(default: uniform and adaptive)")
        ->allow_extra_args(false);
    cmd->add_option("--time", o.time_s, "Wall-clock budget per sampler, seconds")
        ->required()
        ->check(CLI::PositiveNumber);
    cmd->add_option("--snapshots", o.snapshots, "Snapshots per sampler, log-spaced (default 8)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--first-snapshot", o.first_snapshot_s,
                    "Time of the first snapshot, seconds (default: --time / 32)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--reference", o.reference,
                    "Reference EXR (default: render one and cache it)");
    cmd->add_option("--reference-spp", o.reference_spp,
                    "Samples per pixel of a rendered reference (default 4096)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--cache-dir", o.cache_dir,
                    "Reference cache (default $XDG_CACHE_HOME/tessera or ~/.cache/tessera)");
    cmd->add_option("--resolution", c.resolution, "Film resolution WxH (overrides the scene)");
    cmd->add_option("--threads", o.threads, "Worker threads (default: all cores)");
    cmd->add_option("--spp", c.spp, "Cap on samples per pixel (default: none, time decides)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--max-depth", c.max_depth, "Maximum path depth (overrides the scene)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--seed", c.seed, "Sequence seed")->check(CLI::NonNegativeNumber);
    cmd->add_option("--metric", o.metric,
                    "Error of the headline table: mse | relmse | relmse-robust (relMSE without the "
                    "0.1% largest per-pixel errors) | rmse | mae (default relmse-robust)");
    cmd->add_option("--target-error", o.target_errors,
                    "Error level(s) of the headline table, repeatable (default: from the curves)")
        ->allow_extra_args(false);
    cmd->add_flag("--no-report", [&o](int64_t) { o.report = false; },
                  "Do not run scripts/convergence_report.py (report.html)");
    cmd->add_option("--report-script", o.report_script, "Report script to run instead");
    cmd->add_option("--ocio-config", o.display.config_path, "OpenColorIO config for the PNGs");
    cmd->add_option("--exposure", o.display.exposure_stops, "PNG exposure in stops");
    cmd->add_flag("-q,--quiet", o.quiet, "No progress lines");
}

/// `tessera render` and the command-line values that need conversion afterwards.
struct RenderCli {
    tessera::RenderOptions options;
    std::string resolution;
    int spp = 0, max_depth = -1;
    long long seed = -1;
    float clamp = 0;
    std::string sampler_spec = "adaptive";
    uint32_t min_spp = 0;
    double error_target = -1;
    std::string aov_list;
    CLI::Option *aov_option = nullptr;
    std::string no_specialize;
    CLI::App *command = nullptr;
};

/// Declares `tessera render` and its options on `app`, bound to `c`.
void add_render_command(CLI::App &app, RenderCli &c) {
    tessera::RenderOptions &ro = c.options;
    c.command = app.add_subcommand("render", "Render a scene (.pbrt, .obj or .ply)");
    CLI::App *render = c.command;
    render->add_option("scene", ro.scene, "Scene file")->required();
    render->add_option("-o,--output", ro.output,
                       "Output EXR (a display PNG is written beside it); default: the scene's "
                       "Film filename");
    render->add_option("--spp", c.spp,
                       "Samples per pixel (overrides the scene's pixelsamples): uniform's count; "
                       "the adaptive sampler reaches that count's relMSE with fewer samples, or "
                       "caps with --time / --error")
        ->check(CLI::PositiveNumber);
    render->add_option("--resolution", c.resolution, "Film resolution WxH (overrides the scene)");
    render->add_option("--threads", ro.threads, "Worker threads (default: all cores)");
    render->add_option("--seed", c.seed, "Sequence seed")->check(CLI::NonNegativeNumber);
    render->add_option("--max-depth", c.max_depth, "Maximum path depth (overrides the scene)")
        ->check(CLI::NonNegativeNumber);
    render->add_option("--clamp", c.clamp,
                       "Firefly clamp: scale each sample down so that its largest RGB component "
                       "is at most VALUE (biased; default off, or the scene's Film "
                       "\"maxcomponentvalue\")")
        ->check(CLI::PositiveNumber);
    render->add_option("--time", ro.time_s, "Wall-clock budget in seconds (0: none)")
        ->check(CLI::NonNegativeNumber);
    render->add_option("--sampler", c.sampler_spec,
                       "NAME[:key=value,...]: uniform | adaptive (default) | fixed | jin | kim | "
                       "fliptri | flipquad | suffern; `tessera samplers` lists their keys");
    render->add_option("--integrator", ro.integrator,
                       "path | whitted (default: path; whitted for the real-time samplers)");
    render->add_option("--frames", ro.frames,
                       "Real-time samplers: frames to render (statistics over all of them)")
        ->check(CLI::PositiveNumber);
    render->add_option("--orbit", ro.orbit_deg,
                       "Real-time samplers: orbit the camera by DEGREES over the frames");
    render->add_option("--min-spp", c.min_spp,
                       "Samples per pixel of the uniform first pass (default 16)")
        ->check(CLI::PositiveNumber);
    render->add_option("--error", c.error_target,
                       "Adaptive stopping: the image relMSE to reach (with adaptive:dammertz=1 Dammertz's "
                       "region error; 0: none)")
        ->check(CLI::NonNegativeNumber);
    render->add_flag("--deterministic", ro.deterministic,
                     "Barriers between passes: the same image for any thread count");
    render->add_option("--max-passes", ro.max_passes, "Stop after this many passes (0: none)");
    render->add_option("--checkpoint", ro.checkpoint,
                       "Write a checkpoint EXR here at the end (and on Ctrl-C, which otherwise "
                       "writes OUT.checkpoint.exr)");
    render->add_option("--checkpoint-every", ro.checkpoint_every,
                       "Also write the checkpoint every SECONDS")
        ->check(CLI::NonNegativeNumber);
    render->add_option("--resume", ro.resume, "Continue from a checkpoint EXR");
    render->add_option("--stats", ro.stats_path, "Write render statistics as JSON");
    c.aov_option = render->add_option(
        "--aov", c.aov_list,
        "AOV layers to keep and write: a comma list of albedo, normal, depth, or all, or none "
        "(default: the scene's Film, \"gbuffer\" all, \"rgb\" none; --resume keeps the "
        "checkpoint's)");
    render->add_flag("--half", ro.half, "Write half-float EXR colour channels");
    render->add_flag("--no-png", [&ro](int64_t) { ro.write_png = false; }, "Do not write the PNG");
    render->add_option("--ocio-config", ro.display.config_path,
                       "OpenColorIO config for the PNG (default: $OCIO, else built in sRGB)");
    render->add_option("--display", ro.display.display, "OCIO display (default: the config's)");
    render->add_option("--view", ro.display.view, "OCIO view (default: the display's)");
    render->add_option("--exposure", ro.display.exposure_stops, "PNG exposure in stops");
    render->add_flag("-q,--quiet", ro.quiet, "No progress bar or summary");
    render->add_flag(
        "--no-specialize{all}", c.no_specialize,
        "Force the general code paths (benchmarks): all, or --no-specialize=NAME,... "
        "of differentials, lambertian, packet, cull, alpha, attributes "
        "(renderer/scene/specialize.h)");
}

/// Parses --resolution into `overrides`; false (after the message) when malformed.
bool apply_resolution(const std::string &resolution, tessera::SceneOverrides &overrides) {
    if (resolution.empty()) return true;
    int w, h;
    if (!parse_resolution(resolution, &w, &h)) {
        std::fprintf(stderr, "tessera: --resolution: expected WxH, got \"%s\"\n",
                     resolution.c_str());
        return false;
    }
    overrides.width = w;
    overrides.height = h;
    return true;
}

/// Runs `tessera converge` with the parsed command line; returns the exit code.
int run_converge_command(ConvergeCli &c) {
    tessera::ConvergeOptions &o = c.options;
    if (!apply_resolution(c.resolution, o.overrides)) return 2;
    if (c.spp > 0) o.overrides.spp = c.spp;
    if (c.max_depth >= 0) o.overrides.max_depth = c.max_depth;
    if (c.seed >= 0) o.overrides.seed = uint32_t(c.seed);
    tessera::run_converge(o);
    return 0;
}

/// Runs `tessera render` with the parsed command line; returns the exit code.
int run_render_command(RenderCli &c) {
    tessera::RenderOptions &ro = c.options;
    if (!apply_resolution(c.resolution, ro.overrides)) return 2;
    if (c.spp > 0) ro.overrides.spp = c.spp;
    ro.sampler = tessera::parse_sampler_spec(c.sampler_spec);
    if (c.min_spp > 0) ro.min_spp = c.min_spp;
    if (c.error_target >= 0) ro.error = c.error_target;
    if (c.max_depth >= 0) ro.overrides.max_depth = c.max_depth;
    if (c.seed >= 0) ro.overrides.seed = uint32_t(c.seed);
    if (c.clamp > 0) ro.overrides.max_component = c.clamp;
    if (!c.no_specialize.empty()) {
        try {
            ro.no_specialize = tessera::parse_specializations(c.no_specialize);
        } catch (const std::invalid_argument &e) {
            std::fprintf(stderr, "tessera: --no-specialize: %s\n", e.what());
            return 2;
        }
    }
    if (c.aov_option->count() > 0) {
        try {
            ro.overrides.aovs = tessera::sampling::AovSet::parse(c.aov_list);
        } catch (const std::invalid_argument &e) {
            std::fprintf(stderr, "tessera: --aov: %s\n", e.what());
            return 2;
        }
    }
    tessera::run_render(ro);
    return 0;
}

}  // namespace

int main(int argc, char **argv) {
    CLI::App app{"Tessera: a progressive Monte Carlo path tracer for pbrt-v4 scenes"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("tessera ") + TESSERA_VERSION + "\n" +
                                          tessera::mpi_build_info());

    RenderCli render;
    add_render_command(app, render);

    CLI::App *samplers =
        app.add_subcommand("samplers", "List the sampler plugins with their keys and defaults");

    std::string diff_a, diff_b;
    CLI::App *diff =
        app.add_subcommand("diff", "Compare two images: MSE, RMSE, relMSE, PSNR, means");
    diff->add_option("test", diff_a, "Image to test")->required();
    diff->add_option("reference", diff_b, "Reference image")->required();

    ConvergeCli converge;
    add_converge_command(app, converge);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError &e) {
        int rc = app.exit(e);
        return rc == 0 ? 0 : 2;
    }

    // Under mpirun: this process is one rank of the job (renderer/app/mpi_group.h). A rank that
    // fails ends the whole job (the others may wait in a collective): it says what failed, then
    // MPI_Abort, and mpirun names the rank.
    std::unique_ptr<tessera::MpiJob> job;
    auto fail = [&](int rc) {
        if (job && job->size() > 1) job->abort(rc);
        return rc;
    };
    try {
        job = tessera::MpiJob::start(argc, argv);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "tessera: MPI: %s\n", e.what());
        return 2;
    }
    if (job && job->size() > 1) {
        if (!*render.command) {
            if (job->rank() == 0)
                std::fprintf(stderr, "tessera: only `tessera render` runs on several MPI ranks "
                                     "(converge, diff and samplers run in one process)\n");
            return fail(2);
        }
        render.options.group = &job->group();
        render.options.host = job->host();
        if (job->rank() != 0) {
            // Every rank reads the same scene: rank 0 alone reports.
            render.options.quiet = true;
            tessera::mute_warnings(true);
        }
    }

    try {
        if (*diff) return tessera::run_diff(diff_a, diff_b, std::cout, std::cerr);
        if (*samplers) {
            std::cout << tessera::sampling::format_plugin_list();
            return 0;
        }
        if (*converge.command) return run_converge_command(converge);
        if (*render.command) return run_render_command(render);
    } catch (const tessera::SceneError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return fail(2);
    } catch (const tessera::OutputError &e) {
        std::fprintf(stderr, "tessera: cannot write output: %s\n", e.what());
        return fail(1);
    } catch (const std::bad_alloc &) {
        // The limits (renderer/util/limits.h) check the large allocations up front; this is what
        // slipped past them.
        std::fprintf(stderr, "tessera: out of memory\n");
        return fail(1);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "tessera: internal error: %s\n", e.what());
        return fail(1);
    }
    return 0;
}
