#pragma once
// PNG files made byte by byte, for what OpenImageIO's writer (libpng) will not write: palette
// images, headers that lie about their size, hostile iCCP profiles. Stored (uncompressed) deflate
// blocks: no zlib needed. Shared by the CLI tests and the fuzz harnesses.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>

namespace png_bytes {

inline std::string be32(uint32_t v) {
    return {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
            static_cast<char>(v)};
}

// PNG's (and zlib's) CRC-32 of `s`.
inline uint32_t crc32(const std::string& s) {
    uint32_t c = 0xffffffffu;
    for (unsigned char ch : s) {
        c ^= ch;
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1)));
    }
    return ~c;
}

// A zlib stream of `raw` in stored deflate blocks, with its Adler-32.
inline std::string zlib_stored(const std::string& raw) {
    std::string z("\x78\x01", 2);
    size_t at = 0;
    do {
        const size_t n = std::min<size_t>(65535, raw.size() - at);
        z += static_cast<char>(at + n == raw.size() ? 1 : 0);
        z += static_cast<char>(n & 0xff);
        z += static_cast<char>(n >> 8);
        z += static_cast<char>(~n & 0xff);
        z += static_cast<char>((~n >> 8) & 0xff);
        z += raw.substr(at, n);
        at += n;
    } while (at < raw.size());
    uint32_t a = 1, b = 0;
    for (unsigned char ch : raw) a = (a + ch) % 65521, b = (b + a) % 65521;
    return z + be32((b << 16) | a);
}

// One chunk: length, type, data, CRC of type and data.
inline std::string png_chunk(const std::string& type, const std::string& data) {
    return be32(static_cast<uint32_t>(data.size())) + type + data + be32(crc32(type + data));
}

}  // namespace png_bytes
