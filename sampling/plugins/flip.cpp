// `fliptri` and `flipquad`: low-cost adaptive anti-aliasing (M. Shevtsov, M. Letavin,
// A. Rukhlinskiy, "Low Cost Adaptive Anti-Aliasing for Real-Time Ray-Tracing", Intel;
// papers/002_62e7b10230266bf4.txt), with the FLIPTRI / FLIPQUAD primary patterns of
// T. Akenine-Moller, "An Extremely Inexpensive Multisampling Scheme" (2003) and T. Akenine-Moller,
// J. Strom, "Graphics for the Masses" (2003).
//
// Algorithm: the paper's three-pass scheme (section 3, Fig. 2 left), one barrier stage per pass:
//  1. pattern (section 3, Figs. 2 right and 3): sparse pre-sampling with a pattern whose samples
//     lie on pixel edges and corners, defined for one pixel and mirrored ("flipped") in the
//     others -- x mirrored in odd columns, y in odd rows -- so that every edge or corner sample is
//     shared by the pixels that touch it. FLIPTRI: 3 samples per pixel (one corner, two edges),
//     1.25 traced per pixel; FLIPQUAD: 4 edge samples, 2 traced per pixel. Each shared point is
//     traced exactly once (ownership below).
//  2. gradient (section 3, Fig. 4): pairwise gradients between the pixel's pattern samples -- 3
//     pairs for FLIPTRI, 6 for FLIPQUAD -- on luminance (default) or per colour component; the
//     frame-average gradient, reduced serially in end_stage, is the threshold.
//  3. supersample: a pixel whose largest gradient exceeds the threshold gets `extra` rotated-grid
//     (RGSS, N-rooks) samples; the pixel is the equal-weight mean (box filter) of its pattern and
//     extra samples (section 3, last paragraph; section 5: "box-shaped reconstruction filter and
//     equal weights for all samples").
// prev_threshold=1 (section 3: "If supersampling threshold value from the previous frame is
// used ... no dedicated pass is required"): the previous frame's average is the threshold, so
// the gradient and supersample passes fuse into one stage; the current frame's average is
// reduced at the end of the frame for the next one. Defaults: extra = 4 for FLIPTRI (Fig. 5,
// "FLIPTRI with 4 samples"), extra = 16 for FLIPQUAD (Fig. 5, "FLIPQUAD with 16 additional
// per-pixel samples"), the three-pass scheme, luminance gradients, threshold = the average.
//
// Pattern positions (pixel-local, x right, y down, for a pixel with even x and even y; the other
// pixels mirror them). The paper gives them only in its figures, which the text copy lacks;
// they follow from the patterns' construction:
//   FLIPQUAD: top (1/3, 0), right (1, 1/3), bottom (2/3, 1), left (0, 2/3): the 4-rooks (RGSS)
//     pinwheel pushed onto the pixel edges, projections at thirds so that each axis sees four
//     evenly spaced positions 0, 1/3, 2/3, 1 (N-rooks on the edges).
//   FLIPTRI: corner (0, 0), right (1, 1/3), bottom (2/3, 1): FLIPQUAD with its top and left
//     samples merged into the corner they enclose (a triangle, 1/4 + 1/2 + 1/2 = 1.25 samples
//     per pixel). The corners then sit on the even lattice points and the edge samples on the
//     odd lines, i.e. the edge samples are shared within the aligned 2x2 block (its inner cross,
//     Fig. 3 "edge packets shared within 2x2 block") and the corners within the 2x2 block offset
//     by one pixel ("the corner packet is also shared, but within another 2x2 block").
//   RGSS extra samples: an n x n grid rotated so that every row and column of the n^2 x n^2
//     sub-grid holds one sample, k = a n + b -> ((a n + b + 1/2) / n^2, (b n + n-1-a + 1/2) / n^2);
//     n = 2 is the classic 4-sample RGSS (0.625, 0.125), (0.875, 0.625), (0.375, 0.875),
//     (0.125, 0.375), a pinwheel of the opposite hand to the primary one so the two fill each
//     other's gaps. Mirrored per pixel like the primary pattern (Fig. 2 right shows primary and
//     secondary rays laid out over the 2x2 block).
//
// Ownership and data layout. A sample belongs to the pixel that contains it in the CameraSample
// sense (half-open [px, px + 1)), clamped into the image: an edge sample to the pixel on its
// right/below, a sample on the image's right or bottom border to the last column/row, with
// fx (fy) = nextafter(1, 0). The pattern stage of a tile traces exactly the samples its pixels
// own, so every shared point is traced once and written by one tile; the later stages read the
// neighbours' ones (read-only after the barrier). Samples are stored per lattice kind
// (vertical-edge, horizontal-edge and corner sites; FLIPTRI keeps only the lines it uses),
// per-pixel state per pixel, all in 8x8 blocks so that a tile's working data is contiguous, and
// on huge pages where the kernel offers them (sampling/large_buffer.h). The
// gradient stage also sums the pattern's colours and ray shares per pixel, so the supersample stage
// touches only its own pixels. Integer counts go to atomics once per tile (order-free); the frame
// average is summed serially in a fixed order; the outputs are written row-major and swapped into
// the FrameResult. The plugin allocates nothing per frame. Rays go in packets of 8 through
// evaluate_batch, grouped as in the paper's Fig. 3 but widened from 4-wide SSE to the renderer's
// 8-wide packets: FLIPTRI's edge packets hold the inner crosses of two 2x2 blocks, its corner
// packets eight corners; FLIPQUAD's packet holds the eight edge samples a 2x2 block owns; extra
// samples go 8 to a packet in pixel order (two pixels' RGSS-4).
//
// Diagnostics: layer "active" (1 where the pixel got extra samples), layer "gradient" (the
// pixel's largest pairwise gradient over the threshold, max over channels in per-channel mode;
// > 1 means active), FrameResult::rays (rays per pixel: each pattern sample's rays split evenly
// over the pixels that use it, plus the pixel's extra rays). active_unit "pixels".
//
// Deviations from the paper, and why:
//  1. Positions come from the construction above (the figures are not in the text); the paper's
//     SSE-4 packets become groups of 8 (rtcIntersect8). Fig. 5's "FLIPTRI with 4 samples shared
//     for 2x2 pixels block" is read as 4 RGSS samples per active pixel, mirrored within the 2x2
//     block like the primary pattern (3 + 4 = 7 samples, the paper's "8X quality").
//  2. Gradient definition: the paper says only "pair-wise between samples" and "average gradient
//     magnitude ... for the frame". Here a gradient is the finite difference
//     |v_a - v_b| / |p_a - p_b| (per pixel of distance), v the Rec.709 luminance or each colour
//     channel; the threshold is the mean over every finite pair of every pixel; a pixel is active
//     when one of its gradients is strictly above it (a flat image has threshold 0 and activates
//     nothing). Non-finite samples are left out of the gradients and of the pixel mean, and
//     counted in nan_samples.
//  3. The single-pass variant keeps one barrier after the pattern pass (2 stages): a pattern
//     sample on a tile border is owned, and traced, by one tile and read by the next, so no tile
//     can decide before its neighbours have traced. In the paper one thread handles whole 2x2
//     blocks and has no such border. The first frame (no previous threshold yet) and a frame
//     after a cancelled one run the full three-pass scheme.
//  4. texture_average=1 implements the note of section 4 (Fig. 6) with the attribute vector:
//     samples of the pixel's pattern that hit the same textured object, with the same shadow
//     bits and the same reflected object, enter the gradient with their mean (the local average
//     texture intensity), so texture detail alone triggers nothing while object, shadow and
//     reflection boundaries still do. Off by default: the paper's scheme is colour-only, and it
//     needs a source that provides attributes (without them it changes nothing).
//  5. threshold_scale (default 1 = the paper) multiplies the threshold; the paper has no such
//     knob, but it trades quality for rays without touching the scheme.
//  6. Rays per pixel (a diagnostic the paper only shows as images) splits each shared sample's
//     rays evenly over the pixels that use it, so a FLIPTRI interior pixel costs 1.25 samples.
//  7. share_weights=1 (off by default: section 5 weighs all samples equally) weighs each
//     pattern sample of a supersampled pixel by its share of the pixel, the same split as the
//     rays above (1/users: 1/4 for a corner, 1/2 for an edge), and each extra sample by 1. The
//     pattern samples lie on the pixel's border, half or three quarters of their neighbourhood
//     outside it; with equal weights they pull a supersampled pixel toward its neighbours.
//     Pattern-only pixels keep the equal mean. Measured at 1024^2 (PSNR of the display image
//     against fixed:spp=256): fliptri:extra=9 on examples/realtime/thin-shadows 48.80 dB equal,
//     51.62 dB shared; on examples/realtime/cornell-mirror 47.88 / 48.72 dB (fixed:spp=8:
//     49.40 and 47.96 dB), at the same rays.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "sampling/large_buffer.h"
#include "sampling/plugins/plugins.h"

