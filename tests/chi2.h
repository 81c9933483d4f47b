// Chi-square goodness-of-fit test for direction samplers on the unit sphere.
//
// Reusable by any test of an importance sampler that produces directions with a solid-angle pdf
// (BSDFs, lights, phase functions). The recipe follows pbrt-v4's and Mitsuba's sampling tests:
//   1. draw N directions from the sampler with a fixed seed and histogram them on a (theta, phi)
//      grid (theta in [0, pi] from +z, phi in [0, 2 pi) from +x);
//   2. integrate the pdf over every bin (adaptive 2D Simpson in (theta, phi) with the sin(theta)
//      Jacobian), expected count = N * integral;
//   3. samples the sampler rejects (nullopt: absorbed, total internal reflection, a delta lobe the
//      caller leaves out) form one more bin whose expected count is N * (1 - integral over the
//      sphere), so the test also checks the mass of the non-delta part of a mixture;
//   4. pool bins whose expected count is below `min_expected` (5), then compute Pearson's
//      statistic and its p-value from the chi-square distribution (regularized upper incomplete
//      gamma Q(dof/2, x/2)); the test passes when p > significance / num_tests (Bonferroni).
// On failure the observed and expected histograms are written as text to
// tessera::test::output_dir()/chi2_<name>.txt.
//
// Usage:
//   tessera::test::Chi2Options opt;  opt.num_tests = 12;  opt.seed = 7;
//   auto r = tessera::test::chi2_sphere("diffuse", [&](Vec2f u, float uc) -> std::optional<Vec3f> {
//       ...return a unit direction or std::nullopt...}, [&](Vec3f w) { return pdf(w); }, opt);
//   CHECK_MESSAGE(r.passed, r.message);
//
// Everything here is single-threaded and deterministic for a given seed.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "sampling/vecmath.h"
#include "test_helpers.h"

namespace tessera::test {

/// Draws canonical samples in [0, 1) from a fixed seed (mt19937_64, 24-bit mantissas).
class Chi2Rng {
  public:
    explicit Chi2Rng(uint64_t seed) : engine_(seed) {}
    /// Uniform float in [0, 1), never 1.
    float uniform() { return static_cast<float>(engine_() >> 40) * 0x1p-24f; }
    Vec2f uniform2() {
        float a = uniform();
        return {a, uniform()};
    }

  private:
    std::mt19937_64 engine_;
};

/// Settings of one chi-square test. The defaults suit lobes as narrow as GGX alpha ~0.05.
struct Chi2Options {
    int theta_bins = 30;            ///< bins over theta in [0, pi]
    int phi_bins = 60;              ///< bins over phi in [0, 2 pi)
    int sample_count = 300000;      ///< N, samples drawn
    uint64_t seed = 1;              ///< seed of the sample stream
    double significance = 0.01;     ///< overall significance level
    int num_tests = 1;              ///< number of tests in the family (Bonferroni correction)
    double min_expected = 5.0;      ///< bins below this expected count are pooled
    int integration_cells = 2;      ///< per bin and axis, cells refined adaptively
    double integration_tol = 2e-7;  ///< absolute tolerance per bin of the pdf integral
};

/// Outcome of chi2_sphere.
struct Chi2Result {
    bool passed = false;
    double statistic = 0;     ///< Pearson's chi-square
    int dof = 0;              ///< degrees of freedom (pooled bins - 1)
    double p_value = 0;       ///< P(X >= statistic) under the null hypothesis
    double pdf_integral = 0;  ///< integral of the pdf over the sphere (<= 1)
    int rejected = 0;         ///< samples the sampler returned as nullopt
    std::string message;      ///< one-line summary (and the reason on failure)
};

/// Returns a unit direction for canonical samples (u, uc), or nullopt for "no sample".
using DirectionSampler = std::function<std::optional<Vec3f>(Vec2f u, float uc)>;
/// Solid-angle density of the sampler at unit direction w (0 where it never samples).
using DirectionPdf = std::function<double(Vec3f w)>;

namespace detail {

/// ln Gamma for x > 0 (Lanczos approximation, g = 7, n = 9; relative error ~1e-15).
inline double log_gamma(double x) {
    static const double c[9] = {0.99999999999980993,  676.5203681218851,     -1259.1392167224028,
                                771.32342877765313,   -176.61502916214059,   12.507343278686905,
                                -0.13857109526572012, 9.9843695780195716e-6, 1.5056327351493116e-7};
    if (x < 0.5)
        return std::log(M_PI / std::sin(M_PI * x)) - log_gamma(1.0 - x);
    x -= 1.0;
    double a = c[0];
    double t = x + 7.5;
    for (int i = 1; i < 9; ++i)
        a += c[i] / (x + i);
    return 0.5 * std::log(2 * M_PI) + (x + 0.5) * std::log(t) - t + std::log(a);
}

/// Regularized lower incomplete gamma P(a, x) by its power series (converges fast for x < a+1).
inline double gamma_p_series(double a, double x) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 100000; ++n) {
        term *= x / (a + n);
        sum += term;
        if (std::abs(term) < std::abs(sum) * 1e-15)
            break;
    }
    return sum * std::exp(-x + a * std::log(x) - log_gamma(a));
}

