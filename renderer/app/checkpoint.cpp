#include "renderer/app/checkpoint.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "renderer/util/image_io.h"
#include "renderer/util/error.h"

namespace tessera {

namespace {

constexpr const char *kFormatTag = "tessera-checkpoint-1";

using PixelData = sampling::Film::PixelData;

/// The channel layout: name and whether the 4-byte value is a float (else a uint32).
struct Channel {
    std::string name;
    bool is_float;
};

/// The channels of one AOV in the checkpoint (the EXR output's names).
std::vector<std::string> aov_channels(sampling::Aov a) {
    switch (a) {
        case sampling::Aov::Albedo:
            return {"albedo.R", "albedo.G", "albedo.B"};
        case sampling::Aov::Normal:
            return {"normal.X", "normal.Y", "normal.Z"};
        case sampling::Aov::Depth:
            return {"depth.Z"};
    }
    return {};
}

/// The channel layout for a film keeping `aovs`: the beauty words, then the kept AOVs' channels
/// in canonical order. A checkpoint written before AOVs were optional has the channels of
/// AovSet::all() (in another order; reading maps channels by name).
/// A film with prefix snapshots (Film::keeps_prefix) adds their channels at the end.
std::vector<Channel> channel_layout(sampling::AovSet aovs, bool prefix) {
    std::vector<Channel> ch;
    for (const char *c : {"R", "G", "B"}) ch.push_back({c, true});  // mean, for viewers
    for (const char *buf : {"sum", "half"})
        for (const char *c : {"R", "G", "B"})
            for (const char *part : {"lo", "hi"})
                ch.push_back({std::string(buf) + "." + c + "_" + part, false});
    for (const char *c : {"taken", "accepted", "half_accepted", "hits"})
        ch.push_back({std::string("count.") + c, false});
    for (sampling::Aov a : sampling::kAllAovs)
        if (aovs.has(a))
            for (const std::string &name : aov_channels(a)) ch.push_back({name, true});
    if (prefix) {
        for (const char *buf : {"prefix.cur", "prefix.prev"})
            for (const char *c : {"R", "G", "B"}) ch.push_back({std::string(buf) + "." + c, true});
        ch.push_back({"count.prefix_cur_accepted", false});
        ch.push_back({"count.prefix_prev_accepted", false});
    }
    return ch;
}

uint32_t float_bits(float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}
float bits_float(uint32_t u) {
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

/// Packs pixel `i` of the film state into the layout's 4-byte words.
void pack(const PixelData &p, const sampling::Film::AovData &aov,
          const std::vector<sampling::Film::PrefixData> &prefix, size_t i, uint32_t *w) {
    size_t k = 0;
    uint32_t n = p.accepted;
    for (int c = 0; c < 3; ++c) w[k++] = float_bits(n ? float(p.sum[c] / n) : 0.f);
    for (const double *buf : {p.sum, p.half_sum})
        for (int c = 0; c < 3; ++c) {
            uint64_t bits;
            std::memcpy(&bits, &buf[c], 8);
            w[k++] = uint32_t(bits);
            w[k++] = uint32_t(bits >> 32);
        }
    w[k++] = p.taken;
    w[k++] = p.accepted;
    w[k++] = p.half_accepted;
    w[k++] = p.hits;
    if (!aov.albedo.empty())
        for (float v : aov.albedo[i]) w[k++] = float_bits(v);
    if (!aov.normal.empty())
        for (float v : aov.normal[i]) w[k++] = float_bits(v);
    if (!aov.depth.empty()) w[k++] = float_bits(aov.depth[i]);
    if (!prefix.empty()) {
        const sampling::Film::PrefixData &q = prefix[i];
        for (float v : q.cur_mean) w[k++] = float_bits(v);
        for (float v : q.prev_mean) w[k++] = float_bits(v);
        w[k++] = q.cur_accepted;
        w[k++] = q.prev_accepted;
    }
}

/// Unpacks the layout's words into pixel `i`; `aov` already has the kept AOVs' sizes.
void unpack(const uint32_t *w, PixelData &p, sampling::Film::AovData &aov,
            std::vector<sampling::Film::PrefixData> &prefix, size_t i) {
    size_t k = 3;  // skip the mean
    for (double *buf : {p.sum, p.half_sum})
        for (int c = 0; c < 3; ++c) {
            uint64_t bits = uint64_t(w[k]) | (uint64_t(w[k + 1]) << 32);
            k += 2;
            std::memcpy(&buf[c], &bits, 8);
        }
    p.taken = w[k++];
    p.accepted = w[k++];
    p.half_accepted = w[k++];
    p.hits = w[k++];
    if (!aov.albedo.empty())
        for (float &v : aov.albedo[i]) v = bits_float(w[k++]);
    if (!aov.normal.empty())
        for (float &v : aov.normal[i]) v = bits_float(w[k++]);
    if (!aov.depth.empty()) aov.depth[i] = bits_float(w[k++]);
    if (!prefix.empty()) {
        sampling::Film::PrefixData &q = prefix[i];
        for (float &v : q.cur_mean) v = bits_float(w[k++]);
        for (float &v : q.prev_mean) v = bits_float(w[k++]);
        q.cur_accepted = w[k++];
        q.prev_accepted = w[k++];
    }
}

/// The AOVs whose channels the file has; part of an AOV's channels is a damaged file.
sampling::AovSet aovs_in(const imageio::ImageSpec &spec, const std::string &path) {
    sampling::AovSet set;
    for (sampling::Aov a : sampling::kAllAovs) {
        size_t found = 0;
        const std::vector<std::string> names = aov_channels(a);
        for (const std::string &name : names)
            found += size_t(std::count(spec.channelnames.begin(), spec.channelnames.end(), name));
        if (found == names.size())
            set = set.with(a);
        else if (found != 0)
            throw SceneError(path + ":0: checkpoint has only part of the " +
                             sampling::aov_name(a) + " channels (damaged file)");
    }
    return set;
}

}  // namespace

void write_checkpoint(const std::string &path, const sampling::Film &film,
                      const CheckpointState &state) {
    const std::vector<Channel> layout = channel_layout(film.aovs(), film.keeps_prefix());
    const int nch = int(layout.size());
    imageio::ImageSpec spec;
    spec.width = int(film.width());
    spec.height = int(film.height());
    spec.nchannels = nch;
    spec.format = imageio::PixelType::Float;
    for (const Channel &c : layout) {
        spec.channelnames.push_back(c.name);
        spec.channelformats.push_back(c.is_float ? imageio::PixelType::Float
                                                 : imageio::PixelType::UInt32);
    }
    spec.attribute("compression", "zip");
    spec.attribute("tessera:format", kFormatTag);
    spec.attribute("tessera:passes", int(state.passes));
    spec.attribute("tessera:seed", std::to_string(state.seed));
    spec.attribute("tessera:pattern", state.pattern);
    spec.attribute("tessera:elapsed_s", std::to_string(state.elapsed_s));
    spec.attribute("tessera:nan_count", std::to_string(film.nan_count()));
    spec.attribute("tessera:scene", state.scene);
    spec.attribute("tessera:settings", state.settings);

    const std::vector<PixelData> &px = film.raw_pixels();
    std::vector<uint32_t> words(px.size() * size_t(nch));
    for (size_t i = 0; i < px.size(); ++i)
        pack(px[i], film.raw_aovs(), film.raw_prefix(), i, &words[i * size_t(nch)]);

    write_atomically(path, [&](const std::string &tmp) {
        // PixelType::Unknown: the buffer is in the file's native per-channel formats.
        std::string err;
        if (!imageio::backend().write("exr", tmp, spec, imageio::PixelType::Unknown,
                                      words.data(), &err))
            throw std::runtime_error(path + ": cannot write checkpoint: " + err);
    });
}

sampling::AovSet checkpoint_aovs(const std::string &path) {
    OpenedImage img = open_image(path, FileLoc{path, 0}, "checkpoint");
    const imageio::ImageSpec &spec = img.spec;
    if (spec.get_string_attribute("tessera:format") != kFormatTag)
        throw SceneError(path + ":0: not a Tessera checkpoint");
    return aovs_in(spec, path);
}

CheckpointState read_checkpoint(const std::string &path, sampling::Film &film) {
    OpenedImage img = open_image(path, FileLoc{path, 0}, "checkpoint");
    const imageio::ImageSpec &spec = img.spec;
    if (spec.get_string_attribute("tessera:format") != kFormatTag)
        throw SceneError(path + ":0: not a Tessera checkpoint");
    const sampling::AovSet aovs = aovs_in(spec, path);
    if (aovs != film.aovs())
        throw SceneError(path + ":0: checkpoint has the AOVs " + aovs.describe() +
                         ", the render keeps " + film.aovs().describe());
    if (uint32_t(spec.width) != film.width() || uint32_t(spec.height) != film.height())
        throw SceneError(path + ":0: checkpoint is " + std::to_string(spec.width) + "x" +
                         std::to_string(spec.height) + ", the render is " +
                         std::to_string(film.width()) + "x" + std::to_string(film.height()));
    // A render that could not adapt (--spp at most its first pass) writes no prefix
    // snapshots; resumed by one that adapts, they are rebuilt below from what is known.
    bool file_prefix = false;
    for (int f = 0; f < spec.nchannels; ++f)
        file_prefix = file_prefix || spec.channelnames[size_t(f)].rfind("prefix.", 0) == 0;
    const bool rebuild_prefix = film.keeps_prefix() && !file_prefix;
    const std::vector<Channel> layout = channel_layout(aovs, film.keeps_prefix() && file_prefix);
    // The file may store channels in another order (OpenEXR sorts them): map by name.
    std::vector<int> file_index(layout.size(), -1);
    for (size_t c = 0; c < layout.size(); ++c)
        for (int f = 0; f < spec.nchannels; ++f)
            if (spec.channelnames[size_t(f)] == layout[c].name) file_index[c] = f;
    for (size_t c = 0; c < layout.size(); ++c)
        if (file_index[c] < 0)
            throw SceneError(path + ":0: checkpoint lacks channel " + layout[c].name);
    // Every channel is 4 bytes: read native data and reorder.
    std::vector<uint32_t> file_words(size_t(spec.width) * size_t(spec.height) *
                                     size_t(spec.nchannels));
    if (!img.in->read_image(0, spec.nchannels, imageio::PixelType::Unknown, file_words.data()))
        img.fail(img.in->geterror());
    std::vector<PixelData> px(size_t(spec.width) * size_t(spec.height));
    sampling::Film::AovData aov;
    if (aovs.has(sampling::Aov::Albedo)) aov.albedo.resize(px.size());
    if (aovs.has(sampling::Aov::Normal)) aov.normal.resize(px.size());
    if (aovs.has(sampling::Aov::Depth)) aov.depth.resize(px.size());
    std::vector<sampling::Film::PrefixData> prefix(
        film.keeps_prefix() && !rebuild_prefix ? px.size() : 0);
    std::vector<uint32_t> w(layout.size());
    for (size_t i = 0; i < px.size(); ++i) {
        for (size_t c = 0; c < layout.size(); ++c)
            w[c] = file_words[i * size_t(spec.nchannels) + size_t(file_index[c])];
        unpack(w.data(), px[i], aov, prefix, i);
        // A checkpoint is trusted to resume hours of work: reject values no render writes
        // rather than carry NaN or impossible counts into the image.
        const PixelData &q = px[i];
        bool ok = q.accepted <= q.taken && q.half_accepted <= q.accepted && q.hits <= q.accepted;
        for (int c = 0; c < 3; ++c) ok = ok && std::isfinite(q.sum[c]) && std::isfinite(q.half_sum[c]);
        if (!prefix.empty()) {
            const sampling::Film::PrefixData &r = prefix[i];
            ok = ok && r.prev_accepted <= r.cur_accepted && r.cur_accepted <= q.accepted;
            for (int c = 0; c < 3; ++c)
                ok = ok && std::isfinite(r.cur_mean[c]) && std::isfinite(r.prev_mean[c]);
        }
        if (!ok)
            throw SceneError(path + ":0: checkpoint pixel (" + std::to_string(i % size_t(spec.width)) +
                             ", " + std::to_string(i / size_t(spec.width)) +
                             ") holds impossible values (damaged file)");
    }
    CheckpointState st;
    // The metadata is text: a damaged or hand-edited file must give a SceneError, not the
    // std::invalid_argument of std::stoul.
    auto number = [&](const char *key) {
        std::string v = spec.get_string_attribute(key, "0");
        try {
            size_t pos = 0;
            double d = std::stod(v, &pos);
            if (pos == v.size() && std::isfinite(d) && d >= 0) return d;
        } catch (const std::exception &) {
        }
        throw SceneError(path + ":0: checkpoint attribute " + key + " is not a number: \"" + v +
                         "\"");
    };
    st.passes = uint32_t(std::max(0, spec.get_int_attribute("tessera:passes", 0)));
    double seed = number("tessera:seed"), nan_d = number("tessera:nan_count");
    if (seed > double(UINT32_MAX))
        throw SceneError(path + ":0: checkpoint seed is out of range");
    st.seed = uint32_t(seed);
    st.pattern = spec.get_string_attribute("tessera:pattern", "padded");
    st.elapsed_s = number("tessera:elapsed_s");
    uint64_t nan = uint64_t(std::min(nan_d, 1e18));
    st.scene = spec.get_string_attribute("tessera:scene");
    st.settings = spec.get_string_attribute("tessera:settings");
    if (rebuild_prefix) {
        // The snapshot the film takes when a pixel's count reaches a power of two is the mean
        // of all its samples then: exact for a pixel whose count is one now. The snapshots
        // before are lost; an unknown one (no accepted samples) gives the pixel no error
        // estimate (sampling/adaptive_error.h), so it keeps sampling until the film has taken
        // two snapshots of its own, as in a render's first passes: no pixel stops on a guess.
        prefix.assign(px.size(), sampling::Film::PrefixData{});
        for (size_t i = 0; i < px.size(); ++i) {
            const PixelData &q = px[i];
            if (q.taken == 0 || (q.taken & (q.taken - 1)) != 0)
                continue;
            const double inv = q.accepted ? 1.0 / q.accepted : 0.0;
            for (int c = 0; c < 3; ++c) prefix[i].cur_mean[c] = float(q.sum[c] * inv);
            prefix[i].cur_accepted = q.accepted;
        }
    }
    film.restore(std::move(px), std::move(aov), nan, std::move(prefix));
    return st;
}

}  // namespace tessera
