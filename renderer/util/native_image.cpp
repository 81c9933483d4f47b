// Native TGA, PFM and PNG readers (renderer/util/native_image.h).
#include "renderer/util/native_image.h"

#include <png.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <vector>

namespace tessera::imageio {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// The bytes of a file: the first kHeadBytes at open, all of them when the pixels are read.

constexpr size_t kHeadBytes = 4096;

class Source {
  public:
    /// A file on disk; false (and `*error`) when it cannot be read.
    bool open_file(const std::string &path, std::string *error) {
        path_ = path;
        std::error_code ec;
        const uintmax_t n = fs::file_size(path, ec);
        if (ec) return fail(error, "cannot read: " + ec.message());
        size_ = size_t(n);
        return read(std::min(size_, kHeadBytes), error);
    }
    /// Bytes in memory, all of them already there.
    void open_memory(std::string bytes) {
        bytes_ = std::move(bytes);
        size_ = bytes_.size();
        whole_ = true;
    }
    /// The file's size in bytes.
    size_t size() const { return size_; }
    /// The bytes read so far (the head, or everything after load_all).
    const std::string &bytes() const { return bytes_; }
    /// Reads the whole file; false (and `*error`) on failure or when it changed size.
    bool load_all(std::string *error) { return whole_ || read(size_, error); }

  private:
    bool read(size_t n, std::string *error) {
        std::ifstream f(path_, std::ios::binary);
        if (!f) return fail(error, std::string("cannot open: ") + std::strerror(errno));
        bytes_.resize(n);
        f.read(bytes_.data(), std::streamsize(n));
        if (size_t(f.gcount()) != n) return fail(error, "the file changed while it was read");
        whole_ = n == size_;
        return true;
    }
    static bool fail(std::string *error, const std::string &msg) {
        *error = msg;
        return false;
    }

    std::string path_, bytes_;
    size_t size_ = 0;
    bool whole_ = false;
};

uint16_t le16(const unsigned char *p) { return uint16_t(p[0] | (p[1] << 8)); }

size_t bytes_of(PixelType t) {
    switch (t) {
    case PixelType::UInt8: return 1;
    case PixelType::UInt16: return 2;
    case PixelType::Float: return 4;
    default: return 0;
    }
}

/// An image whose pixels a subclass decodes whole, in its native type, into `pixels_`
/// (interleaved, top row first); read_image converts the channels asked for.
class DecodedInput : public ImageInput {
  public:
    bool read_image(int chbegin, int chend, PixelType type, void *data) override {
        const int nc = spec_.nchannels;
        if (chbegin < 0 || chend > nc || chbegin >= chend) return fail("channel range");
        if (pixels_.empty() && !decode()) return false;
        if (type == PixelType::Unknown) type = spec_.format;
        const size_t n = size_t(spec_.width) * size_t(spec_.height);
        const int k = chend - chbegin;
        const PixelType from = spec_.format;
        if (type == from) {
            const size_t b = bytes_of(from);
            auto *dst = static_cast<unsigned char *>(data);
            for (size_t i = 0; i < n; ++i)
                std::memcpy(dst + i * size_t(k) * b, &pixels_[(i * size_t(nc) + chbegin) * b],
                            size_t(k) * b);
            return true;
        }
        if (type != PixelType::Float)
            return fail("the native readers convert to float only");
        float *dst = static_cast<float *>(data);
        // Integers to [0, 1] as OpenImageIO converts them: the value times 1 / max.
        if (from == PixelType::UInt8) {
            constexpr float scale = 1.f / 255.f;
            for (size_t i = 0; i < n; ++i)
                for (int c = 0; c < k; ++c)
                    dst[i * size_t(k) + c] = float(pixels_[i * size_t(nc) + chbegin + c]) * scale;
        } else {  // UInt16
            constexpr float scale = 1.f / 65535.f;
            const auto *src = reinterpret_cast<const uint16_t *>(pixels_.data());
            for (size_t i = 0; i < n; ++i)
                for (int c = 0; c < k; ++c)
                    dst[i * size_t(k) + c] = float(src[i * size_t(nc) + chbegin + c]) * scale;
        }
        return true;
    }
    std::string geterror() override { return error_; }

  protected:
    /// Fills pixels_; false (and error_) on failure.
    virtual bool decode() = 0;
    bool fail(const std::string &msg) {
        error_ = msg;
        return false;
    }
    /// Allocates pixels_ for the whole image.
    void allocate() {
        pixels_.assign(size_t(spec_.width) * size_t(spec_.height) * size_t(spec_.nchannels) *
                           bytes_of(spec_.format),
                       0);
    }

