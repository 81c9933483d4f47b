#include "renderer/scene/geometry.h"

#include "renderer/shading/texture.h"

#include <embree3/rtcore_ray.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <stdexcept>

namespace tessera {

namespace {

void embree_error(void *, RTCError code, const char *str) {
    std::fprintf(stderr, "embree error %d: %s\n", int(code), str ? str : "");
}

struct Vec3d {
    double x, y, z;
};
Vec3d to_object(const Mat4 &m, Vec3d p, bool point) {
    double w = point ? 1.0 : 0.0;
    return {m.m[0][0] * p.x + m.m[0][1] * p.y + m.m[0][2] * p.z + m.m[0][3] * w,
            m.m[1][0] * p.x + m.m[1][1] * p.y + m.m[1][2] * p.z + m.m[1][3] * w,
            m.m[2][0] * p.x + m.m[2][1] * p.y + m.m[2][2] * p.z + m.m[2][3] * w};
}

/// Intersects a quadric in its object space; returns the smallest valid t in (t_min, t_max).
bool intersect_quadric(const Quadric &q, Vec3d o_world, Vec3d d_world, double t_min,
                       double t_max, double *t_hit) {
    const Mat4 &inv = q.render_from_object.inverse_matrix();
    Vec3d o = to_object(inv, o_world, true);
    Vec3d d = to_object(inv, d_world, false);
    if (q.kind == Quadric::Kind::Sphere || q.kind == Quadric::Kind::Cylinder) {
        // x^2 + y^2 + k z^2 = r^2: the sphere (k = 1) or the cylinder (k = 0).
        const bool sphere = q.kind == Quadric::Kind::Sphere;
        const double k = sphere ? 1.0 : 0.0;
        double r = q.radius;
        double a = d.x * d.x + d.y * d.y + k * d.z * d.z;
        if (a == 0) return false;  // a cylinder's axis direction
        double b = 2 * (d.x * o.x + d.y * o.y + k * d.z * o.z);
        double c = o.x * o.x + o.y * o.y + k * o.z * o.z - r * r;
        // Numerically stable discriminant (pbrt-v4 6.2.2): b^2 - 4ac = 4a (r^2 - |o - (b/2a) d|^2 ...)
        double f = b / (2 * a);
        Vec3d vp{o.x - f * d.x, o.y - f * d.y, k * (o.z - f * d.z)};
        double len2 = vp.x * vp.x + vp.y * vp.y + vp.z * vp.z;
        double disc = 4 * a * (r * r - len2);
        if (disc < 0) return false;
        double root = std::sqrt(disc);
        double qq = b < 0 ? -0.5 * (b - root) : -0.5 * (b + root);
        double t0 = qq / a, t1 = c / qq;
        if (t0 > t1) std::swap(t0, t1);
        // Clipping: a partial sphere by z and phi; a cylinder always by z, by phi if partial.
        const bool partial_sphere = sphere && (q.zmin > -r || q.zmax < r || q.phi_max < 2 * kPi);
        const bool clip_z = !sphere || partial_sphere;
        const bool clip_phi = partial_sphere || (!sphere && q.phi_max < 2 * kPi);
        for (double t : {t0, t1}) {
            if (!(t > t_min && t < t_max)) continue;
            double px = o.x + t * d.x, py = o.y + t * d.y, pz = o.z + t * d.z;
            if (clip_z && (pz < q.zmin || pz > q.zmax)) continue;
            if (clip_phi) {
                double phi = std::atan2(py, px);
                if (phi < 0) phi += 2 * M_PI;
                if (phi > q.phi_max) continue;
            }
            *t_hit = t;
            return true;
        }
        return false;
    }
    // Disk at z = height.
    if (d.z == 0) return false;
    double t = (q.height - o.z) / d.z;
    if (!(t > t_min && t < t_max)) return false;
    double px = o.x + t * d.x, py = o.y + t * d.y;
    double r2 = px * px + py * py;
    if (r2 > double(q.radius) * q.radius || r2 < double(q.inner_radius) * q.inner_radius)
        return false;
    if (q.phi_max < 2 * kPi) {
        double phi = std::atan2(py, px);
        if (phi < 0) phi += 2 * M_PI;
        if (phi > q.phi_max) return false;
    }
    *t_hit = t;
    return true;
}

}  // namespace

/// One Embree scene plus the records of its geometries, indexed by Embree geomID.
class GeometryGroup {
  public:
    struct Record {
        enum class Kind { Mesh, Quadric, Instance, Curves } kind;
        int index;  // into meshes / quadrics / Geometry::instances_ / curves
    };
    std::string name;
    RTCScene scene = nullptr;
    std::vector<std::unique_ptr<TriangleMesh>> meshes;
    std::vector<std::unique_ptr<Quadric>> quadrics;
    std::vector<std::unique_ptr<CurveSet>> curves;
    std::vector<Record> records;  // by geomID
    bool committed = false;

