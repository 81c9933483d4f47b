// `jin`: selective and adaptive supersampling (B. Jin, I. Ihm, B. Chang, C. Park, W. Lee,
// S. Jung, "Selective and Adaptive Supersampling for Real-Time Ray Tracing", HPG 2009;
// papers/000_31441cf1add1ec7c.txt).
//
// Algorithm (paper section 4), as three barrier stages, the paper's three kernels (4.3):
//  1. presample (Presampler, 4.1.2 / 4.3.1): one ray through every pixel centre (fx = fy = 0.5,
//     sample index 0). Its colour fills the shaded colour image and, as in the paper's
//     implementation, also serves as the colour reference map (one array here); its first hit
//     fills the geometry attribute map of Table 1: object id, surface normal, shadow count and
//     texture existence at the primary hit and at the first reflection/refraction hit.
//  2. test (ActSubPixDetector, 4.1.3 / 4.2.2 / 4.3.2): every pixel is split into four subpixels;
//     each is compared with the three neighbour pixels on its quadrant's side (Fig. 4: the
//     top-left subpixel with W, N and NW, ...; the "pessimistic" test of 4.1.1, Fig. 3b).
//     Step 1 collects the geometry attributes that disagree with any of the three neighbours and
//     takes the smallest of their thresholds, or tau_col when none disagrees. Step 2 is
//     Mitchell's contrast test on the colour references of the pixel and its three neighbours:
//     C_l = (I_l^max - I_l^min) / (I_l^max + I_l^min) per channel l = R, G, B against
//     tau * (1.36, 1.02, 2.04); any channel at or over its threshold makes the subpixel active.
//     The active subpixels of the tile are then packed into the tile's compact list (4.3.2).
//  3. supersample (ExtraSampler, 4.1.4 / 4.3.3): four stratified jittered samples per packed
//     active subpixel (a 2 x 2 grid of quarter-pixel cells, one jittered point in each), traced in
//     batches through SampleSource::evaluate_batch; the pixel resolves to
//        colour = (4 - n_active) / 4 * centre colour + 1/16 * sum of the 4 n_active extra samples
//     (4.1.4: "the shaded pixel color ... is transferred to its inactive subpixels, each weighted
//     by 1/4 ... accumulating each supersampled color with a weight 1/16"; 4.3.2 multiplies the
//     centre colour by (4 - n_asp) / 4). So each subpixel is a quarter of the pixel: an inactive
//     one takes the centre colour (nearest filtering, section 6), an active one the mean of its
//     four samples, and a fully active pixel is the mean of its 16 extra samples.
//
// Attribute comparisons (4.2.2), all numbered as the bits of the "attributes" layer:
//   bit 0 primary object id (tau_poid)    bit 4 secondary object id (tau_soid)
//   bit 1 primary surface normal (tau_psn) bit 5 secondary surface normal (tau_ssn)
//   bit 2 primary shadow count (tau_psc)   bit 6 secondary shadow count (tau_ssc)
//   bit 3 primary texture (tau_pte)        bit 7 secondary texture (tau_ste)
// Object ids and shadow counts differ when unequal. Texture existence is "set regardless of
// neighbours" when the subpixel's own pixel has a texture. Normals: see deviation 2.
//
// Defaults are the paper's (section 5, Table 2 and its caption): tau_col = tau_pte = tau_ste =
// tau_alpha = 0.6, tau_poid = tau_soid = 0.05, tau_psn = tau_ssn = 0.06, tau_psc = tau_ssc = 0.06.
//
// Diagnostics (FrameResult layers, one float per pixel):
//   "active_subpixels"  0..4 active subpixels (the colour code of Figs. 1 and 7: black, red, green,
//                       blue, white);
//   "active_mask"       which ones: bit q for quadrant q = qx + 2 qy (qx = 1: the half of larger
//                       x, qy = 1: the half of larger y, i.e. the lower half on the film);
//   "test"              what decided, over the pixel's active subpixels (the largest code):
//                       0 none active, 1 colour test with tau_col, 2 colour test with a threshold
//                       picked by disagreeing geometry attributes, 3 colour test with focus_tau;
//   "attributes"        bit mask (above) of the geometry attributes that disagreed for any of the
//                       pixel's subpixels, active or not (the "possibly problematic" subpixels of
//                       Fig. 6b);
//   "samples"           camera samples of the pixel (1 + 4 n_active);
// plus FrameResult::rays (rays per pixel). active_fraction counts subpixels.
//
// Deviations from the paper, and why:
//  1. CPU staging. The stages keep the kernels' barriers, over 8 x 8 tiles instead of CUDA blocks.
//     The packed list of active subpixels is per tile, in a contiguous slab of the tile's own
//     (no atomic append to one global buffer, which would make the order, and so the batches,
//     depend on the thread count); one thread resolves a tile's pixels in order, so the paper's
//     "master subpixel" marking is implicit (entries of a pixel are consecutive).
//  2. The surface normal test. The paper says normals differ "if their cross product is less than
//     a preset value" and gives no value; a cross product shrinks as normals agree, so this is
//     read as the dot product: two unit normals differ when dot(n_a, n_b) < normal_dot (default
//     0.9, an angle of about 25.8 degrees). Normals are compared only when both rays hit a
//     surface that has a normal (an escaped ray is caught by the object id).
//  3. A threshold of 1 turns its attribute off: the attribute is left out of the disagreement
//     list (so the subpixel falls back to tau_col), which is how section 4.2.2 ("turning off some
//     other low-priority attributes by setting their thresholds to one") and Fig. 7 ("all
//     geometry attributes turned off", colour measure alone) use it. With the threshold rule
//     alone a disagreeing attribute at 1 would instead forbid supersampling there.
//  4. The contrast test compares with ">=" so that tau = 0 always supersamples (4.1.3: "when it
//     is set to zero, those pixels are always supersampled"); tau = 1 never fires because every
//     contrast is <= 1 < 1.02. The contrast is taken over the four colours (pixel + its three
//     neighbours), as the ActSubPixDetector does (4.3.2); 0 / 0 counts as contrast 0.
//  5. Shadow count = number of set shadow bits (the number of occluded lights; lights beyond 31
//     share a bit in SurfaceAttributes, so counts saturate there).
//  6. Image borders (not discussed in the paper): a neighbour outside the image is the pixel
//     itself, i.e. no disparity across the border.
//  7. Focus (section 5, "Fairy focused": "the geometry attributes between pixels differ only
//     when the designated Object IDs are involved"): with focus = ID (and focus_count ids from
//     it) a pair of pixels contributes geometry disagreements only if one of them hit a focus
//     object (primary or secondary id), and texture existence only counts on a pixel that did.
//     Added: focus_tau, a ceiling on the threshold of every subpixel whose pixel or any of its
//     three neighbours hit a focus object (1 = no ceiling, the paper's behaviour).
//  8. bilinear = 1 is the texture-filtering option of section 6: an inactive subpixel takes the
//     bilinear interpolation, at the subpixel's centre, of its pixel and the three neighbours of
//     its quadrant (weights 9/16, 3/16, 3/16, 1/16) instead of the pixel's centre colour.
//  9. Non-finite samples are dropped and counted: a non-finite centre sample becomes black; an
//     active subpixel averages its finite samples (the centre colour when none is finite).
//     Without attribute vectors (a source that does not provide them) only the colour test runs.
// The jitter is a pure function of (seed, pixel, sample index): index 0 is the centre sample,
// index 1 + 4 q + s the sample in cell s of subpixel q (Owen-scrambled Sobol, sampling/sequence.h),
// so frames are bit-identical for any thread count.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <vector>

