// Progressive adaptive tile scheduler after MoonRay (Jeffery 2019, "Global Adaptive Sampling
// Hierarchies in Production Ray Tracing", SIGGRAPH Talks), with the error metric and region
// hierarchy of Dammertz, Hanika, Keller, Lensch 2010 ("A Hierarchical Automatic Stopping
// Condition for Monte Carlo Global Illumination"); see docs/ARCHITECTURE.md, "Adaptive stopping".
//
// Passes. Pass 0 takes every pixel to min_spp samples (the uniform start). Each later pass
// raises the target of every ACTIVE pixel: target(p) = target(p-1) + min(target(p-1),
// max_pass_spp), capped at max_spp (16, 32, 64, 128, 192, ... for the defaults). A pixel's
// samples are taken in index order starting at Film::sample_count() (sample consistency, paper
// section 3.2): a pixel that sat out passes resumes its own sequence, and a second render()
// continues where the first stopped.
//
// Quadrants. The tile grid is split at tile column ceil(tiles_x / 2) and row ceil(tiles_y / 2)
// (pixel x = 8 * ceil(tiles_x / 2), clamped to the width), so that every 8x8 tile belongs to
// exactly one quadrant even when width / 2 is not a multiple of 8; a quadrant may be empty (an
// image one tile wide has no right half). Each quadrant has a sampling::RegionTree over its
// rectangle grown by one tile (clamped to the image), rebuilt from scratch after each of its
// passes. A pixel is active when it lies in an incomplete leaf; a tile with no active pixel is
// skipped. In pass 0, and whenever error stopping is off, every pixel is active.
//
// No global barrier (default, paper section 4.1). One atomic work index w hands out (pass, tile)
// pairs in Morton order: pass = w / T, tile = w % T. Each quadrant counts its tiles down
// atomically; the thread that brings the count to zero ("last one out turns off the lights")
// re-arms it with fetch_add(tiles of the quadrant), which accounts for tiles of the next pass
// already counted, and rebuilds the tree while the other threads keep rendering. A tile reads
// its quadrant's tree under the shared lock of its own stripe of the quadrant's StripedRwLocks
// (scheduler/striped_locks.h) only while it computes its active pixels. The tree is double
// buffered: the rebuild writes the idle copy, publishes it with an atomic index, then takes each
// stripe's writer lock in turn (a sweep), after which no reader still uses the old copy.
// Different quadrants rebuild concurrently. If a quadrant finishes another pass while its
// previous rebuild still runs, the last thread out does not wait: the running rebuilder
// rebuilds once more from the newest errors for all such requests (combining).
//
// Memory beyond the film: 4 bytes per pixel of atomic error snapshot, plus 12 bytes per tile of
// published tile error sums, plus per quadrant two trees' summed-area tables over its tiles.
// Rebuilds read one error sum per 8x8 tile (RegionTree::rebuild_cells), so a rebuild costs
// O(tiles) instead of O(pixels): about 8k cells for a 1080p quadrant.
//
// Data-race freedom (the TSan job builds this with -DTESSERA_TSAN=ON):
//  - film pixels are written only by the thread rendering their tile; the same tile of the next
//    pass waits (std::atomic wait/notify on the tile's completed-pass counter) until this one is
//    done, so a pixel never has two writers and its samples stay in index order;
//  - the rebuild never reads the film: each tile publishes its pixels' Dammertz errors into an
//    atomic per-pixel error snapshot after rendering them and their sum into an atomic per-tile
//    sum, and the rebuild reads the tile sums;
//  - a tree copy is read only under a stripe's reader lock, and rewritten only after the writer
//    swept every stripe since the copy stopped being the published one.
// Trees may be stale when a thread starts a tile of the next pass before the quadrant's rebuild
// has finished, so the image depends on timing. `deterministic = true` instead puts a barrier
// between passes (all tiles of pass p, then all four rebuilds on the calling thread): the film is
// then bit-identical for any thread count.
//
// Stopping. The render stops when every quadrant's tree is complete ("converged": the region
// error of every leaf is below error_target), when the passes reach max_spp, when the time budget
// runs out, or on cancel (checked between tiles; tiles in flight finish, so the film stays
// consistent and its counts exact). With error_target 0 or adaptive = false the render is
// uniform and stops at max_spp.
//
// Refinement (refine_target, for renders with a budget). A fixed target either stops the render
// before the budget is spent (time left unused) or is never reached (adaptive == uniform). With
// refine_target the target is a starting point instead: when every quadrant's tree is complete
// at target level L, the target becomes error_target * refine_factor^(L+1) and all quadrants are
// rebuilt against it, reopening the regions now above it; the render goes on until the time
// budget, max_spp or cancel stops it (or the target would fall below refine_min_target:
// "converged"). The level is one counter under a mutex; each rebuild snapshots it at its start
// and computes its target from it, and a rebuild that finds the level moved meanwhile leaves its
// quadrant marked open, so "all complete" always means complete at the current level. In the
// deterministic mode the level changes only between passes on the calling thread.
// Refining, an active pixel's samples in a visit stop at the pass rule applied to its own count
// (16, 32, 64, then +max_pass_spp) when that is below the pass's target, so that a reopened
// region resumes gradually; TileVisit::count_after may then be below `target`. The passes run
// to twice pass_count when max_spp caps them, so pixels reopened late can still reach it.
// Two guards tie the allocation to the image mean (updated at every quadrant rebuild):
// no pixel takes more than refine_spp_ratio x the mean spp (a region that cannot reach the
// target -- fireflies -- would otherwise swallow the budget; a quadrant pass that took no sample
// counts as complete), and pixels below mean / refine_floor_ratio (updated at every rebuild)
// are sampled even inside completed regions (a few dozen samples' Dammertz estimate can call a
// region done too early).
//
// Error metrics (AdaptiveOptions::metric). Dammertz: the trees compare Dammertz's area-weighted
// region error e_b with error_target (MoonRay's rule; sampling/region_tree.h), a perceptual
// stopping rule under which a small region may keep a larger per-pixel error. RelMse (the
// `adaptive` sampler's default in `tessera render`): error_target is the image relMSE to reach,
// the quantity `tessera converge` measures. Each pixel publishes m_p = rho_p / n and
// a_p = rho_p n (rho_p its estimated relMSE, sampling/adaptive_error.h), each tile the sums of
// m_p, a_p, sqrt(a_p) and rho_p. A rebuild turns the image target E into the per-pixel
// threshold t = (P E / sum_p sqrt(a_p))^2 on m_p, the relMSE one more sample removes, and the
// trees compare the plain mean of m_p over a region with t (RegionTreeParams::area_weighted =
// false). Stopping every region at the same m_p is the allocation n_p ~ sqrt(a_p) that reaches
// E with the fewest samples (Lagrange; the oracle of the benchmark in the README). Samples do
// not cost the same everywhere (a background pixel that sees the sky against a layered
// material several bounces deep: 2x the time per sample on pbrt-v4's material-testball), so
// the budget is time, not samples: with c_p the cost of one sample (its tile's mean seconds
// per sample in this render, measured, relative to the image's mean; 1 in the deterministic
// mode, where the image must depend on the film alone: timing must not change it, and a resumed
// render has no costs of the passes before), the least time for E is n_p ~ sqrt(a_p / c_p), every pixel stopping at
// the same m_p / c_p = (P E / sum_p sqrt(a_p c_p))^2; the tiles publish sums of m_p / c_p and
// sqrt(a_p c_p) for it. Inside an open region a pixel is sampled while the mean of m_p / c_p
// over its 3x3 neighbourhood (within its tile) is above the threshold. With
// spp_budget N instead of a target, E is the relMSE of N uniform samples, (1 / P) sum a_p / N,
// re-estimated at every rebuild. Refining, the level lowers E itself by refine_factor, and E is
// at most refine_track times the image's current estimated relMSE (so that the threshold
// follows the error between levels; t then sits at refine_track^2 of the common m_p / c_p of the
// optimal allocation for the current error: a pixel drops out once it holds about
// 1 / refine_track times its share of samples). The sums
// are read from the published tile atomics at every rebuild (O(tiles); in the deterministic
// mode they are fixed between passes, so the result stays bit-identical).
//
// Distributed rendering (AdaptiveOptions::group; see docs/ARCHITECTURE.md, "Distributed
// rendering"). With a RankGroup of N ranks this scheduler is one rank: it renders only the
// tiles tile_owner() deals it (every N-th tile along the Morton curve) into its own film, and
// every pass ends at a barrier on every rank: its threads finish the rank's tiles of the pass
// (barrier-free among themselves, as in the deterministic mode), then one all-gather hands every
// rank the per-tile error sums of every tile (and one sum the counters the guards, the cost
// weighting and the stop decisions need), and each rank rebuilds the same four trees from the
// same numbers. The trees, the open regions, the refinement level and the stopping decision
// are therefore the same on every rank, and with `deterministic` the films' pixels are, tile
// for tile, those of a single-process render (a sum with zeros is exact; the integer counts are
// exact in doubles): rank 0 gathers them into the whole image (gather_film). A rank whose time
// is up, or whose cancel flag is set, stops taking tiles; its flag ends the render on every
// rank at the same pass end. Without `deterministic` the per-tile costs still weight the
// allocation (measured on each rank; the image mean summed over the ranks).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sampling/adaptive_error.h"
#include "sampling/film.h"
#include "sampling/progressive_settings.h"
#include "sampling/region_tree.h"
#include "sampling/sample_source.h"
#include "sampling/sequence.h"
#include "scheduler/progress.h"
#include "scheduler/rank_group.h"
#include "scheduler/tiles.h"

