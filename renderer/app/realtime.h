// The real-time loop of `tessera render --sampler NAME --frames N [--orbit DEGREES]`: runs a
// frame plugin (sampling/pixel_sampler.h) on the frame scheduler, frame after frame, optionally
// orbiting the camera, and writes the last frame (EXR with the plugin's diagnostic layers, PNG)
// and the frame statistics.
#pragma once

#include <atomic>
#include <string>

#include "renderer/app/render_options.h"

namespace tessera {

/// The camera placement of an orbit by `degrees` about the camera's up axis through the pivot
/// (the point on the view axis closest to `center`, e.g. the scene's bounds centre). Pure.
Transform orbit_world_from_camera(const Transform &world_from_camera, Vec3f center,
                                  double degrees);

/// Renders opt.frames frames of `scene` with the frame plugin `sampler` and the integrator
/// `opt.integrator` (default whitted), orbiting the camera by opt.orbit_deg over the frames
/// (frame k at k * orbit / frames). Writes `exr` (beauty "R,G,B" + "rays" + one layer per
/// diagnostic), `png` (when `display`), and opt.stats_path (frame_ms_median, frame_ms_p95,
/// rays_per_pixel, active_fraction, stages_ms_median: each stage's median over the frames without
/// diagnostics, ...). `cancel` stops between frames and tiles. Fills `rep`.
void run_frames(const RenderOptions &opt, Scene &scene, const SamplerSpec &sampler,
                const std::string &exr, const std::string &png, const DisplayTransform *display,
                const std::atomic<bool> *cancel, RenderReport &rep);

}  // namespace tessera
