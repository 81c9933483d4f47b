// Region trees for adaptive stopping: summed-area table of the error, recursive build with
// floating-point splits, and the tile queries of the scheduler (see region_tree.h).
#include "sampling/region_tree.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace tessera::sampling {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double extent(const FloatRect &r, int axis) {
    return axis == 0 ? r.x1 - r.x0 : r.y1 - r.y0;
}
double area(const FloatRect &r) {
    return (r.x1 - r.x0) * (r.y1 - r.y0);
}

PixelBounds intersect(const PixelBounds &a, const PixelBounds &b) {
    return {std::max(a.x0, b.x0), std::max(a.y0, b.y0), std::min(a.x1, b.x1), std::min(a.y1, b.y1)};
}

bool contains(const PixelBounds &outer, const PixelBounds &inner) {
    return inner.x0 >= outer.x0 && inner.y0 >= outer.y0 && inner.x1 <= outer.x1 &&
           inner.y1 <= outer.y1;
}

}  // namespace

PixelBounds FloatRect::outward() const {
    return {int(std::floor(x0)), int(std::floor(y0)), int(std::ceil(x1)), int(std::ceil(y1))};
}

RegionTree::RegionTree(PixelBounds quadrant, PixelBounds grown, double image_area)
    : quadrant_(quadrant), grown_(grown), image_area_(image_area) {
    if (!(image_area > 0))
        throw std::invalid_argument("RegionTree: image_area must be > 0");
    if (!quadrant.empty() && !contains(grown, quadrant))
        throw std::invalid_argument("RegionTree: the grown rectangle must contain the quadrant");
}

// ---------------------------------------------------------------------------------------------
// Integrals over float rectangles.
//
// With the error constant over each pixel's unit square, the integral from the grown
// rectangle's corner to (X, Y), F(X, Y), is bilinear inside each pixel and equals the summed-area
// table S at integer corners; hence F is exactly the bilinear interpolation of S. The integral
// over [x0, x1) x [y0, y1) is F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0), which weights every
// partially covered pixel by its covered fraction.
// ---------------------------------------------------------------------------------------------

namespace {

/// Bilinear interpolation of a (w + 1) x (h + 1) table at local coordinates (u, v) in
/// [0, w] x [0, h].
template <class T>
[[gnu::always_inline]] inline double interp(const std::vector<T> &t, int w, int h, double u, double v) {
    u = std::clamp(u, 0.0, double(w));
    v = std::clamp(v, 0.0, double(h));
    int i = std::min(int(u), w - 1), j = std::min(int(v), h - 1);
    double a = u - i, b = v - j;
    size_t stride = size_t(w) + 1, k = size_t(j) * stride + size_t(i);
    double s00 = double(t[k]), s10 = double(t[k + 1]);
    double s01 = double(t[k + stride]), s11 = double(t[k + stride + 1]);
    return (1 - b) * (s00 + a * (s10 - s00)) + b * (s01 + a * (s11 - s01));
}

}  // namespace

namespace {
/// Pixel offset d along an axis of `span` pixels -> table coordinate, with n cells of `cell`
/// pixels (1 / cell = inv), the last one `span - (n - 1) * cell` wide (1 / width = inv_last).
inline double to_table(double d, double span, int n, int cell, double inv, double inv_last) {
    const double dc = std::clamp(d, 0.0, span);
    const int i = std::min(int(dc * inv), n - 1);
    return i + (dc - double(i) * cell) * (i < n - 1 ? inv : inv_last);
}
}  // namespace

double RegionTree::table_x(double x) const {
    const double d = x - grown_.x0;
    if (cell_ == 1) return d;
    return to_table(d, double(grown_.width()), cols_, cell_, inv_cell_, inv_last_x_);
}

double RegionTree::table_y(double y) const {
    const double d = y - grown_.y0;
    if (cell_ == 1) return d;
    return to_table(d, double(grown_.height()), rows_, cell_, inv_cell_, inv_last_y_);
}

