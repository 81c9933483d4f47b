// `suffern`: Suffern-style adaptive supersampling with (up to) two levels of subdivision, on a
// lattice of sample points shared by all neighbouring pixels.
//
// Source: "Adaptive Supersampling and Anti-Aliasing" (papers/003_b028f904bae3f7dc.txt), a
// write-up of the adaptive sampling of K. Suffern, "Ray Tracing from the Ground Up" (2007).
// What it specifies, and where:
//  - "Suffern Supersampling with Two Levels of Subdivision": a ray through each of the four pixel
//    CORNERS A (top left), B (top right), C (bottom left), D (bottom right). If the corners are
//    within the tolerance, the pixel is the plain average (A + B + C + D) / 4. Otherwise the pixel
//    is split into four squares: rays through the four edge midpoints and the centre; each square
//    whose four corners are out of tolerance is split once more (the `stop` flag of
//    SubfragmentRecurse ends the recursion there), so a pixel uses at most a 5x5 lattice: "at
//    most, a single pixel will require 25 points". A square's colour is the average of its four
//    corners, or of its four sub-squares when split; the pixel is the average of its four squares
//    (`outColor = (upperLeft + upperRight + lowerLeft + lowerRight) / 4`), i.e. every leaf square
//    contributes its corner average weighted by its area (1, 1/4 or 1/16 of the pixel).
//  - The sample cache ("Fragment", 25 colours per pixel, kept in a map keyed on the pixel) lets a
//    pixel reuse the samples on the edges it shares with the pixel above and the pixel to the left.
//  - "Images and Analysis": the tolerance used is 0.05 (also shown: 0.01, 0.005, 0.001): our
//    default. At 0.05 the source traced 301149 primary rays against 1085764 for 4x
//    supersampling (28%) at comparable quality. The colour difference measure is not printed in
//    the write-up; its code (raytracer.cpp of the same project, `WithinTolerance` /
//    `FragmentInTolerance`) is: two colours are within tolerance when |c1 - c2| < tolerance in
//    each of r, g, b; a square is within tolerance when the pairs A-B, A-C, D-B and D-C (its
//    four edges) all are. We use exactly that (strict `<`: tolerance 0 splits every square,
//    even a flat one).
//  - The per-pixel ray count is the "heat map" diagnostic of the write-up.
//
// Our version. Sample points live on one global integer lattice at 4x the pixel resolution:
// lattice point (I, J) is the film position (I / 4, J / 4), I in 0..4W, J in 0..4H; pixel
// (x, y) uses the points (4x + i, 4y + j), i, j in 0..4 (its "local" 5x5 lattice: corners at
// i, j in {0, 4} are level 0, the other points with i, j even are level 1, points with an odd
// coordinate are level 2). Every lattice point is traced at most once per frame and its value is
// shared by every pixel whose square contains it (up to four at a corner, two on an edge). The
// frame runs in five barrier stages (scheduler/frame_scheduler.h; "test" and "level1" only for
// levels >= 1, "level2" only for levels = 2), each stage writing only data that no other tile of
// that stage reads:
//   0 "corners"  each pixel traces its top-left corner (the last column/row also the right and
//                bottom image corners);
//   1 "test"     each pixel decides from its four corners whether it splits (level 1) and, if so,
//                gets a slot of 25 colours in a pool (one atomic fetch_add per tile);
//   2 "level1"   the edge midpoints and centres of split pixels are traced;
//   3 "level2"   each split pixel decides which of its quadrants split (level 2); their points
//                are traced;
//   4 "resolve"  pixel colour, diagnostics.
// A lattice point shared by several pixels is traced by the FIRST of them, in a fixed order,
// that needs it: pixels whose square contains the point, larger y first, then larger x first
// (so normally the pixel that has the point on its top or left edge, like the source's cache,
// but a neighbour traces it when only the neighbour needs it). Whether a pixel needs a point is a
// pure function of lattice values finished in earlier stages (the neighbour's split decisions are
// recomputed, not read from a half-written array), so the tracer is the same for any thread
// count and tile order; it then writes the value into the slot of every split pixel that contains
// the point (distinct memory locations, read only after the next barrier). No locks, no spinning,
// and frames are bit-identical for any thread count.
//
// Deviations from the source, and why:
//  - Sharing: any lattice point (corner, edge midpoint, level-2 edge point) is traced once for all
//    the pixels that contain it, not only with the pixel above and to the left; and the cache is
//    keyed on integer lattice coordinates (the source reports cache misses from float keys).
//  - Sub-square test: the source calls FragmentInTolerance(A, top, centre, left) for the upper
//    left square, i.e. with the corners in the wrong order, so it compares the two diagonals
//    (A-centre, left-top) and skips two edges (A-left, top-centre) -- similarly for the other
//    squares. We test each sub-square's four edges, exactly as the pixel-level test does.
//  - `levels` (0..2, default 2 = the source) bounds the subdivision depth; 0 is corner sampling
//    only. The tolerance is applied to the source's linear radiance as returned.
//  - Two options, off by default (the source's test), that spend the points where the displayed
//    image needs them:
//      display=1  compare the colours after the sRGB transfer function (IEC 61966-2-1) on values
//                 clamped to [0, 1], i.e. as an 8-bit display shows them (and as the source's
//                 [0, 1] colours, shown with gamma 1, were compared). Linear radiance splits
//                 bright regions on differences the eye and a PSNR of the display image barely
//                 see, and leaves dark edges unrefined. Non-finite values still fail every test.
//      level2-factor=F  a quadrant (level 2) splits when its corners differ by >= F x tolerance;
//                 F = 4 makes the test bound the error a square can add to its pixel (a quadrant
//                 weighs 1/4), instead of applying the pixel's bound to each quarter.
//    Measured on examples/realtime/thin-shadows at 1024^2 (PSNR of the display image against
//    fixed:spp=256; rays as a fraction of fixed:spp=4's): the default 0.43 / 45.57 dB;
//    display=1 0.45 / 47.01 dB; display=1,level2-factor=4 0.40 / 45.77 dB (fewer rays and a
//    higher PSNR than the default); the source's level test on linear values with
//    level2-factor=4 0.35 / 43.77 dB.
//  - Image border: the right/bottom image edges have no pixel to the right/below, and a
//    CameraSample's offset must stay in [0, 1): points with I = 4W (J = 4H) are sent as pixel
//    W - 1 (H - 1) with fx (fy) = nextafter(1, 0), i.e. 2^-24 of a pixel inside the image.
//  - Sample index: the point's position in its pixel's 4x4 cell, j * 4 + i (0..15); points on the
//    right/bottom border get 16 + j, 20 + i, 24 (distinct indices within a pixel), so a source
//    that uses the index for random numbers gives a lattice point one value wherever it is traced.
//  - Non-finite samples (NaN/Inf) are counted (FrameResult::nan_samples, on the tracing pixel),
//    fail every tolerance test (so their neighbourhood is refined, which dilutes them), and are
//    left out of the averages: a leaf square averages its finite corners, squares without any are
//    left out and the remaining weights renormalised (a pixel without any finite point is black).
//  - Rays per pixel (FrameResult::rays): the rays of a shared point count for the pixel that
//    traced it (rule above), so the heat map sums to rays_total.
// Memory: the (W + 1)(H + 1) corner values, a few bytes per pixel, and a pool of 25 colours per
// split pixel (grown as needed, kept across frames): a dense 4x lattice would take 16 colours
// per pixel whether or not the pixel splits.
// Known limitation (the method's, not fixed here): a feature that passes between the four
// corners of a pixel without touching any of them (a line thinner than a pixel, a highlight) is
// not detected, so it is missed or aliased; fixed supersampling catches it statistically.
// Diagnostics: layer "level" (deepest subdivision in the pixel: 0, 1, 2), layer "points" (distinct
// lattice points the pixel's colour uses, 4..25). active_fraction: pixels that split (level >= 1).
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>

