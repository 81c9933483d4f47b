// Tessera's PLY reader (renderer/input/ply_reader.h) against generated files of every layout: each
// file is checked against the mesh its generator meant and against an independent reader
// written with numpy (tests/renderer/ply_numpy_reader.py, run once for all files), value for
// value. Then the errors, and the shared scenes' meshes.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include <sys/wait.h>

#include "gzip_test_util.h"
#include "renderer/util/gzip_io.h"
#include "renderer/input/mesh_io.h"
#include "renderer/input/ply_reader.h"
#include "renderer/input/scene_desc.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() { return test::temp_dir("test_ply_reader"); }

// ---------------------------------------------------------------------------------------------
// A PLY writer for the tests: elements of scalar and list properties, in any format.

enum class Fmt { Ascii, Le, Be };
const char *format_name(Fmt f) {
    return f == Fmt::Ascii ? "ascii" : f == Fmt::Le ? "binary_little_endian" : "binary_big_endian";
}

const char *const kTypeNames[16] = {"char",  "uchar",  "short",  "ushort",  "int",   "uint",
                                    "float", "double", "int8",   "uint8",   "int16", "uint16",
                                    "int32", "uint32", "float32", "float64"};
const char *const kIntTypeNames[12] = {"char",  "uchar",  "short",  "ushort", "int",   "uint",
                                       "int8",  "uint8",  "int16",  "uint16", "int32", "uint32"};

/// Canonical code of a type name: i1 u1 i2 u2 i4 u4 f4 f8.
std::string code_of(const std::string &t) {
    static const std::map<std::string, std::string> m = {
        {"char", "i1"},    {"int8", "i1"},    {"uchar", "u1"},   {"uint8", "u1"},
        {"short", "i2"},   {"int16", "i2"},   {"ushort", "u2"},  {"uint16", "u2"},
        {"int", "i4"},     {"int32", "i4"},   {"uint", "u4"},    {"uint32", "u4"},
        {"float", "f4"},   {"float32", "f4"}, {"double", "f8"},  {"float64", "f8"}};
    return m.at(t);
}

struct GenProp {
    std::string type, name;
    bool list = false;
    std::string count_type;
    GenProp() = default;
    GenProp(std::string t, std::string n, bool l = false, std::string ct = "")
        : type(std::move(t)), name(std::move(n)), list(l), count_type(std::move(ct)) {}
};

struct GenElement {
    std::string name;
    std::vector<GenProp> props;
    /// Per record, per property: one value (scalar) or the list's items.
    std::vector<std::vector<std::vector<double>>> records;
};

template <typename T>
void put_bytes(std::string &s, T v, bool big) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big) std::reverse(b, b + sizeof(T));
    s.append(b, sizeof(T));
}

void put_value(std::string &s, const std::string &type, double v, Fmt f) {
    const std::string c = code_of(type);
    if (f == Fmt::Ascii) {
        char buf[64];
        if (c == "f4")
            std::snprintf(buf, sizeof buf, "%.9g", double(float(v)));
        else if (c == "f8")
            std::snprintf(buf, sizeof buf, "%.17g", v);
        else
            std::snprintf(buf, sizeof buf, "%lld", (long long)v);
        s += buf;
        s += ' ';
        return;
    }
    const bool big = f == Fmt::Be;
    if (c == "i1") put_bytes(s, int8_t(v), big);
    if (c == "u1") put_bytes(s, uint8_t(v), big);
    if (c == "i2") put_bytes(s, int16_t(v), big);
    if (c == "u2") put_bytes(s, uint16_t(v), big);
    if (c == "i4") put_bytes(s, int32_t(v), big);
    if (c == "u4") put_bytes(s, uint32_t(v), big);
    if (c == "f4") put_bytes(s, float(v), big);
    if (c == "f8") put_bytes(s, v, big);
}

std::string write_ply(Fmt f, const std::vector<GenElement> &elements, bool crlf = false) {
    const std::string nl = crlf ? "\r\n" : "\n";
    std::string s = "ply" + nl + "format " + format_name(f) + " 1.0" + nl +
                    "comment written by test_ply_reader" + nl;
    for (const GenElement &e : elements) {
        s += "element " + e.name + " " + std::to_string(e.records.size()) + nl;
        for (const GenProp &p : e.props)
            s += p.list ? "property list " + p.count_type + " " + p.type + " " + p.name + nl
                        : "property " + p.type + " " + p.name + nl;
    }
    s += "end_header" + nl;
    for (const GenElement &e : elements)
        for (const auto &rec : e.records) {
            for (size_t k = 0; k < e.props.size(); ++k) {
                const GenProp &p = e.props[k];
                if (p.list) put_value(s, p.count_type, double(rec[k].size()), f);
                for (double v : rec[k]) put_value(s, p.type, v, f);
            }
            if (f == Fmt::Ascii) s += nl;
        }
    return s;
}

