// Unit tests of the image metrics against hand-computed values.
#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>

#include "approx.h"
#include "sampling/image_metrics.h"

using namespace tessera::sampling;

namespace {

// A 2x1 test image and its reference:
//   test: (0.5, 1.0, 0.0), (0.1, 0.2, 0.3)
//   ref:  (0.5, 0.0, 0.0), (0.0, 0.2, 0.5)
RgbImage test_image() {
    return RgbImage(2, 1, std::vector<float>{0.5f, 1.f, 0.f, 0.1f, 0.2f, 0.3f});
}
RgbImage ref_image() { return RgbImage(2, 1, std::vector<float>{0.5f, 0.f, 0.f, 0.f, 0.2f, 0.5f}); }

}  // namespace

TEST_CASE("MSE, RMSE and PSNR by hand") {
    RgbImage t = test_image(), r = ref_image();
    // Squared errors: R {0, 0.01}, G {1, 0}, B {0, 0.04}.
    ChannelMetric m = mse(t, r);
    CHECK(m.channel[0] == tessera::test::Approx(0.005));
    CHECK(m.channel[1] == tessera::test::Approx(0.5));
    CHECK(m.channel[2] == tessera::test::Approx(0.02));
    CHECK(m.total == tessera::test::Approx((0.005 + 0.5 + 0.02) / 3));

    ChannelMetric e = rmse(t, r);
    CHECK(e.channel[1] == tessera::test::Approx(std::sqrt(0.5)));
    CHECK(e.total == tessera::test::Approx(std::sqrt(0.525 / 3)));

    ChannelMetric p = psnr(t, r);
    CHECK(p.channel[0] == tessera::test::Approx(10 * std::log10(1 / 0.005)));
    CHECK(p.total == tessera::test::Approx(10 * std::log10(3 / 0.525)));
    ChannelMetric p4 = psnr(t, r, 4.0);
    CHECK(p4.channel[2] == tessera::test::Approx(10 * std::log10(16 / 0.02)));
    CHECK(std::isinf(psnr(r, r).total));
}

TEST_CASE("relMSE uses (v - ref)^2 / (ref^2 + 0.01)") {
    ChannelMetric m = rel_mse(test_image(), ref_image());
    // R: {0, 0.01 / 0.01} -> 0.5;  G: {1 / 0.01, 0} -> 50;  B: {0, 0.04 / 0.26} -> 0.077
    CHECK(m.channel[0] == tessera::test::Approx(0.5));
    CHECK(m.channel[1] == tessera::test::Approx(50.0));
    CHECK(m.channel[2] == tessera::test::Approx(0.5 * 0.04 / 0.26));
    CHECK(m.total == tessera::test::Approx((0.5 + 50.0 + 0.02 / 0.26) / 3));
}

TEST_CASE("robust relMSE leaves out the 0.1% largest per-pixel errors") {
    // 2000 pixels of reference 0.3 in every channel; test 0.4 (relative error
    // 0.01 / 0.1 = 0.1 per channel) except two fireflies (100: error ~99700) and one pixel whose
    // green is 0.5 (0.4 / 0.1 = 0.4 in green only). floor(0.001 * 2000) = 2 pixels are left out:
    // exactly the fireflies.
    RgbImage ref(40, 50, 0.3f), t(40, 50, 0.4f);
    t.at(3, 4, 0) = t.at(3, 4, 1) = t.at(3, 4, 2) = 100.f;
    t.at(30, 40, 1) = 100.f;
    t.at(7, 7, 1) = 0.5f;
    const double e = 0.01 / 0.1, big = (100.0 - 0.3) * (100.0 - 0.3) / 0.1;
    ChannelMetric r = rel_mse_robust(t, ref);
    CHECK(r.channel[0] == tessera::test::Approx(e));
    CHECK(r.channel[1] == tessera::test::Approx((1997 * e + 0.4) / 1998));
    CHECK(r.channel[2] == tessera::test::Approx(e));
    // Plain relMSE is decided by the two fireflies.
    ChannelMetric plain = rel_mse(t, ref);
    CHECK(plain.channel[1] == tessera::test::Approx((1997 * e + 0.4 + 2 * big) / 2000));
    CHECK(plain.total > 100 * r.total);
    // Dropping nothing is the plain relMSE; compare_images reports the default.
    CHECK(rel_mse_robust(t, ref, 0.0).total == tessera::test::Approx(plain.total));
    CHECK(compare_images(t, ref).rel_mse_robust.total == tessera::test::Approx(r.total));
    // A NaN pixel ranks first among those left out.
    t.at(3, 4, 0) = std::nanf("");
    CHECK(std::isfinite(rel_mse_robust(t, ref).total));
    CHECK(rel_mse_robust(t, ref).channel[1] == tessera::test::Approx(r.channel[1]));
    // Under 1000 pixels nothing is left out; a fraction outside [0, 1) is an error.
    RgbImage small_ref(10, 10, 0.3f), small(10, 10, 0.4f);
    small.at(0, 0, 0) = 100.f;
    CHECK(rel_mse_robust(small, small_ref).total ==
          tessera::test::Approx(rel_mse(small, small_ref).total));
    CHECK_THROWS_AS(rel_mse_robust(t, ref, 1.0), std::invalid_argument);
    CHECK_THROWS_AS(rel_mse_robust(t, ref, -0.1), std::invalid_argument);
}

