// Helpers shared by the real-time plugins' tests: bitwise frame comparison and the message of a
// rejected --sampler value.
#pragma once

#include <doctest/doctest.h>

#include <cstring>
#include <stdexcept>
#include <string>

#include "sampling/pixel_sampler.h"

namespace tessera::test {

/// Bitwise equality of two frames: colours, rays, every diagnostic layer and the counts.
inline void check_same_frame(const sampling::FrameResult &a, const sampling::FrameResult &b) {
    REQUIRE(a.color.size() == b.color.size());
    CHECK(std::memcmp(a.color.data(), b.color.data(), a.color.size() * sizeof(Rgb)) == 0);
    CHECK(a.rays == b.rays);
    REQUIRE(a.diagnostics.size() == b.diagnostics.size());
    for (size_t i = 0; i < a.diagnostics.size(); ++i) {
        CHECK(a.diagnostics[i].name == b.diagnostics[i].name);
        CHECK(a.diagnostics[i].data == b.diagnostics[i].data);
    }
    CHECK(a.samples == b.samples);
    CHECK(a.shaded == b.shaded);
    CHECK(a.rays_total == b.rays_total);
    CHECK(a.nan_samples == b.nan_samples);
    CHECK(a.active_fraction == b.active_fraction);
}

/// The message parse_plugin_spec throws for `text`, or "no error".
inline std::string spec_error(const std::string &text) {
    try {
        sampling::parse_plugin_spec(text);
    } catch (const std::invalid_argument &e) {
        return e.what();
    }
    return "no error";
}

}  // namespace tessera::test
