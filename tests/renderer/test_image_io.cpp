// Tests of EXR/PNG output, atomic writes, the OCIO display transform and `tessera diff`.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "approx.h"
#include "renderer/util/color.h"
#include "renderer/app/diff.h"
#include "renderer/util/image_io.h"
#include "renderer/input/scene_desc.h"
#include "test_helpers.h"

#include <unistd.h>

using namespace tessera;
namespace fs = std::filesystem;

namespace {

// A fresh, empty folder under the test output directory.
fs::path fresh_dir(const std::string &name) {
    fs::path d = fs::path(tessera::test::output_dir()) / "image_io" / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

std::vector<std::string> listing(const fs::path &dir) {
    std::vector<std::string> names;
    for (const auto &e : fs::directory_iterator(dir)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    return names;
}

// Values that exercise sign, range and fractional bits.
std::vector<float> pattern(size_t n, float scale) {
    std::vector<float> v(n);
    for (size_t i = 0; i < n; ++i) v[i] = scale * std::sin(float(i) * 0.37f + 0.1f) * float(i % 7);
    return v;
}

}  // namespace

TEST_CASE("EXR float round trip is bit exact, layers by name") {
    fs::path dir = fresh_dir("float");
    const uint32_t w = 7, h = 5;
    const size_t n = size_t(w) * h;
    std::vector<ImageLayer> layers = {
        {"", {"R", "G", "B"}, pattern(3 * n, 1.f), false},
        {"albedo", {"R", "G", "B"}, pattern(3 * n, 0.1f), false},
        {"depth", {"Z"}, pattern(n, 1000.f), true},
    };
    layers[2].data[4] = kInfinity;
    std::string path = (dir / "a.exr").string();
    write_exr(path, w, h, layers);
    CHECK(listing(dir) == std::vector<std::string>{"a.exr"});  // no temporary left

    uint32_t rw = 0, rh = 0;
    std::vector<float> albedo = read_image_channels(path, {"albedo.R", "albedo.G", "albedo.B"},
                                                    rw, rh);
    CHECK(rw == w);
    CHECK(rh == h);
    CHECK(std::memcmp(albedo.data(), layers[1].data.data(), albedo.size() * 4) == 0);
    std::vector<float> depth = read_image_channels(path, {"depth.Z"}, rw, rh);
    CHECK(std::memcmp(depth.data(), layers[2].data.data(), depth.size() * 4) == 0);
    CHECK(std::isinf(depth[4]));
    sampling::RgbImage rgb = read_image_rgb(path);
    CHECK(rgb.width == w);
    CHECK(std::memcmp(rgb.data.data(), layers[0].data.data(), rgb.data.size() * 4) == 0);
    CHECK_THROWS_AS(read_image_channels(path, {"nope.Z"}, rw, rh), std::runtime_error);
}

TEST_CASE("EXR half keeps half precision; depth and spp stay float") {
    fs::path dir = fresh_dir("half");
    sampling::Film film(4, 3, sampling::AovSet::all());
    for (uint32_t y = 0; y < 3; ++y) {
        for (uint32_t x = 0; x < 4; ++x) {
            for (uint32_t i = 0; i < 3 + x; ++i) {
                Sample s;
                s.radiance = Rgb(0.1f * float(x) + 0.01f * float(i), 1.f / 3.f, 1234.5f);
                s.albedo = Rgb(0.5f, 0.25f, 0.125f);
                s.normal = Vec3f(0, 0, 1);
                s.depth = x == 3 ? kInfinity : 1234.567f + float(y);
                film.add_sample(x, y, i, s);
            }
        }
    }
    std::string path = (dir / "film.exr").string();
    ExrWriteOptions opt;
    opt.half = true;
    write_film_exr(path, film, opt);
    std::vector<std::string> names = image_channel_names(path);
    for (const char *c : {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X",
                          "normal.Y", "normal.Z", "depth.Z", "spp.Y"})
        CHECK(std::find(names.begin(), names.end(), c) != names.end());

    sampling::RgbImage beauty = read_image_rgb(path);
    std::vector<float> expected = film.beauty_rgb();
    for (size_t i = 0; i < expected.size(); ++i)
        CHECK(beauty.data[i] == test::Approx(expected[i]).epsilon(1.0 / 1024));
    uint32_t w = 0, h = 0;
    std::vector<float> depth = read_image_channels(path, {"depth.Z"}, w, h);
    std::vector<float> spp = read_image_channels(path, {"spp.Y"}, w, h);
    CHECK(depth == film.depth());  // exact: always float
    CHECK(spp == film.spp());
    std::vector<float> normal = read_image_channels(path, {"normal.Z"}, w, h);
    CHECK(normal[0] == 1.f);
}

TEST_CASE("display PNG through the embedded OCIO config") {
    DisplayOptions opt;
    opt.use_env = false;
    DisplayTransform dt(opt);
    CHECK(dt.config_source() == "embedded");
    CHECK(dt.display() == "sRGB");
    CHECK(dt.view() == "sRGB");

    fs::path dir = fresh_dir("png");
    sampling::RgbImage img(3, 1);
    for (int c = 0; c < 3; ++c) {
        img.at(0, 0, c) = 0.5f;
        img.at(1, 0, c) = 0.f;
        img.at(2, 0, c) = 1.f;
    }
    img.at(1, 0, 1) = 0.0031308f * 0.5f;  // linear segment: 12.92 * v * 255 = 5.16
    std::string path = (dir / "grey.png").string();
    write_display_image(path, img, opt);
    CHECK(listing(dir) == std::vector<std::string>{"grey.png"});
    sampling::RgbImage back = read_image_rgb(path);
    REQUIRE(back.width == 3);
    auto byte = [&](uint32_t x, int c) { return int(std::lround(back.at(x, 0, c) * 255.f)); };
    for (int c = 0; c < 3; ++c) {
        CHECK(std::abs(byte(0, c) - 188) <= 1);
        CHECK(byte(2, c) == 255);
    }
    CHECK(byte(1, 0) == 0);
    CHECK(byte(1, 1) == 5);

    // The Raw view skips the transfer function: 0.5 -> 128.
    opt.view = "Raw";
    std::vector<uint8_t> raw = DisplayTransform(opt).to_8bit(img);
    CHECK(int(raw[0]) == 128);
    // Exposure +1 stop takes 0.5 to 1.0.
    opt.view = "";
    opt.exposure_stops = 1.f;
    CHECK(int(DisplayTransform(opt).to_8bit(img)[0]) == 255);

    CHECK(quantize_8bit(std::nanf("")) == 0);
    CHECK(quantize_8bit(-1.f) == 0);
    CHECK(quantize_8bit(2.f) == 255);
    opt.display = "no-such-display";
    CHECK_THROWS_AS(DisplayTransform{opt}, std::runtime_error);
}

TEST_CASE("8-bit images: PNG with libpng, other formats through the image module") {
    fs::path dir = fresh_dir("rgb8");
    std::vector<uint8_t> rgb(4 * 3 * 3);
    for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = uint8_t((i * 37 + 11) % 256);
    for (const char *name : {"a.png", "a.tif"}) {
        const std::string path = (dir / name).string();
        write_rgb8(path, 4, 3, rgb);
        OpenedImage img = open_image(path, FileLoc{path, 0}, "image");
        CHECK(img.spec.width == 4);
        CHECK(img.spec.height == 3);
        REQUIRE(img.spec.nchannels == 3);
        CHECK(img.spec.format == imageio::PixelType::UInt8);
        CHECK(img.spec.format_name == (std::string(name) == "a.png" ? "png" : "tiff"));
        std::vector<uint8_t> back(rgb.size());
        REQUIRE(img.in->read_image(0, 3, imageio::PixelType::UInt8, back.data()));
        CHECK(back == rgb);
    }
    CHECK(listing(dir) == std::vector<std::string>{"a.png", "a.tif"});
    // An unknown EXR compression is an error before anything is written.
    ExrWriteOptions bad;
    bad.compression = "lzma";
    CHECK_THROWS_AS(write_exr((dir / "c.exr").string(), 1, 1, {{"", {"Y"}, {1.f}, false}}, bad),
                    std::invalid_argument);
    CHECK(listing(dir) == std::vector<std::string>{"a.png", "a.tif"});
}

TEST_CASE("explicit OCIO config path and $OCIO") {
    fs::path dir = fresh_dir("ocio");
    fs::path cfg = dir / "config.ocio";
    {
        std::ofstream f(cfg);
        f << embedded_ocio_config();
    }
    DisplayOptions opt;
    opt.config_path = cfg.string();
    DisplayTransform from_file(opt);
    CHECK(from_file.config_source() == cfg.string());
    CHECK(from_file.view() == "sRGB");

    const char *old = std::getenv("OCIO");
    std::string saved = old ? old : "";
    setenv("OCIO", cfg.c_str(), 1);
    DisplayTransform from_env{DisplayOptions{}};
    CHECK(from_env.config_source() == "$OCIO=" + cfg.string());
    DisplayOptions no_env;
    no_env.use_env = false;
    CHECK(DisplayTransform(no_env).config_source() == "embedded");
    if (old)
        setenv("OCIO", saved.c_str(), 1);
    else
        unsetenv("OCIO");

    opt.config_path = (dir / "missing.ocio").string();
    CHECK_THROWS_AS(DisplayTransform{opt}, std::runtime_error);
}

TEST_CASE("failed writes throw and leave nothing behind") {
    fs::path dir = fresh_dir("fail");
    std::vector<ImageLayer> layers = {{"", {"R", "G", "B"}, std::vector<float>(12, 0.5f), false}};
    // A folder that does not exist.
    CHECK_THROWS_AS(write_exr((dir / "no/such/dir/x.exr").string(), 2, 2, layers),
                    std::runtime_error);
    // The target is a directory: the file is written, the rename fails, the temp goes.
    fs::create_directories(dir / "taken.exr");
    fs::create_directories(dir / "taken.png");
    CHECK_THROWS_AS(write_exr((dir / "taken.exr").string(), 2, 2, layers), std::runtime_error);
    CHECK_THROWS_AS(write_rgb8((dir / "taken.png").string(), 2, 2, std::vector<uint8_t>(12)),
                    std::runtime_error);
    CHECK(listing(dir) == std::vector<std::string>{"taken.exr", "taken.png"});
    // Malformed layers are rejected before any file is created.
    layers[0].data.pop_back();
    CHECK_THROWS_AS(write_exr((dir / "bad.exr").string(), 2, 2, layers), std::invalid_argument);
    CHECK(listing(dir) == std::vector<std::string>{"taken.exr", "taken.png"});
    CHECK_THROWS_AS(read_image_rgb((dir / "missing.exr").string()), std::runtime_error);
}

TEST_CASE("atomic writes: links are followed, devices written directly, stale temporaries go") {
    fs::path dir = fresh_dir("atomic");
    auto write_text_to = [](const std::string &text) {
        return [text](const std::string &p) {
            std::ofstream f(p);
            f << text;
            f.close();
            if (f.fail()) throw std::runtime_error(p + ": cannot write");
        };
    };
    auto read = [](const fs::path &p) {
        std::ifstream f(p);
        std::stringstream ss;
        ss << f.rdbuf();
        return ss.str();
    };
    // A link is followed: the file it names gets the new content, the link stays a link.
    write_atomically((dir / "real.json").string(), write_text_to("old"));
    fs::create_symlink("real.json", dir / "link.json");
    write_atomically((dir / "link.json").string(), write_text_to("new"));
    CHECK(fs::is_symlink(dir / "link.json"));
    CHECK(read(dir / "real.json") == "new");
    // A device is written as it is (no temporary renamed over /dev/null).
    write_atomically("/dev/null", write_text_to("discarded"));
    CHECK(fs::is_character_file("/dev/null"));
    // /dev/full: the write fails (ENOSPC on the flush) with an OutputError, and a link to it
    // stays a link (a temporary renamed over it would have hidden the failure).
    if (fs::exists("/dev/full")) {
        fs::create_symlink("/dev/full", dir / "full.json");
        CHECK_THROWS_AS(write_atomically((dir / "full.json").string(), write_text_to("x")),
                        OutputError);
        CHECK(fs::is_symlink(dir / "full.json"));
    }
    // A temporary left by a process that no longer runs (pid 2^22 + 1: above the largest
    // pid_max Linux allows) goes with the next write; one of a running process (this one's
    // parent) stays.
    const std::string stale = (dir / "real.json").string() + ".tmp-4194305";
    const std::string live = (dir / "real.json").string() + ".tmp-" + std::to_string(getppid());
    std::ofstream(stale) << "partial";
    std::ofstream(live) << "in progress";
    write_atomically((dir / "real.json").string(), write_text_to("newer"));
    CHECK_FALSE(fs::exists(stale));
    CHECK(fs::exists(live));
    CHECK(read(dir / "real.json") == "newer");
}

TEST_CASE("check_output_path: the mistakes visible before a render are errors before it") {
    fs::path dir = fresh_dir("check_output");
    auto error_of = [](const std::string &path) -> std::string {
        try {
            check_output_path(path, "the image");
        } catch (const SceneError &e) {
            return e.what();
        }
        return "";
    };
    CHECK(error_of((dir / "ok.exr").string()).empty());
    CHECK(listing(dir).empty());  // the probe file is gone
    std::string e = error_of((dir / "no/such/x.exr").string());
    CHECK_MESSAGE(e.rfind((dir / "no/such/x.exr").string() + ":0: the image: the folder ", 0) == 0, e);
    fs::create_directories(dir / "taken.exr");
    e = error_of((dir / "taken.exr").string());
    CHECK(e.find("is a directory") != std::string::npos);
    CHECK(error_of("/dev/null").empty());
    if (::geteuid() != 0) {
        // root writes anywhere: only meaningful for other users.
        fs::create_directories(dir / "readonly");
        fs::permissions(dir / "readonly", fs::perms::owner_read | fs::perms::owner_exec);
        e = error_of((dir / "readonly" / "x.exr").string());
        CHECK(e.find("cannot create files in") != std::string::npos);
        fs::permissions(dir / "readonly", fs::perms::owner_all);
    }
}

TEST_CASE("tessera diff prints metrics and fails on bad input") {
    fs::path dir = fresh_dir("diff");
    // A: (0.5, 1, 0), (0.1, 0.2, 0.3);  B: (0.5, 0, 0), (0, 0.2, 0.5).
    std::vector<ImageLayer> a = {{"", {"R", "G", "B"}, {0.5f, 1.f, 0.f, 0.1f, 0.2f, 0.3f}, false}};
    std::vector<ImageLayer> b = {{"", {"R", "G", "B"}, {0.5f, 0.f, 0.f, 0.f, 0.2f, 0.5f}, false}};
    std::string pa = (dir / "a.exr").string(), pb = (dir / "b.exr").string();
    write_exr(pa, 2, 1, a);
    write_exr(pb, 2, 1, b);
    std::ostringstream out;
    CHECK(run_diff(pa, pb, out, out) == 0);
    std::string text = out.str();
    // MSE per channel: R 0.005, G 0.5, B 0.02, total 0.175; relMSE G = 50.
    auto row = [&](const std::string &name) {
        std::istringstream is(text);
        std::string line;
        while (std::getline(is, line))
            if (line.rfind(name + " ", 0) == 0) return line;
        return std::string();
    };
    std::istringstream mse_row(row("MSE"));
    std::string label;
    double r = 0, g = 0, bb = 0, total = 0;
    mse_row >> label >> r >> g >> bb >> total;
    CHECK(r == test::Approx(0.005).epsilon(1e-4));
    CHECK(g == test::Approx(0.5).epsilon(1e-4));
    CHECK(bb == test::Approx(0.02).epsilon(1e-4));
    CHECK(total == test::Approx(0.175).epsilon(1e-4));
    std::istringstream rel_row(row("relMSE"));
    rel_row >> label >> r >> g;
    CHECK(g == test::Approx(50.0).epsilon(1e-4));
    CHECK(!row("PSNR").empty());
    std::istringstream mean_row(row("mean(B)"));
    mean_row >> label >> r >> g >> bb;
    CHECK(bb == test::Approx(0.25).epsilon(1e-4));

    std::vector<ImageLayer> c = {{"", {"R", "G", "B"}, std::vector<float>(12, 0.f), false}};
    std::string pc = (dir / "c.exr").string();
    write_exr(pc, 2, 2, c);
    std::ostringstream out2, out3;
    CHECK(run_diff(pa, pc, out, out2) == 2);
    CHECK(out2.str().find("sizes differ") != std::string::npos);
    CHECK(run_diff(pa, (dir / "missing.exr").string(), out, out3) == 2);
    CHECK(!out3.str().empty());
}

TEST_CASE("write_film_exr writes only the AOV layers the film keeps") {
    using sampling::Aov;
    using sampling::AovSet;
    fs::path dir = fresh_dir("aov_layers");
    for (AovSet aovs : {AovSet{}, AovSet{Aov::Depth}, AovSet{Aov::Albedo, Aov::Normal},
                        AovSet::all()}) {
        CAPTURE(aovs.describe());
        sampling::Film film(3, 2, aovs);
        for (uint32_t x = 0; x < 3; ++x) {
            Sample s;
            s.radiance = Rgb(0.25f * float(x + 1));
            s.albedo = Rgb(0.5f, 0.25f, 0.125f);
            s.normal = Vec3f(0, 1, 0);
            s.depth = 2.f + float(x);
            film.add_sample(x, 0, 0, s);
        }
        std::string path = (dir / ("film-" + aovs.describe() + ".exr")).string();
        write_film_exr(path, film);
        std::vector<std::string> names = image_channel_names(path);
        std::sort(names.begin(), names.end());
        std::vector<std::string> expected = {"B", "G", "R", "spp.Y"};
        if (aovs.has(Aov::Albedo)) expected.insert(expected.end(), {"albedo.B", "albedo.G", "albedo.R"});
        if (aovs.has(Aov::Normal)) expected.insert(expected.end(), {"normal.X", "normal.Y", "normal.Z"});
        if (aovs.has(Aov::Depth)) expected.push_back("depth.Z");
        std::sort(expected.begin(), expected.end());
        CHECK(names == expected);
        uint32_t w = 0, h = 0;
        CHECK(read_image_channels(path, {"R", "G", "B"}, w, h) == film.beauty_rgb());
        if (aovs.has(Aov::Depth))
            CHECK(read_image_channels(path, {"depth.Z"}, w, h) == film.depth());
        if (aovs.has(Aov::Albedo))
            CHECK(read_image_channels(path, {"albedo.R", "albedo.G", "albedo.B"}, w, h) ==
                  film.albedo_rgb());
    }
}

TEST_CASE("open_image checks every image's header before its pixels are allocated") {
    fs::path dir = fresh_dir("open_image");
    const FileLoc loc{"scene.pbrt", 7};
    auto error_of = [&](const std::string &path, ImageRead read = ImageRead::Whole) {
        try {
            open_image(path, loc, "normalmap", read);
        } catch (const SceneError &e) {
            return std::string(e.what());
        }
        return std::string();
    };
    const std::string missing = (dir / "missing.png").string();
    CHECK(error_of(missing) == "scene.pbrt:7: cannot read normalmap \"" + missing + "\": not found");
    CHECK(error_of(dir.string()).find("is a directory") != std::string::npos);
    // A PNG header claiming 60000x60000 RGB (43 GB as floats), with almost no data after it.
    const unsigned char huge[] = {
        0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48,
        0x44, 0x52, 0x00, 0x00, 0xea, 0x60, 0x00, 0x00, 0xea, 0x60, 0x08, 0x02, 0x00, 0x00,
        0x00, 0x0f, 0xb0, 0xe2, 0x15, 0x00, 0x00, 0x00, 0x0c, 0x49, 0x44, 0x41, 0x54, 0x78,
        0x9c, 0x63, 0x60, 0xa0, 0x3d, 0x00, 0x00, 0x00, 0x64, 0x00, 0x01, 0x86, 0x64, 0x3c,
        0x35, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
    const std::string huge_path = (dir / "huge.png").string();
    std::ofstream(huge_path, std::ios::binary)
        .write(reinterpret_cast<const char *>(huge), sizeof huge);
    for (ImageRead read : {ImageRead::Whole, ImageRead::Streamed})
        CHECK(error_of(huge_path, read).find("is 60000x60000, more than the maximum") !=
              std::string::npos);
    const std::string garbage = (dir / "garbage.exr").string();
    std::ofstream(garbage) << "not an image";
    CHECK(error_of(garbage).rfind("scene.pbrt:7: cannot read normalmap \"" + garbage + "\": ", 0) ==
          0);

    // A good image: the spec and the pixels; a location naming the file is not repeated.
    const std::string good = (dir / "good.exr").string();
    write_exr(good, 2, 1, {{"", {"R", "G", "B"}, {1, 2, 3, 4, 5, 6}, false}});
    OpenedImage img = open_image(good, FileLoc{good, 0}, "checkpoint");
    CHECK(img.spec.width == 2);
    CHECK(img.spec.height == 1);
    CHECK(img.name == "checkpoint");
    CHECK(img.read_floats(1, 3) == std::vector<float>{2, 3, 5, 6});
    CHECK_THROWS_WITH_AS(img.fail("why"), (good + ":0: cannot read checkpoint: why").c_str(),
                         SceneError);
}
