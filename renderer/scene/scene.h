// A renderable scene: geometry, materials, lights, textures, camera and render settings, built
// from a SceneDesc (pbrt-v4 file or OBJ) by scene_builder.cpp.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "renderer/camera/camera.h"
#include "renderer/scene/geometry.h"
#include "renderer/lights/light_sampler.h"
#include "renderer/lights/lights.h"
#include "renderer/media/medium.h"
#include "renderer/shading/material.h"
#include "renderer/shading/texture.h"
#include "sampling/aov_set.h"
#include "sampling/sequence.h"

namespace tessera {

/// What a scene has. Computed at load; what a scene lacks costs nothing (no texture system,
/// no environment distribution, no light sampler work for absent light types).
struct SceneFeatures {
    bool textures = false;        ///< any texture (procedural or image)
    bool image_textures = false;  ///< the OpenImageIO TextureSystem exists
    bool specular = false;        ///< some material has a specular (delta) lobe
    bool transmission = false;    ///< some material transmits
    bool emissive_shapes = false; ///< area lights
    bool environment = false;     ///< an infinite light
    bool environment_map = false; ///< an image-based infinite light (2D distribution built)
    bool delta_lights = false;    ///< point, spot or distant lights
    bool instances = false;       ///< object instancing
    bool quadrics = false;        ///< spheres or disks (user geometry)
    bool curves = false;          ///< pbrt "curve" shapes (Embree curves)
    bool media = false;           ///< participating media (the volumetric path tracer runs)
    std::string describe() const;
};

/// Settings that come from the scene file and can be overridden on the command line.
struct RenderSettings {
    int width = 1280, height = 720;  ///< pbrt-v4 film defaults
    int spp = 16;                    ///< pbrt-v4 sampler default pixelsamples
    int max_depth = 5;               ///< pbrt-v4 path integrator default
    bool regularize = false;
    /// The scene's Integrator is pbrt-v4's "volpath" (its default) rather than "path": the two
    /// treat surfaces without a material ("interface") differently for shadow rays, and only
    /// volpath renders participating media.
    bool volpath = true;
    uint32_t seed = 0;
    /// The points every sampler of the render draws (sampling/sequence.h): the scene's
    /// Sampler "sobol" or "halton" asks for one global low-discrepancy sequence, the others
    /// for padded 2D patterns.
    sampling::SamplePattern sample_pattern = sampling::SamplePattern::Padded;
    std::string output;              ///< Film "filename" (pbrt default "pbrt.exr")
    /// pbrt-v4 sensor imaging ratio: (shutterclose - shutteropen) * Film "iso" / 100.
    float image_scale = 1.f;
    /// Film "whitebalance" (pbrt-v4 PixelSensor): a linear-sRGB matrix (row-major) applied to
    /// every sample when `white_balanced`. pbrt-v4's RGBFilm clamps a sample to
    /// maxcomponentvalue first and white-balances when it writes the pixel; the path tracer
    /// does the same (scale, clamp, balance).
    bool white_balanced = false;
    std::array<float, 9> white_balance{1, 0, 0, 0, 1, 0, 0, 0, 1};
    /// The white balance alone (the identity unless `white_balanced`).
    Rgb balance(Rgb L) const {
        if (!white_balanced) return L;
        const std::array<float, 9> &m = white_balance;
        return {m[0] * L.r + m[1] * L.g + m[2] * L.b, m[3] * L.r + m[4] * L.g + m[5] * L.b,
                m[6] * L.r + m[7] * L.g + m[8] * L.b};
    }
    /// Radiance in film units before the clamp: image_scale, then the white balance (the
    /// Whitted real-time integrator, which clamps after it).
    Rgb to_film(Rgb L) const { return balance(L * image_scale); }
    /// Film "maxcomponentvalue": a sample's RGB is scaled down so its largest component is at
    /// most this (pbrt-v4 RGBFilm::AddSample); +inf = off.
    float max_component = kInfinity;
    /// AOVs the film keeps and the EXR gets (pbrt-v4: Film "rgb" none, Film "gbuffer" albedo,
    /// normal and depth), or --aov.
    sampling::AovSet aovs;
    std::string scene_file;
};

/// Command-line overrides; unset fields keep the scene file's values.
struct SceneOverrides {
    std::optional<int> width, height, spp, max_depth;
    std::optional<uint32_t> seed;
    /// --clamp: the firefly clamp, RenderSettings::max_component (Film "maxcomponentvalue").
    /// Default-initialised so that positional SceneOverrides{...} lists need not name it.
    std::optional<float> max_component = std::nullopt;
    /// Specialization bits (renderer/scene/specialize.h) forced onto the general path where the scene
    /// is built (the "alpha" one: filter callbacks on every mesh).
    uint32_t no_specialize = 0;
    /// --aov: the AOVs to keep, RenderSettings::aovs (overrides the Film type's).
    std::optional<sampling::AovSet> aovs = std::nullopt;
};

class Scene {
  public:
    std::unique_ptr<Geometry> geometry;
    std::unique_ptr<TextureSet> textures;
    std::vector<std::unique_ptr<Material>> materials;
    std::vector<std::unique_ptr<Light>> lights;
    std::vector<const Light *> infinite_lights;
    std::unique_ptr<PowerLightSampler> light_sampler;
    std::unique_ptr<PerspectiveCamera> camera;
    /// Participating media (MakeNamedMedium), indexed by SurfaceInteraction::medium_inside /
    /// medium_outside; empty without media or with Integrator "path".
    std::vector<std::unique_ptr<Medium>> media;
    int camera_medium = -1;  ///< the medium camera rays start in (-1: vacuum)
    PixelFilter filter;
    RenderSettings settings;
    SceneFeatures features;
    /// One paragraph for logs: sizes, features, light count.
    std::string describe() const;
};

/// Builds a scene from its description. Throws SceneError (file:line) on bad input.
std::unique_ptr<Scene> build_scene(const SceneDesc &desc, const SceneOverrides &overrides);

/// Loads a scene file by extension: .pbrt (pbrt-v4), .obj (with a default camera and light),
/// .ply (a single mesh with a default camera and light). Throws SceneError on bad input.
std::unique_ptr<Scene> load_scene(const std::string &path, const SceneOverrides &overrides);

}  // namespace tessera
