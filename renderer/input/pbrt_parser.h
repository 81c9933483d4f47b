// Reader for pbrt-v4 scene files (https://pbrt.org/fileformat-v4) into the plain-data SceneDesc.
//
// The parser only records what the file says; it loads no meshes or images and creates nothing.
// pbrt-v4's behaviour (src/pbrt/parser.cpp, scene.cpp) is the reference for the semantics; where
// Tessera differs it says so below and with a warning carrying file:line.
//
// Conventions of the SceneDesc it fills (render space == world space in Tessera):
//  - Transforms: renderer/util/transform.h matrices are row-major with column vectors (p' = M p).
//    `Transform [16 numbers]` and `ConcatTransform` list the matrix column by column, as in
//    pbrt, so the parser transposes them. Translate/Scale/Rotate/LookAt/ConcatTransform
//    post-multiply the current transformation matrix (CTM = CTM * T), as in pbrt.
//  - camera_from_world: the CTM at the `Camera` directive (world -> camera; camera space looks
//    down +z, +y up). Its inverse is world_from_camera (the eye is at
//    camera_from_world.inverse().point({0,0,0})). `Camera` also defines the named coordinate
//    system "camera" as that inverse, so `CoordSysTransform "camera"` makes the CTM
//    world_from_camera. `WorldBegin` resets the CTM to identity and defines "world".
//  - Shapes: ShapeDesc::render_from_object is the CTM at the `Shape` directive. Shapes inside
//    `ObjectBegin`/`ObjectEnd` go to SceneDesc::objects[name].shapes (not to SceneDesc::shapes),
//    with render_from_object = the CTM at the shape inside the block (i.e. object space of the
//    instance definition). `ObjectInstance` records InstanceDesc::render_from_instance = the CTM
//    at the ObjectInstance directive. The world transform of an instanced shape is therefore
//    render_from_instance * shape.render_from_object (pbrt-v4: renderFromInstance *
//    renderFromObject). Area lights inside object definitions are dropped with a warning, as in
//    pbrt-v4.
//  - Area lights: inside an `AreaLightSource "diffuse" params` scope, every shape gets
//    area_light = params, area_light_type = "diffuse", area_light_loc = its file:line.
//  - Materials: `Material "type" params` creates an anonymous MaterialDesc with a generated name
//    "anonymous#N" (N counts from 1 per parse) and makes it current; `MakeNamedMaterial "name"`
//    takes its type from `"string type"` (that parameter is consumed); `NamedMaterial` makes a
//    name current. ShapeDesc::material is the current name, "" for pbrt's default (diffuse,
//    reflectance 0.5). Undefined material and object names are errors at the end of the parse.
//  - Attribute "shape"|"light"|"material"|"texture"|"medium" params: default parameters that
//    are appended to each later entity of that kind (in the current attribute scope) unless the
//    entity gives the same parameter name itself.
//  - Relative file names: as in pbrt-v4 (ResolveFilename with one search directory), every
//    entity's base_dir is the directory of the MAIN scene file, whichever file declared it.
//    Include/Import and spectrum files look relative to the main file's directory first, then
//    relative to the including file's directory (a fallback for scenes that assume it; the
//    scene builder does the same for plymesh files). Import == Include here. Gzip-compressed
//    includes are reported as unsupported.
//  - Parameter types are canonicalised: "point" -> "point3", "vector" -> "vector3",
//    "normal3" -> "normal", "color" -> "rgb" (with a warning). A `"spectrum"` parameter naming a
//    file is read at parse time and stored as (lambda, value) numbers; a named spectrum stays a
//    string. Bools are stored in Param::bools.
//  - Media: `MakeNamedMedium "name"` makes a MediumDesc (its "string type" consumed, the CTM
//    as render_from_medium; a name made twice is an error); `MediumInterface "in" ["out"]` sets
//    the graphics state's pair (one name: both sides), which every later shape copies and whose
//    outside medium the Camera directive takes. Undefined medium names are errors at the end.
//  - Unsupported features are accepted with a warning: motion blur (TransformTimes; after
//    `ActiveTransform EndTime` transform directives are ignored, only the StartTime transform
//    is kept), ColorSpace other than "srgb", Option, TransformBegin/TransformEnd (deprecated,
//    but they work), WorldEnd (v3).
//
// Errors: a SceneError whose what() is exactly "file:line: message", the line being that of the
// offending token. Warnings go through warn() (scene_desc.h).
//
// Thread-safety: the functions are reentrant; concurrent parses share only the warning log.
#pragma once

#include <string>

#include "renderer/input/scene_desc.h"

namespace tessera {

/// Parses the pbrt-v4 scene file at `path` (and the files it includes). Throws SceneError.
SceneDesc parse_pbrt_file(const std::string &path);

/// Parses scene text held in memory. `filename_for_messages` names it in FileLoc and errors;
/// `base_dir` is the directory relative paths (Include, spectrum files, entity base_dir) resolve
/// against ("" = the current directory). Throws SceneError.
SceneDesc parse_pbrt_string(const std::string &text, const std::string &filename_for_messages,
                            const std::string &base_dir);

}  // namespace tessera
