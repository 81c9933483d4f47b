// Owen-scrambled Sobol sample values: a pure function of (seed, pixel, sample index, dimension).
//
// Algorithm (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)):
//   every 2D request (dimension pair d, d+1) takes the first two Sobol dimensions (van der Corput
//   and the second Sobol generator matrix, a (0,2)-sequence), shuffles the sample index with a
//   hash-seeded nested-uniform (Owen) scramble, then Owen-scrambles each coordinate with its own
//   seed. All seeds derive from hash(seed, px, py, d). Because the index shuffle maps every
//   power-of-two prefix {0..2^m-1} onto an aligned block of 2^m consecutive Sobol points, each
//   pixel's first 2^m samples form a (0,m,2)-net in every 2D pair, and each pair is decorrelated
//   from every other pair and every other pixel. 1D requests use the shuffled, scrambled van der
//   Corput sequence (stratified in every power-of-two prefix).
//
// The Owen scramble is the Laine-Karras style hash on bit-reversed values: each output bit depends
// only on the input bits above it, which is exactly a nested uniform permutation of the dyadic
// intervals (Burley 2020, section 3; Laine and Karras 2011).
//
// Dimension layout (docs/ARCHITECTURE.md, "The data that flows"):
//   dimensions 0 and 1  reserved for the film position inside the pixel (get_pixel_2d);
//   dimensions >= 2     the integrator's, consumed in call order: get_1d takes one dimension,
//                       get_2d takes two. start_pixel_sample() resets the counter to
//                       kFirstFreeDimension.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <string>

#include "sampling/vecmath.h"

