// PLY loading speed: Tessera's reader (renderer/input/ply_reader.h) against assimp 5.2 on the same
// files, and the bare file read both start with, in MB/s of file (counter "MB": 10^6 bytes a
// second of wall time; the files stay in the page cache, so "read" is the speed of a warm
// disk).
//
//   bench_ply [FILE.ply ...] [benchmark flags]
//
// Default files: the Stanford bunny (binary little-endian float x/y/z, uchar/int faces),
// Bitterli's material-testball Mesh002.ply (float x/y/z/nx/ny/nz/u/v, quads; the largest mesh
// of the shared Bitterli scenes) and an ASCII copy of the bunny written here. Per file:
//   read      the file into memory in one read (what load_ply does first)
//   tessera   load_ply: read and decode into MeshData
//   parse     read_ply_mesh on bytes already in memory (the decoder alone)
//   assimp    Assimp::Importer::ReadFile without post-processing, then the copy into MeshData
//             that Tessera's assimp-based load_ply made (only when built with assimp)
// malloc is told to keep freed memory (mallopt): otherwise whether an iteration page-faults its
// buffers in afresh depends on the order the benchmarks run in (glibc trims the heap and maps
// large blocks anew), by up to 6x on the same reader; here every reader is measured with warm
// memory, the first touch of a mesh's memory left out for all alike.
#include <benchmark/benchmark.h>
#include <malloc.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "renderer/input/mesh_io.h"
#include "renderer/input/ply_reader.h"

#ifdef TESSERA_HAVE_ASSIMP
#include <assimp/scene.h>
#include <assimp/Importer.hpp>
#endif

using namespace tessera;

