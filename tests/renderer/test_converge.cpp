// Unit tests of `tessera converge`'s parts: metrics against hand-computed values, log spacing of
// snapshots, log-log fits and crossing times, the headline table and CSV, scene content hashes,
// the reference cache (reused when unchanged, rebuilt when the scene changes) and the checks
// of bad references. End-to-end runs: test_converge_render.cpp.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "approx.h"
#include "render_test_util.h"
#include "renderer/app/converge.h"
#include "renderer/util/image_io.h"
#include "renderer/app/reference.h"
#include "sampling/convergence_curve.h"
#include "sampling/image_metrics.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;

namespace {

// A tiny scene: a diffuse quad lit by a quad area light, its floor from an included file and
// a texture image next to it (both must count in the content hash).
const std::string kScene = test::tiny_lit_scene_header(12, 8) + "Include \"parts/floor.pbrt\"\n";
const char *kFloor = R"(Texture "t" "spectrum" "imagemap" "string filename" [ "tex.pfm" ]
Material "diffuse" "texture reflectance" "t"
Shape "trianglemesh" "point3 P" [ -1 -1 1  1 -1 1  1 1 1  -1 1 1 ]
    "integer indices" [ 0 1 2  0 2 3 ]  "point2 uv" [ 0 0  1 0  1 1  0 1 ]
)";

// A w x h RGB PFM with every value `v` except pixel (bx, by), which gets `bad`.
void write_pfm(const fs::path &p, int w, int h, float v, int bx = -1, int by = -1, float bad = 0) {
    fs::create_directories(p.parent_path());
    std::ofstream f(p, std::ios::binary);
    f << "PF\n" << w << " " << h << "\n-1.0\n";
    for (int y = h - 1; y >= 0; --y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) {
                float value = (x == bx && y == by) ? bad : v;
                f.write(reinterpret_cast<const char *>(&value), 4);
            }
}

fs::path make_scene_folder(const std::string &name) {
    fs::path dir = test::temp_dir(name, true);
    test::write_text(dir / "scene.pbrt", kScene);
    test::write_text(dir / "parts" / "floor.pbrt", kFloor);
    write_pfm(dir / "tex.pfm", 2, 2, 0.5f);
    return dir;
}

std::string error_of(const std::function<void()> &f) {
    try {
        f();
    } catch (const SceneError &e) {
        return e.what();
    }
    return "(no SceneError)";
}

ConvergenceRow row(size_t sampler, uint32_t k, double t, double rel, double coverage = 1) {
    ConvergenceRow r;
    r.sampler = sampler;
    r.snapshot = k;
    r.time_s = r.target_time_s = t;
    r.coverage = coverage;
    r.metrics.rel_mse.total = rel;
    r.metrics.mse.total = rel / 2;
    return r;
}

}  // namespace

