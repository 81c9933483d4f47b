// The relMSE metric of the adaptive scheduler (AdaptiveOptions::metric = RelMse; the file
// comment of scheduler/adaptive_scheduler.h, "Error metrics"): on sources whose per-pixel
// relative variance a_p is known in closed form, the samples follow n_p ~ sqrt(a_p), an spp
// budget reaches the relMSE of that many uniform samples with fewer samples, an error target is
// the image relMSE that is reached, a noisy patch narrower than a tile gets the samples, and the
// deterministic mode stays bit-identical for any thread count.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "sampling/film.h"
#include "scheduler/adaptive_scheduler.h"
#include "synthetic_sources.h"

using namespace tessera;
using namespace tessera::sched;
using tessera::test::TwoNoiseSource;

namespace {

constexpr uint32_t kW = 64, kH = 48;
const sampling::PixelBounds kHard{16, 16, 32, 32};
constexpr float kHardNoise = 0.3f, kEasyNoise = 0.075f;  // a_p ratio 16: n_p ratio 4

AdaptiveOptions relmse_options(uint32_t threads) {
    AdaptiveOptions o;
    o.threads = threads;
    o.seed = 3;
    o.progress = ProgressReporter::Mode::Never;
    o.metric = sampling::ErrorMetric::RelMse;
    o.deterministic = true;
    return o;
}

/// True relMSE of the film against the source's exact mean 0.5 (every channel alike).
double true_rel_mse(const sampling::Film &film) {
    double sum = 0;
    for (uint32_t y = 0; y < film.height(); ++y)
        for (uint32_t x = 0; x < film.width(); ++x) {
            const sampling::PixelStats st = film.pixel_stats(x, y);
            for (int c = 0; c < 3; ++c)
                sum += (st.mean[c] - 0.5) * (st.mean[c] - 0.5) / (0.25 + 0.01);
        }
    return sum / (3.0 * film.width() * film.height());
}

/// Expected relMSE of uniform sampling with n samples per pixel: hash noise u in [-s, s] has
/// variance s^2 / 3.
double uniform_rel_mse(uint32_t n) {
    const double hard = double(kHard.area()), all = double(kW) * kH;
    const double var = (hard * kHardNoise * kHardNoise + (all - hard) * kEasyNoise * kEasyNoise) /
                       (3.0 * all);
    return var / (double(n) * 0.26);
}

std::pair<double, double> spp_in_out(const sampling::Film &film, sampling::PixelBounds r) {
    double in = 0, out = 0;
    uint64_t n_in = 0, n_out = 0;
    for (uint32_t y = 0; y < film.height(); ++y)
        for (uint32_t x = 0; x < film.width(); ++x) {
            const bool inside = int(x) >= r.x0 && int(x) < r.x1 && int(y) >= r.y0 && int(y) < r.y1;
            (inside ? in : out) += film.sample_count(x, y);
            ++(inside ? n_in : n_out);
        }
    return {in / double(n_in), out / double(n_out)};
}

}  // namespace

TEST_CASE("relmse: an spp budget reaches uniform's error with fewer samples, n_p ~ sqrt(a_p)") {
    TwoNoiseSource src(kW, kH, kHard, kHardNoise, kEasyNoise);
    constexpr uint32_t kBudget = 64;
    sampling::Film film(kW, kH);
    AdaptiveOptions o = relmse_options(2);
    o.spp_budget = kBudget;
    o.max_spp = 8 * kBudget;
    AdaptiveScheduler sched(src, film, o);
    REQUIRE(sched.adaptive());
    const AdaptiveStats st = sched.render();
    const auto [in, out] = spp_in_out(film, kHard);
    const double err = true_rel_mse(film), uniform = uniform_rel_mse(kBudget);
    const double samples_ratio = double(st.samples) / (double(kBudget) * kW * kH);
    MESSAGE(st.describe() << "; hard " << in << " spp, easy " << out << " spp; relMSE " << err
                          << " against uniform's " << uniform << "; samples x" << samples_ratio
                          << "; tree target " << st.tree_target);
    CHECK(st.converged);
    // Lagrange: n_p ~ sqrt(a_p), 4x here; the passes' steps (16, 32, 64, +64) blur it.
    CHECK(in / out > 2.5);
    CHECK(in / out < 6.5);
    // The oracle needs (mean sqrt a)^2 / mean a = 0.69 of the samples for uniform's error.
    CHECK(samples_ratio < 0.9);
    CHECK(err < 1.25 * uniform);
    // The stats' estimate is the estimated image relMSE.
    CHECK(st.error_estimate > 0.5 * err);
    CHECK(st.error_estimate < 2.0 * err);
}

