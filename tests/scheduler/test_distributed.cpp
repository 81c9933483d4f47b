// Distributed rendering (scheduler/rank_group.h, "Distributed rendering" in
// scheduler/adaptive_scheduler.h) with N ranks as threads of one process (LocalRankGroup): the
// protocol the MPI build runs, checked without MPI. Deterministic renders over 1-4 ranks equal
// the single-process render bit for bit (uniform, relMSE with an spp budget, refining, Dammertz,
// prefix estimate, NaN samples); every tile is rendered by its owner only and once per pass;
// N passes on one rank count + a resume on another == M passes straight; a time budget and one
// rank's cancel end every rank at the same pass; the barrier-free statistics hold.
#include <doctest/doctest.h>

#include <atomic>
#include <cstring>
#include <memory>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"
#include "scheduler/rank_group.h"
#include "synthetic_sources.h"

using namespace tessera;
using namespace tessera::sched;
using tessera::test::SyntheticParams;
using tessera::test::SyntheticSource;
using tessera::test::TwoNoiseSource;

namespace {

constexpr uint32_t kW = 72, kH = 40;  // 9 x 5 tiles: quadrants of unequal size
const sampling::PixelBounds kHard{16, 8, 40, 24};

/// The film's whole state, every pixel (bytes of Film::pack_pixels) and the NaN count.
std::vector<std::byte> film_bytes(const sampling::Film &film) {
    std::vector<uint32_t> all(size_t(film.width()) * film.height());
    for (size_t i = 0; i < all.size(); ++i) all[i] = uint32_t(i);
    std::vector<std::byte> out;
    film.pack_pixels(all, out);
    const uint64_t nans = film.nan_count();
    const auto *b = reinterpret_cast<const std::byte *>(&nans);
    out.insert(out.end(), b, b + sizeof nans);
    return out;
}

/// A copy of `film` (a checkpoint written and read back).
std::unique_ptr<sampling::Film> copy_film(const sampling::Film &film) {
    auto out = std::make_unique<sampling::Film>(film.width(), film.height(), film.aovs(),
                                                film.keeps_prefix());
    std::vector<uint32_t> all(size_t(film.width()) * film.height());
    for (size_t i = 0; i < all.size(); ++i) all[i] = uint32_t(i);
    std::vector<std::byte> bytes;
    film.pack_pixels(all, bytes);
    out->unpack_pixels(all, bytes, film.nan_count());
    return out;
}

struct RankResult {
    std::unique_ptr<sampling::Film> film;  // rank 0's film after the gather
    std::vector<AdaptiveStats> stats;      // per rank
};

/// Renders with `ranks` ranks of `threads` threads each; every rank starts from a copy of
/// `start` (null: an empty film). `per_rank` adjusts a rank's options (hooks, cancel).
RankResult render_ranks(const SampleSource &src, const AdaptiveOptions &o, uint32_t ranks,
                        uint32_t threads, bool prefix, const sampling::Film *start = nullptr,
                        std::function<void(uint32_t, AdaptiveOptions &)> per_rank = {},
                        std::vector<const std::atomic<bool> *> cancels = {}) {
    auto group = LocalRankGroup::create(ranks);
    std::vector<std::unique_ptr<sampling::Film>> films;
    for (uint32_t r = 0; r < ranks; ++r)
        films.push_back(start ? copy_film(*start)
                              : std::make_unique<sampling::Film>(kW, kH, sampling::AovSet{}, prefix));
    RankResult res;
    res.stats.resize(ranks);
    std::vector<std::thread> pool;
    std::mutex error_mutex;
    std::string error;
    for (uint32_t r = 0; r < ranks; ++r)
        pool.emplace_back([&, r] {
            try {
                AdaptiveOptions ro = o;
                ro.threads = threads;
                ro.group = group[r].get();
                if (per_rank)
                    per_rank(r, ro);
                FilmGatherer gather(*group[r], *films[r]);  // before: the NaN base
                AdaptiveScheduler sched(src, *films[r], ro);
                res.stats[r] = sched.render(r < cancels.size() ? cancels[r] : nullptr);
                gather.gather();
            } catch (const std::exception &e) {
                std::lock_guard<std::mutex> lock(error_mutex);
                error = e.what();
            }
        });
    for (auto &t : pool) t.join();
    REQUIRE(error.empty());
    res.film = std::move(films[0]);
    return res;
}

AdaptiveStats render_single(const SampleSource &src, AdaptiveOptions o, sampling::Film &film,
                            uint32_t threads) {
    o.threads = threads;
    AdaptiveScheduler sched(src, film, o);
    return sched.render();
}

AdaptiveOptions base_options() {
    AdaptiveOptions o;
    o.seed = 5;
    o.progress = ProgressReporter::Mode::Never;
    o.deterministic = true;
    return o;
}

/// The modes of the bit-identity test.
AdaptiveOptions mode_options(int mode) {
    AdaptiveOptions o = base_options();
    switch (mode) {
    case 0:  // uniform
        o.adaptive = false;
        o.max_spp = 48;
        break;
    case 1:  // relMSE, spp budget
        o.metric = sampling::ErrorMetric::RelMse;
        o.spp_budget = 32;
        o.max_spp = 256;
        break;
    case 2:  // relMSE, refining to an spp cap (prefix estimate)
        o.metric = sampling::ErrorMetric::RelMse;
        o.refine_target = true;
        o.error_target = 1.0;
        o.max_spp = 192;
        break;
    default:  // Dammertz, a fixed target
        o.metric = sampling::ErrorMetric::Dammertz;
        o.error_target = 0.002;
        o.max_spp = 256;
        break;
    }
    return o;
}

}  // namespace

