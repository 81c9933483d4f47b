// pbrt-v4 materials: turn texture-evaluated parameters into a Bsdf at a shading point.
//
// Supported: diffuse, diffusetransmission, conductor, dielectric, thindielectric, coateddiffuse
// and coatedconductor (pbrt-v4's stochastic layered BSDF: CoatedDiffuseBxdf, CoatedConductorBxdf,
// renderer/shading/layered_bxdf.h), hair (HairBxdf), interface (no surface: rays pass through), mix
// (pbrt-v4's deterministic per-point choice). Unknown types warn with file:line and render as
// diffuse 0.5.
// Every material but hair honours "displacement" (bump mapping) and "normalmap" (a
// tangent-space normal map image, read linearly).
// Parameter names and defaults are pbrt-v4's (materials.cpp); see bsdf.h for the models.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "renderer/shading/bsdf.h"
#include "renderer/util/interaction.h"
#include "renderer/input/scene_desc.h"
#include "renderer/shading/texture.h"

namespace tessera {

class Material {
  public:
    virtual ~Material() = default;
    /// The BSDF at a shading point; nullopt for "interface" (the ray continues). `tc` carries
    /// the texture lookup point and footprint. Thread-safe.
    virtual std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                         const TextureEvalContext &tc) const = 0;
    /// Union of the lobes this material can produce (BxdfFlags), for SceneFeatures.
    virtual uint8_t possible_flags() const = 0;
    /// True if the material reads a non-constant texture (its parameters, or a bump or normal
    /// map): what the real-time modes' "texture existence" attribute reports.
    bool textured() const { return bumped() || reads_texture(); }
    /// The reflectance when this material is a Lambertian with a constant reflectance and no
    /// bump or normal map (get_bsdf then always returns a DiffuseBxdf of it in the frame
    /// Frame::from_xz(si.dpdu, si.ns)); nullopt otherwise. The path tracer's Lambertian-only
    /// specialisation reads it.
    std::optional<Rgb> constant_lambertian() const {
        return bumped() ? std::nullopt : lambertian_reflectance();
    }
    /// The reflectance at `tc` when this material is a Lambertian (constant or textured) with
    /// no bump or normal map: exactly the DiffuseBxdf reflectance get_bsdf would build for the
    /// same context; nullopt for every other material. Lets a caller that supplies its own
    /// shading frame (the Whitted integrator's shade()) skip get_bsdf. Thread-safe.
    std::optional<Rgb> lambertian_at(const TextureEvalContext &tc) const {
        return bumped() ? std::nullopt : lambertian_reflectance_at(tc);
    }
    virtual std::string describe() const = 0;

    /// Sets pbrt's "displacement" texture: bump mapping of the shading normal.
    void set_displacement(const FloatTexture *displacement) { displacement_ = displacement; }
    /// True for pbrt-v4's "interface" material: no surface, only a boundary between media.
    virtual bool is_interface() const { return false; }
    /// Sets pbrt's "normalmap": a tangent-space normal map (shared, immutable once loaded).
    void set_normal_map(std::shared_ptr<const struct NormalMapImage> map) { normal_map_ = map; }

  protected:
    /// True if a parameter of the material is a non-constant texture.
    virtual bool reads_texture() const = 0;
    /// A constant Lambertian's reflectance (bump mapping aside); nullopt for everything else.
    virtual std::optional<Rgb> lambertian_reflectance() const { return std::nullopt; }
    /// A Lambertian's reflectance at tc (bump mapping aside); nullopt for everything else.
    virtual std::optional<Rgb> lambertian_reflectance_at(const TextureEvalContext &) const {
        return std::nullopt;
    }
    bool bumped() const { return displacement_ != nullptr || normal_map_ != nullptr; }
    /// The shading frame at `si`: from the shading normal and dpdu, bump-mapped when the
    /// material has a displacement texture (pbrt-v4 BumpMap: finite differences of the
    /// displacement over half the uv footprint, or 0.0005 without one; the displacement times
    /// dn/du term is omitted since Tessera keeps no normal derivatives). Thread-safe.
    Frame frame(const SurfaceInteraction &si, const TextureEvalContext &tc) const;

  private:
    const FloatTexture *displacement_ = nullptr;
    std::shared_ptr<const struct NormalMapImage> normal_map_;
};

/// A normal map image: linear RGB, row 0 at the top (pbrt looks up (u, 1 - v)), wrap repeat.
struct NormalMapImage {
    int width = 0, height = 0;
    std::vector<float> rgb;
    /// Bilinear lookup of the tangent-space normal (2 rgb - 1, normalised) at uv.
    Vec3f lookup(Vec2f uv) const;
    /// Reads `path` with OpenImageIO without any colour decoding. Throws SceneError (loc).
    static std::shared_ptr<const NormalMapImage> load(const std::string &path, const FileLoc &loc);
};

/// Builds every material of a scene, indexed by name. `materials` are the scene's named and
/// anonymous materials (mix refers to others by name). Throws SceneError with file:line.
class MaterialSet {
  public:
    MaterialSet(const std::map<std::string, MaterialDesc> &descs, TextureSet &textures);
    /// Index of a material by name, or -1 if absent.
    int index(const std::string &name) const;
    /// Index of the default material (pbrt-v4: diffuse, reflectance 0.5), created on demand.
    int default_index();
    std::vector<std::unique_ptr<Material>> release() { return std::move(materials_); }
    const std::vector<std::unique_ptr<Material>> &materials() const { return materials_; }

  private:
    int build(const std::string &name, const std::map<std::string, MaterialDesc> &descs,
              TextureSet &textures, int depth);
    std::vector<std::unique_ptr<Material>> materials_;
    std::map<std::string, int> by_name_;
    int default_ = -1;
};

}  // namespace tessera
