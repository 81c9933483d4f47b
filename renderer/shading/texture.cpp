// Texture classes, mappings and the image-map cache (see texture.h for the semantics).
#include "renderer/shading/texture.h"
#include "renderer/shading/mipmap.h"
#include "renderer/util/image_io.h"
#include "renderer/util/limits.h"
#include "renderer/util/noise.h"

#include <unistd.h>
#include <array>
#include <atomic>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace tessera {

namespace fs = std::filesystem;

float srgb_to_linear(float v) {
    // IEC 61966-2-1 decoding curve (the same one pbrt-v4's SRGBToLinear tabulates).
    if (v <= 0.04045f) return v * (1.f / 12.92f);
    return std::pow((v + 0.055f) * (1.f / 1.055f), 2.4f);
}

struct TextureSet::OiioState {
    std::unique_ptr<imageio::TextureSystem> ts;
};

namespace {

std::string fmt(float v) {
    std::ostringstream s;
    s << v;
    return s.str();
}
std::string fmt(Rgb c) {
    std::ostringstream s;
    s << '[' << c.r << ' ' << c.g << ' ' << c.b << ']';
    return s.str();
}

template <typename T>
struct TexBase;
template <>
struct TexBase<float> {
    using type = FloatTexture;
};
template <>
struct TexBase<Rgb> {
    using type = SpectrumTexture;
};
template <typename T>
using TexPtr = const typename TexBase<T>::type *;

// ---------------------------------------------------------------------------------------------
// Mappings (pbrt-v4 textures.h: UVMapping, SphericalMapping, CylindricalMapping, PlanarMapping)

struct TexCoord2D {
    Vec2f st;
    float dsdx = 0, dsdy = 0, dtdx = 0, dtdy = 0;
};

class Mapping2D {
  public:
    virtual ~Mapping2D() = default;
    virtual TexCoord2D map(const TextureEvalContext &ctx) const = 0;
    virtual std::string describe() const = 0;
};

class UvMapping final : public Mapping2D {
  public:
    UvMapping(float su, float sv, float du, float dv) : su_(su), sv_(sv), du_(du), dv_(dv) {}
    TexCoord2D map(const TextureEvalContext &ctx) const override {
        return {{su_ * ctx.uv.x + du_, sv_ * ctx.uv.y + dv_},
                su_ * ctx.dudx,
                su_ * ctx.dudy,
                sv_ * ctx.dvdx,
                sv_ * ctx.dvdy};
    }
    std::string describe() const override {
        return "uv(su=" + fmt(su_) + " sv=" + fmt(sv_) + " du=" + fmt(du_) + " dv=" + fmt(dv_) +
               ")";
    }

  private:
    float su_, sv_, du_, dv_;
};

class SphericalMapping final : public Mapping2D {
  public:
    explicit SphericalMapping(const Transform &texture_from_render)
        : texture_from_render_(texture_from_render) {}
    TexCoord2D map(const TextureEvalContext &ctx) const override {
        Vec3f pt = texture_from_render_.point(ctx.p);
        // s = theta / pi and t = phi / 2pi; their gradients with respect to the point.
        // NOTE: pbrt-v4 pairs the phi gradient with s and the theta gradient with t; Tessera
        // pairs each coordinate with its own gradient (only the filter footprint differs).
        float x2y2 = pt.x * pt.x + pt.y * pt.y;
        float sqrt_x2y2 = std::sqrt(x2y2);
        float r2 = x2y2 + pt.z * pt.z;
        Vec3f dtdp = x2y2 > 0 ? Vec3f(-pt.y, pt.x, 0) / (2 * kPi * x2y2) : Vec3f();
        Vec3f dsdp =
            (sqrt_x2y2 > 0 && r2 > 0)
                ? Vec3f(pt.x * pt.z / sqrt_x2y2, pt.y * pt.z / sqrt_x2y2, -sqrt_x2y2) / (kPi * r2)
                : Vec3f();
        Vec3f dpdx = texture_from_render_.vector(ctx.dpdx);
        Vec3f dpdy = texture_from_render_.vector(ctx.dpdy);
        float len = length(pt);
        Vec3f dir = len > 0 ? pt / len : Vec3f(0, 0, 1);
        float theta = safe_acos(dir.z);
        float phi = std::atan2(dir.y, dir.x);
        if (phi < 0) phi += 2 * kPi;
        return {{theta * kInvPi, phi * kInv2Pi},
                dot(dsdp, dpdx),
                dot(dsdp, dpdy),
                dot(dtdp, dpdx),
                dot(dtdp, dpdy)};
    }
    std::string describe() const override { return "spherical"; }

  private:
    Transform texture_from_render_;
};

class CylindricalMapping final : public Mapping2D {
  public:
    explicit CylindricalMapping(const Transform &texture_from_render)
        : texture_from_render_(texture_from_render) {}
    TexCoord2D map(const TextureEvalContext &ctx) const override {
        Vec3f pt = texture_from_render_.point(ctx.p);
        float x2y2 = pt.x * pt.x + pt.y * pt.y;
        Vec3f dsdp = x2y2 > 0 ? Vec3f(-pt.y, pt.x, 0) / (2 * kPi * x2y2) : Vec3f();
        Vec3f dtdp(0, 0, 1);
        Vec3f dpdx = texture_from_render_.vector(ctx.dpdx);
        Vec3f dpdy = texture_from_render_.vector(ctx.dpdy);
        return {{(kPi + std::atan2(pt.y, pt.x)) * kInv2Pi, pt.z},
                dot(dsdp, dpdx),
                dot(dsdp, dpdy),
                dot(dtdp, dpdx),
                dot(dtdp, dpdy)};
    }
    std::string describe() const override { return "cylindrical"; }

  private:
    Transform texture_from_render_;
};

class PlanarMapping final : public Mapping2D {
  public:
    PlanarMapping(const Transform &texture_from_render, Vec3f vs, Vec3f vt, float ds, float dt)
        : texture_from_render_(texture_from_render), vs_(vs), vt_(vt), ds_(ds), dt_(dt) {}
    TexCoord2D map(const TextureEvalContext &ctx) const override {
        Vec3f vec = texture_from_render_.point(ctx.p);
        Vec3f dpdx = texture_from_render_.vector(ctx.dpdx);
        Vec3f dpdy = texture_from_render_.vector(ctx.dpdy);
        return {{ds_ + dot(vec, vs_), dt_ + dot(vec, vt_)},
                dot(vs_, dpdx),
                dot(vs_, dpdy),
                dot(vt_, dpdx),
                dot(vt_, dpdy)};
    }
    std::string describe() const override { return "planar"; }

