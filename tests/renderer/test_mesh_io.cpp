// PLY loading: exact values from small files written here, and the shared Stanford bunny.
#include <doctest/doctest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "approx.h"
#include "gzip_test_util.h"
#include "renderer/input/mesh_io.h"
#include "renderer/input/scene_desc.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() { return test::temp_dir("test_mesh_io"); }

std::string write_text(const std::string &name, const std::string &text) {
    return test::write_text(temp_dir() / name, text);
}

template <typename T>
void put(std::string &s, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s.append(b, sizeof(T));
}

// A unit quad (with normals and s/t uvs) and a triangle attached to it.
const char *kAsciiQuad = R"(ply
format ascii 1.0
comment written by test_mesh_io
element vertex 5
property float x
property float y
property float z
property float nx
property float ny
property float nz
property float s
property float t
property float confidence
element face 2
property list uchar int vertex_indices
end_header
0 0 0 0 0 1 0 0 0.9
1 0 0 0 0 1 1 0 0.9
1 1 0 0 0 1 1 1 0.9
0 1 0 0 0 1 0 1 0.9
2 2 0.5 0 1 0 0.5 0.25 0.9
4 0 1 2 3
3 1 4 2
)";

}  // namespace

TEST_CASE("load_ply: ASCII quad + triangle with normals and s/t uvs") {
    MeshData m = load_ply(write_text("quad_ascii.ply", kAsciiQuad));
    REQUIRE(m.p.size() == 5);
    REQUIRE(m.n.size() == 5);
    REQUIRE(m.uv.size() == 5);
    // The quad splits into (0 1 2), (0 2 3); the triangle stays as it is.
    std::vector<uint32_t> expect = {0, 1, 2, 0, 2, 3, 1, 4, 2};
    CHECK(m.indices == expect);
    CHECK(m.triangle_count() == 3);
    CHECK(m.p[4].x == 2.f);
    CHECK(m.p[4].y == 2.f);
    CHECK(m.p[4].z == 0.5f);
    CHECK(m.n[4].y == 1.f);
    CHECK(m.n[4].z == 0.f);
    CHECK(m.uv[4].x == 0.5f);
    CHECK(m.uv[4].y == 0.25f);  // no v flip
    CHECK(m.uv[2].x == 1.f);
    CHECK(m.uv[2].y == 1.f);
    CHECK(m.face_indices.empty());
}

TEST_CASE("load_ply: binary little-endian with u/v, uchar/uint indices, no normals") {
    std::string s =
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float u\nproperty float v\n"
        "element face 2\nproperty list uchar uint vertex_indices\nend_header\n";
    const float verts[4][5] = {{-1.5f, 0.25f, 3.f, 0.f, 0.f},
                               {1.5f, 0.25f, 3.f, 1.f, 0.f},
                               {1.5f, 2.25f, 3.f, 1.f, 1.f},
                               {-1.5f, 2.25f, -7.125f, 0.f, 0.75f}};
    for (auto &v : verts)
        for (float f : v) put(s, f);
    put<uint8_t>(s, 3);
    for (uint32_t i : {0u, 1u, 2u}) put(s, i);
    put<uint8_t>(s, 4);
    for (uint32_t i : {3u, 2u, 1u, 0u}) put(s, i);
    MeshData m = load_ply(write_text("bin_le.ply", s));
    REQUIRE(m.p.size() == 4);
    CHECK(m.n.empty());  // never generated
    REQUIRE(m.uv.size() == 4);
    for (int i = 0; i < 4; ++i) {
        CHECK(m.p[i].x == verts[i][0]);
        CHECK(m.p[i].y == verts[i][1]);
        CHECK(m.p[i].z == verts[i][2]);
        CHECK(m.uv[i].x == verts[i][3]);
        CHECK(m.uv[i].y == verts[i][4]);
    }
    std::vector<uint32_t> expect = {0, 1, 2, 3, 2, 1, 3, 1, 0};
    CHECK(m.indices == expect);
}

TEST_CASE("load_ply: errors name the file") {
    std::string missing = (temp_dir() / "does_not_exist.ply").string();
    CHECK_THROWS_AS(load_ply(missing), SceneError);
    try {
        load_ply(missing);
    } catch (const SceneError &e) {
        CHECK(std::string(e.what()).rfind(missing + ":0: ", 0) == 0);
    }
    std::string bad = write_text("bad.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                 "property float y\nproperty float z\nelement face 1\n"
                                 "property list uchar int vertex_indices\nend_header\n"
                                 "0 0 0\n3 0 1 7\n");
    CHECK_THROWS_AS(load_ply(bad), SceneError);
    std::string junk = write_text("junk.ply", "this is not a ply file\n");
    CHECK_THROWS_AS(load_ply(junk), SceneError);
}

TEST_CASE("load_ply: other elements before, between and after vertex and face are skipped") {
    // The PLY specification lets elements come in any order; only "vertex" and "face" are read.
    const std::string vertex = "element vertex 3\nproperty float x\nproperty float y\n"
                               "property float z\n";
    const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
    const std::string foo = "element foo 2\nproperty float a\nproperty list uchar int b\n";
    const std::string vdata = "0 0 0\n1 0 0\n0 1 0\n", fdata = "3 0 1 2\n",
                      foodata = "1.5 2 7 8\n2.5 0\n";
    struct Case {
        std::string name, header, body;
    };
    // (No structured bindings: clang cannot capture them in CAPTURE's lambda.)
    for (const Case &c : {Case{"foo_first.ply", foo + vertex + face, foodata + vdata + fdata},
                          Case{"foo_between.ply", vertex + foo + face, vdata + foodata + fdata},
                          Case{"foo_last.ply", vertex + face + foo, vdata + fdata + foodata},
                          Case{"face_first.ply", face + foo + vertex, fdata + foodata + vdata}}) {
        CAPTURE(c.name);
        MeshData m = load_ply(
            write_text(c.name, "ply\nformat ascii 1.0\n" + c.header + "end_header\n" + c.body));
        CHECK(m.p.size() == 3);
        CHECK(m.p[1].x == 1.f);
        CHECK(m.p[2].y == 1.f);
        CHECK(m.indices == std::vector<uint32_t>{0, 1, 2});
    }
}