TEST_CASE("metrics of a snapshot against hand-computed values (MSE, relMSE, RMSE, PSNR, MAE)") {
    // 2x1 pixels. test - ref: R {0.5, 0}, G {0, -1}, B {0, -0.25}.
    sampling::RgbImage ref(2, 1, std::vector<float>{1, 0, 0.5f, 0, 2, 0.5f});
    sampling::RgbImage test(2, 1, std::vector<float>{1.5f, 0, 0.5f, 0, 1, 0.25f});
    sampling::ImageComparison m = sampling::compare_images(test, ref, 1.0);
    CHECK(m.mse.channel[0] == test::Approx(0.125));
    CHECK(m.mse.channel[1] == test::Approx(0.5));
    CHECK(m.mse.channel[2] == test::Approx(0.03125));
    CHECK(m.mse.total == test::Approx(0.21875));
    // relMSE: (v - ref)^2 / (ref^2 + 0.01), averaged over the two pixels.
    CHECK(m.rel_mse.channel[0] == test::Approx(0.25 / 1.01 / 2));
    CHECK(m.rel_mse.channel[1] == test::Approx(1.0 / 4.01 / 2));
    CHECK(m.rel_mse.channel[2] == test::Approx(0.0625 / 0.26 / 2));
    CHECK(m.rel_mse.total == test::Approx((0.25 / 1.01 + 1.0 / 4.01 + 0.0625 / 0.26) / 6));
    CHECK(m.rmse.channel[1] == test::Approx(std::sqrt(0.5)));
    CHECK(m.rmse.total == test::Approx(std::sqrt(0.21875)));
    CHECK(m.psnr.total == test::Approx(10 * std::log10(1 / 0.21875)));
    CHECK(m.mae.channel[0] == test::Approx(0.25));
    CHECK(m.mae.channel[1] == test::Approx(0.5));
    CHECK(m.mae.channel[2] == test::Approx(0.125));
    CHECK(m.mae.total == test::Approx(0.875 / 3));
    CHECK(headline_value(m, "mae") == test::Approx(0.875 / 3));
    CHECK(headline_value(m, "relmse") == m.rel_mse.total);
    CHECK(headline_value(m, "relmse-robust") == m.rel_mse_robust.total);
    CHECK(m.rel_mse_robust.total <= m.rel_mse.total);
    CHECK_THROWS_AS(headline_value(m, "psnr"), std::invalid_argument);

    CHECK(sampling::nonfinite_count(test) == 0);
    test.data[4] = std::numeric_limits<float>::quiet_NaN();
    test.data[5] = std::numeric_limits<float>::infinity();
    CHECK(sampling::nonfinite_count(test) == 2);
}

TEST_CASE("snapshots are log-spaced from the first time to the budget") {
    std::vector<double> t = sampling::log_spaced_times(0.5, 8, 5);
    REQUIRE(t.size() == 5);
    CHECK(t.front() == 0.5);
    CHECK(t.back() == 8.0);  // exactly the budget
    for (size_t i = 0; i + 1 < t.size(); ++i)
        CHECK(t[i + 1] / t[i] == test::Approx(2.0));
    std::vector<double> u = sampling::log_spaced_times(0.1, 60, 8);
    const double ratio = std::pow(600.0, 1.0 / 7);
    for (size_t i = 0; i + 1 < u.size(); ++i)
        CHECK(u[i + 1] / u[i] == test::Approx(ratio));
    CHECK(sampling::log_spaced_times(0.2, 3, 1) == std::vector<double>{3});
    CHECK(sampling::log_spaced_times(2, 2, 3) == std::vector<double>{2, 2, 2});
    CHECK_THROWS_AS(sampling::log_spaced_times(0, 1, 3), std::invalid_argument);
    CHECK_THROWS_AS(sampling::log_spaced_times(2, 1, 3), std::invalid_argument);
    CHECK_THROWS_AS(sampling::log_spaced_times(1, 2, 0), std::invalid_argument);
}

TEST_CASE("log-log fit of a power law; unusable points are skipped") {
    std::vector<double> t{0.5, 1, 2, 4, 8, 16}, e;
    for (double x : t)
        e.push_back(3.0 / x);  // MSE ~ 1/t
    e[0] = std::numeric_limits<double>::quiet_NaN();
    sampling::LogLogFit f = sampling::fit_loglog(t, e);
    CHECK(f.valid);
    CHECK(f.points == 5);
    CHECK(f.slope == test::Approx(-1.0));
    CHECK(f.intercept == test::Approx(std::log10(3.0)));
    std::vector<double> one_t{1}, one_e{1};
    CHECK(!sampling::fit_loglog(one_t, one_e).valid);
    std::vector<double> same_t{2, 2}, two_e{1, 0.5};
    CHECK(!sampling::fit_loglog(same_t, two_e).valid);
    CHECK_THROWS_AS(sampling::fit_loglog(t, one_e), std::invalid_argument);
}

