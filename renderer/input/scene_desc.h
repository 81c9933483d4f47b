// The parsed form of a scene file: plain data, no Embree, no textures loaded.
//
// The pbrt-v4 parser (pbrt_parser.h) and the OBJ loader (obj_loader.h) produce a SceneDesc;
// scene_builder.h turns it into a renderable Scene. Every entity keeps the file:line it came
// from and its parameter list, so the builder can report unused or unsupported parameters.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "renderer/util/error.h"
#include "renderer/util/transform.h"
#include "sampling/vecmath.h"

namespace tessera {

/// One typed parameter: `"float fov" [ 45 ]`. Types are pbrt-v4's: integer, float, point2,
/// vector2, point3, vector3, normal, rgb, blackbody, spectrum, bool, string, texture. The parser
/// canonicalises the aliases point -> point3, vector -> vector3, normal3 -> normal, color -> rgb.
struct Param {
    std::string type, name;
    /// integer/float/point/vector/normal/rgb/blackbody values; spectrum (lambda, value) pairs
    /// (also those read from a spectrum file).
    std::vector<double> numbers;
    std::vector<std::string> strings;   ///< string/texture values, a named spectrum
    std::vector<uint8_t> bools;         ///< bool values (1 = true)
    FileLoc loc;
    mutable bool used = false;

    /// A numeric parameter made by a loader (OBJ, defaults) rather than read from a file.
    static Param numeric(const std::string &type, const std::string &name,
                         std::vector<double> numbers, const FileLoc &loc) {
        Param p;
        p.type = type;
        p.name = name;
        p.numbers = std::move(numbers);
        p.loc = loc;
        return p;
    }
};

/// A parameter list with typed lookups. Every lookup marks the parameter used, so that
/// `report_unused` can warn about what was ignored. Lookups throw SceneError on a type mismatch
/// or a wrong number of values.
class ParamSet {
  public:
    std::vector<Param> params;

    const Param *find(const std::string &name) const;
    float get_float(const std::string &name, float def) const;
    int get_int(const std::string &name, int def) const;
    bool get_bool(const std::string &name, bool def) const;
    std::string get_string(const std::string &name, const std::string &def) const;
    Vec3f get_point3(const std::string &name, Vec3f def) const;
    Vec3f get_vector3(const std::string &name, Vec3f def) const;
    Vec3f get_normal(const std::string &name, Vec3f def) const;
    std::vector<float> get_floats(const std::string &name) const;
    std::vector<int> get_ints(const std::string &name) const;
    std::vector<Vec2f> get_point2s(const std::string &name) const;
    std::vector<Vec3f> get_point3s(const std::string &name) const;
    std::vector<Vec3f> get_vector3s(const std::string &name) const;
    std::vector<Vec3f> get_normals(const std::string &name) const;
    std::vector<std::string> get_strings(const std::string &name) const;
    /// Name of a texture parameter (`"texture reflectance" "mytex"`), empty if absent or if
    /// the parameter of that name is not texture-typed (then it is left unused for get_rgb or
    /// get_float).
    std::string get_texture(const std::string &name) const;
    /// A spectrum-valued parameter given as rgb, blackbody (K), spectrum (named, or
    /// lambda/value pairs), or a single float. Converted to linear sRGB; approximations are
    /// reported once with warn(). `illuminant`: true for emission (blackbody normalised as
    /// pbrt does), false for reflectances (clamped to [0,1] where `unbounded` is false).
    /// std::nullopt if absent or texture-typed. Conversions (spectra.h): illuminant spectra
    /// have luminance 1 (pbrt-v4 lights divide by the photometric value), reflectance spectra
    /// are lit by D65, unbounded non-illuminant spectra (eta, k) are R/G/B band averages;
    /// named glasses give their IOR at 550 nm as a grey triple. Not thread-safe (marks used).
    std::optional<Rgb> get_rgb(const std::string &name, bool illuminant,
                               bool unbounded = true) const;
    /// Warns (file:line) about every parameter that no lookup used.
    void report_unused(const std::string &what) const;
};

/// The pbrt graphics state captured when a shape is declared.
struct ShapeDesc {
    std::string type;          ///< "trianglemesh", "plymesh", "sphere", "disk", "bilinearmesh", ...
    ParamSet params;
    FileLoc loc;
    Transform render_from_object;
    bool reverse_orientation = false;
    std::string material;      ///< name in SceneDesc::materials ("" = the default diffuse)
    /// `MediumInterface "inside" "outside"` current at the shape (names in SceneDesc::media;
    /// "" = vacuum). pbrt-v4: a shape whose two media differ is a medium transition; one whose
    /// media are equal leaves a ray in the medium it is in.
    std::string medium_inside, medium_outside;
    std::optional<ParamSet> area_light;  ///< AreaLightSource "diffuse" params when emissive
    FileLoc area_light_loc;
    std::string area_light_type;
    /// Directory relative file names resolve against: the main scene file's (pbrt-v4); the
    /// declaring file's directory (loc.file) is the builder's fallback.
    std::string base_dir;
};

/// A material, named or anonymous. Anonymous materials get a generated unique name.
struct MaterialDesc {
    std::string name, type;
    ParamSet params;
    FileLoc loc;
    std::string base_dir;
};

/// A texture: `Texture "name" "spectrum"|"float" "class" params`.
struct TextureDesc {
    std::string name, value_type, tex_class;
    ParamSet params;
    FileLoc loc;
    Transform render_from_texture;
    std::string base_dir;
};

/// A light from `LightSource`.
struct LightDesc {
    std::string type;
    ParamSet params;
    FileLoc loc;
    Transform render_from_light;
    std::string base_dir;
};

/// `MakeNamedMedium "name" "string type" ...`: a participating medium, with the CTM at its
/// declaration (render from medium space: grids and their bounds live in medium space).
struct MediumDesc {
    std::string name, type;
    ParamSet params;
    FileLoc loc;
    Transform render_from_medium;
    std::string base_dir;
};

/// `ObjectBegin "name"` ... `ObjectEnd`: shapes in the object's own space.
struct ObjectDesc {
    std::string name;
    std::vector<ShapeDesc> shapes;
    FileLoc loc;
};

/// `ObjectInstance "name"` with the transform current at that point.
struct InstanceDesc {
    std::string object;
    Transform render_from_instance;
    FileLoc loc;
};

/// A scene-wide directive before WorldBegin (Camera, Film, Sampler, Integrator, PixelFilter).
struct OptionDesc {
    std::string type;
    ParamSet params;
    FileLoc loc;
    bool present = false;
};

/// Everything a scene file says. Render space == world space in Tessera.
struct SceneDesc {
    OptionDesc camera, film, sampler, integrator, filter, accelerator;
    Transform camera_from_world;  ///< the CTM at the Camera directive (world -> camera)
    std::vector<ShapeDesc> shapes;
    std::map<std::string, MaterialDesc> materials;
    std::vector<TextureDesc> textures;  ///< in declaration order (textures may reference earlier ones)
    std::vector<LightDesc> lights;
    std::map<std::string, ObjectDesc> objects;
    std::map<std::string, MediumDesc> media;
    /// The outside medium of the MediumInterface current at Camera (pbrt-v4 CameraSceneEntity::
    /// medium): the medium camera rays start in ("" = vacuum).
    std::string camera_medium;
    FileLoc camera_medium_loc;
    std::vector<InstanceDesc> instances;
    std::string main_file;
    /// Files the parser read besides the main file (Include/Import files and spectrum files),
    /// as opened, in reading order; with repeats. Scene content hashes use it (reference.h).
    std::vector<std::string> read_files;
};

}  // namespace tessera
