#include "renderer/integrators/path_integrator.h"

#include "renderer/integrators/path_common.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <type_traits>

namespace tessera {

namespace {

/// What the path loop carries from one bounce to the next that MIS needs: whether the last
/// bounce was specular, the solid-angle pdf of the last BSDF sample, where it was taken.
///
/// A sample whose pdf is only proportional to its density (the layered BSDFs' random walks)
/// needs Bsdf::pdf, another random walk, for that density; MIS reads it only when the next
/// ray finds emission (an area light, or an infinite light on escape), so it is evaluated
/// then, from the previous bounce's BSDF, which the loop keeps alive until the next bounce's
/// emission has been added. Bsdf::pdf is a pure function of its directions (its walk seeds
/// itself from them), so the value is the one an eager call would give, bit for bit.
struct BounceState {
    int depth = 0;
    bool specular_bounce = false;
    LightSampleContext prev_ctx;

    /// The solid-angle density of the last BSDF sample, evaluated on first use.
    float p_bsdf() const {
        if (pending_) {
            p_bsdf_ = pending_->pdf(pending_wo_, pending_wi_);
            pending_ = nullptr;
        }
        return p_bsdf_;
    }
    void set_p_bsdf(float p) {
        p_bsdf_ = p;
        pending_ = nullptr;
    }
    /// p_bsdf() becomes bsdf.pdf(wo, wi); `bsdf` must outlive the next bounce's emission.
    void defer_p_bsdf(const Bsdf &bsdf, Vec3f wo, Vec3f wi) {
        pending_ = &bsdf;
        pending_wo_ = wo;
        pending_wi_ = wi;
    }

