#include "base/bounded_read.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "base/error.h"

namespace spectex {

const char* file_kind(mode_t m) {
    if (S_ISDIR(m)) return "a directory";
    if (S_ISCHR(m)) return "a character device";
    if (S_ISBLK(m)) return "a block device";
    if (S_ISFIFO(m)) return "a FIFO (named pipe)";
    if (S_ISSOCK(m)) return "a socket";
    if (S_ISLNK(m)) return "a symbolic link";
    return "not a regular file";
}

namespace {

void check_stat(const struct stat& st, const std::string& path, uint64_t max_bytes,
                const std::string& what) {
    if (S_ISDIR(st.st_mode)) throw Error(path + ": is a directory, not " + what);
    if (!S_ISREG(st.st_mode))
        throw Error(path + ": " + what + " must be a regular file, not " + file_kind(st.st_mode));
    if (st.st_size < 0 || static_cast<uint64_t>(st.st_size) > max_bytes)
        throw Error(path + ": " + format_bytes(static_cast<uint64_t>(st.st_size)) +
                    " is over the " + format_bytes(max_bytes) + " limit for " + what);
}

}  // namespace

bool path_exists(const std::string& path, int* error) {
    struct stat st;
    if (::stat(path.c_str(), &st) == 0) return true;
    if (error) *error = errno;
    return false;
}

std::string format_bytes(uint64_t n) {
    char buf[64];
    if (n < 1024) {
        std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(n));
    } else {
        const char* units[] = {"KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
        double v = static_cast<double>(n) / 1024.0;
        int u = 0;
        while (v >= 1024.0 && u < 5) v /= 1024.0, ++u;
        if (v == static_cast<double>(static_cast<uint64_t>(v)))
            std::snprintf(buf, sizeof buf, "%.0f %s", v, units[u]);
        else
            std::snprintf(buf, sizeof buf, "%.1f %s", v, units[u]);
    }
    return buf;
}

CheckedFile::CheckedFile(const std::string& path, uint64_t max_bytes, const std::string& what)
    : path_(path), what_(what), max_(max_bytes) {
    if (path.empty()) throw Error("empty path given for " + what);
    struct stat st;
    // 1. The path: a FIFO or a device is refused here, before any open (which could block).
    if (::stat(path.c_str(), &st) != 0) throw Error(path + ": " + std::strerror(errno));
    check_stat(st, path, max_bytes, what);
    // 2. The descriptor: O_NONBLOCK so that a FIFO swapped in meanwhile does not block the open.
    fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd_ < 0) throw Error(path + ": " + std::strerror(errno));
    struct stat fst;
    try {
        if (::fstat(fd_, &fst) != 0) throw Error(path + ": " + std::strerror(errno));
        check_stat(fst, path, max_bytes, what);
        if (fst.st_dev != st.st_dev || fst.st_ino != st.st_ino)
            throw Error(path + ": the file changed while it was being opened");
    } catch (...) {
        ::close(fd_);
        fd_ = -1;
        throw;
    }
    // Regular files ignore O_NONBLOCK, but clear it all the same.
    int fl = ::fcntl(fd_, F_GETFL);
    if (fl >= 0) (void)::fcntl(fd_, F_SETFL, fl & ~O_NONBLOCK);
    size_ = static_cast<uint64_t>(fst.st_size);
}

CheckedFile::~CheckedFile() {
    if (fd_ >= 0) ::close(fd_);
}

std::string CheckedFile::read_all() {
    std::string text;
    // The size fstat gave, plus room to notice growth; files of /proc report 0 and are read in
    // blocks up to the limit.
    text.reserve(static_cast<size_t>(size_ + 1));
    char buf[65536];
    for (;;) {
        ssize_t n = ::read(fd_, buf, sizeof buf);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw Error(path_ + ": read error: " + std::strerror(errno));
        }
        if (n == 0) break;
        if (text.size() + static_cast<size_t>(n) > max_)
            throw Error(path_ + ": grew past the " + format_bytes(max_) + " limit for " + what_ +
                        " while being read");
        text.append(buf, static_cast<size_t>(n));
    }
    return text;
}

std::string read_file_bounded(const std::string& path, uint64_t max_bytes,
                              const std::string& what) {
    CheckedFile f(path, max_bytes, what);
    return f.read_all();
}

void check_regular_file(const std::string& path, uint64_t max_bytes, const std::string& what) {
    CheckedFile f(path, max_bytes, what);
}

std::string printable_excerpt(const std::string& s, size_t max) {
    std::string out;
    for (unsigned char c : s) {
        if (out.size() >= max) return out + "...";
        if (c < 0x20 || c == 0x7f) {
            char b[8];
            std::snprintf(b, sizeof b, "\\x%02x", c);
            out += b;
        } else {
            out += static_cast<char>(c);
        }
    }
    return out;
}

}  // namespace spectex
