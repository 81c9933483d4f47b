// The built-in frame plugins (sampling/pixel_sampler.h). Each file of this folder defines one
// `*_plugin_info()`; sampling/pixel_sampler.cpp lists them in the registry.
#pragma once

#include "sampling/pixel_sampler.h"

namespace tessera::sampling {

/// `fixed`: K samples per pixel (square K on a jittered N x N grid, others stratified LDS).
PluginInfo fixed_plugin_info();

}  // namespace tessera::sampling