namespace tessera::sampling {

namespace {

enum class Pattern { FlipTri, FlipQuad };

constexpr float kThird = 1.f / 3.f;
constexpr float kTwoThirds = 2.f / 3.f;
/// The largest float below 1: a sample on the image's right/bottom border clamped into the last
/// pixel (CameraSample offsets are in [0, 1)).
constexpr float kBelowOne = 0x1.fffffep-1f;
/// Packet width of the renderer (rtcIntersect8).
constexpr uint32_t kPacket = 8;
/// "gradient" layer value where the threshold is 0 but the gradient is not.
constexpr float kRatioCap = 1e6f;
/// CameraSample::index of the first extra sample (pattern samples use 0..11, see site_sample).
constexpr uint32_t kFirstExtraIndex = 16;

/// Index of a 2D array stored in 8x8 blocks, so that a scheduler tile's entries are
/// contiguous (and tiles never share a cache line).
class BlockedLayout {
  public:
    BlockedLayout() = default;
    BlockedLayout(uint32_t w, uint32_t h)
        : bw_((w + 7) / 8), size_(size_t(bw_) * ((h + 7) / 8) * 64) {}
    /// Entries including the padding of partial blocks.
    size_t size() const { return size_; }
    size_t operator()(uint32_t x, uint32_t y) const {
        return (size_t(y >> 3) * bw_ + (x >> 3)) * 64 + ((y & 7u) << 3) + (x & 7u);
    }

  private:
    uint32_t bw_ = 0;
    size_t size_ = 0;
};

/// A 2D array in BlockedLayout.
template <class T>
class BlockedGrid {
  public:
    void resize(uint32_t w, uint32_t h) {
        layout_ = BlockedLayout(w, h);
        data_.assign(layout_.size(), T{});
    }
    void clear() {
        layout_ = BlockedLayout();
        data_.clear();
        data_.shrink_to_fit();
    }
    T &operator()(uint32_t x, uint32_t y) { return data_[layout_(x, y)]; }
    const T &operator()(uint32_t x, uint32_t y) const { return data_[layout_(x, y)]; }

