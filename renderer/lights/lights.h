// Light sources: every emitter Tessera renders, with direct-lighting sampling and its density.
//
// Semantics follow pbrt-v4 (src/pbrt/lights.{h,cpp}; Pharr, Jakob & Humphreys, "Physically Based
// Rendering", 4th ed., 2023, chapter 12): the same parameters, defaults, power normalisation and
// coordinate conventions, in RGB instead of sampled spectra.
//
// Conventions shared by all lights:
//  - `wi` is the unit direction from the reference point toward the light; `pdf` is per unit
//    solid angle at the reference point (1 for delta lights, whose sample is the only one).
//  - Area lights emit on the side of their emitting normal unless `twosided`.
//  - Infinite and distant lights need the scene's bounding sphere: call preprocess() once after
//    the scene is built and before phi() or sampling (default radius 1).
// Lights are immutable after preprocess(); every const method is thread-safe.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "renderer/input/scene_desc.h"
#include "renderer/util/transform.h"
#include "sampling/distribution.h"
#include "sampling/vecmath.h"

namespace tessera {

/// What kind of emitter a light is (pbrt-v4's LightType). Delta lights cannot be hit by rays.
enum class LightType { DeltaPosition, DeltaDirection, Area, Infinite };

/// True for lights that only light sampling can reach (no MIS with BSDF sampling).
inline bool is_delta_light(LightType t) {
    return t == LightType::DeltaPosition || t == LightType::DeltaDirection;
}

/// The point being lit.
struct LightSampleContext {
    Vec3f p;  ///< reference point, world space
    Vec3f n;  ///< geometric normal at p (unit), or zero for a point in a medium / no surface
};

/// One light sample for direct lighting.
struct LightLiSample {
    Rgb L;          ///< radiance arriving at the reference point along -wi (before visibility)
    Vec3f wi;       ///< unit direction from the reference point toward the light
    float pdf = 0;  ///< solid-angle density of wi (1 for delta lights)
    Vec3f p_light;  ///< point on the light (for infinite/distant: 2 scene radii away)
    Vec3f n_light;  ///< emitting-side unit normal at p_light (zero for non-area lights)
};

/// A light sample toward the point p_light as seen from ctx.p: wi (unit) and p_light set, d2 the
/// squared distance; nullopt when the points coincide. The caller fills L, pdf and n_light.
inline std::optional<LightLiSample> sample_toward(const LightSampleContext &ctx, Vec3f p_light,
                                                  float *d2) {
    Vec3f d = p_light - ctx.p;
    *d2 = length_squared(d);
    if (*d2 == 0.f)
        return std::nullopt;
    LightLiSample s;
    s.wi = d / std::sqrt(*d2);
    s.p_light = p_light;
    return s;
}

/// The concrete class of a light where a caller may call it directly (see shape()).
enum class LightShape : uint8_t { Other, Point, Spot, Triangle };

/// Interface of all lights.
class Light {
  public:
    virtual ~Light() = default;
    virtual LightType type() const = 0;
    /// Which final class this is, for hot loops that call its sample_li directly instead of
    /// through the vtable (`static_cast<const PointLight *>(l)->PointLight::sample_li(...)`,
    /// inlined: its body is below). The Whitted integrator's shading loop does.
    LightShape shape() const { return shape_; }
    /// Samples incident illumination at ctx.p with u in [0,1)^2. nullopt when the sample carries
    /// no radiance (back side of a one-sided emitter, zero pdf). Thread-safe.
    virtual std::optional<LightLiSample> sample_li(const LightSampleContext &ctx,
                                                   Vec2f u) const = 0;
    /// Solid-angle density with which sample_li would produce direction wi. For area lights
    /// (p_light, n_light) is where the ray along wi hits this light (n_light as in the
    /// SurfaceInteraction; built-in shapes know their own emitting side); infinite lights use wi
    /// only; delta lights return 0. Thread-safe.
    virtual float pdf_li(const LightSampleContext &ctx, Vec3f wi, Vec3f p_light,
                         Vec3f n_light) const = 0;
    /// Area lights: radiance leaving the surface at p_light toward unit direction w_out. Others:
    /// black. Thread-safe.
    virtual Rgb L(Vec3f p_light, Vec3f n_light, Vec2f uv, Vec3f w_out) const;
    /// Infinite lights: radiance arriving along a ray of direction `dir` (pointing away from the
    /// scene) that escaped. Others: black. Thread-safe.
    virtual Rgb Le(Vec3f dir) const;
    /// Emitted power in W per RGB channel, for power-proportional light selection. Infinite and
    /// distant lights use the scene radius given to preprocess(), as pbrt-v4 does.
    virtual Rgb phi() const = 0;
    /// Receives the scene's bounding sphere (render space). Not thread-safe; call once.
    virtual void preprocess(Vec3f /*scene_center*/, float /*scene_radius*/) {}
    /// One readable line for logs.
    virtual std::string describe() const = 0;

