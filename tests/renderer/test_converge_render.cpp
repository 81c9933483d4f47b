// End-to-end `tessera converge` runs on a tiny scene: the CSV/JSON schema, log-spaced
// snapshots with growing time and samples, the images, the cached reference reused by a second
// run, and a bad reference that stops the command before anything is written.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/app/converge.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;

namespace {

const std::string kScene = test::tiny_lit_scene_header(24, 16) + R"(
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  1 1 1  -1 1 1 ]
    "integer indices" [ 0 1 2  0 2 3 ]
Material "conductor" "float roughness" [ 0.05 ]
Shape "sphere" "float radius" [ 0.3 ]
)";

ConvergeOptions options(const fs::path &dir, const std::string &out) {
    ConvergeOptions o;
    o.scene = (dir / "scene.pbrt").string();
    o.output_dir = (dir / out).string();
    o.samplers = {"uniform", "adaptive:error=0.01,min-spp=4"};
    o.time_s = 0.4;
    o.snapshots = 4;
    o.threads = 2;
    o.reference_spp = 64;
    o.cache_dir = (dir / "cache").string();
    o.report = false;
    o.quiet = true;
    return o;
}

nlohmann::json read_json(const fs::path &p) {
    std::ifstream f(p);
    return nlohmann::json::parse(f);
}

}  // namespace

TEST_CASE("converge writes CSV and JSON rows per sampler and snapshot, with images") {
    fs::path dir = test::temp_dir("converge_e2e", true);
    test::write_text(dir / "scene.pbrt", kScene);
    ConvergeOptions o = options(dir, "out");
    ConvergeResult r = run_converge(o);

    // The schedule: log-spaced from time / 32 to the budget.
    REQUIRE(r.snapshot_times.size() == 4);
    CHECK(r.snapshot_times.front() == test::Approx(0.4 / 32));
    CHECK(r.snapshot_times.back() == 0.4);
    CHECK(r.snapshot_times[2] / r.snapshot_times[1] ==
          test::Approx(r.snapshot_times[1] / r.snapshot_times[0]));
    CHECK(r.reference_rendered);
    CHECK(r.reference_noise_mse >= 0);

    const fs::path out = dir / "out";
    for (const char *f : {"convergence.csv", "convergence.json", "images/reference.png",
                          "images/0-uniform.exr", "images/0-uniform.png",
                          "images/0-uniform.spp.pfm", "images/1-adaptive-error-0.01-min-spp-4.png"})
        CHECK_MESSAGE(fs::is_regular_file(out / f), f);
    CHECK(!fs::exists(out / "report.html"));  // --no-report

    nlohmann::json j = read_json(out / "convergence.json");
    for (const char *k : {"tessera_version", "scene", "scene_hash", "hardware_threads", "threads",
                          "settings", "reference", "samplers", "headline", "rows"})
        CHECK_MESSAGE(j.contains(k), k);
    CHECK(j["tessera_version"] == TESSERA_VERSION);
    CHECK(j["scene_hash"].get<std::string>().size() == 32);
    CHECK(j["hardware_threads"].get<int>() >= 1);
    CHECK(j["threads"] == 2);
    for (const char *k : {"time_s", "snapshots", "snapshot_times_s", "first_snapshot_s", "width",
                          "height", "max_depth", "seed", "metric"})
        CHECK_MESSAGE(j["settings"].contains(k), k);
    CHECK(j["settings"]["width"] == 24);
    CHECK(j["settings"]["height"] == 16);
    CHECK(j["reference"]["spp"] == 64);
    CHECK(j["reference"]["cached"] == false);
    REQUIRE(j["samplers"].size() == 2);
    CHECK(j["samplers"][1]["spec"] == "adaptive:error=0.01,min-spp=4");
    CHECK(j["samplers"][1]["images"]["adaptive"] == true);
    CHECK(j["samplers"][0]["fit"]["mse"].contains("slope"));
    CHECK(j["samplers"][0]["time_to_error"].size() == j["headline"]["levels"].size());

    // Rows: per sampler, snapshots in order, time and samples growing, every metric finite.
    const nlohmann::json &rows = j["rows"];
    CHECK(rows.size() == r.rows.size());
    CHECK(rows.size() >= 4);  // uniform cannot stop early: all 4 snapshots
    for (size_t s = 0; s < 2; ++s) {
        double last_t = -1;
        uint64_t last_samples = 0;
        uint32_t k = 0;
        for (const nlohmann::json &row : rows) {
            if (row["sampler_index"] != s)
                continue;
            CHECK(row["snapshot"] == k++);
            CHECK(row["time_s"].get<double>() > last_t);
            CHECK(row["samples"].get<uint64_t>() >= last_samples);
            CHECK(row["rays"].get<uint64_t>() >= row["samples"].get<uint64_t>());
            CHECK(row["snapshot_cost_s"].get<double>() >= 0);
            last_t = row["time_s"];
            last_samples = row["samples"];
            for (const char *m : {"mse", "relmse", "rmse", "mae"})
                for (const char *c : {"r", "g", "b", "total"}) {
                    CHECK(row[m][c].is_number());
                    CHECK(std::isfinite(row[m][c].get<double>()));
                }
            CHECK(row["mse"]["total"].get<double>() ==
                  test::Approx(row["rmse"]["total"].get<double>() *
                                  row["rmse"]["total"].get<double>()));
        }
        CHECK(last_t <= 0.4 + 0.25);  // chunks stop at tile granularity
    }
    // Uniform: more samples, less error at the end than at the first full snapshot.
    const ConvergenceRow *first = nullptr, *last = nullptr;
    for (const ConvergenceRow &x : r.rows)
        if (x.sampler == 0 && x.coverage >= 1) {
            if (!first)
                first = &x;
            last = &x;
        }
    REQUIRE(first);
    CHECK(last->mean_spp > first->mean_spp);

    // The CSV has the same rows.
    std::ifstream csv(out / "convergence.csv");
    std::string line;
    size_t lines = 0;
    while (std::getline(csv, line))
        ++lines;
    CHECK(lines == rows.size() + 1);

    // A second run reuses the cached reference and gives the same reference noise estimate.
    ConvergeOptions o2 = options(dir, "out2");
    o2.samplers = {"uniform"};
    o2.time_s = 0.1;
    o2.snapshots = 2;
    ConvergeResult r2 = run_converge(o2);
    CHECK(r2.reference_cached);
    CHECK(!r2.reference_rendered);
    CHECK(r2.reference_path == r.reference_path);
    CHECK(r2.reference_noise_mse == r.reference_noise_mse);
    CHECK(read_json(dir / "out2" / "convergence.json")["reference"]["cached"] == true);
}

TEST_CASE("converge: a bad reference or option stops before anything is written") {
    fs::path dir = test::temp_dir("converge_e2e_bad", true);
    test::write_text(dir / "scene.pbrt", kScene);
    ConvergeOptions o = options(dir, "out");
    o.reference = (dir / "missing.exr").string();
    CHECK_THROWS_AS(run_converge(o), SceneError);
    CHECK(!fs::exists(dir / "out"));
    o.reference.clear();
    o.samplers = {"uniform", "bogus"};
    CHECK_THROWS_AS(run_converge(o), SceneError);
    o.samplers = {"uniform"};
    o.metric = "psnr";
    CHECK_THROWS_AS(run_converge(o), SceneError);
    o.metric = "mse";
    o.first_snapshot_s = 1.0;  // after the budget
    CHECK_THROWS_AS(run_converge(o), SceneError);
    CHECK(!fs::exists(dir / "out"));
    CHECK(!fs::exists(dir / "cache"));
}
