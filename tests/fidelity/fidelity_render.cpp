// Fidelity against pbrt-v4: every scene of tests/fidelity/scenes rendered by Tessera and
// compared with pbrt-v4's own render of the same file (tests/fidelity/refs, made by
// make_refs.py with pbrt-v4 commit 5f7a606: two independent renders, seeds 1 and 2).
//
// Per scene, Tessera renders the file twice (sequence seeds 1 and 2, uniform sampling). Both
// sides' noise is estimated per pixel from their two renders (for m = (a + b) / 2,
// Var(m) ~ (a - b)^2 / 4; pixels are independent, since both renderers importance-sample the
// pixel filter instead of splatting). The checks:
//   - the image mean of each channel agrees within `mean` (relative, default 1%), and that
//     tolerance is at least 3 standard deviations of the two means' noise, so that the check
//     means something;
//   - every 8x8-pixel block mean agrees within the measured noise: a block fails when its
//     difference exceeds `z` (default 5) standard deviations of the combined noise AND
//     `block` (relative, default 2%) of the reference block (plus 0.1% of the image mean, for
//     black blocks). 5 sigma over some 20000 block-channels leaves a false alarm in ~1% of
//     runs for Gaussian noise.
// Scenes whose features Tessera cannot match exactly (pbrt-v4 is spectral, Tessera RGB) have
// wider tolerances in expectations.txt, each with its reason and measured size; the README's
// list of deviations from pbrt-v4 cites the same figures.
//
// One doctest case per family (the scene name up to its first '-': material, light, ...);
// ctest runs each family as its own test (fidelity_<family>, label render). Each scene's
// figures are written to <test-output>/fidelity/<family>.tsv; failing scenes also leave
// Tessera's image, the reference and their difference as EXRs there.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "render_test_util.h"
#include "renderer/util/image_io.h"
#include "test_helpers.h"

using namespace tessera;
using namespace tessera::test;
namespace fs = std::filesystem;

