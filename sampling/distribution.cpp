// Tabulated distributions (see distribution.h for the references).
#include "sampling/distribution.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace tessera::sampling {

namespace {

// NaN and infinities would poison every CDF entry after them; treat them as empty cells.
float sanitize(float v) {
    return std::isfinite(v) ? std::abs(v) : 0.f;
}

}  // namespace

PiecewiseConstant1D::PiecewiseConstant1D(std::span<const float> f, float min, float max)
    : min_(min), max_(max) {
    func_.resize(std::max<size_t>(f.size(), 1), 0.f);
    for (size_t i = 0; i < f.size(); ++i)
        func_[i] = sanitize(f[i]);
    const size_t n = func_.size();
    const double width = double(max_ - min_) / double(n);

    // Accumulate in double: with thousands of cells a float running sum loses the small ones.
    std::vector<double> cdf(n + 1, 0.0);
    for (size_t i = 0; i < n; ++i)
        cdf[i + 1] = cdf[i] + double(func_[i]) * width;
    integral_ = float(cdf[n]);
    if (!(cdf[n] > 0.0)) {
        // All zero: sample uniformly so that callers never see an impossible sample.
        fallback_ = true;
        std::fill(func_.begin(), func_.end(), 1.f);
        for (size_t i = 0; i <= n; ++i)
            cdf[i] = double(i) * width;
    }
    sampling_integral_ = float(cdf[n]);
    cdf_.resize(n + 1);
    for (size_t i = 0; i <= n; ++i)
        cdf_[i] = float(cdf[i] / cdf[n]);
    cdf_[n] = 1.f;

    // About four cells per bucket on average: a quarter of the CDF's memory, and where u
    // lands most often (the large cells) a bucket holds one or two entries.
    const size_t buckets = std::max<size_t>(1, n / 4);
    guide_.assign(buckets + 1, 0);
    // guide_[b] = number of entries whose bucket is below b. bucket() is nondecreasing in u and
    // the CDF is sorted, so for u in bucket b every entry of a lower bucket is <= u and every
    // entry of a higher bucket is > u.
    size_t e = 0;
    for (size_t b = 0; b <= buckets; ++b) {
        while (e <= n && size_t(bucket(cdf_[e])) < b)
            ++e;
        guide_[b] = uint32_t(e);
    }
}

int PiecewiseConstant1D::bucket(float u) const {
    const int g = int(guide_.size()) - 1;
    const float x = u * float(g);
    // NaN and negative u go to bucket 0, u >= 1 to the last one; both stay monotone.
    return x >= 0.f ? (x < float(g) ? std::min(int(x), g - 1) : g - 1) : 0;
}

// Index of the cell whose CDF interval contains u: the last i with cdf[i] <= u, clamped to
// [0, n-1]. Zero-width cells are skipped because upper_bound passes over equal CDF values.
// The count of entries <= u is std::upper_bound's, searched only over the guide table's range
// for u's bucket, and written without a data-dependent branch (the half step is a conditional
// move), since the CDF's comparisons are unpredictable.
int PiecewiseConstant1D::find_cell(float u) const {
    const int b = bucket(u);
    const float *base = cdf_.data() + guide_[size_t(b)];
    size_t len = guide_[size_t(b) + 1] - guide_[size_t(b)];
    // Invariant: the number of entries <= u in the range lies in [base - start, base - start + len].
    while (len > 1) {
        const size_t half = len / 2;
        base = base[half] <= u ? base + half : base;
        len -= half;
    }
    const int upper = int(base - cdf_.data()) + (len > 0 && *base <= u ? 1 : 0);
    return clamp(upper - 1, 0, int(cdf_.size()) - 2);
}

float PiecewiseConstant1D::sample_continuous(float u, float *pdf, int *offset) const {
    int o = find_cell(u);
    if (offset)
        *offset = o;
    float du = u - cdf_[o];
    float width = cdf_[o + 1] - cdf_[o];
    if (width > 0.f)
        du /= width;
    du = clamp(du, 0.f, kOneMinusEpsilon);
    if (pdf)
        *pdf = func_[o] / sampling_integral_;
    float t = (float(o) + du) / float(func_.size());
    float x = lerp(t, min_, max_);
    // Rounding in lerp must not push x onto the (excluded) upper end.
    return std::min(x, std::nextafter(max_, min_));
}

int PiecewiseConstant1D::sample_discrete(float u, float *pmf_out, float *u_remapped) const {
    int o = find_cell(u);
    if (pmf_out)
        *pmf_out = pmf(size_t(o));
    if (u_remapped) {
        float width = cdf_[o + 1] - cdf_[o];
        float r = width > 0.f ? (u - cdf_[o]) / width : 0.f;
        *u_remapped = clamp(r, 0.f, kOneMinusEpsilon);
    }
    return o;
}

float PiecewiseConstant1D::pdf(float x) const {
    if (!(x >= min_ && x <= max_))
        return 0.f;
    int n = int(func_.size());
    int i = clamp(int((x - min_) / (max_ - min_) * float(n)), 0, n - 1);
    return func_[size_t(i)] / sampling_integral_;
}

float PiecewiseConstant1D::pmf(size_t i) const {
    return func_[i] * ((max_ - min_) / float(func_.size())) / sampling_integral_;
}

