// Progressive adaptive tile scheduler (MoonRay, Jeffery 2019): quadrant region trees rebuilt by
// the last thread out of each quadrant pass, striped reader-writer locks, no global barrier.
#include "scheduler/adaptive_scheduler.h"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#if defined(__SANITIZE_THREAD__)
#include <sanitizer/tsan_interface.h>
#endif

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <span>
#include <sstream>
#include <stdexcept>

#include "sampling/adaptive_error.h"
#include "scheduler/camera_sample.h"
#include "scheduler/striped_locks.h"

namespace tessera::sched {

namespace {

using Clock = std::chrono::steady_clock;
constexpr float kInfF = std::numeric_limits<float>::infinity();
constexpr uint32_t kTilePixels = kTileSize * kTileSize;

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Takes `m`, returning the seconds waited (0 when it was free at once; see striped_locks.h).
double lock_timed(std::mutex &m) {
    if (m.try_lock())
        return 0.0;
    auto t0 = Clock::now();
    m.lock();
    return seconds_since(t0);
}

// Progress line of an adaptive render: drawn by whichever worker reports work when the redraw
// interval has passed (try-lock, as ProgressReporter), on stderr.
class AdaptiveProgress {
  public:
    AdaptiveProgress(ProgressReporter::Mode mode, uint64_t pixels, uint64_t initial_samples,
                     const AdaptiveOptions &o)
        : pixels_(pixels), initial_samples_(initial_samples), options_(o), start_(Clock::now()) {
        enabled_ = mode == ProgressReporter::Mode::Always ||
                   (mode == ProgressReporter::Mode::Auto && isatty(STDERR_FILENO) == 1);
    }

    void add(uint64_t samples, uint64_t rays) {
        samples_.fetch_add(samples, std::memory_order_relaxed);
        rays_.fetch_add(rays, std::memory_order_relaxed);
        if (!enabled_)
            return;
        int64_t now_ns =
            std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start_).count();
        if (now_ns < next_draw_ns_.load(std::memory_order_relaxed))
            return;
        std::unique_lock<std::mutex> lock(draw_mutex_, std::try_to_lock);
        if (!lock.owns_lock())
            return;
        next_draw_ns_.store(now_ns + 200'000'000, std::memory_order_relaxed);
        draw(false);
    }
    void set_passes(uint32_t passes) {
        uint32_t cur = passes_.load(std::memory_order_relaxed);
        while (cur < passes && !passes_.compare_exchange_weak(cur, passes)) {
        }
    }
    void set_error(double e) { error_.store(e, std::memory_order_relaxed); }
    void set_target(double t) { target_.store(t, std::memory_order_relaxed); }
    void finish() {
        if (!enabled_)
            return;
        std::lock_guard<std::mutex> lock(draw_mutex_);
        draw(true);
    }

  private:
    AdaptiveProgressState state() const {
        AdaptiveProgressState st;
        st.passes = passes_.load(std::memory_order_relaxed);
        uint64_t done = samples_.load(std::memory_order_relaxed);
        st.mean_spp = pixels_ ? double(initial_samples_ + done) / double(pixels_) : 0.0;
        st.error = error_.load(std::memory_order_relaxed);
        st.error_target = target_.load(std::memory_order_relaxed);
        st.elapsed_s = seconds_since(start_);
        if (st.elapsed_s > 0)
            st.rays_per_s = double(rays_.load(std::memory_order_relaxed)) / st.elapsed_s;
        // ETA: the smallest of the estimates each budget gives.
        double eta = -1, frac = 0;
        auto take = [&](double e, double f) {
            if (e >= 0 && (eta < 0 || e < eta))
                eta = e;
            frac = std::max(frac, std::clamp(f, 0.0, 1.0));
        };
        if (options_.time_s > 0)
            take(std::max(0.0, options_.time_s - st.elapsed_s), st.elapsed_s / options_.time_s);
        if (options_.max_spp > 0 && pixels_) {
            double total = double(pixels_) * options_.max_spp - double(initial_samples_);
            double f = total > 0 ? double(done) / total : 1.0;
            // Below 1% the extrapolation is mostly start-up noise.
            if (f > 0.01)
                take(st.elapsed_s * (1 - f) / f, f);
            else
                frac = std::max(frac, std::max(f, 0.0));
        }
        if (st.error_target > 0 && std::isfinite(st.error) && st.error > 0) {
            // Dammertz's error falls as 1/sqrt(spp), relMSE as 1/spp: (e / target)^2 or
            // e / target times the samples so far are needed (pessimistic: completed regions
            // stop costing).
            double ratio = st.error / st.error_target;
            double need = options_.metric == sampling::ErrorMetric::RelMse ? ratio : ratio * ratio;
            take(need > 1 ? st.elapsed_s * (need - 1) : 0.0, 1.0 / std::max(need, 1.0));
        }
        st.eta_s = eta;
        st.fraction = frac;
        return st;
    }
    void draw(bool final_line) {
        std::string line = format_adaptive_progress_line(state());
        size_t len = line.size();
        if (len < last_line_length_)
            line.append(last_line_length_ - len, ' ');
        last_line_length_ = len;
        std::fprintf(stderr, "\r%s%s", line.c_str(), final_line ? "\n" : "");
        std::fflush(stderr);
    }

    bool enabled_ = false;
    uint64_t pixels_ = 0, initial_samples_ = 0;
    AdaptiveOptions options_;
    Clock::time_point start_;
    std::atomic<uint64_t> samples_{0}, rays_{0};
    std::atomic<uint32_t> passes_{0};
    std::atomic<double> error_{-1.0};
    std::atomic<double> target_{options_.error_target};
    std::atomic<int64_t> next_draw_ns_{0};
    std::mutex draw_mutex_;
    size_t last_line_length_ = 0;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// Per-quadrant, per-render and per-worker state.
// ---------------------------------------------------------------------------------------------

struct AdaptiveScheduler::Quadrant {
    explicit Quadrant(uint32_t stripes) : locks(stripes) {}
    sampling::PixelBounds rect, grown;
    std::vector<uint32_t> tiles;  // Morton indices of its tiles
    // Double-buffered tree: readers use trees[active] under their stripe's shared lock; the
    // rebuild writes trees[1 - active], which no reader can be using (see rebuild_quadrant).
    sampling::RegionTree trees[2];
    std::atomic<uint32_t> active{0};
    const sampling::RegionTree &live() const {
        return trees[active.load(std::memory_order_acquire)];
    }
    StripedRwLocks locks;
    alignas(64) std::atomic<int64_t> left{0};  // tiles left in the current pass
    // Serialises this quadrant's rebuilds (the paper's update lock); the stripes are taken only
    // for the swap. Everything below up to the atomics is guarded by it (or belongs to the
    // calling thread in deterministic mode).
    std::mutex rebuild_mutex;
    // The per-tile error sums over `grown` (a union of whole tiles: the quadrant split and the
    // one-tile margin fall on tile boundaries), the input of RegionTree::rebuild_cells.
    sampling::CellErrorImage cells;
    uint32_t rebuilds = 0;
    double rebuild_ms_sum = 0, rebuild_ms_max = 0;
    // Read by other quadrants' progress updates.
    std::atomic<double> error_sum{0};           // finite pixel errors over `rect`, last rebuild
    std::atomic<uint64_t> unknown_pixels{0};    // pixels of `rect` without an estimate
    std::atomic<uint32_t> passes_done{0};       // passes of this quadrant completed (this render)
    std::atomic<uint32_t> rebuild_requests{0};  // see finish_tile_nonbarrier
    // Refining: samples its tiles took since the last pass end (a pass with none is "idle").
    std::atomic<uint64_t> pass_samples{0};
    std::atomic<double> last_tree_target{0};  // RegionTreeParams::target of the last rebuild
};

struct AdaptiveScheduler::RenderContext {
    const std::atomic<bool> *cancel = nullptr;
    Clock::time_point start, deadline;
    bool timed = false;
    uint64_t first_pass = 0, pass_end = 0;
    uint64_t film_total = 0;  // samples in the whole film (all ranks) when the passes start
    tbb::task_arena *arena = nullptr;  // the workers' arena while the passes run
    // Catch-up passes (see run_passes): wanted at all, and the schedule's last target.
    bool catch_up = false;
    uint32_t last_target = 0;
    std::atomic<uint64_t> next_work{0};
    std::atomic<bool> stop{false}, stop_cancel{false}, stop_time{false}, converged{false};
    std::atomic<uint32_t> open_mask{0};  // bit q: quadrant q's tree incomplete
    // Refinement level (AdaptiveOptions::refine_target): the target is target_at(level). The
    // level, and open_mask whenever refinement is on, change only under level_mutex, so a
    // rebuild's "every quadrant complete" and the lowering it triggers are one step.
    std::mutex level_mutex;
    uint32_t level = 0;
    uint32_t refinements = 0;    // levels added in this call (guarded by level_mutex)
    uint32_t nonempty_mask = 0;  // bit q: quadrant q has pixels
    // Refining: per-pixel sample cap of the current level (AdaptiveOptions::refine_spp_ratio;
    // 0: none), and samples in the film (for the image mean the cap follows).
    std::atomic<uint32_t> pixel_cap{0};
    // Refining: pixels below this count are sampled even in completed regions
    // (AdaptiveOptions::refine_floor_ratio; 0: none).
    std::atomic<uint32_t> pixel_floor{0};
    std::atomic<uint64_t> film_samples{0};
    uint64_t pixels = 1;
    // The guards for the film's current mean spp, never lower than before (a CAS max, so any
    // thread may call it): the cap ratio x max(min_spp, mean), at most max_spp, then the floor
    // mean / floor_ratio, at most the cap. Called at the start and at every quadrant rebuild
    // (which is also where refinements happen), so that both follow the mean: a cap frozen at
    // the last refinement let the easy regions overtake the capped hard ones during a long
    // level, and a frozen floor let early-stopped pixels fall far behind.
    void raise_guards(const AdaptiveOptions &o) {
        const double mean = double(film_samples.load(std::memory_order_relaxed)) / double(pixels);
        auto raise = [](std::atomic<uint32_t> &a, uint32_t v) {
            uint32_t cur = a.load(std::memory_order_relaxed);
            while (v > cur && !a.compare_exchange_weak(cur, v, std::memory_order_relaxed)) {
            }
        };
        if (o.refine_spp_ratio > 0) {
            double cap = o.refine_spp_ratio * std::max(double(std::max(o.min_spp, 1u)), mean);
            raise(pixel_cap, uint32_t(std::min(cap, o.max_spp ? double(o.max_spp) : 4e9)));
        }
        if (o.refine_floor_ratio > 0) {
            double floor = mean / o.refine_floor_ratio;
            if (o.refine_spp_ratio > 0)
                floor = std::min(floor, double(pixel_cap.load(std::memory_order_relaxed)));
            raise(pixel_floor, uint32_t(floor));
        }
    }
    std::unique_ptr<AdaptiveProgress> progress;
    std::mutex merge_mutex;
    AdaptiveStats totals;  // per-worker sums merged under merge_mutex

