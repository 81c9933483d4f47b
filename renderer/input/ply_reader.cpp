// Tessera's PLY reader (see ply_reader.h for the format, mesh_io.h for what is kept).
//
// The whole file is in memory. Binary bodies are decoded with loops specialised at compile time
// for the layouts real meshes use (float x/y/z[/nx/ny/nz][/u/v] vertices of fixed size, faces of
// one "list uchar|int|uint int|uint vertex_indices"); every other layout, and ASCII, goes
// through one general record walker that converts each value by its declared type. Each count
// is checked against the bytes that remain before it is trusted.
#include "renderer/input/ply_reader.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include "renderer/util/limits.h"
#include "renderer/util/error.h"

namespace tessera {

namespace {

/// A mesh file has no line numbers to give: errors name line 0 ("file:0: message").
[[noreturn]] void fail(const std::string &path, const std::string &msg) {
    throw SceneError(FileLoc{path, 0}, msg);
}

/// `s` in quotes for a message: at most `max` bytes, bytes outside printable ASCII as \xNN.
std::string quoted(std::string_view s, size_t max = 60) {
    static const char *hex = "0123456789abcdef";
    std::string out = "\"";
    for (size_t i = 0; i < s.size() && i < max; ++i) {
        const auto c = uint8_t(s[i]);
        if (c >= 0x20 && c < 0x7f && c != '"' && c != '\\') {
            out += char(c);
        } else {
            out += "\\x";
            out += hex[c >> 4];
            out += hex[c & 15];
        }
    }
    if (s.size() > max) out += "...";
    return out + "\"";
}

bool parse_type(std::string_view w, PlyType *t) {
    static const struct {
        const char *name;
        PlyType type;
    } kTypes[] = {{"char", PlyType::Int8},      {"int8", PlyType::Int8},
                  {"uchar", PlyType::Uint8},    {"uint8", PlyType::Uint8},
                  {"short", PlyType::Int16},    {"int16", PlyType::Int16},
                  {"ushort", PlyType::Uint16},  {"uint16", PlyType::Uint16},
                  {"int", PlyType::Int32},      {"int32", PlyType::Int32},
                  {"uint", PlyType::Uint32},    {"uint32", PlyType::Uint32},
                  {"float", PlyType::Float32},  {"float32", PlyType::Float32},
                  {"double", PlyType::Float64}, {"float64", PlyType::Float64}};
    for (const auto &k : kTypes)
        if (w == k.name) {
            *t = k.type;
            return true;
        }
    return false;
}

/// Calls f(T{}) with T the C++ type of `t`: one switch per call, so callers put it outside
/// their loops.
template <typename F>
decltype(auto) with_type(PlyType t, F &&f) {
    switch (t) {
    case PlyType::Int8: return f(int8_t{});
    case PlyType::Uint8: return f(uint8_t{});
    case PlyType::Int16: return f(int16_t{});
    case PlyType::Uint16: return f(uint16_t{});
    case PlyType::Int32: return f(int32_t{});
    case PlyType::Uint32: return f(uint32_t{});
    case PlyType::Float32: return f(float{});
    case PlyType::Float64: break;
    }
    return f(double{});
}

/// The value of type T stored at p, byte-swapped when Swap (the file's byte order is not the
/// machine's).
template <typename T, bool Swap>
inline T load(const uint8_t *p) {
    if constexpr (!Swap || sizeof(T) == 1) {
        T v;
        std::memcpy(&v, p, sizeof(T));
        return v;
    } else {
        using U = std::conditional_t<sizeof(T) == 2, uint16_t,
                                     std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>;
        U u;
        std::memcpy(&u, p, sizeof(T));
        if constexpr (sizeof(T) == 2) u = __builtin_bswap16(u);
        if constexpr (sizeof(T) == 4) u = __builtin_bswap32(u);
        if constexpr (sizeof(T) == 8) u = __builtin_bswap64(u);
        T v;
        std::memcpy(&v, &u, sizeof(T));
        return v;
    }
}

/// a * b, or UINT64_MAX when it overflows.
uint64_t mul_sat(uint64_t a, uint64_t b) {
    return b != 0 && a > UINT64_MAX / b ? UINT64_MAX : a * b;
}

/// The record being read, for messages: "face 12: ...".
struct Where {
    const std::string *path = nullptr;
    const PlyElement *element = nullptr;
    uint64_t record = 0;
    [[noreturn]] void fail(const std::string &msg) const {
        tessera::fail(*path, element->name + " " + std::to_string(record) + ": " + msg);
    }
    [[noreturn]] void truncated() const { fail("the data ends early (truncated file)"); }
};

// ---------------------------------------------------------------------------------------------
// Value sources for the general record walker: get_int/get_real read one value of a declared
// type, skip drops values, room says how many values of a type can still fit in the file.

/// Binary values, bounds-checked one by one.
template <bool Swap>
struct BinarySource {
    const uint8_t *pos, *end;
    const Where *where;

