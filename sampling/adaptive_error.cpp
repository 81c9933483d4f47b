// Dammertz et al. 2010 error metrics on the film (see adaptive_error.h).
#include "sampling/adaptive_error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "sampling/image_metrics.h"

namespace tessera::sampling {

namespace {
constexpr float kInfF = std::numeric_limits<float>::infinity();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The second estimate A of the pixel and the weight k of I - A (see the header): the half buffer
// as it is, or the prefix scaled to the half buffer's spread. False when the pixel has no
// estimate.
bool second_estimate(const PixelStats &st, uint32_t min_samples, const std::array<double, 3> *&a,
                     double &k) {
    if (st.accepted < std::max<uint32_t>(min_samples, 2))
        return false;
    a = &st.half_mean;
    k = 1;
    if (st.has_prefix) {
        // m < n, or I == A and the error would read 0 whatever the noise.
        if (st.prefix_accepted == 0 || st.prefix_accepted >= st.accepted)
            return false;
        const double m = st.prefix_accepted, n = st.accepted;
        k = std::sqrt(m / (n - m));
        a = &st.prefix_mean;
        return true;
    }
    // Both halves must be non-empty: with no even sample I == A and the error would read 0.
    return st.half_accepted != 0 && st.half_accepted < st.accepted;
}

}  // namespace

const char *metric_name(ErrorMetric m) {
    return m == ErrorMetric::RelMse ? "relmse" : "dammertz";
}

float pixel_rel_mse(const PixelStats &st, uint32_t min_samples) {
    const std::array<double, 3> *a = nullptr;
    double k = 1;
    if (!second_estimate(st, min_samples, a, k))
        return kInfF;
    double rho = 0;
    for (int c = 0; c < 3; ++c) {
        const double d = k * (st.mean[c] - (*a)[c]);
        rho += d * d / (st.mean[c] * st.mean[c] + kRelMseEpsilon);
    }
    return float(rho / 3);
}

float pixel_error(const PixelStats &st, uint32_t min_samples) {
    const std::array<double, 3> *a = nullptr;
    double k = 1;
    if (!second_estimate(st, min_samples, a, k))
        return kInfF;
    double num = 0, sum = 0, abs_i = 0, abs_a = 0;
    for (int c = 0; c < 3; ++c) {
        num += std::abs(st.mean[c] - (*a)[c]);
        sum += st.mean[c];
        abs_i += std::abs(st.mean[c]);
        abs_a += std::abs((*a)[c]);
    }
    num *= k;
    if (num == 0)
        return 0.f;
    // Dammertz et al. 2010, eq. 2. For a black or net-negative mean (signed radiance only) fall
    // back to the pixel's own magnitude, which is > 0 here since num > 0 (see the header).
    double denom2 = sum > 0 ? sum : std::max(abs_i, abs_a);
    return float(num / std::sqrt(denom2));
}

void compute_errors(const Film &film, PixelBounds region, uint32_t min_samples, ErrorImage &out,
                    ErrorMetric metric) {
    const int w = int(film.width()), h = int(film.height());
    if (out.width != w || out.height != h || out.error.size() != size_t(w) * size_t(h)) {
        out.width = w;
        out.height = h;
        out.error.assign(size_t(w) * size_t(h), kInfF);
    }
    region.x0 = std::max(region.x0, 0);
    region.y0 = std::max(region.y0, 0);
    region.x1 = std::min(region.x1, w);
    region.y1 = std::min(region.y1, h);
    for (int y = region.y0; y < region.y1; ++y) {
        float *row = &out.error[size_t(y) * size_t(w)];
        for (int x = region.x0; x < region.x1; ++x)
            row[x] = metric == ErrorMetric::RelMse
                         ? pixel_rel_mse(film.pixel_stats(uint32_t(x), uint32_t(y)), min_samples)
                         : pixel_error(film.pixel_stats(uint32_t(x), uint32_t(y)), min_samples);
    }
}

double region_error(const ErrorImage &errors, const FloatRect &region, double image_area) {
    // Clip to the image; coverage of pixel column x is the length of [x, x+1) ∩ [x0, x1).
    const double x0 = std::max(region.x0, 0.0), x1 = std::min(region.x1, double(errors.width));
    const double y0 = std::max(region.y0, 0.0), y1 = std::min(region.y1, double(errors.height));
    if (!(x1 > x0) || !(y1 > y0))
        return 0.0;
    const PixelBounds p = FloatRect{x0, y0, x1, y1}.outward();
    double sum = 0;
    for (int y = p.y0; y < p.y1; ++y) {
        const double cy = std::min(y1, double(y + 1)) - std::max(y0, double(y));
        if (!(cy > 0))
            continue;
        for (int x = p.x0; x < p.x1; ++x) {
            const double cx = std::min(x1, double(x + 1)) - std::max(x0, double(x));
            if (!(cx > 0))
                continue;
            const float e = errors.at(x, y);
            if (!(e < kInfF))
                return kInf;
            if (e > 0)
                sum += cx * cy * double(e);
        }
    }
    // e_b = (r / N) sum = sum / sqrt(N * A_image), N the covered area (Dammertz eq. 3).
    const double n = (x1 - x0) * (y1 - y0);
    return sum / std::sqrt(n * image_area);
}

double image_error(const Film &film, uint32_t min_samples) {
    const uint32_t w = film.width(), h = film.height();
    if (w == 0 || h == 0)
        return 0.0;
    double sum = 0;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const float e = pixel_error(film.pixel_stats(x, y), min_samples);
            if (!(e < kInfF))
                return kInf;
            sum += double(e);
        }
    // r = 1 and N = A_image: the mean pixel error.
    return sum / (double(w) * double(h));
}

ErrorSummary summarize_errors(const ErrorImage &errors) {
    ErrorSummary s;
    s.pixels = errors.error.size();
    double sum = 0;
    for (float e : errors.error) {
        if (e < kInfF)
            sum += double(std::max(e, 0.f));
        else
            ++s.unknown_pixels;
    }
    const uint64_t known = s.pixels - s.unknown_pixels;
    s.mean_finite = known ? sum / double(known) : 0.0;
    return s;
}

}  // namespace tessera::sampling
