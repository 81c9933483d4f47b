// Rendering in chunks (tessera render --checkpoint-every, tessera converge snapshots): each
// chunk is a new render() that stops part-way through a pass; the next one must resume at
// AdaptiveStats::resume_pass, the first pass some tile has not finished, so that the tiles late
// in Morton order are not left behind.
#include <doctest/doctest.h>

#include <atomic>
#include <cstdint>

#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"
#include "synthetic_sources.h"

using namespace tessera;
using namespace tessera::sched;
using tessera::test::SyntheticSource;

namespace {

uint32_t min_count(const sampling::Film &film) {
    uint32_t m = UINT32_MAX;
    for (uint32_t y = 0; y < film.height(); ++y)
        for (uint32_t x = 0; x < film.width(); ++x)
            m = std::min(m, film.sample_count(x, y));
    return m;
}

}  // namespace

TEST_CASE("chunks that stop mid-pass resume at resume_pass and cover every pixel") {
    // 64x64 pixels = 64 tiles, 16 per quadrant. Each chunk is cancelled after about 20 tiles
    // of the 16-sample first pass: quadrant 0 (the first 16 tiles in Morton order) completes
    // its pass in the first chunk while the others have not started.
    const uint32_t w = 64, h = 64, chunk_samples = 20 * 64 * 16;
    for (bool deterministic : {false, true}) {
        CAPTURE(deterministic);
        SyntheticSource src(w, h, test::gradient_noise_params());
        sampling::Film film(w, h);
        AdaptiveOptions o;
        o.threads = 2;
        o.seed = 5;
        o.progress = ProgressReporter::Mode::Never;
        o.adaptive = false;
        o.min_spp = 16;
        o.max_spp = 4096;
        o.deterministic = deterministic;
        o.min_extent = 1;  // split down to single pixels (the samplers' default: one tile)
        std::atomic<bool> cancel{false};
        int64_t start = -1;
        for (int chunk = 0; chunk < 4; ++chunk) {
            cancel = false;
            src.cancel_after(src.total() + chunk_samples, &cancel);
            AdaptiveOptions c = o;
            c.start_pass = start;
            AdaptiveStats s = AdaptiveScheduler(src, film, c).render(&cancel);
            CHECK(s.cancelled);
            if (chunk == 0) {
                // The first pass is not finished everywhere: resume there.
                CHECK(s.resume_pass == 0);
                CHECK(min_count(film) == 0);
            }
            CHECK(s.resume_pass <= s.first_pass + s.passes);
            start = int64_t(s.resume_pass);
        }
        // 4 chunks of ~20 tiles: the first pass (64 tiles) is complete everywhere.
        CHECK(min_count(film) >= 16);
        CHECK(start >= 1);
        bool exact = true;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x)
                exact = exact && src.indices_exact(x, y, film.sample_count(x, y));
        CHECK(exact);
    }
}

TEST_CASE("resume_pass equals first_pass + passes when the passes complete") {
    const uint32_t w = 24, h = 16;
    SyntheticSource src(w, h, test::gradient_noise_params());
    sampling::Film film(w, h);
    AdaptiveOptions o;
    o.threads = 2;
    o.progress = ProgressReporter::Mode::Never;
    o.adaptive = false;
    o.max_spp = 64;
    o.min_extent = 1;  // split down to single pixels (the samplers' default: one tile)
    AdaptiveStats s = AdaptiveScheduler(src, film, o).render();
    CHECK(s.passes == AdaptiveScheduler::pass_count(o));
    CHECK(s.resume_pass == s.first_pass + s.passes);
}