namespace tessera::sampling {

/// Dimension pair (kPixelDimension, kPixelDimension + 1) gives the film offset inside the pixel.
inline constexpr uint32_t kPixelDimension = 0;
/// First dimension handed out by get_1d / get_2d after start_pixel_sample().
inline constexpr uint32_t kFirstFreeDimension = 2;

/// The integer steps of the scramble, written once for any 32-bit unsigned word type W: uint32_t
/// (the functions below) or a GCC vector of uint32_t, whose operators act lane by lane with the
/// same wrap-around arithmetic (the 8-lane path tracer, renderer/integrators/path_packet.cpp).
/// Both therefore compute bit-identical values.
namespace lanes {

/// Reverses the 32 bits of v (byte swap, then nibbles, pairs and bits within each byte).
template <class W>
[[gnu::always_inline]] inline constexpr W reverse_bits(W v) {
    v = (v >> 24) | ((v >> 8) & 0x0000ff00u) | ((v << 8) & 0x00ff0000u) | (v << 24);
    v = ((v >> 4) & 0x0f0f0f0fu) | ((v & 0x0f0f0f0fu) << 4);
    v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
    v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
    return v;
}

/// 32-bit integer finaliser with low bias ("lowbias32", C. Wellons 2018). Bijective.
template <class W>
[[gnu::always_inline]] inline constexpr W mix_bits(W x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

/// Salts of the seed hashes: the pixel hash's seed and row, a dimension, and the index shuffle.
inline constexpr uint32_t kSeedSalt = 0x9e3779b9u;
inline constexpr uint32_t kRowSalt = 0x85ebca6bu;
inline constexpr uint32_t kDimensionMul = 0xc2b2ae35u;
inline constexpr uint32_t kDimensionSalt = 0x27d4eb2fu;
inline constexpr uint32_t kShuffleSalt = 0x68bc21ebu;

/// Hash of (seed, px, py): the part of every scramble seed shared by a pixel's dimensions.
template <class W>
[[gnu::always_inline]] inline constexpr W hash_pixel(uint32_t seed, W px, W py) {
    const W h = mix_bits(mix_bits(seed ^ kSeedSalt) ^ px);
    return mix_bits((h + kRowSalt) ^ py);
}

/// Hash of a pixel hash and a dimension.
template <class W>
[[gnu::always_inline]] inline constexpr W hash_dimension(W pixel_hash, W dim) {
    return mix_bits(pixel_hash ^ (dim * kDimensionMul + kDimensionSalt));
}

/// Laine-Karras style permutation of a bit-reversed value: every step keeps "bit k depends on
/// bits <= k only" (Burley 2020, listing 3; Laine and Karras 2011).
template <class W>
[[gnu::always_inline]] inline constexpr W laine_karras(W x, W seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

/// The seed of the index shuffle and of coordinate c (0: x, 1: y) of dimension hash `h`.
template <class W>
[[gnu::always_inline]] inline constexpr W shuffle_seed(W h) {
    return mix_bits(h ^ kShuffleSalt);
}
template <class W>
[[gnu::always_inline]] inline constexpr W coordinate_seed(W h, uint32_t c) {
    return mix_bits(h + (c + 1u));
}

/// scrambled_sobol_1d_rev's value as 32-bit fixed point, from the dimension hash `h` and the
/// bit-reversed sample index.
template <class W>
[[gnu::always_inline]] inline constexpr W sobol_1d_rev(W h, W index_rev) {
    // shuffled = reverse(z); owen_sobol_dim0(shuffled) = reverse(LK(shuffled)).
    const W z = laine_karras(index_rev, shuffle_seed(h));
    return reverse_bits(laine_karras(reverse_bits(z), coordinate_seed(h, 0)));
}

/// scrambled_sobol_2d_rev's coordinates, still bit-reversed: the caller reverses x_rev and
/// y_rev. `dim1_reversed(z)` is sobol_dim1_reversed for W (table lookups or gathers).
template <class W, class Dim1Reversed>
[[gnu::always_inline]] inline constexpr void sobol_2d_rev(W h, W index_rev,
                                                          Dim1Reversed &&dim1_reversed, W &x_rev,
                                                          W &y_rev) {
    const W z = laine_karras(index_rev, shuffle_seed(h));  // reversed shuffle
    x_rev = laine_karras(reverse_bits(z), coordinate_seed(h, 0));
    y_rev = laine_karras(dim1_reversed(z), coordinate_seed(h, 1));
}

}  // namespace lanes

/// Reverses the 32 bits of v.
inline constexpr uint32_t reverse_bits_32(uint32_t v) { return lanes::reverse_bits(v); }

/// 32-bit integer finaliser with low bias ("lowbias32", C. Wellons 2018). Bijective.
inline constexpr uint32_t mix_bits_32(uint32_t x) { return lanes::mix_bits(x); }

/// Hash of (seed, px, py): the part of every scramble seed shared by a pixel's dimensions.
inline constexpr uint32_t hash_pixel(uint32_t seed, uint32_t px, uint32_t py) {
    return lanes::hash_pixel(seed, px, py);
}

/// Hash of a pixel hash and a dimension.
inline constexpr uint32_t hash_dimension(uint32_t pixel_hash, uint32_t dim) {
    return lanes::hash_dimension(pixel_hash, dim);
}

/// Hash of (seed, px, py, dimension), the root of every per-pixel scramble seed.
inline constexpr uint32_t hash_pixel_dimension(uint32_t seed, uint32_t px, uint32_t py,
                                               uint32_t dim) {
    return hash_dimension(hash_pixel(seed, px, py), dim);
}

/// Nested uniform (Owen) scramble of a 32-bit fixed-point value in [0,1): bit k of the result
/// (counting from the most significant) depends only on bits 0..k of x and on the seed, so
/// every dyadic interval is permuted as a whole (Burley 2020, listings 3 and 4).
inline constexpr uint32_t owen_scramble_32(uint32_t x, uint32_t seed) {
    return reverse_bits_32(lanes::laine_karras(reverse_bits_32(x), seed));
}

/// Sobol dimension 0 (van der Corput, base 2) of `index` as 32-bit fixed point.
inline constexpr uint32_t sobol_dim0(uint32_t index) { return reverse_bits_32(index); }

/// Sobol dimension 1 of `index` as 32-bit fixed point, bit by bit (primitive polynomial x + 1:
/// direction numbers v_1 = 2^31, v_k = v_{k-1} ^ (v_{k-1} >> 1)). Reference for the table below.
inline constexpr uint32_t sobol_dim1_reference(uint32_t index) {
    uint32_t result = 0;
    uint32_t v = 0x80000000u;
    for (; index != 0; index >>= 1) {
        if (index & 1u) result ^= v;
        v ^= v >> 1;
    }
    return result;
}

namespace detail {
/// The dimension-1 generator matrix applied to each byte of the index (it is linear over GF(2),
/// so the result is the XOR of four table entries).
inline constexpr std::array<std::array<uint32_t, 256>, 4> kSobolDim1Table = [] {
    std::array<std::array<uint32_t, 256>, 4> t{};
    for (uint32_t b = 0; b < 4; ++b)
        for (uint32_t i = 0; i < 256; ++i) t[b][i] = sobol_dim1_reference(i << (8 * b));
    return t;
}();
}  // namespace detail

/// Sobol dimension 1 of `index` as 32-bit fixed point (four table lookups).
inline constexpr uint32_t sobol_dim1(uint32_t index) {
    return detail::kSobolDim1Table[0][index & 0xffu] ^
           detail::kSobolDim1Table[1][(index >> 8) & 0xffu] ^
           detail::kSobolDim1Table[2][(index >> 16) & 0xffu] ^
           detail::kSobolDim1Table[3][index >> 24];
}

namespace detail {
/// reverse(sobol_dim1(reverse(z))) per byte of z. The Owen scramble works on bit-reversed
/// values and the index shuffle produces a bit-reversed index, so this composite (linear over
/// GF(2) like its parts) saves both reversals of the dimension-1 path.
inline constexpr std::array<std::array<uint32_t, 256>, 4> kSobolDim1ReversedTable = [] {
    std::array<std::array<uint32_t, 256>, 4> t{};
    for (uint32_t b = 0; b < 4; ++b)
        for (uint32_t i = 0; i < 256; ++i)
            t[b][i] = reverse_bits_32(sobol_dim1_reference(reverse_bits_32(i << (8 * b))));
    return t;
}();

/// reverse_bits_32 of both 32-bit halves of v at once (the 2D kernel's final reversals).
inline constexpr uint64_t reverse_bits_2x32(uint64_t v) {
    v = ((v >> 8) & 0x00ff00ff00ff00ffull) | ((v & 0x00ff00ff00ff00ffull) << 8);
    v = ((v >> 16) & 0x0000ffff0000ffffull) | ((v & 0x0000ffff0000ffffull) << 16);
    v = ((v >> 4) & 0x0f0f0f0f0f0f0f0full) | ((v & 0x0f0f0f0f0f0f0f0full) << 4);
    v = ((v >> 2) & 0x3333333333333333ull) | ((v & 0x3333333333333333ull) << 2);
    v = ((v >> 1) & 0x5555555555555555ull) | ((v & 0x5555555555555555ull) << 1);
    return v;
}
}  // namespace detail

/// reverse_bits_32(sobol_dim1(reverse_bits_32(z))) (four table lookups, no reversal).
inline constexpr uint32_t sobol_dim1_reversed(uint32_t z) {
    return detail::kSobolDim1ReversedTable[0][z & 0xffu] ^
           detail::kSobolDim1ReversedTable[1][(z >> 8) & 0xffu] ^
           detail::kSobolDim1ReversedTable[2][(z >> 16) & 0xffu] ^
           detail::kSobolDim1ReversedTable[3][z >> 24];
}

/// 32-bit fixed point to a float in [0, 1). Truncates to the top 24 bits: rounding to nearest
/// could carry a value across a dyadic boundary and break the stratification.
inline float fixed_to_unit_float(uint32_t x) {
    return std::min(static_cast<float>(x >> 8) * 0x1p-24f, kOneMinusEpsilon);
}

/// Laine-Karras hash of a bit-reversed value (the core of owen_scramble_32).
inline constexpr uint32_t laine_karras_32(uint32_t x, uint32_t seed) {
    return lanes::laine_karras(x, seed);
}

/// Owen scramble of Sobol dimension 0 of `index`: owen_scramble_32(sobol_dim0(index), seed)
/// with the two bit reversals that cancel removed.
inline constexpr uint32_t owen_sobol_dim0(uint32_t index, uint32_t seed) {
    return reverse_bits_32(laine_karras_32(index, seed));
}

/// Owen-scrambled 1D value of (pixel hash `h`, sample index): shuffled, scrambled van der Corput.
inline float scrambled_sobol_1d(uint32_t h, uint32_t index) {
    uint32_t shuffled = owen_scramble_32(index, lanes::shuffle_seed(h));
    return fixed_to_unit_float(owen_sobol_dim0(shuffled, lanes::coordinate_seed(h, 0)));
}

/// Owen-scrambled 2D value of (pixel hash `h`, sample index): shuffled, scrambled Sobol (0,2).
inline Vec2f scrambled_sobol_2d(uint32_t h, uint32_t index) {
    uint32_t shuffled = owen_scramble_32(index, lanes::shuffle_seed(h));
    uint32_t x = owen_sobol_dim0(shuffled, lanes::coordinate_seed(h, 0));
    uint32_t y = owen_scramble_32(sobol_dim1(shuffled), lanes::coordinate_seed(h, 1));
    return {fixed_to_unit_float(x), fixed_to_unit_float(y)};
}

/// scrambled_sobol_1d(h, index) given index_rev = reverse_bits_32(index): the same value with
/// two of its four bit reversals removed (the sampler caches index_rev per sample).
inline float scrambled_sobol_1d_rev(uint32_t h, uint32_t index_rev) {
    return fixed_to_unit_float(lanes::sobol_1d_rev(h, index_rev));
}

/// scrambled_sobol_2d(h, index) given index_rev = reverse_bits_32(index), bit-identical:
/// 2 reversals instead of 5 (the dimension-1 path stays in the reversed domain through
/// sobol_dim1_reversed, and the two output reversals run as one 64-bit reversal).
inline Vec2f scrambled_sobol_2d_rev(uint32_t h, uint32_t index_rev) {
    uint32_t x_rev = 0, y_rev = 0;
    lanes::sobol_2d_rev(h, index_rev, sobol_dim1_reversed, x_rev, y_rev);
    uint64_t xy = detail::reverse_bits_2x32((uint64_t(y_rev) << 32) | x_rev);
    return {fixed_to_unit_float(uint32_t(xy)), fixed_to_unit_float(uint32_t(xy >> 32))};
}

/// Which points a SobolSampler hands out.
enum class SamplePattern : uint8_t {
    /// Every request its own shuffled, Owen-scrambled low-dimensional Sobol sequence (the
    /// algorithm at the top of this file): each 2D pair is a (0,m,2)-net in every power-of-two
    /// prefix, and the pairs are decorrelated from each other. pbrt-v4's "zsobol" and
    /// "paddedsobol" are of this family; Tessera's default.
    Padded,
    /// One point of the kSobolMatrixDimensions-dimensional Sobol sequence per sample (Joe and
    /// Kuo's direction numbers), each dimension Owen-scrambled with its own per-pixel seed and
    /// the sample index left unshuffled: the dimensions stay jointly stratified, so an integrand
    /// that couples the film offset, a light choice and a point on the light (direct light on a
    /// diffuse wall) converges faster than 1/N. pbrt-v4's "sobol" sampler (with its Owen
    /// randomisation) draws its points from one such sequence over the whole image; here each
    /// pixel scrambles its own copy, so the values stay a pure function of (seed, pixel, index,
    /// dimension). Dimensions past the table continue with Padded's values.
    Sobol,
};

/// The pattern's name in logs and checkpoints: "padded" or "sobol".
inline const char *pattern_name(SamplePattern p) {
    return p == SamplePattern::Sobol ? "sobol" : "padded";
}

/// Dimensions of the Sobol generator-matrix table (sampling/sobol_matrices.inc).
inline constexpr uint32_t kSobolMatrixDimensions = 1024;
/// kSobolMatrices[j][k]: column k of Sobol dimension j's generator matrix, the direction number
/// v_k as 32-bit fixed point (scripts/make_sobol_matrices.py; Joe and Kuo 2008).
extern const uint32_t kSobolMatrices[kSobolMatrixDimensions][32];

/// Dimension `dim` (< kSobolMatrixDimensions) of Sobol point `index`, as 32-bit fixed point:
/// the XOR of the matrix columns of the index's set bits.
[[gnu::always_inline]] inline uint32_t sobol_sample_32(uint32_t dim, uint32_t index) {
    const uint32_t *m = kSobolMatrices[dim];
    uint32_t r = 0;
    for (; index != 0; index &= index - 1) r ^= m[std::countr_zero(index)];
    return r;
}

/// Dimension `dim` of Sobol point `index`, Owen-scrambled with the dimension hash `h`
/// (SamplePattern::Sobol's value of that dimension).
[[gnu::always_inline]] inline float scrambled_sobol_nd(uint32_t h, uint32_t dim, uint32_t index) {
    return fixed_to_unit_float(owen_scramble_32(sobol_sample_32(dim, index),
                                                lanes::coordinate_seed(h, 0)));
}

/// Per-pixel Owen-scrambled Sobol sampler. A cheap value type (32 bytes): each thread copies
/// it (or constructs its own) and calls start_pixel_sample() before each sample. Not thread-safe
/// per instance; every value is a pure function of (seed, px, py, index, dimension), so the
/// values never depend on which thread or pass draws them.
///
/// How an integrator continues after the scheduler drew the film offset:
///   SobolSampler s(seed);                 // the same seed as the scheduler's options
///   s.start_pixel_sample(cs.px, cs.py, cs.index);
///   float u = s.get_1d();                 // dimension 2, then 3, ...
/// cs.fx, cs.fy equal s.get_pixel_2d() for that (pixel, index).
class SobolSampler {
  public:
    /// `seed` selects an independent scrambling of every pixel and dimension.
    explicit SobolSampler(uint32_t seed = 0, SamplePattern pattern = SamplePattern::Padded)
        : seed_(seed), pattern_(pattern), pixel_hash_(hash_pixel(seed, 0, 0)) {}

    /// Starts sample `index` of pixel (px, py) and resets the dimension to `dimension`
    /// (default kFirstFreeDimension).
    void start_pixel_sample(uint32_t px, uint32_t py, uint32_t index,
                            uint32_t dimension = kFirstFreeDimension) {
        px_ = px;
        py_ = py;
        index_ = index;
        index_rev_ = reverse_bits_32(index);
        dim_ = dimension;
        pixel_hash_ = hash_pixel(seed_, px, py);
    }

    /// Next 1D value in [0,1); consumes one dimension. Always inlined: the path tracer calls
    /// these five times a bounce, and GCC stopped inlining them into it once its translation
    /// unit grew (a 3-5% slower render, measured; the unit's inline growth limit).
    [[gnu::always_inline]] float get_1d() {
        const uint32_t d = dim_++;
        const uint32_t h = hash_dimension(pixel_hash_, d);
        if (pattern_ == SamplePattern::Sobol && d < kSobolMatrixDimensions)
            return scrambled_sobol_nd(h, d, index_);
        return scrambled_sobol_1d_rev(h, index_rev_);
    }

    /// Next 2D value in [0,1)^2; consumes two dimensions (one stratified pair).
    [[gnu::always_inline]] Vec2f get_2d() {
        const uint32_t d = dim_;
        dim_ += 2;
        const uint32_t h = hash_dimension(pixel_hash_, d);
        if (pattern_ == SamplePattern::Sobol && d + 1 < kSobolMatrixDimensions)
            return {scrambled_sobol_nd(h, d, index_),
                    scrambled_sobol_nd(hash_dimension(pixel_hash_, d + 1), d + 1, index_)};
        return scrambled_sobol_2d_rev(h, index_rev_);
    }

    /// Consumes `n` dimensions without computing them: a caller that does not need a value
    /// keeps the dimension layout (and so every later value) as if it had drawn it.
    void skip(uint32_t n) { dim_ += n; }

    /// Film offset inside the pixel in [0,1)^2 from the reserved pair (kPixelDimension,
    /// kPixelDimension + 1). Does not advance the dimension counter.
    Vec2f get_pixel_2d() const {
        const uint32_t h = hash_dimension(pixel_hash_, kPixelDimension);
        if (pattern_ == SamplePattern::Sobol)
            return {scrambled_sobol_nd(h, kPixelDimension, index_),
                    scrambled_sobol_nd(hash_dimension(pixel_hash_, kPixelDimension + 1),
                                       kPixelDimension + 1, index_)};
        return scrambled_sobol_2d_rev(h, index_rev_);
    }

    /// Next dimension get_1d / get_2d will use.
    uint32_t dimension() const { return dim_; }
    uint32_t seed() const { return seed_; }
    SamplePattern pattern() const { return pattern_; }
    uint32_t sample_index() const { return index_; }

    /// One readable line of the sampler's state, for logs.
    std::string describe() const;

  private:
    uint32_t seed_ = 0;
    SamplePattern pattern_ = SamplePattern::Padded;
    uint32_t px_ = 0, py_ = 0;
    uint32_t index_ = 0;
    uint32_t index_rev_ = 0;  // reverse_bits_32(index_), shared by every dimension's shuffle
    uint32_t dim_ = kFirstFreeDimension;
    uint32_t pixel_hash_ = hash_pixel(0, 0, 0);  // hash_pixel(seed_, px_, py_)
};

}  // namespace tessera::sampling