    /// Area lights on a shape with constant alpha 0 (pbrt-v4 DiffuseAreaLight): no ray ever
    /// hits the shape, so the light is reached by light sampling only, without MIS -- its
    /// type() becomes LightType::DeltaPosition, as in pbrt-v4. Call before rendering.
    void set_sample_only() { sample_only_ = true; }
    bool sample_only() const { return sample_only_; }

  protected:
    explicit Light(LightShape shape = LightShape::Other) : shape_(shape) {}
    /// type() of an area light: Area, or DeltaPosition when sample_only().
    LightType area_type() const {
        return sample_only_ ? LightType::DeltaPosition : LightType::Area;
    }

  private:
    LightShape shape_;
    bool sample_only_ = false;
};

/// Isotropic point light (pbrt-v4 "point"): intensity I in W/sr.
class PointLight final : public Light {
  public:
    PointLight(Vec3f p, Rgb intensity) : Light(LightShape::Point), p_(p), I_(intensity) {}
    LightType type() const override { return LightType::DeltaPosition; }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &, Vec3f, Vec3f, Vec3f) const override { return 0.f; }
    Rgb phi() const override { return 4.f * kPi * I_; }
    std::string describe() const override;

  private:
    Vec3f p_;
    Rgb I_;
};

/// Spotlight (pbrt-v4 "spot"): intensity I inside a cone around the light's +z axis, with
/// pbrt-v4's smoothstep falloff between cos(coneangle) and cos(coneangle - conedeltaangle).
class SpotLight final : public Light {
  public:
    /// `render_from_light` places the apex at the origin and the axis along +z.
    SpotLight(const Transform &render_from_light, Rgb intensity, float cos_falloff_start,
              float cos_falloff_end);
    LightType type() const override { return LightType::DeltaPosition; }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &, Vec3f, Vec3f, Vec3f) const override { return 0.f; }
    Rgb phi() const override;
    std::string describe() const override;
    /// Intensity (W/sr) toward light-space unit direction w_light.
    Rgb intensity(Vec3f w_light) const;
    /// pbrt-v4's SmoothStep: 0 below a, 1 above b, cubic Hermite in between.
    static float smooth_step(float x, float a, float b) {
        if (a == b)
            return x < a ? 0.f : 1.f;
        float t = clamp((x - a) / (b - a), 0.f, 1.f);
        return t * t * (3.f - 2.f * t);
    }

  private:
    Transform render_from_light_;
    Vec3f p_;
    Rgb I_;
    float cos_falloff_start_, cos_falloff_end_;
    /// When render_from_light is a similarity (a rotation or reflection times a uniform scale),
    /// the cosine to the light-space axis is dot(axis_, w) in render space: sample_li skips the
    /// inverse transform and the second normalisation. False for sheared or non-uniformly
    /// scaled lights.
    bool similarity_ = false;
    Vec3f axis_;
};

// The delta lights' sample_li are defined here so that a caller that knows the light's type
// (the Whitted integrator's light proxies: `light->PointLight::sample_li(...)`) gets them inlined
// instead of a virtual call per light and shading point.
inline std::optional<LightLiSample> PointLight::sample_li(const LightSampleContext &ctx,
                                                          Vec2f) const {
    float d2;
    std::optional<LightLiSample> s = sample_toward(ctx, p_, &d2);
    if (s) {
        s->L = I_ / d2;  // inverse-square law (eq. 4.12)
        s->pdf = 1.f;
    }
    return s;
}

inline std::optional<LightLiSample> SpotLight::sample_li(const LightSampleContext &ctx,
                                                         Vec2f) const {
    float d2;
    std::optional<LightLiSample> s = sample_toward(ctx, p_, &d2);
    if (!s)
        return s;
    // The falloff is evaluated in light space, as pbrt-v4 does (it matters for sheared or
    // non-uniformly scaled lights); for the others the render-space axis gives the same cosine.
    const float cos_l = similarity_
                            ? dot(axis_, -s->wi)
                            : cos_theta(normalize(render_from_light_.inverse_vector(-s->wi)));
    s->L = I_ * (smooth_step(cos_l, cos_falloff_end_, cos_falloff_start_) / d2);
    if (s->L.is_black())
        return std::nullopt;
    s->pdf = 1.f;
    return s;
}

