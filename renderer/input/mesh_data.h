// The triangle mesh every mesh reader produces (mesh_io.h, ply_reader.h) for the scene builder.
#pragma once

#include <cstdint>
#include <vector>

#include "sampling/vecmath.h"

namespace tessera {

/// An indexed triangle mesh in object space, as read from a file.
struct MeshData {
    std::vector<Vec3f> p;   ///< vertex positions (object space, file units)
    std::vector<Vec3f> n;   ///< per-vertex normals as stored (not normalised); empty if none
    std::vector<Vec2f> uv;  ///< per-vertex texture coordinates; empty if none
    std::vector<uint32_t> indices;  ///< 3 vertex indices per triangle, counter-clockwise as stored
    /// Per triangle, the "face_indices" value of the face it was cut from (pbrt-v4's per-face
    /// ids, e.g. for Ptex); empty when the file's faces have no such property.
    std::vector<int> face_indices;
    /// Per triangle, the index of the file's face it was cut from (a quad gives two triangles);
    /// empty when every face is a triangle. pbrt-v4 normalises an area light's "power" per
    /// face (a quad is one bilinear patch there).
    std::vector<uint32_t> face_of_triangle;

    /// Number of triangles.
    size_t triangle_count() const { return indices.size() / 3; }
};

}  // namespace tessera
