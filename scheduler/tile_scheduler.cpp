// Uniform progressive passes over Morton-ordered tiles on a TBB arena.
#include "scheduler/tile_scheduler.h"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace tessera::sched {

namespace {

// Largest pass of a time-limited render (spp 0), so that passes stay short.
constexpr uint32_t kDefaultTimeLimitedPassSpp = 64;

}  // namespace

std::string RenderStats::describe() const {
    std::ostringstream os;
    os << samples << " samples, " << rays << " rays in " << wall_s << " s ("
       << (wall_s > 0 ? double(rays) / wall_s * 1e-6 : 0.0) << " Mrays/s), " << passes
       << " passes, " << threads << " threads";
    if (nan_samples) os << ", " << nan_samples << " non-finite samples dropped";
    if (cancelled) os << ", cancelled";
    if (out_of_time) os << ", time budget reached";
    return os.str();
}

TileScheduler::TileScheduler(const SampleSource &source, sampling::Film &film,
                             SchedulerOptions options)
    : source_(source), film_(film), options_(options) {
    if (film.width() != source.width() || film.height() != source.height())
        throw std::invalid_argument("TileScheduler: film and sample source sizes differ");
    threads_ = options_.threads ? options_.threads
                                : uint32_t(std::max(1, tbb::info::default_concurrency()));
    tiles_ = make_morton_tiles(film.width(), film.height(), options_.tile_size);
}

std::vector<uint32_t> TileScheduler::pass_targets(uint32_t spp, uint32_t max_pass_spp) {
    std::vector<uint32_t> targets;
    uint64_t done = 0;
    while (done < spp) {
        uint64_t next = done == 0 ? 1 : 2 * done;
        if (max_pass_spp) next = std::min<uint64_t>(next, done + max_pass_spp);
        next = std::min<uint64_t>(next, spp);
        targets.push_back(uint32_t(next));
        done = next;
    }
    return targets;
}

CameraSample TileScheduler::camera_sample(uint32_t seed, uint32_t px, uint32_t py,
                                          uint32_t index) {
    sampling::SobolSampler s(seed);
    s.start_pixel_sample(px, py, index);
    Vec2f u = s.get_pixel_2d();
    CameraSample cs;
    cs.px = px;
    cs.py = py;
    cs.fx = u.x;
    cs.fy = u.y;
    cs.index = index;
    return cs;
}

sampling::SobolSampler TileScheduler::sampler_for(uint32_t seed, const CameraSample &cs) {
    sampling::SobolSampler s(seed);
    s.start_pixel_sample(cs.px, cs.py, cs.index);
    return s;
}

void TileScheduler::render_tile(const Tile &tile, uint32_t target, uint64_t &samples,
                                uint64_t &rays) {
    for (uint32_t py = tile.y0; py < tile.y1; ++py) {
        for (uint32_t px = tile.x0; px < tile.x1; ++px) {
            // The film's count is this pixel's next index: resumes continue the sequence.
            for (uint32_t index = film_.sample_count(px, py); index < target; ++index) {
                CameraSample cs = camera_sample(options_.seed, px, py, index);
                Sample s = source_.evaluate(cs);
                rays += s.rays;
                ++samples;
                film_.add_sample(px, py, index, s);
            }
        }
    }
}

