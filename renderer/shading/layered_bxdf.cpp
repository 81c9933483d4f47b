// LayeredBxdf: pbrt-v4's stochastic layered BSDF (PBRT 4th ed., section 14.3.2; Guo et al.
// 2018). See layered_bxdf.h for the estimators; this file follows the book's structure
// (LayeredBxDF::f, Sample_f and PDF), written for Tessera's types.
#include "renderer/shading/layered_bxdf.h"

#include "renderer/util/random.h"

#include <cstring>
#include <limits>

#include "renderer/shading/bxdfs.h"

namespace tessera {

namespace {

uint64_t hash_dir(Vec3f w) {
    const float v[3] = {w.x, w.y, w.z};
    return hash_floats(v, 3);
}

/// The generator's offset with LayeredBxdf::coherent_seed (any constant).
constexpr uint64_t kCoherentOffset = 0x5bd1e9955bd1e995ull;

/// Transmittance of the unit-extinction slab over a vertical distance dz along w (pbrt-v4
/// LayeredBxDF::Tr): exp(-|dz / w.z|), 1 for a vanishing distance.
float tr(float dz, Vec3f w) {
    if (std::abs(dz) <= std::numeric_limits<float>::min())
        return 1.f;
    return std::exp(-std::abs(dz / w.z));
}

/// A sample the walk can continue from (pbrt-v4's test: a value, a density, off the plane).
bool usable(const std::optional<BsdfSample> &s) {
    return s && !s->f.is_black() && s->pdf > 0.f && s->wi.z != 0.f;
}

/// One of the two interfaces, chosen at run time (pbrt-v4 TopOrBottomBxDF).
template <class Top, class Bottom>
class Side {
  public:
    static Side of_top(const Top &t) { return Side(&t, nullptr); }
    static Side of_bottom(const Bottom &b) { return Side(nullptr, &b); }

    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const {
        return top_ ? top_->f(wo, wi, mode) : bottom_->f(wo, wi, mode);
    }
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode,
                                       BxdfReflTrans lobes = kReflTransAll) const {
        return top_ ? top_->sample_f(wo, uc, u, mode, lobes)
                    : bottom_->sample_f(wo, uc, u, mode, lobes);
    }
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode, BxdfReflTrans lobes = kReflTransAll) const {
        return top_ ? top_->pdf(wo, wi, mode, lobes) : bottom_->pdf(wo, wi, mode, lobes);
    }
    uint8_t flags() const { return top_ ? top_->flags() : bottom_->flags(); }

  private:
    Side(const Top *t, const Bottom *b) : top_(t), bottom_(b) {}
    const Top *top_;
    const Bottom *bottom_;
};

}  // namespace

template <class Top, class Bottom, bool kTwoSided>
LayeredBxdf<Top, Bottom, kTwoSided>::LayeredBxdf(Top top_, Bottom bottom_, float thickness_,
                                                 Rgb albedo_, float g_, int max_depth_,
                                                 int n_samples_)
    : top(top_),
      bottom(bottom_),
      thickness(std::max(thickness_, std::numeric_limits<float>::min())),
      albedo(albedo_),
      g(g_),
      max_depth(std::max(0, max_depth_)),
      n_samples(std::max(1, n_samples_)) {
    // NaN thickness (a broken texture) becomes the thinnest layer too.
    if (!(thickness >= std::numeric_limits<float>::min()))
        thickness = std::numeric_limits<float>::min();
}

template <class Top, class Bottom, bool kTwoSided>
uint8_t LayeredBxdf<Top, Bottom, kTwoSided>::flags() const {
    const uint8_t tf = top.flags(), bf = bottom.flags();
    uint8_t fl = kBxdfReflection;
    if (is_specular_flags(tf))
        fl |= kBxdfSpecular;
    if ((tf & kBxdfDiffuse) || (bf & kBxdfDiffuse) || !albedo.is_black())
        fl |= kBxdfDiffuse;
    else if ((tf & kBxdfGlossy) || (bf & kBxdfGlossy))
        fl |= kBxdfGlossy;
    if ((tf & kBxdfTransmission) && (bf & kBxdfTransmission))
        fl |= kBxdfTransmission;
    return fl;
}