namespace tessera::sched {

class StripedRwLocks;

/// What a tile visit did (for tests and diagnostics; see AdaptiveOptions::visit_hook).
struct TileVisit {
    const Tile *tile = nullptr;
    uint32_t pass = 0;      ///< absolute pass index (0: the uniform start)
    uint32_t target = 0;    ///< the pass's per-pixel sample target
    uint32_t quadrant = 0;  ///< 0..3: top-left, top-right, bottom-left, bottom-right
    bool skipped = false;   ///< no pixel of the tile was active
    /// Per tile pixel, row-major over the tile: 1 when active in this visit.
    std::span<const uint8_t> active;
    /// Per tile pixel: the film's sample count before and after the visit.
    std::span<const uint32_t> count_before, count_after;
};

/// Settings of the adaptive scheduler.
struct AdaptiveOptions {
    /// Samples per pixel of the uniform first pass (>= 1).
    uint32_t min_spp = sampling::kProgressiveDefaults.min_spp;
    uint32_t max_spp = 1024;  ///< per-pixel cap (0: unlimited; needs time_s or error_target)
    double time_s = 0;        ///< wall-clock budget in seconds (0: none)
    /// What error_target means (see the file comment, "Error metrics"): Dammertz's region
    /// error e_b, or (RelMse) the image relMSE to reach.
    sampling::ErrorMetric metric = sampling::ErrorMetric::Dammertz;
    /// Region error (Dammertz e_b) below which a region is complete, or with the RelMse metric
    /// the image relMSE to reach; 0: no error stopping (uniform sampling to max_spp, unless
    /// spp_budget is set). With refine_target: the starting target.
    double error_target = 0;
    /// RelMse metric, no error_target and no refinement: reach the relMSE that spp_budget
    /// uniform samples per pixel would give (estimated from the film at every rebuild,
    /// (1 / P) sum_p a_p / spp_budget), with the fewest samples (see "Error metrics"); pixels
    /// still stop at max_spp. 0: off.
    uint32_t spp_budget = 0;
    /// Refinement (see the file comment): when every region is complete before the budget is
    /// spent, lower the target by refine_factor and go on instead of stopping. Needs a budget
    /// that ends the render (time_s > 0 or max_spp > 0); ignored otherwise and without error
    /// stopping.
    bool refine_target = false;
    /// Target multiplier per refinement, in (0, 1). 0.5: each level needs about 4x the samples
    /// of the previous one in the regions it reopens (error ~ 1/sqrt(spp)), so the levels form
    /// a geometric series and the refinement events (a skipped pass and four rebuilds each)
    /// stay few: O(log(budget)).
    double refine_factor = sampling::kProgressiveDefaults.refine_factor;
    /// RelMse metric, refining: the target is also at most refine_track x the image's
    /// estimated relMSE at each rebuild, so that the pixels of largest marginal gain keep the
    /// samples while the level waits for the hardest region (see "Error metrics"). In [0, 1);
    /// 0: levels only (the default, sampling/progressive_settings.h says why).
    double refine_track = sampling::kProgressiveDefaults.refine_track;
    /// No refinement below this target: the render then stops as converged.
    double refine_min_target = 1e-7;
    /// Refining, no pixel takes more than this many times the image's mean samples per pixel
    /// (at least min_spp), as of the last quadrant rebuild; a quadrant whose pass took no sample
    /// (every open pixel capped) counts as complete. Keeps a region that cannot reach the
    /// target (fireflies; a narrow leaf in a tile of frozen errors) from taking the whole
    /// budget. 0: no cap.
    double refine_spp_ratio = sampling::kProgressiveDefaults.refine_spp_ratio;
    /// Refining, and always with the RelMse metric, pixels below the image's mean samples per
    /// pixel / this ratio (as of the last quadrant rebuild; never above the cap) are sampled
    /// even inside completed regions while the render goes on: the estimate of a few dozen
    /// samples can call a region complete before it showed a rare bright path (a small light's
    /// silhouette, a caustic). 0: no floor.
    double refine_floor_ratio = sampling::kProgressiveDefaults.refine_floor_ratio;
    bool adaptive = true;        ///< false: uniform passes (every pixel active)
    bool deterministic = false;  ///< barrier between passes: bit-identical for any thread count
    uint32_t threads = 0;        ///< worker threads (0: TBB's default concurrency)
    uint32_t seed = 0;           ///< sequence seed of the film offsets (scheduler/camera_sample.h)
    /// Pattern of the film offsets: the integrator's (the scene's RenderSettings::sample_pattern).
    sampling::SamplePattern pattern = sampling::SamplePattern::Padded;
    /// Largest pass in samples per pixel (0: passes keep doubling).
    uint32_t max_pass_spp = sampling::kProgressiveDefaults.max_pass_spp;
    /// Accepted samples a pixel needs before it has an error estimate (below: +inf, open).
    uint32_t min_samples_for_error = 4;
    /// RegionTreeParams::split_factor.
    double split_factor = sampling::kProgressiveDefaults.split_factor;
    /// RegionTreeParams::min_extent: narrowest region, pixels.
    double min_extent = sampling::kProgressiveDefaults.min_extent;
    uint32_t lock_stripes = 64;  ///< RW locks per quadrant (rounded to a power of 2, >= 8)
    ProgressReporter::Mode progress = ProgressReporter::Mode::Auto;
    /// Resume at this absolute pass index (checkpoints record it); -1: the first pass some pixel
    /// still needs. With `deterministic`, N passes + resume at N == the same passes straight.
    int64_t start_pass = -1;
    /// Stop after this absolute pass index is complete (passes 0 .. max_passes-1); 0: no limit.
    uint32_t max_passes = 0;
    /// Called by the rendering thread at the start of every tile visit, before the tree is read
    /// (tests: delays, bookkeeping). May be empty. Must be thread-safe.
    std::function<void(const Tile &, uint32_t pass)> tile_hook;
    /// Called by the rendering thread after every tile visit (rendered or skipped), while it
    /// still owns the tile's pixels. May be empty. Must be thread-safe.
    std::function<void(const TileVisit &)> visit_hook;
    /// Distributed render (see the file comment): this scheduler is rank group->rank() of
    /// group->size() and renders only its tiles; the passes end at a collective on every rank.
    /// Every rank must render with the same options (apart from threads and progress) and a
    /// film in the same state. Null: the whole image in this process.
    RankGroup *group = nullptr;
};

/// What a render() did.
struct AdaptiveStats {
    uint64_t samples = 0;         ///< samples taken in this call (dropped ones included)
    uint64_t rays = 0;            ///< sum of Sample::rays
    uint64_t shadow_rays_avoided = 0;  ///< sum of Sample::shadow_rays_avoided
    uint64_t nan_samples = 0;     ///< samples the film dropped for non-finite radiance
    double wall_s = 0;            ///< wall time of render(), seconds
    uint32_t passes = 0;          ///< completed passes (the maximum over the quadrants)
    uint32_t first_pass = 0;      ///< absolute index of the first pass this call rendered
    /// Absolute index of the first pass that some tile has not completed: where a later render()
    /// of the same film must resume (AdaptiveOptions::start_pass). first_pass + passes when the
    /// passes ran to completion; lower when the time budget or a cancel stopped a pass part-way
    /// in the barrier-free mode (`passes` counts the furthest quadrant, whose tiles come first
    /// in Morton order: resuming there would leave the other quadrants' pixels behind).
    uint32_t resume_pass = 0;
    uint32_t threads = 0;      ///< worker threads
    bool cancelled = false;    ///< stopped by the cancel flag
    bool out_of_time = false;  ///< stopped by the time budget
    /// Every quadrant's tree complete (error target reached); with refinement, complete at a
    /// target that refine_min_target does not let it lower further.
    bool converged = false;
    /// Passes run after the schedule because it ended with an open region holding pixels below
    /// the last pass's target (a region reopened by the last rebuild, or skipped on a stale
    /// tree; see AdaptiveScheduler::render). Included in `passes`.
    uint32_t catch_up_passes = 0;
    /// The region error target in force at the end (error_target when no refinement ran).
    double final_error_target = 0;
    /// Times the target was lowered (AdaptiveOptions::refine_target) in this call.
    uint32_t refinements = 0;
    uint64_t tiles_rendered = 0;  ///< tile visits that took samples or had active pixels
    /// Tile visits skipped: the tile lay in completed regions (it cost the region-tree check
    /// and nothing else).
    uint64_t tiles_skipped = 0;
    uint64_t pixels_skipped = 0;  ///< pixel visits skipped because their region was complete
    /// Seconds threads waited to acquire the trees' locks, summed over threads:
    /// lock_wait_reader_s + lock_wait_writer_s.
    double lock_wait_s = 0;
    double lock_wait_reader_s = 0;  ///< tiles waiting for a stripe's shared lock
    /// Rebuilding threads waiting for the quadrant's rebuild mutex and its stripes.
    double lock_wait_writer_s = 0;
    /// lock_wait_s / (wall_s * threads): the fraction of thread time spent waiting for locks.
    double lock_wait_fraction = 0;
    /// Seconds threads waited for the same tile's previous pass to finish (small images with
    /// more threads than tiles), summed over threads.
    double tile_wait_s = 0;
    uint32_t rebuilds = 0;  ///< tree rebuilds (about one per quadrant and pass)
    /// Rebuild requests served by a rebuild already running for the quadrant (it rebuilt once
    /// more for all of them) instead of a wait.
    uint32_t rebuilds_coalesced = 0;
    double tree_rebuild_ms_max = 0;   ///< slowest rebuild of one quadrant, milliseconds
    double tree_rebuild_ms_mean = 0;  ///< mean rebuild time of one quadrant, milliseconds
    /// Mean rebuild time per quadrant (0..3), milliseconds (0 for an empty quadrant).
    std::array<double, 4> quadrant_rebuild_ms_mean{};
    /// Image error at the end: sampling::image_error (the mean Dammertz pixel error), or with
    /// the RelMse metric the estimated image relMSE (the mean of sampling::pixel_rel_mse);
    /// +inf when some pixel has no estimate.
    double error_estimate = 0;
    /// RelMse metric: the per-pixel threshold on m_p the trees used last (see "Error
    /// metrics"); 0 otherwise.
    double tree_target = 0;
    /// Final samples per pixel: [0] pixels with 0 samples, [k >= 1] pixels with spp in
    /// [2^(k-1), 2^k).
    std::vector<uint64_t> spp_histogram;
    double render_s = 0;   ///< thread-seconds spent rendering tiles, summed over threads
    double rebuild_s = 0;  ///< thread-seconds spent rebuilding trees (incl. error copies)
    /// Distributed render: the ranks of the group (1 otherwise). samples, rays,
    /// shadow_rays_avoided, nan_samples, tiles_* and pixels_skipped are then summed over the
    /// ranks; rank_samples is this rank's own share, comm_s the wall seconds this rank spent
    /// in the collectives and wait_s the seconds it waited at pass ends for slower ranks
    /// (RankGroup::arrive).
    uint32_t ranks = 1;
    uint64_t rank_samples = 0;
    double comm_s = 0, wait_s = 0;
    /// One readable line, e.g. for the CLI's summary.
    std::string describe() const;
};

/// Inputs of one adaptive progress line.
struct AdaptiveProgressState {
    uint32_t passes = 0;      ///< completed passes (maximum over quadrants)
    double mean_spp = 0;      ///< film samples / pixels
    double error = -1;        ///< image error estimate (< 0 or +inf: unknown)
    double error_target = 0;  ///< 0: none
    double elapsed_s = 0;
    double rays_per_s = 0;
    double eta_s = -1;    ///< < 0: unknown
    double fraction = 0;  ///< in [0, 1] for the bar
};

/// "[####....] passes 5  spp 37.2  err 0.0123/0.01  12.3 Mrays/s  ETA 0:42": completed passes,
/// mean samples per pixel, image error / target ("n/a" while unknown), rays per second, ETA.
/// Pure.
std::string format_adaptive_progress_line(const AdaptiveProgressState &st, int bar_width = 20);

/// Renders a SampleSource into a Film with progressive adaptive passes (see the file comment).
/// One render() at a time per instance; the source must be thread-safe.
class AdaptiveScheduler {
  public:
    /// `film` must have the source's resolution. Throws std::invalid_argument for a size
    /// mismatch or when nothing would stop the render (max_spp 0 with neither time_s nor an
    /// error target).
    AdaptiveScheduler(const SampleSource &source, sampling::Film &film,
                      AdaptiveOptions options = {});
    ~AdaptiveScheduler();

