#include "renderer/shading/material.h"


#include <cstring>
#include <filesystem>

#include "renderer/util/image_io.h"
#include "renderer/util/spectra.h"

namespace tessera {

namespace {

/// Roughness parameters shared by conductor, dielectric and coateddiffuse: "roughness", or
/// "uroughness"/"vroughness" (which win), remapped to GGX alpha when "remaproughness" is true.
/// True for a texture that varies over the surface (not a constant); false for null.
template <class Tex>
bool varying(const Tex *t) {
    return t != nullptr && !t->constant_value();
}

struct Roughness {
    const FloatTexture *u = nullptr, *v = nullptr;
    bool remap = true;
    bool varying() const { return tessera::varying(u) || tessera::varying(v); }

    /// `prefix`: "" for most materials, "conductor." for coatedconductor's base.
    static Roughness from(const ParamSet &ps, TextureSet &tex, const std::string &prefix = "") {
        Roughness r;
        const FloatTexture *rough = tex.float_param(ps, prefix + "roughness", 0.f);
        r.u = ps.find(prefix + "uroughness") ? tex.float_param(ps, prefix + "uroughness", 0.f)
                                             : rough;
        r.v = ps.find(prefix + "vroughness") ? tex.float_param(ps, prefix + "vroughness", 0.f)
                                             : rough;
        r.remap = ps.get_bool("remaproughness", true);
        return r;
    }
    TrowbridgeReitz eval(const TextureEvalContext &tc) const {
        float ur = u->evaluate(tc), vr = v->evaluate(tc);
        if (remap) {
            ur = TrowbridgeReitz::roughness_to_alpha(ur);
            vr = TrowbridgeReitz::roughness_to_alpha(vr);
        }
        return TrowbridgeReitz(ur, vr);
    }
};

class DiffuseMaterial final : public Material {
  public:
    explicit DiffuseMaterial(const SpectrumTexture *reflectance) : reflectance_(reflectance) {
        if (std::optional<Rgb> c = reflectance_->constant_value()) {
            constant_ = true;
            constant_reflectance_ = clamp_unit(*c);
        }
    }
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        DiffuseBxdf b;
        b.reflectance =
            constant_ ? constant_reflectance_ : clamp_unit(reflectance_->evaluate(tc));
        return Bsdf(frame(si, tc), b);
    }
    uint8_t possible_flags() const override { return kBxdfReflection | kBxdfDiffuse; }
    bool reads_texture() const override { return !constant_; }
    std::optional<Rgb> lambertian_reflectance() const override {
        if (!constant_) return std::nullopt;
        return constant_reflectance_;
    }
    std::optional<Rgb> lambertian_reflectance_at(const TextureEvalContext &tc) const override {
        return constant_ ? constant_reflectance_ : clamp_unit(reflectance_->evaluate(tc));
    }
    std::string describe() const override { return "diffuse"; }

    static Rgb clamp_unit(Rgb c) {
        return {clamp(c.r, 0.f, 1.f), clamp(c.g, 0.f, 1.f), clamp(c.b, 0.f, 1.f)};
    }

  private:
    const SpectrumTexture *reflectance_;
    bool constant_ = false;       ///< reflectance_ is constant: use the cached value
    Rgb constant_reflectance_{};  ///< clamp_unit(reflectance_) when constant_
};

class ConductorMaterial final : public Material {
  public:
    ConductorMaterial(const SpectrumTexture *eta, const SpectrumTexture *k,
                      const SpectrumTexture *reflectance, Roughness rough)
        : eta_(eta), k_(k), reflectance_(reflectance), rough_(rough) {}
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        ConductorBxdf b;
        b.distrib = rough_.eval(tc);
        if (reflectance_) {
            b.eta = Rgb(1.f);
            b.k = conductor_k_from_reflectance(reflectance_->evaluate(tc));
        } else {
            b.eta = eta_->evaluate(tc);
            b.k = k_->evaluate(tc);
        }
        return Bsdf(frame(si, tc), b);
    }
    uint8_t possible_flags() const override {
        return kBxdfReflection | kBxdfGlossy | kBxdfSpecular;
    }
    bool reads_texture() const override {
        return varying(eta_) || varying(k_) || varying(reflectance_) || rough_.varying();
    }
    std::string describe() const override { return "conductor"; }

