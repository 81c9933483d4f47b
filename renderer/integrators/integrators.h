// The progressive integrators by name (`tessera render --integrator`).
#pragma once

#include <memory>
#include <string>

#include "renderer/scene/scene.h"
#include "sampling/sample_source.h"

namespace tessera {

/// Tessera's path tracer for `scene`: the volumetric one (volpath_integrator.h) when the scene
/// has participating media, else the surface path tracer (path_integrator.h; `no_specialize`:
/// the Specialization bits it must not use).
std::unique_ptr<SampleSource> make_path_tracer(const Scene &scene, uint32_t seed, int max_depth,
                                               uint32_t no_specialize = 0);

/// The integrator called `name` ("path": make_path_tracer, or "whitted") for `scene`, for the progressive
/// samplers (whitted without attribute vectors: they read none). Throws SceneError for an
/// unknown name.
std::unique_ptr<SampleSource> make_integrator(const Scene &scene, const std::string &name,
                                              uint32_t no_specialize = 0);

}  // namespace tessera
