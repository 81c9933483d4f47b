// `kim`: adaptive undersampling with post-correction, after Kim, Seo, Kim, Lim, Nah and Ihm,
// "Adaptive Undersampling for Efficient Mobile Ray Tracing" (papers/001_2818ada877c039e5.txt).
//
// Algorithm (section numbers of the paper):
//  - Sec. 3.1, Fig. 2: the image is partitioned into base pixels B (every other pixel in x and y
//    for the 2x2 base block) and adaptive pixels: A1 between two B pixels of a row, A2 in the
//    rows between (between two B/A1 pixels of a column).
//  - Sec. 3.2 (Stage I, kernel Step-I of Table 2): a primary ray is traced through every B pixel
//    and its ray-attribute vector (OID, POS, NORM, SHDBIT, TCOORD, GCOL) is kept.
//  - Sec. 3.3 (Stages II and III, kernels Step-II-a..c and Step-III-a..c): every A1, then every
//    A2 pixel looks at its two reference pixels. When all seven similarity checks of Table 1
//    pass, its attribute vector is linearly interpolated from them and shaded without a primary
//    ray (SampleSource::shade, counted in FrameResult::shaded); otherwise the pixel is ray traced
//    in full (Sec. 5: "full ray tracing for the current pixel if there is any failure"). As in
//    Step-II-b, the pixels to trace are packed first and traced together through
//    SampleSource::evaluate_batch (ray packets).
//  - Sec. 3.4, Table 1, the checks in this order (the "check" layer stores the first to fail):
//      1 G1  OID_0 == OID_1
//      2 G2  |POS_0 - POS_1| <= T_pos        (T_pos relative to the scene's longest side, Fig. 5)
//      3 G3  NORM_0 . NORM_1 >= T_norm
//      4 G4  ((POS_1 - POS_0) . NORM_0) * ((POS_0 - POS_1) . NORM_1) >= 0: the convexity check.
//            Each factor is the signed height of one hit point above the other hit's tangent
//            plane; the product is negative exactly when the two signs differ, i.e. the surface
//            between the hits has an inflection (Fig. 3), and then the pixel is traced.
//      5 TX  Table 1's formula for each texture coordinate (s and t): TCOORD_0 >= T_tex or
//            TCOORD_1 <= 1 - T_tex, and TCOORD_1 >= T_tex or TCOORD_0 <= 1 - T_tex, on the
//            fractional parts; it fails exactly when the two references straddle the seam of a
//            repeated texture (one below T_tex, the other above 1 - T_tex). (The text's looser
//            wording, "at least one coordinate in [T_tex, 1 - T_tex]", would also fail every
//            pair near a seam on the same side, i.e. 60 % of all textured pairs at T_tex = 0.3.)
//      6 SH  SHDBIT_0 == SHDBIT_1 (all lights); the pixel then inherits the visibility
//      7 GC  |GCOL_0 - GCOL_1| <= T_gcol
//    (8, not a check of the paper: the pixel could not be checked, see "Deviations".)
//    Defaults are those of Sec. 6: T_pos = 0.03, T_norm = 0.9, T_tex = 0.3, T_gcol = 0.15.
//  - Sec. 4, Fig. 4 and Sec. 5 ("Third"): post-correction of missing objects. Ray-traced adaptive
//    pixels are revisited; an interpolated neighbour whose OID (and, with pc-shadow, SHDBIT:
//    "missing shadows") differs from theirs gets a primary ray; when the traced OID (SHDBIT)
//    differs from the interpolated one a missing part was found, the pixel becomes a ray-traced
//    pixel itself and its interpolated neighbours are examined in turn. The paper's many-core
//    form scans every row from left to right, then from right to left, then every column from
//    top to bottom and from bottom to top, each scan propagating progressively along its line;
//    postcorrect=4 runs those four scans, postcorrect=2 the two orthogonal scans the paper
//    names as usually sufficient (left to right, top to bottom), postcorrect=0 none.
//  - Sec. 6.1, Table 5: undersampling combined with supersampling (2x2, 4x4 samples per pixel)
//    runs the same algorithm on the supersampled lattice (the RT ratios of Table 5 show it:
//    512^2 at 2x2 has the ratio of 1024^2 at 1x1); `ss` sets the lattice and the pixel colour is
//    the box-filtered mean of its ss x ss samples.
//
// Stages (each a barrier): base | a1 | a2 | [a1, a2 per further level] | two stages per
// post-correction scan (the segments of the blocks that hold a seed, then the chains that
// cross block borders) |
// resolve. A stage's tile writes only its own lattice points; references
// of neighbouring tiles come from earlier stages and are read-only. Samples are at the centres of
// the lattice cells (the paper's regular sampling; no jitter), so a frame is deterministic.
//
// Deviations from the paper, and why:
//  - Larger base blocks (block = 4, 8; the paper only says "a simple modification"): the A levels
//    recurse by midpoints. For s = block/2, block/4, ..., 1: a row pass (A1) fills the points
//    with y = 0 (mod 2s), x = s (mod 2s) from (x - s, y) and (x + s, y); then a column pass (A2)
//    fills y = s (mod 2s), x = 0 (mod s) from (x, y - s) and (x, y + s). After level s every
//    point of the lattice of step s is known. T_pos stays a world-space distance at every level
//    (references 2s apart are not trusted more), which makes coarse levels stricter.
//  - Image border: an A point whose second reference would lie outside the image (the last
//    column/row of an image whose size is not 1 + a multiple of the block) is extrapolated
//    linearly (t = 1.5) from its two inner references (x - 3s, x - s) after the same seven
//    checks on that pair, so that only B pixels are traced on a smooth surface (exactly 1/4 for
//    block 2); where even that pair is missing (tiny images) the point is traced with check 8.
//    The paper does not say what its 1024^2 images did at the border.
//  - Check 8 "not checkable": a reference has no attribute vector (a source without
//    provides_attributes(): every A pixel is then traced, i.e. full ray tracing) or is missing.
//  - Scene size for T_pos (Fig. 5 normalises each scene to a unit longest side): scene-size > 0
//    gives the longest side of the scene's bounding box; scene-size = 0 (default) measures the
//    longest side of the bounding box of the B pixels' hit points after Stage I. That box holds
//    only the visible part of the scene, so the threshold is, if anything, stricter.
//  - G4 in floating point: a factor within 1e-4 |POS_1 - POS_0| + 1e-6 max|POS| of zero counts
//    as zero, so that rounding on a flat (e.g. tilted planar) surface does not fail the check.
//  - TX uses the fractional part of each coordinate (repeated textures); a pair in which only
//    one reference is textured fails TX; untextured pairs skip it.
//  - Two escaped references (OID -1, background) pass G1; G2-G4 and TX do not apply (no
//    surface); the pixel's colour is the linear interpolation of the references' colours
//    instead of shade() (a source's background may depend on the direction), clamped at 0 when
//    extrapolated. Not counted in `shaded`.
//  - GC compares linear radiance (Euclidean norm of the RGB difference), not 8-bit colours.
//  - Interpolated vectors: POS, TCOORD, GCOL perspective-correct (linear in screen space after
//    division by the view depth, SampleSource::view_depth: the paper interpolates linearly in
//    screen space, which shifts the edges of a texture on a receding plane by up to a pixel;
//    measured on examples/realtime/thin-shadows at 1024^2: 31.1 dB against fixed 1 linear);
//    NORM likewise, then renormalised (kept as is when both normals are equal, so a plane
//    interpolates exactly); OID and SHDBIT copied (G1, SH passed). The secondary hit is not
//    interpolated (shade() does not read it).
//  - Post-correction on blocks (the paper runs one GPU thread per image line): each scan is a
//    parallel stage in which every 8x8-pixel block that holds a seed (a ray-traced adaptive or
//    corrected point; no other block can hold a candidate) scans its own line segments (lines
//    of a block advance in lock step so that candidates are traced together through
//    evaluate_batch); where a segment ends on a ray-traced adaptive pixel whose neighbour in the
//    next block is a candidate, the line is flagged, and a second stage (its jobs: whole lines,
//    split by the job's place in the work list) re-runs the scan over the flagged lines,
//    continuing those chains across block borders with single rays. The result is exactly that
//    of a serial scan of every image line (pc-lines=1 runs that, one job per line: the test's
//    reference), for any thread count. A candidate's traced result is kept even when its
//    OID/SHDBIT did not change (the ray was paid for and is exact), but only changed pixels
//    propagate, as in the paper. B pixels are not revisited (the paper revisits adaptive pixels
//    only; a B pixel's interpolated neighbours always share its OID).
//  - Sec. 5 traces a pixel in full when any check fails (no partial re-use, e.g. of geometry
//    with fresh shadow rays): kept, since SampleSource has no "shadow rays only" call anyway.
//
// CPU layout: per lattice point a 60-byte attribute vector and a 16-byte record (OID and
// SHDBIT, state, diagnostics), stored in blocks of 8 x 8 pixels (the default tile) so that a
// tile's points are contiguous, plus its colour and rays (16 bytes) in row-major arrays: 92
// bytes x ss^2 per pixel (92 MB at 1024^2, 1.4 GB at ss=4), on huge pages where the kernel
// offers them (sampling/large_buffer.h: every stage walks all of it). The last column pass does
// not store the vectors of the points it interpolates (no later pass reads them;
// post-correction compares the record's OID and SHDBIT). For ss = 1 the colour and rays arrays
// are the frame's output itself, and the frame totals are added per stage tile, so the resolve
// stage runs only on frames that write the diagnostic layers (before, it streamed a 32-byte
// record per pixel every frame: 17 ms of a 158 ms frame at 1024^2 on the Bitterli box).
// Nothing is allocated per sample; buffers persist across frames. The FrameScheduler's workers
// persist too; the default frame has 7 stages (base, a1, a2, four scans), 8 with the resolve.
//
// Diagnostics (FrameResult layers, one value per pixel; with ss > 1, over the pixel's samples):
//  "traced"        1 traced, 0 interpolated (ss > 1: fraction of the samples traced)
//  "class"         0 B, 1 A1, 2 A2 (ss > 1: mean over the samples)
//  "check"         first failed similarity check 1..7 (8: not checkable), 0 none (ss > 1: the
//                  smallest non-zero code of the samples)
//  "postcorrected" 0 not revisited, 1 re-traced by post-correction with no change, 2 corrected
//                  (a missing object or shadow found) (ss > 1: the largest code)
// plus rays per pixel; active_fraction = fraction of lattice points traced (the paper's "RT
// ratio"; unit "pixels", or "subpixels" when ss > 1).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "sampling/large_buffer.h"
#include "sampling/plugins/plugins.h"