  private:
    Transform texture_from_render_;
    Vec3f vs_, vt_;
    float ds_, dt_;
};

/// pbrt-v4's TextureMapping2D::Create: "mapping" selects the kind, default "uv".
std::unique_ptr<Mapping2D> make_mapping(const TextureDesc &d) {
    const ParamSet &ps = d.params;
    std::string type = ps.get_string("mapping", "uv");
    Transform texture_from_render = d.render_from_texture.inverse();
    if (type == "uv")
        return std::make_unique<UvMapping>(ps.get_float("uscale", 1.f), ps.get_float("vscale", 1.f),
                                           ps.get_float("udelta", 0.f),
                                           ps.get_float("vdelta", 0.f));
    if (type == "spherical") return std::make_unique<SphericalMapping>(texture_from_render);
    if (type == "cylindrical") return std::make_unique<CylindricalMapping>(texture_from_render);
    if (type == "planar")
        return std::make_unique<PlanarMapping>(
            texture_from_render, ps.get_vector3("v1", {1, 0, 0}), ps.get_vector3("v2", {0, 1, 0}),
            ps.get_float("udelta", 0.f), ps.get_float("vdelta", 0.f));
    warn(d.loc, "2D texture mapping \"" + type + "\" unknown; using \"uv\"");
    return std::make_unique<UvMapping>(1.f, 1.f, 0.f, 0.f);
}

// ---------------------------------------------------------------------------------------------
// Checkerboard filtering (pbrt-v4 textures.cpp, Checkerboard(); PBR 4th ed. section 10.5.1):
// the square wave c(x) = +1 on even cells and -1 on odd ones is convolved with a tent filter of
// radius r through its second antiderivative D: (D(x + r) - 2 D(x) + D(x - r)) / r^2.

/// Second antiderivative of the square wave, D(0) = 0. The first antiderivative is a triangle
/// wave of period 2 (0 at even integers, 1 at odd ones) whose integral over a period is 1.
double square_wave_d2(double x) {
    double k = std::floor(x * 0.5);
    double t = x - 2 * k;  // in [0, 2)
    double d0 = t <= 1 ? 0.5 * t * t : 1 - 0.5 * (2 - t) * (2 - t);
    return k + d0;
}

/// Tent-filtered square wave at x with filter radius r (exact value when r covers no edge).
double filtered_square_wave(double x, double r) {
    if (std::floor(x - r) == std::floor(x + r)) return 1 - 2 * (int64_t(std::floor(x)) & 1);
    return (square_wave_d2(x + r) - 2 * square_wave_d2(x) + square_wave_d2(x - r)) / (r * r);
}

/// Weight of tex2 for a 2D checkerboard (0 on cells where floor(s) + floor(t) is even).
float checker_weight_2d(const TexCoord2D &c) {
    // pbrt widens the footprint by 1.5 to approximate the pixel filter's support.
    double ds = 1.5 * std::max(std::abs(c.dsdx), std::abs(c.dsdy));
    double dt = 1.5 * std::max(std::abs(c.dtdx), std::abs(c.dtdy));
    return float(0.5 - 0.5 * filtered_square_wave(c.st.x, ds) * filtered_square_wave(c.st.y, dt));
}

float checker_weight_3d(const Transform &texture_from_render, const TextureEvalContext &ctx) {
    Vec3f p = texture_from_render.point(ctx.p);
    Vec3f dx = texture_from_render.vector(ctx.dpdx), dy = texture_from_render.vector(ctx.dpdy);
    double w = 1;
    for (int i = 0; i < 3; ++i)
        w *= filtered_square_wave(p[i], 1.5 * std::max(std::abs(dx[i]), std::abs(dy[i])));
    return float(0.5 - 0.5 * w);
}

// ---------------------------------------------------------------------------------------------
// Texture classes, one template for the float and the spectrum variant.

template <typename T>
class ConstantTexture final : public TexBase<T>::type {
  public:
    explicit ConstantTexture(T v) : v_(v) {}
    T evaluate(const TextureEvalContext &) const override { return v_; }
    std::optional<T> constant_value() const override { return v_; }
    std::string describe() const override { return "constant " + fmt(v_); }

  private:
    T v_;
};

template <typename T>
class CheckerboardTexture final : public TexBase<T>::type {
  public:
    CheckerboardTexture(std::unique_ptr<Mapping2D> map2d, std::optional<Transform> map3d,
                        TexPtr<T> tex1, TexPtr<T> tex2)
        : map2d_(std::move(map2d)), map3d_(map3d), tex1_(tex1), tex2_(tex2),
          uv_(dynamic_cast<const UvMapping *>(map2d_.get())), c1_(tex1->constant_value()),
          c2_(tex2->constant_value()) {}
    T evaluate(const TextureEvalContext &ctx) const override {
        // The common checkerboard (uv mapping, two constant colours) makes no virtual call.
        float w = uv_       ? checker_weight_2d(uv_->UvMapping::map(ctx))
                  : map2d_ ? checker_weight_2d(map2d_->map(ctx))
                           : checker_weight_3d(*map3d_, ctx);
        T t0(0.f), t1(0.f);
        if (w != 1) t0 = c1_ ? *c1_ : tex1_->evaluate(ctx);
        if (w != 0) t1 = c2_ ? *c2_ : tex2_->evaluate(ctx);
        return (1 - w) * t0 + w * t1;
    }
    std::string describe() const override {
        return std::string("checkerboard ") + (map2d_ ? map2d_->describe() : "3d") + " (" +
               tex1_->describe() + ", " + tex2_->describe() + ")";
    }

  private:
    std::unique_ptr<Mapping2D> map2d_;
    std::optional<Transform> map3d_;  ///< texture_from_render for the 3D variant
    TexPtr<T> tex1_, tex2_;
    const UvMapping *uv_;        ///< map2d_ when it is a uv mapping (called without dispatch)
    std::optional<T> c1_, c2_;  ///< tex1_, tex2_'s values when constant
};

template <typename T>
class ScaleTexture final : public TexBase<T>::type {
  public:
    ScaleTexture(TexPtr<T> tex, const FloatTexture *scale) : tex_(tex), scale_(scale) {}
    T evaluate(const TextureEvalContext &ctx) const override {
        float s = scale_->evaluate(ctx);
        if (s == 0) return T(0.f);
        return tex_->evaluate(ctx) * s;
    }
    std::string describe() const override {
        return "scale (" + tex_->describe() + ") * (" + scale_->describe() + ")";
    }

