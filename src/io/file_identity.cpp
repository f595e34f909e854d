#include "io/file_identity.h"

#include <sys/stat.h>

#include <filesystem>
#include <system_error>

namespace spectex {

std::optional<FileId> file_id(const std::string& path) {
    struct stat st;
    if (path.empty() || ::stat(path.c_str(), &st) != 0) return std::nullopt;
    return FileId{st.st_dev, st.st_ino};
}

OutputTarget output_target(const std::string& path) {
    namespace fs = std::filesystem;
    OutputTarget t;
    std::error_code ec;
    fs::path p = fs::weakly_canonical(fs::absolute(fs::path(path), ec), ec);
    t.key = ec ? fs::absolute(fs::path(path)).lexically_normal().string() : p.string();
    t.existing = file_id(path);
    return t;
}

void ReadFiles::add(const std::string& path, const std::string& role) {
    struct stat st;
    // "-" is standard input: a file redirected into it is read like any other.
    const std::string p = path == "-" ? std::string("/dev/stdin") : path;
    if (p.empty() || ::stat(p.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return;
    files_.push_back(
        {FileId{st.st_dev, st.st_ino}, path == "-" ? std::string("standard input") : path, role});
}

void ReadFiles::add_data_dir(const std::string& data_dir) {
    namespace fs = std::filesystem;
    std::error_code ec;
    add(data_dir + "/spectex.ocio", "the shipped OCIO config");
    for (fs::directory_iterator it(data_dir + "/spectral", ec), end; !ec && it != end;
         it.increment(ec))
        add(it->path().string(), "a table shipped with spectex");
}

std::string ReadFiles::clash(const std::string& output, const std::string& output_role) const {
    auto id = file_id(output);
    if (!id) return "";
    for (const auto& f : files_)
        if (f.id == *id)
            return output + ": " + output_role + " is the same file as " + f.path + " (" + f.role +
                   "), which this command reads; refusing to overwrite it";
    return "";
}

}  // namespace spectex
