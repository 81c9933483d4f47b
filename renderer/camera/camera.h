// The perspective camera and the pixel reconstruction filter of pbrt-v4, with filter importance
// sampling: each camera sample lands in exactly one pixel, with weight 1 for the positive
// filters and +-w for those with negative lobes (mitchell, sinc).
//
// Conventions (PBRT-NOTES.md): camera space looks down +z, +y up, +x toward the right of the
// image; raster (0,0) is the top-left corner; `fov` spans the shorter image axis.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "renderer/util/interaction.h"
#include "renderer/util/transform.h"

namespace tessera {

class LensSystem;

/// Pixel filter, sampled by importance: `sample(u)` returns an offset from the pixel centre in
/// pixels, distributed proportionally to |f| (pbrt-v4's box, triangle, gaussian, mitchell and
/// sinc filters; all separable, f(x, y) = f_x(x) f_y(y)).
///
/// Filters with negative lobes (Mitchell-Netravali, Lanczos windowed sinc) are sampled from
/// the tabulated |f_x| and |f_y| and give each sample the weight
/// sign(f(x, y)) (int |f_x| int |f_y|) / (int f_x int f_y), so that the plain mean of weighted
/// samples estimates the filtered image int f L / int f, as pbrt-v4's weighted sum
/// sum w L / sum w does (pbrt-v4 FilterSampler; PBRT 4th ed., section 8.8.3).
class PixelFilter {
  public:
    enum class Kind { Box, Triangle, Gaussian, Mitchell, Lanczos };
    PixelFilter() = default;
    /// Box, triangle or gaussian (`sigma`, pbrt-v4's default 0.5).
    PixelFilter(Kind kind, Vec2f radius, float sigma = 0.5f);
    /// pbrt-v4 "mitchell": Mitchell & Netravali 1988 with parameters B and C (default 1/3
    /// each), f(x) = Mitchell1D(2 x / radius).
    static PixelFilter mitchell(Vec2f radius, float b, float c);
    /// pbrt-v4 "sinc": sinc(x) sinc(x / tau) on |x| <= radius (Lanczos; default tau 3).
    static PixelFilter lanczos(Vec2f radius, float tau);
    /// Offset in pixels from the pixel centre, density proportional to |f|; `weight` (when
    /// given) receives the sample's weight (1 for the positive filters).
    Vec2f sample(Vec2f u, float *weight = nullptr) const;
    /// Filter value f(x, y) (tests).
    float evaluate(Vec2f p) const;
    Kind kind() const { return kind_; }
    Vec2f radius() const { return radius_; }
    /// True for the filters whose samples carry weights other than 1 (negative lobes).
    bool has_negative_lobes() const { return !sign_[0].empty(); }
    std::string describe() const;

    /// Gaussian: entries of the tabulated CDF per axis (kTableSize + 1 values) and of its guide
    /// table, for code that inverts the CDF several samples at a time (renderer/integrators/path_packet.cpp);
    /// empty for the other kinds.
    static constexpr int kTableSize = 256, kGuideSize = 1024;
    std::span<const float> cdf(int axis) const { return cdf_[axis]; }
    std::span<const int32_t> guide(int axis) const { return guide_[axis]; }