  private:
    TexPtr<T> tex_;
    const FloatTexture *scale_;
};

template <typename T>
class MixTexture final : public TexBase<T>::type {
  public:
    MixTexture(TexPtr<T> tex1, TexPtr<T> tex2, const FloatTexture *amount)
        : tex1_(tex1), tex2_(tex2), amount_(amount) {}
    T evaluate(const TextureEvalContext &ctx) const override {
        float amt = amount_->evaluate(ctx);
        T t1(0.f), t2(0.f);
        if (amt != 1) t1 = tex1_->evaluate(ctx);
        if (amt != 0) t2 = tex2_->evaluate(ctx);
        return (1 - amt) * t1 + amt * t2;
    }
    std::string describe() const override {
        return "mix (" + tex1_->describe() + ", " + tex2_->describe() + ", amount " +
               amount_->describe() + ")";
    }

  private:
    TexPtr<T> tex1_, tex2_;
    const FloatTexture *amount_;
};

template <typename T>
class DirectionMixTexture final : public TexBase<T>::type {
  public:
    DirectionMixTexture(TexPtr<T> tex1, TexPtr<T> tex2, Vec3f dir)
        : tex1_(tex1), tex2_(tex2), dir_(dir) {}
    T evaluate(const TextureEvalContext &ctx) const override {
        // pbrt-v4: tex1 where the normal is along dir, tex2 where it is perpendicular.
        float amt = absdot(ctx.n, dir_);
        T t1(0.f), t2(0.f);
        if (amt != 0) t1 = tex1_->evaluate(ctx);
        if (amt != 1) t2 = tex2_->evaluate(ctx);
        return amt * t1 + (1 - amt) * t2;
    }
    std::string describe() const override { return "directionmix"; }

  private:
    TexPtr<T> tex1_, tex2_;
    Vec3f dir_;
};

template <typename T>
class BilerpTexture final : public TexBase<T>::type {
  public:
    BilerpTexture(std::unique_ptr<Mapping2D> map, T v00, T v01, T v10, T v11)
        : map_(std::move(map)), v00_(v00), v01_(v01), v10_(v10), v11_(v11) {}
    T evaluate(const TextureEvalContext &ctx) const override {
        Vec2f st = map_->map(ctx).st;
        float s = st.x, t = st.y;
        return (1 - s) * (1 - t) * v00_ + s * (1 - t) * v10_ + (1 - s) * t * v01_ + s * t * v11_;
    }
    std::string describe() const override { return "bilerp " + map_->describe(); }

  private:
    std::unique_ptr<Mapping2D> map_;
    T v00_, v01_, v10_, v11_;
};

/// pbrt-v4 "fbm", "wrinkled" and "windy": noise of the texture-space point (the object space of
/// the Texture statement), band-limited by the transformed footprint.
class NoiseTexture final : public FloatTexture {
  public:
    enum class Kind { Fbm, Wrinkled, Windy };
    NoiseTexture(Kind kind, const Transform &texture_from_render, int octaves, float omega)
        : kind_(kind),
          texture_from_render_(texture_from_render),
          octaves_(octaves),
          omega_(omega) {}
    float evaluate(const TextureEvalContext &ctx) const override {
        Vec3f p = texture_from_render_.point(ctx.p);
        Vec3f dpdx = texture_from_render_.vector(ctx.dpdx);
        Vec3f dpdy = texture_from_render_.vector(ctx.dpdy);
        switch (kind_) {
            case Kind::Fbm:
                return fbm(p, dpdx, dpdy, omega_, octaves_);
            case Kind::Wrinkled:
                return turbulence(p, dpdx, dpdy, omega_, octaves_);
            case Kind::Windy: {
                // pbrt-v4 WindyTexture: a slow fBm of wind strength scales the waves' fBm.
                float wind = fbm(p * 0.1f, dpdx * 0.1f, dpdy * 0.1f, 0.5f, 3);
                float waves = fbm(p, dpdx, dpdy, 0.5f, 6);
                return std::abs(wind) * waves;
            }
        }
        return 0.f;
    }
    std::string describe() const override {
        if (kind_ == Kind::Windy)
            return "windy";
        return std::string(kind_ == Kind::Fbm ? "fbm" : "wrinkled") + " (octaves " +
               std::to_string(octaves_) + ", roughness " + fmt(omega_) + ")";
    }

  private:
    Kind kind_;
    Transform texture_from_render_;
    int octaves_;
    float omega_;
};

/// pbrt-v4 "marble": bands of sin(y + variation fBm) through a cubic Bezier spline of nine
/// fixed colours (PBRT 4th ed., section 10.6.3).
class MarbleTexture final : public SpectrumTexture {
  public:
    MarbleTexture(const Transform &texture_from_render, int octaves, float omega, float scale,
                  float variation)
        : texture_from_render_(texture_from_render),
          octaves_(octaves),
          omega_(omega),
          scale_(scale),
          variation_(variation) {}
    Rgb evaluate(const TextureEvalContext &ctx) const override {
        Vec3f p = texture_from_render_.point(ctx.p) * scale_;
        Vec3f dpdx = texture_from_render_.vector(ctx.dpdx) * scale_;
        Vec3f dpdy = texture_from_render_.vector(ctx.dpdy) * scale_;
        float marble = p.y + variation_ * fbm(p, dpdx, dpdy, omega_, octaves_);
        if (!std::isfinite(marble))
            marble = 0.f;  // a degenerate texture transform
        float t = 0.5f + 0.5f * std::sin(marble);
        static const Rgb kColors[] = {{.58f, .58f, .6f}, {.58f, .58f, .6f}, {.58f, .58f, .6f},
                                      {.5f, .5f, .5f},   {.6f, .59f, .58f}, {.58f, .58f, .6f},
                                      {.58f, .58f, .6f}, {.2f, .2f, .33f},  {.58f, .58f, .6f}};
        constexpr int kSegments = 9 - 3;
        int first = std::min(int(std::floor(t * kSegments)), kSegments - 1);
        t = t * kSegments - float(first);
        // de Casteljau on kColors[first .. first + 3].
        auto lerp_rgb = [](float u, Rgb a, Rgb b) { return (1.f - u) * a + u * b; };
        const Rgb *c = kColors + first;
        Rgb a0 = lerp_rgb(t, c[0], c[1]), a1 = lerp_rgb(t, c[1], c[2]),
            a2 = lerp_rgb(t, c[2], c[3]);
        Rgb b0 = lerp_rgb(t, a0, a1), b1 = lerp_rgb(t, a1, a2);
        return 1.5f * lerp_rgb(t, b0, b1);
    }
    std::string describe() const override { return "marble"; }