RenderStats TileScheduler::render(const RenderBudget &budget, const std::atomic<bool> *cancel) {
    using Clock = std::chrono::steady_clock;
    if (budget.spp == 0 && !(budget.time_s > 0))
        throw std::invalid_argument("RenderBudget: spp 0 needs a time limit");
    const auto start = Clock::now();
    const bool timed = budget.time_s > 0;
    const auto deadline = start + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(timed ? budget.time_s : 0));

    uint32_t spp = budget.spp ? budget.spp : std::numeric_limits<uint32_t>::max();
    uint32_t max_pass = options_.max_pass_spp;
    if (budget.spp == 0 && max_pass == 0) max_pass = kDefaultTimeLimitedPassSpp;

    // Skip passes every pixel already finished (resume on a film that holds samples).
    uint32_t min_taken = std::numeric_limits<uint32_t>::max();
    for (uint32_t y = 0; y < film_.height(); ++y)
        for (uint32_t x = 0; x < film_.width(); ++x)
            min_taken = std::min(min_taken, film_.sample_count(x, y));
    if (film_.width() == 0 || film_.height() == 0) min_taken = spp;

    // For an unlimited (time-only) budget the target list is generated lazily.
    std::vector<uint32_t> targets;
    if (budget.spp) targets = pass_targets(spp, max_pass);

    RenderStats stats;
    stats.threads = threads_;
    const uint64_t nan_before = film_.nan_count();
    const uint64_t pixels = uint64_t(film_.width()) * film_.height();

    ProgressReporter progress(options_.progress);
    progress.begin(uint32_t(targets.size()), budget.spp,
                   budget.spp ? pixels * (budget.spp - std::min(min_taken, budget.spp)) : 0,
                   budget.time_s);

    // More threads than cores were asked for: lift TBB's worker limit for this render, or the
    // arena silently runs with fewer workers.
    std::unique_ptr<tbb::global_control> allow_more;
    if (int(threads_) > tbb::info::default_concurrency())
        allow_more = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, size_t(threads_));
    tbb::task_arena arena{int(threads_)};
    std::atomic<bool> stop_cancel{false}, stop_time{false};
    std::atomic<uint64_t> total_samples{0}, total_rays{0};

    uint32_t done_spp = 0;
    for (uint32_t pass = 0;; ++pass) {
        uint32_t target;
        if (budget.spp) {
            if (pass >= targets.size()) break;
            target = targets[pass];
        } else {
            uint64_t next = done_spp == 0 ? 1 : 2 * uint64_t(done_spp);
            next = std::min<uint64_t>(next, uint64_t(done_spp) + max_pass);
            if (next > std::numeric_limits<uint32_t>::max()) break;
            target = uint32_t(next);
        }
        uint32_t previous = done_spp;
        done_spp = target;
        if (target <= min_taken) continue;  // already there
        progress.begin_pass(pass + 1, previous, target);

        std::atomic<size_t> next_tile{0};
        const size_t n_tiles = tiles_.size();
        auto worker = [&](uint32_t) {
            uint64_t my_samples = 0, my_rays = 0;
            for (;;) {
                if (cancel && cancel->load(std::memory_order_relaxed)) {
                    stop_cancel.store(true, std::memory_order_relaxed);
                    break;
                }
                if (timed && Clock::now() >= deadline) {
                    stop_time.store(true, std::memory_order_relaxed);
                    break;
                }
                if (stop_cancel.load(std::memory_order_relaxed) ||
                    stop_time.load(std::memory_order_relaxed))
                    break;
                size_t t = next_tile.fetch_add(1, std::memory_order_relaxed);
                if (t >= n_tiles) break;
                uint64_t s = 0, r = 0;
                render_tile(tiles_[t], target, s, r);
                my_samples += s;
                my_rays += r;
                progress.add_work(s, r);
            }
            total_samples.fetch_add(my_samples, std::memory_order_relaxed);
            total_rays.fetch_add(my_rays, std::memory_order_relaxed);
        };
        // One task per worker, each draining the shared Morton-ordered work index, so tiles
        // start in Morton order whatever the partitioner does.
        arena.execute([&] {
            tbb::parallel_for(uint32_t(0), threads_, worker, tbb::simple_partitioner());
        });
        if (stop_cancel.load() || stop_time.load()) break;
        ++stats.passes;
    }
    progress.finish();

    stats.samples = total_samples.load();
    stats.rays = total_rays.load();
    stats.nan_samples = film_.nan_count() - nan_before;
    stats.cancelled = stop_cancel.load();
    stats.out_of_time = stop_time.load();
    stats.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
    return stats;
}

std::string TileScheduler::describe() const {
    std::ostringstream os;
    os << "TileScheduler(" << film_.width() << "x" << film_.height() << ", " << tiles_.size()
       << " tiles of " << options_.tile_size << "px in Morton order, " << threads_
       << " threads, seed " << options_.seed << ")";
    return os.str();
}

}  // namespace tessera::sched