TEST_CASE("channel means and compare_images") {
    std::array<double, 3> mt = channel_means(test_image());
    CHECK(mt[0] == tessera::test::Approx(0.3));
    CHECK(mt[1] == tessera::test::Approx(0.6));
    CHECK(mt[2] == tessera::test::Approx(0.15));
    ImageComparison c = compare_images(test_image(), ref_image());
    CHECK(c.mse.channel[1] == tessera::test::Approx(0.5));
    CHECK(c.rel_mse.channel[1] == tessera::test::Approx(50.0));
    CHECK(c.mean_ref[2] == tessera::test::Approx(0.25));
    CHECK(c.mean_test[0] == tessera::test::Approx(0.3));
    CHECK(c.psnr.channel[1] == tessera::test::Approx(10 * std::log10(2.0)));
}

TEST_CASE("size mismatch and malformed images throw") {
    CHECK_THROWS_AS(mse(RgbImage(2, 2), RgbImage(2, 3)), std::invalid_argument);
    RgbImage bad(2, 2);
    bad.data.pop_back();
    CHECK_THROWS_AS(channel_means(bad), std::invalid_argument);
    CHECK_THROWS_AS(box_downsample(RgbImage(2, 2), 0), std::invalid_argument);
}

TEST_CASE("box downsample by an integer factor") {
    // 4x2 image, red = x + 4y, green = 1, blue = y.
    RgbImage img(4, 2);
    for (uint32_t y = 0; y < 2; ++y)
        for (uint32_t x = 0; x < 4; ++x) {
            img.at(x, y, 0) = float(x + 4 * y);
            img.at(x, y, 1) = 1.f;
            img.at(x, y, 2) = float(y);
        }
    RgbImage d = box_downsample(img, 2);
    REQUIRE(d.width == 2);
    REQUIRE(d.height == 1);
    CHECK(d.at(0, 0, 0) == tessera::test::Approx((0 + 1 + 4 + 5) / 4.0));
    CHECK(d.at(1, 0, 0) == tessera::test::Approx((2 + 3 + 6 + 7) / 4.0));
    CHECK(d.at(1, 0, 1) == 1.f);
    CHECK(d.at(0, 0, 2) == tessera::test::Approx(0.5));
    // Factor 3: 2x1 output, the second block is partial (one column of two rows).
    RgbImage e = box_downsample(img, 3);
    REQUIRE(e.width == 2);
    REQUIRE(e.height == 1);
    CHECK(e.at(0, 0, 0) == tessera::test::Approx((0 + 1 + 2 + 4 + 5 + 6) / 6.0));
    CHECK(e.at(1, 0, 0) == tessera::test::Approx((3 + 7) / 2.0));
    // Factor 1 is the identity; the mean is preserved by exact-multiple downsampling.
    CHECK(box_downsample(img, 1).data == img.data);
    CHECK(channel_means(d)[0] == tessera::test::Approx(channel_means(img)[0]));
}
