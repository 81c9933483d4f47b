// Morton-ordered tile list.
#include "scheduler/tiles.h"

#include <algorithm>
#include <cstddef>
#include <stdexcept>

namespace tessera::sched {

std::vector<Tile> make_morton_tiles(uint32_t width, uint32_t height, uint32_t tile_size) {
    if (tile_size == 0) throw std::invalid_argument("make_morton_tiles: tile_size must be >= 1");
    std::vector<Tile> tiles;
    if (width == 0 || height == 0) return tiles;
    uint32_t nx = (width - 1) / tile_size + 1, ny = (height - 1) / tile_size + 1;

    // Sorting the real tiles by their Morton code visits them in the same order as walking the
    // bounding power-of-two grid's codes and skipping those outside, at O(n log n).
    std::vector<uint64_t> codes;
    codes.reserve(size_t(nx) * ny);
    for (uint32_t ty = 0; ty < ny; ++ty)
        for (uint32_t tx = 0; tx < nx; ++tx) codes.push_back(morton_encode_2d(tx, ty));
    std::sort(codes.begin(), codes.end());

    tiles.reserve(codes.size());
    for (uint64_t code : codes) {
        Tile t;
        t.tx = morton_decode_2d(code, t.ty);
        t.x0 = t.tx * tile_size;
        t.y0 = t.ty * tile_size;
        // 64-bit arithmetic so that the last tile of a huge image cannot overflow.
        t.x1 = uint32_t(std::min<uint64_t>(uint64_t(t.x0) + tile_size, width));
        t.y1 = uint32_t(std::min<uint64_t>(uint64_t(t.y0) + tile_size, height));
        t.order = uint32_t(tiles.size());
        tiles.push_back(t);
    }
    return tiles;
}

}  // namespace tessera::sched
