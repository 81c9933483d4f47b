// Checkpoints store the film's accumulation state bit-exactly.
#include <doctest/doctest.h>

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "approx.h"
#include "renderer/app/checkpoint.h"
#include "renderer/util/image_io.h"
#include "renderer/input/scene_desc.h"
#include "test_helpers.h"

using namespace tessera;

namespace {

/// A 13x7 film keeping `aovs`, filled with a fixed pseudo-random mix of hits, misses and a NaN.
void fill(sampling::Film &film) {
    uint32_t state = 12345;
    auto rnd = [&] {
        state = state * 1664525u + 1013904223u;
        return float(state >> 8) * 0x1p-24f;
    };
    for (uint32_t y = 0; y < 7; ++y)
        for (uint32_t x = 0; x < 13; ++x)
            for (uint32_t i = 0; i < (x + y) % 5 + 1; ++i) {
                Sample s;
                s.radiance = Rgb(rnd() * 3, rnd() / 7, rnd() * 1e-3f);
                s.albedo = Rgb(rnd());
                s.normal = Vec3f(rnd(), -rnd(), 0.5f);
                s.depth = (x == 3) ? kInfinity : rnd() * 100;
                film.add_sample(x, y, i, s);
            }
    Sample nan;
    nan.radiance = Rgb(std::nanf(""), 0, 0);
    film.add_sample(0, 0, 9, nan);
}

/// Both films hold bit-identical accumulation state (beauty and AOVs).
void check_same_state(const sampling::Film &a, const sampling::Film &b) {
    CHECK(a.aovs() == b.aovs());
    CHECK(a.nan_count() == b.nan_count());
    REQUIRE(a.raw_pixels().size() == b.raw_pixels().size());
    CHECK(std::memcmp(a.raw_pixels().data(), b.raw_pixels().data(),
                      a.raw_pixels().size() * sizeof(sampling::Film::PixelData)) == 0);
    const sampling::Film::AovData &x = a.raw_aovs(), &y = b.raw_aovs();
    CHECK(x.albedo == y.albedo);
    CHECK(x.normal == y.normal);
    CHECK(x.depth == y.depth);
}

}  // namespace

TEST_CASE("checkpoint round trip restores every pixel's state bit for bit, for any AOV set") {
    using sampling::Aov;
    using sampling::AovSet;
    for (AovSet aovs : {AovSet{}, AovSet{Aov::Depth}, AovSet{Aov::Albedo, Aov::Normal},
                        AovSet::all()}) {
        CAPTURE(aovs.describe());
        sampling::Film film(13, 7, aovs);
        fill(film);
        std::string path = test::output_dir() + "/checkpoint_roundtrip.exr";
        CheckpointState st;
        st.passes = 4;
        st.seed = 77;
        st.elapsed_s = 1.5;
        st.scene = "scene.pbrt";
        st.settings = "adaptive error=0.01";
        write_checkpoint(path, film, st);

        // Only the kept AOVs' channels are in the file.
        CHECK(checkpoint_aovs(path) == aovs);
        std::vector<std::string> names = image_channel_names(path);
        auto has = [&](const char *c) {
            return std::find(names.begin(), names.end(), c) != names.end();
        };
        CHECK(has("albedo.R") == aovs.has(Aov::Albedo));
        CHECK(has("normal.Z") == aovs.has(Aov::Normal));
        CHECK(has("depth.Z") == aovs.has(Aov::Depth));
        CHECK(names.size() == 19 + 3 * aovs.has(Aov::Albedo) + 3 * aovs.has(Aov::Normal) +
                                  aovs.has(Aov::Depth));

        sampling::Film back(13, 7, aovs);
        CheckpointState st2 = read_checkpoint(path, back);
        CHECK(st2.passes == 4);
        CHECK(st2.seed == 77);
        CHECK(st2.elapsed_s == test::Approx(1.5));
        CHECK(st2.scene == "scene.pbrt");
        CHECK(st2.settings == "adaptive error=0.01");
        check_same_state(film, back);

        // A film of another size, or with other AOVs, is refused with a clear message.
        sampling::Film wrong(4, 4, aovs);
        CHECK_THROWS_WITH_AS(read_checkpoint(path, wrong), doctest::Contains("checkpoint is 13x7"),
                             SceneError);
        sampling::Film other(13, 7, aovs == AovSet::all() ? AovSet{} : AovSet::all());
        CHECK_THROWS_WITH_AS(read_checkpoint(path, other),
                             doctest::Contains(("checkpoint has the AOVs " + aovs.describe()).c_str()),
                             SceneError);
        CHECK_THROWS_AS(read_checkpoint(path + ".missing", back), SceneError);
        std::filesystem::remove(path);
    }
}

