// The two per-point costs the real-time plugins trade against each other, on the same points of
// one scene with everything warm in the cache: the Whitted source's evaluate_batch() (primary
// ray in packets of 8, shadow rays, reflections, shading: what a traced pixel costs) and
// shade() of the attribute vectors those samples returned (no ray: what an interpolated pixel of
// `kim` or a filled-in point costs, minus the plugin's own bookkeeping).
//
//   bench_shade [--scene FILE] [--res N] [benchmark flags]
//
// Default scene: examples/realtime/thin-shadows.pbrt (textured diffuse, two delta lights, thin
// conductor wires), at 128x128 pixel centres. Reported per point (items/s).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "renderer/scene/scene.h"
#include "renderer/integrators/whitted_integrator.h"

using namespace tessera;

namespace {

struct Points {
    std::unique_ptr<Scene> scene;
    std::unique_ptr<WhittedIntegrator> source;
    std::vector<CameraSample> samples;
    std::vector<HitAttributes> attributes;  ///< of the samples that hit a surface
};

Points &points() {
    static Points p;
    return p;
}

void prepare(const std::string &path, int res) {
    Points &p = points();
    SceneOverrides ov;
    ov.width = ov.height = res;
    p.scene = load_scene(path, ov);
    p.source = std::make_unique<WhittedIntegrator>(*p.scene, WhittedOptions{});
    for (int y = 0; y < res; ++y)
        for (int x = 0; x < res; ++x) {
            CameraSample cs;
            cs.px = uint32_t(x);
            cs.py = uint32_t(y);
            cs.fx = cs.fy = 0.5f;
            p.samples.push_back(cs);
        }
    std::vector<Sample> out(p.samples.size());
    p.source->evaluate_batch(p.samples, out);
    for (const Sample &s : out)
        if (s.first_hit && s.first_hit->primary.hit())
            p.attributes.push_back(*s.first_hit);
}

void BM_EvaluateBatch(benchmark::State &state) {
    Points &p = points();
    std::vector<Sample> out(64);
    size_t i = 0;
    int64_t items = 0;
    for (auto _ : state) {
        const size_t n = std::min<size_t>(64, p.samples.size() - i);
        p.source->evaluate_batch(std::span<const CameraSample>(p.samples.data() + i, n),
                                 std::span<Sample>(out.data(), n));
        benchmark::DoNotOptimize(out.data());
        items += int64_t(n);
        i = i + n == p.samples.size() ? 0 : i + n;
    }
    state.SetItemsProcessed(items);
}

void BM_Shade(benchmark::State &state) {
    Points &p = points();
    size_t i = 0;
    for (auto _ : state) {
        Rgb c = p.source->shade(p.attributes[i]);
        benchmark::DoNotOptimize(c);
        i = i + 1 == p.attributes.size() ? 0 : i + 1;
    }
    state.SetItemsProcessed(int64_t(state.iterations()));
}

}  // namespace

int main(int argc, char **argv) {
    std::string scene = std::string(TESSERA_SOURCE_DIR) + "/examples/realtime/thin-shadows.pbrt";
    int res = 128;
    std::vector<char *> rest{argv[0]};
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--scene") && i + 1 < argc)
            scene = argv[++i];
        else if (!std::strcmp(argv[i], "--res") && i + 1 < argc)
            res = std::atoi(argv[++i]);
        else
            rest.push_back(argv[i]);
    }
    prepare(scene, res);
    std::printf("%s: %zu samples, %zu surface hits\n", scene.c_str(), points().samples.size(),
                points().attributes.size());
    benchmark::RegisterBenchmark("evaluate_batch", BM_EvaluateBatch);
    benchmark::RegisterBenchmark("shade", BM_Shade);
    int n = int(rest.size());
    benchmark::Initialize(&n, rest.data());
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
