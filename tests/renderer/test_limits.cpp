// Resource limits (renderer/util/limits.h): the checks made before large allocations, and the
// parser's limits on hostile text. The command-line side (exit code 2, file:line) is covered by
// the broken-scene corpus (tests/broken, ctest cli_broken_corpus).
#include <doctest/doctest.h>

#include <sys/resource.h>

#include <string>

#include "render_test_util.h"
#include "renderer/util/limits.h"
#include "renderer/input/pbrt_parser.h"
#include "test_helpers.h"

using namespace tessera;

namespace {

/// The SceneError message of `f`, "" if it throws none.
template <class F>
std::string error_of(F &&f) {
    try {
        f();
    } catch (const SceneError &e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("limits: format_bytes and the memory budget") {
    CHECK(format_bytes(17) == "17 B");
    CHECK(format_bytes(1536) == "1.5 KiB");
    CHECK(format_bytes(uint64_t(640) << 20) == "640 MiB");
    CHECK(format_bytes(uint64_t(3) << 40) == "3.0 TiB");
    const uint64_t budget = memory_budget_bytes();
    CHECK(budget > (uint64_t(64) << 20));  // any machine that runs the tests has 64 MiB
    // An address-space limit lowers the budget (the soft limit, restored afterwards). Not
    // under the sanitizers: their shadow memory needs terabytes of address space.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    return;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
    return;
#endif
#endif
    struct rlimit old {};
    REQUIRE(getrlimit(RLIMIT_AS, &old) == 0);
    struct rlimit lower = old;
    lower.rlim_cur = rlim_t(64) << 30;
    if (old.rlim_max == RLIM_INFINITY || old.rlim_max >= lower.rlim_cur) {
        REQUIRE(setrlimit(RLIMIT_AS, &lower) == 0);
        CHECK(memory_budget_bytes() <= (uint64_t(64) << 30));
        REQUIRE(setrlimit(RLIMIT_AS, &old) == 0);
    }
}

TEST_CASE("limits: film, mesh and image checks name the file and line") {
    const FileLoc loc{"scene.pbrt", 3};
    CHECK(error_of([&] { check_film(16, 16, 4, loc, loc); }).empty());
    std::string e = error_of([&] { check_film(70000, 1, 4, loc, loc); });
    CHECK(e.rfind("scene.pbrt:3: film resolution 70000x1 is larger than the maximum", 0) == 0);
    e = error_of([&] { check_film(40000, 40000, 4, loc, loc); });
    CHECK(e.find("more than the maximum of 1073741824 pixels") != std::string::npos);
    e = error_of([&] { check_film(16, 16, int64_t(1) << 31, loc, {"s.pbrt", 4}); });
    CHECK(e.rfind("s.pbrt:4: pixelsamples", 0) == 0);
    // 30000^2 pixels pass the pixel limit; their memory (~360 GiB) is checked against the
    // budget.
    if (memory_budget_bytes() < film_memory_bytes(30000, 30000)) {
        e = error_of([&] { check_film(30000, 30000, 4, loc, loc); });
        CHECK(e.find("needs about") != std::string::npos);
    }
    e = error_of([&] { check_mesh(kMaxMeshVertices + 1, 1, "trianglemesh", loc); });
    CHECK(e.find("vertices, more than the maximum") != std::string::npos);
    e = error_of([&] { check_image(60000, 60000, 3, "image \"x.png\"", loc); });
    CHECK(e.rfind("scene.pbrt:3: image \"x.png\" is 60000x60000", 0) == 0);
    CHECK(!error_of([&] { check_image(0, 10, 3, "image", loc); }).empty());
}

TEST_CASE("limits: the parser on hostile text") {
    auto parse_error = [](const std::string &text) {
        return error_of([&] { parse_pbrt_string(text, "h.pbrt", ""); });
    };
    // A UTF-8 byte order mark is skipped; other bytes outside strings are rejected by value.
    CHECK(parse_error("\xEF\xBB\xBFWorldBegin\n").empty());
    CHECK(parse_error("WorldBegin\n\x01").rfind("h.pbrt:2: unexpected byte 0x01", 0) == 0);
    CHECK(parse_error("WorldBegin\nShape \"a\xff\"\n").empty());  // UTF-8 in strings is fine
    CHECK(parse_error(std::string("WorldBegin\nShape \"a\0b\"\n", 23)).find("0x00") !=
          std::string::npos);
    // Integers must fit 32 bits, floats a float.
    CHECK(parse_error("WorldBegin\nShape \"trianglemesh\" \"integer indices\" [ 0 1 2147483648 ]")
              .find("out of the 32-bit integer range") != std::string::npos);
    CHECK(parse_error("WorldBegin\nShape \"sphere\" \"float radius\" [ 3.5e38 ]")
              .find("expects numbers, found 3.5e38") != std::string::npos);
    CHECK(parse_error("WorldBegin\nShape \"sphere\" \"float radius\" [ 3.4e38 ]").empty());
    // Unbalanced blocks at the end of the file are errors (pbrt-v4 EndOfFiles).
    CHECK(parse_error("WorldBegin\nAttributeBegin\n").rfind("h.pbrt:2: AttributeBegin without", 0) ==
          0);
    CHECK(parse_error("WorldBegin\nObjectBegin \"o\"\n").rfind("h.pbrt:2: ObjectBegin \"o\" without", 0) ==
          0);
}
