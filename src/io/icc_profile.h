#pragma once
// What an embedded ICC profile calls itself: the colour space of a texture that carries one.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace spectex {

struct IccProfileInfo {
    std::string description;  // the profile's description ("Adobe RGB (1998)"), "" when none
    std::string problem;      // why no description could be read ("its tag table runs past its
                              // end"; "" when one was)
};

// Reads the description of the ICC profile in `bytes` (the 'desc' tag: a textDescriptionType of
// ICC v2, or the first record of a multiLocalizedUnicodeType of v4, English preferred), every
// offset and length checked against the bytes: garbage gives a problem, never a crash.
IccProfileInfo read_icc_profile(const unsigned char* bytes, size_t size);

// Where every tag of a profile lies, checked against the profile's bytes before any decoder reads
// them (a decoder trusting a table entry of 0xFFFFFFF0 bytes, or an offset that wraps, reads far
// outside the profile). `damage` is "" when every tag, and every text record inside a text tag,
// lies inside the profile; `texts` the text tags then decoded (signature, UTF-8 text; 'text',
// 'desc' and 'mluc' types, English records preferred). Bytes that are no profile at all (under 132
// bytes, no 'acsp' signature) are not damage: `is_profile` is false and nothing is read.
struct IccStructure {
    bool is_profile = false;
    std::string damage;
    std::vector<std::pair<std::string, std::string>> texts;
};
IccStructure check_icc_structure(const unsigned char* bytes, size_t size);

}  // namespace spectex