    AdaptiveScheduler(const AdaptiveScheduler &) = delete;
    AdaptiveScheduler &operator=(const AdaptiveScheduler &) = delete;

    /// Renders until converged, max_spp, the time budget or *cancel (see the file comment).
    /// Blocks the caller. A later call resumes: each pixel continues its own sequence, and the
    /// trees are rebuilt from the film first.
    AdaptiveStats render(const std::atomic<bool> *cancel = nullptr);

    /// The region tree of quadrant q (0..3). Not thread-safe against a running render().
    const sampling::RegionTree &tree(int quadrant) const;
    /// Pixel rectangle of quadrant q (may be empty).
    sampling::PixelBounds quadrant_rect(int quadrant) const;
    /// The quadrant of the tile with Morton index t.
    uint32_t tile_quadrant(size_t t) const { return tile_quadrant_[t]; }
    /// The Morton-ordered tile list.
    const std::vector<Tile> &tiles() const { return tiles_; }
    /// Worker threads render() uses.
    uint32_t thread_count() const { return threads_; }
    /// True when error stopping is on (adaptive and error_target > 0).
    bool adaptive() const { return adaptive_; }
    /// True when the target is refined instead of stopping (see AdaptiveOptions::refine_target).
    bool refining() const { return refine_; }
    /// The target at refinement level `level`: error_target * refine_factor^level. Pure.
    double target_at(uint32_t level) const;
    const AdaptiveOptions &options() const { return options_; }