// ---------------------------------------------------------------------------------------------
// Generated meshes and what they must give.

/// What load_ply must return for a generated file.
struct Expected {
    std::vector<float> p, n, uv;
    std::vector<uint32_t> indices, face_of_triangle;
    std::vector<int> face_indices;
};

/// A value of `type` that converts exactly where it must: small integers for integer types,
/// multiples of 1/64 for float, and for double any value (rounded to float by the reader).
double value_for(const std::string &type, std::mt19937 &rng) {
    const std::string c = code_of(type);
    std::uniform_int_distribution<int> small(c[0] == 'u' ? 0 : -60, 100);
    if (c == "f4") return double(std::uniform_int_distribution<int>(-6400, 6400)(rng)) / 64.0;
    if (c == "f8") return std::uniform_real_distribution<double>(-100, 100)(rng);
    return double(small(rng));
}

struct GenOptions {
    Fmt format = Fmt::Le;
    std::string coord_type = "float", count_type = "uchar", index_type = "int";
    bool normals = false;
    const char *uv_names[2] = {nullptr, nullptr};
    std::string normal_type = "float", uv_type = "float";
    int vertices = 12, faces = 10;
    bool polygons = false, degenerate = false;
    std::string face_indices_type;  ///< "" for none
    std::string index_list_name = "vertex_indices";
    int extra_vertex_props = 0, extra_face_props = 0;
    bool shuffle = false;
    /// Extra elements: 0 none, 1 before vertex, 2 between, 3 after face, 4 all three.
    int extra_elements = 0;
    bool face_first = false;  ///< the face element before the vertex element
    bool crlf = false;
};

GenProp random_extra(const std::string &name, std::mt19937 &rng, bool allow_list) {
    GenProp p;
    p.name = name;
    p.type = kTypeNames[rng() % 16];
    if (allow_list && rng() % 2 == 0) {
        p.list = true;
        p.count_type = kIntTypeNames[rng() % 12];
    }
    return p;
}

std::vector<double> random_values(const GenProp &p, std::mt19937 &rng) {
    std::vector<double> v;
    const int n = p.list ? int(rng() % 4) : 1;
    for (int i = 0; i < n; ++i) v.push_back(value_for(p.type, rng));
    return v;
}

GenElement random_element(const std::string &name, std::mt19937 &rng) {
    GenElement e;
    e.name = name;
    const int nprops = 1 + int(rng() % 3);
    for (int k = 0; k < nprops; ++k)
        e.props.push_back(random_extra("q" + std::to_string(k), rng, true));
    const int n = int(rng() % 4);
    for (int i = 0; i < n; ++i) {
        std::vector<std::vector<double>> rec;
        for (const GenProp &p : e.props) rec.push_back(random_values(p, rng));
        e.records.push_back(rec);
    }
    return e;
}