    /// Commits `geom`, attaches it to this group's scene (which takes the reference) and
    /// records what it is under its geomID.
    void attach(RTCGeometry geom, Record::Kind kind, int index) {
        rtcCommitGeometry(geom);
        unsigned id = rtcAttachGeometry(scene, geom);
        rtcReleaseGeometry(geom);
        if (records.size() <= id) records.resize(id + 1);
        records[id] = {kind, index};
    }
};

Vec3f TriangleMesh::oriented_normal(size_t tri) const {
    uint32_t i0 = indices[3 * tri], i1 = indices[3 * tri + 1], i2 = indices[3 * tri + 2];
    Vec3f ng = cross(p[i1] - p[i0], p[i2] - p[i0]);
    float len = length(ng);
    if (!(len > 0)) return {0, 0, 1};
    ng = ng / len;
    if (!n.empty()) {
        Vec3f ns = n[i0] + n[i1] + n[i2];
        ng = face_forward(ng, ns);
    } else if (flip_normal) {
        ng = -ng;
    }
    return ng;
}

float TriangleMesh::area(size_t tri) const {
    uint32_t i0 = indices[3 * tri], i1 = indices[3 * tri + 1], i2 = indices[3 * tri + 2];
    return 0.5f * length(cross(p[i1] - p[i0], p[i2] - p[i0]));
}

Geometry::Geometry() {
    device_ = rtcNewDevice(nullptr);
    if (!device_) throw std::runtime_error("cannot create the Embree device");
    rtcSetDeviceErrorFunction(device_, embree_error, nullptr);
    auto top = std::make_unique<GeometryGroup>();
    top->name = "(top level)";
    top->scene = rtcNewScene(device_);
    groups_.push_back(std::move(top));
}

Geometry::~Geometry() {
    for (auto &g : groups_)
        if (g->scene) rtcReleaseScene(g->scene);
    if (device_) rtcReleaseDevice(device_);
}

int Geometry::new_prototype(const std::string &name) {
    auto g = std::make_unique<GeometryGroup>();
    g->name = name;
    g->scene = rtcNewScene(device_);
    groups_.push_back(std::move(g));
    return int(groups_.size()) - 1;
}

RTCScene Geometry::rtc_scene() const { return groups_[0]->scene; }

std::vector<const TriangleMesh *> Geometry::meshes_by_geom_id() const {
    const GeometryGroup &g = *groups_[0];
    std::vector<const TriangleMesh *> out;
    if (instance_count_ > 0)
        return out;
    for (const auto &rec : g.records) {
        if (rec.kind != GeometryGroup::Record::Kind::Mesh)
            return {};
        const TriangleMesh *m = g.meshes[size_t(rec.index)].get();
        if (m->alpha_texture || m->alpha < 1.f)
            return {};
        out.push_back(m);
    }
    return out;
}

const std::vector<std::unique_ptr<TriangleMesh>> &Geometry::top_level_meshes() const {
    return groups_[0]->meshes;
}

namespace {

/// pbrt-v4's HashFloat(ray.o, ray.d): a uniform value in [0, 1) from the ray's bits.
float hash_ray(float ox, float oy, float oz, float dx, float dy, float dz) {
    float v[6] = {ox, oy, oz, dx, dy, dz};
    uint32_t w[6];
    std::memcpy(w, v, sizeof(w));
    uint64_t h = 0xcbf29ce484222325ull;
    for (uint32_t x : w) h = (h ^ x) * 0x100000001b3ull;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    return float(h >> 40) * 0x1p-24f;
}

/// The alpha test of one candidate hit: false rejects it.
bool alpha_accepts(const TriangleMesh &m, unsigned prim, float b1, float b2, Vec3f o, Vec3f d,
                   float t) {
    float a = m.alpha;
    if (m.alpha_texture) {
        uint32_t i0 = m.indices[3 * prim], i1 = m.indices[3 * prim + 1],
                 i2 = m.indices[3 * prim + 2];
        float b0 = 1.f - b1 - b2;
        TextureEvalContext tc;
        tc.p = o + d * t;
        if (!m.uv.empty())
            tc.uv = m.uv[i0] * b0 + m.uv[i1] * b1 + m.uv[i2] * b2;
        else
            tc.uv = Vec2f(0, 0) * b0 + Vec2f(1, 0) * b1 + Vec2f(1, 1) * b2;
        a = m.alpha_texture->evaluate(tc);
    }
    if (a >= 1.f) return true;
    if (a <= 0.f) return false;
    return hash_ray(o.x, o.y, o.z, d.x, d.y, d.z) <= a;
}

/// Embree filter for both closest-hit and occlusion queries of alpha-tested meshes.
void alpha_filter(const RTCFilterFunctionNArguments *args) {
    const TriangleMesh &m = *static_cast<const TriangleMesh *>(args->geometryUserPtr);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        Vec3f o{RTCRayN_org_x(args->ray, args->N, i), RTCRayN_org_y(args->ray, args->N, i),
                RTCRayN_org_z(args->ray, args->N, i)};
        Vec3f d{RTCRayN_dir_x(args->ray, args->N, i), RTCRayN_dir_y(args->ray, args->N, i),
                RTCRayN_dir_z(args->ray, args->N, i)};
        float t = RTCRayN_tfar(args->ray, args->N, i);
        unsigned prim = RTCHitN_primID(args->hit, args->N, i);
        float u = RTCHitN_u(args->hit, args->N, i), v = RTCHitN_v(args->hit, args->N, i);
        if (!alpha_accepts(m, prim, u, v, o, d, t)) args->valid[i] = 0;
    }
}

}  // namespace