namespace tessera::sampling {

namespace {

/// Codes of the "check" layer (Table 1 order).
enum CheckCode : uint8_t {
    kPassed = 0,
    kG1 = 1,
    kG2 = 2,
    kG3 = 3,
    kG4 = 4,
    kTX = 5,
    kSH = 6,
    kGC = 7,
    kNotCheckable = 8,
};

/// What a lattice point is and how it got its attribute vector.
enum PointState : uint8_t {
    kUnset = 0,     ///< never computed (before the first frame)
    kBase,          ///< B: traced in Stage I
    kInterpolated,  ///< adaptive, interpolated from its two references
    kTracedA,       ///< adaptive, traced because a similarity check failed
    kRetraced,      ///< was interpolated; traced by post-correction, OID/SHDBIT unchanged
    kCorrected,     ///< was interpolated; traced by post-correction, a missing part found
};

inline bool is_traced(uint8_t s) {
    return s == kBase || s == kTracedA || s == kRetraced || s == kCorrected;
}
/// Ray-traced adaptive pixels: the seeds of post-correction (Sec. 4).
inline bool is_seed(uint8_t s) {
    return s == kTracedA || s == kCorrected;
}

/// The paper's ray-attribute vector (OID, POS, NORM, SHDBIT, TCOORD, GCOL), compact.
struct Attr {
    Vec3f pos;
    Vec3f normal;
    Vec2f uv;
    Rgb gcol;
    int32_t oid = -1;
    uint32_t shadow = 0;
    uint8_t has_texture = 0;
    uint8_t valid = 0;  ///< 0: the sample had no attribute vector
    /// View depth of pos (SampleSource::view_depth), computed once per point: by the source for
    /// a traced point, by perspective-correct interpolation (1/z is linear in screen space)
    /// for an interpolated one. 0: unknown (no hit, or behind the camera).
    float z = 0;
};

/// Everything of a lattice point but its attribute vector, colour and rays (16 bytes: the
/// post-correction scans read this one stream, the resolve only on diagnostic frames). `oid`
/// and `shadow` repeat the attribute vector's OID and SHDBIT, which is all post-correction
/// compares: so the vector of a point that is never a reference need not be stored (see
/// adaptive_tile). Colour and rays: KimSampler::col_, ray_.
struct Point {
    int32_t oid = -1;        ///< Attr::oid
    uint32_t shadow = 0;     ///< Attr::shadow
    uint8_t state = kUnset;  ///< PointState
    uint8_t cls = 0;         ///< 0 B, 1 A1, 2 A2
    uint8_t check = 0;       ///< CheckCode of an adaptive point
    uint8_t pc = 0;          ///< post-correction: 0 none, 1 re-traced, 2 corrected
    uint8_t shaded = 0;      ///< 1: shaded from an interpolated vector (SampleSource::shade)
    uint8_t nan = 0;         ///< 1: its colour is not finite (stored as 0, dropped by the resolve)
};
static_assert(sizeof(Point) == 16);

/// Resets a point to Point{} with one 16-byte copy. A plain `pt = Point{}` compiled (g++ 12)
/// to scalar stores into a temporary followed by 8-byte loads that straddle them: a
/// store-forwarding stall on every point, where the profile put a quarter of the adaptive
/// pass's own samples.
inline void reset_point(Point &pt, uint8_t cls) {
    static constexpr Point kFresh{};
    std::memcpy(&pt, &kFresh, sizeof(Point));
    pt.cls = cls;
}

/// A stage tile's contribution to the frame totals, added once per tile (integer sums: the
/// totals do not depend on the order in which tiles finish).
struct Counts {
    uint64_t traced = 0, shaded = 0, rays = 0;
    int64_t nan = 0;  ///< a post-correction ray can turn a non-finite point finite: -1
};

/// The OID and SHDBIT of a point before post-correction traced it.
struct Ident {
    int32_t oid = -1;
    uint32_t shadow = 0;
};

/// Absolute thresholds of Table 1 for one frame.
struct Thresholds {
    float pos = 0;  ///< T_pos times the scene's longest side, world units
    float norm = 0.9f;
    float tex = 0.3f;
    float gcol = 0.15f;
};

/// Writes the attribute vector of a traced sample into `a` field by field. (Building an Attr
/// and then assigning it compiles to a block copy whose wide loads straddle the temporary's
/// narrow stores: a store-forwarding stall per point.)
void store_attr(Attr &a, const Sample &s) {
    if (!s.first_hit) {  // rare: a source without attribute vectors
        a = Attr{};
        return;
    }
    const SurfaceAttributes &p = s.first_hit->primary;
    a.pos = p.position;
    a.normal = p.normal;
    a.uv = p.uv;
    a.gcol = s.first_hit->global_color;
    a.oid = p.object_id;
    a.shadow = p.shadow_bits;
    a.has_texture = p.has_texture ? 1 : 0;
    a.valid = 1;
    a.z = 0.f;
}

HitAttributes hit_from(const Attr &a) {
    HitAttributes h;
    h.primary.object_id = a.oid;
    h.primary.position = a.pos;
    h.primary.normal = a.normal;
    h.primary.shadow_bits = a.shadow;
    h.primary.uv = a.uv;
    h.primary.has_texture = a.has_texture != 0;
    h.global_color = a.gcol;
    return h;
}

/// TX for one coordinate (Table 1: TCOORD_{a,b} >= T_tex or TCOORD_{1-a,b} <= 1 - T_tex for
/// a = 0 and 1): fails only when one reference's fractional coordinate is below T_tex and the
/// other's above 1 - T_tex, i.e. the pair straddles the seam of a repeated texture.
bool tex_coordinate_ok(float c0, float c1, float t) {
    const float f0 = c0 - std::floor(c0), f1 = c1 - std::floor(c1);
    return (f0 >= t || f1 <= 1.f - t) && (f1 >= t || f0 <= 1.f - t);
}

float max_abs(Vec3f v) {
    return std::max(std::fabs(v.x), std::max(std::fabs(v.y), std::fabs(v.z)));
}

/// The seven similarity checks of Table 1 in order; returns the first that fails (kPassed: all
/// pass, interpolation is allowed).
uint8_t first_failed_check(const Attr &a, const Attr &b, const Thresholds &th) {
    if (!a.valid || !b.valid)
        return kNotCheckable;
    if (a.oid != b.oid)
        return kG1;
    if (a.oid >= 0) {
        const Vec3f d = b.pos - a.pos;
        const float dist2 = length_squared(d);
        if (!(dist2 <= th.pos * th.pos))
            return kG2;
        if (!(dot(a.normal, b.normal) >= th.norm))
            return kG3;
        // G4: heights of each hit above the other's tangent plane; rounding noise counts as 0.
        const float h0 = dot(d, a.normal), h1 = dot(-d, b.normal);
        const float tol =
            1e-4f * std::sqrt(dist2) + 1e-6f * std::max(max_abs(a.pos), max_abs(b.pos));
        const int s0 = h0 > tol ? 1 : (h0 < -tol ? -1 : 0);
        const int s1 = h1 > tol ? 1 : (h1 < -tol ? -1 : 0);
        if (s0 * s1 < 0)
            return kG4;
        if (a.has_texture || b.has_texture) {
            if (a.has_texture != b.has_texture)
                return kTX;
            if (!tex_coordinate_ok(a.uv.x, b.uv.x, th.tex) ||
                !tex_coordinate_ok(a.uv.y, b.uv.y, th.tex))
                return kTX;
        }
    }
    if (a.shadow != b.shadow)
        return kSH;
    const Rgb g = a.gcol - b.gcol;
    if (!(g.r * g.r + g.g * g.g + g.b * g.b <= th.gcol * th.gcol))
        return kGC;
    return kPassed;
}

/// The attribute vector at screen parameter t on the line from reference a (t = 0) to b
/// (t = 1); t = 0.5 for a midpoint, 1.5 for the border extrapolation. za, zb: the references'
/// view depths (SampleSource::view_depth). Perspective-correct: a surface attribute that is
/// linear over a plane (position, uv) is linear in screen space only after division by the
/// depth, so the point at screen parameter t lies at s = (t / zb) / ((1 - t) / za + t / zb)
/// along the segment between the two hit points; linear (s = t) when the depths are equal or
/// unusable (affine cameras, a reference behind the camera, extrapolation past the horizon).
void interpolate(Attr &r, const Attr &a, const Attr &b, float t, float za = 1.f,
                 float zb = 1.f) {
    float z = 0.f;
    if (za > 0.f && zb > 0.f) {
        const float den = (1.f - t) / za + t / zb;
        if (den > 0.f) z = 1.f / den;
        if (za != zb) {
            const float s = (t / zb) / den;
            if (den > 0.f && std::isfinite(s)) t = s;
        }
    }
    // Field by field into the destination (see store_attr); r is neither a nor b.
    r.oid = a.oid;
    r.shadow = a.shadow;
    r.has_texture = a.has_texture;
    r.valid = a.valid;
    r.z = std::isfinite(z) ? z : 0.f;
    r.pos = a.pos + (b.pos - a.pos) * t;
    r.normal = a.normal;
    if (a.normal.x != b.normal.x || a.normal.y != b.normal.y || a.normal.z != b.normal.z) {
        const Vec3f n = a.normal + (b.normal - a.normal) * t;
        const float len = length(n);
        if (len > 0.f)
            r.normal = n / len;
    }
    r.uv = a.uv + (b.uv - a.uv) * t;
    r.gcol = a.gcol + (b.gcol - a.gcol) * t;
}

/// Which step a stage performs.
struct StageDesc {
    enum class Kind { Base, Rows, Columns, Scan, Cross, Resolve } kind = Kind::Base;
    uint32_t level = 1;      ///< Rows/Columns: half the reference distance s
    bool horizontal = true;  ///< Scan, Cross: rows (true) or columns
    int step = 1;            ///< Scan, Cross: +1 left-to-right / top-to-bottom, -1 the reverse
    std::string name;
};

/// Lattice coordinates of a point.
struct Coord {
    uint32_t x, y;
};

/// Per-thread scratch of run_tile: reused, so no allocation per sample.
struct Scratch {
    std::vector<Coord> coords;
    std::vector<CameraSample> cs;
    std::vector<Sample> out;
    std::vector<Ident> old;
};

/// First c >= c0 with c % period == residue.
inline uint32_t first_at(uint32_t c0, uint32_t period, uint32_t residue) {
    return c0 + (residue + period - c0 % period) % period;
}

class KimSampler final : public PixelSampler {
  public:
    explicit KimSampler(const PluginParams &p)
        : block_(uint32_t(p.get_int("block"))),
          ss_(uint32_t(p.get_int("ss"))),
          postcorrect_(p.get_int("postcorrect")),
          pc_shadow_(p.get_bool("pc-shadow")),
          pc_lines_(p.get_bool("pc-lines")),
          t_pos_(float(p.get("t-pos"))),
          scene_size_(float(p.get("scene-size"))) {
        th_.norm = float(p.get("t-norm"));
        th_.tex = float(p.get("t-tex"));
        th_.gcol = float(p.get("t-gcol"));
        stages_.push_back({StageDesc::Kind::Base, 0, true, 1, "base"});
        for (uint32_t s = block_ / 2; s >= 1; s /= 2) {
            const std::string suffix = block_ > 2 ? "-s" + std::to_string(s) : "";
            stages_.push_back({StageDesc::Kind::Rows, s, true, 1, "a1" + suffix});
            stages_.push_back({StageDesc::Kind::Columns, s, false, 1, "a2" + suffix});
        }
        // Sec. 5: left to right, right to left, top to bottom, bottom to top; two directions:
        // left to right and top to bottom.
        // Each scan is two stages: the tiles' own segments, then the chains that cross tile
        // borders ("-cross").
        auto scan = [&](bool horizontal, int step, const std::string &name) {
            stages_.push_back({StageDesc::Kind::Scan, 0, horizontal, step, name});
            stages_.push_back({StageDesc::Kind::Cross, 0, horizontal, step, name + "-cross"});
        };
        if (postcorrect_ == 4) {
            scan(true, 1, "postcorrect-lr");
            scan(true, -1, "postcorrect-rl");
            scan(false, 1, "postcorrect-tb");
            scan(false, -1, "postcorrect-bt");
        } else if (postcorrect_ == 2) {
            scan(true, 1, "postcorrect-lr");
            scan(false, 1, "postcorrect-tb");
        }
        stages_.push_back({StageDesc::Kind::Resolve, 0, true, 1, "resolve"});
    }

