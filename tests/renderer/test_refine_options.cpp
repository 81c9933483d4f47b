// The adaptive sampler's refinement keys and their default (renderer/render.h,
// apply_refinement): on with a time budget and no explicit error, off otherwise.
#include <doctest/doctest.h>

#include "renderer/render.h"

using namespace tessera;

TEST_CASE("adaptive:refine keys parse, and the default follows --time and --error") {
    sched::AdaptiveOptions base;
    base.adaptive = true;
    base.error_target = kDefaultErrorTarget;

    // Time budget, no error: refining from the loose start target.
    SamplerSpec plain = parse_sampler_spec("adaptive");
    CHECK(!plain.refine);
    sched::AdaptiveOptions o = base;
    apply_refinement(o, plain, 10.0);
    CHECK(o.refine_target);
    CHECK(o.error_target == kDefaultRefineStartTarget);
    CHECK(o.refine_factor == 0.5);

    // No time budget: as before (stop at convergence).
    o = base;
    apply_refinement(o, plain, 0.0);
    CHECK(!o.refine_target);
    CHECK(o.error_target == kDefaultErrorTarget);

    // An explicit error keeps the fixed target, even with a time budget ...
    SamplerSpec fixed = parse_sampler_spec("adaptive:error=0.003");
    o = base;
    o.error_target = 0.003;
    apply_refinement(o, fixed, 10.0);
    CHECK(!o.refine_target);
    CHECK(o.error_target == 0.003);

    // ... unless refine=1 asks for it: then the explicit error is the start.
    SamplerSpec both = parse_sampler_spec(
        "adaptive:error=0.003,refine=1,refine-factor=0.7,refine-spp-ratio=4,"
        "refine-floor-ratio=0");
    REQUIRE(both.refine);
    CHECK(*both.refine);
    o = base;
    o.error_target = 0.003;
    apply_refinement(o, both, 0.0);
    CHECK(o.refine_target);
    CHECK(o.error_target == 0.003);
    CHECK(o.refine_factor == 0.7);
    CHECK(o.refine_spp_ratio == 4);
    CHECK(o.refine_floor_ratio == 0);
    CHECK(both.describe().find("refine=1") != std::string::npos);
    CHECK(plain.describe().find("refine") == std::string::npos);

    // refine=0 turns the default off.
    o = base;
    apply_refinement(o, parse_sampler_spec("adaptive:refine=0"), 10.0);
    CHECK(!o.refine_target);

    // Bad values are refused with the key named; uniform is left alone.
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:refine=2"), SceneError);
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:refine-factor=1.5"), SceneError);
    sched::AdaptiveOptions u;
    u.adaptive = false;
    apply_refinement(u, parse_sampler_spec("uniform"), 10.0);
    CHECK(!u.refine_target);
}
