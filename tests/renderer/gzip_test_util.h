// Writing gzip files for the tests of gzip-compressed input (renderer/util/gzip_io.h).
#pragma once

#include <zlib.h>

#include <filesystem>
#include <string>

#include "test_helpers.h"

namespace tessera::test {

/// Writes `data` gzip-compressed to `path` (parent folders created) as one gzip member, or
/// appends it as a further member when `append`; returns the path as a string.
inline std::string write_gzip(const std::filesystem::path &path, const std::string &data,
                              bool append = false) {
    std::filesystem::create_directories(path.parent_path());
    gzFile f = gzopen(path.string().c_str(), append ? "ab" : "wb");
    REQUIRE(f != nullptr);
    if (!data.empty()) REQUIRE(gzwrite(f, data.data(), unsigned(data.size())) == int(data.size()));
    REQUIRE(gzclose(f) == Z_OK);
    return path.string();
}

}  // namespace tessera::test
