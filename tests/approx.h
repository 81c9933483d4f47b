// A relative doctest::Approx for the whole suite.
//
// doctest compares |a - b| < epsilon * (scale + max(|a|, |b|)) with a default scale of 1, so
// Approx(x).epsilon(e) is an absolute tolerance e for |x| well below 1, and twice as loose as
// written at 1: a test asking for "1%" of a value near 0.01 accepted 100%, and a white furnace
// "within 0.5%" accepted 1%. Tessera's tests mean epsilon as relative, so this Approx uses scale
// 0. An expected value of exactly 0 has no relative scale: it keeps doctest's absolute tolerance
// (epsilon itself).
#pragma once

#include <doctest/doctest.h>

namespace tessera::test {

inline doctest::Approx Approx(double expected) {
    doctest::Approx a(expected);
    if (expected != 0.0) a.scale(0.0);
    return a;
}

}  // namespace tessera::test