namespace {

const fs::path kDir = fs::path(TESSERA_SOURCE_DIR) / "tests" / "fidelity";

/// A scene's tolerances (expectations.txt; defaults otherwise).
struct Expectation {
    int spp = 64;          ///< Tessera's spp per seed
    double mean = 0.01;    ///< relative tolerance on each channel's image mean
    double block = 0.02;   ///< relative floor of a block difference that can fail
    double z = 5.0;        ///< noise multiple a block difference must exceed to fail
    std::string why;       ///< reason for non-default tolerances
};

/// Reads tests/fidelity/expectations.txt: "name | key=value ... | why" per line, '#'
/// comments. Keys: spp, mean, block, z.
std::map<std::string, Expectation> read_expectations() {
    std::map<std::string, Expectation> out;
    std::ifstream in(kDir / "expectations.txt");
    REQUIRE_MESSAGE(in, "cannot read tests/fidelity/expectations.txt");
    std::string line;
    int line_no = 0;
    auto trim = [](std::string s) {
        size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t\r");
        return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
    };
    while (std::getline(in, line)) {
        ++line_no;
        if (trim(line).empty() || trim(line)[0] == '#') continue;
        size_t p1 = line.find('|'), p2 = line.find('|', p1 + 1);
        REQUIRE_MESSAGE(p1 != std::string::npos,
                        "expectations.txt:" << line_no << ": expected \"name | keys | why\"");
        std::string name = trim(line.substr(0, p1));
        Expectation e;
        std::istringstream keys(line.substr(p1 + 1, p2 == std::string::npos ? std::string::npos
                                                                            : p2 - p1 - 1));
        for (std::string kv; keys >> kv;) {
            size_t eq = kv.find('=');
            REQUIRE_MESSAGE(eq != std::string::npos,
                            "expectations.txt:" << line_no << ": bad key \"" << kv << "\"");
            std::string k = kv.substr(0, eq);
            double v = std::stod(kv.substr(eq + 1));
            if (k == "spp") e.spp = int(v);
            else if (k == "mean") e.mean = v;
            else if (k == "block") e.block = v;
            else if (k == "z") e.z = v;
            else FAIL("expectations.txt:" << line_no << ": unknown key \"" << k << "\"");
        }
        if (p2 != std::string::npos) e.why = trim(line.substr(p2 + 1));
        out[name] = e;
    }
    return out;
}

/// The scenes of one family, sorted.
std::vector<std::string> scenes_of(const std::string &family) {
    std::vector<std::string> names;
    for (const auto &entry : fs::directory_iterator(kDir / "scenes")) {
        std::string n = entry.path().filename().string();
        if (entry.path().extension() != ".pbrt") continue;
        n = n.substr(0, n.size() - 5);
        if (n.substr(0, n.find('-')) == family) names.push_back(n);
    }
    std::sort(names.begin(), names.end());
    return names;
}

/// A pair of independent renders: their mean, and the per-pixel variance of that mean.
struct Pair {
    sampling::RgbImage mean, var, a, b;
};

Pair make_pair(sampling::RgbImage a, sampling::RgbImage b) {
    REQUIRE(a.width == b.width);
    REQUIRE(a.height == b.height);
    Pair p{sampling::RgbImage(a.width, a.height), sampling::RgbImage(a.width, a.height), a, b};
    for (size_t i = 0; i < a.data.size(); ++i) {
        double x = a.data[i], y = b.data[i];
        p.mean.data[i] = float(0.5 * (x + y));
        p.var.data[i] = float(0.25 * (x - y) * (x - y));
    }
    return p;
}

sampling::RgbImage render_seed(Scene &scene, uint32_t seed) {
    scene.settings.seed = seed;
    return render_image(scene);
}

/// Mean of the relMSE terms (v - r)^2 / (r^2 + 0.01) over pixels and channels.
double relmse(const sampling::RgbImage &v, const sampling::RgbImage &r) {
    double s = 0;
    for (size_t i = 0; i < v.data.size(); ++i) {
        double d = double(v.data[i]) - r.data[i];
        s += d * d / (double(r.data[i]) * r.data[i] + 0.01);
    }
    return s / double(v.data.size());
}

void write_diagnostics(const std::string &name, const Pair &t, const Pair &r) {
    fs::path dir = fs::path(output_dir()) / "fidelity";
    fs::create_directories(dir);
    sampling::RgbImage diff(t.mean.width, t.mean.height);
    for (size_t i = 0; i < diff.data.size(); ++i) diff.data[i] = t.mean.data[i] - r.mean.data[i];
    auto save = [&](const std::string &suffix, const sampling::RgbImage &img) {
        write_exr((dir / (name + suffix)).string(), img.width, img.height,
                  {ImageLayer{"", {"R", "G", "B"}, img.data}});
    };
    save(".tessera.exr", t.mean);
    save(".pbrt.exr", r.mean);
    save(".diff.exr", diff);
}

/// Renders one scene (tests/fidelity/scenes/NAME.pbrt, or `scene_file` with the resolution
/// `ov` gives) and checks it against its references; appends a row to `table`.
void check_scene(const std::string &name, const Expectation &e, std::ostream &table,
                 const std::string &scene_file = "", SceneOverrides ov = {}) {
    CAPTURE(name);
    fs::path ref1 = kDir / "refs" / (name + ".seed1.exr"),
             ref2 = kDir / "refs" / (name + ".seed2.exr");
    REQUIRE_MESSAGE(fs::exists(ref1), "no reference " << ref1 << " (tests/fidelity/make_refs.py)");
    REQUIRE(fs::exists(ref2));
    Pair r = make_pair(read_image_rgb(ref1.string()), read_image_rgb(ref2.string()));

    ov.spp = e.spp;
    auto scene = load_scene(
        scene_file.empty() ? (kDir / "scenes" / (name + ".pbrt")).string() : scene_file, ov);
    REQUIRE(scene);
    Pair t = make_pair(render_seed(*scene, 1), render_seed(*scene, 2));
    REQUIRE(t.mean.width == r.mean.width);
    REQUIRE(t.mean.height == r.mean.height);

    const uint32_t w = r.mean.width, h = r.mean.height;
    const double npx = double(w) * h;
    bool ok = true;
    std::ostringstream why_failed;
    double mean_ratio[3], mean_sigma[3], image_mean[3];
    for (int c = 0; c < 3; ++c) {
        double mt = 0, mr = 0, vt = 0, vr = 0;
        for (uint32_t i = 0; i < w * h; ++i) {
            mt += t.mean.data[i * 3 + c];
            mr += r.mean.data[i * 3 + c];
            vt += t.var.data[i * 3 + c];
            vr += r.var.data[i * 3 + c];
        }
        mt /= npx;
        mr /= npx;
        image_mean[c] = mr;
        double sigma = std::sqrt((vt + vr) / (npx * npx));
        mean_ratio[c] = mr != 0 ? mt / mr : (mt == 0 ? 1 : INFINITY);
        mean_sigma[c] = mr != 0 ? sigma / std::abs(mr) : 0;
        if (!(std::abs(mt - mr) <= e.mean * std::abs(mr))) {
            ok = false;
            why_failed << " mean[" << c << "] " << mt << " vs " << mr;
        }
        // The tolerance must stand above the noise, or the check could not fail for a real
        // 1% difference (raise the scene's spp in expectations.txt).
        if (!(3 * sigma <= e.mean * std::abs(mr) || mr == 0)) {
            ok = false;
            why_failed << " noisy[" << c << "] sigma " << sigma / std::abs(mr);
        }
    }

    double worst_ratio = 1, worst_z = 0;
    int failing_blocks = 0;
    for (uint32_t by = 0; by < h; by += 8)
        for (uint32_t bx = 0; bx < w; bx += 8) {
            uint32_t x1 = std::min(w, bx + 8), y1 = std::min(h, by + 8);
            double n = double(x1 - bx) * (y1 - by);
            for (int c = 0; c < 3; ++c) {
                double st = 0, sr = 0, vt = 0, vr = 0;
                for (uint32_t y = by; y < y1; ++y)
                    for (uint32_t x = bx; x < x1; ++x) {
                        st += t.mean.at(x, y, c);
                        sr += r.mean.at(x, y, c);
                        vt += t.var.at(x, y, c);
                        vr += r.var.at(x, y, c);
                    }
                double d = (st - sr) / n, sigma = std::sqrt(vt + vr) / n, ref = sr / n;
                double z = sigma > 0 ? std::abs(d) / sigma : (d == 0 ? 0 : INFINITY);
                double floor = e.block * std::abs(ref) + 1e-3 * std::abs(image_mean[c]);
                if (z > worst_z) worst_z = z;
                // The worst ratio among blocks bright enough for a ratio to mean something.
                if (std::abs(ref) > 0.05 * std::abs(image_mean[c]) && ref != 0) {
                    double ratio = (st / n) / ref;
                    if (std::abs(ratio - 1) > std::abs(worst_ratio - 1)) worst_ratio = ratio;
                }
                if (z > e.z && std::abs(d) > floor) ++failing_blocks;
            }
        }
    if (failing_blocks > 0) {
        ok = false;
        why_failed << " " << failing_blocks << " block-channels outside the noise";
    }
    double rel_tr = relmse(t.mean, r.mean), rel_tt = relmse(t.a, t.b), rel_rr = relmse(r.a, r.b);
    char row[512];
    std::snprintf(row, sizeof row,
                  "%s\t%.4f\t%.4f\t%.4f\t%.4f\t%.4f\t%.1f\t%d\t%.3g\t%.3g\t%.3g\t%s\n",
                  name.c_str(), mean_ratio[0], mean_ratio[1], mean_ratio[2],
                  std::max({mean_sigma[0], mean_sigma[1], mean_sigma[2]}), worst_ratio, worst_z,
                  failing_blocks, rel_tr, rel_tt, rel_rr, ok ? "ok" : "FAIL");
    table << row << std::flush;
    MESSAGE(row);
    if (!ok) {
        write_diagnostics(name, t, r);
        FAIL_CHECK(name << ":" << why_failed.str()
                        << (e.why.empty() ? "" : " (expected deviation: " + e.why + ")"));
    }
}

void check_family(const std::string &family) {
    std::map<std::string, Expectation> expect = read_expectations();
    std::vector<std::string> names = scenes_of(family);
    REQUIRE_MESSAGE(!names.empty(), "no fidelity scenes of family " << family);
    fs::path dir = fs::path(output_dir()) / "fidelity";
    fs::create_directories(dir);
    std::ofstream table(dir / (family + ".tsv"));
    table << "scene\tmean_R\tmean_G\tmean_B\tmean_noise\tworst_block\tmax_z\tbad_blocks"
             "\trelmse_vs_pbrt\trelmse_seeds\trelmse_pbrt_seeds\tresult\n";
    for (const std::string &n : names) {
        auto it = expect.find(n);
        check_scene(n, it == expect.end() ? Expectation{} : it->second, table);
    }
}

/// Public scenes of ../shared/scenes checked against pbrt-v4 references at a reduced
/// resolution (tests/fidelity/make_refs.py SHARED_SCENES renders them): name, path under
/// ../shared, resolution.
struct SharedScene {
    const char *name, *path;
    int width, height;
};
const SharedScene kSharedScenes[] = {
    {"shared-staircase2", "scenes/bitterli/staircase2/scene-v4.pbrt", 128, 128},
};

}  // namespace

