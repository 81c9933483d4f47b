// A synthetic SampleSource with attribute vectors, for the real-time plugins' tests (no Embree):
// a flat 2D "scene" on the film plane made of shapes, each with an object id, a colour that is a
// linear function of the film position (so interpolating two attribute vectors of one shape is
// exact), an optional checker texture, an optional shadow region and an optional reflection.
//
// Film position (x, y) = (px + fx, py + fy). Later shapes cover earlier ones. Attributes:
//   object_id = shape index (background: the first shape, normally a full-image plane),
//   position  = (x, y, shape.depth), normal = shape.normal,
//   uv        = (x, y) / shape.texture_scale, has_texture = shape.texture_scale > 0,
//   shadow_bits = 1 inside any shadow disc,
//   secondary.object_id = shape.reflects (-1: none), global_color = shape.reflection.
// shade(a) = colour(a.position) * checker(a.uv) * (shadowed ? shadow_factor : 1) + global_color,
// and evaluate(cs).radiance == shade(evaluate(cs).first_hit) exactly. Every evaluate() is
// counted per pixel (atomics), so a test can check which pixels were traced and how often.
#pragma once

#include <atomic>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "sampling/sample_source.h"

namespace tessera::test {

struct AttrShape {
    enum class Kind { Plane, Disc, HalfPlane, Line } kind = Kind::Plane;
    // Disc: centre (cx, cy), radius r. HalfPlane: points with nx*x + ny*y < d. Line: points
    // within width/2 of the line nx*x + ny*y = d (n unit).
    float cx = 0, cy = 0, r = 0;
    float nx = 1, ny = 0, d = 0, width = 1;
    Rgb color{0.5f, 0.5f, 0.5f};  ///< colour at film position (0, 0)
    Rgb color_dx, color_dy;       ///< colour change per pixel in x and y (linear shading)
    float depth = 10;             ///< position.z
    Vec3f normal{0, 0, -1};
    float texture_scale = 0;   ///< > 0: checker texture with squares of this many pixels
    int reflects = -1;         ///< secondary object id (-1: no reflection)
    Rgb reflection;            ///< global colour when reflecting
    bool contains(float x, float y) const {
        switch (kind) {
        case Kind::Plane: return true;
        case Kind::Disc: return (x - cx) * (x - cx) + (y - cy) * (y - cy) < r * r;
        case Kind::HalfPlane: return nx * x + ny * y < d;
        case Kind::Line: return std::fabs(nx * x + ny * y - d) < 0.5f * width;
        }
        return false;
    }
};

struct ShadowDisc {
    float cx = 0, cy = 0, r = 0;
};

class SyntheticAttributeSource final : public SampleSource {
  public:
    SyntheticAttributeSource(uint32_t w, uint32_t h) : w_(w), h_(h), counts_(size_t(w) * h) {
        AttrShape background;
        background.color = Rgb(0.2f, 0.3f, 0.4f);
        shapes.push_back(background);
    }
    std::vector<AttrShape> shapes;     ///< shapes[0] is the background plane
    std::vector<ShadowDisc> shadows;   ///< shadow bit 0 set inside any of them
    float shadow_factor = 0.25f;

    uint32_t width() const override { return w_; }
    uint32_t height() const override { return h_; }
    bool provides_attributes() const override { return true; }
    std::string describe() const override { return "synthetic attribute source"; }

    HitAttributes attributes_at(float x, float y) const {
        int id = 0;
        for (int i = int(shapes.size()) - 1; i >= 0; --i)
            if (shapes[size_t(i)].contains(x, y)) {
                id = i;
                break;
            }
        const AttrShape &s = shapes[size_t(id)];
        HitAttributes a;
        a.primary.object_id = id;
        a.primary.position = Vec3f(x, y, s.depth);
        a.primary.normal = s.normal;
        a.primary.has_texture = s.texture_scale > 0;
        if (a.primary.has_texture) a.primary.uv = Vec2f(x / s.texture_scale, y / s.texture_scale);
        for (const ShadowDisc &d : shadows)
            if ((x - d.cx) * (x - d.cx) + (y - d.cy) * (y - d.cy) < d.r * d.r)
                a.primary.shadow_bits = 1;
        if (s.reflects >= 0) {
            a.secondary.object_id = s.reflects;
            a.global_color = s.reflection;
        }
        a.local_color = local(a);
        return a;
    }

