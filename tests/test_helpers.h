// Helpers shared by the tests: where ../shared is, and a skip message when it is absent.
#pragma once

#include <doctest/doctest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace tessera::test {

/// Path of the shared/ folder (scenes, papers) or "" when this clone has none.
inline std::string shared_dir() {
    std::filesystem::path p = TESSERA_SHARED_DIR;
    std::error_code ec;
    if (std::filesystem::is_directory(p / "scenes", ec)) return p.string();
    return {};
}

/// Folder for a failing test's diagnostic images and histograms (created on demand).
inline std::string output_dir() {
    std::filesystem::create_directories(TESSERA_TEST_OUTPUT_DIR);
    return TESSERA_TEST_OUTPUT_DIR;
}

/// A scratch folder `<system temp>/tessera_<name>`, created on demand (emptied when `fresh`).
inline std::filesystem::path temp_dir(const std::string &name, bool fresh = false) {
    std::filesystem::path p = std::filesystem::temp_directory_path() / ("tessera_" + name);
    if (fresh) std::filesystem::remove_all(p);
    std::filesystem::create_directories(p);
    return p;
}

/// Writes `text` to `path` (binary, parent folders created); returns the path as a string.
inline std::string write_text(const std::filesystem::path &path, const std::string &text) {
    std::filesystem::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << text;
    return path.string();
}

}  // namespace tessera::test

/// Skips the rest of a test case with a message when ../shared/scenes is absent.
#define TESSERA_REQUIRE_SHARED(path_var)                                                   \
    std::string path_var = ::tessera::test::shared_dir();                                  \
    if (path_var.empty()) {                                                                \
        MESSAGE("skipped: ../shared/scenes not found (a user's clone has none)");          \
        return;                                                                            \
    }
