// Small vector, colour and frame types shared by every layer of Tessera.
//
// Everything here is header-only and inlined: these types sit on the hot path of every ray.
// Points, vectors and normals share one type (Vec3f); names carry the meaning (p_world, n_shading).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace tessera {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;
inline constexpr float kInv2Pi = 0.15915494309189533577f;
inline constexpr float kInv4Pi = 0.07957747154594766788f;
inline constexpr float kPiOver2 = 1.57079632679489661923f;
inline constexpr float kPiOver4 = 0.78539816339744830961f;
inline constexpr float kInfinity = std::numeric_limits<float>::infinity();
/// Largest float strictly below 1: the upper end of every canonical [0,1) sample.
inline constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

/// Clamp to [lo, hi].
template <typename T>
inline constexpr T clamp(T v, T lo, T hi) {
    return v < lo ? lo : (v > hi ? hi : v);
}
inline constexpr float lerp(float t, float a, float b) { return (1 - t) * a + t * b; }
inline float safe_sqrt(float x) { return std::sqrt(std::max(0.f, x)); }
inline float safe_acos(float x) { return std::acos(clamp(x, -1.f, 1.f)); }
inline float safe_asin(float x) { return std::asin(clamp(x, -1.f, 1.f)); }
inline constexpr float sqr(float x) { return x * x; }
inline constexpr float radians(float deg) { return deg * (kPi / 180.f); }
inline constexpr float degrees(float rad) { return rad * (180.f / kPi); }

/// 2D float vector (film positions, texture coordinates, 2D samples).
struct Vec2f {
    float x = 0, y = 0;
    constexpr Vec2f() = default;
    constexpr Vec2f(float x_, float y_) : x(x_), y(y_) {}
    constexpr float operator[](int i) const { return i == 0 ? x : y; }
    float &operator[](int i) { return i == 0 ? x : y; }
};
inline constexpr Vec2f operator+(Vec2f a, Vec2f b) { return {a.x + b.x, a.y + b.y}; }
inline constexpr Vec2f operator-(Vec2f a, Vec2f b) { return {a.x - b.x, a.y - b.y}; }
inline constexpr Vec2f operator*(Vec2f a, float s) { return {a.x * s, a.y * s}; }
inline constexpr Vec2f operator*(float s, Vec2f a) { return {a.x * s, a.y * s}; }

