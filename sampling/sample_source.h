// The one callback across layers: how `sampling/` and `scheduler/` evaluate a sample without
// knowing anything about the scene (DESIGN.md, "The data that flows").
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "sampling/vecmath.h"

namespace tessera {

/// Where on the film a sample lands: pixel (px, py) plus the offset (fx, fy) in [0,1)^2 inside
/// it, and the per-pixel sample index that selects the sample's random numbers.
struct CameraSample {
    uint32_t px = 0, py = 0;
    float fx = 0.5f, fy = 0.5f;
    uint32_t index = 0;
};

/// The papers' attribute vector of a first hit (used by the real-time modes only).
struct HitAttributes {
    int32_t object_id = -1;  ///< -1: the ray escaped
    Vec3f position, normal;
    uint32_t shadow_bits = 0;  ///< bit i set: light i is occluded
    Vec2f uv;
    bool has_texture = false;
};

/// One evaluated sample: radiance and the AOVs the film keeps.
struct Sample {
    Rgb radiance;
    Rgb albedo;        ///< first-hit reflectance estimate (AOV)
    Vec3f normal;      ///< first-hit shading normal, world space (AOV); zero when escaped
    float depth = 0;   ///< distance along the primary ray (AOV); +inf when escaped
    uint32_t rays = 0; ///< rays traced for this sample (statistics)
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
    /// Shades interpolated attributes without a primary ray (undersampling modes). Default: black.
    virtual Rgb shade(const HitAttributes &) const { return Rgb(0.f); }
    /// One readable line describing the source, for logs.
    virtual std::string describe() const = 0;
};

}  // namespace tessera
