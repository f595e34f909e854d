#include "io/icc_profile.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>

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

namespace {

std::string signature_text(const unsigned char* p) {
    std::string s;
    for (int i = 0; i < 4; ++i) {
        if (p[i] >= 0x20 && p[i] < 0x7f) {
            s += static_cast<char>(p[i]);
        } else {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", p[i]);
            s += hex;
        }
    }
    return s;
}

}  // namespace

IccStructure check_icc_structure(const unsigned char* b, size_t n) {
    IccStructure out;
    if (n < 132 || b[36] != 'a' || b[37] != 'c' || b[38] != 's' || b[39] != 'p') return out;
    out.is_profile = true;
    // The profile is what both its header and its bytes hold: a decoder may trust either.
    const uint64_t size = std::min<uint64_t>(be32(b), n);
    const uint64_t tags = be32(b + 128);
    if (size < 132 || tags > (size - 132) / 12) {
        out.damage = "its tag table (" + std::to_string(tags) + " tags) runs past its end (" +
                     std::to_string(size) + " bytes)";
        return out;
    }
    for (uint64_t t = 0; t < tags; ++t) {
        const unsigned char* e = b + 132 + 12 * t;
        const std::string sig = signature_text(e);
        const uint64_t off = be32(e + 4), len = be32(e + 8);
        if (off > size || len > size - off) {
            out.damage = "tag '" + sig + "' (" + std::to_string(len) + " bytes at offset " +
                         std::to_string(off) + ") lies outside the profile (" +
                         std::to_string(size) + " bytes)";
            return out;
        }
        if (len < 4) {
            out.damage =
                "tag '" + sig + "' has " + std::to_string(len) + " bytes, too few for its type";
            return out;
        }
        const unsigned char* d = b + off;
        const uint32_t type = be32(d);
        auto too_short = [&](uint64_t need) {
            out.damage = "tag '" + sig + "' of type '" + signature_text(d) + "' has " +
                         std::to_string(len) + " bytes, fewer than its header's " +
                         std::to_string(need);
        };
        if (type == 0x74657874) {  // 'text': 4 reserved bytes, then the text
            if (len < 8) return too_short(8), out;
            out.texts.emplace_back(sig, tidy(std::string(reinterpret_cast<const char*>(d + 8),
                                                         static_cast<size_t>(len - 8))));
        } else if (type == 0x64657363) {  // 'desc': the ASCII count, then the text
            if (len < 12) return too_short(12), out;
            const uint64_t count = be32(d + 8);
            if (count > len - 12) {
                out.damage = "tag '" + sig + "': its text of " + std::to_string(count) +
                             " bytes runs past its " + std::to_string(len) + " bytes";
                return out;
            }
            out.texts.emplace_back(sig, tidy(std::string(reinterpret_cast<const char*>(d + 12),
                                                         static_cast<size_t>(count))));
        } else if (type == 0x6d6c7563) {  // 'mluc': records of language, country, length, offset
            if (len < 16) return too_short(16), out;
            const uint64_t records = be32(d + 8), record_size = be32(d + 12);
            if (record_size < 12 || records > (len - 16) / record_size) {
                out.damage = "tag '" + sig + "': its " + std::to_string(records) +
                             " text records of " + std::to_string(record_size) +
                             " bytes do not fit in its " + std::to_string(len) + " bytes";
                return out;
            }
            uint64_t pick = records;  // the first English record, else the first
            bool english = false;
            for (uint64_t r = 0; r < records; ++r) {
                const unsigned char* rec = d + 16 + r * record_size;
                const uint64_t slen = be32(rec + 4), soff = be32(rec + 8);
                if (soff > len || slen > len - soff) {
                    out.damage = "tag '" + sig + "': text record " + std::to_string(r) + " (" +
                                 std::to_string(slen) + " bytes at offset " + std::to_string(soff) +
                                 ") lies outside its " + std::to_string(len) + " bytes";
                    return out;
                }
                if (pick == records) pick = r;
                if (!english && rec[0] == 'e' && rec[1] == 'n') pick = r, english = true;
            }
            if (pick < records) {
                const unsigned char* rec = d + 16 + pick * record_size;
                out.texts.emplace_back(sig,
                                       tidy(utf16be_to_utf8(d + be32(rec + 8), be32(rec + 4) / 2)));
            }
        }
    }
    return out;
}

}  // namespace spectex
