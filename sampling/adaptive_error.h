// Per-pixel and per-region error estimates for adaptive stopping (Dammertz, Hanika, Keller,
// Lensch 2010, "A Hierarchical Automatic Stopping Condition for Monte Carlo Global
// Illumination", section 3; used by MoonRay's region trees, Jeffery 2019, and by region_tree.h).
//
//  - pixel error   e_p = sum_c |I_c - A_c| / sqrt(I_r + I_g + I_b), with I the mean of all
//    accepted samples and A the mean of the half buffer (the accepted odd-index samples). It
//    compares two estimates of the same pixel, one from half the samples, and divides by the
//    square root of the brightness as a rough tone-mapping sensitivity (a deviation matters less
//    on a bright pixel). Units: sqrt(radiance); it falls as 1/sqrt(spp) for a fixed pixel.
//  - region error  e_b = (r / N) * sum_{p in b} e_p, r = sqrt(A_b / A_image), N = A_b the area of
//    the region in pixels, i.e. sum e_p / sqrt(A_b * A_image). A region whose pixels all have
//    error e has e_b = e * sqrt(A_b / A_image): the whole image has e_b = e, a small region
//    less, so small regions are allowed a larger per-pixel error.
//
// A pixel without an estimate (too few samples) has error +inf; a region containing one has
// region error +inf and stays open.
//
// The prefix estimate (films built with keep_prefix; `adaptive:prefix-error=1`). A is instead
// the mean of the pixel's first m samples, m the largest power of two <= n/2 (so n/4 < m <=
// n/2), and |I - A| is weighted by sqrt(m / (n - m)). For independent samples
// Var(I - A) = sigma^2 (1/m - 1/n), so the weight gives sigma^2 / n, the spread of the half
// buffer's |I - A|: the same error targets apply. Why: Tessera's per-pixel sequences are
// Owen-scrambled Sobol points (sampling/sequence.h). The first 2^j samples of a pixel form a
// (0,j,2)-net in every dimension pair, so the mean of all samples converges much faster than
// 1/sqrt(n) on smooth integrands, but the odd-index samples are not a net, and their mean
// converges as 1/sqrt(n): |I - A| then measures the half buffer's own error, not the error of
// I. On a ramp across the pixel (tests/sampling/test_prefix_error.cpp's case, 384 pixels) the
// true error fell as n^-1.5 and the half-buffer estimate as n^-0.5, 23x too high at 16 spp and
// 1400x at 1024; the prefix estimate read 2.6-2.8x the true error throughout (a power-of-two
// prefix is itself a net, about 2^1.5 less accurate than twice as many samples). On the ground
// of examples/uneven-outdoor (256-4096 spp, against a 65536-spp reference) the half buffer
// read 10-20x the true error and only about 1x on the caustics beside it, so it ranked the
// regions wrongly; the prefix estimate read 0.5-1.03x on both.
//
// The relMSE estimate (AdaptiveOptions::metric = ErrorMetric::RelMse, the `adaptive` sampler's
// default). D_c = k (I_c - A_c), with A and k as above, has E[D_c^2] = Var(I_c) (half buffer:
// I - A = (S_even - S_odd) / n, variance sigma^2 / n; prefix: k^2 sigma^2 (1/m - 1/n) =
// sigma^2 / n), so rho_p = (1/3) sum_c D_c^2 / (I_c^2 + 0.01) estimates the pixel's relMSE,
// the same quantity `tessera converge` measures against a reference (sampling/image_metrics.h,
// with I in place of the reference). One pixel's rho_p has about one degree of freedom per
// channel; the trees use it summed over 8x8 tiles. For the allocation, a_p = rho_p n (the
// relative variance of one sample) and m_p = rho_p / n = a_p / n^2, the relMSE one more sample
// removes: an image relMSE E = (1/P) sum a_p / n_p costs the fewest samples when
// n_p = lambda sqrt(a_p) (Lagrange), i.e. when every pixel has the same m_p = 1 / lambda^2 with
// lambda = sum_p sqrt(a_p) / (P E). The scheduler therefore stops a region when its mean m_p is
// below (P E / sum_p sqrt(a_p))^2 (scheduler/adaptive_scheduler.h, "Error metrics").
#pragma once

