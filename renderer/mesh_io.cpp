// PLY reading through assimp (see mesh_io.h for what is kept and how quads are split).
#include "renderer/mesh_io.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "renderer/gzip_io.h"
#include "renderer/limits.h"
#include "renderer/scene_desc.h"

namespace tessera {

namespace {

/// A mesh file has no line numbers to give: errors name line 0 ("file:0: message").
[[noreturn]] void fail(const std::string &path, const std::string &msg) {
    throw SceneError(FileLoc{path, 0}, msg);
}

/// Size in bytes of a PLY scalar type in a binary file, 0 if unknown.
uint64_t ply_type_size(const std::string &t) {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" ||
        t == "float32")
        return 4;
    if (t == "double" || t == "float64") return 8;
    return 0;
}

/// One property of a PLY element: a scalar, or a list (count type, item type). Sizes in bytes
/// of the binary encoding.
struct PlyProperty {
    bool list = false;
    uint64_t count_size = 0, size = 0;  ///< list: count and item sizes; scalar: size
};

struct PlyElement {
    std::string name;
    uint64_t count = 0;
    std::vector<PlyProperty> props;
};

/// A small buffered reader for walking a PLY body without holding it in memory.
class PlyWalker {
  public:
    PlyWalker(std::istream &in, uint64_t remaining)
        : in_(in), remaining_(remaining), buf_(size_t(1) << 16) {}
    uint64_t remaining() const { return remaining_; }
    /// Reads n <= 8 bytes; false at the end of the file.
    bool read(uint8_t *out, uint64_t n) {
        if (n > remaining_) return false;
        for (uint64_t i = 0; i < n; ++i) out[i] = next();
        return true;
    }
    bool skip(uint64_t n) {
        if (n > remaining_) return false;
        uint64_t buffered = std::min<uint64_t>(n, uint64_t(end_ - pos_));
        pos_ += buffered;
        remaining_ -= buffered;
        n -= buffered;
        if (n > 0) {
            in_.seekg(std::streamoff(n), std::ios::cur);
            remaining_ -= n;
        }
        return true;
    }
    /// The next whitespace-separated token (ASCII bodies); "" at the end of the file.
    std::string token() {
        std::string t;
        while (remaining_ > 0) {
            char c = char(next());
            bool space = c == ' ' || c == '\n' || c == '\r' || c == '\t' || c == '\f' || c == '\v';
            if (space) {
                if (!t.empty()) break;
            } else if (t.size() < 64) {
                t += c;
            }
        }
        return t;
    }