    // Checks cancel and time; true when the workers must stop taking tiles.
    bool should_stop() {
        if (stop.load(std::memory_order_relaxed))
            return true;
        if (cancel && cancel->load(std::memory_order_relaxed)) {
            stop_cancel.store(true, std::memory_order_relaxed);
            stop.store(true, std::memory_order_relaxed);
            return true;
        }
        if (timed && Clock::now() >= deadline) {
            stop_time.store(true, std::memory_order_relaxed);
            stop.store(true, std::memory_order_relaxed);
            return true;
        }
        return false;
    }
};

/// Most samples per SampleSource::evaluate_batch call (of one pixel or of consecutive pixels of
/// a tile). The path tracer's packet kernel keeps 8 paths in flight and refills a lane from the
/// batch when its path ends, so a batch of many samples keeps its lanes full (64 against 8:
/// Cornell box +4% samples/s).
constexpr uint32_t kSampleBatch = 64;

/// Most catch-up passes after the schedule (see AdaptiveScheduler::run_passes).
constexpr uint64_t kCatchUpPasses = 4;

struct AdaptiveScheduler::WorkerState {
    uint64_t samples = 0, rays = 0, tiles_rendered = 0, tiles_skipped = 0, pixels_skipped = 0;
    uint64_t shadow_rays_avoided = 0;
    double reader_wait_s = 0, writer_wait_s = 0, tile_wait_s = 0, render_s = 0, rebuild_s = 0;
    uint64_t coalesced_rebuilds = 0;
    std::vector<sampling::PixelBounds> rects;
    std::array<uint8_t, kTilePixels> active{};
    std::array<uint32_t, kTilePixels> before{}, after{};
    // Camera samples on their way through SampleSource::evaluate_batch.
    std::array<CameraSample, kSampleBatch> batch_cs{};
    std::array<Sample, kSampleBatch> batch_out{};

