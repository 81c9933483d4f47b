// Deterministic Whitted-style ray tracer for the real-time anti-aliasing modes
// (docs/ARCHITECTURE.md, "The PixelSampler plugin").
//
// Whitted 1980, "An Improved Illumination Model for Shaded Display": at every hit, direct light
// from each light with one hard shadow ray, plus perfect mirror reflection and refraction
// traced recursively to a fixed depth. There are no random numbers at all, so neighbouring
// samples differ only where the picture has edges (what the papers' similarity tests assume).
//
// - Camera: the primary ray goes through film position (px + fx, py + fy) exactly: no pixel
//   filter warp (the plugins choose sub-pixel positions and average with a box filter), a
//   pinhole (the lens centre; depth of field is ignored).
// - Lights, each with one shadow ray toward its centre: point, spot (pbrt's smoothstep cone),
//   distant, and diffuse area lights as point-like emitters at the centroid of the emitting
//   triangle or disk, E = L A cos_l cos_s / d^2 (|cos_l| when two-sided); an emitting sphere
//   counts as its projected disc, E = L pi r^2 cos_s / d^2 toward its centre (exact for a fully
//   visible sphere), its shadow ray ending on the sphere's near side; points inside an emitting
//   sphere get nothing from it. Emission of area lights is seen directly and in mirrors.
//   Infinite lights only colour escaped rays: they cast no light and no shadows.
// - Materials (the non-specular part shades with the BSDF, f cos): conductors reflect as
//   perfect mirrors with their Fresnel term, rough ones too (plus their glossy highlight of
//   the lights, as in Whitted's model); dielectrics split into reflection R and refraction
//   (1 - R) / eta'^2 (total internal reflection: R = 1); thin dielectrics reflect R' and pass
//   1 - R' straight through; coated diffuse = the BSDF's direct light + a perfect coat
//   reflection weighted by its Fresnel; coated conductor = its direct light + one mirror of
//   weight R + T^2 F_b A / (1 - R F_b A) (both layers as mirrors). The coated materials' f is
//   pbrt-v4's stochastic layered estimate, evaluated with a coherent seed
//   (LayeredBxdf::coherent_seed): a smooth function of the directions, so no noise, but a
//   fixed-pattern error of the one set of walks (nsamples), and ~1 us per light and point.
//   "mix" materials resolve to one component per material
//   and amount: pbrt's MixMaterial hash taken at a fixed point whose threshold is 0.5, so the
//   component with the larger weight wins (amount > 0.5 picks the second). "interface"
//   surfaces are invisible (the ray continues).
// - Textures are looked up at the hit's (p, uv) without ray differentials (the finest level):
//   anti-aliasing is the samplers' job, and shade() has no differentials either.
//
// Attribute vectors (sampling/sample_source.h): evaluate() fills Sample::first_hit; the local
// shading at the first hit is a pure function of (object id, position, normal, uv, shadow
// bits, viewer), so shade(evaluate(cs).first_hit) reproduces evaluate(cs).radiance (exactly,
// apart from the two documented exceptions in shade()).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "renderer/scene/scene.h"
#include "sampling/sample_source.h"

namespace tessera {

/// Parameters of the Whitted integrator.
struct WhittedOptions {
    /// Reflection/refraction depth: a hit at depth d < max_depth spawns its specular rays
    /// (the primary hit has depth 0; 0 = direct light only).
    int max_depth = 5;
    /// Recorded for logs only: the integrator draws no random numbers.
    uint32_t seed = 0;
    /// Attribute groups (kAttr* bits of sampling/sample_source.h) the caller reads, e.g. the
    /// frame plugin's PixelSampler::attributes_used(); kAttrNone: a plain image, no
    /// Sample::first_hit.
    uint32_t attributes = kAttrAll;
    /// true: collect only `attributes` minus what the scene cannot have (no secondary record
    /// without a specular material, no uv / has_texture without textures); the values of what is
    /// collected are the same as on the general path, bit for bit. false (`--no-specialize`):
    /// the general path, every group collected whatever `attributes` says.
    bool specialize = true;
    /// true: shade() builds the BSDF of a Lambertian material without bump or normal map from
    /// its reflectance (cached when constant, else Material::lambertian_at) instead of through
    /// Material::get_bsdf: the same BxDF, so the same colour bit for bit, without the
    /// surface rebuilt for the material and the material's frame. false
    /// (`--no-specialize=lambertian`): always get_bsdf.
    bool lambertian = true;
};

/// Deterministic Whitted ray tracer (see the file comment). Immutable after construction;
/// every method is thread-safe. No allocation per sample.
class WhittedIntegrator final : public SampleSource {
  public:
    /// `scene` must outlive the integrator. The camera may move between frames
    /// (PerspectiveCamera::set_world_from_camera): the viewer position is read per call.
    WhittedIntegrator(const Scene &scene, const WhittedOptions &options = {});

