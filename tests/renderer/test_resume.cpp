// Checkpoint and resume: N passes, checkpoint, resume to M passes == M passes straight.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "renderer/util/image_io.h"
#include "renderer/app/render.h"
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
    for (const char *sampler :
         {"adaptive:error=0.0005", "adaptive:error=0.0005,prefix-error=1", "uniform"}) {
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

TEST_CASE("resume keeps the checkpoint's AOVs; another --aov is refused") {
    fs::path dir = fs::path(test::output_dir()) / "resume_aovs";
    fs::create_directories(dir);
    std::ofstream(dir / "scene.pbrt") << kScene;
    RenderOptions base;
    base.scene = (dir / "scene.pbrt").string();
    base.sampler = parse_sampler_spec("uniform");
    base.deterministic = true;
    base.quiet = true;
    base.write_png = false;
    base.threads = 2;
    base.overrides.spp = 64;
    base.overrides.aovs = sampling::AovSet{sampling::Aov::Albedo, sampling::Aov::Depth};

    RenderOptions straight = base;
    straight.max_passes = 3;
    straight.output = (dir / "straight.exr").string();
    RenderReport rs = run_render(straight);
    CHECK(rs.aovs == std::vector<std::string>{"albedo", "depth"});
    CHECK(rs.film_bytes_per_pixel == sampling::Film::bytes_per_pixel_for(*base.overrides.aovs));

    RenderOptions first = base;
    first.max_passes = 1;
    first.output = (dir / "first.exr").string();
    first.checkpoint = (dir / "ckpt.exr").string();
    run_render(first);

    // Without --aov the resume takes the checkpoint's set (the scene's Film "rgb" has none).
    RenderOptions second = base;
    second.overrides.aovs.reset();
    second.max_passes = 3;
    second.resume = first.checkpoint;
    second.output = (dir / "resumed.exr").string();
    RenderReport r2 = run_render(second);
    CHECK(r2.aovs == rs.aovs);
    uint32_t w, h;
    for (const char *c : {"R", "albedo.G", "depth.Z", "spp.Y"}) {
        CAPTURE(c);
        std::vector<float> a = read_image_channels(straight.output, {c}, w, h);
        std::vector<float> b = read_image_channels(second.output, {c}, w, h);
        REQUIRE(a.size() == b.size());
        CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
    }
    std::vector<std::string> names = image_channel_names(second.output);
    CHECK(std::find(names.begin(), names.end(), "normal.X") == names.end());

    // The same set asked for explicitly is fine; another one is a clear error.
    RenderOptions same = second;
    same.overrides.aovs = base.overrides.aovs;
    same.output = (dir / "same.exr").string();
    CHECK_NOTHROW(run_render(same));
    for (sampling::AovSet other : {sampling::AovSet{}, sampling::AovSet::all()}) {
        RenderOptions bad = second;
        bad.overrides.aovs = other;
        bad.output = (dir / "bad.exr").string();
        CHECK_THROWS_WITH_AS(run_render(bad),
                             doctest::Contains(("checkpoint " + first.checkpoint +
                                                " has the AOVs albedo,depth")
                                                   .c_str()),
                             SceneError);
        CHECK_FALSE(fs::exists(dir / "bad.exr"));
    }
    fs::remove_all(dir);
}
