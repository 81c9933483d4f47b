#include "renderer/media/medium.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "renderer/util/noise.h"
#include "renderer/util/spectra.h"

namespace tessera {

// --- MajorantIterator -------------------------------------------------------------------------

MajorantIterator MajorantIterator::single(float t0, float t1, Rgb sigma_maj) {
    MajorantIterator it;
    it.kind_ = Kind::Single;
    it.t_min_ = t0;
    it.t_max_ = t1;
    it.sigma_t_ = sigma_maj;
    return it;
}

MajorantIterator MajorantIterator::dda(Vec3f o, Vec3f d, float t0, float t1,
                                       const MajorantGrid *grid, Rgb sigma_t) {
    MajorantIterator it;
    it.kind_ = Kind::Dda;
    it.t_min_ = t0;
    it.t_max_ = t1;
    it.sigma_t_ = sigma_t;
    it.grid_ = grid;
    const Vec3f p = o + d * t0;
    for (int a = 0; a < 3; ++a) {
        const int res = grid->res[a];
        it.voxel_[a] = std::clamp(int(p[a] * float(res)), 0, res - 1);
        it.delta_t_[a] = 1.f / (std::abs(d[a]) * float(res));
        float da = d[a] == -0.f ? 0.f : d[a];
        if (da >= 0) {
            const float next_pos = float(it.voxel_[a] + 1) / float(res);
            it.next_crossing_[a] = t0 + (next_pos - p[a]) / da;
            it.step_[a] = 1;
            it.voxel_limit_[a] = res;
        } else {
            const float next_pos = float(it.voxel_[a]) / float(res);
            it.next_crossing_[a] = t0 + (next_pos - p[a]) / da;
            it.step_[a] = -1;
            it.voxel_limit_[a] = -1;
        }
    }
    return it;
}

bool MajorantIterator::next(MajorantSegment *seg) {
    if (kind_ == Kind::None || !(t_min_ < t_max_)) return false;
    if (kind_ == Kind::Single) {
        *seg = {t_min_, t_max_, sigma_t_};
        kind_ = Kind::None;
        return true;
    }
    // The axis whose voxel boundary the ray crosses first (pbrt-v4 DDAMajorantIterator::Next).
    const int bits = ((next_crossing_[0] < next_crossing_[1]) << 2) +
                     ((next_crossing_[0] < next_crossing_[2]) << 1) +
                     (next_crossing_[1] < next_crossing_[2]);
    static constexpr int kCmpToAxis[8] = {2, 1, 2, 1, 2, 2, 0, 0};
    const int axis = kCmpToAxis[bits];
    const float t_exit = std::min(t_max_, next_crossing_[axis]);
    *seg = {t_min_, t_exit, sigma_t_ * grid_->at(voxel_[0], voxel_[1], voxel_[2])};
    t_min_ = t_exit;
    if (next_crossing_[axis] > t_max_) t_min_ = t_max_;
    voxel_[axis] += step_[axis];
    if (voxel_[axis] == voxel_limit_[axis]) t_min_ = t_max_;
    next_crossing_[axis] += delta_t_[axis];
    return true;
}

namespace {

Vec3f vdiv(Vec3f a, Vec3f b) { return {a.x / b.x, a.y / b.y, a.z / b.z}; }

// --- grids --------------------------------------------------------------------------------------

/// Samples at the centres of nx x ny x nz cells over [0,1]^3, trilinearly interpolated, zero
/// outside the samples (pbrt-v4 SampledGrid).
template <class T>
struct SampledGrid {
    int nx = 1, ny = 1, nz = 1;
    std::vector<T> values;