/// The file's bytes for `o` (elements, records and types drawn from `rng`), and in *x the
/// mesh load_ply must return.
std::string generate(const GenOptions &o, std::mt19937 &rng, Expected *x) {
    GenElement v{"vertex", {}, {}}, f{"face", {}, {}};
    // Vertex properties: roles first, shuffled below with the extras.
    struct Role {
        GenProp prop;
        int slot;  // 0-2 p, 3-5 n, 6-7 uv, -1 extra
    };
    std::vector<Role> roles;
    const char *xyz[3] = {"x", "y", "z"}, *nxyz[3] = {"nx", "ny", "nz"};
    for (int i = 0; i < 3; ++i) roles.push_back({{o.coord_type, xyz[i]}, i});
    if (o.normals)
        for (int i = 0; i < 3; ++i) roles.push_back({{o.normal_type, nxyz[i]}, 3 + i});
    if (o.uv_names[0])
        for (int i = 0; i < 2; ++i) roles.push_back({{o.uv_type, o.uv_names[i]}, 6 + i});
    for (int k = 0; k < o.extra_vertex_props; ++k)
        roles.push_back({random_extra("extra" + std::to_string(k), rng, true), -1});
    if (o.shuffle) std::shuffle(roles.begin(), roles.end(), rng);
    for (const Role &r : roles) v.props.push_back(r.prop);
    for (int i = 0; i < o.vertices; ++i) {
        std::vector<std::vector<double>> rec;
        float vals[8] = {};
        for (const Role &r : roles) {
            rec.push_back(random_values(r.prop, rng));
            if (r.slot >= 0) vals[r.slot] = float(rec.back()[0]);
        }
        v.records.push_back(rec);
        x->p.insert(x->p.end(), vals, vals + 3);
        if (o.normals) x->n.insert(x->n.end(), vals + 3, vals + 6);
        if (o.uv_names[0]) x->uv.insert(x->uv.end(), vals + 6, vals + 8);
    }
    // Face properties: the index list, face_indices and extras.
    std::vector<Role> froles;
    GenProp list{o.index_type, o.index_list_name, true, o.count_type};
    froles.push_back({list, 0});
    if (!o.face_indices_type.empty()) froles.push_back({{o.face_indices_type, "face_indices"}, 1});
    for (int k = 0; k < o.extra_face_props; ++k)
        froles.push_back({random_extra("fextra" + std::to_string(k), rng, true), -1});
    if (o.shuffle) std::shuffle(froles.begin(), froles.end(), rng);
    for (const Role &r : froles) f.props.push_back(r.prop);
    bool any_polygon = false;
    for (int i = 0; i < o.faces; ++i) {
        int n = 3;
        if (o.polygons && i % 3 == 1) n = 4 + int(rng() % 4);
        if (o.degenerate && i % 5 == 2) n = int(rng() % 3);
        std::vector<double> idx;
        for (int k = 0; k < n; ++k) idx.push_back(double(rng() % uint32_t(o.vertices)));
        const int id = int(rng() % 50);
        std::vector<std::vector<double>> rec;
        for (const Role &r : froles)
            rec.push_back(r.slot == 0 ? idx : r.slot == 1 ? std::vector<double>{double(id)}
                                                          : random_values(r.prop, rng));
        f.records.push_back(rec);
        any_polygon = any_polygon || n > 3;
        for (int k = 1; k + 1 < n; ++k) {
            for (double j : {idx[0], idx[size_t(k)], idx[size_t(k) + 1]})
                x->indices.push_back(uint32_t(j));
            x->face_of_triangle.push_back(uint32_t(i));
            if (!o.face_indices_type.empty()) x->face_indices.push_back(id);
        }
    }
    if (!any_polygon) x->face_of_triangle.clear();
    std::vector<GenElement> elements;
    const bool before = o.extra_elements == 1 || o.extra_elements == 4,
               between = o.extra_elements == 2 || o.extra_elements == 4,
               after = o.extra_elements == 3 || o.extra_elements == 4;
    if (before) elements.push_back(random_element("material", rng));
    elements.push_back(o.face_first ? f : v);
    if (between) elements.push_back(random_element("edge", rng));
    elements.push_back(o.face_first ? v : f);
    if (after) elements.push_back(random_element("range_grid", rng));
    return write_ply(o.format, elements, o.crlf);
}

// ---------------------------------------------------------------------------------------------
// Comparing meshes.

std::vector<float> flat(const std::vector<Vec3f> &v) {
    std::vector<float> out;
    for (const Vec3f &a : v) out.insert(out.end(), {a.x, a.y, a.z});
    return out;
}
std::vector<float> flat(const std::vector<Vec2f> &v) {
    std::vector<float> out;
    for (const Vec2f &a : v) out.insert(out.end(), {a.x, a.y});
    return out;
}

/// The arrays the numpy reader wrote for one file, or its "error ..." line.
struct NumpyMesh {
    std::string error;
    std::map<std::string, std::vector<float>> f4;
    std::map<std::string, std::vector<uint32_t>> u4;
    std::map<std::string, std::vector<int>> i4;
};

/// The next mesh of the numpy reader's output.
NumpyMesh read_numpy_mesh(std::istream &in) {
    NumpyMesh m;
    std::string line;
    if (!std::getline(in, line) || line != "mesh") {
        m.error = "missing output";
        return m;
    }
    while (std::getline(in, line) && line != "end") {
        if (line.rfind("error", 0) == 0) {
            m.error = line;
            continue;
        }
        std::istringstream ls(line);
        std::string name, dtype;
        size_t count = 0;
        ls >> name >> dtype >> count;
        auto read_into = [&](auto &vec) {
            vec.resize(count);
            in.read(reinterpret_cast<char *>(vec.data()), std::streamsize(4 * count));
        };
        if (dtype == "f4") read_into(m.f4[name]);
        if (dtype == "u4") read_into(m.u4[name]);
        if (dtype == "i4") read_into(m.i4[name]);
        if (!in) {
            m.error = "truncated output";
            break;
        }
    }
    return m;
}

/// Bitwise equality of two float arrays (CHECK reports the first difference only).
void check_floats(const std::vector<float> &a, const std::vector<float> &b, const char *what) {
    CAPTURE(what);
    REQUIRE(a.size() == b.size());
    for (size_t i = 0; i < a.size(); ++i)
        if (std::memcmp(&a[i], &b[i], 4) != 0) {
            CAPTURE(i);
            CHECK(a[i] == b[i]);
            return;
        }
}