#include "sampling/plugins/plugins.h"
#include "sampling/sequence.h"

namespace tessera::sampling {

namespace {

/// The bits of the geometry attribute mask (Table 1 order, primary then secondary).
enum : uint8_t {
    kPoid = 1u << 0,
    kPsn = 1u << 1,
    kPsc = 1u << 2,
    kPte = 1u << 3,
    kSoid = 1u << 4,
    kSsn = 1u << 5,
    kSsc = 1u << 6,
    kSte = 1u << 7,
};

/// Mitchell's (0.4, 0.3, 0.6) rescaled so that tau = 0.3 gives it back (section 4.2.2).
constexpr float kContrastScale[3] = {1.36f, 1.02f, 2.04f};

/// Codes of the "test" layer.
enum : uint8_t { kTestNone = 0, kTestColour = 1, kTestGeometry = 2, kTestFocus = 3 };

/// One pixel of the geometry attribute map (section 4.3.1 packs it into 32 bytes).
struct GeoAttributes {
    int32_t object_id[2] = {-1, -1};   ///< primary, secondary (-1: no hit)
    Vec3f normal[2];                   ///< unit shading normals (zero when absent)
    uint8_t shadow_count[2] = {0, 0};  ///< occluded lights at the primary / secondary hit
    uint8_t flags = 0;                 ///< kHas* bits below
};
enum : uint8_t {
    kHasPrimaryTexture = 1u << 0,
    kHasSecondaryTexture = 1u << 1,
    kHasPrimaryNormal = 1u << 2,
    kHasSecondaryNormal = 1u << 3,
    kInFocus = 1u << 4,  ///< the primary or secondary hit is a focus object
};

/// Typed parameters (defaults: the paper's, see the registry entry below).
struct JinParams {
    /// Thresholds in attribute-bit order: poid, psn, psc, pte, soid, ssn, ssc, ste.
    std::array<float, 8> tau{};
    float tau_col = 0.6f;
    float normal_dot = 0.9f;
    int64_t focus = -1;  ///< first focus object id; -1: off
    int64_t focus_count = 1;
    float focus_tau = 1.f;
    bool bilinear = false;
    uint32_t seed = 0;
};

/// Camera samples per evaluate_batch call: 16 subpixels of 4 samples (a tile's packed list is
/// cut into such chunks; the presample batches a tile's pixel centres the same way).
constexpr uint32_t kBatch = 64;

class JinSampler final : public PixelSampler {
  public:
    explicit JinSampler(const JinParams &p) : p_(p) {
        for (int k = 0; k < 8; ++k)
            if (p_.tau[size_t(k)] < 1.f)
                enabled_ |= uint8_t(1u << k);
    }