    T at(int x, int y, int z) const {
        if (x < 0 || y < 0 || z < 0 || x >= nx || y >= ny || z >= nz) return T(0.f);
        return values[size_t((z * ny + y) * nx + x)];
    }
    T lookup(Vec3f p) const {
        const float sx = p.x * float(nx) - .5f, sy = p.y * float(ny) - .5f,
                    sz = p.z * float(nz) - .5f;
        const int ix = int(std::floor(sx)), iy = int(std::floor(sy)), iz = int(std::floor(sz));
        const float dx = sx - float(ix), dy = sy - float(iy), dz = sz - float(iz);
        auto lerp1 = [](float t, T a, T b) { return a * (1.f - t) + b * t; };
        if (ix >= 0 && iy >= 0 && iz >= 0 && ix + 1 < nx && iy + 1 < ny && iz + 1 < nz) {
            // All eight samples inside (most lookups): index them directly.
            const size_t sx1 = 1, sy1 = size_t(nx), sz1 = size_t(nx) * size_t(ny);
            const T *v = &values[size_t(iz) * sz1 + size_t(iy) * sy1 + size_t(ix)];
            const T e00 = lerp1(dx, v[0], v[sx1]), e10 = lerp1(dx, v[sy1], v[sy1 + sx1]);
            const T e01 = lerp1(dx, v[sz1], v[sz1 + sx1]);
            const T e11 = lerp1(dx, v[sz1 + sy1], v[sz1 + sy1 + sx1]);
            return lerp1(dz, lerp1(dy, e00, e10), lerp1(dy, e01, e11));
        }
        const T d00 = lerp1(dx, at(ix, iy, iz), at(ix + 1, iy, iz));
        const T d10 = lerp1(dx, at(ix, iy + 1, iz), at(ix + 1, iy + 1, iz));
        const T d01 = lerp1(dx, at(ix, iy, iz + 1), at(ix + 1, iy, iz + 1));
        const T d11 = lerp1(dx, at(ix, iy + 1, iz + 1), at(ix + 1, iy + 1, iz + 1));
        return lerp1(dz, lerp1(dy, d00, d10), lerp1(dy, d01, d11));
    }
    /// The largest `scalar(value)` among the samples whose interpolation reaches the box
    /// [lo, hi] of [0,1]^3 (pbrt-v4 SampledGrid::MaxValue).
    template <class S>
    float max_value(Vec3f lo, Vec3f hi, S scalar) const {
        const int n[3] = {nx, ny, nz};
        int i0[3], i1[3];
        for (int a = 0; a < 3; ++a) {
            i0[a] = std::max(int(std::floor(lo[a] * float(n[a]) - .5f)), 0);
            i1[a] = std::min(int(std::floor(hi[a] * float(n[a]) - .5f)) + 1, n[a] - 1);
        }
        float m = scalar(at(i0[0], i0[1], i0[2]));
        for (int z = i0[2]; z <= i1[2]; ++z)
            for (int y = i0[1]; y <= i1[1]; ++y)
                for (int x = i0[0]; x <= i1[0]; ++x) m = std::max(m, scalar(at(x, y, z)));
        return m;
    }
};

/// Fills a 16^3 majorant grid with `max_in(lo, hi)` over each voxel's box.
template <class F>
MajorantGrid make_majorant_grid(F max_in) {
    MajorantGrid g;
    g.voxels.resize(size_t(g.res[0]) * g.res[1] * g.res[2]);
    for (int z = 0; z < g.res[2]; ++z)
        for (int y = 0; y < g.res[1]; ++y)
            for (int x = 0; x < g.res[0]; ++x) {
                Vec3f lo(float(x) / g.res[0], float(y) / g.res[1], float(z) / g.res[2]);
                Vec3f hi(float(x + 1) / g.res[0], float(y + 1) / g.res[1],
                         float(z + 1) / g.res[2]);
                g.voxels[size_t(x + g.res[0] * (y + g.res[1] * z))] = max_in(lo, hi);
            }
    return g;
}

/// Ray-box slab test in medium space: the parametric overlap of [0, t_max) with the box.
bool intersect_box(Vec3f lo, Vec3f hi, Vec3f o, Vec3f d, float t_max, float *t0, float *t1) {
    float a = 0.f, b = t_max;
    for (int i = 0; i < 3; ++i) {
        const float inv = 1.f / d[i];
        float tn = (lo[i] - o[i]) * inv, tf = (hi[i] - o[i]) * inv;
        if (tn > tf) std::swap(tn, tf);
        tf *= 1 + 2 * gamma_n(3);  // pbrt-v4 Bounds3::IntersectP: robust far bound
        a = tn > a ? tn : a;
        b = tf < b ? tf : b;
        if (a > b) return false;
    }
    *t0 = a;
    *t1 = b;
    return true;
}

// --- homogeneous --------------------------------------------------------------------------------

class HomogeneousMedium final : public Medium {
  public:
    HomogeneousMedium(Rgb sigma_a, Rgb sigma_s, Rgb Le) : mp_{sigma_a, sigma_s, Le} {}
    MediumProperties sample_point(Vec3f) const override { return mp_; }
    MajorantIterator sample_ray(const Ray &, float t_max) const override {
        return MajorantIterator::single(0.f, t_max, mp_.sigma_a + mp_.sigma_s);
    }
    bool is_emissive() const override { return mp_.Le.max_value() > 0.f; }
    bool constant_properties(MediumProperties *mp) const override {
        *mp = mp_;
        return true;
    }
    std::string describe() const override {
        char buf[256];
        std::snprintf(buf, sizeof(buf),
                      "homogeneous \"%s\": sigma_a (%g %g %g) sigma_s (%g %g %g) g %g%s",
                      name.c_str(), mp_.sigma_a.r, mp_.sigma_a.g, mp_.sigma_a.b, mp_.sigma_s.r,
                      mp_.sigma_s.g, mp_.sigma_s.b, phase.g, is_emissive() ? ", emissive" : "");
        return buf;
    }

