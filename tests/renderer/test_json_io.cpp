// Tests of write_json_atomic (renderer/util/json_io.h): the bytes it writes, the atomic
// replacement of an existing file, and its errors (docs/ARCHITECTURE.md, "The data that flows":
// the stats JSON is written atomically, a temporary file renamed into place).
#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "renderer/util/image_io.h"
#include "renderer/util/json_io.h"
#include "test_helpers.h"

using namespace tessera;
namespace fs = std::filesystem;

namespace {

std::string read_bytes(const fs::path &p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

std::vector<std::string> listing(const fs::path &dir) {
    std::vector<std::string> names;
    for (const auto &e : fs::directory_iterator(dir)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    return names;
}

// The message of the OutputError that write_json_atomic(path, j) throws ("" when none).
std::string error_of(const std::string &path, const nlohmann::json &j) {
    try {
        write_json_atomic(path, j);
    } catch (const OutputError &e) {
        return e.what();
    }
    return {};
}

nlohmann::json sample_stats() {
    nlohmann::json j;
    j["samples"] = 1234567;
    j["lock_wait_fraction"] = 0.015625;
    j["spp_histogram"] = {0, 3, 5, 8};
    j["scene"] = "examples/cornell-box/scene.pbrt";
    j["nested"] = {{"converged", true}, {"passes", 7}};
    return j;
}

}  // namespace

TEST_CASE("write_json_atomic: writes dump(2) and a newline, nothing else") {
    const fs::path dir = test::temp_dir("json_io_bytes", true);
    const fs::path path = dir / "stats.json";
    const nlohmann::json j = sample_stats();
    write_json_atomic(path.string(), j);
    CHECK(read_bytes(path) == j.dump(2) + "\n");
    CHECK(nlohmann::json::parse(read_bytes(path)) == j);
    // No temporary stays beside it.
    CHECK(listing(dir) == std::vector<std::string>{"stats.json"});
    // An empty object too: "{}" and the newline.
    write_json_atomic(path.string(), nlohmann::json::object());
    CHECK(read_bytes(path) == "{}\n");
}

TEST_CASE("write_json_atomic: replaces an existing file by a rename, leaving no temporary") {
    const fs::path dir = test::temp_dir("json_io_replace", true);
    const fs::path path = dir / "stats.json";
    // A longer old file: the new one must not keep its tail.
    test::write_text(path, std::string(4096, 'x'));
    // A second name for the old file: a rename onto `path` leaves it with the old bytes, a
    // rewrite in place would change them.
    fs::create_hard_link(path, dir / "old.json");
    const nlohmann::json j = sample_stats();
    write_json_atomic(path.string(), j);
    CHECK(read_bytes(path) == j.dump(2) + "\n");
    CHECK(read_bytes(dir / "old.json") == std::string(4096, 'x'));
    CHECK(fs::hard_link_count(path) == 1);
    CHECK(!fs::exists(temp_path_for(path.string())));
    CHECK(listing(dir) == std::vector<std::string>{"old.json", "stats.json"});
}

TEST_CASE("write_json_atomic: an unwritable location throws naming the path") {
    const fs::path dir = test::temp_dir("json_io_errors", true);
    const nlohmann::json j = sample_stats();

    // A folder that does not exist: nothing is created.
    const std::string missing = (dir / "no-such-folder" / "stats.json").string();
    const std::string msg = error_of(missing, j);
    CHECK(msg.find(missing) != std::string::npos);
    CHECK(!fs::exists(dir / "no-such-folder"));
    CHECK(listing(dir).empty());

    // The temporary cannot be created (a folder holds its name): the old file keeps its bytes
    // and the temporary's name is free again.
    const fs::path path = dir / "stats.json";
    test::write_text(path, "old contents\n");
    const std::string tmp = temp_path_for(path.string());
    fs::create_directory(tmp);
    const std::string msg2 = error_of(path.string(), j);
    CHECK(msg2.find(path.string()) != std::string::npos);
    CHECK(read_bytes(path) == "old contents\n");
    CHECK(!fs::exists(tmp));
    CHECK(listing(dir) == std::vector<std::string>{"stats.json"});

    // A full device (written directly: no temporary can be renamed onto it): the failed flush
    // is an error naming it.
    if (fs::exists("/dev/full")) {
        const std::string msg3 = error_of("/dev/full", j);
        CHECK(msg3.find("/dev/full") != std::string::npos);
    }
}
