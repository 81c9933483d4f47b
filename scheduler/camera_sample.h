// Where a scheduled sample lands on the film, and where the integrator's random numbers continue.
//
// The scheduler gives sample `index` of pixel (px, py) the film offset
// (fx, fy) = SobolSampler(seed, pattern) started at (px, py, index) -> get_pixel_2d(), i.e. the
// reserved dimensions 0 and 1 of sampling/sequence.h: a pure function of (seed, pixel, index),
// so the film never depends on the thread count or on the order tiles run. An integrator
// continues the same sequence at dimension sampling::kFirstFreeDimension with
// sampler_for(seed, cs, pattern), or equivalently
//   sampling::SobolSampler s(seed, pattern); s.start_pixel_sample(cs.px, cs.py, cs.index);
// Under SamplePattern::Sobol the film offset and the integrator's dimensions are coordinates of
// one Sobol point, so the scheduler and the integrator must use the same pattern.
#pragma once

#include <cstdint>

#include "sampling/sample_source.h"
#include "sampling/sequence.h"

namespace tessera::sched {

/// The camera sample of sample `index` of pixel (px, py) under sequence seed `seed`: the pixel,
/// the index, and the offset (fx, fy) in [0,1)^2 from the sequence's reserved pixel dimensions
/// (SobolSampler::get_pixel_2d). Pure and thread-safe.
inline CameraSample camera_sample(uint32_t seed, uint32_t px, uint32_t py, uint32_t index,
                                  sampling::SamplePattern pattern = sampling::SamplePattern::Padded) {
    sampling::SobolSampler s(seed, pattern);
    s.start_pixel_sample(px, py, index);
    const Vec2f u = s.get_pixel_2d();
    CameraSample cs;
    cs.px = px;
    cs.py = py;
    cs.fx = u.x;
    cs.fy = u.y;
    cs.index = index;
    return cs;
}

/// A sampler positioned where an integrator continues for `cs`: dimension
/// sampling::kFirstFreeDimension of (seed, cs.px, cs.py, cs.index). `seed` and `pattern` must
/// be the scheduler's (AdaptiveOptions::seed, ::pattern). Pure and thread-safe (returns a fresh
/// value).
inline sampling::SobolSampler sampler_for(
    uint32_t seed, const CameraSample &cs,
    sampling::SamplePattern pattern = sampling::SamplePattern::Padded) {
    sampling::SobolSampler s(seed, pattern);
    s.start_pixel_sample(cs.px, cs.py, cs.index);
    return s;
}

}  // namespace tessera::sched
