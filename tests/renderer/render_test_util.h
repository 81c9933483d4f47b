// Helpers for tests that render small scenes end to end.
#pragma once

#include <string>
#include <vector>

#include "renderer/pbrt_parser.h"
#include "renderer/render.h"
#include "renderer/scene.h"
#include "sampling/film.h"
#include "sampling/image_metrics.h"

namespace tessera::test {

/// Builds a scene from pbrt-v4 text (base dir = the current directory).
inline std::unique_ptr<Scene> scene_from_string(const std::string &text,
                                                const SceneOverrides &ov = {}) {
    return build_scene(parse_pbrt_string(text, "test.pbrt", ""), ov);
}

/// Renders a scene quietly and returns its mean image.
inline sampling::RgbImage render_image(const Scene &scene, uint32_t threads = 0,
                                       sched::AdaptiveStats *stats = nullptr) {
    sampling::Film film(uint32_t(scene.settings.width), uint32_t(scene.settings.height));
    sched::AdaptiveStats s = render_scene(scene, film, threads, 0.0, true, nullptr);
    if (stats) *stats = s;
    return sampling::RgbImage(film.width(), film.height(), film.beauty_rgb());
}

/// Mean of channel c over the image.
inline double image_mean(const sampling::RgbImage &img, int c) {
    double s = 0;
    for (size_t i = 0; i < img.pixel_count(); ++i) s += img.data[i * 3 + size_t(c)];
    return s / double(img.pixel_count());
}

}  // namespace tessera::test
