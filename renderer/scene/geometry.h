// Scene geometry on Embree 3: triangle meshes, quadrics (spheres, disks) as user geometry, and
// object instances as Embree instances of prototype scenes.
//
// Tessera's render space is world space. Triangle meshes are stored in render space (or in a
// prototype's space for instanced objects); quadrics keep their object transform and intersect in
// object space in double precision. Hit points carry an error bound for robust ray spawning
// (interaction.h). Embree runs in robust mode (RTC_SCENE_FLAG_ROBUST).
#pragma once

#include <embree3/rtcore.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "renderer/util/interaction.h"
#include "renderer/util/transform.h"

namespace tessera {

class FloatTexture;

/// Triangle mesh in the space of the group it is added to.
struct TriangleMesh {
    std::vector<Vec3f> p;
    std::vector<Vec3f> n;    ///< per-vertex shading normals (optional)
    std::vector<Vec2f> uv;   ///< per-vertex uv (optional; pbrt default (0,0),(1,0),(1,1))
    std::vector<uint32_t> indices;
    bool flip_normal = false;  ///< ReverseOrientation xor handedness swap
    int material = -1;
    int medium_inside = -1, medium_outside = -1;  ///< Scene::media indices (SurfaceInteraction)
    /// Area lights per triangle (nullptr entries when not emissive); empty for non-emissive meshes.
    std::vector<const Light *> lights;
    /// pbrt's "alpha" cut-out: a texture (evaluated at the hit's uv) or a constant in [0, 1).
    /// Hits where alpha is 0 are ignored; 0 < alpha < 1 keeps a hit with probability alpha,
    /// decided by a hash of the ray (pbrt-v4 GeometricPrimitive::Intersect). Null and 1: opaque.
    const FloatTexture *alpha_texture = nullptr;
    float alpha = 1.f;
    size_t triangle_count() const { return indices.size() / 3; }
    /// Unit geometric normal of triangle `tri` on its emitting side (pbrt-v4 Triangle::Sample).
    Vec3f oriented_normal(size_t tri) const;
    float area(size_t tri) const;
};

/// pbrt "sphere" (radius, zmin, zmax, phimax), "cylinder" (radius, zmin, zmax, phimax: around
/// the z axis, open at both ends) or "disk" (height, radius, innerradius, phimax).
struct Quadric {
    enum class Kind { Sphere, Disk, Cylinder } kind = Kind::Sphere;
    Transform render_from_object;  ///< relative to the group's space
    float radius = 1, zmin = -1, zmax = 1, phi_max = 2 * kPi;  // sphere, cylinder
    float height = 0, inner_radius = 0;                          // disk
    bool flip_normal = false;
    int material = -1;
    int medium_inside = -1, medium_outside = -1;  ///< Scene::media indices (SurfaceInteraction)
    const Light *light = nullptr;
};

/// pbrt "curve" shapes as cubic Bézier segments (the scene builder converts pbrt-v4's B-spline
/// and quadratic bases as pbrt-v4 does), in the space of the group they are added to. Embree
/// intersects "flat" and "cylinder" curves as ribbons that face the ray (pbrt-v4 intersects both
/// that way; "cylinder" only bends the normal across the width) and "ribbon" curves as true
/// ribbons oriented by the normals pbrt gives at the segment ends (pbrt-v4 narrows a ray-facing
/// strip by |n.d| instead; the two differ for rays at an angle to the tangent).
struct CurveSet {
    enum class Type { Flat, Cylinder, Ribbon };
    Type type = Type::Cylinder;
    std::vector<Vec3f> cp;     ///< 4 control points per segment
    std::vector<float> width;  ///< full width at each segment's start and end (2 per segment)
    std::vector<Vec3f> n;      ///< ribbons: unit normal at each segment's start and end
    bool flip_normal = false;  ///< ReverseOrientation xor handedness swap
    bool mirrored = false;     ///< the transform into the group's space swaps handedness
    int material = -1;
    int medium_inside = -1, medium_outside = -1;  ///< Scene::media indices (SurfaceInteraction)
    /// Each segment goes to Embree as `splits` Bézier pieces of equal parameter range, each
    /// tessellated into `tessellation` flat pieces (Embree allows at most 16).
    int splits = 1;
    int tessellation = 8;
    size_t segment_count() const { return cp.size() / 4; }
};

/// One Embree scene: the top level, or an instanced object's prototype.
class GeometryGroup;

/// A shape of the top level (not instanced) with its object id (see Geometry::object_material).
/// Exactly one of `mesh` and `quadric` is set (curves are not listed: they cannot emit).
struct TopLevelShape {
    int32_t object_id = -1;
    const TriangleMesh *mesh = nullptr;
    const Quadric *quadric = nullptr;
};

/// All geometry of a scene. Build with the add_* calls, then `commit()`; afterwards
/// `intersect`, `intersect8` and `occluded` are thread-safe.
///
/// Object ids: `commit()` numbers the shapes densely in the order of the top level's Embree
/// geometry ids: a top-level mesh, sphere or disk gets one id; an instance of a prototype with
/// k shapes gets k consecutive ids (prototype shape j -> base + j), so two instances of one
/// prototype differ. The ids are stable for a given scene file.
class Geometry {
  public:
    Geometry();
    ~Geometry();
    Geometry(const Geometry &) = delete;
    Geometry &operator=(const Geometry &) = delete;