  private:
    BlockedLayout layout_;
    LargeVector<T> data_;
};

/// One traced pattern sample.
struct Site {
    Rgb radiance;
    float luminance = 0;  ///< NaN when the radiance is not finite
    float ray_share = 0;  ///< rays / pixels using the sample (the rays-per-pixel map)
};

/// texture_average only: what identifies "one textured surface" at a sample.
struct TextureKey {
    int32_t object = -1;  ///< object id of a textured first hit, else -1
    uint32_t key = 0;     ///< shadow bits and reflected object
};

/// The three kinds of lattice sites: on a vertical pixel edge (x = i, y = j + offset), on a
/// horizontal one (x = i + offset, y = j), and on a corner (x = i, y = j).
enum class SiteKind : uint8_t { Vertical = 0, Horizontal = 1, Corner = 2 };

/// The sites of one kind: i in [i0, i1], j in [j0, j1] (inclusive), every (1 << si)-th column
/// and (1 << sj)-th row from i0 / j0.
struct Lattice {
    uint32_t i0 = 0, i1 = 0, j0 = 0, j1 = 0;
    uint32_t si = 0, sj = 0;
};

/// What the gradient pass leaves for the supersample pass, per pixel.
struct PixelData {
    Rgb sum;                      ///< finite pattern samples
    uint32_t good = 0;            ///< their number
    Rgb share_sum;                ///< share_weights: finite pattern samples x their pixel share
    float share = 0;              ///< share_weights: the sum of those shares
    float rays = 0;               ///< the pattern's rays for this pixel (shares)
    std::array<float, 3> gmax{};  ///< largest pairwise gradient (luminance: [0] only)
};

/// Extra-sample accumulator of an active pixel.
struct ExtraSum {
    Rgb sum;  ///< finite samples
    uint32_t good = 0;
    uint32_t rays = 0;
};

/// Integer counts of one tile, added to the frame's atomics once per tile (order-free, so
/// deterministic).
struct TileCounts {
    uint64_t samples = 0, rays = 0, nan = 0, active = 0;
    ShadowRayTally shadow;
};

struct Params {
    uint32_t extra = 4;
    bool prev_threshold = false;
    double threshold_scale = 1;
    bool per_channel = false;
    bool texture_average = false;
    bool share_weights = false;
};

/// Fixed-size packet of camera samples for evaluate_batch; `Target` receives each result.
template <class Target>
struct Packet {
    std::array<CameraSample, kPacket> cs;
    std::array<Sample, kPacket> out;
    std::array<Target, kPacket> target;
    uint32_t n = 0;
};

template <Pattern P>
class FlipSampler final : public PixelSampler {
    static constexpr bool kTri = P == Pattern::FlipTri;
    /// Samples in one pixel's pattern.
    static constexpr int K = kTri ? 3 : 4;
    /// Site kinds in use (FLIPQUAD has no corner samples).
    static constexpr int kKinds = kTri ? 3 : 2;

  public:
    explicit FlipSampler(const Params &p) : p_(p), nch_(p.per_channel ? 3 : 1) {
        // RGSS base pattern (pixel with even x and y).
        const uint32_t n = uint32_t(std::lround(std::sqrt(double(p_.extra))));
        const float inv = 1.f / float(p_.extra ? p_.extra : 1);
        for (uint32_t a = 0; a < n; ++a)
            for (uint32_t b = 0; b < n; ++b)
                extra_base_.push_back(Vec2f((float(a * n + b) + 0.5f) * inv,
                                            (float(b * n + (n - 1 - a)) + 0.5f) * inv));
        // Pairwise inverse distances of the base pattern (mirroring keeps them), in the order
        // of pixel_sites(): FLIPTRI corner, vertical edge, horizontal edge; FLIPQUAD left, top,
        // right, bottom.
        std::array<Vec2f, K> base;
        if constexpr (kTri)
            base = {Vec2f(0, 0), Vec2f(1, kThird), Vec2f(kTwoThirds, 1)};
        else
            base = {Vec2f(0, kTwoThirds), Vec2f(kThird, 0), Vec2f(1, kThird), Vec2f(kTwoThirds, 1)};
        int q = 0;
        for (int a = 0; a < K; ++a)
            for (int b = a + 1; b < K; ++b) {
                const float dx = base[size_t(a)].x - base[size_t(b)].x;
                const float dy = base[size_t(a)].y - base[size_t(b)].y;
                pairs_[size_t(q++)] = {a, b, 1.f / std::sqrt(dx * dx + dy * dy)};
            }
    }

    void begin_frame(const SampleSource &source) override {
        if (source.width() != width_ || source.height() != height_ || !allocated_)
            allocate(source.width(), source.height());
        // Output buffers: end_frame swaps them into the result, handing back its fresh zeroed
        // ones; size them again only when something else happened (first frame, resize).
        const size_t n = size_t(width_) * height_;
        for (std::vector<float> *v : {&rays_out_, &active_out_, &ratio_out_})
            if (v->size() != n)
                v->assign(n, 0.f);
        if (color_out_.size() != n)
            color_out_.assign(n, Rgb(0.f));
        samples_ = rays_total_ = nan_ = active_ = resolved_ = 0;
        shadow_.reset();
        fused_ = p_.prev_threshold && have_prev_;
        if (fused_)
            for (int c = 0; c < 3; ++c)
                threshold_[size_t(c)] = p_.threshold_scale * prev_avg_[size_t(c)];
    }

    /// Only radiance, except texture_average: texture existence, object id and shadow bits of
    /// the primary hit and the secondary hit's object id (the TextureKey).
    uint32_t attributes_used() const override {
        return p_.texture_average ? kAttrPrimary | kAttrTexture | kAttrSecondary : kAttrNone;
    }