  private:
    const SpectrumTexture *eta_, *k_, *reflectance_;
    Roughness rough_;
};

class DielectricMaterial final : public Material {
  public:
    DielectricMaterial(float eta, Roughness rough) : eta_(eta), rough_(rough) {}
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        DielectricBxdf b;
        b.eta = eta_;
        b.distrib = rough_.eval(tc);
        return Bsdf(frame(si, tc), b);
    }
    uint8_t possible_flags() const override {
        return kBxdfReflection | kBxdfTransmission | kBxdfSpecular | kBxdfGlossy;
    }
    bool reads_texture() const override { return rough_.varying(); }
    std::string describe() const override { return "dielectric eta " + std::to_string(eta_); }

  private:
    float eta_;
    Roughness rough_;
};

/// pbrt-v4 "thindielectric": a window pane (ThinDielectricBxdf).
class ThinDielectricMaterial final : public Material {
  public:
    explicit ThinDielectricMaterial(float eta) : eta_(eta) {}
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        ThinDielectricBxdf b;
        b.eta = eta_;
        return Bsdf(frame(si, tc), b);
    }
    uint8_t possible_flags() const override {
        return kBxdfReflection | kBxdfTransmission | kBxdfSpecular;
    }
    bool reads_texture() const override { return false; }
    std::string describe() const override { return "thindielectric eta " + std::to_string(eta_); }

  private:
    float eta_;
};

/// The random walk's controls of pbrt-v4's coated materials ("maxdepth" 10, "nsamples" 1),
/// read once by the material's Create() branch below.
struct LayerWalk {
    int max_depth = 10;
    int n_samples = 1;

    static LayerWalk from(const ParamSet &ps, const FileLoc &loc) {
        LayerWalk w;
        w.max_depth = ps.get_int("maxdepth", 10);
        w.n_samples = ps.get_int("nsamples", 1);
        if (w.max_depth < 0) {
            warn(loc, "\"maxdepth\" " + std::to_string(w.max_depth) + " is negative; using 0");
            w.max_depth = 0;
        }
        if (w.n_samples < 1) {
            warn(loc, "\"nsamples\" " + std::to_string(w.n_samples) + " is below 1; using 1");
            w.n_samples = 1;
        }
        return w;
    }
};

/// pbrt-v4 treats an interface IOR of 0 as 1 (no interface); a non-finite one too, here.
float interface_eta(float eta) {
    return eta != 0.f && std::isfinite(eta) ? eta : 1.f;
}

/// pbrt-v4 "coateddiffuse" (CoatedDiffuseMaterial::GetBxDF): a DielectricBxdf coat over a
/// DiffuseBxdf in a CoatedDiffuseBxdf, reflectance and albedo clamped to [0, 1], g to [-1, 1].
class CoatedDiffuseMaterial final : public Material {
  public:
    CoatedDiffuseMaterial(const SpectrumTexture *reflectance, const SpectrumTexture *albedo,
                          const FloatTexture *thickness, const FloatTexture *g, float eta,
                          Roughness rough, LayerWalk walk)
        : reflectance_(reflectance),
          albedo_(albedo),
          thickness_(thickness),
          g_(g),
          eta_(interface_eta(eta)),
          rough_(rough),
          walk_(walk) {}
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        CoatedDiffuseBxdf b(DielectricBxdf{eta_, rough_.eval(tc)},
                            DiffuseBxdf{DiffuseMaterial::clamp_unit(reflectance_->evaluate(tc))},
                            thickness_->evaluate(tc),
                            DiffuseMaterial::clamp_unit(albedo_->evaluate(tc)),
                            clamp(g_->evaluate(tc), -1.f, 1.f), walk_.max_depth, walk_.n_samples);
        return Bsdf(frame(si, tc), b);
    }
    uint8_t possible_flags() const override {
        return kBxdfReflection | kBxdfDiffuse | kBxdfGlossy | kBxdfSpecular;
    }
    bool reads_texture() const override {
        return varying(reflectance_) || varying(albedo_) || varying(thickness_) || varying(g_) ||
               rough_.varying();
    }
    std::string describe() const override { return "coateddiffuse"; }

  private:
    const SpectrumTexture *reflectance_, *albedo_;
    const FloatTexture *thickness_, *g_;
    float eta_;
    Roughness rough_;
    LayerWalk walk_;
};

