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

#include "renderer/scene/geometry.h"
#include "renderer/integrators/path_integrator.h"

// Without AVX (TESSERA_ISA=default) GCC warns that 32-byte vector arguments change the ABI;
// these functions are internal to this file, so no ABI is at stake.
#pragma GCC diagnostic ignored "-Wpsabi"

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

}  // namespace

void PathIntegrator::trace_packet(std::span<const CameraSample> samples,
                                  std::span<Sample> out) const {
    const Scene &sc = scene_;
    const int n = int(samples.size());
    const bool use_nee = strategy_ != DirectStrategy::BsdfOnly;
    const bool use_bsdf_emission = strategy_ != DirectStrategy::LightOnly;
    const std::vector<const TriangleMesh *> &meshes = packet_meshes_;

    // Per-lane path state. A lane traces samples[slot[i]]; when its path ends the lane takes
    // the next sample of the batch, so the lanes stay busy until the batch runs out.
    std::array<PathResult, kLanes> res{};
    std::array<float, kLanes> weight{};
    std::array<int, kLanes> slot{};
    std::array<bool, kLanes> live{}, bounce{};
    std::array<int, kLanes> skips{};
    vi depth{};
    vu pixel_hash{}, index_rev{}, dim{};
    V3 o, d, L, beta, prev_p, prev_n;
    vf p_bsdf{};
    int next = 0;

    // Camera rays of the batch, 8 samples at a time: lane-parallel for a pinhole camera (the
    // operations of camera_ray, PixelFilter::sample and PerspectiveCamera::generate_ray, in the
    // same order), else camera_ray per sample. Also each sample's sampler state after them.
    struct {
        int base = 0, count = 0;
        V3 o, d;
        vf weight{};
        vu pixel_hash{}, index_rev{}, dim{};
    } cam;
    // Lane-parallel camera rays for a pinhole and a positive filter (weight 1); a filter with
    // negative lobes weighs each sample, which camera_ray does.
    const std::optional<PerspectiveCamera::Pinhole> pinhole =
        sc.filter.has_negative_lobes() ? std::nullopt : sc.camera->pinhole();
    uint32_t pinhole_dim = 0;
    if (pinhole) {
        sampling::SobolSampler sampler(seed_);
        sampler.start_pixel_sample(0, 0, 0);
        sampler.skip(2);  // camera_ray: a pinhole skips the lens dimensions
        pinhole_dim = sampler.dimension();
    }
    auto camera_rays = [&](int base) {
        cam.base = base;
        cam.count = std::min(kLanes, n - base);
        if (!pinhole) {
            for (int j = 0; j < cam.count; ++j) {
                const CameraSample &cs = samples[size_t(base + j)];
                sampling::SobolSampler sampler(seed_);
                const CameraRay cray = camera_ray(cs, sampler);
                cam.o.set(j, cray.ray.o);
                cam.d.set(j, cray.ray.d);
                cam.weight[j] = cray.weight;
                cam.pixel_hash[j] = sampling::hash_pixel(seed_, cs.px, cs.py);
                cam.index_rev[j] = sampling::reverse_bits_32(cs.index);
                cam.dim[j] = sampler.dimension();
            }
            return;
        }
        vu px{}, py{}, index{};
        vf fx{}, fy{};
        for (int j = 0; j < kLanes; ++j) {
            // Lanes past the end repeat the last sample (their results are never read).
            const CameraSample &cs = samples[size_t(base + std::min(j, cam.count - 1))];
            px[j] = cs.px, py[j] = cs.py, index[j] = cs.index;
            fx[j] = cs.fx, fy[j] = cs.fy;
        }
        const vf rx = (__builtin_convertvector(px, vf) + 0.5f) + filter_sample_1d(sc.filter, 0, fx);
        const vf ry = (__builtin_convertvector(py, vf) + 0.5f) + filter_sample_1d(sc.filter, 1, fy);
        const PerspectiveCamera::Pinhole &ph = *pinhole;
        const V3 pc{(ph.p0.x + ph.dx.x * rx) + ph.dy.x * ry, (ph.p0.y + ph.dx.y * rx) + ph.dy.y * ry,
                    (ph.p0.z + ph.dx.z * rx) + ph.dy.z * ry};
        const auto &m = ph.world_from_camera;
        const V3 dw{m[0][0] * pc.x + m[0][1] * pc.y + m[0][2] * pc.z,
                    m[1][0] * pc.x + m[1][1] * pc.y + m[1][2] * pc.z,
                    m[2][0] * pc.x + m[2][1] * pc.y + m[2][2] * pc.z};
        cam.d = div(dw, vsqrt(dot(dw, dw)));
        cam.o = {splat(m[0][3]), splat(m[1][3]), splat(m[2][3])};
        cam.weight = splat(1.f);
        cam.pixel_hash = sampling::lanes::hash_pixel(seed_, px, py);
        cam.index_rev = sampling::lanes::reverse_bits(index);
        cam.dim = splat_u(pinhole_dim);
    };
    // Starts the next sample with a camera ray in lane i (or leaves the lane empty).
    auto start_lane = [&](int i) {
        slot[size_t(i)] = -1;
        live[size_t(i)] = false;
        while (next < n) {
            const int k = next++;
            if (k >= cam.base + cam.count)
                camera_rays(k);
            const int j = k - cam.base;
            if (cam.weight[j] == 0.f) {
                // Blocked by the lens system: zero radiance, nothing traced.
                out[size_t(k)] = to_sample(PathResult{});
                continue;
            }
            slot[size_t(i)] = k;
            live[size_t(i)] = true;
            res[size_t(i)] = PathResult{};
            weight[size_t(i)] = cam.weight[j];
            skips[size_t(i)] = 0;
            depth[i] = 0;
            o.set(i, cam.o.get(j));
            d.set(i, cam.d.get(j));
            L.set(i, Rgb(0.f));
            beta.set(i, Rgb(1.f));
            p_bsdf[i] = 1.f;
            pixel_hash[i] = cam.pixel_hash[j];
            index_rev[i] = cam.index_rev[j];
            dim[i] = cam.dim[j];
            return;
        }
    };
    // Lane i's path has ended: its sample goes out, the lane takes the next.
    auto finish_lane = [&](int i) {
        PathResult &r = res[size_t(i)];
        r.L = L.rgb(i) * weight[size_t(i)];
        to_sample(r, out[size_t(slot[size_t(i)])]);
        start_lane(i);
    };
    for (int i = 0; i < kLanes; ++i)
        start_lane(i);

    // Hit data, gathered per lane then processed lane-parallel.
    V3 p0, p1, p2, n0, n1, n2, refl;
    vf b1{}, b2{}, uv0x{}, uv0y{}, uv1x{}, uv1y{}, uv2x{}, uv2y{}, t_hit{};
    std::array<bool, kLanes> has_ns{}, flip{};
    std::array<int, kLanes> material{};
    std::array<const Light *, kLanes> area_light{};
    // Next-event estimation per lane.
    V3 ls_wi, ls_L, ls_p;
    vf ls_pdf = splat(1.f), ls_pmf = splat(1.f);
    std::array<uint8_t, kLanes> ls_kind{};  // 0: no light chosen, 1: a point, 2: a direction,
                                            // 3: chosen but nothing to trace
    std::array<bool, kLanes> ls_delta{};

    alignas(32) RTCRayHit8 rh;
    alignas(32) RTCRay8 sr;
    alignas(32) int valid[kLanes], traced[kLanes];
    // The scene's bounds, enlarged by a thousandth of their size (misses_box).
    const Vec3f box_pad = (sc.geometry->bounds_max() - sc.geometry->bounds_min()) * 1e-3f +
                          Vec3f(1e-6f, 1e-6f, 1e-6f);
    const Vec3f box_lo = sc.geometry->bounds_min() - box_pad,
                box_hi = sc.geometry->bounds_max() + box_pad;
    const RTCScene rtc = sc.geometry->rtc_scene();
    const uint32_t nee_dims = use_nee ? 3u : 0u;
    std::memset(&rh, 0, sizeof(rh));
    std::memset(&sr, 0, sizeof(sr));
    for (int i = 0; i < kLanes; ++i) {
        rh.ray.mask[i] = sr.mask[i] = 0xFFFFFFFFu;
        rh.ray.id[i] = sr.id[i] = unsigned(i);
    }

    while (true) {
        int n_live = 0;
        for (int i = 0; i < kLanes; ++i)
            n_live += live[size_t(i)];
        if (n_live == 0)
            break;

        // Trace the live lanes' rays. A lane whose ray escapes finishes at once and takes the
        // next sample, whose camera ray is traced before the round goes on: the lane-parallel
        // steps below then run on full lanes (most camera rays of an object on a plain
        // background miss it).
        for (int i = 0; i < kLanes; ++i)
            bounce[size_t(i)] = false;
        std::array<bool, kLanes> pending = live;
        while (std::any_of(pending.begin(), pending.end(), [](bool b) { return b; })) {
        // Whole registers in: the packet's fields Embree does not write (tnear, time, mask,
        // id, flags) were set once before the loop.
        for (int i = 0; i < kLanes; ++i)
            valid[i] = pending[size_t(i)] ? -1 : 0;
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
        {
            // A ray that misses the scene's bounds escapes without a traversal (most camera
            // rays of an object against the sky): a lane-parallel test instead of Embree's.
            const vi miss = misses_box(o, d, box_lo, box_hi);
            bool any_traced = false;
            for (int i = 0; i < kLanes; ++i) {
                traced[i] = valid[i] && !miss[i] ? -1 : 0;
                any_traced |= traced[i] != 0;
            }
            if (any_traced) {
                RTCIntersectContext ctx;
                rtcInitIntersectContext(&ctx);
                rtcIntersect8(traced, rtc, &ctx, &rh);
            }
        }

        // Per lane: escapes, and the hit triangle's data.
        pending = {};
        for (int i = 0; i < kLanes; ++i) {
            if (!valid[i])
                continue;
            ++res[size_t(i)].rays;
            if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {
                // Escaped: infinite lights, MIS-weighted against light sampling.
                const Vec3f dir = d.get(i);
                Rgb Li = L.rgb(i);
                const Rgb bt = beta.rgb(i);
                for (const Light *light : sc.infinite_lights) {
                    Rgb Le = light->Le(dir);
                    if (Le.is_black())
                        continue;
                    if (depth[i] == 0) {
                        Li += bt * Le;
                    } else if (use_bsdf_emission) {
                        float w = 1.f;
                        if (use_nee) {
                            float p_l =
                                sc.light_sampler->pmf(light) *
                                light->pdf_li(LightSampleContext{prev_p.get(i), prev_n.get(i)}, dir,
                                              Vec3f(), Vec3f());
                            w = tessera::power_heuristic(p_bsdf[i], p_l);
                        }
                        Li += bt * Le * w;
                    }
                }
                L.set(i, Li);
                live[size_t(i)] = false;
                finish_lane(i);
                pending[size_t(i)] = live[size_t(i)];
                continue;
            }
            const TriangleMesh &m = *meshes[rh.hit.geomID[i]];
            const unsigned prim = rh.hit.primID[i];
            const uint32_t i0 = m.indices[3 * prim], i1 = m.indices[3 * prim + 1],
                           i2 = m.indices[3 * prim + 2];
            p0.set(i, m.p[i0]);
            p1.set(i, m.p[i1]);
            p2.set(i, m.p[i2]);
            Vec2f uv0{0, 0}, uv1{1, 0}, uv2{1, 1};
            if (!m.uv.empty()) {
                uv0 = m.uv[i0];
                uv1 = m.uv[i1];
                uv2 = m.uv[i2];
            }
            uv0x[i] = uv0.x, uv0y[i] = uv0.y, uv1x[i] = uv1.x, uv1y[i] = uv1.y;
            uv2x[i] = uv2.x, uv2y[i] = uv2.y;
            has_ns[size_t(i)] = !m.n.empty();
            if (!m.n.empty()) {
                n0.set(i, m.n[i0]);
                n1.set(i, m.n[i1]);
                n2.set(i, m.n[i2]);
            }
            flip[size_t(i)] = m.flip_normal;
            material[size_t(i)] = m.material;
            area_light[size_t(i)] = m.lights.empty() ? nullptr : m.lights[prim];
            b1[i] = rh.hit.u[i];
            b2[i] = rh.hit.v[i];
            t_hit[i] = rh.ray.tfar[i];
            bounce[size_t(i)] = true;
        }
        }

        // Lane-parallel: Geometry's fill_triangle, then wo.
        constexpr float g7 = gamma_n(7);
        const vf c1 = b1, c2 = b2, c0 = 1.f - c1 - c2;
        const V3 p = p0 * c0 + p1 * c1 + p2 * c2;
        V3 p_error;
        {
            const V3 err = (vabs(p0 * c0) + vabs(p1 * c1) + vabs(p2 * c2)) * splat(g7);
            const vf mag = max_value(vmax(vabs(p0), vmax(vabs(p1), vabs(p2))));
            const vf m7 = mag * g7;
            p_error = vmax(err, V3{m7, m7, m7});
        }
        V3 dpdu, nn, ns;
        {
            const vf duv02x = uv0x - uv2x, duv02y = uv0y - uv2y;
            const vf duv12x = uv1x - uv2x, duv12y = uv1y - uv2y;
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
            dpdu = select(bad, fzx, du);
            g = select(mask_of(flip), -g, g);
            const V3 v = n0 * c0 + n1 * c1 + n2 * c2;
            const vf l2 = dot(v, v);
            const vi ok = mask_of(has_ns) & (l2 > 0.f) & visfinite(l2);
            const V3 vn = div(v, vsqrt(l2));
            nn = select(ok & (dot(g, vn) < 0.f), -g, g);
            ns = select(ok, vn, g);
        }
        V3 wo;
        {
            const vf d2 = dot(d, d);
            wo = select(vabs(d2 - 1.f) < 1e-6f, -d, -div(d, vsqrt(d2)));
        }

        // Per lane: AOVs, emission, the material; the path may end here.
        for (int i = 0; i < kLanes; ++i) {
            if (!bounce[size_t(i)])
                continue;
            PathResult &r = res[size_t(i)];
            if (depth[i] == 0 && skips[size_t(i)] == 0) {
                r.depth = t_hit[i] * length(d.get(i));
                r.normal = ns.get(i);
            }
            if (const Light *al = area_light[size_t(i)]) {
                const Vec3f ph = p.get(i), nh = nn.get(i);
                const float e1 = c1[i], e2 = c2[i], e0 = c0[i];
                const Vec2f uv = Vec2f{uv0x[i], uv0y[i]} * e0 + Vec2f{uv1x[i], uv1y[i]} * e1 +
                                 Vec2f{uv2x[i], uv2y[i]} * e2;
                Rgb Le = al->L(ph, nh, uv, wo.get(i));
                if (!Le.is_black()) {
                    const Rgb bt = beta.rgb(i);
                    Rgb Li = L.rgb(i);
                    if (depth[i] == 0) {
                        Li += bt * Le;
                    } else if (use_bsdf_emission) {
                        float w = 1.f;
                        if (use_nee) {
                            float p_l = sc.light_sampler->pmf(al) *
                                        al->pdf_li(LightSampleContext{prev_p.get(i), prev_n.get(i)},
                                                   normalize(d.get(i)), ph, nh);
                            w = tessera::power_heuristic(p_bsdf[i], p_l);
                        }
                        Li += bt * Le * w;
                    }
                    L.set(i, Li);
                }
            }
            const int mat = material[size_t(i)];
            if (mat < 0) {
                // "interface": no surface here; continue the ray without a bounce.
                bounce[size_t(i)] = false;
                if (++skips[size_t(i)] > 256) {
                    live[size_t(i)] = false;
                } else {
                    o.set(i, offset_ray_origin(p.get(i), p_error.get(i), nn.get(i), d.get(i)));
                }
                continue;
            }
            const Rgb R = lambertian_[size_t(mat)];
            refl.set(i, R);
            if (depth[i] == 0)
                r.albedo = R;
            if (depth[i]++ == max_depth_) {
                bounce[size_t(i)] = false;
                live[size_t(i)] = false;
            }
        }

        // Lane-parallel: the shading frame and the sampler's values of this bounce, in
        // trace_impl's dimension layout: light 1D and 2D (when next-event estimation is on),
        // BSDF 1D (unused by a Lambertian) and 2D, roulette 1D.
        V3 fx, fy;
        frame_from_xz(dpdu, ns, fx, fy);
        vf u_light{}, u2x{}, u2y{}, ub_x, ub_y;
        if (use_nee) {
            u_light = sobol_1d(pixel_hash, dim, index_rev);
            sobol_2d(pixel_hash, dim + 1u, index_rev, u2x, u2y);
        }
        sobol_2d(pixel_hash, dim + (nee_dims + 1u), index_rev, ub_x, ub_y);
        const vf u_rr = sobol_1d(pixel_hash, dim + (nee_dims + 3u), index_rev);

        // Per lane: light selection; other lights than triangles are sampled here, triangle
        // lights' data is gathered for the lane-parallel sampling below.
        V3 tp0, tp1, tp2, tn, tL;
        vf t_area{}, t_pmf{};
        vi t_twosided{}, t_lane{};
        for (int i = 0; i < kLanes; ++i) {
            ls_kind[size_t(i)] = 0;
            if (!bounce[size_t(i)]) continue;
            if (!(use_nee && !refl.rgb(i).is_black() && sc.light_sampler)) continue;
            auto sampled = sc.light_sampler->sample(u_light[i]);
            if (!sampled) continue;
            ls_kind[size_t(i)] = 3;
            if (sampled->light->shape() == LightShape::Triangle) {
                const auto *tri = static_cast<const TriangleLight *>(sampled->light);
                t_lane[i] = -1;
                tp0.set(i, tri->p0());
                tp1.set(i, tri->p1());
                tp2.set(i, tri->p2());
                tn.set(i, tri->normal());
                tL.set(i, tri->radiance());
                t_area[i] = tri->area();
                t_twosided[i] = tri->twosided() ? -1 : 0;
                t_pmf[i] = sampled->pmf;
                // A sample-only (invisible) emitter is a delta light to MIS: no ray finds it.
                ls_delta[size_t(i)] = is_delta_light(tri->type());
                continue;
            }
            auto ls = sampled->light->sample_li(LightSampleContext{p.get(i), nn.get(i)},
                                                {u2x[i], u2y[i]});
            if (!(ls && (!cull_ || !ls->L.is_black()) && ls->pdf > 0)) continue;
            const LightType lt = sampled->light->type();
            ls_delta[size_t(i)] = is_delta_light(lt);
            ls_kind[size_t(i)] =
                (lt == LightType::Infinite || lt == LightType::DeltaDirection) ? 2 : 1;
            ls_wi.set(i, ls->wi);
            ls_L.set(i, ls->L);
            ls_p.set(i, ls->p_light);
            ls_pdf[i] = ls->pdf;
            ls_pmf[i] = sampled->pmf;
        }
        if (t_lane[0] | t_lane[1] | t_lane[2] | t_lane[3] | t_lane[4] | t_lane[5] | t_lane[6] |
            t_lane[7]) {
            // Lane-parallel TriangleLight::sample_li: a uniform point on the triangle
            // (square_to_uniform_triangle), its direction and solid-angle density, the
            // one-sided test and the radiance, with the same operations.
            const vi lower = u2x < u2y;
            const vf half_x = u2x / 2.f, half_y = u2y / 2.f;
            const vf bx = lower ? half_x : u2x - half_y;
            const vf by = lower ? u2y - half_x : half_y;
            const V3 pl = tp0 * bx + tp1 * by + tp2 * (1.f - bx - by);
            const V3 dl = pl - p;
            const vf d2 = dot(dl, dl);
            const vf inv_dist = 1.f / vsqrt(d2);
            const V3 wi = dl * inv_dist;
            const vf cos_l = vabs(dot(tn, wi));
            const vf pdf = d2 / (t_area * cos_l);
            const vi ok = t_lane & (t_area > 0.f) & (d2 != 0.f) & (cos_l != 0.f) &
                          visfinite(pdf) & (pdf != 0.f) & (t_twosided | (dot(tn, wi) < 0.f)) &
                          ~is_black(tL) & (pdf > 0.f);
            ls_wi = select(ok, wi, ls_wi);
            ls_L = select(ok, tL, ls_L);
            ls_p = select(ok, pl, ls_p);
            ls_pdf = ok ? pdf : ls_pdf;
            ls_pmf = ok ? t_pmf : ls_pmf;
            for (int i = 0; i < kLanes; ++i)
                if (ok[i]) ls_kind[size_t(i)] = 1;
        }

        // Lane-parallel: the BSDF's value and density (LambertianBsdf::f_pdf), the MIS
        // weight, the contribution and the shadow ray (spawn_ray / spawn_ray_to).
        V3 contrib, s_o, s_d;
        vf s_tmax;
        vi s_mask;
        {
            vi kind{}, delta{};
            for (int i = 0; i < kLanes; ++i) {
                kind[i] = ls_kind[size_t(i)];
                delta[i] = ls_delta[size_t(i)] ? -1 : 0;
            }
            const vi active = (kind == 1) | (kind == 2);
            const vi directional = kind == 2;
            const vf co = dot(wo, ns), ci = dot(ls_wi, ns);
            const vi same = co * ci > 0.f;
            const V3 fr = refl * splat(kInvPi);
            V3 f = select(same & is_finite(fr), fr, V3{});
            vf p_b = splat(0.f);
            if (use_bsdf_emission) {
                const vf l2 = dot(ls_wi, ls_wi);
                const vf c = vabs(l2 - 1.f) < 1e-6f ? ci : ci / vsqrt(l2);
                const vf pd = vabs(c) * kInvPi;
                p_b = ~delta & same & visfinite(pd) ? pd : splat(0.f);
            }
            f = f * vabs(ci);
            s_mask = active;
            if (cull_)
                s_mask &= ~is_black(f);
            const V3 w = select(directional, ls_wi, ls_p - p);
            s_o = offset_origin(p, p_error, nn, w);
            s_d = select(directional, ls_wi, ls_p - s_o);
            s_tmax = directional ? splat(kInfinity) : splat(1.f - 1e-4f);
            const vf p_l = ls_pmf * ls_pdf;
            const V3 bfl = mul(mul(beta, f), ls_L);
            const vf w_mis = use_bsdf_emission ? power_heuristic(p_l, p_b) : splat(1.f);
            contrib = select(delta, div(bfl, p_l), bfl * (w_mis / p_l));

        }

        // Shadow rays as one packet.
        int n_shadow = 0;
        for (int i = 0; i < kLanes; ++i) {
            valid[i] = 0;
            // A light was chosen but no shadow ray traced (trace_impl's count).
            if (ls_kind[size_t(i)] != 0 && !s_mask[i])
                ++res[size_t(i)].shadow_rays_avoided;
            if (!s_mask[i])
                continue;
            ++n_shadow;
            ++res[size_t(i)].rays;
            valid[i] = -1;
            sr.org_x[i] = s_o.x[i];
            sr.org_y[i] = s_o.y[i];
            sr.org_z[i] = s_o.z[i];
            sr.dir_x[i] = s_d.x[i];
            sr.dir_y[i] = s_d.y[i];
            sr.dir_z[i] = s_d.z[i];
            sr.tfar[i] = s_tmax[i];
        }
        if (n_shadow > 0) {
            RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            rtcOccluded8(valid, rtc, &ctx, &sr);
            vi lit{};
            for (int i = 0; i < kLanes; ++i)
                lit[i] = valid[i] && sr.tfar[i] >= 0.f ? -1 : 0;
            L = select(lit, L + contrib, L);
        }

        // Lane-parallel: BSDF sampling (LambertianBsdf::sample_f), the throughput, the
        // continuation ray and Russian roulette.
        {
            const vi b = mask_of(bounce);
            const vf co = dot(wo, ns);
            const vi black = is_black(refl);
            const vi no_sample = (co == 0.f) | visnan(co) | black;
            V3 wl = cosine_hemisphere(ub_x, ub_y);
            wl.z = co < 0.f ? -wl.z : wl.z;
            const vf pdf = vabs(wl.z) * kInvPi;
            const V3 f = refl * splat(kInvPi);
            const vi fail = ~(pdf > 0.f) | is_black(f) | ~is_finite(f) | ~visfinite(pdf);
            const V3 wi = fx * wl.x + fy * wl.y + ns * wl.z;
            V3 bt = mul(beta, f * (vabs(dot(wi, ns)) / pdf));
            const vf rr_max = max_value(bt);
            const vi rr = (rr_max < 1.f) & (depth > 1);
            const vf q = vmax(splat(0.f), 1.f - rr_max);
            const vi killed = rr & (u_rr < q);
            bt = select(rr, bt * (1.f / (1.f - q)), bt);
            const vi go_on = b & ~no_sample & ~fail & ~killed & ~is_black(bt);
            const vi moved = b & ~no_sample & ~fail;
            beta = select(go_on, bt, beta);
            p_bsdf = moved ? pdf : p_bsdf;
            prev_p = select(moved, p, prev_p);
            prev_n = select(moved, nn, prev_n);
            o = select(moved, offset_origin(p, p_error, nn, wi), o);
            d = select(moved, wi, d);
            dim = b ? dim + (nee_dims + 4u) : dim;
            for (int i = 0; i < kLanes; ++i)
                if (bounce[size_t(i)] && !go_on[i])
                    live[size_t(i)] = false;
        }
        for (int i = 0; i < kLanes; ++i)
            if (slot[size_t(i)] >= 0 && !live[size_t(i)])
                finish_lane(i);
    }
}

}  // namespace tessera
