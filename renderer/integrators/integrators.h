// The progressive integrators by name (`tessera render --integrator`).
#pragma once

#include <memory>
#include <string>

#include "renderer/scene/scene.h"
#include "sampling/sample_source.h"

namespace tessera {

/// The integrator called `name` ("path" or "whitted") for `scene`, for the progressive
/// samplers (whitted without attribute vectors: they read none). Throws SceneError for an
/// unknown name.
std::unique_ptr<SampleSource> make_integrator(const Scene &scene, const std::string &name,
                                              uint32_t no_specialize = 0);

}  // namespace tessera
