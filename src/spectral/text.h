#pragma once
// Small text helpers shared by every layer (one copy of each).
#include <string>

namespace spectex {

// ASCII lower case (names of colour spaces, illuminants, options: never locale-dependent).
inline std::string lower_ascii(std::string s) {
    for (char& c : s)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    return s;
}

}  // namespace spectex
