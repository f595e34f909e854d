#include "pipeline/light_list.h"

#include <set>

#include "io/file_identity.h"
#include "spectral/spectrum.h"
#include "spectral/text.h"

namespace spectex {

namespace {

// What makes two lights one: the shipped name (upper case), the file's device and inode, else the
// text itself.
std::string light_key(const std::string& name) {
    for (const auto& shipped : shipped_illuminants())
        if (lower_ascii(name) == lower_ascii(shipped)) return "name:" + shipped;
    if (const auto id = file_id(name))
        return "file:" + std::to_string(id->dev) + ":" + std::to_string(id->ino);
    return "text:" + name;
}

}  // namespace

std::vector<std::string> distinct_lights(const std::vector<std::string>& names) {
    std::vector<std::string> out;
    std::set<std::string> seen;
    for (const auto& n : names)
        if (seen.insert(light_key(n)).second) out.push_back(n);
    return out;
}

}  // namespace spectex