template <class Top, class Bottom, bool kTwoSided>
Rgb LayeredBxdf<Top, Bottom, kTwoSided>::f(Vec3f wo, Vec3f wi, TransportMode mode) const {
    using S = Side<Top, Bottom>;
    if (kTwoSided && wo.z < 0.f) {
        wo = -wo;
        wi = -wi;
    }
    // The path enters through the interface on wo's side and leaves through the one on wi's:
    // the same one for a reflection, the other for a transmission.
    const bool entered_top = kTwoSided || wo.z > 0.f;
    const bool same = same_hemisphere(wo, wi);
    const bool exit_bottom = same != entered_top;
    const S enter = entered_top ? S::of_top(top) : S::of_bottom(bottom);
    const S exit = exit_bottom ? S::of_bottom(bottom) : S::of_top(top);
    const S non_exit = exit_bottom ? S::of_top(top) : S::of_bottom(bottom);
    const float exit_z = exit_bottom ? 0.f : thickness;
    const bool exit_specular = is_specular_flags(exit.flags());
    const bool non_exit_specular = is_specular_flags(non_exit.flags());
    const bool scattering = !albedo.is_black();
    const HgPhaseFunction phase{g};

    // Reflection at the entrance interface, counted once per walk before the division below.
    Rgb f(0.f);
    if (same)
        f = enter.f(wo, wi, mode) * float(n_samples);

    Pcg32 rng(coherent_seed ? coherent_seed : hash_dir(wo),
              coherent_seed ? kCoherentOffset : hash_dir(wi));
    for (int s = 0; s < n_samples; ++s) {
        // Into the layers from wo, and from wi with the adjoint transport mode (the light's
        // direction of travel): the two ends of the path, both refracted through an interface.
        float uc = rng.uniform();
        Vec2f u = rng.uniform2();
        const std::optional<BsdfSample> wos =
            enter.sample_f(wo, uc, u, mode, kReflTransTransmission);
        if (!usable(wos))
            continue;
        uc = rng.uniform();
        u = rng.uniform2();
        const std::optional<BsdfSample> wis =
            exit.sample_f(wi, uc, u, flip(mode), kReflTransTransmission);
        if (!usable(wis))
            continue;
        // The light's end, ready for next-event estimates: its weight and the direction that
        // reaches the exit interface (-wis->wi, pointing out of the layers).
        const Rgb wis_weight = wis->f / wis->pdf;
        const Vec3f to_exit = -wis->wi;
        // The MIS weight of an estimate through the exit interface along a sampled inner
        // direction w uses, as pbrt-v4's does, the exit interface's density of wi given -w
        // (exitInterface.PDF(-w, wi, mode, Transmission)). The wis strategy's density of w is
        // the exit's density of -w given wi in the adjoint mode, which differs for a rough
        // interface (by eta^2 and a cosine ratio), so the weights do not sum to 1 and f()
        // comes out 5-20% above sample_f under a rough coat (layered_bxdf.h). Kept so that
        // Tessera renders these materials as pbrt-v4 does wherever both sample lights.
        const auto exit_strategy_pdf = [&](Vec3f w_in) {
            return exit.pdf(-w_in, wi, mode, kReflTransTransmission);
        };

        Rgb beta = wos->f * (std::abs(wos->wi.z) / wos->pdf);
        float z = entered_top ? thickness : 0.f;
        Vec3f w = wos->wi;
        for (int depth = 0; depth < max_depth; ++depth) {
            // Russian roulette once the walk has run a few segments and carries little.
            if (depth > 3 && beta.max_value() < 0.25f) {
                const float q = std::max(0.f, 1.f - beta.max_value());
                if (rng.uniform() < q)
                    break;
                beta /= 1.f - q;
            }

            if (!scattering) {
                // Straight to the other interface, attenuated by the slab.
                z = (z == thickness) ? 0.f : thickness;
                beta *= tr(thickness, w);
            } else {
                // Free flight with unit extinction: the vertical distance is exponential with
                // rate 1 / |w.z| (PBRT section 14.3.2, "Account for media between layers").
                const float dz = -std::log(1.f - rng.uniform()) * std::abs(w.z);
                const float zp = w.z > 0.f ? (z + dz) : (z - dz);
                if (zp == z)
                    continue;
                if (0.f < zp && zp < thickness) {
                    // Scattering inside the slab: next-event estimate through the exit along
                    // wis, MIS against the phase function's sampling of the same direction.
                    float wt = 1.f;
                    if (!exit_specular)
                        wt = power_heuristic(wis->pdf, phase.pdf(-w, to_exit));
                    f += beta * albedo * wis_weight *
                         (phase.p(-w, to_exit) * wt * tr(zp - exit_z, wis->wi));
                    const std::optional<PhaseFunctionSample> ps =
                        phase.sample_p(-w, rng.uniform2());
                    if (!ps || !(ps->pdf > 0.f) || ps->wi.z == 0.f)
                        continue;
                    beta *= albedo * (ps->p / ps->pdf);
                    w = ps->wi;
                    z = zp;
                    // Headed for the exit interface: the estimate along the phase sample, MIS
                    // against the wis strategy (see exit_strategy_pdf).
                    if (((z < exit_z && w.z > 0.f) || (z > exit_z && w.z < 0.f)) &&
                        !exit_specular) {
                        const Rgb f_exit = exit.f(-w, wi, mode);
                        if (!f_exit.is_black()) {
                            const float wt2 = power_heuristic(ps->pdf, exit_strategy_pdf(w));
                            f += beta * f_exit * (tr(zp - exit_z, ps->wi) * wt2);
                        }
                    }
                    continue;
                }
                z = clamp(zp, 0.f, thickness);
            }

            if (z == exit_z) {
                // At the exit interface from inside: only its reflection keeps the path in.
                uc = rng.uniform();
                u = rng.uniform2();
                const std::optional<BsdfSample> bs =
                    exit.sample_f(-w, uc, u, mode, kReflTransReflection);
                if (!usable(bs))
                    break;
                beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
                w = bs->wi;
            } else {
                // At the non-exit interface: the next-event estimate toward the exit along wis,
                // MIS against this interface's own sampling.
                if (!non_exit_specular) {
                    float wt = 1.f;
                    if (!exit_specular)
                        wt = power_heuristic(wis->pdf, non_exit.pdf(-w, to_exit, mode));
                    f += beta * non_exit.f(-w, to_exit, mode) * wis_weight *
                         (std::abs(wis->wi.z) * wt * tr(thickness, wis->wi));
                }
                uc = rng.uniform();
                u = rng.uniform2();
                const std::optional<BsdfSample> bs =
                    non_exit.sample_f(-w, uc, u, mode, kReflTransReflection);
                if (!usable(bs))
                    break;
                beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
                w = bs->wi;
                // ...and the estimate along the direction just sampled, MIS against the wis
                // strategy.
                if (!exit_specular) {
                    const Rgb f_exit = exit.f(-w, wi, mode);
                    if (!f_exit.is_black()) {
                        float wt = 1.f;
                        if (!non_exit_specular)
                            wt = power_heuristic(bs->pdf, exit_strategy_pdf(w));
                        f += beta * f_exit * (tr(thickness, bs->wi) * wt);
                    }
                }
            }
        }
    }
    return f / float(n_samples);
}

