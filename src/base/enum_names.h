#pragma once
// The words of an enum, in one table per enum: its value's word (to_string), the value of a word
// (parse), and the list for messages and --help. A table may hold other spellings after the
// canonical one (a value's word is the first row naming it). tests/unit/enum_names_test.cpp holds
// every table to round-tripping its values.
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <utility>

#include "base/text.h"

namespace spectex {

template <typename E, size_t N>
struct EnumNames {
    std::array<std::pair<E, const char*>, N> rows;

    // The first word of `v`; "" for a value with no row (a table missing a value fails its test).
    const char* name(E v) const {
        for (const auto& [value, word] : rows)
            if (value == v) return word;
        return "";
    }
    // The value of `word`, in any case (base/text.h same_word).
    std::optional<E> find(const std::string& word) const {
        for (const auto& [value, w] : rows)
            if (same_word(word, w)) return value;
        return std::nullopt;
    }
    // The canonical words (each value's first), in order: "a, b, c", or with last_sep " or ":
    // "a, b or c".
    std::string list(const std::string& sep = ", ", const std::string& last_sep = "") const {
        std::array<const char*, N> words{};
        size_t count = 0;
        for (size_t i = 0; i < N; ++i)
            if (name(rows[i].first) == rows[i].second) words[count++] = rows[i].second;
        std::string out;
        for (size_t k = 0; k < count; ++k) {
            if (k) out += (k + 1 == count && !last_sep.empty()) ? last_sep : sep;
            out += words[k];
        }
        return out;
    }
};

}  // namespace spectex
