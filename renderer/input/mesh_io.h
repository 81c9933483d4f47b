// Triangle mesh files: PLY, read by Tessera's own reader (renderer/input/ply_reader.h) into plain
// arrays for the scene builder.
//
// pbrt-v4's "plymesh" shape (src/pbrt/util/mesh.cpp, TriQuadMesh::ReadPLY) reads positions,
// optional normals and uvs, triangles and quads, and turns quads into bilinear patches.
// Tessera splits every quad (v0 v1 v2 v3) into the triangles (v0 v1 v2) and (v0 v2 v3) instead,
// which is exact for planar quads and an approximation of pbrt's bilinear patch otherwise.
#pragma once

#include <string>

#include "renderer/input/mesh_data.h"

namespace tessera {

/// Reads a PLY file (ASCII, binary little- or big-endian; PLY specification, see ply_reader.h).
/// A path ending in ".gz" (pbrt-v4-scenes' "mesh.ply.gz") is decompressed into memory first
/// (gzip_io.h), up to a quarter of the memory budget; other files are read whole into memory in
/// one read.
///
/// Reads what pbrt-v4's plymesh reads (TriQuadMesh::ReadPLY), from the elements "vertex" and
/// "face" in whatever order and wherever they are among other elements: positions x/y/z,
/// normals nx/ny/nz (when all three are there), texture coordinates under the first of the
/// names pbrt-v4 accepts (u/v, s/t, texture_u/texture_v, texture_s/texture_t), the face list
/// "vertex_indices" (or "vertex_index") and the per-face scalar "face_indices". Every property
/// may have any PLY scalar type (converted to float, indices to uint32, face_indices to int)
/// and list lengths and indices any integer type; other properties and elements are skipped.
/// Faces with 3 vertices are kept as they are; quads are split into two triangles
/// (v0 v1 v2), (v0 v2 v3); larger polygons are fanned from their first vertex; faces with
/// fewer than 3 vertices are dropped with a warning. Vertices keep the file's order and
/// sharing, and normals are only those the file has.
///
/// Throws SceneError("path:0: message") when the file is missing or cannot be parsed, when it
/// has no faces, when a face references a vertex that does not exist ("face 12: vertex index 7
/// out of range (3 vertices)"), when a count or list length is negative or runs past the end of
/// the file, or when the header declares more than the file can hold or than the limits allow
/// (limits.h; checked before anything is allocated for it). Thread-safe.
MeshData load_ply(const std::string &path);

}  // namespace tessera
