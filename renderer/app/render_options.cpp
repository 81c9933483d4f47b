// The sampler choice of `tessera render --sampler` (render_options.h).
#include "renderer/app/render_options.h"

#include <sstream>

namespace tessera {

std::string SamplerSpec::describe() const {
    if (is_frame()) return plugin.describe();
    std::ostringstream os;
    os << name;
    if (name == "adaptive") {
        // The keys after "adaptive:", comma separated.
        std::ostringstream k;
        // The relMSE metric has no default error (the budget decides): error only when given.
        if (dammertz)
            k << ",dammertz=1,error=" << (error ? *error : kDefaultErrorTarget);
        else if (error)
            k << ",error=" << *error;
        if (min_spp) k << ",min-spp=" << *min_spp;
        k << ",max-pass-spp=" << max_pass_spp << ",split-factor=" << split_factor
          << ",min-extent=" << min_extent;
        // Only when given: checkpoints compare this line, and older ones do not have it.
        if (refine)
            k << ",refine=" << (*refine ? 1 : 0);
        const sampling::ProgressiveSettings &d = sampling::kProgressiveDefaults;  // left out
        if (refine_factor != d.refine_factor) k << ",refine-factor=" << refine_factor;
        if (refine_spp_ratio != d.refine_spp_ratio) k << ",refine-spp-ratio=" << refine_spp_ratio;
        if (refine_floor_ratio != d.refine_floor_ratio)
            k << ",refine-floor-ratio=" << refine_floor_ratio;
        if (refine_track != d.refine_track) k << ",refine-track=" << refine_track;
        // Only when it differs from its default (see prefix_error).
        if (prefix_error != (dammertz ? refine.value_or(false) : true))
            k << ",prefix-error=" << (prefix_error ? 1 : 0);
        os << ":" << k.str().substr(1);
    }
    return os.str();
}

SamplerSpec parse_sampler_spec(const std::string &text) {
    SamplerSpec spec;
    try {
        spec.plugin = sampling::parse_plugin_spec(text);
    } catch (const std::invalid_argument &e) {
        throw SceneError(std::string("--sampler:0: ") + e.what());
    }
    const sampling::PluginParams &p = spec.plugin.params;
    spec.name = spec.plugin.info->name;
    if (spec.is_frame()) return spec;
    if (p.is_set("min-spp")) spec.min_spp = uint32_t(p.get("min-spp"));
    spec.max_pass_spp = uint32_t(p.get("max-pass-spp"));
    if (spec.name == "adaptive") {
        if (p.is_set("error")) spec.error = p.get("error");
        spec.split_factor = p.get("split-factor");
        spec.min_extent = p.get("min-extent");
        if (p.is_set("refine"))
            spec.refine = p.get("refine") != 0;
        spec.refine_factor = p.get("refine-factor");
        spec.refine_spp_ratio = p.get("refine-spp-ratio");
        spec.refine_floor_ratio = p.get("refine-floor-ratio");
        spec.refine_track = p.get("refine-track");
        spec.dammertz = p.get("dammertz") != 0;
        spec.prefix_error = p.is_set("prefix-error") ? p.get("prefix-error") != 0
                            : spec.dammertz           ? spec.refine.value_or(false)
                                                      : true;
    }
    return spec;
}

}  // namespace tessera
