#include "scheduler/frame_scheduler.h"

#include <algorithm>
#include <chrono>
#include <thread>

namespace tessera::sched {

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

FrameScheduler::FrameScheduler(FrameOptions options) : options_(options) {
    threads_ = options_.threads ? options_.threads
                                : std::max(1u, std::thread::hardware_concurrency());
}

FrameTiming FrameScheduler::render(sampling::PixelSampler &sampler, const SampleSource &source,
                                   sampling::FrameResult &result,
                                   const std::atomic<bool> *cancel) {
    const auto t_frame = Clock::now();
    const uint32_t w = source.width(), h = source.height();
    if (w != tiles_w_ || h != tiles_h_ || tiles_.empty()) {
        tiles_ = make_morton_tiles(w, h, options_.tile_size);
        tiles_w_ = w;
        tiles_h_ = h;
    }
    FrameTiming timing;
    sampler.begin_frame(source);
    const int stages = sampler.stage_count();
    const uint32_t n = uint32_t(tiles_.size());
    const uint32_t workers = std::max(1u, std::min(threads_, n));
    for (int stage = 0; stage < stages; ++stage) {
        const auto t_stage = Clock::now();
        std::atomic<uint32_t> next{0};
        std::atomic<bool> stopped{false};
        auto work = [&] {
            for (;;) {
                if (cancel && cancel->load(std::memory_order_relaxed)) {
                    stopped.store(true, std::memory_order_relaxed);
                    return;
                }
                uint32_t i = next.fetch_add(1, std::memory_order_relaxed);
                if (i >= n) return;
                const Tile &t = tiles_[i];
                sampler.run_tile(stage, sampling::PixelRect{t.x0, t.y0, t.x1, t.y1}, source);
            }
        };
        if (workers == 1) {
            work();
        } else {
            std::vector<std::thread> pool;
            pool.reserve(workers - 1);
            for (uint32_t k = 1; k < workers; ++k) pool.emplace_back(work);
            work();
            for (std::thread &t : pool) t.join();
        }
        sampler.end_stage(stage, source);
        timing.stage_names.push_back(sampler.stage_name(stage));
        timing.stage_ms.push_back(ms_since(t_stage));
        if (stopped.load()) timing.cancelled = true;
    }
    sampler.end_frame(result);
    timing.total_ms = ms_since(t_frame);
    return timing;
}

}  // namespace tessera::sched
