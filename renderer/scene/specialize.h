// Specialised code paths: what a scene does not need costs nothing
// (docs/ARCHITECTURE.md, "The data that flows", item 2).
//
// At load, SceneFeatures says what a scene has; from it the path tracer picks specialised code
// paths. Each one gives the same image as the general path (bit for bit where stated; tests in
// tests/renderer/test_specialize.cpp) and is kept only where it pays on a scene that has the
// property (scripts/bench_specialize.py measures each against the general path, forced with
// `--no-specialize[=NAME,...]`). What each one skips:
//   differentials  Nothing is textured (no texture, bump or normal map): no camera ray
//                  differentials, no screen-space footprints (dpdx, dudx, ...) at hits.
//   lambertian     Every material is a Lambertian with a constant reflectance and no bump or
//                  normal map: the reflectance per material is read once at load; no virtual
//                  material call, no texture evaluation, no BSDF variant per hit (the same
//                  arithmetic as Bsdf's Lambertian code, so bit-identical).
//   cull           A light sample that cannot contribute -- behind the shading surface (zero
//                  BSDF value), on the back of a one-sided emitter, outside a spot cone, zero
//                  radiance -- costs no shadow ray. Counted in --stats shadow_rays_avoided.
//   alpha          Embree intersection-filter callbacks only on alpha-tested meshes; the
//                  general path attaches them to every mesh (they accept every hit of an
//                  opaque one). Chosen where the scene is built (SceneOverrides::no_specialize).
//   packet         On top of "lambertian", where the geometry is opaque triangle meshes only
//                  (no instances, quadrics, curves or alpha tests): a pixel's samples are
//                  traced 8 at a time in lockstep, every ray round as one Embree packet, and
//                  each bounce's arithmetic (hit point, frame, sampler, BSDF, MIS, offsets,
//                  roulette) runs lane-parallel (renderer/integrators/path_packet.cpp); bit-identical.
//   attributes     Real-time frame plugins: the Whitted integrator collects only the attribute
//                  groups (sampling/sample_source.h) the plugin reads and the scene can have --
//                  no secondary-hit attributes without a specular material, no uv without a
//                  texture; the general path collects all (WhittedOptions::specialize).
// Always on (not switchable): Embree geometry types only for what exists (user geometry only
// for spheres, cylinders and disks), no environment
// distribution without an image-based light, converged tiles left after the region-tree check,
// AOV buffers only when asked for.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace tessera {

class Scene;

/// Bits of the switchable specialisations.
enum Specialization : uint32_t {
    kSpecDifferentials = 1u << 0,  ///< "differentials"
    kSpecLambertian = 1u << 1,     ///< "lambertian"
    kSpecCull = 1u << 2,           ///< "cull"
    kSpecAlpha = 1u << 3,          ///< "alpha"
    kSpecAttributes = 1u << 4,     ///< "attributes"
    kSpecPacket = 1u << 5,         ///< "packet"
    kSpecAll = (1u << 6) - 1,
};

/// Parses a comma-separated list of specialisation names ("all" = every one) into bits.
/// Throws std::invalid_argument naming the bad entry and the valid names.
uint32_t parse_specializations(std::string_view list);

/// The names of the bits in `mask`, comma-separated ("none" when empty).
std::string specialization_names(uint32_t mask);

/// The progressive path tracer's specialisations whose property `scene` has (cull applies to
/// every scene with lights). kSpecAttributes, the real-time loop's, is never included.
uint32_t applicable_specializations(const Scene &scene);

/// The specialisations in use: `applicable` less those forced off in `disabled`, and less those
/// that build on one forced off ("packet" needs "lambertian").
uint32_t used_specializations(uint32_t applicable, uint32_t disabled);

}  // namespace tessera
