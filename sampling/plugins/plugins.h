// The built-in frame plugins (sampling/pixel_sampler.h). Each file of this folder defines one
// `*_plugin_info()`; sampling/plugins/registry.cpp lists them in the registry.
#pragma once

#include "sampling/pixel_sampler.h"

namespace tessera::sampling {

/// `fixed`: K samples per pixel (square K on a jittered N x N grid, others stratified LDS).
PluginInfo fixed_plugin_info();
/// `jin`: selective and adaptive supersampling (Jin et al. 2009).
PluginInfo jin_plugin_info();
/// `kim`: adaptive undersampling with post-correction (Kim et al. 2013).
PluginInfo kim_plugin_info();
/// `fliptri` and `flipquad`: low-cost adaptive anti-aliasing (Shevtsov et al.).
PluginInfo fliptri_plugin_info();
PluginInfo flipquad_plugin_info();
/// `suffern`: recursive adaptive supersampling on a shared corner lattice (Suffern).
PluginInfo suffern_plugin_info();

}  // namespace tessera::sampling
