// LayeredBxdf: two BxDFs stacked with a homogeneous slab of medium between them, evaluated
// stochastically by a random walk through the layers, as pbrt-v4's LayeredBxDF<TopBxDF,
// BottomBxDF, twoSided> does (PBRT 4th ed., section 14.3.2; Guo, Hasan, Yan and Zhao 2018,
// "Position-Free Monte Carlo Simulation for Arbitrary Layered BSDFs"). pbrt-v4's
// "coateddiffuse" is LayeredBxdf<DielectricBxdf, DiffuseBxdf, true> and "coatedconductor"
// LayeredBxdf<DielectricBxdf, ConductorBxdf, true> (renderer/shading/bsdf.h names them).
//
// Geometry: the top interface sits at z = thickness, the bottom one at z = 0, both with the
// local frame's normal +z; the slab has unit extinction (sigma_t = 1, so `thickness` is in
// mean free paths), single-scattering albedo `albedo` and a Henyey-Greenstein phase function of
// asymmetry g (renderer/shading/phase_function.h). Without albedo the medium only attenuates,
// Tr(dz, w) = exp(-|dz / w.z|).
//
// f(wo, wi): the entrance interface's reflection f_enter(wo, wi), plus `n_samples` random walks
//   each started by sampling the entrance interface's transmission from wo and the exit
//   interface's transmission from wi (the adjoint: the other transport mode), then bouncing
//   between the interfaces (reflection only, Russian roulette past depth 3 when the
//   throughput falls below 0.25, at most `max_depth` segments). At each bounce off the
//   non-exit interface and at each medium scattering event it adds next-event estimates
//   through the exit interface along the presampled wi direction and along the sampled one,
//   weighted by the power heuristic (no MIS where one side is specular). In the medium the
//   distance is sampled exponentially and scattering samples the phase function.
//   NOTE: as in pbrt-v4, the MIS weight of the estimate along the sampled direction w takes
//   the exit interface's density of wi given -w (exitInterface.PDF(-w, wi, mode,
//   Transmission)), where the other strategy's density of w is the exit's density of -w given
//   wi in the adjoint mode; the two differ for a rough interface (by eta^2 and a ratio of
//   cosines), the weights do not sum to 1, and f() comes out above sample_f: by 8-9% for a
//   white diffuse base under a coat of roughness 0.2, 9-19% for a rough coated conductor
//   (tests/renderer/test_layered_bxdf_stat.cpp). pbrt-v4's f() does the same against its own
//   Sample_f, so renders lit through light sampling (area, point, image lights) match
//   pbrt-v4's only with these weights: on tests/fidelity's coated spheres under an area light,
//   the weights of the matching densities made the lit side 4-6% darker than pbrt-v4's.
//   Where Tessera samples a light that pbrt-v4 reaches only by BSDF sampling (a uniform sky,
//   which pbrt-v4's MIS compensation leaves to the BSDF), Tessera is 0.1-0.6% brighter.
// sample_f(wo, uc, u): samples the entrance interface with (uc, u); a reflection is returned
//   as it is; a transmission continues as a random walk (interface and phase-function
//   sampling) until it leaves through an interface. f and pdf are the products along the walk,
//   so f |cos| / pdf is an unbiased weight, but pdf is not the density of wi:
//   pdf_is_proportional is set and MIS must call pdf(). Flags: reflection or transmission by
//   the hemisphere of wi, specular when every event was specular, else glossy.
// pdf(wo, wi): a stochastic estimate of the density of sample_f: the entrance interface's
//   reflection pdf plus the transmit-reflect-transmit (TRT) term, estimated with MIS between
//   the two interfaces' samples where neither is specular (or the transmit-transmit term for
//   a wi on the other side), mixed with a uniform density: lerp(0.9, 1 / (4 pi), estimate),
//   so that it is never 0 where f is not (PBRT section 14.3.2). As in pbrt-v4 the reflection
//   term is the reflection-only sampler's density (not scaled by the R / (R + T) with which
//   sample_f picks it) and the TRT term ignores the refraction's change of solid angle, so the
//   estimate is not normalised (it integrates to 1.2-2.5): it only weighs MIS.
//
// Each call draws its random numbers from its own PCG32 generator (O'Neill 2014) seeded with a
// hash of its arguments (wo and wi for f and pdf, wo, uc and u for sample_f), so f, sample_f and
// pdf are deterministic, pure functions of their arguments: the same call gives the same value
// on any thread, and the renderer stays bit-reproducible. (pbrt-v4 also hashes its --seed into
// the generator; here the walk does not depend on the sampler's seed.) No heap allocation.
// `coherent_seed` replaces the hash of f's and pdf's directions by a fixed seed (see there).
//
// Two-sided (kTwoSided): a wo below the surface is mirrored with wi to the top side, so both
// sides see the top interface first; one-sided, a wo below enters through the bottom
// interface. The walk treats the interfaces as BxDFs with the restricted sampling of
// BxdfReflTrans, so Top and Bottom must provide f(wo, wi, mode), sample_f(wo, uc, u, mode,
// BxdfReflTrans), pdf(wo, wi, mode, BxdfReflTrans) and flags().
//
// The member functions are defined in layered_bxdf.cpp and instantiated there for the two
// combinations bsdf.h uses.
#pragma once