#include <cstdint>

#include "sampling/film.h"
#include "sampling/region_tree.h"

namespace tessera::sampling {

/// Dammertz pixel error e_p of one pixel (see the file comment), >= 0, in sqrt(radiance) units.
/// With stats.has_prefix (a film keeping prefix snapshots) A is the prefix mean, weighted as the
/// file comment says; otherwise the half buffer.
///
/// Returns +inf when the pixel has no estimate: fewer than max(min_samples, 2) accepted
/// samples, no accepted odd-index sample (empty half buffer) or no accepted even-index sample
/// (then I == A and the error would read 0 whatever the noise); with a prefix, no accepted
/// sample in the prefix or none after it.
///
/// Black pixel: when I_r + I_g + I_b <= 0 the formula has no denominator. If I == A the error
/// is 0 (e.g. every sample black). Otherwise (possible only with signed radiance, whose even and
/// odd samples cancel) the denominator becomes sqrt(max(sum_c |I_c|, sum_c |A_c|)), the pixel's
/// own magnitude. A fixed floor such as sqrt(1e-4) would depend on the radiance units of the
/// scene; the pixel's own magnitude keeps e_p scaling as sqrt(k) when radiance is scaled by k,
/// exactly as the formula does for ordinary pixels. Pure function, thread-safe.
float pixel_error(const PixelStats &stats, uint32_t min_samples);

/// What an adaptive render's error target and per-pixel errors mean.
enum class ErrorMetric {
    Dammertz,  ///< pixel_error and the area-weighted region error e_b (Dammertz et al. 2010)
    RelMse,    ///< pixel_rel_mse: the image relMSE the render is to reach (see the file comment)
};

/// "dammertz" or "relmse".
const char *metric_name(ErrorMetric m);

/// Estimated relMSE rho_p of the pixel's mean (see the file comment), >= 0; +inf exactly where
/// pixel_error is +inf (no estimate). Pure function, thread-safe.
float pixel_rel_mse(const PixelStats &stats, uint32_t min_samples);

/// Fills `out.error` with pixel_error (or pixel_rel_mse, by `metric`) over the pixels of `region` (clipped to the film).
/// `out` covers the whole film: if its size differs from the film's it is reallocated and every
/// pixel set to +inf first (so allocate once and reuse). Pixels outside `region` are untouched.
/// Thread-safe for disjoint regions once `out` has the film's size, as long as the film's
/// pixels in `region` are not being written.
void compute_errors(const Film &film, PixelBounds region, uint32_t min_samples, ErrorImage &out,
                    ErrorMetric metric = ErrorMetric::Dammertz);

/// Region error e_b of the float rectangle `region` (pixel units, clipped to the error image):
/// e_b = (r / N) * sum_p c_p e_p, with c_p in [0, 1] the fraction of pixel p covered by the
/// region (a partially covered pixel counts by its covered area), N = sum_p c_p the region's area
/// in pixels, and r = sqrt(N / image_area). +inf if a pixel with positive coverage has +inf or
/// NaN error; 0 for an empty region. O(area): a reference for tests and tools; RegionTree uses a
/// summed-area table for the same quantity. Thread-safe.
double region_error(const ErrorImage &errors, const FloatRect &region, double image_area);

/// Region error of the whole image (r = 1: the mean pixel error), for progress reports.
/// +inf while any pixel lacks an estimate: the root regions cannot complete before every pixel
/// has one, and a mean over the finite pixels would read low in early passes. Progress displays
/// should show "n/a" (or the fraction of pixels with an estimate) instead of a number then.
/// O(pixels); not thread-safe against concurrent add_sample.
double image_error(const Film &film, uint32_t min_samples);

/// Mean pixel error over the pixels that have an estimate, and how many lack one: what a
/// progress bar can show before image_error() becomes finite. `mean_finite` is 0 when no pixel
/// has an estimate. Thread-safe.
struct ErrorSummary {
    double mean_finite = 0;       ///< mean e_p over pixels with a finite error
    uint64_t unknown_pixels = 0;  ///< pixels with +inf (or NaN) error
    uint64_t pixels = 0;          ///< pixels in the image
};
ErrorSummary summarize_errors(const ErrorImage &errors);

}  // namespace tessera::sampling
