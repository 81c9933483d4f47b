// The PixelSampler plugin interface and registry (docs/ARCHITECTURE.md, "The PixelSampler plugin").
//
// A plugin is one sampling mode, selected by name on the command line as
// `--sampler NAME[:key=value,...]`. Two kinds:
//  - progressive (`uniform`, `adaptive`): run by the adaptive tile scheduler
//    (scheduler/adaptive_scheduler.h) pass after pass; the registry holds their parameters so
//    that one parser and `tessera samplers` cover every mode;
//  - frame (`fixed`, `jin`, `kim`, `fliptri`, `flipquad`, `suffern`): the real-time modes. A frame
//    is a sequence of *stages*; each stage is a parallel job over 8x8 tiles in Morton order with
//    a barrier after it (scheduler/frame_scheduler.h), then a serial `end_stage` (reductions such
//    as a frame-average gradient). The plugin object lives across frames, so a mode may reuse the
//    previous frame's state (e.g. its threshold).
//
// Plugins see the scene only through SampleSource: `evaluate`/`evaluate_batch` trace camera
// samples (with the attribute vector when the source provides one) and `shade` turns an
// interpolated attribute vector into a colour. Their random numbers are pure functions of
// (pixel, sample index) (sampling/sequence.h), so frames do not depend on the thread count.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sampling/sample_source.h"

namespace tessera::sampling {

/// Half-open pixel rectangle [x0, x1) x [y0, y1) (one tile).
struct PixelRect {
    uint32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    /// The tile's place in the stage's work list (FrameScheduler: Morton order; tiles next to
    /// each other in it run at the same time on different threads) and the list's length. A
    /// stage whose work is not naturally per tile (a row-major copy) can split it by these.
    uint32_t index = 0, count = 1;
    uint32_t width() const { return x1 - x0; }
    uint32_t height() const { return y1 - y0; }
};

/// One parameter a plugin takes, with its default (the paper's) and valid range.
struct PluginParamSpec {
    std::string key;
    double default_value = 0;
    double min_value = 0, max_value = 1;
    bool integer = false;  ///< only whole numbers accepted (booleans: integer in [0, 1])
    std::string help;      ///< one line for `tessera samplers`
};

/// Validated parameter values of one plugin instance (defaults filled in).
class PluginParams {
  public:
    PluginParams() = default;
    explicit PluginParams(const std::vector<PluginParamSpec> &specs);
    /// The value of a declared key. Throws std::logic_error for an undeclared key (a plugin bug).
    double get(std::string_view key) const;
    int get_int(std::string_view key) const { return int(get(key)); }
    bool get_bool(std::string_view key) const { return get(key) != 0; }
    /// True when the user gave the key explicitly.
    bool is_set(std::string_view key) const;
    /// Sets a declared key (validated by the parser before).
    void set(std::string_view key, double value);
    /// "key=value,key=value" of every parameter, in declaration order.
    std::string describe() const;