void check_against(const MeshData &m, const Expected &x) {
    check_floats(flat(m.p), x.p, "p");
    check_floats(flat(m.n), x.n, "n");
    check_floats(flat(m.uv), x.uv, "uv");
    CHECK(m.indices == x.indices);
    CHECK(m.face_of_triangle == x.face_of_triangle);
    CHECK(m.face_indices == x.face_indices);
}

void check_against(const MeshData &m, const NumpyMesh &x) {
    CAPTURE(x.error);
    REQUIRE(x.error.empty());
    auto get = [](const auto &map, const char *k) {
        auto it = map.find(k);
        return it == map.end() ? std::decay_t<decltype(it->second)>{} : it->second;
    };
    check_floats(flat(m.p), get(x.f4, "p"), "numpy p");
    check_floats(flat(m.n), get(x.f4, "n"), "numpy n");
    check_floats(flat(m.uv), get(x.f4, "uv"), "numpy uv");
    CHECK(m.indices == get(x.u4, "indices"));
    CHECK(m.face_of_triangle == get(x.u4, "face_of_triangle"));
    CHECK(m.face_indices == get(x.i4, "face_indices"));
}

/// Runs the numpy reader over `files` (one process for all); returns its outputs in order, or
/// an empty vector (with a MESSAGE) when python3 with numpy is not available.
std::vector<NumpyMesh> numpy_read(const std::vector<std::string> &files) {
    const std::string python = TESSERA_NUMPY_PYTHON;
    if (python.empty()) {
        MESSAGE("skipped the numpy comparison: no python3 with numpy found at configure time");
        return {};
    }
    const fs::path out = temp_dir() / "numpy_meshes.bin";
    std::string cmd = "\"" + python + "\" -B \"" + TESSERA_SOURCE_DIR +
                      "/tests/renderer/ply_numpy_reader.py\" \"" + out.string() + "\"";
    for (const std::string &f : files) cmd += " \"" + f + "\"";
    const int rc = std::system(cmd.c_str());
    if (WIFEXITED(rc) && WEXITSTATUS(rc) == 77) {
        MESSAGE("skipped the numpy comparison: " << python << " has no numpy");
        return {};
    }
    REQUIRE(rc == 0);
    std::ifstream in(out, std::ios::binary);
    std::vector<NumpyMesh> meshes;
    for (size_t k = 0; k < files.size(); ++k) meshes.push_back(read_numpy_mesh(in));
    return meshes;
}

std::string error_of(const std::string &path) {
    try {
        load_ply(path);
    } catch (const SceneError &e) {
        return e.what();
    }
    return "no error";
}

std::string write_file(const std::string &name, const std::string &bytes) {
    return test::write_text(temp_dir() / name, bytes);
}

const std::string kTriangleHeader =
    "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";

/// Binary files whose data, right after "end_header\n" (or "\r\n"), starts with a byte a text
/// reader would skip: a vertex whose first property is a uchar 10, 13 or 32, or whose float x
/// starts with that byte; and an ASCII body starting with blank lines and spaces, CRLF
/// throughout.
void add_whitespace_first_files(std::vector<std::string> &files, std::vector<Expected> &expected) {
    for (Fmt f : {Fmt::Le, Fmt::Be})
        for (int byte : {0x0a, 0x0d, 0x20})
            for (bool crlf : {false, true})
                for (bool as_float : {false, true}) {
                    GenElement v{"vertex", {}, {}}, fc{"face", {}, {}};
                    if (!as_float) v.props.push_back({"uchar", "tag"});
                    for (const char *c : {"x", "y", "z"}) v.props.push_back({"float", c});
                    fc.props.push_back({"int", "vertex_indices", true, "uchar"});
                    Expected x;
                    for (int i = 0; i < 3; ++i) {
                        // A float whose first byte in the file is `byte`.
                        uint32_t bits = 0x3f800000u | (f == Fmt::Le ? uint32_t(byte) : 0u);
                        if (f == Fmt::Be) bits = (uint32_t(byte) << 24) | 0x00400000u;
                        float first;
                        std::memcpy(&first, &bits, 4);
                        const float px = i == 0 ? first : float(i), py = float(i % 2),
                                    pz = 0.5f * float(i);
                        std::vector<std::vector<double>> rec;
                        if (!as_float) rec.push_back({double(byte)});
                        for (float c : {px, py, pz}) rec.push_back({double(c)});
                        v.records.push_back(rec);
                        x.p.insert(x.p.end(), {px, py, pz});
                    }
                    fc.records.push_back({{0, 1, 2}});
                    x.indices = {0, 1, 2};
                    const std::string bytes = write_ply(f, {v, fc}, crlf);
                    const std::string head = crlf ? "end_header\r\n" : "end_header\n";
                    REQUIRE(uint8_t(bytes[bytes.find(head) + head.size()]) == byte);
                    files.push_back(write_file("first_byte" + std::to_string(files.size()) +
                                                   ".ply",
                                               bytes));
                    expected.push_back(x);
                }
    // ASCII bodies starting with blank lines and spaces, and CRLF throughout.
    files.push_back(write_file("ascii_blank.ply", "ply\r\nformat ascii 1.0\r\n" +
                                                      std::string(kTriangleHeader).replace(
                                                          0, 0, "comment crlf\r\n") +
                                                      "\n\r\n  0 0 0\r\n1 0 0\r\n 0 1 0\r\n"
                                                      "3 0 1 2\r\n"));
    expected.push_back({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {}, {}, {0, 1, 2}, {}, {}});
}

}  // namespace