  private:
    mutable float p_bsdf_ = 1.f;
    mutable const Bsdf *pending_ = nullptr;
    Vec3f pending_wo_, pending_wi_;
};

/// Which estimators the path tracer combines (DirectStrategy): next-event estimation, emission
/// found by BSDF sampling, or both with MIS (power heuristic).
struct Strategies {
    bool nee, bsdf_emission;
};

/// Adds emitted radiance Le found by the path: in full at the camera ray or after a specular
/// bounce, else MIS-weighted (power heuristic) against light sampling, whose solid-angle pdf
/// `light_pdf()` gives (evaluated only when it is needed).
template <class LightPdf>
[[gnu::always_inline]] inline void add_emitted(Rgb Le, const BounceState &b, Strategies st,
                                               Rgb beta, Rgb &L, LightPdf light_pdf) {
    if (b.depth == 0 || b.specular_bounce) {
        L += beta * Le;
    } else if (st.bsdf_emission) {
        float w = 1.f;
        if (st.nee) w = power_heuristic(b.p_bsdf(), light_pdf());
        L += beta * Le * w;
    }
}

/// Adds the radiance of the infinite lights along an escaped ray.
[[gnu::always_inline]] inline void add_escaped_radiance(const Scene &sc, const Ray &ray,
                                                        const BounceState &b, Strategies st,
                                                        Rgb beta, Rgb &L) {
    for (const Light *light : sc.infinite_lights) {
        Rgb Le = light->Le(ray.d);
        if (Le.is_black()) continue;
        add_emitted(Le, b, st, beta, L, [&] {
            return sc.light_sampler->pmf(light) *
                   light->pdf_li(b.prev_ctx, ray.d, Vec3f(), Vec3f());
        });
    }
}

/// Adds the emission of the area light the ray hit.
[[gnu::always_inline]] inline void add_area_emission(const Scene &sc, const Ray &ray,
                                                     const SurfaceInteraction &si,
                                                     const BounceState &b, Strategies st,
                                                     Rgb beta, Rgb &L) {
    Rgb Le = si.area_light->L(si.p, si.n, si.uv, si.wo);
    if (Le.is_black()) return;
    add_emitted(Le, b, st, beta, L, [&] {
        return sc.light_sampler->pmf(si.area_light) *
               si.area_light->pdf_li(b.prev_ctx, normalize(ray.d), si.p, si.n);
    });
}

/// Next-event estimation at `si`: one light sample with its shadow ray, MIS-weighted against
/// BSDF sampling. Without culling (the general path) a sample whose radiance or BSDF value is
/// zero still traces its shadow ray and adds nothing. Consumes 3 dimensions either way.
template <class BsdfType>
[[gnu::always_inline]] inline void add_direct_light(const Scene &sc, const SurfaceInteraction &si,
                                                    const BsdfType &bsdf, Strategies st,
                                                    bool cull, Rgb beta,
                                                    sampling::SobolSampler &sampler, Rgb &L,
                                                    uint32_t &rays, uint32_t &avoided) {
    float u_light = sampler.get_1d();
    Vec2f u2 = sampler.get_2d();
    LightSampleContext ctx{si.p, si.n};
    auto sampled = sc.light_sampler->sample(u_light);
    if (!sampled) return;
    const Light *light = sampled->light;
    bool traced = false;
    if (auto ls = light->sample_li(ctx, u2); ls && (!cull || !ls->L.is_black()) && ls->pdf > 0) {
        LightType lt = light->type();
        const bool delta = is_delta_light(lt);
        float p_b = 0.f;
        Rgb f = (!delta && st.bsdf_emission) ? bsdf.f_pdf(si.wo, ls->wi, &p_b)
                                             : bsdf.f(si.wo, ls->wi);
        f *= absdot(ls->wi, bsdf.frame().z);
        if (!cull || !f.is_black()) {
            traced = true;
            Ray shadow = (lt == LightType::Infinite || lt == LightType::DeltaDirection)
                             ? si.spawn_ray(ls->wi)
                             : si.spawn_ray_to(ls->p_light);
            ++rays;
            if (!sc.geometry->occluded(shadow)) {
                float p_l = sampled->pmf * ls->pdf;
                if (delta) {
                    L += beta * f * ls->L / p_l;
                } else {
                    float w = st.bsdf_emission ? power_heuristic(p_l, p_b) : 1.f;
                    L += beta * f * ls->L * (w / p_l);
                }
            }
        }
    }
    if (!traced) ++avoided;
}

}  // namespace

PathIntegrator::PathIntegrator(const Scene &scene, uint32_t seed, int max_depth,
                               DirectStrategy strategy, uint32_t disabled)
    : scene_(scene),
      seed_(seed),
      pattern_(scene.settings.sample_pattern),
      max_depth_(max_depth),
      strategy_(strategy),
      spp_hint_(scene.settings.spp),
      spec_(used_specializations(applicable_specializations(scene), disabled)) {
    differentials_ = !(spec_ & kSpecDifferentials);
    cull_ = spec_ & kSpecCull;
    if (spec_ & kSpecLambertian) {
        lambertian_.reserve(scene.materials.size());
        for (const auto &m : scene.materials) lambertian_.push_back(*m->constant_lambertian());
        if (spec_ & kSpecPacket)
            packet_meshes_ = scene.geometry->meshes_by_geom_id();
    }
}

std::string PathIntegrator::describe() const {
    const char *s[] = {"MIS", "light sampling only", "BSDF sampling only"};
    char buf[256];
    std::snprintf(buf, sizeof(buf), "path tracer, max depth %d, %s, seed %u, specialised: %s",
                  max_depth_, s[int(strategy_)], seed_, specialization_names(spec_).c_str());
    return buf;
}

CameraRay PathIntegrator::camera_ray(const CameraSample &cs,
                                     sampling::SobolSampler &sampler) const {
    return generate_camera_ray(scene_, cs, sampler, differentials_);
}

void PathIntegrator::to_sample(const PathResult &r, Sample &s) const {
    s.radiance = film_radiance(scene_.settings, r.L);
    s.albedo = r.albedo;
    s.normal = r.normal;
    s.depth = r.depth;
    s.rays = r.rays;
    s.shadow_rays_avoided = r.shadow_rays_avoided;
    s.shadow_rays = 0;
    s.first_hit.reset();
}

Sample PathIntegrator::to_sample(const PathResult &r) const {
    Sample s;
    to_sample(r, s);
    return s;
}

Sample PathIntegrator::evaluate(const CameraSample &cs) const {
    sampling::SobolSampler sampler(seed_, pattern_);
    CameraRay cray = camera_ray(cs, sampler);
    if (cray.weight == 0.f) return to_sample(PathResult{});  // blocked by the lens system
    PathResult r = trace(cray, sampler);
    r.L *= cray.weight;
    return to_sample(r);
}

void PathIntegrator::evaluate_batch(std::span<const CameraSample> samples,
                                    std::span<Sample> out) const {
    if (!packet_meshes_.empty() && samples.size() > 1) {
        trace_packet(samples, out);
        return;
    }
    constexpr size_t kPacket = 8;
    for (size_t base = 0; base < samples.size(); base += kPacket) {
        const size_t n = std::min(kPacket, samples.size() - base);
        if (n == 1) {
            out[base] = evaluate(samples[base]);
            continue;
        }
        std::array<sampling::SobolSampler, kPacket> samplers;
        std::array<CameraRay, kPacket> crays;
        std::array<Ray, kPacket> rays;
        std::array<std::optional<SurfaceInteraction>, kPacket> hits;
        // Samples the lens system blocks trace nothing: the packet holds the others.
        std::array<size_t, kPacket> lane;
        size_t traced = 0;
        for (size_t i = 0; i < n; ++i) {
            samplers[i] = sampling::SobolSampler(seed_, pattern_);
            crays[i] = camera_ray(samples[base + i], samplers[i]);
            if (crays[i].weight != 0.f) {
                lane[i] = traced;
                rays[traced++] = crays[i].ray;
            }
        }
        scene_.geometry->intersect8(rays.data(), int(traced), hits.data());
        for (size_t i = 0; i < n; ++i) {
            if (crays[i].weight == 0.f) {
                out[base + i] = to_sample(PathResult{});
                continue;
            }
            PathResult r = trace(crays[i], samplers[i], &hits[lane[i]]);
            r.L *= crays[i].weight;
            out[base + i] = to_sample(r);
        }
    }
}

Rgb PathIntegrator::radiance(const Ray &ray, uint32_t px, uint32_t py, uint32_t index) const {
    sampling::SobolSampler sampler(seed_, pattern_);
    sampler.start_pixel_sample(px, py, index);
    sampler.skip(2);  // keep the dimension layout of evaluate()
    CameraRay cray;
    cray.ray = ray;
    cray.has_differentials = false;
    return trace(cray, sampler).L;
}

PathIntegrator::PathResult PathIntegrator::trace(const CameraRay &cray,
                                                 sampling::SobolSampler &sampler,
                                                 std::optional<SurfaceInteraction> *first) const {
    return lambertian_.empty() ? trace_impl<false>(cray, sampler, first)
                               : trace_impl<true>(cray, sampler, first);
}

template <bool kLambertian>
PathIntegrator::PathResult PathIntegrator::trace_impl(
    const CameraRay &cray, sampling::SobolSampler &sampler,
    std::optional<SurfaceInteraction> *first) const {
    PathResult res;
    const Scene &sc = scene_;
    Ray ray = cray.ray;
    Rgb L(0.f), beta(1.f);
    BounceState b;
    float eta_scale = 1.f;
    int skips = 0;
    const Strategies st{strategy_ != DirectStrategy::BsdfOnly,
                        strategy_ != DirectStrategy::LightOnly};
    const bool need_differentials = differentials_;
    using BsdfType = std::conditional_t<kLambertian, LambertianBsdf, Bsdf>;
    std::array<std::optional<BsdfType>, 2> bsdfs;
    int slot = 0;

    while (true) {
        // The camera ray's hit may come traced already (evaluate_batch's packets).
        std::optional<SurfaceInteraction> traced =
            first ? std::optional<SurfaceInteraction>() : sc.geometry->intersect(ray);
        std::optional<SurfaceInteraction> &hit = first ? *first : traced;
        first = nullptr;
        ++res.rays;
        if (!hit) {
            add_escaped_radiance(sc, ray, b, st, beta, L);
            break;
        }
        SurfaceInteraction &si = *hit;
        if (b.depth == 0 && skips == 0) {
            res.depth = si.t * length(ray.d);
            res.normal = si.ns;
        }
        if (si.area_light) add_area_emission(sc, ray, si, b, st, beta, L);
        if (need_differentials)
            compute_differentials(si, b.depth == 0 ? &cray : nullptr, *sc.camera, spp_hint_);
        // The BSDF: in the Lambertian specialisation straight from the material's constant
        // reflectance, in the frame Material::frame builds without a bump map.
        // Two BSDF slots, alternating per bounce: the previous bounce's BSDF stays alive for
        // the deferred pdf (BounceState) while this bounce builds its own.
        std::optional<BsdfType> &bsdf = bsdfs[slot];
        bsdf.reset();
        if constexpr (kLambertian) {
            if (si.material >= 0)
                bsdf = LambertianBsdf{Frame::from_xz(si.dpdu, si.ns),
                                      lambertian_[size_t(si.material)]};
        } else {
            TextureEvalContext tc = texture_context(si);
            if (si.material >= 0) bsdf = sc.materials[size_t(si.material)]->get_bsdf(si, tc);
        }
        if (!bsdf) {
            // "interface": no surface here; continue the ray without a bounce.
            if (++skips > 256) break;
            ray = si.spawn_ray(ray.d);
            continue;
        }
        if (b.depth == 0) res.albedo = bsdf->albedo_hint();
        if (b.depth++ == max_depth_) break;

        if (st.nee && bsdf->has_non_specular() && sc.light_sampler)
            add_direct_light(sc, si, *bsdf, st, cull_, beta, sampler, L, res.rays,
                             res.shadow_rays_avoided);
        else if (st.nee)
            sampler.skip(3);  // keep the dimension layout fixed whatever the material

        // BSDF sampling for the next direction.
        float uc = sampler.get_1d();
        Vec2f u = sampler.get_2d();
        std::optional<BsdfSample> bs = bsdf->sample_f(si.wo, uc, u);
        if (!bs || bs->pdf <= 0.f || bs->f.is_black()) break;
        beta *= bs->f * (absdot(bs->wi, bsdf->frame().z) / bs->pdf);
        // A proportional pdf (the layered BSDFs) is replaced by pdf()'s density for MIS,
        // deferred until emission needs it (BounceState); after a specular sample MIS never
        // reads it.
        if constexpr (!kLambertian) {
            if (bs->pdf_is_proportional && !bs->is_specular()) {
                b.defer_p_bsdf(*bsdf, si.wo, bs->wi);
                slot ^= 1;
            } else {
                b.set_p_bsdf(bs->pdf);
            }
        } else {
            b.set_p_bsdf(bs->pdf);
        }
        b.specular_bounce = bs->is_specular();
        if (bs->is_transmission()) eta_scale *= sqr(bs->eta);
        b.prev_ctx = LightSampleContext{si.p, si.n};
        ray = si.spawn_ray(bs->wi);

        // Russian roulette on throughput scaled by the squared relative IOR (pbrt-v4), with
        // Cycles' continuation probability (roulette_termination).
        // The roulette dimension is always consumed, but only hashed when it is used.
        float rr_max = (beta * eta_scale).max_value();
        if (rr_max < 1.f && b.depth > 1) {
            float q = roulette_termination(rr_max);
            if (sampler.get_1d() < q)
                break;
            beta /= 1.f - q;
        } else {
            sampler.skip(1);
        }
        if (beta.is_black()) break;
    }
    res.L = L;
    return res;
}

}  // namespace tessera
