// gzip-compressed input files, as pbrt-v4 reads them: a scene file or an Include/Import whose
// name ends in ".gz" (pbrt-v4 ReadDecompressedFileContents) and a "plymesh" whose file ends in
// ".ply.gz" (pbrt-v4-scenes ships several) are decompressed whole into memory with zlib.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace tessera {

/// True when `path` names a gzip-compressed file by pbrt-v4's rule: it ends in ".gz" (case as
/// written; pbrt-v4's HasExtension compares without case, and so does this).
bool has_gz_extension(std::string_view path);

/// `path` without a final ".gz" (any case); `path` itself when it has none.
std::string strip_gz_extension(const std::string &path);

/// Reads the whole gzip file at `path` (every member of a multi-member file) into *out.
/// A file that is not gzip data at all is read as it is (zlib's transparent mode): a scene
/// saved as "x.pbrt.gz" without compressing it still loads.
/// Returns "" on success, else why not: "not found", "is a directory, not a file", "is not a
/// regular file", "is not valid gzip data (...)" for corrupt or truncated data, or "decompresses
/// to more than <max_bytes>" -- checked while decompressing, so a small file that inflates
/// without bound (a "gzip bomb") stops at `max_bytes`. *out is unspecified on failure.
std::string read_gzip_file(const std::string &path, std::string *out, uint64_t max_bytes);

}  // namespace tessera