    Source src_;
    std::vector<unsigned char> pixels_;
    std::string error_;
};

/// OpenImageIO's default names for n channels: R, G, B, A, then channel4, channel5, ...;
/// one channel is Y, and its readers name grey + alpha Y, A.
std::vector<std::string> channel_names(int n, bool grey) {
    if (grey) return n == 1 ? std::vector<std::string>{"Y"} : std::vector<std::string>{"Y", "A"};
    std::vector<std::string> names;
    static const char *kRgba[] = {"R", "G", "B", "A"};
    for (int i = 0; i < n; ++i) names.emplace_back(kRgba[i]);
    return names;
}

// ---------------------------------------------------------------------------------------------
// TGA (Truevision TGA File Format Specification 2.0): an 18-byte header, an image ID, a colour
// map (skipped for true-colour images), then the pixels, BGR(A) or grey, rows from the bottom
// unless bit 5 of the descriptor is set, columns from the left unless bit 4 is.

constexpr const char kTgaSignature[] = "TRUEVISION-XFILE.";

class TgaInput final : public DecodedInput {
  public:
    /// Reads the header from `src`'s head.
    NativeOpen open(Source src, bool unassociated_alpha, std::string *error) {
        src_ = std::move(src);
        const std::string &b = src_.bytes();
        if (b.size() < 18) return failed(error, "truncated: no TGA header");
        const auto *h = reinterpret_cast<const unsigned char *>(b.data());
        const int id_length = h[0], cmap_type = h[1], type = h[2];
        const int cmap_length = le16(h + 5), cmap_bits = h[7];
        const int width = le16(h + 12), height = le16(h + 14), bpp = h[16];
        desc_ = h[17];
        if (cmap_type > 1) return failed(error, "not a TGA file (colour map type " +
                                                    std::to_string(cmap_type) + ")");
        if (type == 1 || type == 9) return NativeOpen::Declined;  // colour-mapped
        if (type != 2 && type != 3 && type != 10 && type != 11)
            return failed(error, "not a TGA file (image type " + std::to_string(type) + ")");
        rle_ = type >= 9;
        const bool grey = type == 3 || type == 11;
        // Grey + alpha (OpenImageIO names the channels R, G) and 5-5-5 colour (which it
        // expands) are left to OpenImageIO.
        if (bpp == 15 || bpp == 16) return NativeOpen::Declined;
        if (grey && bpp != 8)
            return failed(error, "grey TGA with " + std::to_string(bpp) + " bits per pixel");
        if (!grey && bpp != 24 && bpp != 32)
            return failed(error, "TGA with " + std::to_string(bpp) + " bits per pixel");
        if (width == 0 || height == 0) return failed(error, "empty image (width or height 0)");
        bytes_per_pixel_ = bpp / 8;
        const int nc = grey ? 1 : bytes_per_pixel_ == 4 ? 4 : 3;
        const bool alpha = nc == 4;
        if (alpha && (!unassociated_alpha || (desc_ & 0x0f) == 0 || has_extension_area()))
            return NativeOpen::Declined;
        data_offset_ = 18 + size_t(id_length) +
                       (cmap_type == 1 ? size_t(cmap_length) * size_t((cmap_bits + 7) / 8) : 0);
        if (!rle_ && src_.size() < data_offset_ + size_t(width) * height * bytes_per_pixel_)
            return failed(error, "truncated: " + std::to_string(width) + "x" +
                                     std::to_string(height) + " pixels need " +
                                     std::to_string(data_offset_ + size_t(width) * height *
                                                                       bytes_per_pixel_) +
                                     " bytes, the file has " + std::to_string(src_.size()));
        spec_.width = width;
        spec_.height = height;
        spec_.nchannels = nc;
        spec_.format = PixelType::UInt8;
        spec_.channelnames = channel_names(nc, grey);
        spec_.format_name = "targa";
        spec_.attribute("oiio:ColorSpace", "sRGB");
        return NativeOpen::Opened;
    }

  private:
    static NativeOpen failed(std::string *error, const std::string &msg) {
        *error = msg;
        return NativeOpen::Failed;
    }
    /// True when a TGA 2.0 footer names an extension area (which may say how to read alpha).
    bool has_extension_area() {
        std::string err;
        if (src_.size() < 18 + 26 || !src_.load_all(&err)) return false;
        const std::string &b = src_.bytes();
        const char *footer = b.data() + b.size() - 26;
        if (std::memcmp(footer + 8, kTgaSignature, sizeof(kTgaSignature)) != 0) return false;
        const auto *f = reinterpret_cast<const unsigned char *>(footer);
        return (f[0] | f[1] | f[2] | f[3]) != 0;
    }

