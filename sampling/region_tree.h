// Image-space region trees for adaptive stopping (MoonRay, Jeffery 2019, "Global Adaptive
// Sampling Hierarchies in Production Ray Tracing"; error metric of Dammertz et al. 2010, "A
// Hierarchical Automatic Stopping Condition for Monte Carlo Global Illumination").
//
// One tree per image quadrant, rebuilt from scratch after every pass of that quadrant:
//  - pixel error e_p = sum_c |I_c - A_c| / sqrt(I_r + I_g + I_b), I the mean of all samples, A
//    the mean of the half buffer (odd-index samples); a pixel with too few samples for an
//    estimate has infinite error (its region stays open);
//  - region error e_b = (r / N) * sum_{p in b} e_p, r = sqrt(A_b / A_image), N = pixels in b;
//  - a region is complete when e_b < target; otherwise, if e_b < split_factor * target (the
//    estimate is reliable enough to localise the error; Dammertz uses 256), it splits along its
//    longer axis at the floating-point position that divides its error equally, and both halves
//    are built recursively; else it stays one open leaf.
//  - with RegionTreeParams::area_weighted = false (the relMSE metric) the region error is the
//    plain mean of e_p over the region and completion is decided leaf by leaf down to
//    min_extent (see RegionTreeParams);
//  - the tree's root covers the quadrant grown by one tile (clamped to the image), so error at
//    the seams is seen from both sides when regions split; completion (e_b < target, and the
//    unknown check) is judged on the pixels inside the quadrant only (their mean error, at the
//    whole region's scale r), since the margin is sampled by the neighbour's tree and its
//    error may never fall here (a region wholly in the margin is complete); leaf bounds used
//    for scheduling round outward to whole pixels.
//
// Error integrals over floating-point rectangles weight a partially covered pixel by its covered
// fraction (the error is treated as constant over each pixel's unit square). rebuild() builds a
// summed-area table of the error over the grown rectangle once (double precision); the integral
// over any float rectangle is then exact bilinear interpolation of that table at its 4 corners
// (O(1)) and the split search is a binary search over the table's cell (or pixel) boundaries
// (O(log extent)), so a rebuild costs O(grown area) for the table plus O(nodes * log extent).
// In the mean mode (area_weighted = false) max and min pyramids of the per-cell mean error sit
// beside the table: a region whose every cell (or pixel) reads below the target can only have
// complete leaves (a leaf's error is a weighted mean of them), so it becomes one complete leaf
// without being split, and one whose every cell reads above it can only have open leaves over
// the quadrant's pixels, so it stays one open leaf; the pixels sampled are those of the full
// tree.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sampling/progressive_settings.h"

