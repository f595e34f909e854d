// Small text helpers shared by every layer (one copy of each).
#include "base/text.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

namespace spectex {

bool ends_with_nocase(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() &&
           lower_ascii(s.substr(s.size() - suffix.size())) == lower_ascii(suffix);
}

namespace {

// A C1 control or an invisible format character that reorders or hides text (bidi overrides,
// zero-width marks): one_line writes these as \uXXXX.
bool hidden_code_point(uint32_t cp) {
    return (cp >= 0x80 && cp <= 0x9f) || (cp >= 0x200b && cp <= 0x200f) ||
           (cp >= 0x202a && cp <= 0x202e) || (cp >= 0x2060 && cp <= 0x2069) || cp == 0xfeff ||
           cp == 0x061c || cp == 0x2028 || cp == 0x2029;
}

// bash's $'...' quoting: printable text as it is, everything else as an escape bash reads back.
std::string ansi_c_quote(const std::string& s) {
    std::string q = "$'";
    for (size_t i = 0; i < s.size();) {
        const unsigned char c = static_cast<unsigned char>(s[i]);
        uint32_t cp = 0;
        const size_t len = utf8_sequence_length(s, i, &cp);
        char buf[12];
        if (len > 1 && !hidden_code_point(cp)) {
            q.append(s, i, len);
        } else if (len > 1) {
            std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(cp));
            q += buf;
        } else if (c == '\'' || c == '\\') {
            q += '\\';
            q += static_cast<char>(c);
        } else if (c == '\n') {
            q += "\\n";
        } else if (c == '\t') {
            q += "\\t";
        } else if (len == 1 && c >= 0x20 && c != 0x7f) {
            q += static_cast<char>(c);
        } else {
            std::snprintf(buf, sizeof buf, "\\x%02x", c);
            q += buf;
        }
        i += len ? len : 1;
    }
    return q + "'";
}

}  // namespace

std::string quote_path(const std::string& path) {
    if (one_line(path) != path || path.find('\t') != std::string::npos) return ansi_c_quote(path);
    bool plain = !path.empty();
    for (unsigned char c : path)
        if (c <= 0x20 || c == 0x7f || c == '\'' || c == '"' || c == '\\' || c == '`' || c == '$' ||
            c == ';' || c == '&' || c == '|' || c == '<' || c == '>' || c == '(' || c == ')' ||
            c == '*' || c == '?' || c == '[' || c == '#' || c == '~' || c == '!' || c == '{' ||
            c == '}')
            plain = false;
    if (path.find(": ") != std::string::npos) plain = false;
    if (plain) return path;
    std::string q = "'";
    for (char c : path) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

bool parse_finite(const std::string& s, double* out) {
    if (s.empty() || s.find_first_not_of("0123456789.eE+-") != std::string::npos ||
        s.find_first_of("0123456789") == std::string::npos)
        return false;
    const char* begin = s.c_str();
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(begin, &end);
    if (end != begin + s.size() || errno == ERANGE || !std::isfinite(v)) return false;
    *out = v;
    return true;
}

bool parse_whole(const std::string& s, long long min, long long max, long long* out) {
    const size_t first = !s.empty() && s[0] == '-' ? 1 : 0;
    if (s.size() == first || s.size() - first > 18 ||
        s.find_first_not_of("0123456789", first) != std::string::npos)
        return false;
    long long v = 0;
    for (size_t i = first; i < s.size(); ++i) v = v * 10 + (s[i] - '0');  // 18 digits: no overflow
    if (first) v = -v;
    if (v < min || v > max) return false;
    *out = v;
    return true;
}

size_t utf8_sequence_length(const std::string& s, size_t i, uint32_t* cp) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    const size_t len = c < 0x80           ? 1
                       : (c >> 5) == 0x6  ? 2
                       : (c >> 4) == 0xe  ? 3
                       : (c >> 3) == 0x1e ? 4
                                          : 0;
    if (len == 0 || i + len > s.size()) return 0;
    uint32_t v = len == 1 ? c : c & (0x7fu >> len);
    for (size_t k = 1; k < len; ++k) {
        const unsigned char t = static_cast<unsigned char>(s[i + k]);
        if ((t >> 6) != 0x2) return 0;
        v = (v << 6) | (t & 0x3fu);
    }
    static constexpr uint32_t kMinForLength[5] = {0, 0, 0x80, 0x800,
                                                  0x10000};  // shorter is overlong
    if (v < kMinForLength[len] || v > 0x10ffff || (v >= 0xd800 && v <= 0xdfff)) return 0;
    if (cp) *cp = v;
    return len;
}

bool is_valid_utf8(const std::string& s) {
    for (size_t i = 0; i < s.size();) {
        const size_t len = utf8_sequence_length(s, i);
        if (len == 0) return false;
        i += len;
    }
    return true;
}

std::string one_line(const std::string& text) {
    std::string out;
    bool pending_break = false;
    for (size_t i = 0; i < text.size();) {
        const unsigned char c = static_cast<unsigned char>(text[i]);
        if (c == '\n' || c == '\r') {
            pending_break = !out.empty();
            ++i;
            continue;
        }
        if (pending_break) {
            while (!out.empty() && out.back() == ' ') out.pop_back();
            out += "; ";
            pending_break = false;
            while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
            continue;
        }
        // A whole, valid UTF-8 sequence passes (file names in other scripts stay readable), unless
        // it is a control (C1) or an invisible format character that reorders or hides text (bidi
        // overrides, zero-width marks): those are written as \uXXXX. Anything else is \xNN.
        uint32_t cp = 0;
        const size_t len = utf8_sequence_length(text, i, &cp);
        const bool hidden = len > 1 && hidden_code_point(cp);
        if (c == '\t') {
            out += ' ';
            ++i;
        } else if (len == 1 && c >= 0x20 && c != 0x7f) {
            out += static_cast<char>(c);
            ++i;
        } else if (hidden) {
            char buf[12];
            std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(cp));
            out += buf;
            i += len;
        } else if (len > 1) {
            out.append(text, i, len);
            i += len;
        } else {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\x%02x", c);
            out += buf;
            ++i;
        }
    }
    return out;
}

std::string number_text(double v, const char* format) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

std::string thousands(uint64_t v) {
    std::string s = std::to_string(v), o;
    for (size_t i = 0; i < s.size(); ++i) {
        if (i && (s.size() - i) % 3 == 0) o += ',';
        o += s[i];
    }
    return o;
}

}  // namespace spectex
