// Conversion of pbrt-v4 spectral parameters to linear sRGB (Rec.709 primaries, D65 white).
//
// Tessera renders in RGB. pbrt-v4 renders spectrally, so every spectrum a scene gives (named
// spectra, blackbody temperatures, (lambda, value) tables) is reduced to one RGB triple here:
//  - Illuminants (light "L", "I"): pbrt-v4 divides each light's scale by the spectrum's
//    photometric value (lights.cpp, `scale /= SpectrumToPhotometric(L)`), so a spectral or
//    blackbody emitter has luminance Y = 1 before "scale"/"power". We therefore return the
//    spectrum's colour in sRGB normalised to luminance 1. (An "rgb L" keeps its values: pbrt-v4
//    only normalises the colour space's illuminant of an RGBIlluminantSpectrum.)
//  - Reflectances: the colour of the spectrum lit by D65 (the sRGB white), divided by the
//    luminance of D65, so that a constant reflectance r gives RGB (r, r, r).
//  - Unbounded values such as conductor eta and k given as (lambda, value) tables: the plain
//    average of the spectrum over three bands, blue 400-500 nm, green 500-600 nm, red
//    600-700 nm. Colour-matching projections of eta/k give meaningless (even negative) values,
//    band averages keep Fresnel plausible. pbrt-v4's named metals ("metal-Au-eta", ...) use
//    per-channel indices fitted to pbrt-v4's own rendering of them instead (spectra.cpp,
//    scripts/fit_named_metals.py).
// The CIE 1931 2-degree matching functions are the CIE's table (CIE 15:2004, 5 nm steps,
// linearly interpolated), as pbrt-v4 uses them. XYZ -> linear sRGB uses the IEC 61966-2-1
// matrix.
// All functions are pure and thread-safe.
#pragma once

#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "sampling/vecmath.h"

namespace tessera {

/// CIE 1931 XYZ of a monochromatic unit stimulus at `lambda_nm` (the CIE 1931 table).
Vec3f cie_xyz(float lambda_nm);

/// XYZ -> linear sRGB (Rec.709 primaries, D65 white), IEC 61966-2-1.
Rgb xyz_to_linear_srgb(Vec3f xyz);

/// Planck's law: spectral radiance of a blackbody at `kelvin` for `lambda_nm`, W/(m^2 sr m).
double planck(double lambda_nm, double kelvin);

/// Colour of a blackbody emitter at `kelvin` (> 0) in linear sRGB, normalised to luminance
/// Y = 1 as pbrt-v4's lights do (BlackbodySpectrum is peak-normalised, then the light's scale is
/// divided by its photometric value). 6500 K is close to (1, 1, 1); negative (out-of-gamut)
/// components, below about 1900 K, are clamped to 0.
Rgb blackbody_rgb(float kelvin);

/// pbrt-v4's BlackbodySpectrum itself (peak-normalised, no photometric division) in linear
/// sRGB as pbrt-v4's film sees a raw spectrum (its luminance is the spectrum's inner product with
/// y-bar, about 107 for a flat spectrum of 1): what a grid medium's "temperature" emits per unit
/// Lescale. Negative components clamped.
Rgb blackbody_peak_rgb(float kelvin);

/// pbrt-v4's CIE_Y_integral, the integral of the CIE 1931 y-bar over 360-830 nm: the luminance
/// its film gives a raw spectrum of 1 (or an RGBIlluminantSpectrum of (1, 1, 1)) that no light
/// divides by its photometric value.
inline constexpr float kCieYIntegral = 106.856895f;

/// Chromaticity (x, y) of pbrt-v4's Spectra::D(kelvin), the white a Film "whitebalance" names:
/// the temperature is rescaled to a CCT (x 1.4388 / 1.4380), then the CIE daylight locus
/// (CIE 15:2004) from 4000 K up, and a blackbody's chromaticity below 4000 K, as pbrt-v4 does.
Vec2f daylight_xy(float kelvin);

/// Chromaticity of the sRGB white point (D65), pbrt-v4's RGBColorSpace::sRGB->w.
inline constexpr Vec2f kSrgbWhiteXy{0.3127f, 0.3290f};

/// pbrt-v4's WhiteBalance(src_white, dst_white) -- a von Kries scaling in Bradford LMS space --
/// expressed on linear sRGB: rgb' = M rgb with M row-major. Maps src white to dst white.
std::array<float, 9> white_balance_srgb(Vec2f src_white_xy, Vec2f dst_white_xy);

/// RGB of a piecewise-linear spectrum given by increasing wavelengths `lambda_nm` and `values`
/// (outside the given range the spectrum is 0, as pbrt-v4's PiecewiseLinearSpectrum).
/// `illuminant`: emission, normalised to luminance 1 (see the file comment); otherwise a
/// reflectance lit by D65 (a constant spectrum c gives (c, c, c)). Out-of-gamut colours are
/// clamped to non-negative components.
Rgb sampled_spectrum_rgb(std::span<const float> lambda_nm, std::span<const float> values,
                         bool illuminant);

/// Average of a piecewise-linear spectrum over the blue (400-500 nm), green (500-600 nm) and red
/// (600-700 nm) bands, returned as (r, g, b). Used for eta and k.
Rgb band_average_rgb(std::span<const float> lambda_nm, std::span<const float> values);

/// Conductor optical constants of pbrt-v4's named metals: `metal` is the element part of the
/// name ("Ag", "Al", "Au", "Cu", "CuZn", "MgO", "TiO2"). Returns false if unknown.
bool named_metal(std::string_view metal, Rgb *eta, Rgb *k);

/// RGB of a pbrt-v4 named spectrum ("metal-Au-eta", "glass-BK7", "stdillum-D65", ...), or
/// std::nullopt when the name is unknown or unsupported (camera sensor curves). Glasses give
/// their index of refraction at 550 nm as a grey triple. Illuminants are normalised to luminance
/// 1 when `illuminant` is true (pbrt-v4 lights), otherwise have a maximum component of 1.
std::optional<Rgb> named_spectrum_rgb(std::string_view name, bool illuminant = true);

/// A one-line note on how `name` is approximated ("" when it is exact enough to say nothing),
/// for the caller's warning: e.g. glasses lose their dispersion.
std::string named_spectrum_note(std::string_view name);

}  // namespace tessera
