// Per-pixel accumulation: sums, half buffer, the requested AOVs' running means, dropped-sample
// counting.
#include "sampling/film.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <sstream>

namespace tessera::sampling {

Film::Film(uint32_t width, uint32_t height, AovSet aovs, bool keep_prefix)
    : width_(width), height_(height), aovs_(aovs), pixels_(size_t(width) * height) {
    const size_t n = pixels_.size();
    if (keep_prefix) prefix_.assign(n, PrefixData{});
    if (aovs_.has(Aov::Albedo)) aov_.albedo.assign(n, Float3{0, 0, 0});
    if (aovs_.has(Aov::Normal)) aov_.normal.assign(n, Float3{0, 0, 0});
    if (aovs_.has(Aov::Depth)) aov_.depth.assign(n, 0.f);
}

void Film::add_sample(uint32_t px, uint32_t py, uint32_t sample_index, const Sample &s) {
    PixelData &p = at(px, py);
    ++p.taken;
    const bool finite = s.radiance.is_finite();
    if (finite) {
        ++p.accepted;
        for (int c = 0; c < 3; ++c) p.sum[c] += double(s.radiance[c]);
    }
    if (!prefix_.empty() && (p.taken & (p.taken - 1)) == 0) {
        // The count reached a power of two: the current snapshot becomes the previous one.
        PrefixData &q = prefix_[size_t(py) * width_ + px];
        const double inv = p.accepted ? 1.0 / p.accepted : 0.0;
        for (int c = 0; c < 3; ++c) {
            q.prev_mean[c] = q.cur_mean[c];
            q.cur_mean[c] = float(p.sum[c] * inv);
        }
        q.prev_accepted = q.cur_accepted;
        q.cur_accepted = p.accepted;
    }
    if (!finite) {
        // NOTE: dropped, not zeroed (pbrt-v4 zeroes): see the file comment in film.h.
        nan_count_.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    if (sample_index & 1u) {
        ++p.half_accepted;
        for (int c = 0; c < 3; ++c) p.half_sum[c] += double(s.radiance[c]);
    }
    if (aovs_.empty()) return;
    // A sample "hit" when its depth is finite; broken AOVs (non-finite) count as a miss so
    // they never poison the running means. The test is the same whichever AOVs are kept, so
    // that a film with only depth has the depth means of a film with all three.
    bool hit = std::isfinite(s.depth) && s.albedo.is_finite() && std::isfinite(s.normal.x) &&
               std::isfinite(s.normal.y) && std::isfinite(s.normal.z);
    if (!hit) return;
    ++p.hits;
    const float w = 1.f / float(p.hits);
    const size_t i = size_t(py) * width_ + px;
    if (!aov_.albedo.empty()) {
        Float3 &a = aov_.albedo[i];
        for (int c = 0; c < 3; ++c) a[size_t(c)] += (s.albedo[c] - a[size_t(c)]) * w;
    }
    if (!aov_.normal.empty()) {
        Float3 &nrm = aov_.normal[i];
        for (int c = 0; c < 3; ++c) nrm[size_t(c)] += (s.normal[c] - nrm[size_t(c)]) * w;
    }
    if (!aov_.depth.empty()) aov_.depth[i] += (s.depth - aov_.depth[i]) * w;
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
    if (!prefix_.empty()) {
        const PrefixData &q = prefix_[size_t(py) * width_ + px];
        st.has_prefix = true;
        st.prefix_accepted = q.prev_accepted;
        for (int c = 0; c < 3; ++c) st.prefix_mean[c] = double(q.prev_mean[c]);
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
    std::fill(aov_.albedo.begin(), aov_.albedo.end(), Float3{0, 0, 0});
    std::fill(aov_.normal.begin(), aov_.normal.end(), Float3{0, 0, 0});
    std::fill(aov_.depth.begin(), aov_.depth.end(), 0.f);
    std::fill(prefix_.begin(), prefix_.end(), PrefixData{});
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

namespace {

/// Interleaves per-pixel triples; empty in, empty out (an AOV the film does not keep).
std::vector<float> interleave(const std::vector<Film::Float3> &v) {
    std::vector<float> out(v.size() * 3);
    for (size_t i = 0; i < v.size(); ++i)
        for (size_t c = 0; c < 3; ++c) out[3 * i + c] = v[i][c];
    return out;
}

}  // namespace

std::vector<float> Film::albedo_rgb() const { return interleave(aov_.albedo); }

std::vector<float> Film::normal_xyz() const { return interleave(aov_.normal); }

std::vector<float> Film::depth() const {
    std::vector<float> out(aov_.depth.size());
    for (size_t i = 0; i < out.size(); ++i)
        out[i] = pixels_[i].hits ? aov_.depth[i] : kInfinity;
    return out;
}

std::vector<float> Film::spp() const {
    std::vector<float> out(pixels_.size());
    for (size_t i = 0; i < pixels_.size(); ++i) out[i] = float(pixels_[i].taken);
    return out;
}

std::string Film::describe() const {
    std::ostringstream os;
    os << "Film(" << width_ << "x" << height_ << ", AOVs " << aovs_.describe() << ", "
       << bytes_per_pixel() << " B/pixel, "
       << (double(bytes_per_pixel()) * pixels_.size() / (1024.0 * 1024.0)) << " MiB, "
       << total_samples() << " samples, " << nan_count() << " dropped non-finite)";
    return os.str();
}

void Film::restore(std::vector<PixelData> pixels, AovData aovs, uint64_t nan_count,
                   std::vector<PrefixData> prefix) {
    const size_t n = pixels_.size();
    if (pixels.size() != n)
        throw std::invalid_argument("Film::restore: pixel count does not match the film");
    if (aovs.albedo.size() != aov_.albedo.size() || aovs.normal.size() != aov_.normal.size() ||
        aovs.depth.size() != aov_.depth.size())
        throw std::invalid_argument("Film::restore: the AOVs do not match the film's (" +
                                    aovs_.describe() + ")");
    if (prefix.size() != prefix_.size())
        throw std::invalid_argument(std::string("Film::restore: the prefix snapshots do not match "
                                                "the film's (") +
                                    (keeps_prefix() ? "kept" : "not kept") + ")");
    pixels_ = std::move(pixels);
    aov_ = std::move(aovs);
    prefix_ = std::move(prefix);
    nan_count_.store(nan_count, std::memory_order_relaxed);
}

size_t Film::packed_pixel_bytes() const {
    return sizeof(PixelData) + (aovs_.has(Aov::Albedo) ? sizeof(Float3) : 0) +
           (aovs_.has(Aov::Normal) ? sizeof(Float3) : 0) +
           (aovs_.has(Aov::Depth) ? sizeof(float) : 0) +
           (keeps_prefix() ? sizeof(PrefixData) : 0);
}

namespace {

template <class T> void take(const std::byte *&in, T &v) {
    std::memcpy(&v, in, sizeof(T));
    in += sizeof(T);
}

}  // namespace

void Film::pack_pixels(std::span<const uint32_t> indices, std::vector<std::byte> &out) const {
    const size_t stride = packed_pixel_bytes(), base = out.size();
    out.resize(base + indices.size() * stride);
    std::byte *p = out.data() + base;
    auto put = [&p](const auto &v) {
        std::memcpy(p, &v, sizeof v);
        p += sizeof v;
    };
    for (uint32_t i : indices) {
        put(pixels_[i]);
        if (!aov_.albedo.empty()) put(aov_.albedo[i]);
        if (!aov_.normal.empty()) put(aov_.normal[i]);
        if (!aov_.depth.empty()) put(aov_.depth[i]);
        if (!prefix_.empty()) put(prefix_[i]);
    }
}

void Film::unpack_pixels(std::span<const uint32_t> indices, std::span<const std::byte> in,
                         uint64_t nan_count) {
    if (in.size() != indices.size() * packed_pixel_bytes())
        throw std::invalid_argument("Film::unpack_pixels: " + std::to_string(in.size()) +
                                    " bytes for " + std::to_string(indices.size()) +
                                    " pixels of " + std::to_string(packed_pixel_bytes()));
    const std::byte *p = in.data();
    for (uint32_t i : indices) {
        if (i >= pixels_.size())
            throw std::invalid_argument("Film::unpack_pixels: pixel index outside the film");
        take(p, pixels_[i]);
        if (!aov_.albedo.empty()) take(p, aov_.albedo[i]);
        if (!aov_.normal.empty()) take(p, aov_.normal[i]);
        if (!aov_.depth.empty()) take(p, aov_.depth[i]);
        if (!prefix_.empty()) take(p, prefix_[i]);
    }
    nan_count_.fetch_add(nan_count, std::memory_order_relaxed);
}

}  // namespace tessera::sampling
