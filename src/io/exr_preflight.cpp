#include "io/exr_preflight.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "base/bounded_read.h"
#include "base/error.h"
#include "io/exr_compression.h"

namespace spectex {

namespace {

constexpr uint64_t kMaxChunks = 1ull << 24;
constexpr uint64_t kMaxPixels = 1ull << 31;
constexpr size_t kMaxHeaderBytes = 64u << 20;

int32_t le32(const unsigned char* p) {
    uint32_t v = static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
                 static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
    int32_t s;
    std::memcpy(&s, &v, 4);
    return s;
}

// The size of OpenEXR's fixed-size attribute types (the file format's own table), -1 for types
// whose size varies (string, chlist, preview, ...) or that OpenEXR does not know. OpenEXR reads a
// fixed-size value whatever the size field says, so a wrong size would shift every later byte of
// the header and surface as a misleading error far from its cause.
int fixed_attribute_size(const std::string& type) {
    static const std::pair<const char*, int> kSizes[] = {{"int", 4},
                                                         {"float", 4},
                                                         {"double", 8},
                                                         {"box2i", 16},
                                                         {"box2f", 16},
                                                         {"v2i", 8},
                                                         {"v2f", 8},
                                                         {"v2d", 16},
                                                         {"v3i", 12},
                                                         {"v3f", 12},
                                                         {"v3d", 24},
                                                         {"m33f", 36},
                                                         {"m33d", 72},
                                                         {"m44f", 64},
                                                         {"m44d", 128},
                                                         {"compression", 1},
                                                         {"lineOrder", 1},
                                                         {"envmap", 1},
                                                         {"deepImageState", 1},
                                                         {"tiledesc", 9},
                                                         {"rational", 8},
                                                         {"timecode", 8},
                                                         {"keycode", 28},
                                                         {"chromaticities", 32}};
    for (const auto& [name, size] : kSizes)
        if (type == name) return size;
    return -1;
}

// OpenEXR 3.1 allocates what a variable-size attribute's inner fields claim before it reads them:
// a string vector's element of length 2^31 - 1 or a preview of 65535 x 65535 pixels inside a few
// bytes of attribute costs gigabytes (the fuzzer found the first). Such a value must lie within
// the attribute's own size.
template <typename Bad>
void check_variable_attribute(const std::string& name, const std::string& type,
                              const unsigned char* v, size_t size, const Bad& bad) {
    if (type == "stringvector") {
        for (size_t at = 0; at < size;) {
            if (size - at < 4) bad("attribute '" + name + "' ends inside an element's length");
            const int32_t len = le32(v + at);
            at += 4;
            if (len < 0 || static_cast<size_t>(len) > size - at)
                bad("attribute '" + name + "' has an element of " + std::to_string(len) +
                    " bytes in " + std::to_string(size - at) + " remaining");
            at += static_cast<size_t>(len);
        }
    } else if (type == "chlist") {
        // OpenEXR reads a channel list by its content, not by the size field: each channel a name
        // (a NUL-terminated string) and 16 bytes, then an empty name. A list that ends before or
        // after its size would leave OpenEXR reading the rest of the header from elsewhere than
        // this walk, where a size field can claim gigabytes (found by fuzzing).
        size_t at = 0;
        for (;;) {
            size_t end = at;
            while (end < size && v[end] != 0 && end - at < 256) ++end;
            if (end >= size || v[end] != 0)
                bad("attribute '" + name + "' has a channel name that does not end in it");
            if (end == at) {
                if (end + 1 != size)
                    bad("attribute '" + name + "' ends its channel list " +
                        std::to_string(size - end - 1) + " bytes before its size");
                break;
            }
            at = end + 1;
            if (size - at < 16) bad("attribute '" + name + "' ends inside a channel");
            at += 16;
        }
    } else if (type == "preview") {
        if (size < 8) bad("attribute '" + name + "' is too short for a preview");
        const uint64_t w = static_cast<uint32_t>(le32(v)), h = static_cast<uint32_t>(le32(v + 4));
        if (w > size || h > size || 8 + 4 * w * h != size)
            bad("attribute '" + name + "' claims a " + std::to_string(w) + "x" + std::to_string(h) +
                " preview in " + std::to_string(size) + " bytes");
    }
}

}  // namespace

void exr_preflight(const std::string& path, std::map<std::string, std::string>* part0_strings) {
    // A regular file (never a FIFO, which would block, or a device), checked before reading.
    CheckedFile file(path, file_limits::kImage, "an OpenEXR file");
    // The header is read as far as it goes, not 64 MiB up front: a zeroed 64 MiB buffer cost 16k
    // page faults and ~20 ms a file, which was most of a skip and of `info`.
    std::vector<unsigned char> buf;
    size_t n = 0;
    bool at_end = false;
    // Makes at least `want` bytes available when the file has them; returns whether it does.
    auto have = [&](size_t want) {
        while (n < want && !at_end) {
            size_t grow = std::max<size_t>(buf.empty() ? 65536 : buf.size() * 2, want);
            grow = std::min(grow, kMaxHeaderBytes);
            if (grow <= n) break;
            buf.resize(grow);
            while (n < buf.size()) {
                const ssize_t got =
                    ::pread(file.fd(), buf.data() + n, buf.size() - n, static_cast<off_t>(n));
                if (got < 0 && errno == EINTR) continue;
                if (got < 0) throw Error(path + ": read error: " + std::strerror(errno));
                if (got == 0) {
                    at_end = true;
                    break;
                }
                n += static_cast<size_t>(got);
            }
            if (buf.size() >= kMaxHeaderBytes) at_end = at_end || n >= kMaxHeaderBytes;
        }
        return n >= want;
    };
    have(8);
    auto bad = [&](const std::string& why) {
        throw Error(path + ": corrupt OpenEXR header: " + why);
    };
    if (n < 8 || le32(buf.data()) != 20000630) throw Error(path + ": not an OpenEXR file");
    const uint32_t version = static_cast<uint32_t>(le32(buf.data() + 4));
    const bool multipart = version & 0x1000u, single_tiled = version & 0x200u;
    size_t pos = 8;
    auto read_str = [&](std::string* out) {
        have(pos + 258);
        size_t end = pos;
        while (end < n && buf[end] != 0 && end - pos < 256) ++end;
        if (end >= n || buf[end] != 0) bad("unterminated name");
        out->assign(reinterpret_cast<const char*>(buf.data() + pos), end - pos);
        pos = end + 1;
    };
    for (int part = 0;; ++part) {
        if (part > 0 && !multipart) break;
        if (!have(pos + 1)) bad("truncated");
        if (multipart && part > 0 && buf[pos] == 0) break;  // the empty header ends the list
        bool have_dw = false, tiled = single_tiled;
        int32_t dw[4] = {0, 0, -1, -1};
        uint32_t tx = 0, ty = 0;
        int compression = 0;
        for (;;) {
            std::string name, type;
            read_str(&name);
            if (name.empty()) break;
            read_str(&type);
            if (!have(pos + 4)) bad("truncated");
            const int32_t size = le32(buf.data() + pos);
            pos += 4;
            if (size < 0) bad("attribute '" + name + "' has a negative size");
            if (pos + static_cast<uint64_t>(size) > kMaxHeaderBytes)
                bad("attribute '" + name + "' is " + std::to_string(size) + " bytes, past the " +
                    std::to_string(kMaxHeaderBytes >> 20) + " MiB a header may hold here");
            if ((size > 0 && !have(pos + static_cast<size_t>(size))) ||
                static_cast<size_t>(size) > n - pos)
                bad("attribute '" + name + "' is larger than the file");
            if (const int want = fixed_attribute_size(type); want >= 0 && size != want)
                bad("attribute '" + name + "' of type " + type + " is " + std::to_string(size) +
                    " bytes, not " + std::to_string(want));
            const unsigned char* v = buf.data() + pos;
            check_variable_attribute(name, type, v, static_cast<size_t>(size), bad);
            if (name == "dataWindow" && type == "box2i" && size == 16) {
                for (int i = 0; i < 4; ++i) dw[i] = le32(v + 4 * i);
                have_dw = true;
            } else if (name == "tiles" && type == "tiledesc" && size == 9) {
                tx = static_cast<uint32_t>(le32(v));
                ty = static_cast<uint32_t>(le32(v + 4));
                tiled = true;
            } else if (name == "compression" && size == 1) {
                compression = v[0];
            } else if (name == "type" && type == "string") {
                std::string t(reinterpret_cast<const char*>(v), static_cast<size_t>(size));
                if (t == "tiledimage") tiled = true;
            }
            if (part0_strings && part == 0 && type == "string")
                (*part0_strings)[name] =
                    std::string(reinterpret_cast<const char*>(v), static_cast<size_t>(size));
            pos += static_cast<size_t>(size);
        }
        if (!have_dw) bad("no dataWindow");
        const int64_t w = static_cast<int64_t>(dw[2]) - dw[0] + 1,
                      h = static_cast<int64_t>(dw[3]) - dw[1] + 1;
        if (w <= 0 || h <= 0) bad("empty or inverted dataWindow");
        if (static_cast<uint64_t>(w) * static_cast<uint64_t>(h) > kMaxPixels)
            throw Error(path + ": OpenEXR header claims " + std::to_string(w) + "x" +
                        std::to_string(h) + " pixels; refusing more than 2^31");
        uint64_t chunks;
        if (tiled) {
            if (tx == 0 || ty == 0) bad("tiled without a tile size");
            chunks = ((static_cast<uint64_t>(w) + tx - 1) / tx) *
                     ((static_cast<uint64_t>(h) + ty - 1) / ty);
            chunks = chunks * 4 / 3 +
                     64;  // MIP levels add at most a third (RIP maps are not capped here)
        } else {
            const ExrCompression* known = ExrCompression::find(compression);
            chunks = static_cast<uint64_t>(h) /
                         static_cast<uint64_t>(known ? known->lines_per_chunk : 1) +
                     1;
        }
        if (chunks > kMaxChunks)
            throw Error(path + ": OpenEXR header describes " + std::to_string(chunks) +
                        " chunks; refusing more than 2^24");
    }
}

}  // namespace spectex
