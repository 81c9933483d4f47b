#include "scheduler/frame_scheduler.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace tessera::sched {

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

// Persistent workers: a stage is published under the mutex as a new generation; every worker
// (and the calling thread) drains the shared tile index, and the last one to finish wakes the
// caller. Starting threads once per scheduler instead of once per stage matters for plugins with
// many short stages (kim: 8 stages per frame).
struct FrameScheduler::Pool {
    std::mutex m;
    std::condition_variable wake, done;
    uint64_t generation = 0;
    bool quit = false;
    uint32_t running = 0;  // workers still inside the current stage
    std::function<void()> job;
    std::vector<std::thread> threads;

    explicit Pool(uint32_t workers) {
        for (uint32_t i = 0; i < workers; ++i)
            threads.emplace_back([this] { loop(); });
    }
    ~Pool() {
        {
            std::lock_guard<std::mutex> l(m);
            quit = true;
        }
        wake.notify_all();
        for (std::thread &t : threads) t.join();
    }
    void loop() {
        uint64_t seen = 0;
        for (;;) {
            std::function<void()> *j = nullptr;
            {
                std::unique_lock<std::mutex> l(m);
                wake.wait(l, [&] { return quit || generation != seen; });
                if (quit) return;
                seen = generation;
                j = &job;
            }
            (*j)();
            std::lock_guard<std::mutex> l(m);
            if (--running == 0) done.notify_one();
        }
    }
    /// Runs `body` on every worker and the calling thread; returns when all are done.
    void run(std::function<void()> body) {
        {
            std::lock_guard<std::mutex> l(m);
            job = std::move(body);
            running = uint32_t(threads.size());
            ++generation;
        }
        wake.notify_all();
        job();
        std::unique_lock<std::mutex> l(m);
        done.wait(l, [&] { return running == 0; });
    }
};

FrameScheduler::FrameScheduler(FrameOptions options) : options_(options) {
    threads_ = options_.threads ? options_.threads
                                : std::max(1u, std::thread::hardware_concurrency());
}

FrameScheduler::~FrameScheduler() = default;

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
    const uint32_t n = uint32_t(tiles_.size());
    const uint32_t workers = std::max(1u, std::min(threads_, n));
    if (workers > 1 && (!pool_ || pool_->threads.size() != workers - 1))
        pool_ = std::make_unique<Pool>(workers - 1);

    FrameTiming timing;
    sampler.begin_frame(source);
    const int stages = sampler.stage_count();
    for (int stage = 0; stage < stages; ++stage) {
        const auto t_stage = Clock::now();
        std::atomic<uint32_t> next{0};
        std::atomic<bool> stopped{false};
        // One job per tile, or the stage's own count of jobs that are not tiles.
        const uint32_t asked = sampler.stage_jobs(stage);
        const bool by_tile = asked == sampling::PixelSampler::kTileJobs;
        const uint32_t jobs = by_tile ? n : asked;
        auto rect = [&](uint32_t i) {
            if (!by_tile)
                return sampling::PixelRect{0, 0, 0, 0, i, jobs};
            const Tile &t = tiles_[i];
            return sampling::PixelRect{t.x0, t.y0, t.x1, t.y1, i, n};
        };
        // Threads claim runs of `chunk` consecutive tiles (Morton order) with one atomic add:
        // at 1024x1024 a stage has 16384 tiles, and a tile of a cheap stage (a copy, a scan
        // that finds nothing) takes less time than taking the shared counter's cache line from
        // another core. Runs stay short enough (at least 64 per thread) to balance the load.
        // Each thread also knows its next tile before it runs the current one, so that the
        // sampler can prefetch the next tile's data while the current one computes.
        const uint32_t chunk = std::clamp<uint32_t>(jobs / (workers * 64), 1, 8);
        auto work = [&] {
            uint32_t i = next.fetch_add(chunk, std::memory_order_relaxed);
            uint32_t end = std::min(jobs, i + chunk);
            while (i < jobs) {
                if (cancel && cancel->load(std::memory_order_relaxed)) {
                    stopped.store(true, std::memory_order_relaxed);
                    return;
                }
                uint32_t j = i + 1, jend = end;
                if (j >= end) {
                    j = next.fetch_add(chunk, std::memory_order_relaxed);
                    jend = std::min(jobs, j + chunk);
                }
                if (j < jobs)
                    sampler.prefetch_tile(stage, rect(j));
                sampler.run_tile(stage, rect(i), source);
                i = j;
                end = jend;
            }
        };
        if (jobs == 0) {
            // nothing to run
        } else if (workers == 1 || jobs == 1) {
            work();
        } else {
            pool_->run(work);
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
