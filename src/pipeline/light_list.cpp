#include "pipeline/light_list.h"

#include <optional>
#include <set>

#include "base/error.h"
#include "base/text.h"
#include "io/file_identity.h"
#include "spectral/colour_temperature.h"
#include "spectral/spectrum.h"

namespace spectex {

namespace {

// The temperature a name is written as, or nothing (a malformed one too: its loader reports it).
std::optional<int> temperature_of(const std::string& name) {
    try {
        return colour_temperature_of(name);
    } catch (const Error&) {
        return std::nullopt;
    }
}

// What makes two lights one: the shipped name (upper case), the temperature, the file's device and
// inode, else the text itself.
std::string light_key(const std::string& name) {
    for (const auto& shipped : shipped_illuminants())
        if (lower_ascii(name) == lower_ascii(shipped)) return "name:" + shipped;
    if (const auto kelvin = temperature_of(name)) return "temperature:" + std::to_string(*kelvin);
    if (const auto id = file_id(name))
        return "file:" + std::to_string(id->dev) + ":" + std::to_string(id->ino);
    return "text:" + name;
}

}  // namespace

std::string light_name(const std::string& name) {
    if (const auto kelvin = temperature_of(name)) return colour_temperature_name(*kelvin);
    return name;
}

std::vector<std::string> distinct_lights(const std::vector<std::string>& names) {
    std::vector<std::string> out;
    std::set<std::string> seen;
    for (const auto& n : names)
        if (seen.insert(light_key(n)).second) out.push_back(light_name(n));
    return out;
}

}  // namespace spectex
