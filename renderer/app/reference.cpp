// Reference images: scene content hashes, the reference cache, checks of given references.
#include "renderer/app/reference.h"


#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "renderer/util/image_io.h"
#include "renderer/util/json_io.h"
#include "renderer/util/gzip_io.h"
#include "renderer/integrators/integrators.h"
#include "renderer/input/pbrt_parser.h"
#include "renderer/app/render.h"
#include "scheduler/adaptive_scheduler.h"
#include "scheduler/progressive_run.h"

namespace tessera {

namespace fs = std::filesystem;

namespace {

/// MurmurHash3's 64-bit finaliser (Appleby): every input bit reaches every output bit.
uint64_t fmix64(uint64_t k) {
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdULL;
    k ^= k >> 33;
    k *= 0xc4ceb9fe1a85ec53ULL;
    k ^= k >> 33;
    return k;
}

/// A 128-bit content fingerprint (a cache key, not a cryptographic hash): two FNV-1a lanes of
/// different offset bases over 8-byte words, each finalised with the length and the other.
std::string hex128(const std::string &bytes) {
    uint64_t a = 0xcbf29ce484222325ULL, b = 0x84222325cbf29ce4ULL;
    constexpr uint64_t kPrime = 0x100000001b3ULL;
    size_t i = 0;
    for (; i + 8 <= bytes.size(); i += 8) {
        uint64_t w;
        std::memcpy(&w, bytes.data() + i, 8);
        a = (a ^ w) * kPrime;
        a = (a << 31) | (a >> 33);  // the rotations carry high bits down
        b = (b ^ (w + 0x9e3779b97f4a7c15ULL)) * kPrime;
        b = (b << 29) | (b >> 35);
    }
    for (; i < bytes.size(); ++i) {
        const uint64_t c = static_cast<unsigned char>(bytes[i]);
        a = (a ^ c) * kPrime;
        b = (b ^ (c + 0x9e3779b97f4a7c15ULL)) * kPrime;
    }
    const uint64_t n = bytes.size();
    const uint64_t hi = fmix64(a ^ fmix64(b + n)), lo = fmix64(b ^ fmix64(a ^ n));
    char buf[40];
    std::snprintf(buf, sizeof buf, "%016llx%016llx", (unsigned long long)hi,
                  (unsigned long long)lo);
    return buf;
}

bool read_bytes(const std::string &path, std::string *out) {
    std::ifstream f(path, std::ios::binary);
    if (!f)
        return false;
    std::ostringstream ss;
    ss << f.rdbuf();
    *out = ss.str();
    return bool(f) || f.eof();
}

bool is_file(const fs::path &p) {
    std::error_code ec;
    return fs::is_regular_file(p, ec);
}

// A relative name against the main file's folder, then the naming file's folder (as the scene
// builder resolves meshes and textures); "" when neither is an existing file.
std::string existing_file(const std::string &base_dir, const FileLoc &loc,
                          const std::string &name) {
    if (name.empty() || name.size() > 4096)
        return {};
    fs::path p(name);
    if (p.is_absolute())
        return is_file(p) ? p.string() : std::string();
    fs::path main = base_dir.empty() ? p : fs::path(base_dir) / p;
    if (is_file(main))
        return main.string();
    fs::path alt = fs::path(loc.file).parent_path() / p;
    return is_file(alt) ? alt.string() : std::string();
}

// Adds every string parameter of `ps` that names an existing file.
void add_param_files(const ParamSet &ps, const std::string &base_dir, const FileLoc &loc,
                     std::set<std::string> &out) {
    for (const Param &p : ps.params) {
        if (p.type != "string")
            continue;
        for (const std::string &s : p.strings) {
            std::string f = existing_file(base_dir, p.loc.file.empty() ? loc : p.loc, s);
            if (!f.empty())
                out.insert(f);
        }
    }
}

// The files an OBJ's "mtllib" lines name, and the "map_*" / "bump" / "norm" files of those.
void add_obj_files(const std::string &obj, std::set<std::string> &out) {
    const fs::path dir = fs::path(obj).parent_path();
    auto names_after = [](const std::string &text, auto &&accept) {
        std::istringstream is(text);
        std::string line;
        std::vector<std::string> names;
        while (std::getline(is, line)) {
            std::istringstream ls(line);
            std::string key, last, word;
            if (!(ls >> key) || !accept(key))
                continue;
            while (ls >> word)
                last = word;  // options come first; the file name is last
            if (!last.empty())
                names.push_back(last);
        }
        return names;
    };
    std::string text;
    if (!read_bytes(obj, &text))
        return;
    for (const std::string &m :
         names_after(text, [](const std::string &k) { return k == "mtllib"; })) {
        fs::path mtl = dir / m;
        std::string mtext;
        if (!read_bytes(mtl.string(), &mtext))
            continue;
        out.insert(mtl.string());
        for (const std::string &t : names_after(mtext, [](const std::string &k) {
                 return k.starts_with("map_") || k == "bump" || k == "norm" || k == "disp";
             }))
            if (is_file(dir / t))
                out.insert((dir / t).string());
    }
}

}  // namespace

std::vector<std::string> scene_dependencies(const std::string &scene_path) {
    std::set<std::string> deps;
    std::string ext = fs::path(strip_gz_extension(scene_path)).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (ext == ".obj") {
        add_obj_files(scene_path, deps);
    } else if (ext != ".ply") {
        SceneDesc d = parse_pbrt_file(scene_path);
        for (const std::string &f : d.read_files)
            deps.insert(f);
        for (const ShapeDesc &s : d.shapes)
            add_param_files(s.params, s.base_dir, s.loc, deps);
        for (const auto &[name, o] : d.objects)
            for (const ShapeDesc &s : o.shapes)
                add_param_files(s.params, s.base_dir, s.loc, deps);
        for (const auto &[name, m] : d.materials)
            add_param_files(m.params, m.base_dir, m.loc, deps);
        for (const TextureDesc &t : d.textures)
            add_param_files(t.params, t.base_dir, t.loc, deps);
        for (const LightDesc &l : d.lights)
            add_param_files(l.params, l.base_dir, l.loc, deps);
        // Camera, sampler, integrator and filter take no input files in pbrt-v4 except the
        // camera's lens file; the Film's "filename" is the output and is left out.
        const std::string dir = fs::path(scene_path).parent_path().string();
        for (const OptionDesc *o : {&d.camera, &d.sampler, &d.integrator, &d.filter})
            add_param_files(o->params, dir, o->loc, deps);
    }
    deps.erase(scene_path);
    std::vector<std::string> out{scene_path};
    out.insert(out.end(), deps.begin(), deps.end());
    return out;
}

std::string scene_content_hash(const std::string &scene_path) {
    const fs::path dir = fs::path(scene_path).parent_path();
    std::string manifest;
    for (const std::string &f : scene_dependencies(scene_path)) {
        std::string bytes;
        if (!read_bytes(f, &bytes))
            throw std::runtime_error(f + ": cannot read (scene input)");
        // Names relative to the scene's folder, so that moving the folder keeps the hash.
        std::error_code ec;
        fs::path rel = fs::proximate(fs::path(f), dir.empty() ? fs::path(".") : dir, ec);
        manifest += (ec ? fs::path(f) : rel).generic_string();
        manifest += '\n';
        manifest += hex128(bytes);
        manifest += '\n';
    }
    return hex128(manifest);
}

std::string default_cache_dir() {
    const char *xdg = std::getenv("XDG_CACHE_HOME");
    if (xdg && *xdg)
        return (fs::path(xdg) / "tessera").string();
    const char *home = std::getenv("HOME");
    if (home && *home)
        return (fs::path(home) / ".cache" / "tessera").string();
    return (fs::temp_directory_path() / "tessera-cache").string();
}

std::string reference_key(const std::string &scene_hash, const ReferenceSettings &s) {
    std::ostringstream os;
    // v2: the mean of two independent half renders (v1: one render, half-buffer variance).
    os << "tessera-reference v2\nscene " << scene_hash << "\nresolution " << s.width << "x"
       << s.height << "\nspp " << s.spp << "\nmax_depth " << s.max_depth << "\nseed " << s.seed
       << "\nversion " << TESSERA_VERSION << "\n";
    return hex128(os.str());
}

double Reference::noise_mse() const {
    if (variance.empty())
        return -1;
    double sum = 0;
    for (float v : variance)
        sum += v;
    return sum / double(variance.size());
}

double Reference::noise_rel_mse() const {
    if (variance.empty() || variance.size() != image.data.size())
        return -1;
    double sum = 0;
    for (size_t i = 0; i < variance.size(); ++i) {
        const double r = image.data[i];
        sum += variance[i] / (r * r + 0.01);
    }
    return sum / double(variance.size());
}

Reference load_reference(const std::string &path, uint32_t width, uint32_t height) {
    const std::string where = path + ":0: ";
    std::error_code ec;
    if (!fs::exists(path, ec))
        throw SceneError(where + "reference image not found");
    Reference ref;
    ref.path = path;
    try {
        ref.image = read_image_rgb(path);
    } catch (const std::exception &e) {
        throw SceneError(where + "cannot read the reference image (" + e.what() + ")");
    }
    if (ref.image.width != width || ref.image.height != height)
        throw SceneError(where + "the reference is " + std::to_string(ref.image.width) + "x" +
                         std::to_string(ref.image.height) + " but the renders are " +
                         std::to_string(width) + "x" + std::to_string(height) +
                         " (render the reference at that size, or pass --resolution " +
                         std::to_string(ref.image.width) + "x" + std::to_string(ref.image.height) +
                         ")");
    if (size_t bad = sampling::nonfinite_count(ref.image)) {
        size_t first = 0;
        while (std::isfinite(ref.image.data[first]))
            ++first;
        const size_t px = first / 3;
        throw SceneError(where + "the reference has " + std::to_string(bad) +
                         " non-finite values (NaN or Inf), the first at pixel (" +
                         std::to_string(px % width) + ", " + std::to_string(px / width) +
                         "); errors against it would be meaningless");
    }
    try {
        uint32_t w = 0, h = 0;
        std::vector<float> var =
            read_image_channels(path, {"variance.R", "variance.G", "variance.B"}, w, h);
        bool ok = w == width && h == height &&
                  std::all_of(var.begin(), var.end(), [](float v) { return std::isfinite(v); });
        if (ok)
            ref.variance = std::move(var);
    } catch (const std::exception &) {
        // No variance layer: the noise floor is unknown.
    }
    return ref;
}

Reference render_reference(const Scene &scene, const ReferenceSettings &s) {
    auto t0 = std::chrono::steady_clock::now();
    // Two independent halves (reference.h, "Noise floor"), each uniform and deterministic.
    const uint32_t half_spp = std::max(1u, (s.spp + 1) / 2);
    std::vector<float> halves[2];
    for (uint32_t k = 0; k < 2; ++k) {
        sampling::Film film(s.width, s.height);
        std::unique_ptr<SampleSource> integrator =
            make_path_tracer(scene, s.seed + k, s.max_depth);
        sched::AdaptiveOptions o = uniform_scheduler_options(scene, s.threads, s.quiet);
        o.max_spp = half_spp;
        o.min_spp = std::min(o.min_spp, o.max_spp);
        o.seed = s.seed + k;
        o.deterministic = true;
        sched::ProgressiveRun(*integrator, film, o).advance(0, nullptr);
        halves[k] = film.beauty_rgb();
    }
    Reference ref;
    ref.image = sampling::RgbImage(s.width, s.height);
    ref.variance.resize(halves[0].size());
    for (size_t i = 0; i < halves[0].size(); ++i) {
        const double a = halves[0][i], b = halves[1][i];
        ref.image.data[i] = float(0.5 * (a + b));
        ref.variance[i] = float(0.25 * (a - b) * (a - b));
    }
    ref.rendered = true;
    ref.render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return ref;
}

Reference cached_reference(const Scene &scene, const std::string &scene_path,
                           const ReferenceSettings &s, const std::string &cache_dir) {
    const std::string hash = scene_content_hash(scene_path);
    const std::string key = reference_key(hash, s);
    const fs::path dir(cache_dir.empty() ? default_cache_dir() : cache_dir);
    const fs::path exr = dir / ("ref-" + key + ".exr"), meta = dir / ("ref-" + key + ".json");
    std::error_code ec;
    if (fs::exists(exr, ec)) {
        try {
            Reference ref = load_reference(exr.string(), s.width, s.height);
            ref.key = key;
            ref.from_cache = true;
            return ref;
        } catch (const SceneError &e) {
            // e.what() starts with "<path>:0: ", which the warning prints already.
            std::string why = e.what();
            const std::string prefix = exr.string() + ":0: ";
            if (why.rfind(prefix, 0) == 0)
                why = why.substr(prefix.size());
            warn(FileLoc{exr.string(), 0},
                 "cached reference unusable, rebuilding it (" + why + ")");
        }
    }
    fs::create_directories(dir, ec);
    if (!fs::is_directory(dir, ec))
        throw std::runtime_error(dir.string() + ": cannot create the reference cache folder");

    Reference ref = render_reference(scene, s);
    write_exr(exr.string(), s.width, s.height,
              {ImageLayer{"", {"R", "G", "B"}, ref.image.data, false},
               ImageLayer{"variance", {"R", "G", "B"}, ref.variance, true}});
    nlohmann::json j;
    j["scene"] = scene_path;
    j["scene_hash"] = hash;
    j["width"] = s.width;
    j["height"] = s.height;
    j["spp"] = s.spp;
    j["max_depth"] = s.max_depth;
    j["seed"] = s.seed;
    j["method"] = "mean of two uniform renders of spp/2, seeds seed and seed+1";
    j["version"] = TESSERA_VERSION;
    j["render_s"] = ref.render_s;
    j["dependencies"] = scene_dependencies(scene_path);
    write_json_atomic(meta.string(), j);
    ref.path = exr.string();
    ref.key = key;
    return ref;
}

}  // namespace tessera