double RegionTree::integral(const FloatRect &r) const {
    const double u0 = table_x(r.x0), u1 = table_x(r.x1);
    const double v0 = table_y(r.y0), v1 = table_y(r.y1);
    double s = interp(sat_, cols_, rows_, u1, v1) - interp(sat_, cols_, rows_, u0, v1) -
               interp(sat_, cols_, rows_, u1, v0) + interp(sat_, cols_, rows_, u0, v0);
    // Cancellation can leave a tiny negative value for a zero-error region.
    return std::max(s, 0.0);
}

bool RegionTree::has_unknown(const FloatRect &r) const {
    if (!any_unknown_)
        return false;
    // The pixels with positive coverage are exactly those of the outward-rounded rectangle; the
    // cells with positive coverage are those that contain one of them.
    PixelBounds p = intersect(r.outward(), grown_);
    if (p.empty())
        return false;
    const int i0 = (p.x0 - grown_.x0) / cell_, j0 = (p.y0 - grown_.y0) / cell_;
    const int i1 = std::min(cols_, (p.x1 - grown_.x0 + cell_ - 1) / cell_);
    const int j1 = std::min(rows_, (p.y1 - grown_.y0 + cell_ - 1) / cell_);
    size_t stride = size_t(cols_) + 1;
    auto at = [&](int i, int j) { return int64_t(unknown_sat_[size_t(j) * stride + size_t(i)]); };
    return at(i1, j1) - at(i0, j1) - at(i1, j0) + at(i0, j0) > 0;
}

double RegionTree::from_table(int axis, double t) const {
    const int origin = axis == 0 ? grown_.x0 : grown_.y0;
    if (cell_ == 1)
        return origin + t;
    const int n = axis == 0 ? cols_ : rows_;
    const double span = double(axis == 0 ? grown_.width() : grown_.height());
    const int i = std::clamp(int(t), 0, n - 1);
    const double start = double(i) * cell_;
    return origin + start + (t - i) * std::min(double(cell_), span - start);
}

