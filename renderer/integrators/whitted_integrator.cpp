// Deterministic Whitted ray tracer; see whitted_integrator.h for the model and its limits.
#include "renderer/integrators/whitted_integrator.h"

#include <algorithm>
#include <cstdio>
#include <unordered_map>
#include <variant>

#include "renderer/shading/microfacet.h"

namespace tessera {

namespace {

// pbrt's MixMaterial picks its second component when hash(p, wo) < amount. Materials are
// looked up with this fixed (p, wo), whose hash is exactly 0.5, so every point of a mix
// resolves to the component with the larger weight (ties: the first). Positions reach the
// textures through the TextureEvalContext, not through these fields.
constexpr Vec3f kMixLookupP{396248.f, 0.f, 0.f};
constexpr Vec3f kMixLookupWo{0.f, 0.f, 1.f};

/// Continuations through "interface" surfaces before a ray is given up (as the path tracer).
constexpr int kMaxInterfaceSkips = 256;

/// Shadow bit of light i: lights 31 and up share bit 31 (sample_source.h).
uint32_t shadow_bit(size_t i) {
    return 1u << std::min<size_t>(i, 31);
}

/// One perfect specular lobe: world direction and weight (Fresnel, radiance scaling).
struct SpecularLobe {
    Vec3f wi;
    Rgb weight;
};

/// The perfect specular lobes of a BSDF for outgoing direction wo (world, unit), in the BSDF's
/// own frame: at most two (reflection, transmission). Rough lobes are treated as perfect.
int specular_lobes(const Bsdf &bsdf, Vec3f wo_world, SpecularLobe lobes[2]) {
    const Frame &f = bsdf.frame();
    Vec3f wo = f.to_local(wo_world);
    if (wo.z == 0.f || !std::isfinite(wo.z))
        return 0;
    const Vec3f mirror{-wo.x, -wo.y, wo.z};
    int n = 0;
    auto add = [&](Vec3f wi_local, Rgb w) {
        if (w.is_black() || !w.is_finite())
            return;
        lobes[n++] = {f.to_world(wi_local), w};
    };
    const Bxdf &b = bsdf.bxdf();
    if (const auto *c = std::get_if<ConductorBxdf>(&b)) {
        add(mirror, fr_complex(std::abs(wo.z), c->eta, c->k));
    } else if (const auto *d = std::get_if<DielectricBxdf>(&b)) {
        // Fresnel split (pbrt-v4 DielectricBxDF, specular case); R = 1 under total internal
        // reflection, where refract() fails. Radiance is scaled by 1/eta'^2 across the interface.
        float r = fr_dielectric(wo.z, d->eta);
        add(mirror, Rgb(r));
        float etap = 1.f;
        Vec3f wt;
        if (r < 1.f && refract(wo, Vec3f(0, 0, 1), d->eta, &etap, &wt) && wt.z != 0.f)
            add(wt, Rgb((1.f - r) / sqr(etap)));
    } else if (const auto *t = std::get_if<ThinDielectricBxdf>(&b)) {
        // pbrt-v4 ThinDielectricBxDF: the slab's inter-reflections summed; straight through.
        float r = fr_dielectric(std::abs(wo.z), t->eta), tr = 1.f - r;
        if (r < 1.f) {
            r += tr * tr * r / (1.f - r * r);
            tr = 1.f - r;
        }
        add(mirror, Rgb(r));
        add(-wo, Rgb(tr));
    } else if (const auto *cc = std::get_if<CoatedConductorBxdf>(&b)) {
        // Both layers as perfect mirrors, one mirror lobe (two-sided, like the BxDF): the
        // coat's reflection F plus the light that crosses it, bounces between the metal (F_b
        // at the refracted angle) and the coat's inside (F again, by reciprocity) and leaves:
        // F + T^2 F_b A / (1 - F F_b A), A = Tr^2 of the slab's unit extinction there and back
        // (the sum of LayeredBxdf's specular walks, without the medium's scattered light).
        const float cos_o = std::abs(wo.z), eta = cc->top.eta;
        const float F = eta == 1.f ? 0.f : fr_dielectric(cos_o, eta);
        const float cos_in = safe_sqrt(1.f - (1.f - cos_o * cos_o) / (eta * eta));
        const Rgb Fb = fr_complex(cos_in, cc->bottom.eta, cc->bottom.k);
        const float A = std::exp(-2.f * cc->thickness / std::max(cos_in, 1e-4f));
        Rgb w;
        for (int c = 0; c < 3; ++c) {
            const float den = 1.f - F * Fb[c] * A;
            w[c] = den > 0.f ? F + sqr(1.f - F) * Fb[c] * A / den : F;
        }
        add(mirror, w);
    } else if (const auto *cd = std::get_if<CoatedDiffuseBxdf>(&b)) {
        // The coat's mirror reflection (two-sided, like the BxDF); its base is shaded by f().
        if (cd->top.eta != 1.f)
            add(mirror, Rgb(fr_dielectric(std::abs(wo.z), cd->top.eta)));
    }
    return n;
}

/// The BSDF shaded on the frame of `n`: the material's Bxdf, the layered ones with a coherent
/// seed (LayeredBxdf::coherent_seed), so that their stochastic f() shades smoothly: a preview
/// without per-pixel noise, which the real-time plugins would read as edges.
Bsdf shading_bsdf(Vec3f n, Bxdf b) {
    constexpr uint32_t kSeed = 0x9e3779b9u;
    if (auto *cd = std::get_if<CoatedDiffuseBxdf>(&b))
        cd->coherent_seed = kSeed;
    else if (auto *cc = std::get_if<CoatedConductorBxdf>(&b))
        cc->coherent_seed = kSeed;
    return Bsdf(Frame::from_z(n), b);
}

}  // namespace

/// Per-sample scratch (lives on the stack of evaluate): the ray counters of Sample.
struct WhittedIntegrator::Trace {
    uint32_t rays = 0;         ///< every ray traced (shadow rays included)
    uint32_t shadow_rays = 0;  ///< shadow rays traced
    uint32_t avoided = 0;      ///< shadow rays skipped: the light could not contribute
};

/// What the caller of shade_ray wants besides the radiance (the primary hit's extras).
struct WhittedIntegrator::HitOut {
    SurfaceAttributes *self = nullptr;       ///< this hit's attributes
    SurfaceAttributes *secondary = nullptr;  ///< first hit of the strongest specular ray
    Rgb local, global;                       ///< radiance split (always written)
    Sample *aov = nullptr;                   ///< albedo / normal / depth of this hit
    bool from_camera = false;                ///< the viewer is the camera (wo from its position)
};

WhittedIntegrator::WhittedIntegrator(const Scene &scene, const WhittedOptions &options)
    : scene_(scene), options_(options) {
    options_.max_depth = std::max(0, options_.max_depth);
    if (options_.lambertian) {
        lambertian_.resize(scene_.materials.size());
        for (size_t m = 0; m < scene_.materials.size(); ++m)
            if (scene_.materials[m]) lambertian_[m] = scene_.materials[m]->constant_lambertian();
    }
    // The camera has no "is orthographic" query: its rays are parallel and start at
    // different points exactly then.
    if (scene_.camera) {
        CameraRay a = scene_.camera->generate_ray({0.f, 0.f}, {0.5f, 0.5f}, false);
        CameraRay b = scene_.camera->generate_ray(
            {float(scene_.settings.width), float(scene_.settings.height)}, {0.5f, 0.5f}, false);
        orthographic_ = length(a.ray.d - b.ray.d) < 1e-6f && length(a.ray.o - b.ray.o) > 0.f;
    }

    // Light proxies: delta lights as they are, area lights from the shapes that emit.
    std::unordered_map<const Light *, size_t> index;
    lights_.resize(scene_.lights.size());
    for (size_t i = 0; i < scene_.lights.size(); ++i) {
        const Light *l = scene_.lights[i].get();
        index[l] = i;
        lights_[i].light = l;
        if (l->shape() == LightShape::Point)
            lights_[i].kind = LightProxy::Kind::Point;
        else if (l->shape() == LightShape::Spot)
            lights_[i].kind = LightProxy::Kind::Spot;
        else if (is_delta_light(l->type()))
            lights_[i].kind = LightProxy::Kind::Delta;
    }
    // The radiance an emitter sends from p on the n side (or the other side when it emits only
    // there), and whether it emits on both sides.
    auto emission = [](const Light *l, int32_t id, Vec3f p, Vec3f n) {
        Rgb front = l->L(p, n, {}, n), back = l->L(p, n, {}, -n);
        Emission e;
        e.object_id = id;
        e.L = front.is_black() ? back : front;
        e.twosided = !front.is_black() && !back.is_black();
        return e;
    };
    if (scene_.geometry) {
        for (const TopLevelShape &s : scene_.geometry->top_level_shapes()) {
            if (s.mesh && !s.mesh->lights.empty()) {
                const TriangleMesh &m = *s.mesh;
                bool first = true;
                for (size_t t = 0; t < m.triangle_count() && t < m.lights.size(); ++t) {
                    auto it = index.find(m.lights[t]);
                    if (it == index.end())
                        continue;
                    LightProxy &lp = lights_[it->second];
                    uint32_t i0 = m.indices[3 * t], i1 = m.indices[3 * t + 1],
                             i2 = m.indices[3 * t + 2];
                    lp.kind = LightProxy::Kind::Area;
                    lp.p = (m.p[i0] + m.p[i1] + m.p[i2]) / 3.f;
                    lp.n = m.oriented_normal(t);
                    lp.area = m.area(t);
                    Emission e = emission(lp.light, s.object_id, lp.p, lp.n);
                    lp.L = e.L;
                    lp.twosided = e.twosided;
                    if (first)
                        emissions_.push_back(e);
                    first = false;
                }
            } else if (s.quadric && s.quadric->light) {
                const Quadric &q = *s.quadric;
                auto it = index.find(q.light);
                if (it == index.end())
                    continue;
                LightProxy &lp = lights_[it->second];
                // As scene_builder.cpp: emitting quadrics are uniformly scaled; full spheres
                // and disks have SphereLight and DiskLight, the others QuadricAreaLight.
                const Transform &xf = q.render_from_object;
                float r = q.radius * length(xf.vector({1, 0, 0}));
                if (const auto *ql = dynamic_cast<const QuadricAreaLight *>(q.light)) {
                    // Cylinders and partial quadrics: one light sample (the proxy's "Delta"
                    // path calls sample_li), and the emission at that sample's point.
                    lp.kind = LightProxy::Kind::Delta;
                    Vec3f p, n;
                    ql->sample_point({0.5f, 0.5f}, &p, &n);
                    emissions_.push_back(emission(lp.light, s.object_id, p, n));
                } else if (q.kind == Quadric::Kind::Sphere) {
                    lp.kind = LightProxy::Kind::Sphere;
                    lp.p = xf.point({0, 0, 0});
                    lp.radius = r;
                    lp.area = kPi * r * r;
                    emissions_.push_back(
                        emission(lp.light, s.object_id, lp.p + Vec3f(0, 0, r), Vec3f(0, 0, 1)));
                } else {
                    lp.kind = LightProxy::Kind::Area;
                    lp.p = xf.point({0, 0, q.height});
                    lp.n = normalize(xf.normal({0, 0, 1}));
                    if (q.flip_normal)
                        lp.n = -lp.n;
                    lp.area = kPi * r * r;
                    Emission e = emission(lp.light, s.object_id, lp.p, lp.n);
                    lp.L = e.L;
                    lp.twosided = e.twosided;
                    emissions_.push_back(e);
                }
            }
        }
    }
    std::sort(emissions_.begin(), emissions_.end(),
              [](const Emission &a, const Emission &b) { return a.object_id < b.object_id; });
    textured_.resize(scene_.materials.size());
    for (size_t i = 0; i < scene_.materials.size(); ++i)
        textured_[i] = scene_.features.textures && scene_.materials[i]->textured();

    // What the scene can have: without a material with a specular lobe no reflection or
    // refraction ray is ever traced (specular_lobes() only knows materials whose possible flags
    // say specular), so the secondary record would stay empty; without textures has_texture is
    // always false and no material reads uv (textured() is false), so uv has no effect.
    uint32_t scene_can_have = kAttrAll;
    if (!scene_.features.specular || options_.max_depth == 0)
        scene_can_have &= ~uint32_t(kAttrSecondary);
    if (!scene_.features.textures)
        scene_can_have &= ~uint32_t(kAttrTexture);
    uint32_t wanted = options_.attributes & kAttrAll;
    // Texture and secondary groups live inside the first_hit record.
    if (wanted & (kAttrTexture | kAttrSecondary))
        wanted |= kAttrPrimary;
    collected_ = options_.specialize ? wanted & scene_can_have : uint32_t(kAttrAll);
}

float WhittedIntegrator::view_depth(Vec3f p) const {
    const PerspectiveCamera &cam = *scene_.camera;
    if (cam.orthographic()) return 1.f;
    // A spherical camera looks every way: the distance is its depth.
    if (cam.spherical() != SphericalMapping::None) return length(p - cam.position());
    return dot(p - cam.position(), cam.forward());
}

std::string WhittedIntegrator::describe() const {
    size_t area = 0, delta = 0;
    for (const LightProxy &l : lights_) {
        if (l.kind == LightProxy::Kind::Delta || l.kind == LightProxy::Kind::Point ||
            l.kind == LightProxy::Kind::Spot)
            ++delta;
        if (l.kind == LightProxy::Kind::Area || l.kind == LightProxy::Kind::Sphere)
            ++area;
    }
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "Whitted ray tracer, max depth %d, %zu delta + %zu point-like area lights, "
                  "attributes %s%s, deterministic (seed %u unused)",
                  options_.max_depth, delta, area, describe_attributes(collected_).c_str(),
                  options_.specialize ? "" : " (general path)", options_.seed);
    return buf;
}

