// Triangle mesh files: PLY through assimp 5.2, turned into plain arrays for the scene builder.
//
// pbrt-v4's "plymesh" shape (src/pbrt/util/mesh.cpp, TriQuadMesh::ReadPLY) reads positions,
// optional normals and uvs, triangles and quads, and turns quads into bilinear patches.
// Tessera splits every quad (v0 v1 v2 v3) into the triangles (v0 v1 v2) and (v0 v2 v3) instead,
// which is exact for planar quads and an approximation of pbrt's bilinear patch otherwise.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sampling/vecmath.h"

namespace tessera {

/// An indexed triangle mesh in object space, as read from a file.
struct MeshData {
    std::vector<Vec3f> p;   ///< vertex positions (object space, file units)
    std::vector<Vec3f> n;   ///< per-vertex normals as stored (not normalised); empty if none
    std::vector<Vec2f> uv;  ///< per-vertex texture coordinates; empty if none
    std::vector<uint32_t> indices;  ///< 3 vertex indices per triangle, counter-clockwise as stored
    /// Per-triangle "face_indices" (pbrt's Ptex face ids). Always empty: assimp drops unknown
    /// face properties (see load_ply).
    std::vector<int> face_indices;
    /// Per triangle, the index of the file's face it was cut from (a quad gives two triangles);
    /// empty when every face is a triangle. pbrt-v4 normalises an area light's "power" per
    /// face (a quad is one bilinear patch there).
    std::vector<uint32_t> face_of_triangle;

    /// Number of triangles.
    size_t triangle_count() const { return indices.size() / 3; }
};

/// Reads a PLY file (ASCII, binary little- or big-endian) with assimp. A path ending in ".gz"
/// (pbrt-v4-scenes' "mesh.ply.gz") is decompressed into memory first (gzip_io.h), up to a
/// quarter of the memory budget.
///
/// Reads vertex positions x/y/z, normals nx/ny/nz and texture coordinates under any of the names
/// assimp knows (u/v, s/t, texture_u/texture_v, texture_s/texture_t); other vertex properties
/// are ignored. Faces with 3 vertices are kept as they are; quads are split into two triangles
/// (v0 v1 v2), (v0 v2 v3); larger polygons are fanned from their first vertex. Vertices keep the
/// file's order and sharing: assimp 5.2's PLY importer, run with no post-processing, neither
/// duplicates vertices per face nor triangulates nor generates normals, so this function
/// triangulates itself and only returns normals the file has.
///
/// Throws SceneError("path:0: message") when the file is missing or cannot be parsed, when it
/// has no faces, when a face references a vertex that does not exist, or when the header
/// declares more vertices or faces than the file can hold or than the limits allow (limits.h;
/// checked before assimp allocates anything).
/// Thread-safe (each call uses its own assimp importer).
MeshData load_ply(const std::string &path);

}  // namespace tessera
