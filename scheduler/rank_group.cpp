#include "scheduler/rank_group.h"

#include <algorithm>
#include <barrier>
#include <cstring>
#include <stdexcept>
#include <string>

namespace tessera::sched {

// Every collective: each rank posts a pointer to its data in its slot, all meet at the barrier,
// each reads what it needs from the others' slots into its own result, all meet again (nobody
// changes its data before everyone has read it), then each stores its result.
struct LocalRankGroup::Shared {
    explicit Shared(uint32_t n) : ranks(n), sync(std::ptrdiff_t(n)), slots(n), sizes(n) {}
    uint32_t ranks;
    std::barrier<> sync;
    std::vector<const void *> slots;
    std::vector<size_t> sizes;
};

std::vector<std::unique_ptr<LocalRankGroup>> LocalRankGroup::create(uint32_t ranks) {
    if (ranks == 0)
        throw std::invalid_argument("LocalRankGroup: at least one rank");
    auto shared = std::make_shared<Shared>(ranks);
    std::vector<std::unique_ptr<LocalRankGroup>> members;
    for (uint32_t r = 0; r < ranks; ++r)
        members.push_back(std::make_unique<LocalRankGroup>(shared, r));
    return members;
}

LocalRankGroup::LocalRankGroup(std::shared_ptr<Shared> shared, uint32_t rank)
    : shared_(std::move(shared)), rank_(rank) {}

LocalRankGroup::~LocalRankGroup() = default;

uint32_t LocalRankGroup::size() const { return shared_->ranks; }

void LocalRankGroup::sum(std::span<double> values) {
    const auto t0 = std::chrono::steady_clock::now();
    Shared &s = *shared_;
    s.slots[rank_] = values.data();
    s.sync.arrive_and_wait();
    std::vector<double> out(values.size(), 0.0);
    for (uint32_t r = 0; r < s.ranks; ++r) {
        const double *v = static_cast<const double *>(s.slots[r]);
        for (size_t i = 0; i < out.size(); ++i) out[i] += v[i];
    }
    s.sync.arrive_and_wait();
    std::copy(out.begin(), out.end(), values.begin());
    add_comm(t0);
}

void LocalRankGroup::min(std::span<uint64_t> values) {
    const auto t0 = std::chrono::steady_clock::now();
    Shared &s = *shared_;
    s.slots[rank_] = values.data();
    s.sync.arrive_and_wait();
    std::vector<uint64_t> out(values.begin(), values.end());
    for (uint32_t r = 0; r < s.ranks; ++r) {
        const uint64_t *v = static_cast<const uint64_t *>(s.slots[r]);
        for (size_t i = 0; i < out.size(); ++i) out[i] = std::min(out[i], v[i]);
    }
    s.sync.arrive_and_wait();
    std::copy(out.begin(), out.end(), values.begin());
    add_comm(t0);
}

void LocalRankGroup::all_gather(std::span<const double> mine, std::span<const size_t> counts,
                                std::span<double> all) {
    const auto t0 = std::chrono::steady_clock::now();
    Shared &s = *shared_;
    if (counts.size() != s.ranks || counts[rank_] != mine.size())
        throw std::invalid_argument("LocalRankGroup::all_gather: counts do not match");
    s.slots[rank_] = mine.data();
    s.sync.arrive_and_wait();
    size_t off = 0;
    for (uint32_t r = 0; r < s.ranks; ++r) {
        const double *v = static_cast<const double *>(s.slots[r]);
        if (off + counts[r] > all.size())
            throw std::invalid_argument("LocalRankGroup::all_gather: output too small");
        std::copy(v, v + counts[r], all.begin() + std::ptrdiff_t(off));
        off += counts[r];
    }
    s.sync.arrive_and_wait();
    add_comm(t0);
}

std::vector<std::vector<std::byte>> LocalRankGroup::gather_to_root(std::span<const std::byte> mine) {
    const auto t0 = std::chrono::steady_clock::now();
    Shared &s = *shared_;
    s.slots[rank_] = mine.data();
    s.sizes[rank_] = mine.size();
    s.sync.arrive_and_wait();
    std::vector<std::vector<std::byte>> pieces;
    if (rank_ == 0)
        for (uint32_t r = 0; r < s.ranks; ++r) {
            const std::byte *b = static_cast<const std::byte *>(s.slots[r]);
            pieces.emplace_back(b, b + s.sizes[r]);
        }
    s.sync.arrive_and_wait();
    add_comm(t0);
    return pieces;
}

bool LocalRankGroup::decide(bool flag) {
    const auto t0 = std::chrono::steady_clock::now();
    Shared &s = *shared_;
    const bool mine = flag;
    s.slots[rank_] = &mine;
    s.sync.arrive_and_wait();
    const bool out = *static_cast<const bool *>(s.slots[0]);
    s.sync.arrive_and_wait();
    add_comm(t0);
    return out;
}

void LocalRankGroup::barrier() {
    const auto t0 = std::chrono::steady_clock::now();
    shared_->sync.arrive_and_wait();
    add_comm(t0);
}

void LocalRankGroup::arrive() {
    const auto t0 = std::chrono::steady_clock::now();
    shared_->sync.arrive_and_wait();
    add_wait(t0);
}

std::vector<uint32_t> owned_pixels(const std::vector<Tile> &tiles, uint32_t width,
                                   uint32_t rank, uint32_t ranks) {
    std::vector<uint32_t> idx;
    for (size_t t = rank; t < tiles.size(); t += std::max(1u, ranks)) {
        const Tile &tile = tiles[t];
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x) idx.push_back(y * width + x);
    }
    return idx;
}

FilmGatherer::FilmGatherer(RankGroup &group, sampling::Film &film)
    : group_(group), film_(film), tiles_(make_morton_tiles(film.width(), film.height())),
      nan_sent_(film.nan_count()) {}

void FilmGatherer::gather() {
    const uint32_t ranks = group_.size(), me = group_.rank();
    group_.arrive();
    std::vector<std::byte> mine(sizeof(uint64_t));
    uint64_t nan_delta = 0;
    if (me != 0) {
        // Rank 0's own count already holds its drops.
        const uint64_t now = film_.nan_count();
        nan_delta = now - nan_sent_;
        nan_sent_ = now;
        film_.pack_pixels(owned_pixels(tiles_, film_.width(), me, ranks), mine);
    }
    std::memcpy(mine.data(), &nan_delta, sizeof nan_delta);
    std::vector<std::vector<std::byte>> pieces = group_.gather_to_root(mine);
    if (me != 0)
        return;
    for (uint32_t r = 1; r < ranks; ++r) {
        const std::vector<std::byte> &p = pieces.at(r);
        if (p.size() < sizeof(uint64_t))
            throw std::runtime_error("FilmGatherer: rank " + std::to_string(r) +
                                     " sent no header");
        uint64_t nans = 0;
        std::memcpy(&nans, p.data(), sizeof nans);
        film_.unpack_pixels(owned_pixels(tiles_, film_.width(), r, ranks),
                            std::span<const std::byte>(p).subspan(sizeof(uint64_t)), nans);
    }
}

}  // namespace tessera::sched
