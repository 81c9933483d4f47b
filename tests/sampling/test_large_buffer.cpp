#include <doctest/doctest.h>

#include <cstdint>
#include <numeric>

#include "sampling/large_buffer.h"

using namespace tessera::sampling;

TEST_CASE("LargeVector: 2 MB-aligned storage from 2 MB on, ordinary below, vector semantics") {
    using Alloc = HugePageAllocator<uint32_t>;
    constexpr size_t kPage = Alloc::kHugePage;
    // The threshold is in bytes: 2 MB of uint32_t is 512 Ki elements.
    CHECK_FALSE(Alloc::huge(kPage / 4 - 1));
    CHECK(Alloc::huge(kPage / 4));
    CHECK(HugePageAllocator<double>::huge(kPage / 8));

    LargeVector<uint32_t> big(3 * kPage / 4 + 5);  // 3 MB + 20 bytes: rounded up to 4 MB
    CHECK(reinterpret_cast<uintptr_t>(big.data()) % kPage == 0);
    std::iota(big.begin(), big.end(), 0u);
    CHECK(big.front() == 0u);
    CHECK(big.back() == uint32_t(big.size() - 1));

    // Growth and copies keep the values (each allocation is freed the way it was made: ASan
    // reports a mismatch).
    LargeVector<uint32_t> copy = big;
    copy.resize(copy.size() * 2, 7u);
    CHECK(reinterpret_cast<uintptr_t>(copy.data()) % kPage == 0);
    CHECK(copy[big.size() - 1] == uint32_t(big.size() - 1));
    CHECK(copy.back() == 7u);

    // Small buffers come from std::allocator; shrinking to one also frees the big one.
    LargeVector<uint32_t> small(100, 3u);
    CHECK(small[99] == 3u);
    copy.assign(10, 1u);
    copy.shrink_to_fit();
    CHECK(copy.size() == 10);
    CHECK(copy[9] == 1u);

    // Element types larger than a word, with their own alignment.
    struct alignas(32) Wide {
        float v[8];
    };
    LargeVector<Wide> wide(kPage / sizeof(Wide) + 1);
    CHECK(reinterpret_cast<uintptr_t>(wide.data()) % kPage == 0);
    wide.back().v[7] = 2.f;
    CHECK(wide.back().v[7] == 2.f);
    CHECK(HugePageAllocator<Wide>() == HugePageAllocator<int>());
}