    uint32_t width() const override { return uint32_t(scene_.settings.width); }
    uint32_t height() const override { return uint32_t(scene_.settings.height); }
    /// Traces the primary ray through (px + fx, py + fy) and shades it. Pure function of the
    /// camera sample (cs.index is ignored). radiance = first_hit->local_color +
    /// first_hit->global_color (before the Film "maxcomponentvalue" clamp, when set); both
    /// include the film's image scale. Sample::rays counts every ray traced (primary, shadow,
    /// reflection, refraction, and continuations through "interface" surfaces).
    Sample evaluate(const CameraSample &cs) const override;
    /// Same results as evaluate() per sample, bit for bit; the primary rays are traced as
    /// Embree packets of 8 (the batch's order; remainders of at most 4 and single rays with
    /// rtcIntersect4 / rtcIntersect1). out.size() == samples.size().
    void evaluate_batch(std::span<const CameraSample> samples,
                        std::span<Sample> out) const override;
    bool provides_attributes() const override { return collected_ != kAttrNone; }
    /// The attribute groups evaluate() fills (kAttr* bits; see WhittedOptions).
    uint32_t collected_attributes() const { return collected_; }
    /// Local shading of an (interpolated) attribute vector: emission and direct light at
    /// primary.position with primary.normal and primary.uv for primary.object_id's material,
    /// seen from the camera (its position; orthographic: its direction), light i visible
    /// unless shadow bit min(i, 31) is set (no rays are traced), plus global_color, times the
    /// image scale and clamped like evaluate(). An escaped primary (object_id -1) returns the
    /// environment radiance toward the direction in primary.position. Exceptions to
    /// shade(evaluate(cs).first_hit) == evaluate(cs).radiance: lights 31 and up share bit 31
    /// (set when any of them is blocked; shade() then treats all of them as blocked), and an
    /// emissive mesh whose triangles have different radiance ("power" is per triangle) is seen
    /// with its first triangle's radiance in shade().
    Rgb shade(const HitAttributes &attributes) const override;
    /// Distance of p in front of the camera along its viewing axis (1 for orthographic).
    float view_depth(Vec3f p) const override;
    std::string describe() const override;

    const WhittedOptions &options() const { return options_; }
    /// The primary ray of a camera sample (unit direction).
    Ray camera_ray(const CameraSample &cs) const;

  private:
    /// An entry of scene.lights as Whitted sees it.
    struct LightProxy {
        /// Point and Spot: delta lights whose sample_li is called directly (inlined); Delta:
        /// the other delta lights, through the virtual call.
        enum class Kind { None, Delta, Point, Spot, Area, Sphere } kind = Kind::None;
        const Light *light = nullptr;
        Vec3f p;                ///< area: centroid; sphere: centre
        Vec3f n;                ///< area: emitting-side unit normal
        float area = 0;         ///< area: A; sphere: pi r^2 (its projected disc)
        float radius = 0;       ///< sphere
        Rgb L;                  ///< area: emitted radiance (on the n side unless two-sided)
        bool twosided = false;  ///< area
    };
    /// Emission of an emissive object, as seen directly.
    struct Emission {
        int32_t object_id = -1;
        Rgb L;  ///< radiance on the emitting side
        bool twosided = false;
    };
    /// Where a surface is shaded locally (the attribute vector's view of a hit).
    struct ShadePoint {
        int32_t object_id = -1;
        int material = -1;
        Vec3f p;   ///< position
        Vec3f n;   ///< shading normal (faces the viewer, except on one-sided emitters' backs)
        Vec3f wo;  ///< unit direction toward the viewer
        Vec2f uv;
    };
    /// Per-sample scratch and ray counters (on the stack of evaluate).
    struct Trace;
    /// What a caller of shade_ray wants besides the radiance.
    struct HitOut;

    Sample finish_primary(const Ray &ray, std::optional<SurfaceInteraction> &hit, Trace &tr) const;
    /// Radiance along `ray` whose closest hit is `hit` (already traced and counted);
    /// continues through "interface" surfaces, so `hit` may be replaced.
    Rgb shade_ray(const Ray &ray, std::optional<SurfaceInteraction> &hit, int depth, Trace &tr,
                  HitOut &out) const;
    /// Radiance along a new ray (traces and counts it); fills *attrs with its first hit.
    Rgb trace_ray(const Ray &ray, int depth, Trace &tr, SurfaceAttributes *attrs) const;
    /// The material's BSDF at a shade point, in the material's own (possibly bump-mapped)
    /// frame. `si`: the real hit (evaluate), or null to rebuild the surface from sp (shade).
    std::optional<Bsdf> material_bsdf(const ShadePoint &sp, const SurfaceInteraction *si) const;
    /// Emission plus direct light at a shade point; `bsdf` is framed by sp.n. With `si`
    /// (evaluate): one shadow ray per light that can contribute, setting *bits and counting
    /// tr's rays (traced and avoided); without (shade, tr null): visibility from *bits. A light
    /// that cannot contribute (behind a reflection-only surface, the point behind a one-sided
    /// emitter, outside a spot cone, zero radiance or BSDF value) is skipped identically in both.
    Rgb local_shading(const ShadePoint &sp, const Bsdf *bsdf, const SurfaceInteraction *si,
                      uint32_t *bits, Trace *tr) const;
    Rgb environment(Vec3f dir) const;
    const Emission *emission_of(int32_t object_id) const;
    /// Unit direction toward the viewer from p (perspective: the camera position).
    Vec3f viewer_direction(Vec3f p) const;
    bool has_texture(int material) const;

    const Scene &scene_;
    WhittedOptions options_;
    std::vector<LightProxy> lights_;   ///< parallel to scene.lights
    std::vector<Emission> emissions_;  ///< sorted by object id
    std::vector<uint8_t> textured_;    ///< per material: reads a texture
    uint32_t collected_ = kAttrAll;    ///< attribute groups filled (kAttr* bits)
    bool orthographic_ = false;
    /// Per material: its reflectance when it is a constant Lambertian (sized only with
    /// options_.lambertian).
    std::vector<std::optional<Rgb>> lambertian_;
};

/// Factory for the command line (`--integrator whitted`).
std::unique_ptr<SampleSource> make_whitted_integrator(const Scene &scene,
                                                      const WhittedOptions &options);

}  // namespace tessera
