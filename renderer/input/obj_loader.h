// Wavefront OBJ scenes (with their .mtl materials) as a SceneDesc, read with tinyobjloader.
//
// An OBJ file has geometry and materials only, so load_obj_scene also supplies what a pbrt-v4
// file would add: a camera, a film, and lights when no material emits. The result goes through
// the same scene builder as a parsed pbrt-v4 file.
#pragma once

#include <string>

#include "renderer/input/default_view.h"
#include "renderer/input/scene_desc.h"

namespace tessera {

/// Reads `path` (.obj) and the .mtl files it names (searched next to the .obj) into a SceneDesc.
///
/// Geometry: tinyobjloader (2.0) resolves negative (relative) indices and triangulates: a quad
/// v0 v1 v2 v3 is split along its shorter diagonal, (v0 v1 v2) (v0 v2 v3) when |v2 - v0| <
/// |v3 - v1| and (v0 v1 v3) (v1 v2 v3) otherwise, keeping the winding; larger polygons are
/// triangulated by tinyobjloader too. pbrt-v4 has no OBJ reader, so there is no spec to match.
/// Every OBJ shape (`o`/`g`) becomes one ShapeDesc of type "trianglemesh" per material used inside
/// it, with "point3 P", "integer indices", and "normal N" / "point2 uv" when every corner of
/// the group has them; corners sharing the same (v, vt, vn) triple share a vertex. Positions
/// are not transformed (render_from_object is the identity).
///
/// Materials (.mtl -> MaterialDesc named as in the .mtl):
///  - illum 5 (reflection, no refraction) -> "conductor" perfect mirror:
///    "rgb reflectance" = Ks (or [1 1 1] when Ks is black), roughness 0 (pbrt default);
///  - illum 4, 6, 7 or 9 (refraction) -> "dielectric" with "float eta" = Ni (1.5 when Ni is
///    absent or 1), roughness 0;
///  - otherwise, Ks non-black -> "coateddiffuse" with "rgb reflectance" = Kd and
///    "float roughness" = sqrt(2 / (Ns + 2)) given as a microfacet alpha
///    ("bool remaproughness" false): the Beckmann alpha whose lobe matches a Phong lobe of
///    exponent Ns (Walter et al., "Microfacet Models for Refraction through Rough Surfaces",
///    EGSR 2007, section 5.2). The coat's strength comes from its Fresnel term (eta 1.5), so
///    the magnitude of Ks is not used;
///  - otherwise -> "diffuse" with "rgb reflectance" = Kd.
///  map_Kd adds a spectrum "imagemap" TextureDesc named "<material>:map_Kd" (its -s/-o options
///  become uscale/vscale/udelta/vdelta) that replaces the reflectance. d, Tr, Tf, map_Bump and
///  the other maps are ignored.
///  Ke non-black -> every shape using the material gets area_light "diffuse" with "rgb L" = Ke
///  and "bool twosided" false (emitting on the side of (p1 - p0) x (p2 - p0)).
///
/// Camera: "perspective" with "float fov" kObjCameraFovDeg, looking at the bounding-box centre
/// along -z from the +z side, y up, at the distance where the fov exactly frames the bounding
/// sphere. OBJ is right-handed and pbrt left-handed, so camera_from_world is
/// Scale(-1, 1, 1) * LookAt(...): the image shows the model as right-handed viewers do (+x to
/// the right), without changing the geometry. Film: "rgb", kObjFilmResolution squared.
///
/// Lights: only when no material has Ke: an "infinite" light with uniform "rgb L" [0.5 0.5 0.5]
/// and a "distant" key light "rgb L" [1.5 1.5 1.5] from the upper right front, direction
/// (1, 2, 2) (normalised) toward the origin.
///
/// Throws SceneError("path:0: message") when the file cannot be read or parsed or has no faces;
/// tinyobjloader's warnings (e.g. a missing .mtl) go through warn(). Thread-safe.
SceneDesc load_obj_scene(const std::string &path);

}  // namespace tessera