/// Regularized upper incomplete gamma Q(a, x) by its continued fraction (modified Lentz),
/// for x >= a+1.
inline double gamma_q_fraction(double a, double x) {
    const double tiny = 1e-300;
    double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 100000; ++i) {
        double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (std::abs(d) < tiny)
            d = tiny;
        c = b + an / c;
        if (std::abs(c) < tiny)
            c = tiny;
        d = 1.0 / d;
        double delta = d * c;
        h *= delta;
        if (std::abs(delta - 1.0) < 1e-15)
            break;
    }
    return std::exp(-x + a * std::log(x) - log_gamma(a)) * h;
}

/// 2D Simpson rule over a cell of size hx * hy from its 3x3 samples v[i][j] (i along x).
inline double simpson_3x3(const double v[3][3], double hx, double hy) {
    static const double w[3] = {1, 4, 1};
    double s = 0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            s += w[i] * w[j] * v[i][j];
    return s * hx * hy / 36.0;
}

/// Adaptive 2D Simpson over [x0,x1] x [y0,y1] given the cell's 3x3 samples `v` and its Simpson
/// estimate `whole`: splits the cell in four (evaluating only the 16 new points of the 5x5 grid)
/// until the estimates agree within tol, then applies Richardson's correction.
template <typename F>
double adaptive_simpson_2d(const F &f, double x0, double x1, double y0, double y1,
                           const double v[3][3], double whole, double tol, int depth) {
    double g[5][5];
    double hx = (x1 - x0) / 4, hy = (y1 - y0) / 4;
    for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j)
            g[i][j] = (i % 2 == 0 && j % 2 == 0) ? v[i / 2][j / 2] : f(x0 + i * hx, y0 + j * hy);
    double sub[2][2][3][3];
    double q[2][2], sum = 0;
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b) {
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    sub[a][b][i][j] = g[2 * a + i][2 * b + j];
            q[a][b] = simpson_3x3(sub[a][b], 2 * hx, 2 * hy);
            sum += q[a][b];
        }
    if (depth <= 0 || std::abs(sum - whole) <= 15.0 * tol)
        return sum + (sum - whole) / 15.0;
    double r = 0;
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
            r += adaptive_simpson_2d(f, x0 + 2 * a * hx, x0 + 2 * (a + 1) * hx, y0 + 2 * b * hy,
                                     y0 + 2 * (b + 1) * hy, sub[a][b], q[a][b], 0.25 * tol,
                                     depth - 1);
    return r;
}

/// Adaptive 2D Simpson integral of f over [x0,x1] x [y0,y1] to absolute tolerance tol.
template <typename F>
double integrate_2d(const F &f, double x0, double x1, double y0, double y1, double tol) {
    double v[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            v[i][j] = f(x0 + i * (x1 - x0) / 2, y0 + j * (y1 - y0) / 2);
    double whole = simpson_3x3(v, x1 - x0, y1 - y0);
    return adaptive_simpson_2d(f, x0, x1, y0, y1, v, whole, tol, 7);
}

}  // namespace detail

/// Upper tail of the chi-square distribution with `dof` degrees of freedom at `x`:
/// P(X >= x) = Q(dof/2, x/2). Returns 1 for x <= 0.
inline double chi2_p_value(double x, int dof) {
    if (dof <= 0)
        return 1.0;
    if (x <= 0)
        return 1.0;
    double a = 0.5 * dof, xx = 0.5 * x;
    if (xx < a + 1.0)
        return std::clamp(1.0 - detail::gamma_p_series(a, xx), 0.0, 1.0);
    return std::clamp(detail::gamma_q_fraction(a, xx), 0.0, 1.0);
}