// The split position along `axis` where the error integral of `r` is halved. The search runs in
// table coordinates, where the table's entries sit at integer positions (cell boundaries; pixel
// boundaries for a per-pixel table) and the integral is bilinear between them: H(t), the
// integral from r's lower bound to t, is nondecreasing and linear between boundaries, so a
// binary search over the boundaries inside r finds the cell where H crosses total / 2 and
// linear interpolation inside it gives the exact position, mapped back to pixels (linear inside
// a cell). Where H is flat at total / 2 (no error between two features) the split goes to the
// middle of the flat interval, so it does not hug one side. The result is clamped so that both
// children are at least min_extent wide.
double RegionTree::split_position(const FloatRect &r, int axis, double total) const {
    const double half = 0.5 * total;
    const double lo = axis == 0 ? table_x(r.x0) : table_y(r.y0);
    const double hi = axis == 0 ? table_x(r.x1) : table_y(r.y1);
    const double q0 = axis == 0 ? table_y(r.y0) : table_x(r.x0);
    const double q1 = axis == 0 ? table_y(r.y1) : table_x(r.x1);
    const int n = axis == 0 ? cols_ : rows_, m = axis == 0 ? rows_ : cols_;
    const size_t stride = size_t(cols_) + 1;
    // The across-axis interpolation (rows j0, j0 + 1 at weight f0; j1, j1 + 1 at f1) is the same
    // for every position along the axis.
    auto across = [m](double q, int &j, double &f) {
        q = std::clamp(q, 0.0, double(m));
        j = std::min(int(q), m - 1);
        f = q - j;
    };
    int j0, j1;
    double f0, f1;
    across(q0, j0, f0);
    across(q1, j1, f1);
    const double *t = sat_.data();
    const size_t step = axis == 0 ? stride : 1, along = axis == 0 ? 1 : stride;
    // The strip integral from the table's origin to boundary k along the axis, between q0 and q1.
    auto strip_at = [&](int k) {
        const double *c = t + size_t(k) * along;
        const double *r0 = c + size_t(j0) * step, *r1 = c + size_t(j1) * step;
        return (r1[0] + f1 * (r1[step] - r1[0])) - (r0[0] + f0 * (r0[step] - r0[0]));
    };
    auto strip = [&](double u) {
        u = std::clamp(u, 0.0, double(n));
        const int k = std::min(int(u), n - 1);
        const double s0 = strip_at(k);
        return s0 + (u - k) * (strip_at(k + 1) - s0);
    };
    const double base = strip(lo);
    auto cum = [&](int k) { return strip_at(k) - base; };
    // Boundaries strictly inside (lo, hi): k0 .. k1.
    const int k0 = int(std::floor(lo)) + 1, k1 = int(std::ceil(hi)) - 1;

    // First boundary with cum >= half (k1 + 1 if none): the crossing lies in [prev, next].
    int a = k0, b = k1 + 1;
    while (a < b) {
        int mid = a + (b - a) / 2;
        if (cum(mid) >= half)
            b = mid;
        else
            a = mid + 1;
    }
    double next = a <= k1 ? double(a) : hi, prev = a > k0 ? double(a - 1) : lo;
    double c_prev = a > k0 ? cum(a - 1) : 0.0, c_next = a <= k1 ? cum(a) : total;
    double first =
        c_next > c_prev ? prev + (half - c_prev) / (c_next - c_prev) * (next - prev) : prev;

    // Last boundary with cum <= half (k0 - 1 if none): the crossing lies in [prev2, next2].
    a = k0 - 1;
    b = k1;
    while (a < b) {
        int mid = a + (b - a + 1) / 2;
        if (cum(mid) <= half)
            a = mid;
        else
            b = mid - 1;
    }
    double prev2 = a >= k0 ? double(a) : lo, next2 = a < k1 ? double(a + 1) : hi;
    double c_prev2 = a >= k0 ? cum(a) : 0.0, c_next2 = a < k1 ? cum(a + 1) : total;
    double last = c_next2 > c_prev2
                      ? prev2 + (half - c_prev2) / (c_next2 - c_prev2) * (next2 - prev2)
                      : next2;

    // Both crossings lie inside one cell each, where the map to pixels is linear.
    const double plo = axis == 0 ? r.x0 : r.y0, phi = axis == 0 ? r.x1 : r.y1;
    const double x = 0.5 * (std::clamp(from_table(axis, std::clamp(first, lo, hi)), plo, phi) +
                            std::clamp(from_table(axis, std::clamp(last, lo, hi)), plo, phi));
    return std::clamp(x, plo + params_.min_extent, phi - params_.min_extent);
}

// ---------------------------------------------------------------------------------------------
// Rebuild.
// ---------------------------------------------------------------------------------------------