    /// Cumulative per-pixel target of pass p (see the file comment). Pure.
    static uint32_t pass_target(const AdaptiveOptions &options, uint64_t pass);
    /// Number of passes until every pixel reaches max_spp (0 when max_spp is 0: unbounded).
    static uint64_t pass_count(const AdaptiveOptions &options);
    /// The targets of all passes (max_spp must be > 0). Pure.
    static std::vector<uint32_t> pass_targets(const AdaptiveOptions &options);

    /// One readable line: image, tiles, quadrants, threads, mode.
    std::string describe() const;

  private:
    struct Quadrant;
    struct RenderContext;
    struct WorkerState;
    struct TileTally;
    struct PassCounters;

    /// Passes of the schedule: pass_count, doubled when refining to max_spp, cut at max_passes.
    uint64_t scheduled_passes() const;
    /// The pass render() starts at: start_pass, or the first pass some pixel of the film needs.
    uint64_t resume_pass_of_film(uint64_t n_passes) const;
    /// Resets the tiles' pass counters, the quadrants, the open mask and the guards.
    void reset_for_render(RenderContext &ctx, uint64_t p0);
    /// Allocates and touches the rebuild buffers before the timed rebuilds.
    void warm_rebuild_buffers();
    /// Passes ctx.first_pass .. ctx.pass_end (and the catch-up passes) on the workers.
    void run_passes(RenderContext &ctx, AdaptiveStats &stats);
    void run_barrier_free(RenderContext &ctx, WorkerState &main_ws, AdaptiveStats &stats);
    void run_deterministic(RenderContext &ctx, WorkerState &main_ws, AdaptiveStats &stats);
    /// One pass over every tile, all threads, ending at a barrier (the deterministic passes and
    /// the catch-up passes).
    void run_pass(uint64_t pass, RenderContext &ctx);
    bool catch_up_wanted(uint64_t pass, RenderContext &ctx, WorkerState &ws) const;
    /// rebuild_all, then converged (and stop) when every quadrant is complete.
    void rebuild_all_at_pass_end(RenderContext &ctx, WorkerState &ws, bool pass_end);
    /// The workers' sums, rebuild times and stop reasons into `stats`.
    void collect_stats(const RenderContext &ctx, AdaptiveStats &stats) const;
    void fill_spp_histogram(AdaptiveStats &stats) const;

