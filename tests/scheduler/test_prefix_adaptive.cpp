// The adaptive scheduler with the prefix error estimate (a film built with keep_prefix): a
// pixel whose value depends smoothly on where the sample lands in it converges in a few dozen
// samples with the prefix estimate, while the half buffer, whose odd-index samples are not a
// net, reads an error falling only as 1/sqrt(n) and samples it to the cap.
#include <doctest/doctest.h>

#include <algorithm>

#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"

using namespace tessera;
using namespace tessera::sched;

namespace {

/// A horizontal ramp inside every pixel: 0.5 + 0.4 (fx - 0.5). Noise-free: the only error of
/// a pixel's mean is how well its film offsets cover [0,1). Thread-safe.
class RampSource final : public SampleSource {
  public:
    uint32_t width() const override { return 24; }
    uint32_t height() const override { return 16; }
    std::string describe() const override { return "RampSource"; }
    Sample evaluate(const CameraSample &cs) const override {
        Sample s;
        s.rays = 1;
        s.radiance = Rgb(0.5f + 0.4f * (cs.fx - 0.5f));
        return s;
    }
};

}  // namespace

TEST_CASE("adaptive: with prefix errors a smooth pixel converges, the half buffer never lets it") {
    RampSource src;
    AdaptiveOptions o;
    o.threads = 2;
    o.seed = 3;
    o.deterministic = true;
    o.progress = ProgressReporter::Mode::Never;
    o.max_spp = 1024;
    // Leaves of at least one tile, as the CLI: the smallest (8x8) passes at a mean e_p of
    // 0.002 / sqrt(64 / 384) = 0.005.
    o.min_extent = 8;
    o.error_target = 0.002;
    for (bool prefix : {false, true}) {
        CAPTURE(prefix);
        sampling::Film film(src.width(), src.height(), {}, prefix);
        AdaptiveStats st = AdaptiveScheduler(src, film, o).render();
        uint32_t lo = UINT32_MAX, hi = 0;
        for (uint32_t y = 0; y < src.height(); ++y)
            for (uint32_t x = 0; x < src.width(); ++x) {
                lo = std::min(lo, film.sample_count(x, y));
                hi = std::max(hi, film.sample_count(x, y));
            }
        if (prefix) {
            // The prefix estimate falls as n^-1.5 (3.4e-3 at 32 spp): done within a few passes.
            CHECK(st.converged);
            CHECK(hi <= 64);
        } else {
            // The half-buffer estimate falls as 0.3 / sqrt(n): still 9e-3 at 1024 spp.
            CHECK_FALSE(st.converged);
            CHECK(lo == o.max_spp);
        }
    }
}
