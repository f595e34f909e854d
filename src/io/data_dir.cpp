#include "io/data_dir.h"

#include <sys/stat.h>
#include <unistd.h>

#include <climits>
#include <cstdlib>
#include <string>

#include "base/error.h"
#include "io/paths.h"

namespace spectex {

namespace {

bool has_config(const std::string& dir) {
    struct stat st;
    return ::stat((dir + "/spectex.ocio").c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

}  // namespace

std::string find_data_dir() {
    if (const char* env = std::getenv("SPECTEX_DATA_DIR"); env && *env) {
        if (!has_config(env))
            throw Error(std::string(env) + ": SPECTEX_DATA_DIR has no spectex.ocio");
        return env;
    }
    std::string exe = executable_dir();
    if (!exe.empty()) {
        std::string installed = exe + "/../share/spectex/config";
        if (has_config(installed)) return installed;
    }
    if (has_config(SPECTEX_SOURCE_DATADIR)) return SPECTEX_SOURCE_DATADIR;
    if (has_config(SPECTEX_INSTALL_DATADIR)) return SPECTEX_INSTALL_DATADIR;
    throw Error("cannot find spectex's data folder (spectex.ocio); set SPECTEX_DATA_DIR");
}

std::string cache_folder() {
    if (const char* env = std::getenv("SPECTEX_CACHE_DIR")) return env;
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && xdg[0] == '/')
        return std::string(xdg) + "/spectex";
    // A home that is not there (a service account's /nonexistent) is not made: no cache then.
    struct stat st;
    if (const char* home = std::getenv("HOME");
        home && home[0] == '/' && ::stat(home, &st) == 0 && S_ISDIR(st.st_mode))
        return std::string(home) + "/.cache/spectex";
    return "";
}

std::string executable_identity() {
    struct stat st;
    if (::stat("/proc/self/exe", &st) != 0) return "unknown";
    return std::to_string(st.st_size) + " " + std::to_string(st.st_mtim.tv_sec) + "." +
           std::to_string(st.st_mtim.tv_nsec) + " " + std::to_string(st.st_ino);
}

}  // namespace spectex
