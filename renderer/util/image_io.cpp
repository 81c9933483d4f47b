// Image files: multilayer EXR (OpenEXR), 8-bit display images (libpng), reading back
// (TGA, PFM and PNG natively, renderer/util/native_image.h; the rest with OpenImageIO through
// the image module, renderer/util/image_backend.h).
#include "renderer/util/image_io.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <Imath/half.h>
#include <fcntl.h>
#include <png.h>
#include <signal.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "renderer/util/limits.h"
#include "renderer/util/error.h"
#include "renderer/util/native_image.h"

namespace tessera {
namespace {

namespace fs = std::filesystem;
using imageio::ImageSpec;
using imageio::PixelType;

// The file format the image module should use: from the final path's extension, since the
// temporary's name ends in ".tmp-<pid>".
std::string format_for(const std::string &path) {
    std::string ext = fs::path(path).extension().string();
    if (ext.size() < 2) throw std::runtime_error(path + ": no file extension to pick a format");
    return ext.substr(1);
}

bool is_png(const std::string &path) {
    std::string ext = fs::path(path).extension().string();
    for (char &c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".png";
}

// Writes interleaved pixels through the image module; throws std::runtime_error with its
// message.
void write_with_module(const std::string &final_path, const std::string &file,
                       const ImageSpec &spec, PixelType data_type, const void *data) {
    std::string err;
    if (!imageio::backend().write(format_for(final_path), file, spec, data_type, data, &err))
        throw std::runtime_error(final_path + ": " + err);
}

Imf::Compression exr_compression(const std::string &path, const std::string &name) {
    static const std::pair<const char *, Imf::Compression> kNames[] = {
        {"none", Imf::NO_COMPRESSION},     {"rle", Imf::RLE_COMPRESSION},
        {"zips", Imf::ZIPS_COMPRESSION},   {"zip", Imf::ZIP_COMPRESSION},
        {"piz", Imf::PIZ_COMPRESSION},     {"pxr24", Imf::PXR24_COMPRESSION},
        {"b44", Imf::B44_COMPRESSION},     {"b44a", Imf::B44A_COMPRESSION},
        {"dwaa", Imf::DWAA_COMPRESSION},   {"dwab", Imf::DWAB_COMPRESSION}};
    for (const auto &[n, c] : kNames)
        if (name == n) return c;
    throw std::invalid_argument(path + ": unknown EXR compression \"" + name + "\"");
}

// libpng reports errors through longjmp; the message is kept for the exception thrown after.
struct PngErrors {
    std::string message;
};

void png_error_fn(png_structp png, png_const_charp msg) {
    static_cast<PngErrors *>(png_get_error_ptr(png))->message = msg ? msg : "libpng error";
    png_longjmp(png, 1);
}

void png_warning_fn(png_structp, png_const_charp) {}

// Writes an 8-bit RGB PNG with a "Software" text chunk. Returns "" or libpng's message.
// Only trivially destructible locals live between setjmp and the longjmp that may return
// to it.
std::string write_png_rgb8(const std::string &file, uint32_t width, uint32_t height,
                           const uint8_t *rgb, std::vector<png_bytep> &rows, PngErrors &errors) {
    FILE *fp = std::fopen(file.c_str(), "wb");
    if (!fp) return std::string("cannot open for writing: ") + std::strerror(errno);
    png_structp png =
        png_create_write_struct(PNG_LIBPNG_VER_STRING, &errors, png_error_fn, png_warning_fn);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, nullptr);
        std::fclose(fp);
        return "cannot create the PNG writer";
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        std::fclose(fp);
        return errors.message.empty() ? std::string("libpng error") : errors.message;
    }
    png_init_io(png, fp);
    png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    static char key[] = "Software", text[] = "Tessera";
    png_text t{};
    t.compression = PNG_TEXT_COMPRESSION_NONE;
    t.key = key;
    t.text = text;
    png_set_text(png, info, &t, 1);
    for (uint32_t y = 0; y < height; ++y)
        rows[y] = const_cast<png_bytep>(rgb + size_t(y) * width * 3);
    png_set_rows(png, info, rows.data());
    png_write_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
    png_destroy_write_struct(&png, &info);
    if (std::fclose(fp) != 0) return std::string("close failed: ") + std::strerror(errno);
    return "";
}

// All channels of subimage 0 as float, interleaved.
std::vector<float> read_all_channels(OpenedImage &img) {
    return img.read_floats(0, img.spec.nchannels);
}

int channel_index(const ImageSpec &spec, const std::string &name) {
    for (int i = 0; i < spec.nchannels; ++i)
        if (spec.channelnames[i] == name) return i;
    return -1;
}

}  // namespace

void OpenedImage::fail(const std::string &why) const {
    throw SceneError(loc, "cannot read " + name + ": " + why);
}

