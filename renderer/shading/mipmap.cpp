// MipMap: pbrt-v4's image pyramid and filtered lookups (see mipmap.h for the semantics).
#include "renderer/shading/mipmap.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace tessera {

namespace {

int round_up_pow2(int v) {
    int p = 1;
    while (p < v) p <<= 1;
    return p;
}

/// floor(log2(v)) for v >= 1.
int log2_int(int v) {
    int l = 0;
    while (v > 1) {
        v >>= 1;
        ++l;
    }
    return l;
}

double sinc(double x) {
    x *= 3.14159265358979323846;
    return std::abs(x) < 1e-5 ? 1 - x * x / 6 : std::sin(x) / x;
}

/// pbrt-v4 WindowedSinc: sinc(x) sinc(x / tau) inside |x| <= radius.
double windowed_sinc(double x, double radius, double tau) {
    return std::abs(x) > radius ? 0.0 : sinc(x) * sinc(x / tau);
}

/// Four taps of the resampling filter for each output texel (pbrt-v4 ResampleWeights).
struct ResampleWeight {
    int first = 0;
    float w[4] = {0, 0, 0, 0};
};

std::vector<ResampleWeight> resample_weights(int old_res, int new_res) {
    constexpr double kRadius = 2, kTau = 2;
    std::vector<ResampleWeight> wt(static_cast<size_t>(new_res));
    for (int i = 0; i < new_res; ++i) {
        const double center = (i + 0.5) * old_res / new_res;
        ResampleWeight &r = wt[size_t(i)];
        r.first = int(std::floor(center - kRadius + 0.5));
        double w[4], sum = 0;
        for (int j = 0; j < 4; ++j) {
            w[j] = windowed_sinc(r.first + j + 0.5 - center, kRadius, kTau);
            sum += w[j];
        }
        for (int j = 0; j < 4; ++j) r.w[j] = float(w[j] / sum);
    }
    return wt;
}

/// One coordinate wrapped into [0, n); false where `wrap` is Black and v is outside.
inline bool wrap_coord(int &v, int n, MipWrap wrap) {
    if (v >= 0 && v < n)
        return true;
    switch (wrap) {
        case MipWrap::Repeat:
            v %= n;
            if (v < 0)
                v += n;
            return true;
        case MipWrap::Clamp:
            v = std::clamp(v, 0, n - 1);
            return true;
        case MipWrap::Black:
            break;
    }
    return false;
}

/// Resamples rows (axis 0) or columns (axis 1) of a w x h x nch image to `new_res` texels,
/// rows in parallel.
std::vector<float> resample_axis(const std::vector<float> &src, int w, int h, int nch, int axis,
                                 int new_res, MipWrap wrap) {
    const int old_res = axis == 0 ? w : h;
    // The taps with their source addresses wrapped once (-1: black, weight dropped).
    struct Tap {
        int idx[4];
        float w[4];
    };
    std::vector<Tap> taps(static_cast<size_t>(new_res));
    const std::vector<ResampleWeight> wt = resample_weights(old_res, new_res);
    for (int i = 0; i < new_res; ++i)
        for (int j = 0; j < 4; ++j) {
            int v = wt[size_t(i)].first + j;
            const bool in = wrap_coord(v, old_res, wrap);
            taps[size_t(i)].idx[j] = in ? v : 0;
            taps[size_t(i)].w[j] = in ? wt[size_t(i)].w[j] : 0.f;
        }
    const int ow = axis == 0 ? new_res : w, oh = axis == 0 ? h : new_res;
    const size_t ch = size_t(nch), row_in = size_t(w) * ch, row_out = size_t(ow) * ch;
    std::vector<float> out(size_t(oh) * row_out, 0.f);
    tbb::parallel_for(tbb::blocked_range<int>(0, oh, 16), [&](const tbb::blocked_range<int> &r) {
        for (int y = r.begin(); y < r.end(); ++y) {
            float *o = &out[size_t(y) * row_out];
            if (axis == 0) {
                const float *s = &src[size_t(y) * row_in];
                for (int x = 0; x < ow; ++x) {
                    const Tap &t = taps[size_t(x)];
                    for (size_t c = 0; c < ch; ++c)
                        o[size_t(x) * ch + c] = t.w[0] * s[size_t(t.idx[0]) * ch + c] +
                                                t.w[1] * s[size_t(t.idx[1]) * ch + c] +
                                                t.w[2] * s[size_t(t.idx[2]) * ch + c] +
                                                t.w[3] * s[size_t(t.idx[3]) * ch + c];
                }
            } else {
                const Tap &t = taps[size_t(y)];
                for (int j = 0; j < 4; ++j) {
                    const float *s = &src[size_t(t.idx[j]) * row_in];
                    const float wj = t.w[j];
                    for (size_t k = 0; k < row_out; ++k) o[k] += wj * s[k];
                }
            }
        }
    });
    return out;
}

/// The EWA weight table: exp(-alpha r^2) - exp(-alpha) at r^2 = i / (size - 1), alpha = 2
/// (pbrt-v4 MIPFilterLUT).
constexpr int kEwaLutSize = 128;
const std::array<float, kEwaLutSize> &ewa_lut() {
    static const std::array<float, kEwaLutSize> lut = [] {
        std::array<float, kEwaLutSize> t{};
        constexpr double kAlpha = 2;
        for (int i = 0; i < kEwaLutSize; ++i) {
            const double r2 = double(i) / (kEwaLutSize - 1);
            t[size_t(i)] = float(std::exp(-kAlpha * r2) - std::exp(-kAlpha));
        }
        return t;
    }();
    return lut;
}

}  // namespace