/// Pearson's chi-square p-value of observed vs expected counts; bins whose expected count is
/// below 5 are pooled into one; a sample in a bin of zero expected count gives p = 0.
inline double chi2_counts_p_value(const std::vector<double> &obs, const std::vector<double> &exp) {
    double stat = 0, pool_o = 0, pool_e = 0;
    int bins = 0;
    for (size_t i = 0; i < obs.size(); ++i) {
        if (exp[i] <= 0) {
            if (obs[i] > 0) return 0.0;
            continue;
        }
        if (exp[i] < 5) {
            pool_o += obs[i];
            pool_e += exp[i];
            continue;
        }
        stat += (obs[i] - exp[i]) * (obs[i] - exp[i]) / exp[i];
        ++bins;
    }
    if (pool_e > 0) {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        ++bins;
    }
    return chi2_p_value(stat, bins - 1);
}

/// Integrates `pdf` over each (theta, phi) bin of the sphere. Returns theta_bins * phi_bins
/// probabilities, row-major in theta; their sum is the integral of the pdf over the sphere.
inline std::vector<double> integrate_pdf_bins(const DirectionPdf &pdf, int theta_bins, int phi_bins,
                                              int cells = 2, double tol = 1e-6) {
    std::vector<double> out(static_cast<size_t>(theta_bins) * phi_bins, 0.0);
    // Integrand in (theta, phi) with the solid-angle Jacobian sin(theta).
    auto f = [&](double theta, double phi) {
        double st = std::sin(theta), ct = std::cos(theta);
        Vec3f w(static_cast<float>(st * std::cos(phi)), static_cast<float>(st * std::sin(phi)),
                static_cast<float>(ct));
        double p = pdf(w);
        return std::isfinite(p) ? p * st : 0.0;
    };
    double dt = M_PI / theta_bins, dp = 2 * M_PI / phi_bins;
    for (int it = 0; it < theta_bins; ++it) {
        for (int ip = 0; ip < phi_bins; ++ip) {
            double sum = 0;
            double cell_t = dt / cells, cell_p = dp / cells;
            double cell_tol = tol / (cells * cells);
            for (int a = 0; a < cells; ++a) {
                for (int b = 0; b < cells; ++b) {
                    double t0 = it * dt + a * cell_t, p0 = ip * dp + b * cell_p;
                    sum += detail::integrate_2d(f, t0, t0 + cell_t, p0, p0 + cell_p, cell_tol);
                }
            }
            out[static_cast<size_t>(it) * phi_bins + ip] = std::max(0.0, sum);
        }
    }
    return out;
}

/// Integral of `pdf` over the unit sphere (should be 1 for a normalised non-delta sampler, or the
/// probability of a non-delta, non-rejected sample for mixtures / lobes that can fail).
/// `tol` is the absolute tolerance per bin; the total error is typically far below bins * tol.
inline double integrate_pdf_sphere(const DirectionPdf &pdf, int theta_bins = 30, int phi_bins = 60,
                                   double tol = 2e-8) {
    double s = 0;
    for (double v : integrate_pdf_bins(pdf, theta_bins, phi_bins, 2, tol))
        s += v;
    return s;
}