TEST_CASE("a checkpoint in the layout before AOVs were optional reads as all AOVs") {
    // The old layout, in its channel order: mean RGB, sum and half as lo/hi words, the three
    // AOVs, then the counts; OpenEXR stores them sorted, reading maps them by name.
    sampling::Film film(13, 7, sampling::AovSet::all());
    fill(film);
    std::vector<std::string> names = {"R", "G", "B"};
    for (const char *buf : {"sum", "half"})
        for (const char *c : {"R", "G", "B"})
            for (const char *part : {"lo", "hi"})
                names.push_back(std::string(buf) + "." + c + "_" + part);
    for (const char *c : {"albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z",
                          "depth.Z", "count.taken", "count.accepted", "count.half_accepted",
                          "count.hits"})
        names.push_back(c);
    const int nch = int(names.size());
    REQUIRE(nch == 26);
    OIIO::ImageSpec spec(13, 7, nch, OIIO::TypeDesc::FLOAT);
    spec.channelnames = names;
    spec.channelformats.clear();
    for (const std::string &n : names) {
        bool is_uint = n.rfind("sum.", 0) == 0 || n.rfind("half.", 0) == 0 ||
                       n.rfind("count.", 0) == 0;
        spec.channelformats.push_back(is_uint ? OIIO::TypeDesc::UINT : OIIO::TypeDesc::FLOAT);
    }
    spec.attribute("compression", "zip");
    spec.attribute("tessera:format", "tessera-checkpoint-1");
    spec.attribute("tessera:passes", 3);
    spec.attribute("tessera:seed", "5");
    spec.attribute("tessera:elapsed_s", "2");
    spec.attribute("tessera:nan_count", std::to_string(film.nan_count()));
    spec.attribute("tessera:scene", "old.pbrt");
    spec.attribute("tessera:settings", "uniform");
    auto bits = [](float f) {
        uint32_t u;
        std::memcpy(&u, &f, 4);
        return u;
    };
    const auto &px = film.raw_pixels();
    const auto &aov = film.raw_aovs();
    std::vector<uint32_t> words;
    for (size_t i = 0; i < px.size(); ++i) {
        const sampling::Film::PixelData &p = px[i];
        for (int c = 0; c < 3; ++c) words.push_back(bits(p.accepted ? float(p.sum[c] / p.accepted) : 0.f));
        for (const double *buf : {p.sum, p.half_sum})
            for (int c = 0; c < 3; ++c) {
                uint64_t b;
                std::memcpy(&b, &buf[c], 8);
                words.push_back(uint32_t(b));
                words.push_back(uint32_t(b >> 32));
            }
        for (float v : aov.albedo[i]) words.push_back(bits(v));
        for (float v : aov.normal[i]) words.push_back(bits(v));
        words.push_back(bits(aov.depth[i]));
        for (uint32_t v : {p.taken, p.accepted, p.half_accepted, p.hits}) words.push_back(v);
    }
    std::string path = test::output_dir() + "/checkpoint_old_layout.exr";
    {
        auto out = OIIO::ImageOutput::create("exr");
        REQUIRE(out);
        REQUIRE(out->open(path, spec));
        REQUIRE(out->write_image(OIIO::TypeDesc::UNKNOWN, words.data()));
        REQUIRE(out->close());
    }
    CHECK(checkpoint_aovs(path) == sampling::AovSet::all());
    sampling::Film back(13, 7, sampling::AovSet::all());
    CheckpointState st = read_checkpoint(path, back);
    CHECK(st.passes == 3);
    CHECK(st.seed == 5);
    check_same_state(film, back);
    std::filesystem::remove(path);
}

TEST_CASE("checkpoint of a film with prefix snapshots: round trip, and rebuilt without them") {
    sampling::Film film(13, 7, {}, true);
    fill(film);
    std::string path = test::output_dir() + "/checkpoint_prefix.exr";
    CheckpointState st;
    st.passes = 2;
    st.settings = "adaptive:prefix-error=1";
    write_checkpoint(path, film, st);
    std::vector<std::string> names = image_channel_names(path);
    CHECK(names.size() == 19 + 8);
    CHECK(std::find(names.begin(), names.end(), "prefix.prev.G") != names.end());

    sampling::Film back(13, 7, {}, true);
    read_checkpoint(path, back);
    check_same_state(film, back);
    REQUIRE(back.raw_prefix().size() == film.raw_prefix().size());
    CHECK(std::memcmp(back.raw_prefix().data(), film.raw_prefix().data(),
                      film.raw_prefix().size() * sizeof(sampling::Film::PrefixData)) == 0);
    // Some pixel has both snapshots, so the comparison above compared real values.
    CHECK(film.pixel_stats(4, 0).prefix_accepted == 2);

    // A checkpoint without snapshots (a render that could not adapt) resumes one that needs
    // them: the pixels are those written; a pixel whose count is a power of two gets the
    // snapshot the film took then (the same bits as the film that kept them), every earlier
    // one is unknown, so no pixel has an error estimate until the film takes its own.
    sampling::Film plain(13, 7);
    fill(plain);
    std::string plain_path = test::output_dir() + "/checkpoint_no_prefix.exr";
    write_checkpoint(plain_path, plain, st);
    sampling::Film needs(13, 7, {}, true);
    read_checkpoint(plain_path, needs);
    check_same_state(plain, needs);
    int exact = 0;
    for (uint32_t y = 0; y < 7; ++y)
        for (uint32_t x = 0; x < 13; ++x) {
            const size_t i = size_t(y) * 13 + x;
            const auto &got = needs.raw_prefix()[i], &kept = film.raw_prefix()[i];
            const uint32_t taken = needs.sample_count(x, y);
            CAPTURE(x);
            CAPTURE(y);
            CHECK(got.prev_accepted == 0);
            CHECK(needs.pixel_stats(x, y).prefix_accepted == 0);
            if ((taken & (taken - 1)) == 0) {
                CHECK(got.cur_accepted == kept.cur_accepted);
                CHECK(std::memcmp(got.cur_mean, kept.cur_mean, sizeof got.cur_mean) == 0);
                ++exact;
            } else {
                CHECK(got.cur_accepted == 0);
            }
        }
    CHECK(exact > 20);
    std::filesystem::remove(path);
    std::filesystem::remove(plain_path);
}