    void merge_into(RenderContext &ctx) const {
        std::lock_guard<std::mutex> lock(ctx.merge_mutex);
        AdaptiveStats &t = ctx.totals;
        t.samples += samples;
        t.rays += rays;
        t.shadow_rays_avoided += shadow_rays_avoided;
        t.tiles_rendered += tiles_rendered;
        t.tiles_skipped += tiles_skipped;
        t.pixels_skipped += pixels_skipped;
        t.lock_wait_reader_s += reader_wait_s;
        t.lock_wait_writer_s += writer_wait_s;
        t.tile_wait_s += tile_wait_s;
        t.rebuilds_coalesced += uint32_t(coalesced_rebuilds);
        t.render_s += render_s;
        t.rebuild_s += rebuild_s;
    }
};

// ---------------------------------------------------------------------------------------------
// Stats and progress formatting.
// ---------------------------------------------------------------------------------------------

std::string AdaptiveStats::describe() const {
    std::ostringstream os;
    os << samples << " samples, " << rays << " rays in " << wall_s << " s ("
       << (wall_s > 0 ? double(rays) / wall_s * 1e-6 : 0.0) << " Mrays/s), " << passes
       << " passes, " << threads << " threads, error " << error_estimate;
    if (converged)
        os << " (converged)";
    os << ", " << tiles_skipped << " tiles / " << pixels_skipped << " pixel visits skipped, "
       << rebuilds << " rebuilds (" << rebuilds_coalesced << " coalesced requests, mean "
       << tree_rebuild_ms_mean << " ms, max " << tree_rebuild_ms_max << " ms), lock wait "
       << lock_wait_fraction * 100 << "% (readers " << lock_wait_reader_s * 1e3 << " ms, writers "
       << lock_wait_writer_s * 1e3 << " ms)";
    if (nan_samples)
        os << ", " << nan_samples << " non-finite samples dropped";
    if (cancelled)
        os << ", cancelled";
    if (out_of_time)
        os << ", time budget reached";
    return os.str();
}

std::string format_adaptive_progress_line(const AdaptiveProgressState &st, int bar_width) {
    double f = std::clamp(st.fraction, 0.0, 1.0);
    int filled = int(f * bar_width);
    std::string line = "[";
    line.append(size_t(std::max(0, filled)), '#');
    line.append(size_t(std::max(0, bar_width - filled)), '.');
    line += "] ";
    char buf[200];
    std::snprintf(buf, sizeof buf, "passes %u  spp %.1f", st.passes, st.mean_spp);
    line += buf;
    if (st.error >= 0 && std::isfinite(st.error))
        std::snprintf(buf, sizeof buf, "  err %.4g", st.error);
    else
        std::snprintf(buf, sizeof buf, "  err n/a");
    line += buf;
    if (st.error_target > 0) {
        std::snprintf(buf, sizeof buf, "/%.4g", st.error_target);
        line += buf;
    }
    std::snprintf(buf, sizeof buf, "  %.1f Mrays/s  ETA %s", st.rays_per_s * 1e-6,
                  format_duration(st.eta_s).c_str());
    line += buf;
    return line;
}

// ---------------------------------------------------------------------------------------------
// Pass targets.
// ---------------------------------------------------------------------------------------------

namespace {

uint64_t spp_cap(const AdaptiveOptions &o) {
    return o.max_spp ? o.max_spp : std::numeric_limits<uint32_t>::max();
}

uint64_t first_target(const AdaptiveOptions &o) {
    return std::clamp<uint64_t>(std::max(o.min_spp, 1u), 1, spp_cap(o));
}

// The next target of a pixel with `count` samples by the pass rule (see pass_target): the
// first pass's target from 0, then doubling up to max_pass_spp, then steps of max_pass_spp.
uint32_t grown_target(const AdaptiveOptions &o, uint32_t count) {
    if (count == 0)
        return uint32_t(first_target(o));
    const uint64_t c = count, step = o.max_pass_spp ? std::min<uint64_t>(c, o.max_pass_spp) : c;
    return uint32_t(std::min(spp_cap(o), c + step));
}

}  // namespace

uint32_t AdaptiveScheduler::pass_target(const AdaptiveOptions &o, uint64_t pass) {
    const uint64_t cap = spp_cap(o), step_cap = o.max_pass_spp;
    uint64_t t = first_target(o), p = 0;
    // Doubling while the whole target is below the pass cap (at most ~32 steps).
    while (p < pass && t < cap && (step_cap == 0 || t < step_cap)) {
        t = std::min(cap, t + (step_cap ? std::min(t, step_cap) : t));
        ++p;
    }
    // Then constant steps of max_pass_spp.
    if (p < pass && t < cap) {
        uint64_t steps = pass - p;
        t = steps >= cap ? cap : std::min(cap, t + steps * step_cap);
    }
    return uint32_t(t);
}

uint64_t AdaptiveScheduler::pass_count(const AdaptiveOptions &o) {
    const uint64_t cap = spp_cap(o), step_cap = o.max_pass_spp;
    uint64_t t = first_target(o), p = 0;
    while (t < cap && (step_cap == 0 || t < step_cap)) {
        t = std::min(cap, t + (step_cap ? std::min(t, step_cap) : t));
        ++p;
    }
    if (t < cap)
        p += (cap - t + step_cap - 1) / step_cap;
    return p + 1;
}

std::vector<uint32_t> AdaptiveScheduler::pass_targets(const AdaptiveOptions &o) {
    if (o.max_spp == 0)
        throw std::invalid_argument("pass_targets: max_spp 0 is unbounded");
    std::vector<uint32_t> out;
    uint64_t n = pass_count(o);
    out.reserve(size_t(n));
    for (uint64_t p = 0; p < n; ++p)
        out.push_back(pass_target(o, p));
    return out;
}

// ---------------------------------------------------------------------------------------------
// Construction.
// ---------------------------------------------------------------------------------------------

AdaptiveScheduler::AdaptiveScheduler(const SampleSource &source, sampling::Film &film,
                                     AdaptiveOptions options)
    : source_(source), film_(film), options_(std::move(options)) {
    if (film.width() != source.width() || film.height() != source.height())
        throw std::invalid_argument("AdaptiveScheduler: film and sample source sizes differ");
    relmse_ = options_.metric == sampling::ErrorMetric::RelMse;
    adaptive_ = options_.adaptive &&
                (options_.error_target > 0 ||
                 (relmse_ && options_.spp_budget > 0 && !options_.refine_target));
    if (adaptive_ && options_.refine_target &&
        !(options_.refine_factor > 0 && options_.refine_factor < 1))
        throw std::invalid_argument("AdaptiveScheduler: refine_factor must lie in (0, 1)");
    // Without a budget that ends the render, refinement would never stop.
    refine_ = adaptive_ && options_.refine_target && (options_.time_s > 0 || options_.max_spp > 0);
    // The floor (refine_floor_ratio) guards every relMSE render: an spp budget or an error
    // target stops pixels as early as a refinement level does.
    floor_guard_ = refine_ || (adaptive_ && relmse_);
    if (options_.max_spp == 0 && !(options_.time_s > 0) && !adaptive_)
        throw std::invalid_argument(
            "AdaptiveScheduler: max_spp 0 needs a time budget or an error target");
    threads_ = options_.threads ? options_.threads
                                : uint32_t(std::max(1, tbb::info::default_concurrency()));

    const uint32_t w = film.width(), h = film.height();
    tiles_ = make_morton_tiles(w, h, kTileSize);
    // Split at tile boundaries so that every tile lies in exactly one quadrant.
    const uint32_t tiles_x = (w + kTileSize - 1) / kTileSize;
    const uint32_t tiles_y = (h + kTileSize - 1) / kTileSize;
    const uint32_t cx = (tiles_x + 1) / 2, cy = (tiles_y + 1) / 2;
    const int sx = int(std::min(w, cx * kTileSize)), sy = int(std::min(h, cy * kTileSize));
    const int iw = int(w), ih = int(h), g = int(kTileSize);
    const double image_area = std::max(1.0, double(w) * double(h));
    for (int q = 0; q < 4; ++q) {
        auto quad = std::make_unique<Quadrant>(options_.lock_stripes);
        sampling::PixelBounds r;
        r.x0 = (q & 1) ? sx : 0;
        r.x1 = (q & 1) ? iw : sx;
        r.y0 = (q & 2) ? sy : 0;
        r.y1 = (q & 2) ? ih : sy;
        if (r.empty())
            r = {};
        quad->rect = r;
        if (!r.empty())
            quad->grown = {std::max(0, r.x0 - g), std::max(0, r.y0 - g), std::min(iw, r.x1 + g),
                           std::min(ih, r.y1 + g)};
        quad->trees[0] = sampling::RegionTree(quad->rect, quad->grown, image_area);
        quad->trees[1] = sampling::RegionTree(quad->rect, quad->grown, image_area);
        quadrants_.push_back(std::move(quad));
    }
    tile_quadrant_.resize(tiles_.size());
    for (size_t t = 0; t < tiles_.size(); ++t) {
        uint32_t q = (tiles_[t].tx >= cx ? 1u : 0u) | (tiles_[t].ty >= cy ? 2u : 0u);
        tile_quadrant_[t] = q;
        quadrants_[q]->tiles.push_back(uint32_t(t));
    }
    error_snapshot_ = std::make_unique<std::atomic<float>[]>(size_t(w) * h);
    tile_error_sum_ = std::make_unique<std::atomic<double>[]>(tiles_.size());
    tile_unknown_ = std::make_unique<std::atomic<uint32_t>[]>(tiles_.size());
    if (relmse_) {
        a_snapshot_ = std::make_unique<std::atomic<float>[]>(size_t(w) * h);
        tile_a_sum_ = std::make_unique<std::atomic<double>[]>(tiles_.size());
        tile_sqrt_a_sum_ = std::make_unique<std::atomic<double>[]>(tiles_.size());
        tile_rho_sum_ = std::make_unique<std::atomic<double>[]>(tiles_.size());
        tile_cost_ = std::make_unique<std::atomic<double>[]>(tiles_.size());
        tile_cost_samples_ = std::make_unique<std::atomic<uint64_t>[]>(tiles_.size());
    }
    tiles_x_ = tiles_x;
    tile_at_.assign(size_t(tiles_x) * tiles_y, 0);
    for (size_t t = 0; t < tiles_.size(); ++t)
        tile_at_[size_t(tiles_[t].ty) * tiles_x + tiles_[t].tx] = uint32_t(t);
    tile_done_ = std::make_unique<std::atomic<uint32_t>[]>(tiles_.size());
    group_ = options_.group;
    if (group_) {
        ranks_ = std::max(1u, group_->size());
        rank_ = group_->rank();
        if (rank_ >= ranks_)
            throw std::invalid_argument("AdaptiveScheduler: rank outside its group");
    }
    for (size_t t = 0; t < tiles_.size(); ++t)
        if (tile_owner(t, ranks_) == rank_)
            owned_tiles_.push_back(uint32_t(t));
    if (group_)
        tile_changed_.assign(tiles_.size(), 0);
}

AdaptiveScheduler::~AdaptiveScheduler() = default;

double AdaptiveScheduler::target_at(uint32_t level) const {
    // Repeated multiplication, not pow(): the same bits on every platform and thread.
    double t = options_.error_target;
    for (uint32_t i = 0; i < level; ++i)
        t *= options_.refine_factor;
    return t;
}

const sampling::RegionTree &AdaptiveScheduler::tree(int quadrant) const {
    return quadrants_.at(size_t(quadrant))->live();
}

sampling::PixelBounds AdaptiveScheduler::quadrant_rect(int quadrant) const {
    return quadrants_.at(size_t(quadrant))->rect;
}

std::string AdaptiveScheduler::describe() const {
    std::ostringstream os;
    os << "AdaptiveScheduler(" << film_.width() << "x" << film_.height() << ", " << tiles_.size()
       << " tiles in Morton order, quadrants";
    for (const auto &q : quadrants_)
        os << " " << q->rect.width() << "x" << q->rect.height();
    os << ", " << threads_ << " threads, " << (adaptive_ ? "adaptive" : "uniform")
       << (options_.deterministic ? " deterministic" : " barrier-free") << ", spp "
       << options_.min_spp << ".." << options_.max_spp << ", target " << options_.error_target
       << (refine_ ? " (refined)" : "") << ", seed " << options_.seed << ", "
       << sampling::pattern_name(options_.pattern) << " pattern)";
    return os.str();
}

// ---------------------------------------------------------------------------------------------
// Rendering.
// ---------------------------------------------------------------------------------------------

void AdaptiveScheduler::snapshot_pixel_error(uint32_t x, uint32_t y) {
    const size_t i = size_t(y) * film_.width() + x;
    const sampling::PixelStats st = film_.pixel_stats(x, y);
    if (!relmse_) {
        error_snapshot_[i].store(sampling::pixel_error(st, options_.min_samples_for_error),
                                 std::memory_order_relaxed);
        return;
    }
    // m_p = rho / n and a_p = rho * n (see "Error metrics" in the header).
    const float rho = sampling::pixel_rel_mse(st, options_.min_samples_for_error);
    const double n = std::max(1u, st.accepted);
    error_snapshot_[i].store(rho < kInfF ? float(double(rho) / n) : kInfF,
                             std::memory_order_relaxed);
    a_snapshot_[i].store(rho < kInfF ? float(double(rho) * n) : 0.f, std::memory_order_relaxed);
}

void AdaptiveScheduler::init_error_snapshot() {
    // This rank's tiles (all of them in a single process): a distributed rank's film holds
    // only its own tiles' samples; the others' sums arrive with exchange_tile_sums.
    const uint32_t w = film_.width();
    for (uint32_t t : owned_tiles_) {
        const Tile &tile = tiles_[t];
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x) {
                if (film_.sample_count(x, y) == 0) {
                    error_snapshot_[size_t(y) * w + x].store(kInfF, std::memory_order_relaxed);
                    if (relmse_)
                        a_snapshot_[size_t(y) * w + x].store(0.f, std::memory_order_relaxed);
                } else {
                    snapshot_pixel_error(x, y);
                }
            }
        publish_tile_error(t);
    }
    if (group_)
        exchange_tile_sums();
}

namespace {
// Values per tile in the exchange (after its index): error sum and unknown count, and with the
// relMSE metric the sums of a_p, sqrt(a_p c_p) and rho_p.
constexpr size_t kDammertzTileValues = 2, kRelMseTileValues = 5;
}  // namespace

void AdaptiveScheduler::pack_changed_tiles(std::vector<double> &mine) {
    // Only the tiles whose sums changed since the last exchange (a tile skipped in a pass keeps
    // its sums): late adaptive passes, where most tiles are complete, send little.
    mine.clear();
    for (uint32_t t : owned_tiles_) {
        if (!tile_changed_[t])
            continue;
        tile_changed_[t] = 0;
        mine.push_back(double(t));
        mine.push_back(tile_error_sum_[t].load(std::memory_order_relaxed));
        mine.push_back(double(tile_unknown_[t].load(std::memory_order_relaxed)));
        if (relmse_) {
            mine.push_back(tile_a_sum_[t].load(std::memory_order_relaxed));
            mine.push_back(tile_sqrt_a_sum_[t].load(std::memory_order_relaxed));
            mine.push_back(tile_rho_sum_[t].load(std::memory_order_relaxed));
        }
    }
}

void AdaptiveScheduler::exchange_tile_sums(const std::vector<double> &mine,
                                           const std::vector<size_t> &counts) {
    const size_t k = 1 + (relmse_ ? kRelMseTileValues : kDammertzTileValues);
    size_t total = 0;
    for (size_t c : counts) total += c;
    std::vector<double> all(total);
    group_->all_gather(mine, counts, all);
    for (size_t i = 0; i + k <= all.size(); i += k) {
        const size_t t = size_t(all[i]);
        if (t >= tiles_.size() || tile_owner(t, ranks_) == rank_)
            continue;
        tile_error_sum_[t].store(all[i + 1], std::memory_order_relaxed);
        tile_unknown_[t].store(uint32_t(all[i + 2]), std::memory_order_relaxed);
        if (relmse_) {
            tile_a_sum_[t].store(all[i + 3], std::memory_order_relaxed);
            tile_sqrt_a_sum_[t].store(all[i + 4], std::memory_order_relaxed);
            tile_rho_sum_[t].store(all[i + 5], std::memory_order_relaxed);
        }
    }
}

void AdaptiveScheduler::exchange_tile_sums() {
    std::vector<double> mine;
    pack_changed_tiles(mine);
    std::vector<double> n(ranks_, 0.0);
    n[rank_] = double(mine.size());
    group_->sum(n);
    std::vector<size_t> counts(ranks_);
    for (uint32_t r = 0; r < ranks_; ++r) counts[r] = size_t(n[r]);
    exchange_tile_sums(mine, counts);
}

double AdaptiveScheduler::group_sum(double v) const {
    if (!group_)
        return v;
    group_->sum(std::span<double>(&v, 1));
    return v;
}

double AdaptiveScheduler::tile_cost(size_t t) const {
    // Relative to the image's mean cost per sample, so that a tile not sampled in this render
    // yet (a resumed film, or every tile before the first visit) counts as average (1) in the
    // same units as the others.
    // The mean is the one of the last rebuild: in the deterministic mode it then changes only
    // between passes (the totals grow during a pass in the order the threads finish).
    const uint64_t n = tile_cost_samples_[t].load(std::memory_order_relaxed);
    const double mean = mean_cost_.load(std::memory_order_relaxed);
    if (n == 0 || !(mean > 0))
        return 1.0;
    const double c = tile_cost_[t].load(std::memory_order_relaxed) / double(n);
    return std::max(c / mean, 1e-6);
}

void AdaptiveScheduler::add_tile_cost(size_t t, double cost, uint64_t samples) {
    // Deterministic: every sample costs 1 (tile_cost stays 1). The image must depend on the
    // film alone, and the film keeps no costs: N passes + a resume to M must equal M passes
    // straight, and a resumed scheduler starts without the costs the first one measured.
    if (!relmse_ || samples == 0 || options_.deterministic)
        return;
    // Only the tile's owner writes its entries; the image totals are shared.
    tile_cost_[t].store(tile_cost_[t].load(std::memory_order_relaxed) + cost,
                        std::memory_order_relaxed);
    tile_cost_samples_[t].store(tile_cost_samples_[t].load(std::memory_order_relaxed) + samples,
                                std::memory_order_relaxed);
    double cur = cost_sum_.load(std::memory_order_relaxed);
    while (!cost_sum_.compare_exchange_weak(cur, cur + cost, std::memory_order_relaxed)) {
    }
    cost_samples_.fetch_add(samples, std::memory_order_relaxed);
}

void AdaptiveScheduler::publish_tile_error(size_t t) {
    const Tile &tile = tiles_[t];
    const uint32_t w = film_.width();
    double sum = 0, a_sum = 0, sqrt_a_sum = 0, rho_sum = 0;
    // RelMse: per unit of cost (see "Error metrics"); c > 0.
    const double c = relmse_ ? tile_cost(t) : 1.0;
    uint32_t unknown = 0;
    for (uint32_t y = tile.y0; y < tile.y1; ++y)
        for (uint32_t x = tile.x0; x < tile.x1; ++x) {
            const size_t i = size_t(y) * w + x;
            const float e = error_snapshot_[i].load(std::memory_order_relaxed);
            if (!(e < kInfF)) {
                ++unknown;  // +inf or NaN: no estimate
                continue;
            }
            sum += double(std::max(e, 0.f)) / c;
            if (relmse_) {
                const double a = std::max(0.0, double(a_snapshot_[i].load(std::memory_order_relaxed)));
                a_sum += a;
                sqrt_a_sum += std::sqrt(a * c);
                rho_sum += std::sqrt(a * double(std::max(e, 0.f)) / c);  // rho = sqrt(m a)
            }
        }
    tile_error_sum_[t].store(sum, std::memory_order_relaxed);
    tile_unknown_[t].store(unknown, std::memory_order_relaxed);
    if (group_)
        tile_changed_[t] = 1;  // written by the tile's owner, read after the workers join
    if (relmse_) {
        // rho = sqrt(m a) was summed with m / c: undo the cost.
        rho_sum *= std::sqrt(c);
        tile_a_sum_[t].store(a_sum, std::memory_order_relaxed);
        tile_sqrt_a_sum_[t].store(sqrt_a_sum, std::memory_order_relaxed);
        tile_rho_sum_[t].store(rho_sum, std::memory_order_relaxed);
    }
}

double AdaptiveScheduler::tree_target(uint32_t level) const {
    const double e_target =
        refine_ ? target_at(level) : options_.error_target;
    if (!relmse_)
        return e_target;
    // In tile order, so that the deterministic mode sums identically.
    double a_sum = 0, sqrt_a_sum = 0;
    for (size_t t = 0; t < tiles_.size(); ++t) {
        a_sum += tile_a_sum_[t].load(std::memory_order_relaxed);
        sqrt_a_sum += tile_sqrt_a_sum_[t].load(std::memory_order_relaxed);
    }
    const double pixels = std::max(1.0, double(film_.width()) * double(film_.height()));
    // spp_budget: the relMSE of that many uniform samples, as the film estimates it now.
    double e = !refine_ && options_.error_target <= 0 && options_.spp_budget > 0
                   ? a_sum / (pixels * double(options_.spp_budget))
                   : e_target;
    // Refining, the target also tracks the image's estimated relMSE: at most refine_track
    // times it. The level alone waits for every region to complete before it falls, so while
    // the hardest region works at one level every pixel above its threshold takes the same
    // samples per pass, hard or less hard; a target just below the current error keeps only
    // the pixels whose m_p / c_p exceeds refine_track^2 times the common value of the optimal
    // allocation open, at every rebuild.
    if (refine_ && options_.refine_track > 0) {
        const double now = published_image_error();
        if (std::isfinite(now) && now > 0)
            e = std::min(e, options_.refine_track * now);
    }
    if (!(sqrt_a_sum > 0))
        return std::numeric_limits<double>::infinity();  // no noise anywhere: nothing to do
    const double root = pixels * e / sqrt_a_sum;
    return root * root;
}

double AdaptiveScheduler::published_image_error() const {
    double sum = 0;
    for (size_t t = 0; t < tiles_.size(); ++t) {
        if (tile_unknown_[t].load(std::memory_order_relaxed) != 0)
            return std::numeric_limits<double>::infinity();
        sum += relmse_ ? tile_rho_sum_[t].load(std::memory_order_relaxed)
                       : tile_error_sum_[t].load(std::memory_order_relaxed);
    }
    return sum / std::max(1.0, double(film_.width()) * double(film_.height()));
}

namespace {

// Refining, a pixel grows from its own count by the pass rule (16, 32, 64, +64, ...) instead of
// jumping to the pass's target: a region reopened after sitting out many passes (the pass index
// runs fast while every tile is skipped) would otherwise take thousands of samples at once, far
// beyond what the lowered target asks for. Also at most the level's cap
// (AdaptiveOptions::refine_spp_ratio): a pixel whose region cannot get below the target (a
// firefly, a leaf sharing a tile with frozen errors) would otherwise take every sample of the
// budget.
[[gnu::always_inline]] inline uint32_t refined_pixel_target(const AdaptiveOptions &o,
                                                            uint32_t target, uint32_t first,
                                                            uint32_t pixel_cap) {
    uint32_t pixel_target = std::min(target, grown_target(o, first));
    if (pixel_cap > 0)
        pixel_target = std::min(pixel_target, std::max(first, pixel_cap));
    return pixel_target;
}

}  // namespace

// What one tile visit took, and the camera samples still waiting in the worker's batch.
struct AdaptiveScheduler::TileTally {
    uint64_t samples = 0, rays = 0, shadow_avoided = 0;
    uint32_t batched = 0;  // camera samples waiting in WorkerState::batch_cs

