#include "renderer/integrators/volpath_integrator.h"

#include <algorithm>
#include <cstdio>
#include <limits>

#include "renderer/integrators/path_common.h"
#include "renderer/scene/specialize.h"

namespace tessera {

namespace {

/// Where a light sample is taken from: a surface point (with its interaction, to spawn the
/// shadow ray robustly) or a point in a medium.
struct ScatterPoint {
    const SurfaceInteraction *si = nullptr;  ///< null for a medium point
    Vec3f p, n;                              ///< n zero in a medium
    int medium = -1;                         ///< the medium the path is in at p
};

/// A ray with the medium it travels through.
struct MediumRay {
    Ray ray;
    int medium = -1;
};

/// The shadow ray from `sp` toward the light sample `ls` of a light of type `lt`.
MediumRay shadow_ray_from(const ScatterPoint &sp, const LightLiSample &ls, LightType lt) {
    const bool at_infinity = lt == LightType::Infinite || lt == LightType::DeltaDirection;
    MediumRay r;
    if (sp.si) {
        r.ray = at_infinity ? sp.si->spawn_ray(ls.wi) : sp.si->spawn_ray_to(ls.p_light);
        r.medium = sp.si->medium_after(ls.wi, sp.medium);
    } else {
        r.ray = at_infinity ? Ray{sp.p, ls.wi, kInfinity}
                            : Ray{sp.p, ls.p_light - sp.p, 1.f - 1e-4f};
        r.medium = sp.medium;
    }
    return r;
}

/// The one-sample MIS weight's denominator: the average of a ratio over the channels.
inline float avg(Rgb v) { return v.average(); }

}  // namespace

VolPathIntegrator::VolPathIntegrator(const Scene &scene, uint32_t seed, int max_depth)
    : scene_(scene), seed_(seed), pattern_(scene.settings.sample_pattern), max_depth_(max_depth),
      differentials_(!(applicable_specializations(scene) & kSpecDifferentials)) {
    for (const auto &m : scene.materials) has_interfaces_ = has_interfaces_ || m->is_interface();
}

std::string VolPathIntegrator::describe() const {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "volumetric path tracer (delta tracking, ratio-tracking shadow rays, "
                  "spectral MIS over RGB), max depth %d, %zu media, seed %u",
                  max_depth_, scene_.media.size(), seed_);
    return buf;
}

Sample VolPathIntegrator::evaluate(const CameraSample &cs) const {
    sampling::SobolSampler sampler(seed_, pattern_);
    CameraRay cray = generate_camera_ray(scene_, cs, sampler, differentials_);
    Sample s;
    s.depth = kInfinity;
    if (cray.weight == 0.f) {
        s.radiance = Rgb(0.f);
        return s;
    }
    const int hero = std::min(2, int(sampler.get_1d() * 3.f));
    PathResult r = trace(cray, scene_.camera_medium, hero, sampler);
    s.radiance = film_radiance(scene_.settings, r.L * cray.weight);
    s.albedo = r.albedo;
    s.normal = r.normal;
    s.depth = r.depth;
    s.rays = r.rays;
    return s;
}

void VolPathIntegrator::evaluate_batch(std::span<const CameraSample> samples,
                                       std::span<Sample> out) const {
    for (size_t i = 0; i < samples.size(); ++i) out[i] = evaluate(samples[i]);
}

Rgb VolPathIntegrator::radiance(const Ray &ray, int medium, int hero, uint32_t px, uint32_t py,
                                uint32_t index) const {
    sampling::SobolSampler sampler(seed_, pattern_);
    sampler.start_pixel_sample(px, py, index);
    CameraRay cray;
    cray.ray = ray;
    cray.has_differentials = false;
    return trace(cray, medium, hero, sampler).L;
}

