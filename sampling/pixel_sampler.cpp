#include "sampling/pixel_sampler.h"

#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace tessera::sampling {

namespace {

/// Keys compare with '-' and '_' as the same character ("min-spp" == "min_spp").
bool same_key(std::string_view a, std::string_view b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i) {
        char ca = a[i] == '-' ? '_' : a[i], cb = b[i] == '-' ? '_' : b[i];
        if (ca != cb) return false;
    }
    return true;
}

std::string format_number(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// PluginParams

PluginParams::PluginParams(const std::vector<PluginParamSpec> &specs) {
    for (const PluginParamSpec &s : specs) {
        keys_.push_back(s.key);
        values_.push_back(s.default_value);
        given_.push_back(false);
    }
}

size_t PluginParams::index_of(std::string_view key) const {
    for (size_t i = 0; i < keys_.size(); ++i)
        if (same_key(keys_[i], key)) return i;
    throw std::logic_error("plugin parameter \"" + std::string(key) + "\" is not declared");
}

double PluginParams::get(std::string_view key) const { return values_[index_of(key)]; }

bool PluginParams::is_set(std::string_view key) const { return given_[index_of(key)]; }

void PluginParams::set(std::string_view key, double value) {
    size_t i = index_of(key);
    values_[i] = value;
    given_[i] = true;
}

std::string PluginParams::describe() const {
    std::string out;
    for (size_t i = 0; i < keys_.size(); ++i) {
        if (i) out += ',';
        out += keys_[i] + "=" + format_number(values_[i]);
    }
    return out;
}

// ---------------------------------------------------------------------------------------------
// FrameResult

void FrameResult::reset(uint32_t w, uint32_t h, bool zero) {
    width = w;
    height = h;
    const size_t n = size_t(w) * h;
    if (zero) {
        color.assign(n, Rgb(0.f));
        rays.assign(n, 0.f);
    } else {
        color.resize(n, Rgb(0.f));
        rays.resize(n, 0.f);
    }
    // Keep the layers' memory from frame to frame (a plugin asks for the same layers again):
    // zero them in place instead of freeing and faulting in megabytes per frame.
    for (FrameLayer &l : diagnostics) {
        if (zero)
            l.data.assign(n, 0.f);
        else
            l.data.resize(n, 0.f);
    }
    samples = rays_total = shaded = nan_samples = 0;
    shadow_rays = shadow_rays_avoided = 0;
    active_fraction = 0;
    active_unit = "pixels";
}

FrameLayer &FrameResult::layer(const std::string &name) {
    for (FrameLayer &l : diagnostics)
        if (l.name == name) return l;
    diagnostics.push_back({name, std::vector<float>(size_t(width) * height, 0.f)});
    return diagnostics.back();
}

std::string PixelSampler::stage_name(int stage) const { return "stage" + std::to_string(stage); }

// ---------------------------------------------------------------------------------------------
// Registry (the list itself: sampling/plugins/registry.cpp)

const PluginInfo *find_plugin(std::string_view name) {
    for (const PluginInfo &p : plugin_registry())
        if (p.name == name) return &p;
    return nullptr;
}

std::string PluginSpec::describe() const {
    if (!info) return "";
    std::string p = params.describe();
    return p.empty() ? info->name : info->name + ":" + p;
}

PluginSpec parse_plugin_spec(std::string_view text) {
    size_t colon = text.find(':');
    std::string name(text.substr(0, colon));
    PluginSpec spec;
    spec.info = find_plugin(name);
    if (!spec.info) {
        std::string names;
        for (const PluginInfo &p : plugin_registry()) names += (names.empty() ? "" : ", ") + p.name;
        throw std::invalid_argument("unknown sampler \"" + name + "\" (available: " + names +
                                    "; see `tessera samplers`)");
    }
    spec.params = PluginParams(spec.info->params);
    if (colon == std::string_view::npos) return spec;
    std::string_view rest = text.substr(colon + 1);
    const std::string where = "sampler " + name + ": ";
    while (!rest.empty()) {
        size_t comma = rest.find(',');
        std::string_view item = rest.substr(0, comma);
        rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
        if (item.empty()) continue;
        size_t eq = item.find('=');
        if (eq == std::string_view::npos)
            throw std::invalid_argument(where + "expected key=value, got \"" + std::string(item) +
                                        "\"");
        std::string_view key = item.substr(0, eq), value = item.substr(eq + 1);
        const PluginParamSpec *ps = nullptr;
        for (const PluginParamSpec &s : spec.info->params)
            if (same_key(s.key, key)) ps = &s;
        if (!ps) {
            std::string keys;
            for (const PluginParamSpec &s : spec.info->params)
                keys += (keys.empty() ? "" : ", ") + s.key;
            throw std::invalid_argument(where + "unknown key \"" + std::string(key) + "\" (keys: " +
                                        (keys.empty() ? "none" : keys) + ")");
        }
        if (spec.params.is_set(ps->key))
            throw std::invalid_argument(where + "key \"" + ps->key + "\" given twice");
        double v = 0;
        std::string vs(value);
        const char *b = vs.data(), *e = vs.data() + vs.size();
        auto [ptr, ec] = std::from_chars(b, e, v);
        if (vs.empty() || ec != std::errc() || ptr != e || !std::isfinite(v))
            throw std::invalid_argument(where + ps->key + "=\"" + vs + "\" is not a number");
        if (ps->integer && v != std::floor(v))
            throw std::invalid_argument(where + ps->key + "=" + vs + " must be a whole number");
        if (v < ps->min_value || v > ps->max_value)
            throw std::invalid_argument(where + ps->key + "=" + vs + " is outside [" +
                                        format_number(ps->min_value) + ", " +
                                        format_number(ps->max_value) + "]");
        spec.params.set(ps->key, v);
    }
    return spec;
}

std::string format_plugin_list() {
    std::ostringstream os;
    for (const PluginInfo &p : plugin_registry()) {
        os << p.name << (p.kind == PluginKind::Progressive ? "  (progressive)" : "  (frame)")
           << "\n    " << p.summary << "\n";
        for (const PluginParamSpec &s : p.params) {
            os << "    " << s.key << "=" << format_number(s.default_value) << "  ["
               << format_number(s.min_value) << ", " << format_number(s.max_value) << "]"
               << (s.integer ? " integer" : "") << "  " << s.help << "\n";
        }
        os << "\n";
    }
    os << "Usage: --sampler NAME[:key=value,...], e.g. --sampler jin:tau_col=0.6\n";
    return os.str();
}

}  // namespace tessera::sampling
