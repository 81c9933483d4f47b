// pbrt-v4's "realistic" camera: a lens system of spherical glass interfaces and an aperture
// stop between the film and the scene (Kolb, Mitchell and Hanrahan 1995; pbrt-v4 section 5.3,
// RealisticCamera).
//
// Lens files list the interfaces from the scene side to the film side, four numbers each, in
// millimetres: curvature radius (0 marks the aperture stop), thickness (distance to the next
// interface), index of refraction of the medium behind the interface (toward the film; 0 or 1
// for air) and aperture diameter. '#' starts a comment. The last interface's thickness is
// replaced by the lens-to-film distance that focuses the system at "focusdistance" (thick-lens
// approximation).
//
// Camera space as in pbrt: the film is the plane z = 0 and the lens lies toward +z; a generated
// ray leaves the front element. Each ray's weight is pbrt's cos^4(theta) / (pdf * rear_z^2):
// the image brightness follows the aperture and the film size, as with a real camera.
#pragma once

#include <string>
#include <vector>

#include "sampling/vecmath.h"

namespace tessera {

/// A point or vector of the lens system's ray tracing (double precision: interfaces are
/// millimetres apart and the exit-pupil search traces millions of rays).
struct LensVec {
    double x = 0, y = 0, z = 0;
};

/// One interface of the lens system (pbrt-v4 LensElementInterface), in metres.
struct LensElement {
    double curvature_radius = 0;  ///< signed; 0 for the aperture stop
    double thickness = 0;         ///< to the next interface toward the film
    double eta = 1;               ///< medium behind the interface (0 = air)
    double aperture_radius = 0;
};

/// Reads a pbrt lens description file: numbers separated by white space, '#' comments, four
/// per element. Throws SceneError ("file:line: ...") for a missing or oversized file, a token
/// that is not a finite number, no values, or a count that is not a multiple of four.
std::vector<float> read_lens_file(const std::string &path);

/// The stop's transmission image (pbrt-v4 "aperture"): bilinear, zero outside [0,1]^2,
/// normalised to a mean of pi/4 so that it passes as much light as the round stop.
class ApertureImage {
  public:
    ApertureImage() = default;
    /// pbrt-v4's built-in shapes: "gaussian", "square", "pentagon", "star" (256x256). Returns
    /// an empty image for another name.
    static ApertureImage builtin(const std::string &name);
    /// `values` row-major, row 0 at the top of the picture (flipped to pbrt's orientation).
    ApertureImage(int width, int height, std::vector<float> values);
    bool empty() const { return values_.empty(); }
    /// pbrt Image::BilerpChannel with WrapMode::Black.
    float bilerp(double u, double v) const;

  private:
    float texel(int x, int y) const;
    int width_ = 0, height_ = 0;
    std::vector<float> values_;
};

class LensSystem {
  public:
    /// `lens`: four values per element as read_lens_file() returns them. `aperture_diameter`
    /// in mm (clamped to the stop's own, with a warning in *warnings); `focus_distance` in
    /// metres; `film_diagonal` in metres; the film resolution in pixels. Throws
    /// std::runtime_error when the lens cannot be focused there or passes no light.
    /// `pupil_search_log2`: rays per film segment of the exit-pupil search, as a power of two
    /// (fewer: faster loading, looser bounds, more blocked samples; never bias).
    LensSystem(const std::vector<float> &lens, float aperture_diameter, float focus_distance,
               float film_diagonal, int width, int height, ApertureImage aperture = {},
               std::vector<std::string> *warnings = nullptr, int pupil_search_log2 = 18);

    /// Camera-space ray for raster position `p_raster` (pixels, (0,0) the top-left corner)
    /// through exit-pupil sample `u`: returns its weight, 0 when the lens system blocks it
    /// (then *o and *d are unset). *d is not normalised.
    float generate_ray(Vec2f p_raster, Vec2f u, Vec3f *o, Vec3f *d) const;

    /// Traces a camera-space ray from the film side through every interface (pbrt-v4
    /// TraceLensesFromFilm): its weight (1, or the aperture image's value), 0 if blocked.
    /// With `rotation_invariant`, an aperture image is replaced by the circle around it (the
    /// exit-pupil search; see bound_exit_pupil).
    float trace_from_film(const LensVec &o, const LensVec &d, LensVec *o_out, LensVec *d_out,
                          bool rotation_invariant = false) const;
    /// The reverse direction, from the scene side (no aperture image).
    bool trace_from_scene(const LensVec &o, const LensVec &d, LensVec *o_out, LensVec *d_out) const;

    const std::vector<LensElement> &elements() const { return elements_; }
    /// Lens-to-film distance (the last element's thickness after focusing), metres.
    double rear_z() const { return elements_.back().thickness; }
    /// Film to front element, metres.
    double front_z() const;
    double rear_radius() const { return elements_.back().aperture_radius; }
    /// Effective focal length of the thick-lens approximation, metres.
    double focal_length() const { return focal_length_; }
    /// Film extent in metres (x, y), centred on the optical axis.
    Vec2f film_extent() const { return {float(extent_x_), float(extent_y_)}; }
    /// Exit-pupil bounds (min x, min y, max x, max y) on the rear element's plane for film
    /// radius segment i of kPupilSegments; empty (min > max) where no light passes.
    struct Bounds {
        double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
        bool empty() const { return x0 >= x1 || y0 >= y1; }  // pbrt IsDegenerate
    };
    static constexpr int kPupilSegments = 64;
    const Bounds &pupil_bounds(int i) const { return pupil_[size_t(i)]; }

  private:
    /// Thick-lens cardinal points: pz[0], fz[0] on the film side, pz[1], fz[1] on the scene
    /// side (pbrt-v4 ComputeThickLensApproximation).
    void thick_lens(double pz[2], double fz[2]) const;
    Bounds bound_exit_pupil(double film_x0, double film_x1, uint32_t samples) const;

    std::vector<LensElement> elements_;
    ApertureImage aperture_;
    double film_diagonal_ = 0.035, extent_x_ = 0, extent_y_ = 0;
    double focal_length_ = 0;
    float width_ = 1, height_ = 1;
    std::vector<Bounds> pupil_;
};

}  // namespace tessera