/// 3D float vector: points, directions and normals.
struct Vec3f {
    float x = 0, y = 0, z = 0;
    constexpr Vec3f() = default;
    constexpr Vec3f(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
    constexpr float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
    float &operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
    constexpr Vec3f operator-() const { return {-x, -y, -z}; }
    Vec3f &operator+=(Vec3f b) { x += b.x; y += b.y; z += b.z; return *this; }
    Vec3f &operator-=(Vec3f b) { x -= b.x; y -= b.y; z -= b.z; return *this; }
    Vec3f &operator*=(float s) { x *= s; y *= s; z *= s; return *this; }
};
inline constexpr Vec3f operator+(Vec3f a, Vec3f b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline constexpr Vec3f operator-(Vec3f a, Vec3f b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline constexpr Vec3f operator*(Vec3f a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline constexpr Vec3f operator*(float s, Vec3f a) { return {a.x * s, a.y * s, a.z * s}; }
inline constexpr Vec3f operator/(Vec3f a, float s) { return a * (1.f / s); }
inline constexpr Vec3f mul(Vec3f a, Vec3f b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline constexpr float dot(Vec3f a, Vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline float absdot(Vec3f a, Vec3f b) { return std::abs(dot(a, b)); }
inline constexpr Vec3f cross(Vec3f a, Vec3f b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline constexpr float length_squared(Vec3f a) { return dot(a, a); }
inline float length(Vec3f a) { return std::sqrt(dot(a, a)); }
inline Vec3f normalize(Vec3f a) { return a / length(a); }
inline Vec3f abs(Vec3f a) { return {std::abs(a.x), std::abs(a.y), std::abs(a.z)}; }
inline Vec3f vmin(Vec3f a, Vec3f b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
inline Vec3f vmax(Vec3f a, Vec3f b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
inline float max_component(Vec3f a) { return std::max(a.x, std::max(a.y, a.z)); }
inline float distance(Vec3f a, Vec3f b) { return length(a - b); }
/// Flip `v` so that it lies in the hemisphere of `ref`.
inline Vec3f face_forward(Vec3f v, Vec3f ref) { return dot(v, ref) < 0.f ? -v : v; }
inline Vec3f lerp(float t, Vec3f a, Vec3f b) { return a * (1 - t) + b * t; }

/// Linear RGB triple (radiance, reflectance, throughput). Rec.709 / sRGB primaries, linear.
struct Rgb {
    float r = 0, g = 0, b = 0;
    constexpr Rgb() = default;
    constexpr explicit Rgb(float v) : r(v), g(v), b(v) {}
    constexpr Rgb(float r_, float g_, float b_) : r(r_), g(g_), b(b_) {}
    constexpr float operator[](int i) const { return i == 0 ? r : (i == 1 ? g : b); }
    float &operator[](int i) { return i == 0 ? r : (i == 1 ? g : b); }
    Rgb &operator+=(Rgb o) { r += o.r; g += o.g; b += o.b; return *this; }
    Rgb &operator*=(Rgb o) { r *= o.r; g *= o.g; b *= o.b; return *this; }
    Rgb &operator*=(float s) { r *= s; g *= s; b *= s; return *this; }
    Rgb &operator/=(float s) { return *this *= (1.f / s); }
    constexpr bool is_black() const { return r == 0.f && g == 0.f && b == 0.f; }
    constexpr float max_value() const { return std::max(r, std::max(g, b)); }
    constexpr float average() const { return (r + g + b) * (1.f / 3.f); }
    /// Rec.709 luminance.
    constexpr float luminance() const { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }
    bool is_finite() const { return std::isfinite(r) && std::isfinite(g) && std::isfinite(b); }
};
inline constexpr Rgb operator+(Rgb a, Rgb b) { return {a.r + b.r, a.g + b.g, a.b + b.b}; }
inline constexpr Rgb operator-(Rgb a, Rgb b) { return {a.r - b.r, a.g - b.g, a.b - b.b}; }
inline constexpr Rgb operator*(Rgb a, Rgb b) { return {a.r * b.r, a.g * b.g, a.b * b.b}; }
inline constexpr Rgb operator/(Rgb a, Rgb b) { return {a.r / b.r, a.g / b.g, a.b / b.b}; }
inline constexpr Rgb operator*(Rgb a, float s) { return {a.r * s, a.g * s, a.b * s}; }
inline constexpr Rgb operator*(float s, Rgb a) { return {a.r * s, a.g * s, a.b * s}; }
inline constexpr Rgb operator/(Rgb a, float s) { return a * (1.f / s); }
inline Rgb sqrt(Rgb a) { return {std::sqrt(a.r), std::sqrt(a.g), std::sqrt(a.b)}; }
inline Rgb exp(Rgb a) { return {std::exp(a.r), std::exp(a.g), std::exp(a.b)}; }
inline Rgb clamp_zero(Rgb a) { return {std::max(0.f, a.r), std::max(0.f, a.g), std::max(0.f, a.b)}; }

/// Orthonormal frame; `z` is the normal. Converts between world and local (shading) space.
struct Frame {
    Vec3f x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};
    /// Builds a frame around unit vector `n` (Duff et al. 2017, branchless ONB).
    static Frame from_z(Vec3f n) {
        float sign = std::copysign(1.f, n.z);
        float a = -1.f / (sign + n.z);
        float b = n.x * n.y * a;
        Frame f;
        f.x = {1 + sign * n.x * n.x * a, sign * b, -sign * n.x};
        f.y = {b, sign + n.y * n.y * a, -n.y};
        f.z = n;
        return f;
    }
    /// Frame with `z` = n and `x` along the component of `dpdu` orthogonal to n (anisotropy).
    static Frame from_xz(Vec3f dpdu, Vec3f n) {
        Vec3f t = dpdu - n * dot(n, dpdu);
        float len2 = length_squared(t);
        if (!(len2 > 1e-20f)) return from_z(n);
        Frame f;
        f.z = n;
        f.x = t / std::sqrt(len2);
        f.y = cross(f.z, f.x);
        return f;
    }
    Vec3f to_local(Vec3f v) const { return {dot(v, x), dot(v, y), dot(v, z)}; }
    Vec3f to_world(Vec3f v) const { return x * v.x + y * v.y + z * v.z; }
};

// Local shading-space trigonometry (z is the normal), as in pbrt.
inline float cos_theta(Vec3f w) { return w.z; }
inline float cos2_theta(Vec3f w) { return w.z * w.z; }
inline float abs_cos_theta(Vec3f w) { return std::abs(w.z); }
inline float sin2_theta(Vec3f w) { return std::max(0.f, 1.f - cos2_theta(w)); }
inline float sin_theta(Vec3f w) { return std::sqrt(sin2_theta(w)); }
inline float tan_theta(Vec3f w) { return sin_theta(w) / cos_theta(w); }
inline float tan2_theta(Vec3f w) { return sin2_theta(w) / cos2_theta(w); }
inline float cos_phi(Vec3f w) {
    float s = sin_theta(w);
    return s == 0.f ? 1.f : clamp(w.x / s, -1.f, 1.f);
}
inline float sin_phi(Vec3f w) {
    float s = sin_theta(w);
    return s == 0.f ? 0.f : clamp(w.y / s, -1.f, 1.f);
}
inline bool same_hemisphere(Vec3f a, Vec3f b) { return a.z * b.z > 0.f; }

/// Direction from spherical coordinates (z up).
inline Vec3f spherical_direction(float sin_theta_, float cos_theta_, float phi) {
    float st = clamp(sin_theta_, -1.f, 1.f);
    return {st * std::cos(phi), st * std::sin(phi), clamp(cos_theta_, -1.f, 1.f)};
}

/// Power heuristic with beta = 2 (Veach 1997), for one sample from each of two strategies.
inline float power_heuristic(float pdf_a, float pdf_b) {
    float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    if (std::isinf(a)) return 1.f;
    return a + b > 0.f ? a / (a + b) : 0.f;
}

}  // namespace tessera
