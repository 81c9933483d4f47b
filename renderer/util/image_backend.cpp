// Loads the image back end's module on first use (renderer/util/image_backend.h).
#include "renderer/util/image_backend.h"

#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <system_error>

namespace tessera::imageio {
namespace {

namespace fs = std::filesystem;

constexpr const char *kModuleName = "libtessera_oiio.so";

/// The folder of the running executable, or empty when /proc does not tell.
fs::path executable_dir() {
    std::error_code ec;
    fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    return ec ? fs::path() : exe.parent_path();
}

/// Where the module may be, in the order tried.
std::vector<std::string> candidates() {
    std::vector<std::string> out;
    if (const char *env = std::getenv("TESSERA_IMAGE_MODULE"); env && *env) {
        out.emplace_back(env);
        return out;  // an explicit choice is the only one tried
    }
    const fs::path dir = executable_dir();
    if (!dir.empty()) {
        out.push_back((dir / kModuleName).string());
        out.push_back((dir / ".." / "lib" / "tessera" / kModuleName).lexically_normal().string());
    }
#ifdef TESSERA_IMAGE_MODULE_BUILD_PATH
    // The build tree's module, for the test executables (which live in build/tests).
    out.emplace_back(TESSERA_IMAGE_MODULE_BUILD_PATH);
#endif
    return out;
}

const Backend *load() {
    std::string tried;
    for (const std::string &path : candidates()) {
        std::error_code ec;
        if (!fs::is_regular_file(path, ec)) {
            tried += "\n  " + path + ": not found";
            continue;
        }
        // RTLD_LOCAL: OpenImageIO's symbols stay out of the renderer's scope. Never closed:
        // the objects it returns live until the process ends.
        void *h = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!h) {
            const char *err = ::dlerror();
            tried += "\n  " + path + ": " + (err ? err : "cannot be loaded");
            continue;
        }
        auto entry = reinterpret_cast<BackendEntry>(::dlsym(h, kBackendEntryName));
        if (!entry) {
            tried += "\n  " + path + ": has no " + kBackendEntryName;
            continue;
        }
        return entry();
    }
    throw std::runtime_error(std::string("cannot load the image module ") + kModuleName +
                             " (it reads images and writes formats other than EXR and PNG; "
                             "set TESSERA_IMAGE_MODULE to its path):" + tried);
}

}  // namespace

const Backend &backend() {
    static std::once_flag once;
    static const Backend *instance = nullptr;
    static std::string failure;
    std::call_once(once, [] {
        try {
            instance = load();
        } catch (const std::exception &e) {
            failure = e.what();
        }
    });
    if (!instance) throw std::runtime_error(failure);
    return *instance;
}

}  // namespace tessera::imageio