size_t RegionTree::rebuild(const ErrorImage &errors, const RegionTreeParams &params) {
    // Validate before touching the tree: a rejected call leaves it as it was.
    if (!grown_.empty() &&
        (grown_.x0 < 0 || grown_.y0 < 0 || grown_.x1 > errors.width || grown_.y1 > errors.height ||
         errors.error.size() < size_t(errors.width) * size_t(errors.height)))
        throw std::invalid_argument(
            "RegionTree::rebuild: the error image does not cover the grown rectangle");
    params_ = params;
    nodes_.clear();
    built_ = true;
    any_unknown_ = false;
    cell_ = 1;
    cols_ = grown_.width();
    rows_ = grown_.height();
    if (grown_.empty())
        return 0;

    // Summed-area table of the finite error over the grown rectangle, one pass.
    const int w = grown_.width(), h = grown_.height();
    const size_t stride = size_t(w) + 1;
    sat_.resize(stride * (size_t(h) + 1));
    std::fill(sat_.begin(), sat_.begin() + ptrdiff_t(stride), 0.0);
    const float kInfF = std::numeric_limits<float>::infinity();
    // Row prefix sums are serial chains of dependent additions (FP add latency, ~4 cycles
    // each); running four rows side by side keeps four independent chains in flight, which
    // makes the table ~3x faster to build. NaN and +inf fail (e < inf): no estimate; negative
    // values count as zero.
    // Branch-free: the flag is or-ed, the value selected.
    unsigned bad = 0;
    auto clean = [&](float e) {
        bad |= unsigned(!(e < kInfF));
        return (e > 0 && e < kInfF) ? double(e) : 0.0;
    };
    auto src = [&](int j) {
        return &errors.error[size_t(grown_.y0 + j) * size_t(errors.width) + size_t(grown_.x0)];
    };
    int j = 0;
    for (; j + 4 <= h; j += 4) {
        const float *r0 = src(j), *r1 = src(j + 1), *r2 = src(j + 2), *r3 = src(j + 3);
        const double *above = &sat_[size_t(j) * stride];
        double *o0 = &sat_[size_t(j + 1) * stride], *o1 = o0 + stride, *o2 = o1 + stride,
               *o3 = o2 + stride;
        o0[0] = o1[0] = o2[0] = o3[0] = 0;
        double a0 = 0, a1 = 0, a2 = 0, a3 = 0;
        for (int i = 0; i < w; ++i) {
            a0 += clean(r0[i]);
            a1 += clean(r1[i]);
            a2 += clean(r2[i]);
            a3 += clean(r3[i]);
            const double s0 = above[i + 1] + a0, s1 = s0 + a1, s2 = s1 + a2;
            o0[i + 1] = s0;
            o1[i + 1] = s1;
            o2[i + 1] = s2;
            o3[i + 1] = s2 + a3;
        }
    }
    for (; j < h; ++j) {
        const float *row = src(j);
        const double *above = &sat_[size_t(j) * stride];
        double *out = &sat_[size_t(j + 1) * stride];
        double acc = 0;
        out[0] = 0;
        for (int i = 0; i < w; ++i) {
            acc += clean(row[i]);
            out[i + 1] = above[i + 1] + acc;
        }
    }
    if (!params.area_weighted && params.prune_by_range) {
        max_.resize(size_t(w) * size_t(h));
        for (j = 0; j < h; ++j) {
            const float *row = src(j);
            double *out = &max_[size_t(j) * size_t(w)];
            for (int i = 0; i < w; ++i) out[i] = clean(row[i]);
        }
        build_pyramids();
    }
    // The count table is built only while some pixel lacks an estimate (early passes).
    if (bad) {
        any_unknown_ = true;
        unknown_sat_.resize(sat_.size());
        std::fill(unknown_sat_.begin(), unknown_sat_.begin() + ptrdiff_t(stride), 0u);
        for (j = 0; j < h; ++j) {
            const float *row = src(j);
            const uint32_t *above = &unknown_sat_[size_t(j) * stride];
            uint32_t *out = &unknown_sat_[size_t(j + 1) * stride];
            uint32_t acc = 0;
            out[0] = 0;
            for (int i = 0; i < w; ++i) {
                acc += !(row[i] < kInfF) ? 1u : 0u;
                out[i + 1] = above[i + 1] + acc;
            }
        }
    }

    return build_root();
}

size_t RegionTree::build_root() {
    if (nodes_.capacity() < 256)
        nodes_.reserve(256);
    Node root;
    root.bounds = {double(grown_.x0), double(grown_.y0), double(grown_.x1), double(grown_.y1)};
    nodes_.push_back(root);
    build(0, 0);
    return nodes_.size();
}

