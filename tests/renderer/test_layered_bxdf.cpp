// Unit tests of the stochastic layered BSDF (renderer/shading/layered_bxdf.h) and of the restricted
// dielectric sampling its random walk uses: determinism, two-sidedness, flags, the cases with
// an exact answer (a black base, no coat, an empty walk) and the Bsdf wrapper. Fast and exact;
// the statistical properties are in test_layered_bxdf_stat.cpp.
#include <cmath>
#include <cstring>

#include "approx.h"
#include "bsdf_test_util.h"
#include "chi2.h"
#include "renderer/shading/bsdf.h"
#include "sampling/warp.h"

using namespace tessera;
using tessera::test::dir_from_theta;
using tessera::test::Approx;

namespace {

bool same_bits(Rgb a, Rgb b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

ConductorBxdf metal(float alpha) {
    return ConductorBxdf{TrowbridgeReitz(alpha, alpha), Rgb(0.2f, 0.6f, 1.1f) / 1.5f,
                         Rgb(3.8f, 2.5f, 2.f) / 1.5f};
}

CoatedDiffuseBxdf coated_diffuse(Rgb r, float coat_alpha, float thickness = 0.01f,
                                 Rgb albedo = Rgb(0.f), float g = 0.f, int max_depth = 10,
                                 int n_samples = 1) {
    return CoatedDiffuseBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(coat_alpha, coat_alpha)},
                             DiffuseBxdf{r}, thickness, albedo, g, max_depth, n_samples);
}

}  // namespace

TEST_CASE("restricted dielectric sampling: one lobe with probability 1") {
    const float eta = 1.5f;
    DielectricBxdf smooth{eta, TrowbridgeReitz(0.f, 0.f)};
    for (float th : {0.f, 35.f, 80.f}) {
        const Vec3f wo = dir_from_theta(th);
        const float R = fr_dielectric(wo.z, eta);
        for (float uc : {0.f, 0.5f, kOneMinusEpsilon}) {
            auto r = smooth.sample_f(wo, uc, {0.3f, 0.6f}, TransportMode::Radiance,
                                     kReflTransReflection);
            REQUIRE(r);
            CHECK(r->is_reflection());
            CHECK(r->is_specular());
            CHECK(r->pdf == 1.f);
            CHECK(r->f.r * r->wi.z == Approx(R).epsilon(1e-5));
            auto t = smooth.sample_f(wo, uc, {0.3f, 0.6f}, TransportMode::Radiance,
                                     kReflTransTransmission);
            REQUIRE(t);
            CHECK(t->is_transmission());
            CHECK(t->pdf == 1.f);
            CHECK(t->eta == Approx(eta));
            // T / eta^2 in radiance mode, T in importance mode.
            CHECK(t->f.r * std::abs(t->wi.z) == Approx((1.f - R) / (eta * eta)).epsilon(1e-5));
            auto ti = smooth.sample_f(wo, uc, {0.3f, 0.6f}, TransportMode::Importance,
                                      kReflTransTransmission);
            REQUIRE(ti);
            CHECK(ti->f.r * std::abs(ti->wi.z) == Approx(1.f - R).epsilon(1e-5));
        }
    }
    // Beyond the critical angle from inside there is nothing to transmit.
    const Vec3f inside = -dir_from_theta(60.f);
    CHECK_FALSE(smooth.sample_f(inside, 0.5f, {0.5f, 0.5f}, TransportMode::Radiance,
                                kReflTransTransmission));
    CHECK(
        smooth.sample_f(inside, 0.5f, {0.5f, 0.5f}, TransportMode::Radiance, kReflTransReflection));
    // Rough: the restricted pdf is the lobe's full density; a lobe left out has none.
    DielectricBxdf rough{eta, TrowbridgeReitz(0.3f, 0.3f)};
    const Vec3f wo = dir_from_theta(30.f);
    const Vec3f wr = dir_from_theta(40.f, 210.f), wt = dir_from_theta(160.f, 210.f);
    const float p_all = rough.pdf(wo, wr, TransportMode::Radiance);
    const float p_refl = rough.pdf(wo, wr, TransportMode::Radiance, kReflTransReflection);
    CHECK(p_refl > 5.f * p_all);  // R is small at 40 degrees: the split favoured transmission
    CHECK(rough.pdf(wo, wr, TransportMode::Radiance, kReflTransTransmission) == 0.f);
    CHECK(rough.pdf(wo, wt, TransportMode::Radiance, kReflTransReflection) == 0.f);
    CHECK(rough.pdf(wo, wt, TransportMode::Radiance, kReflTransTransmission) >
          rough.pdf(wo, wt, TransportMode::Radiance));
    // An unrestricted call is the one every other caller makes: the same numbers.
    for (float uc : {0.01f, 0.5f, 0.99f}) {
        auto a = rough.sample_f(wo, uc, {0.2f, 0.7f}, TransportMode::Radiance);
        auto b = rough.sample_f(wo, uc, {0.2f, 0.7f}, TransportMode::Radiance, kReflTransAll);
        REQUIRE(a);
        REQUIRE(b);
        CHECK(same_bits(a->f, b->f));
        CHECK(a->pdf == b->pdf);
    }
    // Diffuse and conductor reflect only.
    CHECK_FALSE(DiffuseBxdf{Rgb(0.5f)}.sample_f(wo, 0.5f, {0.5f, 0.5f}, TransportMode::Radiance,
                                                kReflTransTransmission));
    CHECK(DiffuseBxdf{Rgb(0.5f)}.pdf(wo, wr, TransportMode::Radiance, kReflTransTransmission) ==
          0.f);
    CHECK_FALSE(metal(0.2f).sample_f(wo, 0.5f, {0.5f, 0.5f}, TransportMode::Radiance,
                                     kReflTransTransmission));
    CHECK(metal(0.2f).pdf(wo, wr, TransportMode::Radiance, kReflTransTransmission) == 0.f);
}