    void begin_frame(const SampleSource &source) override {
        width_ = source.width();
        height_ = source.height();
        lw_ = width_ * ss_;
        lh_ = height_ * ss_;
        // Lattice points are stored in blocks of 8 x 8 pixels (one default tile), row-major
        // inside a block, so that a tile's points are contiguous.
        block_shift_ = 3;
        while ((1u << block_shift_) < 8 * ss_)
            ++block_shift_;
        block_mask_ = (1u << block_shift_) - 1;
        blocks_x_ = (lw_ + block_mask_) >> block_shift_;
        const uint32_t blocks_y = (lh_ + block_mask_) >> block_shift_;
        const size_t n = size_t(blocks_x_) * blocks_y << (2 * block_shift_);
        // Nothing is cleared per frame: every stage writes all fields of the points it
        // computes (the colour and rays included: every lattice point is a B or an A point),
        // and a stage reads only points of earlier stages. A cancelled frame runs no tile of any
        // later stage (scheduler/frame_scheduler.h), so no stage sees a point left from the
        // previous frame. The per-pixel outputs are zero at the start of the first frame; after
        // that they hold the frame before last (end_frame swaps them with the FrameResult's,
        // unzeroed), which the stages (ss = 1) or the resolve overwrite everywhere. A cancelled
        // frame may therefore keep old pixels; the real-time loop discards cancelled frames.
        if (attr_.size() != n) {
            attr_.assign(n, Attr{});
            pts_.assign(n, Point{});
            col_.assign(n, Rgb(0.f));
            ray_.assign(n, 0.f);
        }
        const size_t np = size_t(width_) * height_;
        for (std::vector<float> *v : {&pix_rays_, &pix_traced_, &pix_class_, &pix_check_, &pix_pc_})
            if (v->size() != np)
                v->assign(np, 0.f);
        if (pix_color_.size() != np)
            pix_color_.assign(np, Rgb(0.f));
        traced_total_.store(0, std::memory_order_relaxed);
        shaded_total_.store(0, std::memory_order_relaxed);
        nan_total_.store(0, std::memory_order_relaxed);
        rays_total_.store(0, std::memory_order_relaxed);
        shadow_.reset();
        const size_t blocks = size_t(blocks_x_) * blocks_y;
        if (block_seed_size_ != blocks) {
            block_seed_size_ = blocks;
            block_seed_ = std::make_unique<std::atomic<uint8_t>[]>(blocks);
        }
        for (size_t b = 0; b < blocks; ++b)
            block_seed_[b].store(0, std::memory_order_relaxed);
        // One bit per segment (block) of the longest line, for as many lines.
        cross_words_ = ((std::max(lw_, lh_) + block_mask_) >> block_shift_) / 64 + 1;
        const size_t flag_words = size_t(std::max(lw_, lh_)) * cross_words_;
        if (line_flags_size_ != flag_words) {
            line_flags_size_ = flag_words;
            line_flags_ = std::make_unique<std::atomic<uint64_t>[]>(flag_words);
        }
        for (size_t i = 0; i < line_flags_size_; ++i)
            line_flags_[i].store(0, std::memory_order_relaxed);
        crossed_.store(false, std::memory_order_relaxed);
        th_.pos = t_pos_ * scene_size_;
        box_lo_ = Vec3f(kInfinity, kInfinity, kInfinity);
        box_hi_ = Vec3f(-kInfinity, -kInfinity, -kInfinity);
        box_any_ = false;
    }

