// Spectrum -> linear sRGB conversions for pbrt-v4 scene parameters (see spectra.h).
#include "renderer/util/spectra.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace tessera {

namespace {

/// The CIE 1931 2-degree standard colorimetric observer, xbar ybar zbar at 380, 385, ...,
/// 780 nm (CIE 15:2004, table T.4, 5 nm steps).
constexpr double kCie1931[81][3] = {
    {0.001368, 0.000039, 0.006450},  {0.002236, 0.000064, 0.010550},  {0.004243, 0.000120, 0.020050},
    {0.007650, 0.000217, 0.036210},  {0.014310, 0.000396, 0.067850},  {0.023190, 0.000640, 0.110200},
    {0.043510, 0.001210, 0.207400},  {0.077630, 0.002180, 0.371300},  {0.134380, 0.004000, 0.645600},
    {0.214770, 0.007300, 1.039050},  {0.283900, 0.011600, 1.385600},  {0.328500, 0.016840, 1.622960},
    {0.348280, 0.023000, 1.747060},  {0.348060, 0.029800, 1.782600},  {0.336200, 0.038000, 1.772110},
    {0.318700, 0.048000, 1.744100},  {0.290800, 0.060000, 1.669200},  {0.251100, 0.073900, 1.528100},
    {0.195360, 0.090980, 1.287640},  {0.142100, 0.112600, 1.041900},  {0.095640, 0.139020, 0.812950},
    {0.058010, 0.169300, 0.616200},  {0.032010, 0.208020, 0.465180},  {0.014700, 0.258600, 0.353300},
    {0.004900, 0.323000, 0.272000},  {0.002400, 0.407300, 0.212300},  {0.009300, 0.503000, 0.158200},
    {0.029100, 0.608200, 0.111700},  {0.063270, 0.710000, 0.078250},  {0.109600, 0.793200, 0.057250},
    {0.165500, 0.862000, 0.042160},  {0.225750, 0.914850, 0.029840},  {0.290400, 0.954000, 0.020300},
    {0.359700, 0.980300, 0.013400},  {0.433450, 0.994950, 0.008750},  {0.512050, 1.000000, 0.005750},
    {0.594500, 0.995000, 0.003900},  {0.678400, 0.978600, 0.002750},  {0.762100, 0.952000, 0.002100},
    {0.842500, 0.915400, 0.001800},  {0.916300, 0.870000, 0.001650},  {0.978600, 0.816300, 0.001400},
    {1.026300, 0.757000, 0.001100},  {1.056700, 0.694900, 0.001000},  {1.062200, 0.631000, 0.000800},
    {1.045600, 0.566800, 0.000600},  {1.002600, 0.503000, 0.000340},  {0.938400, 0.441200, 0.000240},
    {0.854450, 0.381000, 0.000190},  {0.751400, 0.321000, 0.000100},  {0.642400, 0.265000, 0.000050},
    {0.541900, 0.217000, 0.000030},  {0.447900, 0.175000, 0.000020},  {0.360800, 0.138200, 0.000010},
    {0.283500, 0.107000, 0.000000},  {0.218700, 0.081600, 0.000000},  {0.164900, 0.061000, 0.000000},
    {0.121200, 0.044580, 0.000000},  {0.087400, 0.032000, 0.000000},  {0.063600, 0.023200, 0.000000},
    {0.046770, 0.017000, 0.000000},  {0.032900, 0.011920, 0.000000},  {0.022700, 0.008210, 0.000000},
    {0.015840, 0.005723, 0.000000},  {0.011359, 0.004102, 0.000000},  {0.008111, 0.002929, 0.000000},
    {0.005790, 0.002091, 0.000000},  {0.004109, 0.001484, 0.000000},  {0.002899, 0.001047, 0.000000},
    {0.002049, 0.000740, 0.000000},  {0.001440, 0.000520, 0.000000},  {0.001000, 0.000361, 0.000000},
    {0.000690, 0.000249, 0.000000},  {0.000476, 0.000172, 0.000000},  {0.000332, 0.000120, 0.000000},
    {0.000235, 0.000085, 0.000000},  {0.000166, 0.000060, 0.000000},  {0.000117, 0.000042, 0.000000},
    {0.000083, 0.000030, 0.000000},  {0.000059, 0.000021, 0.000000},  {0.000042, 0.000015, 0.000000},
};

/// CIE standard illuminant D65, relative spectral power at 380, 390, ..., 780 nm (CIE 15:2004,
/// table T.1, 10 nm steps).
constexpr std::array<double, 41> kD65 = {
    49.9755, 54.6482, 82.7549, 91.4860, 93.4318, 86.6823, 104.865, 117.008, 117.812,
    114.861, 115.923, 108.811, 109.354, 107.802, 104.790, 107.689, 104.405, 104.046,
    100.000, 96.3342, 95.7880, 88.6856, 90.0062, 89.5991, 87.6987, 83.2886, 83.6992,
    80.0268, 80.2146, 82.2778, 78.2842, 69.7213, 71.6091, 74.3490, 61.6040, 69.8856,
    75.0870, 63.5927, 46.4182, 66.8054, 63.3828};

/// D65 at any wavelength in [380, 780] nm by linear interpolation, 0 outside.
double d65(double lambda) {
    if (lambda < 380 || lambda > 780) return 0;
    double x = (lambda - 380) / 10;
    int i = std::min(int(x), 39);
    double t = x - i;
    return (1 - t) * kD65[i] + t * kD65[i + 1];
}

/// Piecewise-linear evaluation, 0 outside [lambda.front(), lambda.back()].
double eval_pwl(std::span<const float> lambda, std::span<const float> values, double x) {
    if (lambda.empty() || x < lambda.front() || x > lambda.back()) return 0;
    if (lambda.size() == 1) return values[0];
    size_t hi = 1;
    while (hi + 1 < lambda.size() && lambda[hi] < x) ++hi;
    double l0 = lambda[hi - 1], l1 = lambda[hi];
    double t = l1 > l0 ? (x - l0) / (l1 - l0) : 0;
    return (1 - t) * values[hi - 1] + t * values[hi];
}

// Integration over the visible range with 1 nm steps (as pbrt-v4's SpectrumToXYZ).
constexpr int kLambdaMin = 360, kLambdaMax = 830;

template <typename F>
std::array<double, 3> integrate_xyz(F spectrum) {
    std::array<double, 3> xyz = {0, 0, 0};
    for (int l = kLambdaMin; l <= kLambdaMax; ++l) {
        Vec3f c = cie_xyz(float(l));
        double s = spectrum(double(l));
        xyz[0] += c.x * s;
        xyz[1] += c.y * s;
        xyz[2] += c.z * s;
    }
    return xyz;
}

/// XYZ scaled to luminance 1 and converted to sRGB; black if Y <= 0. Colours outside the sRGB
/// gamut (e.g. blackbodies below ~1900 K) have negative components, clamped to 0: the renderer
/// must never see negative radiance.
Rgb normalised_rgb(std::array<double, 3> xyz) {
    if (!(xyz[1] > 0)) return Rgb(0.f);
    return clamp_zero(
        xyz_to_linear_srgb(Vec3f(float(xyz[0] / xyz[1]), 1.f, float(xyz[2] / xyz[1]))));
}

/// RGB optical constants of pbrt-v4's named metals.
struct MetalEntry {
    const char *name;
    Rgb eta, k;
};

// pbrt-v4 renders its named metals spectrally (measured eta/k tables in its
// src/pbrt/util/spectrum.cpp). For R, G and B these are the complex indices whose Fresnel curve
// is closest (least squares over the incidence angles) to what pbrt-v4 itself renders for a
// smooth sphere of the metal under a white sky: scripts/fit_named_metals.py, which prints this
// table and the residuals (rms 0.001-0.005 of reflectance, 0.017 for gold's red, whose sRGB
// value pbrt-v4 renders at about 1, beyond any Fresnel curve; the band averages of eta and k
// used before were off by 0.01-0.07). MgO and TiO2 are dielectrics (k = 0).
constexpr MetalEntry kMetals[] = {
    {"Ag", {0.1280f, 0.1262f, 0.1646f}, {4.0854f, 3.3670f, 2.5435f}},
    {"Al", {1.5300f, 0.9537f, 0.6214f}, {8.0028f, 6.6922f, 5.5014f}},
    {"Au", {0.0146f, 0.3970f, 1.5630f}, {14.7291f, 2.3144f, 1.7172f}},
    {"Cu", {0.2287f, 0.9658f, 1.1996f}, {4.3093f, 2.6063f, 2.3553f}},
    {"CuZn", {0.6196f, 0.5194f, 1.1178f}, {4.9661f, 2.6563f, 1.8048f}},
    {"MgO", {1.7362f, 1.7435f, 1.7560f}, {0.0000f, 0.0000f, 0.0000f}},
    {"TiO2", {2.8616f, 2.9583f, 3.1866f}, {0.0000f, 0.0000f, 0.0000f}},
};

struct GlassEntry {
    const char *name;
    float eta;
};

// Index of refraction at 550 nm, linearly interpolated in the refractiveindex.info tables
// (Schott catalogue Sellmeier fits) that pbrt-v4 uses for its named glasses. "glass-F5",
// "glass-F10", "glass-F11" are pbrt-v4's names for Schott SF5, SF10, SF11.
constexpr GlassEntry kGlasses[] = {
    {"glass-BK7", 1.5185f},  {"glass-BAF10", 1.6731f}, {"glass-FK51A", 1.4878f},
    {"glass-LASF9", 1.8558f}, {"glass-F5", 1.6771f},    {"glass-SF5", 1.6771f},
    {"glass-F10", 1.7336f},  {"glass-SF10", 1.7336f},  {"glass-F11", 1.7911f},
    {"glass-SF11", 1.7911f},
};

struct IlluminantEntry {
    const char *name;
    float cct_kelvin;  ///< 0: exactly the sRGB white
    bool exact;        ///< true: a blackbody is the definition (illuminant A), or D65 itself
};

// Standard illuminants. D65 is the sRGB white point, so it maps to (1, 1, 1) exactly; A is by
// definition a 2856 K Planckian radiator. The others are approximated by a blackbody at their
// correlated colour temperature (CIE 15:2004), which misses the daylight locus' green offset and
// the line spectra of the F series: reported as an approximation.
constexpr IlluminantEntry kIlluminants[] = {
    {"stdillum-D65", 0, true},     {"stdillum-A", 2856, true},    {"stdillum-D50", 5003, false},
    {"illum-acesD60", 6000, false}, {"stdillum-F1", 6430, false}, {"stdillum-F2", 4230, false},
    {"stdillum-F3", 3450, false},  {"stdillum-F4", 2940, false},  {"stdillum-F5", 6350, false},
    {"stdillum-F6", 4150, false},  {"stdillum-F7", 6500, false},  {"stdillum-F8", 5000, false},
    {"stdillum-F9", 4150, false},  {"stdillum-F10", 5000, false}, {"stdillum-F11", 4000, false},
    {"stdillum-F12", 3000, false},
};

}  // namespace

