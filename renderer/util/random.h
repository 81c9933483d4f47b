// Small random-number tools shared by the stochastic BSDFs (the layered random walk) and the
// media (renderer/media/medium.h): a 64-bit mix, a hash of float bit patterns, and PCG32.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>

#include "sampling/vecmath.h"

namespace tessera {

/// The 64-bit finaliser of MurmurHash3 (Appleby 2008): a bijective mix of all input bits.
inline constexpr uint64_t mix_bits_64(uint64_t v) {
    v ^= v >> 33;
    v *= 0xff51afd7ed558ccdull;
    v ^= v >> 33;
    v *= 0xc4ceb9fe1a85ec53ull;
    v ^= v >> 33;
    return v;
}

/// Hash of the bit patterns of `n` floats (order matters).
inline uint64_t hash_floats(const float *v, int n) {
    uint64_t h = 0x9e3779b97f4a7c15ull;
    for (int i = 0; i < n; ++i) {
        uint32_t bits;
        std::memcpy(&bits, &v[i], sizeof bits);
        h = mix_bits_64(h ^ (uint64_t(bits) + 0x632be59bd9b4e019ull * uint64_t(i + 1)));
    }
    return h;
}

/// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
/// Algorithms for Random Number Generation"): 64-bit LCG state, XSH-RR output. Seeded like
/// pbrt-v4's RNG(sequence index, offset). A plain value: each user (a BSDF call, a medium
/// walk) keeps its own on the stack.
class Pcg32 {
  public:
    Pcg32(uint64_t sequence, uint64_t offset) {
        inc_ = (sequence << 1u) | 1u;
        next();
        state_ += offset;
        next();
    }
    uint32_t next() {
        const uint64_t old = state_;
        state_ = old * 0x5851f42d4c957f2dull + inc_;
        const uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        const uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
    }
    /// Uniform in [0, 1), never 1.
    float uniform() { return std::min(kOneMinusEpsilon, float(next()) * 0x1p-32f); }
    Vec2f uniform2() {
        const float a = uniform();
        return {a, uniform()};
    }

  private:
    uint64_t state_ = 0, inc_ = 1;
};

}  // namespace tessera