/// Directional light (pbrt-v4 "distant"): radiance L arriving from direction `w_to_light`.
class DistantLight final : public Light {
  public:
    DistantLight(Vec3f w_to_light, Rgb radiance) : w_(normalize(w_to_light)), L_(radiance) {}
    LightType type() const override { return LightType::DeltaDirection; }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &, Vec3f, Vec3f, Vec3f) const override { return 0.f; }
    Rgb phi() const override { return L_ * (kPi * scene_radius_ * scene_radius_); }
    void preprocess(Vec3f c, float r) override { scene_center_ = c, scene_radius_ = r; }
    std::string describe() const override;

  private:
    Vec3f w_;
    Rgb L_;
    Vec3f scene_center_;
    float scene_radius_ = 1.f;
};

/// Constant environment (pbrt-v4 "infinite" with "L"): sampled uniformly over the sphere so that
/// MIS with BSDF sampling works.
class UniformInfiniteLight final : public Light {
  public:
    explicit UniformInfiniteLight(Rgb radiance) : L_(radiance) {}
    LightType type() const override { return LightType::Infinite; }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &, Vec3f, Vec3f, Vec3f) const override;
    Rgb Le(Vec3f) const override { return L_; }
    Rgb phi() const override { return L_ * (4.f * kPi * kPi * scene_radius_ * scene_radius_); }
    void preprocess(Vec3f c, float r) override { scene_center_ = c, scene_radius_ = r; }
    std::string describe() const override;

  private:
    Rgb L_;
    Vec3f scene_center_;
    float scene_radius_ = 1.f;
};

/// Environment map (pbrt-v4 "infinite" with "filename"). Square images use pbrt-v4's
/// equal-area octahedral mapping (Clarberg 2008); 2:1 images use the latitude-longitude mapping
/// (theta = v pi from light-space +z, phi = u 2 pi from +x), a Tessera convenience. Radiance
/// lookups take the nearest pixel, as pbrt-v4's ImageLe does; directions are importance sampled
/// by a PiecewiseConstant2D over the pixels' channel average (pbrt-v4's
/// Image::GetSamplingDistribution), times sin(theta) for lat-long.
class ImageInfiniteLight final : public Light {
  public:
    enum class Mapping { EqualArea, Equirect };
    /// `pixels`: width*height linear RGB values, row 0 at the top (v = 0). `scale` multiplies.
    ImageInfiniteLight(const Transform &render_from_light, std::vector<Rgb> pixels, int width,
                       int height, Mapping mapping, float scale);
    LightType type() const override { return LightType::Infinite; }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &, Vec3f wi, Vec3f, Vec3f) const override;
    Rgb Le(Vec3f dir) const override;
    Rgb phi() const override;
    void preprocess(Vec3f c, float r) override { scene_center_ = c, scene_radius_ = r; }
    std::string describe() const override;

    Mapping mapping() const { return mapping_; }
    /// Light-space unit direction of image coordinates uv in [0,1]^2 under `mapping`.
    static Vec3f direction_from_uv(Mapping mapping, Vec2f uv);
    /// Image coordinates of a light-space unit direction under `mapping`.
    static Vec2f uv_from_direction(Mapping mapping, Vec3f w_light);

  private:
    Rgb lookup(Vec2f uv) const;

    Transform render_from_light_;
    std::vector<Rgb> pixels_;
    int width_, height_;
    Mapping mapping_;
    float scale_;
    sampling::PiecewiseConstant2D distribution_;
    Vec3f scene_center_;
    float scene_radius_ = 1.f;
};

/// Diffuse emitter on one triangle (pbrt-v4 DiffuseAreaLight on a Triangle). Sampled uniformly
/// by area (pbrt-v4 switches to spherical-triangle sampling for mid-sized solid angles; area
/// sampling has the same expectation, only more variance for large nearby triangles).
class TriangleLight final : public Light {
  public:
    /// Vertices in world space; `n`: unit normal of the emitting side (the caller applies
    /// pbrt's orientation rules); `radiance`: emitted radiance (after scale/power).
    TriangleLight(Vec3f p0, Vec3f p1, Vec3f p2, Vec3f n, Rgb radiance, bool twosided);
    LightType type() const override { return area_type(); }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &ctx, Vec3f wi, Vec3f p_light,
                 Vec3f n_light) const override;
    Rgb L(Vec3f p_light, Vec3f n_light, Vec2f uv, Vec3f w_out) const override;
    Rgb phi() const override;
    std::string describe() const override;
    float area() const { return area_; }
    /// What sample_li reads (the path tracer's packet kernel samples 8 lanes at once).
    Vec3f p0() const { return p0_; }
    Vec3f p1() const { return p1_; }
    Vec3f p2() const { return p2_; }
    Vec3f normal() const { return n_; }
    Rgb radiance() const { return L_; }
    bool twosided() const { return twosided_; }

  private:
    Vec3f p0_, p1_, p2_, n_;
    Rgb L_;
    bool twosided_;
    float area_;
};

