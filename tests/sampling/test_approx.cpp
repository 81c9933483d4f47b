// The suite's tolerance helper (tests/approx.h): epsilon is relative to the value compared.
#include <doctest/doctest.h>

#include "approx.h"

using tessera::test::Approx;

TEST_CASE("test::Approx: epsilon is relative at every magnitude, absolute only for 0") {
    // doctest's own Approx (scale 1) accepts all of the next three; ours rejects them.
    CHECK(doctest::Approx(0.01).epsilon(0.01) == 0.015);  // 50% off passes
    CHECK(0.015 != Approx(0.01).epsilon(0.01));
    CHECK(doctest::Approx(1.0).epsilon(0.005) == 1.009);  // 0.9% off passes at "0.5%"
    CHECK(1.009 != Approx(1.0).epsilon(0.005));
    CHECK(doctest::Approx(-1e-3).epsilon(0.01) == -5e-3);
    CHECK(-5e-3 != Approx(-1e-3).epsilon(0.01));
    // Within the relative tolerance, on either side and either operand order.
    CHECK(0.0100999 == Approx(0.01).epsilon(0.01));
    CHECK(Approx(0.01).epsilon(0.01) == 0.0099001);
    CHECK(1.0049 == Approx(1.0).epsilon(0.005));
    CHECK(100.99 == Approx(100.0).epsilon(0.01));
    CHECK(101.1 != Approx(100.0).epsilon(0.01));
    CHECK(1e-30 * (1 + 1e-6) == Approx(1e-30));
    CHECK(1e-30 * 1.01 != Approx(1e-30));
    // Exactly 0 expected: epsilon is an absolute tolerance.
    CHECK(0.0 == Approx(0.0));
    CHECK(1e-6 == Approx(0.0).epsilon(1e-5));
    CHECK(1e-4 != Approx(0.0).epsilon(1e-5));
}
