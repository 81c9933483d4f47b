// ParamSet lookups.
//
// Lookups follow pbrt-v4's ParameterDictionary (src/pbrt/paramdict.cpp): a parameter is found by
// name, its type must match the lookup, single-value lookups insist on exactly one value, and each
// lookup marks the parameter as used so that unused parameters can be reported with file:line.
// Unlike pbrt-v4 (which silently skips a parameter whose type differs), a type mismatch here is a
// SceneError: a misspelt type is almost always a mistake in the file.
#include "renderer/input/scene_desc.h"

#include <cstdio>
#include <filesystem>

#include "renderer/util/spectra.h"

namespace tessera {

namespace {

[[noreturn]] void type_error(const Param &p, const char *expected) {
    throw SceneError(p.loc, "parameter \"" + p.name + "\" has type \"" + p.type +
                                "\" but \"" + expected + "\" is expected here");
}

/// Checks that `p` holds exactly `n` numbers (single-value lookups).
void expect_count(const Param &p, size_t have, size_t n) {
    if (have != n)
        throw SceneError(p.loc, "parameter \"" + p.name + "\" expects " + std::to_string(n) +
                                    " value(s) but has " + std::to_string(have));
}

Vec3f get_vec3(const ParamSet &ps, const std::string &name, const char *type, Vec3f def) {
    const Param *p = ps.find(name);
    if (!p) return def;
    if (p->type != type) type_error(*p, type);
    expect_count(*p, p->numbers.size(), 3);
    p->used = true;
    return {float(p->numbers[0]), float(p->numbers[1]), float(p->numbers[2])};
}

std::vector<Vec3f> get_vec3s(const ParamSet &ps, const std::string &name, const char *type) {
    const Param *p = ps.find(name);
    if (!p) return {};
    if (p->type != type) type_error(*p, type);
    if (p->numbers.size() % 3 != 0)
        throw SceneError(p->loc, "parameter \"" + name + "\": number of values (" +
                                     std::to_string(p->numbers.size()) +
                                     ") is not a multiple of 3");
    p->used = true;
    std::vector<Vec3f> out;
    out.reserve(p->numbers.size() / 3);
    for (size_t i = 0; i + 2 < p->numbers.size(); i += 3)
        out.push_back({float(p->numbers[i]), float(p->numbers[i + 1]), float(p->numbers[i + 2])});
    return out;
}

}  // namespace

const Param *ParamSet::find(const std::string &name) const {
    for (const Param &p : params)
        if (p.name == name) return &p;
    return nullptr;
}

float ParamSet::get_float(const std::string &name, float def) const {
    const Param *p = find(name);
    if (!p) return def;
    // An integer where a float is expected is harmless (pbrt-v4 files never rely on the
    // difference), so accept it.
    if (p->type != "float" && p->type != "integer") type_error(*p, "float");
    expect_count(*p, p->numbers.size(), 1);
    p->used = true;
    return float(p->numbers[0]);
}

int ParamSet::get_int(const std::string &name, int def) const {
    const Param *p = find(name);
    if (!p) return def;
    if (p->type != "integer") type_error(*p, "integer");
    expect_count(*p, p->numbers.size(), 1);
    p->used = true;
    return int(p->numbers[0]);
}

bool ParamSet::get_bool(const std::string &name, bool def) const {
    const Param *p = find(name);
    if (!p) return def;
    if (p->type != "bool") type_error(*p, "bool");
    expect_count(*p, p->bools.size(), 1);
    p->used = true;
    return p->bools[0] != 0;
}

std::string ParamSet::get_string(const std::string &name, const std::string &def) const {
    const Param *p = find(name);
    if (!p) return def;
    if (p->type != "string") type_error(*p, "string");
    expect_count(*p, p->strings.size(), 1);
    p->used = true;
    return p->strings[0];
}

Vec3f ParamSet::get_point3(const std::string &name, Vec3f def) const {
    return get_vec3(*this, name, "point3", def);
}
Vec3f ParamSet::get_vector3(const std::string &name, Vec3f def) const {
    return get_vec3(*this, name, "vector3", def);
}
Vec3f ParamSet::get_normal(const std::string &name, Vec3f def) const {
    return get_vec3(*this, name, "normal", def);
}

std::vector<float> ParamSet::get_floats(const std::string &name) const {
    const Param *p = find(name);
    if (!p) return {};
    if (p->type != "float" && p->type != "integer") type_error(*p, "float");
    p->used = true;
    return std::vector<float>(p->numbers.begin(), p->numbers.end());
}

std::vector<int> ParamSet::get_ints(const std::string &name) const {
    const Param *p = find(name);
    if (!p) return {};
    if (p->type != "integer") type_error(*p, "integer");
    p->used = true;
    std::vector<int> out;
    out.reserve(p->numbers.size());
    for (double v : p->numbers) out.push_back(int(v));
    return out;
}

std::vector<Vec2f> ParamSet::get_point2s(const std::string &name) const {
    const Param *p = find(name);
    if (!p) return {};
    // pbrt-v4 files use both "point2 uv" and (older exporters) "float uv"; accept all three.
    if (p->type != "point2" && p->type != "vector2" && p->type != "float")
        type_error(*p, "point2");
    if (p->numbers.size() % 2 != 0)
        throw SceneError(p->loc, "parameter \"" + name + "\": number of values (" +
                                     std::to_string(p->numbers.size()) +
                                     ") is not a multiple of 2");
    p->used = true;
    std::vector<Vec2f> out;
    out.reserve(p->numbers.size() / 2);
    for (size_t i = 0; i + 1 < p->numbers.size(); i += 2)
        out.push_back({float(p->numbers[i]), float(p->numbers[i + 1])});
    return out;
}

std::vector<Vec3f> ParamSet::get_point3s(const std::string &name) const {
    return get_vec3s(*this, name, "point3");
}
std::vector<Vec3f> ParamSet::get_vector3s(const std::string &name) const {
    return get_vec3s(*this, name, "vector3");
}
std::vector<Vec3f> ParamSet::get_normals(const std::string &name) const {
    return get_vec3s(*this, name, "normal");
}

std::vector<std::string> ParamSet::get_strings(const std::string &name) const {
    const Param *p = find(name);
    if (!p) return {};
    if (p->type != "string") type_error(*p, "string");
    p->used = true;
    return p->strings;
}

std::string ParamSet::get_texture(const std::string &name) const {
    const Param *p = find(name);
    // Not a texture: the caller falls back to the constant-valued lookup of the same name.
    if (!p || p->type != "texture") return {};
    expect_count(*p, p->strings.size(), 1);
    p->used = true;
    return p->strings[0];
}

std::optional<Rgb> ParamSet::get_rgb(const std::string &name, bool illuminant,
                                     bool unbounded) const {
    const Param *p = find(name);
    if (!p || p->type == "texture") return std::nullopt;
    Rgb rgb;
    if (p->type == "rgb") {
        expect_count(*p, p->numbers.size(), 3);
        rgb = Rgb(float(p->numbers[0]), float(p->numbers[1]), float(p->numbers[2]));
        // pbrt-v4 rejects negative RGB for reflectances and illuminants (RGBAlbedoSpectrum,
        // RGBIlluminantSpectrum); eta/k style unbounded values must be >= 0 too.
        if (rgb.r < 0 || rgb.g < 0 || rgb.b < 0)
            throw SceneError(p->loc, "parameter \"" + name + "\": RGB values must be >= 0");
    } else if (p->type == "float") {
        expect_count(*p, p->numbers.size(), 1);
        rgb = Rgb(float(p->numbers[0]));
    } else if (p->type == "blackbody") {
        // pbrt-v4 takes one temperature; pbrt-v3 files give [T scale]: honour the scale.
        if (p->numbers.size() != 1 && p->numbers.size() != 2)
            expect_count(*p, p->numbers.size(), 1);
        if (p->numbers[0] <= 0)
            throw SceneError(p->loc, "blackbody temperature must be positive");
        rgb = blackbody_rgb(float(p->numbers[0]));
        if (p->numbers.size() == 2) {
            warn(p->loc, "\"blackbody " + name + "\" with two values is pbrt-v3 syntax; "
                                                 "the second value is used as a scale");
            rgb *= float(p->numbers[1]);
        }
        if (!illuminant)
            warn(p->loc, "blackbody spectrum used for a non-emissive quantity \"" + name + "\"");
    } else if (p->type == "spectrum") {
        if (!p->strings.empty()) {
            expect_count(*p, p->strings.size(), 1);
            const std::string &sname = p->strings[0];
            std::optional<Rgb> named = named_spectrum_rgb(sname, illuminant);
            if (!named)
                throw SceneError(p->loc, "unknown or unsupported named spectrum \"" + sname +
                                             "\"");
            if (std::string note = named_spectrum_note(sname); !note.empty())
                warn(p->loc, "spectrum \"" + sname + "\": " + note);
            rgb = *named;
        } else {
            if (p->numbers.size() < 2 || p->numbers.size() % 2 != 0)
                throw SceneError(p->loc, "parameter \"" + name +
                                             "\": a sampled spectrum needs (lambda, value) "
                                             "pairs, found " +
                                             std::to_string(p->numbers.size()) + " values");
            std::vector<float> lambda, value;
            for (size_t i = 0; i + 1 < p->numbers.size(); i += 2) {
                lambda.push_back(float(p->numbers[i]));
                value.push_back(float(p->numbers[i + 1]));
            }
            for (size_t i = 1; i < lambda.size(); ++i)
                if (!(lambda[i] > lambda[i - 1]))
                    throw SceneError(p->loc, "parameter \"" + name +
                                                 "\": spectrum wavelengths must increase");
            if (illuminant || !unbounded)
                rgb = sampled_spectrum_rgb(lambda, value, illuminant);
            else
                rgb = band_average_rgb(lambda, value);
        }
    } else {
        type_error(*p, "rgb\", \"spectrum\", \"blackbody\" or \"float");
    }
    p->used = true;
    if (!illuminant && !unbounded) {
        Rgb c{clamp(rgb.r, 0.f, 1.f), clamp(rgb.g, 0.f, 1.f), clamp(rgb.b, 0.f, 1.f)};
        if (c.r != rgb.r || c.g != rgb.g || c.b != rgb.b)
            warn(p->loc, "parameter \"" + name + "\" clamped to [0,1]");
        rgb = c;
    }
    return rgb;
}

void ParamSet::report_unused(const std::string &what) const {
    for (const Param &p : params)
        if (!p.used)
            warn(p.loc, what + ": parameter \"" + p.type + " " + p.name + "\" is not used");
}

}  // namespace tessera