namespace tessera::sampling {

/// Half-open integer pixel rectangle [x0, x1) x [y0, y1).
struct PixelBounds {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    int width() const { return x1 - x0; }
    int height() const { return y1 - y0; }
    long long area() const { return (long long)width() * height(); }
    bool empty() const { return x1 <= x0 || y1 <= y0; }
    bool operator==(const PixelBounds &o) const = default;
};

/// Floating-point rectangle in pixel units (a pixel (x, y) covers [x, x+1) x [y, y+1)).
struct FloatRect {
    double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    /// The smallest pixel rectangle containing this one (bounds rounded outward).
    PixelBounds outward() const;
};

/// Per-pixel error image of a whole film: `error[y * width + x]`, +inf where unknown.
struct ErrorImage {
    int width = 0, height = 0;
    std::vector<float> error;
    float at(int x, int y) const { return error[size_t(y) * size_t(width) + size_t(x)]; }
};

/// Error summed over square cells of `cell` x `cell` pixels (the scheduler's 8x8 tiles) that
/// tile a tree's grown rectangle from its top-left corner; the last column and row of cells may
/// be narrower (cut at the rectangle's edge). The coarse input of RegionTree::rebuild_cells.
struct CellErrorImage {
    int cell = 8;               ///< cell edge in pixels (>= 1)
    int cols = 0, rows = 0;     ///< ceil(grown width / cell) x ceil(grown height / cell)
    std::vector<double> sum;    ///< finite, non-negative pixel errors summed per cell, row-major
    std::vector<uint32_t> unknown;  ///< pixels per cell without an error estimate
};

/// Parameters of the stopping rule.
struct RegionTreeParams {
    double target = 0.01;       ///< region error (dimensionless, see file comment) below
                                ///< which a region is complete
    /// Split only when error < split_factor * target.
    double split_factor = kProgressiveDefaults.split_factor;
    int max_depth = 24;         ///< safety bound on the recursion (root has depth 0)
    /// Pixels; a split never makes a child narrower than this along the split axis, so a
    /// region splits only when its longer extent is >= 2 * min_extent.
    double min_extent = kProgressiveDefaults.min_extent;
    /// true: the region error is Dammertz's e_b (the mean pixel error times r =
    /// sqrt(A_b / A_image)), and a region below the target is a complete leaf. false: the
    /// region error is the mean pixel error over the region (r = 1; for the relMSE metric,
    /// whose per-pixel threshold is the same everywhere, sampling/adaptive_error.h), and a
    /// region below the target still splits while it is wide enough, so that a small region of
    /// high error inside a large calm one is not averaged away; it is complete when all its
    /// leaves are.
    bool area_weighted = true;
    /// Mean mode: a region whose cells all read below (above) the target becomes one complete
    /// (open) leaf without being split (see the file comment). The pixels sampled are the same
    /// either way; false builds the full tree (for tests and benchmarks).
    bool prune_by_range = true;
};

/// A binary tree over one quadrant. Not thread-safe: callers hold the quadrant's writer lock for
/// rebuild() and a reader lock for queries (the const queries never write, so any number of
/// readers may run concurrently).
///
/// Before the first rebuild() every pixel of the quadrant is active (nothing is known yet).
/// Memory: a summed-area table of the grown rectangle is kept between rebuilds (8 bytes per
/// pixel, plus 4 bytes per pixel while some pixel has no error estimate; per cell instead of
/// per pixel after rebuild_cells).
class RegionTree {
  public:
    struct Node {
        FloatRect bounds;         ///< pixel units, inside grown()
        double error = 0;         ///< region error e_b; +inf when some pixel has no estimate
        double own_error = 0;     ///< e_b over the pixels inside the quadrant (decides completion)
        bool complete = false;    ///< leaf: own_error < target; inner node: both children complete
        int child[2] = {-1, -1};  ///< indices into nodes(); -1 for leaves
        bool is_leaf() const { return child[0] < 0; }
    };

    /// An empty tree over an empty quadrant (complete, nothing active).
    RegionTree() = default;
    /// `quadrant`: the pixels this tree schedules; `grown`: the quadrant grown by one tile and
    /// clamped to the image (the root's bounds for error computation); `image_area` in pixels
    /// (of the whole image, for the r factor). Throws std::invalid_argument unless `grown`
    /// contains `quadrant` and image_area > 0.
    RegionTree(PixelBounds quadrant, PixelBounds grown, double image_area);

    /// Rebuilds from scratch from the error image (which covers the whole film; only the
    /// pixels of grown() are read; +inf or NaN = no estimate, negative values count as 0).
    /// Returns the number of nodes. Throws std::invalid_argument if `errors` does not cover
    /// grown() (the tree is then unchanged). Needs the writer lock.
    size_t rebuild(const ErrorImage &errors, const RegionTreeParams &params);

    /// Rebuilds from per-cell error sums over grown() (the scheduler's per-tile sums): the same
    /// tree as rebuild() would build from a pixel error image that is constant inside every
    /// cell, at O(cells) instead of O(pixels) for the table. Inside a cell the error is taken
    /// as uniform, so integrals over float rectangles and split positions interpolate linearly
    /// inside cells; a region touching a cell with an unknown pixel stays open. Throws
    /// std::invalid_argument when the cell grid does not cover grown() (the tree is unchanged).
    size_t rebuild_cells(const CellErrorImage &cells, const RegionTreeParams &params);

    /// True when every leaf is complete (nothing left to sample in this quadrant). False before
    /// the first rebuild unless the quadrant is empty.
    bool complete() const;

    /// Clears `out`, then appends the parts of `tile` (clipped to the quadrant) that lie in
    /// incomplete leaves, as pixel rectangles rounded outward (to whole cells after
    /// rebuild_cells: the error is known per cell only). They may overlap each other where a
    /// split falls inside a pixel (or cell); callers must not sample a pixel twice — use
    /// `pixel_active`, or sample the union). Empty when the tile is inside completed regions.
    /// Allocation-free once `out` has capacity.
    void active_rects(const PixelBounds &tile, std::vector<PixelBounds> &out) const;