    // Evaluates the waiting camera samples and adds them to the film in order.
    [[gnu::always_inline]] void flush(const SampleSource &source, sampling::Film &film,
                                      WorkerState &ws) {
        if (batched == 0)
            return;
        source.evaluate_batch(std::span<const CameraSample>(ws.batch_cs.data(), batched),
                              std::span<Sample>(ws.batch_out.data(), batched));
        for (uint32_t k = 0; k < batched; ++k) {
            const Sample &s = ws.batch_out[k];
            const CameraSample &cs = ws.batch_cs[k];
            rays += s.rays;
            shadow_avoided += s.shadow_rays_avoided;
            film.add_sample(cs.px, cs.py, cs.index, s);
        }
        samples += batched;
        batched = 0;
    }
};

void AdaptiveScheduler::wait_for_tile_pass(std::atomic<uint32_t> &done, uint32_t pass,
                                           WorkerState &ws) {
    uint32_t d = done.load(std::memory_order_acquire);
    if (d == pass)
        return;
    auto t0 = Clock::now();
    while (d != pass) {
        done.wait(d, std::memory_order_acquire);
        d = done.load(std::memory_order_acquire);
    }
    ws.tile_wait_s += seconds_since(t0);
}

bool AdaptiveScheduler::select_active_pixels(const Tile &tile, Quadrant &quad, uint32_t pass,
                                             RenderContext &ctx, WorkerState &ws) {
    const uint32_t tw = tile.width(), n = tile.pixel_count();
    std::fill_n(ws.active.begin(), n, uint8_t(1));
    if (!adaptive_ || pass == 0)
        return true;
    // Copy what the tile needs out of the tree under the stripe's shared lock.
    const uint32_t s = quad.locks.index(tile.tx, tile.ty);
    ws.reader_wait_s += quad.locks.lock_shared(s);
    const sampling::RegionTree &tree = quad.live();
    tree.active_rects(
        sampling::PixelBounds{int(tile.x0), int(tile.y0), int(tile.x1), int(tile.y1)}, ws.rects);
    const double pixel_target = tree.params().target;
    quad.locks.unlock_shared(s);
    // Refining: pixels below the level's floor count as active wherever they are (the tile's
    // pixels belong to this thread now, so their counts can be read).
    const uint32_t floor = floor_guard_ ? ctx.pixel_floor.load(std::memory_order_relaxed) : 0;
    bool below_floor = false;
    if (floor > 0)
        for (uint32_t i = 0; i < n && !below_floor; ++i)
            below_floor = film_.sample_count(tile.x0 + i % tw, tile.y0 + i / tw) < floor;
    if (ws.rects.empty() && !below_floor && !options_.visit_hook)
        return false;
    std::fill_n(ws.active.begin(), n, uint8_t(0));
    for (const sampling::PixelBounds &r : ws.rects) {
        int x0 = std::max(r.x0, int(tile.x0)), x1 = std::min(r.x1, int(tile.x1));
        int y0 = std::max(r.y0, int(tile.y0)), y1 = std::min(r.y1, int(tile.y1));
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x)
                ws.active[size_t(y - int(tile.y0)) * tw + size_t(x - int(tile.x0))] = 1;
    }
    if (relmse_ && !ws.rects.empty())
        select_pixels_by_error(tile, pixel_target, ws);
    if (below_floor)
        for (uint32_t i = 0; i < n; ++i)
            if (film_.sample_count(tile.x0 + i % tw, tile.y0 + i / tw) < floor)
                ws.active[i] = 1;
    return true;
}

