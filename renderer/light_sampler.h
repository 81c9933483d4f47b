// Power-proportional light selection (pbrt-v4's PowerLightSampler, lightsamplers.{h,cpp}).
//
// Each light is chosen with probability proportional to the luminance of its emitted power
// phi() (Rec.709 weights), through an alias table: O(1) sampling, O(1) pmf lookup. When every
// light has zero power the choice is uniform. Infinite and distant lights report power through
// the scene radius, so call Light::preprocess() on every light before building the sampler.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "renderer/lights.h"
#include "sampling/distribution.h"

namespace tessera {

/// Picks one light per shading point, proportionally to power. Immutable after construction;
/// all methods are thread-safe. The lights must outlive the sampler.
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
    sampling::AliasTable table_;
    std::unordered_map<const Light *, size_t> index_;
};

}  // namespace tessera