#include "sampling/plugins/plugins.h"

namespace tessera::sampling {

namespace {

constexpr float kOneMinus = 0x1.fffffep-1f;  // nextafter(1, 0): the last offset inside a pixel
constexpr uint32_t kNoSlot = ~0u;
constexpr size_t kSlotSize = 25;  // a pixel's local 5x5 lattice, index j * 5 + i
constexpr size_t kBatch = 64;     // camera samples per evaluate_batch call

enum class StageKind { Corners, Test, Level1, Level2, Resolve };

/// The source's WithinTolerance: every channel differs by less than `tol`. NaN fails.
inline bool within(Rgb a, Rgb b, float tol) {
    return std::fabs(a.r - b.r) < tol && std::fabs(a.g - b.g) < tol && std::fabs(a.b - b.b) < tol;
}

/// The source's FragmentInTolerance over a square's four edges (tl-tr, tl-bl, br-tr, br-bl).
inline bool square_within(Rgb tl, Rgb tr, Rgb bl, Rgb br, float tol) {
    return within(tl, tr, tol) && within(tl, bl, tol) && within(br, tr, tol) && within(br, bl, tol);
}

/// sRGB transfer function (IEC 61966-2-1) of v clamped to [0, 1], from a table with linear
/// interpolation (absolute error below 2e-5: the cells are 1/4096 wide and the first ones lie
/// on the curve's linear segment). Non-finite v gives NaN, so that it fails every test.
class DisplayEncoding {
  public:
    DisplayEncoding() {
        for (int i = 0; i <= kCells; ++i) {
            const double v = double(i) / kCells;
            table_[size_t(i)] =
                float(v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055);
        }
        table_[kCells + 1] = table_[kCells];
    }
    float operator()(float v) const {
        if (!std::isfinite(v))
            return std::numeric_limits<float>::quiet_NaN();
        if (v <= 0.f)
            return 0.f;
        if (v >= 1.f)
            return 1.f;
        const float x = v * float(kCells);
        const int i = int(x);
        const float f = x - float(i);
        return table_[size_t(i)] + f * (table_[size_t(i) + 1] - table_[size_t(i)]);
    }
    Rgb operator()(Rgb c) const { return {(*this)(c.r), (*this)(c.g), (*this)(c.b)}; }

