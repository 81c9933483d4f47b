// Image files: the film's linear multilayer EXR (OpenEXR), display PNGs (libpng), reading
// images back for scenes, references and `tessera diff` (OpenImageIO, through the module of
// renderer/util/image_backend.h), and atomic writes.
//
// EXR channel names (OpenEXR multilayer convention "layer.channel"; the beauty is the
// unnamed default layer, so every viewer shows it first):
//   R, G, B                    beauty: mean radiance, linear Rec.709/sRGB primaries
// the AOV layers, each only when the film keeps it (Film "gbuffer" or --aov; sampling/aov_set.h):
//   albedo.R, albedo.G, albedo.B    first-hit albedo, mean over samples that hit
//   normal.X, normal.Y, normal.Z    first-hit shading normal, world space, mean over hits
//   depth.Z                    first-hit distance along the primary ray, scene units, +inf: no hit
//   spp.Y                      samples taken per pixel
// Colour channels may be written as half (option); depth.Z and spp.Y are always 32-bit float
// (half keeps only 11 significant bits). Compression: ZIP by default.
//
// Atomic writes: every writer here writes "<path>.tmp-<pid>" in the target's directory, flushes
// it to disk (fsync), and renames it onto <path> (std::filesystem::rename, atomic on POSIX
// within one filesystem), then syncs the directory. On any failure the temporary is removed
// and std::runtime_error is thrown, so <path> is either the old file or the complete new one,
// never a partial image -- also after a kill -9 or a power cut. A temporary left behind by a
// killed process (its pid no longer running) is removed by the next successful write of the
// same path. Paths that are not regular files are handled as what they are: a symbolic link
// is followed (the file it names is replaced), a device or FIFO (/dev/stdout, /dev/null) is
// written directly, and a directory is an error.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "renderer/util/error.h"
#include "renderer/util/image_backend.h"
#include "sampling/film.h"
#include "sampling/image_metrics.h"

namespace tessera {

/// An output file could not be written (disk full, I/O error, permissions changed during the
/// render). The CLI reports it as "tessera: cannot write output: ..." with exit code 1.
class OutputError : public std::runtime_error {
  public:
    explicit OutputError(const std::string &msg) : std::runtime_error(msg) {}
};

/// A group of channels of one layer, interleaved per pixel.
struct ImageLayer {
    std::string name;                   ///< layer name; "" for the default layer
    std::vector<std::string> channels;  ///< channel names inside the layer, e.g. {"R","G","B"}
    std::vector<float> data;            ///< channels.size() floats per pixel, row-major
    bool always_float = false;          ///< keep 32-bit float even when writing half
};

/// EXR writer settings.
struct ExrWriteOptions {
    bool half = false;                 ///< colour channels as 16-bit half instead of float
    std::string compression = "zip";   ///< OpenEXR compression ("none", "zip", "piz", ...)
};

/// Writes the layers of a width x height image to a multichannel EXR at `path`, atomically
/// (see the file comment). Throws std::invalid_argument for malformed layers and
/// std::runtime_error when the file cannot be written. Thread-safe for different paths.
void write_exr(const std::string &path, uint32_t width, uint32_t height,
               const std::vector<ImageLayer> &layers, const ExrWriteOptions &options = {});

/// Writes the film's beauty, the AOV layers it keeps (albedo, normal, depth; see
/// Film::aovs()) and spp (names in the file comment),
/// then the `extra` layers (e.g. the adaptive sampler's error estimate). Not thread-safe against
/// concurrent add_sample on the film.
void write_film_exr(const std::string &path, const sampling::Film &film,
                    const ExrWriteOptions &options = {}, std::vector<ImageLayer> extra = {});

/// Writes an 8-bit RGB image (3 bytes per pixel, row-major) in the format given by the path's
/// extension, atomically: .png with libpng, any other through OpenImageIO (the image module).
/// Throws std::runtime_error on failure.
void write_rgb8(const std::string &path, uint32_t width, uint32_t height,
                const std::vector<uint8_t> &rgb);

/// How much of an image its reader takes into memory: open_image checks the memory budget
/// only for images read whole (a tiled, mipmapped texture is streamed by OIIO's TextureSystem).
enum class ImageRead { Whole, Streamed };

/// An image file opened for reading by open_image, its header checked. `name` is how messages
/// name it: `what "path"`, or only `what` when the location already is the file.
struct OpenedImage {
    std::unique_ptr<imageio::ImageInput> in;
    imageio::ImageSpec spec;  ///< subimage 0, MIP level 0
    FileLoc loc;
    std::string name;

