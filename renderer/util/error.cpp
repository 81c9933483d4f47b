// The warning channel (util/error.h).
#include "renderer/util/error.h"

#include <cstdio>
#include <mutex>
#include <set>

namespace tessera {

namespace {

struct WarningLog {
    std::mutex mutex;
    std::set<std::string> seen;
    int count = 0;
    std::string last;
    bool muted = false;
};

WarningLog &warning_log() {
    static WarningLog log;
    return log;
}

}  // namespace

void warn(const FileLoc &loc, const std::string &msg) {
    std::string line = loc.file.empty() ? "warning: " + msg : loc.str() + ": warning: " + msg;
    WarningLog &log = warning_log();
    std::lock_guard<std::mutex> lock(log.mutex);
    // A hostile file can produce any number of distinct warnings: bound the memory the
    // deduplication keeps (at worst a message is then printed again).
    if (log.seen.size() >= 100000) log.seen.clear();
    if (!log.seen.insert(line).second) return;
    ++log.count;
    log.last = line;
    if (!log.muted) std::fprintf(stderr, "%s\n", line.c_str());
}

void mute_warnings(bool muted) {
    WarningLog &log = warning_log();
    std::lock_guard<std::mutex> lock(log.mutex);
    log.muted = muted;
}

int warning_count() {
    WarningLog &log = warning_log();
    std::lock_guard<std::mutex> lock(log.mutex);
    return log.count;
}

std::string last_warning() {
    WarningLog &log = warning_log();
    std::lock_guard<std::mutex> lock(log.mutex);
    return log.last;
}

}  // namespace tessera