// select_pixels_by_error: a pixel sits out only when its 3x3 mean is below this fraction of the
// threshold. Nine pixels' estimates of a few degrees of freedom each scatter by tens of per cent
// around their true mean: at the threshold itself about half of the pixels of a region that is
// uniformly at the threshold would sit out at random, an allocation by noise (on the diffuse
// Cornell box, where the oracle gains little, it cost a few per cent against uniform). Below half
// of it a pixel is clearly easy.
constexpr double kSelectMargin = 0.5;

void AdaptiveScheduler::select_pixels_by_error(const Tile &tile, double target,
                                               WorkerState &ws) const {
    // Inside an open region, a pixel is sampled when the mean m_p of its 3x3 neighbourhood
    // (clipped to the tile) is at least kSelectMargin x the tree's threshold: error concentrated in features
    // narrower than a tile (a highlight, a silhouette) gets the samples, not the whole tile.
    // The 3x3 mean steadies the estimate of single pixels (about one degree of freedom per
    // channel each). Only the tile's own pixels are read: their snapshot changes only in this
    // tile's visits, while a neighbouring tile's may or may not have been rendered in this pass
    // yet, which would make the deterministic mode depend on timing. (A one-pixel spike of
    // 9x the threshold still lifts its 3x3 mean above it.) If no pixel of the tile qualifies, the region is open for pixels in other tiles (a leaf spans
    // several): this tile is skipped. (A region whose every pixel is below the threshold only
    // through the smoothing takes no samples; refining, its quadrant's idle pass counts as
    // complete.)
    const uint32_t tw = tile.width(), n = tile.pixel_count();
    const uint32_t w = film_.width();
    std::array<uint8_t, kTilePixels> keep{};
    const double cost = tile_cost(size_t(&tile - tiles_.data()));
    for (uint32_t i = 0; i < n; ++i) {
        if (!ws.active[i])
            continue;
        const uint32_t px = tile.x0 + i % tw, py = tile.y0 + i / tw;
        double sum = 0;
        int count = 0;
        bool unknown = false;
        for (uint32_t y = py > tile.y0 ? py - 1 : py; y <= std::min(tile.y1 - 1, py + 1); ++y)
            for (uint32_t x = px > tile.x0 ? px - 1 : px; x <= std::min(tile.x1 - 1, px + 1); ++x) {
                const float e = error_snapshot_[size_t(y) * w + x].load(std::memory_order_relaxed);
                unknown = unknown || !(e < kInfF);
                sum += double(std::max(e, 0.f));
                ++count;
            }
        keep[i] = unknown || sum >= kSelectMargin * target * count * cost;
    }
    for (uint32_t i = 0; i < n; ++i) ws.active[i] = keep[i];
}

bool AdaptiveScheduler::sample_tile(const Tile &tile, uint32_t target, uint32_t pixel_cap,
                                    WorkerState &ws, TileTally &tally) {
    const uint32_t tw = tile.width(), n = tile.pixel_count();
    bool any_active = false;
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t px = tile.x0 + i % tw, py = tile.y0 + i / tw;
        const uint32_t first = film_.sample_count(px, py);
        ws.before[i] = first;
        if (!ws.active[i]) {
            ws.after[i] = first;
            ++ws.pixels_skipped;
            continue;
        }
        any_active = true;
        const uint32_t pixel_target =
            refine_ ? refined_pixel_target(options_, target, first, pixel_cap) : target;
        // The film's count is the pixel's next index: each pixel continues its own sequence.
        // The samples of the tile's pixels go to the source in batches of up to kSampleBatch
        // (the path tracer traces them 8 at a time and refills its lanes from the batch, so
        // the batch may run across pixels) and reach the film in pixel and index order.
        for (uint32_t index = first; index < pixel_target;) {
            const uint32_t m =
                std::min<uint32_t>(kSampleBatch - tally.batched, pixel_target - index);
            for (uint32_t k = 0; k < m; ++k)
                ws.batch_cs[tally.batched + k] = camera_sample(options_.seed, px, py, index + k, options_.pattern);
            tally.batched += m;
            index += m;
            if (tally.batched == kSampleBatch)
                tally.flush(source_, film_, ws);
        }
        ws.after[i] = std::max(first, pixel_target);
    }
    tally.flush(source_, film_, ws);
    return any_active;
}

bool AdaptiveScheduler::snapshot_tile_errors(const Tile &tile, const WorkerState &ws) {
    const uint32_t tw = tile.width(), n = tile.pixel_count();
    bool any_new_error = false;
    for (uint32_t i = 0; i < n; ++i) {
        if (ws.after[i] == ws.before[i])
            continue;
        snapshot_pixel_error(tile.x0 + i % tw, tile.y0 + i / tw);
        any_new_error = true;
    }
    return any_new_error;
}

void AdaptiveScheduler::report_visit(const Tile &tile, uint32_t pass, uint32_t target, uint32_t q,
                                     bool any_active, const WorkerState &ws) const {
    const uint32_t n = tile.pixel_count();
    TileVisit v;
    v.tile = &tile;
    v.pass = pass;
    v.target = target;
    v.quadrant = q;
    v.skipped = !any_active;
    v.active = std::span<const uint8_t>(ws.active.data(), n);
    v.count_before = std::span<const uint32_t>(ws.before.data(), n);
    v.count_after = std::span<const uint32_t>(ws.after.data(), n);
    options_.visit_hook(v);
}

void AdaptiveScheduler::process_tile(size_t t, uint32_t pass, RenderContext &ctx, WorkerState &ws) {
    const Tile &tile = tiles_[t];
    const uint32_t q = tile_quadrant_[t];
    Quadrant &quad = *quadrants_[q];

    // The same tile's previous pass may still be in flight on another thread (more threads than
    // tiles, or a slow tile): wait for it, so each pixel has one writer and stays in order.
    std::atomic<uint32_t> &done = tile_done_[t];
    wait_for_tile_pass(done, pass, ws);
    if (options_.tile_hook)
        options_.tile_hook(tile, pass);

    auto t0 = Clock::now();
    const uint32_t target = pass_target(options_, pass);
    const uint32_t pixel_cap = refine_ ? ctx.pixel_cap.load(std::memory_order_relaxed) : 0;
    if (!select_active_pixels(tile, quad, pass, ctx, ws)) {
        // The whole tile lies in converged regions: it costs the tree check and nothing else
        // (no pixel is read or written).
        ws.pixels_skipped += tile.pixel_count();
        ++ws.tiles_skipped;
        ws.render_s += seconds_since(t0);
        done.store(pass + 1, std::memory_order_release);
        done.notify_all();
        return;
    }

    TileTally tally;
    const auto t_sample = Clock::now();
    const bool any_active = sample_tile(tile, target, pixel_cap, ws, tally);
    // The cost of a sample here in seconds, which also see what a ray costs to shade (a layered
    // material); none in the deterministic mode (see add_tile_cost).
    add_tile_cost(t, seconds_since(t_sample), tally.samples);
    if (adaptive_ && snapshot_tile_errors(tile, ws))
        publish_tile_error(t);
    if (any_active)
        ++ws.tiles_rendered;
    else
        ++ws.tiles_skipped;
    ws.samples += tally.samples;
    ws.rays += tally.rays;
    ws.shadow_rays_avoided += tally.shadow_avoided;
    ws.render_s += seconds_since(t0);
    if (ctx.progress)
        ctx.progress->add(tally.samples, tally.rays);
    if (floor_guard_ && tally.samples) {
        quad.pass_samples.fetch_add(tally.samples, std::memory_order_relaxed);
        ctx.film_samples.fetch_add(tally.samples, std::memory_order_relaxed);
    }
    if (options_.visit_hook)
        report_visit(tile, pass, target, q, any_active, ws);
    // Release: the next pass of this tile (maybe on another thread) sees our film writes.
    done.store(pass + 1, std::memory_order_release);
    done.notify_all();
}