    /// The ray-attribute vector of the primary hit (OID, POS, NORM, SHDBIT, GCOL; all read by
    /// shade() whatever the thresholds) and TCOORD with texture existence (the TX check, and
    /// shade() of textured materials). Never the secondary hit (not interpolated).
    uint32_t attributes_used() const override { return kAttrPrimary | kAttrTexture; }

    int stage_count() const override { return int(stages_.size()); }

    /// Cross: one job per line of the scan's direction, none when no chain crossed a tile
    /// border; resolve: one job per pixel row (row-major runs of the output). The other
    /// stages: one job per tile.
    uint32_t stage_jobs(int stage) const override {
        const StageDesc &st = stages_[size_t(stage)];
        if (st.kind == StageDesc::Kind::Cross)
            return crossed_.load(std::memory_order_relaxed) ? (st.horizontal ? lh_ : lw_) : 0;
        if (st.kind == StageDesc::Kind::Resolve)
            return height_;
        if (st.kind == StageDesc::Kind::Scan)  // one job per block that holds a seed, or line
            return pc_lines_ ? (st.horizontal ? lh_ : lw_) : uint32_t(scan_blocks_.size());
        return kTileJobs;
    }
    std::string stage_name(int stage) const override { return stages_[size_t(stage)].name; }

    void run_tile(int stage, const PixelRect &tile, const SampleSource &source) override {
        const StageDesc &st = stages_[size_t(stage)];
        const uint32_t x0 = tile.x0 * ss_, x1 = tile.x1 * ss_;
        const uint32_t y0 = tile.y0 * ss_, y1 = tile.y1 * ss_;
        switch (st.kind) {
            case StageDesc::Kind::Base:
                base_tile(x0, y0, x1, y1, source);
                break;
            case StageDesc::Kind::Rows:
            case StageDesc::Kind::Columns:
                adaptive_tile(st, x0, y0, x1, y1, source);
                break;
            case StageDesc::Kind::Scan: {  // job k: the k-th block with a seed, or line k
                if (pc_lines_) {
                    const uint32_t l = tile.index;
                    if (st.horizontal)
                        scan_rect(st, 0, l, lw_, l + 1, source);
                    else
                        scan_rect(st, l, 0, l + 1, lh_, source);
                    break;
                }
                const uint32_t b = scan_blocks_[tile.index];
                const uint32_t bx = b % blocks_x_, by = b / blocks_x_;
                const uint32_t side = block_mask_ + 1;
                scan_rect(st, bx * side, by * side, std::min(lw_, (bx + 1) * side),
                          std::min(lh_, (by + 1) * side), source);
                break;
            }
            case StageDesc::Kind::Cross: {  // this job's share of the lines
                const uint32_t lines = st.horizontal ? lh_ : lw_;
                const uint32_t count = std::max<uint32_t>(1, tile.count);
                cross_lines(st, uint32_t(uint64_t(tile.index) * lines / count),
                            uint32_t(uint64_t(tile.index + 1) * lines / count), source);
                break;
            }
            case StageDesc::Kind::Resolve:
                resolve_tile(tile);
                break;
        }
    }