  private:
    static constexpr int kCells = 4096;
    std::array<float, kCells + 2> table_{};
};

const DisplayEncoding kDisplay;

/// Bit (qy * 2 + qx) set for each quadrant of a pixel whose closed square contains local lattice
/// point (i, j): a level-2 point is needed when one of these quadrants splits.
constexpr uint8_t quadrant_mask(int i, int j) {
    const uint8_t xs = i < 2 ? 1 : (i > 2 ? 2 : 3);  // bit 0: left column, bit 1: right
    const uint8_t ys = j < 2 ? 1 : (j > 2 ? 2 : 3);
    uint8_t m = 0;
    for (int qy = 0; qy < 2; ++qy)
        for (int qx = 0; qx < 2; ++qx)
            if ((xs >> qx & 1) && (ys >> qy & 1))
                m |= uint8_t(1u << (qy * 2 + qx));
    return m;
}

/// Distinct lattice points a split pixel uses, by its quadrant split bits: 9 (corners, edge
/// midpoints, centre) plus the level-2 points of the split quadrants (shared ones once).
constexpr std::array<uint8_t, 16> kPointsUsed = [] {
    std::array<uint8_t, 16> n{};
    for (int bits = 0; bits < 16; ++bits) {
        int c = 9;
        for (int j = 0; j <= 4; ++j)
            for (int i = 0; i <= 4; ++i)
                if (((i | j) & 1) && (bits & quadrant_mask(i, j)))
                    ++c;
        n[size_t(bits)] = uint8_t(c);
    }
    return n;
}();

/// A colour with the pixel area it stands for (0: nothing finite there).
struct Weighted {
    Rgb c;
    float w = 0;
};

/// Leaf square of `area`: the mean of its four corners ((a + b) + (c + d)) / 4, so a constant
/// image comes out exactly; non-finite corners are left out.
Weighted leaf(Rgb a, Rgb b, Rgb c, Rgb d, float area) {
    if (a.is_finite() && b.is_finite() && c.is_finite() && d.is_finite())
        return {((a + b) + (c + d)) * 0.25f, area};
    Rgb sum(0.f);
    int n = 0;
    for (const Rgb &v : {a, b, c, d})
        if (v.is_finite()) {
            sum += v;
            ++n;
        }
    return n ? Weighted{sum / float(n), area} : Weighted{};
}

/// A split square of `area`: the area-weighted mean of its four children (the source's plain
/// average of four quarters when all are finite).
Weighted combine(const std::array<Weighted, 4> &q, float area) {
    const float quarter = area * 0.25f;
    if (q[0].w == quarter && q[1].w == quarter && q[2].w == quarter && q[3].w == quarter)
        return {((q[0].c + q[1].c) + (q[2].c + q[3].c)) * 0.25f, area};
    Rgb sum(0.f);
    float w = 0;
    for (const Weighted &v : q) {
        sum += v.c * v.w;
        w += v.w;
    }
    return w > 0 ? Weighted{sum / w, w} : Weighted{};
}

/// Pixels whose closed square contains lattice coordinate L (along one axis of n pixels), in the
/// preference order of the tracer rule: the larger pixel coordinate first.
inline int containing(uint32_t L, uint32_t n, std::array<uint32_t, 2> &out) {
    const uint32_t c = L / 4;
    if (L % 4) {
        out[0] = c;
        return 1;
    }
    int k = 0;
    if (c < n)
        out[size_t(k++)] = c;
    if (c >= 1)
        out[size_t(k++)] = c - 1;
    return k;
}

class SuffernSampler final : public PixelSampler {
  public:
    SuffernSampler(float tolerance, int levels, bool display, float level2_factor)
        : tol_(tolerance), tol2_(tolerance * level2_factor), levels_(levels), display_(display) {
        stages_.push_back(StageKind::Corners);
        if (levels_ >= 1) {
            stages_.push_back(StageKind::Test);
            stages_.push_back(StageKind::Level1);
        }
        if (levels_ >= 2)
            stages_.push_back(StageKind::Level2);
        stages_.push_back(StageKind::Resolve);
    }