Vec3f cie_xyz(float lambda_nm) {
    // The CIE 1931 table, linearly interpolated; 0 outside 380-780 nm (the matching functions
    // are below 1e-4 of their peak there).
    const double l = lambda_nm;
    if (!(l >= 380 && l <= 780)) return {0.f, 0.f, 0.f};
    const double x = (l - 380) / 5;
    const int i = std::min(int(x), 79);
    const double t = x - i;
    auto lerp = [&](int c) { return float((1 - t) * kCie1931[i][c] + t * kCie1931[i + 1][c]); };
    return {lerp(0), lerp(1), lerp(2)};
}

Rgb xyz_to_linear_srgb(Vec3f c) {
    return {3.2404542f * c.x - 1.5371385f * c.y - 0.4985314f * c.z,
            -0.9692660f * c.x + 1.8760108f * c.y + 0.0415560f * c.z,
            0.0556434f * c.x - 0.2040259f * c.y + 1.0572252f * c.z};
}

double planck(double lambda_nm, double kelvin) {
    if (kelvin <= 0) return 0;
    constexpr double c = 299792458.0, h = 6.62606957e-34, kb = 1.3806488e-23;
    double l = lambda_nm * 1e-9;
    return (2 * h * c * c) / (std::pow(l, 5) * (std::exp((h * c) / (l * kb * kelvin)) - 1));
}