template <class Top, class Bottom, bool kTwoSided>
std::optional<BsdfSample> LayeredBxdf<Top, Bottom, kTwoSided>::sample_f(Vec3f wo, float uc, Vec2f u,
                                                                        TransportMode mode) const {
    using S = Side<Top, Bottom>;
    bool flip_wi = false;
    if (kTwoSided && wo.z < 0.f) {
        wo = -wo;
        flip_wi = true;
    }
    // The entrance interface, sampled with the caller's numbers: its reflection is the answer.
    const bool entered_top = kTwoSided || wo.z > 0.f;
    std::optional<BsdfSample> bs =
        entered_top ? top.sample_f(wo, uc, u, mode) : bottom.sample_f(wo, uc, u, mode);
    if (!usable(bs))
        return std::nullopt;
    if (bs->is_reflection()) {
        if (flip_wi)
            bs->wi = -bs->wi;
        bs->pdf_is_proportional = true;
        return bs;
    }
    Vec3f w = bs->wi;
    bool specular_path = bs->is_specular();

    // The walk's own numbers, from the caller's: deterministic for (wo, uc, u).
    const float key[3] = {uc, u.x, u.y};
    Pcg32 rng(hash_dir(wo), hash_floats(key, 3));
    Rgb f = bs->f * std::abs(bs->wi.z);
    float pdf = bs->pdf;
    float z = entered_top ? thickness : 0.f;
    const bool scattering = !albedo.is_black();
    const HgPhaseFunction phase{g};

    for (int depth = 0; depth < max_depth; ++depth) {
        // Russian roulette on the sample's weight f / pdf; survival divides the density.
        const float rr_beta = f.max_value() / pdf;
        if (depth > 3 && rr_beta < 0.25f) {
            const float q = std::max(0.f, 1.f - rr_beta);
            if (rng.uniform() < q)
                return std::nullopt;
            pdf *= 1.f - q;
        }
        if (w.z == 0.f)
            return std::nullopt;

        if (scattering) {
            const float dz = -std::log(1.f - rng.uniform()) * std::abs(w.z);
            const float zp = w.z > 0.f ? (z + dz) : (z - dz);
            if (zp == z)
                return std::nullopt;
            if (0.f < zp && zp < thickness) {
                // Scattered in the slab: the phase function picks the new direction.
                const std::optional<PhaseFunctionSample> ps = phase.sample_p(-w, rng.uniform2());
                if (!ps || !(ps->pdf > 0.f) || ps->wi.z == 0.f)
                    return std::nullopt;
                f *= albedo * ps->p;
                pdf *= ps->pdf;
                specular_path = false;
                w = ps->wi;
                z = zp;
                continue;
            }
            z = clamp(zp, 0.f, thickness);
        } else {
            z = (z == thickness) ? 0.f : thickness;
            f *= tr(thickness, w);
        }

        const S iface = z == 0.f ? S::of_bottom(bottom) : S::of_top(top);
        const float uc2 = rng.uniform();
        const Vec2f u2 = rng.uniform2();
        bs = iface.sample_f(-w, uc2, u2, mode);
        if (!usable(bs))
            return std::nullopt;
        f *= bs->f;
        pdf *= bs->pdf;
        specular_path &= bs->is_specular();
        w = bs->wi;

        if (bs->is_transmission()) {
            // Out of the layers: a reflection when it left on wo's side.
            BsdfSample out;
            out.flags = same_hemisphere(wo, w) ? kBxdfReflection : kBxdfTransmission;
            out.flags |= specular_path ? kBxdfSpecular : kBxdfGlossy;
            out.f = f;
            out.wi = flip_wi ? -w : w;
            out.pdf = pdf;
            out.eta = 1.f;
            out.pdf_is_proportional = true;
            return out;
        }
        f *= std::abs(bs->wi.z);
    }
    return std::nullopt;
}