    void begin_frame(const SampleSource &source) override {
        attributes_ = source.provides_attributes();
        shadow_.reset();
        // The presample stage (re)initialises every per-pixel value of its tile, in parallel,
        // and stamps the pixel with the frame number; only a size change clears here (serial).
        if (source.width() != width_ || source.height() != height_ || centre_.empty()) {
            width_ = source.width();
            height_ = source.height();
            const size_t n = size_t(width_) * height_;
            // Packed entries are pixel index * 4 + quadrant in 32 bits.
            if (n > (size_t(1) << 30))
                throw std::length_error("sampler jin: images above 2^30 pixels are not supported");
            centre_.assign(n, Rgb(0.f));
            color_.assign(n, Rgb(0.f));
            geo_.assign(n, GeoAttributes{});
            rays_.assign(n, 0.f);
            samples_.assign(n, 0);
            nan_.assign(n, 0);
            mask_.assign(n, 0);
            test_.assign(n, 0);
            disagree_.assign(n, 0);
            packed_.assign(4 * n, 0);
            tile_active_.assign(n, 0);
            stamp_.assign(n, 0);
            frame_ = 0;
        }
        if (++frame_ == 0) {  // wrapped: no stale stamp may match
            std::fill(stamp_.begin(), stamp_.end(), 0u);
            frame_ = 1;
        }
    }

    int stage_count() const override { return 3; }
    std::string stage_name(int stage) const override {
        static const char *const names[] = {"presample", "test", "supersample"};
        return stage >= 0 && stage < 3 ? names[stage] : PixelSampler::stage_name(stage);
    }

    /// Table 1's attributes that an enabled comparison reads: object ids, normals and shadow
    /// counts of the primary hit always (a hit is known by its id); texture existence only with
    /// tau_pte or tau_ste below 1; the secondary hit only when a secondary comparison is
    /// enabled or focus=ID is set (a focus object may be seen in a mirror).
    uint32_t attributes_used() const override {
        uint32_t a = kAttrPrimary;
        if (enabled_ & (kPte | kSte))
            a |= kAttrTexture;
        if ((enabled_ & (kSoid | kSsn | kSsc | kSte)) || p_.focus >= 0)
            a |= kAttrSecondary;
        return a;
    }

