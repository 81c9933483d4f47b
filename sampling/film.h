// Per-pixel accumulation for the progressive renderer (docs/ARCHITECTURE.md, "The data that flows", item 5).
//
// Each pixel keeps, in double precision, the sum of the radiance of its accepted samples and the
// "half buffer": the sum of the accepted samples with an odd sample index (Dammertz et al. 2010,
// "A Hierarchical Automatic Stopping Condition for Monte Carlo Global Illumination", section 3:
// the pixel error compares the mean of all samples with the mean of the half buffer). Doubles
// keep the mean of 10^6 samples to about 1e-10 relative error (floats would lose ~1e-2).
// AOVs (albedo, normal, depth) are running means in float over the samples that hit something
// (finite depth); a running mean m += (x - m) / n stays within ~sqrt(n) ulps, enough for AOVs.
// Only the AOVs the film was built with (an AovSet, default none) are kept: each lives in its
// own array beside the beauty array, and one that was not asked for costs no memory and no
// work (what a scene does not need costs nothing). Beauty: 64 bytes a pixel; albedo and normal add 12 each, depth 4.
//
// Prefix snapshots (optional, for the prefix error estimator of sampling/adaptive_error.h): a
// film built with keep_prefix also records, per pixel, the mean of its first 2^k samples each
// time its sample count reaches a power of two 2^k, keeping the last two such snapshots (32
// bytes a pixel, float means). A film without them costs nothing for them.
//
// Non-finite radiance: a sample whose radiance has a NaN or Inf component is dropped before it
// reaches any sum and counted in nan_count(). It still counts as *taken* (sample_count(), the
// spp layer, and the index the next pass starts at), but not in the mean. pbrt-v4 zeroes such
// samples instead, which biases the pixel towards black; dropping keeps the mean of the finite
// samples.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sampling/aov_set.h"
#include "sampling/sample_source.h"
#include "sampling/vecmath.h"

namespace tessera::sampling {

/// Everything the film knows about one pixel, in the precision it keeps it. A policy's view.
struct PixelStats {
    std::array<double, 3> mean{};       ///< mean radiance of the accepted samples (0 if none)
    std::array<double, 3> half_mean{};  ///< mean radiance of the accepted odd-index samples
    uint32_t taken = 0;                 ///< samples taken, dropped ones included
    uint32_t accepted = 0;              ///< samples with finite radiance (in `mean`)
    uint32_t half_accepted = 0;         ///< accepted samples with an odd index (in `half_mean`)
    uint32_t hits = 0;                  ///< samples in the AOV means (0 for a film without AOVs)
    /// True when the film keeps prefix snapshots (Film::keeps_prefix()); then prefix_mean is
    /// the mean of the accepted samples among the pixel's first 2^(k-1) samples, where 2^k is
    /// the largest power of two <= taken (so at most half the samples; zero when taken < 2),
    /// and prefix_accepted how many those were.
    bool has_prefix = false;
    std::array<double, 3> prefix_mean{};
    uint32_t prefix_accepted = 0;
};

/// Per-pixel sums of a progressive render. add_sample is safe to call concurrently for
/// DIFFERENT pixels without locks (each pixel is written by one thread at a time, its tile's
/// owner); reads of a pixel must not overlap writes of the same pixel. nan_count() is atomic.
class Film {
  public:
    /// A film of width x height pixels, all sums zero, keeping the AOVs in `aovs` (default:
    /// none, beauty only) and, with keep_prefix, the prefix snapshots (see the file comment).
    Film(uint32_t width, uint32_t height, AovSet aovs = {}, bool keep_prefix = false);

    Film(const Film &) = delete;
    Film &operator=(const Film &) = delete;

    uint32_t width() const { return width_; }
    uint32_t height() const { return height_; }
    /// The AOVs this film keeps (fixed at construction).
    AovSet aovs() const { return aovs_; }
    /// True when the film keeps prefix snapshots (fixed at construction).
    bool keeps_prefix() const { return !prefix_.empty(); }

    /// Accumulates sample `sample_index` of pixel (px, py). Odd indices also go to the half
    /// buffer. Non-finite radiance drops the sample (see the file comment). The sample's
    /// albedo/normal/depth go only to the AOVs the film keeps; a film without AOVs ignores them
    /// (and leaves `hits` at 0). Thread-safe for different pixels; (px, py) must be inside.
    void add_sample(uint32_t px, uint32_t py, uint32_t sample_index, const Sample &s);

    /// Number of samples dropped for NaN or Inf radiance since construction or clear().
    uint64_t nan_count() const { return nan_count_.load(std::memory_order_relaxed); }

    /// Samples taken by pixel (px, py), dropped ones included: the index its next sample gets
    /// when passes take indices in order.
    uint32_t sample_count(uint32_t px, uint32_t py) const { return at(px, py).taken; }

    /// Full statistics of one pixel (double precision).
    PixelStats pixel_stats(uint32_t px, uint32_t py) const;

    /// Mean radiance of pixel (px, py) over its accepted samples; black when it has none.
    Rgb mean(uint32_t px, uint32_t py) const;

    /// Sum over all pixels of the samples taken (dropped ones included). Not thread-safe
    /// against concurrent add_sample.
    uint64_t total_samples() const;

    /// Resets every sum and counter to zero. Not thread-safe.
    void clear();

