// Error-versus-time curves of progressive renders (`tessera converge`): when to take snapshots,
// the slope of a curve on log-log axes, and the time a curve reaches a given error.
//
// A Monte Carlo estimator's variance falls as 1/n, so at a constant sample rate MSE(t) ~ c t^-1:
// a straight line of slope -1 on log-log axes (RMSE and MAE: -1/2). Snapshots are therefore
// spaced evenly in log t, and "time to reach error E" interpolates linearly between the two
// snapshots around E in (log t, log error), i.e. along the power law through them.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace tessera::sampling {

/// `count` times from `first_s` to `last_s` (seconds, both included), evenly spaced in log t:
/// t_k = first_s * (last_s / first_s)^(k / (count - 1)). One snapshot gives {last_s}; the last
/// entry is exactly last_s. Throws std::invalid_argument unless 0 < first_s <= last_s and
/// count >= 1. Pure.
std::vector<double> log_spaced_times(double first_s, double last_s, std::size_t count);

/// A least-squares line through (log10 t, log10 error): error ~ 10^intercept * t^slope.
struct LogLogFit {
    double slope = 0;
    double intercept = 0;
    std::size_t points = 0;  ///< points used (positive, finite time and error)
    bool valid = false;      ///< at least two points with distinct times
};

/// Fits error = a t^slope to the points with t > 0 and finite error > 0 (others are skipped).
/// `time_s` and `error` must have the same size (std::invalid_argument otherwise). Pure.
LogLogFit fit_loglog(std::span<const double> time_s, std::span<const double> error);

/// Where a curve first reaches an error level.
struct Crossing {
    enum class Kind {
        reached,       ///< between two snapshots (or exactly at one): `time_s` interpolated
        before_first,  ///< the first usable snapshot was already at or below the level
        not_reached,   ///< no snapshot reached it
    };
    Kind kind = Kind::not_reached;
    double time_s = 0;  ///< reached: the interpolated time; before_first: that snapshot's time;
                        ///< not_reached: the last snapshot's time (a lower bound)
};

/// The first time the curve (time_s ascending, errors per snapshot) reaches `level` (> 0):
/// the first snapshot i with error[i] <= level, log-log interpolated against snapshot i - 1.
/// Points with non-positive or non-finite values are skipped. Sizes must match. Pure.
Crossing time_to_reach(std::span<const double> time_s, std::span<const double> error, double level);

}  // namespace tessera::sampling