void Geometry::add_mesh(int group, TriangleMesh mesh) {
    GeometryGroup &g = *groups_.at(size_t(group));
    if (mesh.indices.empty()) return;
    auto m = std::make_unique<TriangleMesh>(std::move(mesh));
    RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Shared buffers: Embree reads our arrays directly (vertex buffer padded for SSE loads).
    m->p.reserve(m->p.size() + 1);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m->p.data(), 0,
                               sizeof(Vec3f), m->p.size());
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                               m->indices.data(), 0, 3 * sizeof(uint32_t),
                               m->triangle_count());
    const bool alpha = m->alpha_texture || m->alpha < 1.f;
    if (!alpha) ++opaque_mesh_count_;
    if (alpha || filter_every_mesh_) {
        // Only cut-out meshes pay for filter callbacks (unless the general path is forced).
        rtcSetGeometryUserData(geom, m.get());
        rtcSetGeometryIntersectFilterFunction(geom, alpha_filter);
        rtcSetGeometryOccludedFilterFunction(geom, alpha_filter);
    }
    g.attach(geom, GeometryGroup::Record::Kind::Mesh, int(g.meshes.size()));
    if (group == 0) triangle_count_ += m->triangle_count();
    g.meshes.push_back(std::move(m));
}

namespace {

void quadric_bounds(const RTCBoundsFunctionArguments *args) {
    const Quadric &q = *static_cast<const Quadric *>(args->geometryUserPtr);
    Vec3f lo, hi;
    if (q.kind == Quadric::Kind::Sphere || q.kind == Quadric::Kind::Cylinder) {
        lo = {-q.radius, -q.radius, q.zmin};
        hi = {q.radius, q.radius, q.zmax};
    } else {
        lo = {-q.radius, -q.radius, q.height};
        hi = {q.radius, q.radius, q.height};
    }
    Vec3f bmin(kInfinity, kInfinity, kInfinity), bmax = -bmin;
    for (int c = 0; c < 8; ++c) {
        Vec3f corner{(c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z};
        Vec3f w = q.render_from_object.point(corner);
        bmin = vmin(bmin, w);
        bmax = vmax(bmax, w);
    }
    // Pad by a relative epsilon: the transform is applied in float.
    Vec3f pad = (abs(bmin) + abs(bmax)) * 1e-6f + Vec3f(1e-30f, 1e-30f, 1e-30f);
    args->bounds_o->lower_x = bmin.x - pad.x;
    args->bounds_o->lower_y = bmin.y - pad.y;
    args->bounds_o->lower_z = bmin.z - pad.z;
    args->bounds_o->upper_x = bmax.x + pad.x;
    args->bounds_o->upper_y = bmax.y + pad.y;
    args->bounds_o->upper_z = bmax.z + pad.z;
}

void quadric_intersect(const RTCIntersectFunctionNArguments *args) {
    const Quadric &q = *static_cast<const Quadric *>(args->geometryUserPtr);
    RTCRayN *ray = RTCRayHitN_RayN(args->rayhit, args->N);
    RTCHitN *hit = RTCRayHitN_HitN(args->rayhit, args->N);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        Vec3d o{RTCRayN_org_x(ray, args->N, i), RTCRayN_org_y(ray, args->N, i),
                RTCRayN_org_z(ray, args->N, i)};
        Vec3d d{RTCRayN_dir_x(ray, args->N, i), RTCRayN_dir_y(ray, args->N, i),
                RTCRayN_dir_z(ray, args->N, i)};
        double t;
        if (!intersect_quadric(q, o, d, RTCRayN_tnear(ray, args->N, i),
                               RTCRayN_tfar(ray, args->N, i), &t))
            continue;
        RTCRayN_tfar(ray, args->N, i) = float(t);
        RTCHitN_Ng_x(hit, args->N, i) = 0;
        RTCHitN_Ng_y(hit, args->N, i) = 0;
        RTCHitN_Ng_z(hit, args->N, i) = 1;
        RTCHitN_u(hit, args->N, i) = 0;
        RTCHitN_v(hit, args->N, i) = 0;
        RTCHitN_primID(hit, args->N, i) = args->primID;
        RTCHitN_geomID(hit, args->N, i) = args->geomID;
        RTCHitN_instID(hit, args->N, i, 0) = args->context->instID[0];
    }
}

void quadric_occluded(const RTCOccludedFunctionNArguments *args) {
    const Quadric &q = *static_cast<const Quadric *>(args->geometryUserPtr);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        Vec3d o{RTCRayN_org_x(args->ray, args->N, i), RTCRayN_org_y(args->ray, args->N, i),
                RTCRayN_org_z(args->ray, args->N, i)};
        Vec3d d{RTCRayN_dir_x(args->ray, args->N, i), RTCRayN_dir_y(args->ray, args->N, i),
                RTCRayN_dir_z(args->ray, args->N, i)};
        double t;
        if (intersect_quadric(q, o, d, RTCRayN_tnear(args->ray, args->N, i),
                              RTCRayN_tfar(args->ray, args->N, i), &t))
            RTCRayN_tfar(args->ray, args->N, i) = -kInfinity;
    }
}

}  // namespace

void Geometry::add_quadric(int group, const Quadric &quad) {
    GeometryGroup &g = *groups_.at(size_t(group));
    auto q = std::make_unique<Quadric>(quad);
    RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(geom, 1);
    rtcSetGeometryUserData(geom, q.get());
    rtcSetGeometryBoundsFunction(geom, quadric_bounds, nullptr);
    rtcSetGeometryIntersectFunction(geom, quadric_intersect);
    rtcSetGeometryOccludedFunction(geom, quadric_occluded);
    g.attach(geom, GeometryGroup::Record::Kind::Quadric, int(g.quadrics.size()));
    g.quadrics.push_back(std::move(q));
}