TEST_CASE("distributed: deterministic renders equal the single-process render for 1-4 ranks") {
    TwoNoiseSource noise(kW, kH, kHard, 0.3f, 0.05f);
    SyntheticParams sp;
    sp.noise = 0.2f;
    sp.firefly_probability = 0.002f;
    sp.nan_x = 30;
    sp.nan_y = 17;
    SyntheticSource fireflies(kW, kH, sp);
    for (int mode = 0; mode < 4; ++mode) {
        for (int s = 0; s < 2; ++s) {
            const SampleSource &src = s == 0 ? static_cast<const SampleSource &>(noise) : fireflies;
            const bool prefix = mode == 2;
            const AdaptiveOptions o = mode_options(mode);
            sampling::Film single(kW, kH, {}, prefix);
            const AdaptiveStats st = render_single(src, o, single, 2);
            const std::vector<std::byte> want = film_bytes(single);
            for (uint32_t ranks = 1; ranks <= 4; ++ranks) {
                CAPTURE(mode);
                CAPTURE(s);
                CAPTURE(ranks);
                RankResult res = render_ranks(src, o, ranks, ranks == 3 ? 1 : 2, prefix);
                CHECK(film_bytes(*res.film) == want);
                for (const AdaptiveStats &rs : res.stats) {
                    CHECK(rs.samples == st.samples);
                    CHECK(rs.passes == st.passes);
                    CHECK(rs.converged == st.converged);
                    CHECK(rs.spp_histogram == st.spp_histogram);
                    CHECK(rs.nan_samples == st.nan_samples);
                    CHECK(rs.ranks == ranks);
                }
                uint64_t own = 0;
                for (const AdaptiveStats &rs : res.stats) own += rs.rank_samples;
                CHECK(own == st.samples);
            }
            if (s == 1)
                CHECK(st.nan_samples > 0);  // the NaN pixel's drops were gathered too
        }
    }
}

TEST_CASE("distributed: every tile is rendered by its owner alone, once per pass, ranks x threads") {
    // Barrier-free inside each rank (no `deterministic`), 3 ranks x 2 threads, refining.
    TwoNoiseSource noise(kW, kH, kHard, 0.3f, 0.05f);
    SyntheticParams sp;
    sp.noise = 0.2f;
    SyntheticSource src(kW, kH, sp);
    AdaptiveOptions o = base_options();
    o.deterministic = false;
    o.metric = sampling::ErrorMetric::RelMse;
    o.refine_target = true;
    o.error_target = 1.0;
    o.max_spp = 128;
    const uint32_t ranks = 3;
    std::mutex m;
    std::set<std::pair<uint32_t, uint32_t>> seen;  // (pass, tile) visits
    bool twice = false, foreign = false;
    std::vector<Tile> tiles = make_morton_tiles(kW, kH);
    auto tile_index = [&](const Tile &t) {
        for (size_t i = 0; i < tiles.size(); ++i)
            if (tiles[i].tx == t.tx && tiles[i].ty == t.ty) return uint32_t(i);
        return uint32_t(-1);
    };
    RankResult res = render_ranks(src, o, ranks, 2, false, nullptr, [&](uint32_t r, AdaptiveOptions &ro) {
        ro.visit_hook = [&, r](const TileVisit &v) {
            const uint32_t t = tile_index(*v.tile);
            std::lock_guard<std::mutex> lock(m);
            twice = twice || !seen.insert({v.pass, t}).second;
            foreign = foreign || tile_owner(t, ranks) != r;
        };
    });
    CHECK_FALSE(twice);
    CHECK_FALSE(foreign);
    // Pass 0 visited every tile.
    for (uint32_t t = 0; t < tiles.size(); ++t) CHECK(seen.count({0u, t}) == 1);
    // The gathered counts are exactly the samples the source evaluated, pixel by pixel.
    bool counts_match = true;
    uint64_t film_total = 0;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            counts_match = counts_match && res.film->sample_count(x, y) == src.count(x, y) &&
                           src.indices_exact(x, y, src.count(x, y));
            film_total += res.film->sample_count(x, y);
        }
    CHECK(counts_match);
    CHECK(film_total == res.stats[0].samples);
    for (const AdaptiveStats &rs : res.stats) CHECK(rs.samples == res.stats[0].samples);
    (void)noise;
}