    void begin_frame(const SampleSource &source) override {
        width_ = source.width();
        height_ = source.height();
        const size_t n = size_t(width_) * height_;
        // The corner values need no clearing: every corner is written in stage 0 before any read.
        corners_.resize(size_t(width_ + 1) * (height_ + 1));
        split_.assign(n, 0);
        quads_.assign(n, 0);
        slot_.assign(n, kNoSlot);
        rays_.assign(n, 0);
        nan_.assign(n, 0);
        color_.assign(n, Rgb(0.f));
        level_.assign(n, 0);
        points_.assign(n, 0);
        next_slot_.store(0, std::memory_order_relaxed);
        traced_.store(0, std::memory_order_relaxed);
        shadow_.reset();
    }

    /// Only radiance: no attribute vector.
    uint32_t attributes_used() const override { return kAttrNone; }

    int stage_count() const override { return int(stages_.size()); }

    std::string stage_name(int stage) const override {
        switch (stages_[size_t(stage)]) {
            case StageKind::Corners:
                return "corners";
            case StageKind::Test:
                return "test";
            case StageKind::Level1:
                return "level1";
            case StageKind::Level2:
                return "level2";
            case StageKind::Resolve:
                return "resolve";
        }
        return "stage";
    }

    void run_tile(int stage, const PixelRect &tile, const SampleSource &source) override {
        switch (stages_[size_t(stage)]) {
            case StageKind::Corners:
                trace_corners(tile, source);
                break;
            case StageKind::Test:
                test_corners(tile);
                break;
            case StageKind::Level1:
                trace_level1(tile, source);
                break;
            case StageKind::Level2:
                trace_level2(tile, source);
                break;
            case StageKind::Resolve:
                resolve(tile);
                break;
        }
    }

    void end_stage(int stage, const SampleSource &) override {
        // Serial: size the slot pool for the pixels that split (grows only, kept across frames).
        if (stages_[size_t(stage)] == StageKind::Test) {
            const size_t need = size_t(next_slot_.load()) * kSlotSize;
            if (pool_.size() < need)
                pool_.resize(need);
        }
    }