Ray WhittedIntegrator::camera_ray(const CameraSample &cs) const {
    // No filter warp and the lens centre: the plugins place and weight the samples. A
    // realistic camera's pupil-centre ray is a preview: its exposure weight is not applied,
    // and where the lens blocks it the ray (t_max 0) sees the background.
    Vec2f p_raster{float(cs.px) + cs.fx, float(cs.py) + cs.fy};
    CameraRay cr = scene_.camera->generate_ray(p_raster, {0.5f, 0.5f}, false);
    if (cr.weight == 0.f) return Ray{scene_.camera->position(), scene_.camera->forward(), 0.f};
    return cr.ray;
}

Vec3f WhittedIntegrator::viewer_direction(Vec3f p) const {
    if (orthographic_)
        return -scene_.camera->forward();
    // The camera's origin (cached by the camera): the same for evaluate() and shade().
    return normalize(scene_.camera->position() - p);
}

Rgb WhittedIntegrator::environment(Vec3f dir) const {
    Rgb L(0.f);
    for (const Light *l : scene_.infinite_lights)
        L += l->Le(dir);
    return L;
}

const WhittedIntegrator::Emission *WhittedIntegrator::emission_of(int32_t object_id) const {
    if (emissions_.empty())
        return nullptr;
    auto it = std::lower_bound(emissions_.begin(), emissions_.end(), object_id,
                               [](const Emission &e, int32_t id) { return e.object_id < id; });
    return it != emissions_.end() && it->object_id == object_id ? &*it : nullptr;
}

