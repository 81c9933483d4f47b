// The native TGA, PFM and PNG readers (renderer/util/native_image.h) against OpenImageIO (the
// image module): generated files of every variant they read or decline, every image of
// ../shared/scenes and the examples, and malformed files.
#include <doctest/doctest.h>
#include <png.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "renderer/util/error.h"
#include "renderer/util/image_io.h"
#include "renderer/util/native_image.h"
#include "renderer/util/random.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;
using imageio::NativeOpen;
using imageio::PixelType;

namespace {

fs::path dir() {
    static const fs::path d = tessera::test::temp_dir("native_image", true);
    return d;
}

void write_bytes(const fs::path &p, const std::string &b) {
    std::ofstream(p, std::ios::binary).write(b.data(), std::streamsize(b.size()));
}

/// Pseudo-random bytes, the same for the same seed.
std::vector<uint8_t> noise_bytes(size_t n, uint32_t seed) {
    std::vector<uint8_t> v(n);
    uint32_t s = seed * 2654435761u + 1;
    for (auto &b : v) {
        s ^= s << 13, s ^= s >> 17, s ^= s << 5;
        b = uint8_t(s >> 7);
    }
    return v;
}

// ---- TGA ------------------------------------------------------------------------------------

struct Tga {
    int type = 2, bpp = 24, desc = 0, w = 5, h = 3;
    std::string id{};        ///< image ID field
    int cmap_type = 0, cmap_length = 0, cmap_bits = 0;
    bool footer = false;     ///< a TGA 2.0 footer
    bool extension = false;  ///< ... naming an extension area
};

/// File bytes of `t` with `pixels` (file order, bpp/8 bytes each); RLE types are encoded with
/// runs of equal pixels and literal packets, some crossing rows.
std::string tga_file(const Tga &t, const std::vector<uint8_t> &pixels) {
    std::string b(18, '\0');
    b[0] = char(t.id.size());
    b[1] = char(t.cmap_type);
    b[2] = char(t.type);
    b[5] = char(t.cmap_length & 0xff), b[6] = char(t.cmap_length >> 8);
    b[7] = char(t.cmap_bits);
    b[12] = char(t.w & 0xff), b[13] = char(t.w >> 8);
    b[14] = char(t.h & 0xff), b[15] = char(t.h >> 8);
    b[16] = char(t.bpp);
    b[17] = char(t.desc);
    b += t.id;
    b += std::string(size_t(t.cmap_length) * size_t((t.cmap_bits + 7) / 8), '\x5a');
    const size_t bp = size_t(t.bpp / 8), n = pixels.size() / bp;
    if (t.type < 9) {
        b.append(reinterpret_cast<const char *>(pixels.data()), pixels.size());
    } else {
        size_t i = 0;
        while (i < n) {
            size_t run = 1;
            while (i + run < n && run < 128 &&
                   std::memcmp(&pixels[i * bp], &pixels[(i + run) * bp], bp) == 0)
                ++run;
            if (run >= 2) {
                b += char(0x80 | (run - 1));
                b.append(reinterpret_cast<const char *>(&pixels[i * bp]), bp);
                i += run;
            } else {
                size_t lit = std::min<size_t>({n - i, 7, 128});
                b += char(lit - 1);
                b.append(reinterpret_cast<const char *>(&pixels[i * bp]), lit * bp);
                i += lit;
            }
        }
    }
    if (t.footer) {
        const size_t ext_offset = b.size();
        if (t.extension) b += std::string(495, '\0');
        std::string f(8, '\0');
        if (t.extension)
            for (int k = 0; k < 4; ++k) f[size_t(k)] = char((ext_offset >> (8 * k)) & 0xff);
        f += "TRUEVISION-XFILE.";
        f += '\0';
        b += f;
    }
    return b;
}

/// Pixels with runs (so that RLE has both packet kinds): every third pixel repeats the last.
std::vector<uint8_t> tga_pixels(const Tga &t, uint32_t seed) {
    const size_t bp = size_t(t.bpp / 8), n = size_t(t.w) * size_t(t.h);
    std::vector<uint8_t> px = noise_bytes(n * bp, seed);
    for (size_t i = 1; i < n; ++i)
        if (i % 3 != 0) std::memcpy(&px[i * bp], &px[(i - 1) * bp], bp);
    return px;
}

// ---- PFM ------------------------------------------------------------------------------------

std::string pfm_file(int nc, int w, int h, float scale, bool little, const std::string &sep) {
    std::string b = std::string(nc == 3 ? "PF" : "Pf") + sep + std::to_string(w) + " " +
                    std::to_string(h) + sep + std::to_string(scale) + "\n";
    std::vector<uint8_t> raw = noise_bytes(size_t(w) * h * nc * 4, uint32_t(w * 31 + h));
    for (size_t i = 0; i < raw.size(); i += 4) {
        // Finite floats of both signs and varied exponents, in the file's byte order.
        float v = float(int(raw[i] | (raw[i + 1] << 8)) - 30000) * std::ldexp(1.f, raw[i + 2] % 20 - 10);
        uint32_t u = std::bit_cast<uint32_t>(v);
        for (int k = 0; k < 4; ++k)
            raw[i + size_t(k)] = uint8_t(u >> (little ? 8 * k : 24 - 8 * k));
    }
    b.append(reinterpret_cast<const char *>(raw.data()), raw.size());
    return b;
}

// ---- PNG ------------------------------------------------------------------------------------

struct Png {
    int color_type = PNG_COLOR_TYPE_RGB, depth = 8, w = 7, h = 5;
    bool interlace = false, trns = false;
    double gamma = 0;  ///< a gAMA chunk when > 0
    bool srgb = false;
};

void png_write_to_string(png_structp png, png_bytep data, png_size_t n) {
    static_cast<std::string *>(png_get_io_ptr(png))->append(reinterpret_cast<char *>(data), n);
}
void png_flush_nothing(png_structp) {}

std::string png_file(const Png &p) {
    std::string out;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    REQUIRE(png);
    REQUIRE(info);
    png_set_write_fn(png, &out, png_write_to_string, png_flush_nothing);
    png_set_IHDR(png, info, png_uint_32(p.w), png_uint_32(p.h), p.depth, p.color_type,
                 p.interlace ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    const int samples = p.color_type == PNG_COLOR_TYPE_GRAY         ? 1
                        : p.color_type == PNG_COLOR_TYPE_GRAY_ALPHA ? 2
                        : p.color_type == PNG_COLOR_TYPE_RGB        ? 3
                        : p.color_type == PNG_COLOR_TYPE_RGB_ALPHA  ? 4
                                                                    : 1;
    const int max = (1 << p.depth) - 1;
    std::vector<png_color> palette;
    if (p.color_type == PNG_COLOR_TYPE_PALETTE) {
        std::vector<uint8_t> c = noise_bytes(size_t(max + 1) * 3, 99);
        for (int i = 0; i <= max; ++i) palette.push_back({c[size_t(3 * i)], c[size_t(3 * i + 1)], c[size_t(3 * i + 2)]});
        png_set_PLTE(png, info, palette.data(), int(palette.size()));
    }
    std::vector<png_byte> alphas;
    png_color_16 trans{};
    if (p.trns) {
        if (p.color_type == PNG_COLOR_TYPE_PALETTE) {
            alphas = {0, 128, 255, 7};
            png_set_tRNS(png, info, alphas.data(), int(alphas.size()), nullptr);
        } else {
            trans.gray = uint16_t(max / 3);
            trans.red = trans.green = trans.blue = uint16_t(max / 3);
            png_set_tRNS(png, info, nullptr, 0, &trans);
        }
    }
    if (p.gamma > 0) png_set_gAMA(png, info, p.gamma);
    if (p.srgb) png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    if (p.depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
    if (p.depth < 8) png_set_packing(png);
    const size_t bps = p.depth == 16 ? 2 : 1;
    const size_t row = size_t(p.w) * size_t(samples) * bps;
    std::vector<uint8_t> pix = noise_bytes(row * size_t(p.h), uint32_t(p.color_type * 7 + p.depth));
    if (p.depth < 8)
        for (auto &v : pix) v = uint8_t(v % (max + 1));
    // Some pixels at the tRNS colour, so that its alpha 0 shows.
    if (p.trns && p.color_type != PNG_COLOR_TYPE_PALETTE)
        for (size_t i = 0; i + bps * size_t(samples) <= pix.size(); i += 5 * bps * size_t(samples))
            for (size_t k = 0; k < size_t(samples); ++k) {
                if (bps == 2) {
                    const uint16_t v = uint16_t(max / 3);
                    std::memcpy(&pix[i + 2 * k], &v, 2);
                } else {
                    pix[i + k] = uint8_t(max / 3);
                }
            }
    const int passes = p.interlace ? png_set_interlace_handling(png) : 1;
    for (int pass = 0; pass < passes; ++pass)
        for (int y = 0; y < p.h; ++y) png_write_row(png, &pix[size_t(y) * row]);
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return out;
}

// ---- comparison -----------------------------------------------------------------------------

std::string names_of(const imageio::ImageSpec &s) {
    std::string out;
    for (const std::string &n : s.channelnames) out += n + ",";
    return out;
}

bool linear(const imageio::ImageSpec &s) {
    const std::string cs = s.get_string_attribute("oiio:ColorSpace");
    return cs == "Linear" || cs == "linear" || cs == "scene_linear";
}

/// Opens `path` natively; when opened, checks header and pixels against OpenImageIO's.
NativeOpen compare_with_module(const fs::path &path, bool unassociated_alpha) {
    INFO("file: ", path.string(), " unassociated alpha ", unassociated_alpha);
    std::unique_ptr<imageio::ImageInput> native;
    std::string err;
    const NativeOpen r = imageio::open_native(path.string(), unassociated_alpha, &native, &err);
    if (r != NativeOpen::Opened) return r;
    std::unique_ptr<imageio::ImageInput> oiio =
        imageio::backend().open(path.string(), unassociated_alpha, &err);
    REQUIRE_MESSAGE(oiio, err);
    const imageio::ImageSpec &a = native->spec(), &b = oiio->spec();
    CHECK(a.width == b.width);
    CHECK(a.height == b.height);
    REQUIRE(a.nchannels == b.nchannels);
    CHECK(a.format == b.format);
    CHECK(a.channelformats.empty());
    CHECK(b.channelformats.empty());
    CHECK_MESSAGE(a.channelnames == b.channelnames, "native ", names_of(a), " module ", names_of(b));
    CHECK(a.format_name == b.format_name);
    CHECK(linear(a) == linear(b));
    CHECK(a.tile_width == 0);
    const size_t n = size_t(a.width) * size_t(a.height);
    const int nc = a.nchannels;
    // Every channel as float, bit for bit, and a sub-range of channels.
    std::vector<float> fa(n * size_t(nc)), fb(n * size_t(nc));
    REQUIRE_MESSAGE(native->read_image(0, nc, PixelType::Float, fa.data()), native->geterror());
    REQUIRE(oiio->read_image(0, nc, PixelType::Float, fb.data()));
    CHECK_MESSAGE(std::memcmp(fa.data(), fb.data(), fa.size() * 4) == 0, "first value native ",
                  fa[0], " module ", fb[0]);
    if (nc > 1) {
        std::vector<float> sa(n), sb(n);
        REQUIRE(native->read_image(1, 2, PixelType::Float, sa.data()));
        REQUIRE(oiio->read_image(1, 2, PixelType::Float, sb.data()));
        CHECK(std::memcmp(sa.data(), sb.data(), n * 4) == 0);
    }
    // The stored type, packed.
    const size_t bytes = a.format == PixelType::UInt8 ? 1 : a.format == PixelType::UInt16 ? 2 : 4;
    std::vector<uint8_t> ra(n * size_t(nc) * bytes), rb(ra.size());
    REQUIRE(native->read_image(0, nc, PixelType::Unknown, ra.data()));
    REQUIRE(oiio->read_image(0, nc, PixelType::Unknown, rb.data()));
    CHECK(ra == rb);
    return r;
}

NativeOpen open_only(const fs::path &path, bool unassociated_alpha, std::string *err) {
    std::unique_ptr<imageio::ImageInput> in;
    return imageio::open_native(path.string(), unassociated_alpha, &in, err);
}

}  // namespace

TEST_CASE("native TGA reader: every true-colour and grey variant reads as OpenImageIO reads it") {
    struct Case {
        const char *name;
        Tga t;
        NativeOpen expect;          // with unassociated alpha
        NativeOpen expect_assoc;    // colour to be premultiplied
    };
    const Case cases[] = {
        {"rgb24-bottom", {2, 24, 0x00}, NativeOpen::Opened, NativeOpen::Opened},
        {"rgb24-top", {2, 24, 0x20}, NativeOpen::Opened, NativeOpen::Opened},
        {"rgb24-top-right", {2, 24, 0x30}, NativeOpen::Opened, NativeOpen::Opened},
        {"rgb24-bottom-right", {2, 24, 0x10}, NativeOpen::Opened, NativeOpen::Opened},
        {"rgba32-top", {2, 32, 0x28}, NativeOpen::Opened, NativeOpen::Declined},
        {"rgba32-bottom", {2, 32, 0x08}, NativeOpen::Opened, NativeOpen::Declined},
        {"grey8", {3, 8, 0x00}, NativeOpen::Opened, NativeOpen::Opened},
        {"grey8-top", {3, 8, 0x20}, NativeOpen::Opened, NativeOpen::Opened},
        {"greyalpha16", {3, 16, 0x28}, NativeOpen::Declined, NativeOpen::Declined},
        {"rle-rgb24", {10, 24, 0x00, 13, 9}, NativeOpen::Opened, NativeOpen::Opened},
        {"rle-rgb24-top", {10, 24, 0x20, 13, 9}, NativeOpen::Opened, NativeOpen::Opened},
        {"rle-rgba32", {10, 32, 0x08, 13, 9}, NativeOpen::Opened, NativeOpen::Declined},
        {"rle-grey8", {11, 8, 0x20, 13, 9}, NativeOpen::Opened, NativeOpen::Opened},
        {"with-id", {2, 24, 0x20, 4, 4, "an image id"}, NativeOpen::Opened, NativeOpen::Opened},
        {"unused-colour-map", {2, 24, 0x20, 4, 4, "", 1, 16, 24}, NativeOpen::Opened,
         NativeOpen::Opened},
        {"footer-no-extension", {2, 32, 0x28, 4, 4, "", 0, 0, 0, true, false},
         NativeOpen::Opened, NativeOpen::Declined},
        {"footer-extension", {2, 24, 0x20, 4, 4, "", 0, 0, 0, true, true}, NativeOpen::Opened,
         NativeOpen::Opened},
        // Left to OpenImageIO: alpha with an extension area, 32 bits without alpha bits,
        // 16-bit colour, colour maps.
        {"rgba-extension", {2, 32, 0x28, 4, 4, "", 0, 0, 0, true, true}, NativeOpen::Declined,
         NativeOpen::Declined},
        {"rgb32-no-alpha-bits", {2, 32, 0x20}, NativeOpen::Declined, NativeOpen::Declined},
        {"rgb16", {2, 16, 0x21}, NativeOpen::Declined, NativeOpen::Declined},
        {"colour-mapped", {1, 8, 0x20, 5, 3, "", 1, 4, 24}, NativeOpen::Declined,
         NativeOpen::Declined},
    };
    uint32_t seed = 1;
    for (const Case &c : cases) {
        INFO("case ", std::string(c.name));
        const fs::path p = dir() / (std::string(c.name) + ".tga");
        write_bytes(p, tga_file(c.t, tga_pixels(c.t, seed++)));
        CHECK(compare_with_module(p, true) == c.expect);
        CHECK(compare_with_module(p, false) == c.expect_assoc);
    }
    // A big RLE image: packets of 128 pixels and runs across many rows.
    Tga big{10, 24, 0x00, 300, 200};
    std::vector<uint8_t> px(size_t(big.w) * big.h * 3);
    for (size_t i = 0; i < px.size() / 3; ++i)
        for (int k = 0; k < 3; ++k) px[i * 3 + size_t(k)] = uint8_t((i / 517) * (k + 1));
    write_bytes(dir() / "big-rle.tga", tga_file(big, px));
    CHECK(compare_with_module(dir() / "big-rle.tga", true) == NativeOpen::Opened);
    // Upper-case extension.
    write_bytes(dir() / "UPPER.TGA", tga_file(Tga{}, tga_pixels(Tga{}, 5)));
    CHECK(compare_with_module(dir() / "UPPER.TGA", true) == NativeOpen::Opened);
}

TEST_CASE("native PFM reader: both byte orders, RGB and grey, any scale, as OpenImageIO") {
    int k = 0;
    for (int nc : {1, 3})
        for (float scale : {-1.f, 1.f, -2.5f, 0.25f})
            for (const char *sep : {"\n", " ", "\r\n"}) {
                CAPTURE(nc);
                CAPTURE(scale);
                const fs::path p = dir() / (std::to_string(k++) + "-f.pfm");
                write_bytes(p, pfm_file(nc, 6 + k % 3, 4 + k % 2, scale, scale < 0, sep));
                CHECK(compare_with_module(p, false) == NativeOpen::Opened);
            }
}

TEST_CASE("native PNG reader: grey, palette, tRNS, 1-16 bits, interlaced, gamma, as OpenImageIO") {
    struct Case {
        const char *name;
        Png p;
        NativeOpen expect_assoc;
    };
    const Case cases[] = {
        {"rgb8", {PNG_COLOR_TYPE_RGB, 8}, NativeOpen::Opened},
        {"rgb16", {PNG_COLOR_TYPE_RGB, 16}, NativeOpen::Opened},
        {"rgba8", {PNG_COLOR_TYPE_RGB_ALPHA, 8}, NativeOpen::Declined},
        {"rgba16", {PNG_COLOR_TYPE_RGB_ALPHA, 16}, NativeOpen::Declined},
        {"grey1", {PNG_COLOR_TYPE_GRAY, 1}, NativeOpen::Opened},
        {"grey2", {PNG_COLOR_TYPE_GRAY, 2}, NativeOpen::Opened},
        {"grey4", {PNG_COLOR_TYPE_GRAY, 4}, NativeOpen::Opened},
        {"grey8", {PNG_COLOR_TYPE_GRAY, 8}, NativeOpen::Opened},
        {"grey16", {PNG_COLOR_TYPE_GRAY, 16}, NativeOpen::Opened},
        {"greyalpha8", {PNG_COLOR_TYPE_GRAY_ALPHA, 8}, NativeOpen::Declined},
        {"greyalpha16", {PNG_COLOR_TYPE_GRAY_ALPHA, 16}, NativeOpen::Declined},
        {"palette1", {PNG_COLOR_TYPE_PALETTE, 1}, NativeOpen::Opened},
        {"palette4", {PNG_COLOR_TYPE_PALETTE, 4}, NativeOpen::Opened},
        {"palette8", {PNG_COLOR_TYPE_PALETTE, 8}, NativeOpen::Opened},
        {"palette8-trns", {PNG_COLOR_TYPE_PALETTE, 8, 7, 5, false, true}, NativeOpen::Declined},
        {"grey8-trns", {PNG_COLOR_TYPE_GRAY, 8, 7, 5, false, true}, NativeOpen::Declined},
        {"rgb16-trns", {PNG_COLOR_TYPE_RGB, 16, 7, 5, false, true}, NativeOpen::Declined},
        {"rgb8-interlaced", {PNG_COLOR_TYPE_RGB, 8, 13, 11, true}, NativeOpen::Opened},
        {"rgba16-interlaced", {PNG_COLOR_TYPE_RGB_ALPHA, 16, 13, 11, true}, NativeOpen::Declined},
        {"rgb8-gamma1", {PNG_COLOR_TYPE_RGB, 8, 7, 5, false, false, 1.0}, NativeOpen::Opened},
        {"rgb8-gamma045", {PNG_COLOR_TYPE_RGB, 8, 7, 5, false, false, 0.45455}, NativeOpen::Opened},
        {"rgb8-srgb", {PNG_COLOR_TYPE_RGB, 8, 7, 5, false, false, 0, true}, NativeOpen::Opened},
    };
    for (const Case &c : cases) {
        INFO("case ", std::string(c.name));
        const fs::path p = dir() / (std::string(c.name) + ".png");
        write_bytes(p, png_file(c.p));
        CHECK(compare_with_module(p, true) == NativeOpen::Opened);
        CHECK(compare_with_module(p, false) == c.expect_assoc);
    }
    // The signature decides, not the name.
    write_bytes(dir() / "a-png.tga", png_file(Png{}));
    CHECK(compare_with_module(dir() / "a-png.tga", true) == NativeOpen::Opened);
}

TEST_CASE("native readers: every image of ../shared/scenes and the examples as OpenImageIO") {
    std::vector<fs::path> roots = {fs::path(TESSERA_SOURCE_DIR) / "examples"};
    const std::string shared = tessera::test::shared_dir();
    if (shared.empty())
        MESSAGE("../shared/scenes not found (a user's clone has none): the examples only");
    else
        roots.push_back(fs::path(shared) / "scenes");
    int opened = 0;
    for (const fs::path &root : roots)
        for (const auto &e : fs::recursive_directory_iterator(root)) {
            std::string ext = e.path().extension().string();
            for (char &ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
            if (ext != ".tga" && ext != ".png" && ext != ".pfm") continue;
            for (bool unassoc : {true, false})
                opened += compare_with_module(e.path(), unassoc) == NativeOpen::Opened;
        }
    MESSAGE(opened, " opens compared");
    CHECK(opened >= (shared.empty() ? 8 : 80));
}

TEST_CASE("native readers: malformed files are errors that say what is wrong") {
    // Uncompressed TGA shorter than its header claims: at open, before any pixel.
    Tga t{2, 24, 0x20, 64, 64};
    std::string full = tga_file(t, tga_pixels(t, 3));
    write_bytes(dir() / "short.tga", full.substr(0, full.size() / 2));
    std::string err;
    CHECK(open_only(dir() / "short.tga", true, &err) == NativeOpen::Failed);
    CHECK(err.find("truncated") != std::string::npos);
    write_bytes(dir() / "tiny.tga", "abc");
    CHECK(open_only(dir() / "tiny.tga", true, &err) == NativeOpen::Failed);
    CHECK(err.find("no TGA header") != std::string::npos);
    Tga bad{7, 24, 0x20};
    write_bytes(dir() / "type7.tga", tga_file(bad, tga_pixels(bad, 1)));
    CHECK(open_only(dir() / "type7.tga", true, &err) == NativeOpen::Failed);
    CHECK(err.find("image type 7") != std::string::npos);
    Tga empty{2, 24, 0x20, 0, 4};
    write_bytes(dir() / "empty.tga", tga_file(empty, {}));
    CHECK(open_only(dir() / "empty.tga", true, &err) == NativeOpen::Failed);

    // RLE data that ends early: the header opens, reading the pixels fails.
    Tga rle{10, 24, 0x20, 64, 64};
    std::string rle_full = tga_file(rle, tga_pixels(rle, 4));
    write_bytes(dir() / "short-rle.tga", rle_full.substr(0, rle_full.size() - 40));
    std::unique_ptr<imageio::ImageInput> in;
    REQUIRE(imageio::open_native((dir() / "short-rle.tga").string(), true, &in, &err) ==
            NativeOpen::Opened);
    std::vector<float> px(64 * 64 * 3);
    CHECK_FALSE(in->read_image(0, 3, PixelType::Float, px.data()));
    CHECK(in->geterror().find("truncated run-length data") != std::string::npos);

    // PFM: bad sizes, scale, truncation.
    for (const char *text : {"PF\n-3 2\n-1\n", "PF\n3 x\n-1\n", "PF\n3 2\n0\n", "PF\n3 2\nabc\n",
                             "PF\n3 2\n-1", "Pf\n3 2\n-1\n0123"}) {
        CAPTURE(text);
        write_bytes(dir() / "bad.pfm", text);
        CHECK(open_only(dir() / "bad.pfm", false, &err) == NativeOpen::Failed);
        CHECK_FALSE(err.empty());
    }
    write_bytes(dir() / "huge.pfm", "PF\n99999999 99999999\n-1\nxxxx");
    CHECK(open_only(dir() / "huge.pfm", false, &err) == NativeOpen::Failed);
    CHECK(err.find("truncated") != std::string::npos);

    // PNG cut short and with a damaged chunk.
    const std::string png = png_file(Png{PNG_COLOR_TYPE_RGB, 8, 40, 30});
    write_bytes(dir() / "short.png", png.substr(0, png.size() - 30));
    bool failed_somewhere = false;
    if (imageio::open_native((dir() / "short.png").string(), true, &in, &err) ==
        NativeOpen::Failed) {
        failed_somewhere = true;
    } else {
        std::vector<float> p(40 * 30 * 3);
        failed_somewhere = !in->read_image(0, 3, PixelType::Float, p.data());
    }
    CHECK(failed_somewhere);
    std::string damaged = png;
    damaged[20] ^= 0x55;  // inside IHDR: its CRC no longer matches
    write_bytes(dir() / "damaged.png", damaged);
    CHECK(open_only(dir() / "damaged.png", true, &err) == NativeOpen::Failed);
    CHECK_FALSE(err.empty());

    // Through open_image: "file:line: cannot read image "path": why".
    try {
        open_image((dir() / "short.tga").string(), FileLoc{"scene.pbrt", 12}, "image");
        FAIL("no error");
    } catch (const SceneError &e) {
        const std::string what = e.what();
        CHECK(what.find("scene.pbrt:12") != std::string::npos);
        CHECK(what.find("short.tga") != std::string::npos);
        CHECK(what.find("truncated") != std::string::npos);
    }
}

TEST_CASE("native readers: any bytes named .tga, .png or .pfm are read or rejected, never crash") {
    // The fuzz target's contract on a fixed sample (scripts/run_fuzz.sh runs it at length).
    const std::string seeds[] = {tga_file(Tga{10, 24, 0x20, 9, 7}, tga_pixels(Tga{10, 24, 0x20, 9, 7}, 8)),
                                 pfm_file(3, 5, 4, -1.f, true, "\n"), png_file(Png{})};
    int opened = 0, read = 0;
    for (int s = 0; s < 3; ++s)
        for (uint32_t k = 0; k < 400; ++k) {
            std::string b = seeds[s];
            const std::vector<uint8_t> r = noise_bytes(8, k * 3 + uint32_t(s));
            // Flip a few bytes, or cut the file short.
            if (k % 4 == 0) b.resize(1 + r[0] % b.size());
            for (int j = 0; j < 3; ++j) b[(size_t(r[1 + j]) * 37 + k) % b.size()] ^= char(r[4 + j]);
            std::unique_ptr<imageio::ImageInput> in;
            std::string err;
            const char *name = s == 0 ? "x.tga" : s == 1 ? "x.pfm" : "x.png";
            if (imageio::open_native_memory(b, name, true, &in, &err) != NativeOpen::Opened) continue;
            ++opened;
            const auto &sp = in->spec();
            if (uint64_t(sp.width) * uint64_t(sp.height) * uint64_t(sp.nchannels) > (1u << 24)) continue;
            std::vector<float> px(size_t(sp.width) * size_t(sp.height) * size_t(sp.nchannels));
            read += in->read_image(0, sp.nchannels, PixelType::Float, px.data());
        }
    MESSAGE(opened, " opened, ", read, " read of 1200 damaged files");
    CHECK(opened > 0);
}
