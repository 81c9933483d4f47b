// Loading PLY files: the file (or its gzip decompression) read into memory in one piece, then
// decoded by Tessera's PLY reader (renderer/input/ply_reader.h).
#include "renderer/input/mesh_io.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "renderer/util/gzip_io.h"
#include "renderer/util/limits.h"
#include "renderer/input/ply_reader.h"
#include "renderer/util/error.h"

namespace tessera {

namespace {

[[noreturn]] void fail(const std::string &path, const std::string &msg) {
    throw SceneError(FileLoc{path, 0}, msg);
}

/// The whole file at `path` in one buffer, read with one unbuffered read (the size checked
/// against the memory budget first). *size gets the bytes read: fewer than the file's size if
/// it shrank meanwhile.
std::unique_ptr<char[]> read_whole_file(const std::string &path, size_t *size) {
    std::error_code ec;
    const uint64_t file_size = std::filesystem::file_size(path, ec);
    if (ec) fail(path, "cannot read PLY: " + ec.message());
    check_memory(file_size, "PLY file (" + format_bytes(file_size) + ")", FileLoc{path, 0});
    std::unique_ptr<std::FILE, int (*)(std::FILE *)> f(std::fopen(path.c_str(), "rb"),
                                                       &std::fclose);
    if (!f) fail(path, std::string("cannot read PLY: ") + std::strerror(errno));
    std::setvbuf(f.get(), nullptr, _IONBF, 0);
    auto data = std::make_unique_for_overwrite<char[]>(size_t(file_size) + 1);
    *size = std::fread(data.get(), 1, size_t(file_size), f.get());
    if (std::ferror(f.get())) fail(path, std::string("cannot read PLY: ") + std::strerror(errno));
    return data;
}

}  // namespace

MeshData load_ply(const std::string &path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        fail(path, std::filesystem::is_directory(path, ec) ? "is a directory, not a PLY file"
                                                            : "PLY file not found");
    // A ".ply.gz" file (pbrt-v4-scenes ships several) is decompressed into memory first.
    if (has_gz_extension(path)) {
        std::string data;
        std::string why = read_gzip_file(path, &data, memory_budget_bytes() / 4);
        if (!why.empty()) fail(path, "cannot read PLY: the file " + why);
        return read_ply_mesh(data, path);
    }
    size_t size = 0;
    std::unique_ptr<char[]> data = read_whole_file(path, &size);
    return read_ply_mesh(std::string_view(data.get(), size), path);
}

}  // namespace tessera