bool AdaptiveScheduler::rebuild_quadrant(int q, RenderContext &ctx, WorkerState &ws,
                                         bool pass_idle) {
    Quadrant &quad = *quadrants_[size_t(q)];
    if (quad.rect.empty())
        return false;
    auto t0 = Clock::now();
    // The level this rebuild builds for (a per-rebuild snapshot: another quadrant's rebuild may
    // lower the target meanwhile; see the end).
    uint32_t level = 0;
    if (refine_) {
        std::lock_guard<std::mutex> lock(ctx.level_mutex);
        level = ctx.level;
    }
    // Gather the per-tile error sums of the grown rectangle (tile aligned at its top-left
    // corner; its right and bottom edge are tile boundaries or the image edge); sum the
    // quadrant's own tiles for the progress estimate.
    const uint32_t w = film_.width(), h = film_.height();
    const sampling::PixelBounds &g = quad.grown, &r = quad.rect;
    const int ts = int(kTileSize);
    sampling::CellErrorImage &cells = quad.cells;
    cells.cell = ts;
    cells.cols = (g.width() + ts - 1) / ts;
    cells.rows = (g.height() + ts - 1) / ts;
    cells.sum.resize(size_t(cells.cols) * size_t(cells.rows));
    cells.unknown.resize(cells.sum.size());
    double sum = 0;
    uint64_t unknown = 0;
    for (int j = 0; j < cells.rows; ++j)
        for (int i = 0; i < cells.cols; ++i) {
            const int tx = g.x0 / ts + i, ty = g.y0 / ts + j;
            const uint32_t t = tile_at_[size_t(ty) * tiles_x_ + size_t(tx)];
            const double e = tile_error_sum_[t].load(std::memory_order_relaxed);
            const uint32_t u = tile_unknown_[t].load(std::memory_order_relaxed);
            const size_t k = size_t(j) * size_t(cells.cols) + size_t(i);
            cells.sum[k] = e;
            cells.unknown[k] = u;
            const int px = tx * ts, py = ty * ts;
            if (px >= r.x0 && px < r.x1 && py >= r.y0 && py < r.y1) {
                sum += e;
                unknown += u;
            }
        }
    if (floor_guard_)
        ctx.raise_guards(options_);
    sampling::RegionTreeParams params;
    if (relmse_) {
        const uint64_t n = cost_samples_.load(std::memory_order_relaxed);
        if (n > 0)
            mean_cost_.store(cost_sum_.load(std::memory_order_relaxed) / double(n),
                             std::memory_order_relaxed);
    }
    params.target = tree_target(level);
    params.split_factor = options_.split_factor;
    params.min_extent = options_.min_extent;
    params.area_weighted = !relmse_;
    quad.last_tree_target.store(params.target, std::memory_order_relaxed);
    // Build into the idle copy, publish it, then take each stripe's writer lock in turn: once
    // past all of them, no reader can still be reading the old copy, which becomes the idle one
    // of the next rebuild. Readers wait at most for one stripe's hand-over, never for a whole
    // rebuild, and the writer holds one lock at a time (TSan's deadlock detector tracks at most
    // 64 locks held by one thread).
    const uint32_t idle = 1u - quad.active.load(std::memory_order_relaxed);
    sampling::RegionTree &next = quad.trees[idle];
    next.rebuild_cells(cells, params);
    // Complete means "no open leaf over the quadrant's own pixels" (nothing left for its tiles
    // to sample). An open leaf only in the one-tile margin belongs to a neighbour, which may
    // find its own, differently cut region there complete and stop sampling it: waiting for it
    // would keep this quadrant open with nothing active, and the render would run out its
    // passes without converging (or stall every refinement).
    // Refining, a pass that took no sample (every open pixel at the level's cap) counts as
    // complete too: nothing more can happen at this level.
    const bool complete = next.open_area() <= 0.0 || (refine_ && pass_idle);
    quad.active.store(idle, std::memory_order_release);
    ws.writer_wait_s += quad.locks.sweep();

    quad.error_sum.store(sum, std::memory_order_relaxed);
    quad.unknown_pixels.store(unknown, std::memory_order_relaxed);
    bool refined = false;
    if (!refine_) {
        if (complete)
            ctx.open_mask.fetch_and(~(1u << q), std::memory_order_relaxed);
        else
            ctx.open_mask.fetch_or(1u << q, std::memory_order_relaxed);
    } else {
        std::lock_guard<std::mutex> lock(ctx.level_mutex);
        // A tree built for an older level says nothing about the current target: the quadrant
        // stays open until its next rebuild. The new mask is stored once: other threads read
        // it without the mutex, and a transient zero would stop the render.
        uint32_t mask = ctx.open_mask.load(std::memory_order_relaxed);
        mask = complete && level == ctx.level ? mask & ~(1u << q) : mask | (1u << q);
        if (mask == 0 && target_at(ctx.level + 1) >= options_.refine_min_target) {
            // Every quadrant is complete at the current target and the budget is not spent:
            // lower the target and reopen every quadrant until it is rebuilt against it.
            ++ctx.level;
            ++ctx.refinements;
            mask = ctx.nonempty_mask;
            if (ctx.progress)
                ctx.progress->set_target(target_at(ctx.level));
            refined = true;
        }
        // Otherwise a zero mask means converged at the floor target: the caller stops.
        ctx.open_mask.store(mask, std::memory_order_relaxed);
    }
    const double s = seconds_since(t0);
    ws.rebuild_s += s;
    ++quad.rebuilds;
    quad.rebuild_ms_sum += s * 1e3;
    quad.rebuild_ms_max = std::max(quad.rebuild_ms_max, s * 1e3);

    if (ctx.progress) {
        if (relmse_) {
            ctx.progress->set_error(published_image_error());
        } else {
            double total = 0;
            bool known = true;
            for (const auto &qq : quadrants_) {
                total += qq->error_sum.load(std::memory_order_relaxed);
                known = known && qq->unknown_pixels.load(std::memory_order_relaxed) == 0;
            }
            ctx.progress->set_error(known ? total / (double(w) * double(h))
                                          : std::numeric_limits<double>::infinity());
        }
    }
    return refined;
}

bool AdaptiveScheduler::open_pixel_below(uint32_t target, WorkerState &ws) const {
    // No rebuild runs concurrently (every worker has joined): the live trees are read as is.
    // Distributed: each rank looks at its own tiles, and any rank's answer counts.
    bool found = false;
    for (uint32_t t : owned_tiles_) {
        if (found)
            break;
        const Tile &tile = tiles_[t];
        const Quadrant &quad = *quadrants_[tile_quadrant_[t]];
        quad.live().active_rects(
            sampling::PixelBounds{int(tile.x0), int(tile.y0), int(tile.x1), int(tile.y1)}, ws.rects);
        for (const sampling::PixelBounds &r : ws.rects)
            for (int y = std::max(r.y0, int(tile.y0)); y < std::min(r.y1, int(tile.y1)); ++y)
                for (int x = std::max(r.x0, int(tile.x0)); x < std::min(r.x1, int(tile.x1)); ++x)
                    if (film_.sample_count(uint32_t(x), uint32_t(y)) < target)
                        found = true;
    }
    return group_ ? group_sum(found ? 1.0 : 0.0) > 0 : found;
}

void AdaptiveScheduler::rebuild_all(RenderContext &ctx, WorkerState &ws, bool pass_end) {
    // In order, on one thread: the result depends on the film only (deterministic mode). A
    // rebuild that lowered the target leaves the quadrants before it built for the old one:
    // rebuild all four again (each round lowers the target once; refine_min_target bounds it).
    bool refined = true;
    while (refined) {
        refined = false;
        for (int q = 0; q < 4; ++q) {
            // The pass's samples count once: a rebuild after a refinement (raised cap) is not idle.
            const uint64_t taken =
                refine_ ? quadrants_[size_t(q)]->pass_samples.exchange(0) : uint64_t(1);
            refined = rebuild_quadrant(q, ctx, ws, pass_end && taken == 0) || refined;
        }
        pass_end = false;
    }
}

void AdaptiveScheduler::finish_tile_nonbarrier(size_t t, RenderContext &ctx, WorkerState &ws) {
    const int q = int(tile_quadrant_[t]);
    Quadrant &quad = *quadrants_[size_t(q)];
    if (quad.left.fetch_sub(1, std::memory_order_acq_rel) != 1)
        return;
    // Last one out of this quadrant's pass. Re-arm: threads may already have counted tiles of
    // the next pass(es) (the count went negative); the add accounts for them, and a count still
    // <= 0 means that further passes of this quadrant completed meanwhile (paper, section 4.1).
    // Only the thread that saw the count reach zero adds, and the count stays <= 0 until it
    // does, so no other thread can be re-arming at the same time.
    const int64_t n = int64_t(quad.tiles.size());
    uint32_t completed = 1;
    while (quad.left.fetch_add(n, std::memory_order_acq_rel) + n <= 0)
        ++completed;
    const uint32_t passes = quad.passes_done.fetch_add(completed) + completed;
    if (ctx.progress)
        ctx.progress->set_passes(uint32_t(ctx.first_pass) + passes);
    if (!adaptive_)
        return;
    // Rebuild while the others keep rendering. If this quadrant's previous rebuild is still
    // running (a pass went by faster than a rebuild: skipped tiles, oversubscription), do not
    // wait for it: its thread rebuilds once more, from the newest errors, for every request
    // that arrived meanwhile (combining), and this thread goes back to rendering.
    if (quad.rebuild_requests.fetch_add(1, std::memory_order_acq_rel) != 0)
        return;
    uint32_t seen = 1;
    for (;;) {
        {
            // Uncontended: only the combining thread takes it.
            ws.writer_wait_s += lock_timed(quad.rebuild_mutex);
            std::lock_guard<std::mutex> lock(quad.rebuild_mutex, std::adopt_lock);
            // A rebuild that lowered the target rebuilds this quadrant at once against the new
            // one; the other quadrants follow at the end of their current pass (their tiles are
            // skipped meanwhile, which costs little).
            const bool idle = refine_ && quad.pass_samples.exchange(0) == 0;
            if (rebuild_quadrant(q, ctx, ws, idle))
                while (rebuild_quadrant(q, ctx, ws, false)) {
                }
            if (ctx.open_mask.load(std::memory_order_relaxed) == 0) {
                ctx.converged.store(true, std::memory_order_relaxed);
                ctx.stop.store(true, std::memory_order_relaxed);
            }
        }
        const uint32_t before = quad.rebuild_requests.fetch_sub(seen, std::memory_order_acq_rel);
        if (before == seen)
            break;
        seen = before - seen;
        ++ws.coalesced_rebuilds;
    }
}

namespace {

// The hand-off to and from TBB's workers happens inside libtbb, which the TSan build does not
// instrument, so TSan cannot see that the caller's writes happen before the tasks run (it would
// flag the tasks' first reads, even of the task's own closure). The caller releases, and every
// task acquires, a fixed address, before any closure is read. (TBB's own header code still
// races in TSan's eyes; tests/tsan.supp can silence exactly that with `race_top:tbb::detail`,
// which matches only races whose innermost frame is TBB's, and `called_from_lib:libtbb.so`.)
// The asm memory clobbers keep the compiler from moving the closures' loads above the acquire.
#if defined(__SANITIZE_THREAD__)
char g_tsan_handoff;
void tsan_release_handoff() {
    asm volatile("" ::: "memory");
    __tsan_release(&g_tsan_handoff);
}
void tsan_acquire_handoff() {
    __tsan_acquire(&g_tsan_handoff);
    asm volatile("" ::: "memory");
}
#else
void tsan_release_handoff() {}
void tsan_acquire_handoff() {}
#endif

// Runs body(i) for i in [0, threads) on the arena, one task each (each drains a shared work
// index, so tiles start in Morton order whatever the partitioner does), and returns when all are
// done. Workers release the merge mutex last, so taking it after the join orders their writes
// before the caller's reads (for TSan too).
template <class Ctx, class Body>
void run_workers(tbb::task_arena &arena, uint32_t threads, Ctx &ctx, const Body &body) {
    tsan_release_handoff();
    arena.execute([&] {
        tsan_acquire_handoff();
        // The task's closure must exist before the release the tasks acquire.
        auto task = [&](uint32_t i) {
            tsan_acquire_handoff();
            body(i);
        };
        tsan_release_handoff();
        tbb::parallel_for(uint32_t(0), threads, task, tbb::simple_partitioner());
    });
    std::lock_guard<std::mutex> join(ctx.merge_mutex);
}

}  // namespace

