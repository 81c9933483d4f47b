// Square tiles over the image, visited in Morton (Z) order over the tile grid
// (docs/ARCHITECTURE.md, "Adaptive stopping": 8x8 tiles along a Morton curve, any image size).
//
// The tile grid is ceil(w / s) x ceil(h / s) for tile size s; tiles at the right and bottom edge
// are cut to the image. The order is that of the Morton codes of the tile coordinates (x bits at
// even positions, y bits at odd positions), i.e. the Z curve over the bounding power-of-two grid
// with the codes outside the real grid skipped. It is computed by sorting, so grids of any
// aspect ratio cost O(n log n) and not the area of the bounding square.
#pragma once

#include <cstdint>
#include <vector>

namespace tessera::sched {

/// Default tile edge in pixels.
inline constexpr uint32_t kTileSize = 8;

/// One tile: the half-open pixel rectangle [x0, x1) x [y0, y1), its coordinates on the tile
/// grid, and its position in the Morton order.
struct Tile {
    uint32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;  ///< pixel bounds, half open
    uint32_t tx = 0, ty = 0;                  ///< tile-grid coordinates
    uint32_t order = 0;                       ///< index in the Morton-ordered list
    uint32_t width() const { return x1 - x0; }
    uint32_t height() const { return y1 - y0; }
    uint32_t pixel_count() const { return width() * height(); }
};

/// Spreads the 32 bits of v to the even bit positions of a 64-bit value.
inline constexpr uint64_t morton_spread_bits(uint32_t v) {
    uint64_t x = v;
    x = (x | (x << 16)) & 0x0000ffff0000ffffull;
    x = (x | (x << 8)) & 0x00ff00ff00ff00ffull;
    x = (x | (x << 4)) & 0x0f0f0f0f0f0f0f0full;
    x = (x | (x << 2)) & 0x3333333333333333ull;
    x = (x | (x << 1)) & 0x5555555555555555ull;
    return x;
}

/// Gathers the even bits of a 64-bit value into 32 bits (inverse of morton_spread_bits).
inline constexpr uint32_t morton_compact_bits(uint64_t x) {
    x &= 0x5555555555555555ull;
    x = (x | (x >> 1)) & 0x3333333333333333ull;
    x = (x | (x >> 2)) & 0x0f0f0f0f0f0f0f0full;
    x = (x | (x >> 4)) & 0x00ff00ff00ff00ffull;
    x = (x | (x >> 8)) & 0x0000ffff0000ffffull;
    x = (x | (x >> 16)) & 0x00000000ffffffffull;
    return uint32_t(x);
}

/// 2D Morton code: x in the even bits, y in the odd bits.
inline constexpr uint64_t morton_encode_2d(uint32_t x, uint32_t y) {
    return morton_spread_bits(x) | (morton_spread_bits(y) << 1);
}
/// Inverse of morton_encode_2d: returns x, writes y.
inline constexpr uint32_t morton_decode_2d(uint64_t code, uint32_t &y) {
    y = morton_compact_bits(code >> 1);
    return morton_compact_bits(code);
}

/// The tiles covering a width x height image (tile edge `tile_size` >= 1 pixels) in Morton
/// order; empty for an empty image. Every pixel lies in exactly one tile. Thread-safe (pure).
/// Throws std::invalid_argument for tile_size 0.
std::vector<Tile> make_morton_tiles(uint32_t width, uint32_t height,
                                    uint32_t tile_size = kTileSize);

}  // namespace tessera::sched