TEST_CASE("PLY reader: generated files of every layout match the generator and numpy") {
    std::mt19937 rng(20261201);
    std::vector<GenOptions> cases;
    const Fmt formats[3] = {Fmt::Ascii, Fmt::Le, Fmt::Be};
    const char *uv_pairs[4][2] = {
        {"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
    int k = 0;
    for (Fmt f : formats) {
        // Every scalar type (and alias) for positions, normals and uvs.
        for (int t = 0; t < 16; ++t, ++k) {
            GenOptions o;
            o.format = f;
            o.coord_type = kTypeNames[t];
            o.normals = t % 2 == 0;
            o.normal_type = kTypeNames[(t + 5) % 16];
            o.uv_names[0] = uv_pairs[t % 4][0];
            o.uv_names[1] = uv_pairs[t % 4][1];
            o.uv_type = kTypeNames[(t + 11) % 16];
            cases.push_back(o);
        }
        // The binary layouts with fast paths: float x y z [nx ny nz] [u v] vertices and one
        // "list uchar|int|uint int|uint" per face, large enough to run the loops.
        if (f == Fmt::Ascii) continue;
        for (const char *ct : {"uchar", "int", "uint"})
            for (const char *it : {"int", "uint"})
                for (int nu = 0; nu < 4; ++nu, ++k) {
                    GenOptions o;
                    o.format = f;
                    o.count_type = ct;
                    o.index_type = it;
                    o.normals = nu & 1;
                    if (nu & 2) {
                        o.uv_names[0] = "u";
                        o.uv_names[1] = "v";
                    }
                    o.vertices = 300;
                    o.faces = 500;
                    o.polygons = k % 2 == 1;
                    cases.push_back(o);
                }
    }
    // Every integer type for list lengths and for indices (all 36 pairs, each in two formats,
    // names and aliases in turn), with shuffled properties, extra properties and elements,
    // polygons and face_indices.
    for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b)
            for (int pass = 0; pass < 2; ++pass, ++k) {
                GenOptions o;
                o.format = formats[(a + b + pass) % 3];
                o.count_type = kIntTypeNames[a + 6 * ((a + pass) % 2)];
                o.index_type = kIntTypeNames[b + 6 * ((b + pass + 1) % 2)];
                o.coord_type = kTypeNames[k % 16];
                o.normals = k % 3 == 0;
                o.uv_names[0] = uv_pairs[k % 4][0];
                o.uv_names[1] = uv_pairs[k % 4][1];
                o.polygons = k % 2 == 0;
                o.degenerate = k % 7 == 0;
                o.face_indices_type = k % 3 == 1 ? kTypeNames[k % 16] : "";
                o.extra_vertex_props = k % 3;
                o.extra_face_props = (k / 3) % 3;
                o.shuffle = k % 4 != 3;
                o.extra_elements = k % 5;
                o.face_first = k % 6 == 5;
                o.index_list_name = k % 11 == 4 ? "vertex_index" : "vertex_indices";
                o.crlf = k % 9 == 2;
                cases.push_back(o);
            }
    std::vector<std::string> files;
    std::vector<Expected> expected;
    for (size_t c = 0; c < cases.size(); ++c) {
        Expected x;
        const std::string bytes = generate(cases[c], rng, &x);
        const std::string name = "gen" + std::to_string(c) + ".ply";
        // Every 10th file gzip-compressed, as pbrt-v4-scenes ships them.
        files.push_back(c % 10 == 7 ? test::write_gzip(temp_dir() / (name + ".gz"), bytes)
                                    : write_file(name, bytes));
        expected.push_back(std::move(x));
    }
    add_whitespace_first_files(files, expected);
    std::vector<MeshData> meshes;
    for (size_t c = 0; c < files.size(); ++c) {
        CAPTURE(files[c]);
        meshes.push_back(load_ply(files[c]));
        check_against(meshes.back(), expected[c]);
    }
    std::vector<NumpyMesh> np = numpy_read(files);
    for (size_t c = 0; c < np.size(); ++c) {
        CAPTURE(files[c]);
        check_against(meshes[c], np[c]);
    }
}

TEST_CASE("PLY reader: what pbrt-v4 takes and leaves") {
    // Normals need all three of nx, ny, nz; uvs the first complete pair of pbrt-v4's names.
    const std::string partial =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nproperty float nx\nproperty float ny\nproperty float u\n"
        "property float s\nproperty float t\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n"
        "0 0 0 1 1 9 0.25 0.5\n1 0 0 1 1 9 0.75 1\n0 1 0 1 1 9 1 0\n3 0 1 2\n";
    MeshData m = load_ply(write_file("partial.ply", partial));
    CHECK(m.n.empty());
    REQUIRE(m.uv.size() == 3);
    CHECK(m.uv[0].x == 0.25f);
    CHECK(m.uv[0].y == 0.5f);
    CHECK(m.face_of_triangle.empty());
    CHECK(m.face_indices.empty());

    // A "face_indices" value per triangle, from its face; a quad gives two triangles.
    const std::string ids =
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 2\nproperty int face_indices\n"
        "property list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n7 4 0 1 2 3\n-3 3 0 2 3\n";
    m = load_ply(write_file("face_ids.ply", ids));
    CHECK(m.indices == std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 2, 3});
    CHECK(m.face_of_triangle == std::vector<uint32_t>{0, 0, 1});
    CHECK(m.face_indices == std::vector<int>{7, 7, -3});

    // Lists in the vertex element (binary): skipped by the general reader.
    std::string bin = "ply\nformat binary_big_endian 1.0\nelement vertex 3\n"
                      "property list ushort double weights\nproperty double x\n"
                      "property double y\nproperty double z\nelement face 1\n"
                      "property list uint ushort vertex_indices\nproperty uchar flags\n"
                      "end_header\n";
    for (int i = 0; i < 3; ++i) {
        put_bytes(bin, uint16_t(i), true);
        for (int j = 0; j < i; ++j) put_bytes(bin, 0.5, true);
        for (double c : {1.0 * i, 0.1, -2.0}) put_bytes(bin, c, true);
    }
    put_bytes(bin, uint32_t(3), true);
    for (uint16_t i : {2, 1, 0}) put_bytes(bin, i, true);
    put_bytes(bin, uint8_t(1), true);
    m = load_ply(write_file("vertex_lists.ply", bin));
    REQUIRE(m.p.size() == 3);
    CHECK(m.p[2].x == 2.f);
    CHECK(m.p[1].y == float(0.1));
    CHECK(m.indices == std::vector<uint32_t>{2, 1, 0});

    // Faces of fewer than 3 vertices are dropped (with a warning); a file of nothing else has
    // no triangles.
    const std::string lines =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n2 0 1\n0\n3 0 1 2\n";
    const int warnings = warning_count();
    m = load_ply(write_file("lines.ply", lines));
    CHECK(m.indices == std::vector<uint32_t>{0, 1, 2});
    CHECK(warning_count() == warnings + 1);
    CHECK(last_warning().find("2 faces with fewer than 3 vertices ignored") != std::string::npos);
    // Skipped faces before the first polygon still count in face_of_triangle.
    const std::string mixed =
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
        "property float y\nproperty float z\nelement face 6\n"
        "property list uchar int vertex_indices\nend_header\n";
    std::string mb = mixed;
    for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 1.f, 0.f, 0.f, 1.f, 0.f})
        put_bytes(mb, f, false);
    for (const std::vector<int32_t> &face : std::vector<std::vector<int32_t>>{
             {0, 1, 2}, {}, {1, 2}, {0, 2, 3}, {0, 1, 2, 3}, {3}})
        {
            put_bytes(mb, uint8_t(face.size()), false);
            for (int32_t i : face) put_bytes(mb, i, false);
        }
    m = load_ply(write_file("mixed.ply", mb));
    CHECK(m.indices == std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3});
    CHECK(m.face_of_triangle == std::vector<uint32_t>{0, 3, 4, 4});
}

