#include "io/exr_compression.h"

#include <ImfCompression.h>
#include <openexr.h>

#include "base/error.h"

namespace spectex {

// The C++ library and the C core number compressions alike (the header's byte); both writers take
// the id from the table.
static_assert(int(Imf::NO_COMPRESSION) == int(EXR_COMPRESSION_NONE) &&
                  int(Imf::ZIPS_COMPRESSION) == int(EXR_COMPRESSION_ZIPS) &&
                  int(Imf::ZIP_COMPRESSION) == int(EXR_COMPRESSION_ZIP) &&
                  int(Imf::DWAB_COMPRESSION) == int(EXR_COMPRESSION_DWAB),
              "Imf::Compression and exr_compression_t disagree");

const std::vector<ExrCompression>& ExrCompression::all() {
    // Lines per chunk are OpenEXR's (ImfCompression.h, exr_get_scanlines_per_chunk). Lossy: pxr24
    // rounds float samples to 24 bits, b44/b44a quantise half samples, dwaa/dwab quantise channels
    // name   id                        lines  core   lossy
    static const std::vector<ExrCompression> table = {
        // name     id                        lines  core   lossy
        {"none", Imf::NO_COMPRESSION, 1, true, false},
        {"rle", Imf::RLE_COMPRESSION, 1, false, false},
        {"zips", Imf::ZIPS_COMPRESSION, 1, true, false},
        {"zip", Imf::ZIP_COMPRESSION, 16, true, false},
        {"piz", Imf::PIZ_COMPRESSION, 32, false, false},
        {"pxr24", Imf::PXR24_COMPRESSION, 16, false, true},
        {"b44", Imf::B44_COMPRESSION, 32, false, true},
        {"b44a", Imf::B44A_COMPRESSION, 32, false, true},
        {"dwaa", Imf::DWAA_COMPRESSION, 32, false, true},
        {"dwab", Imf::DWAB_COMPRESSION, 256, false, true},
    };
    return table;
}

const ExrCompression* ExrCompression::find(const std::string& name) {
    for (const auto& c : all())
        if (c.name == name) return &c;
    return nullptr;
}

const ExrCompression* ExrCompression::find(int id) {
    for (const auto& c : all())
        if (c.id == id) return &c;
    return nullptr;
}

ExrCompression ExrCompression::parse(const std::string& name) {
    if (const ExrCompression* c = find(name)) return *c;
    throw Error("unknown compression '" + name + "' (known: " + list(", ", ", ") + ")");
}

std::vector<std::string> ExrCompression::names() {
    std::vector<std::string> v;
    for (const auto& c : all()) v.push_back(c.name);
    return v;
}

bool ExrCompression::lossy_for(bool half_samples) const {
    if (!lossy) return false;
    if (name == "pxr24") return !half_samples;                 // 24-bit floats: half is kept whole
    if (name == "b44" || name == "b44a") return half_samples;  // float channels are kept whole
    return true;
}

std::string ExrCompression::lossy_text() const {
    const bool h = lossy_for(true), f = lossy_for(false);
    return h && f ? "lossy" : h ? "lossy for half" : f ? "lossy for float" : "";
}

namespace {

std::string join(const std::vector<std::string>& v, const std::string& separator,
                 const std::string& last_separator) {
    std::string s;
    for (size_t i = 0; i < v.size(); ++i)
        s += (i == 0 ? "" : i + 1 == v.size() ? last_separator : separator) + v[i];
    return s;
}

}  // namespace

std::string ExrCompression::lossless_list(const std::string& separator,
                                          const std::string& last_separator) {
    std::vector<std::string> v;
    for (const auto& c : all())
        if (!c.lossy) v.push_back(c.name);
    return join(v, separator, last_separator);
}

std::string ExrCompression::list(const std::string& separator, const std::string& last_separator) {
    std::vector<std::string> v;
    for (const auto& c : all())
        v.push_back(c.lossy ? c.name + " (" + c.lossy_text() + ")" : c.name);
    return join(v, separator, last_separator);
}

}  // namespace spectex
