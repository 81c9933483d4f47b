// Turns a SceneDesc into a renderable Scene: settings, textures, materials, Embree geometry,
// area lights, other lights and the light sampler. pbrt-v4 defaults throughout.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "renderer/input/mesh_io.h"
#include "renderer/input/default_view.h"
#include "renderer/util/gzip_io.h"
#include "renderer/camera/lens_system.h"
#include "renderer/util/limits.h"
#include "renderer/input/loop_subdiv.h"
#include "renderer/util/spectra.h"
#if __has_include("renderer/input/obj_loader.h")
#include "renderer/input/obj_loader.h"
#define TESSERA_HAVE_OBJ 1
#endif
#include "renderer/input/pbrt_parser.h"
#include "renderer/scene/scene.h"
#include "renderer/scene/specialize.h"

namespace tessera {

namespace fs = std::filesystem;

std::string SceneFeatures::describe() const {
    std::string s;
    auto add = [&](bool f, const char *name) {
        if (!f) return;
        if (!s.empty()) s += ", ";
        s += name;
    };
    add(textures, "textures");
    add(image_textures, "image textures");
    add(specular, "specular");
    add(transmission, "transmission");
    add(emissive_shapes, "area lights");
    add(environment, "environment");
    add(environment_map, "environment map");
    add(delta_lights, "delta lights");
    add(instances, "instances");
    add(quadrics, "quadrics");
    add(curves, "curves");
    add(media, "media");
    return s.empty() ? "(none)" : s;
}

std::string Scene::describe() const {
    std::ostringstream os;
    os << settings.width << "x" << settings.height << ", " << settings.spp << " spp, max depth "
       << settings.max_depth << "; " << geometry->triangle_count() << " triangles, "
       << geometry->instance_count() << " instances, " << materials.size() << " materials, "
       << lights.size() << " lights; " << filter.describe() << "; features: "
       << features.describe();
    return os.str();
}

namespace {

/// A relative file name against the main file's directory (pbrt-v4), falling back to the
/// directory of the file that named it.
std::string resolve(const std::string &base_dir, const FileLoc &loc, const std::string &file) {
    fs::path p(file);
    if (p.is_absolute()) return p.string();
    fs::path main = base_dir.empty() ? p : fs::path(base_dir) / p;
    std::error_code ec;
    if (fs::exists(main, ec)) return main.string();
    fs::path alt = fs::path(loc.file).parent_path() / p;
    if (fs::exists(alt, ec)) return alt.string();
    return main.string();
}

/// pbrt-v4 Camera "realistic": "lensfile" (required), "aperturediameter" (mm, default 1),
/// "focusdistance" (m, default 10), "aperture" (a built-in stop shape); the film size is
/// Film "diagonal" (mm, default 35).
std::shared_ptr<const LensSystem> build_lens_system(const SceneDesc &d,
                                                    const RenderSettings &s) {
    const ParamSet &cp = d.camera.params;
    const Param *lf = cp.find("lensfile");
    const std::string lens_name = cp.get_string("lensfile", "");
    if (lens_name.empty())
        throw SceneError(d.camera.loc, "Camera \"realistic\" needs a \"string lensfile\" "
                                       "(a lens description file)");
    const std::string base_dir = fs::path(d.main_file).parent_path().string();
    const std::vector<float> elements = read_lens_file(resolve(base_dir, lf->loc, lens_name));
    const float aperture_diameter = cp.get_float("aperturediameter", 1.f);
    const float focus_distance = cp.get_float("focusdistance", 10.f);
    float diagonal_mm = 35.f;
    if (d.film.present) diagonal_mm = d.film.params.get_float("diagonal", 35.f);
    ApertureImage aperture;
    if (const Param *ap = cp.find("aperture")) {
        // A built-in shape, else an image file whose RGB average (linear) is the stop's
        // transmission (pbrt-v4 RealisticCamera::Create).
        const std::string name = cp.get_string("aperture", "");
        aperture = ApertureImage::builtin(name);
        if (aperture.empty() && !name.empty()) {
            const std::string file = resolve(base_dir, ap->loc, name);
            int w = 0, h = 0;
            // Linear RGB; 8- and 16-bit formats decoded from sRGB as pbrt does.
            std::vector<Rgb> img = read_rgb_image(file, ap->loc, &w, &h);
            std::vector<float> values(img.size());
            for (size_t p = 0; p < values.size(); ++p)
                values[p] = std::max(0.f, (img[p].r + img[p].g + img[p].b) / 3.f);
            aperture = ApertureImage(w, h, std::move(values));
            if (aperture.empty())
                throw SceneError(ap->loc, "Camera \"realistic\": the aperture image \"" +
                                              name + "\" passes no light (it is black)");
        }
    }
    std::vector<std::string> warnings;
    try {
        auto lens = std::make_shared<const LensSystem>(elements, aperture_diameter,
                                                       focus_distance, diagonal_mm / 1000.f,
                                                       s.width, s.height, std::move(aperture),
                                                       &warnings);
        for (const std::string &w : warnings) warn(d.camera.loc, "Camera \"realistic\": " + w);
        return lens;
    } catch (const std::runtime_error &e) {
        throw SceneError(d.camera.loc, std::string("Camera \"realistic\": ") + e.what());
    }
}

/// Film: resolution, output name, AOVs, the sensor's imaging ratio, clamp and white balance.
void apply_film(const SceneDesc &d, RenderSettings &s) {
    if (d.film.present) {
        const ParamSet &ps = d.film.params;
        // pbrt-v4: "gbuffer" adds the geometric AOVs to the RGB image; "rgb" has none.
        if (d.film.type == "gbuffer")
            s.aovs = sampling::AovSet::all();
        else if (d.film.type == "spectral")
            warn(d.film.loc, "Film \"spectral\" is rendered as an \"rgb\" film");
        else if (d.film.type != "rgb")
            throw SceneError(d.film.loc, "unknown film type \"" + d.film.type + "\"");
        s.width = ps.get_int("xresolution", 1280);
        s.height = ps.get_int("yresolution", 720);
        s.output = ps.get_string("filename", "pbrt.exr");
        if (ps.find("cropwindow") || ps.find("pixelbounds"))
            warn(d.film.loc, "\"cropwindow\"/\"pixelbounds\" are not supported: the whole film "
                             "is rendered");
        // pbrt-v4's PixelSensor scales the image by imagingRatio = exposure time * ISO / 100
        // (for every sensor, the default "cie1931" included; the exposure time comes from the
        // camera's shutter below), and RGBFilm clamps each sample's largest component.
        s.image_scale = ps.get_float("iso", 100.f) / 100.f;
        s.max_component = ps.get_float("maxcomponentvalue", kInfinity);
        // "whitebalance" T (pbrt-v4 PixelSensor): the white of CIE illuminant D(T) becomes the
        // output's white, by a von Kries (Bradford) matrix on the final RGB. pbrt-v4 balances
        // named camera sensors too (from 6500 K by default); Tessera has no sensor curves, so
        // a named sensor renders as "cie1931" with the given white balance.
        if (const Param *p = ps.find("whitebalance")) {
            const float t = ps.get_float("whitebalance", 0.f);
            if (t < 0.f || !std::isfinite(t))
                throw SceneError(p->loc, "\"whitebalance\" must be a positive temperature in "
                                         "kelvin (or 0: off)");
            if (t > 0.f) {
                s.white_balance = white_balance_srgb(daylight_xy(t), kSrgbWhiteXy);
                s.white_balanced = true;
            }
        }
        for (const char *ignored : {"cropwindow", "pixelbounds", "diagonal", "savefp16",
                                    "sensor"}) {
            if (const Param *p = ps.find(ignored)) {
                if (std::string(ignored) == "sensor" &&
                    ps.get_string("sensor", "cie1931") != "cie1931")
                    warn(p->loc, "Film \"sensor\" \"" + ps.get_string("sensor", "") +
                                     "\" is not supported (no sensor curves): rendered as "
                                     "\"cie1931\"");
                p->used = true;
            }
        }
        // pbrt-v4's GBufferFilm writes camera-space geometry by default; Tessera's AOVs are
        // world space (renderer/util/image_io.h).
        if (const Param *p = ps.find("coordinatesystem")) {
            if (d.film.type == "gbuffer" && ps.get_string("coordinatesystem", "camera") != "world")
                warn(p->loc, "Film \"gbuffer\": the normal AOV is written in world space, not "
                             "camera space");
            p->used = true;
        }
        ps.report_unused("Film");
    } else {
        s.output = "pbrt.exr";
    }
}

/// Sampler: samples per pixel, seed and pattern. Tessera always draws Owen-scrambled Sobol
/// points; pbrt-v4's global sequences ("sobol", "halton") map to SamplePattern::Sobol, whose
/// dimensions stay jointly stratified, and its padded and stratified samplers ("zsobol",
/// "paddedsobol", "pmj02bn", "stratified", "independent") to SamplePattern::Padded.
void apply_sampler(const SceneDesc &d, RenderSettings &s) {
    if (d.sampler.present) {
        static const char *kSamplers[] = {"zsobol", "paddedsobol", "sobol",      "halton",
                                          "pmj02bn", "independent", "stratified"};
        if (std::find(std::begin(kSamplers), std::end(kSamplers), d.sampler.type) ==
            std::end(kSamplers))
            throw SceneError(d.sampler.loc, "unknown sampler type \"" + d.sampler.type + "\"");
        s.spp = d.sampler.params.get_int("pixelsamples", 16);
        s.sample_pattern = d.sampler.type == "sobol" || d.sampler.type == "halton"
                               ? sampling::SamplePattern::Sobol
                               : sampling::SamplePattern::Padded;
        // Tessera always uses its Owen-scrambled Sobol sequence; the other sampler parameters
        // (seed, randomization, jitter) select variants of equal expectation.
        if (const Param *p = d.sampler.params.find("seed")) {
            s.seed = uint32_t(d.sampler.params.get_int("seed", 0));
            p->used = true;
        }
        for (const Param &p : d.sampler.params.params) p.used = true;
    }
}

/// Integrator: path or volpath, depth, the unsupported settings warned about.
void apply_integrator(const SceneDesc &d, RenderSettings &s) {
    if (d.integrator.present) {
        const ParamSet &ps = d.integrator.params;
        const std::string &t = d.integrator.type;
        static const char *kIntegrators[] = {
            "path",       "volpath",       "bdpt",      "mlt",     "sppm", "ambientocclusion",
            "randomwalk", "simplevolpath", "simplepath", "lightpath", "aov", "function"};
        if (std::find(std::begin(kIntegrators), std::end(kIntegrators), t) ==
            std::end(kIntegrators))
            throw SceneError(d.integrator.loc, "unknown integrator type \"" + t + "\"");
        if (t != "path" && t != "volpath")
            warn(d.integrator.loc, "Integrator \"" + t +
                                       "\" is not supported; using the \"path\" integrator");
        s.volpath = t != "path";
        s.max_depth = ps.get_int("maxdepth", 5);
        s.regularize = ps.get_bool("regularize", false);
        if (s.regularize)
            warn(d.integrator.loc, "\"regularize\" is not supported; ignored");
        if (const Param *p = ps.find("lightsampler")) {
            std::string ls = ps.get_string("lightsampler", "bvh");
            if (ls != "power")
                warn(p->loc, "light sampler \"" + ls +
                                 "\" replaced by \"power\" (same expectation, other noise)");
        }
        ps.report_unused("Integrator");
    }
}

/// The command line's overrides, then the film's resolution, spp and memory checked before any
/// geometry is loaded.
void apply_overrides(const SceneDesc &d, const SceneOverrides &ov, RenderSettings &s) {
    if (ov.width) s.width = *ov.width;
    if (ov.height) s.height = *ov.height;
    if (ov.spp) s.spp = *ov.spp;
    if (ov.max_depth) s.max_depth = *ov.max_depth;
    if (ov.seed) s.seed = *ov.seed;
    if (ov.max_component) s.max_component = *ov.max_component;
    if (ov.aovs) s.aovs = *ov.aovs;
    if (!(s.max_component > 0))
        throw SceneError(ov.max_component ? FileLoc{"--clamp", 0} : d.film.loc,
                         "the firefly clamp (maxcomponentvalue) must be positive");
    check_film(s.width, s.height, s.spp,
               ov.width || ov.height ? FileLoc{"--resolution", 0} : d.film.loc,
               ov.spp ? FileLoc{"--spp", 0} : d.sampler.loc, s.aovs);
}

/// The pixel filter (pbrt-v4 default: gaussian, radius 1.5, sigma 0.5).
PixelFilter build_filter(const SceneDesc &d) {
    std::string ft = d.filter.present ? d.filter.type : "gaussian";
    const ParamSet &fp = d.filter.params;
    PixelFilter filter;
    if (ft == "box") {
        filter = PixelFilter(PixelFilter::Kind::Box,
                                {fp.get_float("xradius", 0.5f), fp.get_float("yradius", 0.5f)});
    } else if (ft == "triangle") {
        filter = PixelFilter(PixelFilter::Kind::Triangle,
                                {fp.get_float("xradius", 2.f), fp.get_float("yradius", 2.f)});
    } else if (ft == "gaussian") {
        filter = PixelFilter(PixelFilter::Kind::Gaussian,
                                {fp.get_float("xradius", 1.5f), fp.get_float("yradius", 1.5f)},
                                fp.get_float("sigma", 0.5f));
    } else if (ft == "mitchell") {
        filter = PixelFilter::mitchell(
            {fp.get_float("xradius", 2.f), fp.get_float("yradius", 2.f)},
            fp.get_float("B", 1.f / 3.f), fp.get_float("C", 1.f / 3.f));
    } else if (ft == "sinc") {
        filter = PixelFilter::lanczos(
            {fp.get_float("xradius", 4.f), fp.get_float("yradius", 4.f)}, fp.get_float("tau", 3.f));
    } else {
        throw SceneError(d.filter.loc, "unknown pixel filter type \"" + ft + "\"");
    }
    if (d.filter.present) fp.report_unused("PixelFilter");
    return filter;
}

/// The camera, for the film size in `s`; its shutter interval scales s.image_scale (pbrt-v4
/// PixelSensor imaging ratio).
std::unique_ptr<PerspectiveCamera> build_camera(const SceneDesc &d, RenderSettings &s) {
    float fov = 90.f, lens_radius = 0.f, focal_distance = 1e6f;
    std::shared_ptr<const LensSystem> lens;
    bool orthographic = false;
    SphericalMapping spherical = SphericalMapping::None;
    std::vector<float> sw;
    if (d.camera.present) {
        const ParamSet &cp = d.camera.params;
        if (d.camera.type != "perspective" && d.camera.type != "orthographic" &&
            d.camera.type != "spherical" && d.camera.type != "realistic")
            throw SceneError(d.camera.loc, "Camera \"" + d.camera.type +
                                               "\" is not supported (\"perspective\", "
                                               "\"orthographic\", \"spherical\" and "
                                               "\"realistic\" are)");
        orthographic = d.camera.type == "orthographic";
        if (d.camera.type == "realistic") lens = build_lens_system(d, s);
        if (d.camera.type == "spherical") {
            // pbrt-v4 SphericalCamera: "mapping" equalarea (default) or equirectangular; it
            // reads but does not use the lens and screen parameters.
            const std::string m = cp.get_string("mapping", "equalarea");
            if (m == "equalarea")
                spherical = SphericalMapping::EqualArea;
            else if (m == "equirectangular")
                spherical = SphericalMapping::Equirectangular;
            else
                throw SceneError(cp.find("mapping")->loc,
                                 "spherical camera: unknown \"mapping\" \"" + m +
                                     "\" (equalarea or equirectangular)");
            if (spherical == SphericalMapping::EqualArea && s.width != s.height)
                warn(d.camera.loc, "spherical camera: the equal-area mapping expects a square "
                                   "film; the image is stretched");
            for (const char *ig : {"fov", "lensradius", "focaldistance", "screenwindow",
                                   "frameaspectratio"})
                if (const Param *p = cp.find(ig)) p->used = true;
        }
        // pbrt-v4's RealisticCamera reads none of the projective cameras' parameters.
        const bool projective = !lens;
        if (!orthographic && projective) fov = cp.get_float("fov", 90.f);
        if (projective) lens_radius = cp.get_float("lensradius", 0.f);
        if (orthographic && lens_radius > 0)
            warn(d.camera.loc, "depth of field of the orthographic camera is not supported; "
                               "\"lensradius\" ignored");
        if (projective) focal_distance = cp.get_float("focaldistance", 1e6f);
        if (projective) sw = cp.get_floats("screenwindow");
        if (!sw.empty() && sw.size() != 4)
            throw SceneError(d.camera.loc, "\"screenwindow\" needs 4 values");
        float far = projective ? cp.get_float("frameaspectratio", 0.f) : 0.f;
        if (far > 0.f && sw.empty()) {
            if (far > 1.f)
                sw = {-far, far, -1.f, 1.f};
            else
                sw = {-1.f, 1.f, -1.f / far, 1.f / far};
        }
        // The exposure time scales the image (pbrt-v4 PixelSensor imagingRatio); motion blur
        // itself is not supported.
        float open = cp.get_float("shutteropen", 0.f), close = cp.get_float("shutterclose", 1.f);
        s.image_scale *= std::max(0.f, close - open);
        cp.report_unused("Camera");
    }
    auto camera = std::make_unique<PerspectiveCamera>(d.camera_from_world, s.width, s.height,
                                                      fov, lens_radius, focal_distance,
                                                      sw.empty() ? nullptr : sw.data(),
                                                      orthographic, spherical);
    if (lens) camera->set_lens_system(std::move(lens));
    return camera;
}

void apply_settings(const SceneDesc &d, const SceneOverrides &ov, Scene &sc) {
    RenderSettings &s = sc.settings;
    s.scene_file = d.main_file;
    apply_film(d, s);
    apply_sampler(d, s);
    apply_integrator(d, s);
    apply_overrides(d, ov, s);
    sc.filter = build_filter(d);
    sc.camera = build_camera(d, s);
}

/// A shape's vertex data as its file or parameters give it, before the checks and the transform.
struct RawMesh {
    std::vector<Vec3f> p, n;
    std::vector<Vec2f> uv;
    std::vector<int> idx;
};

/// "trianglemesh" and "loopsubdiv" (subdivided here: pbrt-v4's "levels" rounds of Loop
/// subdivision, vertices on the limit surface).
RawMesh read_triangle_mesh(const ShapeDesc &sd) {
    const ParamSet &ps = sd.params;
    RawMesh r;
    r.p = ps.get_point3s("P");
    r.idx = ps.get_ints("indices");
    r.n = ps.get_normals("N");
    r.uv = ps.get_point2s("uv");
    if (r.uv.empty()) r.uv = ps.get_point2s("st");
    if (r.idx.empty()) {
        if (r.p.size() == 3)
            r.idx = {0, 1, 2};
        else
            throw SceneError(sd.loc, "trianglemesh: \"indices\" missing");
    }
    for (const char *ig : {"S", "faceIndices"})
        if (const Param *x = ps.find(ig)) x->used = true;
    if (sd.type == "loopsubdiv") {
        // pbrt-v4: "levels" (default 3) rounds of Loop subdivision, vertices on the limit
        // surface; the result is a triangle mesh with normals.
        int levels = std::clamp(ps.get_int("levels", 3), 0, 8);
        // Each level quadruples the triangles: check the result's size first.
        check_mesh(uint64_t(r.p.size()) << (2 * levels),
                   uint64_t(r.idx.size() / 3) << (2 * levels),
                   "loopsubdiv with " + std::to_string(levels) + " levels", sd.loc);
        for (int i : r.idx)
            if (i < 0 || size_t(i) >= r.p.size())
                throw SceneError(sd.loc, "loopsubdiv: vertex index out of range");
        if (r.idx.size() % 3 != 0)
            throw SceneError(sd.loc, "loopsubdiv: the number of indices is not a multiple of 3");
        SubdividedMesh sub =
            loop_subdivide(r.p, std::vector<uint32_t>(r.idx.begin(), r.idx.end()), levels);
        r.p = std::move(sub.p);
        r.n = std::move(sub.n);
        r.uv.clear();
        r.idx.assign(sub.indices.begin(), sub.indices.end());
    }
    return r;
}

/// "plymesh": Tessera's PLY reader (input/ply_reader.h). Quads become two triangles each;
/// *face_of_triangle gets the face each triangle was cut from.
RawMesh read_plymesh(const ShapeDesc &sd, std::vector<uint32_t> *face_of_triangle) {
    const ParamSet &ps = sd.params;
    RawMesh r;
    std::string file = resolve(sd.base_dir, sd.loc, ps.get_string("filename", ""));
    MeshData md;
    try {
        md = load_ply(file);
    } catch (const SceneError &e) {
        // Name the Shape directive too: the reader only knows the mesh file.
        throw SceneError(sd.loc, std::string("plymesh: ") + e.what());
    }
    r.p = std::move(md.p);
    r.n = std::move(md.n);
    r.uv = std::move(md.uv);
    r.idx.assign(md.indices.begin(), md.indices.end());
    *face_of_triangle = std::move(md.face_of_triangle);
    if (ps.find("displacement")) {
        warn(sd.loc, "plymesh \"displacement\" is not supported; ignored");
        for (const char *ig : {"displacement", "edgelength"})
            if (const Param *x = ps.find(ig)) x->used = true;
    }
    return r;
}

/// "bilinearmesh": each patch as two triangles (exact for planar patches); without "uv" every
/// patch gets pbrt-v4's parametric corners, its vertices unshared.
RawMesh read_bilinear_mesh(const ShapeDesc &sd, std::vector<uint32_t> *face_of_triangle) {
    const ParamSet &ps = sd.params;
    RawMesh r;
    r.p = ps.get_point3s("P");
    std::vector<int> quads = ps.get_ints("indices");
    r.n = ps.get_normals("N");
    r.uv = ps.get_point2s("uv");
    if (quads.empty() && r.p.size() == 4) quads = {0, 1, 2, 3};
    if (quads.size() % 4 != 0)
        throw SceneError(sd.loc, "bilinearmesh: \"indices\" must hold 4 per patch");
    bool warned = false;
    for (size_t q = 0; q + 3 < quads.size(); q += 4) {
        int v00 = quads[q], v10 = quads[q + 1], v01 = quads[q + 2], v11 = quads[q + 3];
        for (int v : {v00, v10, v01, v11})
            if (v < 0 || size_t(v) >= r.p.size())
                throw SceneError(sd.loc, "bilinearmesh: index out of range");
        // Non-planar patches are approximated by two triangles.
        Vec3f nrm =
            cross(r.p[size_t(v10)] - r.p[size_t(v00)], r.p[size_t(v01)] - r.p[size_t(v00)]);
        float off = dot(normalize(nrm), r.p[size_t(v11)] - r.p[size_t(v00)]);
        float scale = length(r.p[size_t(v11)] - r.p[size_t(v00)]);
        if (!warned && std::abs(off) > 1e-4f * scale) {
            warn(sd.loc, "non-planar bilinear patches are approximated by two triangles");
            warned = true;
        }
        // Patch (v00, v10, v01, v11): triangles (v00, v10, v11) and (v00, v11, v01) keep the
        // orientation of dpdu x dpdv.
        r.idx.insert(r.idx.end(), {v00, v10, v11, v00, v11, v01});
        face_of_triangle->insert(face_of_triangle->end(), 2, uint32_t(q / 4));
    }
    if (r.uv.empty()) {
        // pbrt-v4 gives every patch its own parametric (0,0),(1,0),(0,1),(1,1): unshare the
        // vertices so that each patch's triangles carry those uvs.
        std::vector<Vec3f> p2, n2;
        std::vector<int> idx2;
        for (size_t q = 0; q + 3 < quads.size(); q += 4) {
            int base = int(p2.size());
            const Vec2f corner[4] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
            for (int c = 0; c < 4; ++c) {
                p2.push_back(r.p[size_t(quads[q + size_t(c)])]);
                if (!r.n.empty() && r.n.size() == r.p.size())
                    n2.push_back(r.n[size_t(quads[q + size_t(c)])]);
                r.uv.push_back(corner[c]);
            }
            idx2.insert(idx2.end(), {base, base + 1, base + 3, base, base + 3, base + 2});
        }
        r.p = std::move(p2);
        r.n = std::move(n2);
        r.idx = std::move(idx2);
    }
    return r;
}

/// The checked mesh in the target space: indices in range, normals and uvs kept only when
/// complete and finite, every vertex finite after the transform, orientation as pbrt-v4's.
TriangleMesh finish_mesh(const ShapeDesc &sd, const Transform &xf, RawMesh raw) {
    TriangleMesh m;
    std::vector<Vec3f> &p = raw.p, &n = raw.n;
    std::vector<Vec2f> &uv = raw.uv;
    std::vector<int> &idx = raw.idx;
    if (idx.size() % 3 != 0)
        throw SceneError(sd.loc, sd.type + ": the number of indices is not a multiple of 3");
    if (p.empty()) throw SceneError(sd.loc, sd.type + ": no vertex positions \"P\"");
    for (int i : idx)
        if (i < 0 || size_t(i) >= p.size())
            throw SceneError(sd.loc, sd.type + ": vertex index " + std::to_string(i) +
                                         " out of range (" + std::to_string(p.size()) +
                                         " vertices)");
    if (!n.empty() && n.size() != p.size()) {
        warn(sd.loc, "\"N\" has a different count than \"P\"; normals ignored");
        n.clear();
    }
    if (!uv.empty() && uv.size() != p.size()) {
        warn(sd.loc, "\"uv\" has a different count than \"P\"; uvs ignored");
        uv.clear();
    }
    check_mesh(p.size(), idx.size() / 3, sd.type, sd.loc);
    // Mesh files can hold NaN or Inf (the pbrt parser rejects them in text), and a finite
    // vertex can overflow under a huge transform: either would put NaN into the BVH and every
    // image sample that meets it.
    auto finite = [](Vec3f v) {
        return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
    };
    m.p.reserve(p.size() + 1);
    for (size_t i = 0; i < p.size(); ++i) {
        Vec3f w = xf.point(p[i]);
        if (!finite(w))
            throw SceneError(sd.loc, sd.type + ": vertex " + std::to_string(i) + " (" +
                                         std::to_string(p[i].x) + ", " + std::to_string(p[i].y) +
                                         ", " + std::to_string(p[i].z) + ")" +
                                         (finite(p[i]) ? " is not finite after its transform"
                                                       : " is not finite"));
        m.p.push_back(w);
    }
    if (!std::all_of(n.begin(), n.end(), finite)) {
        warn(sd.loc, sd.type + ": \"N\" has non-finite normals; normals ignored");
        n.clear();
    }
    if (!std::all_of(uv.begin(), uv.end(),
                     [](Vec2f t) { return std::isfinite(t.x) && std::isfinite(t.y); })) {
        warn(sd.loc, sd.type + ": \"uv\" has non-finite values; uvs ignored");
        uv.clear();
    }
    for (Vec3f v : n) {
        Vec3f w = xf.normal(v);
        float l = length(w);
        w = l > 0 ? w / l : w;
        // pbrt-v4's TriangleMesh/BilinearPatchMesh negate N under ReverseOrientation (N then
        // decides the geometric normal's side, and so the emitting side).
        m.n.push_back(sd.reverse_orientation ? -w : w);
    }
    m.uv = std::move(uv);
    m.indices.assign(idx.begin(), idx.end());
    m.flip_normal = sd.reverse_orientation != xf.swaps_handedness();
    return m;
}

/// A shape's triangles in the target space, or nullopt for quadrics/unsupported shapes.
/// *face_of_triangle gets the face (quad, patch) each triangle was cut from, or stays empty
/// when the faces are the triangles themselves.
std::optional<TriangleMesh> triangles_of(const ShapeDesc &sd, const Transform &xf,
                                         std::vector<uint32_t> *face_of_triangle) {
    if (sd.type == "trianglemesh" || sd.type == "loopsubdiv")
        return finish_mesh(sd, xf, read_triangle_mesh(sd));
    if (sd.type == "plymesh") return finish_mesh(sd, xf, read_plymesh(sd, face_of_triangle));
    if (sd.type == "bilinearmesh")
        return finish_mesh(sd, xf, read_bilinear_mesh(sd, face_of_triangle));
    return std::nullopt;
}

void warn_shape_params(const ShapeDesc &sd) {
    const ParamSet &ps = sd.params;
    if (const Param *e = ps.find("emissionfilename")) {
        e->used = true;
        warn(e->loc, "\"emissionfilename\" is not supported; ignored");
    }
}

struct Builder {
    const SceneDesc &d;
    Scene &sc;
    MaterialSet &mats;
    /// MakeNamedMedium names -> Scene::media indices (-1: left out, or media not rendered).
    std::map<std::string, int> medium_index;