TEST_CASE("PLY reader: errors name the file, the element and the record") {
    auto bin_triangle = [](int32_t i0, int32_t i1, int32_t i2, uint8_t n = 3) {
        std::string s = "ply\nformat binary_little_endian 1.0\n" + kTriangleHeader;
        for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put_bytes(s, f, false);
        put_bytes(s, n, false);
        for (int32_t i : {i0, i1, i2}) put_bytes(s, i, false);
        return s;
    };
    struct Case {
        std::string name, bytes, message;
    };
    const std::string ascii = "ply\nformat ascii 1.0\n";
    const std::vector<Case> cases = {
        {"index.ply", bin_triangle(0, 1, 7), "face 0: vertex index 7 out of range (3 vertices)"},
        {"negative_index.ply", bin_triangle(0, -1, 2),
         "face 0: vertex index -1 out of range (3 vertices)"},
        {"ascii_index.ply", ascii + kTriangleHeader + "0 0 0\n1 0 0\n0 1 0\n4 0 1 2 -2\n",
         "face 0: vertex index -2 out of range (3 vertices)"},
        {"list_past_end.ply", bin_triangle(0, 1, 2, 200),
         "face 0: a list of 200 values runs past the end of the file"},
        {"negative_length.ply",
         ascii + "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                 "element face 1\nproperty list char int vertex_indices\nend_header\n"
                 "0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n",
         "face 0: list \"vertex_indices\" has a negative length -3"},
        {"bad_number.ply", ascii + kTriangleHeader + "0 0 0\n1 0x 0\n0 1 0\n3 0 1 2\n",
         "vertex 1: property \"y\": \"0x\" is not a number"},
        {"bad_count.ply", ascii + kTriangleHeader + "0 0 0\n1 0 0\n0 1 0\n3.0 0 1 2\n",
         "face 0: property \"vertex_indices\": \"3.0\" is not an integer"},
        {"uchar_range.ply", ascii + kTriangleHeader + "0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n",
         "face 0: property \"vertex_indices\": \"300\" is out of range for uchar"},
        {"ascii_short.ply", ascii + kTriangleHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1\n",
         "face 0: the data ends early (truncated file)"},
        {"huge_count.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
         "property float x\nproperty float y\nproperty float z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n" + std::string(40, '\0'),
         "PLY header declares 1000000000000 vertices and 1 faces, more than the 221 bytes of "
         "the file can hold (truncated or corrupt file)"},
        {"huge_other.ply",
         "ply\nformat binary_little_endian 1.0\nelement material 99999999999999\n"
         "property uchar a\n" + kTriangleHeader + std::string(40, '\0'),
         "PLY header declares 99999999999999 \"material\" elements, 3 vertices and 1 faces, "
         "more than the"},
        {"no_x.ply", ascii + "element vertex 1\nproperty float y\nproperty float z\n"
                             "element face 0\nproperty list uchar int vertex_indices\n"
                             "end_header\n0 0\n",
         "PLY vertex element has no \"x\" property"},
        {"no_indices.ply", ascii + "element vertex 1\nproperty float x\nproperty float y\n"
                                   "property float z\nelement face 0\nproperty int a\n"
                                   "end_header\n0 0 0\n",
         "PLY face element has no \"vertex_indices\" list"},
        {"float_indices.ply", ascii + "element vertex 1\nproperty float x\nproperty float y\n"
                                      "property float z\nelement face 0\n"
                                      "property list uchar float vertex_indices\n"
                                      "end_header\n0 0 0\n",
         "PLY face list \"vertex_indices\" has items of type float, not an integer type"},
        {"float_count.ply", ascii + "element vertex 1\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 0\n"
                                    "property list float int vertex_indices\nend_header\n",
         "PLY list \"vertex_indices\" has a length of type float, not an integer type"},
        {"unknown_type.ply", ascii + "element vertex 1\nproperty flt x\n",
         "PLY property \"x\" has an unknown type \"flt\""},
        {"twice.ply", ascii + "element vertex 1\nproperty float x\nproperty float x\n",
         "PLY element \"vertex\" has two properties \"x\""},
        {"x_list.ply", ascii + "element vertex 1\nproperty list uchar float x\n"
                               "property float y\nproperty float z\nelement face 0\n"
                               "property list uchar int vertex_indices\nend_header\n",
         "PLY vertex property \"x\" is a list"},
        {"no_face.ply", ascii + "element vertex 1\nproperty float x\nend_header\n0\n",
         "PLY file has no \"face\" element: no triangles or quads"},
        {"bad_first_line.ply", "ply \nformat ascii 1.0\n", "not a PLY file"},
        {"truncated_vertices.ply",
         "ply\nformat binary_little_endian 1.0\nelement face 1\n"
         "property list uchar int vertex_indices\nelement vertex 3\nproperty float x\n"
         "property float y\nproperty float z\nend_header\n\x03" + std::string(12 + 30, '\0'),
         "vertex 2: the data ends early (truncated file)"},
        {"face_id.ply", ascii + "element vertex 3\nproperty float x\nproperty float y\n"
                                "property float z\nelement face 1\n"
                                "property list uchar int vertex_indices\n"
                                "property double face_indices\nend_header\n"
                                "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1e20\n",
         "face 0: face_indices value 100000000000000000000.000000 is not an int"},
        {"control.ply", ascii + "element vertex 1\x01\n", "PLY header line 3 holds a control"},
    };
    for (const Case &c : cases) {
        CAPTURE(c.name);
        const std::string path = write_file(c.name, c.bytes);
        const std::string msg = error_of(path);
        CHECK(msg.rfind(path + ":0: " + c.message, 0) == 0);
        if (msg.rfind(path + ":0: " + c.message, 0) != 0) MESSAGE(msg);
    }
}

