// A default camera and lights for scene files that have none (OBJ, bare PLY meshes).
#pragma once

#include "renderer/input/scene_desc.h"

namespace tessera {

/// Field of view (degrees, shorter image axis) of the default camera
/// (add_default_view: OBJ scenes and bare PLY meshes).
inline constexpr float kObjCameraFovDeg = 40.f;
/// Film resolution (pixels, both axes) of the default film.
inline constexpr int kObjFilmResolution = 512;

/// Camera-from-world for a camera in front of the box [bmin, bmax] (on its +z side, looking
/// toward -z, +y up) whose field of view `fov_deg` exactly frames the box's bounding sphere.
/// World +x appears on the right of the image, as a viewer of a right-handed (OBJ) model
/// expects: Scale(-1, 1, 1) * LookAt(...).
Transform default_camera_from_world(Vec3f bmin, Vec3f bmax, float fov_deg);

/// Fills desc.camera ("perspective", fov kObjCameraFovDeg) and desc.film (kObjFilmResolution
/// squared, filename "<scene stem>.exr") when absent, and, when `has_emitters` is false and the
/// scene has no lights, adds an "infinite" light with uniform L 0.5 and a "distant" key light
/// L 1.5 from direction (1, 2, 2) toward the origin. Thread-safe (pure).
void add_default_view(SceneDesc &desc, Vec3f bmin, Vec3f bmax, bool has_emitters);

/// A SceneDesc holding one "plymesh" shape for the file at `path` (diffuse 0.5), with the
/// default view. Throws SceneError when the mesh cannot be read.
SceneDesc load_ply_scene(const std::string &path);

}  // namespace tessera