  private:
    size_t index_of(std::string_view key) const;
    std::vector<std::string> keys_;
    std::vector<double> values_;
    std::vector<bool> given_;
};

/// One float per pixel, row-major: a diagnostic image of a plugin (written as an EXR layer).
struct FrameLayer {
    std::string name;  ///< e.g. "active", "test", "interpolated"
    std::vector<float> data;
};

/// What one frame of a frame plugin produced.
struct FrameResult {
    uint32_t width = 0, height = 0;
    std::vector<Rgb> color;    ///< final pixel colours, row-major
    std::vector<float> rays;   ///< rays traced per pixel this frame (the rays-per-pixel heat map)
    /// The paper's diagnostic images. A deque, so that references returned by layer() stay
    /// valid when later layers are added.
    std::deque<FrameLayer> diagnostics;
    uint64_t samples = 0;      ///< camera samples evaluated (primary rays traced)
    uint64_t rays_total = 0;   ///< all rays traced (primary, shadow, reflection, refraction)
    uint64_t shadow_rays = 0;  ///< shadow rays traced (part of rays_total; Sample::shadow_rays)
    /// Shadow rays the source did not trace because the light could not contribute (sum of
    /// Sample::shadow_rays_avoided).
    uint64_t shadow_rays_avoided = 0;
    uint64_t shaded = 0;       ///< attribute vectors shaded without a primary ray (`shade`)
    uint64_t nan_samples = 0;  ///< non-finite samples dropped
    /// Fraction of the plugin's decision units (pixels or subpixels) found active, i.e. given
    /// extra work; `active_unit` names the unit.
    double active_fraction = 0;
    std::string active_unit = "pixels";
    /// Clears and sizes every buffer for a w x h frame (existing diagnostic layers are kept,
    /// zeroed, so that their memory is reused from frame to frame). zero = false only sizes
    /// the buffers, leaving old values: for a plugin that overwrites every pixel of every
    /// buffer it swaps in (kim's resolve), which then pays no memset per frame.
    void reset(uint32_t w, uint32_t h, bool zero = true);
    /// Adds (or returns the existing) zero-filled diagnostic layer `name`. The reference stays
    /// valid until the next reset().
    FrameLayer &layer(const std::string &name);
};

/// Shadow-ray counts summed over the batches of one tile, without atomics: a plugin that traces
/// small packets adds them here and hands the tile's sum to FrameShadowRays once (two contended
/// atomic adds per 8-sample packet took about 1.5 % of a fliptri frame on two threads).
struct ShadowRayTally {
    uint64_t traced = 0, avoided = 0;
    void add(std::span<const Sample> samples) {
        for (const Sample &s : samples) {
            traced += s.shadow_rays;
            avoided += s.shadow_rays_avoided;
        }
    }
};

/// A frame's shadow-ray counts (Sample::shadow_rays, shadow_rays_avoided), summed from
/// concurrent run_tile calls with one atomic add per batch (or per tile, via ShadowRayTally);
/// integer sums, so the totals do not depend on the thread count.
class FrameShadowRays {
  public:
    /// Serial (begin_frame).
    void reset() {
        traced_.store(0, std::memory_order_relaxed);
        avoided_.store(0, std::memory_order_relaxed);
    }
    /// Thread-safe: adds the counts of a batch of evaluated samples.
    void add(std::span<const Sample> samples) const {
        uint64_t traced = 0, avoided = 0;
        for (const Sample &s : samples) {
            traced += s.shadow_rays;
            avoided += s.shadow_rays_avoided;
        }
        traced_.fetch_add(traced, std::memory_order_relaxed);
        avoided_.fetch_add(avoided, std::memory_order_relaxed);
    }
    /// Thread-safe: adds a tile's tally.
    void add(const ShadowRayTally &t) const {
        if (t.traced)
            traced_.fetch_add(t.traced, std::memory_order_relaxed);
        if (t.avoided)
            avoided_.fetch_add(t.avoided, std::memory_order_relaxed);
    }
    /// Serial (end_frame): fills FrameResult::shadow_rays and shadow_rays_avoided.
    void write(FrameResult &r) const {
        r.shadow_rays = traced_.load(std::memory_order_relaxed);
        r.shadow_rays_avoided = avoided_.load(std::memory_order_relaxed);
    }

