// `tessera render`: load a scene, render it progressively on the adaptive tile scheduler, write
// EXR + PNG + stats, checkpoints on request and on Ctrl-C.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>

#include "renderer/app/render_options.h"
#include "renderer/scene/scene.h"
#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"

namespace tessera {

/// The EXR and PNG paths for a requested output name: "x.exr" -> (x.exr, x.png); a name with
/// another extension ("cornell-box.png" from a pbrt Film) keeps its stem.
std::pair<std::string, std::string> output_paths(const std::string &requested);

/// Scheduler options for a scene and a sampler choice (shared by the CLI, tests, benchmarks).
sched::AdaptiveOptions scheduler_options(const Scene &scene, const SamplerSpec &sampler,
                                         uint32_t threads, bool quiet);

/// How a render's budget was given: it decides what the adaptive sampler does with it.
struct RenderBudget {
    bool timed = false;      ///< a time budget (--time; `tessera converge` always)
    bool spp_given = false;  ///< --spp given explicitly (a cap when timed)
};

/// The adaptive sampler's mode for a budget (sched::AdaptiveOptions::metric, error_target,
/// refine_target, spp_budget, max_spp); other samplers are left as they are. `o` comes from
/// scheduler_options (max_spp = the scene's spp).
///  - relMSE metric (the default): an explicit error is the image relMSE to reach (refining
///    only with refine=1). Without one, a time budget refines from kRelMseRefineStart until the
///    time is spent (refine=0 turns it off), with no spp cap unless --spp is given; an spp
///    budget N alone stops at the relMSE of N uniform samples (spp_budget = N), letting the
///    hardest pixels go to refine_spp_ratio x N.
///  - dammertz=1: refinement only when asked for (adaptive:refine=1), from
///    kDefaultRefineStartTarget unless an error is given; the scene's spp caps.
void apply_refinement(sched::AdaptiveOptions &o, const SamplerSpec &sampler,
                      RenderBudget budget = {});

/// True when the film of a render with `sampler` must keep prefix snapshots
/// (sampling::Film keep_prefix): an adaptive sampler with prefix-error=1 (the relMSE metric's
/// default).
bool keeps_prefix(const SamplerSpec &sampler);

/// Scheduler options of a uniform render of `scene` to its spp (render_scene, the references).
sched::AdaptiveOptions uniform_scheduler_options(const Scene &scene, uint32_t threads,
                                                 bool quiet);

/// Renders `scene` into `film` with uniform sampling to the scene's spp (tests, benchmarks);
/// `cancel` may stop it early.
sched::AdaptiveStats render_scene(const Scene &scene, sampling::Film &film, uint32_t threads,
                                  double time_s, bool quiet, const std::atomic<bool> *cancel);

/// Runs the whole `tessera render` command. Throws SceneError on bad input (exit code 2) and
/// std::exception on internal errors (exit code 1).
RenderReport run_render(const RenderOptions &options);

}  // namespace tessera
