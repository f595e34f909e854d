#include "io/source_identity.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

#include "base/bounded_read.h"
#include "base/error.h"

namespace spectex {

SourceIdentity SourceIdentity::of(const struct stat& st) {
    SourceIdentity id;
    id.size = static_cast<uint64_t>(st.st_size);
    id.mtime_sec = static_cast<int64_t>(st.st_mtim.tv_sec);
    id.mtime_nsec = st.st_mtim.tv_nsec;
    return id;
}

std::string SourceIdentity::size_text() const { return std::to_string(size); }

std::string SourceIdentity::mtime_text() const {
    char buf[48];
    std::snprintf(buf, sizeof buf, "%lld.%09ld", static_cast<long long>(mtime_sec), mtime_nsec);
    return buf;
}

std::string source_hash_placeholder() { return Fnv1a64::text(0); }

void hash_file_range(int fd, uint64_t from, uint64_t end, Fnv1a64& h, const std::string& path) {
    std::vector<unsigned char> buf(1u << 20);
    while (from < end) {
        const size_t want = static_cast<size_t>(std::min<uint64_t>(buf.size(), end - from));
        const ssize_t got = ::pread(fd, buf.data(), want, static_cast<off_t>(from));
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) throw Error(path + ": read error: " + std::strerror(errno));
        if (got == 0) throw Error(path + ": the file became shorter while it was read");
        h.add(buf.data(), static_cast<size_t>(got));
        from += static_cast<uint64_t>(got);
    }
}

std::string hash_file(const std::string& path) {
    CheckedFile f(path, file_limits::kImage, "an input image");
    Fnv1a64 h;
    hash_file_range(f.fd(), 0, f.size(), h, path);
    return h.text();
}

void patch_string_attribute(int fd, const std::string& name, const std::string& placeholder,
                            const std::string& value, const std::string& path) {
    if (value.size() != placeholder.size())
        throw Error(path + ": internal error: the value of " + name + " changed length");
    // In the header: <name>\0string\0<int32 length><value>. The header is at the start of the file;
    // it is read a megabyte at a time until the attribute shows (a long command line can make a
    // header of hundreds of kilobytes).
    std::string key = name;
    key.push_back('\0');
    key += "string";
    key.push_back('\0');
    const uint32_t len = static_cast<uint32_t>(placeholder.size());
    for (int i = 0; i < 4; ++i) key.push_back(static_cast<char>((len >> (8 * i)) & 0xffu));
    key += placeholder;
    std::string head;
    constexpr size_t kStep = 1u << 20, kMaxHeader = 64u << 20;
    while (head.size() < kMaxHeader) {
        const size_t old = head.size();
        head.resize(old + kStep);
        ssize_t got;
        do got = ::pread(fd, &head[old], kStep, static_cast<off_t>(old));
        while (got < 0 && errno == EINTR);
        if (got < 0) throw Error(path + ": read error: " + std::strerror(errno));
        head.resize(old + static_cast<size_t>(got));
        const size_t at = head.find(key, old >= key.size() ? old - key.size() : 0);
        if (at != std::string::npos) {
            const off_t where = static_cast<off_t>(at + key.size() - placeholder.size());
            ssize_t put;
            do put = ::pwrite(fd, value.data(), value.size(), where);
            while (put < 0 && errno == EINTR);
            if (put != static_cast<ssize_t>(value.size()))
                throw Error(path + ": cannot write: " + std::strerror(put < 0 ? errno : EIO));
            return;
        }
        if (got == 0) break;
    }
    throw Error(path + ": internal error: attribute " + name + " not found in the header written");
}

}  // namespace spectex