    /// Brings the next tile's points into the cache before the current tile runs (see
    /// PixelSampler::prefetch_tile). Base and row passes: plain loads of the rows the pass
    /// reads and writes, one per cache line. On the machine measured (AMD EPYC, virtualised,
    /// single thread, trivial shading) prefetch instructions for these lines changed nothing,
    /// while the loads made the A1 pass 25-30% faster; only bytes of the tile's own lattice
    /// points are read, which no other tile writes. Column passes: prefetch instructions,
    /// which there measured faster than loads.
    void prefetch_tile(int stage, const PixelRect &tile) const override {
        const StageDesc &st = stages_[size_t(stage)];
        const uint32_t x0 = tile.x0 * ss_, x1 = tile.x1 * ss_;
        const uint32_t y0 = tile.y0 * ss_, y1 = tile.y1 * ss_;
        uint32_t acc = 0;
        switch (st.kind) {
            case StageDesc::Kind::Base:  // the B rows: written
                for (uint32_t y = first_at(y0, block_, 0); y < y1; y += block_)
                    acc += touch_row(x0, x1, y, kTouchAll);
                break;
            case StageDesc::Kind::Rows:  // the rows of the pass: references and writes
                for (uint32_t y = first_at(y0, 2 * st.level, 0); y < y1; y += 2 * st.level)
                    acc += touch_row(x0, x1, y, kTouchAll);
                break;
            case StageDesc::Kind::Columns: {
                // Here prefetch instructions do help (loads measured slower): the reference
                // rows, the written rows and the first reference row below the tile.
                prefetch_blocks(x0, y0, x1, y1);
                if (y1 < lh_)
                    for (uint32_t x = x0; x < x1; ++x)
                        __builtin_prefetch(&attr_[at(x, y1)]);
                return;
            }
            default:
                return;
        }
        asm volatile("" : : "r"(acc));
    }

    void end_stage(int stage, const SampleSource & /*source*/) override {
        const StageDesc &st = stages_[size_t(stage)];
        if (!pc_lines_ && size_t(stage) + 1 < stages_.size() &&
            stages_[size_t(stage) + 1].kind == StageDesc::Kind::Scan)
            list_seeded_blocks();
        if (st.kind == StageDesc::Kind::Cross)
            crossed_.store(false, std::memory_order_relaxed);
        if (st.kind == StageDesc::Kind::Base && scene_size_ <= 0.f)
            th_.pos = box_any_ ? t_pos_ * max_component(box_hi_ - box_lo_) : 0.f;
    }

    void end_frame(FrameResult &r) override {
        // The resolve writes every pixel of every buffer swapped in below: no zeroing needed.
        if (!diagnostics())
            drop_diagnostics(r);
        r.reset(width_, height_, /*zero=*/false);
        // Swap, not copy: our buffers get the result's zeroed ones for the next frame.
        r.color.swap(pix_color_);
        r.rays.swap(pix_rays_);
        if (diagnostics()) {
            r.layer("traced").data.swap(pix_traced_);
            r.layer("class").data.swap(pix_class_);
            r.layer("check").data.swap(pix_check_);
            r.layer("postcorrected").data.swap(pix_pc_);
        }
        const uint64_t traced = traced_total_.load(std::memory_order_relaxed);
        r.samples = traced;
        r.shaded = shaded_total_.load(std::memory_order_relaxed);
        r.nan_samples = uint64_t(std::max<int64_t>(0, nan_total_.load(std::memory_order_relaxed)));
        r.rays_total = rays_total_.load(std::memory_order_relaxed);
        shadow_.write(r);
        const double points = double(lw_) * double(lh_);
        r.active_fraction = points > 0 ? double(traced) / points : 0.0;
        r.active_unit = ss_ == 1 ? "pixels" : "subpixels";
    }

  private:
    size_t at(uint32_t x, uint32_t y) const {
        const size_t blk = size_t(y >> block_shift_) * blocks_x_ + (x >> block_shift_);
        return (blk << (2 * block_shift_)) | (size_t(y & block_mask_) << block_shift_) |
               (x & block_mask_);
    }

    void add_counts(const Counts &c) {
        traced_total_.fetch_add(c.traced, std::memory_order_relaxed);
        shaded_total_.fetch_add(c.shaded, std::memory_order_relaxed);
        rays_total_.fetch_add(c.rays, std::memory_order_relaxed);
        nan_total_.fetch_add(c.nan, std::memory_order_relaxed);
    }

    CameraSample camera_sample(uint32_t x, uint32_t y) const {
        CameraSample cs;
        cs.px = x / ss_;
        cs.py = y / ss_;
        cs.fx = (float(x % ss_) + 0.5f) / float(ss_);
        cs.fy = (float(y % ss_) + 0.5f) / float(ss_);
        cs.index = (y % ss_) * ss_ + (x % ss_);
        return cs;
    }

    static Scratch &scratch() {
        thread_local Scratch s;
        return s;
    }

    /// Traces the points of `coords` in batches; `store(k, sample)` receives each result.
    template <typename Store>
    void trace(const std::vector<Coord> &coords, const SampleSource &source, Store &&store) {
        constexpr size_t kBatch = 64;
        Scratch &sc = scratch();
        ShadowRayTally tally;
        for (size_t i0 = 0; i0 < coords.size(); i0 += kBatch) {
            const size_t n = std::min(kBatch, coords.size() - i0);
            sc.cs.resize(n);
            sc.out.resize(n);
            for (size_t k = 0; k < n; ++k)
                sc.cs[k] = camera_sample(coords[i0 + k].x, coords[i0 + k].y);
            source.evaluate_batch(std::span<const CameraSample>(sc.cs.data(), n),
                                  std::span<Sample>(sc.out.data(), n));
            tally.add(std::span<const Sample>(sc.out.data(), n));
            for (size_t k = 0; k < n; ++k)
                store(i0 + k, sc.out[k]);
        }
        shadow_.add(tally);
    }

    /// Stores a traced sample into point i (an index from at()): attributes,
    /// colour (0 when not finite, flagged), rays (a post-correction ray adds to the rays of the
    /// point's interpolation, which are 0: `add_rays`), and counts it as traced.
    void store_traced(size_t i, const Sample &s,
                      const SampleSource &source, bool add_rays, Counts &counts) {
        store_attr(attr_[i], s);
        if (attr_[i].valid && attr_[i].oid >= 0) {
            const float z = source.view_depth(attr_[i].pos);
            attr_[i].z = z > 0.f && std::isfinite(z) ? z : 0.f;
        }
        const bool finite = s.radiance.is_finite();
        col_[i] = finite ? s.radiance : Rgb(0.f);
        ray_[i] = add_rays ? ray_[i] + float(s.rays) : float(s.rays);
        Point &pt = pts_[i];
        counts.nan += int64_t(finite ? 0 : 1) - int64_t(add_rays ? pt.nan : 0);
        pt.oid = attr_[i].oid;
        pt.shadow = attr_[i].shadow;
        pt.nan = finite ? 0 : 1;
        counts.traced += 1;
        counts.rays += s.rays;
    }

    // ---- Stage I: base pixels -----------------------------------------------------------
    void base_tile(uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1, const SampleSource &source) {
        std::vector<Coord> &coords = scratch().coords;
        coords.clear();
        for (uint32_t y = first_at(y0, block_, 0); y < y1; y += block_)
            for (uint32_t x = first_at(x0, block_, 0); x < x1; x += block_)
                coords.push_back({x, y});
        // T_pos is relative to the scene normalised to a unit longest side (Fig. 5): the
        // longest side of the bounding box of the B pixels' hit points, gathered here while
        // they are in cache (min and max do not depend on the order of the tiles) and read by
        // end_stage.
        const bool measure = scene_size_ <= 0.f;
        Vec3f lo(kInfinity, kInfinity, kInfinity), hi(-kInfinity, -kInfinity, -kInfinity);
        bool any = false;
        Counts counts;
        trace(coords, source, [&](size_t k, const Sample &s) {
            const size_t i = at(coords[k].x, coords[k].y);
            reset_point(pts_[i], 0);  // class 0 (B), no check
            store_traced(i, s, source, false, counts);
            pts_[i].state = kBase;
            const Attr &a = attr_[i];
            if (measure && a.valid && a.oid >= 0 && std::isfinite(a.pos.x) &&
                std::isfinite(a.pos.y) && std::isfinite(a.pos.z)) {
                lo = vmin(lo, a.pos);
                hi = vmax(hi, a.pos);
                any = true;
            }
        });
        add_counts(counts);
        if (any) {
            std::lock_guard<std::mutex> lock(box_mutex_);
            box_lo_ = vmin(box_lo_, lo);
            box_hi_ = vmax(box_hi_, hi);
            box_any_ = true;
        }
    }

