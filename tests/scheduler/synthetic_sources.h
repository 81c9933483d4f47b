// Synthetic sample sources for the scheduler tests (no Embree): analytic edges, smooth gradients
// with hash noise, fireflies, a NaN pixel and a "late firefly" that appears only after N samples.
// Every source counts the evaluate() calls per pixel with atomics, and (for images up to 2^20
// pixels) the sum and sum of squares of the sample indices, so a test can check that each pixel
// received exactly the indices 0 .. n-1, once each.
// TwoNoiseSource: flat 0.5 with two noise levels (inside a rectangle and outside).
// Also: VisitRecorder (checks the adaptive scheduler's tile visits through its hooks, with
// seeded random per-tile delays) and leaves_partition (region-tree leaves tile the grown rect).
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "sampling/region_tree.h"
#include "sampling/sample_source.h"
#include "scheduler/adaptive_scheduler.h"

namespace tessera::test {

/// SplitMix64 finaliser. Pure.
inline uint64_t mix64(uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

/// A uniform number in [0, 1) from (px, py, index, salt). Pure.
inline float hash01(uint32_t px, uint32_t py, uint32_t index, uint32_t salt) {
    uint64_t h = mix64((uint64_t(px) << 32 | py) ^ mix64(uint64_t(index) << 32 | salt));
    return float(h >> 40) * (1.0f / float(1u << 24));
}

/// What a SyntheticSource draws.
struct SyntheticParams {
    enum class Base {
        Flat,      ///< constant `level`
        Edge,      ///< step function: 1 where x + 0.37 y < edge_x (film position), else 0.05
        Gradient,  ///< smooth: 0.2 + 0.6 x / W (R), 0.2 + 0.6 y / H (G), 0.5 (B)
    };
    Base base = Base::Gradient;
    float level = 0.5f;
    float edge_x = -1;  ///< edge position (default: W / 2)
    /// Additive noise in [-noise, noise] per channel from a hash of (px, py, index), inside
    /// `noise_rect` (empty: the whole image).
    float noise = 0;
    sampling::PixelBounds noise_rect;
    /// A sample is a firefly (radiance firefly_value) with this probability.
    float firefly_probability = 0;
    float firefly_value = 1e4f;
    /// This pixel returns NaN radiance in every sample (-1: none).
    int nan_x = -1, nan_y = -1;
    /// "Late firefly": this pixel returns `late_value` for sample indices late_after,
    /// late_after + late_period, ... (-1: none). With an odd late_after and an even period all
    /// fireflies land in the half buffer, so the Dammertz error sees them (a value that changed
    /// for good would raise both halves alike and read as no error).
    int late_x = -1, late_y = -1;
    uint32_t late_after = 0, late_period = 16;
    float late_value = 1e12f;
    uint32_t salt = 7;
};

/// A thread-safe synthetic SampleSource with per-pixel evaluation counters.
class SyntheticSource final : public SampleSource {
  public:
    SyntheticSource(uint32_t w, uint32_t h, SyntheticParams p = {})
        : w_(w), h_(h), p_(p), track_indices_(uint64_t(w) * h <= (1u << 20)) {
        const size_t n = size_t(w) * h;
        count_ = std::make_unique<std::atomic<uint32_t>[]>(n);
        if (track_indices_) {
            index_sum_ = std::make_unique<std::atomic<uint64_t>[]>(n);
            index_sq_ = std::make_unique<std::atomic<uint64_t>[]>(n);
        }
        if (p_.edge_x < 0)
            p_.edge_x = float(w) * 0.5f;
    }

    uint32_t width() const override { return w_; }
    uint32_t height() const override { return h_; }
    std::string describe() const override { return "SyntheticSource"; }

    Sample evaluate(const CameraSample &cs) const override {
        const size_t i = size_t(cs.py) * w_ + cs.px;
        count_[i].fetch_add(1, std::memory_order_relaxed);
        if (track_indices_) {
            index_sum_[i].fetch_add(cs.index, std::memory_order_relaxed);
            index_sq_[i].fetch_add(uint64_t(cs.index) * cs.index, std::memory_order_relaxed);
        }
        total_.fetch_add(1, std::memory_order_relaxed);
        if (cancel_after_ && total_.load(std::memory_order_relaxed) >= cancel_after_)
            cancel_flag_->store(true);
        Sample s;
        s.rays = 2;
        s.depth = 1.f;
        s.albedo = Rgb(0.5f);
        s.radiance = radiance(cs);
        return s;
    }

    /// evaluate() calls for pixel (x, y).
    uint32_t count(uint32_t x, uint32_t y) const {
        return count_[size_t(y) * w_ + x].load(std::memory_order_relaxed);
    }
    /// True when pixel (x, y) received exactly `n` samples with indices 0 .. n-1 (checked by
    /// count, index sum and sum of squares; only count for images over 2^20 pixels).
    bool indices_exact(uint32_t x, uint32_t y, uint32_t n) const {
        if (count(x, y) != n)
            return false;
        if (!track_indices_)
            return true;
        const size_t i = size_t(y) * w_ + x;
        uint64_t m = n;
        uint64_t sum = m ? m * (m - 1) / 2 : 0;
        uint64_t sq = m ? (m - 1) * m * (2 * m - 1) / 6 : 0;
        return index_sum_[i].load() == sum && index_sq_[i].load() == sq;
    }
    /// All evaluate() calls.
    uint64_t total() const { return total_.load(); }

    /// Sets *flag once `n` samples were evaluated (0: never).
    void cancel_after(uint64_t n, std::atomic<bool> *flag) {
        cancel_after_ = n;
        cancel_flag_ = flag;
    }

    const SyntheticParams &params() const { return p_; }

  private:
    Rgb radiance(const CameraSample &cs) const {
        const float x = float(cs.px) + cs.fx, y = float(cs.py) + cs.fy;
        if (int(cs.px) == p_.nan_x && int(cs.py) == p_.nan_y)
            return Rgb(std::numeric_limits<float>::quiet_NaN());
        if (int(cs.px) == p_.late_x && int(cs.py) == p_.late_y && cs.index >= p_.late_after &&
            (cs.index - p_.late_after) % std::max(p_.late_period, 1u) == 0)
            return Rgb(p_.late_value);
        Rgb c;
        switch (p_.base) {
            case SyntheticParams::Base::Flat:
                c = Rgb(p_.level);
                break;
            case SyntheticParams::Base::Edge:
                c = Rgb(x + 0.37f * y < p_.edge_x ? 1.f : 0.05f);
                break;
            case SyntheticParams::Base::Gradient:
                c = Rgb(0.2f + 0.6f * x / float(w_), 0.2f + 0.6f * y / float(h_), 0.5f);
                break;
        }
        if (p_.noise > 0) {
            const sampling::PixelBounds &r = p_.noise_rect;
            bool inside = r.empty() || (int(cs.px) >= r.x0 && int(cs.px) < r.x1 &&
                                        int(cs.py) >= r.y0 && int(cs.py) < r.y1);
            if (inside) {
                c.r += p_.noise * (2.f * hash01(cs.px, cs.py, cs.index, p_.salt) - 1.f);
                c.g += p_.noise * (2.f * hash01(cs.px, cs.py, cs.index, p_.salt + 1) - 1.f);
                c.b += p_.noise * (2.f * hash01(cs.px, cs.py, cs.index, p_.salt + 2) - 1.f);
            }
        }
        if (p_.firefly_probability > 0 &&
            hash01(cs.px, cs.py, cs.index, p_.salt + 3) < p_.firefly_probability)
            c = Rgb(p_.firefly_value);
        return c;
    }

    uint32_t w_, h_;
    SyntheticParams p_;
    bool track_indices_;
    std::unique_ptr<std::atomic<uint32_t>[]> count_;
    std::unique_ptr<std::atomic<uint64_t>[]> index_sum_, index_sq_;
    mutable std::atomic<uint64_t> total_{0};
    uint64_t cancel_after_ = 0;
    std::atomic<bool> *cancel_flag_ = nullptr;
};

/// Factories for the named sources of the stress tests.
inline SyntheticParams edge_params() {
    SyntheticParams p;
    p.base = SyntheticParams::Base::Edge;
    return p;
}
inline SyntheticParams gradient_noise_params(float noise = 0.2f) {
    SyntheticParams p;
    p.base = SyntheticParams::Base::Gradient;
    p.noise = noise;
    return p;
}
inline SyntheticParams firefly_params(float probability = 0.002f) {
    SyntheticParams p = gradient_noise_params(0.05f);
    p.firefly_probability = probability;
    return p;
}
inline SyntheticParams nan_params(int x, int y) {
    SyntheticParams p = gradient_noise_params(0.05f);
    p.nan_x = x;
    p.nan_y = y;
    return p;
}

/// Records the tile visits of an AdaptiveScheduler through its hooks and checks the visit
/// invariants as they happen: no (pass, tile) twice, inactive pixels take no samples, active
/// pixels reach the pass target, and (deterministic mode, where the trees do not change during
/// a pass) the active mask equals the tree's pixel_active. Optional seeded random delays of a
/// few microseconds per tile shake up the interleavings.
class VisitRecorder {
  public:
    VisitRecorder(uint32_t w, uint32_t h, size_t tiles, uint64_t delay_seed = 0)
        : w_(w),
          delay_seed_(delay_seed),
          passes_seen_(tiles),
          was_inactive_(size_t(w) * h, 0),
          reopened_(size_t(w) * h, 0) {
        for (auto &a : passes_seen_)
            a.store(0);
    }

    /// Installs the hooks into `o`. `check_trees`: compare masks with the trees (deterministic
    /// mode only; set scheduler() before rendering).
    void install(sched::AdaptiveOptions &o, bool check_trees = false) {
        check_trees_ = check_trees;
        o.tile_hook = [this](const sched::Tile &t, uint32_t pass) { on_tile(t, pass); };
        o.visit_hook = [this](const sched::TileVisit &v) { on_visit(v); };
    }
    void set_scheduler(const sched::AdaptiveScheduler *s) { sched_ = s; }

    std::atomic<uint64_t> visits{0}, double_visits{0}, inactive_sampled{0}, active_short{0},
        mask_mismatch{0}, skipped_visits{0}, overshoot{0};

    /// Pixels that took samples in a visit after a visit in which they were inactive.
    uint64_t reopened_pixels() const {
        uint64_t n = 0;
        for (uint8_t r : reopened_)
            n += r;
        return n;
    }
    bool reopened(uint32_t x, uint32_t y) const { return reopened_[size_t(y) * w_ + x] != 0; }

  private:
    void on_tile(const sched::Tile &t, uint32_t pass) {
        if (!delay_seed_)
            return;
        uint64_t h = mix64(delay_seed_ ^ (uint64_t(t.order) << 24) ^ pass);
        if ((h & 7) != 0)
            return;
        // Busy-wait 0-19 us: sleeping would take at least the timer slack (~50 us).
        auto until = std::chrono::steady_clock::now() + std::chrono::microseconds((h >> 8) % 20);
        while (std::chrono::steady_clock::now() < until) {
        }
    }

    void on_visit(const sched::TileVisit &v) {
        visits.fetch_add(1, std::memory_order_relaxed);
        if (v.skipped)
            skipped_visits.fetch_add(1, std::memory_order_relaxed);
        const sched::Tile &t = *v.tile;
        if (v.pass < 64) {
            uint64_t bit = uint64_t(1) << v.pass;
            if (passes_seen_[t.order].fetch_or(bit) & bit)
                double_visits.fetch_add(1);
        } else {
            std::lock_guard<std::mutex> lock(mutex_);
            if (!late_passes_.insert({t.order, v.pass}).second)
                double_visits.fetch_add(1);
        }
        const uint32_t tw = t.width();
        for (uint32_t i = 0; i < t.pixel_count(); ++i) {
            const uint32_t x = t.x0 + i % tw, y = t.y0 + i / tw;
            const size_t k = size_t(y) * w_ + x;
            // The tile's visits are ordered (one owner at a time), so plain arrays are safe.
            if (!v.active[i]) {
                if (v.count_after[i] != v.count_before[i])
                    inactive_sampled.fetch_add(1);
                was_inactive_[k] = 1;
            } else {
                uint32_t want = std::max(v.count_before[i], v.target);
                if (v.count_after[i] != want)
                    active_short.fetch_add(1);
                if (v.count_after[i] > v.count_before[i] && was_inactive_[k])
                    reopened_[k] = 1;
            }
            if (v.count_after[i] > std::max(v.target, v.count_before[i]))
                overshoot.fetch_add(1);
            if (check_trees_ && sched_ && v.pass > 0 && sched_->adaptive()) {
                bool a = sched_->tree(int(v.quadrant)).pixel_active(int(x), int(y));
                if (a != (v.active[i] != 0))
                    mask_mismatch.fetch_add(1);
            }
        }
    }

    uint32_t w_;
    uint64_t delay_seed_;
    bool check_trees_ = false;
    const sched::AdaptiveScheduler *sched_ = nullptr;
    std::vector<std::atomic<uint64_t>> passes_seen_;
    std::vector<uint8_t> was_inactive_, reopened_;
    std::mutex mutex_;
    std::set<std::pair<uint32_t, uint32_t>> late_passes_;
};

/// True when the leaves of `tree` partition its grown rectangle: leaf bounds inside it, leaf
/// areas summing to its area, and every probed point (pixel centres, or 4096 hashed points for
/// large rectangles) inside exactly one leaf (half-open bounds). An unbuilt tree passes.
inline bool leaves_partition(const sampling::RegionTree &tree) {
    const sampling::PixelBounds &g = tree.grown();
    std::vector<sampling::FloatRect> leaves;
    for (const auto &n : tree.nodes())
        if (n.is_leaf())
            leaves.push_back(n.bounds);
    if (leaves.empty())
        return true;
    double area = 0;
    for (const auto &b : leaves) {
        if (b.x0 < g.x0 || b.y0 < g.y0 || b.x1 > g.x1 || b.y1 > g.y1)
            return false;
        if (!(b.x1 > b.x0 && b.y1 > b.y0))
            return false;
        area += (b.x1 - b.x0) * (b.y1 - b.y0);
    }
    if (std::abs(area - double(g.area())) > 1e-6 * double(g.area()))
        return false;
    auto inside_once = [&](double x, double y) {
        int n = 0;
        for (const auto &b : leaves)
            n += (x >= b.x0 && x < b.x1 && y >= b.y0 && y < b.y1);
        return n == 1;
    };
    if (g.area() * int64_t(leaves.size()) <= (int64_t(1) << 22)) {
        for (int y = g.y0; y < g.y1; ++y)
            for (int x = g.x0; x < g.x1; ++x)
                if (!inside_once(x + 0.5, y + 0.5))
                    return false;
    } else {
        for (uint32_t i = 0; i < 4096; ++i) {
            double x = g.x0 + hash01(i, 1, 2, 3) * g.width();
            double y = g.y0 + hash01(i, 4, 5, 6) * g.height();
            if (!inside_once(x, y))
                return false;
        }
    }
    return true;
}

/// Uneven difficulty: flat 0.5 with hash noise of amplitude `hard` inside `rect` and `easy`
/// elsewhere (so the easy part has an error estimate too, only a smaller one). Thread-safe.
class TwoNoiseSource final : public SampleSource {
  public:
    TwoNoiseSource(uint32_t w, uint32_t h, sampling::PixelBounds rect, float hard, float easy)
        : w_(w), h_(h), rect_(rect), hard_(hard), easy_(easy) {}
    uint32_t width() const override { return w_; }
    uint32_t height() const override { return h_; }
    std::string describe() const override { return "TwoNoiseSource"; }
    Sample evaluate(const CameraSample &cs) const override {
        const bool inside = int(cs.px) >= rect_.x0 && int(cs.px) < rect_.x1 &&
                            int(cs.py) >= rect_.y0 && int(cs.py) < rect_.y1;
        const float u = 2.f * hash01(cs.px, cs.py, cs.index, 11) - 1.f;
        Sample s;
        s.rays = 1;
        s.radiance = Rgb(0.5f + (inside ? hard_ : easy_) * u);
        return s;
    }

  private:
    uint32_t w_, h_;
    sampling::PixelBounds rect_;
    float hard_, easy_;
};


}  // namespace tessera::test
