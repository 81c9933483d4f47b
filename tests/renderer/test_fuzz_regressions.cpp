// Replays every input the fuzz targets once failed on (tests/fuzz/regressions/<target>/*) through
// the same entry points (tests/fuzz/fuzz_entry.h) in the normal build: each input must be accepted
// or rejected with a SceneError -- no other exception, no crash. The ASan+UBSan job runs this test
// under the sanitizers too.
#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "fuzz/fuzz_entry.h"

using namespace tessera;

namespace {

std::vector<std::filesystem::path> inputs_of(const std::string &target) {
    std::vector<std::filesystem::path> out;
    std::filesystem::path dir =
        std::filesystem::path(TESSERA_SOURCE_DIR) / "tests" / "fuzz" / "regressions" / target;
    std::error_code ec;
    for (const auto &e : std::filesystem::directory_iterator(dir, ec))
        if (e.is_regular_file() && e.path().filename() != "README.md") out.push_back(e.path());
    std::sort(out.begin(), out.end());
    return out;
}

std::string read_bytes(const std::filesystem::path &p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void replay(const std::string &target, fuzz::Target t) {
    for (const std::filesystem::path &p : inputs_of(target)) {
        CAPTURE(p.string());
        std::string bytes = read_bytes(p);
        CHECK_NOTHROW(fuzz::run(t, bytes));
    }
}

}  // namespace

TEST_CASE("fuzz regressions: pbrt parser and scene builder") { replay("pbrt", fuzz::Target::Pbrt); }
TEST_CASE("fuzz regressions: PLY loader") { replay("ply", fuzz::Target::Ply); }
TEST_CASE("fuzz regressions: OBJ loader") { replay("obj", fuzz::Target::Obj); }
TEST_CASE("fuzz regressions: native image readers") { replay("image", fuzz::Target::Image); }