TEST_CASE("layered: f, pdf and sample_f are deterministic functions of their arguments") {
    const CoatedDiffuseBxdf b = coated_diffuse(Rgb(0.7f, 0.5f, 0.3f), 0.3f, 0.1f, Rgb(0.5f), 0.3f);
    const Vec3f wo = dir_from_theta(40.f), wi = dir_from_theta(25.f, 190.f);
    const Rgb f1 = b.f(wo, wi, TransportMode::Radiance);
    CHECK(same_bits(f1, b.f(wo, wi, TransportMode::Radiance)));
    CHECK(b.pdf(wo, wi, TransportMode::Radiance) == b.pdf(wo, wi, TransportMode::Radiance));
    auto s1 = b.sample_f(wo, 0.7f, {0.3f, 0.8f}, TransportMode::Radiance);
    auto s2 = b.sample_f(wo, 0.7f, {0.3f, 0.8f}, TransportMode::Radiance);
    REQUIRE(s1.has_value() == s2.has_value());
    if (s1) {
        CHECK(same_bits(s1->f, s2->f));
        CHECK(s1->pdf == s2->pdf);
        CHECK(s1->wi.x == s2->wi.x);
    }
    // A copy (another thread's BSDF) gives the same value; another direction another estimate.
    const CoatedDiffuseBxdf copy = b;
    CHECK(same_bits(f1, copy.f(wo, wi, TransportMode::Radiance)));
    CHECK(!same_bits(f1, b.f(wo, dir_from_theta(25.001f, 190.f), TransportMode::Radiance)));
}

