// Helpers shared by the tests: where ../shared is, and a skip message when it is absent.
#pragma once

#include <doctest/doctest.h>

#include <cstdio>
#include <filesystem>
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

}  // namespace tessera::test

/// Skips the rest of a test case with a message when ../shared/scenes is absent.
#define TESSERA_REQUIRE_SHARED(path_var)                                                   \
    std::string path_var = ::tessera::test::shared_dir();                                  \
    if (path_var.empty()) {                                                                \
        MESSAGE("skipped: ../shared/scenes not found (a user's clone has none)");          \
        return;                                                                            \
    }