size_t MipMap::pyramid_bytes(int width, int height, int channels) {
    size_t w = size_t(round_up_pow2(std::max(1, width)));
    size_t h = size_t(round_up_pow2(std::max(1, height)));
    size_t texels = 0;
    for (;;) {
        texels += w * h;
        if (w == 1 && h == 1)
            break;
        w = std::max<size_t>(1, w / 2);
        h = std::max<size_t>(1, h / 2);
    }
    return texels * size_t(std::max(1, channels)) * sizeof(float);
}

MipMap::MipMap(int width, int height, int channels, std::vector<float> pixels, MipWrap wrap,
               MipFilter filter, float max_anisotropy)
    : nch_(channels), wrap_(wrap), filter_(filter), max_aniso_(max_anisotropy) {
    if (width < 1 || height < 1 || channels < 1 || channels > kMaxChannels ||
        pixels.size() != size_t(width) * size_t(height) * size_t(channels))
        throw std::invalid_argument("MipMap: image size and pixel count disagree");
    // Power-of-two resolution first (pbrt-v4 Image::GeneratePyramid): a dimension already a
    // power of two is left as it is (its resampling weights are the identity).
    int w = width, h = height;
    const int pw = round_up_pow2(w), ph = round_up_pow2(h);
    if (pw != w || ph != h) {
        if (pw != w) {
            pixels = resample_axis(pixels, w, h, nch_, 0, pw, wrap_);
            w = pw;
        }
        if (ph != h) {
            pixels = resample_axis(pixels, w, h, nch_, 1, ph, wrap_);
            h = ph;
        }
        for (float &v : pixels) v = std::max(0.f, v);
    }
    const int n_levels = 1 + log2_int(std::max(w, h));
    levels_.reserve(size_t(n_levels));
    levels_.push_back({w, h, std::move(pixels)});
    while (int(levels_.size()) < n_levels) {
        const Level &src = levels_.back();
        Level next;
        next.w = std::max(1, src.w / 2);
        next.h = std::max(1, src.h / 2);
        next.px.resize(size_t(next.w) * size_t(next.h) * size_t(nch_));
        tbb::parallel_for(0, next.h, [&](int y) {
            const int y0 = 2 * y, y1 = std::min(2 * y + 1, src.h - 1);
            for (int x = 0; x < next.w; ++x) {
                const int x0 = 2 * x, x1 = std::min(2 * x + 1, src.w - 1);
                const size_t ch = size_t(nch_);
                const float *a = &src.px[(size_t(y0) * size_t(src.w) + size_t(x0)) * ch];
                const float *b = &src.px[(size_t(y0) * size_t(src.w) + size_t(x1)) * ch];
                const float *c = &src.px[(size_t(y1) * size_t(src.w) + size_t(x0)) * ch];
                const float *d = &src.px[(size_t(y1) * size_t(src.w) + size_t(x1)) * ch];
                float *o = &next.px[(size_t(y) * size_t(next.w) + size_t(x)) * ch];
                for (size_t k = 0; k < ch; ++k) o[k] = (a[k] + b[k] + c[k] + d[k]) * 0.25f;
            }
        });
        levels_.push_back(std::move(next));
    }
}

