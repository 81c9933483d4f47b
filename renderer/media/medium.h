// Participating media (PBRT 4th ed., chapter 11; pbrt-v4 media.h), in RGB.
//
// A medium answers two questions: its coefficients at a point (sample_point: absorption
// sigma_a, scattering sigma_s and emitted radiance Le, per RGB channel, in 1/length) and, along
// a ray, piecewise-constant majorants sigma_maj >= sigma_a + sigma_s (sample_ray: segments of
// the ray where one majorant holds). The volumetric path tracer (renderer/integrators/
// volpath_integrator.h) samples distances against the majorants (delta tracking, null
// scattering; Novak et al. 2014, Miller et al. 2019) and estimates transmittance by ratio
// tracking; sample_t_maj below is the loop both share.
//
// The types are pbrt-v4's (its file-format page and media.cpp are the specification):
//   - homogeneous: constant sigma_a, sigma_s (times "scale"), g, Le (times "Lescale"), or a
//     measured "preset" (Jensen et al. 2001, Narasimhan et al. 2006, in 1/mm);
//   - uniformgrid: a density grid (nx x ny x nz samples at cell centres, trilinear, zero
//     outside) in the box p0..p1 of medium space scaling sigma_a and sigma_s; optional
//     "temperature" (blackbody emission) or "Le" with an "Lescale" grid;
//   - rgbgrid: per-sample RGB sigma_a, sigma_s and Le grids;
//   - cloud: pbrt-v4's procedural cloud (fractal Perlin noise in a box, renderer/util/noise.h);
//   - nanovdb: not available (Debian ships no NanoVDB reader): a warning, and vacuum.
// Grids carry a 16^3 majorant grid (pbrt-v4 MajorantGrid), walked by a 3D DDA, so that sparse
// volumes are not sampled at the densest voxel's rate.
//
// Coordinates: a medium lives in render space; grids are defined in medium space
// (render_from_medium, the CTM at MakeNamedMedium). Rays passed in are in render space with a
// unit direction. All methods are const and thread-safe.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "renderer/input/scene_desc.h"
#include "renderer/shading/phase_function.h"
#include "renderer/util/interaction.h"
#include "renderer/util/random.h"
#include "renderer/util/transform.h"
#include "sampling/vecmath.h"

namespace tessera {

/// The coefficients of a medium at a point, per RGB channel (1/length; Le in radiance).
struct MediumProperties {
    Rgb sigma_a, sigma_s, Le;
};

/// A stretch [t0, t1) of a ray over which sigma_maj bounds sigma_t.
struct MajorantSegment {
    float t0 = 0, t1 = 0;
    Rgb sigma_maj;
};

/// A grid of maxima over a box (pbrt-v4 MajorantGrid): res^3 voxels over [0,1]^3 of the
/// medium's grid space, each the largest density (or sigma_t) of the samples that can reach it.
struct MajorantGrid {
    int res[3] = {16, 16, 16};
    std::vector<float> voxels;
    float at(int x, int y, int z) const { return voxels[size_t(x + res[0] * (y + res[1] * z))]; }
};

/// Walks a ray's majorant segments: one for a homogeneous medium, one per voxel of the
/// majorant grid crossed for a grid medium (a 3D DDA, Amanatides and Woo 1987, as pbrt-v4's
/// DDAMajorantIterator). Plain value; `next` returns false when the ray has left the medium.
class MajorantIterator {
  public:
    /// No segments (the ray misses the medium's bounds).
    MajorantIterator() = default;
    /// A single segment [t0, t1) of majorant sigma_maj (homogeneous media).
    static MajorantIterator single(float t0, float t1, Rgb sigma_maj);
    /// The voxels of `grid` crossed by the ray o + t d in grid space ([0,1]^3) between t0 and
    /// t1; each segment's majorant is sigma_t times the voxel's value.
    static MajorantIterator dda(Vec3f o_grid, Vec3f d_grid, float t0, float t1,
                                const MajorantGrid *grid, Rgb sigma_t);
    bool next(MajorantSegment *seg);