    int stage_count() const override { return fused_ ? 2 : 3; }

    std::string stage_name(int stage) const override {
        if (stage == 0)
            return "pattern";
        if (fused_)
            return "gradient+supersample";
        return stage == 1 ? "gradient" : "supersample";
    }

    void run_tile(int stage, const PixelRect &tile, const SampleSource &source) override {
        if (tile.x0 >= tile.x1 || tile.y0 >= tile.y1)
            return;
        if (stage == 0) {
            trace_pattern(tile, source);
        } else if (stage == 1) {
            gradients(tile);
            if (fused_)
                supersample(tile, source);
        } else {
            supersample(tile, source);
        }
    }

    void end_stage(int stage, const SampleSource &) override {
        if (stage == 1 && !fused_) {
            frame_avg_ = average_gradient();
            for (int c = 0; c < 3; ++c)
                threshold_[size_t(c)] = p_.threshold_scale * frame_avg_[size_t(c)];
        }
    }

    void end_frame(FrameResult &r) override {
        if (!diagnostics())
            drop_diagnostics(r);  // before reset(), which would zero them
        r.reset(width_, height_);
        // Tiles of a cancelled frame that never resolved stay as the result's reset left them.
        r.color.swap(color_out_);
        r.rays.swap(rays_out_);
        if (diagnostics()) {
            r.layer("active").data.swap(active_out_);
            r.layer("gradient").data.swap(ratio_out_);
        }
        r.samples = samples_.load();
        r.rays_total = rays_total_.load();
        shadow_.write(r);
        r.nan_samples = nan_.load();
        r.shaded = 0;
        r.active_unit = "pixels";
        const uint64_t pixels = uint64_t(width_) * height_;
        r.active_fraction = pixels ? double(active_.load()) / double(pixels) : 0.0;
        // The next frame's threshold (prev_threshold): this frame's average, when complete.
        have_prev_ = resolved_.load() == pixels;
        if (have_prev_)
            prev_avg_ = fused_ ? average_gradient() : frame_avg_;
    }

  private:
    // ----------------------------------------------------------------------------------------
    // Layout

    void allocate(uint32_t w, uint32_t h) {
        width_ = w;
        height_ = h;
        allocated_ = true;
        for (auto &g : sites_)
            g.clear();
        for (auto &g : texture_)
            g.clear();
        if (w == 0 || h == 0)
            return;
        if constexpr (kTri) {
            // Odd vertical lines i = 1, 3, ... <= w; odd rows j <= h; even corners.
            lattice_[0] = {1, w - ((w - 1) & 1u), 0, h - 1, 1, 0};
            lattice_[1] = {0, w - 1, 1, h - ((h - 1) & 1u), 0, 1};
            lattice_[2] = {0, w & ~1u, 0, h & ~1u, 1, 1};
        } else {
            lattice_[0] = {0, w, 0, h - 1, 0, 0};  // left / right edges
            lattice_[1] = {0, w - 1, 0, h, 0, 0};  // top / bottom edges
        }
        for (int k = 0; k < kKinds; ++k) {
            const Lattice &l = lattice_[size_t(k)];
            const uint32_t cw = ((l.i1 - l.i0) >> l.si) + 1, ch = ((l.j1 - l.j0) >> l.sj) + 1;
            sites_[size_t(k)].resize(cw, ch);
            if (p_.texture_average)
                texture_[size_t(k)].resize(cw, ch);
        }
        pix_ = BlockedLayout(w, h);
        pixel_.assign(pix_.size(), PixelData{});
        for (int c = 0; c < 3; ++c)
            gsum_[size_t(c)].assign(c < nch_ ? pix_.size() : 0, 0.f);
        npairs_.assign(pix_.size(), 0);
        extra_.assign(pix_.size(), ExtraSum{});
    }

    /// Compact storage coordinates of lattice site (i, j) of a kind: FLIPTRI keeps only odd
    /// vertical lines, odd horizontal lines and even corners, so it halves the coordinate.
    static uint32_t ci(SiteKind k, uint32_t i) {
        return (kTri && k != SiteKind::Horizontal) ? i >> 1 : i;
    }
    static uint32_t cj(SiteKind k, uint32_t j) {
        return (kTri && k != SiteKind::Vertical) ? j >> 1 : j;
    }
    Site &site(SiteKind k, uint32_t i, uint32_t j) { return sites_[size_t(k)](ci(k, i), cj(k, j)); }
    const Site &site(SiteKind k, uint32_t i, uint32_t j) const {
        return sites_[size_t(k)](ci(k, i), cj(k, j));
    }

    /// Sub-pixel offset of a vertical site along y, or of a horizontal site along x.
    static float offset(SiteKind kind, uint32_t i, uint32_t j) {
        if constexpr (!kTri) {
            // Pixel (i, j)'s left sample is the base left one (y 2/3) for even i and the
            // mirrored right one (y 1/3) for odd i; odd rows mirror y. Likewise along x for the
            // top sample: the base top (x 1/3) or the mirrored bottom (x 2/3).
            const bool even = ((i + j) & 1u) == 0;
            if (kind == SiteKind::Vertical)
                return even ? kTwoThirds : kThird;
            return even ? kThird : kTwoThirds;
        } else {
            // The vertical line i (odd) carries the right sample (y 1/3) of pixel i - 1,
            // mirrored in odd rows; the horizontal line j (odd) the bottom sample (x 2/3) of
            // pixel row j - 1, mirrored in odd columns.
            if (kind == SiteKind::Vertical)
                return (j & 1u) ? kTwoThirds : kThird;
            if (kind == SiteKind::Horizontal)
                return (i & 1u) ? kThird : kTwoThirds;
            return 0.f;
        }
    }

