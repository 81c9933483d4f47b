// The scheduler on a synthetic source under mpirun: MPI_COMM_WORLD (renderer/app/mpi_group.h)
// as the RankGroup of a distributed render (docs/ARCHITECTURE.md, "Distributed rendering").
//
//   mpirun -np N mpi_synthetic
//
// Checks, for the job's N ranks: deterministic renders (uniform, relMSE spp budget, refining,
// Dammertz) gathered on rank 0 equal rank 0's own single-process render bit for bit; without
// `deterministic`, 2 threads a rank, every rank evaluates samples only in its own tiles, no
// tile is visited twice in a pass, and the gathered film's counts are the samples all ranks'
// sources evaluated (summed over the ranks). Rank 0 prints PASS or the failures; the exit code
// is 0 only when every check holds on every rank.
#include <mpi.h>

#include <cstdio>
#include <cstring>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "renderer/app/mpi_group.h"
#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"
#include "scheduler/rank_group.h"
#include "../scheduler/synthetic_sources.h"

using namespace tessera;
using namespace tessera::sched;

namespace {

constexpr uint32_t kW = 72, kH = 40;
int g_failures = 0;

void check(bool ok, const std::string &what) {
    if (!ok) {
        ++g_failures;
        std::fprintf(stderr, "FAIL: %s\n", what.c_str());
    }
}

std::vector<std::byte> film_bytes(const sampling::Film &film) {
    std::vector<uint32_t> all(size_t(film.width()) * film.height());
    for (size_t i = 0; i < all.size(); ++i) all[i] = uint32_t(i);
    std::vector<std::byte> out;
    film.pack_pixels(all, out);
    return out;
}

AdaptiveOptions mode_options(int mode) {
    AdaptiveOptions o;
    o.seed = 9;
    o.progress = ProgressReporter::Mode::Never;
    o.deterministic = true;
    o.threads = 1;
    switch (mode) {
    case 0:
        o.adaptive = false;
        o.max_spp = 48;
        break;
    case 1:
        o.metric = sampling::ErrorMetric::RelMse;
        o.spp_budget = 32;
        o.max_spp = 256;
        break;
    case 2:
        o.metric = sampling::ErrorMetric::RelMse;
        o.refine_target = true;
        o.error_target = 1.0;
        o.max_spp = 192;
        break;
    default:
        o.metric = sampling::ErrorMetric::Dammertz;
        o.error_target = 0.002;
        o.max_spp = 256;
        break;
    }
    return o;
}

}  // namespace

int main(int argc, char **argv) {
    std::unique_ptr<MpiJob> job = MpiJob::start(argc, argv);
    if (!job) {
        std::fprintf(stderr, "mpi_synthetic: run it under mpirun\n");
        return 2;
    }
    RankGroup &group = job->group();
    const uint32_t me = group.rank(), n = group.size();
    const sampling::PixelBounds hard{16, 8, 40, 24};
    test::TwoNoiseSource noise(kW, kH, hard, 0.3f, 0.05f);

    for (int mode = 0; mode < 4; ++mode) {
        const bool prefix = mode == 2;
        AdaptiveOptions o = mode_options(mode);
        sampling::Film film(kW, kH, {}, prefix);
        FilmGatherer gather(group, film);
        AdaptiveOptions ro = o;
        ro.group = &group;
        ro.threads = 1 + me % 2;
        AdaptiveScheduler sched(noise, film, ro);
        const AdaptiveStats st = sched.render();
        gather.gather();
        if (me == 0) {
            sampling::Film single(kW, kH, {}, prefix);
            AdaptiveScheduler one(noise, single, o);
            const AdaptiveStats s1 = one.render();
            check(film_bytes(film) == film_bytes(single),
                  "mode " + std::to_string(mode) + ": " + std::to_string(n) +
                      " ranks differ from one process");
            check(st.samples == s1.samples, "mode " + std::to_string(mode) + ": sample totals");
            check(st.passes == s1.passes, "mode " + std::to_string(mode) + ": passes");
        }
    }

    // Ranks x threads, barrier-free inside each rank, refining.
    {
        test::SyntheticParams sp;
        sp.noise = 0.2f;
        test::SyntheticSource src(kW, kH, sp);
        AdaptiveOptions o = mode_options(2);
        o.deterministic = false;
        o.threads = 2;
        o.group = &group;
        const std::vector<Tile> tiles = make_morton_tiles(kW, kH);
        std::mutex m;
        std::set<std::pair<uint32_t, uint32_t>> seen;
        bool twice = false, foreign = false;
        o.visit_hook = [&](const TileVisit &v) {
            uint32_t t = 0;
            while (t < tiles.size() && !(tiles[t].tx == v.tile->tx && tiles[t].ty == v.tile->ty)) ++t;
            std::lock_guard<std::mutex> lock(m);
            twice = twice || !seen.insert({v.pass, t}).second;
            foreign = foreign || tile_owner(t, n) != me;
        };
        sampling::Film film(kW, kH, {}, true);
        FilmGatherer gather(group, film);
        AdaptiveScheduler sched(src, film, o);
        sched.render();
        gather.gather();
        check(!twice, "rank " + std::to_string(me) + ": a tile visited twice in a pass");
        check(!foreign, "rank " + std::to_string(me) + ": a foreign tile visited");
        // Samples evaluated per pixel, summed over the ranks' sources.
        std::vector<double> counts(size_t(kW) * kH);
        bool outside = false;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) {
                counts[size_t(y) * kW + x] = src.count(x, y);
                const uint32_t t = uint32_t(std::find_if(tiles.begin(), tiles.end(),
                                                         [&](const Tile &tl) {
                                                             return x >= tl.x0 && x < tl.x1 &&
                                                                    y >= tl.y0 && y < tl.y1;
                                                         }) -
                                            tiles.begin());
                outside = outside || (src.count(x, y) > 0 && tile_owner(t, n) != me);
            }
        check(!outside, "rank " + std::to_string(me) + ": samples outside its tiles");
        group.sum(counts);
        if (me == 0) {
            bool match = true;
            for (uint32_t y = 0; y < kH; ++y)
                for (uint32_t x = 0; x < kW; ++x)
                    match = match && double(film.sample_count(x, y)) == counts[size_t(y) * kW + x];
            check(match, "the gathered counts are not the samples the ranks evaluated");
        }
    }

    double failures = g_failures;
    group.sum(std::span<double>(&failures, 1));
    if (me == 0)
        std::printf("%s: %u ranks, %d failures\n", failures == 0 ? "PASS" : "FAIL", n,
                    int(failures));
    return failures == 0 ? 0 : 1;
}
