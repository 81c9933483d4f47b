// `fixed`: K camera samples in every pixel, the baseline of the real-time papers' tables.
//
// A square K = N x N takes one jittered sample in each cell of an N x N grid (the "stratified"
// supersampling the papers compare with); any other K takes the first K points of the pixel's
// Owen-scrambled Sobol (0,2)-sequence, which is stratified for every power of two. The pixel's
// colour is the mean of its samples (a box filter over the pixel, as in the papers). Samples are
// evaluated in batches so that sources can trace them as ray packets.
#include <cmath>

#include "sampling/plugins/plugins.h"
#include "sampling/sequence.h"

namespace tessera::sampling {

namespace {

class FixedSampler final : public PixelSampler {
  public:
    explicit FixedSampler(const PluginParams &p)
        : spp_(uint32_t(p.get_int("spp"))), seed_(uint32_t(p.get_int("seed"))),
          jitter_(p.get_int("jitter") != 0) {
        grid_ = uint32_t(std::lround(std::sqrt(double(spp_))));
        if (grid_ * grid_ != spp_) grid_ = 0;
    }

    void begin_frame(const SampleSource &source) override {
        width_ = source.width();
        height_ = source.height();
        color_.assign(size_t(width_) * height_, Rgb(0.f));
        rays_.assign(size_t(width_) * height_, 0.f);
        nan_.assign(size_t(width_) * height_, 0);
        shadow_.reset();
    }
    /// Only radiance: no attribute vector.
    uint32_t attributes_used() const override { return kAttrNone; }
    int stage_count() const override { return 1; }
    std::string stage_name(int) const override { return "sample"; }

    void run_tile(int, const PixelRect &tile, const SampleSource &source) override {
        constexpr size_t kBatch = 64;
        std::vector<CameraSample> cs;
        std::vector<Sample> out;
        cs.reserve(kBatch);
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x) {
                Rgb sum(0.f);
                uint32_t rays = 0, nan = 0, good = 0;
                for (uint32_t i0 = 0; i0 < spp_; i0 += kBatch) {
                    uint32_t n = std::min<uint32_t>(kBatch, spp_ - i0);
                    cs.resize(n);
                    out.resize(n);
                    for (uint32_t k = 0; k < n; ++k) cs[k] = camera_sample(x, y, i0 + k);
                    source.evaluate_batch(cs, out);
                    shadow_.add(out);
                    for (const Sample &s : out) {
                        rays += s.rays;
                        if (!std::isfinite(s.radiance.r) || !std::isfinite(s.radiance.g) ||
                            !std::isfinite(s.radiance.b)) {
                            ++nan;
                            continue;
                        }
                        sum += s.radiance;
                        ++good;
                    }
                }
                size_t idx = size_t(y) * width_ + x;
                color_[idx] = good ? sum / float(good) : Rgb(0.f);
                rays_[idx] = float(rays);
                nan_[idx] = nan;
            }
    }

    void end_frame(FrameResult &r) override {
        r.reset(width_, height_);
        r.color = color_;
        r.rays = rays_;
        double rays = 0;
        for (float v : rays_) rays += v;
        for (uint32_t v : nan_) r.nan_samples += v;
        r.samples = uint64_t(spp_) * width_ * height_;
        r.rays_total = uint64_t(rays);
        shadow_.write(r);
        r.active_fraction = 1.0;  // every pixel gets all K samples
    }

  private:
    CameraSample camera_sample(uint32_t x, uint32_t y, uint32_t i) const {
        SobolSampler s(seed_);
        s.start_pixel_sample(x, y, i);
        Vec2f u;
        if (grid_) {
            // Jitter inside the cell, or its centre (jitter=0: the pixel centre for spp=1, what
            // the undersampling papers' "ray tracing at one sample per pixel" traces).
            Vec2f j = jitter_ ? s.get_pixel_2d() : Vec2f(0.5f, 0.5f);
            u = Vec2f((float(i % grid_) + j.x) / float(grid_), (float(i / grid_) + j.y) / float(grid_));
        } else {
            u = s.get_pixel_2d();
        }
        CameraSample cs;
        cs.px = x;
        cs.py = y;
        cs.fx = std::min(u.x, 0x1.fffffep-1f);
        cs.fy = std::min(u.y, 0x1.fffffep-1f);
        cs.index = i;
        return cs;
    }

    uint32_t spp_, seed_, grid_ = 0;
    bool jitter_ = true;
    uint32_t width_ = 0, height_ = 0;
    std::vector<Rgb> color_;
    std::vector<float> rays_;
    std::vector<uint32_t> nan_;
    FrameShadowRays shadow_;
};

}  // namespace

PluginInfo fixed_plugin_info() {
    PluginInfo info;
    info.name = "fixed";
    info.kind = PluginKind::Frame;
    info.summary = "K samples per pixel: N x N jittered grid for square K, else stratified "
                   "Sobol points; the baseline of the real-time papers' tables";
    info.params = {
        {"spp", 1, 1, 256, true, "samples per pixel"},
        {"seed", 0, 0, 4294967295.0, true, "sequence seed of the jitter"},
        {"jitter", 1, 0, 1, true,
         "1: one jittered point per grid cell; 0: the cell centres (square spp only)"},
    };
    info.make = [](const PluginParams &p) -> std::unique_ptr<PixelSampler> {
        return std::make_unique<FixedSampler>(p);
    };
    return info;
}

}  // namespace tessera::sampling
