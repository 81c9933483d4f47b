// The adaptive scheduler's tree rebuild (RegionTree::rebuild_cells) on one quadrant of a
// 1920x1080 film: 121x69 cells of 8x8 pixels (the quadrant grown by one tile), as the
// scheduler passes them, in both tree modes.
//
//   bench_region_tree [benchmark flags]
//
// The cell errors are a smooth field (three Gaussian blobs over a floor) times log-normal
// per-cell noise, the shape of a render's per-tile error after a few passes. The argument is
// the target as a fraction of the mean cell error: lower targets cut deeper trees (the
// `nodes` counter). "relmse" is the default sampler's mode (mean error, splits down to
// min_extent while a region is not calm; "Full" without range pruning), "dammertz" the
// area-weighted one.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "sampling/region_tree.h"

using namespace tessera::sampling;

namespace {

constexpr int kW = 1920, kH = 1080, kCell = 8;
const PixelBounds kQuad{0, 0, 960, 540}, kGrown{0, 0, 968, 548};

CellErrorImage make_cells(uint32_t seed, double *mean_pixel_error) {
    CellErrorImage c;
    c.cell = kCell;
    c.cols = (kGrown.width() + kCell - 1) / kCell;
    c.rows = (kGrown.height() + kCell - 1) / kCell;
    c.sum.resize(size_t(c.cols) * size_t(c.rows));
    c.unknown.assign(c.sum.size(), 0u);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> n(0, 1);
    double cx[3], cy[3], s[3];
    for (int k = 0; k < 3; ++k) {
        cx[k] = u(rng) * c.cols;
        cy[k] = u(rng) * c.rows;
        s[k] = (0.05 + 0.2 * u(rng)) * c.cols;
    }
    double total = 0, pixels = 0;
    for (int j = 0; j < c.rows; ++j)
        for (int i = 0; i < c.cols; ++i) {
            double f = 0.05;
            for (int k = 0; k < 3; ++k) {
                const double dx = (i - cx[k]) / s[k], dy = (j - cy[k]) / s[k];
                f += std::exp(-0.5 * (dx * dx + dy * dy));
            }
            const int pw = std::min(kCell, kGrown.width() - i * kCell);
            const int ph = std::min(kCell, kGrown.height() - j * kCell);
            const double e = f * std::exp(0.7 * n(rng)) * pw * ph;
            c.sum[size_t(j) * size_t(c.cols) + size_t(i)] = e;
            total += e;
            pixels += pw * ph;
        }
    *mean_pixel_error = total / pixels;
    return c;
}

void rebuild(benchmark::State &state, bool relmse, bool prune = true) {
    double mean = 0;
    const CellErrorImage cells = make_cells(7, &mean);
    RegionTreeParams p;
    p.area_weighted = !relmse;
    p.prune_by_range = prune;
    // Dammertz's region error carries r = sqrt(A_b / A_image) (at most 0.5 for a quadrant).
    p.target = mean * double(state.range(0)) / 100.0 * (relmse ? 1.0 : 0.05);
    RegionTree tree(kQuad, kGrown, double(kW) * kH);
    size_t nodes = tree.rebuild_cells(cells, p);
    for (auto _ : state) {
        nodes = tree.rebuild_cells(cells, p);
        benchmark::DoNotOptimize(nodes);
    }
    state.counters["nodes"] = double(nodes);
    state.counters["open_leaves"] = double(tree.open_leaf_count());
}

void BM_RebuildRelMSE(benchmark::State &state) { rebuild(state, true); }
void BM_RebuildDammertz(benchmark::State &state) { rebuild(state, false); }
/// The relMSE mode without range pruning (the full tree: same sampled pixels, more nodes).
void BM_RebuildRelMSEFull(benchmark::State &state) { rebuild(state, true, false); }

}  // namespace

BENCHMARK(BM_RebuildRelMSE)->Arg(200)->Arg(100)->Arg(50)->Arg(25)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RebuildRelMSEFull)->Arg(200)->Arg(100)->Arg(50)->Arg(25)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RebuildDammertz)->Arg(200)->Arg(100)->Arg(50)->Arg(25)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