    void end_frame(FrameResult &r) override {
        if (!diagnostics())
            drop_diagnostics(r);  // before reset(), which would zero them
        r.reset(width_, height_);
        r.color = color_;
        // Diagnostic layers (null when off). NOTE: FrameResult::layer() may reallocate the
        // layer list: create both layers first, then point into them.
        float *level = nullptr, *points = nullptr;
        if (diagnostics()) {
            r.layer("level");
            r.layer("points");
            level = r.layer("level").data.data();
            points = r.layer("points").data.data();
        }
        uint64_t rays = 0, split = 0;
        for (size_t i = 0; i < color_.size(); ++i) {
            r.rays[i] = float(rays_[i]);
            rays += rays_[i];
            r.nan_samples += nan_[i];
            if (level) {
                level[i] = float(level_[i]);
                points[i] = float(points_[i]);
            }
            split += split_[i];
        }
        r.samples = traced_.load();
        r.rays_total = rays;
        shadow_.write(r);
        r.active_fraction = color_.empty() ? 0.0 : double(split) / double(color_.size());
        r.active_unit = "pixels";
    }

  private:
    /// Pending camera samples of one tile, flushed through evaluate_batch (on the stack: no
    /// allocation per sample or per tile).
    struct Batch {
        std::array<CameraSample, kBatch> cs;
        std::array<Sample, kBatch> out;
        std::array<uint32_t, kBatch> lx, ly, tracer;  // lattice point and the pixel tracing it
        size_t n = 0;
        uint64_t traced = 0;
    };

    size_t pixel(uint32_t x, uint32_t y) const { return size_t(y) * width_ + x; }

    /// The camera sample of lattice point (I, J); see the file comment for the border and index.
    CameraSample lattice_sample(uint32_t I, uint32_t J) const {
        CameraSample cs;
        const uint32_t ix = I % 4, iy = J % 4;
        cs.px = I / 4;
        cs.py = J / 4;
        cs.fx = float(ix) * 0.25f;
        cs.fy = float(iy) * 0.25f;
        cs.index = iy * 4 + ix;
        const bool clamp_x = cs.px == width_, clamp_y = cs.py == height_;
        if (clamp_x) {
            cs.px = width_ - 1;
            cs.fx = kOneMinus;
        }
        if (clamp_y) {
            cs.py = height_ - 1;
            cs.fy = kOneMinus;
        }
        if (clamp_x || clamp_y)
            cs.index = clamp_x && clamp_y ? 24 : (clamp_x ? 16 + iy : 20 + ix);
        return cs;
    }

    void push(Batch &b, uint32_t I, uint32_t J, size_t tracer, const SampleSource &source) {
        b.cs[b.n] = lattice_sample(I, J);
        b.lx[b.n] = I;
        b.ly[b.n] = J;
        b.tracer[b.n] = uint32_t(tracer);
        if (++b.n == kBatch)
            flush(b, source);
    }

    void flush(Batch &b, const SampleSource &source) {
        if (!b.n)
            return;
        source.evaluate_batch(std::span<const CameraSample>(b.cs.data(), b.n),
                              std::span<Sample>(b.out.data(), b.n));
        shadow_.add(std::span<const Sample>(b.out.data(), b.n));
        for (size_t k = 0; k < b.n; ++k) {
            const Sample &s = b.out[k];
            rays_[b.tracer[k]] += s.rays;
            if (!s.radiance.is_finite())
                ++nan_[b.tracer[k]];
            store(b.lx[k], b.ly[k], s.radiance);
        }
        b.traced += b.n;
        b.n = 0;
    }

    void finish(Batch &b, const SampleSource &source) {
        flush(b, source);
        traced_.fetch_add(b.traced, std::memory_order_relaxed);
    }

    /// Writes a traced value where readers find it: the corner array, or the slot of every split
    /// pixel containing the point (each location is written by exactly one tracer per frame).
    void store(uint32_t I, uint32_t J, Rgb v) {
        if (I % 4 == 0 && J % 4 == 0) {
            corners_[size_t(J / 4) * (width_ + 1) + I / 4] = v;
            return;
        }
        std::array<uint32_t, 2> xs{}, ys{};
        const int nx = containing(I, width_, xs), ny = containing(J, height_, ys);
        for (int b = 0; b < ny; ++b)
            for (int a = 0; a < nx; ++a) {
                const size_t q = pixel(xs[size_t(a)], ys[size_t(b)]);
                if (!split_[q])
                    continue;
                const uint32_t i = I - 4 * xs[size_t(a)], j = J - 4 * ys[size_t(b)];
                pool_[size_t(slot_[q]) * kSlotSize + j * 5 + i] = v;
            }
    }