namespace {

/// Spherical interpolation of unit vectors (pbrt-v4 Slerp). Opposite vectors, where pbrt-v4
/// divides by zero, turn about `axis` (the curve's tangent).
Vec3f slerp(float t, Vec3f a, Vec3f b, Vec3f axis) {
    float c = clamp(dot(a, b), -1.f, 1.f);
    float theta = std::acos(c), s = std::sin(theta);
    if (s > 1e-4f)
        return a * (std::sin((1 - t) * theta) / s) + b * (std::sin(t * theta) / s);
    if (c > 0.f) return normalize(lerp(t, a, b));
    Vec3f perp = cross(axis, a);
    perp = length_squared(perp) > 0.f ? normalize(perp) : Frame::from_z(a).x;
    return a * std::cos(t * kPi) + perp * std::sin(t * kPi);
}

}  // namespace

/// The control points of the cubic Bézier `p` restricted to [u0, u1] (blossoms).
std::array<Vec3f, 4> bezier_piece(const Vec3f *p, float u0, float u1) {
    auto blossom = [&](float a, float b, float c) {
        Vec3f q0 = lerp(a, p[0], p[1]), q1 = lerp(a, p[1], p[2]), q2 = lerp(a, p[2], p[3]);
        return lerp(c, lerp(b, q0, q1), lerp(b, q1, q2));
    };
    if (u0 == 0.f && u1 == 1.f) return {p[0], p[1], p[2], p[3]};
    return {blossom(u0, u0, u0), blossom(u0, u0, u1), blossom(u0, u1, u1), blossom(u1, u1, u1)};
}

void Geometry::add_curves(int group, CurveSet curves) {
    GeometryGroup &g = *groups_.at(size_t(group));
    const size_t nseg = curves.segment_count();
    if (nseg == 0) return;
    auto c = std::make_unique<CurveSet>(std::move(curves));
    c->splits = std::max(1, c->splits);
    const size_t splits = size_t(c->splits), nprim = nseg * splits;
    const bool ribbon = c->type == CurveSet::Type::Ribbon;
    RTCGeometry geom =
        rtcNewGeometry(device_, ribbon ? RTC_GEOMETRY_TYPE_NORMAL_ORIENTED_BEZIER_CURVE
                                       : RTC_GEOMETRY_TYPE_FLAT_BEZIER_CURVE);
    // Control points with Embree's radius, half of pbrt's width. Linear in u along a segment:
    // a Bézier curve whose control values are equally spaced is linear in its parameter.
    auto *v = static_cast<float *>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 4 * nprim));
    auto *idx = static_cast<uint32_t *>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(uint32_t), nprim));
    float *nrm = nullptr;
    if (ribbon)
        nrm = static_cast<float *>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4 * nprim));
    for (size_t prim = 0; prim < nprim; ++prim) {
        const size_t s = prim / splits;
        const float u0 = float(prim % splits) / float(splits);
        const float u1 = float(prim % splits + 1) / float(splits);
        const std::array<Vec3f, 4> piece = bezier_piece(&c->cp[4 * s], u0, u1);
        idx[prim] = uint32_t(4 * prim);
        const float w0 = c->width[2 * s], w1 = c->width[2 * s + 1];
        for (int k = 0; k < 4; ++k) {
            // The width is linear in the segment's parameter, so in the piece's too.
            const float u = u0 + (u1 - u0) * float(k) / 3.f;
            float *dst = v + 4 * (4 * prim + size_t(k));
            dst[0] = piece[size_t(k)].x;
            dst[1] = piece[size_t(k)].y;
            dst[2] = piece[size_t(k)].z;
            dst[3] = 0.5f * (w0 + (w1 - w0) * u);
            if (nrm) {
                Vec3f nk = slerp(u, c->n[2 * s], c->n[2 * s + 1], c->cp[4 * s + 3] - c->cp[4 * s]);
                float *dn = nrm + 3 * (4 * prim + size_t(k));
                dn[0] = nk.x;
                dn[1] = nk.y;
                dn[2] = nk.z;
            }
        }
    }
    rtcSetGeometryTessellationRate(geom, float(clamp(c->tessellation, 1, 16)));
    g.attach(geom, GeometryGroup::Record::Kind::Curves, int(g.curves.size()));
    g.curves.push_back(std::move(c));
}

void Geometry::add_instance(int proto, const Transform &render_from_instance) {
    GeometryGroup &p = *groups_.at(size_t(proto));
    if (!p.committed) {
        rtcSetSceneFlags(p.scene, RTC_SCENE_FLAG_ROBUST);
        rtcCommitScene(p.scene);
        p.committed = true;
    }
    RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(geom, p.scene);
    float xfm[12];  // 3x4 column major
    const Mat4 &m = render_from_instance.matrix();
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 3; ++r) xfm[c * 3 + r] = float(m.m[r][c]);
    rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
    GeometryGroup &top = *groups_[0];
    top.attach(geom, GeometryGroup::Record::Kind::Instance, int(instances_.size()));
    instances_.push_back({proto, render_from_instance});
    ++instance_count_;
}