    int medium_of(const std::string &name) const {
        if (name.empty()) return -1;
        auto it = medium_index.find(name);
        return it == medium_index.end() ? -1 : it->second;
    }

    int material_of(const ShapeDesc &sd) {
        if (sd.material.empty()) return mats.default_index();
        int i = mats.index(sd.material);
        if (i < 0) throw SceneError(sd.loc, "unknown material \"" + sd.material + "\"");
        return i;
    }

    void add_shape(int group, const ShapeDesc &sd, const Transform &xf, bool allow_lights) {
        warn_shape_params(sd);
        int material = material_of(sd);
        const int m_in = medium_of(sd.medium_inside), m_out = medium_of(sd.medium_outside);
        bool emissive = sd.area_light.has_value() && allow_lights;
        // pbrt-v4's volumetric path tracer (its default integrator) passes through a surface
        // without a material both along paths and with its shadow rays (VolPathIntegrator::
        // SampleLd traces shadow rays through them); without media such a surface changes
        // nothing, so it is not built (unless it bounds a medium). pbrt-v4's "path" integrator
        // continues paths through it but lets it block shadow rays (Integrator::Unoccluded);
        // so does Tessera's.
        if (!emissive && sc.settings.volpath && m_in == m_out &&
            mats.materials()[size_t(material)]->is_interface()) {
            for (const Param &p : sd.params.params) p.used = true;
            return;
        }
        if (emissive && sd.area_light_type != "diffuse" && !sd.area_light_type.empty())
            throw SceneError(sd.area_light_loc,
                             "AreaLightSource \"" + sd.area_light_type + "\" is not supported");
        std::vector<uint32_t> face_of_triangle;
        if (std::optional<TriangleMesh> m = triangles_of(sd, xf, &face_of_triangle)) {
            m->material = material;
            m->medium_inside = m_in;
            m->medium_outside = m_out;
            if (const Param *a = sd.params.find("alpha")) {
                if (a->type == "texture") {
                    m->alpha_texture = sc.textures->float_param(sd.params, "alpha", 1.f);
                } else {
                    m->alpha = clamp(sd.params.get_float("alpha", 1.f), 0.f, 1.f);
                }
                // Constant alpha 0 (below): invisible, its lights sample-only, as in pbrt-v4.
                if (emissive && (m->alpha_texture || (m->alpha < 1.f && m->alpha > 0.f)))
                    warn(a->loc, "\"alpha\" does not mask the emission of area lights");
            }
            // pbrt-v4 (DiffuseAreaLight): an emitter whose alpha is the constant 0 is never hit
            // by a ray, so it is reached by light sampling alone, with full weight.
            const bool invisible = !m->alpha_texture && m->alpha <= 0.f;
            if (emissive) {
                m->lights.assign(m->triangle_count(), nullptr);
                // "power" is per pbrt-v4 shape: per triangle, or per quad/patch where the
                // triangles were cut from one (pbrt-v4 makes one light per bilinear patch).
                std::vector<float> face_area;
                if (!face_of_triangle.empty()) {
                    for (size_t t = 0; t < m->triangle_count(); ++t) {
                        const size_t f = face_of_triangle[t];
                        if (face_area.size() <= f) face_area.resize(f + 1, 0.f);
                        face_area[f] += m->area(t);
                    }
                }
                for (size_t t = 0; t < m->triangle_count(); ++t) {
                    float area = m->area(t);
                    const float shape_area =
                        face_area.empty() ? area : face_area[face_of_triangle[t]];
                    AreaEmission em =
                        make_area_emission(*sd.area_light, sd.area_light_loc, shape_area);
                    if (em.L.is_black() || !(area > 0)) continue;
                    uint32_t i0 = m->indices[3 * t], i1 = m->indices[3 * t + 1],
                             i2 = m->indices[3 * t + 2];
                    auto light = std::make_unique<TriangleLight>(
                        m->p[i0], m->p[i1], m->p[i2], m->oriented_normal(t), em.L, em.twosided);
                    if (invisible) light->set_sample_only();
                    m->lights[t] = light.get();
                    sc.lights.push_back(std::move(light));
                    sc.features.emissive_shapes = true;
                }
                sd.area_light->report_unused("AreaLightSource");
            }
            sd.params.report_unused("Shape \"" + sd.type + "\"");
            // Nothing can hit an invisible mesh: it stays out of the BVH.
            if (!invisible) sc.geometry->add_mesh(group, std::move(*m));
            return;
        }
        if (sd.type == "sphere" || sd.type == "disk" || sd.type == "cylinder") {
            const ParamSet &ps = sd.params;
            // Constant alpha 0: the shape is invisible (pbrt-v4) -- not added to the geometry;
            // an emitter stays as a sample-only light. Other alpha values are not supported.
            const bool invisible = hidden_by_alpha(ps, "spheres, cylinders and disks");
            Quadric q;
            q.render_from_object = xf;
            q.material = material;
            q.medium_inside = m_in;
            q.medium_outside = m_out;
            q.flip_normal = sd.reverse_orientation != xf.swaps_handedness();
            if (sd.type == "sphere") {
                q.kind = Quadric::Kind::Sphere;
                q.radius = ps.get_float("radius", 1.f);
                q.zmin = clamp(ps.get_float("zmin", -q.radius), -q.radius, q.radius);
                q.zmax = clamp(ps.get_float("zmax", q.radius), -q.radius, q.radius);
                if (q.zmin > q.zmax) std::swap(q.zmin, q.zmax);
            } else if (sd.type == "cylinder") {
                // pbrt-v4 Cylinder: radius 1, zmin -1, zmax 1 (swapped when reversed).
                q.kind = Quadric::Kind::Cylinder;
                q.radius = ps.get_float("radius", 1.f);
                q.zmin = ps.get_float("zmin", -1.f);
                q.zmax = ps.get_float("zmax", 1.f);
                if (q.zmin > q.zmax) std::swap(q.zmin, q.zmax);
            } else {
                q.kind = Quadric::Kind::Disk;
                q.height = ps.get_float("height", 0.f);
                q.radius = ps.get_float("radius", 1.f);
                q.inner_radius = ps.get_float("innerradius", 0.f);
            }
            q.phi_max = radians(clamp(ps.get_float("phimax", 360.f), 0.f, 360.f));
            if (!(q.radius > 0)) throw SceneError(sd.loc, sd.type + ": radius must be positive");
            if (emissive) add_quadric_light(sd, q, invisible);
            ps.report_unused("Shape \"" + sd.type + "\"");
            if (invisible) return;
            sc.features.quadrics = true;
            sc.geometry->add_quadric(group, q);
            return;
        }
        if (sd.type == "curve") {
            add_curve(group, sd, xf, material, emissive);
            return;
        }
        // Every shape of pbrt-v4 is handled above; pbrt-v4 stops on any other (pbrt-v3's
        // "cone", "paraboloid", "hyperboloid", "heightfield", "nurbs" among them).
        throw SceneError(sd.loc, "unknown shape type \"" + sd.type + "\"");
    }