bool WhittedIntegrator::has_texture(int material) const {
    return material >= 0 && size_t(material) < textured_.size() && textured_[size_t(material)];
}

std::optional<Bsdf> WhittedIntegrator::material_bsdf(const ShadePoint &sp,
                                                     const SurfaceInteraction *si) const {
    if (sp.material < 0 || size_t(sp.material) >= scene_.materials.size())
        return std::nullopt;
    // What the material sees: the hit itself when there is one (its tangents orient bump and
    // normal maps), else a surface rebuilt from the attributes. The BxDF's parameters depend
    // only on the texture context (p, uv, and n up to sign) and the fixed mix lookup, so both
    // give the same BxDF.
    SurfaceInteraction look;
    TextureEvalContext tc;
    tc.p = sp.p;
    tc.uv = sp.uv;
    if (si) {
        look = *si;
        // shade() sees +-normalize(ns) (unless a bump map moved it): the same up to sign, which
        // textures ignore (directionmix takes |cos|).
        tc.n = normalize(si->ns);
    } else {
        Frame f = Frame::from_z(sp.n);
        look.p = sp.p;
        look.n = look.ns = sp.n;
        look.dpdu = f.x;
        look.dpdv = f.y;
        look.uv = sp.uv;
        tc.n = sp.n;
    }
    look.p = kMixLookupP;
    look.wo = kMixLookupWo;
    return scene_.materials[size_t(sp.material)]->get_bsdf(look, tc);
}

