// Resource limits for hostile or mistaken input: a scene file must never make Tessera allocate
// more memory than the machine has, recurse without bound, or read forever. Each limit fails
// with a SceneError "file:line: message" (exit code 2) BEFORE the allocation it guards.
//
// The memory check is a sanity bound on single large allocations (the film, a mesh, an image
// read whole), made against the memory this process may use (memory_budget_bytes()); it is not
// an accountant of the process's total use. Estimates are deliberately on the low side (they
// count the data structures Tessera allocates, not allocator overhead or Embree's BVH slack), so
// a check never rejects a scene that would have fit.
#pragma once

#include <cstdint>
#include <string>

#include "renderer/util/error.h"
#include "sampling/aov_set.h"

namespace tessera {

/// Largest film width or height, pixels.
inline constexpr int kMaxFilmSide = 1 << 16;
/// Largest film area, pixels (a 32768x32768 film).
inline constexpr uint64_t kMaxFilmPixels = uint64_t(1) << 30;
/// Largest samples-per-pixel count: sample indices are 32-bit, and the film counts samples in
/// 32-bit unsigned integers.
inline constexpr int kMaxSpp = 1 << 30;
/// Deepest nesting of Include/Import files (a file including itself is reported at once).
inline constexpr int kMaxIncludeDepth = 64;
/// Deepest nesting of AttributeBegin / TransformBegin / ObjectBegin blocks.
inline constexpr int kMaxAttributeNesting = 1 << 16;
/// Most vertices and triangles in one mesh: Embree and Tessera index them with 32-bit integers
/// (primitive ids, vertex indices).
inline constexpr uint64_t kMaxMeshVertices = (uint64_t(1) << 31) - 1;
inline constexpr uint64_t kMaxMeshTriangles = (uint64_t(1) << 31) - 1;
/// Largest image read whole into memory (environment maps, textures being converted), pixels.
inline constexpr uint64_t kMaxImagePixels = uint64_t(1) << 30;
/// Largest text file (scene, include, spectrum) read whole into memory, bytes.
inline constexpr uint64_t kMaxTextFileBytes = uint64_t(1) << 33;

/// Bytes per film pixel a render needs beyond the Film itself: the resolved layers, the EXR
/// interleave buffer, the error image, region-tree tables, the PNG and a checkpoint's words.
inline constexpr uint64_t kOutputBytesPerPixel = 320;

/// Memory this process may use, bytes: the smallest of physical memory, the address-space and
/// data-segment limits (`ulimit -v`, `ulimit -d`) and the cgroup v2 `memory.max`. Thread-safe.
uint64_t memory_budget_bytes();

/// "1.5 GiB", "640 MiB", "12 KiB", "17 B".
std::string format_bytes(uint64_t bytes);

/// Throws SceneError(loc, "<what> needs about X of memory, more than the Y available") when
/// `bytes` exceeds memory_budget_bytes(). `what` names the thing, e.g. "film 100000x100000".
void check_memory(uint64_t bytes, const std::string &what, const FileLoc &loc);

/// Memory a render of a width x height film keeping `aovs` needs (film plus
/// kOutputBytesPerPixel), bytes. The default counts every AOV (an upper bound).
uint64_t film_memory_bytes(uint64_t width, uint64_t height,
                           sampling::AovSet aovs = sampling::AovSet::all());

/// Memory a triangle mesh of `vertices` and `triangles` needs once built (positions, normals,
/// uvs, indices, per-triangle light pointers and Embree's BVH at about 32 bytes a triangle).
uint64_t mesh_memory_bytes(uint64_t vertices, uint64_t triangles);

/// Checks a film resolution and spp against the limits above and the memory budget; `loc`
/// names where the value came from ("--resolution:0" or the Film directive). Throws SceneError.
void check_film(int64_t width, int64_t height, int64_t spp, const FileLoc &loc,
                const FileLoc &spp_loc, sampling::AovSet aovs = sampling::AovSet::all());

/// Checks mesh sizes against kMaxMeshVertices/kMaxMeshTriangles and the memory budget.
/// `what` names the mesh ("trianglemesh", "plymesh \"x.ply\""). Throws SceneError(loc, ...).
void check_mesh(uint64_t vertices, uint64_t triangles, const std::string &what,
                const FileLoc &loc);

/// Checks an image's header: width, height and channels above 0 and at most kMaxImagePixels
/// pixels. `what` names the image ("image \"x.png\""). Throws SceneError(loc, ...).
void check_image_size(int64_t width, int64_t height, int64_t channels, const std::string &what,
                      const FileLoc &loc);

/// Checks an image that is about to be read whole (width x height x channels floats):
/// check_image_size, then the memory budget.
void check_image(int64_t width, int64_t height, int64_t channels, const std::string &what,
                 const FileLoc &loc);

/// Peak resident memory of this process in bytes (Linux getrusage).
size_t peak_rss_bytes();

}  // namespace tessera