  private:
    enum class Kind : uint8_t { None, Single, Dda } kind_ = Kind::None;
    float t_min_ = 0, t_max_ = 0;
    Rgb sigma_t_;
    const MajorantGrid *grid_ = nullptr;
    float next_crossing_[3] = {0, 0, 0}, delta_t_[3] = {0, 0, 0};
    int step_[3] = {0, 0, 0}, voxel_limit_[3] = {0, 0, 0}, voxel_[3] = {0, 0, 0};
};

class Medium {
  public:
    virtual ~Medium() = default;
    /// The coefficients at render-space point p.
    virtual MediumProperties sample_point(Vec3f p) const = 0;
    /// The majorant segments of the ray o + t d (render space, d unit) for t in [0, t_max).
    virtual MajorantIterator sample_ray(const Ray &ray, float t_max) const = 0;
    /// Whether any point emits (Le > 0 somewhere).
    virtual bool is_emissive() const = 0;
    /// True for a medium whose coefficients are the same everywhere (homogeneous; sigma_t is
    /// then its own majorant): `*mp` is set, and transmittance along a segment is
    /// exp(-sigma_t d) in closed form.
    virtual bool constant_properties(MediumProperties * /*mp*/) const { return false; }
    /// One line for logs: type and main parameters.
    virtual std::string describe() const = 0;
    HgPhaseFunction phase;
    std::string name;
};

/// exp(-d sigma) per channel; one exponential when the three coefficients are equal (grey
/// media: the same bits, a third of the work).
inline Rgb transmittance(Rgb sigma, float d) {
    if (sigma.r == sigma.g && sigma.g == sigma.b) return Rgb(std::exp(-d * sigma.r));
    return exp(-d * sigma);
}

/// pbrt-v4 SampleT_maj: samples distances along `ray` (render space, any direction length) in
/// `medium` up to t_max (in the ray's parameter), exponentially against each segment's
/// majorant in channel `hero`. At every sampled point calls
/// `callback(Vec3f p, const MediumProperties &mp, Rgb sigma_maj, Rgb T_maj)`, where T_maj is
/// the majorant transmittance since the previous point; the callback returns false to stop.
/// The first distance uses `u`, later ones `rng`. Returns the majorant transmittance from the
/// last point to t_max (1 when the callback stopped the walk).
///
/// Unlike pbrt-v4, which draws a new exponential distance in every segment it enters, one
/// optical depth (an Exp(1) variate) is drawn per collision and spent across segments: the
/// same process (the exponential is memoryless), with one logarithm per collision instead of
/// one per majorant voxel crossed.
template <class F>
Rgb sample_t_maj(const Medium &medium, Ray ray, float t_max, float u, Pcg32 &rng, int hero,
                 F &&callback) {
    const float len = length(ray.d);
    t_max *= len;
    ray.d = ray.d / len;
    MajorantIterator it = medium.sample_ray(ray, t_max);
    Rgb T_maj(1.f);
    MajorantSegment seg;
    float tau = -std::log1p(-u);  // optical depth (hero channel) to the next collision
    while (it.next(&seg)) {
        const float s_h = seg.sigma_maj[hero];
        float t_min = seg.t0;
        while (true) {
            float dt = seg.t1 - t_min;
            if (std::isinf(dt)) dt = std::numeric_limits<float>::max();
            if (s_h > 0.f && tau < s_h * dt) {
                const float t = t_min + tau / s_h;
                T_maj *= transmittance(seg.sigma_maj, t - t_min);
                const Vec3f p = ray.o + ray.d * t;
                if (!callback(p, medium.sample_point(p), seg.sigma_maj, T_maj)) return Rgb(1.f);
                T_maj = Rgb(1.f);
                t_min = t;
                tau = -std::log1p(-rng.uniform());
            } else {
                tau -= s_h * dt;
                T_maj *= transmittance(seg.sigma_maj, dt);
                break;
            }
        }
    }
    return T_maj;
}

/// Builds a medium from its MakeNamedMedium description. Throws SceneError (file:line) on bad
/// parameters; warns (and returns nullptr: the medium acts as vacuum) for a "nanovdb" medium,
/// which needs a NanoVDB reader this build does not have.
std::unique_ptr<Medium> make_medium(const MediumDesc &desc);

/// The measured coefficients pbrt-v4 names with "preset" (sigma_a, sigma_s in 1/mm); false for
/// an unknown name.
bool medium_preset(const std::string &name, Rgb *sigma_a, Rgb *sigma_s);

}  // namespace tessera
