// Snapshot schedules, log-log fits and crossing times of error-versus-time curves.
#include "sampling/convergence_curve.h"

#include <cmath>
#include <stdexcept>

namespace tessera::sampling {

namespace {

bool usable(double t, double e) {
    return t > 0 && std::isfinite(t) && e > 0 && std::isfinite(e);
}

void check_sizes(std::span<const double> a, std::span<const double> b) {
    if (a.size() != b.size())
        throw std::invalid_argument("convergence curve: times and errors differ in length");
}

}  // namespace

std::vector<double> log_spaced_times(double first_s, double last_s, std::size_t count) {
    if (!(first_s > 0) || !(last_s >= first_s) || !std::isfinite(last_s) || count == 0)
        throw std::invalid_argument("log_spaced_times: need 0 < first <= last and count >= 1");
    if (count == 1)
        return {last_s};
    std::vector<double> t(count);
    const double log_ratio = std::log(last_s / first_s);
    for (std::size_t k = 0; k < count; ++k)
        t[k] = first_s * std::exp(log_ratio * double(k) / double(count - 1));
    // exp(log(x)) may miss the end by an ulp; the budget must be exact.
    t.front() = first_s;
    t.back() = last_s;
    return t;
}

LogLogFit fit_loglog(std::span<const double> time_s, std::span<const double> error) {
    check_sizes(time_s, error);
    // Ordinary least squares on (x, y) = (log10 t, log10 e), in double.
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < time_s.size(); ++i) {
        if (!usable(time_s[i], error[i]))
            continue;
        const double x = std::log10(time_s[i]), y = std::log10(error[i]);
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
        ++n;
    }
    LogLogFit fit;
    fit.points = n;
    if (n < 2)
        return fit;
    const double denom = double(n) * sxx - sx * sx;
    // All times equal (to rounding): no slope.
    if (!(std::abs(denom) > 1e-12 * std::max(1.0, double(n) * sxx)))
        return fit;
    fit.slope = (double(n) * sxy - sx * sy) / denom;
    fit.intercept = (sy - fit.slope * sx) / double(n);
    fit.valid = true;
    return fit;
}

Crossing time_to_reach(std::span<const double> time_s, std::span<const double> error,
                       double level) {
    check_sizes(time_s, error);
    Crossing c;
    if (!(level > 0))
        return c;
    bool have_prev = false;
    double t_prev = 0, e_prev = 0;
    for (std::size_t i = 0; i < time_s.size(); ++i) {
        const double t = time_s[i], e = error[i];
        if (!usable(t, e))
            continue;
        if (e <= level) {
            if (!have_prev) {
                c.kind = Crossing::Kind::before_first;
                c.time_s = t;
                return c;
            }
            c.kind = Crossing::Kind::reached;
            // Straight line in (log t, log e) between the previous snapshot (above the level)
            // and this one (at or below it).
            const double lt0 = std::log(t_prev), lt1 = std::log(t);
            const double le0 = std::log(e_prev), le1 = std::log(e), ll = std::log(level);
            const double f = le0 == le1 ? 1.0 : (le0 - ll) / (le0 - le1);
            c.time_s = std::exp(lt0 + f * (lt1 - lt0));
            return c;
        }
        have_prev = true;
        t_prev = t;
        e_prev = e;
        c.time_s = t;
    }
    c.kind = Crossing::Kind::not_reached;
    return c;
}

}  // namespace tessera::sampling
