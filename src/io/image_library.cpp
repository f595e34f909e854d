#include "io/image_library.h"

#include <dlfcn.h>
#include <unistd.h>

#include <climits>
#include <cstdlib>
#include <mutex>

#include "base/error.h"
#include "io/image_source.h"
#include "io/paths.h"

namespace spectex {

namespace {

std::mutex g_mutex;
ImageLibrary* g_library = nullptr;
int g_threads = -1;  // not set

ImageLibrary* load_module() {
    std::vector<std::string> candidates;
    if (const char* env = std::getenv("SPECTEX_MODULE_DIR"); env && *env) {
        candidates.push_back(std::string(env) + "/spectex-oiio.so");
    } else {
        const std::string exe = executable_dir();
        candidates.push_back(exe + "/spectex-oiio.so");
        candidates.push_back(exe + "/" SPECTEX_MODULE_RELDIR "/spectex-oiio.so");
        candidates.push_back(SPECTEX_MODULE_INSTALLDIR "/spectex-oiio.so");
    }
    std::string why;
    for (const auto& path : candidates) {
        if (::access(path.c_str(), F_OK) != 0) continue;
        void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!handle) {
            const char* e = ::dlerror();
            why = path + ": " + (e ? e : "cannot load");
            continue;
        }
        using Entry = ImageLibrary* (*)();
        auto entry = reinterpret_cast<Entry>(::dlsym(handle, SPECTEX_IMAGE_LIBRARY_ENTRY));
        if (!entry) {
            why = path + ": no " SPECTEX_IMAGE_LIBRARY_ENTRY;
            continue;
        }
        return entry();  // the handle stays open for the life of the process
    }
    if (why.empty()) {
        why = "not found in";
        for (const auto& c : candidates) why += " " + c;
    }
    throw Error("cannot load spectex's image module (OpenImageIO): " + why +
                " (SPECTEX_MODULE_DIR names its folder)");
}

}  // namespace

ImageLibrary& image_library() {
    std::lock_guard<std::mutex> lock(g_mutex);
    if (!g_library) {
        g_library = load_module();
        if (g_threads >= 0) g_library->set_threads(g_threads);
    }
    return *g_library;
}

void set_image_threads(int threads) {
    std::lock_guard<std::mutex> lock(g_mutex);
    g_threads = threads;
    if (g_library) g_library->set_threads(threads);
}

std::unique_ptr<ImageSource> ImageSource::open(const std::string& path, uint64_t max_pixels) {
    return image_library().open_source(path, max_pixels);
}

void register_image_library(ImageLibrary* library) {
    std::lock_guard<std::mutex> lock(g_mutex);
    g_library = library;
    if (g_library && g_threads >= 0) g_library->set_threads(g_threads);
}

}  // namespace spectex
