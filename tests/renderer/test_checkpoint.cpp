// Checkpoints store the film's accumulation state bit-exactly.
#include <doctest/doctest.h>

#include <cstring>
#include <filesystem>

#include "renderer/checkpoint.h"
#include "renderer/scene_desc.h"
#include "test_helpers.h"

using namespace tessera;

TEST_CASE("checkpoint round trip restores every pixel's state bit for bit") {
    sampling::Film film(13, 7);
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
    std::string path = test::output_dir() + "/checkpoint_roundtrip.exr";
    CheckpointState st;
    st.passes = 4;
    st.seed = 77;
    st.elapsed_s = 1.5;
    st.scene = "scene.pbrt";
    st.settings = "adaptive error=0.01";
    write_checkpoint(path, film, st);

    sampling::Film back(13, 7);
    CheckpointState st2 = read_checkpoint(path, back);
    CHECK(st2.passes == 4);
    CHECK(st2.seed == 77);
    CHECK(st2.elapsed_s == doctest::Approx(1.5));
    CHECK(st2.scene == "scene.pbrt");
    CHECK(st2.settings == "adaptive error=0.01");
    CHECK(back.nan_count() == film.nan_count());
    REQUIRE(back.raw_pixels().size() == film.raw_pixels().size());
    CHECK(std::memcmp(back.raw_pixels().data(), film.raw_pixels().data(),
                      film.raw_pixels().size() * sizeof(sampling::Film::PixelData)) == 0);

    // A film of another size is refused with a clear message.
    sampling::Film wrong(4, 4);
    CHECK_THROWS_WITH_AS(read_checkpoint(path, wrong), doctest::Contains("checkpoint is 13x7"),
                         SceneError);
    CHECK_THROWS_AS(read_checkpoint(path + ".missing", back), SceneError);
    std::filesystem::remove(path);
}
