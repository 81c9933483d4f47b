// Striped reader-writer locks for the adaptive scheduler's region trees (MoonRay: Jeffery 2019,
// "Global Adaptive Sampling Hierarchies in Production Ray Tracing", section 4.3).
//
// A quadrant's tree is read by every tile of the quadrant (thousands of times per pass) and
// written once per pass. A single std::shared_mutex would make every reader write the same
// cache line (its reader count), so readers are spread over an array of p cache-line-aligned
// locks: tile (x, y) of the tile grid uses stripe (y * (p/2 + 1) + x) mod p. p/2 + 1 is odd, so
// co-prime with the power-of-two p, and for p >= 8 no two of the 8 neighbours of a tile share its
// stripe (horizontal: +-1, vertical: +-(p/2 + 1), diagonal: +-p/2, +-(p/2 + 2), none 0 mod p).
// A writer publishes new data (e.g. flips an atomic index to a freshly built copy) and then
// sweeps: it takes and releases each stripe's writer lock in turn, after which no reader can
// still use the old copy. MoonRay's writer holds the lock for the whole update; publishing first
// means readers wait at most for one stripe's hand-over, and the writer never holds more than
// one lock (TSan's deadlock detector aborts beyond 64 locks held by one thread).
//
// Wait time is measured cheaply: a try-lock first; only when it fails is the blocking
// acquisition timed with steady_clock. The uncontended path therefore costs no clock read and
// reports 0 (its real cost, one atomic RMW, is far below the clock's resolution anyway).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <shared_mutex>

namespace tessera::sched {

/// Smallest stripe count for which 8-neighbours never share a stripe.
inline constexpr uint32_t kMinLockStripes = 8;

/// The stripe of tile-grid cell (x, y) for a power-of-two stripe count p (>= 2). Pure.
inline constexpr uint32_t stripe_index(uint32_t x, uint32_t y, uint32_t p) {
    return (y * (p / 2 + 1) + x) & (p - 1);
}

/// Rounds n up to a power of two, at least kMinLockStripes (and at most 2^16). Pure.
inline constexpr uint32_t round_stripe_count(uint32_t n) {
    uint32_t p = kMinLockStripes;
    while (p < n && p < (1u << 16))
        p <<= 1;
    return p;
}

/// An array of cache-line-aligned reader-writer locks. lock_* return the seconds the caller
/// waited (0 when the lock was free at once). All methods are thread-safe.
class StripedRwLocks {
  public:
    /// `stripes` is rounded with round_stripe_count.
    explicit StripedRwLocks(uint32_t stripes = 64)
        : size_(round_stripe_count(stripes)), locks_(new Stripe[size_]) {}

    StripedRwLocks(const StripedRwLocks &) = delete;
    StripedRwLocks &operator=(const StripedRwLocks &) = delete;

    /// Number of stripes (a power of two >= kMinLockStripes).
    uint32_t size() const { return size_; }
    /// The stripe of tile-grid cell (x, y).
    uint32_t index(uint32_t x, uint32_t y) const { return stripe_index(x, y, size_); }

    /// Takes stripe s shared. Returns the seconds waited.
    double lock_shared(uint32_t s) {
        std::shared_mutex &m = locks_[s].mutex;
        if (m.try_lock_shared())
            return 0.0;
        auto t0 = std::chrono::steady_clock::now();
        m.lock_shared();
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    void unlock_shared(uint32_t s) { locks_[s].mutex.unlock_shared(); }

    /// Takes and releases each stripe's writer lock in turn, in index order: on return, every
    /// reader that held a stripe when sweep() was called has released it. With the data readers
    /// look up published (e.g. an atomic index) before the sweep, the old data is then unused.
    /// Holds one lock at a time. Returns the seconds waited.
    double sweep() {
        double waited = 0;
        for (uint32_t s = 0; s < size_; ++s) {
            std::shared_mutex &m = locks_[s].mutex;
            if (!m.try_lock()) {
                auto t0 = std::chrono::steady_clock::now();
                m.lock();
                waited +=
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            }
            m.unlock();
        }
        return waited;
    }

  private:
    // One lock per cache line: readers of different stripes never share a line.
    struct alignas(64) Stripe {
        std::shared_mutex mutex;
    };

    uint32_t size_;
    std::unique_ptr<Stripe[]> locks_;
};

}  // namespace tessera::sched
