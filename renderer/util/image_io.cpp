// Image files through OpenImageIO: multilayer EXR, 8-bit display images, reading back.
#include "renderer/util/image_io.h"

#include <OpenImageIO/imageio.h>
#include <fcntl.h>
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

#include "renderer/util/limits.h"
#include "renderer/util/error.h"

namespace tessera {
namespace {

namespace fs = std::filesystem;
using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

// The file format OIIO should use: from the final path's extension, since the temporary's
// name ends in ".tmp-<pid>".
std::string format_for(const std::string &path) {
    std::string ext = fs::path(path).extension().string();
    if (ext.size() < 2) throw std::runtime_error(path + ": no file extension to pick a format");
    return ext.substr(1);
}

// Writes interleaved pixels with OIIO; throws std::runtime_error with OIIO's message.
void write_with_oiio(const std::string &final_path, const std::string &file, const ImageSpec &spec,
                     TypeDesc data_type, const void *data) {
    auto out = ImageOutput::create(format_for(final_path));
    if (!out)
        throw std::runtime_error(final_path + ": no image writer: " + OIIO::geterror());
    if (!out->open(file, spec))
        throw std::runtime_error(final_path + ": cannot open for writing: " + out->geterror());
    if (!out->write_image(data_type, data)) {
        std::string err = out->geterror();
        out->close();
        throw std::runtime_error(final_path + ": write failed: " + err);
    }
    if (!out->close())
        throw std::runtime_error(final_path + ": close failed: " + out->geterror());
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
    if (!in->read_image(0, 0, chbegin, chend, TypeDesc::FLOAT, px.data())) fail(in->geterror());
    return px;
}

OpenedImage open_image(const std::string &path, const FileLoc &loc, const std::string &what,
                       ImageRead read) {
    OpenedImage img;
    img.loc = loc;
    img.name = loc.file == path ? what : what + " \"" + path + "\"";
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (!fs::exists(st)) img.fail("not found");
    if (fs::is_directory(st)) img.fail("is a directory, not a file");
    // A FIFO or device would block the reader or never end.
    if (!fs::is_regular_file(st)) img.fail("not a regular file");
    img.in = ImageInput::open(path);
    if (!img.in) {
        const std::string err = OIIO::geterror();
        img.fail(err.empty() ? "not an image file OpenImageIO can read" : err);
    }
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
    ImageSpec spec(int(width), int(height), 0, TypeDesc::FLOAT);
    spec.channelnames.clear();
    std::vector<TypeDesc> formats;
    for (const ImageLayer &layer : layers) {
        if (layer.channels.empty() || layer.data.size() != pixels * layer.channels.size())
            throw std::invalid_argument(path + ": layer '" + layer.name +
                                        "' has a data size that does not match its channels");
        for (const std::string &c : layer.channels) {
            spec.channelnames.push_back(layer.name.empty() ? c : layer.name + "." + c);
            formats.push_back(options.half && !layer.always_float ? TypeDesc::HALF
                                                                  : TypeDesc::FLOAT);
        }
    }
    spec.nchannels = int(spec.channelnames.size());
    if (spec.nchannels == 0) throw std::invalid_argument(path + ": no channels to write");
    bool mixed = std::any_of(formats.begin(), formats.end(),
                             [&](TypeDesc t) { return t != formats.front(); });
    spec.format = formats.front();
    if (mixed) spec.channelformats = formats;
    spec.alpha_channel = -1;
    spec.z_channel = -1;
    spec.attribute("compression", options.compression);
    spec.attribute("Software", "Tessera");

    // Interleave every layer into one float buffer; OIIO converts to half where asked.
    std::vector<float> interleaved(pixels * size_t(spec.nchannels));
    size_t offset = 0;
    for (const ImageLayer &layer : layers) {
        size_t nc = layer.channels.size();
        for (size_t i = 0; i < pixels; ++i)
            for (size_t c = 0; c < nc; ++c)
                interleaved[i * spec.nchannels + offset + c] = layer.data[i * nc + c];
        offset += nc;
    }
    write_atomically(path, [&](const std::string &tmp) {
        write_with_oiio(path, tmp, spec, TypeDesc::FLOAT, interleaved.data());
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
    ImageSpec spec(int(width), int(height), 3, TypeDesc::UINT8);
    spec.attribute("Software", "Tessera");
    write_atomically(path, [&](const std::string &tmp) {
        write_with_oiio(path, tmp, spec, TypeDesc::UINT8, rgb.data());
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
