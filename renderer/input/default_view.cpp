#include "renderer/input/default_view.h"

#include <filesystem>

#include "renderer/util/gzip_io.h"
#include "renderer/input/mesh_io.h"

namespace tessera {

namespace {

Param make_param(const std::string &type, const std::string &name, std::vector<double> numbers,
                 const FileLoc &loc) {
    return Param::numeric(type, name, std::move(numbers), loc);
}

}  // namespace

Transform default_camera_from_world(Vec3f bmin, Vec3f bmax, float fov_deg) {
    Vec3f center = (bmin + bmax) * 0.5f;
    float radius = 0.5f * length(bmax - bmin);
    if (!(radius > 0)) radius = 1;
    // The distance at which the field of view exactly frames the bounding sphere.
    float distance = radius / std::sin(radians(0.5f * fov_deg));
    Vec3f eye = center + Vec3f(0, 0, distance);
    // pbrt is left-handed: Scale(-1, 1, 1) shows a right-handed model with +x to the right,
    // as its authors saw it, without changing the geometry.
    return Transform::scale(-1, 1, 1) * Transform::look_at(eye, center, Vec3f(0, 1, 0));
}

void add_default_view(SceneDesc &desc, Vec3f bmin, Vec3f bmax, bool has_emitters) {
    FileLoc loc{desc.main_file, 0};
    const float fov = kObjCameraFovDeg;
    if (!desc.camera.present) {
        desc.camera.present = true;
        desc.camera.type = "perspective";
        desc.camera.loc = loc;
        desc.camera.params.params.push_back(make_param("float", "fov", {fov}, loc));
        desc.camera_from_world = default_camera_from_world(bmin, bmax, fov);
    }
    if (!desc.film.present) {
        desc.film.present = true;
        desc.film.type = "rgb";
        desc.film.loc = loc;
        double res = kObjFilmResolution;
        desc.film.params.params.push_back(make_param("integer", "xresolution", {res}, loc));
        desc.film.params.params.push_back(make_param("integer", "yresolution", {res}, loc));
        // `tessera render model.obj` writes model.exr and model.png in the current folder.
        Param f;
        f.type = "string";
        f.name = "filename";
        f.strings = {std::filesystem::path(strip_gz_extension(desc.main_file)).stem().string() +
                     ".exr"};
        f.loc = loc;
        desc.film.params.params.push_back(f);
    }
    if (!has_emitters && desc.lights.empty()) {
        std::string base_dir = std::filesystem::path(desc.main_file).parent_path().string();
        LightDesc env;
        env.type = "infinite";
        env.loc = loc;
        env.base_dir = base_dir;
        env.params.params.push_back(make_param("rgb", "L", {0.5, 0.5, 0.5}, loc));
        desc.lights.push_back(env);
        LightDesc key;
        key.type = "distant";
        key.loc = loc;
        key.base_dir = base_dir;
        key.params.params.push_back(make_param("point3", "from", {1, 2, 2}, loc));
        key.params.params.push_back(make_param("point3", "to", {0, 0, 0}, loc));
        key.params.params.push_back(make_param("rgb", "L", {1.5, 1.5, 1.5}, loc));
        desc.lights.push_back(key);
    }
}

SceneDesc load_ply_scene(const std::string &path) {
    MeshData md = load_ply(path);
    SceneDesc desc;
    desc.main_file = path;
    Vec3f bmin(kInfinity, kInfinity, kInfinity), bmax = -bmin;
    for (Vec3f p : md.p) {
        bmin = vmin(bmin, p);
        bmax = vmax(bmax, p);
    }
    ShapeDesc sd;
    sd.type = "plymesh";
    sd.loc = FileLoc{path, 0};
    Param f;
    f.type = "string";
    f.name = "filename";
    f.strings = {std::filesystem::absolute(path).string()};
    f.loc = sd.loc;
    sd.params.params.push_back(f);
    desc.shapes.push_back(sd);
    add_default_view(desc, bmin, bmax, false);
    return desc;
}

}  // namespace tessera