TEST_CASE("time to reach an error: log-log interpolation, before the first, not reached") {
    std::vector<double> t{1, 2, 4, 8}, e{1, 0.5, 0.25, 0.125};  // e = 1 / t
    sampling::Crossing c = sampling::time_to_reach(t, e, 0.35);
    CHECK(c.kind == sampling::Crossing::Kind::reached);
    CHECK(c.time_s == test::Approx(1 / 0.35));  // exact on a power law
    c = sampling::time_to_reach(t, e, 0.25);
    CHECK(c.kind == sampling::Crossing::Kind::reached);
    CHECK(c.time_s == test::Approx(4.0));
    c = sampling::time_to_reach(t, e, 2.0);
    CHECK(c.kind == sampling::Crossing::Kind::before_first);
    CHECK(c.time_s == 1.0);
    c = sampling::time_to_reach(t, e, 0.1);
    CHECK(c.kind == sampling::Crossing::Kind::not_reached);
    CHECK(c.time_s == 8.0);
    // The first crossing counts, even when noise lifts the curve again later.
    std::vector<double> t2{1, 2, 4}, e2{1, 0.2, 0.3};
    c = sampling::time_to_reach(t2, e2, 0.25);
    CHECK(c.kind == sampling::Crossing::Kind::reached);
    CHECK(c.time_s < 2.0);
}

TEST_CASE("headline levels, table and CSV of a result") {
    ConvergeResult r;
    r.metric = "relmse";
    r.samplers.resize(2);
    r.samplers[0].spec = "uniform";
    r.samplers[1].spec = "adaptive:error=0.002,min-spp=8";
    // uniform: e = 1 / t; adaptive: e = 0.5 / t (twice as fast); a partial first snapshot.
    for (uint32_t k = 0; k < 4; ++k) {
        const double t = std::pow(2.0, k);
        r.rows.push_back(row(0, k, t, 1.0 / t, k == 0 ? 0.5 : 1.0));
        r.rows.push_back(row(1, k, t, 0.5 / t));
    }
    r.levels = default_levels(r);
    REQUIRE(r.levels.size() == 3);
    CHECK(r.levels[2] == test::Approx(0.125));  // the worst final error
    CHECK(r.levels[1] == test::Approx(0.25));
    CHECK(r.levels[0] == test::Approx(0.5));
    for (size_t i = 0; i < 2; ++i) {
        std::vector<double> t, e;
        for (const ConvergenceRow &x : r.rows)
            if (x.sampler == i && x.coverage >= 1) {
                t.push_back(x.time_s);
                e.push_back(x.metrics.rel_mse.total);
            }
        for (double l : r.levels)
            r.samplers[i].crossings.push_back(sampling::time_to_reach(t, e, l));
    }
    std::string table = format_headline(r);
    CAPTURE(table);
    CHECK(table.find("relMSE") != std::string::npos);
    CHECK(table.find("E=0.125") != std::string::npos);
    CHECK(table.find("2.00x") != std::string::npos);  // adaptive: half the time
    CHECK(table.find("<=1") != std::string::npos);    // adaptive is below 0.5 at t = 1

    std::string csv = convergence_csv(r);
    std::istringstream is(csv);
    std::string header, line;
    std::getline(is, header);
    CHECK(header.rfind("sampler_index,sampler,snapshot,target_time_s,time_s,", 0) == 0);
    for (const char *col : {",mean_spp,", ",samples,", ",rays,", ",coverage,", ",mse_r,",
                            ",relmse,", ",rmse_b,", ",psnr,", ",mae_g,", ",relmse_robust_r,"})
        CHECK(header.find(col) != std::string::npos);
    const size_t columns = size_t(std::count(header.begin(), header.end(), ',')) + 1;
    CHECK(columns == 12 + 6 * 4);
    CHECK(header.size() >= 14);
    CHECK(header.substr(header.size() - 14) == ",relmse_robust");
    size_t lines = 0;
    while (std::getline(is, line)) {
        ++lines;
        // The quoted spec holds one comma; every other comma separates a column.
        size_t commas = size_t(std::count(line.begin(), line.end(), ','));
        CHECK(commas == columns - 1 + (line.find("min-spp") != std::string::npos ? 1 : 0));
    }
    CHECK(lines == r.rows.size());
    CHECK(csv.find("\"adaptive:error=0.002,min-spp=8\"") != std::string::npos);
}