    void run_tile(int stage, const PixelRect &tile, const SampleSource &source) override {
        switch (stage) {
            case 0:
                presample(tile, source);
                break;
            case 1:
                test(tile);
                break;
            case 2:
                supersample(tile, source);
                break;
            default:
                break;
        }
    }

    void end_frame(FrameResult &r) override {
        if (!diagnostics())
            drop_diagnostics(r);  // before reset(), which would zero them
        r.reset(width_, height_);
        // Diagnostic layers (null when off). NOTE: layer() appends to a vector, which
        // invalidates references to earlier layers: create every layer first, then point.
        float *active = nullptr, *mask = nullptr, *test = nullptr, *attributes = nullptr,
              *samples = nullptr;
        if (diagnostics()) {
            for (const char *name :
                 {"active_subpixels", "active_mask", "test", "attributes", "samples"})
                r.layer(name);
            active = r.layer("active_subpixels").data.data();
            mask = r.layer("active_mask").data.data();
            test = r.layer("test").data.data();
            attributes = r.layer("attributes").data.data();
            samples = r.layer("samples").data.data();
        }
        uint64_t active_total = 0;
        double rays = 0;
        for (size_t i = 0; i < color_.size(); ++i) {
            if (stamp_[i] != frame_)
                continue;  // a cancelled frame did not reach this pixel: black, no counts
            r.color[i] = color_[i];
            r.rays[i] = rays_[i];
            const int n = std::popcount(unsigned(mask_[i]));
            active_total += uint64_t(n);
            if (active) {
                active[i] = float(n);
                mask[i] = float(mask_[i]);
                test[i] = float(test_[i]);
                attributes[i] = float(disagree_[i]);
                samples[i] = float(samples_[i]);
            }
            r.samples += samples_[i];
            r.nan_samples += nan_[i];
            rays += double(rays_[i]);
        }
        r.rays_total = uint64_t(rays);
        shadow_.write(r);
        r.active_unit = "subpixels";
        r.active_fraction = color_.empty() ? 0.0 : double(active_total) / double(4 * color_.size());
    }

  private:
    size_t index(uint32_t x, uint32_t y) const { return size_t(y) * width_ + x; }

    /// Start of the tile's slab of packed subpixel entries. Tiles form a grid (every tile of a
    /// row of tiles spans the same pixel rows y0..y1, as FrameScheduler's tiles do), so the
    /// ranges [4 (y0 W + x0 h), 4 (y0 W + x1 h)) of a row of tiles partition that row's
    /// 4 W h entries: each tile owns a contiguous slab of capacity 4 w h.
    size_t slab(const PixelRect &t) const {
        return 4 * (size_t(t.y0) * width_ + size_t(t.x0) * t.height());
    }

    bool in_focus(int32_t id) const {
        return p_.focus >= 0 && id >= p_.focus && int64_t(id) < p_.focus + p_.focus_count;
    }

    // ------------------------------------------------------------------------------------
    // Stage 1: one centre sample per pixel -> colour image / colour reference / attribute map.

    void presample(const PixelRect &tile, const SampleSource &source) {
        std::array<CameraSample, kBatch> cs;
        std::array<Sample, kBatch> out;
        const uint32_t tw = tile.width(), count = tile.width() * tile.height();
        tile_active_[index(tile.x0, tile.y0)] = 0;
        for (uint32_t start = 0; start < count; start += kBatch) {
            const uint32_t n = std::min(kBatch, count - start);
            for (uint32_t k = 0; k < n; ++k) {
                CameraSample &c = cs[k];
                c.px = tile.x0 + (start + k) % tw;
                c.py = tile.y0 + (start + k) / tw;
                c.fx = c.fy = 0.5f;
                c.index = 0;
            }
            source.evaluate_batch(std::span<const CameraSample>(cs.data(), n),
                                  std::span<Sample>(out.data(), n));
            shadow_.add(std::span<const Sample>(out.data(), n));
            for (uint32_t k = 0; k < n; ++k) {
                const size_t i = index(cs[k].px, cs[k].py);
                const Sample &s = out[k];
                stamp_[i] = frame_;
                rays_[i] = float(s.rays);
                samples_[i] = 1;
                nan_[i] = 0;
                mask_[i] = test_[i] = disagree_[i] = 0;
                Rgb c = s.radiance;
                if (!c.is_finite()) {
                    c = Rgb(0.f);
                    nan_[i] = 1;
                }
                centre_[i] = c;
                color_[i] = c;
                geo_[i] = attributes_ && s.first_hit ? gather(*s.first_hit) : GeoAttributes{};
            }
        }
    }

