// The image-file back end: OpenImageIO behind an interface of Tessera's own, in a module loaded
// on first use (docs/ARCHITECTURE.md, "Image files" under "Outputs people use").
//
// Debian's OpenImageIO links some 270 shared libraries (OpenCV, GDAL, DCMTK, FFmpeg, ...):
// loading and relocating them takes a third of a second, every time a process starts. Most
// renders read no image at all, and the film's EXR and display PNG are written with OpenEXR
// and libpng directly (renderer/util/image_io.cpp), so the executable does not link
// OpenImageIO: image reading, other output formats, checkpoints and the TextureSystem go
// through this interface, whose implementation (renderer/util/oiio_backend.cpp) is the module
// libtessera_oiio.so, opened with dlopen the first time backend() is called.
//
// The types mirror the parts of OpenImageIO's ImageSpec, ImageInput, ImageOutput and
// TextureSystem that Tessera uses; nothing here throws across the module boundary (errors come
// back as strings).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace tessera::imageio {

/// A pixel component's type in a file or a buffer (OIIO::TypeDesc's base types).
enum class PixelType : uint8_t {
    Unknown,  ///< in a read or write: each channel in its own format (channelformats)
    UInt8, Int8, UInt16, Int16, UInt32, Int32, UInt64, Int64, Half, Float, Double
};

/// True for Half, Float and Double.
constexpr bool is_float(PixelType t) {
    return t == PixelType::Half || t == PixelType::Float || t == PixelType::Double;
}

/// A named metadata value of an image: a string or an int.
struct Attribute {
    std::string name;
    std::string text;  ///< the value of a string attribute
    int number = 0;    ///< the value of an int attribute
    bool is_int = false;
};

/// An image's header (subimage 0, MIP level 0).
struct ImageSpec {
    int width = 0, height = 0, nchannels = 0;
    PixelType format = PixelType::Float;   ///< the channels' type (the first's, when mixed)
    std::vector<PixelType> channelformats;  ///< one per channel when they differ, else empty
    std::vector<std::string> channelnames;
    int tile_width = 0;      ///< 0 for a scanline image
    int mip_levels = 1;      ///< MIP levels of subimage 0 (read only)
    std::string format_name; ///< the reader's format, e.g. "openexr", "png" (read only)
    std::vector<Attribute> attributes;

    /// The value of a string attribute, or `fallback` when there is none of that name.
    std::string get_string_attribute(const std::string &name,
                                     const std::string &fallback = "") const {
        for (const Attribute &a : attributes)
            if (a.name == name && !a.is_int) return a.text;
        return fallback;
    }
    /// The value of an int attribute, or `fallback`.
    int get_int_attribute(const std::string &name, int fallback = 0) const {
        for (const Attribute &a : attributes)
            if (a.name == name && a.is_int) return a.number;
        return fallback;
    }
    void attribute(const std::string &name, const std::string &text) {
        attributes.push_back({name, text, 0, false});
    }
    void attribute(const std::string &name, int number) {
        attributes.push_back({name, "", number, true});
    }
};

/// An image file open for reading.
class ImageInput {
  public:
    virtual ~ImageInput() = default;
    const ImageSpec &spec() const { return spec_; }
    /// Channels [chbegin, chend) of every pixel of subimage 0, MIP level 0, interleaved,
    /// row-major, converted to `type` (Unknown: in each channel's own format, packed).
    virtual bool read_image(int chbegin, int chend, PixelType type, void *data) = 0;
    /// The message of the last failure.
    virtual std::string geterror() = 0;

  protected:
    ImageSpec spec_;
};

/// How a TextureSystem lookup filters (OIIO::TextureOpt's fields Tessera sets).
struct TextureOptions {
    enum class Wrap : uint8_t { Black, Clamp, Periodic };
    enum class Mip : uint8_t { OneLevel, Trilinear, Aniso };
    enum class Interp : uint8_t { Closest, Bilinear };
    Wrap swrap = Wrap::Periodic, twrap = Wrap::Periodic;
    Mip mip = Mip::OneLevel;
    Interp interp = Interp::Bilinear;
    int anisotropic = 8;
};

/// A private OpenImageIO TextureSystem: tiled, mipmapped files streamed through its cache.
class TextureSystem {
  public:
    virtual ~TextureSystem() = default;
    /// The handle of a texture file and its channel count; null (and `*error` set) when it
    /// cannot be opened.
    virtual void *handle(const std::string &path, int *nchannels, std::string *error) = 0;
    /// A filtered lookup of `nchannels` channels at (s, t), t growing down from the first row;
    /// false (and `out` untouched) on failure. Thread-safe.
    virtual bool texture(void *handle, const TextureOptions &opt, float s, float t, float dsdx,
                         float dtdx, float dsdy, float dtdy, int nchannels,
                         float *out) const = 0;
};

/// The back end's entry points.
class Backend {
  public:
    virtual ~Backend() = default;
    /// Opens `path` for reading; null with `*error` set when it cannot be read.
    /// `unassociated_alpha`: colour not premultiplied by alpha (OIIO's oiio:UnassociatedAlpha).
    virtual std::unique_ptr<ImageInput> open(const std::string &path, bool unassociated_alpha,
                                             std::string *error) const = 0;
    /// Writes `spec.nchannels` interleaved channels of `data_type` (Unknown: the spec's own
    /// per-channel formats) to `file` in the format named `format` ("exr", "png", "tif", ...).
    virtual bool write(const std::string &format, const std::string &file, const ImageSpec &spec,
                       PixelType data_type, const void *data, std::string *error) const = 0;
    /// Writes float pixels as a tiled (64x64), box-filtered, mipmapped texture file, stored as
    /// `stored` (Half or Float).
    virtual bool make_texture(const std::string &file, int width, int height, int nchannels,
                              const float *pixels, PixelType stored,
                              std::string *error) const = 0;
    /// A new private TextureSystem whose cache holds at most `max_memory_mb`.
    virtual std::unique_ptr<TextureSystem> texture_system(float max_memory_mb) const = 0;
};

/// The back end, its module loaded on the first call (thread-safe). Looks for
/// libtessera_oiio.so in $TESSERA_IMAGE_MODULE (a file) when set, next to the executable,
/// in <executable>/../lib/tessera, and in the build tree. Throws std::runtime_error naming
/// where it looked when the module cannot be loaded.
const Backend &backend();

/// The entry point the module exports (extern "C", so that dlsym finds it by this name).
using BackendEntry = const Backend *(*)();
inline constexpr const char *kBackendEntryName = "tessera_image_backend_v1";

}  // namespace tessera::imageio