/// pbrt-v4 "hair" (HairMaterial): a HairBxdf whose absorption comes from "sigma_a", else from
/// a colour, else from melanin concentrations (exactly one of the three is set). h is
/// -1 + 2 v: v runs across a curve's width.
class HairMaterial final : public Material {
  public:
    HairMaterial(const SpectrumTexture *sigma_a, const SpectrumTexture *color,
                 const FloatTexture *eumelanin, const FloatTexture *pheomelanin,
                 const FloatTexture *eta, const FloatTexture *beta_m, const FloatTexture *beta_n,
                 const FloatTexture *alpha)
        : sigma_a_(sigma_a),
          color_(color),
          eumelanin_(eumelanin),
          pheomelanin_(pheomelanin),
          eta_(eta),
          beta_m_(beta_m),
          beta_n_(beta_n),
          alpha_(alpha) {}
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        // pbrt-v4 HairMaterial::GetBxDF.
        float bm = clamp(beta_m_->evaluate(tc), 1e-2f, 1.f);
        float bn = clamp(beta_n_->evaluate(tc), 1e-2f, 1.f);
        Rgb sigma_a;
        if (sigma_a_) {
            Rgb v = sigma_a_->evaluate(tc);
            sigma_a = Rgb(std::max(v.r, 0.f), std::max(v.g, 0.f), std::max(v.b, 0.f));
        } else if (color_) {
            sigma_a = HairBxdf::sigma_a_from_reflectance(
                DiffuseMaterial::clamp_unit(color_->evaluate(tc)), bn);
        } else {
            sigma_a = HairBxdf::sigma_a_from_concentration(
                std::max(0.f, eumelanin_->evaluate(tc)), std::max(0.f, pheomelanin_->evaluate(tc)));
        }
        HairBxdf b(-1.f + 2.f * si.uv.y, eta_->evaluate(tc), sigma_a, bm, bn, alpha_->evaluate(tc));
        return Bsdf(frame(si, tc), b);
    }
    uint8_t possible_flags() const override { return kBxdfReflection | kBxdfGlossy; }
    bool reads_texture() const override {
        return varying(sigma_a_) || varying(color_) || varying(eumelanin_) ||
               varying(pheomelanin_) || varying(eta_) || varying(beta_m_) || varying(beta_n_) ||
               varying(alpha_);
    }
    std::string describe() const override { return "hair"; }

  private:
    const SpectrumTexture *sigma_a_, *color_;
    const FloatTexture *eumelanin_, *pheomelanin_, *eta_, *beta_m_, *beta_n_, *alpha_;
};

/// pbrt-v4 "diffusetransmission" (DiffuseTransmissionBxdf).
class DiffuseTransmissionMaterial final : public Material {
  public:
    DiffuseTransmissionMaterial(const SpectrumTexture *reflectance,
                                const SpectrumTexture *transmittance, float scale)
        : reflectance_(reflectance), transmittance_(transmittance), scale_(scale) {}
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        DiffuseTransmissionBxdf b;
        b.r = DiffuseMaterial::clamp_unit(reflectance_->evaluate(tc) * scale_);
        b.t = DiffuseMaterial::clamp_unit(transmittance_->evaluate(tc) * scale_);
        return Bsdf(frame(si, tc), b);
    }
    uint8_t possible_flags() const override {
        return kBxdfReflection | kBxdfTransmission | kBxdfDiffuse;
    }
    bool reads_texture() const override { return varying(reflectance_) || varying(transmittance_); }
    std::string describe() const override { return "diffusetransmission"; }

  private:
    const SpectrumTexture *reflectance_, *transmittance_;
    float scale_;
};