    /// Shapes without an alpha test: constant alpha 0 hides them (pbrt-v4); any other alpha
    /// than 0 or 1 warns that `shapes` render opaque.
    static bool hidden_by_alpha(const ParamSet &ps, const std::string &shapes) {
        const Param *a = ps.find("alpha");
        if (!a) return false;
        a->used = true;
        const bool constant = a->type == "float" && !a->numbers.empty();
        const bool invisible = constant && a->numbers[0] <= 0.0;
        if (!(constant && (a->numbers[0] >= 1.0 || invisible)))
            warn(a->loc, "\"alpha\" on " + shapes +
                             " is not supported except 0 and 1; rendered opaque");
        return invisible;
    }

    /// pbrt-v4 "curve" (CreateCurves): Bézier or uniform B-spline control points of degree 2
    /// or 3, each segment turned into a cubic Bézier; the width runs linearly from width0 to
    /// width1 over the segments.
    void add_curve(int group, const ShapeDesc &sd, const Transform &xf, int material,
                   bool emissive) {
        const ParamSet &ps = sd.params;
        const float width = ps.get_float("width", 1.f);
        const float width0 = ps.get_float("width0", width), width1 = ps.get_float("width1", width);
        if (!(width0 >= 0.f) || !(width1 >= 0.f) || !(std::max(width0, width1) > 0.f))
            throw SceneError(sd.loc, "curve: the widths must be non-negative and not both 0");
        const int degree = ps.get_int("degree", 3);
        if (degree != 2 && degree != 3)
            throw SceneError(sd.loc, "curve: invalid degree " + std::to_string(degree) +
                                         ": only degree 2 and 3 curves are supported");
        const std::string basis = ps.get_string("basis", "bezier");
        if (basis != "bezier" && basis != "bspline")
            throw SceneError(sd.loc, "curve: invalid basis \"" + basis +
                                         "\": only \"bezier\" and \"bspline\" are supported");
        const std::vector<Vec3f> cp = ps.get_point3s("P");
        const size_t ncp = cp.size(), deg = size_t(degree);
        size_t nseg = 0;
        if (basis == "bezier") {
            if (ncp < deg + 1 || (ncp - 1 - deg) % deg != 0)
                throw SceneError(sd.loc, "curve: " + std::to_string(ncp) +
                                             " control points; the degree " +
                                             std::to_string(degree) + " Bezier basis needs " +
                                             std::to_string(degree + 1) + " + n * " +
                                             std::to_string(degree));
            nseg = (ncp - 1) / deg;
        } else {
            if (ncp < deg + 1)
                throw SceneError(sd.loc, "curve: " + std::to_string(ncp) +
                                             " control points; the degree " +
                                             std::to_string(degree) +
                                             " b-spline basis needs at least " +
                                             std::to_string(degree + 1));
            nseg = ncp - deg;
        }
        CurveSet c;
        const std::string type = ps.get_string("type", "flat");
        if (type == "flat") {
            c.type = CurveSet::Type::Flat;
        } else if (type == "ribbon") {
            c.type = CurveSet::Type::Ribbon;
        } else if (type == "cylinder") {
            c.type = CurveSet::Type::Cylinder;
        } else {
            warn(sd.loc, "curve: unknown type \"" + type + "\"; using \"cylinder\"");
            c.type = CurveSet::Type::Cylinder;
        }
        std::vector<Vec3f> normals = ps.get_normals("N");
        if (!normals.empty() && c.type != CurveSet::Type::Ribbon) {
            warn(ps.find("N")->loc, "curve: normals \"N\" are only used by \"ribbon\" curves; "
                                    "ignored");
            normals.clear();
        } else if (c.type == CurveSet::Type::Ribbon && normals.size() != nseg + 1) {
            throw SceneError(sd.loc, "curve: a ribbon with " + std::to_string(nseg) +
                                         " segments needs " + std::to_string(nseg + 1) +
                                         " normals \"N\" (one per segment end), not " +
                                         std::to_string(normals.size()));
        }
        // pbrt-v4 splits each segment into 2^splitdepth pieces (tighter bounds: here too, a
        // long thin segment in one piece traced 4x slower), then refines each piece adaptively
        // while intersecting; Embree tessellates each piece at the rate set below.
        const int split_depth = std::clamp(ps.get_int("splitdepth", 3), 0, 10);
        // Constant alpha 0 hides the curve (pbrt-v4); other alpha values are not supported.
        const bool invisible = hidden_by_alpha(ps, "curves");
        if (emissive) {
            // pbrt-v4 cannot sample points on curves, so they cannot be area lights there.
            warn(sd.area_light_loc, "area lights on curves are not supported; the curve does "
                                    "not emit");
            for (const Param &p : sd.area_light->params) p.used = true;
        }
        // Widths are in object space: scaled by the transform's mean scale (exact for uniform
        // scales, where pbrt-v4's object-space intersection gives the same width).
        const float scale = float(std::cbrt(std::abs(xf.determinant3())));
        for (size_t seg = 0; seg < nseg; ++seg) {
            std::array<Vec3f, 4> b;
            if (basis == "bezier") {
                const Vec3f *q = &cp[seg * deg];
                if (degree == 2)
                    b = {q[0], lerp(2.f / 3.f, q[0], q[1]), lerp(1.f / 3.f, q[1], q[2]), q[2]};
                else
                    b = {q[0], q[1], q[2], q[3]};
            } else if (degree == 2) {
                const Vec3f *q = &cp[seg];
                Vec3f p11 = lerp(0.5f, q[0], q[1]), p22 = lerp(0.5f, q[1], q[2]);
                b = {p11, lerp(2.f / 3.f, p11, q[1]), lerp(1.f / 3.f, q[1], p22), p22};
            } else {
                const Vec3f *q = &cp[seg];
                Vec3f p122 = lerp(2.f / 3.f, q[0], q[1]), p223 = lerp(1.f / 3.f, q[1], q[2]);
                Vec3f p233 = lerp(2.f / 3.f, q[1], q[2]), p334 = lerp(1.f / 3.f, q[2], q[3]);
                b = {lerp(0.5f, p122, p223), p223, p233, lerp(0.5f, p233, p334)};
            }
            for (const Vec3f &p : b) c.cp.push_back(xf.point(p));
            const float t0 = float(seg) / float(nseg), t1 = float(seg + 1) / float(nseg);
            c.width.push_back(lerp(t0, width0, width1) * scale);
            c.width.push_back(lerp(t1, width0, width1) * scale);
            if (c.type == CurveSet::Type::Ribbon) {
                for (size_t k : {seg, seg + 1}) {
                    Vec3f nk = xf.normal(normals[k]);
                    if (!(length_squared(nk) > 0.f))
                        throw SceneError(ps.find("N")->loc, "curve: normal " +
                                                               std::to_string(k) + " is zero");
                    c.n.push_back(normalize(nk));
                }
            }
        }
        // pbrt-v4's refinement depth (Curve::IntersectRay): flat pieces within a twentieth of
        // the width of the curve, from the largest second difference of the control points;
        // 2^depth flat pieces per segment (at most 1024, as in pbrt), in the 2^splitdepth
        // Bézier pieces or more: Embree tessellates a piece into at most 16.
        int depth = 0;
        for (size_t seg = 0; seg < nseg; ++seg) {
            const Vec3f *q = &c.cp[4 * seg];
            float l0 = 0.f;
            for (int i = 0; i < 2; ++i)
                l0 = std::max(l0, max_component(abs(q[i] - q[i + 1] * 2.f + q[i + 2])));
            const float eps = std::max(c.width[2 * seg], c.width[2 * seg + 1]) * 0.05f;
            const float r = 1.41421356f * 6.f * l0 / (8.f * eps);
            // pbrt-v4's Log2Int rounds to the nearest power of two.
            if (r > 1.f && r < 1e30f)
                depth = std::max(depth, std::min(int(std::lround(std::log2(r))) / 2, 10));
            else if (!(r <= 1.f))
                depth = 10;  // overflow: the finest refinement
        }
        const int split = std::max(split_depth, depth - 4);
        c.splits = 1 << split;
        c.tessellation = 1 << std::clamp(depth - split, 0, 4);
        c.flip_normal = sd.reverse_orientation != xf.swaps_handedness();
        c.mirrored = xf.swaps_handedness();
        c.material = material;
        c.medium_inside = medium_of(sd.medium_inside);
        c.medium_outside = medium_of(sd.medium_outside);
        ps.report_unused("Shape \"curve\"");
        if (invisible) return;
        sc.features.curves = true;
        sc.geometry->add_curves(group, std::move(c));
    }