size_t MipMap::bytes() const {
    size_t b = 0;
    for (const Level &l : levels_) b += l.px.size() * sizeof(float);
    return b;
}

bool MipMap::remap(const Level &l, int &x, int &y) const {
    return wrap_coord(x, l.w, wrap_) && wrap_coord(y, l.h, wrap_);
}

void MipMap::texel(int level, int x, int y, float *out) const {
    const Level &l = levels_[size_t(level)];
    if (!remap(l, x, y)) {
        for (int c = 0; c < nch_; ++c) out[c] = 0.f;
        return;
    }
    const float *p = &l.px[(size_t(y) * size_t(l.w) + size_t(x)) * size_t(nch_)];
    for (int c = 0; c < nch_; ++c) out[c] = p[c];
}

void MipMap::bilerp(int level, Vec2f st, float *out) const {
    const Level &l = levels_[size_t(level)];
    float x = st.x * float(l.w) - 0.5f, y = st.y * float(l.h) - 0.5f;
    // A non-finite address, or one far outside the range of int, is meaningless: texel 0.
    if (!(std::abs(x) < 1e9f))
        x = 0.f;
    if (!(std::abs(y) < 1e9f))
        y = 0.f;
    const float fx = std::floor(x), fy = std::floor(y);
    const float dx = x - fx, dy = y - fy;
    const int xi = int(fx), yi = int(fy);
    const float w00 = (1 - dx) * (1 - dy), w10 = dx * (1 - dy), w01 = (1 - dx) * dy,
                w11 = dx * dy;
    const size_t ch = size_t(nch_);
    if (xi >= 0 && yi >= 0 && xi + 1 < l.w && yi + 1 < l.h) {
        // All four texels inside: no wrapping.
        const float *p0 = &l.px[(size_t(yi) * size_t(l.w) + size_t(xi)) * ch];
        const float *p1 = p0 + size_t(l.w) * ch;
        for (size_t c = 0; c < ch; ++c)
            out[c] = w00 * p0[c] + w10 * p0[c + ch] + w01 * p1[c] + w11 * p1[c + ch];
        return;
    }
    float a[kMaxChannels], b[kMaxChannels], c4[kMaxChannels], d[kMaxChannels];
    texel(level, xi, yi, a);
    texel(level, xi + 1, yi, b);
    texel(level, xi, yi + 1, c4);
    texel(level, xi + 1, yi + 1, d);
    for (size_t c = 0; c < ch; ++c) out[c] = w00 * a[c] + w10 * b[c] + w01 * c4[c] + w11 * d[c];
}

void MipMap::filter(Vec2f st, Vec2f dst0, Vec2f dst1, float *out) const {
    const int n_levels = levels();
    if (filter_ != MipFilter::Ewa) {
        const float width = 2.f * std::max({std::abs(dst0.x), std::abs(dst0.y), std::abs(dst1.x),
                                            std::abs(dst1.y)});
        const float level = float(n_levels - 1) + std::log2(std::max(width, 1e-8f));
        if (!(level < float(n_levels - 1))) {
            texel(n_levels - 1, 0, 0, out);
            return;
        }
        const int il = std::max(0, int(std::floor(level)));
        if (filter_ == MipFilter::Point) {
            const Level &l = levels_[size_t(il)];
            float x = std::round(st.x * float(l.w) - 0.5f), y = std::round(st.y * float(l.h) - 0.5f);
            texel(il, std::abs(x) < 1e9f ? int(x) : 0, std::abs(y) < 1e9f ? int(y) : 0, out);
        } else if (filter_ == MipFilter::Bilinear || il == 0) {
            bilerp(il, st, out);
        } else {
            const float delta = level - float(il);
            float hi[kMaxChannels];
            bilerp(il, st, out);
            bilerp(il + 1, st, hi);
            for (int c = 0; c < nch_; ++c) out[c] = lerp(delta, out[c], hi[c]);
        }
        return;
    }
    // EWA: the longer axis first; clamp the eccentricity to max_anisotropy.
    if (dst0.x * dst0.x + dst0.y * dst0.y < dst1.x * dst1.x + dst1.y * dst1.y)
        std::swap(dst0, dst1);
    const float longer = std::sqrt(dst0.x * dst0.x + dst0.y * dst0.y);
    float shorter = std::sqrt(dst1.x * dst1.x + dst1.y * dst1.y);
    if (shorter * max_aniso_ < longer && shorter > 0.f) {
        const float scale = longer / (shorter * max_aniso_);
        dst1 = dst1 * scale;
        shorter *= scale;
    }
    if (shorter == 0.f) {
        bilerp(0, st, out);
        return;
    }
    const float lod = std::max(0.f, float(n_levels - 1) + std::log2(shorter));
    const int il = int(std::floor(lod));
    const float t = lod - float(il);
    ewa(il, st, dst0, dst1, out);
    if (t > 0.f) {
        float hi[kMaxChannels];
        ewa(il + 1, st, dst0, dst1, hi);
        for (int c = 0; c < nch_; ++c) out[c] = lerp(t, out[c], hi[c]);
    }
}