  private:
    MediumProperties mp_;
};

// --- grids (uniformgrid, rgbgrid) -------------------------------------------------------------

/// What the two grid media share: the box p0..p1 in medium space, the transform, the majorant
/// grid and the ray walk.
class BoxMedium : public Medium {
  public:
    BoxMedium(Vec3f p0, Vec3f p1, const Transform &render_from_medium)
        : lo_(vmin(p0, p1)), hi_(vmax(p0, p1)), xf_(render_from_medium) {}
    MajorantIterator sample_ray(const Ray &ray, float t_max) const override {
        const Vec3f o = xf_.inverse_point(ray.o), d = xf_.inverse_vector(ray.d);
        float t0, t1;
        if (!intersect_box(lo_, hi_, o, d, t_max, &t0, &t1)) return {};
        const Vec3f diag = hi_ - lo_;
        const Vec3f og = vdiv(o - lo_, diag), dg = vdiv(d, diag);
        return MajorantIterator::dda(og, dg, t0, t1, &majorants_, sigma_t_scale_);
    }

  protected:
    /// Render-space point -> [0,1]^3 of the box.
    Vec3f to_grid(Vec3f p) const { return vdiv(xf_.inverse_point(p) - lo_, hi_ - lo_); }
    /// Outside the box the medium is vacuum (the interpolation would reach half a cell out;
    /// the majorant walk never asks there).
    static bool outside(Vec3f g) {
        return !(g.x >= 0.f && g.x <= 1.f && g.y >= 0.f && g.y <= 1.f && g.z >= 0.f && g.z <= 1.f);
    }
    Vec3f lo_, hi_;
    Transform xf_;
    MajorantGrid majorants_;
    Rgb sigma_t_scale_{1.f};  ///< a segment's majorant is this times the voxel's value
};

/// Temperatures to the emitted colour of pbrt-v4's (peak-normalised) blackbody, tabulated
/// every 10 K up to 40000 K and interpolated.
class BlackbodyTable {
  public:
    BlackbodyTable() {
        table_.resize(kCount);
        for (int i = 0; i < kCount; ++i) table_[size_t(i)] = blackbody_peak_rgb(float(i) * kStep);
    }
    Rgb operator()(float kelvin) const {
        float x = std::clamp(kelvin / kStep, 0.f, float(kCount - 1));
        int i = std::min(int(x), kCount - 2);
        float f = x - float(i);
        return table_[size_t(i)] * (1.f - f) + table_[size_t(i + 1)] * f;
    }

  private:
    static constexpr int kCount = 4001;
    static constexpr float kStep = 10.f;
    std::vector<Rgb> table_;
};

class DensityGridMedium final : public BoxMedium {
  public:
    DensityGridMedium(Vec3f p0, Vec3f p1, const Transform &xf, Rgb sigma_a, Rgb sigma_s,
                      SampledGrid<float> density, std::optional<SampledGrid<float>> temperature,
                      float temperature_scale, float temperature_offset, Rgb Le,
                      SampledGrid<float> Le_scale)
        : BoxMedium(p0, p1, xf), sigma_a_(sigma_a), sigma_s_(sigma_s),
          density_(std::move(density)), temperature_(std::move(temperature)),
          temperature_scale_(temperature_scale), temperature_offset_(temperature_offset),
          Le_(Le), Le_scale_(std::move(Le_scale)) {
        emissive_ = temperature_ ? true : Le_.max_value() > 0.f;
        if (temperature_) blackbody_ = std::make_unique<BlackbodyTable>();
        sigma_t_scale_ = sigma_a_ + sigma_s_;
        majorants_ = make_majorant_grid([&](Vec3f lo, Vec3f hi) {
            return density_.max_value(lo, hi, [](float v) { return v; });
        });
    }
    MediumProperties sample_point(Vec3f pr) const override {
        const Vec3f p = to_grid(pr);
        if (outside(p)) return {};
        const float d = density_.lookup(p);
        MediumProperties mp{sigma_a_ * d, sigma_s_ * d, Rgb(0.f)};
        if (emissive_) {
            const float scale = Le_scale_.lookup(p);
            if (scale > 0.f) {
                if (temperature_) {
                    float temp = (temperature_->lookup(p) - temperature_offset_) *
                                 temperature_scale_;
                    // pbrt-v4: "There's probably not much light coming from it" below 100 K.
                    if (temp > 100.f) mp.Le = (*blackbody_)(temp) * scale;
                } else {
                    mp.Le = Le_ * scale;
                }
            }
        }
        return mp;
    }
    bool is_emissive() const override { return emissive_; }
    std::string describe() const override {
        char buf[256];
        std::snprintf(buf, sizeof(buf), "uniformgrid \"%s\": %dx%dx%d density, g %g%s",
                      name.c_str(), density_.nx, density_.ny, density_.nz, phase.g,
                      temperature_ ? ", temperature" : (emissive_ ? ", emissive" : ""));
        return buf;
    }