    // ---- Stages II and III: adaptive pixels ---------------------------------------------
    /// The two references of an adaptive point at coordinate c (along the pass's axis) and the
    /// interpolation parameter; false when there are none (tiny images).
    bool references(uint32_t c, uint32_t s, uint32_t limit, uint32_t &ca, uint32_t &cb,
                    float &t) const {
        if (c + s < limit) {
            ca = c - s;
            cb = c + s;
            t = 0.5f;
            return true;
        }
        if (c >= 3 * s) {  // image border: extrapolate from the two inner references
            ca = c - 3 * s;
            cb = c - s;
            t = 1.5f;
            return true;
        }
        return false;
    }

    void adaptive_tile(const StageDesc &st, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                       const SampleSource &source) {
        const uint32_t s = st.level, period = 2 * s;
        const bool rows = st.kind == StageDesc::Kind::Rows;
        const uint8_t cls = rows ? 1 : 2;
        // The last column pass (s = 1) fills the odd lattice rows, which no later pass takes as
        // references: its interpolated points keep only OID and SHDBIT (in Point), which is
        // what post-correction compares. That saves writing a third of the attribute array
        // every frame (measured at 1024^2: a2 5-10 ms shorter). Traced points still store
        // their whole vector (store_traced).
        const bool store_vectors = rows || s > 1;
        std::vector<Coord> &coords = scratch().coords;
        coords.clear();
        Counts counts;
        // Rows (A1): y = 0 (mod 2s), x = s (mod 2s). Columns (A2): y = s (mod 2s), x = 0 (mod s).
        const uint32_t ystart = first_at(y0, period, rows ? 0 : s);
        const uint32_t xstep = rows ? period : s;
        const uint32_t xstart = first_at(x0, xstep, rows ? s : 0);
        for (uint32_t y = ystart; y < y1; y += period)
            for (uint32_t x = xstart; x < x1; x += xstep) {
                const size_t i = at(x, y);
                Point &pt = pts_[i];
                reset_point(pt, cls);
                uint32_t ca = 0, cb = 0;
                float t = 0.5f;
                uint8_t code = kNotCheckable;
                size_t ia = 0, ib = 0;
                if (references(rows ? x : y, s, rows ? lw_ : lh_, ca, cb, t)) {
                    ia = rows ? at(ca, y) : at(x, ca);
                    ib = rows ? at(cb, y) : at(x, cb);
                    code = first_failed_check(attr_[ia], attr_[ib], th_);
                }
                pt.check = code;
                if (code != kPassed) {
                    coords.push_back({x, y});
                    continue;
                }
                const Attr &a = attr_[ia], &b = attr_[ib];
                Attr local;
                Attr &r = store_vectors ? attr_[i] : local;
                if (a.oid >= 0)
                    interpolate(r, a, b, t, a.z, b.z);
                else
                    interpolate(r, a, b, t);
                pt.oid = r.oid;
                pt.shadow = r.shadow;
                Rgb color;
                if (a.oid >= 0) {
                    color = source.shade(hit_from(r));
                    pt.shaded = 1;
                    ++counts.shaded;
                } else {  // both escaped: no surface to shade
                    color = clamp_zero(col_[ia] + (col_[ib] - col_[ia]) * t);
                }
                // A non-finite reference (stored as 0) makes the interpolation non-finite too.
                const bool finite =
                    color.is_finite() && (a.oid >= 0 || !(pts_[ia].nan || pts_[ib].nan));
                pt.nan = finite ? 0 : 1;
                counts.nan += pt.nan;
                col_[i] = finite ? color : Rgb(0.f);
                ray_[i] = 0.f;
                pt.state = kInterpolated;
            }
        // Step-II-b/c: the failed points, packed, traced together.
        trace(coords, source, [&](size_t k, const Sample &smp) {
            const size_t i = at(coords[k].x, coords[k].y);
            store_traced(i, smp, source, false, counts);
            pts_[i].state = kTracedA;
            mark_seed(i);
        });
        add_counts(counts);
    }

    // ---- Post-correction (Sec. 4, Sec. 5) -------------------------------------------------
    /// Is point `cur` (interpolated) a candidate next to the ray-traced adaptive point `prev`?
    bool candidate(size_t cur, size_t prev) const {
        if (pts_[cur].state != kInterpolated || !is_seed(pts_[prev].state))
            return false;
        const Point &c = pts_[cur], &p = pts_[prev];
        return c.oid != p.oid || (pc_shadow_ && c.shadow != p.shadow);
    }

    /// Stores the post-correction ray of the point at (x, y) whose interpolated OID and SHDBIT
    /// were `old`.
    void apply_correction(uint32_t x, uint32_t y, const Ident &old, const Sample &s,
                          const SampleSource &source, Counts &counts) {
        const size_t i = at(x, y);
        store_traced(i, s, source, true, counts);
        const Point &now = pts_[i];
        const bool changed = now.oid != old.oid || (pc_shadow_ && now.shadow != old.shadow);
        pts_[i].state = changed ? kCorrected : kRetraced;
        pts_[i].pc = changed ? 2 : 1;
        if (changed)
            mark_seed(i);
    }

    /// Software prefetches of the lattice blocks under [x0, x1) x [y0, y1): attribute vectors,
    /// point records, colours and rays.
    void prefetch_blocks(uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) const {
        if (x1 <= x0 || y1 <= y0) return;
        const size_t per_block = size_t(1) << (2 * block_shift_);
        for (uint32_t by = y0 >> block_shift_; by <= (y1 - 1) >> block_shift_; ++by)
            for (uint32_t bx = x0 >> block_shift_; bx <= (x1 - 1) >> block_shift_; ++bx) {
                const size_t first = (size_t(by) * blocks_x_ + bx) * per_block;
                const char *a = reinterpret_cast<const char *>(attr_.data() + first);
                const char *p = reinterpret_cast<const char *>(pts_.data() + first);
                const char *c = reinterpret_cast<const char *>(col_.data() + first);
                const char *r = reinterpret_cast<const char *>(ray_.data() + first);
                for (size_t off = 0; off < per_block * sizeof(Attr); off += 64)
                    __builtin_prefetch(a + off);
                for (size_t off = 0; off < per_block * sizeof(Point); off += 64)
                    __builtin_prefetch(p + off);
                for (size_t off = 0; off < per_block * sizeof(Rgb); off += 64)
                    __builtin_prefetch(c + off, 1);
                for (size_t off = 0; off < per_block * sizeof(float); off += 64)
                    __builtin_prefetch(r + off, 1);
            }
    }

    /// Reads one byte of every cache line of [p, p + n) (see prefetch_tile).
    template <class T>
    static uint32_t touch_run(const T *p, size_t n) {
        if (n == 0) return 0;
        const auto *c = reinterpret_cast<const volatile unsigned char *>(p);
        const size_t bytes = n * sizeof(T);
        uint32_t acc = c[bytes - 1];
        for (size_t off = 0; off < bytes; off += 64)
            acc += c[off];
        return acc;
    }

    static constexpr int kTouchAttr = 1, kTouchRecords = 2, kTouchAll = 3;