    uint64_t room(PlyType t) const { return uint64_t(end - pos) / ply_type_size(t); }
    int64_t get_int(PlyType t, const PlyProperty &) {
        if (room(t) == 0) where->truncated();
        return with_type(t, [&](auto tag) -> int64_t {
            using T = decltype(tag);
            const T v = load<T, Swap>(pos);
            pos += sizeof(T);
            if constexpr (std::is_integral_v<T>) return int64_t(v);
            return 0;  // not reached: integer properties only (checked with the header)
        });
    }
    double get_real(PlyType t, const PlyProperty &) {
        if (room(t) == 0) where->truncated();
        return with_type(t, [&](auto tag) {
            using T = decltype(tag);
            const T v = load<T, Swap>(pos);
            pos += sizeof(T);
            return double(v);
        });
    }
    void skip(PlyType t, uint64_t n, const PlyProperty &) {
        if (n > room(t)) where->truncated();
        pos += n * ply_type_size(t);
    }
};

/// ASCII values: whitespace-separated tokens (the specification writes one record a line;
/// like rply, any whitespace separates values here).
struct AsciiSource {
    const char *pos, *end;
    const Where *where;

    static bool is_space(char c) { return c == ' ' || (c >= '\t' && c <= '\r'); }
    /// A token needs at least one byte and a separator.
    uint64_t room(PlyType) const { return (uint64_t(end - pos) + 1) / 2; }
    std::string_view token() {
        while (pos < end && is_space(*pos)) ++pos;
        const char *b = pos;
        while (pos < end && !is_space(*pos)) ++pos;
        if (pos == b) where->truncated();
        return {b, size_t(pos - b)};
    }
    /// The start of the next token (a '+' sign skipped), after whitespace.
    const char *next_number() {
        while (pos < end && is_space(*pos)) ++pos;
        if (pos == end) where->truncated();
        const bool plus = *pos == '+' && end - pos > 1 &&
                          (pos[1] == '.' || (pos[1] >= '0' && pos[1] <= '9'));
        return plus ? pos + 1 : pos;
    }
    /// Parses the number at b with from_chars, which must end at the token's end: the
    /// conversion and the token scan in one pass.
    template <typename T>
    T parse(const char *b, const PlyProperty &p, PlyType t) {
        T v{};
        const auto r = std::from_chars(b, end, v);
        if (r.ec != std::errc() || (r.ptr != end && !is_space(*r.ptr))) [[unlikely]] {
            const std::string_view tok = token();
            if (r.ec == std::errc::result_out_of_range)
                bad(p, tok, (std::string("is out of range for ") + ply_type_name(t)).c_str());
            bad(p, tok, std::is_integral_v<T> ? "is not an integer" : "is not a number");
        }
        pos = r.ptr;
        return v;
    }
    [[noreturn]] void bad(const PlyProperty &p, std::string_view tok, const char *what) {
        where->fail("property \"" + p.name + "\": " + quoted(tok) + " " + what);
    }
    int64_t get_int(PlyType t, const PlyProperty &p) {
        const char *b = next_number();
        const char *start = pos;
        const int64_t v = parse<int64_t>(b, p, t);
        // The range of each integer type, in PlyType order.
        static constexpr int64_t kLo[6] = {INT8_MIN, 0, INT16_MIN, 0, INT32_MIN, 0};
        static constexpr int64_t kHi[6] = {INT8_MAX, UINT8_MAX, INT16_MAX, UINT16_MAX, INT32_MAX,
                                           UINT32_MAX};
        if (v < kLo[int(t)] || v > kHi[int(t)]) [[unlikely]] {
            pos = start;
            bad(p, token(), (std::string("is out of range for ") + ply_type_name(t)).c_str());
        }
        return v;
    }
    double get_real(PlyType t, const PlyProperty &p) {
        if (ply_type_is_integer(t)) return double(get_int(t, p));
        const char *b = next_number();
        // A float is parsed as float: correctly rounded once, not via double.
        if (t == PlyType::Float32) return parse<float>(b, p, t);
        return parse<double>(b, p, t);
    }
    void skip(PlyType, uint64_t n, const PlyProperty &) {
        for (uint64_t i = 0; i < n; ++i) token();
    }
};

/// A list's length, checked: not negative, and not more items than the file has room for.
template <class Src>
uint64_t list_count(Src &src, const Where &w, const PlyProperty &p) {
    const int64_t n = src.get_int(p.count_type, p);
    if (n < 0) w.fail("list \"" + p.name + "\" has a negative length " + std::to_string(n));
    if (uint64_t(n) > src.room(p.type))
        w.fail("a list of " + std::to_string(n) + " values runs past the end of the file");
    return uint64_t(n);
}

// ---------------------------------------------------------------------------------------------
// Vertices.

/// Vertex outputs by slot: x y z nx ny nz u v. A slot's value i goes to dst[slot] + i * stride;
/// dst is null for a slot the mesh does not keep (and for all when there are no vertices).
constexpr int kSlots = 8;
struct VertexOut {
    uint8_t *dst[kSlots] = {};
    uint32_t stride[kSlots] = {};
    void store(int slot, uint64_t i, float v) const {
        std::memcpy(dst[slot] + i * stride[slot], &v, sizeof(float));
    }
};

static_assert(std::is_trivially_copyable_v<Vec3f> && sizeof(Vec3f) == 3 * sizeof(float));
static_assert(std::is_trivially_copyable_v<Vec2f> && sizeof(Vec2f) == 2 * sizeof(float));

/// Which vertex property feeds which slot (-1: none), and what the mesh gets.
struct VertexLayout {
    int prop[kSlots] = {-1, -1, -1, -1, -1, -1, -1, -1};
    bool normals = false, uvs = false;
};

VertexLayout vertex_layout(const PlyElement &e, const std::string &path) {
    VertexLayout lay;
    auto scalar = [&](const char *name) {
        int k = e.find(name);
        return k >= 0 && !e.properties[size_t(k)].is_list ? k : -1;
    };
    for (int s = 0; s < 3; ++s) {
        const char *name = s == 0 ? "x" : s == 1 ? "y" : "z";
        int k = e.find(name);
        if (k < 0) fail(path, std::string("PLY vertex element has no \"") + name + "\" property");
        if (e.properties[size_t(k)].is_list)
            fail(path, std::string("PLY vertex property \"") + name + "\" is a list");
        lay.prop[s] = k;
    }
    // Normals need all three components, as in pbrt-v4 (TriQuadMesh::ReadPLY).
    int nx = scalar("nx"), ny = scalar("ny"), nz = scalar("nz");
    if (nx >= 0 && ny >= 0 && nz >= 0) {
        lay.normals = true;
        lay.prop[3] = nx;
        lay.prop[4] = ny;
        lay.prop[5] = nz;
    }
    // Texture coordinates under the names pbrt-v4 accepts, the first complete pair winning.
    static const char *kUvNames[][2] = {
        {"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
    for (const auto &uv : kUvNames) {
        int u = scalar(uv[0]), v = scalar(uv[1]);
        if (u >= 0 && v >= 0) {
            lay.uvs = true;
            lay.prop[6] = u;
            lay.prop[7] = v;
            break;
        }
    }
    return lay;
}

/// One column of a fixed-size record: `count` values of type T at src, src + stride, ...
template <typename T, bool Swap>
void decode_column(const uint8_t *src, uint64_t count, size_t stride, uint8_t *dst,
                   size_t dst_stride) {
    for (uint64_t i = 0; i < count; ++i) {
        const float v = float(load<T, Swap>(src + i * stride));
        std::memcpy(dst + i * dst_stride, &v, sizeof(float));
    }
}

/// Records whose positions (and normals, uvs) are consecutive native floats: plain copies.
template <bool Normals, bool Uvs>
void copy_float_vertices(const uint8_t *base, uint64_t count, size_t stride, const size_t *off,
                         MeshData &m) {
    uint8_t *p = reinterpret_cast<uint8_t *>(m.p.data());
    uint8_t *n = reinterpret_cast<uint8_t *>(m.n.data());
    uint8_t *uv = reinterpret_cast<uint8_t *>(m.uv.data());
    for (uint64_t i = 0; i < count; ++i) {
        const uint8_t *r = base + i * stride;
        std::memcpy(p + 12 * i, r + off[0], 12);
        if constexpr (Normals) std::memcpy(n + 12 * i, r + off[3], 12);
        if constexpr (Uvs) std::memcpy(uv + 8 * i, r + off[6], 8);
    }
}

/// A vertex element without lists: fixed-size records, decoded column by column (one type
/// dispatch per column), or copied when the wanted properties are consecutive native floats.
template <bool Swap>
void decode_fixed_vertices(const uint8_t *base, const PlyElement &e, size_t stride,
                           const VertexLayout &lay, const VertexOut &out, MeshData &m) {
    size_t offset[kSlots] = {};
    {
        std::vector<size_t> prop_offset(e.properties.size());
        size_t o = 0;
        for (size_t k = 0; k < e.properties.size(); ++k) {
            prop_offset[k] = o;
            o += ply_type_size(e.properties[k].type);
        }
        for (int s = 0; s < kSlots; ++s)
            if (lay.prop[s] >= 0) offset[s] = prop_offset[size_t(lay.prop[s])];
    }
    auto floats_in_a_row = [&](int first, int n) {
        for (int s = first; s < first + n; ++s)
            if (e.properties[size_t(lay.prop[s])].type != PlyType::Float32 ||
                offset[s] != offset[first] + 4 * size_t(s - first))
                return false;
        return true;
    };
    if (!Swap && floats_in_a_row(0, 3) && (!lay.normals || floats_in_a_row(3, 3)) &&
        (!lay.uvs || floats_in_a_row(6, 2))) {
        if (lay.normals && lay.uvs)
            copy_float_vertices<true, true>(base, e.count, stride, offset, m);
        else if (lay.normals)
            copy_float_vertices<true, false>(base, e.count, stride, offset, m);
        else if (lay.uvs)
            copy_float_vertices<false, true>(base, e.count, stride, offset, m);
        else
            copy_float_vertices<false, false>(base, e.count, stride, offset, m);
        return;
    }
    for (int s = 0; s < kSlots; ++s) {
        if (!out.dst[s]) continue;
        with_type(e.properties[size_t(lay.prop[s])].type, [&](auto tag) {
            decode_column<decltype(tag), Swap>(base + offset[s], e.count, stride, out.dst[s],
                                              out.stride[s]);
        });
    }
}

/// Any vertex element, record by record (ASCII, or binary records holding lists).
template <class Src>
void read_vertices_general(Src &src, Where &w, const PlyElement &e, const VertexLayout &lay,
                           const VertexOut &out) {
    std::vector<int> slot_of(e.properties.size(), -1);
    for (int s = 0; s < kSlots; ++s)
        if (lay.prop[s] >= 0 && out.dst[s]) slot_of[size_t(lay.prop[s])] = s;
    for (uint64_t i = 0; i < e.count; ++i) {
        w.record = i;
        for (size_t k = 0; k < e.properties.size(); ++k) {
            const PlyProperty &p = e.properties[k];
            if (p.is_list)
                src.skip(p.type, list_count(src, w, p), p);
            else if (slot_of[k] >= 0)
                out.store(slot_of[k], i, float(src.get_real(p.type, p)));
            else
                src.skip(p.type, 1, p);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Faces.

/// The triangles cut from the faces, in arrays that grow only after check_mesh allowed it.
/// The face each triangle comes from is recorded only once a polygon has been seen: until
/// then triangle t comes from face t plus the faces of fewer than 3 vertices skipped before it.
class TriangleOut {
  public:
    TriangleOut(uint64_t vertices, uint64_t faces, bool face_ids, const std::string &path)
        : vertices_(vertices), face_ids_(face_ids), path_(path) {
        grow(faces);
    }
    /// Makes room for `extra` more triangles.
    void reserve(uint64_t extra) {
        if (count_ + extra <= capacity_) return;
        // Amortised growth, but never past the limit for a size that itself fits.
        grow(std::max(count_ + extra, std::min(capacity_ + capacity_ / 2, kMaxMeshTriangles)));
    }
    /// Appends a triangle of face `face`; room must have been reserved.
    void put(uint32_t a, uint32_t b, uint32_t c, uint32_t face) {
        uint32_t *t = idx_.data() + 3 * count_;
        t[0] = a;
        t[1] = b;
        t[2] = c;
        if (polygons_) face_[count_] = face;
        ++count_;
    }
    /// Appends the fan of a polygon (v0 vi vi+1): a quad (v0 v1 v2 v3) gives (v0 v1 v2) and
    /// (v0 v2 v3). Faces of fewer than 3 vertices are counted and dropped.
    void add(const uint32_t *v, uint64_t n, uint32_t face) {
        if (n < 3) {
            if (!polygons_) {
                if (skips_.empty() || skips_.back().first != count_)
                    skips_.push_back({uint32_t(count_), 0});
                ++skips_.back().second;
            }
            ++skipped_;
            return;
        }
        reserve(n - 2);
        if (n > 3 && !polygons_) record_faces();
        for (uint64_t j = 1; j + 1 < n; ++j) put(v[0], v[j], v[j + 1], face);
    }
    uint64_t count() const { return count_; }
    /// Gives the triangles of the last face(s) their "face_indices" value.
    void set_face_id(uint64_t from, int id) {
        for (uint64_t t = from; t < count_; ++t) ids_[t] = id;
    }
    uint64_t skipped() const { return skipped_; }
    void finish(MeshData &m) {
        idx_.resize(3 * count_);
        m.indices = std::move(idx_);
        if (polygons_) {
            face_.resize(count_);
            m.face_of_triangle = std::move(face_);
        }
        if (face_ids_) {
            ids_.resize(count_);
            m.face_indices = std::move(ids_);
        }
    }

  private:
    void grow(uint64_t triangles) {
        check_mesh(vertices_, triangles, "PLY mesh", FileLoc{path_, 0});
        capacity_ = triangles;
        idx_.resize(3 * capacity_);
        if (polygons_) face_.resize(capacity_);
        if (face_ids_) ids_.resize(capacity_);
    }
    /// The first polygon: the faces of the triangles so far, from the skips.
    void record_faces() {
        polygons_ = true;
        face_.resize(capacity_);
        size_t k = 0;
        uint64_t shift = 0;
        for (uint64_t t = 0; t < count_; ++t) {
            for (; k < skips_.size() && skips_[k].first <= t; ++k) shift += skips_[k].second;
            face_[t] = uint32_t(t + shift);
        }
        skips_ = {};
    }
    uint64_t vertices_;
    bool face_ids_;
    const std::string &path_;
    uint64_t count_ = 0, capacity_ = 0, skipped_ = 0;
    bool polygons_ = false;
    std::vector<uint32_t> idx_, face_;
    /// Until the first polygon: (count_, faces skipped there) for each run of skipped faces;
    /// at most one entry per triangle.
    std::vector<std::pair<uint32_t, uint32_t>> skips_;
    std::vector<int> ids_;
};

[[noreturn]] void bad_index(const Where &w, int64_t v, uint64_t vertices) {
    w.fail("vertex index " + std::to_string(v) + " out of range (" + std::to_string(vertices) +
           " vertices)");
}

/// What the face element holds, by property index.
struct FaceLayout {
    int indices = -1;     ///< the vertex_indices (or vertex_index) list
    int face_index = -1;  ///< the scalar face_indices, or -1
};

FaceLayout face_layout(const PlyElement &e, const std::string &path) {
    FaceLayout lay;
    lay.indices = e.find("vertex_indices");
    if (lay.indices < 0) lay.indices = e.find("vertex_index");
    if (lay.indices < 0) fail(path, "PLY face element has no \"vertex_indices\" list");
    const PlyProperty &p = e.properties[size_t(lay.indices)];
    if (!p.is_list) fail(path, "PLY face property \"" + p.name + "\" is not a list");
    if (!ply_type_is_integer(p.type))
        fail(path, "PLY face list \"" + p.name + "\" has items of type " +
                       ply_type_name(p.type) + ", not an integer type");
    const int fi = e.find("face_indices");
    if (fi >= 0 && !e.properties[size_t(fi)].is_list) lay.face_index = fi;
    return lay;
}

/// A face_indices value as an int (pbrt-v4 reads it as one), range-checked.
int face_id_value(double v, const Where &w) {
    if (!(v >= double(std::numeric_limits<int>::lowest()) &&
          v <= double(std::numeric_limits<int>::max())))
        w.fail("face_indices value " + std::to_string(v) + " is not an int");
    return int(v);
}

/// Any face element, record by record (ASCII, or binary layouts without a fast path).
template <class Src>
void read_faces_general(Src &src, Where &w, const PlyElement &e, const FaceLayout &lay,
                        uint64_t vertices, TriangleOut &out) {
    std::vector<uint32_t> poly;
    for (uint64_t f = 0; f < e.count; ++f) {
        w.record = f;
        const uint64_t first = out.count();
        int id = 0;
        for (size_t k = 0; k < e.properties.size(); ++k) {
            const PlyProperty &p = e.properties[k];
            if (int(k) == lay.indices) {
                const uint64_t n = list_count(src, w, p);
                poly.resize(n);
                for (uint64_t j = 0; j < n; ++j) {
                    const int64_t v = src.get_int(p.type, p);
                    if (v < 0 || uint64_t(v) >= vertices) bad_index(w, v, vertices);
                    poly[j] = uint32_t(v);
                }
            } else if (int(k) == lay.face_index) {
                id = face_id_value(src.get_real(p.type, p), w);
            } else if (p.is_list) {
                src.skip(p.type, list_count(src, w, p), p);
            } else {
                src.skip(p.type, 1, p);
            }
        }
        out.add(poly.data(), poly.size(), uint32_t(f));
        if (lay.face_index >= 0) out.set_face_id(first, id);
    }
}

/// Faces whose only property is "list C I vertex_indices" (C uchar, int or uint; I int or
/// uint): the layout of nearly every mesh file. Returns the position after the element.
template <typename C, typename I, bool Swap>
const uint8_t *read_faces_fast(const uint8_t *pos, const uint8_t *end, Where &w,
                               const PlyElement &e, uint64_t vertices, TriangleOut &out) {
    std::vector<uint32_t> poly;
    for (uint64_t f = 0; f < e.count; ++f) {
        if (size_t(end - pos) < sizeof(C)) {
            w.record = f;
            w.truncated();
        }
        const int64_t n = int64_t(load<C, Swap>(pos));
        pos += sizeof(C);
        if (n < 0 || uint64_t(n) > size_t(end - pos) / sizeof(I)) [[unlikely]] {
            w.record = f;
            if (n < 0) w.fail("list \"" + e.properties[0].name + "\" has a negative length " +
                              std::to_string(n));
            w.fail("a list of " + std::to_string(n) + " values runs past the end of the file");
        }
        if (n == 3) [[likely]] {
            // A negative int index becomes >= 2^31 as uint32, above every vertex count.
            const uint32_t a = uint32_t(load<I, Swap>(pos)),
                           b = uint32_t(load<I, Swap>(pos + sizeof(I))),
                           c = uint32_t(load<I, Swap>(pos + 2 * sizeof(I)));
            if (a >= vertices || b >= vertices || c >= vertices) [[unlikely]] {
                w.record = f;
                for (int j = 0; j < 3; ++j) {
                    const int64_t v = int64_t(load<I, Swap>(pos + size_t(j) * sizeof(I)));
                    if (v < 0 || uint64_t(v) >= vertices) bad_index(w, v, vertices);
                }
            }
            out.reserve(1);
            out.put(a, b, c, uint32_t(f));
        } else {
            poly.resize(size_t(n));
            for (int64_t j = 0; j < n; ++j) {
                const int64_t v = int64_t(load<I, Swap>(pos + size_t(j) * sizeof(I)));
                if (v < 0 || uint64_t(v) >= vertices) {
                    w.record = f;
                    bad_index(w, v, vertices);
                }
                poly[size_t(j)] = uint32_t(v);
            }
            out.add(poly.data(), uint64_t(n), uint32_t(f));
        }
        pos += size_t(n) * sizeof(I);
    }
    return pos;
}

/// The fast face reader for this element's layout, or nullptr when it has none.
template <bool Swap>
auto fast_face_reader(const PlyElement &e) {
    using Fn = const uint8_t *(*)(const uint8_t *, const uint8_t *, Where &, const PlyElement &,
                                  uint64_t, TriangleOut &);
    Fn fn = nullptr;
    if (e.properties.size() != 1) return fn;
    const PlyProperty &p = e.properties[0];
    auto with_index = [&](auto count_tag) {
        using C = decltype(count_tag);
        if (p.type == PlyType::Int32) fn = &read_faces_fast<C, int32_t, Swap>;
        if (p.type == PlyType::Uint32) fn = &read_faces_fast<C, uint32_t, Swap>;
    };
    if (p.count_type == PlyType::Uint8) with_index(uint8_t{});
    if (p.count_type == PlyType::Int32) with_index(int32_t{});
    if (p.count_type == PlyType::Uint32) with_index(uint32_t{});
    return fn;
}

/// Elements that are neither vertex nor face, skipped.
template <class Src>
void skip_element_general(Src &src, Where &w, const PlyElement &e) {
    for (uint64_t i = 0; i < e.count; ++i) {
        w.record = i;
        for (const PlyProperty &p : e.properties)
            src.skip(p.type, p.is_list ? list_count(src, w, p) : 1, p);
    }
}

/// Bytes (binary) or tokens (ASCII) a record of `e` needs at least: its scalars and list
/// lengths.
uint64_t min_record_size(const PlyElement &e, bool ascii) {
    uint64_t n = 0;
    for (const PlyProperty &p : e.properties)
        n += ascii ? 2 : ply_type_size(p.is_list ? p.count_type : p.type);
    return n;
}

/// "3 vertices, 1 faces and 10 \"material\" elements".
std::string describe_counts(const std::vector<PlyElement> &elements) {
    std::vector<std::string> parts;
    for (const PlyElement &e : elements) {
        const std::string n = std::to_string(e.count);
        if (e.name == "vertex")
            parts.push_back(n + " vertices");
        else if (e.name == "face")
            parts.push_back(n + " faces");
        else
            parts.push_back(n + " " + quoted(e.name, 40) + " elements");
    }
    std::string s;
    for (size_t i = 0; i < parts.size(); ++i)
        s += (i == 0 ? "" : i + 1 == parts.size() ? " and " : ", ") + parts[i];
    return s;
}

/// The body walk, binary with byte order Swap.
template <bool Swap>
void read_binary_body(const uint8_t *pos, const uint8_t *end, const PlyHeader &h, Where &w,
                      const VertexLayout &vlay, const VertexOut &vout, const FaceLayout &flay,
                      uint64_t vertices, TriangleOut &tris, MeshData &m) {
    for (const PlyElement &e : h.elements) {
        w.element = &e;
        w.record = 0;
        if (e.count == 0 || e.properties.empty()) continue;  // no bytes
        const bool lists = std::any_of(e.properties.begin(), e.properties.end(),
                                       [](const PlyProperty &p) { return p.is_list; });
        if (!lists) {
            // Fixed-size records: one bounds check for the whole element, then no more.
            const uint64_t stride = min_record_size(e, false);
            const uint64_t left = uint64_t(end - pos);
            if (e.count > left / stride) {
                w.record = left / stride;
                w.truncated();
            }
            if (e.name == "vertex") decode_fixed_vertices<Swap>(pos, e, stride, vlay, vout, m);
            pos += e.count * stride;
            continue;
        }
        // Records with lists have no fixed size: each length is checked as it is read.
        if (e.name == "face") {
            if (auto fast = fast_face_reader<Swap>(e)) {
                pos = fast(pos, end, w, e, vertices, tris);
                continue;
            }
        }
        BinarySource<Swap> src{pos, end, &w};
        if (e.name == "vertex")
            read_vertices_general(src, w, e, vlay, vout);
        else if (e.name == "face")
            read_faces_general(src, w, e, flay, vertices, tris);
        else
            skip_element_general(src, w, e);
        pos = src.pos;
    }
}

}  // namespace

const char *ply_type_name(PlyType t) {
    switch (t) {
    case PlyType::Int8: return "char";
    case PlyType::Uint8: return "uchar";
    case PlyType::Int16: return "short";
    case PlyType::Uint16: return "ushort";
    case PlyType::Int32: return "int";
    case PlyType::Uint32: return "uint";
    case PlyType::Float32: return "float";
    case PlyType::Float64: return "double";
    }
    return "?";
}

int PlyElement::find(std::string_view n) const {
    for (size_t k = 0; k < properties.size(); ++k)
        if (properties[k].name == n) return int(k);
    return -1;
}

PlyHeader parse_ply_header(std::string_view bytes, const std::string &path) {
    PlyHeader h;
    size_t pos = 0;
    bool have_format = false;
    for (int line_no = 1;; ++line_no) {
        if (pos >= bytes.size())
            fail(path, "PLY header has no \"end_header\" line (truncated or corrupt file)");
        const size_t nl = bytes.find('\n', pos);
        std::string_view line = bytes.substr(pos, nl == std::string_view::npos ? nl : nl - pos);
        pos = nl == std::string_view::npos ? bytes.size() : nl + 1;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line_no == 1) {
            // The specification's magic: the file's first line is "ply".
            if (line != "ply") fail(path, "not a PLY file (the first line is not \"ply\")");
            continue;
        }
        // Words are separated by spaces or tabs; other control characters mean a binary or
        // corrupt file.
        bool non_ascii = false;
        for (char ch : line) {
            const auto c = uint8_t(ch);
            if ((c < 0x20 && c != '\t') || c == 0x7f)
                fail(path, "PLY header line " + std::to_string(line_no) +
                               " holds a control character (a binary or corrupt file)");
            non_ascii = non_ascii || c >= 0x80;
        }
        std::string_view words[6];
        size_t nwords = 0;
        for (size_t i = 0; i < line.size();) {
            if (line[i] == ' ' || line[i] == '\t') {
                ++i;
                continue;
            }
            size_t j = i;
            while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
            if (nwords < 6) words[nwords] = line.substr(i, j - i);
            ++nwords;
            i = j;
        }
        if (nwords == 0) continue;  // a blank line says nothing
        const std::string_view kw = words[0];
        if (kw == "comment" || kw == "obj_info") continue;
        if (non_ascii)
            fail(path, "PLY header line " + std::to_string(line_no) +
                           " holds a non-ASCII character outside a comment");
        auto expect_words = [&](size_t n) {
            if (nwords != n) fail(path, "malformed PLY header line " + quoted(line, 80));
        };
        if (kw == "format") {
            expect_words(3);
            if (have_format || !h.elements.empty())
                fail(path, "PLY header has a second or late \"format\" line");
            have_format = true;
            if (words[1] == "ascii")
                h.format = PlyFormat::Ascii;
            else if (words[1] == "binary_little_endian")
                h.format = PlyFormat::BinaryLittleEndian;
            else if (words[1] == "binary_big_endian")
                h.format = PlyFormat::BinaryBigEndian;
            else
                fail(path, "unknown PLY format " + quoted(words[1]));
        } else if (kw == "element") {
            expect_words(3);
            if (!have_format) fail(path, "PLY element before the \"format\" line");
            PlyElement e;
            e.name = std::string(words[1]);
            if ((e.name == "vertex" || e.name == "face") && h.elements.end() !=
                std::find_if(h.elements.begin(), h.elements.end(),
                             [&](const PlyElement &x) { return x.name == e.name; }))
                fail(path, "PLY element \"" + e.name + "\" appears twice");
            const std::string_view num = words[2];
            auto r = std::from_chars(num.data(), num.data() + num.size(), e.count);
            if (num.empty() || num[0] < '0' || num[0] > '9' || r.ec != std::errc() ||
                r.ptr != num.data() + num.size())
                fail(path, "PLY element " + quoted(e.name) + " has a bad count " + quoted(num));
            h.elements.push_back(std::move(e));
        } else if (kw == "property") {
            if (h.elements.empty()) fail(path, "PLY property before any element");
            PlyElement &e = h.elements.back();
            PlyProperty p;
            if (nwords >= 2 && words[1] == "list") {
                expect_words(5);
                p.is_list = true;
                p.name = std::string(words[4]);
                if (!parse_type(words[2], &p.count_type) || !parse_type(words[3], &p.type))
                    fail(path, "PLY list " + quoted(p.name) + " has unknown types " +
                                   quoted(std::string(words[2]) + " " + std::string(words[3])));
                if (!ply_type_is_integer(p.count_type))
                    fail(path, "PLY list " + quoted(p.name) + " has a length of type " +
                                   ply_type_name(p.count_type) + ", not an integer type");
            } else {
                expect_words(3);
                p.name = std::string(words[2]);
                if (!parse_type(words[1], &p.type))
                    fail(path, "PLY property " + quoted(p.name) + " has an unknown type " +
                                   quoted(words[1]));
            }
            if (e.find(p.name) >= 0)
                fail(path, "PLY element " + quoted(e.name) + " has two properties " +
                               quoted(p.name));
            e.properties.push_back(std::move(p));
        } else if (kw == "end_header") {
            expect_words(1);
            break;
        } else {
            fail(path, "unknown PLY header line " + quoted(line, 80));
        }
    }
    if (!have_format) fail(path, "PLY header has no \"format\" line");
    h.body_offset = pos;
    return h;
}

MeshData read_ply_mesh(std::string_view bytes, const std::string &path) {
    const PlyHeader h = parse_ply_header(bytes, path);
    const bool ascii = h.format == PlyFormat::Ascii;
    const PlyElement *vertex = nullptr, *face = nullptr;
    for (const PlyElement &e : h.elements) {
        if (e.name == "vertex") vertex = &e;
        if (e.name == "face") face = &e;
    }
    if (!vertex) fail(path, "PLY file has no \"vertex\" element");
    if (!face) fail(path, "PLY file has no \"face\" element: no triangles or quads");
    const VertexLayout vlay = vertex_layout(*vertex, path);
    const FaceLayout flay = face_layout(*face, path);

    // What the header claims must fit in the file, before anything is allocated for it.
    const uint64_t body = bytes.size() - h.body_offset;
    uint64_t need = 0;
    for (const PlyElement &e : h.elements)
        need = std::min(UINT64_MAX - 1, need + mul_sat(e.count, min_record_size(e, ascii)));
    if (need > body + (ascii ? 1 : 0))  // the last ASCII token needs no separator
        fail(path, "PLY header declares " + describe_counts(h.elements) + ", more than the " +
                       std::to_string(bytes.size()) +
                       " bytes of the file can hold (truncated or corrupt file)");
    const uint64_t vertices = vertex->count;
    // The mesh the header describes, a triangle a face, must fit the limits; polygons are
    // checked again as their triangles come.
    check_mesh(vertices, face->count, "PLY mesh", FileLoc{path, 0});

    MeshData m;
    m.p.resize(vertices);
    if (vlay.normals) m.n.resize(vertices);
    if (vlay.uvs) m.uv.resize(vertices);
    VertexOut vout;
    for (int s = 0; s < kSlots && vertices > 0; ++s) {
        uint8_t *base = s < 3 ? reinterpret_cast<uint8_t *>(m.p.data())
                        : s < 6 ? reinterpret_cast<uint8_t *>(m.n.data())
                                : reinterpret_cast<uint8_t *>(m.uv.data());
        const bool wanted = s < 3 || (s < 6 ? vlay.normals : vlay.uvs);
        if (!wanted) continue;
        vout.dst[s] = base + 4 * (s < 6 ? s % 3 : s - 6);
        vout.stride[s] = s < 6 ? 12 : 8;
    }
    // Room for one triangle a face, as far as the file can hold such faces (a face of fewer
    // vertices takes less room and gives no triangle); polygons grow the arrays as they come.
    const uint64_t triangle_face_bytes =
        min_record_size(*face, ascii) +
        3 * (ascii ? 2 : ply_type_size(face->properties[size_t(flay.indices)].type));
    TriangleOut tris(vertices, std::min(face->count, body / triangle_face_bytes + 1),
                     flay.face_index >= 0, path);

    // Elements in file order; "vertex" and "face" may come anywhere, before or after each other
    // (indices are checked against the header's vertex count, known from the start).
    Where w;
    w.path = &path;
    const auto *begin = reinterpret_cast<const uint8_t *>(bytes.data());
    const uint8_t *pos = begin + h.body_offset, *end = begin + bytes.size();
    if (ascii) {
        AsciiSource src{reinterpret_cast<const char *>(pos), reinterpret_cast<const char *>(end),
                        &w};
        for (const PlyElement &e : h.elements) {
            w.element = &e;
            w.record = 0;
            if (e.count == 0 || e.properties.empty()) continue;
            if (&e == vertex)
                read_vertices_general(src, w, e, vlay, vout);
            else if (&e == face)
                read_faces_general(src, w, e, flay, vertices, tris);
            else
                skip_element_general(src, w, e);
        }
    } else {
        const bool file_big = h.format == PlyFormat::BinaryBigEndian;
        if (file_big == (std::endian::native == std::endian::big))
            read_binary_body<false>(pos, end, h, w, vlay, vout, flay, vertices, tris, m);
        else
            read_binary_body<true>(pos, end, h, w, vlay, vout, flay, vertices, tris, m);
    }

    if (tris.count() == 0) fail(path, "PLY file has no triangles or quads");
    if (tris.skipped() > 0)
        warn(FileLoc{path, 0}, std::to_string(tris.skipped()) +
                                   " faces with fewer than 3 vertices ignored (points and "
                                   "lines have no surface)");
    tris.finish(m);
    return m;
}

}  // namespace tessera
