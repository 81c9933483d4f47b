// Loop subdivision surfaces for pbrt-v4's "loopsubdiv" shape (Loop 1987, "Smooth Subdivision
// Surfaces Based on Triangles"; pbrt-v4 LoopSubdivide).
#pragma once

#include <cstdint>
#include <vector>

#include "sampling/vecmath.h"

namespace tessera {

/// A subdivided triangle mesh: positions on the limit surface, per-vertex normals, triangles.
struct SubdividedMesh {
    std::vector<Vec3f> p;
    std::vector<Vec3f> n;
    std::vector<uint32_t> indices;
};

/// Subdivides the control mesh (`p`, triangles `indices`) `levels` times with Loop's rules
/// (Warren's beta for interior vertices, the 3/8-1/8 edge rule; boundary edges and vertices use
/// the cubic B-spline rules 1/2-1/2 and 1/8-3/4-1/8), then moves every vertex to its limit
/// position (interior: gamma = 1 / (k + 3 / (8 beta)); boundary: 1/5-3/5-1/5), as pbrt-v4 does.
/// Normals: NOTE: pbrt-v4 evaluates the limit tangents with Loop's tangent masks; here they are
/// the area-weighted average of the final faces' normals (the same surface, a slightly
/// different shading normal). Orientation of the input triangles is kept. Non-manifold edges
/// (more than two faces) are treated as boundaries. Pure function, thread-safe.
SubdividedMesh loop_subdivide(const std::vector<Vec3f> &p, const std::vector<uint32_t> &indices,
                              int levels);

}  // namespace tessera