    bool decode() override {
        if (!src_.load_all(&error_)) return false;
        const std::string &b = src_.bytes();
        const auto *p = reinterpret_cast<const unsigned char *>(b.data()) + data_offset_;
        const unsigned char *end = reinterpret_cast<const unsigned char *>(b.data()) + b.size();
        const size_t w = size_t(spec_.width), h = size_t(spec_.height);
        const int bpp = bytes_per_pixel_, nc = spec_.nchannels;
        allocate();
        // File order: pixel i of the file is row i / w (from the bottom unless top-origin),
        // column i % w (from the right when right-origin).
        const bool top = desc_ & 0x20, right = desc_ & 0x10;
        auto store = [&](size_t i, const unsigned char *px) {
            const size_t fy = i / w, fx = i % w;
            const size_t y = top ? fy : h - 1 - fy, x = right ? w - 1 - fx : fx;
            unsigned char *dst = &pixels_[(y * w + x) * size_t(nc)];
            if (nc == 1) {
                dst[0] = px[0];
            } else {  // BGR(A) -> RGB(A)
                dst[0] = px[2];
                dst[1] = px[1];
                dst[2] = px[0];
                if (nc == 4) dst[3] = px[3];
            }
        };
        const size_t n = w * h;
        if (!rle_) {
            for (size_t i = 0; i < n; ++i) store(i, p + i * size_t(bpp));
            return true;
        }
        // Run-length packets: a count byte (high bit: one pixel repeated, else literal
        // pixels) for 1-128 pixels; packets may run across rows.
        size_t i = 0;
        while (i < n) {
            if (p >= end) return fail("truncated run-length data");
            const int head = *p++;
            const size_t count = std::min(size_t(head & 0x7f) + 1, n - i);
            if (head & 0x80) {
                if (end - p < bpp) return fail("truncated run-length data");
                for (size_t k = 0; k < count; ++k) store(i + k, p);
                p += bpp;
            } else {
                if (size_t(end - p) < count * size_t(bpp))
                    return fail("truncated run-length data");
                for (size_t k = 0; k < count; ++k) store(i + k, p + k * size_t(bpp));
                p += count * size_t(bpp);
            }
            i += count;
        }
        return true;
    }

    size_t data_offset_ = 0;
    int bytes_per_pixel_ = 0;
    int desc_ = 0;
    bool rle_ = false;
};

// ---------------------------------------------------------------------------------------------
// PFM (Portable Float Map): "PF" (RGB) or "Pf" (grey), width, height and a scale whose sign
// gives the byte order (negative: little-endian), each followed by white space, then 32-bit
// floats, rows from the bottom. The values are multiplied by |scale|, as pbrt-v4 and
// OpenImageIO read them.

class PfmInput final : public DecodedInput {
  public:
    NativeOpen open(Source src, std::string *error) {
        src_ = std::move(src);
        const std::string &b = src_.bytes();
        size_t pos = 2;
        const int nc = b[1] == 'F' ? 3 : 1;
        // One header token after white space; false when there is none.
        auto token = [&](std::string *out) {
            if (pos >= b.size() || !std::isspace(static_cast<unsigned char>(b[pos]))) return false;
            while (pos < b.size() && std::isspace(static_cast<unsigned char>(b[pos]))) ++pos;
            const size_t start = pos;
            while (pos < b.size() && !std::isspace(static_cast<unsigned char>(b[pos])) &&
                   pos - start < 64)
                ++pos;
            *out = b.substr(start, pos - start);
            return !out->empty() && pos < b.size();
        };
        std::string ws, hs, ss;
        if (!token(&ws) || !token(&hs) || !token(&ss))
            return failed(error, "not a PFM header (PF or Pf, width, height, scale)");
        long long width = 0, height = 0;
        double scale = 0;
        if (!parse_int(ws, &width) || !parse_int(hs, &height) || width <= 0 || height <= 0)
            return failed(error, "PFM width and height must be positive integers (\"" + ws +
                                     "\", \"" + hs + "\")");
        if (width > std::numeric_limits<int>::max() || height > std::numeric_limits<int>::max())
            return failed(error, "PFM size " + ws + "x" + hs + " is too large");
        char *endp = nullptr;
        errno = 0;
        scale = std::strtod(ss.c_str(), &endp);
        if (endp != ss.c_str() + ss.size() || errno != 0 || scale == 0 || !std::isfinite(scale))
            return failed(error, "PFM scale \"" + ss + "\" must be a non-zero number");
        if (!std::isspace(static_cast<unsigned char>(b[pos])))
            return failed(error, "PFM scale \"" + ss + "\" must be a non-zero number");
        little_endian_ = scale < 0;
        scale_ = float(std::abs(scale));
        data_offset_ = pos + 1;  // one white-space character ends the header
        const size_t need = size_t(width) * size_t(height) * size_t(nc) * 4;
        if (need / size_t(width) / size_t(height) != size_t(nc) * 4 ||
            src_.size() < data_offset_ + need)
            return failed(error, "truncated: " + ws + "x" + hs + " pixels need " +
                                     std::to_string(data_offset_ + need) +
                                     " bytes, the file has " + std::to_string(src_.size()));
        spec_.width = int(width);
        spec_.height = int(height);
        spec_.nchannels = nc;
        spec_.format = PixelType::Float;
        spec_.channelnames = channel_names(nc, nc == 1);
        spec_.format_name = "pnm";  // OpenImageIO reads PFM with its PNM reader
        return NativeOpen::Opened;
    }

