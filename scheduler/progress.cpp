// Progress bar on stderr.
#include "scheduler/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace tessera::sched {

double estimate_eta_s(const ProgressState &st) {
    double eta = -1.0;
    if (st.fraction > 0.0 && st.fraction <= 1.0)
        eta = st.elapsed_s * (1.0 - st.fraction) / st.fraction;
    if (st.time_budget_s > 0.0) {
        double left = std::max(0.0, st.time_budget_s - st.elapsed_s);
        eta = eta < 0.0 ? left : std::min(eta, left);
    }
    return eta;
}

std::string format_duration(double seconds) {
    if (!(seconds >= 0.0) || !std::isfinite(seconds)) return "--:--";
    auto total = static_cast<long long>(std::llround(seconds));
    long long h = total / 3600, m = (total / 60) % 60, s = total % 60;
    char buf[64];
    if (h > 0)
        std::snprintf(buf, sizeof buf, "%lld:%02lld:%02lld", h, m, s);
    else
        std::snprintf(buf, sizeof buf, "%lld:%02lld", m, s);
    return buf;
}

std::string format_progress_line(const ProgressState &st, int bar_width) {
    double f = std::clamp(st.fraction, 0.0, 1.0);
    int filled = static_cast<int>(f * bar_width);
    std::string line = "[";
    line.append(size_t(filled), '#');
    line.append(size_t(std::max(0, bar_width - filled)), '.');
    line += "] ";
    char buf[160];
    if (st.passes > 0)
        std::snprintf(buf, sizeof buf, "pass %u/%u", st.pass, st.passes);
    else
        std::snprintf(buf, sizeof buf, "pass %u", st.pass);
    line += buf;
    if (st.spp_total > 0)
        std::snprintf(buf, sizeof buf, "  spp %u/%u", st.spp_done, st.spp_total);
    else
        std::snprintf(buf, sizeof buf, "  spp %u", st.spp_done);
    line += buf;
    std::snprintf(buf, sizeof buf, "  %.1f Mrays/s  ETA %s", st.rays_per_s * 1e-6,
                  format_duration(estimate_eta_s(st)).c_str());
    line += buf;
    return line;
}

ProgressReporter::ProgressReporter(Mode mode, double redraw_interval_s)
    : redraw_interval_s_(redraw_interval_s), start_(std::chrono::steady_clock::now()) {
    enabled_ = mode == Mode::Always || (mode == Mode::Auto && isatty(STDERR_FILENO) == 1);
}

void ProgressReporter::begin(uint32_t passes, uint32_t spp_total, uint64_t total_samples,
                             double time_budget_s) {
    passes_ = passes;
    spp_total_ = spp_total;
    total_samples_ = total_samples;
    time_budget_s_ = time_budget_s;
    samples_ = 0;
    rays_ = 0;
    next_draw_ns_ = 0;
    start_ = std::chrono::steady_clock::now();
}

void ProgressReporter::begin_pass(uint32_t pass, uint32_t spp_done, uint32_t spp_target) {
    pass_ = pass;
    spp_done_ = spp_done;
    spp_target_ = spp_target;
    if (enabled_) {
        std::lock_guard<std::mutex> lock(draw_mutex_);
        draw(false);
    }
}

void ProgressReporter::add_work(uint64_t samples, uint64_t rays) {
    samples_.fetch_add(samples, std::memory_order_relaxed);
    rays_.fetch_add(rays, std::memory_order_relaxed);
    if (!enabled_) return;
    auto now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::steady_clock::now() - start_)
                      .count();
    if (now_ns < next_draw_ns_.load(std::memory_order_relaxed)) return;
    // Only one worker draws; the others go back to work at once.
    std::unique_lock<std::mutex> lock(draw_mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return;
    next_draw_ns_.store(now_ns + int64_t(redraw_interval_s_ * 1e9), std::memory_order_relaxed);
    draw(false);
}

void ProgressReporter::finish() {
    if (!enabled_) return;
    std::lock_guard<std::mutex> lock(draw_mutex_);
    draw(true);
}

ProgressState ProgressReporter::state() const {
    ProgressState st;
    st.pass = pass_.load(std::memory_order_relaxed);
    st.passes = passes_;
    st.spp_done = spp_done_.load(std::memory_order_relaxed);
    st.spp_target = spp_target_.load(std::memory_order_relaxed);
    st.spp_total = spp_total_;
    st.time_budget_s = time_budget_s_;
    st.elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    uint64_t samples = samples_.load(std::memory_order_relaxed);
    if (total_samples_ > 0) st.fraction = std::min(1.0, double(samples) / total_samples_);
    if (st.time_budget_s > 0)
        st.fraction = std::max(st.fraction, std::min(1.0, st.elapsed_s / st.time_budget_s));
    if (st.elapsed_s > 0) st.rays_per_s = rays_.load(std::memory_order_relaxed) / st.elapsed_s;
    return st;
}

void ProgressReporter::draw(bool final_line) {
    ProgressState st = state();
    if (final_line) st.spp_done = st.spp_target;
    std::string line = format_progress_line(st);
    // Pad with spaces so a shorter line fully overwrites the previous one.
    size_t len = line.size();
    if (len < last_line_length_) line.append(last_line_length_ - len, ' ');
    last_line_length_ = len;
    std::fprintf(stderr, "\r%s%s", line.c_str(), final_line ? "\n" : "");
    std::fflush(stderr);
}

}  // namespace tessera::sched
