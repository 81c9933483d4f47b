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
        // Sized, not cleared: every tile writes all its pixels (a cancelled frame, which the
        // real-time loop discards, may keep old values where no tile ran).
        color_.resize(size_t(width_) * height_, Rgb(0.f));
        rays_.resize(size_t(width_) * height_, 0.f);
        nan_.resize(size_t(width_) * height_, 0);
        shadow_.reset();
    }
    /// Only radiance: no attribute vector.
    uint32_t attributes_used() const override { return kAttrNone; }
    int stage_count() const override { return 1; }
    std::string stage_name(int) const override { return "sample"; }

    void run_tile(int, const PixelRect &tile, const SampleSource &source) override {
        // The tile's samples go to the source in batches of up to 64, across pixels (a pixel's
        // samples in order, pixels in row order), so that one sample per pixel is traced in
        // packets as well (the Whitted integrator's rtcIntersect8). Each pixel's sum is the
        // same whatever the batching: its samples are added in sample order.
        constexpr size_t kBatch = 64;
        thread_local std::vector<CameraSample> cs;
        thread_local std::vector<Sample> out;
        struct Acc {
            Rgb sum{0.f};
            uint32_t rays = 0, nan = 0, good = 0;
        };
        const uint32_t tw = tile.x1 - tile.x0;
        thread_local std::vector<Acc> acc;
        acc.assign(size_t(tw) * (tile.y1 - tile.y0), Acc{});
        cs.clear();
        auto flush = [&] {
            if (cs.empty()) return;
            out.resize(cs.size());
            source.evaluate_batch(cs, out);
            shadow_.add(out);
            for (size_t k = 0; k < cs.size(); ++k) {
                Acc &a = acc[size_t(cs[k].py - tile.y0) * tw + (cs[k].px - tile.x0)];
                const Sample &smp = out[k];
                a.rays += smp.rays;
                if (!std::isfinite(smp.radiance.r) || !std::isfinite(smp.radiance.g) ||
                    !std::isfinite(smp.radiance.b)) {
                    ++a.nan;
                    continue;
                }
                a.sum += smp.radiance;
                ++a.good;
            }
            cs.clear();
        };
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x)
                for (uint32_t i = 0; i < spp_; ++i) {
                    cs.push_back(camera_sample(x, y, i));
                    if (cs.size() == kBatch) flush();
                }
        flush();
        for (uint32_t y = tile.y0; y < tile.y1; ++y)
            for (uint32_t x = tile.x0; x < tile.x1; ++x) {
                const Acc &a = acc[size_t(y - tile.y0) * tw + (x - tile.x0)];
                const size_t idx = size_t(y) * width_ + x;
                color_[idx] = a.good ? a.sum / float(a.good) : Rgb(0.f);
                rays_[idx] = float(a.rays);
                nan_[idx] = a.nan;
            }
    }

    void end_frame(FrameResult &r) override {
        double rays = 0;
        for (float v : rays_) rays += v;
        // Swap, not copy: the result's old buffers come back sized for the next frame.
        r.reset(width_, height_, /*zero=*/false);
        r.color.swap(color_);
        r.rays.swap(rays_);
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
