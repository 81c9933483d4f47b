#include "renderer/camera/lens_system.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "renderer/util/error.h"

namespace tessera {

namespace fs = std::filesystem;

namespace {

LensVec operator+(LensVec a, LensVec b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
LensVec operator-(LensVec a, LensVec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
LensVec operator*(LensVec a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double dot(LensVec a, LensVec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
LensVec normalize(LensVec a) { return a * (1.0 / std::sqrt(dot(a, a))); }
LensVec flip_z(LensVec a) { return {a.x, a.y, -a.z}; }

/// Roots t0 <= t1 of a t^2 + b t + c (the numerically stable form).
bool quadratic(double a, double b, double c, double *t0, double *t1) {
    if (a == 0) {
        if (b == 0) return false;
        *t0 = *t1 = -c / b;
        return true;
    }
    double discrim = b * b - 4 * a * c;
    if (discrim < 0) return false;
    double root = std::sqrt(discrim);
    double q = -0.5 * (b + std::copysign(root, b));
    *t0 = q / a;
    *t1 = q != 0 ? c / q : *t0;
    if (*t0 > *t1) std::swap(*t0, *t1);
    return true;
}

/// Ray (lens space) against a spherical interface of signed `radius` centred on the axis at
/// z_center (pbrt-v4 IntersectSphericalElement): the hit on the side the ray meets first for
/// this curvature, and the normal facing the ray's origin.
bool intersect_spherical_element(double radius, double z_center, LensVec o, LensVec d,
                                 double *t, LensVec *n) {
    LensVec oc = o - LensVec{0, 0, z_center};
    double a = dot(d, d), b = 2 * dot(d, oc), c = dot(oc, oc) - radius * radius;
    double t0, t1;
    if (!quadratic(a, b, c, &t0, &t1)) return false;
    bool closer = (d.z > 0) ^ (radius < 0);
    *t = closer ? std::min(t0, t1) : std::max(t0, t1);
    if (*t < 0) return false;
    LensVec nn = normalize(oc + d * *t);
    if (dot(nn, d * -1.0) < 0) nn = nn * -1.0;
    *n = nn;
    return true;
}

/// Snell refraction of wi (pointing away from the surface, unit) about n with relative index
/// eta = eta_t / eta_i (pbrt-v4 Refract); false on total internal reflection.
bool refract(LensVec wi, LensVec n, double eta, LensVec *wt) {
    double cos_i = dot(n, wi);
    if (cos_i < 0) {
        eta = 1 / eta;
        cos_i = -cos_i;
        n = n * -1.0;
    }
    double sin2_i = std::max(0.0, 1 - cos_i * cos_i);
    double sin2_t = sin2_i / (eta * eta);
    if (sin2_t >= 1) return false;
    double cos_t = std::sqrt(std::max(0.0, 1 - sin2_t));
    *wt = wi * (-1 / eta) + n * (cos_i / eta - cos_t);
    return true;
}

/// Radical inverse of i in base 3 (pbrt's RadicalInverse(1, i)).
double radical_inverse_3(uint32_t i) {
    double inv = 1.0 / 3, f = inv, r = 0;
    while (i) {
        r += double(i % 3) * f;
        i /= 3;
        f *= inv;
    }
    return r;
}

/// Radical inverse of i in base 2 (pbrt's RadicalInverse(0, i)).
double radical_inverse_2(uint32_t i) {
    double f = 0.5, r = 0;
    while (i) {
        if (i & 1u) r += f;
        i >>= 1;
        f *= 0.5;
    }
    return r;
}

double lerp(double t, double a, double b) { return (1 - t) * a + t * b; }

/// A number for messages ("%g").
std::string num(double v) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%g", v);
    return buf;
}

/// More interfaces than any photographic lens has (pbrt-v4-scenes' lenses have up to ~20);
/// the exit-pupil search traces every one 4 million times.
constexpr size_t kMaxLensElements = 64;

}  // namespace

std::vector<float> read_lens_file(const std::string &path) {
    std::error_code ec;
    fs::file_status st = fs::status(path, ec);
    if (!fs::is_regular_file(st))
        throw SceneError(path + ":0: cannot read the lens file: " +
                         (!fs::exists(st) ? "not found" : "not a regular file"));
    // Lens files are a few dozen numbers; anything this large is not one.
    constexpr uintmax_t kMaxLensFileBytes = uintmax_t(1) << 20;
    if (fs::file_size(path, ec) > kMaxLensFileBytes)
        throw SceneError(path + ":0: the lens file is larger than 1 MiB; not a lens description");
    std::ifstream in(path);
    if (!in) throw SceneError(path + ":0: cannot open the lens file");
    // pbrt-v4 ReadFloatFile: a number is a run of digits, '.', 'e', 'E', '+' and '-' that
    // starts with a digit, '.', '+' or '-'; '#' starts a comment; any other text is skipped
    // with a warning (so a header line without '#' still loads).
    std::vector<float> values;
    std::string line;
    int line_no = 0;
    auto starts_number = [](char c) {
        return std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '+' || c == '-';
    };
    auto in_number = [&](char c) { return starts_number(c) || c == 'e' || c == 'E'; };
    int warned_lines = 0;  // a binary file would warn on every line: the first three do
    while (std::getline(in, line)) {
        ++line_no;
        if (size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
        bool warned = warned_lines >= 3;
        for (size_t i = 0; i < line.size();) {
            const char c = line[i];
            if (std::isspace(static_cast<unsigned char>(c))) {
                ++i;
                continue;
            }
            if (!starts_number(c)) {
                if (!warned) {
                    warn(FileLoc{path, line_no}, "lens file: unexpected text \"" +
                                                     line.substr(i, 16) + "\" skipped");
                    ++warned_lines;
                }
                warned = true;
                ++i;
                continue;
            }
            size_t j = i;
            while (j < line.size() && in_number(line[j])) ++j;
            const std::string token = line.substr(i, j - i);
            char *end = nullptr;
            errno = 0;
            double v = std::strtod(token.c_str(), &end);
            if (end != token.c_str() + token.size() || errno == ERANGE || !std::isfinite(v) ||
                std::abs(v) > 1e30)
                throw SceneError(FileLoc{path, line_no},
                                 "lens file: \"" + token + "\" is not a finite number");
            values.push_back(float(v));
            i = j;
        }
    }
    if (values.empty())
        throw SceneError(FileLoc{path, line_no}, "lens file: no values (four per lens element: "
                                                 "curvature radius, thickness, index of "
                                                 "refraction, aperture diameter)");
    if (values.size() % 4 != 0)
        throw SceneError(FileLoc{path, line_no},
                         "lens file: " + std::to_string(values.size()) +
                             " values, not a multiple of four (curvature radius, thickness, "
                             "index of refraction, aperture diameter per element)");
    return values;
}

// ---------------------------------------------------------------------------------------------
// ApertureImage

ApertureImage::ApertureImage(int width, int height, std::vector<float> values)
    : width_(width), height_(height), values_(std::move(values)) {
    if (width_ <= 0 || height_ <= 0 || values_.size() != size_t(width_) * size_t(height_)) {
        *this = ApertureImage();
        return;
    }
    // pbrt-v4 flips the image vertically, then scales its mean to pi/4 (the round stop's
    // share of its bounding square).
    for (int y = 0; y < height_ / 2; ++y)
        std::swap_ranges(values_.begin() + size_t(y) * size_t(width_),
                         values_.begin() + size_t(y + 1) * size_t(width_),
                         values_.begin() + size_t(height_ - 1 - y) * size_t(width_));
    double sum = 0;
    for (float v : values_) sum += v;
    double avg = sum / double(values_.size());
    if (!(avg > 0)) {
        *this = ApertureImage();
        return;
    }
    const float scale = float((M_PI / 4) / avg);
    for (float &v : values_) v *= scale;
}

ApertureImage ApertureImage::builtin(const std::string &name) {
    constexpr int res = 256;
    std::vector<float> img(size_t(res) * res, 0.f);
    auto pixel_point = [](int x, int y) {
        return Vec2f{-1 + 2 * (float(x) + 0.5f) / res, -1 + 2 * (float(y) + 0.5f) / res};
    };
    // Non-zero winding number fill of a polygon (pbrt-v4's rasterisation of the shapes).
    auto rasterize = [&](const std::vector<Vec2f> &vert) {
        for (int y = 0; y < res; ++y)
            for (int x = 0; x < res; ++x) {
                Vec2f p = pixel_point(x, y);
                int winding = 0;
                for (size_t i = 0; i < vert.size(); ++i) {
                    size_t i1 = (i + 1) % vert.size();
                    float e = (p.x - vert[i].x) * (vert[i1].y - vert[i].y) -
                              (p.y - vert[i].y) * (vert[i1].x - vert[i].x);
                    if (vert[i].y <= p.y) {
                        if (vert[i1].y > p.y && e > 0) ++winding;
                    } else if (vert[i1].y <= p.y && e < 0) {
                        --winding;
                    }
                }
                img[size_t(y) * res + size_t(x)] = winding == 0 ? 0.f : 1.f;
            }
    };
    if (name == "gaussian") {
        for (int y = 0; y < res; ++y)
            for (int x = 0; x < res; ++x) {
                Vec2f p = pixel_point(x, y);
                float r2 = p.x * p.x + p.y * p.y;
                img[size_t(y) * res + size_t(x)] =
                    std::max(0.f, std::exp(-r2) - std::exp(-1.f));
            }
    } else if (name == "square") {
        for (int y = res / 4; y < 3 * res / 4; ++y)
            for (int x = res / 4; x < 3 * res / 4; ++x) img[size_t(y) * res + size_t(x)] = 4.f;
    } else if (name == "pentagon") {
        const float c1 = (std::sqrt(5.f) - 1) / 4, c2 = (std::sqrt(5.f) + 1) / 4;
        const float s1 = std::sqrt(10.f + 2.f * std::sqrt(5.f)) / 4;
        const float s2 = std::sqrt(10.f - 2.f * std::sqrt(5.f)) / 4;
        std::vector<Vec2f> vert = {{0, 1}, {s1, c1}, {s2, -c2}, {-s2, -c2}, {-s1, c1}};
        for (Vec2f &v : vert) v = v * 0.8f;
        rasterize(vert);
    } else if (name == "star") {
        std::vector<Vec2f> vert(10);
        for (int i = 0; i < 10; ++i) {
            float r = (i & 1) ? 1.f
                              : std::cos(72.f * float(M_PI) / 180) / std::cos(36.f * float(M_PI) / 180);
            vert[size_t(i)] = {r * std::cos(float(M_PI) * float(i) / 5.f),
                               r * std::sin(float(M_PI) * float(i) / 5.f)};
        }
        std::reverse(vert.begin(), vert.end());
        rasterize(vert);
    } else {
        return {};
    }
    return ApertureImage(res, res, std::move(img));
}

float ApertureImage::texel(int x, int y) const {
    if (x < 0 || y < 0 || x >= width_ || y >= height_) return 0.f;
    return values_[size_t(y) * size_t(width_) + size_t(x)];
}

float ApertureImage::bilerp(double u, double v) const {
    double x = u * width_ - 0.5, y = v * height_ - 0.5;
    double xf = std::floor(x), yf = std::floor(y);
    if (!std::isfinite(xf) || !std::isfinite(yf) || std::abs(xf) > 1e8 || std::abs(yf) > 1e8)
        return 0.f;
    int xi = int(xf), yi = int(yf);
    double dx = x - xf, dy = y - yf;
    return float((1 - dx) * (1 - dy) * texel(xi, yi) + dx * (1 - dy) * texel(xi + 1, yi) +
                 (1 - dx) * dy * texel(xi, yi + 1) + dx * dy * texel(xi + 1, yi + 1));
}

// ---------------------------------------------------------------------------------------------
// LensSystem

LensSystem::LensSystem(const std::vector<float> &lens, float aperture_diameter,
                       float focus_distance, float film_diagonal, int width, int height,
                       ApertureImage aperture, std::vector<std::string> *warnings,
                       int pupil_search_log2)
    : aperture_(std::move(aperture)), film_diagonal_(film_diagonal), width_(float(width)),
      height_(float(height)) {
    if (lens.empty() || lens.size() % 4 != 0)
        throw std::runtime_error("the lens description needs four values per element");
    if (lens.size() / 4 > kMaxLensElements)
        throw std::runtime_error("the lens has " + std::to_string(lens.size() / 4) +
                                 " elements; at most " + std::to_string(kMaxLensElements) +
                                 " are supported");
    if (!(film_diagonal > 0) || !std::isfinite(film_diagonal))
        throw std::runtime_error("the film diagonal must be positive");
    if (!(focus_distance > 0) || !std::isfinite(focus_distance))
        throw std::runtime_error("\"focusdistance\" must be positive");
    // The film's physical extent: its diagonal, with the image's aspect ratio.
    const double aspect = double(height) / double(width);
    extent_x_ = std::sqrt(film_diagonal_ * film_diagonal_ / (1 + aspect * aspect));
    extent_y_ = aspect * extent_x_;

    for (size_t i = 0; i < lens.size(); i += 4) {
        LensElement e;
        e.curvature_radius = double(lens[i]) / 1000;
        e.thickness = double(lens[i + 1]) / 1000;
        e.eta = double(lens[i + 2]);
        double diameter = double(lens[i + 3]) / 1000;
        if (e.curvature_radius == 0) {
            const double wanted = double(aperture_diameter) / 1000;
            if (wanted > diameter) {
                if (warnings)
                    warnings->push_back("\"aperturediameter\" " + num(aperture_diameter) +
                                        " mm is larger than the stop's " +
                                        num(diameter * 1000) + " mm; clamped");
            } else {
                diameter = wanted;
            }
        }
        if (!(diameter > 0))
            throw std::runtime_error("lens element " + std::to_string(i / 4 + 1) +
                                     " has no aperture (diameter " + num(diameter * 1000) +
                                     " mm)");
        if (e.curvature_radius != 0 && !(e.eta >= 0))
            throw std::runtime_error("lens element " + std::to_string(i / 4 + 1) +
                                     " has a negative index of refraction");
        e.aperture_radius = diameter / 2;
        elements_.push_back(e);
    }

    // Focus: move the film so that the thick-lens approximation images focus_distance on it
    // (pbrt-v4 FocusThickLens).
    double pz[2], fz[2];
    thick_lens(pz, fz);
    const double f = fz[0] - pz[0];
    focal_length_ = f;
    const double z = -double(focus_distance);
    const double a = pz[1] - z - pz[0];
    const double c = a * (a - 4 * f);
    if (!(c > 0))
        throw std::runtime_error("\"focusdistance\" " + num(focus_distance) +
                                 " m is too close for this lens (focal length " +
                                 num(f * 1000) + " mm)");
    // pbrt's delta = (pz1 - z + pz0 - sqrt(c)) / 2 subtracts two numbers of the size of the
    // focus distance: at 1e20 m the whole correction cancels and the film stays where the
    // file put it. For a > 0, sqrt(c) = a sqrt(1 - 4f/a) and the same value is
    // pz0 + 2f / (1 + sqrt(1 - 4f/a)), which tends to the focal point as z -> -infinity.
    const double delta = a > 0 ? pz[0] + 2 * f / (1 + std::sqrt(1 - 4 * f / a))
                               : (pz[1] - z + pz[0] - std::sqrt(c)) / 2;
    elements_.back().thickness += delta;
    if (!(elements_.back().thickness > 0))
        throw std::runtime_error("the lens cannot focus at " + num(focus_distance) +
                                 " m: the film would lie inside the lens");

    // Exit-pupil bounds per film radius segment, in parallel. pbrt-v4 traces 2^20 rays per
    // segment; 2^18 (bound_exit_pupil) loads 4x faster (about 1 s for an 11-element lens on
    // 2 threads) at the price of a sample-spacing margin twice pbrt's: a looser bound means
    // more samples the lens blocks (more noise per sample), never bias, as each ray's weight
    // carries the bound's area.
    const uint32_t samples = 1u << std::clamp(pupil_search_log2, 8, 24);
    pupil_.resize(kPupilSegments);
    tbb::parallel_for(0, kPupilSegments, [&](int i) {
        double r0 = double(i) / kPupilSegments * film_diagonal_ / 2;
        double r1 = double(i + 1) / kPupilSegments * film_diagonal_ / 2;
        pupil_[size_t(i)] = bound_exit_pupil(r0, r1, samples);
    });
    bool any = false;
    for (const Bounds &b : pupil_) any |= !b.empty();
    if (!any) throw std::runtime_error("no light passes the lens system (is the stop closed?)");
}

double LensSystem::front_z() const {
    double z = 0;
    for (const LensElement &e : elements_) z += e.thickness;
    return z;
}

float LensSystem::trace_from_film(const LensVec &o, const LensVec &d, LensVec *o_out,
                                  LensVec *d_out, bool rotation_invariant) const {
    double element_z = 0;
    float weight = 1.f;
    // Lens space: camera space with z flipped, the film at 0 and the elements toward -z.
    LensVec ro = flip_z(o), rd = flip_z(d);
    for (int i = int(elements_.size()) - 1; i >= 0; --i) {
        const LensElement &e = elements_[size_t(i)];
        element_z -= e.thickness;
        double t;
        LensVec n;
        const bool stop = e.curvature_radius == 0;
        if (stop) {
            t = (element_z - ro.z) / rd.z;
            if (!(t >= 0)) return 0.f;
        } else if (!intersect_spherical_element(e.curvature_radius,
                                                element_z + e.curvature_radius, ro, rd, &t,
                                                &n)) {
            return 0.f;
        }
        LensVec hit = ro + rd * t;
        const double r2 = hit.x * hit.x + hit.y * hit.y;
        if (stop && !aperture_.empty() && rotation_invariant) {
            // The image covers the square around the stop's circle: its corners reach sqrt(2)
            // times the radius.
            if (r2 > 2 * e.aperture_radius * e.aperture_radius) return 0.f;
        } else if (stop && !aperture_.empty()) {
            weight = aperture_.bilerp((hit.x / e.aperture_radius + 1) / 2,
                                      (hit.y / e.aperture_radius + 1) / 2);
            if (weight == 0.f) return 0.f;
        } else if (r2 > e.aperture_radius * e.aperture_radius) {
            return 0.f;
        }
        ro = hit;
        if (!stop) {
            // From the film side the ray leaves this element's medium for the previous one's.
            // (pbrt-v4 takes eta_i = element.eta as is; an index of 0, which lens files use
            // for air at the stop, is read as 1 here too instead of dividing by zero.)
            double eta_i = e.eta != 0 ? e.eta : 1;
            double eta_t = (i > 0 && elements_[size_t(i - 1)].eta != 0)
                               ? elements_[size_t(i - 1)].eta
                               : 1;
            LensVec w;
            if (!refract(normalize(rd * -1.0), n, eta_t / eta_i, &w)) return 0.f;
            rd = w;
        }
    }
    if (o_out) *o_out = flip_z(ro);
    if (d_out) *d_out = flip_z(rd);
    return weight;
}

bool LensSystem::trace_from_scene(const LensVec &o, const LensVec &d, LensVec *o_out,
                                  LensVec *d_out) const {
    double element_z = -front_z();
    LensVec ro = flip_z(o), rd = flip_z(d);
    for (size_t i = 0; i < elements_.size(); ++i) {
        const LensElement &e = elements_[i];
        double t;
        LensVec n;
        const bool stop = e.curvature_radius == 0;
        if (stop) {
            t = (element_z - ro.z) / rd.z;
            if (!(t >= 0)) return false;
        } else if (!intersect_spherical_element(e.curvature_radius,
                                                element_z + e.curvature_radius, ro, rd, &t,
                                                &n)) {
            return false;
        }
        LensVec hit = ro + rd * t;
        if (hit.x * hit.x + hit.y * hit.y > e.aperture_radius * e.aperture_radius) return false;
        ro = hit;
        if (!stop) {
            double eta_i = (i == 0 || elements_[i - 1].eta == 0) ? 1 : elements_[i - 1].eta;
            double eta_t = e.eta != 0 ? e.eta : 1;
            LensVec w;
            if (!refract(normalize(rd * -1.0), n, eta_t / eta_i, &w)) return false;
            rd = w;
        }
        element_z += e.thickness;
    }
    if (o_out) *o_out = flip_z(ro);
    if (d_out) *d_out = flip_z(rd);
    return true;
}

void LensSystem::thick_lens(double pz[2], double fz[2]) const {
    // Rays parallel to the axis at a small height, from each side (pbrt-v4
    // ComputeThickLensApproximation and ComputeCardinalPoints).
    const double x = 0.001 * film_diagonal_;
    auto cardinal = [](LensVec in_o, LensVec out_o, LensVec out_d, double *p, double *f) {
        double tf = -out_o.x / out_d.x;
        *f = -(out_o.z + out_d.z * tf);
        double tp = (in_o.x - out_o.x) / out_d.x;
        *p = -(out_o.z + out_d.z * tp);
    };
    LensVec scene_o{x, 0, front_z() + 1}, film_o, film_d;
    if (!trace_from_scene(scene_o, {0, 0, -1}, &film_o, &film_d) || film_d.x == 0)
        throw std::runtime_error("no ray parallel to the axis passes the lens system from the "
                                 "scene side (is the stop extremely small?)");
    cardinal(scene_o, film_o, film_d, &pz[0], &fz[0]);
    LensVec film_start{x, 0, rear_z() - 1}, out_o, out_d;
    if (trace_from_film(film_start, {0, 0, 1}, &out_o, &out_d) == 0.f || out_d.x == 0)
        throw std::runtime_error("no ray parallel to the axis passes the lens system from the "
                                 "film side (is the stop extremely small?)");
    cardinal(film_start, out_o, out_d, &pz[1], &fz[1]);
    for (int i = 0; i < 2; ++i)
        if (!std::isfinite(pz[i]) || !std::isfinite(fz[i]))
            throw std::runtime_error("the lens system has no finite focal length");
}

// The bounds are searched for film points on the +x axis and rotated to each film point's
// angle when sampled, which holds for a lens with rotational symmetry. A non-round aperture
// image breaks it: pbrt-v4 bounds the image's shape itself, and rotating that box leaves out
// parts of the shape for film points off the x axis (a square stop loses up to ~10% of the
// light at 45 degrees). Here the search replaces the image by the circle around it, so the
// rotated box always contains every ray the image passes.
LensSystem::Bounds LensSystem::bound_exit_pupil(double film_x0, double film_x1,
                                                uint32_t samples) const {
    const uint32_t kSamples = samples;
    Bounds b;
    const double rr = 1.5 * rear_radius();
    for (uint32_t i = 0; i < kSamples; ++i) {
        LensVec p_film{lerp((double(i) + 0.5) / kSamples, film_x0, film_x1), 0, 0};
        LensVec p_rear{lerp(radical_inverse_2(i), -rr, rr), lerp(radical_inverse_3(i), -rr, rr),
                       rear_z()};
        bool inside = p_rear.x >= b.x0 && p_rear.x <= b.x1 && p_rear.y >= b.y0 &&
                      p_rear.y <= b.y1;
        if (!inside && trace_from_film(p_film, p_rear - p_film, nullptr, nullptr, true) != 0.f) {
            b.x0 = std::min(b.x0, p_rear.x);
            b.y0 = std::min(b.y0, p_rear.y);
            b.x1 = std::max(b.x1, p_rear.x);
            b.y1 = std::max(b.y1, p_rear.y);
        }
    }
    if (b.empty()) return b;
    // Expand by the sample spacing (pbrt: twice the sampled square's diagonal / sqrt(n)).
    const double margin = 2 * (2 * rr * std::sqrt(2.0)) / std::sqrt(double(kSamples));
    b.x0 -= margin;
    b.y0 -= margin;
    b.x1 += margin;
    b.y1 += margin;
    return b;
}

float LensSystem::generate_ray(Vec2f p_raster, Vec2f u, Vec3f *o, Vec3f *d) const {
    // The film point: raster (0,0) at the top left; the lens inverts the image, so raster +x
    // maps to film -x (pbrt-v4 RealisticCamera::GenerateRay).
    const double sx = double(p_raster.x) / width_, sy = double(p_raster.y) / height_;
    LensVec p_film{-lerp(sx, -extent_x_ / 2, extent_x_ / 2), lerp(sy, -extent_y_ / 2, extent_y_ / 2),
                   0};
    // A point in the exit pupil's bounds for this film radius, rotated to the film point's
    // angle (pbrt-v4 SampleExitPupil).
    const double r_film = std::sqrt(p_film.x * p_film.x + p_film.y * p_film.y);
    int index = int(r_film / (film_diagonal_ / 2) * kPupilSegments);
    index = std::clamp(index, 0, kPupilSegments - 1);
    const Bounds &b = pupil_[size_t(index)];
    if (b.empty()) return 0.f;
    const double lx = lerp(double(u.x), b.x0, b.x1), ly = lerp(double(u.y), b.y0, b.y1);
    const double area = (b.x1 - b.x0) * (b.y1 - b.y0);
    const double sin_t = r_film != 0 ? p_film.y / r_film : 0;
    const double cos_t = r_film != 0 ? p_film.x / r_film : 1;
    LensVec p_pupil{cos_t * lx - sin_t * ly, sin_t * lx + cos_t * ly, rear_z()};
    LensVec dir = p_pupil - p_film;
    LensVec ro, rd;
    double weight = trace_from_film(p_film, dir, &ro, &rd);
    if (weight == 0) return 0.f;
    const double cos_theta = normalize(dir).z;
    const double c2 = cos_theta * cos_theta;
    weight *= c2 * c2 * area / (rear_z() * rear_z());
    *o = Vec3f(float(ro.x), float(ro.y), float(ro.z));
    *d = Vec3f(float(rd.x), float(rd.y), float(rd.z));
    return std::isfinite(weight) ? float(weight) : 0.f;
}

}  // namespace tessera
