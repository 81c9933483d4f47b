#include "renderer/render.h"

#include <sys/resource.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "renderer/image_io.h"
#include "renderer/path_integrator.h"

namespace tessera {

namespace fs = std::filesystem;

namespace {

std::atomic<bool> g_cancel{false};

extern "C" void on_signal(int) { g_cancel.store(true); }

/// Installs SIGINT/SIGTERM handlers for the duration of a render: the first signal finishes
/// the tiles in flight and writes the image; the handlers are restored afterwards.
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

}  // namespace

size_t peak_rss_bytes() {
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    return size_t(ru.ru_maxrss) * 1024;
}

std::pair<std::string, std::string> output_paths(const std::string &requested) {
    fs::path p(requested.empty() ? "pbrt.exr" : requested);
    fs::path stem = p;
    stem.replace_extension();
    return {stem.string() + ".exr", stem.string() + ".png"};
}

sched::RenderStats render_scene(const Scene &scene, sampling::Film &film, uint32_t threads,
                                double time_s, bool quiet, const std::atomic<bool> *cancel) {
    PathIntegrator integrator(scene, scene.settings.seed, scene.settings.max_depth);
    sched::SchedulerOptions so;
    so.threads = threads;
    so.seed = scene.settings.seed;
    so.progress = quiet ? sched::ProgressReporter::Mode::Never : sched::ProgressReporter::Mode::Auto;
    sched::TileScheduler scheduler(integrator, film, so);
    sched::RenderBudget budget;
    budget.spp = uint32_t(scene.settings.spp);
    budget.time_s = time_s;
    return scheduler.render(budget, cancel);
}

RenderReport run_render(const RenderOptions &opt) {
    RenderReport rep;
    auto t0 = std::chrono::steady_clock::now();
    std::unique_ptr<Scene> scene = load_scene(opt.scene, opt.overrides);
    rep.load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!opt.quiet) std::fprintf(stderr, "tessera: %s\n", scene->describe().c_str());

    std::string requested = opt.output.empty() ? scene->settings.output : opt.output;
    auto [exr, png] = output_paths(requested);
    rep.exr_path = exr;
    rep.png_path = opt.write_png ? png : "";
    // Fail before rendering when the output folder does not exist.
    fs::path dir = fs::path(exr).parent_path();
    std::error_code ec;
    if (!dir.empty() && !fs::is_directory(dir, ec))
        throw SceneError(exr + ":0: the output folder does not exist");

    sampling::Film film(uint32_t(scene->settings.width), uint32_t(scene->settings.height));
    {
        SignalGuard guard;
        rep.stats = render_scene(*scene, film, opt.threads, opt.time_s, opt.quiet, &g_cancel);
    }
    if (rep.stats.cancelled && !opt.quiet)
        std::fprintf(stderr, "tessera: interrupted; writing the partial image\n");

    ExrWriteOptions eo;
    eo.half = opt.half;
    write_film_exr(exr, film, eo);
    if (opt.write_png) {
        sampling::RgbImage img(film.width(), film.height(), film.beauty_rgb());
        write_display_image(png, img, opt.display);
    }
    rep.width = film.width();
    rep.height = film.height();
    rep.spp = uint32_t(scene->settings.spp);
    rep.film_bytes_per_pixel = film.bytes_per_pixel();
    rep.peak_rss_bytes = peak_rss_bytes();

    if (!opt.stats_path.empty()) {
        const auto &s = rep.stats;
        nlohmann::json j;
        j["scene"] = opt.scene;
        j["width"] = rep.width;
        j["height"] = rep.height;
        j["spp"] = rep.spp;
        j["samples"] = s.samples;
        j["rays"] = s.rays;
        j["nan_count"] = s.nan_samples;
        j["threads"] = s.threads;
        j["passes"] = s.passes;
        j["wall_s"] = s.wall_s;
        j["load_s"] = rep.load_s;
        j["mrays_per_s"] = s.wall_s > 0 ? double(s.rays) / s.wall_s * 1e-6 : 0.0;
        j["samples_per_s"] = s.wall_s > 0 ? double(s.samples) / s.wall_s : 0.0;
        j["cancelled"] = s.cancelled;
        j["out_of_time"] = s.out_of_time;
        j["film_bytes_per_pixel"] = rep.film_bytes_per_pixel;
        j["peak_rss_bytes"] = rep.peak_rss_bytes;
        j["features"] = scene->features.describe();
        j["version"] = TESSERA_VERSION;
        write_atomically(opt.stats_path, [&](const std::string &tmp) {
            std::ofstream f(tmp);
            f << j.dump(2) << "\n";
            if (!f) throw std::runtime_error(opt.stats_path + ": cannot write");
        });
    }
    if (!opt.quiet)
        std::fprintf(stderr, "tessera: %s\ntessera: wrote %s%s%s\n", rep.stats.describe().c_str(),
                     exr.c_str(), opt.write_png ? " and " : "", opt.write_png ? png.c_str() : "");
    return rep;
}

}  // namespace tessera
