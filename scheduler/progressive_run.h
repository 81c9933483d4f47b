// One progressive render session of a film: the adaptive tile scheduler
// (scheduler/adaptive_scheduler.h) run chunk by chunk, each chunk a fresh AdaptiveScheduler
// that resumes where the previous one stopped. `tessera render` (its --checkpoint-every chunks),
// `tessera converge` (one chunk per snapshot) and the reference renders all advance one of these.
//
// Between chunks the session carries what a chunk cannot know by itself:
//  - the pass to resume from: AdaptiveStats::resume_pass of the last chunk, the first pass some
//    tile has not finished (resuming after the furthest quadrant's pass would leave the others
//    behind); checkpoints record it;
//  - the refined error target (AdaptiveOptions::refine_target): the next chunk starts from the
//    target the last one reached, not from the first one;
//  - the summed statistics of all chunks (accumulate).
// With `deterministic` options, N chunks that each end on a pass boundary give the same film,
// bit for bit, as one uninterrupted render (each pixel continues its own sample sequence).
//
// The session knows nothing of scenes or files: it takes any SampleSource and a Film, which
// makes it the place where another way of running the chunks (several machines, each with its
// own source) can plug in without touching its callers.
#pragma once

#include <atomic>
#include <cstdint>

#include "sampling/film.h"
#include "sampling/sample_source.h"
#include "scheduler/adaptive_scheduler.h"

namespace tessera::sched {

/// Adds the counters of one AdaptiveScheduler::render() call to the running totals of a
/// session: counts and thread-seconds are summed, the rebuild mean is weighted by rebuilds, the
/// maxima kept; the end state (threads, flags, final target, error, histogram) is the last
/// call's. `passes`, `first_pass` and `resume_pass` are left alone (ProgressiveRun sets them).
void accumulate(AdaptiveStats &total, const AdaptiveStats &s);

/// A progressive render of `film` from `source`, advanced chunk by chunk (see the file comment).
/// The source and the film must outlive the session; one advance() at a time.
class ProgressiveRun {
  public:
    /// `options` as for AdaptiveScheduler, except `time_s`, which advance() gives per chunk.
    /// `options.start_pass` is where the first chunk starts (-1: the first pass some pixel
    /// still needs; a resumed checkpoint's pass otherwise).
    ProgressiveRun(const SampleSource &source, sampling::Film &film, AdaptiveOptions options);

    /// Renders one chunk of at most `time_s` seconds (0: no time limit; it then ends on
    /// convergence, max_spp, max_passes or *cancel) and returns that chunk's statistics. Throws
    /// what AdaptiveScheduler throws.
    AdaptiveStats advance(double time_s, const std::atomic<bool> *cancel = nullptr);

    /// The options the next chunk renders with: start_pass and error_target as carried over.
    const AdaptiveOptions &options() const { return options_; }
    /// Where the next chunk (and a checkpoint) resumes: the last chunk's resume_pass, or the
    /// constructor's start_pass before any chunk.
    int64_t start_pass() const { return options_.start_pass; }
    /// All chunks so far, summed (accumulate); `passes` is the absolute count of passes
    /// completed (first_pass + passes of the last chunk), 0 before any chunk.
    const AdaptiveStats &total() const { return total_; }
    /// Chunks rendered so far.
    uint32_t chunks() const { return chunks_; }

  private:
    const SampleSource &source_;
    sampling::Film &film_;
    AdaptiveOptions options_;
    AdaptiveStats total_;
    uint32_t chunks_ = 0;
};

}  // namespace tessera::sched
