// Volumetric path tracer: pbrt-v4's VolPathIntegrator (PBRT 4th ed., section 14.2) in RGB.
//
// Along each ray segment inside a medium, distances are sampled against the medium's majorant
// (delta tracking with null scattering, Novak et al. 2014); at a sampled point the path is
// absorbed (adding the medium's emission), scatters (next-event estimation through the media
// with ratio-tracking transmittance, then Henyey-Greenstein phase sampling) or continues (a
// null collision). Through homogeneous media shadow rays take the closed-form transmittance,
// the expectation of pbrt-v4's ratio-tracking estimate there (same image, less noise). Surfaces shade as in the path tracer; surfaces without a material
// ("interface") only move the ray from one medium into another.
//
// Chromatic media (sigma_t differing per channel): pbrt-v4's spectral MIS (Miller, Georgiev and
// Jarosz 2019, "A null-scattering path integral formulation of light transport") carried over
// to three channels. Each camera sample picks a hero channel uniformly; distances are sampled
// with the hero's majorant, and the path carries, besides its throughput beta, the ratios
// r_u (of each channel's unidirectional path pdf to the hero's) and r_l (light-sampling pdf to
// the hero's); contributions are divided by the channel average of those ratios, the one-sample
// MIS over the channel choice. A channel whose sigma_t is 0 is then carried by the others'
// samples: no bias and no division by zero. Direct light combines light and BSDF/phase sampling
// with the balance heuristic, as pbrt-v4's volpath does.
//
// The integrator runs for every scene with media (integrators.h make_path_tracer); a scene
// without media keeps the surface path tracer (path_integrator.h) and pays nothing.
#pragma once

#include <optional>
#include <span>
#include <string>

#include "renderer/scene/scene.h"
#include "sampling/sample_source.h"
#include "sampling/sequence.h"

namespace tessera {

class VolPathIntegrator final : public SampleSource {
  public:
    /// `scene` must outlive the integrator. `seed` selects the sample sequence, whose pattern
    /// is the scene's (RenderSettings::sample_pattern).
    VolPathIntegrator(const Scene &scene, uint32_t seed, int max_depth);
    uint32_t width() const override { return uint32_t(scene_.settings.width); }
    uint32_t height() const override { return uint32_t(scene_.settings.height); }
    /// Thread-safe; a pure function of the camera sample and the seed.
    Sample evaluate(const CameraSample &cs) const override;
    void evaluate_batch(std::span<const CameraSample> samples,
                        std::span<Sample> out) const override;
    std::string describe() const override;
    /// Radiance along an arbitrary ray starting in medium `medium` (-1: vacuum) with hero
    /// channel `hero` (tests: furnaces, slabs); `index` picks the sample sequence.
    Rgb radiance(const Ray &ray, int medium, int hero, uint32_t px, uint32_t py,
                 uint32_t index) const;

  private:
    struct PathResult {
        Rgb L, albedo;
        Vec3f normal;
        float depth = kInfinity;
        uint32_t rays = 0;
    };
    PathResult trace(const CameraRay &cray, int medium, int hero,
                     sampling::SobolSampler &sampler) const;
    const Scene &scene_;
    uint32_t seed_;
    sampling::SamplePattern pattern_;
    int max_depth_;
    bool differentials_;
    /// Some surface is an "interface" bounding a medium: shadow rays in vacuum must find their
    /// hits (to pass through such surfaces) instead of asking only whether anything blocks.
    bool has_interfaces_ = false;
};

}  // namespace tessera