  private:
    static NativeOpen failed(std::string *error, const std::string &msg) {
        *error = msg;
        return NativeOpen::Failed;
    }
    static bool parse_int(const std::string &s, long long *v) {
        if (s.empty() || s.size() > 18) return false;
        for (char c : s)
            if (c < '0' || c > '9') return false;
        *v = std::stoll(s);
        return true;
    }
    bool decode() override {
        if (!src_.load_all(&error_)) return false;
        allocate();
        const size_t w = size_t(spec_.width), h = size_t(spec_.height);
        const size_t row = w * size_t(spec_.nchannels) * 4;
        const char *data = src_.bytes().data() + data_offset_;
        constexpr bool host_little = std::endian::native == std::endian::little;
        for (size_t y = 0; y < h; ++y) {
            unsigned char *dst = &pixels_[(h - 1 - y) * row];
            std::memcpy(dst, data + y * row, row);
            if (little_endian_ != host_little)
                for (size_t i = 0; i < row; i += 4) {
                    std::swap(dst[i], dst[i + 3]);
                    std::swap(dst[i + 1], dst[i + 2]);
                }
        }
        if (scale_ != 1.f) {
            float *v = reinterpret_cast<float *>(pixels_.data());
            for (size_t i = 0, n = pixels_.size() / 4; i < n; ++i) v[i] *= scale_;
        }
        return true;
    }