// The families; ctest runs each alone (tests/CMakeLists.txt: fidelity_<family>).
const char *const kFamilies[] = {"material", "coated", "furnace", "texture", "light", "camera",
                                 "filter", "film", "integrator", "spectral", "shape",
                                 "medium"};

TEST_CASE("families: every scene belongs to one, and every family has scenes") {
    for (const auto &entry : fs::directory_iterator(kDir / "scenes")) {
        if (entry.path().extension() != ".pbrt") continue;
        std::string n = entry.path().stem().string();
        bool known = false;
        for (const char *f : kFamilies) known = known || n.substr(0, n.find('-')) == f;
        CHECK_MESSAGE(known, n << ".pbrt: its family (the name up to the first '-') is not one "
                                  "of fidelity_render.cpp's");
    }
    for (const char *f : kFamilies) CHECK_MESSAGE(!scenes_of(f).empty(), f);
    // Every expectation names a scene that exists.
    for (const auto &entry : read_expectations()) {
        const std::string &name = entry.first;
        bool shared = false;
        for (const SharedScene &sh : kSharedScenes) shared = shared || name == sh.name;
        CHECK_MESSAGE((shared || fs::exists(kDir / "scenes" / (name + ".pbrt"))),
                      "expectations.txt names a scene that does not exist: " << name);
    }
}