void OpenedImage::check_read_whole() const {
    check_image(spec.width, spec.height, spec.nchannels, name, loc);
}

std::vector<float> OpenedImage::read_floats(int chbegin, int chend) {
    std::vector<float> px(size_t(spec.width) * size_t(spec.height) * size_t(chend - chbegin));
    if (!in->read_image(chbegin, chend, PixelType::Float, px.data())) fail(in->geterror());
    return px;
}

OpenedImage open_image(const std::string &path, const FileLoc &loc, const std::string &what,
                       ImageRead read, bool unassociated_alpha) {
    OpenedImage img;
    img.loc = loc;
    img.name = loc.file == path ? what : what + " \"" + path + "\"";
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (!fs::exists(st)) img.fail("not found");
    if (fs::is_directory(st)) img.fail("is a directory, not a file");
    // A FIFO or device would block the reader or never end.
    if (!fs::is_regular_file(st)) img.fail("not a regular file");
    std::string err;
    // The formats read natively first (renderer/util/native_image.h); the image module for
    // the rest.
    switch (imageio::open_native(path, unassociated_alpha, &img.in, &err)) {
    case imageio::NativeOpen::Opened: break;
    case imageio::NativeOpen::Failed: img.fail(err);
    case imageio::NativeOpen::Declined:
        try {
            img.in = imageio::backend().open(path, unassociated_alpha, &err);
        } catch (const std::runtime_error &e) {
            img.fail(e.what());  // the module is missing
        }
    }
    if (!img.in) img.fail(err.empty() ? "not an image file OpenImageIO can read" : err);
    img.spec = img.in->spec();
    if (read == ImageRead::Whole)
        img.check_read_whole();
    else
        check_image_size(img.spec.width, img.spec.height, img.spec.nchannels, img.name, loc);
    return img;
}

std::string temp_path_for(const std::string &path) {
    return path + ".tmp-" + std::to_string(long(::getpid()));
}

namespace {

/// fsync of a file or directory by name; false (errno set) on failure.
bool sync_path(const std::string &path, bool directory) {
    int fd = ::open(path.c_str(), directory ? (O_RDONLY | O_DIRECTORY) : O_RDONLY);
    if (fd < 0) return false;
    bool ok = ::fsync(fd) == 0;
    int saved = errno;
    ::close(fd);
    errno = saved;
    return ok;
}

/// Removes "<name>.tmp-<pid>" files next to `path` whose process no longer runs (left by a
/// kill -9 or a crash). Best effort: errors are ignored.
void remove_stale_temporaries(const fs::path &path) {
    std::error_code ec;
    const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    const std::string prefix = path.filename().string() + ".tmp-";
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.rfind(prefix, 0) != 0) continue;
        const std::string digits = name.substr(prefix.size());
        if (digits.empty() || digits.size() > 9 ||
            digits.find_first_not_of("0123456789") != std::string::npos)
            continue;
        const long pid = std::stol(digits);
        if (pid == long(::getpid())) continue;
        if (::kill(pid_t(pid), 0) != 0 && errno == ESRCH) fs::remove(it->path(), ec);
    }
}

}  // namespace

void write_atomically(const std::string &path,
                      const std::function<void(const std::string &temp_path)> &write) {
    std::error_code ec;
    // Follow a link to what it names (the rename would otherwise replace the link itself).
    std::string target = path;
    if (fs::is_symlink(fs::symlink_status(path, ec))) {
        fs::path resolved = fs::weakly_canonical(path, ec);
        if (!ec) target = resolved.string();
    }
    fs::file_status st = fs::status(target, ec);
    if (fs::is_directory(st)) throw OutputError(path + ": is a directory");
    if (fs::exists(st) && !fs::is_regular_file(st)) {
        // A device or FIFO (/dev/stdout, /dev/null): no temporary can be renamed onto it.
        try {
            write(target);
        } catch (const std::exception &e) {
            throw OutputError(e.what());
        }
        return;
    }
    const std::string tmp = temp_path_for(target);
    try {
        write(tmp);
        // The data must be on disk before the rename makes it the file: otherwise a power cut
        // can leave the new name pointing at an empty or partial file.
        if (!sync_path(tmp, false))
            throw std::runtime_error(path + ": cannot sync to disk: " + std::strerror(errno));
        fs::rename(tmp, target);
    } catch (const std::exception &e) {
        fs::remove(tmp, ec);
        throw OutputError(e.what());
    }
    const fs::path t(target);
    sync_path(t.has_parent_path() ? t.parent_path().string() : ".", true);
    remove_stale_temporaries(t);
}

