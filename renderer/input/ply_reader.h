// Tessera's own PLY reader: the header parser and the body decoder behind load_ply (mesh_io.h).
//
// The format is Greg Turk's PLY polygon file format ("PLY - Polygon File Format", 1994, the
// specification pbrt-v4's rply and Mitsuba 3 follow): a text header
//
//     ply
//     format ascii|binary_little_endian|binary_big_endian 1.0
//     element <name> <count>
//     property <type> <name>                         a scalar
//     property list <count type> <item type> <name>  a list: its length, then its items
//     end_header
//
// with "comment" and "obj_info" lines anywhere, followed by each element's records in header
// order, every record holding its properties in declaration order. Scalar types are
// char/uchar/short/ushort/int/uint/float/double and their aliases int8/uint8/int16/uint16/
// int32/uint32/float32/float64. The reader takes what pbrt-v4's plymesh takes (positions,
// normals, uvs, vertex_indices, face_indices; see mesh_io.h) from elements "vertex" and "face"
// wherever they are and skips every other property and element.
//
// Hostile input: every count in the header and in the body is checked against the bytes that
// remain and against the mesh limits (renderer/util/limits.h) before anything is allocated for it,
// so what the reader allocates is bounded by the file's size.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "renderer/input/mesh_data.h"

namespace tessera {

/// A PLY scalar type (the specification's eight; each alias maps to one of them).
enum class PlyType : uint8_t { Int8, Uint8, Int16, Uint16, Int32, Uint32, Float32, Float64 };

/// Size in bytes of `t` in a binary PLY body.
constexpr uint32_t ply_type_size(PlyType t) {
    switch (t) {
    case PlyType::Int8:
    case PlyType::Uint8: return 1;
    case PlyType::Int16:
    case PlyType::Uint16: return 2;
    case PlyType::Int32:
    case PlyType::Uint32:
    case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
    }
    return 0;
}

/// True for the six integer types.
constexpr bool ply_type_is_integer(PlyType t) {
    return t != PlyType::Float32 && t != PlyType::Float64;
}

/// The specification's name of `t` ("uchar", "float", ...), for messages.
const char *ply_type_name(PlyType t);

/// One property of an element: a scalar of `type`, or a list whose length is a `count_type`
/// followed by that many `type` items.
struct PlyProperty {
    std::string name;
    PlyType type = PlyType::Float32;  ///< the scalar's type, or a list's item type
    bool is_list = false;
    PlyType count_type = PlyType::Uint8;  ///< lists only; always an integer type
};

/// One element of the header: `count` records of `properties`.
struct PlyElement {
    std::string name;
    uint64_t count = 0;
    std::vector<PlyProperty> properties;
    /// Index in `properties` of the property called `name`, or -1.
    int find(std::string_view name) const;
};

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

/// A parsed header: the format, the elements in file order and where the body starts.
struct PlyHeader {
    PlyFormat format = PlyFormat::Ascii;
    std::vector<PlyElement> elements;
    size_t body_offset = 0;  ///< offset of the first body byte (just after "end_header\n")
};

/// Parses the header at the start of `bytes`, the whole file. The header ends at the line
/// terminator ("\n" or "\r\n") after "end_header": the body starts at the very next byte, even
/// when that byte is a newline, carriage return or space (binary data). Throws
/// SceneError("path:0: ...") for anything the specification does not allow (a first line other
/// than "ply", an unknown keyword or type, a property before any element, a second format line,
/// a missing end_header, ...). Thread-safe.
PlyHeader parse_ply_header(std::string_view bytes, const std::string &path);

/// Reads a mesh from `bytes`, the whole contents of the PLY file `path` (named in messages
/// only). See load_ply (mesh_io.h) for what is read and how faces become triangles. Throws
/// SceneError("path:0: ...") on any error, naming the element and record, e.g.
/// "mesh.ply:0: face 12: vertex index 7 out of range (3 vertices)". Thread-safe.
MeshData read_ply_mesh(std::string_view bytes, const std::string &path);

}  // namespace tessera
