// Buffers of tens of megabytes that a frame walks through stage after stage: the real-time
// plugins' per-point records (kim's attribute vectors, fliptri's lattice sites and pixel data).
//
// Each stage of such a plugin touches every tile's records once, in Morton order, so a
// 1024x1024 frame crosses some 20000 distinct 4 KB pages per stage: more than the TLB holds,
// and in a virtual machine every miss is a two-level page walk. Backed by 2 MB transparent huge
// pages, the same buffers span 40-odd TLB entries. Measured at 1024x1024 on two threads, in
// interleaved runs against the same code on ordinary pages, identical images: `kim` 3-4 % less
// time per frame on the Bitterli box (three pairs) and on examples/realtime/thin-shadows (its
// a1 and a2 stages 2-8 ms each); `fliptri:extra=9,share_weights=1` on thin-shadows 2-3 % in
// one period of the shared machine, within the noise in a quieter one.
//
// HugePageAllocator asks the kernel for huge pages with madvise(MADV_HUGEPAGE) on 2 MB-aligned
// allocations of at least 2 MB (Linux with transparent huge pages in "madvise" or "always"
// mode; elsewhere, or when the kernel declines, the memory is ordinary and only the alignment
// differs). Smaller allocations go through std::allocator. Stateless: every instance is equal.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace tessera::sampling {

template <class T>
class HugePageAllocator {
  public:
    using value_type = T;
    /// Size and alignment of a huge page (x86-64 and AArch64 Linux defaults).
    static constexpr size_t kHugePage = size_t(2) << 20;

    HugePageAllocator() = default;
    template <class U>
    HugePageAllocator(const HugePageAllocator<U> &) noexcept {}

    T *allocate(size_t n) {
        if (n > std::allocator_traits<std::allocator<T>>::max_size(std::allocator<T>{}))
            throw std::bad_array_new_length();
        if (!huge(n))
            return std::allocator<T>{}.allocate(n);
        const size_t bytes = rounded(n);
        void *p = std::aligned_alloc(kHugePage, bytes);
        if (!p)
            throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
        // Advice only: a kernel without transparent huge pages returns EINVAL and the pages
        // stay ordinary.
        (void)madvise(p, bytes, MADV_HUGEPAGE);
#endif
        return static_cast<T *>(p);
    }

    void deallocate(T *p, size_t n) noexcept {
        if (!huge(n))
            std::allocator<T>{}.deallocate(p, n);
        else
            std::free(p);
    }

    template <class U>
    bool operator==(const HugePageAllocator<U> &) const noexcept {
        return true;
    }
    template <class U>
    bool operator!=(const HugePageAllocator<U> &) const noexcept {
        return false;
    }

    /// Whether an allocation of n elements is huge-page backed (and 2 MB aligned).
    static bool huge(size_t n) { return n * sizeof(T) >= kHugePage; }

  private:
    static size_t rounded(size_t n) { return (n * sizeof(T) + kHugePage - 1) / kHugePage * kHugePage; }
};

/// A std::vector whose storage is huge-page backed once it reaches 2 MB.
template <class T>
using LargeVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace tessera::sampling
