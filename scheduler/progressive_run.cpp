#include "scheduler/progressive_run.h"

#include <algorithm>
#include <utility>

namespace tessera::sched {

void accumulate(AdaptiveStats &total, const AdaptiveStats &s) {
    total.samples += s.samples;
    total.rays += s.rays;
    total.shadow_rays_avoided += s.shadow_rays_avoided;
    total.nan_samples += s.nan_samples;
    total.wall_s += s.wall_s;
    total.threads = s.threads;
    total.cancelled = s.cancelled;
    total.out_of_time = s.out_of_time;
    total.converged = s.converged;
    total.refinements += s.refinements;
    total.catch_up_passes += s.catch_up_passes;
    total.final_error_target = s.final_error_target;
    total.tiles_rendered += s.tiles_rendered;
    total.tiles_skipped += s.tiles_skipped;
    total.pixels_skipped += s.pixels_skipped;
    total.lock_wait_s += s.lock_wait_s;
    total.lock_wait_reader_s += s.lock_wait_reader_s;
    total.lock_wait_writer_s += s.lock_wait_writer_s;
    total.tile_wait_s += s.tile_wait_s;
    double ms_sum =
        total.tree_rebuild_ms_mean * total.rebuilds + s.tree_rebuild_ms_mean * s.rebuilds;
    total.rebuilds += s.rebuilds;
    total.rebuilds_coalesced += s.rebuilds_coalesced;
    total.tree_rebuild_ms_mean = total.rebuilds ? ms_sum / total.rebuilds : 0.0;
    total.tree_rebuild_ms_max = std::max(total.tree_rebuild_ms_max, s.tree_rebuild_ms_max);
    total.error_estimate = s.error_estimate;
    total.tree_target = s.tree_target;
    total.spp_histogram = s.spp_histogram;
    total.render_s += s.render_s;
    total.ranks = s.ranks;
    total.rank_samples += s.rank_samples;
    total.comm_s += s.comm_s;
    total.wait_s += s.wait_s;
    total.rebuild_s += s.rebuild_s;
    total.lock_wait_fraction = total.wall_s > 0 && total.threads
                                   ? total.lock_wait_s / (total.wall_s * double(total.threads))
                                   : 0.0;
}

ProgressiveRun::ProgressiveRun(const SampleSource &source, sampling::Film &film,
                               AdaptiveOptions options)
    : source_(source), film_(film), options_(std::move(options)) {}

AdaptiveStats ProgressiveRun::advance(double time_s, const std::atomic<bool> *cancel) {
    AdaptiveOptions chunk = options_;
    chunk.time_s = time_s;
    AdaptiveScheduler scheduler(source_, film_, chunk);
    AdaptiveStats s = scheduler.render(cancel);
    ++chunks_;
    accumulate(total_, s);
    total_.passes = s.first_pass + s.passes;
    // The next chunk resumes at the first pass some tile has not finished, not after the
    // furthest quadrant's: the others would never catch up.
    options_.start_pass = int64_t(s.resume_pass);
    // A refined target carries over to the next chunk.
    if (options_.refine_target)
        options_.error_target = s.final_error_target;
    return s;
}

}  // namespace tessera::sched