TEST_CASE("distributed: N passes on some ranks + a resume on others == M passes straight") {
    TwoNoiseSource src(kW, kH, kHard, 0.3f, 0.05f);
    for (int mode = 1; mode < 4; ++mode) {
        CAPTURE(mode);
        const bool prefix = mode == 2;
        AdaptiveOptions o = mode_options(mode);
        sampling::Film straight(kW, kH, {}, prefix);
        const AdaptiveStats all = render_single(src, o, straight, 2);
        REQUIRE(all.passes >= 3);
        const uint32_t cut = all.passes / 2;
        for (const auto &ranks : {std::pair{2u, 3u}, std::pair{4u, 1u}, std::pair{1u, 2u}}) {
            // Plain variables: clang does not let doctest's CAPTURE lambdas see bindings.
            const uint32_t first = ranks.first, second = ranks.second;
            CAPTURE(first);
            CAPTURE(second);
            AdaptiveOptions a = o;
            a.max_passes = cut;
            RankResult part = render_ranks(src, a, first, 1, prefix);
            REQUIRE(part.stats[0].resume_pass == cut);
            AdaptiveOptions b = o;
            b.start_pass = part.stats[0].resume_pass;
            RankResult rest = render_ranks(src, b, second, 2, prefix, part.film.get());
            CHECK(film_bytes(*rest.film) == film_bytes(straight));
        }
    }
}

TEST_CASE("distributed: a time budget and one rank's cancel end every rank at the same pass") {
    SyntheticParams sp;
    sp.noise = 0.2f;
    SUBCASE("time") {
        SyntheticSource src(kW, kH, sp);
        AdaptiveOptions o = base_options();
        o.adaptive = false;
        o.max_spp = 0;  // only the time ends it
        o.time_s = 0.3;
        RankResult res = render_ranks(src, o, 3, 1, false);
        for (const AdaptiveStats &rs : res.stats) {
            CHECK(rs.out_of_time);
            CHECK(rs.resume_pass == res.stats[0].resume_pass);
            CHECK(rs.samples == res.stats[0].samples);
            CHECK(rs.wall_s < 5.0);
        }
        // Every pixel has the samples of the passes before resume_pass, and the film has
        // exactly what the source evaluated.
        const uint32_t done = AdaptiveScheduler::pass_target(o, res.stats[0].resume_pass - 1);
        bool ok = true;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x)
                ok = ok && res.film->sample_count(x, y) >= done &&
                     res.film->sample_count(x, y) == src.count(x, y);
        CHECK(ok);
    }
    SUBCASE("cancel") {
        SyntheticSource src(kW, kH, sp);
        std::atomic<bool> cancel{false};
        src.cancel_after(40000, &cancel);  // about 14 spp: inside the third pass
        AdaptiveOptions o = base_options();
        o.adaptive = false;
        o.max_spp = 4096;
        // Only rank 1 sees the flag.
        RankResult res = render_ranks(src, o, 3, 1, false, nullptr, {}, {nullptr, &cancel, nullptr});
        for (const AdaptiveStats &rs : res.stats) {
            CHECK(rs.cancelled);
            CHECK(rs.resume_pass == res.stats[0].resume_pass);
        }
        CHECK(res.stats[0].resume_pass < 6);
        bool ok = true;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x)
                ok = ok && res.film->sample_count(x, y) == src.count(x, y);
        CHECK(ok);
    }
}

TEST_CASE("distributed: barrier-free ranks keep the spp budget's statistics") {
    // Without `deterministic` (per-tile costs measured on each rank), an spp budget of 32
    // still reaches about the relMSE of 32 uniform samples with fewer samples.
    TwoNoiseSource src(kW, kH, kHard, 0.3f, 0.05f);
    AdaptiveOptions o = base_options();
    o.deterministic = false;
    o.metric = sampling::ErrorMetric::RelMse;
    o.spp_budget = 32;
    o.max_spp = 256;
    RankResult res = render_ranks(src, o, 2, 2, false);
    double err = 0, uni = 0;
    const double hard = double(kHard.area()), all = double(kW) * kH;
    uni = (hard * 0.09 + (all - hard) * 0.0025) / (3.0 * all) / (32.0 * 0.26);
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const sampling::PixelStats st = res.film->pixel_stats(x, y);
            for (int c = 0; c < 3; ++c) err += (st.mean[c] - 0.5) * (st.mean[c] - 0.5) / 0.26;
        }
    err /= 3.0 * all;
    MESSAGE("relMSE " << err << " against uniform 32 spp " << uni << ", samples "
                      << res.stats[0].samples << " against " << 32 * kW * kH);
    CHECK(err < 1.3 * uni);
    CHECK(double(res.stats[0].samples) < 0.95 * 32.0 * all);
}
