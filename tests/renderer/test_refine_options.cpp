// The adaptive sampler's modes for a budget (renderer/app/render.h, apply_refinement): with the
// relMSE metric (the default) the budget decides (a time budget refines with no spp cap, an spp
// budget alone becomes spp_budget, an explicit error is the relMSE target); with dammertz=1
// refinement stays opt-in (adaptive:refine=1) from a loose target unless an error is given.
// Also the prefix-error default of each, and the settings line checkpoints compare.
#include <doctest/doctest.h>

#include "renderer/app/render.h"

using namespace tessera;

namespace {

sched::AdaptiveOptions base_options() {
    sched::AdaptiveOptions o;
    o.adaptive = true;
    o.error_target = kDefaultErrorTarget;
    o.max_spp = 256;  // the scene's spp, as scheduler_options sets it
    return o;
}

}  // namespace

TEST_CASE("relMSE metric: the budget decides") {
    const SamplerSpec plain = parse_sampler_spec("adaptive");
    CHECK(!plain.dammertz);
    CHECK(plain.metric() == sampling::ErrorMetric::RelMse);

    // --spp alone: the relMSE of that many uniform samples, pixels up to refine-spp-ratio x it.
    sched::AdaptiveOptions o = base_options();
    apply_refinement(o, plain);
    CHECK(o.metric == sampling::ErrorMetric::RelMse);
    CHECK(!o.refine_target);
    CHECK(o.error_target == 0);
    CHECK(o.spp_budget == 256);
    CHECK(o.max_spp == 256 * 8);

    // --time: refining from kRelMseRefineStart, the scene's spp no cap...
    o = base_options();
    apply_refinement(o, plain, RenderBudget{true, false});
    CHECK(o.refine_target);
    CHECK(o.error_target == kRelMseRefineStart);
    CHECK(o.max_spp == 0);
    CHECK(o.spp_budget == 0);
    // ... but --spp with --time is.
    o = base_options();
    apply_refinement(o, plain, RenderBudget{true, true});
    CHECK(o.refine_target);
    CHECK(o.max_spp == 256);
    // refine=0 with --time: the time budget with an spp budget.
    o = base_options();
    apply_refinement(o, parse_sampler_spec("adaptive:refine=0"), RenderBudget{true, true});
    CHECK(!o.refine_target);
    CHECK(o.spp_budget == 256);

    // An explicit error is the image relMSE to reach; refine=1 starts from it.
    o = base_options();
    apply_refinement(o, parse_sampler_spec("adaptive:error=0.002"), RenderBudget{true, false});
    CHECK(!o.refine_target);
    CHECK(o.error_target == 0.002);
    CHECK(o.max_spp == 256);
    o = base_options();
    apply_refinement(o, parse_sampler_spec("adaptive:error=0.003,refine=1,refine-factor=0.7"));
    CHECK(o.refine_target);
    CHECK(o.error_target == 0.003);
    CHECK(o.refine_factor == 0.7);

    // Uniform is left alone.
    sched::AdaptiveOptions u;
    u.adaptive = false;
    u.max_spp = 64;
    apply_refinement(u, parse_sampler_spec("uniform"), RenderBudget{true, false});
    CHECK(!u.refine_target);
    CHECK(u.max_spp == 64);
    CHECK(u.spp_budget == 0);
}

