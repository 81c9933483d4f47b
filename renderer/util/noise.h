// pbrt-v4's procedural noise (src/pbrt/util/noise.cpp): Perlin's improved noise with pbrt's
// gradient set, fractional Brownian motion and turbulence, band-limited by the texture
// footprint. Computed float for float in pbrt-v4's order of operations, so that the "fbm",
// "wrinkled", "windy", "marble" and "dots" textures give pbrt-v4's values.
#pragma once

#include "sampling/vecmath.h"

namespace tessera {

/// Perlin noise at (x, y, z), in about [-1, 1]; 0 at every lattice point. pbrt-v4's defaults
/// put two-argument and one-argument calls at y, z = 0.5.
float perlin_noise(float x, float y = 0.5f, float z = 0.5f);
inline float perlin_noise(Vec3f p) {
    return perlin_noise(p.x, p.y, p.z);
}

/// The gradient of perlin_noise by forward differences of 0.01 (pbrt-v4 DNoise).
Vec3f perlin_dnoise(Vec3f p);

/// Fractional Brownian motion: octaves of noise at frequencies 1.99^i with weights omega^i,
/// as many as the footprint (dpdx, dpdy, in texture space) resolves, at most max_octaves, the
/// last one faded in (pbrt-v4 FBm).
float fbm(Vec3f p, Vec3f dpdx, Vec3f dpdy, float omega, int max_octaves);

/// fbm() of |noise|, with the octaves the footprint cannot resolve replaced by their average
/// 0.2 (pbrt-v4 Turbulence).
float turbulence(Vec3f p, Vec3f dpdx, Vec3f dpdy, float omega, int max_octaves);

}  // namespace tessera
