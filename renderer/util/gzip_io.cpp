#include "renderer/util/gzip_io.h"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <memory>

#include "renderer/util/limits.h"

namespace tessera {

namespace fs = std::filesystem;

bool has_gz_extension(std::string_view path) {
    if (path.size() < 3) return false;
    std::string_view ext = path.substr(path.size() - 3);
    return ext[0] == '.' && std::tolower(static_cast<unsigned char>(ext[1])) == 'g' &&
           std::tolower(static_cast<unsigned char>(ext[2])) == 'z';
}

std::string strip_gz_extension(const std::string &path) {
    return has_gz_extension(path) ? path.substr(0, path.size() - 3) : path;
}

std::string read_gzip_file(const std::string &path, std::string *out, uint64_t max_bytes) {
    std::error_code ec;
    fs::file_status st = fs::status(path, ec);
    if (ec || !fs::exists(st)) return "not found";
    if (fs::is_directory(st)) return "is a directory, not a file";
    // Only regular files: a FIFO or a device would never end.
    if (!fs::is_regular_file(st)) return "is not a regular file";
    // Closed on every way out, a bad_alloc from the growing string included.
    std::unique_ptr<gzFile_s, int (*)(gzFile)> file(gzopen(path.c_str(), "rb"), gzclose);
    gzFile f = file.get();
    if (!f) return "cannot be opened";
    gzbuffer(f, 1u << 17);
    out->clear();
    std::string why;
    constexpr size_t kChunk = size_t(1) << 20;
    while (true) {
        const size_t old = out->size();
        if (old >= max_bytes) {
            // One byte more than the limit is enough to know it is over.
            char probe;
            if (gzread(f, &probe, 1) == 1)
                why = "decompresses to more than the maximum of " + format_bytes(max_bytes);
            break;
        }
        const size_t want = size_t(std::min<uint64_t>(kChunk, max_bytes - old));
        out->resize(old + want);
        const int got = gzread(f, out->data() + old, unsigned(want));
        if (got < 0) {
            out->resize(old);
            break;  // the error is read below
        }
        out->resize(old + size_t(got));
        if (size_t(got) < want) break;  // the end of the data (or an error, read below)
    }
    int err = Z_OK;
    const char *msg = gzerror(f, &err);
    if (why.empty() && err != Z_OK)
        why = std::string("is not valid gzip data (") +
              (err == Z_BUF_ERROR ? "truncated: unexpected end of file"
                                  : (err == Z_ERRNO ? "read error" : msg)) +
              ")";
    return why;
}

}  // namespace tessera