namespace {

std::string read_bytes(const std::string &path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

/// Sets the counter "MB" (shown as MB/s: 10^6 bytes of file a second of wall time).
void count_bytes(benchmark::State &state, size_t bytes) {
    state.counters["MB"] = benchmark::Counter(double(state.iterations()) * double(bytes) / 1e6,
                                                benchmark::Counter::kIsRate);
}

void BM_Read(benchmark::State &state, std::string path) {
    const size_t size = std::filesystem::file_size(path);
    for (auto _ : state) {
        // A new buffer each time, as load_ply has.
        auto buf = std::make_unique_for_overwrite<char[]>(size);
        std::FILE *f = std::fopen(path.c_str(), "rb");
        std::setvbuf(f, nullptr, _IONBF, 0);
        benchmark::DoNotOptimize(std::fread(buf.get(), 1, size, f));
        std::fclose(f);
    }
    count_bytes(state, size);
}

void BM_Tessera(benchmark::State &state, std::string path) {
    size_t triangles = 0;
    for (auto _ : state) {
        MeshData m = load_ply(path);
        triangles = m.triangle_count();
        benchmark::DoNotOptimize(m.p.data());
    }
    state.counters["triangles"] = double(triangles);
    count_bytes(state, std::filesystem::file_size(path));
}

void BM_Parse(benchmark::State &state, std::string path) {
    const std::string bytes = read_bytes(path);
    for (auto _ : state) {
        MeshData m = read_ply_mesh(bytes, path);
        benchmark::DoNotOptimize(m.p.data());
    }
    count_bytes(state, bytes.size());
}

#ifdef TESSERA_HAVE_ASSIMP
void BM_Assimp(benchmark::State &state, std::string path) {
    size_t triangles = 0;
    for (auto _ : state) {
        Assimp::Importer importer;
        const aiScene *scene = importer.ReadFile(path, 0);
        if (!scene || scene->mNumMeshes == 0) {
            state.SkipWithError(("assimp cannot read " + path).c_str());
            return;
        }
        // The copy into MeshData, as the assimp-based load_ply made it.
        MeshData m;
        const aiMesh *am = scene->mMeshes[0];
        m.p.reserve(am->mNumVertices);
        if (am->HasNormals()) m.n.reserve(am->mNumVertices);
        if (am->HasTextureCoords(0)) m.uv.reserve(am->mNumVertices);
        for (unsigned v = 0; v < am->mNumVertices; ++v) {
            m.p.push_back({am->mVertices[v].x, am->mVertices[v].y, am->mVertices[v].z});
            if (am->HasNormals())
                m.n.push_back({am->mNormals[v].x, am->mNormals[v].y, am->mNormals[v].z});
            if (am->HasTextureCoords(0))
                m.uv.push_back({am->mTextureCoords[0][v].x, am->mTextureCoords[0][v].y});
        }
        m.indices.reserve(3 * size_t(am->mNumFaces));
        for (unsigned f = 0; f < am->mNumFaces; ++f) {
            const aiFace &face = am->mFaces[f];
            for (unsigned i = 1; i + 1 < face.mNumIndices; ++i) {
                m.indices.push_back(face.mIndices[0]);
                m.indices.push_back(face.mIndices[i]);
                m.indices.push_back(face.mIndices[i + 1]);
            }
        }
        triangles = m.triangle_count();
        benchmark::DoNotOptimize(m.p.data());
    }
    state.counters["triangles"] = double(triangles);
    count_bytes(state, std::filesystem::file_size(path));
}
#endif

/// An ASCII copy of the binary mesh at `path` (positions with 9 significant digits).
std::string write_ascii_copy(const std::string &path) {
    MeshData m = load_ply(path);
    const std::filesystem::path out =
        std::filesystem::temp_directory_path() /
        ("tessera_bench_ply_" + std::filesystem::path(path).stem().string() + "_ascii.ply");
    std::FILE *f = std::fopen(out.string().c_str(), "wb");
    std::fprintf(f,
                 "ply\nformat ascii 1.0\nelement vertex %zu\nproperty float x\nproperty float y\n"
                 "property float z\nelement face %zu\nproperty list uchar int vertex_indices\n"
                 "end_header\n",
                 m.p.size(), m.triangle_count());
    for (const Vec3f &p : m.p) std::fprintf(f, "%.9g %.9g %.9g\n", p.x, p.y, p.z);
    for (size_t t = 0; t < m.triangle_count(); ++t)
        std::fprintf(f, "3 %u %u %u\n", m.indices[3 * t], m.indices[3 * t + 1],
                     m.indices[3 * t + 2]);
    std::fclose(f);
    return out.string();
}

}  // namespace

int main(int argc, char **argv) {
    mallopt(M_MMAP_THRESHOLD, 1 << 30);
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
    std::vector<std::string> files;
    std::vector<char *> rest{argv[0]};
    for (int i = 1; i < argc; ++i) {
        if (argv[i][0] != '-')
            files.push_back(argv[i]);
        else
            rest.push_back(argv[i]);
    }
    if (files.empty()) {
        const std::string shared = std::string(TESSERA_SHARED_DIR) + "/scenes/";
        files = {shared + "stanford-bunny/bunny.ply",
                 shared + "bitterli/material-testball/models/Mesh002.ply"};
        for (const std::string &f : files)
            if (!std::filesystem::exists(f)) {
                std::fprintf(stderr, "bench_ply: %s not found (give PLY files)\n", f.c_str());
                return 2;
            }
        files.push_back(write_ascii_copy(files[0]));
    }
    for (const std::string &f : files) {
        const std::string name = std::filesystem::path(f).filename().string();
        std::printf("%s: %.2f MB\n", f.c_str(), double(std::filesystem::file_size(f)) / 1e6);
        benchmark::RegisterBenchmark(("read/" + name).c_str(), BM_Read, f)->UseRealTime();
        benchmark::RegisterBenchmark(("tessera/" + name).c_str(), BM_Tessera, f)->UseRealTime();
        benchmark::RegisterBenchmark(("parse/" + name).c_str(), BM_Parse, f)->UseRealTime();
#ifdef TESSERA_HAVE_ASSIMP
        benchmark::RegisterBenchmark(("assimp/" + name).c_str(), BM_Assimp, f)->UseRealTime();
#endif
    }
    int n = int(rest.size());
    benchmark::Initialize(&n, rest.data());
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