Rgb blackbody_rgb(float kelvin) {
    // pbrt-v4's BlackbodySpectrum divides by its peak (Wien's law), and every light then divides
    // its scale by the spectrum's photometric value, so only the chromaticity survives: the
    // emitted colour has luminance 1.
    return normalised_rgb(integrate_xyz([&](double l) { return planck(l, kelvin); }));
}

Rgb blackbody_peak_rgb(float kelvin) {
    if (!(kelvin > 0)) return Rgb(0.f);
    const double lambda_max_nm = 2.8977721e-3 / double(kelvin) * 1e9;  // Wien's law
    const double peak = planck(lambda_max_nm, kelvin);
    // pbrt-v4's sensor takes a spectrum's XYZ as its inner products with the matching
    // functions (PixelSensor::ToSensorRGB, no division by the integral of y-bar): a
    // peak-normalised blackbody has a luminance of about 107 at 6500 K.
    std::array<double, 3> xyz = integrate_xyz([&](double l) { return planck(l, kelvin) / peak; });
    return clamp_zero(xyz_to_linear_srgb(Vec3f(float(xyz[0]), float(xyz[1]), float(xyz[2]))));
}

Vec2f daylight_xy(float kelvin) {
    const double cct = double(kelvin) * 1.4388 / 1.4380;
    if (cct < 4000) {
        // pbrt-v4: "CIE D ill-defined, use blackbody".
        std::array<double, 3> c = integrate_xyz([&](double l) { return planck(l, cct); });
        const double sum = c[0] + c[1] + c[2];
        return sum > 0 ? Vec2f{float(c[0] / sum), float(c[1] / sum)} : kSrgbWhiteXy;
    }
    const double t = cct, t2 = t * t, t3 = t2 * t;
    const double x = t <= 7000 ? -4.607e9 / t3 + 2.9678e6 / t2 + 0.09911e3 / t + 0.244063
                               : -2.0064e9 / t3 + 1.9018e6 / t2 + 0.24748e3 / t + 0.23704;
    const double y = -3 * x * x + 2.870 * x - 0.275;
    return {float(x), float(y)};
}

