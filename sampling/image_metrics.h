// Error metrics between float RGB images, for convergence plots, regression tests and
// `tessera diff`.
//
// Definitions, per channel c over N pixels (total = mean over the three channels):
//   MSE_c    = (1/N) sum (v - ref)^2
//   RMSE_c   = sqrt(MSE_c)
//   relMSE_c = (1/N) sum (v - ref)^2 / (ref^2 + 0.01)   (pbrt-v4 imgtool's convention; the
//              0.01 keeps dark pixels from dominating)
//   PSNR_c   = 10 log10(peak^2 / MSE_c) in dB (+inf when MSE_c is 0)
//   MAE_c    = (1/N) sum |v - ref|   (mean absolute error)
//   robust relMSE: relMSE over the pixels left when the fraction f (default 0.1%) of pixels
//              with the largest relative error (the mean of their three channels' terms) is
//              left out: floor(f N) pixels, NaN and Inf errors first. The adaptive sampling
//              literature reports it this way, because on scenes with rare bright paths the
//              plain relMSE of one render is decided by a few fireflies.
// Sums run in double precision. Non-finite pixel values are not special-cased: they propagate.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace tessera::sampling {

/// A float RGB image: row-major from the top-left pixel, 3 interleaved floats per pixel
/// (linear unless stated otherwise). `data.size()` must be 3 * width * height.
struct RgbImage {
    uint32_t width = 0, height = 0;
    std::vector<float> data;

    RgbImage() = default;
    /// A width x height image filled with `value`.
    RgbImage(uint32_t w, uint32_t h, float value = 0.f)
        : width(w), height(h), data(std::size_t(w) * h * 3, value) {}
    /// Wraps existing interleaved RGB data (3 * w * h floats).
    RgbImage(uint32_t w, uint32_t h, std::vector<float> rgb)
        : width(w), height(h), data(std::move(rgb)) {}

    std::size_t pixel_count() const { return std::size_t(width) * height; }
    float &at(uint32_t x, uint32_t y, int c) {
        return data[(std::size_t(y) * width + x) * 3 + c];
    }
    float at(uint32_t x, uint32_t y, int c) const {
        return data[(std::size_t(y) * width + x) * 3 + c];
    }
};

/// A metric per channel (R, G, B) and over all channels (the mean of the three for MSE-like
/// metrics; for PSNR, computed from the total MSE).
struct ChannelMetric {
    std::array<double, 3> channel{};
    double total = 0;
};

/// All metrics of a test image against a reference.
struct ImageComparison {
    ChannelMetric mse, rmse, rel_mse, psnr, mae;
    ChannelMetric rel_mse_robust;  ///< relMSE without the 0.1% largest per-pixel errors
    std::array<double, 3> mean_test{}, mean_ref{};
};

/// The 0.01 of relMSE's denominator (ref^2 + 0.01), shared with the adaptive sampler's per-pixel
/// relMSE estimate (sampling/adaptive_error.h), so that the error the sampler targets is the
/// error `tessera converge` and `tessera diff` report.
inline constexpr double kRelMseEpsilon = 0.01;

/// Mean squared error. Throws std::invalid_argument when the sizes differ or an image is
/// malformed. Thread-safe (pure).
ChannelMetric mse(const RgbImage &test, const RgbImage &ref);
/// Root mean squared error (sqrt of each MSE entry; total = sqrt(total MSE)).
ChannelMetric rmse(const RgbImage &test, const RgbImage &ref);
/// Relative MSE, (v - ref)^2 / (ref^2 + 0.01) averaged (pbrt's convention).
ChannelMetric rel_mse(const RgbImage &test, const RgbImage &ref);
/// The fraction of pixels the robust relMSE leaves out by default.
inline constexpr double kRobustDropFraction = 0.001;
/// Relative MSE without the floor(drop_fraction * N) pixels of largest relative error (see
/// the definitions above). Throws std::invalid_argument as mse() does, and for a
/// drop_fraction outside [0, 1). Thread-safe (pure).
ChannelMetric rel_mse_robust(const RgbImage &test, const RgbImage &ref,
                             double drop_fraction = kRobustDropFraction);
/// Peak signal-to-noise ratio in dB for the given peak value; +inf where MSE is 0.
ChannelMetric psnr(const RgbImage &test, const RgbImage &ref, double peak = 1.0);
/// Mean absolute error, |v - ref| averaged.
ChannelMetric mae(const RgbImage &test, const RgbImage &ref);
/// Number of values (not pixels) that are NaN or +-Inf. Thread-safe (pure).
std::size_t nonfinite_count(const RgbImage &img);
/// Mean of each channel (double precision); zeros for an empty image.
std::array<double, 3> channel_means(const RgbImage &img);
/// Every metric at once (one pass over the pixels for the MSE-like ones).
ImageComparison compare_images(const RgbImage &test, const RgbImage &ref, double peak = 1.0);

/// Box-filter downsampling by an integer factor >= 1: output pixel (x, y) is the mean of the
/// input block [x*f, x*f+f) x [y*f, y*f+f). The output is ceil(w/f) x ceil(h/f); partial
/// blocks at the right and bottom edge average the pixels they have. Throws
/// std::invalid_argument for factor 0.
RgbImage box_downsample(const RgbImage &img, uint32_t factor);

}  // namespace tessera::sampling