    /// Value of local point (i, j) of pixel (x, y); non-corner points need the pixel split.
    Rgb value(uint32_t x, uint32_t y, uint32_t i, uint32_t j) const {
        if (i % 4 == 0 && j % 4 == 0)
            return corners_[size_t(y + j / 4) * (width_ + 1) + x + i / 4];
        return pool_[size_t(slot_[pixel(x, y)]) * kSlotSize + j * 5 + i];
    }

    /// The split test of a square (corners in the source's colours, or as displayed).
    bool square_ok(Rgb tl, Rgb tr, Rgb bl, Rgb br, float tol) const {
        if (display_)
            return square_within(kDisplay(tl), kDisplay(tr), kDisplay(bl), kDisplay(br), tol);
        return square_within(tl, tr, bl, br, tol);
    }

    /// Which quadrants of split pixel (x, y) split again (bit qy * 2 + qx): a pure function of
    /// the pixel's level-0 and level-1 values, so a neighbour may recompute it.
    uint8_t quadrant_splits(uint32_t x, uint32_t y) const {
        uint8_t bits = 0;
        for (uint32_t qy = 0; qy < 2; ++qy)
            for (uint32_t qx = 0; qx < 2; ++qx) {
                const uint32_t i = 2 * qx, j = 2 * qy;
                if (!square_ok(value(x, y, i, j), value(x, y, i + 2, j), value(x, y, i, j + 2),
                               value(x, y, i + 2, j + 2), tol2_))
                    bits |= uint8_t(1u << (qy * 2 + qx));
            }
        return bits;
    }

    /// True when the pixel tracing lattice point (I, J) is `p`: the first pixel containing the
    /// point, in the fixed order, for which `needs(x, y)` holds.
    template <class Needs>
    bool traces(size_t p, uint32_t I, uint32_t J, Needs needs) const {
        std::array<uint32_t, 2> xs{}, ys{};
        const int nx = containing(I, width_, xs), ny = containing(J, height_, ys);
        for (int b = 0; b < ny; ++b)
            for (int a = 0; a < nx; ++a)
                if (needs(xs[size_t(a)], ys[size_t(b)]))
                    return pixel(xs[size_t(a)], ys[size_t(b)]) == p;
        return false;
    }

    // Stage 0: every corner once, by the pixel that has it as top-left corner (clamped).
    void trace_corners(const PixelRect &t, const SampleSource &source) {
        Batch b;
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x) {
                const size_t p = pixel(x, y);
                const bool last_x = x + 1 == width_, last_y = y + 1 == height_;
                push(b, 4 * x, 4 * y, p, source);
                if (last_x)
                    push(b, 4 * width_, 4 * y, p, source);
                if (last_y)
                    push(b, 4 * x, 4 * height_, p, source);
                if (last_x && last_y)
                    push(b, 4 * width_, 4 * height_, p, source);
            }
        finish(b, source);
    }