VolPathIntegrator::PathResult VolPathIntegrator::trace(const CameraRay &cray, int medium,
                                                       int hero,
                                                       sampling::SobolSampler &sampler) const {
    const Scene &sc = scene_;
    const int h = hero;
    PathResult res;
    Rgb L(0.f), beta(1.f), r_u(1.f), r_l(1.f);
    bool specular_bounce = false;
    int depth = 0, skips = 0;
    float eta_scale = 1.f;
    LightSampleContext prev_ctx;
    MediumRay ray{cray.ray, medium};
    bool first_surface = true;

    // Next-event estimation from sp (pbrt-v4 VolPathIntegrator::SampleLd): one light sample,
    // its transmittance by ratio tracking through every medium and interface on the way, MIS
    // (balance heuristic) against BSDF or phase sampling. `f_and_pdf(wi, &pdf)` is the
    // BSDF (times |cos|) or phase value and its sampling density.
    auto sample_ld = [&](const ScatterPoint &sp, auto &&f_and_pdf, Rgb beta_p, Rgb r_p) {
        const float u_light = sampler.get_1d();
        const Vec2f u2 = sampler.get_2d();
        if (!sc.light_sampler) return;
        auto sampled = sc.light_sampler->sample(u_light);
        if (!sampled) return;
        const Light *light = sampled->light;
        LightSampleContext ctx{sp.p, sp.n};
        std::optional<LightLiSample> ls = light->sample_li(ctx, u2);
        if (!ls || ls->L.is_black() || !(ls->pdf > 0.f)) return;
        const float p_l = sampled->pmf * ls->pdf;
        float scatter_pdf = 0.f;
        const Rgb f_hat = f_and_pdf(ls->wi, &scatter_pdf);
        if (f_hat.is_black()) return;
        const LightType lt = light->type();
        MediumRay sr = shadow_ray_from(sp, *ls, lt);
        Rgb T_ray(1.f), rl(1.f), ru(1.f);
        const float key[6] = {sr.ray.o.x, sr.ray.o.y, sr.ray.o.z,
                              sr.ray.d.x, sr.ray.d.y, sr.ray.d.z};
        Pcg32 rng(hash_floats(key, 6), 0);
        const bool at_infinity = lt == LightType::Infinite || lt == LightType::DeltaDirection;
        for (int crossings = 0; crossings < 256; ++crossings) {
            ++res.rays;
            std::optional<SurfaceInteraction> hit;
            if (sr.medium >= 0 || has_interfaces_) {
                hit = sc.geometry->intersect(sr.ray);
                if (hit && !(hit->material >= 0 && sc.materials[size_t(hit->material)]
                                                       ->is_interface()))
                    return;  // an opaque (or shading) surface blocks the light
            } else if (sc.geometry->occluded(sr.ray)) {
                return;
            }
            MediumProperties cmp;
            if (sr.medium >= 0 && sc.media[size_t(sr.medium)]->constant_properties(&cmp)) {
                // A homogeneous segment: ratio tracking against a majorant equal to sigma_t is
                // all or nothing (the first collision zeroes it); its expectation given the
                // ratios is the closed form, used instead (same mean, no noise): T_ray gets
                // exp(-sigma_t d), and both ratios the channels' transmittance over the hero's,
                // as ratio tracking leaves them when no collision happens.
                float d = (hit ? hit->t : sr.ray.t_max) * length(sr.ray.d);
                if (std::isinf(d)) d = std::numeric_limits<float>::max();
                const Rgb T = transmittance(cmp.sigma_a + cmp.sigma_s, d);
                const float th = T[h];
                if (!(th > 0.f)) return;
                T_ray *= T;
                rl *= T / th;
                ru *= T / th;
            } else if (sr.medium >= 0) {
                const float t_max = hit ? hit->t : sr.ray.t_max;
                const float u = rng.uniform();
                Rgb T_maj = sample_t_maj(
                    *sc.media[size_t(sr.medium)], sr.ray, t_max, u, rng, h,
                    [&](Vec3f, const MediumProperties &mp, Rgb sigma_maj, Rgb Tm) {
                        const Rgb sigma_n = clamp_zero(sigma_maj - mp.sigma_a - mp.sigma_s);
                        const float pdf = Tm[h] * sigma_maj[h];
                        T_ray *= Tm * sigma_n / pdf;
                        rl *= Tm * sigma_maj / pdf;
                        ru *= Tm * sigma_n / pdf;
                        // Russian roulette on a low transmittance estimate.
                        const Rgb Tr = T_ray / avg(rl + ru);
                        if (Tr.max_value() < 0.05f) {
                            constexpr float q = 0.75f;
                            if (rng.uniform() < q)
                                T_ray = Rgb(0.f);
                            else
                                T_ray /= 1.f - q;
                        }
                        return !T_ray.is_black();
                    });
                const float th = T_maj[h];
                if (th > 0.f) {
                    T_ray *= T_maj / th;
                    rl *= T_maj / th;
                    ru *= T_maj / th;
                } else {
                    T_ray = Rgb(0.f);
                }
            }
            if (T_ray.is_black() || !T_ray.is_finite()) return;
            if (!hit) break;
            // An interface: continue from it, into the medium on its far side.
            const int next_medium = hit->medium_after(sr.ray.d, sr.medium);
            sr.ray = at_infinity ? hit->spawn_ray(ls->wi) : hit->spawn_ray_to(ls->p_light);
            sr.medium = next_medium;
        }
        rl *= r_p * p_l;
        ru *= r_p * scatter_pdf;
        if (is_delta_light(lt))
            L += beta_p * f_hat * T_ray * ls->L / avg(rl);
        else
            L += beta_p * f_hat * T_ray * ls->L / avg(rl + ru);
    };

    while (true) {
        std::optional<SurfaceInteraction> hit = sc.geometry->intersect(ray.ray);
        ++res.rays;
        // --- the medium along the ray: delta tracking up to the surface (or infinity).
        MediumProperties cmp;
        if (ray.medium >= 0 && sc.media[size_t(ray.medium)]->constant_properties(&cmp) &&
            cmp.sigma_s.is_black()) {
            // A homogeneous medium that only absorbs: no path can scatter in it, so the
            // expectation of delta tracking's estimate (absorbed with probability
            // 1 - exp(-sigma_a d), or through with weight 1) given the path so far is the
            // closed form, used instead (Rao-Blackwellization: the same mean, no noise, and
            // no per-channel colour noise from the hero's absorption events). The path's
            // probability does not depend on the channel here, so both MIS ratios stay;
            // the emission along the segment integrates to Le (1 - exp(-sigma_a d)).
            sampler.skip(3);  // the three dimensions delta tracking draws, kept in step
            float d = (hit ? hit->t : kInfinity) * length(ray.ray.d);
            if (std::isinf(d)) d = std::numeric_limits<float>::max();
            const Rgb T = transmittance(cmp.sigma_a, d);
            if (depth < max_depth_ && !cmp.Le.is_black())
                L += beta * cmp.Le * (Rgb(1.f) - T) / avg(r_u);
            beta *= T;
            if (beta.is_black()) break;
        } else if (ray.medium >= 0) {
            bool scattered = false, terminated = false;
            const float t_max = hit ? hit->t : kInfinity;
            const uint64_t seed0 = uint64_t(sampler.get_1d() * 4294967296.0);
            const uint64_t seed1 = uint64_t(sampler.get_1d() * 4294967296.0);
            Pcg32 rng(seed0, seed1);
            const float u = sampler.get_1d();
            const Medium &med = *sc.media[size_t(ray.medium)];
            Rgb T_maj = sample_t_maj(
                med, ray.ray, t_max, u, rng, h,
                [&](Vec3f p, const MediumProperties &mp, Rgb sigma_maj, Rgb Tm) {
                    // Emission of the medium (absorbed-then-emitted radiance sigma_a Le).
                    if (depth < max_depth_ && !mp.Le.is_black()) {
                        const float pdf = sigma_maj[h] * Tm[h];
                        const Rgb betap = beta * Tm / pdf;
                        const Rgb r_e = r_u * sigma_maj * Tm / pdf;
                        if (!r_e.is_black()) L += betap * mp.sigma_a * mp.Le / avg(r_e);
                    }
                    const float p_absorb = mp.sigma_a[h] / sigma_maj[h];
                    const float p_scatter = mp.sigma_s[h] / sigma_maj[h];
                    const float p_null = std::max(0.f, 1.f - p_absorb - p_scatter);
                    const float u_mode = rng.uniform() * (p_absorb + p_scatter + p_null);
                    if (u_mode < p_absorb) {
                        terminated = true;
                        return false;
                    }
                    if (u_mode < p_absorb + p_scatter) {
                        // A real scattering event.
                        if (depth++ >= max_depth_) {
                            terminated = true;
                            return false;
                        }
                        const float pdf = Tm[h] * mp.sigma_s[h];
                        beta *= Tm * mp.sigma_s / pdf;
                        r_u *= Tm * mp.sigma_s / pdf;
                        if (beta.is_black() || r_u.is_black()) return false;
                        const Vec3f wo = -normalize(ray.ray.d);
                        const HgPhaseFunction &phase = med.phase;
                        ScatterPoint sp{nullptr, p, Vec3f(), ray.medium};
                        sample_ld(
                            sp,
                            [&](Vec3f wi, float *pdf_out) {
                                const float v = phase.p(wo, wi);
                                *pdf_out = phase.pdf(wo, wi);
                                return Rgb(v);
                            },
                            beta, r_u);
                        const Vec2f up = sampler.get_2d();
                        std::optional<PhaseFunctionSample> ps = phase.sample_p(wo, up);
                        if (!ps || !(ps->pdf > 0.f)) {
                            terminated = true;
                        } else {
                            beta *= ps->p / ps->pdf;
                            r_l = r_u / ps->pdf;
                            prev_ctx = LightSampleContext{p, Vec3f()};
                            scattered = true;
                            ray.ray = Ray{p, ps->wi, kInfinity};
                            specular_bounce = false;
                        }
                        return false;
                    }
                    // A null collision: the path continues, reweighted.
                    const Rgb sigma_n = clamp_zero(sigma_maj - mp.sigma_a - mp.sigma_s);
                    const float pdf = Tm[h] * sigma_n[h];
                    if (pdf == 0.f) {
                        beta = Rgb(0.f);
                    } else {
                        beta *= Tm * sigma_n / pdf;
                        r_u *= Tm * sigma_n / pdf;
                        r_l *= Tm * sigma_maj / pdf;
                    }
                    return !beta.is_black() && !r_u.is_black();
                });
            if (terminated || beta.is_black() || r_u.is_black() || !beta.is_finite()) break;
            if (scattered) continue;
            const float th = T_maj[h];
            if (!(th > 0.f)) break;
            beta *= T_maj / th;
            r_u *= T_maj / th;
            r_l *= T_maj / th;
        }

        // --- escaped: the infinite lights.
        if (!hit) {
            for (const Light *light : sc.infinite_lights) {
                Rgb Le = light->Le(ray.ray.d);
                if (Le.is_black()) continue;
                if (depth == 0 || specular_bounce) {
                    L += beta * Le / avg(r_u);
                } else {
                    const float p_l = sc.light_sampler->pmf(light) *
                                      light->pdf_li(prev_ctx, normalize(ray.ray.d), Vec3f(),
                                                    Vec3f());
                    L += beta * Le / avg(r_u + r_l * p_l);
                }
            }
            break;
        }
        SurfaceInteraction &si = *hit;
        if (first_surface && depth == 0) {
            res.depth = si.t * length(ray.ray.d);
            res.normal = si.ns;
        }
        // --- emission of an area light.
        if (si.area_light) {
            Rgb Le = si.area_light->L(si.p, si.n, si.uv, si.wo);
            if (!Le.is_black()) {
                if (depth == 0 || specular_bounce) {
                    L += beta * Le / avg(r_u);
                } else {
                    const float p_l = sc.light_sampler->pmf(si.area_light) *
                                      si.area_light->pdf_li(prev_ctx, normalize(ray.ray.d),
                                                            si.p, si.n);
                    L += beta * Le / avg(r_u + r_l * p_l);
                }
            }
        }
        if (differentials_)
            compute_differentials(si, depth == 0 && first_surface ? &cray : nullptr, *sc.camera,
                                  sc.settings.spp);
        std::optional<Bsdf> bsdf;
        if (si.material >= 0) {
            TextureEvalContext tc = texture_context(si);
            bsdf = sc.materials[size_t(si.material)]->get_bsdf(si, tc);
        }
        if (!bsdf) {
            // An interface: the ray passes into the medium on the far side, no bounce.
            if (++skips > 256) break;
            ray.medium = si.medium_after(ray.ray.d, ray.medium);
            ray.ray = si.spawn_ray(ray.ray.d);
            continue;
        }
        if (first_surface) {
            if (depth == 0) res.albedo = bsdf->albedo_hint();
            first_surface = false;
        }
        if (depth++ >= max_depth_) break;

        const Vec3f wo = si.wo;
        if (bsdf->has_non_specular()) {
            ScatterPoint sp{&si, si.p, si.n, ray.medium};
            const Bsdf &b = *bsdf;
            sample_ld(
                sp,
                [&](Vec3f wi, float *pdf_out) {
                    Rgb f = b.f_pdf(wo, wi, pdf_out);
                    return f * absdot(wi, b.frame().z);
                },
                beta, r_u);
        } else {
            sampler.skip(3);
        }
        prev_ctx = LightSampleContext{si.p, si.n};
        const float uc = sampler.get_1d();
        const Vec2f u = sampler.get_2d();
        std::optional<BsdfSample> bs = bsdf->sample_f(wo, uc, u);
        if (!bs || !(bs->pdf > 0.f) || bs->f.is_black()) break;
        beta *= bs->f * (absdot(bs->wi, bsdf->frame().z) / bs->pdf);
        if (bs->pdf_is_proportional)
            r_l = r_u / bsdf->pdf(wo, bs->wi);
        else
            r_l = r_u / bs->pdf;
        specular_bounce = bs->is_specular();
        if (bs->is_transmission()) eta_scale *= sqr(bs->eta);
        ray.medium = si.medium_after(bs->wi, ray.medium);
        ray.ray = si.spawn_ray(bs->wi);
        if (beta.is_black() || !beta.is_finite()) break;
        // Russian roulette on throughput over the MIS ratio, times eta^2 (pbrt-v4), with
        // Cycles' continuation probability (roulette_termination).
        const Rgb rr_beta = beta * eta_scale / avg(r_u);
        const float u_rr = sampler.get_1d();
        const float rr_max = rr_beta.max_value();
        if (rr_max < 1.f && depth > 1) {
            const float q = roulette_termination(rr_max);
            if (u_rr < q) break;
            beta /= 1.f - q;
        }
    }
    res.L = L;
    return res;
}

}  // namespace tessera