/// Diffuse emitter on a full sphere (pbrt-v4 DiffuseAreaLight on a Sphere). From outside it
/// samples the cone of directions the sphere subtends (pbrt-v4 Sphere::Sample(ctx, u)); from
/// inside, uniformly by area. `reverse_orientation`: normals point inward, so a one-sided
/// sphere light emits toward its centre.
class SphereLight final : public Light {
  public:
    SphereLight(Vec3f center, float radius, Rgb radiance, bool reverse_orientation = false,
                bool twosided = false);
    LightType type() const override { return area_type(); }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &ctx, Vec3f wi, Vec3f p_light,
                 Vec3f n_light) const override;
    Rgb L(Vec3f p_light, Vec3f n_light, Vec2f uv, Vec3f w_out) const override;
    Rgb phi() const override;
    std::string describe() const override;
    float area() const { return 4.f * kPi * radius_ * radius_; }

  private:
    Vec3f emitting_normal(Vec3f p) const;

    Vec3f c_;
    float radius_;
    Rgb L_;
    bool reverse_, twosided_;
};

/// Diffuse emitter on a disk (pbrt-v4 DiffuseAreaLight on a Disk with innerradius 0 and
/// phimax 360), sampled uniformly by area (concentric mapping).
class DiskLight final : public Light {
  public:
    /// `n`: unit normal of the emitting side.
    DiskLight(Vec3f center, Vec3f n, float radius, Rgb radiance, bool twosided = false);
    LightType type() const override { return area_type(); }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &ctx, Vec3f wi, Vec3f p_light,
                 Vec3f n_light) const override;
    Rgb L(Vec3f p_light, Vec3f n_light, Vec2f uv, Vec3f w_out) const override;
    Rgb phi() const override;
    std::string describe() const override;
    float area() const { return kPi * radius_ * radius_; }

  private:
    Vec3f c_;
    Frame frame_;
    float radius_;
    Rgb L_;
    bool twosided_;
};

/// Diffuse emitter on a cylinder, a partial sphere or a partial disk / annulus (pbrt-v4
/// DiffuseAreaLight on those shapes), sampled uniformly by area -- exactly: each surface has a
/// constant area element in (z, phi) (sphere, cylinder) or (r^2, phi) (disk). Full spheres and
/// full disks use SphereLight and DiskLight. `render_from_object` must scale uniformly (the
/// caller checks); the emitting side is the outward normal, inward when `flip_normal`.
class QuadricAreaLight final : public Light {
  public:
    enum class Kind { Sphere, Cylinder, Disk };
    struct Shape {
        Kind kind = Kind::Cylinder;
        float radius = 1, zmin = -1, zmax = 1, phi_max = 2 * kPi;  ///< sphere, cylinder
        float inner_radius = 0, height = 0;                        ///< disk
        bool flip_normal = false;
    };
    QuadricAreaLight(const Shape &shape, const Transform &render_from_object, Rgb radiance,
                     bool twosided = false);
    LightType type() const override { return area_type(); }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    /// The emitting normal is recomputed from p_light (n_light is not needed).
    float pdf_li(const LightSampleContext &ctx, Vec3f wi, Vec3f p_light,
                 Vec3f n_light) const override;
    Rgb L(Vec3f p_light, Vec3f n_light, Vec2f uv, Vec3f w_out) const override;
    Rgb phi() const override;
    std::string describe() const override;
    /// World-space area.
    float area() const { return area_; }
    /// The point for u in [0,1)^2 (uniform by area) and its emitting normal, world space.
    void sample_point(Vec2f u, Vec3f *p, Vec3f *n) const;

  private:
    Vec3f emitting_normal(Vec3f p_world) const;
    Shape shape_;
    Transform xf_;
    float area_;
    Rgb L_;
    bool twosided_;
};