void Geometry::commit() {
    GeometryGroup &top = *groups_[0];
    rtcSetSceneFlags(top.scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(top.scene, RTC_BUILD_QUALITY_HIGH);
    rtcCommitScene(top.scene);
    top.committed = true;
    RTCBounds b;
    rtcGetSceneBounds(top.scene, &b);
    bmin_ = {b.lower_x, b.lower_y, b.lower_z};
    bmax_ = {b.upper_x, b.upper_y, b.upper_z};
    if (!(bmin_.x <= bmax_.x)) bmin_ = bmax_ = {0, 0, 0};
    // Object ids in top-level geomID order; an instance reserves one id per prototype shape.
    object_base_.assign(top.records.size(), 0);
    int64_t next = 0;
    for (size_t id = 0; id < top.records.size(); ++id) {
        object_base_[id] = int32_t(next);
        const auto &rec = top.records[id];
        if (rec.kind == GeometryGroup::Record::Kind::Instance)
            next += int64_t(groups_[size_t(instances_[size_t(rec.index)].proto)]->records.size());
        else
            ++next;
    }
    // NOTE: beyond 2^31 - 1 shapes the ids would wrap; no scene comes near that.
    object_count_ = int32_t(std::min<int64_t>(next, INT32_MAX));
}

int Geometry::object_material(int32_t object_id) const {
    if (object_id < 0 || object_id >= object_count_ || object_base_.empty()) return -1;
    // The last top-level geometry whose first id is <= object_id.
    auto it = std::upper_bound(object_base_.begin(), object_base_.end(), object_id);
    size_t geom = size_t(it - object_base_.begin()) - 1;
    const GeometryGroup *g = groups_[0].get();
    GeometryGroup::Record rec = g->records[geom];
    if (rec.kind == GeometryGroup::Record::Kind::Instance) {
        g = groups_[size_t(instances_[size_t(rec.index)].proto)].get();
        size_t local = size_t(object_id - object_base_[geom]);
        if (local >= g->records.size()) return -1;
        rec = g->records[local];
    }
    if (rec.kind == GeometryGroup::Record::Kind::Mesh)
        return g->meshes[size_t(rec.index)]->material;
    if (rec.kind == GeometryGroup::Record::Kind::Quadric)
        return g->quadrics[size_t(rec.index)]->material;
    if (rec.kind == GeometryGroup::Record::Kind::Curves)
        return g->curves[size_t(rec.index)]->material;
    return -1;  // nested instances are not built
}

std::vector<TopLevelShape> Geometry::top_level_shapes() const {
    std::vector<TopLevelShape> out;
    const GeometryGroup &top = *groups_[0];
    for (size_t id = 0; id < top.records.size() && id < object_base_.size(); ++id) {
        const auto &rec = top.records[id];
        TopLevelShape s;
        s.object_id = object_base_[id];
        if (rec.kind == GeometryGroup::Record::Kind::Mesh)
            s.mesh = top.meshes[size_t(rec.index)].get();
        else if (rec.kind == GeometryGroup::Record::Kind::Quadric)
            s.quadric = top.quadrics[size_t(rec.index)].get();
        else
            continue;
        out.push_back(s);
    }
    return out;
}

namespace {

/// Error bound of a transformed point (pbrt-v4 Transform::operator()(Point3fi)).
Vec3f transform_error(const Mat4 &m, Vec3f p, Vec3f err) {
    Vec3f out;
    for (int r = 0; r < 3; ++r) {
        double e = 0, a = 0;
        for (int c = 0; c < 3; ++c) {
            e += std::abs(m.m[r][c]) * err[c];
            a += std::abs(m.m[r][c] * p[c]);
        }
        a += std::abs(m.m[r][3]);
        out[r] = float((gamma_n(3) + 1) * e + gamma_n(3) * a);
    }
    return out;
}

void fill_triangle(const TriangleMesh &m, unsigned prim, float b1, float b2,
                   SurfaceInteraction &si) {
    uint32_t i0 = m.indices[3 * prim], i1 = m.indices[3 * prim + 1], i2 = m.indices[3 * prim + 2];
    Vec3f p0 = m.p[i0], p1 = m.p[i1], p2 = m.p[i2];
    float b0 = 1.f - b1 - b2;
    si.p = p0 * b0 + p1 * b1 + p2 * b2;
    si.p_error = (abs(p0 * b0) + abs(p1 * b1) + abs(p2 * b2)) * gamma_n(7);
    // pbrt's per-axis bound is zero on axis-aligned planes through 0 (a floor at y = 0). pbrt's
    // own watertight test rejects t below its error bound; Embree's does not, so the bound
    // gets a floor relative to the triangle's largest coordinate (still scale-invariant).
    float mag = max_component(vmax(abs(p0), vmax(abs(p1), abs(p2))));
    si.p_error = vmax(si.p_error, Vec3f(mag, mag, mag) * gamma_n(7));
    Vec2f uv0{0, 0}, uv1{1, 0}, uv2{1, 1};
    if (!m.uv.empty()) {
        uv0 = m.uv[i0];
        uv1 = m.uv[i1];
        uv2 = m.uv[i2];
    }
    si.uv = uv0 * b0 + uv1 * b1 + uv2 * b2;
    // dpdu from the uv parameterisation (pbrt-v4 Triangle::InteractionFromIntersection).
    Vec2f duv02 = uv0 - uv2, duv12 = uv1 - uv2;
    Vec3f dp02 = p0 - p2, dp12 = p1 - p2;
    float det = duv02.x * duv12.y - duv02.y * duv12.x;
    Vec3f ng = cross(dp02, dp12);
    float ng_len = length(ng);
    ng = ng_len > 0 ? ng / ng_len : Vec3f(0, 0, 1);
    bool degenerate_uv = std::abs(det) < 1e-9f;
    Vec3f dpdu, dpdv;
    if (!degenerate_uv) {
        float inv = 1.f / det;
        dpdu = (dp02 * duv12.y - dp12 * duv02.y) * inv;
        dpdv = (dp12 * duv02.x - dp02 * duv12.x) * inv;
    }
    // cross(dpdu, dpdv) = cross(dp02, dp12) / det, so it vanishes exactly when the geometric
    // normal does: test ng_len instead of a second cross product.
    if (degenerate_uv || !(ng_len > 0) || !std::isfinite(dpdu.x) || !std::isfinite(dpdv.x)) {
        Frame f = Frame::from_z(ng);
        dpdu = f.x;
        dpdv = f.y;
    }
    si.dpdu = dpdu;
    si.dpdv = dpdv;
    if (m.flip_normal) ng = -ng;
    si.n = ng;
    si.ns = ng;
    if (!m.n.empty()) {
        Vec3f ns = m.n[i0] * b0 + m.n[i1] * b1 + m.n[i2] * b2;
        float l2 = length_squared(ns);
        if (l2 > 0.f && std::isfinite(l2)) {
            ns = ns / std::sqrt(l2);
            // The shading normal is authoritative for orientation (pbrt-v4 SetShadingGeometry).
            si.n = face_forward(si.n, ns);
            si.ns = ns;
        }
    }
    si.material = m.material;
    si.medium_inside = m.medium_inside;
    si.medium_outside = m.medium_outside;
    if (!m.lights.empty()) si.area_light = m.lights[prim];
}

void fill_quadric(const Quadric &q, Vec3f p_world, SurfaceInteraction &si) {
    const Mat4 &inv = q.render_from_object.inverse_matrix();
    Vec3d pw{p_world.x, p_world.y, p_world.z};
    Vec3d po = to_object(inv, pw, true);
    Vec3f p_obj, n_obj, dpdu_obj, dpdv_obj, err_obj;
    Vec2f uv;
    if (q.kind == Quadric::Kind::Sphere) {
        // Reproject onto the surface to reduce error (pbrt-v4 6.8.5).
        double len = std::sqrt(po.x * po.x + po.y * po.y + po.z * po.z);
        double s = len > 0 ? q.radius / len : 1.0;
        po = {po.x * s, po.y * s, po.z * s};
        if (po.x == 0 && po.y == 0) po.x = 1e-5 * q.radius;
        p_obj = {float(po.x), float(po.y), float(po.z)};
        err_obj = abs(p_obj) * gamma_n(5);
        double phi = std::atan2(po.y, po.x);
        if (phi < 0) phi += 2 * M_PI;
        double cos_theta = std::clamp(po.z / q.radius, -1.0, 1.0);
        double theta = std::acos(cos_theta);
        double theta_zmin = std::acos(std::clamp(double(q.zmin) / q.radius, -1.0, 1.0));
        double theta_zmax = std::acos(std::clamp(double(q.zmax) / q.radius, -1.0, 1.0));
        uv = {float(phi / q.phi_max), float((theta - theta_zmin) / (theta_zmax - theta_zmin))};
        n_obj = normalize(p_obj);
        dpdu_obj = {float(-q.phi_max * po.y), float(q.phi_max * po.x), 0.f};
        double zr = std::sqrt(po.x * po.x + po.y * po.y);
        double cphi = zr > 0 ? po.x / zr : 1, sphi = zr > 0 ? po.y / zr : 0;
        double dtheta = theta_zmax - theta_zmin;
        dpdv_obj = {float(dtheta * po.z * cphi), float(dtheta * po.z * sphi),
                    float(-dtheta * q.radius * std::sin(theta))};
    } else if (q.kind == Quadric::Kind::Cylinder) {
        // Reproject onto the surface (pbrt-v4 Cylinder::BasicIntersect) and bound the error.
        double hit_rad = std::sqrt(po.x * po.x + po.y * po.y);
        if (hit_rad > 0) {
            po.x *= q.radius / hit_rad;
            po.y *= q.radius / hit_rad;
        } else {
            po.x = q.radius;
        }
        po.z = std::clamp(po.z, double(q.zmin), double(q.zmax));
        p_obj = {float(po.x), float(po.y), float(po.z)};
        err_obj = Vec3f(std::abs(p_obj.x), std::abs(p_obj.y), 0.f) * gamma_n(3);
        double phi = std::atan2(po.y, po.x);
        if (phi < 0) phi += 2 * M_PI;
        double dz = double(q.zmax) - q.zmin;
        uv = {float(phi / q.phi_max), float(dz > 0 ? (po.z - q.zmin) / dz : 0.0)};
        // cross(dpdu, dpdv) points away from the axis: the normal is (x, y, 0) / r.
        n_obj = normalize(Vec3f(p_obj.x, p_obj.y, 0.f));
        dpdu_obj = {float(-q.phi_max * po.y), float(q.phi_max * po.x), 0.f};
        dpdv_obj = {0.f, 0.f, float(dz > 0 ? dz : 1.0)};
    } else {
        po.z = q.height;
        p_obj = {float(po.x), float(po.y), float(po.z)};
        err_obj = {0, 0, 0};
        double r = std::sqrt(po.x * po.x + po.y * po.y);
        double phi = std::atan2(po.y, po.x);
        if (phi < 0) phi += 2 * M_PI;
        uv = {float(phi / q.phi_max),
              float((q.radius - r) / (q.radius - q.inner_radius))};
        n_obj = {0, 0, 1};
        dpdu_obj = {float(-q.phi_max * po.y), float(q.phi_max * po.x), 0.f};
        double rs = r > 0 ? (q.inner_radius - q.radius) / r : 0.0;
        dpdv_obj = {float(po.x * rs), float(po.y * rs), 0.f};
        if (length_squared(dpdu_obj) == 0.f || length_squared(dpdv_obj) == 0.f) {
            dpdu_obj = {1, 0, 0};
            dpdv_obj = {0, 1, 0};
        }
    }
    if (q.flip_normal) n_obj = -n_obj;
    const Transform &t = q.render_from_object;
    si.p = t.point(p_obj);
    si.p_error = transform_error(t.matrix(), p_obj, err_obj);
    si.n = normalize(t.normal(n_obj));
    si.ns = si.n;
    si.dpdu = t.vector(dpdu_obj);
    si.dpdv = t.vector(dpdv_obj);
    si.uv = uv;
    si.material = q.material;
    si.medium_inside = q.medium_inside;
    si.medium_outside = q.medium_outside;
    si.area_light = q.light;
}

/// The hit of ray (o, d) at t on Embree primitive `prim` at its curve parameter u, all in the
/// curve set's space (pbrt-v4 Curve::IntersectSegment's interaction).
void fill_curve(const CurveSet &c, unsigned prim, float u, Vec3f o, Vec3f d, float t,
                SurfaceInteraction &si) {
    // Embree's primitive is piece prim % splits of segment prim / splits: u along the segment.
    const unsigned splits = unsigned(c.splits), seg = prim / splits;
    u = (float(prim % splits) + clamp(u, 0.f, 1.f)) / float(splits);
    const Vec3f *cp = &c.cp[4 * size_t(seg)];
    // De Casteljau: the point and the tangent of the cubic Bézier.
    Vec3f a = lerp(u, cp[0], cp[1]), b = lerp(u, cp[1], cp[2]), e = lerp(u, cp[2], cp[3]);
    Vec3f ab = lerp(u, a, b), be = lerp(u, b, e);
    Vec3f centre = lerp(u, ab, be);
    Vec3f dpdu = (be - ab) * 3.f;
    if (length_squared(dpdu) == 0.f) dpdu = cp[3] - cp[0];
    if (length_squared(dpdu) == 0.f) dpdu = {1, 0, 0};
    Vec3f p = o + d * t;
    Vec3f dir = normalize(d);
    // pbrt-v4 builds the frame in object space; here it is the group's space. A mirroring
    // transform between them turns cross products around: `mirror` turns them back, so v,
    // dpdv and n are pbrt's.
    const float mirror = c.mirrored ? -1.f : 1.f;
    // Across the width: perpendicular to the tangent and to the ray (flat, cylinder) or to the
    // interpolated normal (ribbon).
    Vec3f side = c.type == CurveSet::Type::Ribbon
                     ? cross(slerp(u, c.n[2 * size_t(seg)], c.n[2 * size_t(seg) + 1], dpdu), dpdu)
                     : cross(dir, dpdu);
    if (length_squared(side) == 0.f) side = Frame::from_z(normalize(dpdu)).x;
    side = normalize(side) * mirror;
    const float offset = dot(p - centre, side);
    // The width at the hit; a tapered end of width 0 still gets the hit's own distance.
    float w = lerp(u, c.width[2 * size_t(seg)], c.width[2 * size_t(seg) + 1]);
    w = std::max(w, 2.f * std::abs(offset));
    if (!(w > 0.f)) w = std::max(max_component(abs(p)), 1e-30f) * gamma_n(7);
    const float v = 0.5f + offset / w;
    Vec3f dpdv = side * w;
    if (c.type == CurveSet::Type::Cylinder) {
        // pbrt-v4: dpdv rotated about dpdu by -lerp(v, -90, 90) degrees, so the normal sweeps
        // across the width as a cylinder's would.
        float theta = mirror * radians(lerp(clamp(v, 0.f, 1.f), -90.f, 90.f));
        Vec3f axis = normalize(dpdu);
        float cs = std::cos(-theta), sn = std::sin(-theta);
        dpdv = dpdv * cs + cross(axis, dpdv) * sn + axis * (dot(axis, dpdv) * (1 - cs));
    }
    Vec3f n = cross(dpdu, dpdv) * mirror;
    n = length_squared(n) > 0.f ? normalize(n) : -dir;
    if (c.flip_normal) n = -n;
    si.p = p;
    // pbrt-v4 bounds the hit by the curve's width at the hit: rays leave the ribbon by that.
    si.p_error = Vec3f(w, w, w);
    si.n = n;
    si.ns = n;
    si.dpdu = dpdu;
    si.dpdv = dpdv;
    si.uv = {u, clamp(v, 0.f, 1.f)};
    si.material = c.material;
    si.medium_inside = c.medium_inside;
    si.medium_outside = c.medium_outside;
    si.area_light = nullptr;
}

}  // namespace

std::optional<SurfaceInteraction> Geometry::intersect(const Ray &ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    rh.ray.org_x = ray.o.x;
    rh.ray.org_y = ray.o.y;
    rh.ray.org_z = ray.o.z;
    rh.ray.dir_x = ray.d.x;
    rh.ray.dir_y = ray.d.y;
    rh.ray.dir_z = ray.d.z;
    rh.ray.tnear = 0.f;
    rh.ray.tfar = ray.t_max;
    rh.ray.time = 0.f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(groups_[0]->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;

    // Filled in place: the interaction is ~200 bytes, and a local copied into the optional
    // showed up in the profile.
    std::optional<SurfaceInteraction> out(std::in_place);
    fill_hit(ray, rh.ray.tfar, rh.hit.geomID, rh.hit.primID, rh.hit.instID[0], rh.hit.u,
             rh.hit.v, *out);
    return out;
}

namespace {

/// Loads rays[0..n) into an Embree packet of width K (RTCRayHit4 / RTCRayHit8) and marks
/// those lanes valid; the other lanes are invalid and left zeroed.
template <int K, class RayHitK>
void load_packet(const Ray *rays, int n, RayHitK &rh, int *valid) {
    std::memset(&rh, 0, sizeof(rh));
    for (int i = 0; i < K; ++i) {
        valid[i] = i < n ? -1 : 0;
        rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
        if (i >= n) continue;
        const Ray &r = rays[i];
        rh.ray.org_x[i] = r.o.x;
        rh.ray.org_y[i] = r.o.y;
        rh.ray.org_z[i] = r.o.z;
        rh.ray.dir_x[i] = r.d.x;
        rh.ray.dir_y[i] = r.d.y;
        rh.ray.dir_z[i] = r.d.z;
        rh.ray.tnear[i] = 0.f;
        rh.ray.tfar[i] = r.t_max;
        rh.ray.time[i] = 0.f;
        rh.ray.mask[i] = 0xFFFFFFFFu;
        rh.ray.id[i] = unsigned(i);
        rh.ray.flags[i] = 0;
    }
}

}  // namespace

void Geometry::intersect8(const Ray *rays, int count,
                          std::optional<SurfaceInteraction> *out) const {
    RTCScene scene = groups_[0]->scene;
    // Unpacks lane i of a packet through the single-ray hit record code.
    auto unpack = [&](const auto &rh, int i, int base) {
        std::optional<SurfaceInteraction> &o = out[base + i];
        if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {
            o.reset();
            return;
        }
        o.emplace();
        fill_hit(rays[base + i], rh.ray.tfar[i], rh.hit.geomID[i], rh.hit.primID[i],
                 rh.hit.instID[0][i], rh.hit.u[i], rh.hit.v[i], *o);
    };
    int base = 0;
    while (base < count) {
        int n = std::min(8, count - base);
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        if (n == 1) {
            out[base] = intersect(rays[base]);
        } else if (n <= 4) {
            alignas(16) int valid[4];
            alignas(16) RTCRayHit4 rh;
            load_packet<4>(rays + base, n, rh, valid);
            rtcIntersect4(valid, scene, &ctx, &rh);
            for (int i = 0; i < n; ++i) unpack(rh, i, base);
        } else {
            alignas(32) int valid[8];
            alignas(32) RTCRayHit8 rh;
            load_packet<8>(rays + base, n, rh, valid);
            rtcIntersect8(valid, scene, &ctx, &rh);
            for (int i = 0; i < n; ++i) unpack(rh, i, base);
        }
        base += n;
    }
}

void Geometry::fill_hit(const Ray &ray, float t, unsigned geom_id, unsigned prim_id,
                        unsigned inst_id, float u, float v, SurfaceInteraction &si) const {
    si.t = t;
    const GeometryGroup *g = groups_[0].get();
    const Transform *inst = nullptr;
    if (inst_id != RTC_INVALID_GEOMETRY_ID) {
        const auto &rec = g->records[inst_id];
        const InstanceRec &ir = instances_[size_t(rec.index)];
        inst = &ir.render_from_instance;
        g = groups_[size_t(ir.proto)].get();
        si.object_id = inst_id < object_base_.size() ? object_base_[inst_id] + int32_t(geom_id)
                                                     : -1;
    } else {
        si.object_id = geom_id < object_base_.size() ? object_base_[geom_id] : -1;
    }
    const auto &rec = g->records[geom_id];
    if (rec.kind == GeometryGroup::Record::Kind::Mesh) {
        fill_triangle(*g->meshes[size_t(rec.index)], prim_id, u, v, si);
    } else if (rec.kind == GeometryGroup::Record::Kind::Curves) {
        Vec3f o = ray.o, d = ray.d;
        if (inst) {
            o = inst->inverse_point(o);
            d = inst->inverse_vector(d);
        }
        fill_curve(*g->curves[size_t(rec.index)], prim_id, u, o, d, si.t, si);
    } else {
        // Quadrics compute their hit from the ray in their group's space.
        Vec3f o = ray.o, d = ray.d;
        if (inst) {
            o = inst->inverse_point(o);
            d = inst->inverse_vector(d);
        }
        fill_quadric(*g->quadrics[size_t(rec.index)], o + d * si.t, si);
    }
    if (inst) {
        Vec3f p_inst = si.p;
        si.p = inst->point(p_inst);
        si.p_error = transform_error(inst->matrix(), p_inst, si.p_error);
        si.n = normalize(inst->normal(si.n));
        si.ns = normalize(inst->normal(si.ns));
        si.dpdu = inst->vector(si.dpdu);
        si.dpdv = inst->vector(si.dpdv);
        si.area_light = nullptr;  // area lights are not supported on instances (as in pbrt-v4)
    }
    // Integrator rays are unit already; normalise only the others (tests pass any length).
    float d2 = length_squared(ray.d);
    si.wo = std::abs(d2 - 1.f) < 1e-6f ? -ray.d : -(ray.d / std::sqrt(d2));
}

bool Geometry::occluded(const Ray &ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r;
    r.org_x = ray.o.x;
    r.org_y = ray.o.y;
    r.org_z = ray.o.z;
    r.dir_x = ray.d.x;
    r.dir_y = ray.d.y;
    r.dir_z = ray.d.z;
    r.tnear = 0.f;
    r.tfar = ray.t_max;
    r.time = 0.f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(groups_[0]->scene, &ctx, &r);
    return r.tfar < 0.f;
}

}  // namespace tessera
