// The adaptive sampler's refinement keys and their default (renderer/app/render.h,
// apply_refinement): opt-in (adaptive:refine=1), starting from a loose target unless an error
// is given.
#include <doctest/doctest.h>

#include "renderer/app/render.h"

using namespace tessera;

TEST_CASE("adaptive:refine keys parse; refinement is opt-in") {
    sched::AdaptiveOptions base;
    base.adaptive = true;
    base.error_target = kDefaultErrorTarget;

    // Unset: no refinement, the fixed default target.
    SamplerSpec plain = parse_sampler_spec("adaptive");
    CHECK(!plain.refine);
    CHECK(plain.refine_floor_ratio == 3);
    sched::AdaptiveOptions o = base;
    apply_refinement(o, plain);
    CHECK(!o.refine_target);
    CHECK(o.error_target == kDefaultErrorTarget);

    // refine=1 without an error: refining from the loose start target.
    SamplerSpec on = parse_sampler_spec("adaptive:refine=1");
    REQUIRE(on.refine);
    o = base;
    apply_refinement(o, on);
    CHECK(o.refine_target);
    CHECK(o.error_target == kDefaultRefineStartTarget);
    CHECK(o.refine_factor == 0.5);
    CHECK(o.refine_spp_ratio == 8);
    CHECK(o.refine_floor_ratio == 3);

    // An explicit error with refine=1 is the start target; the other keys are passed on.
    SamplerSpec both = parse_sampler_spec(
        "adaptive:error=0.003,refine=1,refine-factor=0.7,refine-spp-ratio=4,"
        "refine-floor-ratio=0");
    REQUIRE(both.refine);
    CHECK(*both.refine);
    o = base;
    o.error_target = 0.003;
    apply_refinement(o, both);
    CHECK(o.refine_target);
    CHECK(o.error_target == 0.003);
    CHECK(o.refine_factor == 0.7);
    CHECK(o.refine_spp_ratio == 4);
    CHECK(o.refine_floor_ratio == 0);
    CHECK(both.describe().find("refine=1") != std::string::npos);
    CHECK(both.describe().find("refine-floor-ratio=0") != std::string::npos);
    CHECK(plain.describe().find("refine") == std::string::npos);

    // refine=0 is the same as unset.
    o = base;
    apply_refinement(o, parse_sampler_spec("adaptive:refine=0"));
    CHECK(!o.refine_target);
    CHECK(o.error_target == kDefaultErrorTarget);

    // Bad values are refused with the key named; uniform is left alone.
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:refine=2"), SceneError);
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:refine-factor=1.5"), SceneError);
    sched::AdaptiveOptions u;
    u.adaptive = false;
    apply_refinement(u, parse_sampler_spec("uniform"));
    CHECK(!u.refine_target);
}

TEST_CASE("adaptive:prefix-error: on by default exactly when refining, recorded when not") {
    SamplerSpec plain = parse_sampler_spec("adaptive");
    CHECK_FALSE(plain.prefix_error);
    CHECK_FALSE(keeps_prefix(plain));
    CHECK(plain.describe().find("prefix-error") == std::string::npos);

    SamplerSpec refine = parse_sampler_spec("adaptive:refine=1");
    CHECK(refine.prefix_error);
    CHECK(keeps_prefix(refine));
    CHECK(refine.describe().find("prefix-error") == std::string::npos);

    SamplerSpec refine_half = parse_sampler_spec("adaptive:refine=1,prefix-error=0");
    CHECK_FALSE(refine_half.prefix_error);
    CHECK_FALSE(keeps_prefix(refine_half));
    CHECK(refine_half.describe().find(",prefix-error=0") != std::string::npos);

    SamplerSpec prefix = parse_sampler_spec("adaptive:prefix-error=1");
    CHECK(prefix.prefix_error);
    CHECK(keeps_prefix(prefix));
    CHECK(prefix.describe().find(",prefix-error=1") != std::string::npos);
    // The settings line round-trips (checkpoints compare it).
    CHECK(parse_sampler_spec(prefix.describe()).prefix_error);
    CHECK_FALSE(parse_sampler_spec(refine_half.describe()).prefix_error);

    CHECK_FALSE(keeps_prefix(parse_sampler_spec("uniform")));
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:prefix-error=2"), SceneError);
    CHECK_THROWS_AS(parse_sampler_spec("uniform:prefix-error=1"), SceneError);
}
