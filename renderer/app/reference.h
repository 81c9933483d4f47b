// Reference images for `tessera converge`: reading and checking a given one, or rendering one
// (uniform, deterministic, many samples) and caching it by scene content and settings.
//
// Cache. A reference is stored as <cache_dir>/ref-<key>.exr (R, G, B plus `variance.{R,G,B}`,
// below) with a readable ref-<key>.json beside it. The key hashes the scene's content hash
// (scene_content_hash), the resolution, samples per pixel, maximum depth, sequence seed, the
// reference method and the Tessera version; anything else that changes the picture lives in the
// scene files. A reference whose files are unchanged is read back; a changed scene, include,
// mesh, texture or setting gives a new key and a new render. Writes are atomic (image_io.h), so
// an interrupted render leaves no entry behind.
//
// Noise floor. A reference is itself a Monte Carlo estimate: E[MSE(test, ref)] = true MSE(test)
// + mean Var(ref) when the two are independent (they are: the reference uses its own seeds, see
// reference_seed). To estimate Var(ref) the reference is the mean of two renders of spp / 2
// samples with independent scrambles (seeds `seed` and `seed` + 1): with R1, R2 their images,
// E[(R1 - R2)^2] / 4 = Var((R1 + R2) / 2) per pixel, unbiased. (The film's half buffer would give
// no such estimate: the even and odd samples of one Owen-scrambled Sobol sequence are negatively
// correlated, and (I - A)^2 overestimated the floor tenfold in a test.) The cached EXR keeps the
// estimate as `variance.{R,G,B}`, and the convergence plots draw its mean as a floor.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "renderer/scene/scene.h"
#include "sampling/image_metrics.h"

namespace tessera {

/// Files a render of `scene_path` reads: the scene file itself first, then (sorted, without
/// repeats) its Include/Import files, spectrum files and every string parameter that names an
/// existing file (meshes, image textures, environment maps), resolved as the scene builder does;
/// for .obj, its mtllib files and the texture maps they name. The Film's output "filename" is
/// not an input. Throws SceneError when the scene cannot be parsed.
std::vector<std::string> scene_dependencies(const std::string &scene_path);

/// 32 hex digits (128-bit farmhash fingerprint) over the dependencies' contents and their names
/// relative to the scene file's folder: unchanged when the folder moves, changed when any
/// dependency's bytes change. Throws SceneError (unparsable scene) or std::runtime_error
/// (unreadable dependency).
std::string scene_content_hash(const std::string &scene_path);

/// The default cache folder: $XDG_CACHE_HOME/tessera, else $HOME/.cache/tessera, else
/// <temp>/tessera-cache.
std::string default_cache_dir();

/// The seed a reference uses for a render seeded `seed`: a different one, so that reference and
/// test image do not share sample values (same seed, same pixel, same index -> same path).
inline uint32_t reference_seed(uint32_t seed) {
    return seed ^ 0x52454631u;
}  // "REF1"

/// What a reference render is made of (the cache key covers all but threads and quiet).
struct ReferenceSettings {
    uint32_t width = 0, height = 0;
    uint32_t spp = 4096;   ///< uniform samples per pixel (two renders of spp / 2, rounded up)
    int max_depth = 5;     ///< path depth
    uint32_t seed = 0;     ///< seed of the first half (reference_seed of the test renders' seed)
    uint32_t threads = 0;  ///< worker threads (0: all cores); the image does not depend on it
    bool quiet = false;    ///< no progress bar
};

/// The cache key of a reference: 32 hex digits over the scene hash and the settings.
std::string reference_key(const std::string &scene_hash, const ReferenceSettings &settings);

/// A reference image in memory.
struct Reference {
    sampling::RgbImage image;  ///< linear RGB
    /// Estimated variance of each pixel's mean, 3 floats per pixel; empty when unknown (a
    /// reference given with --reference that has no variance layer).
    std::vector<float> variance;
    std::string path;         ///< the EXR it was read from or written to
    std::string key;          ///< cache key ("" for a given reference)
    bool from_cache = false;  ///< read back from the cache
    bool rendered = false;    ///< rendered by this call
    double render_s = 0;      ///< wall time of that render
    /// Mean estimated variance over pixels and channels: the expected MSE a perfect test
    /// image would show against this reference. < 0 when unknown.
    double noise_mse() const;
    /// The same for relMSE (variance / (ref^2 + 0.01), averaged). < 0 when unknown.
    double noise_rel_mse() const;
};

/// Reads and checks a reference image: it must exist, be readable, be width x height and have
/// only finite values. Reads `variance.{R,G,B}` when present. Throws SceneError
/// ("PATH:0: message") otherwise; reads nothing else.
Reference load_reference(const std::string &path, uint32_t width, uint32_t height);

/// The cached reference of `scene` (loaded from `scene_path` with the settings' resolution and
/// depth) if the cache has a valid one; otherwise renders it (uniform, deterministic:
/// bit-identical for any thread count), writes it to the cache, and returns it. A corrupt cache
/// entry is reported and rebuilt. Throws SceneError / std::runtime_error (unwritable cache).
Reference cached_reference(const Scene &scene, const std::string &scene_path,
                           const ReferenceSettings &settings, const std::string &cache_dir);

/// Renders a reference into memory (what cached_reference does on a miss; tests): the mean of
/// two independent half renders and the variance estimate from their difference.
Reference render_reference(const Scene &scene, const ReferenceSettings &settings);

}  // namespace tessera