    /// The camera sample of lattice site (i, j), clamped into the image (header comment).
    CameraSample site_sample(SiteKind kind, uint32_t i, uint32_t j) const {
        CameraSample cs;
        cs.px = i;
        cs.py = j;
        cs.fx = kind == SiteKind::Horizontal ? offset(kind, i, j) : 0.f;
        cs.fy = kind == SiteKind::Vertical ? offset(kind, i, j) : 0.f;
        uint32_t border = 0;
        if (i >= width_) {
            cs.px = width_ - 1;
            cs.fx = kBelowOne;
            border |= 1;
        }
        if (j >= height_) {
            cs.py = height_ - 1;
            cs.fy = kBelowOne;
            border |= 2;
        }
        // Unique per owner pixel: 4 per kind (the border variants).
        cs.index = uint32_t(kind) * 4 + border;
        return cs;
    }

    /// Pixels whose pattern uses site (i, j) (2 for an edge, 4 for a corner; fewer on the
    /// image border).
    uint32_t users(SiteKind kind, uint32_t i, uint32_t j) const {
        const uint32_t ux = (i > 0 ? 1u : 0u) + (i < width_ ? 1u : 0u);
        const uint32_t uy = (j > 0 ? 1u : 0u) + (j < height_ ? 1u : 0u);
        if (kind == SiteKind::Vertical)
            return ux;
        if (kind == SiteKind::Horizontal)
            return uy;
        return ux * uy;
    }

    /// 1 / users(kind, i, j), from a table (users is 1, 2 or 4): the same values, no division.
    float inv_users(SiteKind kind, uint32_t i, uint32_t j) const {
        static constexpr float kInverse[5] = {0.f, 1.f, 0.5f, 1.f / 3.f, 0.25f};
        return kInverse[users(kind, i, j)];
    }

    /// The pattern of pixel (x, y): FLIPTRI corner, vertical edge, horizontal edge; FLIPQUAD
    /// left, top, right, bottom (the order of pairs_).
    template <class Fn>
    static void for_pixel_sites(uint32_t x, uint32_t y, Fn &&fn) {
        if constexpr (kTri) {
            fn(0, SiteKind::Corner, x + (x & 1u), y + (y & 1u));
            fn(1, SiteKind::Vertical, x | 1u, y);
            fn(2, SiteKind::Horizontal, x, y | 1u);
        } else {
            fn(0, SiteKind::Vertical, x, y);
            fn(1, SiteKind::Horizontal, x, y);
            fn(2, SiteKind::Vertical, x + 1, y);
            fn(3, SiteKind::Horizontal, x, y + 1);
        }
    }

    /// Calls fn(i, j) for every site of a kind whose owner pixel -- the site's lattice
    /// coordinate clamped to the last column/row -- lies in [ox0, ox1) x [oy0, oy1), by rows.
    template <class Fn>
    void for_owned_sites(const Lattice &l, uint32_t ox0, uint32_t ox1, uint32_t oy0, uint32_t oy1,
                         Fn &&fn) const {
        const uint32_t ie = std::min(ox1 == width_ ? width_ + 1 : ox1, l.i1 + 1);
        const uint32_t je = std::min(oy1 == height_ ? height_ + 1 : oy1, l.j1 + 1);
        auto first = [](uint32_t a, uint32_t start, uint32_t shift) {
            if (a <= start)
                return start;
            return (shift && ((a - start) & 1u)) ? a + 1 : a;
        };
        for (uint32_t j = first(oy0, l.j0, l.sj); j < je; j += 1u << l.sj)
            for (uint32_t i = first(ox0, l.i0, l.si); i < ie; i += 1u << l.si)
                fn(i, j);
    }

    // ----------------------------------------------------------------------------------------
    // Stage "pattern": the primary pattern, each sample traced by its owner's tile

    struct SiteTarget {
        Site *site = nullptr;
        TextureKey *texture = nullptr;
        float inv_users = 1;
    };

    void flush(Packet<SiteTarget> &pk, const SampleSource &source, TileCounts &counts) const {
        if (!pk.n)
            return;
        source.evaluate_batch(std::span<const CameraSample>(pk.cs.data(), pk.n),
                              std::span<Sample>(pk.out.data(), pk.n));
        counts.shadow.add(std::span<const Sample>(pk.out.data(), pk.n));
        for (uint32_t k = 0; k < pk.n; ++k) {
            const Sample &s = pk.out[k];
            const SiteTarget &t = pk.target[k];
            const bool finite = s.radiance.is_finite();
            t.site->radiance = s.radiance;
            t.site->luminance = finite ? s.radiance.luminance() : std::nanf("");
            t.site->ray_share = float(s.rays) * t.inv_users;
            if (t.texture) {
                *t.texture = {};
                if (s.first_hit && s.first_hit->primary.has_texture) {
                    const HitAttributes &a = *s.first_hit;
                    t.texture->object = a.primary.object_id;
                    t.texture->key =
                        a.primary.shadow_bits ^ (uint32_t(a.secondary.object_id + 1) * 0x9e3779b1u);
                }
            }
            counts.rays += s.rays;
            counts.nan += finite ? 0 : 1;
        }
        counts.samples += pk.n;
        pk.n = 0;
    }

