// Runs a frame plugin (sampling/pixel_sampler.h): each stage is a parallel job over 8x8 tiles in
// Morton order, with a barrier after it and the plugin's serial end_stage (docs/ARCHITECTURE.md, "The
// PixelSampler plugin": barrier stages). Workers draw runs of up to 8 consecutive tiles from
// one atomic index, so tiles start in Morton order on all threads; the frame's pixels do not
// depend on the thread count as long as the plugin writes only its own tile's pixels in
// run_tile. Before running a tile, a worker passes its next tile to the plugin's
// prefetch_tile. A stage may instead ask for its own number of jobs that are not tiles
// (PixelSampler::stage_jobs: rows of a copy, lines of a scan, or none), handed out the same way. The worker threads are
// started once per FrameScheduler and reused for every stage and frame.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sampling/pixel_sampler.h"
#include "scheduler/tiles.h"

namespace tessera::sched {

struct FrameOptions {
    uint32_t threads = 0;              ///< worker threads (0: hardware concurrency)
    uint32_t tile_size = kTileSize;    ///< tile edge in pixels
};

/// Wall time of one frame and of each of its stages.
struct FrameTiming {
    double total_ms = 0;
    std::vector<std::string> stage_names;
    std::vector<double> stage_ms;  ///< parallel part + end_stage, per stage
    bool cancelled = false;        ///< a stage stopped early (the frame is incomplete)
};

class FrameScheduler {
  public:
    explicit FrameScheduler(FrameOptions options = {});
    ~FrameScheduler();
    FrameScheduler(const FrameScheduler &) = delete;
    FrameScheduler &operator=(const FrameScheduler &) = delete;
    uint32_t threads() const { return threads_; }

    /// Renders one frame of `source` with `sampler` into `result`. `cancel` (may be null) is
    /// checked between tiles; a cancelled frame still ends its stages and frame (with the
    /// tiles not run left as the plugin initialised them) and reports `cancelled`.
    FrameTiming render(sampling::PixelSampler &sampler, const SampleSource &source,
                       sampling::FrameResult &result,
                       const std::atomic<bool> *cancel = nullptr);

  private:
    FrameOptions options_;
    uint32_t threads_ = 1;
    uint32_t tiles_w_ = 0, tiles_h_ = 0;
    std::vector<Tile> tiles_;
    struct Pool;                  // persistent worker threads (threads_ - 1 of them)
    std::unique_ptr<Pool> pool_;
};

}  // namespace tessera::sched