TEST_CASE("material") { check_family("material"); }
TEST_CASE("coated") { check_family("coated"); }
TEST_CASE("furnace") { check_family("furnace"); }
TEST_CASE("texture") { check_family("texture"); }
TEST_CASE("light") { check_family("light"); }
TEST_CASE("camera") { check_family("camera"); }
TEST_CASE("filter") { check_family("filter"); }
TEST_CASE("film") { check_family("film"); }
TEST_CASE("integrator") { check_family("integrator"); }
TEST_CASE("spectral") { check_family("spectral"); }
TEST_CASE("medium") { check_family("medium"); }

TEST_CASE("shared") {
    TESSERA_REQUIRE_SHARED(shared);
    std::map<std::string, Expectation> expect = read_expectations();
    fs::path dir = fs::path(output_dir()) / "fidelity";
    fs::create_directories(dir);
    std::ofstream table(dir / "shared.tsv");
    table << "scene\tmean_R\tmean_G\tmean_B\tmean_noise\tworst_block\tmax_z\tbad_blocks"
             "\trelmse_vs_pbrt\trelmse_seeds\trelmse_pbrt_seeds\tresult\n";
    for (const SharedScene &sh : kSharedScenes) {
        SceneOverrides ov;
        ov.width = sh.width;
        ov.height = sh.height;
        auto it = expect.find(sh.name);
        check_scene(sh.name, it == expect.end() ? Expectation{} : it->second, table,
                    (fs::path(shared) / sh.path).string(), ov);
    }
}
TEST_CASE("shape") { check_family("shape"); }