TEST_CASE("dammertz=1: MoonRay's rule, refinement opt-in") {
    // Unset: no refinement, the fixed default target.
    SamplerSpec plain = parse_sampler_spec("adaptive:dammertz=1");
    CHECK(plain.dammertz);
    CHECK(!plain.refine);
    CHECK(plain.refine_floor_ratio == 3);
    sched::AdaptiveOptions o = base_options();
    apply_refinement(o, plain, RenderBudget{true, false});
    CHECK(o.metric == sampling::ErrorMetric::Dammertz);
    CHECK(!o.refine_target);
    CHECK(o.error_target == kDefaultErrorTarget);
    CHECK(o.max_spp == 256);

    // refine=1 without an error: refining from the loose start target.
    SamplerSpec on = parse_sampler_spec("adaptive:dammertz=1,refine=1");
    REQUIRE(on.refine);
    o = base_options();
    apply_refinement(o, on);
    CHECK(o.refine_target);
    CHECK(o.error_target == kDefaultRefineStartTarget);
    CHECK(o.refine_factor == 0.5);
    CHECK(o.refine_spp_ratio == 8);
    CHECK(o.refine_floor_ratio == 3);

    // An explicit error with refine=1 is the start target; the other keys are passed on.
    SamplerSpec both = parse_sampler_spec(
        "adaptive:dammertz=1,error=0.003,refine=1,refine-factor=0.7,refine-spp-ratio=4,"
        "refine-floor-ratio=0");
    REQUIRE(both.refine);
    CHECK(*both.refine);
    o = base_options();
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
    o = base_options();
    apply_refinement(o, parse_sampler_spec("adaptive:dammertz=1,refine=0"));
    CHECK(!o.refine_target);
    CHECK(o.error_target == kDefaultErrorTarget);

    // Bad values are refused with the key named.
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:refine=2"), SceneError);
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:dammertz=2"), SceneError);
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:refine-factor=1.5"), SceneError);
}

TEST_CASE("adaptive:prefix-error: on by default (dammertz=1: exactly when refining)") {
    SamplerSpec plain = parse_sampler_spec("adaptive");
    CHECK(plain.prefix_error);
    CHECK(keeps_prefix(plain));
    CHECK(plain.describe().find("prefix-error") == std::string::npos);
    SamplerSpec half = parse_sampler_spec("adaptive:prefix-error=0");
    CHECK_FALSE(keeps_prefix(half));
    CHECK(half.describe().find(",prefix-error=0") != std::string::npos);

    SamplerSpec d = parse_sampler_spec("adaptive:dammertz=1");
    CHECK_FALSE(d.prefix_error);
    CHECK_FALSE(keeps_prefix(d));
    CHECK(d.describe().find("prefix-error") == std::string::npos);

    SamplerSpec refine = parse_sampler_spec("adaptive:dammertz=1,refine=1");
    CHECK(refine.prefix_error);
    CHECK(keeps_prefix(refine));
    CHECK(refine.describe().find("prefix-error") == std::string::npos);

    SamplerSpec refine_half = parse_sampler_spec("adaptive:dammertz=1,refine=1,prefix-error=0");
    CHECK_FALSE(refine_half.prefix_error);
    CHECK_FALSE(keeps_prefix(refine_half));
    CHECK(refine_half.describe().find(",prefix-error=0") != std::string::npos);

    SamplerSpec prefix = parse_sampler_spec("adaptive:dammertz=1,prefix-error=1");
    CHECK(prefix.prefix_error);
    CHECK(keeps_prefix(prefix));
    CHECK(prefix.describe().find(",prefix-error=1") != std::string::npos);
    // The settings line round-trips (checkpoints compare it).
    for (const SamplerSpec *s : {&plain, &half, &d, &refine, &refine_half, &prefix}) {
        const SamplerSpec back = parse_sampler_spec(s->describe());
        CHECK(back.describe() == s->describe());
        CHECK(back.prefix_error == s->prefix_error);
        CHECK(back.dammertz == s->dammertz);
    }
    CHECK(parse_sampler_spec("adaptive:error=0.0004").describe().find("error=0.0004") !=
          std::string::npos);

    CHECK_FALSE(keeps_prefix(parse_sampler_spec("uniform")));
    CHECK_THROWS_AS(parse_sampler_spec("adaptive:prefix-error=2"), SceneError);
    CHECK_THROWS_AS(parse_sampler_spec("uniform:prefix-error=1"), SceneError);
}
