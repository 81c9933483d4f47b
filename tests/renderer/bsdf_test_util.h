// Helpers shared by the BSDF tests (test_bsdf*, test_layered_bxdf*).
#pragma once

#include <cmath>

#include "sampling/vecmath.h"

namespace tessera::test {

/// The unit direction at polar angle theta and azimuth phi (degrees) in a local shading frame
/// (z is the normal).
inline Vec3f dir_from_theta(float theta_deg, float phi_deg = 30.f) {
    float t = radians(theta_deg), p = radians(phi_deg);
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

}  // namespace tessera::test
