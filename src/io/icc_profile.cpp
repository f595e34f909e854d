#include "io/icc_profile.h"

#include <algorithm>
#include <cstdint>

namespace spectex {

namespace {

uint32_t be32(const unsigned char* p) {
    return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}
uint16_t be16(const unsigned char* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

// UTF-16BE to UTF-8 (a lone surrogate becomes U+FFFD).
std::string utf16be_to_utf8(const unsigned char* p, size_t units) {
    std::string out;
    auto put = [&](uint32_t c) {
        if (c < 0x80) {
            out += static_cast<char>(c);
        } else if (c < 0x800) {
            out += static_cast<char>(0xc0 | (c >> 6));
            out += static_cast<char>(0x80 | (c & 0x3f));
        } else if (c < 0x10000) {
            out += static_cast<char>(0xe0 | (c >> 12));
            out += static_cast<char>(0x80 | ((c >> 6) & 0x3f));
            out += static_cast<char>(0x80 | (c & 0x3f));
        } else {
            out += static_cast<char>(0xf0 | (c >> 18));
            out += static_cast<char>(0x80 | ((c >> 12) & 0x3f));
            out += static_cast<char>(0x80 | ((c >> 6) & 0x3f));
            out += static_cast<char>(0x80 | (c & 0x3f));
        }
    };
    for (size_t i = 0; i < units; ++i) {
        uint32_t c = be16(p + 2 * i);
        if (c >= 0xd800 && c < 0xdc00 && i + 1 < units) {
            const uint32_t lo = be16(p + 2 * (i + 1));
            if (lo >= 0xdc00 && lo < 0xe000) {
                put(0x10000 + ((c - 0xd800) << 10) + (lo - 0xdc00));
                ++i;
                continue;
            }
        }
        put(c >= 0xd800 && c < 0xe000 ? 0xfffd : c);
    }
    return out;
}

// Trailing NULs and spaces off; at most 256 bytes kept (a description is a name, not a text).
std::string tidy(std::string s) {
    const size_t nul = s.find('\0');
    if (nul != std::string::npos) s.resize(nul);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\n' || s.back() == '\r')) s.pop_back();
    if (s.size() > 256) s.resize(256);
    return s;
}

}  // namespace

IccProfileInfo read_icc_profile(const unsigned char* b, size_t n) {
    IccProfileInfo info;
    if (n < 132) {
        info.problem = std::to_string(n) + " bytes, too short for a profile";
        return info;
    }
    if (b[36] != 'a' || b[37] != 'c' || b[38] != 's' || b[39] != 'p') {
        info.problem = "no 'acsp' signature: not a profile";
        return info;
    }
    const uint64_t size = std::min<uint64_t>(be32(b), n);  // the header's size, within the bytes
    const uint64_t tags = be32(b + 128);
    if (size < 132 || tags > (size - 132) / 12) {
        info.problem = "its tag table runs past its end";
        return info;
    }
    for (uint64_t t = 0; t < tags; ++t) {
        const unsigned char* e = b + 132 + 12 * t;
        if (be32(e) != 0x64657363)  // 'desc'
            continue;
        const uint64_t off = be32(e + 4), len = be32(e + 8);
        if (off > size || len > size - off || len < 12) {
            info.problem = "its description tag lies outside it";
            return info;
        }
        const unsigned char* d = b + off;
        const uint32_t type = be32(d);
        if (type == 0x64657363) {  // 'desc': textDescriptionType, ASCII count then the text
            const uint64_t count = be32(d + 8);
            if (count > len - 12) {
                info.problem = "its description runs past its tag";
                return info;
            }
            info.description = tidy(std::string(reinterpret_cast<const char*>(d + 12), count));
        } else if (type == 0x6d6c7563) {  // 'mluc': records of language, country, length, offset
            if (len < 16) {
                info.problem = "its description tag is cut short";
                return info;
            }
            const uint64_t records = be32(d + 8), record_size = be32(d + 12);
            if (record_size < 12 || records == 0 || records > (len - 16) / record_size) {
                info.problem = "its description records run past their tag";
                return info;
            }
            uint64_t pick = 0;
            for (uint64_t r = 0; r < records; ++r)
                if (d[16 + r * record_size] == 'e' && d[17 + r * record_size] == 'n') {
                    pick = r;
                    break;
                }
            const unsigned char* rec = d + 16 + pick * record_size;
            const uint64_t slen = be32(rec + 4), soff = be32(rec + 8);
            if (soff > len || slen > len - soff) {
                info.problem = "its description text lies outside its tag";
                return info;
            }
            info.description = tidy(utf16be_to_utf8(d + soff, slen / 2));
        } else {
            info.problem = "its description is of a type spectex does not read";
            return info;
        }
        if (info.description.empty()) info.problem = "its description is empty";
        return info;
    }
    info.problem = "it has no description";
    return info;
}

}  // namespace spectex