  private:
    Transform texture_from_render_;
    int octaves_;
    float omega_, scale_, variation_;
};

/// pbrt-v4's polka-dot test: a dot of radius 0.35, jittered by noise, in each unit cell (centred
/// on integer st) whose noise is positive.
bool inside_polka_dot(Vec2f st) {
    // Cells beyond int's range (or not a number): no dot (pbrt-v4: undefined).
    if (!(std::abs(st.x) < 1e9f && std::abs(st.y) < 1e9f))
        return false;
    int s_cell = int(std::floor(st.x + 0.5f)), t_cell = int(std::floor(st.y + 0.5f));
    if (!(perlin_noise(float(s_cell) + 0.5f, float(t_cell) + 0.5f) > 0.f))
        return false;
    const float radius = 0.35f, max_shift = 0.5f - radius;
    float s_center =
        float(s_cell) + max_shift * perlin_noise(float(s_cell) + 1.5f, float(t_cell) + 2.8f);
    float t_center =
        float(t_cell) + max_shift * perlin_noise(float(s_cell) + 4.5f, float(t_cell) + 9.8f);
    float ds = st.x - s_center, dt = st.y - t_center;
    return ds * ds + dt * dt < radius * radius;
}

/// pbrt-v4 "dots". NOTE: pbrt-v4 (like pbrt-v3) hands "inside" to the constructor's outside-dot
/// argument and "outside" to its inside-dot one, so its dots show "outside" (default 0) and the
/// rest shows "inside" (default 1). Tessera renders what pbrt-v4 renders.
template <typename T>
class DotsTexture final : public TexBase<T>::type {
  public:
    DotsTexture(std::unique_ptr<Mapping2D> map, TexPtr<T> in_dots, TexPtr<T> elsewhere)
        : map_(std::move(map)), in_dots_(in_dots), elsewhere_(elsewhere) {}
    T evaluate(const TextureEvalContext &ctx) const override {
        return inside_polka_dot(map_->map(ctx).st) ? in_dots_->evaluate(ctx)
                                                   : elsewhere_->evaluate(ctx);
    }
    std::string describe() const override {
        return "dots " + map_->describe() + " (" + in_dots_->describe() + " in the dots, " +
               elsewhere_->describe() + " elsewhere)";
    }

  private:
    std::unique_ptr<Mapping2D> map_;
    TexPtr<T> in_dots_, elsewhere_;
};

/// Clamps a spectrum texture to [0,1] (pbrt's albedo spectra for reflectances).
class ClampedSpectrumTexture final : public SpectrumTexture {
  public:
    explicit ClampedSpectrumTexture(const SpectrumTexture *tex) : tex_(tex) {}
    Rgb evaluate(const TextureEvalContext &ctx) const override {
        Rgb c = tex_->evaluate(ctx);
        return {clamp(c.r, 0.f, 1.f), clamp(c.g, 0.f, 1.f), clamp(c.b, 0.f, 1.f)};
    }
    std::string describe() const override { return "clamp01 (" + tex_->describe() + ")"; }

  private:
    const SpectrumTexture *tex_;
};

// ---------------------------------------------------------------------------------------------
// Image maps: an in-memory pyramid (MipMap), or OpenImageIO's TextureSystem for images too
// large for one.

struct ImageLookup {
    std::shared_ptr<const MipMap> mip;  ///< the in-memory pyramid, or null for OIIO
    const imageio::TextureSystem *ts = nullptr;
    void *handle = nullptr;
    imageio::TextureOptions opt;
    int file_channels = 1;
    std::string filename;  ///< the source image (for describe())

    /// Filtered lookup of `nch` channels at pbrt's (s, 1 - t): the image's top row at t = 0.
    void lookup(const TexCoord2D &c, int nch, float *out) const {
        if (mip) {
            // pbrt-v4 passes the derivatives of the unflipped t (ImageTexture::Evaluate).
            float v[MipMap::kMaxChannels] = {0, 0, 0, 0};
            mip->filter({c.st.x, 1 - c.st.y}, {c.dsdx, c.dtdx}, {c.dsdy, c.dtdy}, v);
            for (int i = 0; i < nch; ++i) out[i] = v[std::min(i, mip->channels() - 1)];
            return;
        }
        // OIIO's t grows downwards from the first image row, exactly like pbrt's flipped t.
        if (!ts->texture(handle, opt, c.st.x, 1 - c.st.y, c.dsdx, -c.dtdx, c.dsdy, -c.dtdy, nch,
                         out))
            for (int i = 0; i < nch; ++i) out[i] = 0;
    }
    std::string describe() const {
        return "\"" + filename + "\"" + (mip ? "" : " (OpenImageIO)");
    }
};

class FloatImageTexture final : public FloatTexture {
  public:
    FloatImageTexture(std::unique_ptr<Mapping2D> map, ImageLookup img, float scale, bool invert)
        : map_(std::move(map)), img_(std::move(img)), scale_(scale), invert_(invert) {}
    float evaluate(const TextureEvalContext &ctx) const override {
        float v = 0;
        img_.lookup(map_->map(ctx), 1, &v);
        v *= scale_;
        return invert_ ? std::max(0.f, 1 - v) : v;
    }
    std::string describe() const override {
        return "imagemap " + img_.describe() + " " + map_->describe() + " scale " + fmt(scale_);
    }

  private:
    std::unique_ptr<Mapping2D> map_;
    ImageLookup img_;
    float scale_;
    bool invert_;
};

class SpectrumImageTexture final : public SpectrumTexture {
  public:
    SpectrumImageTexture(std::unique_ptr<Mapping2D> map, ImageLookup img, float scale, bool invert)
        : map_(std::move(map)), img_(std::move(img)), scale_(scale), invert_(invert) {}
    Rgb evaluate(const TextureEvalContext &ctx) const override {
        float v[3] = {0, 0, 0};
        int nch = img_.file_channels >= 3 ? 3 : 1;
        img_.lookup(map_->map(ctx), nch, v);
        Rgb c = nch == 3 ? Rgb(v[0], v[1], v[2]) : Rgb(v[0]);
        c *= scale_;
        return clamp_zero(invert_ ? Rgb(1.f) - c : c);
    }
    std::string describe() const override {
        return "imagemap " + img_.describe() + " " + map_->describe() + " scale " + fmt(scale_);
    }