    /// Throws SceneError(loc, "cannot read <name>: <why>").
    [[noreturn]] void fail(const std::string &why) const;
    /// The memory check of an image read whole (check_image), for one opened as Streamed that
    /// is read whole after all.
    void check_read_whole() const;
    /// Channels [chbegin, chend) of every pixel as float, interleaved, row-major.
    std::vector<float> read_floats(int chbegin, int chend);
};

/// The one way a scene, a reference or a checkpoint opens an image file: checks that `path`
/// exists and is a regular file, that OpenImageIO can read it, that its width, height and
/// channels are above 0 and its size within kMaxImagePixels (renderer/util/limits.h) and, for
/// ImageRead::Whole, that width x height x channels floats fit the memory budget -- all before
/// any pixel is allocated. `what` names the image in messages ("image", "normalmap",
/// "checkpoint"); `unassociated_alpha`: colour as stored, not premultiplied by alpha. Throws
/// SceneError "file:line: cannot read what \"path\": why", or the limit's message.
OpenedImage open_image(const std::string &path, const FileLoc &loc, const std::string &what,
                       ImageRead read = ImageRead::Whole, bool unassociated_alpha = false);

/// Reads the colour of an image file as linear float RGB: channels R, G, B when present, else
/// the first layer with channels "<layer>.R/G/B", else a single channel replicated to grey,
/// else the first three channels. Integer formats are normalised to [0, 1] without any
/// transfer-function decoding. Throws std::runtime_error when the file cannot be read.
sampling::RgbImage read_image_rgb(const std::string &path);

/// Reads the named channels (full names, e.g. "depth.Z") of an image file as floats
/// interleaved in the order given; sets width and height. Throws std::runtime_error when the
/// file cannot be read or a channel is missing.
std::vector<float> read_image_channels(const std::string &path,
                                       const std::vector<std::string> &channel_names,
                                       uint32_t &width, uint32_t &height);

/// The channel names of an image file, in the reader's order. Throws std::runtime_error.
std::vector<std::string> image_channel_names(const std::string &path);

/// The temporary name an atomic write of `path` uses: "<path>.tmp-<pid>".
std::string temp_path_for(const std::string &path);

/// Runs `write(temp_path)`, syncs the temporary to disk and renames it onto `path`; removes
/// the temporary and rethrows (as OutputError) if `write` throws or the sync or rename
/// fails. See the file comment for links, devices and directories.
void write_atomically(const std::string &path,
                      const std::function<void(const std::string &temp_path)> &write);

/// Writes `text` to `path` atomically (write_atomically). Throws std::runtime_error.
void write_text_atomically(const std::string &path, const std::string &text);

/// Checks before a long render that `path` will be writable by write_atomically: its folder
/// exists and accepts a new file (a probe file is created there and removed), and `path` is
/// not a directory. Devices and FIFOs are accepted as they are. `what` names the output in
/// messages ("--stats", "the checkpoint"). Throws SceneError("path:0: message"). When the
/// folder's free space is below `expected_bytes`, prints a warning (compression may still
/// make the file fit). Not a guarantee -- the disk can fill up later -- but it turns the
/// mistakes that can be seen at the start into an error at the start.
void check_output_path(const std::string &path, const std::string &what,
                       uint64_t expected_bytes = 0);

}  // namespace tessera
