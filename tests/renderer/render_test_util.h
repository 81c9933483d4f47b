// Helpers for tests that render small scenes end to end.
#pragma once

#include <string>
#include <vector>

#include "renderer/integrators/path_integrator.h"
#include "renderer/input/pbrt_parser.h"
#include "renderer/app/render.h"
#include "renderer/scene/scene.h"
#include "sampling/film.h"
#include "sampling/image_metrics.h"
#include "scheduler/adaptive_scheduler.h"

namespace tessera::test {

/// Builds a scene from pbrt-v4 text (base dir = the current directory).
inline std::unique_ptr<Scene> scene_from_string(const std::string &text,
                                                const SceneOverrides &ov = {}) {
    return build_scene(parse_pbrt_string(text, "test.pbrt", ""), ov);
}

/// pbrt-v4 text of a tiny scene's first part: camera at z = -3 looking at the origin, a
/// w x h film, and a 1x1 quad area light (L = 4) at y = 1, facing down. Tests append the rest.
inline std::string tiny_lit_scene_header(int w, int h) {
    return "LookAt 0 0 -3  0 0 0  0 1 0\n"
           "Camera \"perspective\" \"float fov\" [ 45 ]\n"
           "Film \"rgb\" \"integer xresolution\" [ " + std::to_string(w) +
           " ] \"integer yresolution\" [ " + std::to_string(h) + " ]\n"
           "Sampler \"zsobol\" \"integer pixelsamples\" [ 4 ]\n"
           "WorldBegin\n"
           "AttributeBegin\n"
           "  AreaLightSource \"diffuse\" \"rgb L\" [ 4 4 4 ]\n"
           "  Shape \"trianglemesh\"\n"
           "      \"point3 P\" [ -0.5 1 -0.5  0.5 1 -0.5  0.5 1 0.5  -0.5 1 0.5 ]\n"
           "      \"integer indices\" [ 0 1 2  0 2 3 ]\n"
           "AttributeEnd\n";
}

/// Renders a scene quietly and returns its mean image.
inline sampling::RgbImage render_image(const Scene &scene, uint32_t threads = 0,
                                       sched::AdaptiveStats *stats = nullptr) {
    sampling::Film film(uint32_t(scene.settings.width), uint32_t(scene.settings.height));
    sched::AdaptiveStats s = render_scene(scene, film, threads, 0.0, true, nullptr);
    if (stats) *stats = s;
    return sampling::RgbImage(film.width(), film.height(), film.beauty_rgb());
}

/// Renders a scene with the path tracer and one direct-lighting strategy (uniform sampling,
/// the given seed): light-only, BSDF-only and MIS renders must agree within noise.
inline sampling::RgbImage render_with_strategy(const Scene &scene, DirectStrategy strategy,
                                               uint32_t seed) {
    PathIntegrator integ(scene, seed, scene.settings.max_depth, strategy);
    sampling::Film film(uint32_t(scene.settings.width), uint32_t(scene.settings.height));
    SamplerSpec uniform;
    uniform.name = "uniform";
    sched::AdaptiveOptions so = scheduler_options(scene, uniform, 0, true);
    so.seed = seed;
    sched::AdaptiveScheduler(integ, film, so).render();
    return sampling::RgbImage(film.width(), film.height(), film.beauty_rgb());
}

/// Mean of channel c over the image.
inline double image_mean(const sampling::RgbImage &img, int c) {
    double s = 0;
    for (size_t i = 0; i < img.pixel_count(); ++i) s += img.data[i * 3 + size_t(c)];
    return s / double(img.pixel_count());
}

}  // namespace tessera::test