  private:
    std::unique_ptr<Mapping2D> map_;
    ImageLookup img_;
    float scale_;
    bool invert_;
};

/// A colour encoding of integer images: pbrt-v4's ColorEncoding ("linear", "sRGB", "gamma g").
struct Encoding {
    enum Kind { Linear, Srgb, Gamma } kind = Linear;
    float gamma = 1;
    std::string name() const {
        return kind == Linear ? "linear" : kind == Srgb ? "sRGB" : "gamma " + fmt(gamma);
    }
    float decode(float v) const {
        if (kind == Srgb) return srgb_to_linear(v);
        if (kind == Gamma) return std::pow(std::max(v, 0.f), gamma);
        return v;
    }
};

Encoding parse_encoding(const std::string &s, const FileLoc &loc) {
    std::string lower;
    for (char ch : s) lower += char(std::tolower(static_cast<unsigned char>(ch)));
    if (lower == "linear") return {};
    if (lower == "srgb") return {Encoding::Srgb, 1};
    if (lower.rfind("gamma ", 0) == 0) {
        try {
            float g = std::stof(lower.substr(6));
            if (g > 0) return {Encoding::Gamma, g};
        } catch (const std::exception &) {
        }
    }
    throw SceneError(loc, "unknown color encoding \"" + s + "\" (linear, sRGB or \"gamma g\")");
}

/// FNV-1a, 64 bit: a stable hash for cache file names.
uint64_t fnv1a(const std::string &s) {
    uint64_t h = 1469598103934665603ull;
    for (unsigned char ch : s) {
        h ^= ch;
        h *= 1099511628211ull;
    }
    return h;
}

/// FNV-1a of a whole file's bytes.
uint64_t file_hash(const std::string &path, const FileLoc &loc) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(loc, path + ": cannot read image file");
    uint64_t h = 1469598103934665603ull;
    std::vector<char> buf(1 << 16);
    while (in) {
        in.read(buf.data(), std::streamsize(buf.size()));
        std::streamsize n = in.gcount();
        for (std::streamsize i = 0; i < n; ++i) {
            h ^= static_cast<unsigned char>(buf[size_t(i)]);
            h *= 1099511628211ull;
        }
    }
    return h;
}

/// A decoded image map: linear texels in memory (width x height x channels, row 0 the top
/// row), or, with `path` set, a file OIIO's TextureSystem reads directly with linear texels.
struct PreparedImage {
    std::string path;
    int channels = 1;
    int width = 0, height = 0;
    std::vector<float> pixels;
};

PreparedImage texture_file(std::string path, int channels) {
    PreparedImage p;
    p.path = std::move(path);
    p.channels = channels;
    return p;
}

