// One way to write a JSON file (the stats of `tessera render`, the real-time loop's stats,
// `tessera converge`'s convergence.json, the reference cache's metadata): atomically, so that a
// reader never sees half a file, and checked, so that a full disk is an error.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace tessera {

/// Writes `j` to `path` as `j.dump(2)` plus a newline, through a temporary beside it that is
/// renamed onto `path` (write_atomically, renderer/util/image_io.h: links are followed, a device
/// such as /dev/stdout is written directly). The stream is checked after the text is flushed
/// and again after it is closed, since a full disk may show only then. Throws OutputError
/// naming `path` ("PATH: cannot write ...") and leaves no temporary behind.
void write_json_atomic(const std::string &path, const nlohmann::json &j);

}  // namespace tessera
