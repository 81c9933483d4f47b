// Checkpoint and resume: N passes, checkpoint, resume to M passes == M passes straight.
#include <doctest/doctest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "renderer/image_io.h"
#include "renderer/render.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;

namespace {

const char *kScene = R"(
LookAt 0 1 3.5  0 1 0  0 1 0
Camera "perspective" "float fov" [ 45 ]
Film "rgb" "integer xresolution" [ 40 ] "integer yresolution" [ 24 ]
Sampler "zsobol" "integer pixelsamples" [ 256 ]
Integrator "path" "integer maxdepth" [ 4 ]
WorldBegin
Material "diffuse" "rgb reflectance" [ 0.6 0.5 0.4 ]
Shape "bilinearmesh" "point3 P" [ -1 0 1  1 0 1  -1 0 -1  1 0 -1 ]
Shape "bilinearmesh" "point3 P" [ -1 0 -1  1 0 -1  -1 2 -1  1 2 -1 ]
Material "dielectric"
AttributeBegin
Translate 0.3 0.4 0
Shape "sphere" "float radius" [ 0.4 ]
AttributeEnd
AttributeBegin
AreaLightSource "diffuse" "rgb L" [ 8 8 8 ]
Shape "sphere" "float radius" [ 0.1 ]
AttributeEnd
)";

std::vector<float> beauty(const std::string &exr) {
    uint32_t w, h;
    return read_image_channels(exr, {"R", "G", "B", "spp.Y"}, w, h);
}

}  // namespace

TEST_CASE("deterministic resume: 2 passes + checkpoint + resume to 5 == 5 passes straight") {
    fs::path dir = fs::path(test::output_dir()) / "resume";
    fs::create_directories(dir);
    std::ofstream(dir / "scene.pbrt") << kScene;
    for (const char *sampler : {"adaptive:error=0.0005", "uniform"}) {
        INFO("sampler " << sampler);
        RenderOptions base;
        base.scene = (dir / "scene.pbrt").string();
        base.sampler = parse_sampler_spec(sampler);
        base.deterministic = true;
        base.quiet = true;
        base.write_png = false;
        base.overrides.spp = 256;

        RenderOptions straight = base;
        straight.max_passes = 5;
        straight.threads = 2;
        straight.output = (dir / "straight.exr").string();
        RenderReport rs = run_render(straight);
        CHECK(rs.passes_total == 5);

        RenderOptions first = base;
        first.max_passes = 2;
        first.threads = 1;
        first.output = (dir / "first.exr").string();
        first.checkpoint = (dir / "ckpt.exr").string();
        RenderReport r1 = run_render(first);
        CHECK(r1.passes_total == 2);
        REQUIRE(fs::exists(dir / "ckpt.exr"));

        RenderOptions second = base;
        second.max_passes = 5;
        second.threads = 3;
        second.resume = (dir / "ckpt.exr").string();
        second.output = (dir / "resumed.exr").string();
        RenderReport r2 = run_render(second);
        CHECK(r2.passes_total == 5);

        std::vector<float> a = beauty(straight.output), b = beauty(second.output);
        REQUIRE(a.size() == b.size());
        CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
        // The partial render really was partial.
        std::vector<float> p = beauty(first.output);
        CHECK(std::memcmp(a.data(), p.data(), a.size() * sizeof(float)) != 0);
    }
    fs::remove_all(dir);
}

TEST_CASE("resume refuses a checkpoint of another render") {
    fs::path dir = fs::path(test::output_dir()) / "resume_bad";
    fs::create_directories(dir);
    std::ofstream(dir / "scene.pbrt") << kScene;
    RenderOptions o;
    o.scene = (dir / "scene.pbrt").string();
    o.quiet = true;
    o.write_png = false;
    o.overrides.spp = 4;
    o.output = (dir / "a.exr").string();
    o.checkpoint = (dir / "a.ckpt.exr").string();
    run_render(o);
    RenderOptions r = o;
    r.overrides.seed = 99;
    r.resume = o.checkpoint;
    r.output = (dir / "b.exr").string();
    CHECK_THROWS_WITH_AS(run_render(r), doctest::Contains("seed"), SceneError);
    RenderOptions s = o;
    s.overrides.width = 10;
    s.overrides.height = 10;
    s.resume = o.checkpoint;
    s.output = (dir / "c.exr").string();
    CHECK_THROWS_WITH_AS(run_render(s), doctest::Contains("checkpoint is 40x24"), SceneError);
    fs::remove_all(dir);
}
