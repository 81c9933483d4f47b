// PLY reading through assimp (see mesh_io.h for what is kept and how quads are split).
#include "renderer/mesh_io.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

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

/// Reads the PLY header and checks its element counts against the file size and the mesh
/// limits (limits.h) before assimp sees the file: a header claiming 10^12 vertices must not
/// reach an importer that would reserve memory for them. Each element needs at least 1 byte
/// per scalar property (binary), or 2 (ASCII: a digit and a separator); a list property at
/// least its count. Unknown types and malformed headers are left to assimp to report.
void check_ply_header(const std::string &path) {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    if (!std::getline(in, line) || (line != "ply" && line != "ply\r")) return;
    bool binary = false;
    uint64_t min_bytes = 0, vertices = 0, faces = 0;
    uint64_t count = 0, per_element = 0;  // of the element being declared
    bool known_sizes = true;
    auto close_element = [&]() {
        // count * per_element, saturating.
        if (per_element != 0 && count > (UINT64_MAX - min_bytes) / per_element)
            min_bytes = UINT64_MAX;
        else
            min_bytes += count * per_element;
    };
    size_t header_bytes = line.size() + 1;
    // A header is a few hundred bytes; 100000 lines without end_header is not a PLY file.
    for (int n = 0; std::getline(in, line) && n < 100000; ++n) {
        header_bytes += line.size() + 1;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream ws(line);
        std::string kw;
        ws >> kw;
        if (kw == "format") {
            std::string f;
            ws >> f;
            binary = f != "ascii";
        } else if (kw == "element") {
            close_element();
            std::string name, num;
            ws >> name >> num;
            // Counts are unsigned decimal integers; anything else is assimp's to reject.
            if (num.empty() || num.find_first_not_of("0123456789") != std::string::npos ||
                num.size() > 19)
                fail(path, "PLY element \"" + name + "\" has a bad count \"" + num + "\"");
            count = std::stoull(num);
            per_element = 0;
            if (name == "vertex") vertices = count;
            if (name == "face") faces = count;
        } else if (kw == "property") {
            std::string t;
            ws >> t;
            if (t == "list") ws >> t;  // the count's type: an empty list holds only the count
            uint64_t size = ply_type_size(t);
            if (size == 0) known_sizes = false;
            per_element += binary ? size : 2;
        } else if (kw == "end_header") {
            close_element();
            std::error_code ec;
            uint64_t file_size = std::filesystem::file_size(path, ec);
            if (!ec && known_sizes && min_bytes > file_size - std::min<uint64_t>(file_size, header_bytes))
                fail(path, "PLY header declares " + std::to_string(vertices) + " vertices and " +
                               std::to_string(faces) + " faces, more than the " +
                               std::to_string(file_size) +
                               " bytes of the file can hold (truncated or corrupt file)");
            // Every face is at least one triangle.
            check_mesh(vertices, faces, "PLY mesh", FileLoc{path, 0});
            return;
        }
    }
    // NOTE: assimp 5.2 loops forever on a header that never ends (found by the corpus in
    // tests/broken/meshes/no_end_header.ply): it must not see such a file.
    fail(path, "PLY header has no \"end_header\" line (truncated or corrupt file)");
}

}  // namespace

MeshData load_ply(const std::string &path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        fail(path, std::filesystem::is_directory(path, ec) ? "is a directory, not a PLY file"
                                                            : "PLY file not found");
    check_ply_header(path);

    Assimp::Importer importer;
    // NOTE: no post-processing at all. aiProcess_JoinIdenticalVertices would drop unreferenced
    // vertices and merge equal ones (the bunny's 35947 vertices become 34834),
    // aiProcess_Triangulate is not needed for triangles and quads, and normal generation must not
    // invent shading normals. Vertex positions, order and sharing therefore stay exactly as in the
    // file.
    const aiScene *scene = importer.ReadFile(path, 0);
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
            for (unsigned i = 1; i + 1 < face.mNumIndices; ++i) {
                mesh.indices.push_back(base + face.mIndices[0]);
                mesh.indices.push_back(base + face.mIndices[i]);
                mesh.indices.push_back(base + face.mIndices[i + 1]);
            }
        }
    }
    if (mesh.indices.empty()) fail(path, "PLY file has no triangles or quads");
    return mesh;
}

}  // namespace tessera