/// Runs the chi-square test described at the top of this file. `name` names the output file.
/// Not thread-safe only in that it writes a file on failure; otherwise a pure function.
inline Chi2Result chi2_sphere(const std::string &name, const DirectionSampler &sample,
                              const DirectionPdf &pdf, const Chi2Options &opt = {}) {
    Chi2Result res;
    const int nt = opt.theta_bins, np = opt.phi_bins;
    const size_t nbins = static_cast<size_t>(nt) * np;
    std::vector<double> observed(nbins + 1, 0.0);  // last entry: rejected samples
    Chi2Rng rng(opt.seed);
    std::ostringstream why;
    int bad_direction = 0;
    for (int i = 0; i < opt.sample_count; ++i) {
        float uc = rng.uniform();
        Vec2f u = rng.uniform2();
        std::optional<Vec3f> w = sample(u, uc);
        if (!w) {
            observed[nbins] += 1;
            ++res.rejected;
            continue;
        }
        float len = length(*w);
        if (!std::isfinite(len) || std::abs(len - 1.f) > 1e-3f) {
            ++bad_direction;
            continue;
        }
        Vec3f d = *w / len;
        double theta = std::acos(std::clamp(static_cast<double>(d.z), -1.0, 1.0));
        double phi = std::atan2(static_cast<double>(d.y), static_cast<double>(d.x));
        if (phi < 0)
            phi += 2 * M_PI;
        int it = std::min(nt - 1, static_cast<int>(theta / M_PI * nt));
        int ip = std::min(np - 1, static_cast<int>(phi / (2 * M_PI) * np));
        observed[static_cast<size_t>(it) * np + ip] += 1;
    }

    std::vector<double> expected =
        integrate_pdf_bins(pdf, nt, np, opt.integration_cells, opt.integration_tol);
    double total = 0;
    for (double &e : expected) {
        total += e;
        e *= opt.sample_count;
    }
    res.pdf_integral = total;
    expected.push_back(std::max(0.0, 1.0 - total) * opt.sample_count);

    bool ok = true;
    if (bad_direction > 0) {
        why << bad_direction << " samples were not unit vectors; ";
        ok = false;
    }
    if (total > 1.0 + 1e-3) {
        why << "pdf integrates to " << total << " > 1; ";
        ok = false;
    }
    // A sample where the pdf integrates to (numerically) zero means sampler and pdf disagree.
    for (size_t i = 0; i <= nbins; ++i) {
        if (observed[i] > 0 && expected[i] < 1e-9 * opt.sample_count) {
            why << "bin " << i << " has " << observed[i] << " samples but expected ~0; ";
            ok = false;
            break;
        }
    }

    // Pool the small bins, smallest first, into one bin whose expected count reaches the minimum.
    std::vector<size_t> order(nbins + 1);
    for (size_t i = 0; i <= nbins; ++i)
        order[i] = i;
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return expected[a] < expected[b]; });
    double chi2 = 0, pool_obs = 0, pool_exp = 0;
    int used_bins = 0;
    for (size_t idx : order) {
        double e = expected[idx], o = observed[idx];
        if (e <= 0 && o <= 0)
            continue;
        if (e < opt.min_expected) {
            pool_obs += o;
            pool_exp += e;
        } else if (pool_exp > 0 && pool_exp < opt.min_expected) {
            // Merge the too-small pool into this (the next smallest) bin.
            pool_obs += o;
            pool_exp += e;
            chi2 += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
            ++used_bins;
            pool_obs = pool_exp = 0;
        } else {
            chi2 += (o - e) * (o - e) / e;
            ++used_bins;
        }
    }
    if (pool_exp > 0) {
        chi2 += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
        ++used_bins;
    } else if (pool_obs > 0) {
        ok = false;
        why << pool_obs << " samples in bins of zero expected count; ";
    }
    res.statistic = chi2;
    res.dof = used_bins - 1;
    res.p_value = chi2_p_value(chi2, res.dof);
    double alpha = opt.significance / std::max(1, opt.num_tests);
    if (!(res.p_value > alpha)) {
        ok = false;
        why << "p-value " << res.p_value << " <= " << alpha << "; ";
    }
    res.passed = ok;

    std::ostringstream msg;
    msg << "chi2[" << name << "]: " << (ok ? "passed" : "FAILED") << " statistic=" << chi2
        << " dof=" << res.dof << " p=" << res.p_value << " pdf_integral=" << total
        << " rejected=" << res.rejected << "/" << opt.sample_count;
    if (!ok) {
        msg << " (" << why.str() << ")";
        std::string path = output_dir() + "/chi2_" + name + ".txt";
        std::ofstream out(path);
        out << "# " << msg.str() << "\n# rows: theta bins (0 = +z), columns: phi bins\n";
        out << "# observed\n";
        for (int it = 0; it < nt; ++it) {
            for (int ip = 0; ip < np; ++ip)
                out << observed[static_cast<size_t>(it) * np + ip] << ' ';
            out << '\n';
        }
        out << "# expected\n";
        for (int it = 0; it < nt; ++it) {
            for (int ip = 0; ip < np; ++ip)
                out << expected[static_cast<size_t>(it) * np + ip] << ' ';
            out << '\n';
        }
        out << "# rejected: observed " << observed[nbins] << " expected " << expected[nbins]
            << "\n";
        msg << " histograms in " << path;
    }
    res.message = msg.str();
    return res;
}

}  // namespace tessera::test
