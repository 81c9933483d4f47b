// Uniform progressive rendering: passes over the Morton-ordered 8x8 tiles on TBB workers.
//
// Pass k takes every pixel up to the cumulative target min(2^k, spp) samples (pass sizes
// 1, 1, 2, 4, 8, ... the last one cut so the total is exactly spp). Within a pass, workers
// take tiles in Morton order from a shared atomic work index; each tile is rendered by one
// thread, pixel by pixel, each pixel's samples in index order. A pixel's next sample index is
// the film's count of samples it has taken, so a pixel's samples are always accumulated in the
// order 0, 1, 2, ... by one thread at a time: the film is bit-identical for any thread count,
// and a render that resumes on a film that already holds samples continues each pixel's own
// sequence.
//
// Film position: the scheduler gives sample `index` of pixel (px, py) the offset
// (fx, fy) = SobolSampler(seed) started at (px, py, index) -> get_pixel_2d(), i.e. the reserved
// dimensions 0 and 1 of sampling/sequence.h: a pure function of (seed, pixel, index). An
// integrator continues the same sequence at dimension 2 with
//   sampling::SobolSampler s(seed); s.start_pixel_sample(cs.px, cs.py, cs.index);
// (see TileScheduler::sampler_for).
//
// Stopping: the cancel flag and the time budget are checked between tiles, so a stop leaves
// some pixels a pass ahead of others; the film's per-pixel counts stay exact.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "sampling/film.h"
#include "sampling/sample_source.h"
#include "sampling/sequence.h"
#include "scheduler/progress.h"
#include "scheduler/tiles.h"

namespace tessera::sched {

/// How long to render: samples per pixel and an optional wall-clock limit.
struct RenderBudget {
    uint32_t spp = 16;   ///< target samples per pixel (0: unlimited, needs time_s > 0)
    double time_s = 0;   ///< wall-clock limit in seconds (0: none)
};

/// Scheduler settings.
struct SchedulerOptions {
    /// Worker threads (0: all cores, TBB's default concurrency).
    uint32_t threads = 0;
    /// Sequence seed of the film offsets; give the integrator's SobolSampler the same one.
    uint32_t seed = 0;
    /// Tile edge in pixels.
    uint32_t tile_size = kTileSize;
    /// Progress bar on stderr (Auto: when stderr is a terminal).
    ProgressReporter::Mode progress = ProgressReporter::Mode::Auto;
    /// Largest pass in samples per pixel (0: no cap; for time-limited renders, spp 0, it
    /// means 64).
    uint32_t max_pass_spp = 0;
};

/// What a render did.
struct RenderStats {
    uint64_t samples = 0;      ///< samples taken in this call (dropped ones included)
    uint64_t rays = 0;         ///< sum of Sample::rays
    uint64_t nan_samples = 0;  ///< samples dropped by the film for non-finite radiance
    double wall_s = 0;         ///< wall time, seconds
    uint32_t passes = 0;       ///< passes run to completion
    uint32_t threads = 0;      ///< worker threads of the arena
    bool cancelled = false;    ///< stopped by the cancel flag
    bool out_of_time = false;  ///< stopped by the time budget
    /// One readable line, e.g. for the CLI's summary.
    std::string describe() const;
};

/// Renders uniform progressive passes of a SampleSource into a Film. One render() at a time
/// per instance (not re-entrant); the source must be thread-safe (SampleSource contract).
class TileScheduler {
  public:
    /// `film` must have the source's resolution; throws std::invalid_argument otherwise.
    TileScheduler(const SampleSource &source, sampling::Film &film, SchedulerOptions options = {});

    /// Renders until every pixel has budget.spp samples (counting samples the film already
    /// holds), the time budget runs out, or *cancel becomes true. Blocks the caller.
    RenderStats render(const RenderBudget &budget, const std::atomic<bool> *cancel = nullptr);

    /// Cumulative per-pixel sample targets of the passes for `spp` samples per pixel:
    /// 1, 2, 4, ..., spp, each step at most `max_pass_spp` (0: no cap) larger. Pure.
    static std::vector<uint32_t> pass_targets(uint32_t spp, uint32_t max_pass_spp = 0);

    /// The camera sample of sample `index` of pixel (px, py): offset from the sequence's
    /// reserved pixel dimensions. Pure.
    static CameraSample camera_sample(uint32_t seed, uint32_t px, uint32_t py, uint32_t index);

    /// A sampler positioned where an integrator continues for `cs`: dimension
    /// sampling::kFirstFreeDimension of (seed, cs.px, cs.py, cs.index). Pure.
    static sampling::SobolSampler sampler_for(uint32_t seed, const CameraSample &cs);

    /// The Morton-ordered tile list.
    const std::vector<Tile> &tiles() const { return tiles_; }
    /// Worker threads render() uses.
    uint32_t thread_count() const { return threads_; }
    /// One readable line: image size, tiles, threads, seed.
    std::string describe() const;

  private:
    // Brings every pixel of `tile` to `target` samples, adding to the counters.
    void render_tile(const Tile &tile, uint32_t target, uint64_t &samples, uint64_t &rays);

    const SampleSource &source_;
    sampling::Film &film_;
    SchedulerOptions options_;
    uint32_t threads_ = 1;
    std::vector<Tile> tiles_;
};

}  // namespace tessera::sched
