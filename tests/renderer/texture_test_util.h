// Builders of texture parameters and descriptions for the texture tests (test_texture,
// test_noise): what the parser would produce for one `Texture` line.
#pragma once

#include <string>
#include <vector>

#include "renderer/input/scene_desc.h"

namespace tessera::test {

inline Param num(const std::string &type, const std::string &name, std::vector<double> v) {
    Param p;
    p.type = type;
    p.name = name;
    p.numbers = std::move(v);
    p.loc = {"test.pbrt", 1};
    return p;
}
inline Param str(const std::string &type, const std::string &name, const std::string &v) {
    Param p;
    p.type = type;
    p.name = name;
    p.strings = {v};
    p.loc = {"test.pbrt", 1};
    return p;
}
inline Param flag(const std::string &name, bool v) {
    Param p;
    p.type = "bool";
    p.name = name;
    p.bools = {uint8_t(v)};
    return p;
}

inline TextureDesc desc(const std::string &name, const std::string &type, const std::string &cls,
                        std::vector<Param> params = {}, Transform render_from_texture = {}) {
    TextureDesc d;
    d.name = name;
    d.value_type = type;
    d.tex_class = cls;
    d.params.params = std::move(params);
    d.loc = {"test.pbrt", 7};
    d.render_from_texture = render_from_texture;
    return d;
}

}  // namespace tessera::test