    GeoAttributes gather(const HitAttributes &h) const {
        GeoAttributes g;
        const SurfaceAttributes *surf[2] = {&h.primary, &h.secondary};
        for (int k = 0; k < 2; ++k) {
            const SurfaceAttributes &s = *surf[k];
            if (!s.hit())
                continue;
            g.object_id[k] = s.object_id;
            g.shadow_count[k] = uint8_t(std::popcount(s.shadow_bits));
            if (s.has_texture)
                g.flags |= k == 0 ? kHasPrimaryTexture : kHasSecondaryTexture;
            const float len2 = length_squared(s.normal);
            if (len2 > 0.f && std::isfinite(len2)) {
                g.normal[k] = s.normal / std::sqrt(len2);
                g.flags |= k == 0 ? kHasPrimaryNormal : kHasSecondaryNormal;
            }
            if (in_focus(s.object_id))
                g.flags |= kInFocus;
        }
        return g;
    }

    // ------------------------------------------------------------------------------------
    // Stage 2: the two-step subpixel test, then packing the tile's active subpixels.

    /// Geometry attributes (object id, normal, shadow count; primary and secondary) on which
    /// pixels a and b disagree, before the enabled mask.
    uint8_t pair_disagreement(const GeoAttributes &a, const GeoAttributes &b) const {
        if (p_.focus >= 0 && !((a.flags | b.flags) & kInFocus))
            return 0;
        uint8_t m = 0;
        for (int k = 0; k < 2; ++k) {
            const unsigned shift = unsigned(4 * k);
            if (a.object_id[k] != b.object_id[k])
                m |= uint8_t(kPoid << shift);
            const uint8_t has_normal = k == 0 ? kHasPrimaryNormal : kHasSecondaryNormal;
            if ((a.flags & has_normal) && (b.flags & has_normal) &&
                dot(a.normal[k], b.normal[k]) < p_.normal_dot)
                m |= uint8_t(kPsn << shift);
            if (a.shadow_count[k] != b.shadow_count[k])
                m |= uint8_t(kPsc << shift);
        }
        return m;
    }