size_t RegionTree::rebuild_cells(const CellErrorImage &cells, const RegionTreeParams &params) {
    const int c = cells.cell;
    if (!grown_.empty() &&
        (c < 1 || cells.cols != (grown_.width() + c - 1) / c ||
         cells.rows != (grown_.height() + c - 1) / c ||
         cells.sum.size() < size_t(cells.cols) * size_t(cells.rows) ||
         cells.unknown.size() < size_t(cells.cols) * size_t(cells.rows)))
        throw std::invalid_argument(
            "RegionTree::rebuild_cells: the cell grid does not cover the grown rectangle");
    params_ = params;
    nodes_.clear();
    built_ = true;
    any_unknown_ = false;
    cell_ = std::max(1, c);
    cols_ = cells.cols;
    rows_ = cells.rows;
    if (grown_.empty())
        return 0;
    inv_cell_ = 1.0 / cell_;
    inv_last_x_ = 1.0 / (grown_.width() - (cols_ - 1) * cell_);
    inv_last_y_ = 1.0 / (grown_.height() - (rows_ - 1) * cell_);
    const size_t stride = size_t(cols_) + 1;
    sat_.assign(stride * (size_t(rows_) + 1), 0.0);
    unknown_sat_.assign(sat_.size(), 0u);
    for (int j = 0; j < rows_; ++j) {
        double acc = 0;
        uint32_t uacc = 0;
        for (int i = 0; i < cols_; ++i) {
            const size_t k = size_t(j) * size_t(cols_) + size_t(i);
            const double v = cells.sum[k];
            acc += (v > 0 && v < kInf) ? v : 0.0;
            uacc += cells.unknown[k];
            sat_[size_t(j + 1) * stride + size_t(i + 1)] = sat_[size_t(j) * stride + size_t(i + 1)] + acc;
            unknown_sat_[size_t(j + 1) * stride + size_t(i + 1)] =
                unknown_sat_[size_t(j) * stride + size_t(i + 1)] + uacc;
        }
    }
    any_unknown_ = unknown_sat_.back() > 0;
    if (!params.area_weighted && params.prune_by_range) {
        max_.resize(size_t(cols_) * size_t(rows_));
        for (int j = 0; j < rows_; ++j) {
            const double ch = std::min(cell_, grown_.height() - j * cell_);
            for (int i = 0; i < cols_; ++i) {
                const double cw = std::min(cell_, grown_.width() - i * cell_);
                const size_t k = size_t(j) * size_t(cols_) + size_t(i);
                const double v = cells.sum[k];
                max_[k] = (v > 0 && v < kInf) ? v / (cw * ch) : 0.0;
            }
        }
        build_pyramids();
    }
    return build_root();
}

void RegionTree::build_pyramids() {
    max_.resize(size_t(cols_) * size_t(rows_));
    min_.assign(max_.begin(), max_.end());
    level_.assign(1, 0);
    level_cols_.assign(1, cols_);
    level_rows_.assign(1, rows_);
    while (level_cols_.back() > 1 || level_rows_.back() > 1) {
        const int pc = level_cols_.back(), pr = level_rows_.back();
        const int c = (pc + 1) / 2, r = (pr + 1) / 2;
        const size_t prev = level_.back(), base = prev + size_t(pc) * size_t(pr);
        max_.resize(base + size_t(c) * size_t(r));
        min_.resize(max_.size());
        for (int j = 0; j < r; ++j) {
            const size_t y0 = prev + size_t(2 * j) * size_t(pc);
            const size_t y1 = prev + size_t(std::min(2 * j + 1, pr - 1)) * size_t(pc);
            for (int i = 0; i < c; ++i) {
                const size_t x0 = size_t(2 * i), x1 = size_t(std::min(2 * i + 1, pc - 1));
                const size_t k = base + size_t(j) * size_t(c) + size_t(i);
                max_[k] = std::max(std::max(max_[y0 + x0], max_[y0 + x1]),
                                   std::max(max_[y1 + x0], max_[y1 + x1]));
                min_[k] = std::min(std::min(min_[y0 + x0], min_[y0 + x1]),
                                   std::min(min_[y1 + x0], min_[y1 + x1]));
            }
        }
        level_.push_back(base);
        level_cols_.push_back(c);
        level_rows_.push_back(r);
    }
}

