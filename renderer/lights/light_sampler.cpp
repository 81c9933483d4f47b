// Power-proportional light selection (see light_sampler.h).
#include "renderer/lights/light_sampler.h"

#include <algorithm>
#include <cmath>

namespace tessera {

PowerLightSampler::PowerLightSampler(std::span<const Light *const> lights)
    : lights_(lights.begin(), lights.end()) {
    std::vector<float> power[2];
    double total[2] = {0, 0};
    for (size_t i = 0; i < lights_.size(); ++i) {
        const LightType t = lights_[i]->type();
        const int g = t == LightType::Infinite || t == LightType::DeltaDirection ? 1 : 0;
        // Luminance weighs the channels as the eye (and the image's noise) does; a light with a
        // negative or non-finite power gets none (the alias table treats those as 0).
        float phi = lights_[i]->phi().luminance();
        phi = std::isfinite(phi) ? std::max(0.f, phi) : 0.f;
        members_[g].push_back(i);
        power[g].push_back(phi);
        total[g] += phi;
        index_.emplace(lights_[i], i);
    }
    // The alias tables fall back to the uniform choice when every power in them is zero.
    for (int g = 0; g < 2; ++g) table_[g] = sampling::AliasTable(power[g]);
    if (members_[1].empty()) {
        p_infinite_ = 0.f;
    } else if (members_[0].empty()) {
        p_infinite_ = 1.f;
    } else if (total[0] > 0 && total[1] > 0) {
        p_infinite_ = 0.5f;
    } else if (total[0] > 0 || total[1] > 0) {
        p_infinite_ = total[1] > 0 ? 1.f : 0.f;  // never spend samples on a dark group
    } else {
        p_infinite_ = float(members_[1].size()) / float(lights_.size());  // all dark: uniform
    }
    pmf_.assign(lights_.size(), 0.f);
    for (int g = 0; g < 2; ++g) {
        const float pg = g == 1 ? p_infinite_ : 1.f - p_infinite_;
        for (size_t k = 0; k < members_[g].size(); ++k)
            pmf_[members_[g][k]] = pg * table_[g].pmf(k);
    }
}

float PowerLightSampler::pmf(const Light *light) const {
    // A few lights (the common case): a scan beats hashing.
    if (lights_.size() <= kScanLimit) {
        for (size_t i = 0; i < lights_.size(); ++i)
            if (lights_[i] == light) return pmf_[i];
        return 0.f;
    }
    auto it = index_.find(light);
    return it == index_.end() ? 0.f : pmf_[it->second];
}

std::string PowerLightSampler::describe() const {
    return "PowerLightSampler lights=" + std::to_string(lights_.size()) + " (" +
           std::to_string(members_[1].size()) + " infinite-extent, chosen with p=" +
           std::to_string(p_infinite_) + ")";
}

}  // namespace tessera