TEST_CASE("PLY reader: header counts are bounded by the file before anything is allocated") {
    // 10^12 vertices in a 200-byte file: refused at once, whatever the memory budget.
    const auto t0 = std::chrono::steady_clock::now();
    std::string s = "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\n"
                    "property float y\nproperty float z\nelement face 1\n"
                    "property list uchar int vertex_indices\nend_header\n0 0 0\n";
    CHECK(error_of(write_file("huge_ascii.ply", s)).find("declares 1000000000000 vertices") !=
          std::string::npos);
    // A face count the file's megabyte cannot hold.
    std::string big = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                      "property float x\nproperty float y\nproperty float z\n"
                      "element face 3000000000\nproperty list uchar int vertex_indices\n"
                      "end_header\n";
    CHECK_THROWS_WITH(read_ply_mesh(big + std::string(36, '\0') +
                                        std::string(size_t(1) << 20, '\0'),
                                    "big.ply"),
                      doctest::Contains("more than the"));
    // Polygons multiply triangles: growth past the reservation is checked (here the limit on
    // triangles is far off, so it succeeds), and elements without properties take no bytes.
    std::string poly = "ply\nformat binary_little_endian 1.0\nelement empty 100000000000\n"
                       "element vertex 3\nproperty float x\nproperty float y\n"
                       "property float z\nelement face 2\n"
                       "property list uchar uchar vertex_indices\nend_header\n";
    for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put_bytes(poly, f, false);
    for (int face = 0; face < 2; ++face) {
        put_bytes(poly, uint8_t(200), false);
        for (int i = 0; i < 200; ++i) put_bytes(poly, uint8_t(i % 3), false);
    }
    MeshData m = read_ply_mesh(poly, "poly.ply");
    CHECK(m.triangle_count() == 2 * 198);
    CHECK(m.face_of_triangle.size() == 2 * 198);
    CHECK(m.face_of_triangle.back() == 1);
    CHECK(std::chrono::steady_clock::now() - t0 < std::chrono::seconds(1));
}

