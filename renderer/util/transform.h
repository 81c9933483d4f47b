// 4x4 affine/projective transforms with their inverse, as the pbrt-v4 format uses them.
//
// Matrices are stored row-major: m[row][col], points are column vectors (p' = M p). Note that
// the pbrt file format lists `Transform`/`ConcatTransform` numbers column by column; the parser
// transposes (PBRT-NOTES.md).
#pragma once

#include <array>
#include <cstring>

#include "sampling/vecmath.h"

namespace tessera {

struct Mat4 {
    double m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    static Mat4 identity() { return Mat4{}; }
    bool is_identity() const {
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j)
                if (m[i][j] != (i == j ? 1.0 : 0.0)) return false;
        return true;
    }
    bool operator==(const Mat4 &o) const { return std::memcmp(m, o.m, sizeof(m)) == 0; }
};

inline Mat4 operator*(const Mat4 &a, const Mat4 &b) {
    Mat4 r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            double s = 0;
            for (int k = 0; k < 4; ++k) s += a.m[i][k] * b.m[k][j];
            r.m[i][j] = s;
        }
    return r;
}

inline Mat4 transpose(const Mat4 &a) {
    Mat4 r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) r.m[i][j] = a.m[j][i];
    return r;
}

/// General 4x4 inverse by Gauss-Jordan elimination with full pivoting. Returns false if singular.
inline bool invert(const Mat4 &a, Mat4 &out) {
    double inv[4][8];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            inv[i][j] = a.m[i][j];
            inv[i][j + 4] = (i == j) ? 1.0 : 0.0;
        }
    for (int c = 0; c < 4; ++c) {
        int piv = c;
        for (int r = c + 1; r < 4; ++r)
            if (std::abs(inv[r][c]) > std::abs(inv[piv][c])) piv = r;
        if (inv[piv][c] == 0.0) return false;
        if (piv != c)
            for (int j = 0; j < 8; ++j) std::swap(inv[c][j], inv[piv][j]);
        double d = 1.0 / inv[c][c];
        for (int j = 0; j < 8; ++j) inv[c][j] *= d;
        for (int r = 0; r < 4; ++r) {
            if (r == c) continue;
            double f = inv[r][c];
            if (f == 0.0) continue;
            for (int j = 0; j < 8; ++j) inv[r][j] -= f * inv[c][j];
        }
    }
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) out.m[i][j] = inv[i][j + 4];
    return true;
}

/// A transform and its inverse. Singular matrices keep an all-zero inverse (`is_invertible`).
class Transform {
  public:
    Transform() = default;
    explicit Transform(const Mat4 &m) : m_(m) { invertible_ = invert(m, inv_); }
    Transform(const Mat4 &m, const Mat4 &inv) : m_(m), inv_(inv) {}

    const Mat4 &matrix() const { return m_; }
    const Mat4 &inverse_matrix() const { return inv_; }
    bool is_invertible() const { return invertible_; }
    bool is_identity() const { return m_.is_identity(); }
    Transform inverse() const { return Transform(inv_, m_); }
    bool operator==(const Transform &o) const { return m_ == o.m_; }

    Transform operator*(const Transform &o) const { return Transform(m_ * o.m_, o.inv_ * inv_); }

    /// Applies to a point (homogeneous divide when w != 1).
    Vec3f point(Vec3f p) const { return apply_point(m_, p); }
    Vec3f vector(Vec3f v) const { return apply_vector(m_, v); }
    /// inverse().point(p) and inverse().vector(v) without building the inverse Transform (its
    /// two 4x4 double matrices were copied on every call, which showed up in light sampling).
    Vec3f inverse_point(Vec3f p) const { return apply_point(inv_, p); }
    Vec3f inverse_vector(Vec3f v) const { return apply_vector(inv_, v); }
    /// Normals transform by the inverse transpose.
    Vec3f normal(Vec3f n) const {
        return {float(inv_.m[0][0] * n.x + inv_.m[1][0] * n.y + inv_.m[2][0] * n.z),
                float(inv_.m[0][1] * n.x + inv_.m[1][1] * n.y + inv_.m[2][1] * n.z),
                float(inv_.m[0][2] * n.x + inv_.m[1][2] * n.y + inv_.m[2][2] * n.z)};
    }
    /// Determinant of the upper 3x3 (the volume scale; negative when handedness flips).
    double determinant3() const {
        const auto &a = m_.m;
        return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
               a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
               a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    }
    /// True if the transform flips handedness (negative determinant of the upper 3x3).
    bool swaps_handedness() const { return determinant3() < 0; }