  private:
    uint8_t next() {
        if (pos_ == end_) {
            in_.read(reinterpret_cast<char *>(buf_.data()), std::streamsize(buf_.size()));
            pos_ = buf_.data();
            end_ = pos_ + std::max<std::streamsize>(0, in_.gcount());
            if (pos_ == end_) {  // shorter than its size said: treat as the end
                remaining_ = 0;
                return 0;
            }
        }
        --remaining_;
        return *pos_++;
    }
    std::istream &in_;
    uint64_t remaining_;
    std::vector<uint8_t> buf_;
    uint8_t *pos_ = nullptr, *end_ = nullptr;
};

/// Checks a PLY file before assimp reads it. assimp 5.2 trusts every count it reads: a header
/// without end_header makes it loop forever, a header claiming 10^12 vertices or one face list
/// claiming 4 billion indices makes it allocate tens of GB (found by tests/broken and fuzz_ply;
/// 13 GB from a 500-byte file). So the header's element counts are checked against the file
/// size and the mesh limits (limits.h), and the body is walked once -- streaming, without
/// keeping anything -- to check that every list's count fits in the bytes (binary) or tokens
/// (ASCII) that remain. After this, what assimp allocates is bounded by the file size.
void check_ply_stream(std::istream &in, uint64_t file_size, const std::string &path) {
    std::string line;
    // The file must start with the line "ply", as the specification (and pbrt-v4's rply)
    // says. assimp is more lenient -- it skips blank lines and looks at three bytes -- and then
    // trusts the rest: fuzz_ply hung it with "ply5555..." and with a blank first line.
    if (!std::getline(in, line) || (line != "ply" && line != "ply\r"))
        fail(path, "not a PLY file (the first line is not \"ply\")");
    std::string format;
    std::vector<PlyElement> elements;
    uint64_t header_bytes = line.size() + 1;
    bool ended = false;
    // A header is a few hundred bytes; 100000 lines without end_header is not a PLY file.
    for (int n = 0; !ended && std::getline(in, line) && n < 100000; ++n) {
        header_bytes += line.size() + 1;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        // Printable ASCII only: assimp splits words at spaces and tabs only, so a vertical tab
        // hid "end_header" from it while a C++ stream saw it (fuzz_ply: assimp then seeks
        // forever).
        for (char c : line)
            if (c < 0x20 || c > 0x7e)
                fail(path, "PLY header line " + std::to_string(n + 2) +
                               " holds a control or non-ASCII character");
        std::istringstream ws(line);
        std::string kw;
        ws >> kw;
        // Only the lines of the PLY specification, each with exactly its words: the body walk
        // below must see the same layout as assimp, and assimp's header reader differs from
        // this one on malformed lines (fuzz_ply: a vertex property hidden behind "%%%%" made
        // assimp read a face count from the wrong bytes and allocate 8.5 GB).
        std::vector<std::string> words;
        for (std::string w; ws >> w;) words.push_back(w);
        auto expect_words = [&](size_t n) {
            if (words.size() != n)
                fail(path, "malformed PLY header line \"" + line.substr(0, 80) + "\"");
        };
        if (kw == "comment" || kw == "obj_info") continue;
        // One format line before any element, and each element name once (the
        // specification's layout): fuzz_ply made assimp free memory it had not allocated with a
        // second format line and repeated "vertex" and "face" elements.
        if (kw == "format") {
            expect_words(2);
            if (!format.empty() || !elements.empty())
                fail(path, "PLY header has a second or late \"format\" line");
            format = words[0];
        } else if (kw == "element") {
            expect_words(2);
            if (format.empty()) fail(path, "PLY element before the \"format\" line");
            for (const PlyElement &seen : elements)
                if (seen.name == words[0])
                    fail(path, "PLY element \"" + words[0] + "\" appears twice");
            PlyElement e;
            e.name = words[0];
            const std::string &num = words[1];
            if (num.empty() || num.find_first_not_of("0123456789") != std::string::npos ||
                num.size() > 19)
                fail(path, "PLY element \"" + e.name + "\" has a bad count \"" + num + "\"");
            e.count = std::stoull(num);
            elements.push_back(e);
        } else if (kw == "property") {
            if (elements.empty()) fail(path, "PLY property before any element");
            PlyProperty p;
            std::string t, item;
            expect_words(words.size() >= 1 && words[0] == "list" ? 4 : 2);
            t = words[0];
            if (t == "list") {
                p.list = true;
                t = words[1];
                item = words[2];
                p.count_size = ply_type_size(t);
                p.size = ply_type_size(item);
                if (p.count_size == 0 || p.size == 0)
                    fail(path, "PLY list property with unknown types \"" + t + " " + item + "\"");
            } else {
                p.size = ply_type_size(t);
                if (p.size == 0) fail(path, "PLY property with unknown type \"" + t + "\"");
            }
            elements.back().props.push_back(p);
        } else if (kw == "end_header") {
            expect_words(0);
            ended = true;
        } else {
            fail(path, "unknown PLY header line \"" + line.substr(0, 80) + "\"");
        }
    }
    // NOTE: assimp 5.2 loops forever on a header that never ends (found by the corpus in
    // tests/broken/meshes/no_end_header.ply): it must not see such a file.
    if (!ended) fail(path, "PLY header has no \"end_header\" line (truncated or corrupt file)");
    const bool ascii = format == "ascii", big = format == "binary_big_endian";
    if (!ascii && !big && format != "binary_little_endian")
        fail(path, "unknown PLY format \"" + format + "\"");
    // A mesh needs its "vertex" element. assimp 5.2 reads a file without one from the wrong
    // bytes (fuzz_ply: an element named "444...4vertex" made it allocate 11 GB). (Vertices
    // without faces are read and rejected later: "no triangles or quads".)
    bool has_vertex = false;
    for (const PlyElement &e : elements)
        has_vertex = has_vertex || e.name == "vertex";
    if (!has_vertex)
        fail(path, "PLY file has no \"vertex\" element");
    // assimp 5.2 misreads the data after an element it does not know (neither "vertex" nor
    // "face") unless it comes after both: it found no faces, or indices from the wrong bytes,
    // or (fuzz_ply) a face count that made it allocate 4.4 GB. Such elements are allowed only
    // at the end, where nothing is read after them.
    size_t last_mesh_element = 0;
    for (size_t i = 0; i < elements.size(); ++i)
        if (elements[i].name == "vertex" || elements[i].name == "face") last_mesh_element = i;
    for (size_t i = 0; i < last_mesh_element; ++i)
        if (elements[i].name != "vertex" && elements[i].name != "face")
            fail(path, "PLY element \"" + elements[i].name.substr(0, 40) +
                           "\" comes before the vertices or faces; other elements are supported "
                           "only after them");

    const uint64_t body = file_size - std::min(file_size, header_bytes);
    // Each element needs at least 1 byte per scalar property in binary, or 2 in ASCII (a digit
    // and a separator); a list at least its count.
    uint64_t min_bytes = 0, vertices = 0, faces = 0;
    for (const PlyElement &e : elements) {
        uint64_t per = 0;
        for (const PlyProperty &p : e.props) per += ascii ? 2 : (p.list ? p.count_size : p.size);
        min_bytes = per != 0 && e.count > (UINT64_MAX - min_bytes) / per ? UINT64_MAX
                                                                          : min_bytes + e.count * per;
        if (e.name == "vertex") vertices = e.count;
        if (e.name == "face") faces = e.count;
    }
    if (min_bytes > body)
        fail(path, "PLY header declares " + std::to_string(vertices) + " vertices and " +
                       std::to_string(faces) + " faces, more than the " +
                       std::to_string(file_size) +
                       " bytes of the file can hold (truncated or corrupt file)");
    // Every face is at least one triangle.
    check_mesh(vertices, faces, "PLY mesh", FileLoc{path, 0});

    // Walk the body: every list count must fit in what is left of the file.
    PlyWalker w(in, body);
    auto bad_list = [&](const PlyElement &e, uint64_t i, const std::string &what) {
        fail(path, "PLY " + e.name + " " + std::to_string(i) + ": " + what +
                       " (truncated or corrupt file)");
    };
    for (const PlyElement &e : elements) {
        bool has_list = false;
        uint64_t fixed = 0;
        for (const PlyProperty &p : e.props) {
            has_list = has_list || p.list;
            fixed += p.size;
        }
        if (!ascii && !has_list) {  // fixed-size records: one skip
            if (!w.skip(e.count * fixed)) bad_list(e, 0, "the data ends early");
            continue;
        }
        for (uint64_t i = 0; i < e.count; ++i)
            for (const PlyProperty &p : e.props) {
                if (ascii) {
                    std::string t = w.token();
                    if (t.empty()) bad_list(e, i, "the data ends early");
                    if (!p.list) continue;
                    if (t.find_first_not_of("0123456789") != std::string::npos || t.size() > 18)
                        bad_list(e, i, "list count \"" + t + "\" is not a count");
                    uint64_t n = std::stoull(t);
                    if (n > w.remaining() / 2)
                        bad_list(e, i, "a list of " + t + " values runs past the end of the file");
                    for (uint64_t k = 0; k < n; ++k)
                        if (w.token().empty()) bad_list(e, i, "the data ends early");
                } else if (p.list) {
                    uint8_t b[8] = {};
                    if (!w.read(b, p.count_size)) bad_list(e, i, "the data ends early");
                    uint64_t n = 0;
                    for (uint64_t k = 0; k < p.count_size; ++k)
                        n |= uint64_t(b[big ? p.count_size - 1 - k : k]) << (8 * k);
                    // Signed count types: a negative count is a huge unsigned one here, and
                    // fails the same test.
                    if (n > w.remaining() / p.size)
                        bad_list(e, i, "a list of " + std::to_string(n) +
                                           " values runs past the end of the file");
                    w.skip(n * p.size);
                } else if (!w.skip(p.size)) {
                    bad_list(e, i, "the data ends early");
                }
            }
    }
}

}  // namespace