#include <optional>

#include "renderer/shading/bxdf_types.h"
#include "renderer/shading/phase_function.h"

namespace tessera {

/// pbrt-v4's LayeredBxDF (see the file comment). Plain value; every method is const, pure and
/// thread-safe. Instantiated for <DielectricBxdf, DiffuseBxdf, true> and <DielectricBxdf,
/// ConductorBxdf, true>.
template <class Top, class Bottom, bool kTwoSided>
struct LayeredBxdf {
    Top top;
    Bottom bottom;
    float thickness = 0.01f;  ///< slab thickness in mean free paths (> 0: at least FLT_MIN)
    Rgb albedo{0.f};          ///< single-scattering albedo of the slab's medium, in [0, 1]
    float g = 0.f;            ///< Henyey-Greenstein asymmetry of the medium, in [-1, 1]
    int max_depth = 10;       ///< most segments of one random walk (pbrt-v4 "maxdepth")
    int n_samples = 1;        ///< random walks per f() and pdf() estimate (pbrt-v4 "nsamples")
    /// 0 (the default, pbrt-v4's behaviour): f() and pdf() seed their walks with a hash of the
    /// directions, so neighbouring shading points get independent estimates (noise). Nonzero:
    /// every call draws its walks from this seed alone, which makes f() and pdf() smooth
    /// functions of the directions: one fixed set of walks, whose error is a fixed pattern
    /// instead of noise (the deterministic Whitted integrator shades with it). Not a pbrt-v4
    /// parameter; sample_f always hashes its arguments.
    uint32_t coherent_seed = 0;

    LayeredBxdf() = default;
    /// pbrt-v4's constructor: thickness is raised to FLT_MIN; max_depth is clamped to >= 0 and
    /// n_samples to >= 1 (pbrt-v4 divides by n_samples).
    LayeredBxdf(Top top_, Bottom bottom_, float thickness_, Rgb albedo_, float g_, int max_depth_,
                int n_samples_);

    /// Stochastic estimate of the BSDF value (no cosine) for the pair; deterministic for given
    /// arguments. Units: 1/sr. Delta paths (a smooth coat over a smooth base) give 0 here.
    Rgb f(Vec3f wo, Vec3f wi, TransportMode mode) const;
    /// Samples wi by a random walk started with (uc, u); pdf_is_proportional is set.
    std::optional<BsdfSample> sample_f(Vec3f wo, float uc, Vec2f u, TransportMode mode) const;
    /// Stochastic estimate of sample_f's density of wi; deterministic for given arguments; > 0
    /// everywhere (at least 0.1 / (4 pi)). Units: 1/sr.
    float pdf(Vec3f wo, Vec3f wi, TransportMode mode) const;
    /// pbrt-v4's flags: reflection; specular when the top is; diffuse when either interface is
    /// or the medium scatters, else glossy when either is; transmission when both transmit.
    uint8_t flags() const;
};

}  // namespace tessera
