// Rays, surface interactions and robust spawning of secondary rays.
//
// Ray origins are offset along the geometric normal by the hit point's computed floating-point
// error bound, then rounded away from the surface (pbrt-v4, "Robust Spawned Ray Origins",
// Pharr, Jakob, Humphreys 2023, section 6.8.6). This keeps self-intersection away without a
// scene-scale epsilon, so scenes scaled by 1e-4 or 1e5 render the same picture.
#pragma once

#include <bit>
#include <cstdint>

#include "sampling/vecmath.h"

namespace tessera {

class Light;

/// A ray with origin, direction (not necessarily unit) and parametric extent (0, t_max).
struct Ray {
    Vec3f o, d;
    float t_max = kInfinity;
};

/// Next representable float above/below (pbrt's NextFloatUp/Down); inf and -0 handled.
inline float next_float_up(float v) {
    if (std::isinf(v) && v > 0.f) return v;
    if (v == -0.f) v = 0.f;
    uint32_t ui = std::bit_cast<uint32_t>(v);
    ui = v >= 0 ? ui + 1 : ui - 1;
    return std::bit_cast<float>(ui);
}
inline float next_float_down(float v) {
    if (std::isinf(v) && v < 0.f) return v;
    if (v == 0.f) v = -0.f;
    uint32_t ui = std::bit_cast<uint32_t>(v);
    ui = v > 0 ? ui - 1 : ui + 1;
    return std::bit_cast<float>(ui);
}

/// Conservative bound on the relative error of n floating-point operations (gamma_n, pbrt 6.8).
inline constexpr float gamma_n(int n) {
    constexpr float eps = std::numeric_limits<float>::epsilon() * 0.5f;
    return (n * eps) / (1 - n * eps);
}

/// Offsets `p` (with absolute error bound `p_error`) along geometric normal `n` to the side of
/// `w`, far enough that a ray leaving it cannot re-intersect the surface it started on.
inline Vec3f offset_ray_origin(Vec3f p, Vec3f p_error, Vec3f n, Vec3f w) {
    float d = dot(abs(n), p_error);
    Vec3f offset = n * d;
    if (dot(w, n) < 0) offset = -offset;
    Vec3f po = p + offset;
    for (int i = 0; i < 3; ++i) {
        if (offset[i] > 0)
            po[i] = next_float_up(po[i]);
        else if (offset[i] < 0)
            po[i] = next_float_down(po[i]);
    }
    return po;
}

/// Everything the integrator needs about a ray-surface hit, in world space.
struct SurfaceInteraction {
    Vec3f p;              ///< hit point
    Vec3f p_error;        ///< absolute floating-point error bound of p, per axis
    Vec3f n;              ///< geometric normal (unit), oriented per pbrt rules (emission side)
    Vec3f ns;             ///< shading normal (unit), on the same side as n
    Vec3f dpdu, dpdv;     ///< surface tangents (anisotropic frames, texture mapping)
    Vec2f uv;             ///< surface parameterisation / texture coordinates
    Vec3f wo;             ///< unit direction toward the ray origin
    float t = 0;          ///< ray parameter of the hit
    int material = -1;    ///< index into Scene::materials (-1: none, "interface")
    /// The shape's media (Scene::media indices, -1 = vacuum). pbrt-v4: where they differ the
    /// surface is a medium transition, and a ray leaving it enters `medium_outside` on the side
    /// of n, `medium_inside` on the other; where they are equal a ray keeps its medium.
    int medium_inside = -1, medium_outside = -1;
    /// Stable id of the shape hit (Geometry::object_material maps it back): one per triangle
    /// mesh, sphere or disk, and one per (instance, prototype shape) pair.
    int32_t object_id = -1;
    const Light *area_light = nullptr;  ///< emitter of this surface, if any
    // Screen-space derivatives for texture filtering (pbrt-v4 Camera::Approximate_dp_dxy).
    Vec3f dpdx, dpdy;
    float dudx = 0, dudy = 0, dvdx = 0, dvdy = 0;

    bool medium_transition() const { return medium_inside != medium_outside; }
    /// The medium a ray leaving in direction w is in, coming from medium `current`.
    int medium_after(Vec3f w, int current) const {
        if (!medium_transition()) return current;
        return dot(w, n) > 0.f ? medium_outside : medium_inside;
    }
    /// Spawns a ray leaving the surface in direction d.
    Ray spawn_ray(Vec3f d) const { return Ray{offset_ray_origin(p, p_error, n, d), d, kInfinity}; }
    /// Origin and end points for a shadow ray toward `p_to` (another surface point or light).
    Ray spawn_ray_to(Vec3f p_to) const {
        Vec3f o = offset_ray_origin(p, p_error, n, p_to - p);
        Vec3f d = p_to - o;
        return Ray{o, d, 1.f - 1e-4f};
    }
};

}  // namespace tessera
