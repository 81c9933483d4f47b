// Textures for material parameters, with pbrt-v4's semantics (src/pbrt/textures.{h,cpp}).
//
// A TextureSet builds every `Texture` directive of a scene, in declaration order, into float and
// spectrum (linear RGB) textures that materials evaluate at a shading point. Supported classes:
// "constant", "scale", "mix", "directionmix", "checkerboard" (2D and 3D, filtered with pbrt-v4's
// closed-form tent-filtered integral), "bilerp", "imagemap", and pbrt-v4's procedural noise
// classes (renderer/util/noise.h): "fbm", "wrinkled" and "windy" (float), "marble" (spectrum) and
// "dots" (both; with pbrt-v4's own swap of "inside" and "outside", see DotsTexture). "ptex" is
// reported with file:line and replaced by a constant 0.5; an unknown class is a SceneError, and
// so is a noise class of the wrong kind (pbrt-v4 has no spectrum fbm, no float marble).
//
// 2D mappings are pbrt-v4's: "uv" (uscale, vscale, udelta, vdelta), "spherical", "cylindrical"
// and "planar" (v1, v2, udelta, vdelta); the last three use the inverse of the texture's
// render_from_texture transform. 3D checkerboards use the same transform (point mapping).
//
// Image maps are decoded to linear texels and filtered with the uv derivatives through an
// in-memory pyramid with pbrt-v4's lookups (renderer/shading/mipmap.h), or, for images too
// large for one and for tiled mipmapped files, OpenImageIO's TextureSystem; see TextureSet.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "renderer/input/scene_desc.h"
#include "sampling/vecmath.h"

namespace tessera {

/// What a texture sees of a shading point (render space), as pbrt-v4's TextureEvalContext.
/// The derivatives are per pixel step in x and y on the film (ray differentials); zero
/// derivatives mean "no footprint" (the finest image level, no filtering of checkerboards).
struct TextureEvalContext {
    Vec3f p;                                       ///< render-space position
    Vec3f dpdx, dpdy;                              ///< dp/dx, dp/dy (render space, per pixel)
    Vec3f n;                                       ///< surface normal (render space, unit)
    Vec2f uv;                                      ///< surface (u, v)
    float dudx = 0, dudy = 0, dvdx = 0, dvdy = 0;  ///< uv derivatives per pixel
};

/// A scalar texture. evaluate() is const and thread-safe for every class Tessera builds.
class FloatTexture {
  public:
    virtual ~FloatTexture() = default;
    /// Texture value at `ctx` (unitless; e.g. roughness, eta, amount).
    virtual float evaluate(const TextureEvalContext &ctx) const = 0;
    /// The value if the texture is constant (evaluate() ignores ctx), else nullopt.
    virtual std::optional<float> constant_value() const { return std::nullopt; }
    /// One-line description for logs.
    virtual std::string describe() const = 0;
};

/// A colour texture in linear sRGB (Rec.709 primaries). evaluate() is const and thread-safe.
class SpectrumTexture {
  public:
    virtual ~SpectrumTexture() = default;
    /// Linear RGB at `ctx`. Never negative for image maps (pbrt clamps them at zero).
    virtual Rgb evaluate(const TextureEvalContext &ctx) const = 0;
    /// The value if the texture is constant (evaluate() ignores ctx), else nullopt.
    virtual std::optional<Rgb> constant_value() const { return std::nullopt; }
    /// One-line description for logs.
    virtual std::string describe() const = 0;
};

/// sRGB transfer function, decoding direction (IEC 61966-2-1): encoded [0,1] -> linear [0,1].
float srgb_to_linear(float v);

/// Every texture of a scene, built once at load time.
///
/// Construction walks `descs` in order; a texture may reference textures declared before it
/// (pbrt-v4 semantics). Errors in the input (unknown referenced texture, unreadable image, bad
/// wrap mode) throw SceneError with file:line; approximations and unsupported classes warn().
///
/// Image maps: the file named by "filename" (relative to the declaring file's directory) is
/// read once with OpenImageIO. Texels are linearised *before* filtering, as pbrt-v4 does:
/// unless the file already is a linear, tiled, mipmapped texture, the image is decoded
/// ("encoding": "sRGB" | "linear" | "gamma g"; default "sRGB" for 8/16-bit integer images and
/// "linear" for half/float images, which are always linear; JPEG, TGA, BMP, GIF, PSD, PIC and
/// PNM images are always sRGB and their alpha is dropped, as pbrt-v4's stb_image path does --
/// another "encoding" warns). The linear image becomes an in-memory MipMap (pbrt-v4's
/// pyramid and its point, bilinear, trilinear and EWA lookups, "maxanisotropy" default 8) when
/// its pyramid takes at most kMaxPyramidBytes and the set's pyramids together at most
/// kMaxSetPyramidBytes. Larger images are written once as a tiled, mipmapped half/float
/// OpenEXR texture (OIIO make_texture, box-filtered levels) in
/// `<system temp dir>/tessera-texcache/`, keyed by a hash of the source file's bytes and the
/// encoding, reused by later runs (the folder may be deleted at any time) and streamed by
/// OpenImageIO's TextureSystem, as are linear tiled mipmapped files ("ewa" maps to OIIO's
/// anisotropic filter there). Lookups use pbrt's (s, 1 - t) v flip, "wrap" (repeat | black |
/// clamp), "filter" (pbrt-v4 default "bilinear" = bilinear within one MIP level; "point",
/// "trilinear", "ewa"), "scale" and "invert". A float image map of a
/// one-channel image reads it; of a colour image, the average of the linear R, G, B, or the
/// alpha channel (decoded like the colour channels, as pbrt-v4 does) when an RGBA image's alpha
/// is not all 1 (pbrt-v4's MIPMap::Bilerp<Float>, the "bilinear" and "trilinear" filters); with
/// the "point" and "ewa" filters, channel 0 (pbrt-v4's MIPMap::Texel<Float>); a spectrum
/// image map reads RGB, or grey from 1 channel. Relative file names resolve against the main
/// scene file's directory, then the declaring file's.
///
/// The OpenImageIO TextureSystem is created only if an image map needs it, and destroyed
/// with the TextureSet.
///
/// Thread-safety: construction and the *_param helpers (which may create constant textures)
/// are not thread-safe and belong to scene loading; every texture's evaluate() may then be
/// called from any number of threads at once (OIIO's TextureSystem is thread-safe and keeps
/// per-thread state internally).
class TextureSet {
  public:
    /// Largest in-memory pyramid of one image map (a 4096 x 2048 RGB image's, 128 MiB).
    static constexpr size_t kMaxPyramidBytes = size_t(128) << 20;
    /// Largest sum of the in-memory pyramids of a set.
    static constexpr size_t kMaxSetPyramidBytes = size_t(2) << 30;

