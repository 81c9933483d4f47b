#include "renderer/default_view.h"

#include <filesystem>

#include "renderer/mesh_io.h"

namespace tessera {

namespace {

Param make_param(const std::string &type, const std::string &name, std::vector<double> nums,
                 const FileLoc &loc) {
    Param p;
    p.type = type;
    p.name = name;
    p.numbers = std::move(nums);
    p.loc = loc;
    return p;
}

}  // namespace

Transform default_camera_from_world(Vec3f bmin, Vec3f bmax, float fov_deg) {
    Vec3f center = (bmin + bmax) * 0.5f;
    float radius = std::max(length(bmax - bmin) * 0.5f, 1e-4f);
    // Distance at which the bounding sphere fits the vertical field of view, with a margin.
    float dist = 1.1f * radius / std::sin(radians(fov_deg) * 0.5f);
    Vec3f eye{center.x, center.y, center.z + dist};
    // camera x = world x, camera y = world y, camera z = -(world z - eye z): looking toward -z
    // without mirroring the image (a handedness flip, as exporters from right-handed tools do).
    Mat4 m;
    m.m[0][3] = -eye.x;
    m.m[1][3] = -eye.y;
    m.m[2][2] = -1;
    m.m[2][3] = eye.z;
    return Transform(m);
}

void add_default_view(SceneDesc &desc, Vec3f bmin, Vec3f bmax, bool has_emitters) {
    FileLoc loc{desc.main_file, 0};
    const float fov = 40.f;
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
        desc.film.params.params.push_back(make_param("integer", "xresolution", {512}, loc));
        desc.film.params.params.push_back(make_param("integer", "yresolution", {512}, loc));
        Param f;
        f.type = "string";
        f.name = "filename";
        f.strings = {std::filesystem::path(desc.main_file).stem().string() + ".exr"};
        f.loc = loc;
        desc.film.params.params.push_back(f);
    }
    if (!has_emitters && desc.lights.empty()) {
        LightDesc sky;
        sky.type = "infinite";
        sky.loc = loc;
        sky.params.params.push_back(make_param("rgb", "L", {0.25, 0.25, 0.25}, loc));
        desc.lights.push_back(sky);
        LightDesc key;
        key.type = "distant";
        key.loc = loc;
        key.params.params.push_back(make_param("rgb", "L", {3, 3, 3}, loc));
        Vec3f c = (bmin + bmax) * 0.5f;
        float r = std::max(length(bmax - bmin), 1e-3f);
        key.params.params.push_back(
            make_param("point3", "from", {c.x - 0.5 * r, c.y + r, c.z + r}, loc));
        key.params.params.push_back(make_param("point3", "to", {c.x, c.y, c.z}, loc));
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