  private:
    Rgb sigma_a_, sigma_s_;
    SampledGrid<float> density_;
    std::optional<SampledGrid<float>> temperature_;
    float temperature_scale_, temperature_offset_;
    Rgb Le_;
    SampledGrid<float> Le_scale_;
    bool emissive_ = false;
    std::unique_ptr<BlackbodyTable> blackbody_;
};

class RgbGridMedium final : public BoxMedium {
  public:
    RgbGridMedium(Vec3f p0, Vec3f p1, const Transform &xf,
                  std::optional<SampledGrid<Rgb>> sigma_a,
                  std::optional<SampledGrid<Rgb>> sigma_s, float sigma_scale,
                  std::optional<SampledGrid<Rgb>> Le, float Le_scale)
        : BoxMedium(p0, p1, xf), sigma_a_(std::move(sigma_a)), sigma_s_(std::move(sigma_s)),
          sigma_scale_(sigma_scale), Le_(std::move(Le)), Le_scale_(Le_scale) {
        auto mx = [](Rgb v) { return v.max_value(); };
        majorants_ = make_majorant_grid([&](Vec3f lo, Vec3f hi) {
            float a = sigma_a_ ? sigma_a_->max_value(lo, hi, mx) : 1.f;
            float s = sigma_s_ ? sigma_s_->max_value(lo, hi, mx) : 1.f;
            return sigma_scale_ * (a + s);
        });
        sigma_t_scale_ = Rgb(1.f);
    }
    MediumProperties sample_point(Vec3f pr) const override {
        const Vec3f p = to_grid(pr);
        if (outside(p)) return {};
        MediumProperties mp;
        mp.sigma_a = (sigma_a_ ? clamp_zero(sigma_a_->lookup(p)) : Rgb(1.f)) * sigma_scale_;
        mp.sigma_s = (sigma_s_ ? clamp_zero(sigma_s_->lookup(p)) : Rgb(1.f)) * sigma_scale_;
        if (Le_ && Le_scale_ > 0.f) mp.Le = clamp_zero(Le_->lookup(p)) * Le_scale_;
        return mp;
    }
    bool is_emissive() const override { return Le_ && Le_scale_ > 0.f; }
    std::string describe() const override {
        const SampledGrid<Rgb> &g = sigma_a_ ? *sigma_a_ : *sigma_s_;
        char buf[256];
        std::snprintf(buf, sizeof(buf), "rgbgrid \"%s\": %dx%dx%d, g %g%s", name.c_str(), g.nx,
                      g.ny, g.nz, phase.g, is_emissive() ? ", emissive" : "");
        return buf;
    }

  private:
    std::optional<SampledGrid<Rgb>> sigma_a_, sigma_s_;
    float sigma_scale_;
    std::optional<SampledGrid<Rgb>> Le_;
    float Le_scale_;
};

/// pbrt-v4's procedural "cloud": fractal Perlin noise (two octaves of gradient-noise warping
/// scaled by "wispiness", five octaves of noise) in the box p0..p1, thinning with height and
/// dense below half the box (pbrt-v4 CloudMedium::Density, operation for operation). The
/// density is in [0, 1], so sigma_a + sigma_s bounds it along the whole box.
class CloudMedium final : public BoxMedium {
  public:
    CloudMedium(Vec3f p0, Vec3f p1, const Transform &xf, Rgb sigma_a, Rgb sigma_s,
                float density, float wispiness, float frequency)
        : BoxMedium(p0, p1, xf), sigma_a_(sigma_a), sigma_s_(sigma_s), density_(density),
          wispiness_(wispiness), frequency_(frequency) {}
    MediumProperties sample_point(Vec3f pr) const override {
        const Vec3f p = to_grid(pr);
        if (outside(p)) return {};
        const float d = density(p);
        return {sigma_a_ * d, sigma_s_ * d, Rgb(0.f)};
    }
    MajorantIterator sample_ray(const Ray &ray, float t_max) const override {
        const Vec3f o = xf_.inverse_point(ray.o), dir = xf_.inverse_vector(ray.d);
        float t0, t1;
        if (!intersect_box(lo_, hi_, o, dir, t_max, &t0, &t1)) return {};
        return MajorantIterator::single(t0, t1, sigma_a_ + sigma_s_);
    }
    bool is_emissive() const override { return false; }
    std::string describe() const override {
        char buf[200];
        std::snprintf(buf, sizeof(buf), "cloud \"%s\": density %g, wispiness %g, frequency %g",
                      name.c_str(), density_, wispiness_, frequency_);
        return buf;
    }