void MipMap::ewa(int level, Vec2f st, Vec2f dst0, Vec2f dst1, float *out) const {
    if (level >= levels()) {
        texel(levels() - 1, 0, 0, out);
        return;
    }
    const Level &l = levels_[size_t(level)];
    const float s = st.x * float(l.w) - 0.5f, t = st.y * float(l.h) - 0.5f;
    dst0 = Vec2f{dst0.x * float(l.w), dst0.y * float(l.h)};
    dst1 = Vec2f{dst1.x * float(l.w), dst1.y * float(l.h)};
    // The ellipse A s^2 + B s t + C t^2 = F through the footprint, widened by a texel so that
    // it always covers one (Heckbert 1989), normalised to F = 1.
    float a = dst0.y * dst0.y + dst1.y * dst1.y + 1;
    float b = -2 * (dst0.x * dst0.y + dst1.x * dst1.y);
    float c = dst0.x * dst0.x + dst1.x * dst1.x + 1;
    const float inv_f = 1 / (a * c - b * b * 0.25f);
    a *= inv_f;
    b *= inv_f;
    c *= inv_f;
    const float det = -b * b + 4 * a * c, inv_det = 1 / det;
    const float u_sqrt = std::sqrt(std::max(0.f, det * c)),
                v_sqrt = std::sqrt(std::max(0.f, a * det));
    const float fs0 = std::ceil(s - 2 * inv_det * u_sqrt), fs1 = std::floor(s + 2 * inv_det * u_sqrt);
    const float ft0 = std::ceil(t - 2 * inv_det * v_sqrt), ft1 = std::floor(t + 2 * inv_det * v_sqrt);
    for (int k = 0; k < nch_; ++k) out[k] = 0.f;
    if (!(fs1 - fs0 < 1e6f && ft1 - ft0 < 1e6f && std::abs(fs0) < 1e9f && std::abs(ft0) < 1e9f))
        return;  // a non-finite or absurd footprint
    const int s0 = int(fs0), s1 = int(fs1), t0 = int(ft0), t1 = int(ft1);
    const std::array<float, kEwaLutSize> &lut = ewa_lut();
    float sum[kMaxChannels] = {0, 0, 0, 0}, sum_w = 0;
    for (int it = t0; it <= t1; ++it) {
        const float tt = float(it) - t;
        for (int is = s0; is <= s1; ++is) {
            const float ss = float(is) - s;
            const float r2 = a * ss * ss + b * ss * tt + c * tt * tt;
            if (r2 < 1) {
                const int idx = std::min(int(r2 * kEwaLutSize), kEwaLutSize - 1);
                const float w = lut[size_t(idx)];
                float v[kMaxChannels];
                texel(level, is, it, v);
                for (int k = 0; k < nch_; ++k) sum[k] += w * v[k];
                sum_w += w;
            }
        }
    }
    if (sum_w > 0.f)
        for (int k = 0; k < nch_; ++k) out[k] = sum[k] / sum_w;
}

}  // namespace tessera