    // Stage 1: level-0 test and a pool slot per split pixel.
    void test_corners(const PixelRect &t) {
        uint32_t count = 0;
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x) {
                const bool split = !square_ok(value(x, y, 0, 0), value(x, y, 4, 0),
                                              value(x, y, 0, 4), value(x, y, 4, 4), tol_);
                split_[pixel(x, y)] = split;
                count += split;
            }
        if (!count)
            return;
        // Slot numbers depend on the tile order; values and the image do not.
        uint32_t next = next_slot_.fetch_add(count, std::memory_order_relaxed);
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x)
                if (split_[pixel(x, y)])
                    slot_[pixel(x, y)] = next++;
    }

    // Stage 2: edge midpoints and centre of every split pixel; a shared midpoint is needed by
    // every split pixel containing it.
    void trace_level1(const PixelRect &t, const SampleSource &source) {
        static constexpr std::array<std::array<uint32_t, 2>, 5> kPoints{
            {{2, 0}, {0, 2}, {2, 2}, {4, 2}, {2, 4}}};
        auto needs = [this](uint32_t x, uint32_t y) { return split_[pixel(x, y)] != 0; };
        Batch b;
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x) {
                const size_t p = pixel(x, y);
                if (!split_[p])
                    continue;
                for (const auto &ij : kPoints) {
                    const uint32_t I = 4 * x + ij[0], J = 4 * y + ij[1];
                    if (traces(p, I, J, needs))
                        push(b, I, J, p, source);
                }
            }
        finish(b, source);
    }

    // Stage 3: quadrant tests, then the level-2 points of split quadrants. A point on the
    // pixel's edge may be needed by the neighbour across it; its quadrant decisions are
    // recomputed here from its (finished) level-1 values, at most once per neighbour.
    void trace_level2(const PixelRect &t, const SampleSource &source) {
        Batch b;
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x) {
                const size_t p = pixel(x, y);
                if (!split_[p])
                    continue;
                const uint8_t own = quadrant_splits(x, y);
                quads_[p] = own;
                if (!own)
                    continue;
                std::array<int, 4> neighbour{-1, -1, -1, -1};  // left, right, up, down (lazy)
                auto needs = [&](uint32_t qx, uint32_t qy, uint32_t I, uint32_t J) {
                    if (qx == x && qy == y)
                        return true;  // only points p needs are asked
                    const size_t q = pixel(qx, qy);
                    if (!split_[q])
                        return false;
                    const int side = qx < x ? 0 : qx > x ? 1 : qy < y ? 2 : 3;
                    if (neighbour[size_t(side)] < 0)
                        neighbour[size_t(side)] = quadrant_splits(qx, qy);
                    const uint8_t mask = quadrant_mask(int(I - 4 * qx), int(J - 4 * qy));
                    return (neighbour[size_t(side)] & mask) != 0;
                };
                for (uint32_t j = 0; j <= 4; ++j)
                    for (uint32_t i = 0; i <= 4; ++i) {
                        if (!((i | j) & 1) || !(own & quadrant_mask(int(i), int(j))))
                            continue;
                        const uint32_t I = 4 * x + i, J = 4 * y + j;
                        if (traces(p, I, J,
                                   [&](uint32_t qx, uint32_t qy) { return needs(qx, qy, I, J); }))
                            push(b, I, J, p, source);
                    }
            }
        finish(b, source);
    }

    // Stage 4: the source's averaging (area-weighted corner means of the leaf squares).
    void resolve(const PixelRect &t) {
        for (uint32_t y = t.y0; y < t.y1; ++y)
            for (uint32_t x = t.x0; x < t.x1; ++x) {
                const size_t p = pixel(x, y);
                auto v = [&](uint32_t i, uint32_t j) { return value(x, y, i, j); };
                if (!split_[p]) {
                    color_[p] = leaf(v(0, 0), v(4, 0), v(0, 4), v(4, 4), 1.f).c;
                    level_[p] = 0;
                    points_[p] = 4;
                    continue;
                }
                // Gather the pixel's 5x5 lattice (its slot plus the shared corner array).
                std::array<Rgb, kSlotSize> f;
                std::copy_n(&pool_[size_t(slot_[p]) * kSlotSize], kSlotSize, f.begin());
                f[0] = v(0, 0);
                f[4] = v(4, 0);
                f[20] = v(0, 4);
                f[24] = v(4, 4);
                auto at = [&f](uint32_t i, uint32_t j) { return f[j * 5 + i]; };
                const uint8_t bits = quads_[p];
                std::array<Weighted, 4> quad;
                for (uint32_t qy = 0; qy < 2; ++qy)
                    for (uint32_t qx = 0; qx < 2; ++qx) {
                        const uint32_t i = 2 * qx, j = 2 * qy;
                        Weighted &w = quad[qy * 2 + qx];
                        if (!(bits >> (qy * 2 + qx) & 1)) {
                            w = leaf(at(i, j), at(i + 2, j), at(i, j + 2), at(i + 2, j + 2), 0.25f);
                            continue;
                        }
                        std::array<Weighted, 4> sub;
                        for (uint32_t sy = 0; sy < 2; ++sy)
                            for (uint32_t sx = 0; sx < 2; ++sx) {
                                const uint32_t a = i + sx, c = j + sy;
                                sub[sy * 2 + sx] = leaf(at(a, c), at(a + 1, c), at(a, c + 1),
                                                        at(a + 1, c + 1), 0.0625f);
                            }
                        w = combine(sub, 0.25f);
                    }
                color_[p] = combine(quad, 1.f).c;
                level_[p] = bits ? 2 : 1;
                points_[p] = kPointsUsed[bits];
            }
    }

    const float tol_;   ///< pixel (level 0 -> 1) test
    const float tol2_;  ///< quadrant (level 1 -> 2) test: tolerance x level2-factor
    const int levels_;
    const bool display_;  ///< compare display-encoded colours
    std::vector<StageKind> stages_;
    uint32_t width_ = 0, height_ = 0;
    std::vector<Rgb> corners_;    ///< level-0 values, (W + 1) x (H + 1), row-major
    std::vector<uint8_t> split_;  ///< per pixel: corners out of tolerance (stage 1)
    std::vector<uint8_t> quads_;  ///< per pixel: quadrants split again (stage 3, own pixel)
    std::vector<uint32_t> slot_;  ///< per split pixel: its slot in pool_
    std::vector<Rgb> pool_;       ///< 25 values per split pixel (corners unused)
    std::vector<uint32_t> rays_;  ///< rays traced per pixel (tracer attribution)
    std::vector<uint32_t> nan_;   ///< non-finite samples per tracing pixel
    std::vector<Rgb> color_;
    std::vector<uint8_t> level_, points_;
    std::atomic<uint32_t> next_slot_{0};
    std::atomic<uint64_t> traced_{0};
    FrameShadowRays shadow_;
};

}  // namespace