TEST_CASE("scene content hash covers includes and referenced files, not the folder's place") {
    fs::path dir = make_scene_folder("converge_hash");
    const std::string scene = (dir / "scene.pbrt").string();
    std::vector<std::string> deps = scene_dependencies(scene);
    REQUIRE(deps.size() == 3);
    CHECK(deps[0] == scene);
    CHECK(fs::path(deps[1]).filename() == "floor.pbrt");
    CHECK(fs::path(deps[2]).filename() == "tex.pfm");
    const std::string h0 = scene_content_hash(scene);
    CHECK(h0.size() == 32);
    CHECK(scene_content_hash(scene) == h0);
    // A copy of the folder elsewhere hashes the same.
    fs::path copy = test::temp_dir("converge_hash_copy", true);
    fs::copy(dir, copy, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    CHECK(scene_content_hash((copy / "scene.pbrt").string()) == h0);
    // Changing the texture, the include or the main file changes it.
    write_pfm(copy / "tex.pfm", 2, 2, 0.6f);
    const std::string h1 = scene_content_hash((copy / "scene.pbrt").string());
    CHECK(h1 != h0);
    test::write_text(copy / "parts" / "floor.pbrt", std::string(kFloor) + "# edited\n");
    const std::string h2 = scene_content_hash((copy / "scene.pbrt").string());
    CHECK(h2 != h1);
    test::write_text(copy / "scene.pbrt", std::string(kScene) + "# edited\n");
    CHECK(scene_content_hash((copy / "scene.pbrt").string()) != h2);
}

TEST_CASE("scene content hash covers the lens file and the goniometric and projection images") {
    // Files named by string parameters of the camera and of lights count as scene input.
    fs::path dir = test::temp_dir("converge_hash_optics", true);
    const std::string scene = (dir / "scene.pbrt").string();
    test::write_text(dir / "scene.pbrt",
                     "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
                     "Camera \"realistic\" \"string lensfile\" \"lenses/singlet.dat\"\n"
                     "WorldBegin\n"
                     "LightSource \"goniometric\" \"string filename\" \"gonio.pfm\"\n"
                     "LightSource \"projection\" \"string filename\" \"maps/slide.pfm\"\n");
    test::write_text(dir / "lenses" / "singlet.dat", "# r t eta ap\n50 5 1.5 20\n-50 45 1 20\n");
    write_pfm(dir / "gonio.pfm", 4, 4, 1.f);
    write_pfm(dir / "maps" / "slide.pfm", 4, 2, 1.f);
    std::vector<std::string> deps = scene_dependencies(scene);
    std::vector<std::string> names;
    for (const std::string &d : deps)
        names.push_back(fs::proximate(fs::path(d), dir).generic_string());
    std::sort(names.begin(), names.end());
    CHECK(names == std::vector<std::string>{"gonio.pfm", "lenses/singlet.dat", "maps/slide.pfm",
                                            "scene.pbrt"});
    // Editing any one of them changes the hash.
    std::string h = scene_content_hash(scene);
    test::write_text(dir / "lenses" / "singlet.dat", "# r t eta ap\n50 5 1.6 20\n-50 45 1 20\n");
    std::string h_lens = scene_content_hash(scene);
    CHECK(h_lens != h);
    write_pfm(dir / "gonio.pfm", 4, 4, 2.f);
    std::string h_gonio = scene_content_hash(scene);
    CHECK(h_gonio != h_lens);
    write_pfm(dir / "maps" / "slide.pfm", 4, 2, 0.5f);
    CHECK(scene_content_hash(scene) != h_gonio);
}

TEST_CASE("reference cache: reused when unchanged, rebuilt when the scene or settings change") {
    fs::path dir = make_scene_folder("converge_cache");
    fs::path cache = test::temp_dir("converge_cache_store", true);
    const std::string scene_path = (dir / "scene.pbrt").string();
    ReferenceSettings rs;
    rs.width = 12;
    rs.height = 8;
    rs.spp = 8;
    rs.max_depth = 3;
    rs.seed = reference_seed(0);
    rs.threads = 2;
    rs.quiet = true;
    CHECK(rs.seed != 0);  // never the test renders' seed
    auto count_entries = [&] {
        size_t n = 0;
        for (const auto &e : fs::directory_iterator(cache))
            n += e.path().extension() == ".exr" ? 1 : 0;
        return n;
    };
    auto load = [&](const ReferenceSettings &s) {
        SceneOverrides ov;
        ov.width = int(s.width);
        ov.height = int(s.height);
        std::unique_ptr<Scene> scene = load_scene(scene_path, ov);
        return cached_reference(*scene, scene_path, s, cache.string());
    };

    Reference a = load(rs);
    CHECK(a.rendered);
    CHECK(!a.from_cache);
    CHECK(a.variance.size() == a.image.data.size());
    CHECK(a.noise_mse() >= 0);
    CHECK(count_entries() == 1);
    Reference b = load(rs);
    CHECK(b.from_cache);
    CHECK(!b.rendered);
    CHECK(b.path == a.path);
    CHECK(b.image.data == a.image.data);
    CHECK(b.variance == a.variance);

    // The included file changes: a new key, a new render.
    test::write_text(dir / "parts" / "floor.pbrt", std::string(kFloor) + "# brighter\n");
    Reference c = load(rs);
    CHECK(c.rendered);
    CHECK(c.key != a.key);
    CHECK(count_entries() == 2);
    CHECK(load(rs).from_cache);
    // Other settings: another key.
    ReferenceSettings more = rs;
    more.spp = 16;
    CHECK(reference_key("x", more) != reference_key("x", rs));
    Reference d = load(more);
    CHECK(d.rendered);
    CHECK(count_entries() == 3);
    // A corrupt entry is rebuilt, not trusted.
    test::write_text(d.path, "not an image");
    Reference e = load(more);
    CHECK(e.rendered);
    CHECK(e.image.data == d.image.data);  // deterministic
}

TEST_CASE("bad references: missing, unreadable, wrong size, NaN/Inf give clear errors") {
    fs::path dir = test::temp_dir("converge_badref", true);
    std::string msg = error_of([&] { load_reference((dir / "none.exr").string(), 4, 4); });
    CHECK(msg.find("none.exr:0: reference image not found") != std::string::npos);

    test::write_text(dir / "junk.exr", "this is not an EXR");
    msg = error_of([&] { load_reference((dir / "junk.exr").string(), 4, 4); });
    CHECK(msg.find("junk.exr:0: cannot read the reference image") != std::string::npos);

    write_pfm(dir / "small.pfm", 3, 2, 0.5f);
    msg = error_of([&] { load_reference((dir / "small.pfm").string(), 4, 4); });
    CHECK(msg.find("the reference is 3x2 but the renders are 4x4") != std::string::npos);

    write_pfm(dir / "nan.pfm", 4, 4, 0.5f, 2, 1, std::numeric_limits<float>::quiet_NaN());
    msg = error_of([&] { load_reference((dir / "nan.pfm").string(), 4, 4); });
    CHECK(msg.find("3 non-finite values (NaN or Inf), the first at pixel (2, 1)") !=
          std::string::npos);
    write_pfm(dir / "inf.pfm", 4, 4, 0.5f, 0, 3, std::numeric_limits<float>::infinity());
    msg = error_of([&] { load_reference((dir / "inf.pfm").string(), 4, 4); });
    CHECK(msg.find("non-finite") != std::string::npos);

    write_pfm(dir / "good.pfm", 4, 4, 0.5f);
    Reference ok = load_reference((dir / "good.pfm").string(), 4, 4);
    CHECK(ok.image.width == 4);
    CHECK(ok.variance.empty());  // no variance layer: noise floor unknown
    CHECK(ok.noise_mse() < 0);
}
