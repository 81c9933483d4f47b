// The one callback across layers: how `sampling/` and `scheduler/` evaluate a sample without
// knowing anything about the scene (docs/ARCHITECTURE.md, "The data that flows").
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include "sampling/vecmath.h"

namespace tessera {

/// Where on the film a sample lands: pixel (px, py) plus the offset (fx, fy) in [0,1)^2 inside
/// it, and the per-pixel sample index that selects the sample's random numbers.
struct CameraSample {
    uint32_t px = 0, py = 0;
    float fx = 0.5f, fy = 0.5f;
    uint32_t index = 0;
};

/// Geometry attributes of one ray-surface hit, as the real-time papers collect them (Kim et al.
/// 2013 "ray-attribute vector"; Jin et al. 2009 Table 1).
///
/// A ray that escaped has object_id -1 and carries its unit direction in `position` (shade()
/// looks the environment up there). A secondary record with no ray behind it (the first hit
/// is not specular, or the depth limit is 0) has object_id -1 and position zero.
struct SurfaceAttributes {
    int32_t object_id = -1;  ///< stable id of the shape hit (one per mesh, sphere, disk and
                             ///< instanced shape); -1: no hit (see above)
    Vec3f position;          ///< world-space hit point; escaped: the unit ray direction
    /// Unit shading normal, world space, facing the viewer (the camera for the primary hit,
    /// the ray's origin for the secondary one); on one-sided emitters it stays on the emitting
    /// side, so that shading knows whether the emitter is seen from its back.
    Vec3f normal;
    /// Bit i set: the hit point is in shadow with respect to light i of Scene::lights (lights
    /// 0..31; lights beyond 31 share bit 31, set when any of them is blocked). Only lights that
    /// would light the point are tested: a light behind the surface or outside a spot cone
    /// leaves its bit 0.
    uint32_t shadow_bits = 0;
    Vec2f uv;                  ///< surface texture coordinates
    bool has_texture = false;  ///< the material reads a texture at this hit
    bool hit() const { return object_id >= 0; }
};

/// The papers' attribute vector of a camera sample: the first hit, the first reflection or
/// refraction hit, and the "global colour" (Kim's GCOL: the radiance that arrived through
/// specular reflection and refraction). Filled by integrators that support the real-time modes
/// (the Whitted integrator); `SampleSource::shade` turns an (interpolated) vector into a colour.
struct HitAttributes {
    SurfaceAttributes primary;    ///< first hit of the primary ray
    /// First hit of the first reflection/refraction ray (for a dielectric, of the stronger of
    /// the two).
    SurfaceAttributes secondary;
    Rgb global_color;  ///< radiance via specular reflection/refraction (GCOL)
    Rgb local_color;   ///< the rest: direct light and emission at the first hit
    // Sample::radiance == local_color + global_color (in film units, before any clamp).
};

/// Groups of the attribute vector an integrator collects (bit mask), at the granularity of the
/// work an integrator can skip: a frame plugin declares what it reads
/// (PixelSampler::attributes_used), the integrator collects that minus what the scene cannot have.
enum AttributeBits : uint32_t {
    kAttrNone = 0,
    /// HitAttributes::primary's object id, position, normal and shadow bits, and the
    /// local/global colour split: the record itself (Sample::first_hit is filled).
    kAttrPrimary = 1u << 0,
    /// uv and has_texture of every recorded hit (the material table lookup per hit).
    kAttrTexture = 1u << 1,
    /// HitAttributes::secondary (the first reflection/refraction hit).
    kAttrSecondary = 1u << 2,
    kAttrAll = kAttrPrimary | kAttrTexture | kAttrSecondary,
};

/// Readable names of the groups in `bits` ("primary+texture+secondary", "none").
inline std::string describe_attributes(uint32_t bits) {
    if (!(bits & kAttrAll))
        return "none";
    std::string s;
    for (auto [bit, name] : {std::pair<uint32_t, const char *>{kAttrPrimary, "primary"},
                             {kAttrTexture, "texture"},
                             {kAttrSecondary, "secondary"}})
        if (bits & bit) {
            if (!s.empty())
                s += '+';
            s += name;
        }
    return s;
}

/// One evaluated sample: radiance and the AOVs the film keeps.
struct Sample {
    Rgb radiance;
    Rgb albedo;        ///< first-hit reflectance estimate (AOV)
    Vec3f normal;      ///< first-hit shading normal, world space (AOV); zero when escaped
    float depth = 0;   ///< distance along the primary ray (AOV); +inf when escaped
    uint32_t rays = 0; ///< rays traced for this sample (statistics)
    /// Shadow rays not traced because the light could not contribute (behind the surface or
    /// the light's emitting side, outside a spot cone, zero radiance or zero BSDF value).
    uint32_t shadow_rays_avoided = 0;
    uint32_t shadow_rays = 0;  ///< shadow rays traced for this sample (included in `rays`)
    std::optional<HitAttributes> first_hit;
};

/// What the scheduler calls to evaluate samples. Implementations must be thread-safe: many
/// threads call `evaluate` concurrently, each with its own CameraSample.
class SampleSource {
  public:
    virtual ~SampleSource() = default;
    /// Film resolution in pixels.
    virtual uint32_t width() const = 0;
    virtual uint32_t height() const = 0;
    /// Traces and shades one camera sample. The result must be a pure function of the
    /// CameraSample (and the source's seed), never of the calling thread.
    virtual Sample evaluate(const CameraSample &cs) const = 0;
    /// Evaluates a batch of camera samples (e.g. a ray packet: the Whitted integrator traces
    /// primary rays with rtcIntersect4/8). out.size() == samples.size(). Default: one by one.
    virtual void evaluate_batch(std::span<const CameraSample> samples,
                                std::span<Sample> out) const {
        for (size_t i = 0; i < samples.size(); ++i) out[i] = evaluate(samples[i]);
    }
    /// True when evaluate() fills Sample::first_hit (the integrator supports the real-time
    /// modes' attribute vectors and shade()).
    virtual bool provides_attributes() const { return false; }
    /// Shades an attribute vector without tracing a primary ray (undersampling modes): local
    /// shading at primary.position / normal / uv with the shadow bits as given (no shadow rays),
    /// plus global_color. Default (sources without attributes): black.
    virtual Rgb shade(const HitAttributes &) const { return Rgb(0.f); }
    /// Depth of world point p along the camera's viewing axis (perspective projection divides
    /// by it), for perspective-correct interpolation of attribute vectors in screen space.
    /// 1 when the projection is affine (orthographic cameras, synthetic sources): then linear
    /// interpolation is the correct one.
    virtual float view_depth(Vec3f /*p*/) const { return 1.f; }
    /// One readable line describing the source, for logs.
    virtual std::string describe() const = 0;
};

}  // namespace tessera
