// OpenColorIO display transforms and the display PNG.
#include "renderer/util/color.h"

#include <OpenColorIO/OpenColorIO.h>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include "renderer/util/image_io.h"

namespace OCIO = OCIO_NAMESPACE;

namespace tessera {

namespace {

// NOTE: the sRGB curve is written as its decoding direction (encoded -> linear, the
// ExponentWithLinear "forward" direction), so the colorspace's from_scene_reference runs it
// inverse: linear -> sRGB encoded.
constexpr const char *kEmbeddedConfig = R"(ocio_profile_version: 2

environment: {}
search_path: ""
strictparsing: true
luma: [0.2126, 0.7152, 0.0722]
name: tessera-embedded
description: Tessera's built-in config. Scene-linear Rec.709/sRGB to the sRGB display.

roles:
  default: linear
  scene_linear: linear
  data: raw
  color_picking: sRGB
  texture_paint: sRGB
  matte_paint: sRGB

file_rules:
  - !<Rule> {name: Default, colorspace: default}

displays:
  sRGB:
    - !<View> {name: sRGB, colorspace: sRGB}
    - !<View> {name: Raw, colorspace: raw}

active_displays: [sRGB]
active_views: [sRGB, Raw]

colorspaces:
  - !<ColorSpace>
    name: linear
    family: Scene-linear
    equalitygroup: ""
    bitdepth: 32f
    description: Scene-linear Rec.709/sRGB primaries, D65 white (the reference space)
    isdata: false
    encoding: scene-linear
    allocation: lg2
    allocationvars: [-15, 6]

  - !<ColorSpace>
    name: sRGB
    family: Display
    equalitygroup: ""
    bitdepth: 32f
    description: IEC 61966-2-1 sRGB encoding of Rec.709/sRGB primaries
    isdata: false
    encoding: sdr-video
    allocation: uniform
    from_scene_reference: !<ExponentWithLinearTransform>
      {gamma: 2.4, offset: 0.055, direction: inverse}

  - !<ColorSpace>
    name: raw
    family: Utility
    equalitygroup: ""
    bitdepth: 32f
    description: Data, no colour transform
    isdata: true
    encoding: data
    allocation: uniform
)";

}  // namespace

const char *embedded_ocio_config() { return kEmbeddedConfig; }

struct DisplayTransform::Impl {
    OCIO::ConstConfigRcPtr config;
    OCIO::ConstCPUProcessorRcPtr cpu;
    std::string source, input, display, view;
    float exposure_stops = 0.f;
};

DisplayTransform::DisplayTransform(const DisplayOptions &options) : impl_(new Impl) {
    Impl &m = *impl_;
    try {
        const char *env = options.use_env ? std::getenv("OCIO") : nullptr;
        if (!options.config_path.empty()) {
            m.config = OCIO::Config::CreateFromFile(options.config_path.c_str());
            m.source = options.config_path;
        } else if (env && *env) {
            m.config = OCIO::Config::CreateFromFile(env);
            m.source = std::string("$OCIO=") + env;
        } else {
            std::istringstream is(kEmbeddedConfig);
            m.config = OCIO::Config::CreateFromStream(is);
            m.source = "embedded";
        }
        m.input = options.input_colorspace.empty() ? std::string(OCIO::ROLE_SCENE_LINEAR)
                                                   : options.input_colorspace;
        m.display = options.display.empty() ? m.config->getDefaultDisplay() : options.display;
        m.view = options.view.empty() ? m.config->getDefaultView(m.display.c_str())
                                      : options.view;
        if (m.view.empty())
            throw std::runtime_error("display '" + m.display + "' has no view");
        m.exposure_stops = options.exposure_stops;
        OCIO::ConstProcessorRcPtr proc =
            m.config->getProcessor(m.input.c_str(), m.display.c_str(), m.view.c_str(),
                                   OCIO::TRANSFORM_DIR_FORWARD);
        m.cpu = proc->getDefaultCPUProcessor();
    } catch (const OCIO::Exception &e) {
        throw std::runtime_error(std::string("OpenColorIO: ") + e.what());
    }
}

DisplayTransform::~DisplayTransform() = default;
DisplayTransform::DisplayTransform(DisplayTransform &&) noexcept = default;
DisplayTransform &DisplayTransform::operator=(DisplayTransform &&) noexcept = default;

void DisplayTransform::apply(std::vector<float> &rgb) const {
    if (rgb.empty()) return;
    if (rgb.size() % 3 != 0)
        throw std::invalid_argument("DisplayTransform::apply: size is not a multiple of 3");
    if (impl_->exposure_stops != 0.f) {
        float scale = std::exp2(impl_->exposure_stops);
        for (float &v : rgb) v *= scale;
    }
    // One row of all the pixels: OCIO's packed descriptor wants width x height x channels.
    OCIO::PackedImageDesc desc(rgb.data(), long(rgb.size() / 3), 1, 3);
    impl_->cpu->apply(desc);
}

std::vector<uint8_t> DisplayTransform::to_8bit(const sampling::RgbImage &image) const {
    std::vector<float> rgb = image.data;
    apply(rgb);
    std::vector<uint8_t> out(rgb.size());
    for (size_t i = 0; i < rgb.size(); ++i) out[i] = quantize_8bit(rgb[i]);
    return out;
}

const std::string &DisplayTransform::display() const { return impl_->display; }
const std::string &DisplayTransform::view() const { return impl_->view; }
const std::string &DisplayTransform::config_source() const { return impl_->source; }

std::string DisplayTransform::describe() const {
    std::ostringstream os;
    os << "OCIO(config=" << impl_->source << ", input=" << impl_->input
       << ", display=" << impl_->display << ", view=" << impl_->view
       << ", exposure=" << impl_->exposure_stops << " stops)";
    return os.str();
}

uint8_t quantize_8bit(float v) {
    if (!(v > 0.f)) return 0;  // also NaN
    if (v >= 1.f) return 255;
    return uint8_t(v * 255.f + 0.5f);
}

void write_display_image(const std::string &path, const sampling::RgbImage &image,
                         const DisplayOptions &options) {
    DisplayTransform transform(options);
    write_rgb8(path, image.width, image.height, transform.to_8bit(image));
}

}  // namespace tessera
