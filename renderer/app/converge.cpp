// `tessera converge`: equal-time error-versus-time runs of several samplers against a reference.
#include "renderer/app/converge.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "renderer/util/image_io.h"
#include "renderer/util/json_io.h"
#include "renderer/integrators/integrators.h"
#include "renderer/app/reference.h"
#include "scheduler/adaptive_scheduler.h"
#include "scheduler/progressive_run.h"

extern char **environ;

namespace tessera {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// "3-adaptive-error-0.002": index, then the spec with every character outside [A-Za-z0-9.]
// replaced by '-', for file names.
std::string make_slug(size_t index, const std::string &spec) {
    std::string s = std::to_string(index) + "-";
    for (char c : spec)
        s += std::isalnum(static_cast<unsigned char>(c)) || c == '.' ? c : '-';
    return s;
}

// Writes a single-channel little-endian PFM ("Pf"), rows bottom to top as the format says.
void write_pfm(const std::string &path, uint32_t w, uint32_t h, const std::vector<float> &v) {
    write_atomically(path, [&](const std::string &tmp) {
        std::ofstream f(tmp, std::ios::binary);
        f << "Pf\n" << w << " " << h << "\n-1.0\n";
        for (uint32_t y = h; y-- > 0;)
            f.write(reinterpret_cast<const char *>(v.data() + size_t(y) * w),
                    std::streamsize(sizeof(float) * w));
        if (!f)
            throw std::runtime_error(path + ": cannot write");
    });
}

// One sampler's progressive render, advanced snapshot by snapshot. The samplers' chunks are
// interleaved (snapshot k of every sampler, then k + 1), so that a machine that slows down for a
// while (other processes) costs every sampler alike instead of the one that happened to run.
class SamplerRun {
  public:
    SamplerRun(const Scene &scene, const SamplerSpec &spec, const ConvergeOptions &opt)
        : film_(uint32_t(scene.settings.width), uint32_t(scene.settings.height), {},
                keeps_prefix(spec)),
          integrator_(make_path_tracer(scene, scene.settings.seed, scene.settings.max_depth)),
          run_(*integrator_, film_, options(scene, spec, opt)) {}

    /// Renders until `target_s` seconds of render time in all (unless it stopped by itself),
    /// then takes snapshot `k`: the row and, when `keep` or it stopped, the final images.
    ConvergenceRow advance(double target_s, uint32_t k, bool keep, const sampling::RgbImage &ref) {
        const double remaining = target_s - render_s_;
        if (remaining > 0 && !stopped_) {
            auto t0 = Clock::now();
            // Each chunk resumes at the first pass some tile has not finished and from the
            // refined target (sched::ProgressiveRun).
            sched::AdaptiveStats st = run_.advance(remaining, nullptr);
            render_s_ += seconds_since(t0);
            // Neither time nor cancel stopped it: converged, or every pass up to --spp done.
            stopped_ = !st.out_of_time;
        }
        // The snapshot: copies of the mean image and the counts (timed, not in render_s_).
        const uint32_t w = film_.width(), h = film_.height();
        const double pixels = double(w) * double(h);
        auto t_snap = Clock::now();
        sampling::RgbImage img(w, h, film_.beauty_rgb());
        std::vector<float> spp = film_.spp();
        ConvergenceRow row;
        row.snapshot_cost_s = seconds_since(t_snap);
        row.snapshot = k;
        row.target_time_s = target_s;
        row.time_s = render_s_;
        row.samples = run_.total().samples;
        row.rays = run_.total().rays;
        row.passes = run_.chunks() ? uint32_t(run_.start_pass()) : 0;
        row.mean_spp = double(film_.total_samples()) / pixels;
        row.coverage =
            double(std::count_if(spp.begin(), spp.end(), [](float v) { return v > 0; })) / pixels;
        row.stopped = stopped_;
        row.metrics = sampling::compare_images(img, ref, 1.0);
        if (keep || stopped_) {
            final_beauty = std::move(img);
            final_spp = std::move(spp);
        }
        return row;
    }

    bool stopped() const { return stopped_; }

