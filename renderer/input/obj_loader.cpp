// OBJ + MTL -> SceneDesc (see obj_loader.h for the mapping and its sources).
#include "renderer/input/obj_loader.h"

#include "renderer/input/default_view.h"

#include <tiny_obj_loader.h>

#include <filesystem>
#include <map>
#include <sstream>
#include <tuple>

namespace tessera {

namespace fs = std::filesystem;

namespace {

Param make_param(const std::string &type, const std::string &name, std::vector<double> numbers,
                 const FileLoc &loc) {
    return Param::numeric(type, name, std::move(numbers), loc);
}

Param make_string(const std::string &type, const std::string &name, const std::string &value,
                  const FileLoc &loc) {
    Param p;
    p.type = type;
    p.name = name;
    p.strings = {value};
    p.loc = loc;
    return p;
}

Param make_bool(const std::string &name, bool value, const FileLoc &loc) {
    Param p;
    p.type = "bool";
    p.name = name;
    p.bools = {uint8_t(value ? 1 : 0)};
    p.loc = loc;
    return p;
}

Param make_rgb(const std::string &name, const tinyobj::real_t c[3], const FileLoc &loc) {
    return make_param("rgb", name, {double(c[0]), double(c[1]), double(c[2])}, loc);
}

bool is_black(const tinyobj::real_t c[3]) {
    return c[0] <= 0 && c[1] <= 0 && c[2] <= 0;
}

/// Turns one .mtl material into a MaterialDesc (and its map_Kd texture, if any).
MaterialDesc convert_material(const tinyobj::material_t &m, const FileLoc &loc,
                              const std::string &base_dir, std::vector<TextureDesc> &textures) {
    MaterialDesc md;
    md.name = m.name;
    md.loc = loc;
    md.base_dir = base_dir;
    std::vector<Param> &ps = md.params.params;
    const bool refracts = m.illum == 4 || m.illum == 6 || m.illum == 7 || m.illum == 9;
    if (m.illum == 5) {
        md.type = "conductor";
        // A perfect mirror: pbrt-v4's conductor takes a reflectance instead of eta/k.
        const tinyobj::real_t white[3] = {1, 1, 1};
        const tinyobj::real_t *r = is_black(m.specular) ? white : m.specular;
        tinyobj::real_t rc[3];
        for (int i = 0; i < 3; ++i) rc[i] = std::min<tinyobj::real_t>(r[i], 1);
        ps.push_back(make_rgb("reflectance", rc, loc));
        ps.push_back(make_param("float", "roughness", {0.0}, loc));
        return md;
    }
    if (refracts) {
        md.type = "dielectric";
        double eta = (m.ior > 0 && m.ior != 1) ? double(m.ior) : 1.5;
        ps.push_back(make_param("float", "eta", {eta}, loc));
        ps.push_back(make_param("float", "roughness", {0.0}, loc));
        return md;
    }
    md.type = is_black(m.specular) ? "diffuse" : "coateddiffuse";
    if (!m.diffuse_texname.empty()) {
        TextureDesc td;
        td.name = m.name + ":map_Kd";
        td.value_type = "spectrum";
        td.tex_class = "imagemap";
        td.loc = loc;
        td.base_dir = base_dir;
        td.params.params.push_back(make_string("string", "filename", m.diffuse_texname, loc));
        const tinyobj::texture_option_t &o = m.diffuse_texopt;
        if (o.scale[0] != 1)
            td.params.params.push_back(make_param("float", "uscale", {double(o.scale[0])}, loc));
        if (o.scale[1] != 1)
            td.params.params.push_back(make_param("float", "vscale", {double(o.scale[1])}, loc));
        if (o.origin_offset[0] != 0)
            td.params.params.push_back(
                make_param("float", "udelta", {double(o.origin_offset[0])}, loc));
        if (o.origin_offset[1] != 0)
            td.params.params.push_back(
                make_param("float", "vdelta", {double(o.origin_offset[1])}, loc));
        textures.push_back(td);
        ps.push_back(make_string("texture", "reflectance", td.name, loc));
    } else {
        ps.push_back(make_rgb("reflectance", m.diffuse, loc));
    }
    if (md.type == "coateddiffuse") {
        // Phong exponent -> Beckmann alpha (Walter et al. 2007, eq. 33 inverted).
        double ns = std::max<double>(m.shininess, 0.0);
        ps.push_back(make_param("float", "roughness", {std::sqrt(2.0 / (ns + 2.0))}, loc));
        ps.push_back(make_bool("remaproughness", false, loc));
    }
    return md;
}

/// One output mesh: the corners of one (OBJ shape, material) pair.
struct Group {
    std::vector<Vec3f> p, n;
    std::vector<Vec2f> uv;
    std::vector<int> indices;
    bool all_normals = true, all_uv = true;
    std::map<std::tuple<int, int, int>, int> vertex_of;  ///< (v, vt, vn) -> output vertex
};

}  // namespace

SceneDesc load_obj_scene(const std::string &path) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec))
        throw SceneError(path + (fs::is_directory(path, ec) ? ":0: is a directory, not an OBJ file"
                                                            : ":0: OBJ file not found"));
    const FileLoc loc{path, 0};
    const std::string base_dir = fs::path(path).parent_path().string();

    tinyobj::ObjReaderConfig config;
    config.triangulate = true;  // quads split along the shorter diagonal
    config.vertex_color = false;
    tinyobj::ObjReader reader;
    bool ok = reader.ParseFromFile(path, config);
    if (!reader.Warning().empty()) {
        std::istringstream lines(reader.Warning());
        for (std::string line; std::getline(lines, line);)
            if (!line.empty()) warn(loc, line);
    }
    if (!ok || !reader.Valid()) throw SceneError(path + ":0: cannot read OBJ: " + reader.Error());

    const tinyobj::attrib_t &attrib = reader.GetAttrib();
    const auto &shapes = reader.GetShapes();
    const auto &materials = reader.GetMaterials();

    SceneDesc scene;
    scene.main_file = path;
    bool any_emitter = false;
    for (const tinyobj::material_t &m : materials) {
        if (scene.materials.count(m.name))
            warn(loc, "material \"" + m.name + "\" defined twice; using the first");
        else
            scene.materials[m.name] = convert_material(m, loc, base_dir, scene.textures);
        any_emitter = any_emitter || !is_black(m.emission);
    }

    Vec3f lo(kInfinity, kInfinity, kInfinity), hi = -lo;
    for (const tinyobj::shape_t &shape : shapes) {
        const tinyobj::mesh_t &mesh = shape.mesh;
        // Group the shape's faces by material, keeping first-use order.
        std::vector<int> order;
        std::map<int, Group> groups;
        size_t offset = 0;
        for (size_t f = 0; f < mesh.num_face_vertices.size(); ++f) {
            const int nv = mesh.num_face_vertices[f];
            const int mat = f < mesh.material_ids.size() ? mesh.material_ids[f] : -1;
            if (nv != 3) {  // triangulation leaves only triangles; skip anything else
                offset += size_t(nv);
                continue;
            }
            if (!groups.count(mat)) order.push_back(mat);
            Group &g = groups[mat];
            for (int k = 0; k < 3; ++k) {
                const tinyobj::index_t &ix = mesh.indices[offset + size_t(k)];
                if (ix.vertex_index < 0 ||
                    3 * size_t(ix.vertex_index) + 2 >= attrib.vertices.size())
                    throw SceneError(path + ":0: face references a missing vertex");
                auto key = std::make_tuple(ix.vertex_index, ix.texcoord_index, ix.normal_index);
                auto it = g.vertex_of.find(key);
                if (it != g.vertex_of.end()) {
                    g.indices.push_back(it->second);
                    continue;
                }
                const int id = int(g.p.size());
                g.vertex_of.emplace(key, id);
                g.indices.push_back(id);
                const float *v = &attrib.vertices[3 * size_t(ix.vertex_index)];
                g.p.push_back({v[0], v[1], v[2]});
                lo = vmin(lo, g.p.back());
                hi = vmax(hi, g.p.back());
                if (ix.normal_index >= 0 &&
                    3 * size_t(ix.normal_index) + 2 < attrib.normals.size()) {
                    const float *nn = &attrib.normals[3 * size_t(ix.normal_index)];
                    g.n.push_back({nn[0], nn[1], nn[2]});
                } else {
                    g.all_normals = false;
                }
                if (ix.texcoord_index >= 0 &&
                    2 * size_t(ix.texcoord_index) + 1 < attrib.texcoords.size()) {
                    const float *t = &attrib.texcoords[2 * size_t(ix.texcoord_index)];
                    g.uv.push_back({t[0], t[1]});
                } else {
                    g.all_uv = false;
                }
            }
            offset += 3;
        }
        for (int mat : order) {
            Group &g = groups[mat];
            ShapeDesc sd;
            sd.type = "trianglemesh";
            sd.loc = loc;
            sd.base_dir = base_dir;
            std::vector<double> pts, idx;
            pts.reserve(3 * g.p.size());
            for (Vec3f q : g.p) pts.insert(pts.end(), {q.x, q.y, q.z});
            idx.assign(g.indices.begin(), g.indices.end());
            sd.params.params.push_back(make_param("point3", "P", std::move(pts), loc));
            sd.params.params.push_back(make_param("integer", "indices", std::move(idx), loc));
            if (g.all_normals && !g.n.empty()) {
                std::vector<double> ns;
                for (Vec3f q : g.n) ns.insert(ns.end(), {q.x, q.y, q.z});
                sd.params.params.push_back(make_param("normal", "N", std::move(ns), loc));
            }
            if (g.all_uv && !g.uv.empty()) {
                std::vector<double> uvs;
                for (Vec2f q : g.uv) uvs.insert(uvs.end(), {q.x, q.y});
                sd.params.params.push_back(make_param("point2", "uv", std::move(uvs), loc));
            }
            if (mat >= 0 && size_t(mat) < materials.size()) {
                const tinyobj::material_t &m = materials[size_t(mat)];
                sd.material = m.name;
                if (!is_black(m.emission)) {
                    ParamSet light;
                    light.params.push_back(make_rgb("L", m.emission, loc));
                    light.params.push_back(make_bool("twosided", false, loc));
                    sd.area_light = light;
                    sd.area_light_type = "diffuse";
                    sd.area_light_loc = loc;
                }
            }
            scene.shapes.push_back(std::move(sd));
        }
    }
    if (scene.shapes.empty()) throw SceneError(path + ":0: OBJ file has no faces");

    // Camera, film and (without emitters) lights: see obj_loader.h and default_view.h.
    add_default_view(scene, lo, hi, any_emitter);
    return scene;
}

}  // namespace tessera
