#pragma once
// What an embedded ICC profile calls itself: the colour space of a texture that carries one.
#include <cstddef>
#include <string>

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

}  // namespace spectex