namespace {

using Mat3d = std::array<double, 9>;

Mat3d mul(const Mat3d &a, const Mat3d &b) {
    Mat3d r{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k)
                r[size_t(3 * i + j)] += a[size_t(3 * i + k)] * b[size_t(3 * k + j)];
    return r;
}

Mat3d inverse(const Mat3d &m) {
    const double a = m[0], b = m[1], c = m[2], d = m[3], e = m[4], f = m[5], g = m[6], h = m[7],
                 i = m[8];
    const double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
    const double det = a * A + b * B + c * C;
    return {A / det, -(b * i - c * h) / det, (b * f - c * e) / det,
            B / det, (a * i - c * g) / det,  -(a * f - c * d) / det,
            C / det, -(a * h - b * g) / det, (a * e - b * d) / det};
}

std::array<double, 3> apply(const Mat3d &m, std::array<double, 3> v) {
    return {m[0] * v[0] + m[1] * v[1] + m[2] * v[2], m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
            m[6] * v[0] + m[7] * v[1] + m[8] * v[2]};
}

}  // namespace

std::array<float, 9> white_balance_srgb(Vec2f src, Vec2f dst) {
    // Bradford cone response (pbrt-v4 LMSFromXYZ).
    const Mat3d lms_from_xyz = {0.8951, 0.2664, -0.1614, -0.7502, 1.7135,
                                0.0367, 0.0389, -0.0685, 1.0296};
    // XYZ from linear sRGB: the inverse of xyz_to_linear_srgb's matrix, so that M is the
    // identity when src == dst.
    const Mat3d srgb_from_xyz = {3.2404542,  -1.5371385, -0.4985314, -0.9692660, 1.8760108,
                                 0.0415560,  0.0556434,  -0.2040259, 1.0572252};
    const Mat3d xyz_from_srgb = inverse(srgb_from_xyz);
    auto lms_of = [&](Vec2f xy) {  // XYZ of the chromaticity at Y = 1
        return apply(lms_from_xyz, {xy.x / xy.y, 1.0, (1.0 - xy.x - xy.y) / xy.y});
    };
    const std::array<double, 3> s = lms_of(src), d = lms_of(dst);
    const Mat3d scale = {d[0] / s[0], 0, 0, 0, d[1] / s[1], 0, 0, 0, d[2] / s[2]};
    const Mat3d xyz_wb = mul(inverse(lms_from_xyz), mul(scale, lms_from_xyz));
    const Mat3d m = mul(srgb_from_xyz, mul(xyz_wb, xyz_from_srgb));
    std::array<float, 9> out{};
    for (size_t k = 0; k < 9; ++k) out[k] = float(m[k]);
    return out;
}