    void test(const PixelRect &tile) {
        uint32_t *packed = packed_.data() + slab(tile);
        uint32_t n_packed = 0;
        for (uint32_t y = tile.y0; y < tile.y1; ++y) {
            const uint32_t ys[2] = {y > 0 ? y - 1 : y, y + 1 < height_ ? y + 1 : y};
            for (uint32_t x = tile.x0; x < tile.x1; ++x) {
                const uint32_t xs[2] = {x > 0 ? x - 1 : x, x + 1 < width_ ? x + 1 : x};
                const size_t i = index(x, y);
                const GeoAttributes &g = geo_[i];
                // Pairwise disagreements with the 8 neighbours, [dy][dx] with 0 = this pixel's
                // row/column and 1/2 = the lower/higher side; each is shared by 1-2 subpixels.
                uint8_t pair[3][3] = {};
                bool focus_near[3][3] = {};
                const uint32_t cols[3] = {x, xs[0], xs[1]}, rows[3] = {y, ys[0], ys[1]};
                for (int r = 0; r < 3; ++r)
                    for (int c = 0; c < 3; ++c) {
                        if (r == 0 && c == 0)
                            continue;
                        const size_t j = index(cols[c], rows[r]);
                        const GeoAttributes &o = geo_[j];
                        // A clamped neighbour is the pixel itself: no disparity (deviation 6).
                        pair[r][c] = attributes_ && j != i ? pair_disagreement(g, o) : 0;
                        focus_near[r][c] = (o.flags & kInFocus) != 0;
                    }
                uint8_t own = 0;  // texture existence: set by the pixel's own attribute
                if (g.flags & kHasPrimaryTexture)
                    own |= kPte;
                if (g.flags & kHasSecondaryTexture)
                    own |= kSte;
                const bool own_focus = (g.flags & kInFocus) != 0;
                if (p_.focus >= 0 && !own_focus)
                    own = 0;

                uint8_t mask = 0, code = kTestNone, seen = 0;
                for (uint32_t q = 0; q < 4; ++q) {
                    const int c = 1 + int(q & 1u), r = 1 + int(q >> 1);
                    const uint8_t dis =
                        uint8_t((own | pair[0][c] | pair[r][0] | pair[r][c]) & enabled_);
                    seen |= dis;
                    // Step 1: the smallest threshold of the disagreeing attributes, else tau_col.
                    float tau = p_.tau_col;
                    uint8_t why = kTestColour;
                    if (dis) {
                        tau = 1.f;
                        for (int k = 0; k < 8; ++k)
                            if (dis & (1u << k))
                                tau = std::min(tau, p_.tau[size_t(k)]);
                        why = kTestGeometry;
                    }
                    if (p_.focus >= 0 && p_.focus_tau < tau &&
                        (own_focus || focus_near[0][c] || focus_near[r][0] || focus_near[r][c])) {
                        tau = p_.focus_tau;
                        why = kTestFocus;
                    }
                    // Step 2: Mitchell's contrast over the four colour references.
                    const Rgb &c0 = centre_[i], &ch = centre_[index(cols[c], y)],
                              &cv = centre_[index(x, rows[r])],
                              &cd = centre_[index(cols[c], rows[r])];
                    bool active = false;
                    for (int l = 0; l < 3; ++l) {
                        const float hi = std::max(std::max(c0[l], ch[l]), std::max(cv[l], cd[l]));
                        const float lo = std::min(std::min(c0[l], ch[l]), std::min(cv[l], cd[l]));
                        const float sum = hi + lo, t = tau * kContrastScale[l];
                        // (hi - lo) / sum >= t without the division; 0 / 0 is contrast 0.
                        active |= sum > 0.f ? hi - lo >= t * sum : t <= 0.f;
                    }
                    if (active) {
                        mask |= uint8_t(1u << q);
                        code = std::max(code, why);
                        packed[n_packed++] = uint32_t(i) * 4u + q;  // pixel order, then quadrant
                    }
                }
                mask_[i] = mask;
                test_[i] = code;
                disagree_[i] = seen;
            }
        }
        tile_active_[index(tile.x0, tile.y0)] = n_packed;
    }

    // ------------------------------------------------------------------------------------
    // Stage 3: 4 stratified jittered samples per packed active subpixel, then the resolve.

    CameraSample extra_sample(uint32_t entry, uint32_t s) const {
        const uint32_t pixel = entry >> 2, q = entry & 3u;
        CameraSample c;
        c.px = pixel % width_;
        c.py = pixel / width_;
        c.index = 1 + 4 * q + s;
        SobolSampler seq(p_.seed);
        seq.start_pixel_sample(c.px, c.py, c.index);
        const Vec2f j = seq.get_pixel_2d();
        // Cell s of the subpixel's 2 x 2 grid: quarter-pixel cells, subpixel q's half first.
        const float cx = float(2 * (q & 1u) + (s & 1u)), cy = float(2 * (q >> 1) + (s >> 1));
        c.fx = std::min((cx + j.x) * 0.25f, 0x1.fffffep-1f);
        c.fy = std::min((cy + j.y) * 0.25f, 0x1.fffffep-1f);
        return c;
    }

    /// The colour of an inactive subpixel q of pixel (x, y): the centre colour (the paper), or
    /// with `bilinear` the interpolation at the subpixel centre (section 6).
    Rgb inactive_colour(uint32_t x, uint32_t y, uint32_t q) const {
        const size_t i = index(x, y);
        if (!p_.bilinear)
            return centre_[i];
        const uint32_t nx = (q & 1u) ? (x + 1 < width_ ? x + 1 : x) : (x > 0 ? x - 1 : x);
        const uint32_t ny = (q >> 1) ? (y + 1 < height_ ? y + 1 : y) : (y > 0 ? y - 1 : y);
        return centre_[i] * (9.f / 16.f) + centre_[index(nx, y)] * (3.f / 16.f) +
               centre_[index(x, ny)] * (3.f / 16.f) + centre_[index(nx, ny)] * (1.f / 16.f);
    }