    void process_tile(size_t t, uint32_t pass, RenderContext &ctx, WorkerState &ws);
    /// Waits until tile `done` has completed the passes before `pass`.
    static void wait_for_tile_pass(std::atomic<uint32_t> &done, uint32_t pass, WorkerState &ws);
    /// Marks the tile's active pixels in ws.active; false when the tile is skipped whole.
    bool select_active_pixels(const Tile &tile, Quadrant &quad, uint32_t pass,
                              RenderContext &ctx, WorkerState &ws);
    /// RelMse metric: within the tile's open regions, keeps the pixels whose 3x3 mean of
    /// m_p / c_p reaches kSelectMargin x `target`.
    void select_pixels_by_error(const Tile &tile, double target, WorkerState &ws) const;
    /// Takes the active pixels' samples of the pass; true when some pixel was active.
    bool sample_tile(const Tile &tile, uint32_t target, uint32_t pixel_cap, WorkerState &ws,
                     TileTally &tally);
    /// Stores the new errors of the pixels that took samples; true when there was one.
    bool snapshot_tile_errors(const Tile &tile, const WorkerState &ws);
    void report_visit(const Tile &tile, uint32_t pass, uint32_t target, uint32_t q,
                      bool any_active, const WorkerState &ws) const;
    void finish_tile_nonbarrier(size_t t, RenderContext &ctx, WorkerState &ws);
    /// Rebuilds quadrant q's tree against the current target level; returns true when this
    /// rebuild completed the image and lowered the target (the caller rebuilds again).
    /// `pass_idle`: the quadrant's pass just ended without taking a sample (refining).
    bool rebuild_quadrant(int q, RenderContext &ctx, WorkerState &ws, bool pass_idle = false);
    /// Does an open region of the live trees hold a pixel with fewer than `target` samples?
    /// (After the workers have joined; the barrier-free catch-up passes.)
    bool open_pixel_below(uint32_t target, WorkerState &ws) const;
    /// Rebuilds all four quadrants in order on the calling thread, again while that lowers the
    /// target (deterministic mode and resume).
    /// `pass_end`: after a pass (its samples decide which quadrants were idle).
    void rebuild_all(RenderContext &ctx, WorkerState &ws, bool pass_end);
    void init_error_snapshot();
    /// Distributed: the sums of every tile that changed on some rank since the last exchange
    /// (RankGroup::all_gather of each rank's changed tiles), written into the tile atomics of
    /// the tiles this rank does not own; the payload sizes first (one small sum).
    void exchange_tile_sums();
    /// The same with the payload already packed and its per-rank sizes known.
    void exchange_tile_sums(const std::vector<double> &mine, const std::vector<size_t> &counts);
    /// This rank's changed tiles as (index, sums...) records; clears their marks.
    void pack_changed_tiles(std::vector<double> &mine);
    std::vector<uint8_t> tile_changed_;  // distributed: tile sums published since the exchange
    /// Distributed, at the end of a pass: the tile sums, then the summed counters (film and
    /// quadrant samples, costs, progress) and the stop flags (any rank's stop ends the render).
    void exchange_pass(RenderContext &ctx, const PassCounters &before);
    /// The sum over the ranks of `v` (v itself in a single process).
    double group_sum(double v) const;
    /// Samples in the film over this rank's tiles, summed over the ranks (the whole film's).
    uint64_t owned_film_samples() const;
    RankGroup *group_ = nullptr;
    uint32_t ranks_ = 1, rank_ = 0;
    std::vector<uint32_t> owned_tiles_;  // Morton indices of the tiles this rank renders

