// The `tessera` command line: render, samplers, diff.
//
// Exit codes: 0 success, 2 bad input (with "file:line: message"), 1 internal error.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <regex>

#include "renderer/diff.h"
#include "renderer/render.h"

namespace {

/// Parses "WxH" into width and height; false if malformed.
bool parse_resolution(const std::string &s, int *w, int *h) {
    std::smatch m;
    static const std::regex re(R"(^\s*(\d+)\s*[xX]\s*(\d+)\s*$)");
    if (!std::regex_match(s, m, re)) return false;
    *w = std::stoi(m[1]);
    *h = std::stoi(m[2]);
    return *w > 0 && *h > 0;
}

}  // namespace

int main(int argc, char **argv) {
    CLI::App app{"Tessera: a progressive Monte Carlo path tracer for pbrt-v4 scenes"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("tessera ") + TESSERA_VERSION);

    tessera::RenderOptions ro;
    std::string resolution;
    int spp = 0, max_depth = -1;
    long long seed = -1;
    CLI::App *render = app.add_subcommand("render", "Render a scene (.pbrt, .obj or .ply)");
    render->add_option("scene", ro.scene, "Scene file")->required();
    render->add_option("-o,--output", ro.output,
                       "Output EXR (a display PNG is written beside it); default: the scene's "
                       "Film filename");
    render->add_option("--spp", spp, "Maximum samples per pixel (overrides the scene's pixelsamples)")
        ->check(CLI::PositiveNumber);
    render->add_option("--resolution", resolution, "Film resolution WxH (overrides the scene)");
    render->add_option("--threads", ro.threads, "Worker threads (default: all cores)");
    render->add_option("--seed", seed, "Sequence seed")->check(CLI::NonNegativeNumber);
    render->add_option("--max-depth", max_depth, "Maximum path depth (overrides the scene)")
        ->check(CLI::NonNegativeNumber);
    render->add_option("--time", ro.time_s, "Wall-clock budget in seconds (0: none)")
        ->check(CLI::NonNegativeNumber);
    std::string sampler_spec = "adaptive";
    render->add_option("--sampler", sampler_spec,
                       "NAME[:key=value,...]: uniform | adaptive (default) | fixed | jin | kim | "
                       "fliptri | flipquad | suffern; `tessera samplers` lists their keys");
    render->add_option("--integrator", ro.integrator,
                       "path | whitted (default: path; whitted for the real-time samplers)");
    render->add_option("--frames", ro.frames,
                       "Real-time samplers: frames to render (statistics over all of them)")
        ->check(CLI::PositiveNumber);
    render->add_option("--orbit", ro.orbit_deg,
                       "Real-time samplers: orbit the camera by DEGREES over the frames");
    uint32_t min_spp = 0;
    render->add_option("--min-spp", min_spp,
                       "Samples per pixel of the uniform first pass (default 16)")
        ->check(CLI::PositiveNumber);
    double error_target = -1;
    render->add_option("--error", error_target,
                       "Adaptive stopping: region error target (Dammertz; 0: none)")
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
    render->add_flag("--half", ro.half, "Write half-float EXR colour channels");
    render->add_flag("--no-png", [&](int64_t) { ro.write_png = false; }, "Do not write the PNG");
    render->add_option("--ocio-config", ro.display.config_path,
                       "OpenColorIO config for the PNG (default: $OCIO, else built in sRGB)");
    render->add_option("--display", ro.display.display, "OCIO display (default: the config's)");
    render->add_option("--view", ro.display.view, "OCIO view (default: the display's)");
    render->add_option("--exposure", ro.display.exposure_stops, "PNG exposure in stops");
    render->add_flag("-q,--quiet", ro.quiet, "No progress bar or summary");

    CLI::App *samplers =
        app.add_subcommand("samplers", "List the sampler plugins with their keys and defaults");

    std::string diff_a, diff_b;
    CLI::App *diff = app.add_subcommand("diff", "Compare two images: MSE, RMSE, relMSE, PSNR, means");
    diff->add_option("test", diff_a, "Image to test")->required();
    diff->add_option("reference", diff_b, "Reference image")->required();

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError &e) {
        int rc = app.exit(e);
        return rc == 0 ? 0 : 2;
    }

    try {
        if (*diff) return tessera::run_diff(diff_a, diff_b, std::cout, std::cerr);
        if (*samplers) {
            std::cout << tessera::sampling::format_plugin_list();
            return 0;
        }
        if (*render) {
            if (!resolution.empty()) {
                int w, h;
                if (!parse_resolution(resolution, &w, &h)) {
                    std::fprintf(stderr, "tessera: --resolution: expected WxH, got \"%s\"\n",
                                 resolution.c_str());
                    return 2;
                }
                ro.overrides.width = w;
                ro.overrides.height = h;
            }
            if (spp > 0) ro.overrides.spp = spp;
            ro.sampler = tessera::parse_sampler_spec(sampler_spec);
            if (min_spp > 0) ro.min_spp = min_spp;
            if (error_target >= 0) ro.error = error_target;
            if (max_depth >= 0) ro.overrides.max_depth = max_depth;
            if (seed >= 0) ro.overrides.seed = uint32_t(seed);
            tessera::run_render(ro);
            return 0;
        }
    } catch (const tessera::SceneError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "tessera: internal error: %s\n", e.what());
        return 1;
    }
    return 0;
}