Rgb WhittedIntegrator::local_shading(const ShadePoint &sp, const Bsdf *bsdf,
                                     const SurfaceInteraction *si, uint32_t *bits,
                                     Trace *tr) const {
    Rgb L(0.f);
    if (const Emission *e = emission_of(sp.object_id))
        if (e->twosided || dot(sp.n, sp.wo) > 0.f)
            L += e->L;
    if (!bsdf || !bsdf->has_non_specular())
        return L;
    // A BSDF without transmission is zero unless wi is on wo's side of the shading normal (the
    // BxDFs' same_hemisphere test, on the same local z = dot(w, sp.n)), so such lights are
    // skipped before their radiance and the BSDF are evaluated. Usually wo is above sp.n; on the
    // back of a one-sided emitter it is below. Hair is flagged reflection-only (as in pbrt-v4)
    // but its TT and TRT lobes leave through the far side of the fiber.
    const bool reflect_only =
        !(bsdf->flags() & kBxdfTransmission) && !std::holds_alternative<HairBxdf>(bsdf->bxdf());
    const float cos_o = dot(sp.wo, sp.n);
    // Every early `continue` below is a light that cannot contribute here: no shadow ray. The
    // same tests run in shade() (tr null), so shadow bits and shade() stay consistent.
    auto skip = [tr] {
        if (tr)
            ++tr->avoided;
    };
    for (size_t i = 0; i < lights_.size(); ++i) {
        const LightProxy &lp = lights_[i];
        Vec3f wi, target;
        Rgb Li;
        bool directional = false;
        switch (lp.kind) {
            case LightProxy::Kind::None:
                continue;
            case LightProxy::Kind::Delta:
            case LightProxy::Kind::Point:
            case LightProxy::Kind::Spot: {
                // sample_li is nullopt for zero radiance, i.e. also outside a spot cone. Point
                // and spot lights: the same function without the virtual call.
                const LightSampleContext ctx{sp.p, sp.n};
                std::optional<LightLiSample> ls =
                    lp.kind == LightProxy::Kind::Point
                        ? static_cast<const PointLight *>(lp.light)->PointLight::sample_li(ctx, {})
                    : lp.kind == LightProxy::Kind::Spot
                        ? static_cast<const SpotLight *>(lp.light)->SpotLight::sample_li(ctx, {})
                        : lp.light->sample_li(ctx, {0.5f, 0.5f});
                if (!ls) {
                    skip();
                    continue;
                }
                wi = ls->wi;
                if (reflect_only && !(cos_o * dot(wi, sp.n) > 0.f)) {
                    skip();
                    continue;
                }
                // pdf 1 for point, spot and distant lights; an area light reached this way
                // (sample-only, or a QuadricAreaLight) gives radiance over its solid-angle pdf.
                Li = ls->pdf > 0.f ? ls->L / ls->pdf : Rgb(0.f);
                target = ls->p_light;
                directional = lp.light->type() == LightType::DeltaDirection;
                break;
            }
            case LightProxy::Kind::Area: {
                // Point-like emitter at the centroid: E = L A |cos_l| / d^2 (L() is black on the
                // back of a one-sided emitter).
                Vec3f d = lp.p - sp.p;
                float d2 = length_squared(d);
                if (!(d2 > 0.f)) {
                    skip();
                    continue;
                }
                wi = d / std::sqrt(d2);
                float cos_l = dot(lp.n, wi);  // < 0: the point is on the emitting side
                if ((!(cos_l < 0.f) && !lp.twosided) ||
                    (reflect_only && !(cos_o * dot(wi, sp.n) > 0.f))) {
                    skip();
                    continue;
                }
                Li = lp.L * (lp.area * std::abs(cos_l) / d2);
                target = lp.p;
                break;
            }
            case LightProxy::Kind::Sphere: {
                // The sphere's projected disc, facing the point: E = L pi r^2 / d^2 (exact when
                // the whole sphere is above the horizon). The shadow ray ends on its near side.
                Vec3f d = lp.p - sp.p;
                float d2 = length_squared(d);
                if (!(d2 > lp.radius * lp.radius)) {
                    skip();
                    continue;
                }
                wi = d / std::sqrt(d2);
                if (reflect_only && !(cos_o * dot(wi, sp.n) > 0.f)) {
                    skip();
                    continue;
                }
                target = lp.p - wi * lp.radius;
                Li = lp.light->L(target, -wi, {}, -wi) * (lp.area / d2);
                break;
            }
        }
        // Zero radiance (e.g. a black emitter) or a zero BSDF value: nothing to trace for.
        if (Li.is_black()) {
            skip();
            continue;
        }
        Rgb c = bsdf->f(sp.wo, wi) * Li * absdot(wi, sp.n);
        if (c.is_black() || !c.is_finite()) {
            skip();
            continue;
        }
        const uint32_t bit = shadow_bit(i);
        if (si) {
            Ray shadow = directional ? si->spawn_ray(wi) : si->spawn_ray_to(target);
            ++tr->rays;
            ++tr->shadow_rays;
            if (scene_.geometry->occluded(shadow)) {
                *bits |= bit;
                continue;
            }
        } else if (*bits & bit) {
            continue;
        }
        L += c;
    }
    return L;
}