    /// True if pixel (x, y) lies in the quadrant and in the outward-rounded bounds of an
    /// incomplete leaf (a pixel only partly covered by an incomplete leaf is active; after
    /// rebuild_cells, every pixel of a cell that an incomplete leaf touches).
    bool pixel_active(int x, int y) const;

    /// The active pixels of a tile of at most 8x8 pixels as a bit mask: bit
    /// (y - tile.y0) * 8 + (x - tile.x0) is set iff pixel_active(x, y). 0 when the tile lies in
    /// completed regions (skip it). The union of active_rects without duplicates, in one
    /// traversal; allocation-free. Tiles larger than 8x8 are truncated to their first 8x8.
    uint64_t active_mask(const PixelBounds &tile) const;

    const std::vector<Node> &nodes() const { return nodes_; }
    const PixelBounds &quadrant() const { return quadrant_; }
    const PixelBounds &grown() const { return grown_; }
    /// The parameters of the last rebuild (the default ones before the first).
    const RegionTreeParams &params() const { return params_; }
    /// Error of the root region (the quadrant's error estimate).
    double root_error() const { return nodes_.empty() ? 0.0 : nodes_[0].error; }
    /// Number of leaves, and of those the incomplete ones (0, 0 before the first rebuild).
    size_t leaf_count() const;
    size_t open_leaf_count() const;
    /// Area in pixels (float bounds) of the incomplete leaves, clipped to the quadrant.
    double open_area() const;
    /// One readable line: quadrant, node and leaf counts, open area, root error.
    std::string describe() const;

  private:
    size_t build_root();
    /// Pixel coordinate -> table coordinate along an axis (cells of cell_ pixels, the last one
    /// possibly narrower): linear inside each cell.
    double table_x(double x) const;
    double table_y(double y) const;
    /// Table coordinate -> pixel coordinate along axis 0 (x) or 1 (y): the inverse of table_x
    /// and table_y inside the grown rectangle.
    double from_table(int axis, double t) const;
    double integral(const FloatRect &r) const;
    bool has_unknown(const FloatRect &r) const;
    double split_position(const FloatRect &r, int axis, double total) const;
    /// Builds the max and min pyramids from level 0 (the per-cell mean error, cols_ x rows_,
    /// already in max_).
    void build_pyramids();
    /// Bounds of the mean error of the cells with positive coverage by `r`: lo <= the least,
    /// hi >= the largest.
    void error_range(const FloatRect &r, double &lo, double &hi) const;
    void build(int node, int depth);
    /// The pixels a region's samples go to: its bounds rounded outward to pixels, and to whole
    /// cells when built from cell sums.
    PixelBounds sample_bounds(const FloatRect &b) const;
    void collect(int node, const PixelBounds &tile, std::vector<PixelBounds> &out) const;
    void collect_mask(int node, const PixelBounds &clip, int ox, int oy, uint64_t &mask) const;
    bool active_at(int node, int x, int y) const;

    PixelBounds quadrant_, grown_;
    double image_area_ = 1;
    std::vector<Node> nodes_;
    bool built_ = false;
    RegionTreeParams params_;
    // Scratch of rebuild(), kept to avoid reallocating: summed-area tables over grown_,
    // (width + 1) x (height + 1), of the finite error and of the count of unknown pixels.
    std::vector<double> sat_;
    std::vector<uint32_t> unknown_sat_;
    int cell_ = 1;                 ///< table cell edge in pixels (1: per-pixel table)
    int cols_ = 0, rows_ = 0;      ///< table cells: (cols_ + 1) x (rows_ + 1) entries
    /// 1 / cell_, and 1 / the width of the last column and row of cells (may be narrower).
    double inv_cell_ = 1, inv_last_x_ = 1, inv_last_y_ = 1;
    bool any_unknown_ = false;
    // Mean mode only: the max and min pyramids of the per-cell (per-pixel for rebuild()) mean
    // error, level 0 first, each level halving both extents (rounding up); level_[k] is the
    // offset, level_cols_[k] and level_rows_[k] the extent of level k.
    std::vector<double> max_, min_;
    std::vector<size_t> level_;
    std::vector<int> level_cols_, level_rows_;
};

}  // namespace tessera::sampling