  private:
    float sample_1d(float u, int axis, int *cell = nullptr) const;
    /// The 1D factor of the filter along `axis` at offset x (pixels).
    float evaluate_1d(float x, int axis) const;
    /// Tabulates |f_1d| per axis into cdf_ and guide_ (and the signs for signed filters).
    void tabulate();
    Kind kind_ = Kind::Box;
    Vec2f radius_{0.5f, 0.5f};
    float sigma_ = 0.5f;       ///< gaussian sigma
    float b_ = 1.f / 3, c_ = 1.f / 3;  ///< mitchell B and C
    float tau_ = 3.f;          ///< lanczos tau
    float weight_ = 1.f;       ///< int |f| / int f over both axes (signed filters)
    // Gaussian, mitchell, lanczos: tabulated 1D CDF of |f| per axis (the filter is separable).
    std::vector<float> cdf_[2];
    // Signed filters: the sign of f in each table cell, per axis (empty otherwise).
    std::vector<int8_t> sign_[2];
    // Guide table per axis: guide_[a][k] is the largest i with cdf_[a][i] <= k / kGuideSize, so
    // the CDF inversion starts next to its answer instead of binary-searching 257 entries
    // (a dozen mispredicted branches per axis and sample).
    std::vector<int32_t> guide_[2];
};

/// Camera ray with the differentials of its origin and direction for one pixel step in x and y.
struct CameraRay {
    Ray ray;
    Vec3f rx_o, rx_d, ry_o, ry_d;
    bool has_differentials = false;
    /// Factor on the radiance the ray brings back: 1, except through a lens system (pbrt-v4
    /// CameraRay::weight); 0 when the lens blocks the sample (then `ray` is meaningless and
    /// the sample adds zero radiance).
    float weight = 1.f;
};

/// pbrt-v4 "spherical" camera mappings of the film onto the sphere of directions.
enum class SphericalMapping { None, EqualArea, Equirectangular };

/// pbrt-v4 "perspective" camera: fov, lensradius, focaldistance, screenwindow, frameaspectratio;
/// also its "orthographic" camera, and its "spherical" camera (every direction from the camera
/// position: raster (x, y) / film size through the equal-area or equirectangular map, camera
/// +y toward the top of the map).
class PerspectiveCamera {
  public:
    /// `camera_from_world` is the CTM at the Camera directive; width/height is the film.
    PerspectiveCamera(const Transform &camera_from_world, int width, int height, float fov_deg,
                      float lens_radius, float focal_distance,
                      const float *screen_window = nullptr, bool orthographic = false,
                      SphericalMapping spherical = SphericalMapping::None);
    /// Ray through raster position (x, y) in pixels; `u_lens` in [0,1)^2 for depth of field
    /// (ignored when lens_radius() is 0). With `differentials` false the ray differentials are
    /// left unset (has_differentials false): scenes without textures never read them.
    /// Thread-safe.
    CameraRay generate_ray(Vec2f p_raster, Vec2f u_lens, bool differentials = true) const;
    /// Lens radius in scene units; 0 for a pinhole (then generate_ray ignores u_lens).
    float lens_radius() const { return lens_radius_; }
    /// Makes this a pbrt-v4 "realistic" camera: rays start on the film and pass `lens`
    /// (renderer/camera/lens_system.h), at the camera's placement; the projection parameters are
    /// unused from then on.
    void set_lens_system(std::shared_ptr<const LensSystem> lens);
    const LensSystem *lens_system() const { return lens_.get(); }
    /// Whether generate_ray reads u_lens (a thin lens or a lens system).
    bool uses_lens_sample() const { return lens_radius_ > 0 || lens_; }
    /// The camera's origin in world space (cached per placement: shading and the real-time
    /// modes' view depth read it per point).
    Vec3f position() const { return position_; }
    /// The camera's placement (world from camera space).
    const Transform &world_from_camera() const { return world_from_camera_; }
    /// Moves the camera: a new world-from-camera transform, the projection unchanged (the
    /// real-time loop's --orbit). Not thread-safe against concurrent generate_ray.
    void set_world_from_camera(const Transform &world_from_camera);
    /// Camera-space direction toward +z transformed to world, normalised (cached per placement).
    Vec3f forward() const { return forward_; }
    bool orthographic() const { return orthographic_; }
    SphericalMapping spherical() const { return spherical_; }
    /// What generate_ray computes for a plain pinhole (no lens radius, not orthographic or
    /// spherical, no lens system): the ray starts at the camera position, rows 0-2, column 3 of
    /// `world_from_camera`, and points along normalize(M (p0 + x dx + y dy)) for raster point
    /// (x, y), M the 3x3 part of those rows. For code that generates several rays at a time
    /// with the same operations (renderer/integrators/path_packet.cpp). std::nullopt for other cameras.
    struct Pinhole {
        Vec3f p0, dx, dy;
        float world_from_camera[3][4];
    };
    std::optional<Pinhole> pinhole() const;
    /// Approximate position differentials at point p with normal n, for texture filtering
    /// (pbrt-v4 CameraBase::Approximate_dp_dxy), used after the first bounce.
    void approximate_dp_dxy(Vec3f p, Vec3f n, int spp, Vec3f *dpdx, Vec3f *dpdy) const;

  private:
    /// world_from_camera_ as float rows (x, y, z); column 3 is the camera position. Ray
    /// generation is per sample, so it avoids the double-precision projective path of Transform.
    Vec3f camera_point_world(Vec3f p) const;
    Vec3f camera_vector_world(Vec3f v) const;

    Transform world_from_camera_;
    Transform camera_from_raster_;
    // Raster (0, 0) and one raster step in x and y, in camera space on the near plane. Raster
    // points at depth 0 map to the near plane affinely, so p_camera = p0 + x dx + y dy.
    Vec3f p0_camera_, dx_camera_, dy_camera_;
    float world_from_camera_f_[3][4];
    Vec3f position_, forward_;  ///< see position(), forward()
    float lens_radius_, focal_distance_;
    bool orthographic_ = false;  ///< pbrt-v4 "orthographic": parallel rays along camera +z
    SphericalMapping spherical_ = SphericalMapping::None;  ///< pbrt-v4 "spherical"
    std::shared_ptr<const LensSystem> lens_;                ///< pbrt-v4 "realistic"
    /// Realistic camera: the ray through the lens system, in world space, with finite
    /// differences for the differentials (pbrt-v4 CameraBase::GenerateRayDifferential).
    CameraRay lens_ray(Vec2f p_raster, Vec2f u_lens, bool differentials) const;
    float width_ = 1, height_ = 1;                          ///< film size in pixels
    /// Spherical camera: the camera-space direction of raster point p (pbrt-v4
    /// SphericalCamera::GenerateRay).
    Vec3f spherical_direction(Vec2f p_raster) const;
    Vec3f min_pos_dx_, min_pos_dy_, min_dir_dx_, min_dir_dy_;
};

}  // namespace tessera