/// True for the 8-bit formats pbrt-v4 reads through stb_image (every extension but exr, png,
/// pfm, hdr and qoi; tiff is not one of them: stb cannot read it, so Tessera's own rules apply).
/// pbrt-v4 tags those images sRGB whatever "encoding" says and drops their alpha.
bool read_by_pbrt_as_srgb_rgb(const std::string &path) {
    std::string ext = fs::path(path).extension().string();
    for (char &c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    for (const char *e : {".jpg", ".jpeg", ".tga", ".bmp", ".gif", ".psd", ".pic", ".pnm",
                          ".ppm", ".pgm"})
        if (ext == e) return true;
    return false;
}

/// Linearises `path`: in memory when its pyramid takes at most `memory_budget` bytes, else
/// into a cached mipmapped texture unless it already is a linear one.
/// `scalar`: a float texture. `first_channel`: its lookups read channel 0 of a colour image
/// (pbrt-v4's "point" and "ewa" filters, MIPMap::Texel<Float>) instead of the RGB average.
PreparedImage prepare_image(const std::string &path, const std::string &encoding_param,
                            const FileLoc &loc, bool scalar, bool first_channel,
                            size_t memory_budget) {
    // Streamed: tiled mipmapped files are read by the TextureSystem tile by tile; the memory
    // check comes below, before a conversion reads the image whole.
    // Colour as stored, not premultiplied by alpha: pbrt ignores alpha in image maps.
    OpenedImage img = open_image(path, loc, "image", ImageRead::Streamed, true);
    const imageio::ImageSpec &spec = img.spec;
    const int levels = spec.mip_levels;

    const bool float_image = imageio::is_float(spec.format);
    Encoding enc = parse_encoding(
        encoding_param.empty() ? (float_image ? "linear" : "sRGB") : encoding_param, loc);
    if (float_image && enc.kind != Encoding::Linear) {
        // pbrt-v4 applies encodings to 8- and 16-bit images only.
        warn(loc, path + ": encoding \"" + encoding_param +
                      "\" ignored for a floating-point image (always linear)");
        enc = Encoding{};
    }
    const bool stb_rules = !float_image && read_by_pbrt_as_srgb_rgb(path);
    if (stb_rules && enc.kind != Encoding::Srgb) {
        warn(loc, path + ": encoding \"" + encoding_param +
                      "\" ignored: pbrt-v4 reads this image format as sRGB");
        enc = Encoding{Encoding::Srgb};
    }
    // Float textures of colour images follow pbrt-v4's MIPMap lookups of Float: the average of
    // R, G and B, or the alpha channel of an RGBA image whose alpha is not all 1 (cut-out masks).
    const bool scalar_from_colour = scalar && spec.nchannels >= 3;
    const int out_channels = scalar_from_colour ? 1 : (spec.nchannels >= 3 ? 3 : 1);
    const bool in_memory =
        MipMap::pyramid_bytes(spec.width, spec.height, out_channels) <= memory_budget;
    if (!in_memory && enc.kind == Encoding::Linear && spec.tile_width > 0 && levels > 1 &&
        !scalar_from_colour)
        return texture_file(path, spec.nchannels);

    // Which channel a scalar texture reads: alpha (when not all 1, and the format keeps it),
    // channel 0, or the RGB average.
    const bool keep_alpha = !stb_rules && !first_channel;
    std::error_code ec;
    fs::path dir, cached;
    if (!in_memory) {
        // The key hashes the file's bytes (not its name or date), so a rewritten but identical
        // image, or the same image in two folders, shares one cache entry.
        std::string key =
            "tessera-texcache-v2|" + std::to_string(file_hash(path, loc)) + "|" + enc.name() +
            "|" + std::to_string(out_channels) +
            (scalar_from_colour
                 ? (first_channel ? "|scalar-ch0" : (keep_alpha ? "|scalar" : "|scalar-rgb"))
                 : "");
        char hex[17];
        std::snprintf(hex, sizeof(hex), "%016llx", (unsigned long long)fnv1a(key));
        dir = fs::temp_directory_path(ec) / "tessera-texcache";
        fs::create_directories(dir, ec);
        cached = dir / (fs::path(path).stem().string() + "-" + hex + ".exr");
        if (fs::is_regular_file(cached, ec)) return texture_file(cached.string(), out_channels);
    }

    // A header may claim any size: check before the conversion below reads it whole (tiled
    // mipmapped files, returned above, are streamed by the TextureSystem instead).
    img.check_read_whole();
    // An 8-bit texel is one of 256 values: decode those once (pbrt-v4's sRGB table).
    const bool eight_bit = spec.format == imageio::PixelType::UInt8 &&
                           spec.channelformats.empty() && enc.kind != Encoding::Linear;
    std::array<float, 256> table{};
    if (eight_bit)
        for (int i = 0; i < 256; ++i) table[size_t(i)] = enc.decode(float(i) / 255.f);
    const auto decode = [&](float v) {
        return eight_bit ? table[size_t(std::clamp(int(v * 255.f + 0.5f), 0, 255))]
                         : enc.decode(v);
    };
    const size_t npixels = size_t(spec.width) * size_t(spec.height);
    std::vector<float> pixels;
    if (scalar_from_colour) {
        const int nin = std::min(spec.nchannels, 4);
        const std::vector<float> rgba = img.read_floats(0, nin);
        bool use_alpha = false;
        if (nin == 4 && keep_alpha)
            for (size_t i = 3; i < rgba.size(); i += 4)
                if (rgba[i] < 1.f) {
                    use_alpha = true;
                    break;
                }
        pixels.resize(npixels);
        for (size_t i = 0; i < pixels.size(); ++i) {
            const float *px = &rgba[i * size_t(nin)];
            // Every channel of an integer image is decoded, alpha too: pbrt-v4's
            // Image::GetChannel runs the encoding on whichever channel it reads.
            pixels[i] = use_alpha       ? decode(px[3])
                        : first_channel ? decode(px[0])
                                        : (decode(px[0]) + decode(px[1]) + decode(px[2])) / 3.f;
        }
    } else {
        pixels = img.read_floats(0, out_channels);
        if (enc.kind != Encoding::Linear)
            for (float &v : pixels) v = decode(v);
    }
    if (in_memory) {
        PreparedImage out;
        out.channels = out_channels;
        out.width = spec.width;
        out.height = spec.height;
        out.pixels = std::move(pixels);
        return out;
    }
    // 8/16-bit sources become half (11-bit mantissa, finer than an 8-bit step); float stays.
    const imageio::PixelType stored = float_image && spec.format != imageio::PixelType::Half
                                          ? imageio::PixelType::Float
                                          : imageio::PixelType::Half;
    // Write under a unique name, then rename: another process may build the same entry.
    static std::atomic<int> counter{0};
    fs::path tmp = dir / (cached.stem().string() + ".tmp" + std::to_string(::getpid()) + "_" +
                          std::to_string(counter++) + ".exr");
    std::string err;
    if (!imageio::backend().make_texture(tmp.string(), spec.width, spec.height, out_channels,
                                         pixels.data(), stored, &err))
        throw SceneError(loc, path + ": cannot write the mipmapped texture " + tmp.string() + ": " +
                                  err);
    fs::rename(tmp, cached, ec);
    if (ec) {
        fs::remove(tmp, ec);
        if (!fs::is_regular_file(cached, ec))
            throw SceneError(loc, path + ": cannot create texture cache file " + cached.string());
    }
    return texture_file(cached.string(), out_channels);
}

/// A relative file name against the main file's directory (pbrt-v4), falling back to the
/// directory of the file that declared the texture.
std::string resolve(const std::string &file, const std::string &base_dir, const FileLoc &loc) {
    if (file.empty() || fs::path(file).is_absolute()) return file;
    std::string main = base_dir.empty() ? file : (fs::path(base_dir) / file).string();
    std::error_code ec;
    if (fs::exists(main, ec)) return main;
    fs::path alt = fs::path(loc.file).parent_path() / file;
    return fs::exists(alt, ec) ? alt.string() : main;
}

}  // namespace

// -------------------------------------------------------------------------------------------------
// TextureSet

/// Builds one TextureDesc (split out of the constructor to keep the per-class code together).
struct TextureSet::Builder {
    TextureSet &set;
    const TextureDesc &d;

    const FloatTexture *own(std::unique_ptr<FloatTexture> t) {
        set.owned_floats_.push_back(std::move(t));
        return set.owned_floats_.back().get();
    }
    const SpectrumTexture *own(std::unique_ptr<SpectrumTexture> t) {
        set.owned_spectra_.push_back(std::move(t));
        return set.owned_spectra_.back().get();
    }

    /// A float parameter of this texture: a reference to an earlier float texture or a value.
    const FloatTexture *float_tex(const std::string &name, float def) {
        return set.float_param(d.params, name, def);
    }
    /// A spectrum parameter of this texture, unclamped (the use decides on clamping).
    const SpectrumTexture *spectrum_tex(const std::string &name, Rgb def) {
        return set.spectrum_param(d.params, name, def, true);
    }
    TexPtr<float> tex(const std::string &name, float def) { return float_tex(name, def); }
    TexPtr<Rgb> tex(const std::string &name, Rgb def) { return spectrum_tex(name, def); }
    float value(const std::string &name, float def) { return d.params.get_float(name, def); }
    Rgb value(const std::string &name, Rgb def) {
        return d.params.get_rgb(name, false, true).value_or(def);
    }

