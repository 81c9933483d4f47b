// Progress bar for progressive renders: pass, samples per pixel, Mrays/s and ETA on stderr.
//
// The bar is drawn only when enabled (by default: when stderr is a terminal), at most every
// `redraw_interval_s`, by whichever worker thread reports work when the interval has passed
// (try-lock, so workers never wait for the terminal). The line is rewritten in place with '\r'
// and finished with a newline by finish().
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace tessera::sched {

/// What one progress line shows.
struct ProgressState {
    uint32_t pass = 0;          ///< current pass, 1-based
    uint32_t passes = 0;        ///< planned passes (0: unknown)
    uint32_t spp_done = 0;      ///< samples per pixel completed before the current pass
    uint32_t spp_target = 0;    ///< samples per pixel when the current pass ends
    uint32_t spp_total = 0;     ///< samples per pixel requested (0: limited by time only)
    double fraction = 0;        ///< fraction of all planned work done, in [0, 1]
    double elapsed_s = 0;       ///< wall time since begin(), seconds
    double rays_per_s = 0;      ///< rays traced per second since begin()
    double time_budget_s = 0;   ///< time limit in seconds (0: none)
};

/// Estimated seconds left: elapsed * (1 - f) / f, capped by the time budget; negative when
/// unknown (nothing done yet). Pure.
double estimate_eta_s(const ProgressState &st);

/// Formats a progress line (no '\r' or newline), e.g.
/// "[#########.........] pass 3/7  spp 4/64  12.3 Mrays/s  ETA 0:42". Pure.
std::string format_progress_line(const ProgressState &st, int bar_width = 24);

/// Formats seconds as "m:ss" or "h:mm:ss"; "--:--" for a negative or non-finite value. Pure.
std::string format_duration(double seconds);

/// Thread-safe progress reporter. begin / begin_pass / finish are called by the thread that
/// drives the render; add_work by any worker thread.
class ProgressReporter {
  public:
    enum class Mode {
        Auto,    ///< draw when stderr is a terminal (isatty)
        Always,  ///< always draw (to stderr)
        Never,   ///< quiet
    };

    explicit ProgressReporter(Mode mode = Mode::Auto, double redraw_interval_s = 0.2);

    /// True when this reporter draws anything.
    bool enabled() const { return enabled_; }

    /// Starts a render of `passes` passes up to `spp_total` samples per pixel, about
    /// `total_samples` samples in all (0: unknown), with an optional time budget in seconds.
    void begin(uint32_t passes, uint32_t spp_total, uint64_t total_samples, double time_budget_s);
    /// Starts pass `pass` (1-based) that takes every pixel from spp_done to spp_target.
    void begin_pass(uint32_t pass, uint32_t spp_done, uint32_t spp_target);
    /// Reports finished work; redraws when due. Thread-safe and wait-free for the caller
    /// except when it is the one that redraws.
    void add_work(uint64_t samples, uint64_t rays);
    /// Draws the final state and ends the line.
    void finish();

    /// The current state (for tests and logs). Thread-safe.
    ProgressState state() const;

  private:
    void draw(bool final_line);

    bool enabled_ = false;
    double redraw_interval_s_ = 0.2;
    std::chrono::steady_clock::time_point start_;
    std::atomic<uint64_t> samples_{0}, rays_{0};
    std::atomic<int64_t> next_draw_ns_{0};
    std::atomic<uint32_t> pass_{0}, spp_done_{0}, spp_target_{0};
    uint32_t passes_ = 0, spp_total_ = 0;
    uint64_t total_samples_ = 0;
    double time_budget_s_ = 0;
    std::mutex draw_mutex_;
    size_t last_line_length_ = 0;
};

}  // namespace tessera::sched
