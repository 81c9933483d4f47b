// Light sources (see lights.h). Equation references are to pbrt-v4's book (Pharr, Jakob,
// Humphreys, "Physically Based Rendering", 4th ed., 2023) unless stated otherwise.
#include "renderer/lights/lights.h"
#include "renderer/util/image_io.h"
#include "renderer/util/limits.h"


#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "sampling/warp.h"

namespace tessera {

namespace {

std::string rgb_str(Rgb c) {
    std::ostringstream s;
    s << "(" << c.r << ", " << c.g << ", " << c.b << ")";
    return s.str();
}

std::string vec_str(Vec3f v) {
    std::ostringstream s;
    s << "(" << v.x << ", " << v.y << ", " << v.z << ")";
    return s.str();
}

/// Converts an area density at p_light to solid angle at p_ref (eq. 4.9): d^2 / |cos theta_l|.
/// Returns 0 for a grazing or coincident configuration.
float area_to_solid_angle_pdf(float pdf_area, Vec3f p_ref, Vec3f p_light, Vec3f n_light) {
    Vec3f d = p_light - p_ref;
    float d2 = length_squared(d);
    if (d2 == 0.f)
        return 0.f;
    float cos_l = absdot(n_light, d / std::sqrt(d2));
    if (cos_l == 0.f)
        return 0.f;
    float pdf = pdf_area * d2 / cos_l;
    return std::isfinite(pdf) ? pdf : 0.f;
}

/// sRGB decoding (IEC 61966-2-1) for 8/16-bit images.
float srgb_to_linear(float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

std::string resolve_path(const std::string &base_dir, const std::string &file) {
    std::filesystem::path p(file);
    if (p.is_absolute() || base_dir.empty())
        return file;
    return (std::filesystem::path(base_dir) / p).string();
}

/// A transform whose columns are the frame's axes: maps light-space +z onto f.z.
Transform transform_from_frame(const Frame &f) {
    Mat4 m;
    for (int i = 0; i < 3; ++i) {
        m.m[i][0] = f.x[i];
        m.m[i][1] = f.y[i];
        m.m[i][2] = f.z[i];
    }
    return Transform(m, transpose(m));
}

}  // namespace

Rgb Light::L(Vec3f, Vec3f, Vec2f, Vec3f) const {
    return Rgb(0.f);
}
Rgb Light::Le(Vec3f) const {
    return Rgb(0.f);
}

// ---------------------------------------------------------------------------------------------
// PointLight

std::string PointLight::describe() const {
    return "PointLight p=" + vec_str(p_) + " I=" + rgb_str(I_);
}

// ---------------------------------------------------------------------------------------------
// SpotLight

SpotLight::SpotLight(const Transform &render_from_light, Rgb intensity, float cos_falloff_start,
                     float cos_falloff_end)
    : Light(LightShape::Spot),
      render_from_light_(render_from_light),
      p_(render_from_light.point({0, 0, 0})),
      I_(intensity),
      cos_falloff_start_(cos_falloff_start),
      cos_falloff_end_(cos_falloff_end) {
    // M^T M = s^2 I, i.e. the columns are orthogonal and of one length.
    const Mat4 &m = render_from_light.matrix();
    double g[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            g[i][j] = m.m[0][i] * m.m[0][j] + m.m[1][i] * m.m[1][j] + m.m[2][i] * m.m[2][j];
    const double s2 = g[0][0];
    bool similarity = s2 > 0 && m.m[3][0] == 0 && m.m[3][1] == 0 && m.m[3][2] == 0;
    for (int i = 0; i < 3 && similarity; ++i)
        for (int j = 0; j < 3; ++j)
            similarity = similarity && std::abs(g[i][j] - (i == j ? s2 : 0.0)) <= 1e-6 * s2;
    similarity_ = similarity;
    if (similarity_) axis_ = normalize(render_from_light.vector({0, 0, 1}));
}

Rgb SpotLight::intensity(Vec3f w_light) const {
    return I_ * smooth_step(cos_theta(w_light), cos_falloff_end_, cos_falloff_start_);
}

Rgb SpotLight::phi() const {
    // Integral of the smoothstep falloff over the sphere (pbrt-v4 SpotLight::Phi): the full
    // cone plus half of the falloff band.
    return I_ * (2.f * kPi *
                 ((1.f - cos_falloff_start_) + (cos_falloff_start_ - cos_falloff_end_) / 2.f));
}

std::string SpotLight::describe() const {
    return "SpotLight p=" + vec_str(p_) + " I=" + rgb_str(I_) +
           " cos_start=" + std::to_string(cos_falloff_start_) +
           " cos_end=" + std::to_string(cos_falloff_end_);
}

// ---------------------------------------------------------------------------------------------
// GoniometricLight

GoniometricLight::GoniometricLight(const Transform &render_from_light, Rgb intensity,
                                   std::vector<float> image, int res)
    : Light(LightShape::Other),
      render_from_light_(render_from_light),
      p_(render_from_light.point({0, 0, 0})),
      I_(intensity),
      image_(std::move(image)),
      res_(res) {
    double sum = 0;
    for (float v : image_) sum += v;
    mean_ = image_.empty() ? 0.f : float(sum / double(image_.size()));
}

Rgb GoniometricLight::intensity(Vec3f w_light) const {
    float l2 = length_squared(w_light);
    if (!(l2 > 0.f) || image_.empty()) return Rgb(0.f);
    Vec3f w = w_light / std::sqrt(l2);
    // pbrt-v4 composes renderFromLight with a y/z swap, so the map sees (x, z, y).
    Vec2f uv = sampling::equal_area_sphere_to_square({w.x, w.z, w.y});
    // Image::LookupNearest: truncate uv * resolution, clamp to the image.
    int x = std::clamp(int(uv.x * float(res_)), 0, res_ - 1);
    int y = std::clamp(int(uv.y * float(res_)), 0, res_ - 1);
    return I_ * image_[size_t(y) * size_t(res_) + size_t(x)];
}

namespace {

/// A point emitter's light sample: its intensity toward -wi in light space over d^2; nullopt
/// where it sends nothing (as for a spot light outside its cone).
template <class IntensityFn>
std::optional<LightLiSample> sample_point_emitter(const LightSampleContext &ctx, Vec3f p,
                                                  const Transform &render_from_light,
                                                  IntensityFn intensity) {
    float d2;
    std::optional<LightLiSample> s = sample_toward(ctx, p, &d2);
    if (!s) return std::nullopt;
    s->L = intensity(render_from_light.inverse_vector(-s->wi)) / d2;
    if (s->L.is_black()) return std::nullopt;
    s->pdf = 1.f;
    return s;
}

}  // namespace

std::optional<LightLiSample> GoniometricLight::sample_li(const LightSampleContext &ctx,
                                                         Vec2f) const {
    return sample_point_emitter(ctx, p_, render_from_light_,
                                [this](Vec3f w) { return intensity(w); });
}

Rgb GoniometricLight::phi() const { return I_ * (4.f * kPi * mean_); }

std::string GoniometricLight::describe() const {
    return "GoniometricLight p=" + vec_str(p_) + " I=" + rgb_str(I_) + " image=" +
           std::to_string(res_) + "x" + std::to_string(res_);
}

// ---------------------------------------------------------------------------------------------
// ProjectionLight

ProjectionLight::ProjectionLight(const Transform &render_from_light, std::vector<Rgb> image,
                                 int width, int height, float fov_deg, float scale)
    : Light(LightShape::Other),
      render_from_light_(render_from_light),
      p_(render_from_light.point({0, 0, 0})),
      image_(std::move(image)),
      width_(width),
      height_(height),
      scale_(scale) {
    const float aspect = float(width) / float(height);
    if (aspect > 1.f) {
        x0_ = -aspect, x1_ = aspect, y0_ = -1.f, y1_ = 1.f;
    } else {
        x0_ = -1.f, x1_ = 1.f, y0_ = -1.f / aspect, y1_ = 1.f / aspect;
    }
    const float opposite = std::tan(radians(fov_deg) / 2.f);
    inv_tan_ = 1.f / opposite;
    area_ = 4.f * opposite * opposite * (aspect > 1.f ? aspect : 1.f / aspect);
}

Rgb ProjectionLight::intensity(Vec3f w_light) const {
    float l2 = length_squared(w_light);
    if (!(l2 > 0.f)) return Rgb(0.f);
    Vec3f w = w_light / std::sqrt(l2);
    // pbrt-v4 flips the light's y (renderFromLight * Scale(1, -1, 1)) so that the image's top
    // row lands toward +y.
    w.y = -w.y;
    constexpr float kHither = 1e-3f;
    if (w.z < kHither) return Rgb(0.f);
    const float sx = w.x * inv_tan_ / w.z, sy = w.y * inv_tan_ / w.z;
    if (!(sx >= x0_ && sx <= x1_ && sy >= y0_ && sy <= y1_)) return Rgb(0.f);
    // Image::LookupNearest of the screen offset: truncate, clamp to the image.
    const float u = (sx - x0_) / (x1_ - x0_), v = (sy - y0_) / (y1_ - y0_);
    const int x = std::clamp(int(u * float(width_)), 0, width_ - 1);
    const int y = std::clamp(int(v * float(height_)), 0, height_ - 1);
    const Rgb c = image_[size_t(y) * size_t(width_) + size_t(x)];
    return Rgb(std::max(0.f, c.r), std::max(0.f, c.g), std::max(0.f, c.b)) * scale_;
}

std::optional<LightLiSample> ProjectionLight::sample_li(const LightSampleContext &ctx,
                                                        Vec2f) const {
    return sample_point_emitter(ctx, p_, render_from_light_,
                                [this](Vec3f w) { return intensity(w); });
}

namespace {

/// cos^3 of the direction through the screen point at the centre of pixel (x, y), the
/// solid-angle-per-screen-area factor of a projection light's pixel.
float projection_cos3(int x, int y, int w, int h, float x0, float x1, float y0, float y1,
                      float inv_tan) {
    const float sx = x0 + (x1 - x0) * (float(x) + 0.5f) / float(w);
    const float sy = y0 + (y1 - y0) * (float(y) + 0.5f) / float(h);
    // The screen point (sx, sy) at depth 1 is the light-space direction (sx, sy) / inv_tan.
    Vec3f d = normalize(Vec3f(sx / inv_tan, sy / inv_tan, 1.f));
    return d.z * d.z * d.z;
}

}  // namespace

Rgb ProjectionLight::phi() const {
    double sum[3] = {0, 0, 0};
    for (int y = 0; y < height_; ++y)
        for (int x = 0; x < width_; ++x) {
            const float c3 = projection_cos3(x, y, width_, height_, x0_, x1_, y0_, y1_, inv_tan_);
            const Rgb c = image_[size_t(y) * size_t(width_) + size_t(x)];
            sum[0] += std::max(0.f, c.r) * c3;
            sum[1] += std::max(0.f, c.g) * c3;
            sum[2] += std::max(0.f, c.b) * c3;
        }
    const double k = double(scale_) * area_ / (double(width_) * height_);
    return Rgb(float(sum[0] * k), float(sum[1] * k), float(sum[2] * k));
}

float ProjectionLight::unit_power() const {
    double sum = 0;
    for (int y = 0; y < height_; ++y)
        for (int x = 0; x < width_; ++x)
            sum += double(image_[size_t(y) * size_t(width_) + size_t(x)].luminance()) *
                   projection_cos3(x, y, width_, height_, x0_, x1_, y0_, y1_, inv_tan_);
    return float(double(area_) * sum / (double(width_) * height_));
}

std::string ProjectionLight::describe() const {
    return "ProjectionLight p=" + vec_str(p_) + " image=" + std::to_string(width_) + "x" +
           std::to_string(height_) + " scale=" + std::to_string(scale_);
}

// ---------------------------------------------------------------------------------------------
// DistantLight

std::optional<LightLiSample> DistantLight::sample_li(const LightSampleContext &ctx, Vec2f) const {
    LightLiSample s;
    s.wi = w_;
    s.L = L_;
    s.pdf = 1.f;
    // Outside the scene's bounding sphere, so a shadow ray to it crosses every occluder.
    s.p_light = ctx.p + w_ * (2.f * scene_radius_);
    return s;
}

std::string DistantLight::describe() const {
    return "DistantLight w=" + vec_str(w_) + " L=" + rgb_str(L_);
}

// ---------------------------------------------------------------------------------------------
// UniformInfiniteLight

std::optional<LightLiSample> UniformInfiniteLight::sample_li(const LightSampleContext &ctx,
                                                             Vec2f u) const {
    LightLiSample s;
    s.wi = sampling::square_to_uniform_sphere(u);
    s.pdf = sampling::uniform_sphere_pdf();
    s.L = L_;
    s.p_light = ctx.p + s.wi * (2.f * scene_radius_);
    return s;
}

float UniformInfiniteLight::pdf_li(const LightSampleContext &, Vec3f, Vec3f, Vec3f) const {
    return sampling::uniform_sphere_pdf();
}

std::string UniformInfiniteLight::describe() const {
    return "UniformInfiniteLight L=" + rgb_str(L_);
}

// ---------------------------------------------------------------------------------------------
// ImageInfiniteLight

namespace {

// Relative solid angle of pixel row y: sin(theta) at the row centre for lat-long maps, 1 for the
// equal-area map, whose pixels all cover 4 pi / (w h) sr.
float row_weight(ImageInfiniteLight::Mapping m, int y, int height) {
    if (m == ImageInfiniteLight::Mapping::EqualArea)
        return 1.f;
    return std::sin(kPi * (float(y) + 0.5f) / float(height));
}

}  // namespace

ImageInfiniteLight::ImageInfiniteLight(const Transform &render_from_light, std::vector<Rgb> pixels,
                                       int width, int height, Mapping mapping, float scale)
    : render_from_light_(render_from_light),
      pixels_(std::move(pixels)),
      width_(std::max(width, 1)),
      height_(std::max(height, 1)),
      mapping_(mapping),
      scale_(scale) {
    pixels_.resize(size_t(width_) * size_t(height_));
    std::vector<float> d(pixels_.size());
    for (int y = 0; y < height_; ++y) {
        // Lat-long rows near the poles cover less solid angle: weight by sin(theta) so that the
        // density follows radiance per steradian (pbrt-v3 InfiniteAreaLight).
        float w_row = row_weight(mapping_, y, height_);
        for (int x = 0; x < width_; ++x) {
            Rgb c = clamp_zero(pixels_[size_t(y) * size_t(width_) + size_t(x)]);
            d[size_t(y) * size_t(width_) + size_t(x)] = c.average() * w_row;
        }
    }
    distribution_ = sampling::PiecewiseConstant2D(d, width_, height_);
}

Vec3f ImageInfiniteLight::direction_from_uv(Mapping mapping, Vec2f uv) {
    if (mapping == Mapping::EqualArea)
        return sampling::equal_area_square_to_sphere(uv);
    float theta = uv.y * kPi, phi = uv.x * 2.f * kPi;
    return spherical_direction(std::sin(theta), std::cos(theta), phi);
}

Vec2f ImageInfiniteLight::uv_from_direction(Mapping mapping, Vec3f w) {
    if (mapping == Mapping::EqualArea)
        return sampling::equal_area_sphere_to_square(w);
    float theta = safe_acos(w.z);
    float phi = std::atan2(w.y, w.x);
    if (phi < 0.f)
        phi += 2.f * kPi;
    return {phi * kInv2Pi, theta * kInvPi};
}

Rgb ImageInfiniteLight::lookup(Vec2f uv) const {
    // Nearest pixel, like pbrt-v4's ImageLe; this also makes Le exactly proportional to the
    // sampling density within each pixel.
    int x = clamp(int(uv.x * float(width_)), 0, width_ - 1);
    int y = clamp(int(uv.y * float(height_)), 0, height_ - 1);
    return clamp_zero(pixels_[size_t(y) * size_t(width_) + size_t(x)]) * scale_;
}

std::optional<LightLiSample> ImageInfiniteLight::sample_li(const LightSampleContext &ctx,
                                                           Vec2f u) const {
    float map_pdf = 0.f;
    Vec2f uv = distribution_.sample(u, &map_pdf);
    if (map_pdf == 0.f)
        return std::nullopt;
    Vec3f w_light = direction_from_uv(mapping_, uv);
    float pdf;
    if (mapping_ == Mapping::EqualArea) {
        // The equal-area map has a constant Jacobian of 4 pi sr per unit square.
        pdf = map_pdf / (4.f * kPi);
    } else {
        // d(omega) = 2 pi^2 sin(theta) du dv for the lat-long map.
        float sin_theta = std::sin(uv.y * kPi);
        if (sin_theta <= 0.f)
            return std::nullopt;
        pdf = map_pdf / (2.f * kPi * kPi * sin_theta);
    }
    LightLiSample s;
    s.wi = normalize(render_from_light_.vector(w_light));
    s.pdf = pdf;
    s.L = lookup(uv);
    s.p_light = ctx.p + s.wi * (2.f * scene_radius_);
    return s;
}

float ImageInfiniteLight::pdf_li(const LightSampleContext &, Vec3f wi, Vec3f, Vec3f) const {
    Vec3f w_light = normalize(render_from_light_.inverse_vector(wi));
    Vec2f uv = uv_from_direction(mapping_, w_light);
    float map_pdf = distribution_.pdf(uv);
    if (mapping_ == Mapping::EqualArea)
        return map_pdf / (4.f * kPi);
    float sin_theta = safe_sqrt(1.f - w_light.z * w_light.z);
    if (sin_theta <= 0.f)
        return 0.f;
    return map_pdf / (2.f * kPi * kPi * sin_theta);
}

Rgb ImageInfiniteLight::Le(Vec3f dir) const {
    Vec3f w_light = normalize(render_from_light_.inverse_vector(dir));
    return lookup(uv_from_direction(mapping_, w_light));
}

Rgb ImageInfiniteLight::phi() const {
    // Mean radiance over the sphere, then pbrt-v4's fluence-to-power factor 4 pi * pi r^2.
    Rgb sum(0.f);
    double weight = 0;
    for (int y = 0; y < height_; ++y) {
        float w_row = row_weight(mapping_, y, height_);
        for (int x = 0; x < width_; ++x)
            sum += clamp_zero(pixels_[size_t(y) * size_t(width_) + size_t(x)]) * w_row;
        weight += double(w_row) * width_;
    }
    Rgb mean = weight > 0 ? sum / float(weight) : Rgb(0.f);
    return mean * (scale_ * 4.f * kPi * kPi * scene_radius_ * scene_radius_);
}

std::string ImageInfiniteLight::describe() const {
    return std::string("ImageInfiniteLight ") + std::to_string(width_) + "x" +
           std::to_string(height_) +
           (mapping_ == Mapping::EqualArea ? " equal-area" : " equirect") +
           " scale=" + std::to_string(scale_);
}

// ---------------------------------------------------------------------------------------------
// TriangleLight

TriangleLight::TriangleLight(Vec3f p0, Vec3f p1, Vec3f p2, Vec3f n, Rgb radiance, bool twosided)
    : Light(LightShape::Triangle), p0_(p0), p1_(p1), p2_(p2), n_(normalize(n)), L_(radiance), twosided_(twosided) {
    area_ = 0.5f * length(cross(p1 - p0, p2 - p0));
}

std::optional<LightLiSample> TriangleLight::sample_li(const LightSampleContext &ctx,
                                                      Vec2f u) const {
    if (!(area_ > 0.f))
        return std::nullopt;
    Vec2f b = sampling::square_to_uniform_triangle(u);
    Vec3f p = p0_ * b.x + p1_ * b.y + p2_ * (1.f - b.x - b.y);
    Vec3f d = p - ctx.p;
    float d2 = length_squared(d);
    if (d2 == 0.f)
        return std::nullopt;
    LightLiSample s;
    float inv_dist = 1.f / std::sqrt(d2);
    s.wi = d * inv_dist;
    // area_to_solid_angle_pdf(1 / area, ctx.p, p, n_) inlined, reusing d2 and wi.
    float cos_l = absdot(n_, s.wi);
    if (cos_l == 0.f)
        return std::nullopt;
    s.pdf = d2 / (area_ * cos_l);
    if (!std::isfinite(s.pdf) || s.pdf == 0.f)
        return std::nullopt;
    // The one-sided test of L(): emission leaves the n_ side only.
    if (!twosided_ && dot(n_, s.wi) >= 0.f)
        return std::nullopt;
    s.L = L_;
    if (s.L.is_black())
        return std::nullopt;
    s.p_light = p;
    s.n_light = face_forward(n_, -s.wi);
    return s;
}

float TriangleLight::pdf_li(const LightSampleContext &ctx, Vec3f, Vec3f p_light, Vec3f) const {
    if (!(area_ > 0.f))
        return 0.f;
    return area_to_solid_angle_pdf(1.f / area_, ctx.p, p_light, n_);
}

Rgb TriangleLight::L(Vec3f, Vec3f, Vec2f, Vec3f w_out) const {
    if (!twosided_ && dot(n_, w_out) <= 0.f)
        return Rgb(0.f);
    return L_;
}

Rgb TriangleLight::phi() const {
    return L_ * (kPi * area_ * (twosided_ ? 2.f : 1.f));
}

std::string TriangleLight::describe() const {
    return "TriangleLight p0=" + vec_str(p0_) + " p1=" + vec_str(p1_) + " p2=" + vec_str(p2_) +
           " n=" + vec_str(n_) + " L=" + rgb_str(L_) + (twosided_ ? " twosided" : "");
}

// ---------------------------------------------------------------------------------------------
// SphereLight

namespace {

// Below sin^2(1.5 deg) the cone is sampled with a Taylor expansion: 1 - cos(theta_max) would
// cancel catastrophically in float (pbrt-v4 Sphere::Sample).
constexpr float kSmallSin2ThetaMax = 0.00068523f;

struct SphereCone {
    float sin2_max, sin_max, cos_max, one_minus_cos_max;
};

SphereCone sphere_cone(float radius, float dist2) {
    SphereCone c;
    c.sin2_max = radius * radius / dist2;
    c.sin_max = std::sqrt(c.sin2_max);
    c.cos_max = safe_sqrt(1.f - c.sin2_max);
    c.one_minus_cos_max = c.sin2_max < kSmallSin2ThetaMax ? c.sin2_max / 2.f : 1.f - c.cos_max;
    return c;
}

}  // namespace

SphereLight::SphereLight(Vec3f center, float radius, Rgb radiance, bool reverse_orientation,
                         bool twosided)
    : c_(center),
      radius_(std::abs(radius)),
      L_(radiance),
      reverse_(reverse_orientation),
      twosided_(twosided) {}

Vec3f SphereLight::emitting_normal(Vec3f p) const {
    Vec3f n = normalize(p - c_);
    return reverse_ ? -n : n;
}

std::optional<LightLiSample> SphereLight::sample_li(const LightSampleContext &ctx, Vec2f u) const {
    if (!(radius_ > 0.f))
        return std::nullopt;
    float dc2 = length_squared(ctx.p - c_);
    Vec3f p, n_out;
    float pdf;
    if (dc2 <= radius_ * radius_) {
        // Inside: uniform by area, converted to solid angle.
        n_out = sampling::square_to_uniform_sphere(u);
        p = c_ + n_out * radius_;
        pdf = area_to_solid_angle_pdf(1.f / area(), ctx.p, p, n_out);
        if (pdf == 0.f)
            return std::nullopt;
    } else {
        // Outside: uniform in the cone of directions subtended by the sphere (section 6.2.4),
        // then the point where that direction first meets the sphere, found through the angle
        // alpha at the centre instead of a ray intersection.
        SphereCone cone = sphere_cone(radius_, dc2);
        float cos_t = (cone.cos_max - 1.f) * u.x + 1.f;
        float sin2_t = 1.f - cos_t * cos_t;
        if (cone.sin2_max < kSmallSin2ThetaMax) {
            sin2_t = cone.sin2_max * u.x;
            cos_t = std::sqrt(1.f - sin2_t);
        }
        float cos_alpha = sin2_t / cone.sin_max + cos_t * safe_sqrt(1.f - sin2_t / cone.sin2_max);
        float sin_alpha = safe_sqrt(1.f - cos_alpha * cos_alpha);
        float phi = u.y * 2.f * kPi;
        Vec3f w = spherical_direction(sin_alpha, cos_alpha, phi);
        Frame frame = Frame::from_z(normalize(c_ - ctx.p));
        n_out = frame.to_world(-w);
        p = c_ + n_out * radius_;
        pdf = 1.f / (2.f * kPi * cone.one_minus_cos_max);
    }
    float d2;
    std::optional<LightLiSample> s = sample_toward(ctx, p, &d2);
    if (!s)
        return s;
    s->pdf = pdf;
    s->L = L(p, n_out, {}, -s->wi);
    if (s->L.is_black())
        return std::nullopt;
    s->n_light = face_forward(emitting_normal(p), -s->wi);
    return s;
}

float SphereLight::pdf_li(const LightSampleContext &ctx, Vec3f, Vec3f p_light, Vec3f) const {
    if (!(radius_ > 0.f))
        return 0.f;
    float dc2 = length_squared(ctx.p - c_);
    if (dc2 <= radius_ * radius_)
        return area_to_solid_angle_pdf(1.f / area(), ctx.p, p_light, normalize(p_light - c_));
    // As pbrt-v4: the caller only asks for directions that hit the sphere, whose density is the
    // cone's constant one.
    return 1.f / (2.f * kPi * sphere_cone(radius_, dc2).one_minus_cos_max);
}

Rgb SphereLight::L(Vec3f p_light, Vec3f, Vec2f, Vec3f w_out) const {
    if (!twosided_ && dot(emitting_normal(p_light), w_out) <= 0.f)
        return Rgb(0.f);
    return L_;
}

Rgb SphereLight::phi() const {
    return L_ * (kPi * area() * (twosided_ ? 2.f : 1.f));
}

std::string SphereLight::describe() const {
    return "SphereLight c=" + vec_str(c_) + " r=" + std::to_string(radius_) + " L=" + rgb_str(L_) +
           (reverse_ ? " reversed" : "") + (twosided_ ? " twosided" : "");
}

// ---------------------------------------------------------------------------------------------
// DiskLight

DiskLight::DiskLight(Vec3f center, Vec3f n, float radius, Rgb radiance, bool twosided)
    : c_(center),
      frame_(Frame::from_z(normalize(n))),
      radius_(std::abs(radius)),
      L_(radiance),
      twosided_(twosided) {}

std::optional<LightLiSample> DiskLight::sample_li(const LightSampleContext &ctx, Vec2f u) const {
    if (!(radius_ > 0.f))
        return std::nullopt;
    Vec2f d = sampling::square_to_disk_concentric(u);
    Vec3f p = c_ + frame_.x * (d.x * radius_) + frame_.y * (d.y * radius_);
    Vec3f to = p - ctx.p;
    float d2 = length_squared(to);
    if (d2 == 0.f)
        return std::nullopt;
    LightLiSample s;
    s.wi = to / std::sqrt(d2);
    s.pdf = area_to_solid_angle_pdf(1.f / area(), ctx.p, p, frame_.z);
    if (s.pdf == 0.f)
        return std::nullopt;
    s.L = L(p, frame_.z, {}, -s.wi);
    if (s.L.is_black())
        return std::nullopt;
    s.p_light = p;
    s.n_light = face_forward(frame_.z, -s.wi);
    return s;
}

float DiskLight::pdf_li(const LightSampleContext &ctx, Vec3f, Vec3f p_light, Vec3f) const {
    if (!(radius_ > 0.f))
        return 0.f;
    return area_to_solid_angle_pdf(1.f / area(), ctx.p, p_light, frame_.z);
}

Rgb DiskLight::L(Vec3f, Vec3f, Vec2f, Vec3f w_out) const {
    if (!twosided_ && dot(frame_.z, w_out) <= 0.f)
        return Rgb(0.f);
    return L_;
}

Rgb DiskLight::phi() const {
    return L_ * (kPi * area() * (twosided_ ? 2.f : 1.f));
}

std::string DiskLight::describe() const {
    return "DiskLight c=" + vec_str(c_) + " n=" + vec_str(frame_.z) +
           " r=" + std::to_string(radius_) + " L=" + rgb_str(L_) + (twosided_ ? " twosided" : "");
}

// ---------------------------------------------------------------------------------------------
// QuadricAreaLight

QuadricAreaLight::QuadricAreaLight(const Shape &shape, const Transform &render_from_object,
                                   Rgb radiance, bool twosided)
    : shape_(shape), xf_(render_from_object), L_(radiance), twosided_(twosided) {
    const float s = length(xf_.vector({1, 0, 0}));  // uniform scale (checked by the caller)
    float a = 0;
    switch (shape_.kind) {
        case Kind::Sphere:
        case Kind::Cylinder:  // both r dphi dz (Archimedes for the sphere)
            a = shape_.phi_max * shape_.radius * (shape_.zmax - shape_.zmin);
            break;
        case Kind::Disk:
            a = 0.5f * shape_.phi_max *
                (shape_.radius * shape_.radius - shape_.inner_radius * shape_.inner_radius);
            break;
    }
    area_ = std::max(0.f, a) * s * s;
}

void QuadricAreaLight::sample_point(Vec2f u, Vec3f *p, Vec3f *n) const {
    const float phi = u.y * shape_.phi_max;
    const float c = std::cos(phi), sn = std::sin(phi);
    Vec3f po, no;
    switch (shape_.kind) {
        case Kind::Sphere: {
            const float z = shape_.zmin + u.x * (shape_.zmax - shape_.zmin);
            const float rxy = safe_sqrt(shape_.radius * shape_.radius - z * z);
            po = {rxy * c, rxy * sn, z};
            no = po / shape_.radius;
            break;
        }
        case Kind::Cylinder:
            po = {shape_.radius * c, shape_.radius * sn,
                  shape_.zmin + u.x * (shape_.zmax - shape_.zmin)};
            no = {c, sn, 0};
            break;
        case Kind::Disk: {
            const float ri2 = shape_.inner_radius * shape_.inner_radius;
            const float r = std::sqrt(ri2 + u.x * (shape_.radius * shape_.radius - ri2));
            po = {r * c, r * sn, shape_.height};
            no = {0, 0, 1};
            break;
        }
    }
    if (shape_.flip_normal) no = -no;
    *p = xf_.point(po);
    *n = normalize(xf_.normal(no));
}

Vec3f QuadricAreaLight::emitting_normal(Vec3f p_world) const {
    Vec3f po = xf_.inverse_point(p_world);
    Vec3f no = shape_.kind == Kind::Sphere     ? po
               : shape_.kind == Kind::Cylinder ? Vec3f(po.x, po.y, 0.f)
                                               : Vec3f(0, 0, 1);
    if (shape_.flip_normal) no = -no;
    return normalize(xf_.normal(no));
}

std::optional<LightLiSample> QuadricAreaLight::sample_li(const LightSampleContext &ctx,
                                                         Vec2f u) const {
    if (!(area_ > 0.f))
        return std::nullopt;
    Vec3f p, n;
    sample_point(u, &p, &n);
    float d2;
    std::optional<LightLiSample> s = sample_toward(ctx, p, &d2);
    if (!s)
        return std::nullopt;
    const float cos_l = absdot(n, s->wi);
    if (cos_l == 0.f)
        return std::nullopt;
    s->pdf = d2 / (area_ * cos_l);
    if (!std::isfinite(s->pdf))
        return std::nullopt;
    if (!twosided_ && dot(n, s->wi) >= 0.f)
        return std::nullopt;
    s->L = L_;
    if (s->L.is_black())
        return std::nullopt;
    s->n_light = face_forward(n, -s->wi);
    return s;
}

float QuadricAreaLight::pdf_li(const LightSampleContext &ctx, Vec3f, Vec3f p_light,
                               Vec3f) const {
    if (!(area_ > 0.f))
        return 0.f;
    return area_to_solid_angle_pdf(1.f / area_, ctx.p, p_light, emitting_normal(p_light));
}

Rgb QuadricAreaLight::L(Vec3f p_light, Vec3f, Vec2f, Vec3f w_out) const {
    if (!twosided_ && dot(emitting_normal(p_light), w_out) <= 0.f)
        return Rgb(0.f);
    return L_;
}

Rgb QuadricAreaLight::phi() const {
    return L_ * (kPi * area_ * (twosided_ ? 2.f : 1.f));
}

std::string QuadricAreaLight::describe() const {
    const char *names[] = {"sphere", "cylinder", "disk"};
    return std::string("QuadricAreaLight ") + names[int(shape_.kind)] +
           " area=" + std::to_string(area_) + " L=" + rgb_str(L_) +
           (twosided_ ? " twosided" : "");
}

// ---------------------------------------------------------------------------------------------
// Image reading

std::vector<Rgb> read_rgb_image(const std::string &path, const FileLoc &loc, int *width,
                                int *height) {
    // Empty images, and sizes from a header that cannot be allocated, are rejected here.
    OpenedImage img = open_image(path, loc, "image");
    const imageio::ImageSpec &spec = img.spec;
    const int w = spec.width, h = spec.height, nc = spec.nchannels;
    const std::vector<float> buf = img.read_floats(0, nc);

    // Channel order by name where the file names them (EXR), else the first three.
    int ch[3] = {0, nc > 1 ? 1 : 0, nc > 2 ? 2 : 0};
    if (nc == 2)
        ch[1] = ch[2] = 0;  // grey + alpha
    const char *names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < nc && i < int(spec.channelnames.size()); ++i)
            if (spec.channelnames[size_t(i)] == names[c])
                ch[c] = i;

    // Integer formats hold display-encoded values unless the file says linear.
    std::string cs = spec.get_string_attribute("oiio:ColorSpace");
    bool encoded = (spec.format == imageio::PixelType::UInt8 ||
                    spec.format == imageio::PixelType::UInt16) &&
                   cs != "Linear" && cs != "linear" && cs != "scene_linear";

    std::vector<Rgb> out(size_t(w) * size_t(h));
    for (size_t i = 0; i < out.size(); ++i) {
        const float *px = &buf[i * size_t(nc)];
        Rgb c(px[ch[0]], px[ch[1]], px[ch[2]]);
        if (!c.is_finite())
            throw SceneError(
                loc, "image \"" + path + "\" has infinite or NaN pixels and cannot be a light");
        if (encoded)
            c = Rgb(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b));
        out[i] = c;
    }
    *width = w;
    *height = h;
    return out;
}

// ---------------------------------------------------------------------------------------------
// Factories

namespace {

/// The weights pbrt-v4 gives an environment image's R, G and B values when it computes the
/// map's illuminance. pbrt-v4 (lights.cpp, Light::Create) sums values[c] * lum[c], c = 0..2,
/// over the image's channels *as stored*, lum being the luminance coefficients of R, G, B.
/// OpenEXR stores channels sorted by name (B, G, R), so for an EXR file pbrt-v4 weighs blue
/// by red's coefficient and red by blue's; other formats store R, G, B in that order. Tessera
/// uses the same weights, so that "illuminance" gives the brightness it gives in pbrt-v4.
Rgb pbrt_illuminance_weights(const std::string &path, const FileLoc &loc) {
    const Rgb lum(0.2126f, 0.7152f, 0.0722f);
    // The caller has read the image already: only its header is needed here.
    OpenedImage img = open_image(path, loc, "image", ImageRead::Streamed);
    if (img.spec.format_name != "openexr") return lum;
    std::vector<std::string> names = img.spec.channelnames;
    std::sort(names.begin(), names.end());
    Rgb w(0.f);
    const float coef[3] = {lum.r, lum.g, lum.b};
    for (size_t c = 0; c < 3 && c < names.size(); ++c) {
        if (names[c] == "R") w.r = coef[c];
        else if (names[c] == "G") w.g = coef[c];
        else if (names[c] == "B") w.b = coef[c];
        else {
            warn(loc, "\"" + path + "\": pbrt-v4 computes \"illuminance\" from the first three "
                      "channels stored, here not R, G and B; Tessera uses the luminance instead");
            return lum;
        }
    }
    return w;
}

std::unique_ptr<Light> make_infinite(const LightDesc &desc) {
    const ParamSet &ps = desc.params;
    std::optional<Rgb> L = ps.get_rgb("L", true);
    float scale = ps.get_float("scale", 1.f);
    std::string filename = ps.get_string("filename", "");
    float E_v = ps.get_float("illuminance", -1.f);
    if (ps.find("portal")) {
        ps.get_point3s("portal");
        warn(desc.loc,
             "infinite light \"portal\" is not supported; the whole environment is "
             "sampled instead (same image, more noise indoors)");
    }
    if (L && !filename.empty())
        throw SceneError(desc.loc,
                         "can't specify both emission \"L\" and \"filename\" with an "
                         "\"infinite\" light");
    if (filename.empty()) {
        // Constant environment; pbrt-v4 normalises "illuminance" with the cosine-weighted
        // hemisphere integral of a unit radiance, pi.
        if (E_v > 0.f)
            scale *= E_v / kPi;
        return std::make_unique<UniformInfiniteLight>(L.value_or(Rgb(1.f)) * scale);
    }

    std::string path = resolve_path(desc.base_dir, filename);
    int w = 0, h = 0;
    std::vector<Rgb> pixels = read_rgb_image(path, desc.loc, &w, &h);
    ImageInfiniteLight::Mapping mapping;
    if (w == h) {
        mapping = ImageInfiniteLight::Mapping::EqualArea;
    } else if (w == 2 * h) {
        mapping = ImageInfiniteLight::Mapping::Equirect;
        warn(desc.loc, "\"" + filename +
                           "\" is a 2:1 image: read as a latitude-longitude map "
                           "(pbrt-v4 expects square equal-area octahedral maps)");
    } else {
        throw SceneError(desc.loc, "\"" + filename + "\": image resolution (" + std::to_string(w) +
                                       ", " + std::to_string(h) +
                                       ") is neither square (equal-area) nor 2:1 (lat-long)");
    }
    if (E_v > 0.f) {
        // Illuminance of the map on an upward (+z in light space) patch, by pixel centres.
        const Rgb lum = pbrt_illuminance_weights(path, desc.loc);
        double e = 0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                Vec2f uv{(x + 0.5f) / float(w), (y + 0.5f) / float(h)};
                Vec3f dir = ImageInfiniteLight::direction_from_uv(mapping, uv);
                if (dir.z <= 0.f)
                    continue;
                double d_omega =
                    mapping == ImageInfiniteLight::Mapping::EqualArea
                        ? 4.0 * kPi / (double(w) * h)
                        : 2.0 * kPi * kPi / (double(w) * h) * std::sin(kPi * (y + 0.5f) / h);
                const Rgb &p = pixels[size_t(y) * size_t(w) + size_t(x)];
                e += double(lum.r * p.r + lum.g * p.g + lum.b * p.b) * dir.z * d_omega;
            }
        // NOTE: pbrt-v4 (lights.cpp, Light::Create) weights each pixel by 2 pi / (w h) instead
        // of the 4 pi / (w h) an equal-area pixel covers, i.e. it computes half the map's
        // illuminance; we keep its factor so scenes render as they do in pbrt-v4.
        double k_e = 0.5 * e;
        if (k_e > 0)
            scale *= float(double(E_v) / k_e);
    }
    return std::make_unique<ImageInfiniteLight>(desc.render_from_light, std::move(pixels), w, h,
                                                mapping, scale);
}

/// pbrt-v4 GoniometricLight::Create: "I" (the illuminant), "scale", "power" (normalised by
/// 4 pi times the image's mean), "filename" (square; RGB averaged, or one channel).
std::unique_ptr<Light> make_goniometric(const LightDesc &desc) {
    const ParamSet &ps = desc.params;
    Rgb I = ps.get_rgb("I", true).value_or(Rgb(1.f));
    float scale = ps.get_float("scale", 1.f);
    float power = ps.get_float("power", -1.f);
    const std::string filename = ps.get_string("filename", "");
    std::vector<float> image;
    int res = 0;
    if (filename.empty()) {
        // pbrt-v4 warns and builds a light with an empty image, which emits nothing.
        warn(desc.loc, "goniometric light: no \"filename\"; the light emits nothing");
        return nullptr;
    }
    int w = 0, h = 0;
    std::vector<Rgb> px = read_rgb_image(resolve_path(desc.base_dir, filename), desc.loc, &w, &h);
    if (w != h)
        throw SceneError(desc.loc, "goniometric light: \"" + filename + "\" is " +
                                       std::to_string(w) + "x" + std::to_string(h) +
                                       "; it must be square (an equal-area map of directions)");
    res = w;
    image.resize(px.size());
    double sum = 0;
    for (size_t i = 0; i < px.size(); ++i) {
        image[i] = px[i].average();
        sum += image[i];
    }
    if (power > 0.f) {
        const double k_e = 4.0 * kPi * sum / double(image.size());
        if (k_e > 0) scale *= float(double(power) / k_e);
    }
    // pbrt-v4 composes renderFromLight with a y/z swap; GoniometricLight::intensity applies
    // the swap itself, so the transform stays the scene's.
    std::unique_ptr<Light> light = std::make_unique<GoniometricLight>(
        desc.render_from_light, I * scale, std::move(image), res);
    return light;
}

/// pbrt-v4 ProjectionLight::Create: "scale", "power" (normalised by the image's luminance
/// over the frustum), "fov" (90), "filename" (required; RGB).
std::unique_ptr<Light> make_projection(const LightDesc &desc) {
    const ParamSet &ps = desc.params;
    float scale = ps.get_float("scale", 1.f);
    float power = ps.get_float("power", -1.f);
    float fov = ps.get_float("fov", 90.f);
    const std::string filename = ps.get_string("filename", "");
    if (filename.empty())
        throw SceneError(desc.loc, "projection light: needs a \"filename\" (the image it "
                                   "projects)");
    if (!(fov > 0.f && fov < 180.f))
        throw SceneError(desc.loc, "projection light: \"fov\" must be between 0 and 180 "
                                   "degrees");
    int w = 0, h = 0;
    std::vector<Rgb> px = read_rgb_image(resolve_path(desc.base_dir, filename), desc.loc, &w, &h);
    auto light = std::make_unique<ProjectionLight>(desc.render_from_light, px, w, h, fov, scale);
    if (power > 0.f) {
        const float k = light->unit_power();
        if (k > 0.f)
            light = std::make_unique<ProjectionLight>(desc.render_from_light, std::move(px), w, h,
                                                      fov, scale * power / k);
    }
    return light;
}

}  // namespace