  private:
    float density(Vec3f p) const {
        Vec3f pp = p * frequency_;
        if (wispiness_ > 0) {
            float vomega = 0.05f * wispiness_, vlambda = 10.f;
            for (int i = 0; i < 2; ++i) {
                pp += perlin_dnoise(pp * vlambda) * vomega;
                vomega *= 0.5f;
                vlambda *= 1.99f;
            }
        }
        float d = 0, omega = 0.5f, lambda = 1.f;
        for (int i = 0; i < 5; ++i) {
            d += omega * perlin_noise(pp * lambda);
            omega *= 0.5f;
            lambda *= 1.99f;
        }
        d = clamp((1 - p.y) * 4.5f * density_ * d, 0.f, 1.f);
        d += 2 * std::max(0.f, 0.5f - p.y);
        return clamp(d, 0.f, 1.f);
    }
    Rgb sigma_a_, sigma_s_;
    float density_, wispiness_, frequency_;
};

// --- construction -------------------------------------------------------------------------------

struct Preset {
    const char *name;
    Rgb sigma_prime_s, sigma_a;  // 1/mm
};

// pbrt-v4 GetMediumScatteringProperties: Jensen, Marschner, Levoy and Hanrahan 2001, "A
// Practical Model for Subsurface Light Transport" (the first twelve), and Narasimhan, Gupta,
// Donner, Ramamoorthi, Nayar and Jensen 2006, "Acquiring Scattering Properties of Participating
// Media by Dilution" (the rest). Reduced scattering sigma_s', absorption sigma_a, in 1/mm.
constexpr Preset kPresets[] = {
    {"Apple", {2.29f, 2.39f, 1.97f}, {0.0030f, 0.0034f, 0.046f}},
    {"Chicken1", {0.15f, 0.21f, 0.38f}, {0.015f, 0.077f, 0.19f}},
    {"Chicken2", {0.19f, 0.25f, 0.32f}, {0.018f, 0.088f, 0.20f}},
    {"Cream", {7.38f, 5.47f, 3.15f}, {0.0002f, 0.0028f, 0.0163f}},
    {"Ketchup", {0.18f, 0.07f, 0.03f}, {0.061f, 0.97f, 1.45f}},
    {"Marble", {2.19f, 2.62f, 3.00f}, {0.0021f, 0.0041f, 0.0071f}},
    {"Potato", {0.68f, 0.70f, 0.55f}, {0.0024f, 0.0090f, 0.12f}},
    {"Skimmilk", {0.70f, 1.22f, 1.90f}, {0.0014f, 0.0025f, 0.0142f}},
    {"Skin1", {0.74f, 0.88f, 1.01f}, {0.032f, 0.17f, 0.48f}},
    {"Skin2", {1.09f, 1.59f, 1.79f}, {0.013f, 0.070f, 0.145f}},
    {"Spectralon", {11.6f, 20.4f, 14.9f}, {0.00f, 0.00f, 0.00f}},
    {"Wholemilk", {2.55f, 3.21f, 3.77f}, {0.0011f, 0.0024f, 0.014f}},
    {"Lowfat Milk", {0.89187f, 1.5136f, 2.532f}, {0.002875f, 0.00575f, 0.0115f}},
    {"Reduced Milk", {2.4858f, 3.1669f, 4.5214f}, {0.0025556f, 0.0051111f, 0.012778f}},
    {"Regular Milk", {4.5513f, 5.8294f, 7.136f}, {0.0015333f, 0.0046f, 0.019933f}},
    {"Espresso", {0.72378f, 0.84557f, 1.0247f}, {4.7984f, 6.5751f, 8.8493f}},
    {"Mint Mocha Coffee", {0.31602f, 0.38538f, 0.48131f}, {3.772f, 5.8228f, 7.82f}},
    {"Lowfat Soy Milk", {0.30576f, 0.34233f, 0.61664f}, {0.0014375f, 0.0071875f, 0.035937f}},
    {"Regular Soy Milk", {0.59223f, 0.73866f, 1.4693f}, {0.0019167f, 0.0095833f, 0.065167f}},
    {"Lowfat Chocolate Milk", {0.64925f, 0.83916f, 1.1057f}, {0.0115f, 0.0368f, 0.1564f}},
    {"Regular Chocolate Milk", {1.4585f, 2.1289f, 2.9527f}, {0.010063f, 0.043125f, 0.14375f}},
    {"Coke", {8.9053e-05f, 8.372e-05f, 0.f}, {0.10014f, 0.16503f, 0.2468f}},
    {"Pepsi", {6.1697e-05f, 4.2564e-05f, 0.f}, {0.091641f, 0.14158f, 0.20729f}},
    {"Sprite", {6.0306e-06f, 6.4139e-06f, 6.5504e-06f}, {0.001886f, 0.0018308f, 0.0020025f}},
    {"Gatorade", {0.0024574f, 0.003007f, 0.0037325f}, {0.024794f, 0.019289f, 0.008878f}},
    {"Chardonnay", {1.7982e-05f, 1.3758e-05f, 1.2023e-05f}, {0.010782f, 0.011855f, 0.023997f}},
    {"White Zinfandel", {1.7501e-05f, 1.9069e-05f, 1.288e-05f},
     {0.012072f, 0.016184f, 0.019843f}},
    {"Merlot", {2.1129e-05f, 0.f, 0.f}, {0.11632f, 0.25191f, 0.29434f}},
    {"Budweiser Beer", {2.4356e-05f, 2.4079e-05f, 1.0564e-05f},
     {0.011492f, 0.024911f, 0.057786f}},
    {"Coors Light Beer", {5.0922e-05f, 4.301e-05f, 0.f}, {0.006164f, 0.013984f, 0.034983f}},
    {"Clorox", {0.0024035f, 0.0031373f, 0.003991f}, {0.0033542f, 0.014892f, 0.026297f}},
    {"Apple Juice", {0.00013612f, 0.00015836f, 0.000227f}, {0.012957f, 0.023741f, 0.052184f}},
    {"Cranberry Juice", {0.00010402f, 0.00011646f, 7.8139e-05f},
     {0.039437f, 0.094223f, 0.12426f}},
    {"Grape Juice", {5.382e-05f, 0.f, 0.f}, {0.10404f, 0.23958f, 0.29325f}},
    {"Ruby Grapefruit Juice", {0.011002f, 0.010927f, 0.011036f},
     {0.085867f, 0.18314f, 0.25262f}},
    {"White Grapefruit Juice", {0.22826f, 0.23998f, 0.32748f}, {0.0138f, 0.018831f, 0.056781f}},
    {"Shampoo", {0.0007176f, 0.0008303f, 0.0009016f}, {0.014107f, 0.045693f, 0.061717f}},
    {"Strawberry Shampoo", {0.00015671f, 0.00015947f, 1.518e-05f},
     {0.01449f, 0.05796f, 0.075823f}},
    {"Head & Shoulders Shampoo", {0.023805f, 0.028804f, 0.034306f},
     {0.084621f, 0.15688f, 0.20365f}},
    {"Lemon Tea Powder", {0.040224f, 0.045264f, 0.051081f}, {2.4288f, 4.5757f, 7.2127f}},
    {"Orange Powder", {0.00015617f, 0.00017482f, 0.0001762f}, {0.001449f, 0.003441f, 0.007863f}},
    {"Pink Lemonade Powder", {0.00012103f, 0.00013073f, 0.00012528f},
     {0.001165f, 0.002366f, 0.003195f}},
    {"Cappuccino Powder", {1.8436f, 2.5851f, 2.1662f}, {35.844f, 49.547f, 61.084f}},
    {"Salt Powder", {0.027333f, 0.032451f, 0.031979f}, {0.28415f, 0.3257f, 0.34148f}},
    {"Sugar Powder", {0.00022272f, 0.00025513f, 0.000271f}, {0.012638f, 0.031051f, 0.050124f}},
    {"Suisse Mocha Powder", {2.7979f, 3.5452f, 4.3365f}, {17.502f, 27.004f, 35.433f}},
    {"Pacific Ocean Surface Water", {0.0001764f, 0.00032095f, 0.00019617f},
     {0.031845f, 0.031324f, 0.030147f}},
};

/// A spectrum-valued coefficient (sigma_a, sigma_s): rgb, spectrum or float; default 1.
Rgb coefficient(const ParamSet &ps, const char *name) {
    if (const Param *p = ps.find(name); p && p->type == "texture")
        throw SceneError(p->loc, std::string("medium parameter \"") + name +
                                     "\" cannot be a texture");
    return ps.get_rgb(name, false, true).value_or(Rgb(1.f));
}

/// The emission "Le" (an illuminant: luminance-normalised as pbrt-v4 divides by the
/// photometric value), zero when absent.
Rgb emission(const ParamSet &ps) { return ps.get_rgb("Le", true, true).value_or(Rgb(0.f)); }

void check_finite_nonnegative(const Param *p, const std::vector<float> &v) {
    for (float x : v)
        if (!std::isfinite(x) || x < 0.f)
            throw SceneError(p->loc, "\"" + p->name + "\": values must be finite and >= 0");
}

/// nx, ny, nz: positive, and their product the count of `what`'s values.
void grid_resolution(const MediumDesc &d, size_t count, const char *what, int n[3]) {
    const ParamSet &ps = d.params;
    const char *names[3] = {"nx", "ny", "nz"};
    for (int a = 0; a < 3; ++a) {
        n[a] = ps.get_int(names[a], 1);
        if (n[a] < 1) {
            const Param *p = ps.find(names[a]);
            throw SceneError(p ? p->loc : d.loc, std::string("MakeNamedMedium \"") + d.name +
                                                     "\": \"" + names[a] + "\" must be >= 1");
        }
    }
    const uint64_t want = uint64_t(n[0]) * uint64_t(n[1]) * uint64_t(n[2]);
    if (want != count) {
        const Param *p = ps.find(what);
        throw SceneError(p ? p->loc : d.loc,
                         "MakeNamedMedium \"" + d.name + "\": " + std::to_string(count) +
                             " \"" + what + "\" values; expected nx*ny*nz = " +
                             std::to_string(want));
    }
}

std::vector<Rgb> rgb_array(const ParamSet &ps, const char *name) {
    const Param *p = ps.find(name);
    if (!p) return {};
    if (p->type != "rgb")
        throw SceneError(p->loc, std::string("\"") + name + "\": expected \"rgb\" values, got \"" +
                                     p->type + "\"");
    p->used = true;
    if (p->numbers.size() % 3 != 0)
        throw SceneError(p->loc, std::string("\"") + name +
                                     "\": the number of values is not a multiple of 3");
    std::vector<Rgb> out;
    out.reserve(p->numbers.size() / 3);
    for (size_t i = 0; i + 2 < p->numbers.size(); i += 3) {
        Rgb v(float(p->numbers[i]), float(p->numbers[i + 1]), float(p->numbers[i + 2]));
        if (!v.is_finite() || v.r < 0 || v.g < 0 || v.b < 0)
            throw SceneError(p->loc, std::string("\"") + name +
                                         "\": values must be finite and >= 0");
        out.push_back(v);
    }
    return out;
}

float phase_g(const MediumDesc &d) {
    float g = d.params.get_float("g", 0.f);
    if (!(g > -1.f && g < 1.f)) {
        const Param *p = d.params.find("g");
        throw SceneError(p ? p->loc : d.loc, "MakeNamedMedium \"" + d.name +
                                                 "\": \"g\" must be in (-1, 1)");
    }
    return g;
}

std::unique_ptr<Medium> make_homogeneous(const MediumDesc &d) {
    const ParamSet &ps = d.params;
    Rgb sigma_a, sigma_s;
    bool have_preset = false;
    if (std::string preset = ps.get_string("preset", ""); !preset.empty()) {
        have_preset = medium_preset(preset, &sigma_a, &sigma_s);
        if (!have_preset)
            warn(ps.find("preset")->loc, "medium preset \"" + preset + "\" not found");
    }
    if (!have_preset) {
        sigma_a = coefficient(ps, "sigma_a");
        sigma_s = coefficient(ps, "sigma_s");
    }
    const float scale = ps.get_float("scale", 1.f);
    Rgb Le = emission(ps) * ps.get_float("Lescale", 1.f);
    auto m = std::make_unique<HomogeneousMedium>(sigma_a * scale, sigma_s * scale, clamp_zero(Le));
    m->phase.g = phase_g(d);
    return m;
}

std::unique_ptr<Medium> make_uniform_grid(const MediumDesc &d) {
    const ParamSet &ps = d.params;
    const Param *pd = ps.find("density");
    if (!pd)
        throw SceneError(d.loc, "MakeNamedMedium \"" + d.name +
                                    "\": no \"density\" values for the grid medium");
    std::vector<float> density = ps.get_floats("density");
    check_finite_nonnegative(pd, density);
    int n[3];
    grid_resolution(d, density.size(), "density", n);
    std::optional<SampledGrid<float>> temperature;
    if (const Param *pt = ps.find("temperature")) {
        std::vector<float> t = ps.get_floats("temperature");
        if (t.size() != density.size())
            throw SceneError(pt->loc, "MakeNamedMedium \"" + d.name + "\": " +
                                          std::to_string(t.size()) + " \"temperature\" values "
                                          "for " + std::to_string(density.size()) +
                                          " \"density\" values");
        temperature = SampledGrid<float>{n[0], n[1], n[2], std::move(t)};
    }
    Rgb Le(0.f);
    if (const Param *pl = ps.find("Le")) {
        if (temperature)
            throw SceneError(pl->loc, "MakeNamedMedium \"" + d.name +
                                          "\": both \"Le\" and \"temperature\" were given");
        Le = clamp_zero(emission(ps));
    }
    // Without "Lescale" pbrt-v4 scales by a 1x1x1 grid of 1, whose interpolation (zero outside
    // the samples) falls off toward the box's faces; Tessera keeps that grid as it is.
    SampledGrid<float> Le_scale{1, 1, 1, {1.f}};
    if (const Param *pl = ps.find("Lescale")) {
        std::vector<float> s = ps.get_floats("Lescale");
        check_finite_nonnegative(pl, s);
        if (s.size() != density.size())
            throw SceneError(pl->loc, "MakeNamedMedium \"" + d.name + "\": expected " +
                                          std::to_string(density.size()) +
                                          " \"Lescale\" values, got " + std::to_string(s.size()));
        Le_scale = SampledGrid<float>{n[0], n[1], n[2], std::move(s)};
    }
    const Vec3f p0 = ps.get_point3("p0", {0, 0, 0}), p1 = ps.get_point3("p1", {1, 1, 1});
    const float scale = ps.get_float("scale", 1.f);
    const Rgb sigma_a = coefficient(ps, "sigma_a") * scale;
    const Rgb sigma_s = coefficient(ps, "sigma_s") * scale;
    const float t_offset =
        ps.get_float("temperatureoffset", ps.get_float("temperaturecutoff", 0.f));
    const float t_scale = ps.get_float("temperaturescale", 1.f);
    auto m = std::make_unique<DensityGridMedium>(
        p0, p1, d.render_from_medium, sigma_a, sigma_s,
        SampledGrid<float>{n[0], n[1], n[2], std::move(density)}, std::move(temperature),
        t_scale, t_offset, Le, std::move(Le_scale));
    m->phase.g = phase_g(d);
    return m;
}

std::unique_ptr<Medium> make_cloud(const MediumDesc &d) {
    const ParamSet &ps = d.params;
    const Vec3f p0 = ps.get_point3("p0", {0, 0, 0}), p1 = ps.get_point3("p1", {1, 1, 1});
    auto m = std::make_unique<CloudMedium>(p0, p1, d.render_from_medium, coefficient(ps, "sigma_a"),
                                           coefficient(ps, "sigma_s"), ps.get_float("density", 1.f),
                                           ps.get_float("wispiness", 1.f),
                                           ps.get_float("frequency", 5.f));
    m->phase.g = phase_g(d);
    return m;
}

std::unique_ptr<Medium> make_rgb_grid(const MediumDesc &d) {
    const ParamSet &ps = d.params;
    std::vector<Rgb> sa = rgb_array(ps, "sigma_a"), ss = rgb_array(ps, "sigma_s"),
                     le = rgb_array(ps, "Le");
    if (sa.empty() && ss.empty())
        throw SceneError(d.loc, "MakeNamedMedium \"" + d.name +
                                    "\": an rgbgrid needs \"sigma_a\" and/or \"sigma_s\" values");
    const size_t count = !sa.empty() ? sa.size() : ss.size();
    if (!sa.empty() && !ss.empty() && sa.size() != ss.size())
        throw SceneError(ps.find("sigma_s")->loc,
                         "MakeNamedMedium \"" + d.name + "\": " + std::to_string(sa.size()) +
                             " \"sigma_a\" but " + std::to_string(ss.size()) +
                             " \"sigma_s\" values");
    if (!le.empty() && sa.empty())
        throw SceneError(ps.find("Le")->loc, "MakeNamedMedium \"" + d.name +
                                                 "\": an rgbgrid with \"Le\" needs \"sigma_a\"");
    if (!le.empty() && le.size() != count)
        throw SceneError(ps.find("Le")->loc, "MakeNamedMedium \"" + d.name + "\": expected " +
                                                 std::to_string(count) + " \"Le\" values, got " +
                                                 std::to_string(le.size()));
    int n[3];
    grid_resolution(d, count, !sa.empty() ? "sigma_a" : "sigma_s", n);
    auto grid = [&](std::vector<Rgb> v) -> std::optional<SampledGrid<Rgb>> {
        if (v.empty()) return std::nullopt;
        return SampledGrid<Rgb>{n[0], n[1], n[2], std::move(v)};
    };
    const Vec3f p0 = ps.get_point3("p0", {0, 0, 0}), p1 = ps.get_point3("p1", {1, 1, 1});
    // pbrt-v4 reads the grid's "Le" as RGBIlluminantSpectrum values and, unlike its lights and
    // the other media, never divides them by their photometric value: on its film an Le of
    // (1, 1, 1) has a luminance of kCieYIntegral (spectra.h). Tessera renders the file as
    // pbrt-v4 does.
    const float Le_scale = ps.get_float("Lescale", 1.f) * kCieYIntegral;
    const float scale = ps.get_float("scale", 1.f);
    auto m = std::make_unique<RgbGridMedium>(p0, p1, d.render_from_medium, grid(std::move(sa)),
                                             grid(std::move(ss)), scale, grid(std::move(le)),
                                             Le_scale);
    m->phase.g = phase_g(d);
    return m;
}

}  // namespace

bool medium_preset(const std::string &name, Rgb *sigma_a, Rgb *sigma_s) {
    for (const Preset &p : kPresets)
        if (name == p.name) {
            *sigma_a = p.sigma_a;
            *sigma_s = p.sigma_prime_s;
            return true;
        }
    return false;
}

std::unique_ptr<Medium> make_medium(const MediumDesc &d) {
    std::unique_ptr<Medium> m;
    if (d.type == "homogeneous") {
        m = make_homogeneous(d);
    } else if (d.type == "uniformgrid") {
        m = make_uniform_grid(d);
    } else if (d.type == "rgbgrid") {
        m = make_rgb_grid(d);
    } else if (d.type == "cloud") {
        m = make_cloud(d);
    } else if (d.type == "nanovdb") {
        // Debian's OpenVDB packages (libopenvdb-dev 10) ship no NanoVDB headers.
        std::string file = d.params.get_string("filename", "");
        for (const Param &p : d.params.params) p.used = true;
        warn(d.loc, "MakeNamedMedium \"" + d.name + "\": \"nanovdb\" media need a NanoVDB "
                    "reader, which this build does not have" +
                        (file.empty() ? std::string() : " (file \"" + file + "\")") +
                        "; the medium is left out (vacuum)");
        return nullptr;
    } else {
        throw SceneError(d.loc, "MakeNamedMedium \"" + d.name + "\": unknown medium type \"" +
                                    d.type + "\"");
    }
    m->name = d.name;
    d.params.report_unused("MakeNamedMedium \"" + d.name + "\"");
    return m;
}

}  // namespace tessera