    size_t data_offset_ = 0;
    bool little_endian_ = true;
    float scale_ = 1.f;
};

// ---------------------------------------------------------------------------------------------
// PNG through libpng: palettes, grey below 8 bits and tRNS expanded, 16-bit samples in host
// order, interlacing undone -- grey, grey + alpha, RGB or RGBA of 8 or 16 bits, as OpenImageIO
// reads them.

struct PngReader {
    const std::string *bytes = nullptr;
    size_t pos = 0;
    std::string message;
};

void png_read_fn(png_structp png, png_bytep out, png_size_t n) {
    auto *r = static_cast<PngReader *>(png_get_io_ptr(png));
    if (r->bytes->size() - r->pos < n) png_error(png, "truncated PNG data");
    std::memcpy(out, r->bytes->data() + r->pos, n);
    r->pos += n;
}

void png_error_fn(png_structp png, png_const_charp msg) {
    static_cast<PngReader *>(png_get_error_ptr(png))->message = msg ? msg : "libpng error";
    png_longjmp(png, 1);
}

void png_warning_fn(png_structp, png_const_charp) {}

/// What the header says once the transforms are set.
struct PngHeader {
    png_uint_32 width = 0, height = 0;
    int channels = 0, bit_depth = 0;
    bool linear = false;  ///< a gAMA chunk of 1.0 and no sRGB chunk
};

/// Reads the header and, when `rows` is not null, the pixels into rows[0..height). Returns ""
/// or libpng's message. Only trivially destructible locals live between setjmp and a longjmp.
std::string read_png(const std::string &bytes, PngHeader *hdr, png_bytep *rows) {
    PngReader reader;
    reader.bytes = &bytes;
    png_structp png =
        png_create_read_struct(PNG_LIBPNG_VER_STRING, &reader, png_error_fn, png_warning_fn);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_read_struct(&png, nullptr, nullptr);
        return "cannot create the PNG reader";
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        return reader.message.empty() ? std::string("libpng error") : reader.message;
    }
    png_set_read_fn(png, &reader, png_read_fn);
    png_read_info(png, info);
    const int color_type = png_get_color_type(png, info);
    const int depth = png_get_bit_depth(png, info);
    if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (color_type == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    if (depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    hdr->width = png_get_image_width(png, info);
    hdr->height = png_get_image_height(png, info);
    hdr->channels = png_get_channels(png, info);
    hdr->bit_depth = png_get_bit_depth(png, info);
    double gamma = 0;
    hdr->linear = !png_get_valid(png, info, PNG_INFO_sRGB) &&
                  png_get_gAMA(png, info, &gamma) && std::abs(gamma - 1.0) < 1e-5;
    if (rows) {
        png_read_image(png, rows);
        png_read_end(png, nullptr);
    }
    png_destroy_read_struct(&png, &info, nullptr);
    return "";
}

class PngInput final : public DecodedInput {
  public:
    NativeOpen open(Source src, bool unassociated_alpha, std::string *error) {
        src_ = std::move(src);
        if (!src_.load_all(error)) return NativeOpen::Failed;
        PngHeader h;
        if (std::string msg = read_png(src_.bytes(), &h, nullptr); !msg.empty()) {
            *error = msg;
            return NativeOpen::Failed;
        }
        const bool alpha = h.channels == 2 || h.channels == 4;
        if (alpha && !unassociated_alpha) return NativeOpen::Declined;
        if (h.width > uint32_t(std::numeric_limits<int>::max()) ||
            h.height > uint32_t(std::numeric_limits<int>::max())) {
            *error = "PNG size too large";
            return NativeOpen::Failed;
        }
        spec_.width = int(h.width);
        spec_.height = int(h.height);
        spec_.nchannels = h.channels;
        spec_.format = h.bit_depth == 16 ? PixelType::UInt16 : PixelType::UInt8;
        spec_.channelnames = channel_names(h.channels, h.channels <= 2);
        spec_.format_name = "png";
        spec_.attribute("oiio:ColorSpace", h.linear ? "linear" : "sRGB");
        return NativeOpen::Opened;
    }

  private:
    bool decode() override {
        allocate();
        const size_t row = size_t(spec_.width) * size_t(spec_.nchannels) * bytes_of(spec_.format);
        std::vector<png_bytep> rows(size_t(spec_.height));
        for (size_t y = 0; y < rows.size(); ++y) rows[y] = &pixels_[y * row];
        PngHeader h;
        if (std::string msg = read_png(src_.bytes(), &h, rows.data()); !msg.empty())
            return fail(msg);
        return true;
    }
};

bool tga_extension(const std::string &name) {
    std::string ext = fs::path(name).extension().string();
    for (char &c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".tga" || ext == ".tpic";
}

NativeOpen open_source(Source src, const std::string &name, bool unassociated_alpha,
                       std::unique_ptr<ImageInput> *out, std::string *error) {
    const std::string &b = src.bytes();
    static const unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    NativeOpen r = NativeOpen::Declined;
    if (b.size() >= 8 && std::memcmp(b.data(), kPngSignature, 8) == 0) {
        auto in = std::make_unique<PngInput>();
        r = in->open(std::move(src), unassociated_alpha, error);
        if (r == NativeOpen::Opened) *out = std::move(in);
    } else if (b.size() >= 3 && b[0] == 'P' && (b[1] == 'F' || b[1] == 'f') &&
               std::isspace(static_cast<unsigned char>(b[2]))) {
        auto in = std::make_unique<PfmInput>();
        r = in->open(std::move(src), error);
        if (r == NativeOpen::Opened) *out = std::move(in);
    } else if (tga_extension(name)) {
        auto in = std::make_unique<TgaInput>();
        r = in->open(std::move(src), unassociated_alpha, error);
        if (r == NativeOpen::Opened) *out = std::move(in);
    }
    return r;
}

}  // namespace

NativeOpen open_native(const std::string &path, bool unassociated_alpha,
                       std::unique_ptr<ImageInput> *out, std::string *error) {
    Source src;
    if (!src.open_file(path, error)) return NativeOpen::Failed;
    return open_source(std::move(src), path, unassociated_alpha, out, error);
}

NativeOpen open_native_memory(std::string bytes, const std::string &name,
                              bool unassociated_alpha, std::unique_ptr<ImageInput> *out,
                              std::string *error) {
    Source src;
    src.open_memory(std::move(bytes));
    return open_source(std::move(src), name, unassociated_alpha, out, error);
}

}  // namespace tessera::imageio
