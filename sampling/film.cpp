// Per-pixel accumulation: sums, half buffer, AOV running means, dropped-sample counting.
#include "sampling/film.h"

#include <stdexcept>

#include <cmath>
#include <sstream>

namespace tessera::sampling {

Film::Film(uint32_t width, uint32_t height)
    : width_(width), height_(height), pixels_(size_t(width) * height) {}

void Film::add_sample(uint32_t px, uint32_t py, uint32_t sample_index, const Sample &s) {
    PixelData &p = at(px, py);
    ++p.taken;
    if (!s.radiance.is_finite()) {
        // NOTE: dropped, not zeroed (pbrt-v4 zeroes): see the file comment in film.h.
        nan_count_.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    ++p.accepted;
    for (int c = 0; c < 3; ++c) p.sum[c] += double(s.radiance[c]);
    if (sample_index & 1u) {
        ++p.half_accepted;
        for (int c = 0; c < 3; ++c) p.half_sum[c] += double(s.radiance[c]);
    }
    // A sample "hit" when its depth is finite; broken AOVs (non-finite) count as a miss so
    // they never poison the running means.
    bool hit = std::isfinite(s.depth) && s.albedo.is_finite() && std::isfinite(s.normal.x) &&
               std::isfinite(s.normal.y) && std::isfinite(s.normal.z);
    if (hit) {
        ++p.hits;
        float w = 1.f / float(p.hits);
        for (int c = 0; c < 3; ++c) {
            p.albedo[c] += (s.albedo[c] - p.albedo[c]) * w;
            p.normal[c] += (s.normal[c] - p.normal[c]) * w;
        }
        p.depth += (s.depth - p.depth) * w;
    }
}

PixelStats Film::pixel_stats(uint32_t px, uint32_t py) const {
    const PixelData &p = at(px, py);
    PixelStats st;
    st.taken = p.taken;
    st.accepted = p.accepted;
    st.half_accepted = p.half_accepted;
    st.hits = p.hits;
    for (int c = 0; c < 3; ++c) {
        st.mean[c] = p.accepted ? p.sum[c] / p.accepted : 0.0;
        st.half_mean[c] = p.half_accepted ? p.half_sum[c] / p.half_accepted : 0.0;
    }
    return st;
}

Rgb Film::mean(uint32_t px, uint32_t py) const {
    const PixelData &p = at(px, py);
    if (p.accepted == 0) return Rgb(0.f);
    double inv = 1.0 / p.accepted;
    return {float(p.sum[0] * inv), float(p.sum[1] * inv), float(p.sum[2] * inv)};
}

uint64_t Film::total_samples() const {
    uint64_t n = 0;
    for (const PixelData &p : pixels_) n += p.taken;
    return n;
}

void Film::clear() {
    for (PixelData &p : pixels_) p = PixelData{};
    nan_count_.store(0, std::memory_order_relaxed);
}

std::vector<float> Film::beauty_rgb() const {
    std::vector<float> out(pixels_.size() * 3);
    for (size_t i = 0; i < pixels_.size(); ++i) {
        const PixelData &p = pixels_[i];
        double inv = p.accepted ? 1.0 / p.accepted : 0.0;
        for (int c = 0; c < 3; ++c) out[3 * i + c] = float(p.sum[c] * inv);
    }
    return out;
}

std::vector<float> Film::half_rgb() const {
    std::vector<float> out(pixels_.size() * 3);
    for (size_t i = 0; i < pixels_.size(); ++i) {
        const PixelData &p = pixels_[i];
        double inv = p.half_accepted ? 1.0 / p.half_accepted : 0.0;
        for (int c = 0; c < 3; ++c) out[3 * i + c] = float(p.half_sum[c] * inv);
    }
    return out;
}

std::vector<float> Film::albedo_rgb() const {
    std::vector<float> out(pixels_.size() * 3);
    for (size_t i = 0; i < pixels_.size(); ++i)
        for (int c = 0; c < 3; ++c) out[3 * i + c] = pixels_[i].albedo[c];
    return out;
}

std::vector<float> Film::normal_xyz() const {
    std::vector<float> out(pixels_.size() * 3);
    for (size_t i = 0; i < pixels_.size(); ++i)
        for (int c = 0; c < 3; ++c) out[3 * i + c] = pixels_[i].normal[c];
    return out;
}

std::vector<float> Film::depth() const {
    std::vector<float> out(pixels_.size());
    for (size_t i = 0; i < pixels_.size(); ++i)
        out[i] = pixels_[i].hits ? pixels_[i].depth : kInfinity;
    return out;
}

std::vector<float> Film::spp() const {
    std::vector<float> out(pixels_.size());
    for (size_t i = 0; i < pixels_.size(); ++i) out[i] = float(pixels_[i].taken);
    return out;
}

std::string Film::describe() const {
    std::ostringstream os;
    os << "Film(" << width_ << "x" << height_ << ", " << bytes_per_pixel() << " B/pixel, "
       << (double(bytes_per_pixel()) * pixels_.size() / (1024.0 * 1024.0)) << " MiB, "
       << total_samples() << " samples, " << nan_count() << " dropped non-finite)";
    return os.str();
}

void Film::restore(std::vector<PixelData> pixels, uint64_t nan_count) {
    if (pixels.size() != pixels_.size())
        throw std::invalid_argument("Film::restore: pixel count does not match the film");
    pixels_ = std::move(pixels);
    nan_count_.store(nan_count, std::memory_order_relaxed);
}

}  // namespace tessera::sampling
