// Image readers of Tessera's own for the formats scenes use most: Truevision TGA (true-colour
// and grey, uncompressed or run-length encoded, 8, 24 and 32 bits per pixel), PFM, and PNG
// (libpng, which the executable links already for the display PNG). docs/ARCHITECTURE.md,
// "Image files".
//
// A scene whose images are all of these formats never opens the image module, whose
// OpenImageIO and ~270 libraries cost 0.3 s and ~120 MiB at the first image read (every
// textured Bitterli scene paid it), and TGA files are decoded from one read of the file instead
// of OpenImageIO's fread per pixel. Whatever these readers decline goes to the image module as
// before: other formats, TGA colour maps and 16-bit pixels, a TGA with alpha and a TGA 2.0
// extension area (whose alpha type OpenImageIO interprets), and any image with alpha whose
// colour is to be premultiplied (OpenImageIO associates it, in PNG through the file's gamma).
// What they read is what OpenImageIO reads, bit for bit: the header fields Tessera uses (size,
// channels and their names, pixel type, the colour space's linearity) and every pixel value
// (tests/renderer/test_native_image.cpp compares both on generated files of every variant and on
// every image of ../shared/scenes and the examples).
//
// Like OpenImageIO's readers, these read only the header when the file is opened, so the
// caller can check the size it claims before any pixel is allocated (open_image).
#pragma once

#include <memory>
#include <string>

#include "renderer/util/image_backend.h"

namespace tessera::imageio {

/// What open_native made of a file.
enum class NativeOpen {
    Declined,  ///< not a format (or variant) read here: use the image module
    Opened,    ///< `*out` is the open file
    Failed     ///< a file of a format read here, but malformed: `*error` says how
};

/// Opens the image file `path` with a native reader when its format is one (PNG and PFM by
/// their signatures, TGA by the extension ".tga", since TGA has no signature).
/// `unassociated_alpha`: colour as stored (OpenImageIO's oiio:UnassociatedAlpha); without it
/// an image with alpha is declined.
NativeOpen open_native(const std::string &path, bool unassociated_alpha,
                       std::unique_ptr<ImageInput> *out, std::string *error);

/// The same for a file's bytes in memory; `name` gives the extension (fuzzing, tests).
NativeOpen open_native_memory(std::string bytes, const std::string &name,
                              bool unassociated_alpha, std::unique_ptr<ImageInput> *out,
                              std::string *error);

}  // namespace tessera::imageio
