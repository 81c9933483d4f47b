// pbrt-v4 Noise, FBm and Turbulence (see noise.h). The order of every floating-point operation
// follows pbrt-v4's source; the build's -ffp-contract=off keeps the products unfused.
#include "renderer/util/noise.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

namespace tessera {

namespace {

// Ken Perlin's permutation of 0..255 (the table of his reference implementation, which pbrt
// uses), repeated once so that lookups of (table entry + coordinate) need no wrap.
constexpr std::array<uint8_t, 256> kPerm = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225, 140, 36,  103,
    30,  69,  142, 8,   99,  37,  240, 21,  10,  23,  190, 6,   148, 247, 120, 234, 75,  0,   26,
    197, 62,  94,  252, 219, 203, 117, 35,  11,  32,  57,  177, 33,  88,  237, 149, 56,  87,  174,
    20,  125, 136, 171, 168, 68,  175, 74,  165, 71,  134, 139, 48,  27,  166, 77,  146, 158, 231,
    83,  111, 229, 122, 60,  211, 133, 230, 220, 105, 92,  41,  55,  46,  245, 40,  244, 102, 143,
    54,  65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,  18,  169, 200, 196,
    135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,  52,  217, 226, 250, 124,
    123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212, 207, 206, 59,  227, 47,  16,  58,  17,
    182, 189, 28,  42,  223, 183, 170, 213, 119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101,
    155, 167, 43,  172, 9,   129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185,
    112, 104, 218, 246, 97,  228, 251, 34,  242, 193, 238, 210, 144, 12,  191, 179, 162, 241, 81,
    51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,  181, 199, 106, 157, 184, 84,  204, 176,
    115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,  222, 114, 67,  29,  24,  72,  243,
    141, 128, 195, 78,  66,  215, 61,  156, 180};

int perm(int i) {
    return kPerm[size_t(i & 255)];
}

/// Dot product of the corner's pseudo-random gradient with the offset (dx, dy, dz): one of
/// twelve edge directions, picked by pbrt-v4's hash. Its hashes 12 to 15 repeat directions 0,
/// 1, 10 and 11 (Perlin's reference repeats 0, 9, 1 and 11): the values are pbrt-v4's.
/// Evaluated without branches (the hash is random: branches on it mispredict half the time):
/// the same selections and sign flips, so the same bits.
float grad(int x, int y, int z, float dx, float dy, float dz) {
    const int h = perm(perm(perm(x) + y) + z) & 15;
    // u: dx for h < 8, 12 and 13, else dy; v: dy for h < 4, 12 and 13, else dz.
    static constexpr uint8_t kU[16] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 0, 0, 1, 1};
    static constexpr uint8_t kV[16] = {1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 1, 1, 2, 2};
    const float c[3] = {dx, dy, dz};
    const uint32_t su = uint32_t(h & 1) << 31, sv = uint32_t(h & 2) << 30;
    const float u = std::bit_cast<float>(std::bit_cast<uint32_t>(c[kU[h]]) ^ su);
    const float v = std::bit_cast<float>(std::bit_cast<uint32_t>(c[kV[h]]) ^ sv);
    return u + v;
}

/// 6 t^5 - 15 t^4 + 10 t^3, evaluated as pbrt-v4 does (powers by squaring, no Horner form).
float noise_weight(float t) {
    float t2 = t * t;
    float t4 = t2 * t2;
    float t5 = t4 * t, t3 = t2 * t;
    return (6.f * t5 - 15.f * t4) + 10.f * t3;
}

float lerp_f(float t, float a, float b) {
    return (1.f - t) * a + t * b;
}

float smooth_step(float x, float a, float b) {
    if (a == b)
        return x < a ? 0.f : 1.f;
    float t = clamp((x - a) / (b - a), 0.f, 1.f);
    return (t * t) * (3.f - 2.f * t);
}

/// pbrt-v4 Log2: the natural log times 1 / ln 2 rounded to float.
float log2_pbrt(float x) {
    constexpr float kInvLog2 = 1.442695040888963387f;
    return std::log(x) * kInvLog2;
}