/// pbrt-v4 "coatedconductor" (CoatedConductorMaterial::GetBxDF): a DielectricBxdf coat over a
/// ConductorBxdf in a CoatedConductorBxdf. The conductor's eta and k (or, for a "reflectance",
/// eta 1 and the k that gives it) are divided by the coat's IOR, as pbrt-v4 does: the metal
/// sits in the coat, not in air.
class CoatedConductorMaterial final : public Material {
  public:
    CoatedConductorMaterial(float coat_eta, Roughness coat_rough, const SpectrumTexture *eta,
                            const SpectrumTexture *k, const SpectrumTexture *reflectance,
                            Roughness base_rough, const FloatTexture *thickness,
                            const SpectrumTexture *albedo, const FloatTexture *g, LayerWalk walk)
        : coat_eta_(interface_eta(coat_eta)),
          coat_rough_(coat_rough),
          eta_(eta),
          k_(k),
          reflectance_(reflectance),
          base_rough_(base_rough),
          thickness_(thickness),
          albedo_(albedo),
          g_(g),
          walk_(walk) {}
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        Rgb ce(1.f), ck;
        if (reflectance_) {
            ck = conductor_k_from_reflectance(reflectance_->evaluate(tc));
        } else {
            ce = eta_->evaluate(tc);
            ck = k_->evaluate(tc);
        }
        ConductorBxdf base{base_rough_.eval(tc), ce / coat_eta_, ck / coat_eta_};
        CoatedConductorBxdf b(DielectricBxdf{coat_eta_, coat_rough_.eval(tc)}, base,
                              thickness_->evaluate(tc),
                              DiffuseMaterial::clamp_unit(albedo_->evaluate(tc)),
                              clamp(g_->evaluate(tc), -1.f, 1.f), walk_.max_depth, walk_.n_samples);
        return Bsdf(frame(si, tc), b);
    }
    uint8_t possible_flags() const override {
        return kBxdfReflection | kBxdfDiffuse | kBxdfGlossy | kBxdfSpecular;
    }
    bool reads_texture() const override {
        return coat_rough_.varying() || varying(eta_) || varying(k_) || varying(reflectance_) ||
               base_rough_.varying() || varying(thickness_) || varying(albedo_) || varying(g_);
    }
    std::string describe() const override { return "coatedconductor"; }

  private:
    float coat_eta_;
    Roughness coat_rough_;
    const SpectrumTexture *eta_, *k_, *reflectance_;
    Roughness base_rough_;
    const FloatTexture *thickness_;
    const SpectrumTexture *albedo_;
    const FloatTexture *g_;
    LayerWalk walk_;
};

class InterfaceMaterial final : public Material {
  public:
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &,
                                 const TextureEvalContext &) const override {
        return std::nullopt;
    }
    uint8_t possible_flags() const override { return 0; }
    bool reads_texture() const override { return false; }
    bool is_interface() const override { return true; }
    std::string describe() const override { return "interface"; }
};

/// pbrt-v4 MixMaterial: picks one of two materials per shading point with probability
/// `amount` for the second, using a hash of the point and direction (deterministic, so the
/// choice does not consume sample dimensions).
class MixMaterial final : public Material {
  public:
    MixMaterial(const Material *a, const Material *b, const FloatTexture *amount)
        : a_(a), b_(b), amount_(amount) {}
    std::optional<Bsdf> get_bsdf(const SurfaceInteraction &si,
                                 const TextureEvalContext &tc) const override {
        float amt = amount_->evaluate(tc);
        const Material *m = a_;
        if (amt >= 1.f) {
            m = b_;
        } else if (amt > 0.f) {
            uint32_t words[6];
            std::memcpy(words, &si.p, sizeof(float) * 3);
            std::memcpy(words + 3, &si.wo, sizeof(float) * 3);
            uint64_t h = 1469598103934665603ull;
            for (uint32_t w : words) h = (h ^ w) * 1099511628211ull;
            h ^= h >> 33;
            h *= 0xff51afd7ed558ccdull;
            h ^= h >> 33;
            float u = float(h >> 40) * 0x1p-24f;
            m = u < amt ? b_ : a_;
        }
        if (!m) return std::nullopt;
        return m->get_bsdf(si, tc);
    }
    uint8_t possible_flags() const override {
        return uint8_t((a_ ? a_->possible_flags() : 0) | (b_ ? b_->possible_flags() : 0));
    }
    bool reads_texture() const override {
        return varying(amount_) || (a_ && a_->textured()) || (b_ && b_->textured());
    }
    std::string describe() const override { return "mix"; }