    Rgb shade(const HitAttributes &a) const override { return local(a) + a.global_color; }

    Sample evaluate(const CameraSample &cs) const override {
        counts_[size_t(cs.py) * w_ + cs.px].fetch_add(1, std::memory_order_relaxed);
        Sample s;
        HitAttributes a = attributes_at(float(cs.px) + cs.fx, float(cs.py) + cs.fy);
        s.radiance = shade(a);
        s.rays = 2 + (a.secondary.object_id >= 0 ? 1u : 0u);  // primary + shadow (+ reflection)
        s.first_hit = a;
        return s;
    }

    /// evaluate() calls that pixel (x, y) received since the last reset_counts().
    uint32_t count(uint32_t x, uint32_t y) const {
        return counts_[size_t(y) * w_ + x].load(std::memory_order_relaxed);
    }
    uint64_t total_count() const {
        uint64_t n = 0;
        for (const auto &c : counts_) n += c.load(std::memory_order_relaxed);
        return n;
    }
    void reset_counts() {
        for (auto &c : counts_) c.store(0, std::memory_order_relaxed);
    }
    /// The exact pixel colour: the mean of shade() over an n x n grid of sub-pixel points.
    Rgb ground_truth(uint32_t px, uint32_t py, int n = 16) const {
        Rgb sum(0.f);
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                sum += shade(attributes_at(float(px) + (float(i) + 0.5f) / float(n),
                                           float(py) + (float(j) + 0.5f) / float(n)));
        return sum / float(n * n);
    }

  private:
    Rgb local(const HitAttributes &a) const {
        if (a.primary.object_id < 0 || size_t(a.primary.object_id) >= shapes.size()) return Rgb(0.f);
        const AttrShape &s = shapes[size_t(a.primary.object_id)];
        const float x = a.primary.position.x, y = a.primary.position.y;
        Rgb c = s.color + s.color_dx * x + s.color_dy * y;
        if (a.primary.has_texture) {
            int cu = int(std::floor(a.primary.uv.x)), cv = int(std::floor(a.primary.uv.y));
            if ((cu + cv) & 1) c = c * 0.3f;
        }
        if (a.primary.shadow_bits) c = c * shadow_factor;
        return c;
    }

    uint32_t w_, h_;
    mutable std::vector<std::atomic<uint32_t>> counts_;
};

/// A busy scene: discs, thin lines in both directions, a checker texture, a reflection and
/// shadows, on a size that is not a multiple of the tile size (45 x 38). kim post-corrects on it.
inline std::unique_ptr<SyntheticAttributeSource> busy_attribute_scene() {
    auto src = std::make_unique<SyntheticAttributeSource>(45, 38);
    src->shapes[0].color_dx = Rgb(0.004f, 0.f, 0.002f);
    AttrShape s;
    s.kind = AttrShape::Kind::Disc;
    s.cx = 14, s.cy = 12, s.r = 9;
    s.color = Rgb(0.7f, 0.2f, 0.2f);
    s.normal = normalize(Vec3f(0.3f, 0, -1));
    src->shapes.push_back(s);
    s.cx = 30, s.cy = 25, s.r = 11;
    s.texture_scale = 5;
    s.color = Rgb(0.3f, 0.7f, 0.3f);
    s.normal = Vec3f(0, 0, -1);
    src->shapes.push_back(s);
    AttrShape line;
    line.kind = AttrShape::Kind::Line;
    line.nx = 1, line.ny = 0, line.d = 23.5f, line.width = 0.8f;
    line.color = Rgb(0.1f, 0.1f, 0.9f);
    src->shapes.push_back(line);
    line.nx = 0.08f, line.ny = 0.9968f, line.d = 19.1f, line.width = 1.2f;
    line.color = Rgb(0.9f, 0.9f, 0.1f);
    src->shapes.push_back(line);
    AttrShape mirror;
    mirror.kind = AttrShape::Kind::HalfPlane;
    mirror.nx = 0, mirror.ny = -1, mirror.d = -31;
    mirror.reflects = 1;
    mirror.reflection = Rgb(0.3f, 0.3f, 0.35f);
    src->shapes.push_back(mirror);
    src->shadows.push_back(ShadowDisc{8, 30, 4});
    src->shadows.push_back(ShadowDisc{36, 8, 0.7f});
    return src;
}

}  // namespace tessera::test