/// pbrt-v4 "goniometric": a point light at the light-space origin whose intensity toward each
/// direction is read from a square image in the equal-area octahedral mapping (nearest pixel),
/// with light-space y and z swapped first, as pbrt-v4 does: the image's pole (+z of the map)
/// is the light's +y.
class GoniometricLight final : public Light {
  public:
    /// `image`: res x res linear values (row 0 at the top), already multiplied by nothing;
    /// `intensity` carries "I", "scale" and the "power" normalisation.
    GoniometricLight(const Transform &render_from_light, Rgb intensity, std::vector<float> image,
                     int res);
    LightType type() const override { return LightType::DeltaPosition; }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &, Vec3f, Vec3f, Vec3f) const override { return 0.f; }
    /// 4 pi I times the image's mean (pbrt-v4 GoniometricLight::Phi).
    Rgb phi() const override;
    std::string describe() const override;
    /// Intensity (W/sr) toward light-space direction w (any length; before the y/z swap).
    Rgb intensity(Vec3f w_light) const;
    /// The image's mean value.
    float image_mean() const { return mean_; }

  private:
    Transform render_from_light_;
    Vec3f p_;
    Rgb I_;
    std::vector<float> image_;
    int res_;
    float mean_ = 0;
};

/// pbrt-v4 "projection": a point light at the light-space origin projecting an RGB image
/// through a perspective frustum of `fov` (degrees, the image's shorter axis) along +z, like a
/// slide projector (the image's top toward +y, nearest pixel, nothing outside the frustum).
class ProjectionLight final : public Light {
  public:
    /// `image`: width x height linear RGB, row 0 at the top; `scale` carries "scale" and the
    /// "power" normalisation.
    ProjectionLight(const Transform &render_from_light, std::vector<Rgb> image, int width,
                    int height, float fov_deg, float scale);
    LightType type() const override { return LightType::DeltaPosition; }
    std::optional<LightLiSample> sample_li(const LightSampleContext &ctx, Vec2f u) const override;
    float pdf_li(const LightSampleContext &, Vec3f, Vec3f, Vec3f) const override { return 0.f; }
    /// scale * A * mean(rgb * cos^3) over the image (pbrt-v4 ProjectionLight::Phi).
    Rgb phi() const override;
    std::string describe() const override;
    /// Intensity (W/sr) toward light-space direction w (any length).
    Rgb intensity(Vec3f w_light) const;
    /// pbrt-v4's normalisation of "power": A * mean(luminance * cos^3) per unit scale.
    float unit_power() const;

  private:
    Transform render_from_light_;
    Vec3f p_;
    std::vector<Rgb> image_;
    int width_, height_;
    float scale_;
    float inv_tan_;        ///< 1 / tan(fov / 2)
    float x0_, x1_, y0_, y1_;  ///< screen bounds (the shorter axis spans [-1, 1])
    float area_;           ///< A: the screen window's area at distance 1
};

/// Builds a light from a `LightSource` directive: "point", "spot", "distant", "infinite" (with
/// "L", with "filename", or neither: the colour space's illuminant, RGB (1,1,1)). Parameters,
/// defaults and the "power"/"illuminance" normalisations are pbrt-v4's; "goniometric" reads a
/// square equal-area image ("filename"; RGB averaged), "projection" an RGB image ("filename",
/// "fov"). Unknown types throw SceneError with file:line. Image files are read with
/// OpenImageIO and resolved against desc.base_dir; 8-bit images are decoded from sRGB. Unused
/// parameters are reported with warn(). Not thread-safe only through warn()'s ordering.
std::unique_ptr<Light> make_light(const LightDesc &desc);

/// Emission of an `AreaLightSource "diffuse"`.
struct AreaEmission {
    Rgb L{1.f, 1.f, 1.f};  ///< emitted radiance, after "scale" and "power"
    bool twosided = false;
};

/// Reads AreaLightSource "diffuse" parameters: "L" (default: the colour space's illuminant,
/// RGB (1,1,1)), "scale" (1), "twosided" (false), "power" (W; normalises L so that this shape
/// emits that power: L *= power / (pi * area * (twosided ? 2 : 1)), ignoring L's colour, as
/// pbrt-v4 does). `shape_area` is the area of one pbrt Shape (pbrt-v4 makes one light per
/// triangle of a mesh, so "power" applies per triangle). "filename" (image-textured emission)
/// is not supported: warns and uses L. Throws SceneError for an unknown type elsewhere.
AreaEmission make_area_emission(const ParamSet &params, const FileLoc &loc, float shape_area);

/// Reads an image as linear RGB (row 0 at the top) with OpenImageIO. 8-bit/16-bit integer
/// images are decoded from sRGB unless tagged linear; one-channel images become grey. Throws
/// SceneError(loc, ...) when the file cannot be read or holds non-finite pixels.
std::vector<Rgb> read_rgb_image(const std::string &path, const FileLoc &loc, int *width,
                                int *height);

}  // namespace tessera