    /// touch_run over lattice row y from x0 to x1 (split at block borders): the attribute
    /// vectors (kTouchAttr) and/or the point records, colours and rays (kTouchRecords).
    uint32_t touch_row(uint32_t x0, uint32_t x1, uint32_t y, int what) const {
        uint32_t acc = 0;
        for (uint32_t x = x0; x < x1;) {
            const uint32_t n = std::min(x1 - x, block_mask_ + 1 - (x & block_mask_));
            const size_t i = at(x, y);
            if (what & kTouchAttr)
                acc += touch_run(&attr_[i], n);
            if (what & kTouchRecords)
                acc += touch_run(&pts_[i], n) + touch_run(&col_[i], n) + touch_run(&ray_[i], n);
            x += n;
        }
        return acc;
    }

    /// Before a scan: the blocks that hold a seed, the scan's jobs (stage_jobs). A scan finds
    /// candidates only after a seed (candidate()), and marks seeds only in the block it scans,
    /// so the blocks without one have nothing to do; at 1024^2 they are most of the 16384, and
    /// dispatching them cost 0.7-0.9 ms per scan. Serial (end_stage).
    void list_seeded_blocks() {
        scan_blocks_.clear();
        for (size_t b = 0; b < block_seed_size_; ++b)
            if (block_seed_[b].load(std::memory_order_relaxed))
                scan_blocks_.push_back(uint32_t(b));
    }

    /// Notes that the block of point i (an index from at()) holds a seed of post-correction.
    void mark_seed(size_t i) {
        block_seed_[i >> (2 * block_shift_)].store(1, std::memory_order_relaxed);
    }

    /// One scan over the line segments of the lattice rectangle [x0, x1) x [y0, y1) (a block),
    /// all its lines in lock step so that the candidates of one step are traced as one batch.
    void scan_rect(const StageDesc &st, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                   const SampleSource &source) {
        // Along: the scan axis; across: the lines.
        const uint32_t a0 = st.horizontal ? x0 : y0, a1 = st.horizontal ? x1 : y1;
        const uint32_t l0 = st.horizontal ? y0 : x0, l1 = st.horizontal ? y1 : x1;
        auto point = [&](uint32_t along, uint32_t line) {
            return st.horizontal ? at(along, line) : at(line, along);
        };
        // Called for the blocks that hold a seed only (list_seeded_blocks), or whole lines.
        if (x1 <= x0 || y1 <= y0)
            return;
        Scratch &sc = scratch();
        const uint32_t n_along = a1 - a0;
        for (uint32_t k = 1; k < n_along; ++k) {
            const uint32_t cur = st.step > 0 ? a0 + k : a1 - 1 - k;
            const uint32_t prev = st.step > 0 ? cur - 1 : cur + 1;
            sc.coords.clear();
            sc.old.clear();
            for (uint32_t l = l0; l < l1; ++l) {
                const size_t ic = point(cur, l);
                if (!candidate(ic, point(prev, l)))
                    continue;
                sc.coords.push_back(st.horizontal ? Coord{cur, l} : Coord{l, cur});
                sc.old.push_back({pts_[ic].oid, pts_[ic].shadow});
            }
            if (sc.coords.empty())
                continue;
            Counts counts;
            trace(sc.coords, source, [&](size_t j, const Sample &s) {
                apply_correction(sc.coords[j].x, sc.coords[j].y, sc.old[j], s, source, counts);
            });
            add_counts(counts);
        }
        // A chain that reaches the segment's end continues in the next block: flag the line for
        // the Cross stage. The neighbour read here is the first point of the next block's segment
        // in this scan direction, which no job writes during this stage (it has no predecessor
        // inside its own block), so the read does not race.
        const uint32_t exit = st.step > 0 ? a1 - 1 : a0;
        const uint32_t limit = st.horizontal ? lw_ : lh_;
        if ((st.step > 0 && exit + 1 >= limit) || (st.step < 0 && exit == 0))
            return;
        const uint32_t next = st.step > 0 ? exit + 1 : exit - 1;
        // The Cross stage's walks start at the crossings (see cross_lines): one bit per segment
        // of the line, that of `next`.
        const uint32_t seg = next >> block_shift_;
        const uint64_t bit = uint64_t(1) << (seg & 63);
        for (uint32_t l = l0; l < l1; ++l)
            if (candidate(point(next, l), point(exit, l))) {
                crossed_.store(true, std::memory_order_relaxed);
                line_flags_[size_t(l) * cross_words_ + (seg >> 6)].fetch_or(
                    bit, std::memory_order_relaxed);
            }
    }

    /// Lines [l0, l1) of the Cross stage after a scan: continues the chains that crossed block
    /// borders. From each crossing of a line, in scan order, the scan re-runs while it finds
    /// candidates (one ray each). Same result as one serial scan per line: the block scans have
    /// traced every candidate whose predecessor lies in the same segment; after them a
    /// candidate can follow only a crossing (a candidate whose predecessor is the previous
    /// segment's last point, flagged by that segment's scan), or a point this walk has just
    /// traced and changed, which the walk reaches next. So a walk that meets a point that is
    /// not a candidate can skip to the next crossing it has not passed. A line is one job's
    /// alone, and a point is on one line of the scan's direction, so jobs write disjoint points.
    void cross_lines(const StageDesc &st, uint32_t l0, uint32_t l1, const SampleSource &source) {
        const uint32_t len = st.horizontal ? lw_ : lh_;
        const uint32_t side = block_mask_ + 1;
        Sample s;
        for (uint32_t l = l0; l < l1; ++l) {
            std::atomic<uint64_t> *flags = &line_flags_[size_t(l) * cross_words_];
            uint32_t done = 1;  // the walks have passed the steps below this one
            for (uint32_t i = 0; i < cross_words_; ++i) {
                // The crossed segments in scan order.
                const uint32_t w = st.step > 0 ? i : cross_words_ - 1 - i;
                uint64_t bits = flags[w].exchange(0, std::memory_order_relaxed);
                while (bits) {
                    const int b = st.step > 0 ? __builtin_ctzll(bits) : 63 - __builtin_clzll(bits);
                    bits &= ~(uint64_t(1) << b);
                    const uint32_t seg = w * 64 + uint32_t(b);
                    // The segment's first point in scan order, as a step number.
                    const uint32_t start =
                        st.step > 0 ? seg * side : len - std::min(len, (seg + 1) * side);
                    for (uint32_t k = std::max(start, done); k < len; ++k) {
                        done = k + 1;
                        const uint32_t cur = st.step > 0 ? k : len - 1 - k;
                        const uint32_t prev = st.step > 0 ? cur - 1 : cur + 1;
                        const uint32_t x = st.horizontal ? cur : l, y = st.horizontal ? l : cur;
                        const size_t ic = at(x, y);
                        if (!candidate(ic, st.horizontal ? at(prev, l) : at(l, prev)))
                            break;
                        const Ident old{pts_[ic].oid, pts_[ic].shadow};
                        s = source.evaluate(camera_sample(x, y));
                        shadow_.add(std::span<const Sample>(&s, 1));
                        Counts counts;
                        apply_correction(x, y, old, s, source, counts);
                        add_counts(counts);
                    }
                }
            }
        }
    }