    void trace_pattern(const PixelRect &tile, const SampleSource &source) {
        TileCounts counts;
        Packet<SiteTarget> edges, corners;
        // 2x2 blocks (aligned to even coordinates) in row-major order; within a block the sites
        // its pixels own: vertical then horizontal edges into the edge packets (FLIPTRI: the
        // block's inner cross, 4 samples), corners into their own packets (Fig. 3).
        for (uint32_t by = tile.y0 & ~1u; by < tile.y1; by += 2)
            for (uint32_t bx = tile.x0 & ~1u; bx < tile.x1; bx += 2) {
                const uint32_t ox0 = std::max(bx, tile.x0), ox1 = std::min(bx + 2, tile.x1);
                const uint32_t oy0 = std::max(by, tile.y0), oy1 = std::min(by + 2, tile.y1);
                for (int k = 0; k < kKinds; ++k) {
                    const SiteKind kind = SiteKind(k);
                    Packet<SiteTarget> &pk = kind == SiteKind::Corner ? corners : edges;
                    for_owned_sites(
                        lattice_[size_t(k)], ox0, ox1, oy0, oy1, [&](uint32_t i, uint32_t j) {
                            pk.cs[pk.n] = site_sample(kind, i, j);
                            SiteTarget &t = pk.target[pk.n];
                            t.site = &site(kind, i, j);
                            t.texture = p_.texture_average
                                            ? &texture_[size_t(k)](ci(kind, i), cj(kind, j))
                                            : nullptr;
                            t.inv_users = inv_users(kind, i, j);
                            if (++pk.n == kPacket)
                                flush(pk, source, counts);
                        });
                }
            }
        flush(edges, source, counts);
        flush(corners, source, counts);
        samples_ += counts.samples;
        shadow_.add(counts.shadow);
        rays_total_ += counts.rays;
        nan_ += counts.nan;
    }

    // ----------------------------------------------------------------------------------------
    // Stage "gradient": pairwise gradients; end_stage reduces the frame average

    void gradients(const PixelRect &tile) {
        std::array<const Site *, K> s{};
        std::array<std::array<float, 3>, K> v{};
        std::array<bool, K> finite{};
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x) {
                const size_t pi = pix_(x, y);
                PixelData &d = pixel_[pi];
                std::array<float, K> share{};
                for_pixel_sites(x, y, [&](int k, SiteKind kind, uint32_t i, uint32_t j) {
                    s[size_t(k)] = &site(kind, i, j);
                    if (p_.share_weights)
                        share[size_t(k)] = inv_users(kind, i, j);
                });
                // The pattern's part of the resolve (equal weights), while the sites are at hand.
                bool all_finite = true;
                d.sum = Rgb(0.f);
                d.good = 0;
                d.share_sum = Rgb(0.f);
                d.share = 0;
                d.rays = 0;
                for (int k = 0; k < K; ++k) {
                    const Site &sk = *s[size_t(k)];
                    const bool ok = !std::isnan(sk.luminance);  // finite radiance
                    // (A luminance overflowing to inf is left out of the gradients only.)
                    finite[size_t(k)] = nch_ == 1 ? std::isfinite(sk.luminance) : ok;
                    all_finite = all_finite && finite[size_t(k)];
                    d.rays += sk.ray_share;
                    if (ok) {
                        d.sum += sk.radiance;
                        ++d.good;
                        if (p_.share_weights) {
                            d.share_sum += sk.radiance * share[size_t(k)];
                            d.share += share[size_t(k)];
                        }
                    }
                    if (nch_ == 1)
                        v[size_t(k)][0] = sk.luminance;
                    else
                        v[size_t(k)] = {sk.radiance.r, sk.radiance.g, sk.radiance.b};
                }
                if (p_.texture_average)
                    texture_average(x, y, finite, v);
                uint8_t pairs = 0;
                for (int c = 0; c < nch_; ++c) {
                    float gmax = 0, gsum = 0;
                    pairs = 0;
                    for (const Pair &pr : pairs_) {
                        if (!all_finite && (!finite[size_t(pr.a)] || !finite[size_t(pr.b)]))
                            continue;
                        const float g =
                            std::fabs(v[size_t(pr.a)][size_t(c)] - v[size_t(pr.b)][size_t(c)]) *
                            pr.inv_dist;
                        gmax = std::max(gmax, g);
                        gsum += g;
                        ++pairs;
                    }
                    d.gmax[size_t(c)] = gmax;
                    gsum_[size_t(c)][pi] = gsum;
                }
                npairs_[pi] = pairs;
            }
    }

    /// Section 4, Fig. 6: samples of the pattern on one textured surface (same object, shadow
    /// bits and reflected object) take their mean value, so the texture's own detail gives no
    /// gradient while other boundaries still do.
    void texture_average(uint32_t x, uint32_t y, const std::array<bool, K> &finite,
                         std::array<std::array<float, 3>, K> &v) const {
        std::array<TextureKey, K> key{};
        for_pixel_sites(x, y, [&](int k, SiteKind kind, uint32_t i, uint32_t j) {
            key[size_t(k)] = texture_[size_t(kind)](ci(kind, i), cj(kind, j));
        });
        std::array<bool, K> done{};
        for (int a = 0; a < K; ++a) {
            if (done[size_t(a)] || !finite[size_t(a)] || key[size_t(a)].object < 0)
                continue;
            auto same = [&](int b) {
                return !done[size_t(b)] && finite[size_t(b)] &&
                       key[size_t(b)].object == key[size_t(a)].object &&
                       key[size_t(b)].key == key[size_t(a)].key;
            };
            std::array<float, 3> sum = v[size_t(a)];
            int n = 1;
            for (int b = a + 1; b < K; ++b)
                if (same(b)) {
                    for (int c = 0; c < 3; ++c)
                        sum[size_t(c)] += v[size_t(b)][size_t(c)];
                    ++n;
                }
            if (n == 1)
                continue;
            for (int c = 0; c < 3; ++c)
                sum[size_t(c)] /= float(n);
            for (int b = K - 1; b > a; --b)
                if (same(b)) {
                    v[size_t(b)] = sum;
                    done[size_t(b)] = true;
                }
            v[size_t(a)] = sum;
            done[size_t(a)] = true;
        }
    }