void RegionTree::error_range(const FloatRect &r, double &lo, double &hi) const {
    lo = hi = 0;
    // The cells with positive coverage: table coordinates rounded outward, as has_unknown.
    PixelBounds p = intersect(r.outward(), grown_);
    if (p.empty())
        return;
    int i0 = (p.x0 - grown_.x0) / cell_, j0 = (p.y0 - grown_.y0) / cell_;
    int i1 = std::min(cols_, (p.x1 - grown_.x0 + cell_ - 1) / cell_) - 1;
    int j1 = std::min(rows_, (p.y1 - grown_.y0 + cell_ - 1) / cell_) - 1;
    // The coarsest level needed for at most 4 x 4 entries: each holds the max (min) of the
    // cells under it, so the max (min) over them bounds the region's from above (below); they
    // may also cover cells outside it.
    size_t k = 0;
    while (k + 1 < level_.size() && ((i1 >> k) - (i0 >> k) >= 4 || (j1 >> k) - (j0 >> k) >= 4))
        ++k;
    i0 >>= k;
    i1 >>= k;
    j0 >>= k;
    j1 >>= k;
    const size_t c = size_t(level_cols_[k]);
    const double *mx = &max_[level_[k]], *mn = &min_[level_[k]];
    hi = 0;
    lo = kInf;
    for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
            hi = std::max(hi, mx[size_t(j) * c + size_t(i)]);
            lo = std::min(lo, mn[size_t(j) * c + size_t(i)]);
        }
}

void RegionTree::build(int n, int depth) {
    // NOTE: nodes_ may reallocate below; work on a copy of the bounds and index by n.
    const FloatRect b = nodes_[size_t(n)].bounds;
    const double a = area(b);
    // The part of the region this quadrant samples. Completion is judged on its pixels alone: the
    // margin's pixels belong to a neighbour, which stops sampling them by its own tree, so an
    // error there may never fall however long this quadrant samples its side (its pixels would
    // run to max_spp, or a region wholly in the margin would keep the quadrant open with
    // nothing to sample). The margin still steers where regions split (the whole region's
    // error is halved), so error at the seams is seen from both sides.
    const FloatRect own{std::max(b.x0, double(quadrant_.x0)), std::max(b.y0, double(quadrant_.y0)),
                        std::min(b.x1, double(quadrant_.x1)), std::min(b.y1, double(quadrant_.y1))};
    const bool any_own = own.x1 > own.x0 && own.y1 > own.y0;
    Node &node = nodes_[size_t(n)];
    if (any_own && has_unknown(own)) {
        // Too few samples here: the estimate is meaningless, keep the region open whole.
        node.error = node.own_error = kInf;
        node.complete = false;
        return;
    }
    const double sum = integral(b);
    // e_b = (r / N) * sum e_p with r = sqrt(A_b / A_image) and N = A_b, i.e.
    // sum / sqrt(A_b * A_image) (Dammertz et al. 2010, eq. 3).
    // r = 1 without area weighting (the plain mean).
    const double r = params_.area_weighted ? std::sqrt(a / image_area_) : 1.0;
    const double e = a <= 0 ? 0.0 : params_.area_weighted ? sum / std::sqrt(a * image_area_) : sum / a;
    node.error = has_unknown(b) ? kInf : e;  // unknown only in the margin: judged without it
    const double a_own = any_own ? area(own) : 0.0;
    // The own part's mean error at the whole region's scale r: a region straddling the seam
    // is held to the same standard as one inside the quadrant, only over the pixels that
    // sampling here can improve (its own part's smaller area would lower e_b by itself).
    node.own_error = !any_own    ? 0.0
                     : a_own == a ? e
                                  : integral(own) / a_own * r;
    const int axis = extent(b, 0) >= extent(b, 1) ? 0 : 1;
    const bool can_split = depth < params_.max_depth &&
                           extent(b, axis) >= 2 * params_.min_extent && sum > 0;
    // Mean mode: no leaf below can reach the target when even all of the region's error in the
    // smallest leaf a split can make (min_extent on each side) stays below it, so the region is
    // complete without splitting (calm regions cost one node, not one per tile). A leaf whose
    // own part is a sliver at the quadrant's edge is judged on that part alone and could read
    // higher; the margin's pixels are the neighbour's, which judges them whole.
    const double min_leaf = std::min(extent(b, 0), params_.min_extent) *
                            std::min(extent(b, 1), params_.min_extent);
    // Likewise when every cell under the own part reads below the target: each leaf's error
    // is a weighted mean of those cells' errors. When every one reads above it, every leaf
    // over the own part would be open and the rest lie in the margin, whose pixels are not
    // sampled here: the region stays one open leaf, with the same pixels active.
    // The range query costs about as much as building a few nodes: asked only of regions with
    // a subtree of more than a handful of nodes to save (it changes no sampled pixel).
    double cell_lo = 0, cell_hi = kInf;
    if (!params_.area_weighted && params_.prune_by_range && any_own &&
        a >= 16 * params_.min_extent * params_.min_extent)
        error_range(own, cell_lo, cell_hi);
    const bool calm = !params_.area_weighted && min_leaf > 0 &&
                      (sum / min_leaf < params_.target || cell_hi < params_.target);
    const bool saturated = !params_.area_weighted && cell_lo > params_.target;
    if (!any_own ||
        (node.own_error < params_.target && (params_.area_weighted || !can_split || calm))) {
        node.complete = true;
        return;
    }
    if (!(e < params_.split_factor * params_.target) || !can_split || saturated) {
        nodes_[size_t(n)].complete = false;
        return;
    }
    const double t = split_position(b, axis, sum);
    FloatRect lo = b, hi = b;
    if (axis == 0)
        lo.x1 = hi.x0 = t;
    else
        lo.y1 = hi.y0 = t;

    const int c0 = int(nodes_.size());
    Node child;
    child.bounds = lo;
    nodes_.push_back(child);
    child.bounds = hi;
    nodes_.push_back(child);
    nodes_[size_t(n)].child[0] = c0;
    nodes_[size_t(n)].child[1] = c0 + 1;
    build(c0, depth + 1);
    build(c0 + 1, depth + 1);
    nodes_[size_t(n)].complete = nodes_[size_t(c0)].complete && nodes_[size_t(c0 + 1)].complete;
}