    // Resolves: row-major from the top-left pixel, interleaved channels. Not thread-safe
    // against concurrent add_sample. The resolve of an AOV the film does not keep returns an
    // empty vector (callers check aovs() first).
    /// Mean radiance, 3 floats per pixel (linear Rec.709 RGB).
    std::vector<float> beauty_rgb() const;
    /// Mean of the half buffer (odd-index samples), 3 floats per pixel.
    std::vector<float> half_rgb() const;
    /// Mean first-hit albedo over the samples that hit, 3 floats per pixel (0 if none hit).
    std::vector<float> albedo_rgb() const;
    /// Mean first-hit shading normal over the samples that hit (not renormalised), 3 floats
    /// per pixel, world space (0 if none hit).
    std::vector<float> normal_xyz() const;
    /// Mean first-hit distance over the samples that hit, in scene units; +inf if none hit.
    std::vector<float> depth() const;
    /// Samples taken per pixel (dropped ones included), 1 float per pixel.
    std::vector<float> spp() const;

    /// Film memory per pixel in bytes for a film keeping `aovs`: the beauty data plus the AOV
    /// arrays (the memory limits use it before a film exists).
    static constexpr size_t bytes_per_pixel_for(AovSet aovs, bool keep_prefix = false) {
        return sizeof(PixelData) + (aovs.has(Aov::Albedo) ? sizeof(Float3) : 0) +
               (aovs.has(Aov::Normal) ? sizeof(Float3) : 0) +
               (aovs.has(Aov::Depth) ? sizeof(float) : 0) +
               (keep_prefix ? sizeof(PrefixData) : 0);
    }
    /// Film memory per pixel of this film in bytes (beauty plus its AOVs).
    size_t bytes_per_pixel() const { return bytes_per_pixel_for(aovs_, keeps_prefix()); }

    /// One readable line: size, memory, samples, dropped samples.
    std::string describe() const;

    /// The raw beauty accumulation state of one pixel, exactly as the film keeps it
    /// (checkpoints). 64 bytes.
    struct PixelData {
        double sum[3] = {0, 0, 0};       // radiance sum of accepted samples
        double half_sum[3] = {0, 0, 0};  // radiance sum of accepted odd-index samples
        uint32_t taken = 0;
        uint32_t accepted = 0;
        uint32_t half_accepted = 0;
        uint32_t hits = 0;               // samples in the AOV running means
    };
    /// The prefix snapshots of one pixel (films with keep_prefix): the means of the accepted
    /// samples among its first 2^k and first 2^(k-1) samples, 2^k the largest power of two
    /// <= taken (zero before the count reaches them), and how many of those were accepted.
    /// 32 bytes.
    struct PrefixData {
        float cur_mean[3] = {0, 0, 0};
        float prev_mean[3] = {0, 0, 0};
        uint32_t cur_accepted = 0;
        uint32_t prev_accepted = 0;
    };
    using Float3 = std::array<float, 3>;
    /// The raw AOV running means, row-major, one entry per pixel for each AOV the film keeps
    /// and empty for the others.
    struct AovData {
        std::vector<Float3> albedo;
        std::vector<Float3> normal;
        std::vector<float> depth;
    };

    /// Raw pixel state, row-major (checkpoint writing). Not thread-safe against add_sample.
    const std::vector<PixelData> &raw_pixels() const { return pixels_; }
    /// Raw AOV means (checkpoint writing). Not thread-safe against add_sample.
    const AovData &raw_aovs() const { return aov_; }
    /// Raw prefix snapshots, row-major; empty unless keeps_prefix(). Not thread-safe against
    /// add_sample.
    const std::vector<PrefixData> &raw_prefix() const { return prefix_; }
    /// Replaces the whole accumulation state (checkpoint resume): `pixels` must hold
    /// width * height entries, and `aovs` that many for each AOV the film keeps and none for
    /// the others, and `prefix` that many when the film keeps prefix snapshots (else none).
    /// Throws std::invalid_argument otherwise. Not thread-safe.
    void restore(std::vector<PixelData> pixels, AovData aovs, uint64_t nan_count,
                 std::vector<PrefixData> prefix = {});

    /// Bytes one pixel's whole state takes in pack_pixels: its PixelData, the AOV means the
    /// film keeps and its prefix snapshots.
    size_t packed_pixel_bytes() const;
    /// Appends the exact state of the pixels with row-major indices `indices` to `out` (a
    /// distributed render sends the pixels a rank owns to rank 0 this way). Not thread-safe
    /// against add_sample.
    void pack_pixels(std::span<const uint32_t> indices, std::vector<std::byte> &out) const;
    /// Overwrites the pixels `indices` with the state pack_pixels wrote for the same indices
    /// on a film of the same size, AOVs and prefix setting; adds `nan_count` to nan_count().
    /// Throws std::invalid_argument when `in` has not exactly that size. Not thread-safe.
    void unpack_pixels(std::span<const uint32_t> indices, std::span<const std::byte> in,
                       uint64_t nan_count = 0);

  private:

    const PixelData &at(uint32_t px, uint32_t py) const {
        return pixels_[size_t(py) * width_ + px];
    }
    PixelData &at(uint32_t px, uint32_t py) { return pixels_[size_t(py) * width_ + px]; }

    uint32_t width_ = 0, height_ = 0;
    AovSet aovs_;
    std::vector<PixelData> pixels_;
    AovData aov_;
    std::vector<PrefixData> prefix_;
    std::atomic<uint64_t> nan_count_{0};
};

}  // namespace tessera::sampling