    static Transform translate(Vec3f d) {
        Mat4 m;
        m.m[0][3] = d.x; m.m[1][3] = d.y; m.m[2][3] = d.z;
        Mat4 inv;
        inv.m[0][3] = -d.x; inv.m[1][3] = -d.y; inv.m[2][3] = -d.z;
        return Transform(m, inv);
    }
    static Transform scale(double x, double y, double z) {
        Mat4 m;
        m.m[0][0] = x; m.m[1][1] = y; m.m[2][2] = z;
        return Transform(m);
    }
    /// Rotation by `deg` degrees about `axis` (normalised here).
    static Transform rotate(double deg, Vec3f axis);
    /// pbrt's LookAt: returns camera-from-world (world -> camera) for eye/look/up.
    /// Returns std::nullopt-like identity with `ok=false` when up is parallel to the view.
    static Transform look_at(Vec3f eye, Vec3f look, Vec3f up, bool *ok = nullptr);
    /// Perspective projection of pbrt (camera space -> screen space, z mapped to [0,1]).
    static Transform perspective(double fov_deg, double n, double f);

  private:
    static Vec3f apply_point(const Mat4 &a, Vec3f p) {
        double x = p.x, y = p.y, z = p.z;
        double xp = a.m[0][0] * x + a.m[0][1] * y + a.m[0][2] * z + a.m[0][3];
        double yp = a.m[1][0] * x + a.m[1][1] * y + a.m[1][2] * z + a.m[1][3];
        double zp = a.m[2][0] * x + a.m[2][1] * y + a.m[2][2] * z + a.m[2][3];
        double wp = a.m[3][0] * x + a.m[3][1] * y + a.m[3][2] * z + a.m[3][3];
        if (wp == 1.0) return {float(xp), float(yp), float(zp)};
        return {float(xp / wp), float(yp / wp), float(zp / wp)};
    }
    static Vec3f apply_vector(const Mat4 &a, Vec3f v) {
        return {float(a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z),
                float(a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z),
                float(a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z)};
    }

    Mat4 m_, inv_;
    bool invertible_ = true;
};

inline Transform Transform::rotate(double deg, Vec3f axis_f) {
    double ax = axis_f.x, ay = axis_f.y, az = axis_f.z;
    double len = std::sqrt(ax * ax + ay * ay + az * az);
    Mat4 m;
    if (len == 0) return Transform(m);
    ax /= len; ay /= len; az /= len;
    double theta = deg * 3.14159265358979323846 / 180.0;
    double s = std::sin(theta), c = std::cos(theta);
    m.m[0][0] = ax * ax + (1 - ax * ax) * c;
    m.m[0][1] = ax * ay * (1 - c) - az * s;
    m.m[0][2] = ax * az * (1 - c) + ay * s;
    m.m[1][0] = ax * ay * (1 - c) + az * s;
    m.m[1][1] = ay * ay + (1 - ay * ay) * c;
    m.m[1][2] = ay * az * (1 - c) - ax * s;
    m.m[2][0] = ax * az * (1 - c) - ay * s;
    m.m[2][1] = ay * az * (1 - c) + ax * s;
    m.m[2][2] = az * az + (1 - az * az) * c;
    return Transform(m, transpose(m));
}

inline Transform Transform::look_at(Vec3f eye, Vec3f look, Vec3f up, bool *ok) {
    auto norm = [](std::array<double, 3> v) {
        double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        return std::array<double, 3>{v[0] / l, v[1] / l, v[2] / l};
    };
    auto crossd = [](std::array<double, 3> a, std::array<double, 3> b) {
        return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                     a[0] * b[1] - a[1] * b[0]};
    };
    std::array<double, 3> dir = norm({double(look.x) - eye.x, double(look.y) - eye.y,
                                      double(look.z) - eye.z});
    std::array<double, 3> upn = norm({up.x, up.y, up.z});
    std::array<double, 3> right = crossd(upn, dir);
    double rl = std::sqrt(right[0] * right[0] + right[1] * right[1] + right[2] * right[2]);
    if (ok) *ok = rl > 1e-12 && std::isfinite(rl);
    if (!(rl > 1e-12)) return Transform();
    right = {right[0] / rl, right[1] / rl, right[2] / rl};
    std::array<double, 3> new_up = crossd(dir, right);
    Mat4 world_from_camera;
    for (int i = 0; i < 3; ++i) {
        world_from_camera.m[i][0] = right[i];
        world_from_camera.m[i][1] = new_up[i];
        world_from_camera.m[i][2] = dir[i];
    }
    world_from_camera.m[0][3] = eye.x;
    world_from_camera.m[1][3] = eye.y;
    world_from_camera.m[2][3] = eye.z;
    Mat4 camera_from_world;
    invert(world_from_camera, camera_from_world);
    return Transform(camera_from_world, world_from_camera);
}

inline Transform Transform::perspective(double fov_deg, double n, double f) {
    Mat4 persp;
    persp.m[2][2] = f / (f - n);
    persp.m[2][3] = -f * n / (f - n);
    persp.m[3][2] = 1;
    persp.m[3][3] = 0;
    double inv_tan = 1.0 / std::tan(fov_deg * 3.14159265358979323846 / 360.0);
    return Transform(scale(inv_tan, inv_tan, 1).matrix() * persp);
}

}  // namespace tessera
