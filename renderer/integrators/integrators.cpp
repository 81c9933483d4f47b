#include "renderer/integrators/integrators.h"

#include "renderer/integrators/path_integrator.h"
#include "renderer/integrators/volpath_integrator.h"
#include "renderer/integrators/whitted_integrator.h"

namespace tessera {

std::unique_ptr<SampleSource> make_path_tracer(const Scene &scene, uint32_t seed, int max_depth,
                                               uint32_t no_specialize) {
    if (scene.features.media) return std::make_unique<VolPathIntegrator>(scene, seed, max_depth);
    return std::make_unique<PathIntegrator>(scene, seed, max_depth, DirectStrategy::Mis,
                                            no_specialize);
}

std::unique_ptr<SampleSource> make_integrator(const Scene &scene, const std::string &name,
                                              uint32_t no_specialize) {
    if (name == "path")
        return make_path_tracer(scene, scene.settings.seed, scene.settings.max_depth,
                                no_specialize);
    if (name == "whitted") {
        WhittedOptions wo;
        wo.max_depth = scene.settings.max_depth;
        wo.seed = scene.settings.seed;
        // The progressive samplers read only radiance (the real-time loop in realtime.cpp asks
        // for what its frame plugin reads).
        wo.attributes = kAttrNone;
        return make_whitted_integrator(scene, wo);
    }
    throw SceneError("--integrator:0: unknown integrator \"" + name + "\" (path, whitted)");
}

}  // namespace tessera