TEST_CASE("layered: two-sided, no transmission, flags") {
    const CoatedConductorBxdf b(DielectricBxdf{1.5f, TrowbridgeReitz(0.2f, 0.2f)}, metal(0.3f),
                                0.05f, Rgb(0.f), 0.f, 10, 1);
    const Vec3f wo = dir_from_theta(50.f), wi = dir_from_theta(30.f, 250.f);
    // Mirrored directions see the top interface too: the same call, bit for bit.
    CHECK(same_bits(b.f(-wo, -wi, TransportMode::Radiance), b.f(wo, wi, TransportMode::Radiance)));
    CHECK(b.pdf(-wo, -wi, TransportMode::Radiance) == b.pdf(wo, wi, TransportMode::Radiance));
    auto up = b.sample_f(wo, 0.9f, {0.4f, 0.2f}, TransportMode::Radiance);
    auto down = b.sample_f(-wo, 0.9f, {0.4f, 0.2f}, TransportMode::Radiance);
    REQUIRE(up);
    REQUIRE(down);
    CHECK(down->wi.z == -up->wi.z);
    CHECK(same_bits(up->f, down->f));
    // Opaque: nothing reaches the other side, but pdf() keeps its uniform floor there.
    CHECK(b.f(wo, -wi, TransportMode::Radiance).is_black());
    CHECK(b.pdf(wo, -wi, TransportMode::Radiance) == Approx(0.1f * kInv4Pi).epsilon(1e-6));
    CHECK(b.pdf(wo, wi, TransportMode::Radiance) >= 0.1f * kInv4Pi);
    // pbrt-v4's flags.
    CHECK(b.flags() == (kBxdfReflection | kBxdfGlossy));
    CHECK(coated_diffuse(Rgb(0.5f), 0.f).flags() ==
          (kBxdfReflection | kBxdfSpecular | kBxdfDiffuse));
    CHECK(coated_diffuse(Rgb(0.f), 0.f).flags() == (kBxdfReflection | kBxdfSpecular));
    CHECK(coated_diffuse(Rgb(0.f), 0.f, 0.1f, Rgb(0.5f)).flags() ==
          (kBxdfReflection | kBxdfSpecular | kBxdfDiffuse));
    const CoatedConductorBxdf mirror(DielectricBxdf{1.5f, TrowbridgeReitz(0.f, 0.f)}, metal(0.f),
                                     0.01f, Rgb(0.f), 0.f, 10, 1);
    CHECK(mirror.flags() == (kBxdfReflection | kBxdfSpecular));
    // Every sample is a reflection and says its pdf is only proportional.
    test::Chi2Rng rng(3);
    int n = 0;
    for (int i = 0; i < 200; ++i) {
        auto s = b.sample_f(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance);
        if (!s)
            continue;
        ++n;
        CHECK(s->is_reflection());
        CHECK(s->pdf_is_proportional);
        CHECK(s->eta == 1.f);
        CHECK(s->wi.z > 0.f);
        CHECK(std::abs(length(s->wi) - 1.f) < 1e-4f);
    }
    CHECK(n > 100);
}

TEST_CASE("layered: a black base under a smooth coat reflects only the coat's Fresnel") {
    // f() is 0 (the coat is a delta, the base black) and sample_f returns the coat's mirror
    // with weight 1 for uc < R and nothing otherwise: E[weight] = R exactly.
    const CoatedDiffuseBxdf b = coated_diffuse(Rgb(0.f), 0.f);
    for (float th : {0.f, 45.f, 85.f}) {
        const Vec3f wo = dir_from_theta(th);
        const float R = fr_dielectric(wo.z, 1.5f);
        CHECK(b.f(wo, dir_from_theta(20.f, 100.f), TransportMode::Radiance).is_black());
        auto refl = b.sample_f(wo, 0.99f * R, {0.5f, 0.5f}, TransportMode::Radiance);
        REQUIRE(refl);
        CHECK(refl->is_specular());
        CHECK(refl->f.g * refl->wi.z / refl->pdf == Approx(1.f).epsilon(1e-5));
        CHECK(refl->pdf == Approx(R).epsilon(1e-6));
        CHECK_FALSE(b.sample_f(wo, R + 0.01f, {0.5f, 0.5f}, TransportMode::Radiance));
    }
}

TEST_CASE("layered: without a coat (eta 1) and a vanishing layer it is the bare base") {
    const ConductorBxdf base = metal(0.3f);
    const CoatedConductorBxdf b(DielectricBxdf{1.f, TrowbridgeReitz(0.f, 0.f)}, base, 0.f, Rgb(0.f),
                                0.f, 10, 1);
    test::Chi2Rng rng(9);
    for (int i = 0; i < 50; ++i) {
        const Vec3f wo = sampling::square_to_uniform_hemisphere(rng.uniform2());
        const Vec3f wi = sampling::square_to_uniform_hemisphere(rng.uniform2());
        const Rgb a = b.f(wo, wi, TransportMode::Radiance);
        const Rgb c = base.f(wo, wi, TransportMode::Radiance);
        for (int ch = 0; ch < 3; ++ch)
            CHECK(a[ch] == Approx(c[ch]).epsilon(1e-4));
        // sample_f: straight through, a sample of the conductor, straight out: its weight.
        auto s = b.sample_f(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance);
        if (s) {
            const float expected = base.f(wo, s->wi, TransportMode::Radiance).g * s->wi.z /
                                   base.pdf(wo, s->wi, TransportMode::Radiance);
            CHECK(s->f.g * s->wi.z / s->pdf == Approx(expected).epsilon(1e-3));
        }
    }
}

