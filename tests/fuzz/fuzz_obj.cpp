// libFuzzer target: the OBJ/MTL loader (tinyobjloader) and the scene builder.
// Built with -DTESSERA_FUZZ=ON (clang); run by scripts/run_fuzz.sh. See fuzz_entry.h.
#include <cstddef>
#include <cstdint>

#include "fuzz_entry.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    tessera::fuzz::run(tessera::fuzz::Target::Obj,
                       std::string_view(reinterpret_cast<const char *>(data), size));
    return 0;
}
