// What each fuzz target does with one input, shared by the libFuzzer targets (tests/fuzz/fuzz_*.cpp,
// built with -DTESSERA_FUZZ=ON, run by scripts/run_fuzz.sh) and by the regression test that
// replays the inputs fuzzing once crashed on (tests/renderer/test_fuzz_regressions.cpp, normal
// build).
//
// The contract under test: any byte string is either accepted or rejected with a SceneError.
// Anything else -- another exception type (it would reach the CLI as "internal error", exit 1),
// a crash, a sanitizer report, a hang or a huge allocation -- is a bug.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "renderer/input/mesh_io.h"
#include "renderer/input/obj_loader.h"
#include "renderer/input/ply_reader.h"
#include "renderer/input/pbrt_parser.h"
#include "renderer/scene/scene.h"
#include "renderer/util/native_image.h"
#include "renderer/util/limits.h"

namespace tessera::fuzz {

/// Which loader an input goes to.
enum class Target { Pbrt, Ply, Obj, Image };

/// A scratch folder of this process for inputs that must be files (the mesh loaders take paths).
inline const std::filesystem::path &scratch_dir() {
    static const std::filesystem::path dir = [] {
        std::filesystem::path d = std::filesystem::temp_directory_path() /
                                  ("tessera-fuzz-" + std::to_string(long(::getpid())));
        std::filesystem::create_directories(d);
        return d;
    }();
    return dir;
}

inline void write_file(const std::filesystem::path &p, std::string_view bytes) {
    std::ofstream(p, std::ios::binary | std::ios::trunc).write(bytes.data(),
                                                                std::streamsize(bytes.size()));
}

/// Parses `bytes` as a pbrt-v4 scene and, when that succeeds, builds it at 4x4 pixels and 1 spp
/// (materials, textures, meshes, lights, Embree geometry; no rendering). Relative file names
/// resolve against the scratch folder, which holds nothing.
inline void run_pbrt(std::string_view bytes) {
    SceneDesc desc = parse_pbrt_string(std::string(bytes), "fuzz.pbrt", scratch_dir().string());
    // Loop subdivision at its maximum of 8 levels turns a tetrahedron into 262144 triangles:
    // legitimate, 0.8 s in a Release build, but over the fuzzer's 10 s timeout under ASan. Cap
    // the levels at 2 (the code paths are the same) so that the fuzzer spends its time on
    // parsing and building.
    auto cap_levels = [](std::vector<ShapeDesc> &shapes) {
        for (ShapeDesc &sd : shapes)
            for (Param &p : sd.params.params)
                if (sd.type == "loopsubdiv" && p.name == "levels")
                    for (double &v : p.numbers) v = std::min(v, 2.0);
    };
    cap_levels(desc.shapes);
    for (auto &[name, object] : desc.objects) cap_levels(object.shapes);
    SceneOverrides ov;
    ov.width = ov.height = 4;
    ov.spp = 1;
    build_scene(desc, ov);
}

/// Reads `bytes` as the contents of a PLY file with read_ply_mesh (Tessera's reader,
/// renderer/input/ply_reader.h: what load_ply runs on the file it has read into memory). From memory,
/// so that the fuzzer spends its time in the reader rather than on writing files.
inline void run_ply(std::string_view bytes) { read_ply_mesh(bytes, "fuzz.ply"); }

/// Loads `bytes` as an OBJ scene with load_obj_scene (tinyobjloader). Everything after a line
/// "#MTL" becomes the material library fuzz.mtl beside it, so that `mtllib fuzz.mtl` reaches the
/// MTL parser too.
inline void run_obj(std::string_view bytes) {
    std::string_view obj = bytes, mtl;
    if (size_t cut = bytes.find("\n#MTL\n"); cut != std::string_view::npos) {
        obj = bytes.substr(0, cut + 1);
        mtl = bytes.substr(cut + 6);
    }
    write_file(scratch_dir() / "fuzz.mtl", mtl);
    std::filesystem::path p = scratch_dir() / "fuzz.obj";
    write_file(p, obj);
    SceneDesc desc = load_obj_scene(p.string());
    SceneOverrides ov;
    ov.width = ov.height = 4;
    ov.spp = 1;
    build_scene(desc, ov);
}

/// Reads `bytes` with the native image readers (renderer/util/native_image.h): the first byte
/// picks the name (.tga, .pfm or .png: TGA is known by its extension only) and whether alpha
/// is kept unassociated, the rest is the file. An opened image is read whole when open_image
/// would allow it (the size limit of renderer/util/limits.h, here also 64 MiB of floats).
/// Failures are return values, never exceptions.
inline void run_image(std::string_view bytes) {
    if (bytes.empty()) return;
    const unsigned char sel = static_cast<unsigned char>(bytes[0]);
    static const char *kNames[] = {"fuzz.tga", "fuzz.pfm", "fuzz.png"};
    std::unique_ptr<imageio::ImageInput> in;
    std::string err;
    if (imageio::open_native_memory(std::string(bytes.substr(1)), kNames[sel % 3],
                                    (sel & 0x80) != 0, &in,
                                    &err) != imageio::NativeOpen::Opened)
        return;
    const imageio::ImageSpec &s = in->spec();
    const uint64_t n = uint64_t(s.width) * uint64_t(s.height) * uint64_t(s.nchannels);
    if (s.width <= 0 || s.height <= 0 || s.nchannels <= 0 ||
        uint64_t(s.width) * uint64_t(s.height) > kMaxImagePixels || n > (uint64_t(1) << 24))
        return;
    std::vector<float> px(n);
    in->read_image(0, s.nchannels, imageio::PixelType::Float, px.data());
}

/// Runs one input; SceneError (bad input, reported as file:line) is the accepted way to fail.
inline void run(Target t, std::string_view bytes) {
    try {
        switch (t) {
        case Target::Pbrt: run_pbrt(bytes); break;
        case Target::Ply: run_ply(bytes); break;
        case Target::Obj: run_obj(bytes); break;
        case Target::Image: run_image(bytes); break;
        }
    } catch (const SceneError &) {
    }
}

}  // namespace tessera::fuzz