void check_output_path(const std::string &path, const std::string &what,
                       uint64_t expected_bytes) {
    auto fail = [&](const std::string &msg) {
        throw SceneError(FileLoc{path, 0}, what + ": " + msg);
    };
    std::error_code ec;
    fs::file_status st = fs::status(path, ec);
    if (fs::is_directory(st)) fail("is a directory, not a file");
    if (fs::exists(st) && !fs::is_regular_file(st)) return;  // a device or FIFO: written as is
    std::string target = path;
    if (fs::is_symlink(fs::symlink_status(path, ec))) {
        fs::path resolved = fs::weakly_canonical(path, ec);
        if (!ec) target = resolved.string();
    }
    const fs::path t(target);
    const fs::path dir = t.has_parent_path() ? t.parent_path() : fs::path(".");
    if (!fs::is_directory(dir, ec)) fail("the folder " + dir.string() + " does not exist");
    // A probe file: permissions, read-only file systems and a full inode table all show here,
    // for root too (which access(2) would not tell).
    const std::string probe = (dir / (".tessera-probe-" + std::to_string(long(::getpid())))).string();
    int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0600);
    if (fd < 0) fail(std::string("cannot create files in ") + dir.string() + ": " +
                     std::strerror(errno));
    ::close(fd);
    ::unlink(probe.c_str());
    struct statvfs vfs {};
    if (expected_bytes > 0 && ::statvfs(dir.c_str(), &vfs) == 0) {
        uint64_t free_bytes = uint64_t(vfs.f_bavail) * uint64_t(vfs.f_frsize);
        if (free_bytes < expected_bytes)
            warn(FileLoc{path, 0}, what + ": only " + format_bytes(free_bytes) + " free in " +
                                       dir.string() + "; the file may need up to " +
                                       format_bytes(expected_bytes));
    }
}

void write_text_atomically(const std::string &path, const std::string &text) {
    write_atomically(path, [&](const std::string &tmp) {
        std::ofstream f(tmp, std::ios::binary);
        f << text;
        if (!f) throw std::runtime_error(path + ": cannot write");
    });
}

void write_exr(const std::string &path, uint32_t width, uint32_t height,
               const std::vector<ImageLayer> &layers, const ExrWriteOptions &options) {
    if (width == 0 || height == 0) throw std::invalid_argument(path + ": empty image");
    const size_t pixels = size_t(width) * height;
    Imf::Header header(static_cast<int>(width), static_cast<int>(height));
    header.compression() = exr_compression(path, options.compression);
    header.insert("software", Imf::StringAttribute("Tessera"));
    // Each float channel a strided slice of its layer's data; a half channel a copy converted
    // by Imath's half (round to nearest even), since OpenEXR writes only the slice's own type.
    Imf::FrameBuffer fb;
    std::vector<std::vector<half>> halves;
    size_t nchannels = 0;
    for (const ImageLayer &layer : layers) {
        if (layer.channels.empty() || layer.data.size() != pixels * layer.channels.size())
            throw std::invalid_argument(path + ": layer '" + layer.name +
                                        "' has a data size that does not match its channels");
        const size_t nc = layer.channels.size();
        for (size_t c = 0; c < nc; ++c) {
            const std::string name =
                layer.name.empty() ? layer.channels[c] : layer.name + "." + layer.channels[c];
            if (header.channels().findChannel(name))
                throw std::invalid_argument(path + ": channel '" + name + "' given twice");
            if (options.half && !layer.always_float) {
                header.channels().insert(name, Imf::Channel(Imf::HALF));
                std::vector<half> &h = halves.emplace_back(pixels);
                for (size_t i = 0; i < pixels; ++i) h[i] = half(layer.data[i * nc + c]);
                fb.insert(name, Imf::Slice(Imf::HALF, reinterpret_cast<char *>(h.data()),
                                           sizeof(half), sizeof(half) * width));
            } else {
                header.channels().insert(name, Imf::Channel(Imf::FLOAT));
                fb.insert(name, Imf::Slice(Imf::FLOAT,
                                           const_cast<char *>(reinterpret_cast<const char *>(
                                               layer.data.data() + c)),
                                           sizeof(float) * nc, sizeof(float) * nc * width));
            }
            ++nchannels;
        }
    }
    if (nchannels == 0) throw std::invalid_argument(path + ": no channels to write");
    write_atomically(path, [&](const std::string &tmp) {
        try {
            const int threads = int(std::max(1u, std::thread::hardware_concurrency()));
            Imf::OutputFile file(tmp.c_str(), header, threads);
            file.setFrameBuffer(fb);
            file.writePixels(int(height));
        } catch (const std::exception &e) {
            throw std::runtime_error(path + ": write failed: " + e.what());
        }
    });
}