TEST_CASE("PLY reader: every mesh of the shared scenes loads; whitespace-first ones match numpy") {
    TESSERA_REQUIRE_SHARED(shared);
    std::vector<std::string> files, numpy_files;
    for (const auto &e : fs::recursive_directory_iterator(shared + "/scenes")) {
        const std::string p = e.path().string();
        const bool ply = p.size() > 4 && p.compare(p.size() - 4, 4, ".ply") == 0;
        const bool gz = p.size() > 7 && p.compare(p.size() - 7, 7, ".ply.gz") == 0;
        if (e.is_regular_file() && (ply || gz)) files.push_back(p);
    }
    std::sort(files.begin(), files.end());
    CHECK(files.size() > 1000);
    size_t triangles = 0;
    for (const std::string &f : files) {
        CAPTURE(f);
        MeshData m = load_ply(f);
        triangles += m.triangle_count();
        bool finite = true, in_range = true;
        for (const Vec3f &p : m.p)
            finite = finite && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
        for (uint32_t i : m.indices) in_range = in_range && i < m.p.size();
        CHECK(finite);
        CHECK(in_range);
        CHECK(m.triangle_count() > 0);
        // The files whose binary data starts with a byte a text reader would skip.
        if (!has_gz_extension(f)) {
            std::ifstream in(f, std::ios::binary);
            std::string head(4096, '\0');
            in.read(head.data(), std::streamsize(head.size()));
            head.resize(size_t(in.gcount()));
            const size_t at = head.find("end_header\n");
            if (at != std::string::npos && at + 11 < head.size() &&
                head.find("format ascii") == std::string::npos) {
                const char c = head[at + 11];
                if (c == '\n' || c == '\r' || c == ' ') numpy_files.push_back(f);
            }
        }
    }
    MESSAGE(files.size() << " PLY files, " << triangles << " triangles; " << numpy_files.size()
                         << " start their data with \\n, \\r or a space");
    for (const char *must : {"/bitterli/dining-room/models/Mesh027.ply",
                             "/bitterli/staircase/models/Mesh230.ply"})
        CHECK(std::find(numpy_files.begin(), numpy_files.end(), shared + "/scenes" + must) !=
              numpy_files.end());
    std::vector<NumpyMesh> np = numpy_read(numpy_files);
    for (size_t c = 0; c < np.size(); ++c) {
        CAPTURE(numpy_files[c]);
        check_against(load_ply(numpy_files[c]), np[c]);
    }
}