    /// Group 0 is the top level; `new_prototype` makes an object for instancing.
    int new_prototype(const std::string &name);
    int top_level() const { return 0; }

    void add_mesh(int group, TriangleMesh mesh);
    void add_quadric(int group, const Quadric &q);
    /// Adds curve segments (Embree flat or normal-oriented Bézier curves).
    void add_curves(int group, CurveSet curves);
    /// Adds an instance of prototype `proto` at the top level.
    void add_instance(int proto, const Transform &render_from_instance);
    /// Builds the BVHs. Call once after adding everything.
    void commit();

    /// Closest hit along the ray within (0, ray.t_max), or nothing.
    std::optional<SurfaceInteraction> intersect(const Ray &ray) const;
    /// The closest hits of `count` rays, traced as Embree ray packets: groups of 8 in order
    /// (rtcIntersect8 with a valid mask), a last group of at most 4 with rtcIntersect4 and a
    /// single ray with rtcIntersect1. out[i] is exactly what intersect(rays[i]) returns (the
    /// same hit record code; the tests check bit equality). Thread-safe.
    void intersect8(const Ray *rays, int count, std::optional<SurfaceInteraction> *out) const;
    /// True if anything blocks the segment (0, ray.t_max).
    bool occluded(const Ray &ray) const;

    /// Number of object ids (valid after commit): ids are 0 .. object_count() - 1.
    int32_t object_count() const { return object_count_; }
    /// Scene::materials index of an object's shape (-1: none or an invalid id). O(log n).
    int object_material(int32_t object_id) const;
    /// The top level's meshes, spheres and disks with their object ids (after commit).
    std::vector<TopLevelShape> top_level_shapes() const;

    /// World-space bounds of everything (valid after commit).
    Vec3f bounds_min() const { return bmin_; }
    Vec3f bounds_max() const { return bmax_; }
    size_t triangle_count() const { return triangle_count_; }
    size_t instance_count() const { return instance_count_; }
    /// Meshes added without an alpha test (all levels).
    size_t opaque_mesh_count() const { return opaque_mesh_count_; }
    /// The general path of the "alpha" specialisation (renderer/scene/specialize.h): every mesh gets
    /// the alpha filter callbacks, which accept every hit of an opaque mesh. Call before add_*.
    void set_filter_every_mesh(bool on) { filter_every_mesh_ = on; }
    /// The top-level Embree scene (benchmarks compare against raw Embree calls on it).
    RTCScene rtc_scene() const;
    /// The top level's meshes indexed by Embree geomID, when the top level holds opaque
    /// triangle meshes and nothing else (no instances, quadrics, curves or alpha tests: the
    /// path tracer's packet kernel reads hits straight from Embree); empty otherwise.
    std::vector<const TriangleMesh *> meshes_by_geom_id() const;
    /// Meshes of the top level (for building area lights).
    const std::vector<std::unique_ptr<TriangleMesh>> &top_level_meshes() const;

  private:
    /// Fills `si` from an Embree hit of `ray` (the ray in render space; t, ids and barycentrics
    /// as Embree returns them). Shared by intersect and intersect8.
    void fill_hit(const Ray &ray, float t, unsigned geom_id, unsigned prim_id, unsigned inst_id,
                  float u, float v, SurfaceInteraction &si) const;

    RTCDevice device_ = nullptr;
    std::vector<std::unique_ptr<GeometryGroup>> groups_;
    struct InstanceRec {
        int proto;
        Transform render_from_instance;
    };
    std::vector<InstanceRec> instances_;  // indexed by the instance's geomID in the top level
    std::vector<int> instance_geom_to_rec_;
    /// First object id of each top-level Embree geometry (by geomID; ascending).
    std::vector<int32_t> object_base_;
    int32_t object_count_ = 0;
    Vec3f bmin_, bmax_;
    size_t triangle_count_ = 0, instance_count_ = 0, opaque_mesh_count_ = 0;
    bool filter_every_mesh_ = false;
};

}  // namespace tessera