std::unique_ptr<Light> make_light(const LightDesc &desc) {
    const ParamSet &ps = desc.params;
    const Transform &R = desc.render_from_light;
    std::unique_ptr<Light> light;
    if (desc.type == "point") {
        Rgb I = ps.get_rgb("I", true).value_or(Rgb(1.f));
        float scale = ps.get_float("scale", 1.f);
        float power = ps.get_float("power", -1.f);
        // pbrt-v4 normalises the spectrum's photometric value, not the RGB: the colour stays.
        if (power > 0.f)
            scale *= power / (4.f * kPi);
        Vec3f from = ps.get_point3("from", {0, 0, 0});
        light = std::make_unique<PointLight>(R.point(from), I * scale);
    } else if (desc.type == "spot") {
        Rgb I = ps.get_rgb("I", true).value_or(Rgb(1.f));
        float scale = ps.get_float("scale", 1.f);
        float power = ps.get_float("power", -1.f);
        float cone_angle = ps.get_float("coneangle", 30.f);
        float cone_delta = ps.get_float("conedeltaangle", 5.f);
        Vec3f from = ps.get_point3("from", {0, 0, 0});
        Vec3f to = ps.get_point3("to", {0, 0, 1});
        Vec3f dir = to - from;
        if (!(length_squared(dir) > 0.f))
            throw SceneError(desc.loc, "spot light: \"from\" and \"to\" must differ");
        float cos_end = std::cos(radians(cone_angle));
        float cos_start = std::cos(radians(cone_angle - cone_delta));
        if (power > 0.f)
            scale *= power / (2.f * kPi * ((1.f - cos_start) + (cos_start - cos_end) / 2.f));
        Transform light_to_render =
            R * Transform::translate(from) * transform_from_frame(Frame::from_z(normalize(dir)));
        light = std::make_unique<SpotLight>(light_to_render, I * scale, cos_start, cos_end);
    } else if (desc.type == "distant") {
        Rgb L = ps.get_rgb("L", true).value_or(Rgb(1.f));
        float scale = ps.get_float("scale", 1.f);
        Vec3f from = ps.get_point3("from", {0, 0, 0});
        Vec3f to = ps.get_point3("to", {0, 0, 1});
        // For a distant light, illuminance on a perpendicular patch equals its radiance.
        float E_v = ps.get_float("illuminance", -1.f);
        if (E_v > 0.f)
            scale *= E_v;
        Vec3f w = R.vector(from - to);
        if (!(length_squared(w) > 0.f))
            throw SceneError(desc.loc, "distant light: \"from\" and \"to\" must differ");
        light = std::make_unique<DistantLight>(normalize(w), L * scale);
    } else if (desc.type == "infinite") {
        light = make_infinite(desc);
    } else if (desc.type == "goniometric") {
        light = make_goniometric(desc);
    } else if (desc.type == "projection") {
        light = make_projection(desc);
    } else {
        throw SceneError(desc.loc, "unknown light type \"" + desc.type + "\"");
    }
    ps.report_unused("light \"" + desc.type + "\"");
    return light;
}

AreaEmission make_area_emission(const ParamSet &params, const FileLoc &loc, float shape_area) {
    AreaEmission e;
    e.L = params.get_rgb("L", true).value_or(Rgb(1.f));
    float scale = params.get_float("scale", 1.f);
    e.twosided = params.get_bool("twosided", false);
    std::string filename = params.get_string("filename", "");
    if (!filename.empty())
        warn(loc,
             "AreaLightSource \"diffuse\": image-textured emission \"filename\" is not "
             "supported; using \"L\"");
    float power = params.get_float("power", -1.f);
    if (power > 0.f && shape_area > 0.f)
        scale *= power / (kPi * shape_area * (e.twosided ? 2.f : 1.f));
    e.L *= scale;
    params.report_unused("AreaLightSource \"diffuse\"");
    return e;
}

}  // namespace tessera