    /// Final colour of pixel i: inactive subpixels from the centre sample, plus `extra` (the
    /// active subpixels' quarter-weighted means, i.e. 1/16 per extra sample).
    void resolve(size_t i, Rgb extra) {
        const uint32_t x = uint32_t(i % width_), y = uint32_t(i / width_);
        const uint32_t mask = mask_[i];
        if (!p_.bilinear) {
            color_[i] = centre_[i] * (float(4 - std::popcount(mask)) * 0.25f) + extra;
            return;
        }
        Rgb c = extra;
        for (uint32_t q = 0; q < 4; ++q)
            if (!(mask & (1u << q)))
                c += inactive_colour(x, y, q) * 0.25f;
        color_[i] = c;
    }

    void supersample(const PixelRect &tile, const SampleSource &source) {
        const uint32_t *packed = packed_.data() + slab(tile);
        const uint32_t n = tile_active_[index(tile.x0, tile.y0)];
        if (p_.bilinear) {
            // Pixels without active subpixels still change under bilinear filtering.
            for (uint32_t y = tile.y0; y < tile.y1; ++y)
                for (uint32_t x = tile.x0; x < tile.x1; ++x)
                    if (!mask_[index(x, y)])
                        resolve(index(x, y), Rgb(0.f));
        }
        std::array<CameraSample, kBatch> cs;
        std::array<Sample, kBatch> out;
        constexpr uint32_t kPerBatch = kBatch / 4;
        // Entries of one pixel are consecutive; the running pixel ("master" in 4.3.2) resolves
        // when the next pixel starts, which may be in a later batch.
        size_t pixel = SIZE_MAX;
        Rgb extra(0.f);
        for (uint32_t start = 0; start < n; start += kPerBatch) {
            const uint32_t m = std::min(kPerBatch, n - start);
            for (uint32_t k = 0; k < m; ++k)
                for (uint32_t s = 0; s < 4; ++s)
                    cs[4 * k + s] = extra_sample(packed[start + k], s);
            source.evaluate_batch(std::span<const CameraSample>(cs.data(), 4 * m),
                                  std::span<Sample>(out.data(), 4 * m));
            shadow_.add(std::span<const Sample>(out.data(), 4 * m));
            for (uint32_t k = 0; k < m; ++k) {
                const size_t i = packed[start + k] >> 2;
                if (i != pixel) {
                    if (pixel != SIZE_MAX)
                        resolve(pixel, extra);
                    pixel = i;
                    extra = Rgb(0.f);
                }
                Rgb sum(0.f);
                uint32_t good = 0, rays = 0;
                for (uint32_t s = 0; s < 4; ++s) {
                    const Sample &smp = out[4 * k + s];
                    rays += smp.rays;
                    if (!smp.radiance.is_finite()) {
                        ++nan_[i];
                        continue;
                    }
                    sum += smp.radiance;
                    ++good;
                }
                // 1/16 per sample when all four are finite (section 4.1.4).
                extra += good == 4 ? sum * (1.f / 16.f)
                         : good    ? sum * (0.25f / float(good))
                                   : centre_[i] * 0.25f;
                rays_[i] += float(rays);
                samples_[i] += 4;
            }
        }
        if (pixel != SIZE_MAX)
            resolve(pixel, extra);
    }

