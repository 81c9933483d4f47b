// Display images through OpenColorIO (docs/ARCHITECTURE.md, "Outputs people use": a display PNG).
//
// Which OCIO config: an explicit `config_path` wins; otherwise $OCIO when set (and `use_env`);
// otherwise a small OCIO v2 config embedded in the code (embedded_ocio_config()):
//   colorspace "linear"  scene-linear Rec.709/sRGB primaries, D65 (roles default, scene_linear)
//   colorspace "sRGB"    the sRGB transfer function of IEC 61966-2-1 (ExponentWithLinear,
//                        gamma 2.4, offset 0.055) on the same primaries
//   colorspace "raw"     data, no transform
//   display "sRGB" with views "sRGB" (default) and "Raw".
// The image is taken to be in the config's scene_linear role unless `input_colorspace` says
// otherwise. Display and view default to the config's default display and its default view.
// Output is clamped to [0, 1] and quantised to 8 bits with round-to-nearest; NaN gives 0.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sampling/image_metrics.h"

namespace tessera {

/// Where the display transform comes from and what it targets.
struct DisplayOptions {
    std::string config_path;       ///< OCIO config file ("" : $OCIO or the embedded config)
    bool use_env = true;           ///< honour $OCIO when config_path is empty
    std::string input_colorspace;  ///< colorspace of the image ("" : role scene_linear)
    std::string display;           ///< display ("" : the config's default display)
    std::string view;              ///< view ("" : the display's default view)
    float exposure_stops = 0.f;    ///< scale by 2^stops before the transform
};

/// The embedded OCIO v2 config text (see the file comment).
const char *embedded_ocio_config();

/// A resolved OCIO display transform (config + processor). Construction parses the config and
/// builds the CPU processor; throws std::runtime_error on a bad config, display or view.
/// apply/to_8bit are const and thread-safe.
class DisplayTransform {
  public:
    explicit DisplayTransform(const DisplayOptions &options = {});
    ~DisplayTransform();
    DisplayTransform(DisplayTransform &&) noexcept;
    DisplayTransform &operator=(DisplayTransform &&) noexcept;

    /// Transforms interleaved RGB floats in place (exposure, then the display transform).
    void apply(std::vector<float> &rgb) const;
    /// The display-referred 8-bit RGB of a linear image (3 bytes per pixel).
    std::vector<uint8_t> to_8bit(const sampling::RgbImage &image) const;

    const std::string &display() const;
    const std::string &view() const;
    /// Where the config came from: a path, "$OCIO=<path>" or "embedded".
    const std::string &config_source() const;
    /// One readable line: config source, input colorspace, display, view, exposure.
    std::string describe() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Quantises a display-referred value to 8 bits: clamp to [0, 1], round to nearest; NaN -> 0.
uint8_t quantize_8bit(float v);

/// Writes the display transform of a linear image as an 8-bit PNG (or any format of the path's
/// extension), atomically (renderer/util/image_io.h). Throws std::runtime_error on failure.
void write_display_image(const std::string &path, const sampling::RgbImage &image,
                         const DisplayOptions &options = {});

}  // namespace tessera