uint64_t AdaptiveScheduler::scheduled_passes() const {
    uint64_t n_passes = pass_count(options_);
    // Refining, pixels grow from their own counts (process_tile): one reopened in the last pass
    // needs up to pass_count more passes to reach max_spp. Bounded, so an spp budget still ends.
    if (refine_ && options_.max_spp > 0)
        n_passes *= 2;
    if (options_.max_passes > 0) n_passes = std::min<uint64_t>(n_passes, options_.max_passes);
    return n_passes;
}

uint64_t AdaptiveScheduler::resume_pass_of_film(uint64_t n_passes) const {
    if (options_.start_pass >= 0)
        return uint64_t(options_.start_pass);
    // Resume: start at the first pass some pixel still needs.
    uint64_t min_taken = std::numeric_limits<uint32_t>::max();
    for (uint32_t t : owned_tiles_) {
        const Tile &tile = tiles_[t];
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x)
                min_taken = std::min<uint64_t>(min_taken, film_.sample_count(x, y));
    }
    if (group_)
        group_->min(std::span<uint64_t>(&min_taken, 1));
    uint64_t p0 = 0;
    while (p0 < n_passes && pass_target(options_, p0) <= min_taken)
        ++p0;
    return p0;
}

void AdaptiveScheduler::reset_for_render(RenderContext &ctx, uint64_t p0) {
    const uint64_t pixels = uint64_t(film_.width()) * film_.height();
    for (size_t t = 0; t < tiles_.size(); ++t)
        tile_done_[t].store(uint32_t(p0));
    uint32_t open = 0;
    for (int q = 0; q < 4; ++q) {
        Quadrant &quad = *quadrants_[size_t(q)];
        quad.left.store(int64_t(quad.tiles.size()));
        quad.passes_done = 0;
        quad.rebuild_requests = 0;
        quad.rebuilds = 0;
        quad.rebuild_ms_sum = quad.rebuild_ms_max = 0;
        quad.error_sum = 0;
        quad.unknown_pixels = quad.rect.area() > 0 ? uint64_t(quad.rect.area()) : 0;
        const double area = std::max(1.0, double(pixels));
        // Unbuilt trees: every pixel active until the first rebuild.
        quad.trees[0] = sampling::RegionTree(quad.rect, quad.grown, area);
        quad.trees[1] = sampling::RegionTree(quad.rect, quad.grown, area);
        if (!quad.rect.empty())
            open |= 1u << q;
    }
    ctx.open_mask.store(open);
    ctx.nonempty_mask = open;
    ctx.pixels = std::max<uint64_t>(1, pixels);
    ctx.film_samples.store(ctx.film_total);
    for (int q = 0; q < 4; ++q)
        quadrants_[size_t(q)]->pass_samples.store(0);
    if (floor_guard_)
        ctx.raise_guards(options_);
}

void AdaptiveScheduler::warm_rebuild_buffers() {
    // Allocate and touch every rebuild buffer now (both tree copies' summed-area tables and the
    // error image), so that page faults do not land inside the timed, lock-holding rebuilds. A
    // rebuild from an all-unknown error image leaves each tree one open leaf: every pixel stays
    // active until the first real rebuild.
    for (int q = 0; q < 4; ++q) {
        Quadrant &quad = *quadrants_[size_t(q)];
        if (quad.rect.empty()) continue;
        const sampling::PixelBounds &g = quad.grown;
        const int ts = int(kTileSize);
        sampling::CellErrorImage &cells = quad.cells;
        cells.cell = ts;
        cells.cols = (g.width() + ts - 1) / ts;
        cells.rows = (g.height() + ts - 1) / ts;
        cells.sum.assign(size_t(cells.cols) * size_t(cells.rows), 0.0);
        cells.unknown.assign(cells.sum.size(), 1u);
        sampling::RegionTreeParams warm;
        warm.target = options_.error_target;
        quad.trees[0].rebuild_cells(cells, warm);
        quad.trees[1].rebuild_cells(cells, warm);
    }
}

void AdaptiveScheduler::rebuild_all_at_pass_end(RenderContext &ctx, WorkerState &ws,
                                                bool pass_end) {
    rebuild_all(ctx, ws, pass_end);
    if (ctx.open_mask.load() == 0)
        ctx.converged = ctx.stop = true;
}

bool AdaptiveScheduler::catch_up_wanted(uint64_t pass, RenderContext &ctx, WorkerState &ws) const {
    return pass < ctx.pass_end + kCatchUpPasses && !ctx.stop.load() &&
           ctx.open_mask.load() != 0 && open_pixel_below(ctx.last_target, ws);
}

// What the ranks sum at a pass end (exchange_pass): the counters as they were before the pass.
struct AdaptiveScheduler::PassCounters {
    uint64_t film_samples = 0, cost_samples = 0, samples = 0, rays = 0;
    std::array<uint64_t, 4> pass_samples{};
    double cost_sum = 0;
    static PassCounters read(const RenderContext &ctx, const AdaptiveScheduler &s) {
        PassCounters c;
        c.film_samples = ctx.film_samples.load();
        for (int q = 0; q < 4; ++q) c.pass_samples[size_t(q)] = s.quadrants_[size_t(q)]->pass_samples.load();
        c.cost_sum = s.cost_sum_.load();
        c.cost_samples = s.cost_samples_.load();
        c.samples = ctx.totals.samples;
        c.rays = ctx.totals.rays;
        return c;
    }
};

void AdaptiveScheduler::exchange_pass(RenderContext &ctx, const PassCounters &before) {
    // Every worker has joined: the counters hold this rank's pass. Integer counts travel as
    // doubles (exact below 2^53).
    // Wait for the slowest rank first (load imbalance, counted apart), then one sum of the
    // counters (and of each rank's payload size), then the changed tiles' sums.
    group_->arrive();
    std::vector<double> mine;
    if (adaptive_)
        pack_changed_tiles(mine);
    std::vector<double> v(11 + ranks_, 0.0);
    v[11 + rank_] = double(mine.size());
    v[0] = double(ctx.film_samples.load() - before.film_samples);
    for (int q = 0; q < 4; ++q)
        v[size_t(1 + q)] =
            double(quadrants_[size_t(q)]->pass_samples.load() - before.pass_samples[size_t(q)]);
    v[5] = cost_sum_.load() - before.cost_sum;
    v[6] = double(cost_samples_.load() - before.cost_samples);
    v[7] = ctx.stop_cancel.load() ? 1 : 0;
    v[8] = ctx.stop_time.load() ? 1 : 0;
    const uint64_t my_samples = ctx.totals.samples - before.samples;
    const uint64_t my_rays = ctx.totals.rays - before.rays;
    v[9] = double(my_samples);
    v[10] = double(my_rays);
    group_->sum(v);
    ctx.film_samples.store(before.film_samples + uint64_t(v[0]));
    for (int q = 0; q < 4; ++q)
        quadrants_[size_t(q)]->pass_samples.store(before.pass_samples[size_t(q)] +
                                                  uint64_t(v[size_t(1 + q)]));
    cost_sum_.store(before.cost_sum + v[5]);
    cost_samples_.store(before.cost_samples + uint64_t(v[6]));
    if (v[7] > 0)
        ctx.stop_cancel = ctx.stop = true;
    if (v[8] > 0)
        ctx.stop_time = ctx.stop = true;
    if (ctx.progress)
        ctx.progress->add(uint64_t(v[9]) - my_samples, uint64_t(v[10]) - my_rays);
    if (adaptive_) {
        std::vector<size_t> counts(ranks_);
        for (uint32_t r = 0; r < ranks_; ++r) counts[r] = size_t(v[11 + r]);
        exchange_tile_sums(mine, counts);
    }
}

void AdaptiveScheduler::run_pass(uint64_t pass, RenderContext &ctx) {
    // This rank's tiles (every tile in a single process), in Morton order.
    const size_t n_tiles = owned_tiles_.size();
    ctx.next_work.store(0);
    auto worker = [&](uint32_t) {
        WorkerState ws;
        while (!ctx.should_stop()) {
            uint64_t i = ctx.next_work.fetch_add(1, std::memory_order_relaxed);
            if (i >= n_tiles)
                break;
            process_tile(size_t(owned_tiles_[size_t(i)]), uint32_t(pass), ctx, ws);
        }
        ws.merge_into(ctx);
    };
    run_workers(*ctx.arena, threads_, ctx, worker);
}

void AdaptiveScheduler::run_barrier_free(RenderContext &ctx, WorkerState &main_ws,
                                         AdaptiveStats &stats) {
    // One work index over (pass, tile) pairs for the whole render.
    const size_t n_tiles = tiles_.size();
    ctx.next_work.store(ctx.first_pass * n_tiles);
    const uint64_t w_end = ctx.pass_end * n_tiles;
    auto worker = [&](uint32_t) {
        WorkerState ws;
        while (!ctx.should_stop()) {
            uint64_t item = ctx.next_work.fetch_add(1, std::memory_order_relaxed);
            if (item >= w_end)
                break;
            size_t t = size_t(item % n_tiles);
            process_tile(t, uint32_t(item / n_tiles), ctx, ws);
            finish_tile_nonbarrier(t, ctx, ws);
        }
        ws.merge_into(ctx);
    };
    if (!ctx.stop.load())
        run_workers(*ctx.arena, threads_, ctx, worker);
    for (const auto &q : quadrants_)
        stats.passes = std::max(stats.passes, q->passes_done.load());
    if (!ctx.catch_up || ctx.stop.load())
        return;
    // All rebuilds are done, but a quadrant's last one may predate its neighbours' last samples
    // in its margin: rebuild from the finished film first. (Not after a stop: converged, out of
    // time or cancelled.)
    rebuild_all_at_pass_end(ctx, main_ws, true);
    for (uint64_t pass = ctx.pass_end; catch_up_wanted(pass, ctx, main_ws); ++pass) {
        run_pass(pass, ctx);
        ++stats.catch_up_passes;
        ctx.progress->set_passes(uint32_t(pass + 1));
        rebuild_all_at_pass_end(ctx, main_ws, true);
    }
    stats.passes += stats.catch_up_passes;
}