PiecewiseConstant2D::PiecewiseConstant2D(std::span<const float> f, int nu, int nv) {
    nu = std::max(nu, 1);
    nv = std::max(nv, 1);
    conditional_.reserve(size_t(nv));
    std::vector<float> row_integrals(static_cast<size_t>(nv), 0.f);
    for (int v = 0; v < nv; ++v) {
        std::span<const float> row;
        if (f.size() >= size_t(nu) * size_t(nv))
            row = f.subspan(size_t(v) * size_t(nu), size_t(nu));
        if (row.empty()) {
            std::vector<float> zeros(size_t(nu), 0.f);
            conditional_.emplace_back(std::span<const float>(zeros));
        } else {
            conditional_.emplace_back(row);
        }
        row_integrals[size_t(v)] = conditional_.back().integral();
    }
    marginal_ = PiecewiseConstant1D(row_integrals);
}

Vec2f PiecewiseConstant2D::sample(Vec2f u, float *pdf_out, int *cell_u, int *cell_v) const {
    float pdf_v = 0, pdf_u = 0;
    int iv = 0, iu = 0;
    float y = marginal_.sample_continuous(u.y, &pdf_v, &iv);
    float x = conditional_[size_t(iv)].sample_continuous(u.x, &pdf_u, &iu);
    if (pdf_out)
        *pdf_out = pdf_v * pdf_u;
    if (cell_u)
        *cell_u = iu;
    if (cell_v)
        *cell_v = iv;
    return {x, y};
}

float PiecewiseConstant2D::pdf(Vec2f p) const {
    int n_v = nv(), n_u = nu();
    int iv = clamp(int(p.y * float(n_v)), 0, n_v - 1);
    int iu = clamp(int(p.x * float(n_u)), 0, n_u - 1);
    const PiecewiseConstant1D &row = conditional_[size_t(iv)];
    // Marginal density of the row times the conditional density within it (both on [0,1]).
    float pdf_v = marginal_.pmf(size_t(iv)) * float(n_v);
    float pdf_u = row.pmf(size_t(iu)) * float(n_u);
    return pdf_v * pdf_u;
}

AliasTable::AliasTable(std::span<const float> weights) {
    const size_t n = weights.size();
    if (n == 0)
        return;
    bins_.resize(n);
    double sum = 0;
    for (float w : weights)
        sum += double(sanitize(w));
    std::vector<double> p(n);
    for (size_t i = 0; i < n; ++i)
        p[i] = sum > 0 ? double(sanitize(weights[i])) / sum : 1.0 / double(n);
    for (size_t i = 0; i < n; ++i)
        bins_[i].p = float(p[i]);

    // Vose: scaled probabilities below 1 are "small" and get topped up by a "large" alias.
    std::vector<std::pair<size_t, double>> small, large;
    for (size_t i = 0; i < n; ++i) {
        double q = p[i] * double(n);
        (q < 1.0 ? small : large).emplace_back(i, q);
    }
    while (!small.empty() && !large.empty()) {
        auto [si, sq] = small.back();
        small.pop_back();
        auto [li, lq] = large.back();
        large.pop_back();
        bins_[si].q = float(sq);
        bins_[si].alias = int(li);
        double rest = lq - (1.0 - sq);
        (rest < 1.0 ? small : large).emplace_back(li, rest);
    }
    // What is left is 1 up to rounding.
    for (auto &[i, q] : small)
        bins_[i].q = 1.f, bins_[i].alias = -1;
    for (auto &[i, q] : large)
        bins_[i].q = 1.f, bins_[i].alias = -1;
}

Vec3f equal_area_square_to_sphere(Vec2f p) {
    // Fold the square onto [0,1]^2 of |u|,|v| in [-1,1]^2 coordinates; the signed distance
    // from the diagonal |u|+|v| = 1 selects the hemisphere (inside the diamond: +z).
    float u = 2.f * p.x - 1.f, v = 2.f * p.y - 1.f;
    float au = std::abs(u), av = std::abs(v);
    float signed_dist = 1.f - (au + av);
    float r = 1.f - std::abs(signed_dist);
    // Clarberg 2008, eq. (5)-(6): phi runs linearly along each edge of the diamond ring.
    float phi = (r == 0.f ? 1.f : (av - au) / r + 1.f) * kPiOver4;
    float z = std::copysign(1.f - r * r, signed_dist);
    float cos_phi = std::copysign(std::cos(phi), u);
    float sin_phi = std::copysign(std::sin(phi), v);
    float s = r * safe_sqrt(2.f - r * r);
    return {cos_phi * s, sin_phi * s, z};
}

Vec2f equal_area_sphere_to_square(Vec3f d) {
    float x = std::abs(d.x), y = std::abs(d.y), z = std::abs(d.z);
    // r = sqrt(1 - |z|) is the ring index; the area of the cap above z is 2 pi (1 - z).
    float r = safe_sqrt(1.f - z);
    float a = std::max(x, y), b = std::min(x, y);
    float ratio = a == 0.f ? 0.f : b / a;
    float phi = std::atan(ratio) * (2.f / kPi);  // in [0, 1] over the first octant
    if (x < y)
        phi = 1.f - phi;
    float v = phi * r;
    float u = r - v;
    if (d.z < 0.f) {
        // Lower hemisphere: reflect across the diamond's edge.
        std::swap(u, v);
        u = 1.f - u;
        v = 1.f - v;
    }
    u = std::copysign(u, d.x);
    v = std::copysign(v, d.y);
    return {0.5f * (u + 1.f), 0.5f * (v + 1.f)};
}

}  // namespace tessera::sampling