void write_film_exr(const std::string &path, const sampling::Film &film,
                    const ExrWriteOptions &options, std::vector<ImageLayer> extra) {
    std::vector<ImageLayer> layers;
    layers.push_back({"", {"R", "G", "B"}, film.beauty_rgb(), false});
    // Only the AOVs the film keeps (Film "gbuffer" or --aov).
    const sampling::AovSet aovs = film.aovs();
    if (aovs.has(sampling::Aov::Albedo))
        layers.push_back({"albedo", {"R", "G", "B"}, film.albedo_rgb(), false});
    if (aovs.has(sampling::Aov::Normal))
        layers.push_back({"normal", {"X", "Y", "Z"}, film.normal_xyz(), false});
    if (aovs.has(sampling::Aov::Depth))
        layers.push_back({"depth", {"Z"}, film.depth(), true});
    layers.push_back({"spp", {"Y"}, film.spp(), true});
    for (ImageLayer &l : extra) layers.push_back(std::move(l));
    write_exr(path, film.width(), film.height(), layers, options);
}

void write_rgb8(const std::string &path, uint32_t width, uint32_t height,
                const std::vector<uint8_t> &rgb) {
    if (width == 0 || height == 0 || rgb.size() != size_t(width) * height * 3)
        throw std::invalid_argument(path + ": 8-bit image size does not match its data");
    if (is_png(path)) {
        std::vector<png_bytep> rows(height);
        PngErrors errors;
        write_atomically(path, [&](const std::string &tmp) {
            const std::string err = write_png_rgb8(tmp, width, height, rgb.data(), rows, errors);
            if (!err.empty()) throw std::runtime_error(path + ": " + err);
        });
        return;
    }
    ImageSpec spec;
    spec.width = int(width);
    spec.height = int(height);
    spec.nchannels = 3;
    spec.format = PixelType::UInt8;
    spec.channelnames = {"R", "G", "B"};
    spec.attribute("Software", "Tessera");
    write_atomically(path, [&](const std::string &tmp) {
        write_with_module(path, tmp, spec, PixelType::UInt8, rgb.data());
    });
}

std::vector<std::string> image_channel_names(const std::string &path) {
    return open_image(path, FileLoc{path, 0}, "image", ImageRead::Streamed).spec.channelnames;
}

std::vector<float> read_image_channels(const std::string &path,
                                       const std::vector<std::string> &channel_names,
                                       uint32_t &width, uint32_t &height) {
    OpenedImage img = open_image(path, FileLoc{path, 0}, "image");
    std::vector<int> idx;
    for (const std::string &name : channel_names) {
        int i = channel_index(img.spec, name);
        if (i < 0) throw std::runtime_error(path + ": no channel '" + name + "'");
        idx.push_back(i);
    }
    std::vector<float> all = read_all_channels(img);
    width = uint32_t(img.spec.width);
    height = uint32_t(img.spec.height);
    const size_t pixels = size_t(width) * height, nc = size_t(img.spec.nchannels);
    std::vector<float> out(pixels * idx.size());
    for (size_t p = 0; p < pixels; ++p)
        for (size_t c = 0; c < idx.size(); ++c) out[p * idx.size() + c] = all[p * nc + idx[c]];
    return out;
}

sampling::RgbImage read_image_rgb(const std::string &path) {
    OpenedImage img = open_image(path, FileLoc{path, 0}, "image");
    const ImageSpec &s = img.spec;
    int ch[3] = {channel_index(s, "R"), channel_index(s, "G"), channel_index(s, "B")};
    if (ch[0] < 0 || ch[1] < 0 || ch[2] < 0) {
        // First layer that has R, G and B, in channel order.
        ch[0] = ch[1] = ch[2] = -1;
        for (int i = 0; i < s.nchannels && ch[0] < 0; ++i) {
            const std::string &n = s.channelnames[i];
            if (n.size() > 2 && n.compare(n.size() - 2, 2, ".R") == 0) {
                std::string layer = n.substr(0, n.size() - 2);
                int g = channel_index(s, layer + ".G"), b = channel_index(s, layer + ".B");
                if (g >= 0 && b >= 0) {
                    ch[0] = i;
                    ch[1] = g;
                    ch[2] = b;
                }
            }
        }
    }
    if (ch[0] < 0) {
        if (s.nchannels >= 3) {
            ch[0] = 0, ch[1] = 1, ch[2] = 2;
        } else {
            ch[0] = ch[1] = ch[2] = 0;
        }
    }
    std::vector<float> all = read_all_channels(img);
    sampling::RgbImage out(uint32_t(s.width), uint32_t(s.height));
    const size_t pixels = out.pixel_count(), nc = size_t(s.nchannels);
    for (size_t p = 0; p < pixels; ++p)
        for (int c = 0; c < 3; ++c) out.data[3 * p + c] = all[p * nc + ch[c]];
    return out;
}

}  // namespace tessera