PluginInfo suffern_plugin_info() {
    PluginInfo info;
    info.name = "suffern";
    info.kind = PluginKind::Frame;
    info.summary =
        "adaptive supersampling (Suffern; 'Adaptive Supersampling and Anti-Aliasing'): "
        "corner samples on a lattice shared by all neighbours, squares whose corners "
        "differ by >= tolerance split recursively, up to 25 points per pixel";
    info.params = {
        {"tolerance", 0.05, 0, 1e9, false,
         "split a square when two corners along an edge differ by >= this in a channel"},
        {"levels", 2, 0, 2, true,
         "subdivision levels: 0 corners only, 1 up to 9, 2 up to 25 points"},
        {"display", 0, 0, 1, true,
         "1: compare the colours as displayed (sRGB transfer function on [0, 1]); 0: linear "
         "radiance, as returned (the source)"},
        {"level2-factor", 1, 1e-3, 1e6, false,
         "a quadrant splits again when its corners differ by >= this x tolerance (1: the "
         "source; 4: the bound on the quadrant's share of its pixel's error)"},
    };
    info.make = [](const PluginParams &p) -> std::unique_ptr<PixelSampler> {
        // The parser checks ranges; parameters built in code are checked again here. (The
        // keys are independent: there is no cross-parameter constraint.)
        const double tol = p.get("tolerance");
        const double levels = p.get("levels");
        if (!std::isfinite(tol) || tol < 0)
            throw std::invalid_argument("suffern: tolerance=" + std::to_string(tol) +
                                        " must be a finite number >= 0");
        if (levels != 0 && levels != 1 && levels != 2)
            throw std::invalid_argument("suffern: levels=" + std::to_string(levels) +
                                        " must be 0, 1 or 2");
        const double factor = p.get("level2-factor");
        if (!std::isfinite(factor) || factor <= 0)
            throw std::invalid_argument("suffern: level2-factor=" + std::to_string(factor) +
                                        " must be a finite number > 0");
        return std::make_unique<SuffernSampler>(float(tol), int(levels), p.get_bool("display"),
                                                float(factor));
    };
    return info;
}

}  // namespace tessera::sampling
