#include "io/paths.h"

#include <filesystem>

namespace spectex {

std::string folder_of(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    if (slash == std::string::npos) return ".";
    if (slash == 0) return "/";
    return path.substr(0, slash);
}

std::string file_name_of(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string executable_dir() {
    std::error_code ec;
    const std::string p = std::filesystem::read_symlink("/proc/self/exe", ec).native();
    if (ec || p.empty()) return "";
    return p.substr(0, p.find_last_of('/'));
}

}  // namespace spectex
