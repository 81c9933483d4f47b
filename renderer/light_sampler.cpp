// Power-proportional light selection (see light_sampler.h).
#include "renderer/light_sampler.h"

namespace tessera {

PowerLightSampler::PowerLightSampler(std::span<const Light *const> lights)
    : lights_(lights.begin(), lights.end()) {
    std::vector<float> power;
    power.reserve(lights_.size());
    for (size_t i = 0; i < lights_.size(); ++i) {
        // Luminance weighs the channels as the eye (and the image's noise) does; a light with a
        // negative or non-finite power gets none (the alias table treats those as 0).
        power.push_back(std::max(0.f, lights_[i]->phi().luminance()));
        index_.emplace(lights_[i], i);
    }
    // The alias table falls back to the uniform choice when every power is zero.
    table_ = sampling::AliasTable(power);
}

std::optional<PowerLightSampler::Sampled> PowerLightSampler::sample(float u,
                                                                    float *u_remapped) const {
    if (lights_.empty())
        return std::nullopt;
    float pmf = 0;
    int i = table_.sample(u, &pmf, u_remapped);
    return Sampled{lights_[size_t(i)], pmf};
}

float PowerLightSampler::pmf(const Light *light) const {
    // A few lights (the common case): a scan beats hashing.
    if (lights_.size() <= kScanLimit) {
        for (size_t i = 0; i < lights_.size(); ++i)
            if (lights_[i] == light) return table_.pmf(i);
        return 0.f;
    }
    auto it = index_.find(light);
    return it == index_.end() ? 0.f : table_.pmf(it->second);
}

std::string PowerLightSampler::describe() const {
    return "PowerLightSampler lights=" + std::to_string(lights_.size());
}

}  // namespace tessera