  private:
    const Material *a_, *b_;
    const FloatTexture *amount_;
};

/// Conductor eta/k default: copper (pbrt-v4 "metal-Cu-eta" / "metal-Cu-k").
Rgb copper(bool k) {
    Rgb eta(0.2f, 0.92f, 1.1f), kk(3.9f, 2.45f, 2.14f);
    named_metal("Cu", &eta, &kk);
    return k ? kk : eta;
}

/// Scalar IOR from `name` ("eta" by default) given as a float, a float texture (constant only)
/// or a spectrum (named glass or RGB: dispersion is not modelled, the green value is used).
float scalar_eta(const ParamSet &ps, const FileLoc &loc, float def,
                 const std::string &name = "eta") {
    const Param *p = ps.find(name);
    if (!p) return def;
    if (p->type == "float")
        return ps.get_float(name, def);
    if (p->type == "texture") {
        warn(loc, "textured \"" + name + "\" is not supported; using " + std::to_string(def));
        p->used = true;
        return def;
    }
    std::optional<Rgb> c = ps.get_rgb(name, false, true);
    if (!c) return def;
    if (std::abs(c->r - c->b) > 1e-3f)
        warn(loc, "spectrally varying \"" + name +
                      "\" (dispersion) is approximated by its "
                      "value at the green primary");
    return c->g;
}

}  // namespace

Vec3f NormalMapImage::lookup(Vec2f uv) const {
    // pbrt-v4 NormalMap: bilinear, repeat, at (u, 1 - v) with row 0 at the top.
    float x = uv.x * float(width) - 0.5f, y = (1.f - uv.y) * float(height) - 0.5f;
    int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    float fx = x - float(x0), fy = y - float(y0);
    auto texel = [&](int xi, int yi) {
        xi = ((xi % width) + width) % width;
        yi = ((yi % height) + height) % height;
        const float *t = &rgb[(size_t(yi) * size_t(width) + size_t(xi)) * 3];
        return Vec3f(t[0], t[1], t[2]);
    };
    Vec3f c = texel(x0, y0) * ((1 - fx) * (1 - fy)) + texel(x0 + 1, y0) * (fx * (1 - fy)) +
              texel(x0, y0 + 1) * ((1 - fx) * fy) + texel(x0 + 1, y0 + 1) * (fx * fy);
    Vec3f n = c * 2.f - Vec3f(1, 1, 1);
    float l = length(n);
    return l > 0 ? n / l : Vec3f(0, 0, 1);
}

std::shared_ptr<const NormalMapImage> NormalMapImage::load(const std::string &path,
                                                           const FileLoc &loc) {
    // The header is checked (size, memory) before any pixel is allocated.
    OpenedImage file = open_image(path, loc, "normalmap");
    if (file.spec.nchannels < 3) throw SceneError(loc, "normalmap \"" + path + "\" needs RGB");
    auto img = std::make_shared<NormalMapImage>();
    img->width = file.spec.width;
    img->height = file.spec.height;
    // Linear: the texel values are vector components, not colours.
    img->rgb = file.read_floats(0, 3);
    return img;
}