  private:
    mutable std::atomic<uint64_t> traced_{0}, avoided_{0};
};

/// A real-time sampling mode. One instance renders one frame at a time; `run_tile` is called
/// concurrently for different tiles of one stage, so it may write only the data of its own
/// tile's pixels (or use atomics); everything else happens in the serial calls.
class PixelSampler {
  public:
    virtual ~PixelSampler() = default;
    /// Serial. Prepares a frame at the source's resolution (reallocates on a size change).
    virtual void begin_frame(const SampleSource &source) = 0;
    /// Stages of the current frame (constant during a frame).
    virtual int stage_count() const = 0;
    /// Short name of a stage for timing reports ("presample", "test", "supersample", ...).
    virtual std::string stage_name(int stage) const;
    /// What stage `stage` is split into, asked serially just before it starts (after
    /// end_stage of the stage before): kTileJobs (the default), one job per tile, or N jobs
    /// that are not tiles: run_tile then gets an empty rectangle with index k of count N, and
    /// the stage splits its work by those (rows of a copy, lines of a scan). N = 0 runs no job
    /// (end_stage still runs).
    static constexpr uint32_t kTileJobs = ~0u;
    virtual uint32_t stage_jobs(int /*stage*/) const { return kTileJobs; }
    /// Parallel over tiles (or the stage's jobs, see stage_jobs). Tiles of stage s+1 start only
    /// after every tile of stage s finished and end_stage(s) returned.
    virtual void run_tile(int stage, const PixelRect &tile, const SampleSource &source) = 0;
    /// A hint, from the thread that will run `tile` of `stage` next, called just before it
    /// runs the tile it holds now: bring the next tile's data into the cache (prefetch
    /// instructions, or reads of bytes that only that tile writes in this stage; no writes, no
    /// state). Stages that walk large per-frame arrays tile by tile otherwise wait for one cold
    /// miss after another at every tile's start. Default: nothing.
    virtual void prefetch_tile(int /*stage*/, const PixelRect & /*tile*/) const {}
    /// Serial, after the barrier that ends `stage`.
    virtual void end_stage(int /*stage*/, const SampleSource & /*source*/) {}
    /// Serial, after the last stage: writes the frame's colours, rays, diagnostics and counts.
    virtual void end_frame(FrameResult &result) = 0;
    /// The attribute groups (kAttr* bits, sampling/sample_source.h) this instance reads from
    /// Sample::first_hit, for its parameters; the source may leave the rest out. Thread-safe,
    /// constant for the instance. Default: everything (a plugin that does not say).
    virtual uint32_t attributes_used() const { return kAttrAll; }

    /// Whether frames write their diagnostic layers (FrameResult::diagnostics; the colour, the
    /// per-pixel rays and the counts are always written, and do not depend on this). Default
    /// on. Serial, between frames. The real-time loop turns them off for the frames it does
    /// not write out: at 1024x1024 they are several megabytes per layer and frame.
    void set_diagnostics(bool on) { diagnostics_ = on; }
    bool diagnostics() const { return diagnostics_; }

  protected:
    /// Plugins' end_frame, when diagnostics are off: drops the layers an earlier frame added.
    static void drop_diagnostics(FrameResult &r) { r.diagnostics.clear(); }

  private:
    bool diagnostics_ = true;
};

/// Progressive modes run on the adaptive scheduler; frame modes on the frame scheduler.
enum class PluginKind { Progressive, Frame };

/// A registered plugin.
struct PluginInfo {
    std::string name;
    PluginKind kind = PluginKind::Frame;
    std::string summary;  ///< one line: what it does and its source paper
    std::vector<PluginParamSpec> params;
    /// Makes a frame plugin (empty for progressive ones).
    std::function<std::unique_ptr<PixelSampler>(const PluginParams &)> make;
};

/// Every plugin, in the order `tessera samplers` lists them.
const std::vector<PluginInfo> &plugin_registry();
/// The plugin called `name`, or nullptr.
const PluginInfo *find_plugin(std::string_view name);

/// A parsed `--sampler` value.
struct PluginSpec {
    const PluginInfo *info = nullptr;
    PluginParams params;
    /// "name:key=value,..." with every parameter (defaults included).
    std::string describe() const;
};

/// Parses "NAME[:key=value,...]". Throws std::invalid_argument with a message naming the
/// plugin and the key for an unknown plugin, an unknown key, a repeated key, a malformed item,
/// a non-number, a non-integer for an integer key, or a value outside the key's range.
PluginSpec parse_plugin_spec(std::string_view text);

/// The text of `tessera samplers`: every plugin, its summary, and its keys with defaults,
/// ranges and help.
std::string format_plugin_list();

}  // namespace tessera::sampling
