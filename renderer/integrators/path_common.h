// What the two path tracers (path_integrator.h, volpath_integrator.h) share: the camera ray of a
// camera sample, the ray differentials' footprint and texture context at a hit, Russian
// roulette, and the film's treatment of a path's radiance.
#pragma once

#include <algorithm>
#include <cmath>

#include "renderer/camera/camera.h"
#include "renderer/scene/scene.h"
#include "renderer/shading/texture.h"
#include "renderer/util/interaction.h"
#include "sampling/sample_source.h"
#include "sampling/sequence.h"

namespace tessera {

/// Screen-space derivatives of p and (u, v) at a hit (pbrt-v4 SurfaceInteraction::
/// ComputeDifferentials): from the camera ray's differentials at the first hit, else from the
/// camera's approximation.
inline void compute_differentials(SurfaceInteraction &si, const CameraRay *cray,
                                  const PerspectiveCamera &camera, int spp) {
    Vec3f n = si.n;
    bool done = false;
    if (cray && cray->has_differentials) {
        float dx = dot(n, cray->rx_d), dy = dot(n, cray->ry_d);
        if (dx != 0.f && dy != 0.f) {
            float d = -dot(n, si.p);
            float tx = (-dot(n, cray->rx_o) - d) / dx;
            float ty = (-dot(n, cray->ry_o) - d) / dy;
            if (std::isfinite(tx) && std::isfinite(ty)) {
                float scale = std::max(0.125f, 1.f / std::sqrt(float(std::max(spp, 1))));
                si.dpdx = (cray->rx_o + cray->rx_d * tx - si.p) * scale;
                si.dpdy = (cray->ry_o + cray->ry_d * ty - si.p) * scale;
                done = true;
            }
        }
    }
    if (!done) camera.approximate_dp_dxy(si.p, n, spp, &si.dpdx, &si.dpdy);
    float ata00 = dot(si.dpdu, si.dpdu), ata01 = dot(si.dpdu, si.dpdv),
          ata11 = dot(si.dpdv, si.dpdv);
    float inv_det = 1.f / (ata00 * ata11 - ata01 * ata01);
    if (!std::isfinite(inv_det)) inv_det = 0.f;
    float atb0x = dot(si.dpdu, si.dpdx), atb1x = dot(si.dpdv, si.dpdx);
    float atb0y = dot(si.dpdu, si.dpdy), atb1y = dot(si.dpdv, si.dpdy);
    auto c = [](float v) { return std::isfinite(v) ? clamp(v, -1e8f, 1e8f) : 0.f; };
    si.dudx = c((ata11 * atb0x - ata01 * atb1x) * inv_det);
    si.dvdx = c((ata00 * atb1x - ata01 * atb0x) * inv_det);
    si.dudy = c((ata11 * atb0y - ata01 * atb1y) * inv_det);
    si.dvdy = c((ata00 * atb1y - ata01 * atb0y) * inv_det);
}

inline TextureEvalContext texture_context(const SurfaceInteraction &si) {
    TextureEvalContext tc;
    tc.p = si.p;
    tc.dpdx = si.dpdx;
    tc.dpdy = si.dpdy;
    tc.n = si.n;
    tc.uv = si.uv;
    tc.dudx = si.dudx;
    tc.dudy = si.dudy;
    tc.dvdx = si.dvdx;
    tc.dvdy = si.dvdy;
    return tc;
}

/// The camera ray of `cs`, leaving `sampler` at the path's first dimension. Filter importance
/// sampling: the film offset (fx, fy) in [0,1)^2 is warped through the pixel filter; the sample
/// stays in pixel (px, py) with weight 1 (+-w for a filter with negative lobes, carried by the
/// camera ray's weight).
inline CameraRay generate_camera_ray(const Scene &scene, const CameraSample &cs,
                                     sampling::SobolSampler &sampler, bool differentials) {
    sampler.start_pixel_sample(cs.px, cs.py, cs.index);
    float filter_weight = 1.f;
    Vec2f offset = scene.filter.sample({cs.fx, cs.fy}, &filter_weight);
    Vec2f p_raster{float(cs.px) + 0.5f + offset.x, float(cs.py) + 0.5f + offset.y};
    // A pinhole ignores the lens sample: skip its dimensions rather than hash them.
    Vec2f u_lens{0.5f, 0.5f};
    if (scene.camera->uses_lens_sample())
        u_lens = sampler.get_2d();
    else
        sampler.skip(2);
    // Only texture filtering reads the ray differentials.
    CameraRay r = scene.camera->generate_ray(p_raster, u_lens, differentials);
    r.weight *= filter_weight;
    return r;
}

/// Russian roulette's termination probability for a path whose throughput (beta times eta^2,
/// pbrt-v4's roulette quantity) has largest component t < 1, after the second bounce:
/// 1 - sqrt(t), i.e. the continuation probability sqrt(t) of Cycles
/// (path_state_continuation_probability) where pbrt-v4 continues with probability t. Either is
/// unbiased (a survivor's throughput is divided by its continuation probability); sqrt(t) lets
/// paths of moderate throughput live longer, which costs time per sample and usually saves
/// more in variance: over the examples and ../shared/scenes the time to equal error improved
/// by a median 1.085-1.12x, a few scenes (examples/cornell-box, classroom) lost up to 3%
/// (README, "Russian roulette"). The path tracer's packet kernel computes the same value
/// lane-wise.
inline float roulette_termination(float t) { return std::max(0.f, 1.f - std::sqrt(t)); }

/// A path's radiance as the film takes it (pbrt-v4 RGBFilm): the sensor scale, the
/// maxcomponentvalue clamp, then the white balance.
inline Rgb film_radiance(const RenderSettings &settings, Rgb L) {
    L *= settings.image_scale;
    float m = L.max_value();
    if (m > settings.max_component) L *= settings.max_component / m;
    return settings.balance(L);
}

}  // namespace tessera