    JinParams p_;
    uint8_t enabled_ = 0;  ///< attribute bits whose threshold is below 1 (deviation 3)
    bool attributes_ = false;
    FrameShadowRays shadow_;
    uint32_t width_ = 0, height_ = 0;
    // Per pixel, row-major.
    std::vector<Rgb> centre_;  ///< presampled colour: shaded colour image and colour reference
    std::vector<Rgb> color_;   ///< final colour
    std::vector<GeoAttributes> geo_;  ///< geometry attribute map
    std::vector<float> rays_;
    std::vector<uint32_t> samples_, nan_;
    std::vector<uint8_t> mask_;      ///< active subpixels, bit q = quadrant q
    std::vector<uint8_t> test_;      ///< "test" layer code
    std::vector<uint8_t> disagree_;  ///< "attributes" layer bits
    /// Packed active subpixels (pixel index * 4 + quadrant), one contiguous slab per tile.
    std::vector<uint32_t> packed_;
    /// Length of a tile's packed list, stored at the tile's first pixel.
    std::vector<uint32_t> tile_active_;
    /// Frame number of the pixel's last presample (== frame_: the pixel belongs to this frame).
    std::vector<uint32_t> stamp_;
    uint32_t frame_ = 0;
};

}  // namespace

PluginInfo jin_plugin_info() {
    PluginInfo info;
    info.name = "jin";
    info.kind = PluginKind::Frame;
    info.summary =
        "selective and adaptive supersampling (Jin et al. 2009): centre presample, "
        "geometry attributes pick the contrast threshold of 4 subpixels per pixel, "
        "4 jittered samples per active subpixel";
    info.params = {
        {"tau_col", 0.6, 0, 1, false, "colour reference threshold (tau_alpha; 1: colour off)"},
        {"tau_poid", 0.05, 0, 1, false, "threshold where primary object ids differ (1: off)"},
        {"tau_psn", 0.06, 0, 1, false, "threshold where primary surface normals differ (1: off)"},
        {"tau_psc", 0.06, 0, 1, false, "threshold where primary shadow counts differ (1: off)"},
        {"tau_pte", 0.6, 0, 1, false, "threshold on pixels with a primary texture (1: off)"},
        {"tau_soid", 0.05, 0, 1, false, "threshold where secondary object ids differ (1: off)"},
        {"tau_ssn", 0.06, 0, 1, false, "threshold where secondary surface normals differ (1: off)"},
        {"tau_ssc", 0.06, 0, 1, false, "threshold where secondary shadow counts differ (1: off)"},
        {"tau_ste", 0.6, 0, 1, false, "threshold on pixels with a secondary texture (1: off)"},
        {"normal_dot", 0.9, -1, 1, false,
         "normals differ when their dot product is below this (paper: 'a preset value')"},
        {"focus", -1, -1, 2147483647.0, true,
         "focus object id: geometry attributes differ only next to it (-1: off)"},
        {"focus_count", 1, 1, 2147483647.0, true, "focus on ids focus .. focus+focus_count-1"},
        {"focus_tau", 1, 0, 1, false, "threshold ceiling next to focus objects (1: none)"},
        {"bilinear", 0, 0, 1, true, "inactive subpixels: 0 centre colour, 1 bilinear (sec. 6)"},
        {"seed", 0, 0, 4294967295.0, true, "sequence seed of the jitter"},
    };
    info.make = [](const PluginParams &p) -> std::unique_ptr<PixelSampler> {
        JinParams j;
        static const char *const keys[8] = {"tau_poid", "tau_psn", "tau_psc", "tau_pte",
                                            "tau_soid", "tau_ssn", "tau_ssc", "tau_ste"};
        for (size_t k = 0; k < 8; ++k)
            j.tau[k] = float(p.get(keys[k]));
        j.tau_col = float(p.get("tau_col"));
        j.normal_dot = float(p.get("normal_dot"));
        j.focus = int64_t(p.get("focus"));
        j.focus_count = int64_t(p.get("focus_count"));
        j.focus_tau = float(p.get("focus_tau"));
        j.bilinear = p.get_bool("bilinear");
        j.seed = uint32_t(p.get("seed"));
        if (j.focus < 0) {
            for (const char *key : {"focus_count", "focus_tau"})
                if (p.is_set(key))
                    throw std::invalid_argument(std::string("sampler jin: ") + key +
                                                " needs focus=ID (focus is off)");
        } else if (j.focus + j.focus_count - 1 > std::numeric_limits<int32_t>::max()) {
            throw std::invalid_argument(
                "sampler jin: focus_count reaches past the largest object id 2147483647");
        }
        return std::make_unique<JinSampler>(j);
    };
    return info;
}

}  // namespace tessera::sampling
