// An in-memory image pyramid with pbrt-v4's filtered lookups (PBRT 4th ed., section 10.4.3,
// "Image Texture Evaluation"; pbrt-v4's Image::GeneratePyramid and MIPMap::Filter), for the
// image maps of a scene.
//
// Building: an image whose width or height is not a power of two is first resampled up to the
// next powers of two with a separable windowed sinc (radius 2, tau 2, four taps per output
// texel, pbrt-v4's Image::FloatResizeUp; values below 0 are clamped to 0); each further level
// is the 2x2 box average of the one below, down to 1x1, so there are 1 + log2(max(w, h))
// levels. Texels are linear floats (pbrt-v4 stores 8-bit levels re-encoded in 8 bits; the
// difference is below one 8-bit step).
//
// Lookups take pbrt's image coordinates: s grows to the right, t downwards from the image's
// top row (a texture's (s, 1 - t)), one unit across the image, and the footprint derivatives
// dst0 = (ds/dx, dt/dx), dst1 = (ds/dy, dt/dy) of the texture's (s, t) as pbrt-v4 passes them
// (its t-derivatives are not negated with t; only EWA's ellipse orientation sees the sign).
//   Point      the nearest texel of the level the footprint width selects
//   Bilinear   bilinear interpolation on that level
//   Trilinear  bilinear on the two levels around the width, blended (level 0 alone where the
//              width selects a level below 1, as pbrt-v4 does)
//   Ewa        Heckbert's elliptically weighted average with a Gaussian weight table on the
//              two levels around the minor axis, the major axis clamped to max_anisotropy
//              times the minor one (Greene and Heckbert 1986)
// A footprint wider than the image returns the 1x1 level. Texel addresses wrap per MipWrap
// (pbrt-v4 WrapMode: repeat, black, clamp). Immutable after construction; lookups are
// thread-safe.
#pragma once

#include <cstddef>
#include <vector>

#include "sampling/vecmath.h"

namespace tessera {

enum class MipFilter { Point, Bilinear, Trilinear, Ewa };
enum class MipWrap { Repeat, Black, Clamp };

class MipMap {
  public:
    static constexpr int kMaxChannels = 4;

    /// `pixels`: width x height x channels linear floats, row-major, row 0 the image's top
    /// row. channels in [1, kMaxChannels].
    MipMap(int width, int height, int channels, std::vector<float> pixels, MipWrap wrap,
           MipFilter filter, float max_anisotropy = 8.f);

    /// Bytes the pyramid of a width x height x channels image takes (power-of-two resampling
    /// included), to decide before building one.
    static size_t pyramid_bytes(int width, int height, int channels);

    int channels() const { return nch_; }
    int levels() const { return int(levels_.size()); }
    int level_width(int level) const { return levels_[size_t(level)].w; }
    int level_height(int level) const { return levels_[size_t(level)].h; }
    size_t bytes() const;
    MipFilter filter_mode() const { return filter_; }

    /// The filtered value at `st` for the footprint (dst0, dst1): channels() floats to `out`.
    void filter(Vec2f st, Vec2f dst0, Vec2f dst1, float *out) const;

    /// One texel of a level, its address wrapped (black outside for MipWrap::Black).
    void texel(int level, int x, int y, float *out) const;
    /// Bilinear interpolation of a level at `st` (texel centres at (i + 0.5) / width).
    void bilerp(int level, Vec2f st, float *out) const;

  private:
    struct Level {
        int w = 0, h = 0;
        std::vector<float> px;
    };
    /// Wraps (x, y) into the level; false where MipWrap::Black leaves it outside.
    bool remap(const Level &l, int &x, int &y) const;
    void ewa(int level, Vec2f st, Vec2f dst0, Vec2f dst1, float *out) const;

    std::vector<Level> levels_;
    int nch_ = 1;
    MipWrap wrap_ = MipWrap::Repeat;
    MipFilter filter_ = MipFilter::Bilinear;
    float max_aniso_ = 8.f;
};

}  // namespace tessera