Frame Material::frame(const SurfaceInteraction &si, const TextureEvalContext &tc) const {
    if (normal_map_) {
        // pbrt-v4 NormalMap: the map's normal in the frame of dpdu and the shading normal.
        Frame local = Frame::from_xz(si.dpdu, si.ns);
        Vec3f ns = local.to_world(normal_map_->lookup(tc.uv));
        return Frame::from_xz(si.dpdu, face_forward(normalize(ns), si.ns));
    }
    if (!displacement_) return Frame::from_xz(si.dpdu, si.ns);
    // pbrt-v4 BumpMap (materials.h): shift the lookup by half the uv footprint along u and v.
    float du = 0.5f * (std::abs(tc.dudx) + std::abs(tc.dudy));
    if (du == 0.f) du = 0.0005f;
    float dv = 0.5f * (std::abs(tc.dvdx) + std::abs(tc.dvdy));
    if (dv == 0.f) dv = 0.0005f;
    TextureEvalContext shifted = tc;
    shifted.p = tc.p + si.dpdu * du;
    shifted.uv = Vec2f(tc.uv.x + du, tc.uv.y);
    float u_displace = displacement_->evaluate(shifted);
    shifted.p = tc.p + si.dpdv * dv;
    shifted.uv = Vec2f(tc.uv.x, tc.uv.y + dv);
    float v_displace = displacement_->evaluate(shifted);
    float displace = displacement_->evaluate(tc);
    Vec3f dpdu = si.dpdu + si.ns * ((u_displace - displace) / du);
    Vec3f dpdv = si.dpdv + si.ns * ((v_displace - displace) / dv);
    Vec3f ns = cross(dpdu, dpdv);
    float len = length(ns);
    if (!(len > 0.f) || !std::isfinite(len)) return Frame::from_xz(si.dpdu, si.ns);
    ns = face_forward(ns / len, si.ns);
    return Frame::from_xz(dpdu, ns);
}

MaterialSet::MaterialSet(const std::map<std::string, MaterialDesc> &descs, TextureSet &textures) {
    for (const auto &[name, desc] : descs) build(name, descs, textures, 0);
}

int MaterialSet::index(const std::string &name) const {
    auto it = by_name_.find(name);
    return it == by_name_.end() ? -1 : it->second;
}

int MaterialSet::default_index() {
    if (default_ < 0) {
        static const ParamSet empty;
        (void)empty;
        struct Const final : SpectrumTexture {
            Rgb evaluate(const TextureEvalContext &) const override { return Rgb(0.5f); }
            // Constant: the default material is not "textured" (the specialisations of scene/specialize.h rely on it).
            std::optional<Rgb> constant_value() const override { return Rgb(0.5f); }
            std::string describe() const override { return "constant 0.5"; }
        };
        static const Const half;
        materials_.push_back(std::make_unique<DiffuseMaterial>(&half));
        default_ = int(materials_.size()) - 1;
    }
    return default_;
}

