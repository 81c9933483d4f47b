// The ranks of a distributed render: N processes (or, in the tests, N threads) that render one
// image together, each its own share of the tiles (docs/ARCHITECTURE.md, "Distributed
// rendering").
//
// RankGroup is the scheduler's whole view of the communication: a handful of collectives, each
// called by every rank in the same order (as MPI requires). The scheduler knows nothing of MPI:
// the `tessera` executable plugs in an MPI implementation (renderer/app/mpi_group.h, built with
// TESSERA_MPI), and the tests use LocalRankGroup, N ranks as threads of one process.
//
// Tile ownership. Tiles are dealt to ranks round-robin along the Morton curve (tile t belongs
// to rank t mod N), so that every rank holds a spread of the whole image at tile granularity
// (8x8 pixels): an expensive corner of the image costs every rank about the same, and no rank
// holds one stripe.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "sampling/film.h"
#include "scheduler/tiles.h"

namespace tessera::sched {

/// The rank that renders tile `t` (its Morton index) among `ranks` ranks (see the file comment).
inline uint32_t tile_owner(size_t t, uint32_t ranks) { return ranks > 1 ? uint32_t(t % ranks) : 0u; }

/// Collectives across the ranks of one render. Every rank calls each one, in the same order,
/// with the same sizes (except where a size is per rank). Implementations add the wall time
/// spent inside them to comm_seconds().
class RankGroup {
  public:
    virtual ~RankGroup() = default;
    virtual uint32_t rank() const = 0;
    virtual uint32_t size() const = 0;

    /// Element-wise sum over the ranks, in place, the result on every rank. Integer-valued
    /// doubles up to 2^53 sum exactly; a value that only one rank contributes (the others give
    /// zero) arrives unchanged, bit for bit.
    virtual void sum(std::span<double> values) = 0;
    /// Element-wise minimum over the ranks, in place, on every rank.
    virtual void min(std::span<uint64_t> values) = 0;
    /// Concatenation of every rank's `mine` in rank order, on every rank; `counts[r]` is the
    /// length rank r gives (the same table on every rank), `all` holds their sum.
    virtual void all_gather(std::span<const double> mine, std::span<const size_t> counts,
                            std::span<double> all) = 0;
    /// Rank 0 receives every rank's bytes (rank order; its own first); the others receive
    /// nothing. Returns the per-rank pieces on rank 0, an empty vector elsewhere.
    virtual std::vector<std::vector<std::byte>> gather_to_root(std::span<const std::byte> mine) = 0;
    /// Rank 0's value of `flag` on every rank (rank 0 decides).
    virtual bool decide(bool flag) = 0;
    /// Waits for every rank.
    virtual void barrier() = 0;
    /// Waits for every rank before an exchange, counted in wait_seconds() instead of
    /// comm_seconds(): the time a rank that finished its share early waits for the slowest
    /// (load imbalance), apart from the exchange's own cost.
    virtual void arrive() = 0;

    /// Wall seconds this rank spent inside the collectives except arrive(): the cost of the
    /// communication itself (and of what skew remains after an arrive()).
    double comm_seconds() const { return comm_s_; }
    /// Wall seconds this rank waited in arrive() for the other ranks.
    double wait_seconds() const { return wait_s_; }

  protected:
    /// Adds the time since `t0` to comm_seconds(); implementations call it on return.
    void add_comm(std::chrono::steady_clock::time_point t0) {
        comm_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    /// Adds the time since `t0` to wait_seconds() (arrive()).
    void add_wait(std::chrono::steady_clock::time_point t0) {
        wait_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }

  private:
    double comm_s_ = 0, wait_s_ = 0;
};

/// N ranks as threads of one process (tests, and a check of the protocol without MPI): make
/// a group with LocalRankGroup::create(N), hand member(r) to the thread of rank r.
class LocalRankGroup final : public RankGroup {
  public:
    struct Shared;
    /// The N members of a new group; member r is rank r. Each member is used by one thread.
    static std::vector<std::unique_ptr<LocalRankGroup>> create(uint32_t ranks);

    LocalRankGroup(std::shared_ptr<Shared> shared, uint32_t rank);
    ~LocalRankGroup() override;
    uint32_t rank() const override { return rank_; }
    uint32_t size() const override;
    void sum(std::span<double> values) override;
    void min(std::span<uint64_t> values) override;
    void all_gather(std::span<const double> mine, std::span<const size_t> counts,
                    std::span<double> all) override;
    std::vector<std::vector<std::byte>> gather_to_root(std::span<const std::byte> mine) override;
    bool decide(bool flag) override;
    void barrier() override;
    void arrive() override;

  private:
    std::shared_ptr<Shared> shared_;
    uint32_t rank_ = 0;
};

/// The row-major indices of the pixels of the tiles `rank` owns among `ranks` (Morton tile
/// order, row-major within a tile): the order in which gather_film sends them.
std::vector<uint32_t> owned_pixels(const std::vector<Tile> &tiles, uint32_t width,
                                   uint32_t rank, uint32_t ranks);

/// Brings the pixels of a distributed render into rank 0's film: every rank sends the exact
/// state of the pixels of its own tiles (Film::pack_pixels), rank 0 overwrites its copies of
/// them; the other ranks' films stay as they are. Collective. Samples a rank's film dropped
/// for NaN/Inf since the gatherer was made (or since the last gather) are added to rank 0's
/// count.
class FilmGatherer {
  public:
    /// `film`'s current NaN count is the base every rank shares (zero, or a checkpoint's).
    FilmGatherer(RankGroup &group, sampling::Film &film);
    void gather();

  private:
    RankGroup &group_;
    sampling::Film &film_;
    std::vector<Tile> tiles_;
    uint64_t nan_sent_ = 0;
};

}  // namespace tessera::sched
