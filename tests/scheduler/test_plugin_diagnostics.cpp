// PixelSampler::set_diagnostics: every frame plugin, with its diagnostic layers turned off,
// renders the same colours, rays and counts bit for bit and leaves no layer in the result; turned
// on again, its next frame equals a fresh plugin's first frame, layers included.
#include <doctest/doctest.h>

#include <memory>
#include <string>

#include "plugin_test_util.h"
#include "sampling/pixel_sampler.h"
#include "scheduler/frame_scheduler.h"
#include "synthetic_attribute_source.h"

using namespace tessera;
using namespace tessera::sampling;
using tessera::test::AttrShape;
using tessera::test::ShadowDisc;
using tessera::test::SyntheticAttributeSource;

namespace {

/// Shapes, a texture, a thin line, a shadow and a reflection: every plugin finds work.
std::unique_ptr<SyntheticAttributeSource> scene() {
    auto src = std::make_unique<SyntheticAttributeSource>(37, 29);
    src->shapes[0].color_dx = Rgb(0.004f, 0.f, 0.002f);
    AttrShape disc;
    disc.kind = AttrShape::Kind::Disc;
    disc.cx = 12, disc.cy = 10, disc.r = 7;
    disc.color = Rgb(0.7f, 0.2f, 0.2f);
    disc.texture_scale = 4;
    src->shapes.push_back(disc);
    AttrShape line;
    line.kind = AttrShape::Kind::Line;
    line.nx = 0.6f, line.ny = 0.8f, line.d = 20.3f, line.width = 0.7f;
    line.color = Rgb(0.1f, 0.1f, 0.9f);
    src->shapes.push_back(line);
    AttrShape mirror;
    mirror.kind = AttrShape::Kind::HalfPlane;
    mirror.nx = 0, mirror.ny = -1, mirror.d = -22;
    mirror.reflects = 1;
    mirror.reflection = Rgb(0.3f, 0.3f, 0.35f);
    src->shapes.push_back(mirror);
    src->shadows.push_back(ShadowDisc{27, 8, 5});
    return src;
}

}  // namespace

TEST_CASE("diagnostics off: same colours, rays and counts, no layers; on again: a fresh frame") {
    auto src = scene();
    sched::FrameScheduler scheduler(sched::FrameOptions{2, sched::kTileSize});
    int plugins = 0, with_layers = 0;
    for (const PluginInfo &info : plugin_registry()) {
        if (info.kind != PluginKind::Frame) continue;
        CAPTURE(info.name);
        ++plugins;
        const PluginSpec spec = parse_plugin_spec(info.name);
        auto fresh_plugin = spec.info->make(spec.params);
        FrameResult fresh;
        scheduler.render(*fresh_plugin, *src, fresh);
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
    CHECK(plugins >= 6);       // fixed, jin, kim, fliptri, flipquad, suffern
    CHECK(with_layers >= 5);   // all but fixed write diagnostic layers
}
