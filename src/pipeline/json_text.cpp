#include "pipeline/json_text.h"

#include <cmath>
#include <cstdio>

#include "base/error.h"
#include "base/text.h"

namespace spectex {

std::string utf8_with_replacements(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    for (size_t i = 0; i < s.size();) {
        const size_t len = utf8_sequence_length(s, i);
        if (len == 0) {
            out += "\xef\xbf\xbd";  // U+FFFD REPLACEMENT CHARACTER
            ++i;
        } else {
            out.append(s, i, len);
            i += len;
        }
    }
    return out;
}

std::string bytes_hex(const std::string& s) {
    static const char kDigits[] = "0123456789abcdef";
    std::string out;
    out.reserve(2 * s.size());
    for (const char ch : s) {
        const unsigned char c = static_cast<unsigned char>(ch);
        out += kDigits[c >> 4];
        out += kDigits[c & 0xf];
    }
    return out;
}

void put_text(Json& object, const std::string& key, const std::string& text) {
    if (is_valid_utf8(text)) {
        object[key] = text;
        return;
    }
    object[key] = utf8_with_replacements(text);
    object[key + "_bytes_hex"] = bytes_hex(text);
}

void put_text_or_null(Json& object, const std::string& key, const std::string& text) {
    if (text.empty())
        object[key] = nullptr;
    else
        put_text(object, key, text);
}

void put_texts(Json& object, const std::string& key, const std::vector<std::string>& texts) {
    Json list = Json::array(), hex = Json::array();
    bool any_invalid = false;
    for (const auto& t : texts) {
        const bool valid = is_valid_utf8(t);
        any_invalid = any_invalid || !valid;
        list.push_back(valid ? t : utf8_with_replacements(t));
        hex.push_back(valid ? Json(nullptr) : Json(bytes_hex(t)));
    }
    object[key] = std::move(list);
    if (any_invalid) object[key + "_bytes_hex"] = std::move(hex);
}

Json json_number_text(const std::string& text) {
    Json n = Json::parse(text, nullptr, false);
    if (!n.is_number()) throw Error("internal error: '" + text + "' is not a JSON number");
    return n;
}

Json json_number(double v, const char* format) {
    if (!std::isfinite(v)) return nullptr;
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return json_number_text(buf);
}

std::string json_line(const Json& document) {
    return document.dump(-1, ' ', false, Json::error_handler_t::replace) + "\n";
}

}  // namespace spectex