// ---------------------------------------------------------------------------------------------
// Queries (const: safe for concurrent readers).
// ---------------------------------------------------------------------------------------------

bool RegionTree::complete() const {
    if (quadrant_.empty())
        return true;
    if (!built_)
        return false;
    return nodes_.empty() || nodes_[0].complete;
}

PixelBounds RegionTree::sample_bounds(const FloatRect &b) const {
    PixelBounds r = b.outward();
    if (cell_ <= 1)
        return r;
    // Built from cell sums, the error is known per cell only: sampling part of a cell cannot
    // lower the part of its error that the unsampled pixels hold, which a region reads as
    // spread over the whole cell, so a region covering part of a cell could run to max_spp
    // without converging. Whole cells are sampled instead.
    auto down = [&](int v, int o) { return o + (v - o) / cell_ * cell_; };
    auto up = [&](int v, int o) { return o + (v - o + cell_ - 1) / cell_ * cell_; };
    return {down(r.x0, grown_.x0), down(r.y0, grown_.y0), std::min(up(r.x1, grown_.x0), grown_.x1),
            std::min(up(r.y1, grown_.y0), grown_.y1)};
}

void RegionTree::collect(int n, const PixelBounds &tile, std::vector<PixelBounds> &out) const {
    const Node &node = nodes_[size_t(n)];
    if (node.complete)
        return;
    PixelBounds r = intersect(sample_bounds(node.bounds), tile);
    if (r.empty())
        return;
    if (node.is_leaf()) {
        out.push_back(r);
        return;
    }
    collect(node.child[0], tile, out);
    collect(node.child[1], tile, out);
}

void RegionTree::active_rects(const PixelBounds &tile, std::vector<PixelBounds> &out) const {
    out.clear();
    PixelBounds t = intersect(tile, quadrant_);
    if (t.empty())
        return;
    if (!built_) {
        out.push_back(t);
        return;
    }
    if (nodes_.empty())
        return;
    collect(0, t, out);
}

