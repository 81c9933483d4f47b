// The settings of the progressive samplers (`uniform` and `adaptive`, run by the adaptive tile
// scheduler) and their defaults, written once. Everything that has such a setting takes its
// default from kProgressiveDefaults: the plugin registry's entries (sampling/plugins/registry.cpp,
// listed by `tessera samplers`), the parsed sampler choice (renderer/app/render_options.h,
// SamplerSpec), the scheduler's options (scheduler/adaptive_scheduler.h, AdaptiveOptions) and
// the region tree's parameters (sampling/region_tree.h, RegionTreeParams).
#pragma once

#include <cstdint>

namespace tessera::sampling {

/// A progressive sampler's settings (the `--sampler adaptive:key=value` keys).
struct ProgressiveSettings {
    /// adaptive:error: region error (Dammertz e_b; sampling/region_tree.h) below which a region
    /// stops. Chosen with `tessera converge`.
    double error = 0.001;
    /// min-spp: samples per pixel of the uniform first pass. MoonRay's uniform start is 16
    /// samples; fewer shows 8x8 block artefacts.
    uint32_t min_spp = 16;
    /// max-pass-spp: largest pass in samples per pixel (0: passes keep doubling).
    uint32_t max_pass_spp = 64;
    /// adaptive:split-factor: a region splits only while e_b < split_factor x target (the
    /// estimate is then reliable enough to localise the error; Dammertz et al. 2010 use 256).
    double split_factor = 256;
    /// adaptive:min-extent: narrowest region a split may create, pixels. One tile: narrower
    /// leaves chase the noise of single pixels' error estimates (salt-and-pepper sample maps).
    double min_extent = 8;
    /// Starting error target of a refining render (adaptive:refine=1) given no error: loose, so
    /// that the easy regions stop early and the target then falls by refine_factor each time
    /// every region is complete.
    double refine_start_error = 0.01;
    /// The same for the relMSE metric (the `adaptive` default): an image relMSE. Levels above
    /// the film's own error cost one rebuild each, so starting loose costs almost nothing.
    double relmse_refine_start = 1.0;
    /// adaptive:refine-track: refining with the relMSE metric, the target is at most this times
    /// the image's current estimated relMSE (scheduler/adaptive_scheduler.h, "Error metrics");
    /// 0: off. Off by default: at 0.8 it lost 5-13% on the diffuse Cornell box,
    /// material-testball and teapot (a per-pixel estimate of a few dozen samples stops pixels
    /// too early) and won 5-15% on veach-mis-like scenes (scripts/bench_adaptive.py, 2 seeds).
    double refine_track = 0;
    /// adaptive:refine-factor: error target multiplier per refinement, in (0, 1).
    double refine_factor = 0.5;
    /// adaptive:refine-spp-ratio: refining, no pixel above this x the mean spp (0: no cap).
    double refine_spp_ratio = 8;
    /// adaptive:refine-floor-ratio: refining, pixels below the mean spp / this are sampled even
    /// inside completed regions (0: no floor).
    double refine_floor_ratio = 3;
};

/// The defaults: the one place they are written.
inline constexpr ProgressiveSettings kProgressiveDefaults{};

}  // namespace tessera::sampling