    // ---- Resolve: box filter of the ss x ss samples of each pixel -----------------------
    /// A job is not a tile but its share of the row-major output by its place in the work list
    /// (PixelRect::index of count; stage_jobs asks for one job per pixel row): a run of
    /// consecutive pixels. (Per tile, a job's pixels would be 8 short rows sharing cache lines
    /// with the next tile's, resolved at the same time on another thread.) The reads (blocked
    /// layout) are shared only.
    void resolve_tile(const PixelRect &tile) {
        const size_t np = size_t(width_) * height_, count = std::max<size_t>(1, tile.count);
        const size_t begin = size_t(tile.index) * np / count;
        const size_t end = (size_t(tile.index) + 1) * np / count;
        const float inv_n = 1.f / float(ss_ * ss_);
        const bool diag = diagnostics();
        uint32_t px = uint32_t(begin % width_), py = uint32_t(begin / width_);
        if (ss_ == 1 && !diag) {  // a copy: a point's colour is already 0 when not finite
            // Within a block, a row's points are consecutive: copy them a block row at a time.
            for (size_t o = begin; o < end;) {
                const size_t run = std::min<size_t>(end - o, width_ - px);
                for (size_t k = 0; k < run;) {
                    const uint32_t x = px + uint32_t(k);
                    const size_t seg = std::min<size_t>(run - k, block_mask_ + 1 - (x & block_mask_));
                    const size_t p = at(x, py);
                    std::memcpy(&pix_color_[o], &col_[p], seg * sizeof(Rgb));
                    std::memcpy(&pix_rays_[o], &ray_[p], seg * sizeof(float));
                    k += seg;
                    o += seg;
                }
                px = 0;
                ++py;
            }
            return;
        }
        for (size_t o = begin; o < end; ++o) {
            Rgb sum(0.f);
            float n_rays = 0.f;
            uint32_t good = 0;
            for (uint32_t j = 0; j < ss_; ++j)
                for (uint32_t i = 0; i < ss_; ++i) {
                    const size_t p = at(px * ss_ + i, py * ss_ + j);
                    sum += col_[p];  // 0 when not finite
                    n_rays += ray_[p];
                    good += pts_[p].nan ? 0 : 1;
                }
            pix_color_[o] = good ? sum / float(good) : Rgb(0.f);
            pix_rays_[o] = n_rays;
            if (diag) {
                uint32_t n_traced = 0, cls_sum = 0, check = 0, pc = 0;
                for (uint32_t j = 0; j < ss_; ++j)
                    for (uint32_t i = 0; i < ss_; ++i) {
                        const Point &m = pts_[at(px * ss_ + i, py * ss_ + j)];
                        n_traced += is_traced(m.state) ? 1 : 0;
                        cls_sum += m.cls;
                        if (m.check && (!check || m.check < check))
                            check = m.check;
                        pc = std::max<uint32_t>(pc, m.pc);
                    }
                pix_traced_[o] = float(n_traced) * inv_n;
                pix_class_[o] = float(cls_sum) * inv_n;
                pix_check_[o] = float(check);
                pix_pc_[o] = float(pc);
            }
            if (++px == width_) {
                px = 0;
                ++py;
            }
        }
    }

    // Parameters.
    uint32_t block_, ss_;
    int postcorrect_;
    bool pc_shadow_;
    bool pc_lines_;  ///< a scan's jobs are whole image lines (the paper's), not blocks
    float t_pos_, scene_size_;
    Thresholds th_;
    std::vector<StageDesc> stages_;

    // Frame geometry: pixels and the (supersampled) lattice.
    uint32_t width_ = 0, height_ = 0, lw_ = 0, lh_ = 0;
    uint32_t block_shift_ = 3, block_mask_ = 7, blocks_x_ = 0;

    // Per lattice point (blocked layout, see at()).
    LargeVector<Attr> attr_;
    LargeVector<Point> pts_;

    // Per lattice point (blocked layout, see at()): colour (0 when not finite) and rays.
    LargeVector<Rgb> col_;
    LargeVector<float> ray_;

    // Per pixel (row-major), written by the resolve stage.
    std::vector<Rgb> pix_color_;
    std::vector<float> pix_rays_, pix_traced_, pix_class_, pix_check_, pix_pc_;
    // Frame totals, added per stage tile (Counts).
    std::atomic<uint64_t> traced_total_{0}, shaded_total_{0}, rays_total_{0};
    std::atomic<int64_t> nan_total_{0};
    FrameShadowRays shadow_;
    // Bounding box of the B pixels' hit points this frame (scene-size = 0), merged per tile.
    std::mutex box_mutex_;
    Vec3f box_lo_, box_hi_;
    bool box_any_ = false;

    // Post-correction: lines (rows or columns) whose chains cross a tile border.
    // Per line, cross_words_ words: bit s set when a chain of the current scan crosses into
    // segment (block) s of the line (scan_rect sets it, cross_lines clears it).
    std::unique_ptr<std::atomic<uint64_t>[]> line_flags_;
    size_t line_flags_size_ = 0;
    uint32_t cross_words_ = 1;
    std::atomic<bool> crossed_{false};  ///< some line was flagged in the current scan
    // Per block of at(): 1 when it holds a seed (kTracedA or kCorrected) this frame, so that a
    // scan skips the tiles without one without reading their points.
    std::unique_ptr<std::atomic<uint8_t>[]> block_seed_;
    size_t block_seed_size_ = 0;
    std::vector<uint32_t> scan_blocks_;  ///< the current scan's jobs (list_seeded_blocks)
};

}  // namespace

PluginInfo kim_plugin_info() {
    PluginInfo info;
    info.name = "kim";
    info.kind = PluginKind::Frame;
    info.summary =
        "adaptive undersampling: base pixels traced, A1/A2 pixels interpolated from two "
        "references when seven similarity checks pass, post-correction scans for "
        "missing objects and shadows (Kim et al., Adaptive Undersampling for "
        "Efficient Mobile Ray Tracing)";
    info.params = {
        {"block", 2, 2, 8, true, "base block: B pixel every block-th pixel in x and y (2, 4 or 8)"},
        {"ss", 1, 1, 4, true, "supersampling: ss x ss samples per pixel (1, 2 or 4), box filter"},
        {"t-pos", 0.03, 0, 1e6, false,
         "G2: largest hit-point distance, relative to the scene's longest side"},
        {"t-norm", 0.9, -1, 1, false, "G3: smallest dot product of the two normals"},
        {"t-tex", 0.3, 0, 0.5, false,
         "TX: fails when the references straddle a texture seam (< t-tex and > 1 - t-tex)"},
        {"t-gcol", 0.15, 0, 1e6, false,
         "GC: largest difference of the global (reflected/refracted) colours"},
        {"postcorrect", 4, 0, 4, true,
         "post-correction scans: 0 off, 2 (left-right, top-bottom), 4 (all four directions)"},
        {"pc-shadow", 1, 0, 1, true, "post-correction also looks for missing shadows (SHDBIT)"},
        {"pc-lines", 0, 0, 1, true,
         "1: each scan runs one job per image line, serially along it (the paper's threads; a "
         "reference), 0: one per 8x8-pixel block that holds a seed, chains across blocks after"},
        {"scene-size", 0, 0, 1e30, false,
         "longest side of the scene for t-pos (0: measured from the base pixels' hits)"},
    };
    info.make = [](const PluginParams &p) -> std::unique_ptr<PixelSampler> {
        const int block = p.get_int("block");
        if (block != 2 && block != 4 && block != 8)
            throw std::invalid_argument("kim: block must be 2, 4 or 8 (got " +
                                        std::to_string(block) + ")");
        const int ss = p.get_int("ss");
        if (ss != 1 && ss != 2 && ss != 4)
            throw std::invalid_argument("kim: ss must be 1, 2 or 4 (got " + std::to_string(ss) +
                                        ")");
        const int pc = p.get_int("postcorrect");
        if (pc != 0 && pc != 2 && pc != 4)
            throw std::invalid_argument("kim: postcorrect must be 0, 2 or 4 (got " +
                                        std::to_string(pc) + ")");
        return std::make_unique<KimSampler>(p);
    };
    return info;
}

}  // namespace tessera::sampling
