// PLY reading through assimp (see mesh_io.h for what is kept and how quads are split).
#include "renderer/mesh_io.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <filesystem>

#include "renderer/scene_desc.h"

namespace tessera {

namespace {

[[noreturn]] void fail(const std::string &path, const std::string &msg) {
    throw SceneError(path + ": " + msg);
}

}  // namespace

MeshData load_ply(const std::string &path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) fail(path, "PLY file not found");

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