namespace {

/// The material's "normalmap" image (a file name relative to the scene's directory, else to
/// the file that defines the material), or null without one.
std::shared_ptr<const NormalMapImage> load_normal_map(const MaterialDesc &d) {
    const ParamSet &ps = d.params;
    if (!ps.find("normalmap")) return nullptr;
    std::string file = ps.get_string("normalmap", "");
    if (file.empty()) return nullptr;
    namespace fs = std::filesystem;
    fs::path path(file);
    if (path.is_relative() && !d.base_dir.empty()) {
        std::error_code ec;
        path = fs::path(d.base_dir) / file;
        if (!fs::exists(path, ec)) path = fs::path(d.loc.file).parent_path() / file;
    }
    return NormalMapImage::load(path.string(), d.loc);
}

/// pbrt-v4 "hair" (HairMaterial::Create): the first of sigma_a, a colour and the melanin
/// concentrations that is given wins; without any, brown hair (eumelanin 1.3). Newer pbrt-v4
/// names the colour "reflectance", older "color": both are read.
std::unique_ptr<Material> make_hair(const ParamSet &ps, TextureSet &tex) {
    const Param *colour = ps.find("reflectance");
    std::string colour_name = "reflectance";
    if (const Param *old_name = ps.find("color")) {
        if (colour) {
            warn(old_name->loc, "hair: \"color\" ignored since \"reflectance\" was given");
            old_name->used = true;
        } else {
            colour = old_name;
            colour_name = "color";
        }
    }
    auto ignore = [&](const Param *p, const std::string &why) {
        if (!p)
            return;
        warn(p->loc, "hair: \"" + p->name + "\" ignored since \"" + why + "\" was given");
        p->used = true;
    };
    const Param *eu = ps.find("eumelanin"), *pheo = ps.find("pheomelanin");
    const SpectrumTexture *sigma_a = nullptr, *color = nullptr;
    const FloatTexture *eumelanin = nullptr, *pheomelanin = nullptr;
    if (ps.find("sigma_a")) {
        sigma_a = tex.spectrum_param(ps, "sigma_a", std::nullopt, true);
        ignore(colour, "sigma_a");
        ignore(eu, "sigma_a");
        ignore(pheo, "sigma_a");
    } else if (colour) {
        color = tex.spectrum_param(ps, colour_name, std::nullopt, false);
        ignore(eu, colour_name);
        ignore(pheo, colour_name);
    } else {
        eumelanin = tex.float_param(ps, "eumelanin", eu || pheo ? 0.f : 1.3f);
        pheomelanin = tex.float_param(ps, "pheomelanin", 0.f);
    }
    return std::make_unique<HairMaterial>(
        sigma_a, color, eumelanin, pheomelanin, tex.float_param(ps, "eta", 1.55f),
        tex.float_param(ps, "beta_m", 0.3f), tex.float_param(ps, "beta_n", 0.3f),
        tex.float_param(ps, "alpha", 2.f));
}

/// Every material type but "mix" and "hair", from its pbrt-v4 parameters and defaults
/// (pbrt-v4 src/pbrt/materials.cpp, each type's Create; see shading/bsdf.h).
std::unique_ptr<Material> make_material(const MaterialDesc &d, TextureSet &tex) {
    const ParamSet &ps = d.params;
    const std::string &type = d.type;
    if (type == "coatedconductor") {
        // pbrt-v4 CoatedConductorMaterial::Create: "interface.*" for the coat, "conductor.*" or
        // "reflectance" for the metal; "thickness" 0.01, "albedo" 0 and "g" 0 for the layer's
        // medium, "maxdepth" 10 and "nsamples" 1 for the random walk.
        const SpectrumTexture *refl = tex.spectrum_param(ps, "reflectance", std::nullopt, false);
        const SpectrumTexture *eta = nullptr, *k = nullptr;
        if (!refl) {
            eta = tex.spectrum_param(ps, "conductor.eta", copper(false), true);
            k = tex.spectrum_param(ps, "conductor.k", copper(true), true);
        }
        return std::make_unique<CoatedConductorMaterial>(
            scalar_eta(ps, d.loc, 1.5f, "interface.eta"), Roughness::from(ps, tex, "interface."),
            eta, k, refl, Roughness::from(ps, tex, "conductor."),
            tex.float_param(ps, "thickness", 0.01f),
            tex.spectrum_param(ps, "albedo", Rgb(0.f), false), tex.float_param(ps, "g", 0.f),
            LayerWalk::from(ps, d.loc));
    }
    if (type == "diffusetransmission") {
        // pbrt-v4 DiffuseTransmissionMaterial: reflectance 0.25, transmittance 0.25, both times
        // "scale" (a float, 1) and clamped to [0, 1].
        return std::make_unique<DiffuseTransmissionMaterial>(
            tex.spectrum_param(ps, "reflectance", Rgb(0.25f), true),
            tex.spectrum_param(ps, "transmittance", Rgb(0.25f), true), ps.get_float("scale", 1.f));
    }
    if (type == "diffuse")
        return std::make_unique<DiffuseMaterial>(
            tex.spectrum_param(ps, "reflectance", Rgb(0.5f), false));
    if (type == "conductor") {
        const SpectrumTexture *refl = tex.spectrum_param(ps, "reflectance", std::nullopt, false);
        const SpectrumTexture *eta = nullptr, *k = nullptr;
        if (!refl) {
            eta = tex.spectrum_param(ps, "eta", copper(false), true);
            k = tex.spectrum_param(ps, "k", copper(true), true);
        }
        return std::make_unique<ConductorMaterial>(eta, k, refl, Roughness::from(ps, tex));
    }
    if (type == "dielectric")
        return std::make_unique<DielectricMaterial>(scalar_eta(ps, d.loc, 1.5f),
                                                    Roughness::from(ps, tex));
    if (type == "thindielectric")
        return std::make_unique<ThinDielectricMaterial>(scalar_eta(ps, d.loc, 1.5f));
    if (type == "coateddiffuse") {
        // pbrt-v4 CoatedDiffuseMaterial::Create.
        return std::make_unique<CoatedDiffuseMaterial>(
            tex.spectrum_param(ps, "reflectance", Rgb(0.5f), false),
            tex.spectrum_param(ps, "albedo", Rgb(0.f), false),
            tex.float_param(ps, "thickness", 0.01f), tex.float_param(ps, "g", 0.f),
            scalar_eta(ps, d.loc, 1.5f), Roughness::from(ps, tex), LayerWalk::from(ps, d.loc));
    }
    if (type == "interface" || type == "" || type == "none")
        return std::make_unique<InterfaceMaterial>();
    // pbrt-v4 stops on a material type it does not know (pbrt-v3's "plastic", "matte",
    // "uber"... among them); its own types that Tessera lacks render as diffuse.
    if (type != "measured" && type != "subsurface")
        throw SceneError(d.loc, "unknown material type \"" + type + "\"");
    warn(d.loc, "material type \"" + type +
                    "\" is not supported; rendering it as diffuse (reflectance 0.5)");
    auto m = std::make_unique<DiffuseMaterial>(
        tex.spectrum_param(ps, "reflectance", Rgb(0.5f), false));
    for (const Param &p : ps.params) p.used = true;
    return m;
}

}  // namespace