    /// Mean pairwise gradient of the frame, per channel (luminance: [0]); serial, fixed order,
    /// over the compact per-pixel sums.
    std::array<double, 3> average_gradient() const {
        std::array<double, 3> avg{0, 0, 0};
        uint64_t pairs = 0;
        for (uint8_t n : npairs_)
            pairs += n;
        if (pairs == 0)
            return avg;
        for (int c = 0; c < nch_; ++c) {
            double sum = 0;
            for (float g : gsum_[size_t(c)])
                sum += g;
            avg[size_t(c)] = sum / double(pairs);
        }
        return avg;
    }

    // ----------------------------------------------------------------------------------------
    // Stage "supersample": decision, extra samples and resolve

    void supersample(const PixelRect &tile, const SampleSource &source) {
        const bool diag = diagnostics();
        TileCounts counts;
        Packet<ExtraSum *> pk;
        auto flush_extra = [&] {
            if (!pk.n)
                return;
            source.evaluate_batch(std::span<const CameraSample>(pk.cs.data(), pk.n),
                                  std::span<Sample>(pk.out.data(), pk.n));
            counts.shadow.add(std::span<const Sample>(pk.out.data(), pk.n));
            for (uint32_t k = 0; k < pk.n; ++k) {
                ExtraSum &e = *pk.target[k];
                const Sample &smp = pk.out[k];
                e.rays += smp.rays;
                counts.rays += smp.rays;
                if (smp.radiance.is_finite()) {
                    e.sum += smp.radiance;
                    ++e.good;
                } else {
                    ++counts.nan;
                }
            }
            counts.samples += pk.n;
            pk.n = 0;
        };
        auto resolve = [&](uint32_t x, uint32_t y, const PixelData &d, const ExtraSum *e) {
            const size_t idx = size_t(y) * width_ + x;
            Rgb sum = d.sum;
            uint32_t n = d.good;
            float rays = d.rays;
            if (e && p_.share_weights) {
                // Each pattern sample weighs its share of the pixel (1/4 for a corner, 1/2 for
                // an edge), each extra sample 1.
                rays_out_[idx] = rays + float(e->rays);
                const float w = d.share + float(e->good);
                color_out_[idx] = w > 0.f ? (d.share_sum + e->sum) / w : Rgb(0.f);
                return;
            }
            if (e) {
                sum += e->sum;
                n += e->good;
                rays += float(e->rays);
            }
            color_out_[idx] = n ? sum / float(n) : Rgb(0.f);
            rays_out_[idx] = rays;
        };
        // Decide; resolve inactive pixels at once, trace the active ones' extra samples 2x2
        // block by block (neighbouring pixels' packets are coherent).
        for (uint32_t by = tile.y0 & ~1u; by < tile.y1; by += 2)
            for (uint32_t bx = tile.x0 & ~1u; bx < tile.x1; bx += 2)
                for (uint32_t y = std::max(by, tile.y0); y < std::min(by + 2, tile.y1); ++y)
                    for (uint32_t x = std::max(bx, tile.x0); x < std::min(bx + 2, tile.x1); ++x) {
                        const size_t pi = pix_(x, y);
                        const PixelData &d = pixel_[pi];
                        bool active = false;
                        for (int c = 0; c < nch_; ++c)
                            active = active || double(d.gmax[size_t(c)]) > threshold_[size_t(c)];
                        const size_t idx = size_t(y) * width_ + x;
                        if (diag) {  // the "gradient" layer (a division per channel)
                            float ratio = 0;
                            for (int c = 0; c < nch_; ++c) {
                                const double t = threshold_[size_t(c)];
                                const float g = d.gmax[size_t(c)];
                                const float rc =
                                    t > 0 ? float(std::min(double(g) / t, double(kRatioCap)))
                                          : (g > 0 ? kRatioCap : 0.f);
                                ratio = std::max(ratio, rc);
                            }
                            ratio_out_[idx] = ratio;
                        }
                        active_out_[idx] = active ? 1.f : 0.f;
                        if (!active) {
                            resolve(x, y, d, nullptr);
                            continue;
                        }
                        ++counts.active;
                        ExtraSum &e = extra_[pi];
                        e = {};
                        for (uint32_t k = 0; k < extra_base_.size(); ++k) {
                            CameraSample &cs = pk.cs[pk.n];
                            cs.px = x;
                            cs.py = y;
                            cs.fx = (x & 1u) ? 1.f - extra_base_[k].x : extra_base_[k].x;
                            cs.fy = (y & 1u) ? 1.f - extra_base_[k].y : extra_base_[k].y;
                            cs.index = kFirstExtraIndex + k;
                            pk.target[pk.n] = &e;
                            if (++pk.n == kPacket)
                                flush_extra();
                        }
                    }
        flush_extra();
        // Resolve the active pixels: pattern and extra samples (box filter; equal weights, or
        // the pattern samples' shares with share_weights).
        if (counts.active)
            for (uint32_t y = tile.y0; y < tile.y1; ++y)
                for (uint32_t x = tile.x0; x < tile.x1; ++x)
                    if (active_out_[size_t(y) * width_ + x] != 0.f) {
                        const size_t pi = pix_(x, y);
                        resolve(x, y, pixel_[pi], &extra_[pi]);
                    }
        samples_ += counts.samples;
        shadow_.add(counts.shadow);
        rays_total_ += counts.rays;
        nan_ += counts.nan;
        active_ += counts.active;
        resolved_ += uint64_t(tile.width()) * tile.height();
    }

