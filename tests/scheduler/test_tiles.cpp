// Unit tests of the Morton-ordered tile list: coverage and order for many image sizes.
#include <doctest/doctest.h>

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "scheduler/tiles.h"

using namespace tessera::sched;

namespace {

// Independent Morton decode: bit i of x is bit 2i of the code, bit i of y is bit 2i+1.
std::pair<uint32_t, uint32_t> slow_decode(uint64_t code) {
    uint32_t x = 0, y = 0;
    for (int i = 0; i < 32; ++i) {
        x |= uint32_t((code >> (2 * i)) & 1u) << i;
        y |= uint32_t((code >> (2 * i + 1)) & 1u) << i;
    }
    return {x, y};
}

// The tile grid visited along the Z curve of the bounding power-of-two square, skipping the
// codes outside the grid (the definition the scheduler's order must match).
std::vector<std::pair<uint32_t, uint32_t>> reference_order(uint32_t nx, uint32_t ny) {
    uint32_t side = 1;
    while (side < nx || side < ny) side *= 2;
    std::vector<std::pair<uint32_t, uint32_t>> order;
    for (uint64_t code = 0; code < uint64_t(side) * side; ++code) {
        auto [x, y] = slow_decode(code);
        if (x < nx && y < ny) order.emplace_back(x, y);
    }
    return order;
}

void check_tiling(uint32_t w, uint32_t h, uint32_t ts) {
    INFO("image " << w << "x" << h << " tile " << ts);
    std::vector<Tile> tiles = make_morton_tiles(w, h, ts);
    uint32_t nx = (w + ts - 1) / ts, ny = (h + ts - 1) / ts;
    REQUIRE(tiles.size() == size_t(nx) * ny);

    // Every pixel in exactly one tile; tiles inside the image; only edge tiles are partial.
    std::vector<uint8_t> hits(size_t(w) * h, 0);
    for (size_t i = 0; i < tiles.size(); ++i) {
        const Tile &t = tiles[i];
        REQUIRE(t.order == i);
        REQUIRE(t.x0 < t.x1);
        REQUIRE(t.y0 < t.y1);
        REQUIRE(t.x1 <= w);
        REQUIRE(t.y1 <= h);
        REQUIRE(t.x0 == t.tx * ts);
        REQUIRE(t.y0 == t.ty * ts);
        REQUIRE((t.width() == ts || t.x1 == w));
        REQUIRE((t.height() == ts || t.y1 == h));
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x) ++hits[size_t(y) * w + x];
    }
    bool all_once = true;
    for (uint8_t c : hits) all_once = all_once && c == 1;
    CHECK(all_once);

    // Morton order equals the independent enumeration.
    auto ref = reference_order(nx, ny);
    REQUIRE(ref.size() == tiles.size());
    bool same = true;
    for (size_t i = 0; i < tiles.size(); ++i)
        same = same && tiles[i].tx == ref[i].first && tiles[i].ty == ref[i].second;
    CHECK(same);
}

}  // namespace

TEST_CASE("tiles cover every pixel once, in Morton order") {
    const std::pair<uint32_t, uint32_t> sizes[] = {{1, 1},   {1, 1000}, {1000, 1},   {7, 9},
                                                   {8, 8},   {9, 9},    {1920, 1080}, {16, 8},
                                                   {65, 17}, {24, 40}};
    for (auto [w, h] : sizes) check_tiling(w, h, kTileSize);
    check_tiling(9, 9, 1);
    check_tiling(100, 37, 16);
}

TEST_CASE("Morton order of a 4x4 grid by hand") {
    std::vector<Tile> tiles = make_morton_tiles(32, 32);
    const uint32_t expected[16][2] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}, {2, 0}, {3, 0},
                                      {2, 1}, {3, 1}, {0, 2}, {1, 2}, {0, 3}, {1, 3},
                                      {2, 2}, {3, 2}, {2, 3}, {3, 3}};
    REQUIRE(tiles.size() == 16);
    for (int i = 0; i < 16; ++i) {
        CHECK(tiles[i].tx == expected[i][0]);
        CHECK(tiles[i].ty == expected[i][1]);
    }
    // A 3x2 grid walks the 4x4 square's codes and skips those outside (column 3, rows 2-3):
    // (0,0) (1,0) (0,1) (1,1) (2,0) (2,1).
    std::vector<Tile> small = make_morton_tiles(24, 16);
    REQUIRE(small.size() == 6);
    CHECK(small[4].tx == 2);
    CHECK(small[4].ty == 0);
    CHECK(small[5].tx == 2);
    CHECK(small[5].ty == 1);
}

TEST_CASE("morton encode and decode") {
    CHECK(morton_encode_2d(0, 0) == 0);
    CHECK(morton_encode_2d(1, 0) == 1);
    CHECK(morton_encode_2d(0, 1) == 2);
    CHECK(morton_encode_2d(3, 3) == 15);
    CHECK(morton_encode_2d(0xffffffffu, 0) == 0x5555555555555555ull);
    uint32_t s = 1;
    for (int i = 0; i < 1000; ++i) {
        s = s * 1664525u + 1013904223u;
        uint32_t x = s, y = s * 2654435761u;
        uint32_t dy = 0;
        uint32_t dx = morton_decode_2d(morton_encode_2d(x, y), dy);
        REQUIRE(dx == x);
        REQUIRE(dy == y);
        auto [sx, sy] = slow_decode(morton_encode_2d(x, y));
        REQUIRE(sx == x);
        REQUIRE(sy == y);
    }
}

TEST_CASE("empty images and bad tile sizes") {
    CHECK(make_morton_tiles(0, 10).empty());
    CHECK(make_morton_tiles(10, 0).empty());
    CHECK_THROWS(make_morton_tiles(10, 10, 0));
}