template <class Top, class Bottom, bool kTwoSided>
float LayeredBxdf<Top, Bottom, kTwoSided>::pdf(Vec3f wo, Vec3f wi, TransportMode mode) const {
    using S = Side<Top, Bottom>;
    if (kTwoSided && wo.z < 0.f) {
        wo = -wo;
        wi = -wi;
    }
    Pcg32 rng(coherent_seed ? coherent_seed : hash_dir(wi),
              coherent_seed ? kCoherentOffset : hash_dir(wo));
    const bool entered_top = kTwoSided || wo.z > 0.f;
    const bool same = same_hemisphere(wo, wi);

    // The entrance interface's reflection, as sample_f returns it.
    float pdf_sum = 0.f;
    if (same) {
        pdf_sum +=
            float(n_samples) * (entered_top ? top.pdf(wo, wi, mode, kReflTransReflection)
                                            : bottom.pdf(wo, wi, mode, kReflTransReflection));
    }

    for (int s = 0; s < n_samples; ++s) {
        if (same) {
            // Transmit, reflect at the far interface, transmit back (TRT; PBRT eq. 14.37).
            const S r_iface = entered_top ? S::of_bottom(bottom) : S::of_top(top);
            const S t_iface = entered_top ? S::of_top(top) : S::of_bottom(bottom);
            float uc = rng.uniform();
            Vec2f u = rng.uniform2();
            const std::optional<BsdfSample> wos =
                t_iface.sample_f(wo, uc, u, mode, kReflTransTransmission);
            uc = rng.uniform();
            u = rng.uniform2();
            const std::optional<BsdfSample> wis =
                t_iface.sample_f(wi, uc, u, flip(mode), kReflTransTransmission);
            if (!(wos && !wos->f.is_black() && wos->pdf > 0.f && wis && !wis->f.is_black() &&
                  wis->pdf > 0.f))
                continue;
            if (!is_non_specular_flags(t_iface.flags())) {
                // A specular entrance fixes both inner directions: the reflection's density.
                pdf_sum += r_iface.pdf(-wos->wi, -wis->wi, mode);
            } else {
                uc = rng.uniform();
                u = rng.uniform2();
                const std::optional<BsdfSample> rs = r_iface.sample_f(-wos->wi, uc, u, mode);
                if (rs && !rs->f.is_black() && rs->pdf > 0.f) {
                    if (!is_non_specular_flags(r_iface.flags())) {
                        pdf_sum += t_iface.pdf(-rs->wi, wi, mode);
                    } else {
                        // Two estimates of the product's density, combined with MIS (PBRT
                        // section 14.3.2, "Evaluate TRT term for PDF estimate").
                        const float r_pdf = r_iface.pdf(-wos->wi, -wis->wi, mode);
                        pdf_sum += power_heuristic(wis->pdf, r_pdf) * r_pdf;
                        const float t_pdf = t_iface.pdf(-rs->wi, wi, mode);
                        pdf_sum += power_heuristic(rs->pdf, t_pdf) * t_pdf;
                    }
                }
            }
        } else {
            // Transmission through both interfaces (TT).
            const S to_iface = entered_top ? S::of_top(top) : S::of_bottom(bottom);
            const S ti_iface = entered_top ? S::of_bottom(bottom) : S::of_top(top);
            float uc = rng.uniform();
            Vec2f u = rng.uniform2();
            const std::optional<BsdfSample> wos = to_iface.sample_f(wo, uc, u, mode);
            if (!usable(wos) || wos->is_reflection())
                continue;
            uc = rng.uniform();
            u = rng.uniform2();
            const std::optional<BsdfSample> wis = ti_iface.sample_f(wi, uc, u, flip(mode));
            if (!usable(wis) || wis->is_reflection())
                continue;
            if (is_specular_flags(to_iface.flags()))
                pdf_sum += ti_iface.pdf(-wos->wi, wi, mode);
            else if (is_specular_flags(ti_iface.flags()))
                pdf_sum += to_iface.pdf(wo, -wis->wi, mode);
            else
                pdf_sum +=
                    0.5f * (to_iface.pdf(wo, -wis->wi, mode) + ti_iface.pdf(-wos->wi, wi, mode));
        }
    }
    // Mixed with a uniform density so that no direction f reaches has a zero pdf.
    return lerp(0.9f, kInv4Pi, pdf_sum / float(n_samples));
}

template struct LayeredBxdf<DielectricBxdf, DiffuseBxdf, true>;
template struct LayeredBxdf<DielectricBxdf, ConductorBxdf, true>;

}  // namespace tessera
