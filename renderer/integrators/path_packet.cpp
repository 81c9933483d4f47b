// The path tracer's "packet" specialisation (renderer/scene/specialize.h): up to 8 samples traced
// in lockstep, lane-parallel.
//
// Scenes whose materials are all constant Lambertians (the "lambertian" specialisation) and
// whose geometry is opaque triangle meshes only take this kernel in evaluate_batch. Each round
// traces the live paths' rays as one Embree packet, then runs every step of a bounce as a loop
// over the 8 lanes on structure-of-arrays data: the hit point, its error bounds, normals and
// shading frame (Geometry's fill_triangle and Frame::from_xz), the sampler's values, the BSDF
// value and density, the MIS weight, the ray offsets, cosine-weighted sampling, Russian
// roulette. GCC vectorises these loops (8 floats per AVX2 instruction). A pinhole camera's
// rays, the pixel filter's importance sampling included, are generated 8 at a time too, and a
// ray that misses the scene's bounds escapes without an Embree call. What is rare or
// polymorphic stays a per-lane call: light selection and light sampling (other than triangle
// lights), emission found by a hit or by an escaped ray, other cameras' rays.
//
// Every lane performs the operations of PathIntegrator::trace_impl<true> in the same order on
// the same floats (-ffp-contract=off: no fused multiply-adds), so a sample's value is bit for
// bit the scalar path's; tests/renderer/test_specialize.cpp checks that.
#include <embree3/rtcore.h>
#include <immintrin.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>

// Without AVX (TESSERA_ISA=default, or a sanitizer build) the compiler warns that 32-byte
// vector arguments change the ABI: here and in the 8-lane Sobol hashes of sampling/sequence.h
// that this file instantiates (so before the includes: clang checks the pragma where the
// template is written). The functions are internal to this file, so no ABI is at stake.
#pragma GCC diagnostic ignored "-Wpsabi"

#include "renderer/scene/geometry.h"
#include "renderer/integrators/path_integrator.h"

