#pragma once
// The JSON documents spectex writes (bake --json, info/verify/sample/plan --json) are built as
// nlohmann::ordered_json: keys stay in the order they are set, which the documentation lists and
// scripts and tests may rely on. Strings and numbers go in through the helpers below.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace spectex {

using Json = nlohmann::ordered_json;

// s as valid UTF-8: each byte that is not part of a well-formed UTF-8 sequence becomes U+FFFD.
std::string utf8_with_replacements(const std::string& s);
// The bytes of s as lower-case hex, two digits a byte ("caf\xe9" -> "636166e9").
std::string bytes_hex(const std::string& s);

// JSON strings are UTF-8, but file names and header text are bytes. object[key] = text, with
// U+FFFD for each byte that is not UTF-8 (utf8_with_replacements), and only then also
// object[key + "_bytes_hex"] = the exact bytes (bytes_hex), so that the JSON stays valid and a
// script recovers the name: os.fsdecode(bytes.fromhex(record["input_bytes_hex"])).
void put_text(Json& object, const std::string& key, const std::string& text);
// put_text, or null when text is empty.
void put_text_or_null(Json& object, const std::string& key, const std::string& text);
// A list of texts: object[key] = [...] as put_text does each one, and when any is not UTF-8,
// object[key + "_bytes_hex"] = one entry each (the hex, or null for an entry that is UTF-8).
void put_texts(Json& object, const std::string& key, const std::vector<std::string>& texts);

// The number that printf(format, v) writes, as a JSON reader reads it: what the hand-written
// reports printed, so values keep their precision ("%.9g") and integral text stays an integer
// ("380", not "380.0"). null when v is not finite (JSON has no NaN or infinity).
Json json_number(double v, const char* format);
// A number written as text (format_wavelength's "383.7"), as JSON reads it.
Json json_number_text(const std::string& text);

// One line of JSON: the compact document (no spaces, as before) and a line break. Every string went
// through put_text, so nothing should need replacing; should one not have, its invalid bytes
// become U+FFFD rather than the report failing.
std::string json_line(const Json& document);

}  // namespace spectex
