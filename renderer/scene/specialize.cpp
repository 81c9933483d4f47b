#include "renderer/scene/specialize.h"

#include <stdexcept>

#include "renderer/scene/scene.h"

namespace tessera {

namespace {

struct Named {
    const char *name;
    uint32_t bit;
};
constexpr Named kNames[] = {
    {"differentials", kSpecDifferentials},
    {"lambertian", kSpecLambertian},
    {"cull", kSpecCull},
    {"alpha", kSpecAlpha},
    {"attributes", kSpecAttributes},
    {"packet", kSpecPacket},
};

}  // namespace

uint32_t parse_specializations(std::string_view list) {
    uint32_t mask = 0;
    size_t start = 0;
    while (start <= list.size()) {
        size_t end = list.find(',', start);
        if (end == std::string_view::npos) end = list.size();
        std::string_view item = list.substr(start, end - start);
        bool found = false;
        if (item == "all") {
            mask |= kSpecAll;
            found = true;
        }
        for (const Named &n : kNames)
            if (item == n.name) {
                mask |= n.bit;
                found = true;
            }
        if (!found) {
            std::string valid = "all";
            for (const Named &n : kNames) valid += std::string(", ") + n.name;
            throw std::invalid_argument("unknown specialisation \"" + std::string(item) +
                                        "\" (valid: " + valid + ")");
        }
        start = end + 1;
    }
    return mask;
}

std::string specialization_names(uint32_t mask) {
    std::string s;
    for (const Named &n : kNames)
        if (mask & n.bit) {
            if (!s.empty()) s += ',';
            s += n.name;
        }
    return s.empty() ? "none" : s;
}

uint32_t applicable_specializations(const Scene &scene) {
    uint32_t mask = 0;
    // Only materials read textures with footprints (varying parameters, bump and normal
    // maps); constant textures and alpha tests need no differentials.
    bool any_textured = false;
    for (const auto &m : scene.materials) any_textured |= m->textured();
    if (!any_textured) mask |= kSpecDifferentials;
    bool lambertian = !scene.materials.empty();
    for (const auto &m : scene.materials) lambertian &= m->constant_lambertian().has_value();
    if (lambertian) mask |= kSpecLambertian;
    if (lambertian && scene.geometry && !scene.geometry->meshes_by_geom_id().empty())
        mask |= kSpecPacket;
    if (!scene.lights.empty()) mask |= kSpecCull;
    if (scene.geometry && scene.geometry->opaque_mesh_count() > 0) mask |= kSpecAlpha;
    // kSpecAttributes is the real-time loop's (what is collected depends on the frame plugin;
    // its stats report attributes_collected): not listed here.
    // The volumetric path tracer (scenes with media) has no Lambertian, packet or culling
    // variants: only the differentials and alpha rules apply to it.
    if (scene.features.media) mask &= kSpecDifferentials | kSpecAlpha;
    return mask;
}

uint32_t used_specializations(uint32_t applicable, uint32_t disabled) {
    uint32_t used = applicable & ~disabled;
    if (!(used & kSpecLambertian))
        used &= ~uint32_t(kSpecPacket);
    return used;
}

}  // namespace tessera
