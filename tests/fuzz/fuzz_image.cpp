// libFuzzer target: the native TGA, PFM and PNG readers (renderer/util/native_image.h): headers,
// run-length data, libpng's input. Built with -DTESSERA_FUZZ=ON (clang); run by
// scripts/run_fuzz.sh. See fuzz_entry.h.
#include <cstddef>
#include <cstdint>

#include "fuzz_entry.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    tessera::fuzz::run(tessera::fuzz::Target::Image,
                       std::string_view(reinterpret_cast<const char *>(data), size));
    return 0;
}
