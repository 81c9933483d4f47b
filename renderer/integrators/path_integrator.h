// Unidirectional path tracer with next-event estimation and multiple importance sampling.
//
// For each camera sample: trace the primary ray through the filter-importance-sampled film
// position; at every non-specular vertex sample one light (chosen proportionally to power) and
// the BSDF, combining both strategies with the power heuristic (Veach 1997, ch. 9); Russian
// roulette after the second bounce on throughput x eta^2 (pbrt-v4 PathIntegrator), continuing
// with probability sqrt of it (Cycles; roulette_termination in path_common.h). Radiance
// that is NaN or Inf is left for the film to drop and count.
#pragma once

#include <atomic>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "renderer/scene/scene.h"
#include "renderer/scene/specialize.h"
#include "sampling/sample_source.h"
#include "sampling/sequence.h"

namespace tessera {

/// How direct light is estimated (the MIS consistency test compares all three).
enum class DirectStrategy {
    Mis,        ///< light and BSDF sampling, power heuristic (the default)
    LightOnly,  ///< next-event estimation only; emission found by BSDF sampling ignored
    BsdfOnly,   ///< BSDF sampling only; no shadow rays (delta lights contribute nothing)
};

class PathIntegrator final : public SampleSource {
  public:
    /// `scene` must outlive the integrator. `seed` selects the sample sequence, whose pattern
    /// is the scene's (RenderSettings::sample_pattern). The
    /// specialised code paths (renderer/scene/specialize.h) that apply to the scene are used, except
    /// those in `disabled` (Specialization bits), which take the general path.
    PathIntegrator(const Scene &scene, uint32_t seed, int max_depth,
                   DirectStrategy strategy = DirectStrategy::Mis, uint32_t disabled = 0);
    uint32_t width() const override { return uint32_t(scene_.settings.width); }
    uint32_t height() const override { return uint32_t(scene_.settings.height); }
    /// Thread-safe; a pure function of the camera sample and the seed.
    Sample evaluate(const CameraSample &cs) const override;
    /// The same samples as evaluate(), their camera rays traced as 8-wide packets (a pixel's
    /// consecutive samples are nearly coherent); the paths continue one by one, or, with the
    /// packet specialisation, 8 at a time in lockstep (trace_packet).
    void evaluate_batch(std::span<const CameraSample> samples,
                        std::span<Sample> out) const override;
    std::string describe() const override;
    /// The Specialization bits in use (applicable to the scene and not disabled).
    uint32_t specializations() const { return spec_; }
    /// Radiance along an arbitrary ray (tests: furnaces); `sampler_index` picks the sequence.
    Rgb radiance(const Ray &ray, uint32_t px, uint32_t py, uint32_t index) const;

  private:
    struct PathResult {
        Rgb L, albedo;
        Vec3f normal;
        float depth = kInfinity;
        uint32_t rays = 0;
        uint32_t shadow_rays_avoided = 0;
    };
    /// The camera ray of `cs`; leaves `sampler` at the path's first dimension.
    CameraRay camera_ray(const CameraSample &cs, sampling::SobolSampler &sampler) const;
    Sample to_sample(const PathResult &r) const;
    /// to_sample into an existing Sample (every field written), without a temporary.
    void to_sample(const PathResult &r, Sample &s) const;
    /// `first`, when given, is the camera ray's hit already traced (evaluate_batch).
    PathResult trace(const CameraRay &cray, sampling::SobolSampler &sampler,
                     std::optional<SurfaceInteraction> *first = nullptr) const;
    /// The path loop; kLambertian: every material is a constant Lambertian (lambertian_).
    template <bool kLambertian>
    PathResult trace_impl(const CameraRay &cray, sampling::SobolSampler &sampler,
                          std::optional<SurfaceInteraction> *first) const;

    /// The "packet" specialisation (renderer/integrators/path_packet.cpp): the samples traced 8 paths at a
    /// time in lockstep (a lane whose path ends takes the next sample), each bounce's
    /// arithmetic lane-parallel; every sample gets trace_impl<true>'s result.
    void trace_packet(std::span<const CameraSample> samples, std::span<Sample> out) const;

    const Scene &scene_;
    uint32_t seed_;
    sampling::SamplePattern pattern_;
    int max_depth_;
    DirectStrategy strategy_;
    int spp_hint_;
    uint32_t spec_ = 0;
    bool differentials_ = true;   ///< ray differentials and texture footprints are computed
    bool cull_ = false;           ///< no shadow rays toward lights that cannot contribute
    std::vector<Rgb> lambertian_; ///< per material: its reflectance (lambertian specialisation)
    /// The packet specialisation's meshes by Embree geomID; empty when it is off.
    std::vector<const TriangleMesh *> packet_meshes_;
};

}  // namespace tessera
