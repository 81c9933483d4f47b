// PixelSampler::set_diagnostics: every frame plugin, with its diagnostic layers turned off,
// renders the same colours, rays and counts bit for bit and leaves no layer in the result; turned
// on again, its next frame equals a fresh plugin's first frame, layers included.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "plugin_test_util.h"
#include "sampling/pixel_sampler.h"
#include "scheduler/frame_scheduler.h"
#include "synthetic_attribute_source.h"

using namespace tessera;
using namespace tessera::sampling;
using tessera::test::SyntheticAttributeSource;

namespace {

/// The scene with non-finite radiance in a band of pixels (traced and shaded alike), so that the
/// plugins' NaN counts and dropped samples are compared too.
class NanBandSource final : public SampleSource {
  public:
    explicit NanBandSource(const SyntheticAttributeSource &s) : s_(s) {}
    uint32_t width() const override { return s_.width(); }
    uint32_t height() const override { return s_.height(); }
    bool provides_attributes() const override { return true; }
    std::string describe() const override { return "synthetic source with a NaN band"; }
    Sample evaluate(const CameraSample &cs) const override {
        Sample r = s_.evaluate(cs);
        if (in_band(float(cs.px) + cs.fx)) r.radiance = Rgb(std::nanf(""), 0.f, 0.f);
        return r;
    }
    Rgb shade(const HitAttributes &a) const override {
        return in_band(a.primary.position.x) ? Rgb(std::nanf(""), 0.f, 0.f) : s_.shade(a);
    }

  private:
    static bool in_band(float x) { return x > 22.2f && x < 24.9f; }  // across a line
    const SyntheticAttributeSource &s_;
};

}  // namespace

TEST_CASE("diagnostics off: same colours, rays and counts, no layers; on again: a fresh frame") {
    auto synthetic = test::busy_attribute_scene();
    const NanBandSource with_nans(*synthetic);
    sched::FrameScheduler scheduler(sched::FrameOptions{2, sched::kTileSize});
    int plugins = 0, with_layers = 0;
    // Every frame plugin with its defaults; kim also on the scale of this flat scene (so that
    // it interpolates and post-corrects), with larger blocks (several A1/A2 levels) and with
    // supersampling.
    std::vector<std::string> specs;
    for (const PluginInfo &info : plugin_registry())
        if (info.kind == PluginKind::Frame) specs.push_back(info.name);
    for (const char *kim : {"kim:scene-size=300", "kim:scene-size=300,block=4",
                            "kim:scene-size=300,ss=2"})
        specs.push_back(kim);
    for (const std::string &text : specs)
    for (const SampleSource *src : {static_cast<const SampleSource *>(synthetic.get()),
                                    static_cast<const SampleSource *>(&with_nans)}) {
        CAPTURE(text);
        CAPTURE(src->describe());
        ++plugins;
        const PluginSpec spec = parse_plugin_spec(text);
        auto fresh_plugin = spec.info->make(spec.params);
        FrameResult fresh;
        scheduler.render(*fresh_plugin, *src, fresh);
        if (src == &with_nans) CHECK(fresh.nan_samples > 0);
        if (text.rfind("kim:", 0) == 0) {
            // Post-correction ran (what direct output must also count).
            float corrected = 0;
            for (const FrameLayer &l : fresh.diagnostics)
                if (l.name == "postcorrected")
                    for (float v : l.data) corrected = std::max(corrected, v);
            CHECK(corrected > 0.f);
        }
        with_layers += !fresh.diagnostics.empty();

        auto plugin = spec.info->make(spec.params);
        FrameResult r;
        scheduler.render(*plugin, *src, r);  // with layers, so that "off" must remove them
        plugin->set_diagnostics(false);
        for (int frame = 0; frame < 2; ++frame) {
            scheduler.render(*plugin, *src, r);
            CHECK(r.diagnostics.empty());
            FrameResult colour_only = fresh;
            colour_only.diagnostics.clear();
            test::check_same_frame(colour_only, r);
        }
        plugin->set_diagnostics(true);
        scheduler.render(*plugin, *src, r);
        test::check_same_frame(fresh, r);
    }
    CHECK(plugins >= 18);      // (fixed, jin, kim, fliptri, flipquad, suffern, 3 x kim) x 2
    CHECK(with_layers >= 16);  // all but fixed write diagnostic layers
}