namespace tessera {

namespace {

constexpr int kLanes = 8;

// GCC vector types: 8 lanes, one AVX2 register. Arithmetic is element-wise IEEE, as in scalar
// code; comparisons give lane masks (-1 or 0); `m ? a : b` selects per lane.
typedef float vf __attribute__((vector_size(32)));
typedef int32_t vi __attribute__((vector_size(32)));
typedef uint32_t vu __attribute__((vector_size(32)));

inline vf splat(float a) {
    return vf{} + a;
}
inline vu splat_u(uint32_t a) {
    return vu{} + a;
}
/// Lane-wise sqrt: one vsqrtps with AVX (the default build's x86-64-v3), else lane by lane.
inline vf vsqrt(vf a) {
#ifdef __AVX__
    return (vf)_mm256_sqrt_ps((__m256)a);
#else
    vf r = a;
    for (int i = 0; i < kLanes; ++i)
        r[i] = std::sqrt(a[i]);
    return r;
#endif
}
inline vf vabs(vf a) {
    return (vf)((vu)a & 0x7fffffffu);
}
/// std::max(a, b) and std::min(a, b), lane by lane (the same NaN behaviour).
inline vf vmax(vf a, vf b) {
    return a < b ? b : a;
}
inline vf vmin(vf a, vf b) {
    return b < a ? b : a;
}
inline vi visfinite(vf a) {
    return (vi)(((vu)a & 0x7f800000u) != 0x7f800000u);
}
inline vi visnan(vf a) {
    return a != a;
}

/// 8 lanes of a 3-vector or an RGB triple. Operators as Vec3f's / Rgb's, in the same order.
struct V3 {
    vf x{}, y{}, z{};
    Vec3f get(int i) const { return {x[i], y[i], z[i]}; }
    void set(int i, Vec3f a) {
        x[i] = a.x;
        y[i] = a.y;
        z[i] = a.z;
    }
    void set(int i, Rgb a) {
        x[i] = a.r;
        y[i] = a.g;
        z[i] = a.b;
    }
    Rgb rgb(int i) const { return {x[i], y[i], z[i]}; }
};
inline V3 operator+(const V3 &a, const V3 &b) {
    return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline V3 operator-(const V3 &a, const V3 &b) {
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline V3 operator-(const V3 &a) {
    return {-a.x, -a.y, -a.z};
}
inline V3 operator*(const V3 &a, vf s) {
    return {a.x * s, a.y * s, a.z * s};
}
inline V3 mul(const V3 &a, const V3 &b) {
    return {a.x * b.x, a.y * b.y, a.z * b.z};
}
inline vf dot(const V3 &a, const V3 &b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline V3 cross(const V3 &a, const V3 &b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline V3 vabs(const V3 &a) {
    return {vabs(a.x), vabs(a.y), vabs(a.z)};
}
inline V3 vmax(const V3 &a, const V3 &b) {
    return {vmax(a.x, b.x), vmax(a.y, b.y), vmax(a.z, b.z)};
}
inline V3 select(vi m, const V3 &a, const V3 &b) {
    return {m ? a.x : b.x, m ? a.y : b.y, m ? a.z : b.z};
}
/// Vec3f / float and Rgb / float: multiplication by the reciprocal.
inline V3 div(const V3 &a, vf s) {
    return a * (1.f / s);
}
inline vi is_black(const V3 &c) {
    return (c.x == 0.f) & (c.y == 0.f) & (c.z == 0.f);
}
inline vi is_finite(const V3 &c) {
    return visfinite(c.x) & visfinite(c.y) & visfinite(c.z);
}
/// Rgb::max_value and max_component: std::max(x, std::max(y, z)).
inline vf max_value(const V3 &c) {
    return vmax(c.x, vmax(c.y, c.z));
}

/// Frame::from_z (Duff et al. 2017) and Frame::from_xz, lane by lane.
inline void frame_from_z(const V3 &n, V3 &x, V3 &y) {
    const vf sign = (vf)(((vu)n.z & 0x80000000u) | (vu)splat(1.f));
    const vf a = -1.f / (sign + n.z);
    const vf b = n.x * n.y * a;
    x = {1 + sign * n.x * n.x * a, sign * b, -sign * n.x};
    y = {b, sign + n.y * n.y * a, -n.y};
}
inline void frame_from_xz(const V3 &dpdu, const V3 &n, V3 &x, V3 &y) {
    const V3 t = dpdu - n * dot(n, dpdu);
    const vf len2 = dot(t, t);
    const vi ok = len2 > 1e-20f;
    const V3 xs = div(t, vsqrt(len2));
    const V3 ys = cross(n, xs);
    V3 xz, yz;
    frame_from_z(n, xz, yz);
    x = select(ok, xs, xz);
    y = select(ok, ys, yz);
}

/// next_float_up / next_float_down (renderer/util/interaction.h), lane by lane.
inline vf next_up(vf v) {
    const vf v2 = v == 0.f ? splat(0.f) : v;
    vu ui = (vu)v2;
    ui = v2 >= 0.f ? ui + 1u : ui - 1u;
    return v == kInfinity ? v : (vf)ui;
}
inline vf next_down(vf v) {
    const vf v2 = v == 0.f ? splat(-0.f) : v;
    vu ui = (vu)v2;
    ui = v2 > 0.f ? ui - 1u : ui + 1u;
    return v == -kInfinity ? v : (vf)ui;
}
/// offset_ray_origin, lane by lane.
inline V3 offset_origin(const V3 &p, const V3 &p_error, const V3 &n, const V3 &w) {
    const vf d = vabs(n.x) * p_error.x + vabs(n.y) * p_error.y + vabs(n.z) * p_error.z;
    V3 offset = n * d;
    offset = select(dot(w, n) < 0.f, -offset, offset);
    const V3 po = p + offset;
    auto step = [](vf off, vf v) {
        return off > 0.f ? next_up(v) : (off < 0.f ? next_down(v) : v);
    };
    return {step(offset.x, po.x), step(offset.y, po.y), step(offset.z, po.z)};
}

/// power_heuristic, lane by lane.
inline vf power_heuristic(vf pdf_a, vf pdf_b) {
    const vf a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    const vf w = a + b > 0.f ? a / (a + b) : splat(0.f);
    return vabs(a) == kInfinity ? splat(1.f) : w;
}

// The sampler's values for 8 lanes: SobolSampler::get_1d / get_2d of each lane's pixel hash,
// dimension and bit-reversed sample index, by the same integer steps (sampling::lanes in
// sampling/sequence.h, instantiated for 8-lane vectors).

inline vf fixed_to_unit(vu x) {
    const vf f = __builtin_convertvector((vi)(x >> 8), vf) * 0x1p-24f;
    return vmin(f, splat(kOneMinusEpsilon));
}

vf sobol_1d(vu pixel_hash, vu dim, vu index_rev) {
    const vu h = sampling::lanes::hash_dimension(pixel_hash, dim);
    return fixed_to_unit(sampling::lanes::sobol_1d_rev(h, index_rev));
}

// sampling::sobol_dim1_reversed: four byte-indexed tables, XORed.
inline vu sobol_dim1_reversed(vu z) {
#ifdef __AVX2__
    const auto &table = sampling::detail::kSobolDim1ReversedTable;
    auto gather = [](const uint32_t *t, vu idx) {
        return (vu)_mm256_i32gather_epi32(reinterpret_cast<const int *>(t), (__m256i)idx, 4);
    };
    return gather(table[0].data(), z & 0xffu) ^ gather(table[1].data(), (z >> 8) & 0xffu) ^
           gather(table[2].data(), (z >> 16) & 0xffu) ^ gather(table[3].data(), z >> 24);
#else
    vu d1 = z;
    for (int i = 0; i < kLanes; ++i) d1[i] = sampling::sobol_dim1_reversed(z[i]);
    return d1;
#endif
}

void sobol_2d(vu pixel_hash, vu dim, vu index_rev, vf &ux, vf &uy) {
    const vu h = sampling::lanes::hash_dimension(pixel_hash, dim);
    vu x_rev, y_rev;
    sampling::lanes::sobol_2d_rev(h, index_rev, sobol_dim1_reversed, x_rev, y_rev);
    ux = fixed_to_unit(sampling::lanes::reverse_bits(x_rev));
    uy = fixed_to_unit(sampling::lanes::reverse_bits(y_rev));
}

/// sampling::square_to_cosine_hemisphere (concentric map, sincos_quarter_pi), lane by lane.
inline V3 cosine_hemisphere(vf ux, vf uy) {
    const vf ox = 2.f * ux - 1.f, oy = 2.f * uy - 1.f;
    const vi zero = (ox == 0.f) & (oy == 0.f);
    const vi xbig = vabs(ox) > vabs(oy);
    const vf num = xbig ? oy : ox, den = xbig ? ox : oy;
    const vf x = kPiOver4 * (num / den);
    const vf x2 = x * x;
    const vf s =
        x * (1.f + x2 * (-1.f / 6 + x2 * (1.f / 120 + x2 * (-1.f / 5040 + x2 * (1.f / 362880)))));
    const vf c = 1.f + x2 * (-0.5f + x2 * (1.f / 24 + x2 * (-1.f / 720 + x2 * (1.f / 40320))));
    vf dx = xbig ? ox * c : oy * s;
    vf dy = xbig ? ox * s : oy * c;
    dx = zero ? splat(0.f) : dx;
    dy = zero ? splat(0.f) : dy;
    const vf dz = vsqrt(vmax(splat(0.f), 1.f - dx * dx - dy * dy));
    return {dx, dy, dz};
}

/// Whether any lane of a mask is set.
inline bool any(vi m) {
#ifdef __AVX__
    return _mm256_movemask_ps((__m256)m) != 0;
#else
    for (int i = 0; i < kLanes; ++i)
        if (m[i]) return true;
    return false;
#endif
}

/// t[idx], lane by lane (AVX2 gathers where available).
inline vf gather(const float *t, vi idx) {
#ifdef __AVX2__
    return (vf)_mm256_i32gather_ps(t, (__m256i)idx, 4);
#else
    vf r{};
    for (int i = 0; i < kLanes; ++i) r[i] = t[idx[i]];
    return r;
#endif
}
inline vi gather(const int32_t *t, vi idx) {
#ifdef __AVX2__
    return (vi)_mm256_i32gather_epi32(reinterpret_cast<const int *>(t), (__m256i)idx, 4);
#else
    vi r{};
    for (int i = 0; i < kLanes; ++i) r[i] = t[idx[i]];
    return r;
#endif
}

// SamplePattern::Sobol, lane by lane: sampling::sobol_sample_32 of each lane's own dimension
// (masked gathers of the matrix columns of the index's set bits), then the same Owen scramble
// as scrambled_sobol_nd. Lanes at a dimension past the table take the padded values, as
// SobolSampler::get_1d / get_2d do.

inline vu sobol_sample(vu dim, vu index) {
    const vu d = dim < sampling::kSobolMatrixDimensions ? dim
                                                         : splat_u(sampling::kSobolMatrixDimensions - 1);
    vu r = splat_u(0);
#ifdef __AVX2__
    const int *m = reinterpret_cast<const int *>(&sampling::kSobolMatrices[0][0]);
    vu col = d * 32u;
    for (vu rest = index; _mm256_movemask_ps((__m256)(rest != 0)) != 0; rest >>= 1, col += 1u) {
        const vi take = -(vi)(rest & 1u);
        r ^= (vu)_mm256_mask_i32gather_epi32(_mm256_setzero_si256(), m, (__m256i)col,
                                             (__m256i)take, 4);
    }
#else
    for (int i = 0; i < kLanes; ++i) r[i] = sampling::sobol_sample_32(d[i], index[i]);
#endif
    return r;
}

inline vf scrambled_sobol_nd(vu pixel_hash, vu dim, vu index) {
    const vu h = sampling::lanes::hash_dimension(pixel_hash, dim);
    const vu x = sampling::lanes::reverse_bits(sampling::lanes::laine_karras(
        sampling::lanes::reverse_bits(sobol_sample(dim, index)),
        sampling::lanes::coordinate_seed(h, 0)));
    return fixed_to_unit(x);
}

/// SobolSampler::get_1d / get_2d under either pattern (`sobol`: SamplePattern::Sobol).
inline vf sample_1d(bool sobol, vu pixel_hash, vu dim, vu index_rev) {
    if (!sobol)
        return sobol_1d(pixel_hash, dim, index_rev);
    const vi table = (vi)(dim < sampling::kSobolMatrixDimensions);
    const vf v = scrambled_sobol_nd(pixel_hash, dim, sampling::lanes::reverse_bits(index_rev));
    return any(~table) ? (table ? v : sobol_1d(pixel_hash, dim, index_rev)) : v;
}

inline void sample_2d(bool sobol, vu pixel_hash, vu dim, vu index_rev, vf &ux, vf &uy) {
    if (!sobol)
        return sobol_2d(pixel_hash, dim, index_rev, ux, uy);
    const vi table = (vi)(dim + 1u < sampling::kSobolMatrixDimensions);
    const vu index = sampling::lanes::reverse_bits(index_rev);
    ux = scrambled_sobol_nd(pixel_hash, dim, index);
    uy = scrambled_sobol_nd(pixel_hash, dim + 1u, index);
    if (any(~table)) {
        vf px, py;
        sobol_2d(pixel_hash, dim, index_rev, px, py);
        ux = table ? ux : px;
        uy = table ? uy : py;
    }
}

/// PixelFilter::sample_1d, lane by lane: the box, the tent (sampling::sample_tent) and the
/// Gaussian's guided inversion of its tabulated CDF, with the same operations.
vf filter_sample_1d(const PixelFilter &f, int axis, vf u) {
    const float r = f.radius()[axis];
    switch (f.kind()) {
    case PixelFilter::Kind::Box:
        return (2.f * u - 1.f) * r;
    case PixelFilter::Kind::Triangle: {
        const vf lo = -r + r * vsqrt(u * 2.f);
        const vf hi = r - r * vsqrt(1.f - (u - 0.5f) * 2.f);
        return u < 0.5f ? lo : hi;
    }
    // The tabulated filters invert the same CDF (the signed ones' weights are not applied
    // here: camera_rays takes the per-sample path for them).
    case PixelFilter::Kind::Gaussian:
    case PixelFilter::Kind::Mitchell:
    case PixelFilter::Kind::Lanczos: {
        constexpr int kN = PixelFilter::kTableSize, kG = PixelFilter::kGuideSize;
        const float *cdf = f.cdf(axis).data();
        const vi k = __builtin_convertvector(u * float(kG), vi);
        vi i = gather(f.guide(axis).data(), k < kG - 1 ? k : vi{} + (kG - 1));
        // Walk up while cdf[i + 1] <= u (i + 1 <= kN), as the scalar loop does per lane.
        while (true) {
            const vi in = i + 1 <= kN;
            const vi up = in & (gather(cdf, in ? i + 1 : i) <= u);
            if (!any(up))
                break;
            i -= up;  // up is -1 where a lane steps
        }
        i = i < 0 ? vi{} : (i > kN - 1 ? vi{} + (kN - 1) : i);
        const vf c0 = gather(cdf, i), c1 = gather(cdf, i + 1);
        const vf t = c1 > c0 ? (u - c0) / (c1 - c0) : splat(0.5f);
        return -r + (__builtin_convertvector(i, vf) + t) * (2 * r / kN);
    }
    }
    return vf{};
}

/// Lanes whose ray o + t d, t >= 0, surely misses the box [lo, hi] (a slab test with a relative
/// slack far above its rounding error; a NaN, from a direction parallel to a face through the
/// origin, counts as a possible hit).
inline vi misses_box(const V3 &o, const V3 &d, Vec3f lo, Vec3f hi) {
    vf tn = splat(0.f), tf = splat(kInfinity);
    vi nan{};
    auto slab = [&](vf oa, vf da, float l, float h) {
        const vf inv = 1.f / da;
        const vf t0 = (l - oa) * inv, t1 = (h - oa) * inv;
        nan |= visnan(t0) | visnan(t1);
        tn = vmax(tn, vmin(t0, t1));
        tf = vmin(tf, vmax(t0, t1));
    };
    slab(o.x, d.x, lo.x, hi.x);
    slab(o.y, d.y, lo.y, hi.y);
    slab(o.z, d.z, lo.z, hi.z);
    return (tn > tf + 1e-4f * (vabs(tn) + vabs(tf))) & ~nan;
}

vi mask_of(const std::array<bool, kLanes> &b) {
    vi m{};
    for (int i = 0; i < kLanes; ++i)
        m[i] = b[size_t(i)] ? -1 : 0;
    return m;
}

// ---------------------------------------------------------------------------------------------
// The packet kernel's state and the stages of one round of trace_packet, in its order. Every
// stage is always inlined into trace_packet: the split is for reading, the code is the one loop
// it was (bench_throughput measures both).

/// What the packet kernel takes from the integrator.
struct PacketSettings {
    const Scene &sc;
    const std::vector<const TriangleMesh *> &meshes;  ///< by Embree geomID
    const std::vector<Rgb> &lambertian;               ///< per material: its reflectance
    int max_depth;
    bool use_nee, use_bsdf_emission, cull;
    uint32_t nee_dims;  ///< the light's dimensions a bounce consumes: 3, or 0 without NEE
    bool sobol;         ///< the sampler's pattern is SamplePattern::Sobol
};

/// Per-lane path state. A lane traces samples[slot[i]]; when its path ends the lane takes the
/// next sample of the batch, so the lanes stay busy until the batch runs out. `Result` is
/// PathIntegrator's per-sample result.
template <class Result>
struct PacketPaths {
    std::array<Result, kLanes> res{};
    std::array<float, kLanes> weight{};
    std::array<int, kLanes> slot{};
    std::array<bool, kLanes> live{}, bounce{};
    std::array<int, kLanes> skips{};
    vi depth{};
    vu pixel_hash{}, index_rev{}, dim{};
    V3 o, d, L, beta, prev_p, prev_n;
    vf p_bsdf{};
    int next = 0;  ///< the next sample of the batch a lane takes
};

/// Camera rays of the batch, 8 samples at a time, and each sample's sampler state after them.
struct CameraBatch {
    int base = 0, count = 0;
    V3 o, d;
    vf weight{};
    vu pixel_hash{}, index_rev{}, dim{};
};

/// Lane-parallel camera rays of samples[cam.base, cam.base + 8) for a pinhole and a positive
/// filter (weight 1): the operations of camera_ray, PixelFilter::sample and
/// PerspectiveCamera::generate_ray, in the same order. `pinhole_dim`: the sampler's dimension
/// after them.
[[gnu::always_inline]] inline void pinhole_rays(const PerspectiveCamera::Pinhole &ph,
                                                const PixelFilter &filter,
                                                std::span<const CameraSample> samples,
                                                uint32_t seed, uint32_t pinhole_dim,
                                                CameraBatch &cam) {
    vu px{}, py{}, index{};
    vf fx{}, fy{};
    for (int j = 0; j < kLanes; ++j) {
        // Lanes past the end repeat the last sample (their results are never read).
        const CameraSample &cs = samples[size_t(cam.base + std::min(j, cam.count - 1))];
        px[j] = cs.px, py[j] = cs.py, index[j] = cs.index;
        fx[j] = cs.fx, fy[j] = cs.fy;
    }
    const vf rx = (__builtin_convertvector(px, vf) + 0.5f) + filter_sample_1d(filter, 0, fx);
    const vf ry = (__builtin_convertvector(py, vf) + 0.5f) + filter_sample_1d(filter, 1, fy);
    const V3 pc{(ph.p0.x + ph.dx.x * rx) + ph.dy.x * ry, (ph.p0.y + ph.dx.y * rx) + ph.dy.y * ry,
                (ph.p0.z + ph.dx.z * rx) + ph.dy.z * ry};
    const auto &m = ph.world_from_camera;
    const V3 dw{m[0][0] * pc.x + m[0][1] * pc.y + m[0][2] * pc.z,
                m[1][0] * pc.x + m[1][1] * pc.y + m[1][2] * pc.z,
                m[2][0] * pc.x + m[2][1] * pc.y + m[2][2] * pc.z};
    cam.d = div(dw, vsqrt(dot(dw, dw)));
    cam.o = {splat(m[0][3]), splat(m[1][3]), splat(m[2][3])};
    cam.weight = splat(1.f);
    cam.pixel_hash = sampling::lanes::hash_pixel(seed, px, py);
    cam.index_rev = sampling::lanes::reverse_bits(index);
    cam.dim = splat_u(pinhole_dim);
}

/// Embree's ray packets and what decides which rays they take.
struct PacketRays {
    alignas(32) RTCRayHit8 rh;
    alignas(32) RTCRay8 sr;
    alignas(32) int valid[kLanes], traced[kLanes];
    /// The scene's bounds, enlarged by a thousandth of their size (misses_box).
    Vec3f box_lo, box_hi;
    RTCScene rtc;

    explicit PacketRays(const Geometry &g) {
        const Vec3f box_pad =
            (g.bounds_max() - g.bounds_min()) * 1e-3f + Vec3f(1e-6f, 1e-6f, 1e-6f);
        box_lo = g.bounds_min() - box_pad;
        box_hi = g.bounds_max() + box_pad;
        rtc = g.rtc_scene();
        std::memset(&rh, 0, sizeof(rh));
        std::memset(&sr, 0, sizeof(sr));
        for (int i = 0; i < kLanes; ++i) {
            rh.ray.mask[i] = sr.mask[i] = 0xFFFFFFFFu;
            rh.ray.id[i] = sr.id[i] = unsigned(i);
        }
    }
};

/// The hit triangles' data, gathered per lane, then processed lane-parallel; `refl`, the hit
/// material's reflectance.
struct PacketHits {
    V3 p0, p1, p2, n0, n1, n2, refl;
    vf b1{}, b2{}, uv0x{}, uv0y{}, uv1x{}, uv1y{}, uv2x{}, uv2y{}, t_hit{};
    std::array<bool, kLanes> has_ns{}, flip{};
    std::array<int, kLanes> material{};
    std::array<const Light *, kLanes> area_light{};
};

/// Next-event estimation per lane: the light sample of this bounce.
struct PacketLightSamples {
    V3 wi, L, p;
    vf pdf = splat(1.f), pmf = splat(1.f);
    std::array<uint8_t, kLanes> kind{};  // 0: no light chosen, 1: a point, 2: a direction,
                                         // 3: chosen but nothing to trace
    std::array<bool, kLanes> delta{};
};

/// Intersects the `pending` lanes' rays as one packet (their hits in rays.rh). Whole registers
/// in: the packet's fields Embree does not write (tnear, time, mask, id, flags) were set once,
/// by PacketRays.
[[gnu::always_inline]] inline void intersect_rays(const V3 &o, const V3 &d,
                                                  const std::array<bool, kLanes> &pending,
                                                  PacketRays &rays) {
    RTCRayHit8 &rh = rays.rh;
    for (int i = 0; i < kLanes; ++i)
        rays.valid[i] = pending[size_t(i)] ? -1 : 0;
    std::memcpy(rh.ray.org_x, &o.x, sizeof(vf));
    std::memcpy(rh.ray.org_y, &o.y, sizeof(vf));
    std::memcpy(rh.ray.org_z, &o.z, sizeof(vf));
    std::memcpy(rh.ray.dir_x, &d.x, sizeof(vf));
    std::memcpy(rh.ray.dir_y, &d.y, sizeof(vf));
    std::memcpy(rh.ray.dir_z, &d.z, sizeof(vf));
    for (int i = 0; i < kLanes; ++i) {
        rh.ray.tfar[i] = kInfinity;
        rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
    // A ray that misses the scene's bounds escapes without a traversal (most camera rays of an
    // object against the sky): a lane-parallel test instead of Embree's.
    const vi miss = misses_box(o, d, rays.box_lo, rays.box_hi);
    bool any_traced = false;
    for (int i = 0; i < kLanes; ++i) {
        rays.traced[i] = rays.valid[i] && !miss[i] ? -1 : 0;
        any_traced |= rays.traced[i] != 0;
    }
    if (any_traced) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        rtcIntersect8(rays.traced, rays.rtc, &ctx, &rh);
    }
}

/// Lane i's ray escaped: the infinite lights' radiance, MIS-weighted against light sampling.
template <class Result>
[[gnu::always_inline]] inline void add_escaped_radiance(PacketPaths<Result> &P,
                                                        const PacketSettings &S, int i) {
    const Scene &sc = S.sc;
    const Vec3f dir = P.d.get(i);
    Rgb Li = P.L.rgb(i);
    const Rgb bt = P.beta.rgb(i);
    for (const Light *light : sc.infinite_lights) {
        Rgb Le = light->Le(dir);
        if (Le.is_black())
            continue;
        if (P.depth[i] == 0) {
            Li += bt * Le;
        } else if (S.use_bsdf_emission) {
            float w = 1.f;
            if (S.use_nee) {
                float p_l = sc.light_sampler->pmf(light) *
                            light->pdf_li(LightSampleContext{P.prev_p.get(i), P.prev_n.get(i)},
                                          dir, Vec3f(), Vec3f());
                w = tessera::power_heuristic(P.p_bsdf[i], p_l);
            }
            Li += bt * Le * w;
        }
    }
    P.L.set(i, Li);
}

/// Lane i's hit triangle (rays.rh): its vertices, uvs, normals, material and light.
[[gnu::always_inline]] inline void gather_hit(const PacketRays &rays,
                                              const std::vector<const TriangleMesh *> &meshes,
                                              int i, PacketHits &H) {
    const RTCRayHit8 &rh = rays.rh;
    const TriangleMesh &m = *meshes[rh.hit.geomID[i]];
    const unsigned prim = rh.hit.primID[i];
    const uint32_t i0 = m.indices[3 * prim], i1 = m.indices[3 * prim + 1],
                   i2 = m.indices[3 * prim + 2];
    H.p0.set(i, m.p[i0]);
    H.p1.set(i, m.p[i1]);
    H.p2.set(i, m.p[i2]);
    Vec2f uv0{0, 0}, uv1{1, 0}, uv2{1, 1};
    if (!m.uv.empty()) {
        uv0 = m.uv[i0];
        uv1 = m.uv[i1];
        uv2 = m.uv[i2];
    }
    H.uv0x[i] = uv0.x, H.uv0y[i] = uv0.y, H.uv1x[i] = uv1.x, H.uv1y[i] = uv1.y;
    H.uv2x[i] = uv2.x, H.uv2y[i] = uv2.y;
    H.has_ns[size_t(i)] = !m.n.empty();
    if (!m.n.empty()) {
        H.n0.set(i, m.n[i0]);
        H.n1.set(i, m.n[i1]);
        H.n2.set(i, m.n[i2]);
    }
    H.flip[size_t(i)] = m.flip_normal;
    H.material[size_t(i)] = m.material;
    H.area_light[size_t(i)] = m.lights.empty() ? nullptr : m.lights[prim];
    H.b1[i] = rh.hit.u[i];
    H.b2[i] = rh.hit.v[i];
    H.t_hit[i] = rh.ray.tfar[i];
}

/// Traces the live lanes' rays; sets bounce[i] for the lanes that hit a triangle (its data in
/// H). A lane whose ray escapes finishes at once (finish_lane) and takes the next sample, whose
/// camera ray is traced before the round goes on: the lane-parallel steps after this one then
/// run on full lanes (most camera rays of an object on a plain background miss it).
template <class Result, class FinishLane>
[[gnu::always_inline]] inline void intersect(PacketPaths<Result> &P, PacketRays &rays,
                                             PacketHits &H, const PacketSettings &S,
                                             FinishLane &&finish_lane) {
    for (int i = 0; i < kLanes; ++i)
        P.bounce[size_t(i)] = false;
    std::array<bool, kLanes> pending = P.live;
    while (std::any_of(pending.begin(), pending.end(), [](bool b) { return b; })) {
        intersect_rays(P.o, P.d, pending, rays);
        // Per lane: escapes, and the hit triangle's data.
        pending = {};
        for (int i = 0; i < kLanes; ++i) {
            if (!rays.valid[i])
                continue;
            ++P.res[size_t(i)].rays;
            if (rays.rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {
                add_escaped_radiance(P, S, i);
                P.live[size_t(i)] = false;
                finish_lane(i);
                pending[size_t(i)] = P.live[size_t(i)];
                continue;
            }
            gather_hit(rays, S.meshes, i, H);
            P.bounce[size_t(i)] = true;
        }
    }
}

/// The hit points, lane-parallel: Geometry's fill_triangle, then wo.
struct PacketSurface {
    vf c0{}, c1{}, c2{};  ///< barycentrics
    V3 p, p_error, dpdu, nn, ns, wo;
};

[[gnu::always_inline]] inline PacketSurface surface_points(const PacketHits &H, const V3 &d) {
    constexpr float g7 = gamma_n(7);
    PacketSurface s;
    const vf c1 = H.b1, c2 = H.b2, c0 = 1.f - c1 - c2;
    s.c0 = c0, s.c1 = c1, s.c2 = c2;
    const V3 &p0 = H.p0, &p1 = H.p1, &p2 = H.p2;
    s.p = p0 * c0 + p1 * c1 + p2 * c2;
    {
        const V3 err = (vabs(p0 * c0) + vabs(p1 * c1) + vabs(p2 * c2)) * splat(g7);
        const vf mag = max_value(vmax(vabs(p0), vmax(vabs(p1), vabs(p2))));
        const vf m7 = mag * g7;
        s.p_error = vmax(err, V3{m7, m7, m7});
    }
    {
        const vf duv02x = H.uv0x - H.uv2x, duv02y = H.uv0y - H.uv2y;
        const vf duv12x = H.uv1x - H.uv2x, duv12y = H.uv1y - H.uv2y;
        const V3 dp02 = p0 - p2, dp12 = p1 - p2;
        const vf det = duv02x * duv12y - duv02y * duv12x;
        V3 g = cross(dp02, dp12);
        const vf g_len = vsqrt(dot(g, g));
        const vi g_pos = g_len > 0.f;
        g = select(g_pos, div(g, g_len), V3{splat(0.f), splat(0.f), splat(1.f)});
        const vi degenerate_uv = vabs(det) < 1e-9f;
        const vf inv = 1.f / det;
        const V3 du = (dp02 * duv12y - dp12 * duv02y) * inv;
        const V3 dv = (dp12 * duv02x - dp02 * duv12x) * inv;
        const vi bad = degenerate_uv | ~g_pos | ~visfinite(du.x) | ~visfinite(dv.x);
        V3 fzx, fzy;
        frame_from_z(g, fzx, fzy);
        s.dpdu = select(bad, fzx, du);
        g = select(mask_of(H.flip), -g, g);
        const V3 v = H.n0 * c0 + H.n1 * c1 + H.n2 * c2;
        const vf l2 = dot(v, v);
        const vi ok = mask_of(H.has_ns) & (l2 > 0.f) & visfinite(l2);
        const V3 vn = div(v, vsqrt(l2));
        s.nn = select(ok & (dot(g, vn) < 0.f), -g, g);
        s.ns = select(ok, vn, g);
    }
    {
        const vf d2 = dot(d, d);
        s.wo = select(vabs(d2 - 1.f) < 1e-6f, -d, -div(d, vsqrt(d2)));
    }
    return s;
}

/// Lane i hit an emitter: its radiance, MIS-weighted against light sampling.
template <class Result>
[[gnu::always_inline]] inline void add_emission(PacketPaths<Result> &P, const PacketHits &H,
                                                const PacketSurface &s, const PacketSettings &S,
                                                const Light *al, int i) {
    const Vec3f ph = s.p.get(i), nh = s.nn.get(i);
    const float e1 = s.c1[i], e2 = s.c2[i], e0 = s.c0[i];
    const Vec2f uv = Vec2f{H.uv0x[i], H.uv0y[i]} * e0 + Vec2f{H.uv1x[i], H.uv1y[i]} * e1 +
                     Vec2f{H.uv2x[i], H.uv2y[i]} * e2;
    Rgb Le = al->L(ph, nh, uv, s.wo.get(i));
    if (Le.is_black())
        return;
    const Rgb bt = P.beta.rgb(i);
    Rgb Li = P.L.rgb(i);
    if (P.depth[i] == 0) {
        Li += bt * Le;
    } else if (S.use_bsdf_emission) {
        float w = 1.f;
        if (S.use_nee) {
            float p_l = S.sc.light_sampler->pmf(al) *
                        al->pdf_li(LightSampleContext{P.prev_p.get(i), P.prev_n.get(i)},
                                   normalize(P.d.get(i)), ph, nh);
            w = tessera::power_heuristic(P.p_bsdf[i], p_l);
        }
        Li += bt * Le * w;
    }
    P.L.set(i, Li);
}

/// Per lane: the first hit's AOVs, emission, the material; the path may end here (an
/// "interface" skipped too often, or the last bounce).
template <class Result>
[[gnu::always_inline]] inline void shade_hits(PacketPaths<Result> &P, PacketHits &H,
                                              const PacketSurface &s, const PacketSettings &S) {
    for (int i = 0; i < kLanes; ++i) {
        if (!P.bounce[size_t(i)])
            continue;
        Result &r = P.res[size_t(i)];
        if (P.depth[i] == 0 && P.skips[size_t(i)] == 0) {
            r.depth = H.t_hit[i] * length(P.d.get(i));
            r.normal = s.ns.get(i);
        }
        if (const Light *al = H.area_light[size_t(i)])
            add_emission(P, H, s, S, al, i);
        const int mat = H.material[size_t(i)];
        if (mat < 0) {
            // "interface": no surface here; continue the ray without a bounce.
            P.bounce[size_t(i)] = false;
            if (++P.skips[size_t(i)] > 256) {
                P.live[size_t(i)] = false;
            } else {
                P.o.set(i, offset_ray_origin(s.p.get(i), s.p_error.get(i), s.nn.get(i),
                                             P.d.get(i)));
            }
            continue;
        }
        const Rgb R = S.lambertian[size_t(mat)];
        H.refl.set(i, R);
        if (P.depth[i] == 0)
            r.albedo = R;
        if (P.depth[i]++ == S.max_depth) {
            P.bounce[size_t(i)] = false;
            P.live[size_t(i)] = false;
        }
    }
}

/// The sampler's values of a bounce, in trace_impl's dimension layout: light 1D and 2D (when
/// next-event estimation is on), BSDF 1D (unused by a Lambertian) and 2D, roulette 1D.
struct BounceSamples {
    vf u_light{}, u2x{}, u2y{}, ub_x{}, ub_y{}, u_rr{};
};

template <class Result>
[[gnu::always_inline]] inline BounceSamples bounce_samples(const PacketPaths<Result> &P,
                                                           const PacketSettings &S) {
    BounceSamples u;
    if (S.use_nee) {
        u.u_light = sample_1d(S.sobol, P.pixel_hash, P.dim, P.index_rev);
        sample_2d(S.sobol, P.pixel_hash, P.dim + 1u, P.index_rev, u.u2x, u.u2y);
    }
    sample_2d(S.sobol, P.pixel_hash, P.dim + (S.nee_dims + 1u), P.index_rev, u.ub_x, u.ub_y);
    u.u_rr = sample_1d(S.sobol, P.pixel_hash, P.dim + (S.nee_dims + 3u), P.index_rev);
    return u;
}

/// The triangle lights chosen by select_lights, for the lane-parallel sampling after it.
struct TriangleLightLanes {
    V3 p0, p1, p2, n, L;
    vf area{}, pmf{};
    vi twosided{}, lane{};  ///< lane: -1 where the lane's light is a triangle
};

/// Per lane: light selection. Other lights than triangles are sampled here (into ls); triangle
/// lights' data is gathered into the result, for sample_triangle_lights.
template <class Result>
[[gnu::always_inline]] inline TriangleLightLanes select_lights(const PacketPaths<Result> &P,
                                                               const PacketHits &H,
                                                               const PacketSurface &s,
                                                               const BounceSamples &u,
                                                               const PacketSettings &S,
                                                               PacketLightSamples &ls) {
    const Scene &sc = S.sc;
    TriangleLightLanes t;
    for (int i = 0; i < kLanes; ++i) {
        ls.kind[size_t(i)] = 0;
        if (!P.bounce[size_t(i)]) continue;
        if (!(S.use_nee && !H.refl.rgb(i).is_black() && sc.light_sampler)) continue;
        auto sampled = sc.light_sampler->sample(u.u_light[i]);
        if (!sampled) continue;
        ls.kind[size_t(i)] = 3;
        if (sampled->light->shape() == LightShape::Triangle) {
            const auto *tri = static_cast<const TriangleLight *>(sampled->light);
            t.lane[i] = -1;
            t.p0.set(i, tri->p0());
            t.p1.set(i, tri->p1());
            t.p2.set(i, tri->p2());
            t.n.set(i, tri->normal());
            t.L.set(i, tri->radiance());
            t.area[i] = tri->area();
            t.twosided[i] = tri->twosided() ? -1 : 0;
            t.pmf[i] = sampled->pmf;
            // A sample-only (invisible) emitter is a delta light to MIS: no ray finds it.
            ls.delta[size_t(i)] = is_delta_light(tri->type());
            continue;
        }
        auto l = sampled->light->sample_li(LightSampleContext{s.p.get(i), s.nn.get(i)},
                                           {u.u2x[i], u.u2y[i]});
        if (!(l && (!S.cull || !l->L.is_black()) && l->pdf > 0)) continue;
        const LightType lt = sampled->light->type();
        ls.delta[size_t(i)] = is_delta_light(lt);
        ls.kind[size_t(i)] = (lt == LightType::Infinite || lt == LightType::DeltaDirection) ? 2 : 1;
        ls.wi.set(i, l->wi);
        ls.L.set(i, l->L);
        ls.p.set(i, l->p_light);
        ls.pdf[i] = l->pdf;
        ls.pmf[i] = sampled->pmf;
    }
    return t;
}

/// Lane-parallel TriangleLight::sample_li for the lanes that chose a triangle light: a uniform
/// point on the triangle (square_to_uniform_triangle), its direction and solid-angle density,
/// the one-sided test and the radiance, with the same operations.
[[gnu::always_inline]] inline void sample_triangle_lights(const TriangleLightLanes &t,
                                                          const BounceSamples &u, const V3 &p,
                                                          PacketLightSamples &ls) {
    const vi &t_lane = t.lane;
    if (!(t_lane[0] | t_lane[1] | t_lane[2] | t_lane[3] | t_lane[4] | t_lane[5] | t_lane[6] |
          t_lane[7]))
        return;
    const vf u2x = u.u2x, u2y = u.u2y;
    const vi lower = u2x < u2y;
    const vf half_x = u2x / 2.f, half_y = u2y / 2.f;
    const vf bx = lower ? half_x : u2x - half_y;
    const vf by = lower ? u2y - half_x : half_y;
    const V3 pl = t.p0 * bx + t.p1 * by + t.p2 * (1.f - bx - by);
    const V3 dl = pl - p;
    const vf d2 = dot(dl, dl);
    const vf inv_dist = 1.f / vsqrt(d2);
    const V3 wi = dl * inv_dist;
    const vf cos_l = vabs(dot(t.n, wi));
    const vf pdf = d2 / (t.area * cos_l);
    const vi ok = t_lane & (t.area > 0.f) & (d2 != 0.f) & (cos_l != 0.f) & visfinite(pdf) &
                  (pdf != 0.f) & (t.twosided | (dot(t.n, wi) < 0.f)) & ~is_black(t.L) &
                  (pdf > 0.f);
    ls.wi = select(ok, wi, ls.wi);
    ls.L = select(ok, t.L, ls.L);
    ls.p = select(ok, pl, ls.p);
    ls.pdf = ok ? pdf : ls.pdf;
    ls.pmf = ok ? t.pmf : ls.pmf;
    for (int i = 0; i < kLanes; ++i)
        if (ok[i]) ls.kind[size_t(i)] = 1;
}

/// The light samples' contributions and their shadow rays.
struct ShadowRays {
    V3 contrib, o, d;
    vf tmax{};
    vi mask{};  ///< lanes with a shadow ray to trace
};

/// Lane-parallel: the BSDF's value and density (LambertianBsdf::f_pdf), the MIS weight, the
/// contribution and the shadow ray (spawn_ray / spawn_ray_to).
template <class Result>
[[gnu::always_inline]] inline ShadowRays direct_light(const PacketPaths<Result> &P,
                                                      const PacketHits &H,
                                                      const PacketSurface &s,
                                                      const PacketLightSamples &ls,
                                                      const PacketSettings &S) {
    ShadowRays sh;
    vi kind{}, delta{};
    for (int i = 0; i < kLanes; ++i) {
        kind[i] = ls.kind[size_t(i)];
        delta[i] = ls.delta[size_t(i)] ? -1 : 0;
    }
    const vi active = (kind == 1) | (kind == 2);
    const vi directional = kind == 2;
    const vf co = dot(s.wo, s.ns), ci = dot(ls.wi, s.ns);
    const vi same = co * ci > 0.f;
    const V3 fr = H.refl * splat(kInvPi);
    V3 f = select(same & is_finite(fr), fr, V3{});
    vf p_b = splat(0.f);
    if (S.use_bsdf_emission) {
        const vf l2 = dot(ls.wi, ls.wi);
        const vf c = vabs(l2 - 1.f) < 1e-6f ? ci : ci / vsqrt(l2);
        const vf pd = vabs(c) * kInvPi;
        p_b = ~delta & same & visfinite(pd) ? pd : splat(0.f);
    }
    f = f * vabs(ci);
    sh.mask = active;
    if (S.cull)
        sh.mask &= ~is_black(f);
    const V3 w = select(directional, ls.wi, ls.p - s.p);
    sh.o = offset_origin(s.p, s.p_error, s.nn, w);
    sh.d = select(directional, ls.wi, ls.p - sh.o);
    sh.tmax = directional ? splat(kInfinity) : splat(1.f - 1e-4f);
    const vf p_l = ls.pmf * ls.pdf;
    const V3 bfl = mul(mul(P.beta, f), ls.L);
    const vf w_mis = S.use_bsdf_emission ? power_heuristic(p_l, p_b) : splat(1.f);
    sh.contrib = select(delta, div(bfl, p_l), bfl * (w_mis / p_l));
    return sh;
}

/// Traces the shadow rays as one packet and adds the unoccluded lanes' contributions to L.
template <class Result>
[[gnu::always_inline]] inline void trace_shadow_rays(PacketPaths<Result> &P, PacketRays &rays,
                                                     const PacketLightSamples &ls,
                                                     const ShadowRays &sh) {
    RTCRay8 &sr = rays.sr;
    int n_shadow = 0;
    for (int i = 0; i < kLanes; ++i) {
        rays.valid[i] = 0;
        // A light was chosen but no shadow ray traced (trace_impl's count).
        if (ls.kind[size_t(i)] != 0 && !sh.mask[i])
            ++P.res[size_t(i)].shadow_rays_avoided;
        if (!sh.mask[i])
            continue;
        ++n_shadow;
        ++P.res[size_t(i)].rays;
        rays.valid[i] = -1;
        sr.org_x[i] = sh.o.x[i];
        sr.org_y[i] = sh.o.y[i];
        sr.org_z[i] = sh.o.z[i];
        sr.dir_x[i] = sh.d.x[i];
        sr.dir_y[i] = sh.d.y[i];
        sr.dir_z[i] = sh.d.z[i];
        sr.tfar[i] = sh.tmax[i];
    }
    if (n_shadow > 0) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        rtcOccluded8(rays.valid, rays.rtc, &ctx, &sr);
        vi lit{};
        for (int i = 0; i < kLanes; ++i)
            lit[i] = rays.valid[i] && sr.tfar[i] >= 0.f ? -1 : 0;
        P.L = select(lit, P.L + sh.contrib, P.L);
    }
}

/// Lane-parallel: BSDF sampling (LambertianBsdf::sample_f) in the shading frame, the
/// throughput, the continuation ray and Russian roulette; a lane whose path ends is marked.
template <class Result>
[[gnu::always_inline]] inline void continue_paths(PacketPaths<Result> &P, const PacketHits &H,
                                                  const PacketSurface &s,
                                                  const BounceSamples &u,
                                                  const PacketSettings &S) {
    V3 fx, fy;
    frame_from_xz(s.dpdu, s.ns, fx, fy);
    const vi b = mask_of(P.bounce);
    const vf co = dot(s.wo, s.ns);
    const vi black = is_black(H.refl);
    const vi no_sample = (co == 0.f) | visnan(co) | black;
    V3 wl = cosine_hemisphere(u.ub_x, u.ub_y);
    wl.z = co < 0.f ? -wl.z : wl.z;
    const vf pdf = vabs(wl.z) * kInvPi;
    const V3 f = H.refl * splat(kInvPi);
    const vi fail = ~(pdf > 0.f) | is_black(f) | ~is_finite(f) | ~visfinite(pdf);
    const V3 wi = fx * wl.x + fy * wl.y + s.ns * wl.z;
    V3 bt = mul(P.beta, f * (vabs(dot(wi, s.ns)) / pdf));
    const vf rr_max = max_value(bt);
    const vi rr = (rr_max < 1.f) & (P.depth > 1);
    const vf q = vmax(splat(0.f), 1.f - vsqrt(rr_max));  // roulette_termination
    const vi killed = rr & (u.u_rr < q);
    bt = select(rr, bt * (1.f / (1.f - q)), bt);
    const vi go_on = b & ~no_sample & ~fail & ~killed & ~is_black(bt);
    const vi moved = b & ~no_sample & ~fail;
    P.beta = select(go_on, bt, P.beta);
    P.p_bsdf = moved ? pdf : P.p_bsdf;
    P.prev_p = select(moved, s.p, P.prev_p);
    P.prev_n = select(moved, s.nn, P.prev_n);
    P.o = select(moved, offset_origin(s.p, s.p_error, s.nn, wi), P.o);
    P.d = select(moved, wi, P.d);
    P.dim = b ? P.dim + (S.nee_dims + 4u) : P.dim;
    for (int i = 0; i < kLanes; ++i)
        if (P.bounce[size_t(i)] && !go_on[i])
            P.live[size_t(i)] = false;
}

}  // namespace

void PathIntegrator::trace_packet(std::span<const CameraSample> samples,
                                  std::span<Sample> out) const {
    const Scene &sc = scene_;
    const int n = int(samples.size());
    const bool use_nee = strategy_ != DirectStrategy::BsdfOnly;
    const PacketSettings S{sc,      packet_meshes_,
                           lambertian_, max_depth_,
                           use_nee, strategy_ != DirectStrategy::LightOnly,
                           cull_,   use_nee ? 3u : 0u,
                           pattern_ == sampling::SamplePattern::Sobol};
    PacketPaths<PathResult> P;

    // Camera rays, 8 samples at a time: lane-parallel for a pinhole and a positive filter
    // (weight 1); a filter with negative lobes weighs each sample, which camera_ray does.
    CameraBatch cam;
    const std::optional<PerspectiveCamera::Pinhole> pinhole =
        sc.filter.has_negative_lobes() ? std::nullopt : sc.camera->pinhole();
    uint32_t pinhole_dim = 0;
    if (pinhole) {
        sampling::SobolSampler sampler(seed_, pattern_);
        sampler.start_pixel_sample(0, 0, 0);
        sampler.skip(2);  // camera_ray: a pinhole skips the lens dimensions
        pinhole_dim = sampler.dimension();
    }
    auto camera_rays = [&](int base) {
        cam.base = base;
        cam.count = std::min(kLanes, n - base);
        if (pinhole) {
            pinhole_rays(*pinhole, sc.filter, samples, seed_, pinhole_dim, cam);
            return;
        }
        for (int j = 0; j < cam.count; ++j) {
            const CameraSample &cs = samples[size_t(base + j)];
            sampling::SobolSampler sampler(seed_, pattern_);
            const CameraRay cray = camera_ray(cs, sampler);
            cam.o.set(j, cray.ray.o);
            cam.d.set(j, cray.ray.d);
            cam.weight[j] = cray.weight;
            cam.pixel_hash[j] = sampling::hash_pixel(seed_, cs.px, cs.py);
            cam.index_rev[j] = sampling::reverse_bits_32(cs.index);
            cam.dim[j] = sampler.dimension();
        }
    };
    // Starts the next sample with a camera ray in lane i (or leaves the lane empty).
    auto start_lane = [&](int i) {
        P.slot[size_t(i)] = -1;
        P.live[size_t(i)] = false;
        while (P.next < n) {
            const int k = P.next++;
            if (k >= cam.base + cam.count)
                camera_rays(k);
            const int j = k - cam.base;
            if (cam.weight[j] == 0.f) {
                // Blocked by the lens system: zero radiance, nothing traced.
                out[size_t(k)] = to_sample(PathResult{});
                continue;
            }
            P.slot[size_t(i)] = k;
            P.live[size_t(i)] = true;
            P.res[size_t(i)] = PathResult{};
            P.weight[size_t(i)] = cam.weight[j];
            P.skips[size_t(i)] = 0;
            P.depth[i] = 0;
            P.o.set(i, cam.o.get(j));
            P.d.set(i, cam.d.get(j));
            P.L.set(i, Rgb(0.f));
            P.beta.set(i, Rgb(1.f));
            P.p_bsdf[i] = 1.f;
            P.pixel_hash[i] = cam.pixel_hash[j];
            P.index_rev[i] = cam.index_rev[j];
            P.dim[i] = cam.dim[j];
            return;
        }
    };
    // Lane i's path has ended: its sample goes out, the lane takes the next.
    auto finish_lane = [&](int i) {
        PathResult &r = P.res[size_t(i)];
        r.L = P.L.rgb(i) * P.weight[size_t(i)];
        to_sample(r, out[size_t(P.slot[size_t(i)])]);
        start_lane(i);
    };
    for (int i = 0; i < kLanes; ++i)
        start_lane(i);

    PacketHits H;
    PacketLightSamples ls;
    PacketRays rays(*sc.geometry);
    // One round: a bounce of every live lane.
    while (true) {
        int n_live = 0;
        for (int i = 0; i < kLanes; ++i)
            n_live += P.live[size_t(i)];
        if (n_live == 0)
            break;
        intersect(P, rays, H, S, finish_lane);
        const PacketSurface s = surface_points(H, P.d);
        shade_hits(P, H, s, S);
        const BounceSamples u = bounce_samples(P, S);
        const TriangleLightLanes tri = select_lights(P, H, s, u, S, ls);
        sample_triangle_lights(tri, u, s.p, ls);
        const ShadowRays sh = direct_light(P, H, s, ls, S);
        trace_shadow_rays(P, rays, ls, sh);
        continue_paths(P, H, s, u, S);
        for (int i = 0; i < kLanes; ++i)
            if (P.slot[size_t(i)] >= 0 && !P.live[size_t(i)])
                finish_lane(i);
    }
}

}  // namespace tessera
