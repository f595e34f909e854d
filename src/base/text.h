#pragma once
// Small text helpers shared by every layer (one copy of each).
#include <cstddef>
#include <cstdint>
#include <string>

namespace spectex {

// ASCII lower case (names of colour spaces, illuminants, options: never locale-dependent).
inline std::string lower_ascii(std::string s) {
    for (char& c : s)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    return s;
}

// Whether two words are the same, ASCII letters compared without case: the one rule for the words
// every option takes (--method LATTICE is --method lattice, as light and wrap names always were).
inline bool same_word(const std::string& a, const std::string& b) {
    return lower_ascii(a) == lower_ascii(b);
}

// Whether `s` ends with `suffix`, ASCII letters compared without case (".EXR" is ".exr").
bool ends_with_nocase(const std::string& s, const std::string& suffix);

// A whole token as a finite double, read in the C locale: decimal digits, a point, a sign and an
// exponent only: no leading or trailing characters (space included), no overflow, no inf or nan,
// no hexadecimal ("0x10" is not 16). False leaves *out untouched.
bool parse_finite(const std::string& s, double* out);

// A whole token as a whole number from min to max: decimal digits, with a leading '-' only (no
// '+', no space, no hexadecimal or octal reading, no wrap-around: "4294967297" is not 1). False
// leaves *out untouched.
bool parse_whole(const std::string& s, long long min, long long max, long long* out);

// The length (1 to 4) of the well-formed UTF-8 sequence starting at s[i], or 0 when none starts
// there: a stray continuation byte, a truncated sequence, an overlong form, a UTF-16 surrogate or a
// code point above U+10FFFF (file names and header text are bytes, not necessarily UTF-8). *cp,
// when given, receives the code point of a well-formed sequence.
size_t utf8_sequence_length(const std::string& s, size_t i, uint32_t* cp = nullptr);
bool is_valid_utf8(const std::string& s);

// A path as messages name it: as it is when a shell would read it back as one word and the
// "<file>: <cause>" convention stays unambiguous, else in single quotes ('my file.png',
// 'a: b.png', an empty name as ''), a quote inside written '\''. A name holding bytes that one_line
// would escape (control bytes, bytes that are not UTF-8, invisible format characters) is written
// in bash's $'...' form instead ($'caf\xe9.png', $'a\nb'), so that the message can be pasted back.
std::string quote_path(const std::string& path);

// A message as one printable line: line breaks become "; ", control bytes and bytes that are not
// valid UTF-8 (a binary file's name or contents quoted by a library) become \xNN, and characters
// that would act on a terminal or hide text (C1 controls, bidi overrides, zero-width marks) \uXXXX.
std::string one_line(const std::string& text);

// A number as printf's `format` writes it ("%.3g" of 0.1234 is "0.123"), for messages and reports.
std::string number_text(double v, const char* format = "%.6g");

// v with its thousands grouped by commas: "16,777,216".
std::string thousands(uint64_t v);

}  // namespace spectex
