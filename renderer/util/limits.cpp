// Resource limits (see limits.h): the memory budget of this process and the checks made before
// large allocations.
#include "renderer/util/limits.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>

#include "sampling/film.h"

namespace tessera {

namespace {

/// A cgroup v2 "memory.max" value of this process's cgroup, or UINT64_MAX ("max", absent).
uint64_t cgroup_memory_max() {
    std::ifstream cg("/proc/self/cgroup");
    std::string line, path;
    // cgroup v2 has one line "0::/path".
    while (std::getline(cg, line))
        if (line.rfind("0::", 0) == 0) path = line.substr(3);
    if (path.empty()) return UINT64_MAX;
    std::ifstream mm("/sys/fs/cgroup" + path + "/memory.max");
    std::string v;
    if (!(mm >> v) || v == "max") return UINT64_MAX;
    try {
        return std::stoull(v);
    } catch (const std::exception &) {
        return UINT64_MAX;
    }
}

uint64_t rlimit_bytes(int resource) {
    struct rlimit rl {};
    if (getrlimit(resource, &rl) != 0 || rl.rlim_cur == RLIM_INFINITY) return UINT64_MAX;
    return uint64_t(rl.rlim_cur);
}

/// a * b, saturating at UINT64_MAX.
uint64_t mul_sat(uint64_t a, uint64_t b) {
    if (a != 0 && b > UINT64_MAX / a) return UINT64_MAX;
    return a * b;
}

uint64_t add_sat(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }

}  // namespace

uint64_t memory_budget_bytes() {
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    uint64_t budget = pages > 0 && page > 0 ? mul_sat(uint64_t(pages), uint64_t(page)) : UINT64_MAX;
    budget = std::min({budget, rlimit_bytes(RLIMIT_AS), rlimit_bytes(RLIMIT_DATA),
                       cgroup_memory_max()});
    return budget;
}

std::string format_bytes(uint64_t bytes) {
    const char *units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    double v = double(bytes);
    int u = 0;
    while (v >= 1024.0 && u < 6) {
        v /= 1024.0;
        ++u;
    }
    char buf[32];
    if (u == 0)
        std::snprintf(buf, sizeof buf, "%llu B", (unsigned long long)bytes);
    else
        std::snprintf(buf, sizeof buf, v < 10 ? "%.1f %s" : "%.0f %s", v, units[u]);
    return buf;
}

void check_memory(uint64_t bytes, const std::string &what, const FileLoc &loc) {
    uint64_t budget = memory_budget_bytes();
    if (bytes > budget)
        throw SceneError(loc, what + " needs about " + format_bytes(bytes) +
                                  " of memory, more than the " + format_bytes(budget) +
                                  " this process may use");
}

uint64_t film_memory_bytes(uint64_t width, uint64_t height, sampling::AovSet aovs) {
    return mul_sat(mul_sat(width, height),
                   sampling::Film::bytes_per_pixel_for(aovs) + kOutputBytesPerPixel);
}

uint64_t mesh_memory_bytes(uint64_t vertices, uint64_t triangles) {
    // Vertex: position 12, normal 12, uv 8 bytes; triangle: 3 indices 12, light pointer 8,
    // Embree BVH about 32.
    return add_sat(mul_sat(vertices, 32), mul_sat(triangles, 52));
}

void check_film(int64_t width, int64_t height, int64_t spp, const FileLoc &loc,
                const FileLoc &spp_loc, sampling::AovSet aovs) {
    const std::string res = std::to_string(width) + "x" + std::to_string(height);
    if (width <= 0 || height <= 0)
        throw SceneError(loc, "film resolution " + res + ": width and height must be positive");
    if (width > kMaxFilmSide || height > kMaxFilmSide)
        throw SceneError(loc, "film resolution " + res + " is larger than the maximum of " +
                                  std::to_string(kMaxFilmSide) + " pixels a side");
    if (uint64_t(width) * uint64_t(height) > kMaxFilmPixels)
        throw SceneError(loc, "film resolution " + res + " has more than the maximum of " +
                                  std::to_string(kMaxFilmPixels) + " pixels");
    if (spp <= 0) throw SceneError(spp_loc, "pixelsamples must be positive");
    if (spp > kMaxSpp)
        throw SceneError(spp_loc, "pixelsamples " + std::to_string(spp) +
                                      " is larger than the maximum of " +
                                      std::to_string(kMaxSpp));
    check_memory(film_memory_bytes(uint64_t(width), uint64_t(height), aovs), "a film of " + res,
                 loc);
}

void check_mesh(uint64_t vertices, uint64_t triangles, const std::string &what,
                const FileLoc &loc) {
    if (vertices > kMaxMeshVertices)
        throw SceneError(loc, what + ": " + std::to_string(vertices) +
                                  " vertices, more than the maximum of " +
                                  std::to_string(kMaxMeshVertices));
    if (triangles > kMaxMeshTriangles)
        throw SceneError(loc, what + ": " + std::to_string(triangles) +
                                  " triangles, more than the maximum of " +
                                  std::to_string(kMaxMeshTriangles));
    check_memory(mesh_memory_bytes(vertices, triangles),
                 what + " (" + std::to_string(vertices) + " vertices, " +
                     std::to_string(triangles) + " triangles)",
                 loc);
}

void check_image_size(int64_t width, int64_t height, int64_t channels, const std::string &what,
                      const FileLoc &loc) {
    if (width <= 0 || height <= 0 || channels <= 0)
        throw SceneError(loc, what + " is empty (" + std::to_string(width) + "x" +
                                  std::to_string(height) + ", " + std::to_string(channels) +
                                  " channels)");
    uint64_t pixels = uint64_t(width) * uint64_t(height);
    if (pixels > kMaxImagePixels)
        throw SceneError(loc, what + " is " + std::to_string(width) + "x" +
                                  std::to_string(height) + ", more than the maximum of " +
                                  std::to_string(kMaxImagePixels) + " pixels");
}

void check_image(int64_t width, int64_t height, int64_t channels, const std::string &what,
                 const FileLoc &loc) {
    check_image_size(width, height, channels, what, loc);
    const uint64_t pixels = uint64_t(width) * uint64_t(height);
    // Read as float, then converted (RGB floats or a distribution): about 3 copies.
    check_memory(mul_sat(pixels, mul_sat(uint64_t(channels), 12)),
                 what + " (" + std::to_string(width) + "x" + std::to_string(height) + ")", loc);
}

size_t peak_rss_bytes() {
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    return size_t(ru.ru_maxrss) * 1024;
}

}  // namespace tessera