TEST_CASE("load_ply: Stanford bunny (binary) and bunny_lowres (ASCII, extra properties)") {
    TESSERA_REQUIRE_SHARED(shared);
    MeshData big = load_ply(shared + "/scenes/stanford-bunny/bunny.ply");
    CHECK(big.p.size() == 35947);
    CHECK(big.triangle_count() == 69451);
    CHECK(big.n.empty());
    CHECK(big.uv.empty());
    // First vertex of the file.
    CHECK(big.p[0].x == test::Approx(-0.0378297).epsilon(1e-6));
    CHECK(big.p[0].y == test::Approx(0.12794).epsilon(1e-6));
    CHECK(big.p[0].z == test::Approx(0.00447467).epsilon(1e-6));
    // First face of the file.
    CHECK(big.indices[0] == 21216);
    CHECK(big.indices[1] == 21215);
    CHECK(big.indices[2] == 20399);
    uint32_t max_index = 0;
    for (uint32_t i : big.indices) max_index = std::max(max_index, i);
    CHECK(max_index < big.p.size());

    MeshData low = load_ply(shared + "/scenes/stanford-bunny/bunny_lowres.ply");
    CHECK(low.p.size() == 453);
    CHECK(low.triangle_count() == 948);
    CHECK(low.p[0].x == test::Approx(-0.0312216).epsilon(1e-6));
    CHECK(low.p[0].y == test::Approx(0.126304).epsilon(1e-6));
    CHECK(low.p[0].z == test::Approx(0.00514924).epsilon(1e-6));
    CHECK(low.indices[0] == 164);
    CHECK(low.indices[1] == 94);
    CHECK(low.indices[2] == 98);
}

TEST_CASE("load_ply: a .ply.gz file gives exactly the mesh of the .ply it compresses") {
    // pbrt-v4-scenes ships meshes as "geometry/*.ply.gz"; pbrt-v4 decompresses them.
    auto same = [](const MeshData &a, const MeshData &b) {
        REQUIRE(a.p.size() == b.p.size());
        for (size_t i = 0; i < a.p.size(); ++i) {
            CHECK(a.p[i].x == b.p[i].x);
            CHECK(a.p[i].y == b.p[i].y);
            CHECK(a.p[i].z == b.p[i].z);
        }
        CHECK(a.n.size() == b.n.size());
        CHECK(a.uv.size() == b.uv.size());
        CHECK(a.indices == b.indices);
    };
    MeshData ascii = load_ply(write_text("gz_ascii.ply", kAsciiQuad));
    MeshData ascii_gz = load_ply(test::write_gzip(temp_dir() / "gz_ascii.ply.gz", kAsciiQuad));
    same(ascii, ascii_gz);
    CHECK(ascii_gz.n.size() == 5);
    CHECK(ascii_gz.uv[4].y == 0.25f);

    // Binary, and the bunny where ../shared is present.
    std::string s =
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
        "property float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.5f, 0.f}) put(s, f);
    put<uint8_t>(s, 3);
    for (int32_t i : {2, 1, 0}) put(s, i);
    same(load_ply(write_text("gz_bin.ply", s)),
         load_ply(test::write_gzip(temp_dir() / "gz_bin.ply.gz", s)));

    std::string shared = test::shared_dir();
    if (!shared.empty()) {
        std::ifstream in(shared + "/scenes/stanford-bunny/bunny.ply", std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        MeshData gz = load_ply(test::write_gzip(temp_dir() / "bunny.ply.gz", bytes));
        same(load_ply(shared + "/scenes/stanford-bunny/bunny.ply"), gz);
        CHECK(gz.triangle_count() == 69451);
    }
}

TEST_CASE("load_ply: a broken .ply.gz is an error naming the file") {
    // Decompressed but malformed: the same checks as a plain PLY file.
    std::string no_end = test::write_gzip(temp_dir() / "no_end.ply.gz",
                                          "ply\nformat ascii 1.0\nelement vertex 3\n");
    CHECK_THROWS_WITH(load_ply(no_end), doctest::Contains((no_end + ":0: PLY header has no").c_str()));
    // A face list that runs past the end of the decompressed data.
    std::string past = test::write_gzip(
        temp_dir() / "past.ply.gz",
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n" +
            std::string(36, '\0') + "\xff");
    CHECK_THROWS_WITH(load_ply(past), doctest::Contains("runs past the end of the file"));
    // Truncated compressed data.
    std::string whole = test::write_gzip(temp_dir() / "whole.ply.gz", kAsciiQuad);
    std::ifstream in(whole, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::string cut = write_text("cut.ply.gz", bytes.substr(0, bytes.size() - 10));
    CHECK_THROWS_WITH(load_ply(cut),
                      doctest::Contains((cut + ":0: cannot read PLY: the file is not valid gzip data").c_str()));
}