Rgb WhittedIntegrator::trace_ray(const Ray &ray, int depth, Trace &tr,
                                 SurfaceAttributes *attrs) const {
    ++tr.rays;
    std::optional<SurfaceInteraction> hit = scene_.geometry->intersect(ray);
    HitOut out;
    out.self = attrs;
    return shade_ray(ray, hit, depth, tr, out);
}

Rgb WhittedIntegrator::shade_ray(const Ray &ray_in, std::optional<SurfaceInteraction> &hit,
                                 int depth, Trace &tr, HitOut &out) const {
    Ray ray = ray_in;
    std::optional<Bsdf> bsdf;
    ShadePoint sp;
    for (int skips = 0;; ++skips) {
        if (!hit) {
            // Escaped: the environment, looked up as shade() will (from the stored direction).
            Vec3f dir = ray.d;
            if (out.self) {
                *out.self = SurfaceAttributes{};
                out.self->position = dir;
            }
            out.local = environment(normalize(dir));
            out.global = Rgb(0.f);
            return out.local;
        }
        const SurfaceInteraction &si = *hit;
        sp.object_id = si.object_id;
        sp.material = si.material;
        sp.p = si.p;
        sp.uv = si.uv;
        sp.wo = out.from_camera ? viewer_direction(si.p) : si.wo;
        bsdf = material_bsdf(sp, &si);
        if (bsdf)
            break;
        // "interface": no surface here; the ray continues unchanged.
        if (skips >= kMaxInterfaceSkips) {
            hit.reset();
            out.local = out.global = Rgb(0.f);
            if (out.self)
                *out.self = SurfaceAttributes{};
            return Rgb(0.f);
        }
        ray = si.spawn_ray(ray.d);
        ++tr.rays;
        hit = scene_.geometry->intersect(ray);
    }
    const SurfaceInteraction &si = *hit;
    // The stored normal faces the viewer, except on one-sided emitters, where it stays on the
    // emitting side so that shade() knows which side is seen.
    const Emission *em = emission_of(si.object_id);
    const Vec3f ns = bsdf->frame().z;
    Vec3f n_stored = (em && !em->twosided) ? face_forward(ns, si.n) : face_forward(ns, sp.wo);
    sp.n = normalize(n_stored);  // shade() normalises the (interpolated) normal the same way
    const Bsdf shading = shading_bsdf(sp.n, bsdf->bxdf());
    uint32_t bits = 0;
    out.local = local_shading(sp, &shading, &si, &bits, &tr);
    if (out.self) {
        SurfaceAttributes &a = *out.self;
        a.object_id = si.object_id;
        a.position = si.p;
        a.normal = n_stored;
        a.shadow_bits = bits;
        if (collected_ & kAttrTexture) {
            a.uv = si.uv;
            a.has_texture = has_texture(si.material);
        }
    }
    if (out.aov) {
        out.aov->albedo = bsdf->albedo_hint();
        out.aov->normal = si.ns;
        out.aov->depth = si.t * length(ray.d);
    }

    // Perfect reflection and refraction, with the material's own (bump-mapped) frame.
    out.global = Rgb(0.f);
    if (depth < options_.max_depth) {
        SpecularLobe lobes[2];
        int n = specular_lobes(*bsdf, si.wo, lobes);
        int strongest = 0;
        if (n == 2 && lobes[1].weight.average() > lobes[0].weight.average())
            strongest = 1;
        for (int i = 0; i < n; ++i) {
            Ray r = si.spawn_ray(lobes[i].wi);
            SurfaceAttributes *attrs = i == strongest ? out.secondary : nullptr;
            out.global += lobes[i].weight * trace_ray(r, depth + 1, tr, attrs);
        }
    }
    return out.local + out.global;
}

