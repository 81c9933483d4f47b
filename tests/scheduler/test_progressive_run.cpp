// sched::ProgressiveRun: a render advanced chunk by chunk (each chunk a fresh scheduler that
// resumes at the last chunk's resume_pass) gives the film of one uninterrupted render, bit for
// bit, with deterministic passes; its totals are the chunks' statistics summed.
#include <doctest/doctest.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <vector>

#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"
#include "scheduler/progressive_run.h"
#include "synthetic_sources.h"

using namespace tessera;
using namespace tessera::sched;
using tessera::test::SyntheticSource;

namespace {

bool same_bits(const std::vector<float> &a, const std::vector<float> &b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

bool same_film(const sampling::Film &a, const sampling::Film &b) {
    return same_bits(a.beauty_rgb(), b.beauty_rgb()) && same_bits(a.half_rgb(), b.half_rgb()) &&
           same_bits(a.spp(), b.spp());
}

AdaptiveOptions base_options() {
    AdaptiveOptions o;
    o.threads = 2;
    o.seed = 11;
    o.progress = ProgressReporter::Mode::Never;
    o.deterministic = true;
    return o;
}

}  // namespace

TEST_CASE("ProgressiveRun: chunks stopped mid-pass give the uninterrupted film; stats summed") {
    const uint32_t w = 40, h = 24;
    AdaptiveOptions o = base_options();
    o.adaptive = false;
    o.min_spp = 4;
    o.max_spp = 48;

    SyntheticSource src_straight(w, h, test::gradient_noise_params());
    sampling::Film straight(w, h);
    ProgressiveRun one(src_straight, straight, o);
    AdaptiveStats s1 = one.advance(0);
    CHECK(one.chunks() == 1);
    CHECK(s1.samples == uint64_t(w) * h * o.max_spp);
    CHECK(one.total().samples == s1.samples);
    CHECK(one.total().passes == AdaptiveScheduler::pass_count(o));

    SyntheticSource src(w, h, test::gradient_noise_params());
    sampling::Film film(w, h);
    ProgressiveRun run(src, film, o);
    CHECK(run.start_pass() == -1);
    std::atomic<bool> cancel{false};
    uint64_t samples = 0, rays = 0;
    uint32_t chunks = 0;
    // Each chunk is cancelled after about 1.5 passes' worth of the 4-sample first pass.
    const uint64_t chunk_samples = uint64_t(w) * h * 6;
    while (true) {
        cancel = false;
        src.cancel_after(src.total() + chunk_samples, &cancel);
        AdaptiveStats s = run.advance(0, &cancel);
        ++chunks;
        samples += s.samples;
        rays += s.rays;
        CHECK(run.start_pass() == int64_t(s.resume_pass));
        CHECK(run.total().passes == s.first_pass + s.passes);
        if (!s.cancelled)
            break;
        REQUIRE(chunks < 100);
    }
    CHECK(chunks > 2);
    CHECK(run.chunks() == chunks);
    CHECK(run.total().samples == samples);
    CHECK(run.total().rays == rays);
    CHECK(samples == s1.samples);
    CHECK(run.total().passes == one.total().passes);
    CHECK(same_film(film, straight));
}

TEST_CASE("ProgressiveRun: adaptive chunks ending on pass boundaries match one render") {
    const uint32_t w = 48, h = 32;  // 24 tiles
    AdaptiveOptions o = base_options();
    o.threads = 1;
    o.adaptive = true;
    o.error_target = 0.002;
    o.min_spp = 8;
    o.max_spp = 256;

    SyntheticSource src_straight(w, h, test::gradient_noise_params(0.1f));
    sampling::Film straight(w, h);
    ProgressiveRun one(src_straight, straight, o);
    const AdaptiveStats s1 = one.advance(0);

    // One thread and barriers between passes: tiles run in order, so cancelling in the last
    // tile visit of every second pass ends each chunk on a pass boundary.
    SyntheticSource src(w, h, test::gradient_noise_params(0.1f));
    sampling::Film film(w, h);
    std::atomic<bool> cancel{false};
    std::atomic<uint32_t> last_pass_cut{0};
    const size_t tiles = (w / 8) * (h / 8);
    std::atomic<size_t> visits{0};
    AdaptiveOptions c = o;
    c.tile_hook = [&](const Tile &, uint32_t pass) {
        const size_t v = ++visits;
        if (v % tiles == 0 && pass % 2 == 1) {
            last_pass_cut = pass;
            cancel = true;
        }
    };
    ProgressiveRun run(src, film, c);
    uint32_t chunks = 0;
    uint64_t samples = 0;
    while (true) {
        cancel = false;
        visits = 0;
        AdaptiveStats s = run.advance(0, &cancel);
        ++chunks;
        samples += s.samples;
        if (!s.cancelled)
            break;
        // Every tile finished the pass the hook cut after: the next chunk starts the next one.
        CHECK(s.resume_pass == last_pass_cut + 1);
        REQUIRE(chunks < 100);
    }
    CHECK(chunks > 1);
    CHECK(run.total().samples == samples);
    CHECK(samples == s1.samples);
    CHECK(run.total().converged == s1.converged);
    CHECK(same_film(film, straight));
}