Rgb sampled_spectrum_rgb(std::span<const float> lambda_nm, std::span<const float> values,
                         bool illuminant) {
    auto s = [&](double l) { return eval_pwl(lambda_nm, values, l); };
    if (illuminant) return normalised_rgb(integrate_xyz(s));
    // Reflectance: reflected light of D65 relative to D65's own luminance, so that the
    // constant spectrum 1 maps to sRGB white (1, 1, 1) up to the rounding of the tables.
    std::array<double, 3> xyz = integrate_xyz([&](double l) { return s(l) * d65(l); });
    std::array<double, 3> white = integrate_xyz(d65);
    Rgb rgb = xyz_to_linear_srgb(Vec3f(float(xyz[0] / white[1]), float(xyz[1] / white[1]),
                                       float(xyz[2] / white[1])));
    // Remove the small residual tint of the tables (D65's tabulated chromaticity against the
    // sRGB white point): divide by the RGB of the perfect white reflector.
    Rgb w = xyz_to_linear_srgb(Vec3f(float(white[0] / white[1]), 1.f,
                                     float(white[2] / white[1])));
    return clamp_zero(rgb / w);  // out-of-gamut reflectances: no negative components
}

Rgb band_average_rgb(std::span<const float> lambda_nm, std::span<const float> values) {
    auto band = [&](double a, double b) {
        constexpr int n = 200;
        double sum = 0;
        for (int i = 0; i < n; ++i) sum += eval_pwl(lambda_nm, values, a + (b - a) * (i + 0.5) / n);
        return float(sum / n);
    };
    return {band(600, 700), band(500, 600), band(400, 500)};
}

bool named_metal(std::string_view metal, Rgb *eta, Rgb *k) {
    for (const MetalEntry &m : kMetals)
        if (metal == m.name) {
            if (eta) *eta = m.eta;
            if (k) *k = m.k;
            return true;
        }
    return false;
}

std::optional<Rgb> named_spectrum_rgb(std::string_view name, bool illuminant) {
    if (name.starts_with("metal-")) {
        std::string_view rest = name.substr(6);
        bool is_eta = rest.ends_with("-eta"), is_k = rest.ends_with("-k");
        if (!is_eta && !is_k) return std::nullopt;
        std::string_view metal = rest.substr(0, rest.size() - (is_eta ? 4 : 2));
        Rgb eta, k;
        if (!named_metal(metal, &eta, &k)) return std::nullopt;
        return is_eta ? eta : k;
    }
    for (const GlassEntry &g : kGlasses)
        if (name == g.name) return Rgb(g.eta);
    for (const IlluminantEntry &e : kIlluminants)
        if (name == e.name) {
            Rgb c = e.cct_kelvin == 0 ? Rgb(1.f) : blackbody_rgb(e.cct_kelvin);
            // As a reflectance-like quantity, scale to a maximum of 1 instead of luminance 1.
            if (!illuminant && c.max_value() > 0) c = c / c.max_value();
            return c;
        }
    // Camera sensor curves (canon_eos_*, nikon_*, sony_*, hasselblad_*) only make sense in a
    // spectral film: unsupported.
    return std::nullopt;
}

std::string named_spectrum_note(std::string_view name) {
    if (name.starts_with("glass-"))
        return "dispersion is not simulated; using the index of refraction at 550 nm";
    if (name == "metal-CuZn-eta" || name == "metal-CuZn-k")
        return "approximated by a tabulated RGB value (no spectral data)";
    for (const IlluminantEntry &e : kIlluminants)
        if (name == e.name && !e.exact)
            return "approximated by a blackbody at the illuminant's colour temperature";
    return {};
}

}  // namespace tessera