    const SampleSource &source_;
    sampling::Film &film_;
    AdaptiveOptions options_;
    bool adaptive_ = false;
    bool refine_ = false;
    uint32_t threads_ = 1;
    std::vector<Tile> tiles_;
    std::vector<uint32_t> tile_quadrant_;
    std::vector<std::unique_ptr<Quadrant>> quadrants_;
    // Last published Dammertz error of every pixel (see the file comment).
    std::unique_ptr<std::atomic<float>[]> error_snapshot_;
    // Per tile (Morton index): the sum of its pixels' finite errors in the snapshot and the
    // count of its pixels without an estimate, published by the tile after each visit. The
    // rebuild reads these (one value per 8x8 tile), not the pixels.
    std::unique_ptr<std::atomic<double>[]> tile_error_sum_;
    std::unique_ptr<std::atomic<uint32_t>[]> tile_unknown_;
    std::vector<uint32_t> tile_at_;  // tile grid (tx, ty) -> Morton index, row-major
    uint32_t tiles_x_ = 0;
    void publish_tile_error(size_t t);
    /// Stores pixel (x, y)'s error in the snapshot (and a_p, RelMse); the caller owns the pixel.
    void snapshot_pixel_error(uint32_t x, uint32_t y);
    /// The tree target of a rebuild at refinement `level`: error_target / target_at(level), or
    /// with the RelMse metric the threshold on m_p that reaches that image relMSE, from the
    /// published tile sums (see "Error metrics").
    double tree_target(uint32_t level) const;
    /// Estimated image relMSE (RelMse metric) or mean Dammertz error from the tile sums; +inf
    /// while some pixel has no estimate.
    double published_image_error() const;
    // RelMse metric: per pixel a_p = rho_p n (the snapshot holds m_p = rho_p / n), per tile the
    // sums of a_p, sqrt(a_p) and rho_p over its pixels with an estimate.
    std::unique_ptr<std::atomic<float>[]> a_snapshot_;
    std::unique_ptr<std::atomic<double>[]> tile_a_sum_, tile_sqrt_a_sum_, tile_rho_sum_;
    // RelMse metric: per tile the cost of its samples in this render (seconds; nothing in the
    // deterministic mode) and their count; the image's totals for tiles not sampled yet.
    std::unique_ptr<std::atomic<double>[]> tile_cost_;
    std::unique_ptr<std::atomic<uint64_t>[]> tile_cost_samples_;
    std::atomic<double> cost_sum_{0};
    std::atomic<uint64_t> cost_samples_{0};
    std::atomic<double> mean_cost_{0};  // cost_sum_ / cost_samples_ as of the last rebuild
    /// Cost per sample of tile t relative to the image's mean (1 before it has one).
    double tile_cost(size_t t) const;
    /// Adds a visit's cost and samples to tile t (its owner calls it).
    void add_tile_cost(size_t t, double cost, uint64_t samples);
    bool relmse_ = false;
    bool floor_guard_ = false;  // refine_floor_ratio applies (refining, or the relMSE metric)
    // Per tile: passes completed (absolute pass index + 1), for the tile-order wait.
    std::unique_ptr<std::atomic<uint32_t>[]> tile_done_;
};

}  // namespace tessera::sched