Sample WhittedIntegrator::finish_primary(const Ray &ray, std::optional<SurfaceInteraction> &hit,
                                         Trace &tr) const {
    Sample s;
    s.normal = Vec3f(0, 0, 0);
    s.depth = kInfinity;
    HitAttributes ha;
    HitOut out;
    out.from_camera = true;
    out.aov = &s;
    if (collected_ & kAttrPrimary)
        out.self = &ha.primary;
    if (collected_ & kAttrSecondary)
        out.secondary = &ha.secondary;
    shade_ray(ray, hit, 0, tr, out);
    // radiance = local + global, each in film units, so that shade() can rebuild it exactly.
    Rgb local = scene_.settings.to_film(out.local), global = scene_.settings.to_film(out.global);
    s.radiance = local + global;
    float m = s.radiance.max_value();
    if (m > scene_.settings.max_component)
        s.radiance *= scene_.settings.max_component / m;
    s.rays = tr.rays;
    s.shadow_rays = tr.shadow_rays;
    s.shadow_rays_avoided = tr.avoided;
    if (collected_ & kAttrPrimary) {
        ha.local_color = local;
        ha.global_color = global;
        s.first_hit = ha;
    }
    return s;
}

Sample WhittedIntegrator::evaluate(const CameraSample &cs) const {
    Ray ray = camera_ray(cs);
    Trace tr;
    tr.rays = 1;
    std::optional<SurfaceInteraction> hit = scene_.geometry->intersect(ray);
    return finish_primary(ray, hit, tr);
}

