#include "io/rebuild_record.h"

#include <libdeflate.h>

#include <cstdint>
#include <cstdio>
#include <cstring>

#include "io/provenance_keys.h"

namespace spectex {

namespace {

// 9 significant digits: every float32 reads back from them exactly, and renderers hold the weights
// and the breakpoints in single precision.
std::string numbers(const std::vector<double>& v) {
    std::string out;
    char buf[32];
    for (size_t i = 0; i < v.size(); ++i) {
        std::snprintf(buf, sizeof buf, "%.9g", v[i]);
        out += (i ? " " : "") + std::string(buf);
    }
    return out;
}

// The table as little-endian float32 bytes, whatever the host's order.
std::string float_bytes(const std::vector<float>& t) {
    std::string out(t.size() * 4, '\0');
    for (size_t i = 0; i < t.size(); ++i) {
        uint32_t u;
        std::memcpy(&u, &t[i], 4);
        for (int b = 0; b < 4; ++b) out[4 * i + b] = static_cast<char>((u >> (8 * b)) & 0xff);
    }
    return out;
}

}  // namespace

std::string base64_encode(const void* data, size_t n) {
    static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const auto* p = static_cast<const unsigned char*>(data);
    std::string out;
    out.reserve((n + 2) / 3 * 4);
    for (size_t i = 0; i < n; i += 3) {
        const uint32_t v = (uint32_t(p[i]) << 16) | (i + 1 < n ? uint32_t(p[i + 1]) << 8 : 0) |
                           (i + 2 < n ? uint32_t(p[i + 2]) : 0);
        out += digits[(v >> 18) & 63];
        out += digits[(v >> 12) & 63];
        out += i + 1 < n ? digits[(v >> 6) & 63] : '=';
        out += i + 2 < n ? digits[v & 63] : '=';
    }
    return out;
}

std::string rebuild_checksum(const std::string& rule, const std::string& axis,
                             const std::string& to_rgb, const std::string& table,
                             const std::string& wavelength_list) {
    uint32_t crc = 0;
    for (const std::string* s : {&rule, &axis, &to_rgb, &table, &wavelength_list}) {
        crc = libdeflate_crc32(crc, s->data(), s->size());
        crc = libdeflate_crc32(crc, "\n", 1);
    }
    char hex[16];
    std::snprintf(hex, sizeof hex, "%08x", static_cast<unsigned>(crc));
    return std::string("crc32:") + hex;
}

std::vector<std::pair<std::string, std::string>> rebuild_attributes(
    const RebuildTable& t, const std::vector<double>& to_rgb, const std::string& wavelength_list) {
    if (t.rule.empty() || t.table.empty() || t.table.size() > kRebuildTableLimit) return {};
    namespace key = provenance_key;
    const std::string axis = numbers(t.axis), weights = numbers(to_rgb);
    const std::string bytes = float_bytes(t.table);
    const std::string table = base64_encode(bytes.data(), bytes.size());
    std::vector<std::pair<std::string, std::string>> a = {{key::kRebuild, t.rule}};
    if (!t.axis.empty()) a.push_back({key::kRebuildAxis, axis});
    a.push_back({key::kRebuildToRgb, weights});
    a.push_back({key::kRebuildTable, table});
    a.push_back(
        {key::kRebuildChecksum, rebuild_checksum(t.rule, axis, weights, table, wavelength_list)});
    return a;
}

}  // namespace spectex
