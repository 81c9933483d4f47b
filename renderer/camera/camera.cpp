#include "renderer/camera/camera.h"

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "renderer/camera/lens_system.h"
#include "sampling/distribution.h"
#include "sampling/warp.h"

namespace tessera {

namespace {
constexpr int kFilterTableSize = PixelFilter::kTableSize;

float gaussian_1d(float x, float sigma) {
    return std::exp(-x * x / (2 * sigma * sigma)) / std::sqrt(2 * kPi * sigma * sigma);
}
}  // namespace

/// pbrt-v4 MitchellFilter::Mitchell1D on x in [-2, 2].
float mitchell_1d(float x, float b, float c) {
    x = std::abs(x);
    if (x <= 1)
        return ((12 - 9 * b - 6 * c) * x * x * x + (-18 + 12 * b + 6 * c) * x * x + (6 - 2 * b)) *
               (1.f / 6.f);
    if (x <= 2)
        return ((-b - 6 * c) * x * x * x + (6 * b + 30 * c) * x * x + (-12 * b - 48 * c) * x +
                (8 * b + 24 * c)) *
               (1.f / 6.f);
    return 0.f;
}

float sinc(float x) {
    x = std::abs(x);
    return x < 1e-5f ? 1.f : std::sin(kPi * x) / (kPi * x);
}

PixelFilter::PixelFilter(Kind kind, Vec2f radius, float sigma)
    : kind_(kind), radius_(radius), sigma_(sigma) {
    if (kind_ == Kind::Gaussian) tabulate();
}

PixelFilter PixelFilter::mitchell(Vec2f radius, float b, float c) {
    PixelFilter f;
    f.kind_ = Kind::Mitchell;
    f.radius_ = radius;
    f.b_ = b;
    f.c_ = c;
    f.tabulate();
    return f;
}

PixelFilter PixelFilter::lanczos(Vec2f radius, float tau) {
    PixelFilter f;
    f.kind_ = Kind::Lanczos;
    f.radius_ = radius;
    f.tau_ = tau;
    f.tabulate();
    return f;
}

float PixelFilter::evaluate_1d(float x, int axis) const {
    const float r = radius_[axis];
    if (std::abs(x) > r) return 0.f;
    switch (kind_) {
    case Kind::Box:
        return 1.f;
    case Kind::Triangle:
        return std::max(0.f, r - std::abs(x));
    case Kind::Gaussian:
        return std::max(0.f, gaussian_1d(x, sigma_) - gaussian_1d(r, sigma_));
    case Kind::Mitchell:
        return mitchell_1d(2 * x / r, b_, c_);
    case Kind::Lanczos:
        return sinc(x) * sinc(x / tau_);
    }
    return 0.f;
}

void PixelFilter::tabulate() {
    // Tabulate |f_1d| per axis at the cell centres; sampling inverts the piecewise-constant
    // CDF. Signed filters keep each cell's sign and the normalisation int |f| / int f.
    const bool is_signed = kind_ == Kind::Mitchell || kind_ == Kind::Lanczos;
    weight_ = 1.f;
    for (int axis = 0; axis < 2; ++axis) {
        float r = radius_[axis];
        std::vector<float> &cdf = cdf_[axis];
        cdf.assign(kFilterTableSize + 1, 0.f);
        if (is_signed) sign_[axis].assign(kFilterTableSize, 1);
        double sum_abs = 0, sum = 0;
        for (int i = 0; i < kFilterTableSize; ++i) {
            float x = -r + (i + 0.5f) * (2 * r / kFilterTableSize);
            float f = evaluate_1d(x, axis);
            if (is_signed) sign_[axis][size_t(i)] = f < 0 ? -1 : 1;
            sum_abs += std::abs(f);
            sum += f;
            cdf[size_t(i) + 1] = cdf[size_t(i)] + std::abs(f);
        }
        if (is_signed && sum > 0) weight_ *= float(sum_abs / sum);
        float total = cdf.back();
        for (float &c : cdf) c = total > 0 ? c / total : 0.f;
        std::vector<int32_t> &guide = guide_[axis];
        guide.resize(kGuideSize);
        for (int k = 0; k < kGuideSize; ++k) {
            float u = float(k) / kGuideSize;
            auto it = std::upper_bound(cdf.begin(), cdf.end(), u);
            guide[size_t(k)] = std::max(0, int(it - cdf.begin()) - 1);
        }
    }
}

float PixelFilter::sample_1d(float u, int axis, int *cell) const {
    float r = radius_[axis];
    switch (kind_) {
    case Kind::Box:
        return (2 * u - 1) * r;
    case Kind::Triangle:
        return sampling::sample_tent(u, r);
    case Kind::Gaussian:
    case Kind::Mitchell:
    case Kind::Lanczos: {
        const std::vector<float> &cdf = cdf_[axis];
        // Largest i with cdf[i] <= u (what upper_bound - 1 gives), walking up from the guide
        // entry of u's bucket; cdf[0] = 0 <= u, so the guide entry never overshoots.
        int k = std::min(int(u * kGuideSize), kGuideSize - 1);
        int i = guide_[axis][size_t(k)];
        while (i + 1 <= kFilterTableSize && cdf[size_t(i) + 1] <= u)
            ++i;
        i = std::clamp(i, 0, kFilterTableSize - 1);
        if (cell) *cell = i;
        float c0 = cdf[size_t(i)], c1 = cdf[size_t(i) + 1];
        float t = c1 > c0 ? (u - c0) / (c1 - c0) : 0.5f;
        return -r + (i + t) * (2 * r / kFilterTableSize);
    }
    }
    return 0.f;
}

Vec2f PixelFilter::sample(Vec2f u, float *weight) const {
    if (!has_negative_lobes()) {
        if (weight) *weight = 1.f;
        return {sample_1d(u.x, 0), sample_1d(u.y, 1)};
    }
    int cx = 0, cy = 0;
    Vec2f p{sample_1d(u.x, 0, &cx), sample_1d(u.y, 1, &cy)};
    if (weight) *weight = float(sign_[0][size_t(cx)] * sign_[1][size_t(cy)]) * weight_;
    return p;
}

float PixelFilter::evaluate(Vec2f p) const {
    if (std::abs(p.x) > radius_.x || std::abs(p.y) > radius_.y) return 0.f;
    return evaluate_1d(p.x, 0) * evaluate_1d(p.y, 1);
}

std::string PixelFilter::describe() const {
    const char *names[] = {"box", "triangle", "gaussian", "mitchell", "sinc"};
    char buf[128];
    std::snprintf(buf, sizeof(buf), "%s filter, radius (%g, %g)", names[int(kind_)], radius_.x,
                  radius_.y);
    return buf;
}

PerspectiveCamera::PerspectiveCamera(const Transform &camera_from_world, int width, int height,
                                     float fov_deg, float lens_radius, float focal_distance,
                                     const float *screen_window, bool orthographic,
                                     SphericalMapping spherical)
    : world_from_camera_(camera_from_world.inverse()),
      lens_radius_(orthographic || spherical != SphericalMapping::None ? 0.f : lens_radius),
      focal_distance_(focal_distance),
      orthographic_(orthographic),
      spherical_(spherical),
      width_(float(width)),
      height_(float(height)) {
    // Screen window: the shorter axis spans [-1, 1] (pbrt-v4 CameraBase).
    float aspect = float(width) / float(height);
    float sw[4];
    if (screen_window) {
        std::copy(screen_window, screen_window + 4, sw);
    } else if (aspect > 1.f) {
        sw[0] = -aspect; sw[1] = aspect; sw[2] = -1.f; sw[3] = 1.f;
    } else {
        sw[0] = -1.f; sw[1] = 1.f; sw[2] = -1.f / aspect; sw[3] = 1.f / aspect;
    }
    // pbrt-v4: Perspective(fov, 1e-2, 1000), or Orthographic(0, 1) = the identity in x and y.
    Transform screen_from_camera =
        orthographic ? Transform() : Transform::perspective(fov_deg, 1e-2, 1000.0);
    Transform raster_from_screen = Transform::scale(width, -height, 1) *
                                   Transform::scale(1.0 / (sw[1] - sw[0]), 1.0 / (sw[3] - sw[2]), 1) *
                                   Transform::translate({-sw[0], -sw[3], 0});
    camera_from_raster_ = screen_from_camera.inverse() * raster_from_screen.inverse();
    p0_camera_ = camera_from_raster_.point({0, 0, 0});
    dx_camera_ = camera_from_raster_.point({1, 0, 0}) - p0_camera_;
    dy_camera_ = camera_from_raster_.point({0, 1, 0}) - p0_camera_;
    set_world_from_camera(world_from_camera_);

    // Smallest differentials over the film, for Approximate_dp_dxy (pbrt-v4 FindMinimumDifferentials).
    min_pos_dx_ = min_pos_dy_ = {kInfinity, kInfinity, kInfinity};
    min_dir_dx_ = min_dir_dy_ = {kInfinity, kInfinity, kInfinity};
    const int n = 32;
    for (int i = 0; i < n; ++i) {
        Vec2f pr{float(i) / (n - 1) * width, float(i) / (n - 1) * height};
        Vec3f pc = camera_from_raster_.point({pr.x, pr.y, 0});
        Vec3f d = normalize(pc);
        Vec3f dx = normalize(pc + dx_camera_) - d;
        Vec3f dy = normalize(pc + dy_camera_) - d;
        if (length_squared(dx) < length_squared(min_dir_dx_)) min_dir_dx_ = dx;
        if (length_squared(dy) < length_squared(min_dir_dy_)) min_dir_dy_ = dy;
    }
    min_pos_dx_ = min_pos_dy_ = {0, 0, 0};
    if (spherical_ != SphericalMapping::None) {
        // The same search over the spherical map's one-pixel direction steps.
        min_dir_dx_ = min_dir_dy_ = {kInfinity, kInfinity, kInfinity};
        for (int i = 0; i < n; ++i) {
            Vec2f pr{(float(i) + 0.5f) / n * width, (float(i) + 0.5f) / n * height};
            Vec3f d = spherical_direction(pr);
            // Relative to d as the z axis (approximate_dp_dxy rotates them around w).
            Frame f = Frame::from_z(d);
            Vec3f dx = f.to_local(spherical_direction(pr + Vec2f{1, 0})) - Vec3f(0, 0, 1);
            Vec3f dy = f.to_local(spherical_direction(pr + Vec2f{0, 1})) - Vec3f(0, 0, 1);
            if (length_squared(dx) > 0 && length_squared(dx) < length_squared(min_dir_dx_))
                min_dir_dx_ = dx;
            if (length_squared(dy) > 0 && length_squared(dy) < length_squared(min_dir_dy_))
                min_dir_dy_ = dy;
        }
    }
}

Vec3f PerspectiveCamera::spherical_direction(Vec2f p_raster) const {
    Vec2f uv{p_raster.x / width_, p_raster.y / height_};
    Vec3f dir;
    if (spherical_ == SphericalMapping::Equirectangular) {
        const float theta = kPi * uv.y, phi = 2 * kPi * uv.x;
        dir = {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
    } else {
        // pbrt-v4 WrapEqualAreaSquare: mirror across an edge and flip the other coordinate.
        if (uv.x < 0) {
            uv.x = -uv.x;
            uv.y = 1 - uv.y;
        } else if (uv.x > 1) {
            uv.x = 2 - uv.x;
            uv.y = 1 - uv.y;
        }
        if (uv.y < 0) {
            uv.x = 1 - uv.x;
            uv.y = -uv.y;
        } else if (uv.y > 1) {
            uv.x = 1 - uv.x;
            uv.y = 2 - uv.y;
        }
        dir = sampling::equal_area_square_to_sphere(uv);
    }
    std::swap(dir.y, dir.z);
    return dir;
}

void PerspectiveCamera::set_world_from_camera(const Transform &world_from_camera) {
    world_from_camera_ = world_from_camera;
    const Mat4 &wc = world_from_camera_.matrix();
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            world_from_camera_f_[r][c] = float(wc.m[r][c]);
    position_ = world_from_camera_.point({0, 0, 0});
    forward_ = normalize(world_from_camera_.vector({0, 0, 1}));
}

std::optional<PerspectiveCamera::Pinhole> PerspectiveCamera::pinhole() const {
    if (lens_ || lens_radius_ > 0 || orthographic_ || spherical_ != SphericalMapping::None)
        return std::nullopt;
    Pinhole ph{p0_camera_, dx_camera_, dy_camera_, {}};
    std::memcpy(ph.world_from_camera, world_from_camera_f_, sizeof(world_from_camera_f_));
    return ph;
}

Vec3f PerspectiveCamera::camera_point_world(Vec3f p) const {
    const auto &m = world_from_camera_f_;
    return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
}

Vec3f PerspectiveCamera::camera_vector_world(Vec3f v) const {
    const auto &m = world_from_camera_f_;
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}

void PerspectiveCamera::set_lens_system(std::shared_ptr<const LensSystem> lens) {
    lens_ = std::move(lens);
    if (!lens_) return;
    // The smallest direction differentials over the film's diagonal through the pupil's
    // centre (pbrt-v4 FindMinimumDifferentials), relative to each ray as the z axis.
    min_dir_dx_ = min_dir_dy_ = {kInfinity, kInfinity, kInfinity};
    min_pos_dx_ = min_pos_dy_ = {0, 0, 0};
    const int n = 64;
    for (int i = 0; i < n; ++i) {
        Vec2f pr{float(i) / (n - 1) * width_, float(i) / (n - 1) * height_};
        CameraRay cr = lens_ray(pr, {0.5f, 0.5f}, true);
        if (cr.weight == 0.f || !cr.has_differentials) continue;
        Frame f = Frame::from_z(cr.ray.d);
        Vec3f dx = normalize(f.to_local(normalize(cr.rx_d))) - Vec3f(0, 0, 1);
        Vec3f dy = normalize(f.to_local(normalize(cr.ry_d))) - Vec3f(0, 0, 1);
        if (length_squared(dx) > 0 && length_squared(dx) < length_squared(min_dir_dx_))
            min_dir_dx_ = dx;
        if (length_squared(dy) > 0 && length_squared(dy) < length_squared(min_dir_dy_))
            min_dir_dy_ = dy;
    }
    if (!std::isfinite(min_dir_dx_.x)) min_dir_dx_ = {0, 0, 0};
    if (!std::isfinite(min_dir_dy_.x)) min_dir_dy_ = {0, 0, 0};
}

CameraRay PerspectiveCamera::lens_ray(Vec2f p_raster, Vec2f u_lens, bool differentials) const {
    CameraRay cr;
    Vec3f o, d;
    cr.weight = lens_->generate_ray(p_raster, u_lens, &o, &d);
    if (cr.weight == 0.f) return cr;
    cr.ray.o = camera_point_world(o);
    cr.ray.d = normalize(camera_vector_world(d));
    cr.ray.t_max = kInfinity;
    if (!differentials) return cr;
    // Finite differences a twentieth of a pixel away with the same lens sample, the other
    // way if the lens blocks that one; no differentials if both are blocked.
    auto shifted = [&](Vec2f step, Vec3f *o_d, Vec3f *d_d) {
        for (float eps : {0.05f, -0.05f}) {
            Vec3f so, sd;
            if (lens_->generate_ray(p_raster + step * eps, u_lens, &so, &sd) == 0.f) continue;
            Vec3f wo = camera_point_world(so), wd = normalize(camera_vector_world(sd));
            *o_d = cr.ray.o + (wo - cr.ray.o) / eps;
            *d_d = cr.ray.d + (wd - cr.ray.d) / eps;
            return true;
        }
        return false;
    };
    cr.has_differentials = shifted({1, 0}, &cr.rx_o, &cr.rx_d) &&
                           shifted({0, 1}, &cr.ry_o, &cr.ry_d);
    return cr;
}

CameraRay PerspectiveCamera::generate_ray(Vec2f p_raster, Vec2f u_lens, bool differentials) const {
    if (lens_) return lens_ray(p_raster, u_lens, differentials);
    Vec3f p_camera = p0_camera_ + dx_camera_ * p_raster.x + dy_camera_ * p_raster.y;
    CameraRay cr;
    cr.ray.t_max = kInfinity;
    if (lens_radius_ > 0) {
        Vec3f d = normalize(p_camera);
        Vec2f pl = sampling::square_to_disk_concentric(u_lens) * lens_radius_;
        float ft = focal_distance_ / d.z;
        Vec3f p_focus = d * ft;
        Vec3f o{pl.x, pl.y, 0};
        cr.ray.o = camera_point_world(o);
        cr.ray.d = normalize(camera_vector_world(p_focus - o));
        if (differentials) {
            // Differentials through the same lens point (pbrt-v4 PerspectiveCamera).
            Vec3f dxc = normalize(p_camera + dx_camera_);
            Vec3f dyc = normalize(p_camera + dy_camera_);
            Vec3f fx = dxc * (focal_distance_ / dxc.z), fy = dyc * (focal_distance_ / dyc.z);
            cr.rx_o = cr.ry_o = cr.ray.o;
            cr.rx_d = normalize(camera_vector_world(fx - o));
            cr.ry_d = normalize(camera_vector_world(fy - o));
            cr.has_differentials = true;
        }
        return cr;
    }
    if (spherical_ != SphericalMapping::None) {
        cr.ray.o = position();
        cr.ray.d = normalize(camera_vector_world(spherical_direction(p_raster)));
        if (differentials) {
            // One-pixel finite differences (pbrt-v4 CameraBase::GenerateRayDifferential).
            cr.rx_o = cr.ry_o = cr.ray.o;
            cr.rx_d = normalize(camera_vector_world(spherical_direction(p_raster + Vec2f{1, 0})));
            cr.ry_d = normalize(camera_vector_world(spherical_direction(p_raster + Vec2f{0, 1})));
            cr.has_differentials = true;
        }
        return cr;
    }
    if (orthographic_) {
        // Parallel rays along camera +z from the film plane (pbrt-v4 OrthographicCamera).
        cr.ray.o = camera_point_world(p_camera);
        cr.ray.d = normalize(camera_vector_world({0, 0, 1}));
        if (differentials) {
            cr.rx_o = camera_point_world(p_camera + dx_camera_);
            cr.ry_o = camera_point_world(p_camera + dy_camera_);
            cr.rx_d = cr.ry_d = cr.ray.d;
            cr.has_differentials = true;
        }
        return cr;
    }
    // Pinhole: one normalisation in world space (the camera transform may scale).
    cr.ray.o = {world_from_camera_f_[0][3], world_from_camera_f_[1][3], world_from_camera_f_[2][3]};
    cr.ray.d = normalize(camera_vector_world(p_camera));
    if (differentials) {
        cr.rx_o = cr.ry_o = cr.ray.o;
        cr.rx_d = normalize(camera_vector_world(p_camera + dx_camera_));
        cr.ry_d = normalize(camera_vector_world(p_camera + dy_camera_));
        cr.has_differentials = true;
    }
    return cr;
}

void PerspectiveCamera::approximate_dp_dxy(Vec3f p, Vec3f n, int spp, Vec3f *dpdx,
                                           Vec3f *dpdy) const {
    // Intersect the smallest camera differential rays, translated to pass the camera origin
    // toward p, with the tangent plane at p (pbrt-v4 CameraBase::Approximate_dp_dxy).
    if (orthographic_) {
        // A raster step is the same world vector everywhere (projected on the tangent plane).
        float spp_scale = std::max(0.125f, 1.f / std::sqrt(float(std::max(spp, 1))));
        Vec3f d = camera_vector_world({0, 0, 1});
        auto project = [&](Vec3f v) {
            float dn = dot(n, d);
            return std::abs(dn) > 1e-8f ? (v - d * (dot(n, v) / dn)) * spp_scale : Vec3f();
        };
        *dpdx = project(camera_vector_world(dx_camera_));
        *dpdy = project(camera_vector_world(dy_camera_));
        return;
    }
    Vec3f cam = position();
    Vec3f to_p = p - cam;
    float dist = length(to_p);
    float spp_scale = std::max(0.125f, 1.f / std::sqrt(float(std::max(spp, 1))));
    if (!(dist > 0)) {
        *dpdx = *dpdy = {0, 0, 0};
        return;
    }
    Vec3f w = to_p / dist;
    Frame f = Frame::from_z(w);
    auto hit = [&](Vec3f ddir_cam) {
        // Rotate the camera-space differential so that it is relative to w instead of +z.
        Vec3f d = normalize(w + f.x * ddir_cam.x + f.y * ddir_cam.y);
        float denom = dot(n, d);
        if (std::abs(denom) < 1e-8f) return Vec3f(0, 0, 0);
        float t = dot(n, to_p) / denom;
        return (cam + d * t - p) * spp_scale;
    };
    *dpdx = hit(min_dir_dx_);
    *dpdy = hit(min_dir_dy_);
}

}  // namespace tessera
