// Light selection by power (pbrt-v4's PowerLightSampler, lightsamplers.{h,cpp}), with the
// infinite-extent lights kept apart as pbrt-v4's BVHLightSampler keeps them.
//
// Lights fall into two groups: infinite-extent lights (infinite and distant: LightType
// Infinite and DeltaDirection) and local ones (point, spot, area). Within a group a light is
// chosen with probability proportional to the luminance of its emitted power phi() (Rec.709
// weights), through an alias table: O(1) sampling, O(1) pmf lookup. When both groups have
// power, each group is chosen with probability 1/2 (pbrt-v4 BVHLightSampler: pInfinite =
// |infinite| / (|infinite| + 1) with the BVH counting as one; here the infinite group counts
// as one too). The reason: an infinite light's "power" grows with the square of the scene
// radius, so pure power selection starved small local lights next to a sky -- a sphere light
// of radius 1e-3 and radiance 1e6 above a 200-unit ground plane under a sky of radiance 1 was
// chosen for 5e-5 of the samples, and 64 spp images showed no trace of it
// (tests/renderer/test_numerical_stress_render.cpp). With only one group, selection is purely
// by power. When every light of a group has zero power its choice is uniform. Infinite and
// distant lights report power through the scene radius, so call Light::preprocess() on every
// light before building the sampler.
#pragma once

#include <algorithm>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "renderer/lights/lights.h"
#include "sampling/distribution.h"

namespace tessera {

/// Picks one light per shading point: a group (infinite-extent or local, 1/2 each when both
/// have power), then a light of the group proportionally to power. Immutable after
/// construction; all methods are thread-safe. The lights must outlive the sampler.
class PowerLightSampler {
  public:
    /// A chosen light and the probability of having chosen it.
    struct Sampled {
        const Light *light = nullptr;
        float pmf = 0;
    };

    PowerLightSampler() = default;
    explicit PowerLightSampler(std::span<const Light *const> lights);

    /// Chooses a light for u in [0,1); nullopt when there are no lights. `u_remapped`, if given,
    /// receives a fresh uniform value in [0,1) derived from u.
    std::optional<Sampled> sample(float u, float *u_remapped = nullptr) const;
    /// Probability that sample() returns `light` (0 for a light the sampler does not know).
    float pmf(const Light *light) const;
    /// Number of lights.
    size_t size() const { return lights_.size(); }
    /// One readable line for logs.
    std::string describe() const;

  private:
    static constexpr size_t kScanLimit = 8;  ///< pmf() scans up to this many lights
    std::vector<const Light *> lights_;
    std::vector<float> pmf_;  ///< probability of each light (group choice included)
    /// Per group (0: local, 1: infinite extent): the lights' indices and an alias table over
    /// their powers.
    std::vector<size_t> members_[2];
    sampling::AliasTable table_[2];
    float p_infinite_ = 0;  ///< probability of choosing the infinite-extent group
    std::unordered_map<const Light *, size_t> index_;
};

/// Inline: the path tracer picks a light with it at every vertex.
inline std::optional<PowerLightSampler::Sampled> PowerLightSampler::sample(float u,
                                                                    float *u_remapped) const {
    if (lights_.empty())
        return std::nullopt;
    // Choose the group with u, then reuse the rest of u (rescaled to [0,1)) inside it.
    int g = u < p_infinite_ ? 1 : 0;
    float ug = g == 1 ? u / p_infinite_ : (u - p_infinite_) / (1.f - p_infinite_);
    ug = std::clamp(ug, 0.f, kOneMinusEpsilon);
    float group_pmf = 0;
    int k = table_[g].sample(ug, &group_pmf, u_remapped);
    size_t i = members_[g][size_t(k)];
    return Sampled{lights_[i], pmf_[i]};
}

}  // namespace tessera