void WhittedIntegrator::evaluate_batch(std::span<const CameraSample> samples,
                                       std::span<Sample> out) const {
    const size_t n = std::min(samples.size(), out.size());
    for (size_t base = 0; base < n; base += 8) {
        const int k = int(std::min<size_t>(8, n - base));
        Ray rays[8];
        std::optional<SurfaceInteraction> hits[8];
        for (int i = 0; i < k; ++i)
            rays[i] = camera_ray(samples[base + size_t(i)]);
        scene_.geometry->intersect8(rays, k, hits);
        for (int i = 0; i < k; ++i) {
            Trace tr;
            tr.rays = 1;
            out[base + size_t(i)] = finish_primary(rays[i], hits[i], tr);
        }
    }
}

Rgb WhittedIntegrator::shade(const HitAttributes &attributes) const {
    const SurfaceAttributes &a = attributes.primary;
    Rgb local;
    if (!a.hit()) {
        local = environment(normalize(a.position));
    } else {
        ShadePoint sp;
        sp.object_id = a.object_id;
        sp.material = scene_.geometry->object_material(a.object_id);
        sp.p = a.position;
        sp.n = normalize(a.normal);
        sp.uv = a.uv;
        sp.wo = viewer_direction(a.position);
        uint32_t bits = a.shadow_bits;
        const size_t m = size_t(sp.material);
        // A Lambertian without bump or normal map: its reflectance straight from the cache
        // (constant) or from the texture, with the texture context material_bsdf would build.
        std::optional<Rgb> lambert;
        if (options_.lambertian && sp.material >= 0 && m < scene_.materials.size() &&
            scene_.materials[m]) {
            if (lambertian_[m]) {
                lambert = lambertian_[m];
            } else {
                TextureEvalContext tc;
                tc.p = sp.p;
                tc.uv = sp.uv;
                tc.n = sp.n;
                lambert = scene_.materials[m]->lambertian_at(tc);
            }
        }
        if (lambert) {
            // What get_bsdf would give, re-framed on sp.n as below.
            DiffuseBxdf b;
            b.reflectance = *lambert;
            const Bsdf shading(Frame::from_z(sp.n), Bxdf(b));
            local = local_shading(sp, &shading, nullptr, &bits, nullptr);
        } else if (std::optional<Bsdf> bsdf = material_bsdf(sp, nullptr)) {
            const Bsdf shading = shading_bsdf(sp.n, bsdf->bxdf());
            local = local_shading(sp, &shading, nullptr, &bits, nullptr);
        } else {
            local = local_shading(sp, nullptr, nullptr, &bits, nullptr);
        }
    }
    Rgb r = scene_.settings.to_film(local) + attributes.global_color;
    float m = r.max_value();
    if (m > scene_.settings.max_component)
        r *= scene_.settings.max_component / m;
    return r;
}

std::unique_ptr<SampleSource> make_whitted_integrator(const Scene &scene,
                                                      const WhittedOptions &options) {
    return std::make_unique<WhittedIntegrator>(scene, options);
}

}  // namespace tessera
