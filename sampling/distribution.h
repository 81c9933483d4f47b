// Tabulated distributions for importance sampling: piecewise-constant 1D and 2D densities and
// an alias table for discrete choices.
//
// PiecewiseConstant1D/2D follow the inversion method of Pharr, Jakob & Humphreys, "Physically
// Based Rendering", 4th ed. (2023), sections A.4.3 and A.5.2: the density is proportional to |f|
// on equal-width cells; the 2D case samples a marginal over rows, then the conditional within the
// chosen row. AliasTable is Vose's O(1) alias method (Vose 1991, "A linear algorithm for
// generating random numbers with a given distribution"; Walker 1974).
//
// All-zero (or empty) functions fall back to the uniform density, so sampling never fails and
// pdf() stays consistent with sample(). All types are immutable after construction, so every
// const method is thread-safe.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "sampling/vecmath.h"

namespace tessera::sampling {

/// Piecewise-constant density on [min, max] proportional to |f| over n equal cells.
class PiecewiseConstant1D {
  public:
    PiecewiseConstant1D() : PiecewiseConstant1D(std::span<const float>{}) {}
    /// Builds the density from `f` (absolute values are used; NaN counts as 0). An empty or
    /// all-zero `f` gives the uniform density on [min, max].
    explicit PiecewiseConstant1D(std::span<const float> f, float min = 0.f, float max = 1.f);

    /// Number of cells.
    size_t size() const { return func_.size(); }
    /// Integral of |f| over [min, max] (0 for an all-zero function, even though sampling then
    /// falls back to uniform).
    float integral() const { return integral_; }
    /// True when the function was all zero and the uniform fallback is in use.
    bool is_uniform_fallback() const { return fallback_; }
    float min() const { return min_; }
    float max() const { return max_; }
    /// Value of |f| in cell i (after the fallback: 1 everywhere).
    float func(size_t i) const { return func_[i]; }
    /// The CDF at the cell boundaries: size() + 1 values from 0 to 1, nondecreasing.
    const std::vector<float> &cdf() const { return cdf_; }

    /// Samples x in [min, max) by inversion. `pdf`: density at x (per unit x); `offset`: the
    /// cell index. u in [0,1).
    float sample_continuous(float u, float *pdf = nullptr, int *offset = nullptr) const;
    /// Picks a cell with probability proportional to its value. `pmf`: that probability;
    /// `u_remapped`: u rescaled to [0,1) within the chosen cell (reusable as a fresh sample).
    int sample_discrete(float u, float *pmf = nullptr, float *u_remapped = nullptr) const;
    /// Density at x (per unit x); 0 outside [min, max].
    float pdf(float x) const;
    /// Probability of cell i under sample_discrete.
    float pmf(size_t i) const;

  private:
    std::vector<float> func_;  // |f| per cell (ones for the fallback)
    std::vector<float> cdf_;   // size n+1, cdf_[0] = 0, cdf_[n] = 1
    float min_, max_;
    float integral_ = 0;       // true integral of |f|
    float sampling_integral_;  // integral of func_ (the normaliser actually used)
    bool fallback_ = false;
    // Guide table (Chen and Asau's cut points): u in [0,1) falls in bucket
    // b = bucket(u) of guide_.size() - 1; the count of CDF entries <= u lies in
    // [guide_[b], guide_[b + 1]], so the search runs over that range only (usually a cache line)
    // instead of the whole CDF, with the same result.
    std::vector<uint32_t> guide_;
    int bucket(float u) const;
    int find_cell(float u) const;
};

/// Piecewise-constant density on [0,1]^2 from an nu x nv grid of values (row-major,
/// f[v * nu + u]); the density is per unit area of the square.
class PiecewiseConstant2D {
  public:
    PiecewiseConstant2D() = default;
    /// `f` must hold nu * nv values (row v = 0 first). Absolute values are used; all-zero gives
    /// the uniform density 1.
    PiecewiseConstant2D(std::span<const float> f, int nu, int nv);

    int nu() const { return int(conditional_.size() ? conditional_[0].size() : 0); }
    int nv() const { return int(conditional_.size()); }
    /// Integral of |f| over [0,1]^2.
    float integral() const { return marginal_.integral(); }

    /// Samples a point in [0,1)^2; `pdf` receives the density there (per unit area), `cell`
    /// the (column, row) of the chosen cell.
    Vec2f sample(Vec2f u, float *pdf = nullptr, int *cell_u = nullptr, int *cell_v = nullptr) const;
    /// Density at p in [0,1]^2 (clamped into the grid).
    float pdf(Vec2f p) const;

  private:
    std::vector<PiecewiseConstant1D> conditional_;  // one per row v, over u
    PiecewiseConstant1D marginal_;                  // over v, from the rows' integrals
};

/// Discrete distribution with O(1) sampling (Vose's alias method) and O(1) pmf lookup.
class AliasTable {
  public:
    AliasTable() = default;
    /// Weights must be >= 0 (negative and NaN count as 0). All-zero weights give the uniform
    /// distribution; an empty span gives an empty table.
    explicit AliasTable(std::span<const float> weights);

    size_t size() const { return bins_.size(); }
    /// Probability of index i.
    float pmf(size_t i) const { return bins_[i].p; }
    /// Picks an index for u in [0,1). `pmf`: its probability; `u_remapped`: a fresh uniform
    /// value in [0,1) derived from u. Returns -1 for an empty table.
    int sample(float u, float *pmf = nullptr, float *u_remapped = nullptr) const;

  private:
    struct Bin {
        float q = 0;  // probability of keeping this bin (else take alias)
        float p = 0;  // normalised pmf of this index
        int alias = -1;
    };
    std::vector<Bin> bins_;
};

/// Inline: the path tracer picks a light with it at every vertex.
inline int AliasTable::sample(float u, float *pmf_out, float *u_remapped) const {
    if (bins_.empty())
        return -1;
    const size_t n = bins_.size();
    float scaled = u * float(n);
    size_t o = std::min(size_t(scaled), n - 1);
    float up = std::min(scaled - float(o), kOneMinusEpsilon);
    int idx;
    float r;
    if (up < bins_[o].q || bins_[o].alias < 0) {
        idx = int(o);
        r = bins_[o].q > 0.f ? up / bins_[o].q : 0.f;
    } else {
        idx = bins_[o].alias;
        r = (up - bins_[o].q) / (1.f - bins_[o].q);
    }
    if (pmf_out)
        *pmf_out = bins_[size_t(idx)].p;
    if (u_remapped)
        *u_remapped = clamp(r, 0.f, kOneMinusEpsilon);
    return idx;
}

/// Equal-area octahedral map from the unit square to the unit sphere (Clarberg 2008, "Fast
/// equal-area mapping of the (hemi)sphere using SIMD"; pbrt-v4's EqualAreaSquareToSphere).
/// The +z hemisphere maps to the inner diamond |2u-1| + |2v-1| <= 1. Density 1/(4 pi).
Vec3f equal_area_square_to_sphere(Vec2f p);
/// Inverse of equal_area_square_to_sphere for a unit vector d.
Vec2f equal_area_sphere_to_square(Vec3f d);

}  // namespace tessera::sampling