namespace {
/// Bits of `r` in the 8x8 mask of a tile with origin (ox, oy); r lies in the tile's first 8x8.
uint64_t rect_bits(const PixelBounds &r, int ox, int oy) {
    const int x0 = r.x0 - ox, width = r.x1 - r.x0;
    const uint64_t row = (width >= 8 ? uint64_t(0xff) : (uint64_t(1) << width) - 1) << x0;
    uint64_t bits = 0;
    for (int y = r.y0 - oy; y < r.y1 - oy; ++y)
        bits |= row << (8 * y);
    return bits;
}
}  // namespace

void RegionTree::collect_mask(int n, const PixelBounds &clip, int ox, int oy, uint64_t &mask) const {
    const Node &node = nodes_[size_t(n)];
    if (node.complete)
        return;
    PixelBounds r = intersect(sample_bounds(node.bounds), clip);
    if (r.empty())
        return;
    if (node.is_leaf()) {
        mask |= rect_bits(r, ox, oy);
        return;
    }
    collect_mask(node.child[0], clip, ox, oy, mask);
    collect_mask(node.child[1], clip, ox, oy, mask);
}

uint64_t RegionTree::active_mask(const PixelBounds &tile) const {
    // Clip to the tile's first 8x8 and to the quadrant; bits stay relative to the tile origin.
    const PixelBounds t8{tile.x0, tile.y0, std::min(tile.x1, tile.x0 + 8),
                       std::min(tile.y1, tile.y0 + 8)};
    const PixelBounds clip = intersect(t8, quadrant_);
    if (clip.empty())
        return 0;
    if (!built_)
        return rect_bits(clip, tile.x0, tile.y0);
    uint64_t mask = 0;
    if (!nodes_.empty())
        collect_mask(0, clip, tile.x0, tile.y0, mask);
    return mask;
}

bool RegionTree::active_at(int n, int x, int y) const {
    const Node &node = nodes_[size_t(n)];
    if (node.complete)
        return false;
    PixelBounds r = sample_bounds(node.bounds);
    if (x < r.x0 || x >= r.x1 || y < r.y0 || y >= r.y1)
        return false;
    if (node.is_leaf())
        return true;
    // A split inside pixel x makes it touch both children.
    return active_at(node.child[0], x, y) || active_at(node.child[1], x, y);
}

bool RegionTree::pixel_active(int x, int y) const {
    if (x < quadrant_.x0 || x >= quadrant_.x1 || y < quadrant_.y0 || y >= quadrant_.y1)
        return false;
    if (!built_)
        return true;
    return !nodes_.empty() && active_at(0, x, y);
}

size_t RegionTree::leaf_count() const {
    size_t n = 0;
    for (const Node &node : nodes_)
        n += node.is_leaf() ? 1 : 0;
    return n;
}

size_t RegionTree::open_leaf_count() const {
    size_t n = 0;
    for (const Node &node : nodes_)
        n += node.is_leaf() && !node.complete ? 1 : 0;
    return n;
}

double RegionTree::open_area() const {
    if (!built_)
        return double(quadrant_.area());
    double s = 0;
    for (const Node &node : nodes_) {
        if (!node.is_leaf() || node.complete)
            continue;
        FloatRect c = node.bounds;
        c.x0 = std::max(c.x0, double(quadrant_.x0));
        c.y0 = std::max(c.y0, double(quadrant_.y0));
        c.x1 = std::min(c.x1, double(quadrant_.x1));
        c.y1 = std::min(c.y1, double(quadrant_.y1));
        if (c.x1 > c.x0 && c.y1 > c.y0)
            s += area(c);
    }
    return s;
}

std::string RegionTree::describe() const {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "RegionTree quadrant [%d,%d)x[%d,%d) grown [%d,%d)x[%d,%d): %s, %zu nodes, "
                  "%zu leaves (%zu open), open area %.0f px, root error %.4g",
                  quadrant_.x0, quadrant_.x1, quadrant_.y0, quadrant_.y1, grown_.x0, grown_.x1,
                  grown_.y0, grown_.y1, !built_ ? "not built" : (complete() ? "complete" : "open"),
                  nodes_.size(), leaf_count(), open_leaf_count(), open_area(), root_error());
    return buf;
}

}  // namespace tessera::sampling
