// Image error metrics (MSE, RMSE, relMSE, PSNR, MAE, means) and box downsampling.
#include "sampling/image_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tessera::sampling {
namespace {

void check_image(const RgbImage &img, const char *what) {
    if (img.data.size() != img.pixel_count() * 3)
        throw std::invalid_argument(std::string(what) + ": image data size " +
                                    std::to_string(img.data.size()) + " does not match " +
                                    std::to_string(img.width) + "x" +
                                    std::to_string(img.height) + "x3");
}

void check_pair(const RgbImage &test, const RgbImage &ref) {
    check_image(test, "test image");
    check_image(ref, "reference image");
    if (test.width != ref.width || test.height != ref.height)
        throw std::invalid_argument("image sizes differ: " + std::to_string(test.width) + "x" +
                                    std::to_string(test.height) + " vs " +
                                    std::to_string(ref.width) + "x" +
                                    std::to_string(ref.height));
}

// Accumulates per-channel sums of squared, relative squared and absolute errors.
struct ErrorSums {
    std::array<double, 3> sq{}, rel{}, abs{};
    size_t n = 0;
};

ErrorSums error_sums(const RgbImage &test, const RgbImage &ref) {
    check_pair(test, ref);
    ErrorSums s;
    s.n = test.pixel_count();
    for (size_t i = 0; i < s.n; ++i) {
        for (int c = 0; c < 3; ++c) {
            double v = test.data[3 * i + c], r = ref.data[3 * i + c];
            double d2 = (v - r) * (v - r);
            s.sq[c] += d2;
            s.rel[c] += d2 / (r * r + kRelMseEpsilon);
            s.abs[c] += std::abs(v - r);
        }
    }
    return s;
}

ChannelMetric average(const std::array<double, 3> &sums, size_t n) {
    ChannelMetric m;
    if (n == 0) return m;
    for (int c = 0; c < 3; ++c) m.channel[c] = sums[c] / double(n);
    m.total = (m.channel[0] + m.channel[1] + m.channel[2]) / 3.0;
    return m;
}

double psnr_of(double mse_value, double peak) {
    if (mse_value == 0.0) return std::numeric_limits<double>::infinity();
    return 10.0 * std::log10(peak * peak / mse_value);
}

ChannelMetric rmse_of(const ChannelMetric &m) {
    ChannelMetric r;
    for (int c = 0; c < 3; ++c) r.channel[c] = std::sqrt(m.channel[c]);
    r.total = std::sqrt(m.total);
    return r;
}

ChannelMetric psnr_from(const ChannelMetric &m, double peak) {
    ChannelMetric p;
    for (int c = 0; c < 3; ++c) p.channel[c] = psnr_of(m.channel[c], peak);
    p.total = psnr_of(m.total, peak);
    return p;
}

}  // namespace

ChannelMetric mse(const RgbImage &test, const RgbImage &ref) {
    ErrorSums s = error_sums(test, ref);
    return average(s.sq, s.n);
}

ChannelMetric rmse(const RgbImage &test, const RgbImage &ref) { return rmse_of(mse(test, ref)); }

ChannelMetric rel_mse(const RgbImage &test, const RgbImage &ref) {
    ErrorSums s = error_sums(test, ref);
    return average(s.rel, s.n);
}

ChannelMetric psnr(const RgbImage &test, const RgbImage &ref, double peak) {
    return psnr_from(mse(test, ref), peak);
}

ChannelMetric mae(const RgbImage &test, const RgbImage &ref) {
    ErrorSums s = error_sums(test, ref);
    return average(s.abs, s.n);
}

ChannelMetric rel_mse_robust(const RgbImage &test, const RgbImage &ref, double drop_fraction) {
    check_pair(test, ref);
    if (!(drop_fraction >= 0.0 && drop_fraction < 1.0))
        throw std::invalid_argument("rel_mse_robust: drop fraction must be in [0, 1)");
    const size_t n = test.pixel_count();
    // Per pixel, the three channels' relative squared errors and their mean (the ranking key;
    // NaN ranks as +Inf, so non-finite pixels are the first left out).
    std::vector<std::array<double, 3>> rel(n);
    std::vector<std::pair<double, size_t>> key(n);
    for (size_t i = 0; i < n; ++i) {
        double sum = 0;
        for (int c = 0; c < 3; ++c) {
            double v = test.data[3 * i + c], r = ref.data[3 * i + c];
            rel[i][c] = (v - r) * (v - r) / (r * r + kRelMseEpsilon);
            sum += rel[i][c];
        }
        key[i] = {std::isnan(sum) ? std::numeric_limits<double>::infinity() : sum, i};
    }
    const size_t drop = size_t(std::floor(drop_fraction * double(n)));
    if (drop > 0)
        std::nth_element(key.begin(), key.begin() + std::ptrdiff_t(n - drop), key.end());
    std::array<double, 3> sums{};
    for (size_t j = 0; j < n - drop; ++j)
        for (int c = 0; c < 3; ++c) sums[c] += rel[key[j].second][c];
    return average(sums, n - drop);
}

std::size_t nonfinite_count(const RgbImage &img) {
    check_image(img, "image");
    return std::size_t(std::count_if(img.data.begin(), img.data.end(),
                                     [](float v) { return !std::isfinite(v); }));
}

std::array<double, 3> channel_means(const RgbImage &img) {
    check_image(img, "image");
    std::array<double, 3> m{};
    size_t n = img.pixel_count();
    if (n == 0) return m;
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) m[c] += img.data[3 * i + c];
    for (double &v : m) v /= double(n);
    return m;
}

ImageComparison compare_images(const RgbImage &test, const RgbImage &ref, double peak) {
    ErrorSums s = error_sums(test, ref);
    ImageComparison out;
    out.mse = average(s.sq, s.n);
    out.rmse = rmse_of(out.mse);
    out.rel_mse = average(s.rel, s.n);
    out.rel_mse_robust = rel_mse_robust(test, ref);
    out.psnr = psnr_from(out.mse, peak);
    out.mae = average(s.abs, s.n);
    out.mean_test = channel_means(test);
    out.mean_ref = channel_means(ref);
    return out;
}

RgbImage box_downsample(const RgbImage &img, uint32_t factor) {
    check_image(img, "image");
    if (factor == 0) throw std::invalid_argument("box_downsample: factor must be >= 1");
    uint32_t ow = (img.width + factor - 1) / factor, oh = (img.height + factor - 1) / factor;
    RgbImage out(ow, oh);
    for (uint32_t oy = 0; oy < oh; ++oy) {
        for (uint32_t ox = 0; ox < ow; ++ox) {
            uint32_t x1 = std::min(img.width, (ox + 1) * factor);
            uint32_t y1 = std::min(img.height, (oy + 1) * factor);
            double sum[3] = {0, 0, 0};
            for (uint32_t y = oy * factor; y < y1; ++y)
                for (uint32_t x = ox * factor; x < x1; ++x)
                    for (int c = 0; c < 3; ++c) sum[c] += img.at(x, y, c);
            double n = double(x1 - ox * factor) * double(y1 - oy * factor);
            for (int c = 0; c < 3; ++c) out.at(ox, oy, c) = float(sum[c] / n);
        }
    }
    return out;
}

}  // namespace tessera::sampling