void AdaptiveScheduler::run_deterministic(RenderContext &ctx, WorkerState &main_ws,
                                          AdaptiveStats &stats) {
    // A barrier after each pass, then all rebuilds on this thread.
    for (uint64_t pass = ctx.first_pass; !ctx.stop.load(); ++pass) {
        if (pass >= ctx.pass_end && !(ctx.catch_up && catch_up_wanted(pass, ctx, main_ws)))
            break;
        if (pass >= ctx.pass_end)
            ++stats.catch_up_passes;
        const PassCounters before = PassCounters::read(ctx, *this);
        run_pass(pass, ctx);
        if (group_)
            exchange_pass(ctx, before);
        if (ctx.stop_cancel.load() || ctx.stop_time.load())
            break;
        ++stats.passes;
        ctx.progress->set_passes(uint32_t(pass + 1));
        if (adaptive_)
            rebuild_all_at_pass_end(ctx, main_ws, true);
    }
}

void AdaptiveScheduler::run_passes(RenderContext &ctx, AdaptiveStats &stats) {
    const uint64_t pixels = uint64_t(film_.width()) * film_.height();
    const uint64_t p0 = ctx.first_pass, n_passes = ctx.pass_end;
    ctx.film_total = owned_film_samples();
    ctx.progress = std::make_unique<AdaptiveProgress>(options_.progress, pixels, ctx.film_total,
                                                      options_);
    reset_for_render(ctx, p0);
    WorkerState main_ws;
    if (adaptive_) {
        warm_rebuild_buffers();
        init_error_snapshot();
        // Resuming past the uniform start: the trees come from the film's samples.
        if (p0 > 0)
            rebuild_all_at_pass_end(ctx, main_ws, false);
    }

    // More threads than cores: lift TBB's limit for this render, or the arena silently runs with
    // fewer workers.
    std::unique_ptr<tbb::global_control> allow_more;
    if (int(threads_) > tbb::info::default_concurrency())
        allow_more = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, size_t(threads_));
    tbb::task_arena arena{int(threads_)};
    ctx.arena = &arena;

    // Catch-up passes. The schedule can end with a region open whose pixels are below its last
    // target: the last rebuild cut the tree anew (float splits), or, barrier-free, a thread
    // running ahead on a stale tree (its neighbour's rebuild preempted) skipped a region in the
    // last passes that a later rebuild reopened. The render would end unconverged below max_spp.
    // While that holds, run one more pass (a new pass index whose target is the last one: no
    // pixel goes past the schedule's final count, so the sample budget means the same), at most
    // kCatchUpPasses. Only where the schedule ends at the spp cap (not when max_passes cut it
    // short) and not when refining (there the passes already continue while the budget allows,
    // and a pass may lower the target).
    ctx.last_target = n_passes > 0 ? pass_target(options_, n_passes - 1) : 0;
    ctx.catch_up = adaptive_ && !refine_ && n_passes > 0 &&
                   pass_target(options_, n_passes) == ctx.last_target;

    if (!options_.deterministic && !group_)
        run_barrier_free(ctx, main_ws, stats);
    else
        run_deterministic(ctx, main_ws, stats);
    main_ws.merge_into(ctx);
    ctx.progress->finish();
    ctx.arena = nullptr;
    // tile_done_[t] is the next pass tile t needs (all workers have joined).
    uint64_t resume = std::numeric_limits<uint32_t>::max();
    for (uint32_t t : owned_tiles_)
        resume = std::min<uint64_t>(resume, tile_done_[t].load(std::memory_order_acquire));
    if (group_)
        group_->min(std::span<uint64_t>(&resume, 1));
    if (!tiles_.empty())
        stats.resume_pass = uint32_t(resume);
}

void AdaptiveScheduler::collect_stats(const RenderContext &ctx, AdaptiveStats &stats) const {
    const AdaptiveStats &t = ctx.totals;
    stats.samples = t.samples;
    stats.rays = t.rays;
    stats.shadow_rays_avoided = t.shadow_rays_avoided;
    stats.tiles_rendered = t.tiles_rendered;
    stats.tiles_skipped = t.tiles_skipped;
    stats.pixels_skipped = t.pixels_skipped;
    stats.lock_wait_reader_s = t.lock_wait_reader_s;
    stats.lock_wait_writer_s = t.lock_wait_writer_s;
    stats.lock_wait_s = t.lock_wait_reader_s + t.lock_wait_writer_s;
    stats.tile_wait_s = t.tile_wait_s;
    stats.render_s = t.render_s;
    stats.rebuild_s = t.rebuild_s;
    stats.rebuilds_coalesced = t.rebuilds_coalesced;
    double ms_sum = 0;
    for (int q = 0; q < 4; ++q) {
        const Quadrant &quad = *quadrants_[size_t(q)];
        stats.rebuilds += quad.rebuilds;
        ms_sum += quad.rebuild_ms_sum;
        stats.tree_rebuild_ms_max = std::max(stats.tree_rebuild_ms_max, quad.rebuild_ms_max);
        stats.quadrant_rebuild_ms_mean[size_t(q)] =
            quad.rebuilds ? quad.rebuild_ms_sum / quad.rebuilds : 0.0;
    }
    stats.tree_rebuild_ms_mean = stats.rebuilds ? ms_sum / stats.rebuilds : 0.0;
    stats.cancelled = ctx.stop_cancel.load();
    stats.out_of_time = ctx.stop_time.load();
    stats.converged = ctx.converged.load();
    stats.refinements = ctx.refinements;
    stats.final_error_target = refine_ ? target_at(ctx.level) : options_.error_target;
}

uint64_t AdaptiveScheduler::owned_film_samples() const {
    uint64_t n = 0;
    for (uint32_t t : owned_tiles_) {
        const Tile &tile = tiles_[t];
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x) n += film_.sample_count(x, y);
    }
    return group_ ? uint64_t(group_sum(double(n))) : n;
}

void AdaptiveScheduler::fill_spp_histogram(AdaptiveStats &stats) const {
    // Bins for every 32-bit count (bin 0: no sample; bin k: [2^(k-1), 2^k)), this rank's tiles,
    // summed over the ranks; trailing empty bins dropped.
    std::vector<double> bins(33, 0.0);
    for (uint32_t t : owned_tiles_) {
        const Tile &tile = tiles_[t];
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x) {
                const uint32_t c = film_.sample_count(x, y);
                bins[c == 0 ? 0 : size_t(std::bit_width(c))] += 1;
            }
    }
    if (group_)
        group_->sum(bins);
    size_t n = bins.size();
    while (n > 1 && bins[n - 1] == 0) --n;
    stats.spp_histogram.assign(n, 0);
    for (size_t k = 0; k < n; ++k) stats.spp_histogram[k] = uint64_t(bins[k]);
}

AdaptiveStats AdaptiveScheduler::render(const std::atomic<bool> *cancel) {
    RenderContext ctx;
    ctx.cancel = cancel;
    ctx.start = Clock::now();
    ctx.timed = options_.time_s > 0;
    ctx.deadline = ctx.start + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double>(ctx.timed ? options_.time_s : 0));
    AdaptiveStats stats;
    stats.threads = threads_;
    const double comm_before = group_ ? group_->comm_seconds() : 0.0;
    const double wait_before = group_ ? group_->wait_seconds() : 0.0;
    const uint64_t pixels = uint64_t(film_.width()) * film_.height();
    const uint64_t nan_before = film_.nan_count();

    const uint64_t n_passes = scheduled_passes();
    const uint64_t p0 = resume_pass_of_film(n_passes);
    stats.first_pass = uint32_t(std::min<uint64_t>(p0, std::numeric_limits<uint32_t>::max()));
    stats.resume_pass = stats.first_pass;
    ctx.first_pass = p0;
    ctx.pass_end = n_passes;
    if (pixels > 0 && p0 < n_passes)
        run_passes(ctx, stats);

    collect_stats(ctx, stats);
    stats.nan_samples = film_.nan_count() - nan_before;
    stats.rank_samples = stats.samples;
    if (group_) {
        // The whole image's counts on every rank.
        std::array<double, 7> v{double(stats.samples),        double(stats.rays),
                                double(stats.shadow_rays_avoided), double(stats.nan_samples),
                                double(stats.tiles_rendered), double(stats.tiles_skipped),
                                double(stats.pixels_skipped)};
        group_->sum(v);
        stats.samples = uint64_t(v[0]);
        stats.rays = uint64_t(v[1]);
        stats.shadow_rays_avoided = uint64_t(v[2]);
        stats.nan_samples = uint64_t(v[3]);
        stats.tiles_rendered = uint64_t(v[4]);
        stats.tiles_skipped = uint64_t(v[5]);
        stats.pixels_skipped = uint64_t(v[6]);
        stats.ranks = ranks_;
    }
    if (relmse_ || group_) {
        // The film as it is now (the snapshot may lag a cancelled tile's last samples).
        init_error_snapshot();
        stats.error_estimate = published_image_error();
        for (const auto &q : quadrants_)
            stats.tree_target = std::max(stats.tree_target,
                                         q->last_tree_target.load(std::memory_order_relaxed));
    } else {
        stats.error_estimate = sampling::image_error(film_, options_.min_samples_for_error);
    }
    fill_spp_histogram(stats);
    stats.wall_s = seconds_since(ctx.start);
    if (group_) {
        stats.comm_s = group_->comm_seconds() - comm_before;
        stats.wait_s = group_->wait_seconds() - wait_before;
    }
    stats.lock_wait_fraction =
        stats.wall_s > 0 ? stats.lock_wait_s / (stats.wall_s * double(threads_)) : 0.0;
    return stats;
}

}  // namespace tessera::sched
