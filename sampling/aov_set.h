// Which AOVs (arbitrary output variables) a film keeps besides the beauty: a small bit set.
//
// pbrt-v4 semantics: Film "rgb" writes RGB only, Film "gbuffer" writes the geometric AOVs
// (albedo, normal, depth). An AOV that is not in the set costs no memory and no work in
// Film::add_sample, and is neither written to the EXR nor to checkpoints ("what a scene does not need costs nothing": skip what a
// scene doesn't need").
#pragma once

#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

namespace tessera::sampling {

/// One AOV: its bit in an AovSet.
enum class Aov : uint8_t {
    Albedo = 1,  ///< first-hit albedo, RGB
    Normal = 2,  ///< first-hit shading normal, world space XYZ
    Depth = 4,   ///< first-hit distance, scene units
};

/// The AOVs in canonical order (the order of names, EXR layers and checkpoint channels).
inline constexpr Aov kAllAovs[] = {Aov::Albedo, Aov::Normal, Aov::Depth};

/// A set of AOVs. Default: empty (beauty only). A plain value; thread-safe to copy and read.
class AovSet {
  public:
    constexpr AovSet() = default;
    constexpr AovSet(std::initializer_list<Aov> aovs) {
        for (Aov a : aovs)
            bits_ |= uint8_t(a);
    }

    /// Albedo, normal and depth (Film "gbuffer", `--aov all`).
    static constexpr AovSet all() { return {Aov::Albedo, Aov::Normal, Aov::Depth}; }

    constexpr bool has(Aov a) const { return (bits_ & uint8_t(a)) != 0; }
    constexpr bool empty() const { return bits_ == 0; }
    constexpr uint8_t bits() const { return bits_; }
    constexpr AovSet with(Aov a) const {
        AovSet s = *this;
        s.bits_ |= uint8_t(a);
        return s;
    }
    constexpr bool operator==(const AovSet &o) const { return bits_ == o.bits_; }
    constexpr bool operator!=(const AovSet &o) const { return bits_ != o.bits_; }

    /// The names of the AOVs in the set, in canonical order, e.g. {"albedo", "depth"}.
    std::vector<std::string> names() const;

    /// "albedo,normal,depth", "depth" or "none" (the form parse() reads back).
    std::string describe() const;

    /// Parses a comma list of albedo, normal, depth (any order, repeats allowed), or "all", or
    /// "none". Throws std::invalid_argument naming the bad entry and the accepted ones.
    static AovSet parse(const std::string &text);

  private:
    uint8_t bits_ = 0;
};

/// The lower-case name of an AOV ("albedo", "normal", "depth").
const char *aov_name(Aov a);

}  // namespace tessera::sampling