/// The number of octaves the footprint resolves, in [0, max_octaves] (fractional).
float octave_count(Vec3f dpdx, Vec3f dpdy, int max_octaves) {
    float len2 = std::max(length_squared(dpdx), length_squared(dpdy));
    float n = clamp(-1.f - log2_pbrt(len2) / 2.f, 0.f, float(max_octaves));
    return std::isnan(n) ? 0.f : n;  // a NaN footprint: no octaves (pbrt-v4: undefined)
}

}  // namespace

float perlin_noise(float x, float y, float z) {
    // pbrt-v4 keeps huge coordinates in range (exact below 2^30).
    // Not a number or infinite (a huge texture transform): no noise (pbrt-v4: undefined).
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        return 0.f;
    constexpr float kWrap = 1073741824.f;
    // fmod is the identity below 2^30 (most calls: skip it, same bits).
    if (!(std::abs(x) < kWrap && std::abs(y) < kWrap && std::abs(z) < kWrap)) {
        x = std::fmod(x, kWrap);
        y = std::fmod(y, kWrap);
        z = std::fmod(z, kWrap);
    }
    int ix = int(std::floor(x)), iy = int(std::floor(y)), iz = int(std::floor(z));
    float dx = x - float(ix), dy = y - float(iy), dz = z - float(iz);
    ix &= 255;
    iy &= 255;
    iz &= 255;
    float w000 = grad(ix, iy, iz, dx, dy, dz);
    float w100 = grad(ix + 1, iy, iz, dx - 1, dy, dz);
    float w010 = grad(ix, iy + 1, iz, dx, dy - 1, dz);
    float w110 = grad(ix + 1, iy + 1, iz, dx - 1, dy - 1, dz);
    float w001 = grad(ix, iy, iz + 1, dx, dy, dz - 1);
    float w101 = grad(ix + 1, iy, iz + 1, dx - 1, dy, dz - 1);
    float w011 = grad(ix, iy + 1, iz + 1, dx, dy - 1, dz - 1);
    float w111 = grad(ix + 1, iy + 1, iz + 1, dx - 1, dy - 1, dz - 1);
    float wx = noise_weight(dx), wy = noise_weight(dy), wz = noise_weight(dz);
    float x00 = lerp_f(wx, w000, w100), x10 = lerp_f(wx, w010, w110);
    float x01 = lerp_f(wx, w001, w101), x11 = lerp_f(wx, w011, w111);
    float y0 = lerp_f(wy, x00, x10), y1 = lerp_f(wy, x01, x11);
    return lerp_f(wz, y0, y1);
}

Vec3f perlin_dnoise(Vec3f p) {
    const float delta = .01f;
    const float n = perlin_noise(p);
    const Vec3f nd(perlin_noise(p + Vec3f(delta, 0, 0)), perlin_noise(p + Vec3f(0, delta, 0)),
                   perlin_noise(p + Vec3f(0, 0, delta)));
    return (nd - Vec3f(n, n, n)) / delta;
}

float fbm(Vec3f p, Vec3f dpdx, Vec3f dpdy, float omega, int max_octaves) {
    float n = octave_count(dpdx, dpdy, max_octaves);
    int n_int = int(std::floor(n));
    float sum = 0.f, lambda = 1.f, o = 1.f;
    for (int i = 0; i < n_int; ++i) {
        sum += o * perlin_noise(p * lambda);
        lambda *= 1.99f;
        o *= omega;
    }
    float n_partial = n - float(n_int);
    sum += (o * smooth_step(n_partial, 0.3f, 0.7f)) * perlin_noise(p * lambda);
    return sum;
}

float turbulence(Vec3f p, Vec3f dpdx, Vec3f dpdy, float omega, int max_octaves) {
    float n = octave_count(dpdx, dpdy, max_octaves);
    int n_int = int(std::floor(n));
    float sum = 0.f, lambda = 1.f, o = 1.f;
    for (int i = 0; i < n_int; ++i) {
        sum += o * std::abs(perlin_noise(p * lambda));
        lambda *= 1.99f;
        o *= omega;
    }
    float n_partial = n - float(n_int);
    sum += o * lerp_f(smooth_step(n_partial, 0.3f, 0.7f), 0.2f, std::abs(perlin_noise(p * lambda)));
    for (int i = n_int; i < max_octaves; ++i) {
        sum += o * 0.2f;
        o *= omega;
    }
    return sum;
}

}  // namespace tessera