TEST_CASE("layered: maxdepth 0 keeps only the entrance reflection; nsamples averages") {
    const CoatedDiffuseBxdf none = coated_diffuse(Rgb(0.8f), 0.3f, 0.01f, Rgb(0.f), 0.f, 0, 1);
    const DielectricBxdf coat{1.5f, TrowbridgeReitz(0.3f, 0.3f)};
    const Vec3f wo = dir_from_theta(30.f), wi = dir_from_theta(35.f, 200.f);
    CHECK(none.f(wo, wi, TransportMode::Radiance).g ==
          Approx(coat.f(wo, wi, TransportMode::Radiance).r).epsilon(1e-6));
    test::Chi2Rng rng(4);
    for (int i = 0; i < 100; ++i) {
        auto s = none.sample_f(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance);
        if (s)
            CHECK(s->f.g == Approx(coat.f(wo, s->wi, TransportMode::Radiance).r).epsilon(1e-5));
    }
    // More walks per estimate: the same expectation, less spread (checked in the _stat test);
    // here only that the constructor keeps at least one walk and no negative depth.
    const CoatedDiffuseBxdf clamped = coated_diffuse(Rgb(0.8f), 0.3f, -1.f, Rgb(0.f), 0.f, -3, 0);
    CHECK(clamped.n_samples == 1);
    CHECK(clamped.max_depth == 0);
    CHECK(clamped.thickness > 0.f);
    CHECK(coated_diffuse(Rgb(0.8f), 0.3f, 0.01f, Rgb(0.f), 0.f, 10, 8).n_samples == 8);
}

TEST_CASE("layered: the Bsdf wrapper passes pdf_is_proportional and the albedo hint") {
    const Frame frame = Frame::from_z(normalize(Vec3f(0.3f, -0.5f, 0.8f)));
    Bsdf b(frame, coated_diffuse(Rgb(0.2f, 0.4f, 0.6f), 0.2f));
    CHECK(b.albedo_hint().b == Approx(0.6f));
    CHECK(b.has_non_specular());
    const Vec3f wo = frame.to_world(dir_from_theta(40.f));
    test::Chi2Rng rng(8);
    int n = 0;
    for (int i = 0; i < 50; ++i) {
        auto s = b.sample_f(wo, rng.uniform(), rng.uniform2());
        if (!s)
            continue;
        ++n;
        CHECK(s->pdf_is_proportional);
        CHECK(dot(s->wi, frame.z) > 0.f);
        float p = 0.f;
        const Rgb f = b.f_pdf(wo, s->wi, &p);
        CHECK(p > 0.f);
        CHECK(f.is_finite());
    }
    CHECK(n > 20);
    Bsdf cc(frame, CoatedConductorBxdf(DielectricBxdf{1.5f, TrowbridgeReitz(0.f, 0.f)},
                                       ConductorBxdf{TrowbridgeReitz(0.f, 0.f), Rgb(1.f),
                                                     conductor_k_from_reflectance(Rgb(0.5f))},
                                       0.01f, Rgb(0.f), 0.f, 10, 1));
    CHECK(cc.albedo_hint().r == Approx(0.5f).epsilon(1e-3));
    CHECK_FALSE(cc.has_non_specular());
}

TEST_CASE("layered: a coherent seed makes f a smooth function of the directions") {
    // With the default seeding (a hash of the directions) two nearby directions get
    // independent estimates; with a coherent seed the same walks, so nearly the same value.
    CoatedDiffuseBxdf noisy = coated_diffuse(Rgb(0.7f), 0.3f);
    CoatedDiffuseBxdf smooth = noisy;
    smooth.coherent_seed = 7;
    const Vec3f wo = dir_from_theta(35.f);
    int noisy_jumps = 0;
    for (int i = 0; i < 50; ++i) {
        const float th = 10.f + float(i);
        const Vec3f a = dir_from_theta(th, 200.f), b = dir_from_theta(th + 0.01f, 200.f);
        const float fa = smooth.f(wo, a, TransportMode::Radiance).g;
        const float fb = smooth.f(wo, b, TransportMode::Radiance).g;
        CHECK(fb == Approx(fa).epsilon(2e-3));
        CHECK(same_bits(smooth.f(wo, a, TransportMode::Radiance), Rgb(fa)));
        CHECK(smooth.pdf(wo, b, TransportMode::Radiance) ==
              Approx(smooth.pdf(wo, a, TransportMode::Radiance)).epsilon(2e-3));
        const float na = noisy.f(wo, a, TransportMode::Radiance).g;
        const float nb = noisy.f(wo, b, TransportMode::Radiance).g;
        if (std::abs(na - nb) > 0.02f * std::max(na, nb))
            ++noisy_jumps;
    }
    CHECK(noisy_jumps > 25);
}