    /// `sample_only`: the shape is invisible (constant alpha 0); its light is sample-only.
    void add_quadric_light(const ShapeDesc &sd, Quadric &q, bool sample_only) {
        const Transform &xf = q.render_from_object;
        // Only similarity transforms keep quadrics round: check the scale factors.
        Vec3f ex = xf.vector({1, 0, 0}), ey = xf.vector({0, 1, 0}), ez = xf.vector({0, 0, 1});
        float sx = length(ex), sy = length(ey), sz = length(ez);
        bool uniform = std::abs(sx - sy) < 1e-4f * sx && std::abs(sx - sz) < 1e-4f * sx;
        if (!uniform) {
            warn(sd.area_light_loc, "area lights on non-uniformly scaled " + sd.type +
                                        "s are not supported; the shape does not emit");
            return;
        }
        bool full = q.kind != Quadric::Kind::Cylinder && q.phi_max >= 2 * kPi - 1e-6f &&
                    (q.kind == Quadric::Kind::Disk
                         ? q.inner_radius == 0.f
                         : (q.zmin <= -q.radius && q.zmax >= q.radius));
        float r = q.radius * sx;
        // pbrt-v4's Shape::Area() is object-space: "power" ignores the scale.
        const float dz = q.zmax - q.zmin;
        float area = q.kind == Quadric::Kind::Disk
                         ? 0.5f * q.phi_max * (q.radius * q.radius - q.inner_radius * q.inner_radius)
                         : q.phi_max * q.radius * dz;  // sphere (Archimedes) and cylinder
        AreaEmission em = make_area_emission(*sd.area_light, sd.area_light_loc, area);
        sd.area_light->report_unused("AreaLightSource");
        if (em.L.is_black()) return;
        std::unique_ptr<Light> light;
        if (!full) {
            // Cylinders, partial spheres, annuli and disk sectors: uniform area sampling.
            QuadricAreaLight::Shape shape;
            shape.kind = q.kind == Quadric::Kind::Sphere     ? QuadricAreaLight::Kind::Sphere
                         : q.kind == Quadric::Kind::Cylinder ? QuadricAreaLight::Kind::Cylinder
                                                             : QuadricAreaLight::Kind::Disk;
            shape.radius = q.radius;
            shape.zmin = q.zmin;
            shape.zmax = q.zmax;
            shape.phi_max = q.phi_max;
            shape.inner_radius = q.inner_radius;
            shape.height = q.height;
            shape.flip_normal = q.flip_normal;
            light = std::make_unique<QuadricAreaLight>(shape, xf, em.L, em.twosided);
        } else if (q.kind == Quadric::Kind::Sphere) {
            light = std::make_unique<SphereLight>(xf.point({0, 0, 0}), r, em.L, q.flip_normal,
                                                  em.twosided);
        } else {
            Vec3f n = normalize(xf.normal({0, 0, 1}));
            if (q.flip_normal) n = -n;
            light = std::make_unique<DiskLight>(xf.point({0, 0, q.height}), n, r, em.L,
                                                em.twosided);
        }
        if (sample_only) light->set_sample_only();
        q.light = light.get();
        sc.lights.push_back(std::move(light));
        sc.features.emissive_shapes = true;
    }
};

}  // namespace

/// The scene's media (pbrt-v4 BasicScene::CreateMedia) and the camera's. pbrt-v4's "path"
/// integrator ignores media (its PathIntegrator has no volume code): the scene renders as if
/// they were vacuum, with pbrt-v4's warning; volpath renders them.
void build_media(const SceneDesc &d, std::map<std::string, int> &index, Scene &sc) {
    if (d.media.empty()) return;
    if (!sc.settings.volpath) {
        for (const auto &[name, md] : d.media)
            for (const Param &p : md.params.params) p.used = true;
        warn(d.integrator.loc, "the scene has participating media but Integrator \"path\" does "
                               "not render them (as in pbrt-v4); use \"volpath\"");
        return;
    }
    for (const auto &[name, md] : d.media) {
        std::unique_ptr<Medium> m = make_medium(md);
        if (!m) continue;
        index[name] = int(sc.media.size());
        sc.media.push_back(std::move(m));
    }
    sc.features.media = !sc.media.empty();
    if (!d.camera_medium.empty()) {
        auto it = index.find(d.camera_medium);
        sc.camera_medium = it == index.end() ? -1 : it->second;
    }
}

std::unique_ptr<Scene> build_scene(const SceneDesc &d, const SceneOverrides &ov) {
    auto sc = std::make_unique<Scene>();
    apply_settings(d, ov, *sc);

    sc->textures = std::make_unique<TextureSet>(d.textures);
    sc->features.textures = !d.textures.empty();
    sc->features.image_textures = sc->textures->has_image_maps();
    MaterialSet mats(d.materials, *sc->textures);

    sc->geometry = std::make_unique<Geometry>();
    sc->geometry->set_filter_every_mesh(ov.no_specialize & kSpecAlpha);
    Builder b{d, *sc, mats, {}};
    build_media(d, b.medium_index, *sc);
    for (const ShapeDesc &sd : d.shapes)
        b.add_shape(sc->geometry->top_level(), sd, sd.render_from_object, true);

    // Object instancing: one Embree prototype scene per used object.
    std::map<std::string, int> protos;
    for (const InstanceDesc &inst : d.instances) {
        auto it = d.objects.find(inst.object);
        if (it == d.objects.end())
            throw SceneError(inst.loc, "unknown object \"" + inst.object + "\"");
        auto pit = protos.find(inst.object);
        if (pit == protos.end()) {
            int g = sc->geometry->new_prototype(inst.object);
            for (const ShapeDesc &sd : it->second.shapes)
                b.add_shape(g, sd, sd.render_from_object, false);
            pit = protos.emplace(inst.object, g).first;
        }
        sc->geometry->add_instance(pit->second, inst.render_from_instance);
        sc->features.instances = true;
    }
    sc->geometry->commit();

    for (const LightDesc &ld : d.lights) {
        std::unique_ptr<Light> l = make_light(ld);
        if (!l) continue;
        LightType t = l->type();
        if (t == LightType::Infinite) {
            sc->features.environment = true;
            if (dynamic_cast<const ImageInfiniteLight *>(l.get()))
                sc->features.environment_map = true;
            sc->infinite_lights.push_back(l.get());
        } else {
            sc->features.delta_lights = true;
        }
        sc->lights.push_back(std::move(l));
    }
    Vec3f bmin = sc->geometry->bounds_min(), bmax = sc->geometry->bounds_max();
    Vec3f center = (bmin + bmax) * 0.5f;
    float radius = std::max(length(bmax - center), 1e-3f);
    for (auto &l : sc->lights) l->preprocess(center, radius);
    if (!sc->lights.empty()) {
        std::vector<const Light *> ptrs;
        for (auto &l : sc->lights) ptrs.push_back(l.get());
        sc->light_sampler = std::make_unique<PowerLightSampler>(ptrs);
    } else {
        warn(FileLoc{d.main_file, 0}, "the scene has no lights: the image will be black");
    }

    sc->materials = mats.release();
    for (const auto &m : sc->materials) {
        uint8_t f = m->possible_flags();
        if (f & kBxdfSpecular) sc->features.specular = true;
        if (f & kBxdfTransmission) sc->features.transmission = true;
    }
    return sc;
}

std::unique_ptr<Scene> load_scene(const std::string &path, const SceneOverrides &ov) {
    std::error_code ec;
    fs::file_status st = fs::status(path, ec);
    if (!fs::is_regular_file(st))
        throw SceneError(path + ":0: cannot open the scene file: " +
                         (!fs::exists(st)            ? "not found"
                          : fs::is_directory(st)     ? "is a directory, not a file"
                                                     : "is not a regular file"));
    // "x.ply.gz" is a PLY mesh and "x.pbrt.gz" a scene file, both gzip-compressed.
    std::string ext = fs::path(strip_gz_extension(path)).extension().string();
    for (char &c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    SceneDesc desc;
    if (ext == ".obj" && has_gz_extension(path)) {
        throw SceneError(path + ":0: gzip-compressed OBJ files are not supported; decompress it "
                                "(gunzip) first");
    } else if (ext == ".obj") {
#ifdef TESSERA_HAVE_OBJ
        desc = load_obj_scene(path);
#endif
    } else if (ext == ".ply") {
        desc = load_ply_scene(path);
    } else {
        desc = parse_pbrt_file(path);
    }
    return build_scene(desc, ov);
}

}  // namespace tessera