    struct Pair {
        int a = 0, b = 0;
        float inv_dist = 0;  ///< 1 / distance of the two samples, in pixels
    };

    const Params p_;
    const int nch_;  ///< gradient channels (1: luminance, 3: RGB)
    std::array<Pair, K *(K - 1) / 2> pairs_{};
    std::vector<Vec2f> extra_base_;  ///< RGSS positions of a pixel with even x and y
    uint32_t width_ = 0, height_ = 0;
    bool allocated_ = false;
    std::array<Lattice, 3> lattice_{};                ///< by SiteKind
    std::array<BlockedGrid<Site>, 3> sites_;          ///< by SiteKind
    std::array<BlockedGrid<TextureKey>, 3> texture_;  ///< texture_average only
    // Per pixel, in 8x8 blocks (pix_): the gradient pass's results, its sums (compact, for the
    // serial reduction of the frame average), and the active pixels' extra samples.
    BlockedLayout pix_;
    LargeVector<PixelData> pixel_;
    std::array<LargeVector<float>, 3> gsum_;  ///< sum of the pixel's gradients, per channel
    LargeVector<uint8_t> npairs_;             ///< finite pairs in gsum_
    LargeVector<ExtraSum> extra_;
    // Row-major outputs, swapped into the FrameResult by end_frame.
    std::vector<Rgb> color_out_;
    std::vector<float> rays_out_, active_out_, ratio_out_;
    std::atomic<uint64_t> samples_{0}, rays_total_{0}, nan_{0}, active_{0}, resolved_{0};
    FrameShadowRays shadow_;
    bool fused_ = false;      ///< this frame uses the previous threshold (2 stages)
    bool have_prev_ = false;  ///< prev_avg_ holds a complete frame's average
    std::array<double, 3> prev_avg_{0, 0, 0};   ///< previous frame's average gradient
    std::array<double, 3> frame_avg_{0, 0, 0};  ///< this frame's (three-pass scheme)
    std::array<double, 3> threshold_{0, 0, 0};  ///< in use this frame (scale applied)
};

std::vector<PluginParamSpec> flip_params(int extra_default) {
    return {
        {"extra", double(extra_default), 0, 64, true,
         "RGSS samples added to a pixel whose gradient exceeds the threshold (a square number, "
         "rotated n x n grid; 0: pattern only, \"active\" marks what would be supersampled)"},
        {"prev_threshold", 0, 0, 1, true,
         "1: threshold = the previous frame's average gradient, gradients and extra samples in "
         "one stage (paper section 3)"},
        {"threshold_scale", 1, 0, 1000, false,
         "multiplies the frame-average gradient threshold (1: the paper's)"},
        {"per_channel", 0, 0, 1, true,
         "gradients per colour channel, each with its own average threshold (0: luminance)"},
        {"texture_average", 0, 0, 1, true,
         "samples on one textured surface enter the gradient with their mean (section 4, Fig. 6; "
         "needs attribute vectors)"},
        {"share_weights", 0, 0, 1, true,
         "1: in a supersampled pixel each pattern sample weighs its share of the pixel (corner "
         "1/4, edge 1/2) and each extra sample 1; 0: equal weights (the paper's)"},
    };
}

Params flip_params_from(const std::string &name, const PluginParams &pp) {
    Params p;
    const int extra = pp.get_int("extra");
    const int n = int(std::lround(std::sqrt(double(std::max(extra, 0)))));
    if (extra < 0 || n * n != extra)
        throw std::invalid_argument("sampler " + name + ": extra=" + std::to_string(extra) +
                                    " must be a square number (0, 1, 4, 9, 16, 25, 36, 49, 64) "
                                    "for the rotated-grid (RGSS) pattern");
    p.extra = uint32_t(extra);
    p.prev_threshold = pp.get_bool("prev_threshold");
    p.threshold_scale = pp.get("threshold_scale");
    p.per_channel = pp.get_bool("per_channel");
    p.texture_average = pp.get_bool("texture_average");
    p.share_weights = pp.get_bool("share_weights");
    return p;
}

}  // namespace

PluginInfo fliptri_plugin_info() {
    PluginInfo info;
    info.name = "fliptri";
    info.kind = PluginKind::Frame;
    info.summary =
        "Shevtsov et al.: FLIPTRI pattern (1.25 rays/pixel) shared over 2x2 blocks, "
        "pairwise gradients against the frame average, RGSS extra samples";
    info.params = flip_params(4);
    info.make = [](const PluginParams &p) -> std::unique_ptr<PixelSampler> {
        return std::make_unique<FlipSampler<Pattern::FlipTri>>(flip_params_from("fliptri", p));
    };
    return info;
}

PluginInfo flipquad_plugin_info() {
    PluginInfo info;
    info.name = "flipquad";
    info.kind = PluginKind::Frame;
    info.summary =
        "Shevtsov et al.: FLIPQUAD pattern (2 rays/pixel) shared over 2x2 blocks, "
        "pairwise gradients against the frame average, 16 rotated-grid extra samples";
    info.params = flip_params(16);
    info.make = [](const PluginParams &p) -> std::unique_ptr<PixelSampler> {
        return std::make_unique<FlipSampler<Pattern::FlipQuad>>(flip_params_from("flipquad", p));
    };
    return info;
}

}  // namespace tessera::sampling