    template <typename T>
    TexPtr<T> build() {
        const std::string &cls = d.tex_class;
        const ParamSet &ps = d.params;
        auto make = [&](auto ptr) -> TexPtr<T> { return own(std::move(ptr)); };
        if (cls == "constant")
            return make(std::make_unique<ConstantTexture<T>>(value("value", T(1.f))));
        if (cls == "scale")
            return make(
                std::make_unique<ScaleTexture<T>>(tex("tex", T(1.f)), float_tex("scale", 1.f)));
        if (cls == "mix")
            return make(std::make_unique<MixTexture<T>>(tex("tex1", T(0.f)), tex("tex2", T(1.f)),
                                                        float_tex("amount", 0.5f)));
        if (cls == "directionmix") {
            Vec3f dir = ps.get_vector3("dir", {0, 1, 0});
            dir = d.render_from_texture.vector(dir);
            if (!(length(dir) > 0)) throw SceneError(d.loc, "directionmix: \"dir\" is zero");
            return make(std::make_unique<DirectionMixTexture<T>>(
                tex("tex1", T(0.f)), tex("tex2", T(1.f)), normalize(dir)));
        }
        if (cls == "checkerboard") {
            int dim = ps.get_int("dimension", 2);
            if (dim != 2 && dim != 3)
                throw SceneError(
                    d.loc, std::to_string(dim) + " dimensional checkerboard texture not supported");
            TexPtr<T> t1 = tex("tex1", T(1.f)), t2 = tex("tex2", T(0.f));
            if (dim == 2)
                return make(std::make_unique<CheckerboardTexture<T>>(make_mapping(d), std::nullopt,
                                                                     t1, t2));
            return make(std::make_unique<CheckerboardTexture<T>>(
                nullptr, d.render_from_texture.inverse(), t1, t2));
        }
        if (cls == "bilerp")
            return make(std::make_unique<BilerpTexture<T>>(
                make_mapping(d), value("v00", T(0.f)), value("v01", T(1.f)), value("v10", T(0.f)),
                value("v11", T(1.f))));
        if (cls == "imagemap") {
            auto map = make_mapping(d);
            ImageLookup img = image(ps);
            float scale = ps.get_float("scale", 1.f);
            bool invert = ps.get_bool("invert", false);
            if constexpr (std::is_same_v<T, float>)
                return make(std::make_unique<FloatImageTexture>(std::move(map), std::move(img),
                                                                scale, invert));
            else
                return make(std::make_unique<SpectrumImageTexture>(std::move(map), std::move(img),
                                                                   scale, invert));
        }
        if (cls == "fbm" || cls == "wrinkled" || cls == "windy") {
            if constexpr (std::is_same_v<T, float>) {
                using Kind = NoiseTexture::Kind;
                Kind kind =
                    cls == "fbm" ? Kind::Fbm : (cls == "wrinkled" ? Kind::Wrinkled : Kind::Windy);
                int octaves = kind == Kind::Windy ? 0 : ps.get_int("octaves", 8);
                float omega = kind == Kind::Windy ? 0.f : ps.get_float("roughness", 0.5f);
                if (octaves < 0 || octaves > 64)
                    throw SceneError(d.loc, cls + ": \"octaves\" must be in [0, 64]");
                return make(std::make_unique<NoiseTexture>(kind, d.render_from_texture.inverse(),
                                                           octaves, omega));
            } else {
                throw SceneError(d.loc, "\"" + cls + "\" is a float texture only (pbrt-v4)");
            }
        }
        if (cls == "marble") {
            if constexpr (std::is_same_v<T, Rgb>) {
                int octaves = ps.get_int("octaves", 8);
                if (octaves < 0 || octaves > 64)
                    throw SceneError(d.loc, "marble: \"octaves\" must be in [0, 64]");
                return make(std::make_unique<MarbleTexture>(
                    d.render_from_texture.inverse(), octaves, ps.get_float("roughness", 0.5f),
                    ps.get_float("scale", 1.f), ps.get_float("variation", 0.2f)));
            } else {
                throw SceneError(d.loc, "\"marble\" is a spectrum texture only (pbrt-v4)");
            }
        }
        if (cls == "dots") {
            // pbrt-v4's swap (see DotsTexture): "outside" shows in the dots.
            TexPtr<T> inside = tex("inside", T(1.f)), outside = tex("outside", T(0.f));
            return make(std::make_unique<DotsTexture<T>>(make_mapping(d), outside, inside));
        }
        static const char *kUnsupported[] = {"ptex"};
        bool known = false;
        for (const char *k : kUnsupported) known = known || cls == k;
        if (!known) throw SceneError(d.loc, "texture class \"" + cls + "\" unknown");
        warn(d.loc, "texture class \"" + cls + "\" is not supported; texture \"" + d.name +
                        "\" is a constant 0.5");
        // Mark the parameters used: the class warning already covers them.
        for (const Param &p : ps.params) p.used = true;
        return make(std::make_unique<ConstantTexture<T>>(T(0.5f)));
    }

    /// The set's TextureSystem, created with the first image map.
    imageio::TextureSystem *texture_system() {
        if (!set.oiio_) {
            auto state = std::make_unique<OiioState>();
            // A private (unshared) system: its cache dies with the TextureSet. Files are tiled
            // and mipmapped by prepare_image, so no automip is needed.
            try {
                state->ts = imageio::backend().texture_system(1024.f);
            } catch (const std::runtime_error &e) {
                throw SceneError(d.loc, e.what());
            }
            set.oiio_ = std::move(state);
        }
        return set.oiio_->ts.get();
    }

