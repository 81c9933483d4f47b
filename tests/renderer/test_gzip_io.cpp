// gzip-compressed input (renderer/util/gzip_io.h): exact round trips, multi-member files, plain data
// under a ".gz" name, and clear errors for truncated, corrupt and oversized data.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "gzip_test_util.h"
#include "renderer/util/gzip_io.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;

namespace {

fs::path dir() { return test::temp_dir("test_gzip_io"); }

std::string read_bytes(const std::string &path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

/// Text of `n` bytes that is not all one byte (so it compresses, but not to nothing).
std::string pattern(size_t n) {
    std::string s(n, ' ');
    uint32_t x = 12345;
    for (char &c : s) {
        x = x * 1664525u + 1013904223u;
        c = char('a' + (x >> 24) % 26);
    }
    return s;
}

}  // namespace

TEST_CASE("has_gz_extension / strip_gz_extension") {
    CHECK(has_gz_extension("scene.pbrt.gz"));
    CHECK(has_gz_extension("MESH.PLY.GZ"));
    CHECK(has_gz_extension(".gz"));
    CHECK_FALSE(has_gz_extension("scene.pbrt"));
    CHECK_FALSE(has_gz_extension("gz"));
    CHECK_FALSE(has_gz_extension("a.tgz"));
    CHECK(strip_gz_extension("geometry/mesh.ply.gz") == "geometry/mesh.ply");
    CHECK(strip_gz_extension("mesh.ply") == "mesh.ply");
}

TEST_CASE("read_gzip_file: exact round trip, larger than one read chunk") {
    // 3 MiB + 5 bytes: three full 1 MiB reads and a partial one.
    const std::string data = pattern((size_t(3) << 20) + 5);
    std::string path = test::write_gzip(dir() / "big.gz", data);
    CHECK(fs::file_size(path) < data.size());  // really compressed
    std::string out;
    CHECK(read_gzip_file(path, &out, uint64_t(1) << 30) == "");
    CHECK(out.size() == data.size());
    CHECK(out == data);
}

TEST_CASE("read_gzip_file: every member of a multi-member file, and an empty file") {
    std::string path = test::write_gzip(dir() / "multi.gz", "first member\n");
    test::write_gzip(path, "second member\n", true);
    std::string out;
    CHECK(read_gzip_file(path, &out, 1000) == "");
    CHECK(out == "first member\nsecond member\n");

    std::string empty = test::write_gzip(dir() / "empty.gz", "");
    CHECK(read_gzip_file(empty, &out, 1000) == "");
    CHECK(out.empty());
}

TEST_CASE("read_gzip_file: data that is not gzip is read as it is") {
    std::string path = test::write_text(dir() / "plain.pbrt.gz", "WorldBegin\n");
    std::string out;
    CHECK(read_gzip_file(path, &out, 1000) == "");
    CHECK(out == "WorldBegin\n");
}

TEST_CASE("read_gzip_file: truncated and corrupt data are errors, not short reads") {
    const std::string data = pattern(200000);
    std::string whole = read_bytes(test::write_gzip(dir() / "whole.gz", data));
    REQUIRE(whole.size() > 1000);
    std::string out;

    // Cut in the middle of the deflate stream, and cut just before the 8-byte trailer.
    for (size_t keep : {whole.size() / 2, whole.size() - 8}) {
        CAPTURE(keep);
        std::string cut = test::write_text(dir() / "cut.gz", whole.substr(0, keep));
        std::string why = read_gzip_file(cut, &out, uint64_t(1) << 30);
        CHECK(why.find("is not valid gzip data") == 0);
        CHECK(why.find("truncated") != std::string::npos);
    }

    // A changed byte in the compressed body: a bad stream or a CRC mismatch, never a success.
    std::string bad = whole;
    bad[bad.size() / 2] = char(bad[bad.size() / 2] ^ 0x5a);
    std::string corrupt = test::write_text(dir() / "corrupt.gz", bad);
    CHECK(read_gzip_file(corrupt, &out, uint64_t(1) << 30).find("is not valid gzip data") == 0);

    // A changed CRC in the trailer.
    std::string crc = whole;
    crc[crc.size() - 6] = char(crc[crc.size() - 6] ^ 0x01);
    std::string bad_crc = test::write_text(dir() / "bad_crc.gz", crc);
    CHECK(read_gzip_file(bad_crc, &out, uint64_t(1) << 30).find("is not valid gzip data") == 0);
}

TEST_CASE("read_gzip_file: the size limit stops a gzip bomb while decompressing") {
    // 64 MiB of zeros compress to about 64 KiB.
    const std::string zeros(size_t(64) << 20, '\0');
    std::string bomb = test::write_gzip(dir() / "bomb.gz", zeros);
    CHECK(fs::file_size(bomb) < (size_t(1) << 20));
    std::string out;
    std::string why = read_gzip_file(bomb, &out, uint64_t(1) << 20);
    CHECK(why == "decompresses to more than the maximum of 1.0 MiB");
    CHECK(out.size() <= (size_t(1) << 20));

    // Exactly at the limit is fine; one byte over is not.
    std::string exact = test::write_gzip(dir() / "exact.gz", pattern(4096));
    CHECK(read_gzip_file(exact, &out, 4096) == "");
    CHECK(out.size() == 4096);
    CHECK(read_gzip_file(exact, &out, 4095).find("decompresses to more than") == 0);
}

TEST_CASE("read_gzip_file: missing files, folders and non-regular files") {
    std::string out;
    CHECK(read_gzip_file((dir() / "missing.gz").string(), &out, 100) == "not found");
    fs::create_directories(dir() / "folder.gz");
    CHECK(read_gzip_file((dir() / "folder.gz").string(), &out, 100) ==
          "is a directory, not a file");
    CHECK(read_gzip_file("/dev/zero", &out, 100) == "is not a regular file");
}