MeshData load_ply(const std::string &path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        fail(path, std::filesystem::is_directory(path, ec) ? "is a directory, not a PLY file"
                                                            : "PLY file not found");
    // A ".ply.gz" file (pbrt-v4-scenes ships several) is decompressed into memory, checked
    // there and given to assimp from memory.
    const bool gz = has_gz_extension(path);
    std::string data;
    if (gz) {
        std::string why = read_gzip_file(path, &data, memory_budget_bytes() / 4);
        if (!why.empty()) fail(path, "cannot read PLY: the file " + why);
        std::istringstream in(std::move(data));
        check_ply_stream(in, in.view().size(), path);
        data = std::move(in).str();
    } else {
        std::ifstream in(path, std::ios::binary);
        const uint64_t file_size = std::filesystem::file_size(path, ec);
        if (ec || !in) fail(path, "cannot read PLY: " + (ec ? ec.message() : "cannot be opened"));
        check_ply_stream(in, file_size, path);
    }

    Assimp::Importer importer;
    // NOTE: no post-processing at all. aiProcess_JoinIdenticalVertices would drop unreferenced
    // vertices and merge equal ones (the bunny's 35947 vertices become 34834),
    // aiProcess_Triangulate is not needed for triangles and quads, and normal generation must not
    // invent shading normals. Vertex positions, order and sharing therefore stay exactly as in the
    // file.
    const aiScene *scene = gz ? importer.ReadFileFromMemory(data.data(), data.size(), 0, "ply")
                              : importer.ReadFile(path, 0);
    if (!scene) fail(path, std::string("cannot read PLY: ") + importer.GetErrorString());
    if (scene->mNumMeshes == 0) fail(path, "PLY file has no mesh");

    MeshData mesh;
    // A PLY file gives one assimp mesh; concatenate in case a future importer splits it.
    bool all_normals = true, all_uv = true;
    size_t total_vertices = 0;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh *am = scene->mMeshes[m];
        all_normals = all_normals && am->HasNormals();
        all_uv = all_uv && am->HasTextureCoords(0);
        total_vertices += am->mNumVertices;
    }
    mesh.p.reserve(total_vertices);
    if (all_normals) mesh.n.reserve(total_vertices);
    if (all_uv) mesh.uv.reserve(total_vertices);

    std::vector<uint32_t> face_of_triangle;
    uint32_t face_count = 0;
    bool any_polygon = false;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh *am = scene->mMeshes[m];
        const uint32_t base = uint32_t(mesh.p.size());
        for (unsigned v = 0; v < am->mNumVertices; ++v) {
            const aiVector3D &q = am->mVertices[v];
            mesh.p.push_back({q.x, q.y, q.z});
            if (all_normals) {
                const aiVector3D &nn = am->mNormals[v];
                mesh.n.push_back({nn.x, nn.y, nn.z});
            }
            if (all_uv) {
                const aiVector3D &t = am->mTextureCoords[0][v];
                mesh.uv.push_back({t.x, t.y});
            }
        }
        mesh.indices.reserve(mesh.indices.size() + 3 * size_t(am->mNumFaces));
        for (unsigned f = 0; f < am->mNumFaces; ++f) {
            const aiFace &face = am->mFaces[f];
            // Points and lines (faces of 1 or 2 vertices) carry no surface.
            if (face.mNumIndices < 3) continue;
            for (unsigned i = 0; i < face.mNumIndices; ++i)
                if (face.mIndices[i] >= am->mNumVertices)
                    fail(path, "face " + std::to_string(f) + " references vertex " +
                                   std::to_string(face.mIndices[i]) + " of " +
                                   std::to_string(am->mNumVertices));
            // Fan from vertex 0: a quad (v0 v1 v2 v3) gives (v0 v1 v2) and (v0 v2 v3).
            if (face.mNumIndices > 3) any_polygon = true;
            for (unsigned i = 1; i + 1 < face.mNumIndices; ++i) {
                mesh.indices.push_back(base + face.mIndices[0]);
                mesh.indices.push_back(base + face.mIndices[i]);
                mesh.indices.push_back(base + face.mIndices[i + 1]);
                face_of_triangle.push_back(face_count);
            }
            ++face_count;
        }
    }
    if (mesh.indices.empty()) fail(path, "PLY file has no triangles or quads");
    if (any_polygon) mesh.face_of_triangle = std::move(face_of_triangle);
    return mesh;
}

}  // namespace tessera