TEST_CASE("relmse: the error target is the image relMSE the render reaches") {
    TwoNoiseSource src(kW, kH, kHard, kHardNoise, kEasyNoise);
    for (uint32_t n : {64u, 256u}) {
        const double target = uniform_rel_mse(n);
        sampling::Film film(kW, kH);
        AdaptiveOptions o = relmse_options(2);
        o.error_target = target;
        o.max_spp = 16 * n;
        AdaptiveScheduler sched(src, film, o);
        const AdaptiveStats st = sched.render();
        const double err = true_rel_mse(film);
        MESSAGE("target " << target << ": relMSE " << err << ", " << st.describe());
        CHECK(st.converged);
        CHECK(err < 1.3 * target);
        CHECK(err > 0.3 * target);  // not far past it either (the passes overshoot a little)
        CHECK(double(st.samples) < 0.95 * double(n) * kW * kH);
    }
}

TEST_CASE("relmse: a noisy patch narrower than a tile gets the samples, not its whole tile") {
    // Noise only in a 3x3 patch inside one tile (plus a trace elsewhere, so that every pixel has
    // an estimate).
    const sampling::PixelBounds patch{26, 19, 29, 22};
    TwoNoiseSource src(kW, kH, patch, 0.4f, 0.005f);
    sampling::Film film(kW, kH);
    AdaptiveOptions o = relmse_options(2);
    o.spp_budget = 32;
    o.max_spp = 512;
    AdaptiveScheduler sched(src, film, o);
    const AdaptiveStats st = sched.render();
    const auto [in, out] = spp_in_out(film, patch);
    // The patch's tile (24..32 x 16..24) outside the patch and its 1-pixel ring.
    double same_tile = 0;
    int count = 0;
    for (uint32_t y = 16; y < 24; ++y)
        for (uint32_t x = 24; x < 32; ++x)
            if (!(int(x) >= patch.x0 - 1 && int(x) < patch.x1 + 1 && int(y) >= patch.y0 - 1 &&
                  int(y) < patch.y1 + 1)) {
                same_tile += film.sample_count(x, y);
                ++count;
            }
    same_tile /= count;
    MESSAGE(st.describe() << "; patch " << in << " spp, rest of its tile " << same_tile
                          << ", elsewhere " << out);
    // E is uniform's relMSE at 32 spp, which the patch dominates: it needs about 34 spp
    // (the passes give 64), the calm pixels stay near the uniform first pass.
    CHECK(in >= 48);
    CHECK(in > 3 * out);
    CHECK(in > 3 * same_tile);
}

TEST_CASE("relmse: deterministic renders are bit-identical for 1 and 3 threads") {
    TwoNoiseSource src(kW, kH, kHard, kHardNoise, kEasyNoise);
    for (int mode = 0; mode < 3; ++mode) {
        CAPTURE(mode);
        std::vector<std::vector<float>> images;
        for (uint32_t threads : {1u, 3u}) {
            sampling::Film film(kW, kH, {}, mode == 2);
            AdaptiveOptions o = relmse_options(threads);
            if (mode == 0) {
                o.spp_budget = 48;
                o.max_spp = 384;
            } else {  // refining to an spp cap, half buffer and prefix estimate
                o.refine_target = true;
                o.error_target = 1.0;
                o.max_spp = 256;
            }
            AdaptiveScheduler sched(src, film, o);
            sched.render();
            std::vector<float> img(size_t(kW) * kH * 4);
            for (uint32_t y = 0; y < kH; ++y)
                for (uint32_t x = 0; x < kW; ++x) {
                    const sampling::PixelStats s = film.pixel_stats(x, y);
                    float *p = &img[(size_t(y) * kW + x) * 4];
                    for (int c = 0; c < 3; ++c) p[c] = float(s.mean[c]);
                    p[3] = float(s.taken);
                }
            images.push_back(std::move(img));
        }
        CHECK(std::memcmp(images[0].data(), images[1].data(), images[0].size() * 4) == 0);
    }
}
