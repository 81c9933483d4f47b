// Errors and warnings about input: where something came from (FileLoc), the bad-input exception
// every reader throws (SceneError: exit code 2 in the CLI, "file:line: what is wrong") and the
// warning channel (deduplicated, thread-safe). Every layer reports through this header alone.
#pragma once

#include <stdexcept>
#include <string>

namespace tessera {

/// Where something came from in an input file.
struct FileLoc {
    std::string file;
    int line = 0;
    std::string str() const { return file + ":" + std::to_string(line); }
};

/// A bad-input error: the message already starts with "file:line: ". Exit code 2 in the CLI.
class SceneError : public std::runtime_error {
  public:
    explicit SceneError(const std::string &msg) : std::runtime_error(msg) {}
    SceneError(const FileLoc &loc, const std::string &msg)
        : std::runtime_error(loc.str() + ": " + msg) {}
};

/// Prints a warning "file:line: warning: msg" to stderr (thread-safe, deduplicated per message).
void warn(const FileLoc &loc, const std::string &msg);
/// Counts warnings without printing them (the ranks of a distributed render other than rank 0:
/// every rank reads the same scene, and rank 0 says it once). Thread-safe.
void mute_warnings(bool muted);
/// Number of warnings printed so far (tests). Thread-safe.
int warning_count();
/// The most recent warning line printed ("file:line: warning: msg"), "" if none. Thread-safe.
std::string last_warning();

}  // namespace tessera
