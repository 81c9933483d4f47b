// The plugin registry (sampling/pixel_sampler.h, plugin_registry): the progressive samplers,
// whose defaults come from sampling/progressive_settings.h, then the frame plugins of this
// folder.
#include <sstream>
#include <string>
#include <vector>

#include "sampling/pixel_sampler.h"
#include "sampling/plugins/plugins.h"
#include "sampling/progressive_settings.h"

namespace tessera::sampling {

namespace {

std::string number(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

std::vector<PluginInfo> progressive_plugins() {
    constexpr const ProgressiveSettings &d = kProgressiveDefaults;
    std::vector<PluginInfo> out;
    PluginInfo uniform;
    uniform.name = "uniform";
    uniform.kind = PluginKind::Progressive;
    uniform.summary =
        "progressive passes, every pixel to --spp samples (the path tracer's baseline)";
    uniform.params = {
        {"min-spp", double(d.min_spp), 1, 1 << 20, true, "samples per pixel of the first pass"},
        {"max-pass-spp", double(d.max_pass_spp), 0, 1 << 20, true,
         "largest pass in samples per pixel (0: doubling)"},
    };
    out.push_back(uniform);

    PluginInfo adaptive;
    adaptive.name = "adaptive";
    adaptive.kind = PluginKind::Progressive;
    adaptive.summary =
        "MoonRay-style quadrant region trees; stops each region at the per-pixel relMSE "
        "threshold that reaches the budget's image error with the fewest samples (dammertz=1: "
        "Dammertz's region error)";
    adaptive.params = {
        {"error", d.error, 0, 1e6, false,
         "image relMSE to reach (dammertz=1: region error e_b, default " + number(d.error) +
             "); unset: the budget decides (--time: refine, --spp N: the relMSE of N uniform "
             "samples)"},
        {"dammertz", 0, 0, 1, true,
         "1: MoonRay's rule, Dammertz's area-weighted region error and a fixed target"},
        {"min-spp", double(d.min_spp), 1, 1 << 20, true,
         "samples per pixel of the uniform first pass"},
        {"max-pass-spp", double(d.max_pass_spp), 0, 1 << 20, true,
         "largest pass in samples per pixel (0: doubling)"},
        {"split-factor", d.split_factor, 1, 1e9, false,
         "split a region while e_b < split-factor x error"},
        {"min-extent", d.min_extent, 1, 1 << 20, false,
         "narrowest region a split may create, pixels"},
        {"refine", 0, 0, 1, true,
         "when every region is complete before the time/spp budget is spent, lower the error "
         "target and go on (default: on with --time and no error=; starts from relMSE " +
             number(d.relmse_refine_start) + ", dammertz=1: opt-in from " +
             number(d.refine_start_error) + ", unless error= is given)"},
        {"refine-factor", d.refine_factor, 0.01, 0.99, false,
         "error target multiplier per refinement"},
        {"refine-spp-ratio", d.refine_spp_ratio, 0, 1e6, false,
         "refining: no pixel above this x the mean spp (0: no cap)"},
        {"refine-floor-ratio", d.refine_floor_ratio, 0, 1e6, false,
         "refining: pixels below the mean spp / this are sampled anyway (0: no floor)"},
        {"refine-track", d.refine_track, 0, 0.99, false,
         "refining (relMSE): target at most this x the current estimated relMSE (0: off)"},
        {"prefix-error", 0, 0, 1, true,
         "1: pixel error against the mean of the first 2^k samples instead of the half buffer "
         "(tracks the true error of Tessera's Sobol sequences; see README); unset: 1, and with "
         "dammertz=1 exactly when refine=1"},
    };
    out.push_back(adaptive);
    return out;
}

std::vector<PluginInfo> make_registry() {
    std::vector<PluginInfo> out = progressive_plugins();
    out.push_back(fixed_plugin_info());
    out.push_back(jin_plugin_info());
    out.push_back(kim_plugin_info());
    out.push_back(fliptri_plugin_info());
    out.push_back(flipquad_plugin_info());
    out.push_back(suffern_plugin_info());
    return out;
}

}  // namespace

const std::vector<PluginInfo> &plugin_registry() {
    static const std::vector<PluginInfo> registry = make_registry();
    return registry;
}

}  // namespace tessera::sampling