int MaterialSet::build(const std::string &name, const std::map<std::string, MaterialDesc> &descs,
                       TextureSet &tex, int depth) {
    if (auto it = by_name_.find(name); it != by_name_.end()) return it->second;
    auto dit = descs.find(name);
    if (dit == descs.end()) return -1;
    const MaterialDesc &d = dit->second;
    if (depth > 16) throw SceneError(d.loc, "material \"" + name + "\": mix nesting too deep");
    const ParamSet &ps = d.params;
    std::unique_ptr<Material> m;
    const FloatTexture *displacement = nullptr;
    if (ps.find("displacement")) {
        // A constant displacement moves nothing: only textures bump the normal.
        if (!ps.get_texture("displacement").empty())
            displacement = tex.float_param(ps, "displacement", 0.f);
    }
    std::shared_ptr<const NormalMapImage> normal_map = load_normal_map(d);
    for (const char *p : {"displacement", "normalmap"})
        if (const Param *x = ps.find(p)) x->used = true;

    if (d.type == "hair") {
        m = make_hair(ps, tex);
        // pbrt-v4's hair has neither: the shading normal is the fiber's own.
        if (displacement || normal_map) {
            warn(d.loc,
                 "hair: \"displacement\" and \"normalmap\" are not supported on hair "
                 "(pbrt-v4 has neither); ignored");
            displacement = nullptr;
            normal_map.reset();
        }
    } else if (d.type == "mix") {
        std::vector<std::string> names = ps.get_strings("materials");
        if (names.size() != 2)
            throw SceneError(d.loc, "mix material \"" + name + "\" needs exactly two \"materials\"");
        const Material *ma = nullptr, *mb = nullptr;
        for (int i = 0; i < 2; ++i) {
            int idx = build(names[size_t(i)], descs, tex, depth + 1);
            if (idx < 0)
                throw SceneError(d.loc, "mix material \"" + name + "\": unknown material \"" +
                                            names[size_t(i)] + "\"");
            (i == 0 ? ma : mb) = materials_[size_t(idx)].get();
        }
        m = std::make_unique<MixMaterial>(ma, mb, tex.float_param(ps, "amount", 0.5f));
    } else {
        m = make_material(d, tex);
    }
    ps.report_unused("material \"" + name + "\"");
    if (displacement) m->set_displacement(displacement);
    if (normal_map) m->set_normal_map(normal_map);
    materials_.push_back(std::move(m));
    int idx = int(materials_.size()) - 1;
    by_name_[name] = idx;
    return idx;
}

}  // namespace tessera
