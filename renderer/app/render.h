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

/// Target refinement of an adaptive render (sched::AdaptiveOptions::refine_target): on only when
/// the sampler asks for it (adaptive:refine=1; the scheduler ignores it without a time or spp
/// budget). Refining without an explicit error starts at kDefaultRefineStartTarget. Other
/// samplers are left as they are.
void apply_refinement(sched::AdaptiveOptions &o, const SamplerSpec &sampler);

/// True when the film of a render with `sampler` must keep prefix snapshots
/// (sampling::Film keep_prefix): an adaptive sampler with prefix-error=1.
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