    sampling::RgbImage final_beauty;  ///< the last snapshot's mean image
    std::vector<float> final_spp;     ///< and its samples per pixel

  private:
    static sched::AdaptiveOptions options(const Scene &scene, const SamplerSpec &spec,
                                          const ConvergeOptions &opt) {
        sched::AdaptiveOptions o = scheduler_options(scene, spec, opt.threads, true);
        // Time is the budget: no sample cap unless --spp gives one.
        o.max_spp = opt.overrides.spp ? uint32_t(*opt.overrides.spp) : 0;
        if (o.max_spp)
            o.min_spp = std::min(o.min_spp, o.max_spp);
        // Time is the budget: refining runs (the relMSE default, or refine=1) lower their
        // target as regions complete and use the whole budget ("stopped" then means the spp
        // cap or the floor target).
        apply_refinement(o, spec, RenderBudget{true, opt.overrides.spp.has_value()});
        return o;
    }

    sampling::Film film_;
    std::unique_ptr<SampleSource> integrator_;
    sched::ProgressiveRun run_;
    double render_s_ = 0;
    bool stopped_ = false;
};

// Fits and crossing times of the usable rows (coverage 1) of sampler `i`.
void summarise_sampler(ConvergeResult &r, size_t i) {
    std::vector<double> t, mse, rel, rel_robust, rmse, mae, head;
    for (const ConvergenceRow &row : r.rows) {
        if (row.sampler != i)
            continue;
        r.samplers[i].final_time_s = row.time_s;
        if (row.coverage < 1.0)
            continue;
        t.push_back(row.time_s);
        mse.push_back(row.metrics.mse.total);
        rel.push_back(row.metrics.rel_mse.total);
        rel_robust.push_back(row.metrics.rel_mse_robust.total);
        rmse.push_back(row.metrics.rmse.total);
        mae.push_back(row.metrics.mae.total);
        head.push_back(headline_value(row.metrics, r.metric));
    }
    ConvergenceSampler &s = r.samplers[i];
    s.fit_mse = sampling::fit_loglog(t, mse);
    s.fit_rel_mse = sampling::fit_loglog(t, rel);
    s.fit_rel_mse_robust = sampling::fit_loglog(t, rel_robust);
    s.fit_rmse = sampling::fit_loglog(t, rmse);
    s.fit_mae = sampling::fit_loglog(t, mae);
    s.crossings.clear();
    for (double level : r.levels)
        s.crossings.push_back(sampling::time_to_reach(t, head, level));
}

nlohmann::json finite_or_null(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json metric_json(const sampling::ChannelMetric &m) {
    return {{"r", finite_or_null(m.channel[0])},
            {"g", finite_or_null(m.channel[1])},
            {"b", finite_or_null(m.channel[2])},
            {"total", finite_or_null(m.total)}};
}

nlohmann::json fit_json(const sampling::LogLogFit &f) {
    if (!f.valid)
        return {{"slope", nullptr}, {"intercept", nullptr}, {"points", f.points}};
    return {{"slope", f.slope}, {"intercept", f.intercept}, {"points", f.points}};
}

const char *crossing_kind(sampling::Crossing::Kind k) {
    switch (k) {
        case sampling::Crossing::Kind::reached:
            return "reached";
        case sampling::Crossing::Kind::before_first:
            return "before_first";
        default:
            return "not_reached";
    }
}

std::string metric_label(const std::string &metric) {
    if (metric == "mse")
        return "MSE";
    if (metric == "relmse")
        return "relMSE";
    if (metric == "relmse-robust")
        return "relMSE-0.1%";
    if (metric == "rmse")
        return "RMSE";
    return "MAE";
}

// One table cell: "12.3", "<0.47" (already below at the first usable snapshot), ">30" (not
// reached within the budget).
std::string crossing_cell(const sampling::Crossing &c) {
    char buf[64];
    const char *prefix = c.kind == sampling::Crossing::Kind::before_first  ? "<="
                         : c.kind == sampling::Crossing::Kind::not_reached ? ">"
                                                                           : "";
    std::snprintf(buf, sizeof buf, "%s%.3g", prefix, c.time_s);
    return buf;
}

nlohmann::json result_json(const ConvergeResult &r, const ConvergeOptions &opt,
                           const std::string &scene_path,
                           const std::vector<nlohmann::json> &images) {
    nlohmann::json j;
    j["tessera_version"] = TESSERA_VERSION;
    j["scene"] = scene_path;
    j["scene_hash"] = r.scene_hash;
    j["hardware_threads"] = r.hardware_threads;
    j["threads"] = r.threads;
    j["settings"] = {{"time_s", opt.time_s},
                     {"snapshots", opt.snapshots},
                     {"snapshot_times_s", r.snapshot_times},
                     {"width", r.width},
                     {"height", r.height},
                     {"max_depth", nullptr},
                     {"seed", nullptr},
                     {"spp_cap", opt.overrides.spp ? nlohmann::json(*opt.overrides.spp)
                                                   : nlohmann::json(nullptr)},
                     {"metric", r.metric}};
    j["reference"] = {
        {"path", r.reference_path},
        {"cached", r.reference_cached},
        {"rendered", r.reference_rendered},
        {"noise_mse", r.reference_noise_mse >= 0 ? nlohmann::json(r.reference_noise_mse)
                                                 : nlohmann::json(nullptr)},
        {"noise_relmse", r.reference_noise_rel_mse >= 0 ? nlohmann::json(r.reference_noise_rel_mse)
                                                        : nlohmann::json(nullptr)}};
    nlohmann::json samplers = nlohmann::json::array();
    for (size_t i = 0; i < r.samplers.size(); ++i) {
        const ConvergenceSampler &s = r.samplers[i];
        nlohmann::json cross = nlohmann::json::array();
        for (size_t l = 0; l < s.crossings.size(); ++l)
            cross.push_back({{"level", r.levels[l]},
                             {"kind", crossing_kind(s.crossings[l].kind)},
                             {"time_s", s.crossings[l].time_s}});
        samplers.push_back({{"index", i},
                            {"spec", s.spec},
                            {"description", s.description},
                            {"slug", s.slug},
                            {"final_time_s", s.final_time_s},
                            {"fit",
                             {{"mse", fit_json(s.fit_mse)},
                              {"relmse", fit_json(s.fit_rel_mse)},
                              {"relmse_robust", fit_json(s.fit_rel_mse_robust)},
                              {"rmse", fit_json(s.fit_rmse)},
                              {"mae", fit_json(s.fit_mae)}}},
                            {"time_to_error", cross},
                            {"images", images[i]}});
    }
    j["samplers"] = samplers;
    j["headline"] = {{"metric", r.metric}, {"levels", r.levels}};
    nlohmann::json rows = nlohmann::json::array();
    for (const ConvergenceRow &row : r.rows) {
        const sampling::ImageComparison &m = row.metrics;
        rows.push_back({{"sampler_index", row.sampler},
                        {"sampler", r.samplers[row.sampler].spec},
                        {"snapshot", row.snapshot},
                        {"target_time_s", row.target_time_s},
                        {"time_s", row.time_s},
                        {"snapshot_cost_s", row.snapshot_cost_s},
                        {"mean_spp", row.mean_spp},
                        {"samples", row.samples},
                        {"rays", row.rays},
                        {"passes", row.passes},
                        {"coverage", row.coverage},
                        {"stopped", row.stopped},
                        {"mse", metric_json(m.mse)},
                        {"relmse", metric_json(m.rel_mse)},
                        {"relmse_robust", metric_json(m.rel_mse_robust)},
                        {"rmse", metric_json(m.rmse)},
                        {"psnr", metric_json(m.psnr)},
                        {"mae", metric_json(m.mae)}});
    }
    j["rows"] = rows;
    return j;
}

// Runs `argv` (argv[0] looked up in PATH), waits, and returns its exit status (127: not run).
int run_program(const std::vector<std::string> &args) {
    std::vector<char *> argv;
    for (const std::string &a : args)
        argv.push_back(const_cast<char *>(a.c_str()));
    argv.push_back(nullptr);
    pid_t pid = 0;
    if (posix_spawnp(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0)
        return 127;
    int status = 0;
    if (waitpid(pid, &status, 0) < 0)
        return 127;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

void check_options(const ConvergeOptions &o) {
    if (!(o.time_s > 0) || !std::isfinite(o.time_s))
        throw SceneError("--time: a budget in seconds > 0 is required");
    if (o.snapshots < 1)
        throw SceneError("--snapshots: at least 1");
    if (o.first_snapshot_s < 0 || o.first_snapshot_s > o.time_s)
        throw SceneError("--first-snapshot: must lie in (0, --time]");
    if (o.output_dir.empty())
        throw SceneError("-o: an output folder is required");
    if (o.metric != "mse" && o.metric != "relmse" && o.metric != "relmse-robust" &&
        o.metric != "rmse" && o.metric != "mae")
        throw SceneError("--metric: expected mse, relmse, relmse-robust, rmse or mae, got \"" +
                         o.metric + "\"");
    for (double e : o.target_errors)
        if (!(e > 0) || !std::isfinite(e))
            throw SceneError("--target-error: must be > 0");
    if (o.reference_spp < 1)
        throw SceneError("--reference-spp: at least 1");
}

}  // namespace

double headline_value(const sampling::ImageComparison &m, const std::string &metric) {
    if (metric == "mse")
        return m.mse.total;
    if (metric == "relmse")
        return m.rel_mse.total;
    if (metric == "relmse-robust")
        return m.rel_mse_robust.total;
    if (metric == "rmse")
        return m.rmse.total;
    if (metric == "mae")
        return m.mae.total;
    throw std::invalid_argument("unknown metric \"" + metric + "\"");
}

std::vector<double> default_levels(const ConvergeResult &r) {
    double worst = 0;
    for (size_t i = 0; i < r.samplers.size(); ++i) {
        double last = -1;
        for (const ConvergenceRow &row : r.rows)
            if (row.sampler == i && row.coverage >= 1.0)
                last = headline_value(row.metrics, r.metric);
        if (std::isfinite(last))
            worst = std::max(worst, last);
    }
    if (!(worst > 0))
        return {};
    return {4 * worst, 2 * worst, worst};
}

std::string format_headline(const ConvergeResult &r) {
    std::ostringstream os;
    char buf[256];
    os << "time to reach " << metric_label(r.metric)
       << " E, seconds (log-log interpolation between snapshots; <= : already at the first "
          "snapshot, > : not within the budget)\n";
    size_t name_w = 8;
    for (const ConvergenceSampler &s : r.samplers)
        name_w = std::max(name_w, s.spec.size());
    std::snprintf(buf, sizeof buf, "%-*s", int(name_w), "sampler");
    os << buf;
    for (double l : r.levels) {
        char level[32];
        std::snprintf(level, sizeof level, "E=%.3g", l);
        std::snprintf(buf, sizeof buf, "  %12s", level);
        os << buf;
    }
    os << "  speed-up\n";
    const size_t last = r.levels.empty() ? 0 : r.levels.size() - 1;
    for (const ConvergenceSampler &s : r.samplers) {
        std::snprintf(buf, sizeof buf, "%-*s", int(name_w), s.spec.c_str());
        os << buf;
        for (const sampling::Crossing &c : s.crossings) {
            std::snprintf(buf, sizeof buf, "  %12s", crossing_cell(c).c_str());
            os << buf;
        }
        // Speed-up at the lowest level against the first sampler, when both reached it.
        std::string speed = "-";
        if (!r.levels.empty() && !r.samplers.front().crossings.empty()) {
            const sampling::Crossing &a = r.samplers.front().crossings[last],
                                     &b = s.crossings[last];
            if (a.kind == sampling::Crossing::Kind::reached &&
                b.kind == sampling::Crossing::Kind::reached && b.time_s > 0) {
                std::snprintf(buf, sizeof buf, "%.2fx", a.time_s / b.time_s);
                speed = buf;
            }
        }
        std::snprintf(buf, sizeof buf, "  %8s\n", speed.c_str());
        os << buf;
    }
    return os.str();
}

std::string convergence_csv(const ConvergeResult &r) {
    std::ostringstream os;
    os << "sampler_index,sampler,snapshot,target_time_s,time_s,snapshot_cost_s,mean_spp,samples,"
          "rays,passes,coverage,stopped";
    for (const char *m : {"mse", "relmse", "rmse", "psnr", "mae", "relmse_robust"})
        os << "," << m << "_r," << m << "_g," << m << "_b," << m;
    os << "\n";
    char buf[64];
    auto num = [&](double v) {
        std::snprintf(buf, sizeof buf, "%.9g", v);
        return std::string(buf);
    };
    for (const ConvergenceRow &row : r.rows) {
        // The spec may hold commas (adaptive:error=0.002,min-spp=8): quoted.
        os << row.sampler << ",\"" << r.samplers[row.sampler].spec << "\"," << row.snapshot << ","
           << num(row.target_time_s) << "," << num(row.time_s) << "," << num(row.snapshot_cost_s)
           << "," << num(row.mean_spp) << "," << row.samples << "," << row.rays << "," << row.passes
           << "," << num(row.coverage) << "," << (row.stopped ? 1 : 0);
        const sampling::ImageComparison &m = row.metrics;
        for (const sampling::ChannelMetric *cm :
             {&m.mse, &m.rel_mse, &m.rmse, &m.psnr, &m.mae, &m.rel_mse_robust})
            os << "," << num(cm->channel[0]) << "," << num(cm->channel[1]) << ","
               << num(cm->channel[2]) << "," << num(cm->total);
        os << "\n";
    }
    return os.str();
}

std::string find_report_script() {
    const char *env = std::getenv("TESSERA_REPORT_SCRIPT");
    std::error_code ec;
    if (env && *env)
        return fs::is_regular_file(env, ec) ? std::string(env) : std::string();
    std::vector<fs::path> candidates;
    fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        fs::path dir = exe.parent_path();
        candidates.push_back(dir / ".." / "share" / "tessera" / "convergence_report.py");
        candidates.push_back(dir / ".." / "scripts" / "convergence_report.py");
        candidates.push_back(dir / "scripts" / "convergence_report.py");
    }
    candidates.push_back(fs::path(TESSERA_SOURCE_DIR) / "scripts" / "convergence_report.py");
    for (const fs::path &p : candidates)
        if (fs::is_regular_file(p, ec))
            return fs::weakly_canonical(p, ec).string();
    return {};
}

namespace {

// The progressive samplers to compare (--sampler, default uniform and adaptive), parsed.
std::vector<SamplerSpec> parse_converge_samplers(const ConvergeOptions &opt) {
    std::vector<SamplerSpec> specs;
    for (const std::string &s : opt.samplers) {
        specs.push_back(parse_sampler_spec(s));
        if (specs.back().is_frame())
            throw SceneError("--sampler:0: " + specs.back().name +
                             " is a real-time frame sampler; tessera converge compares the "
                             "progressive samplers (uniform, adaptive[:...]); compare real-time "
                             "samplers with scripts/bench_realtime.py");
    }
    return specs;
}

// The reference of the reference cache (renderer/app/reference.h): rendered, or reused from the
// cache, for the scene's size, depth and seed.
Reference cached_converge_reference(const ConvergeOptions &opt, const Scene &scene,
                                    const ConvergeResult &r) {
    ReferenceSettings rs;
    rs.width = r.width;
    rs.height = r.height;
    rs.spp = opt.reference_spp;
    rs.max_depth = scene.settings.max_depth;
    rs.seed = reference_seed(scene.settings.seed);
    rs.threads = opt.threads;
    rs.quiet = opt.quiet;
    if (!opt.quiet)
        std::fprintf(stderr, "tessera: reference: %u spp at %ux%u, seed %u (cache %s)\n", rs.spp,
                     rs.width, rs.height, rs.seed,
                     (opt.cache_dir.empty() ? default_cache_dir() : opt.cache_dir).c_str());
    Reference ref = cached_reference(scene, opt.scene, rs, opt.cache_dir);
    if (!opt.quiet)
        std::fprintf(stderr, "tessera: reference %s: %s\n",
                     ref.from_cache ? "reused from the cache" : "rendered and cached",
                     ref.path.c_str());
    return ref;
}

// Runs every sampler to every snapshot time, interleaved: snapshot k of every sampler before
// snapshot k + 1 of any (SamplerRun). Fills r.samplers and r.rows (in the order taken).
std::vector<std::unique_ptr<SamplerRun>> run_snapshots(const ConvergeOptions &opt,
                                                       const std::vector<SamplerSpec> &specs,
                                                       const Scene &scene, const Reference &ref,
                                                       ConvergeResult &r) {
    std::vector<std::unique_ptr<SamplerRun>> runs;
    for (size_t i = 0; i < specs.size(); ++i) {
        ConvergenceSampler s;
        s.spec = opt.samplers[i];
        s.description = specs[i].describe();
        s.slug = make_slug(i, s.spec);
        r.samplers.push_back(s);
        runs.push_back(std::make_unique<SamplerRun>(scene, specs[i], opt));
    }
    const size_t n = r.snapshot_times.size();
    for (size_t k = 0; k < n; ++k) {
        for (size_t i = 0; i < runs.size(); ++i) {
            if (runs[i]->stopped())
                continue;
            ConvergenceRow row =
                runs[i]->advance(r.snapshot_times[k], uint32_t(k), k + 1 == n, ref.image);
            row.sampler = i;
            if (!opt.quiet)
                std::fprintf(stderr,
                             "tessera: %-28s snapshot %zu/%zu  t %7.3f s  spp %8.1f  relMSE %.4g  "
                             "relMSE-0.1%% %.4g  MSE %.4g%s\n",
                             r.samplers[i].spec.c_str(), k + 1, n, row.time_s, row.mean_spp,
                             row.metrics.rel_mse.total, row.metrics.rel_mse_robust.total,
                             row.metrics.mse.total,
                             row.stopped ? "  (stopped: converged or --spp reached)" : "");
            r.rows.push_back(row);
        }
    }
    return runs;
}

// Orders the rows by sampler, picks the error levels and summarises every sampler against them.
void summarise_converge(const ConvergeOptions &opt, ConvergeResult &r) {
    // Rows per sampler, snapshots in order.
    std::stable_sort(
        r.rows.begin(), r.rows.end(),
        [](const ConvergenceRow &a, const ConvergenceRow &b) { return a.sampler < b.sampler; });
    r.threads =
        opt.threads ? opt.threads : uint32_t(std::max(1u, std::thread::hardware_concurrency()));
    r.levels = opt.target_errors.empty() ? default_levels(r) : opt.target_errors;
    std::sort(r.levels.begin(), r.levels.end(), std::greater<>());
    for (size_t i = 0; i < r.samplers.size(); ++i)
        summarise_sampler(r, i);
}

// Images: the reference and each sampler's final snapshot (EXR with spp, PNG, spp PFM); returns
// their entries of convergence.json.
std::vector<nlohmann::json> write_converge_images(
    const fs::path &images, const DisplayTransform &display, const Reference &ref,
    const ConvergeResult &r, const std::vector<std::unique_ptr<SamplerRun>> &runs,
    const std::vector<SamplerSpec> &specs) {
    auto write_png = [&](const fs::path &p, const sampling::RgbImage &img) {
        write_rgb8(p.string(), img.width, img.height, display.to_8bit(img));
    };
    write_png(images / "reference.png", ref.image);
    std::vector<nlohmann::json> image_json;
    for (size_t i = 0; i < r.samplers.size(); ++i) {
        const std::string stem = r.samplers[i].slug;
        const SamplerRun &f = *runs[i];
        write_exr((images / (stem + ".exr")).string(), r.width, r.height,
                  {ImageLayer{"", {"R", "G", "B"}, f.final_beauty.data, false},
                   ImageLayer{"spp", {"Y"}, f.final_spp, true}});
        write_png(images / (stem + ".png"), f.final_beauty);
        write_pfm((images / (stem + ".spp.pfm")).string(), r.width, r.height, f.final_spp);
        image_json.push_back({{"exr", "images/" + stem + ".exr"},
                              {"png", "images/" + stem + ".png"},
                              {"spp_pfm", "images/" + stem + ".spp.pfm"},
                              {"adaptive", specs[i].name == "adaptive"}});
    }
    return image_json;
}

// report.html through scripts/convergence_report.py (--no-report skips it); a failure is a
// warning, the CSV and JSON being complete.
void write_converge_report(const ConvergeOptions &opt, const fs::path &dir, ConvergeResult &r) {
    std::string script = opt.report_script.empty() ? find_report_script() : opt.report_script;
    const char *py = std::getenv("TESSERA_PYTHON");
    int rc = script.empty() ? 127 : run_program({py && *py ? py : "python3", script, dir.string()});
    if (rc == 0) {
        r.report_path = (dir / "report.html").string();
        if (!opt.quiet)
            std::fprintf(stderr, "tessera: wrote %s\n", r.report_path.c_str());
    } else {
        std::fprintf(stderr,
                     "tessera: warning: report.html not written (%s); convergence.csv and "
                     "convergence.json are complete (--no-report skips the report)\n",
                     script.empty() ? "scripts/convergence_report.py not found"
                                    : "the report script failed, see above");
    }
}

}  // namespace

ConvergeResult run_converge(const ConvergeOptions &opt_in) {
    ConvergeOptions opt = opt_in;
    if (opt.samplers.empty())
        opt.samplers = {"uniform", "adaptive"};
    check_options(opt);
    const std::vector<SamplerSpec> specs = parse_converge_samplers(opt);

    // Bad input first, before anything is rendered or written.
    std::unique_ptr<Scene> scene = load_scene(opt.scene, opt.overrides);
    std::optional<DisplayTransform> display;
    try {
        display.emplace(opt.display);
    } catch (const std::exception &e) {
        throw SceneError(std::string("--ocio-config/--display/--view:0: ") + e.what());
    }
    ConvergeResult r;
    r.width = uint32_t(scene->settings.width);
    r.height = uint32_t(scene->settings.height);
    r.metric = opt.metric;
    r.hardware_threads = std::thread::hardware_concurrency();
    r.scene_hash = scene_content_hash(opt.scene);
    Reference ref;
    if (!opt.reference.empty())
        ref = load_reference(opt.reference, r.width, r.height);

    const fs::path dir(opt.output_dir);
    std::error_code ec;
    fs::create_directories(dir / "images", ec);
    if (!fs::is_directory(dir / "images", ec))
        throw SceneError(opt.output_dir + ":0: cannot create the output folder");

    if (opt.reference.empty())
        ref = cached_converge_reference(opt, *scene, r);
    r.reference_path = ref.path;
    r.reference_cached = ref.from_cache;
    r.reference_rendered = ref.rendered;
    r.reference_noise_mse = ref.noise_mse();
    r.reference_noise_rel_mse = ref.noise_rel_mse();

    const double first = opt.first_snapshot_s > 0 ? opt.first_snapshot_s : opt.time_s / 32;
    r.snapshot_times = sampling::log_spaced_times(first, opt.time_s, opt.snapshots);
    const std::vector<std::unique_ptr<SamplerRun>> runs =
        run_snapshots(opt, specs, *scene, ref, r);
    summarise_converge(opt, r);

    const std::vector<nlohmann::json> image_json =
        write_converge_images(dir / "images", *display, ref, r, runs, specs);
    nlohmann::json j = result_json(r, opt, opt.scene, image_json);
    j["settings"]["max_depth"] = scene->settings.max_depth;
    j["settings"]["seed"] = scene->settings.seed;
    j["settings"]["first_snapshot_s"] = first;
    j["reference"]["png"] = "images/reference.png";
    j["reference"]["spp"] =
        opt.reference.empty() ? nlohmann::json(opt.reference_spp) : nlohmann::json(nullptr);
    write_text_atomically((dir / "convergence.csv").string(), convergence_csv(r));
    write_json_atomic((dir / "convergence.json").string(), j);

    std::printf("tessera converge: %s, %ux%u, %.3g s per sampler, %u threads\n", opt.scene.c_str(),
                r.width, r.height, opt.time_s, r.threads);
    std::fputs(format_headline(r).c_str(), stdout);
    std::fflush(stdout);

    if (opt.report)
        write_converge_report(opt, dir, r);
    return r;
}

}  // namespace tessera