    ImageLookup image(const ParamSet &ps) {
        std::string filename = ps.get_string("filename", "");
        if (filename.empty()) throw SceneError(d.loc, "imagemap: \"filename\" is required");
        std::string path = resolve(filename, d.base_dir, d.loc);
        std::error_code ec;
        if (!fs::is_regular_file(path, ec))
            throw SceneError(d.loc, "imagemap: image file \"" + path +
                                        (fs::is_directory(path, ec) ? "\" is a directory"
                                                                    : "\" not found"));

        ImageLookup img;
        img.filename = path;
        std::string wrap = ps.get_string("wrap", "repeat");
        using Opt = imageio::TextureOptions;
        Opt::Wrap w;
        if (wrap == "repeat") {
            w = Opt::Wrap::Periodic;
        } else if (wrap == "black") {
            w = Opt::Wrap::Black;
        } else if (wrap == "clamp") {
            w = Opt::Wrap::Clamp;
        } else if (wrap == "octahedralsphere") {
            warn(d.loc, "wrap mode \"octahedralsphere\" is not supported; using \"clamp\"");
            w = Opt::Wrap::Clamp;
        } else {
            throw SceneError(d.loc, "imagemap: wrap mode \"" + wrap + "\" unknown");
        }
        img.opt.swrap = img.opt.twrap = w;
        std::string filter = ps.get_string("filter", "bilinear");
        float max_aniso = ps.get_float("maxanisotropy", 8.f);
        img.opt.anisotropic = std::max(1, int(max_aniso));
        if (filter == "point") {
            img.opt.mip = Opt::Mip::OneLevel;
            img.opt.interp = Opt::Interp::Closest;
        } else if (filter == "trilinear") {
            img.opt.mip = Opt::Mip::Trilinear;
            img.opt.interp = Opt::Interp::Bilinear;
        } else if (filter == "ewa" || filter == "EWA") {
            // NOTE: OIIO's anisotropic filter stands in for pbrt's EWA (both elliptical).
            img.opt.mip = Opt::Mip::Aniso;
            img.opt.interp = Opt::Interp::Bilinear;
        } else {
            if (filter != "bilinear")
                warn(d.loc, "imagemap: filter \"" + filter + "\" unknown; using \"bilinear\"");
            img.opt.mip = Opt::Mip::OneLevel;
            img.opt.interp = Opt::Interp::Bilinear;
        }
        const bool ch0 = filter == "point" || filter == "ewa" || filter == "EWA";
        const size_t budget =
            std::min(kMaxPyramidBytes,
                     set.max_set_pyramid_bytes_ -
                         std::min(set.max_set_pyramid_bytes_, set.pyramid_bytes_));
        PreparedImage prep = prepare_image(path, ps.get_string("encoding", ""), d.loc,
                                           d.value_type == "float", ch0, budget);
        ++set.image_maps_;
        if (prep.path.empty()) {
            const MipFilter mf = filter == "point"       ? MipFilter::Point
                                 : filter == "trilinear" ? MipFilter::Trilinear
                                 : (filter == "ewa" || filter == "EWA") ? MipFilter::Ewa
                                                                        : MipFilter::Bilinear;
            const MipWrap mw = w == Opt::Wrap::Periodic ? MipWrap::Repeat
                               : w == Opt::Wrap::Black  ? MipWrap::Black
                                                                   : MipWrap::Clamp;
            img.mip = std::make_shared<const MipMap>(prep.width, prep.height, prep.channels,
                                                     std::move(prep.pixels), mw, mf, max_aniso);
            img.file_channels = prep.channels;
            set.pyramid_bytes_ += img.mip->bytes();
            return img;
        }
        imageio::TextureSystem *ts = texture_system();
        std::string err;
        img.handle = ts->handle(prep.path, &img.file_channels, &err);
        if (!img.handle)
            throw SceneError(d.loc, path + ": texture system cannot read " + prep.path + ": " +
                                        err);
        img.ts = ts;
        return img;
    }
};

TextureSet::TextureSet(const std::vector<TextureDesc> &descs, size_t max_set_pyramid_bytes)
    : max_set_pyramid_bytes_(max_set_pyramid_bytes) {
    for (const TextureDesc &d : descs) {
        bool is_float = d.value_type == "float";
        bool is_spectrum =
            d.value_type == "spectrum" || d.value_type == "color" || d.value_type == "rgb";
        if (!is_float && !is_spectrum)
            throw SceneError(d.loc, "texture \"" + d.name + "\": type \"" + d.value_type +
                                        "\" unknown (must be \"float\" or \"spectrum\")");
        if ((is_float ? floats_.count(d.name) : spectra_.count(d.name)) != 0)
            throw SceneError(d.loc, "redefining texture \"" + d.name + "\"");
        Builder b{*this, d};
        if (is_float)
            floats_[d.name] = b.build<float>();
        else
            spectra_[d.name] = b.build<Rgb>();
        d.params.report_unused("Texture \"" + d.name + "\"");
    }
}

TextureSet::~TextureSet() {
    // Textures hold TextureSystem handles: free them before the TextureSystem itself.
    owned_floats_.clear();
    owned_spectra_.clear();
    oiio_.reset();
}

const FloatTexture *TextureSet::get_float(const std::string &name) const {
    auto it = floats_.find(name);
    return it == floats_.end() ? nullptr : it->second;
}

const SpectrumTexture *TextureSet::get_spectrum(const std::string &name) const {
    auto it = spectra_.find(name);
    return it == spectra_.end() ? nullptr : it->second;
}

const FloatTexture *TextureSet::float_param(const ParamSet &ps, const std::string &name,
                                            float def) {
    std::string ref = ps.get_texture(name);
    if (!ref.empty()) {
        if (const FloatTexture *t = get_float(ref)) return t;
        const Param *p = ps.find(name);
        throw SceneError(
            p->loc, "float texture \"" + ref + "\" (parameter \"" + name + "\") is not defined" +
                        (get_spectrum(ref) ? " (a spectrum texture has that name)" : ""));
    }
    owned_floats_.push_back(std::make_unique<ConstantTexture<float>>(ps.get_float(name, def)));
    return owned_floats_.back().get();
}

const SpectrumTexture *TextureSet::spectrum_param(const ParamSet &ps, const std::string &name,
                                                  std::optional<Rgb> def, bool unbounded) {
    std::string ref = ps.get_texture(name);
    if (!ref.empty()) {
        const SpectrumTexture *t = get_spectrum(ref);
        if (!t) {
            const Param *p = ps.find(name);
            throw SceneError(p->loc,
                             "spectrum texture \"" + ref + "\" (parameter \"" + name +
                                 "\") is not defined" +
                                 (get_float(ref) ? " (a float texture has that name)" : ""));
        }
        if (unbounded) return t;
        auto it = clamped_.find(t);
        if (it != clamped_.end()) return it->second;
        owned_spectra_.push_back(std::make_unique<ClampedSpectrumTexture>(t));
        return clamped_[t] = owned_spectra_.back().get();
    }
    std::optional<Rgb> v = ps.get_rgb(name, false, unbounded);
    if (!v) v = def;
    if (!v) return nullptr;
    if (!unbounded) *v = Rgb(clamp(v->r, 0.f, 1.f), clamp(v->g, 0.f, 1.f), clamp(v->b, 0.f, 1.f));
    owned_spectra_.push_back(std::make_unique<ConstantTexture<Rgb>>(*v));
    return owned_spectra_.back().get();
}

}  // namespace tessera