    /// `max_set_pyramid_bytes`: the in-memory pyramids' budget (0: every image map through
    /// OpenImageIO).
    explicit TextureSet(const std::vector<TextureDesc> &descs,
                        size_t max_set_pyramid_bytes = kMaxSetPyramidBytes);
    ~TextureSet();
    TextureSet(const TextureSet &) = delete;
    TextureSet &operator=(const TextureSet &) = delete;

    /// The float texture declared with `name`, or nullptr.
    const FloatTexture *get_float(const std::string &name) const;
    /// The spectrum texture declared with `name`, or nullptr.
    const SpectrumTexture *get_spectrum(const std::string &name) const;

    /// A material's float parameter: a texture reference (`"texture roughness" "name"`), a
    /// value (`"float roughness" 0.1`, returned as a constant texture), or `def` when absent.
    /// Throws SceneError if the referenced float texture does not exist. Never nullptr.
    const FloatTexture *float_param(const ParamSet &ps, const std::string &name, float def);
    /// A material's colour parameter: texture reference, rgb/spectrum/blackbody/float value, or
    /// `def`; nullptr when absent and `def` is empty. `unbounded` false (reflectances) clamps
    /// the values, textured ones at evaluation time, to [0,1] as pbrt's albedo spectra do.
    const SpectrumTexture *spectrum_param(const ParamSet &ps, const std::string &name,
                                          std::optional<Rgb> def, bool unbounded);

    /// True if the set has an image map (an in-memory pyramid or an OpenImageIO texture).
    bool has_image_maps() const { return image_maps_ > 0; }
    /// True if an image map too large for an in-memory pyramid, or a tiled mipmapped file,
    /// made this set create an OpenImageIO TextureSystem (texture.cpp, "Image maps").
    bool uses_texture_system() const { return oiio_ != nullptr; }
    /// Bytes held by the in-memory image pyramids.
    size_t pyramid_bytes() const { return pyramid_bytes_; }
    /// Number of textures built from descriptors (float + spectrum).
    size_t size() const { return floats_.size() + spectra_.size(); }

  private:
    struct Builder;
    friend struct Builder;
    struct OiioState;  ///< the TextureSystem and the image cache folder (texture.cpp)

    std::vector<std::unique_ptr<FloatTexture>> owned_floats_;
    std::vector<std::unique_ptr<SpectrumTexture>> owned_spectra_;
    std::map<std::string, const FloatTexture *> floats_;
    std::map<std::string, const SpectrumTexture *> spectra_;
    std::map<const SpectrumTexture *, const SpectrumTexture *> clamped_;  ///< albedo wrappers
    std::unique_ptr<OiioState> oiio_;
    size_t image_maps_ = 0;  ///< image maps built
    size_t pyramid_bytes_ = 0;
    size_t max_set_pyramid_bytes_ = kMaxSetPyramidBytes;
};

}  // namespace tessera
