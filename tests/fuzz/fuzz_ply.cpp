// libFuzzer target: the PLY mesh loader (renderer/input/ply_reader.h): header, body and limits.
// Built with -DTESSERA_FUZZ=ON (clang); run by scripts/run_fuzz.sh. See fuzz_entry.h.
#include <cstddef>
#include <cstdint>

#include "fuzz_entry.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    tessera::fuzz::run(tessera::fuzz::Target::Ply,
                       std::string_view(reinterpret_cast<const char *>(data), size));
    return 0;
}
