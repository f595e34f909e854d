// OpenImageIO's ICC profile decoder, replaced: its readers (PNG, JPEG, TIFF, PSD, ICO, JPEG 2000)
// call decode_icc_profile() on the profile a file embeds when they open it, and OpenImageIO 2.4's
// trusts the tag table: a tag of 0xFFFFFFF0 bytes, an offset that wraps, a 'desc' tag shorter
// than its own header or an 'mluc' record pointing past its tag makes it read far outside the
// profile and the process dies with SIGSEGV (a batch with it: every later file lost, no record).
//
// The library calls its exported decoder through its PLT, so this definition (exported from the
// module that links the library, or from a program that links it) is the one every reader calls:
// no byte of a profile reaches a decoder that has not checked it. The profile is checked by
// check_icc_structure (io/icc_profile.h: every offset and length against the profile's bytes);
// a damaged one decodes to nothing and returns false (the readers then keep the raw bytes as the
// ICCProfile attribute, as they do for any profile the decoder rejects), and OiioImageSource
// refuses the file ("ICC profile: <cause>"). A sound one gets the attributes OpenImageIO's own
// decoder gives: the header's fields and the text tags, ICCProfile:<name>.
// tests/cli/hostile_profiles_test.cpp fails (signal 11) if this stops being the decoder called.
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

#include <cstdint>
#include <string>

#include "io/icc_profile.h"

OIIO_NAMESPACE_BEGIN

// The declaration of OpenImageIO/tiffutils.h (which needs libtiff's headers), exported.
OIIO_API bool decode_icc_profile(cspan<uint8_t> iccdata, ImageSpec& spec, std::string& error);

namespace {

uint32_t be32(const uint8_t* p) {
    return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}
uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

const char* pick(const std::string& key, const char* const (*table)[2], size_t n) {
    for (size_t i = 0; i < n; ++i)
        if (key == table[i][0]) return table[i][1];
    return nullptr;
}

void set_if(ImageSpec& spec, const char* name, const char* value) {
    if (value) spec.attribute(name, value);
}

}  // namespace

__attribute__((visibility("default"))) bool decode_icc_profile(cspan<uint8_t> iccdata,
                                                               ImageSpec& spec,
                                                               std::string& error) {
    const uint8_t* b = iccdata.data();
    const size_t n = static_cast<size_t>(iccdata.size());
    const spectex::IccStructure s = spectex::check_icc_structure(b, n);
    if (!s.is_profile) {
        error = n < 132 ? "ICC profile too small" : "ICC profile has bad magic number";
        return false;
    }
    if (!s.damage.empty()) {
        error = "ICC profile: " + s.damage;
        return false;
    }
    if (be32(b) != n) {
        error = "ICC profile size mismatch";
        return false;
    }
    using Strutil::fmt::format;
    static const char* const classes[][2] = {
        {"scnr", "Input device profile"},  {"mntr", "Display device profile"},
        {"prtr", "Output device profile"}, {"link", "DeviceLink profile"},
        {"spac", "ColorSpace profile"},    {"abst", "Abstract profile"},
        {"nmcl", "NamedColor profile"}};
    static const char* const spaces[][2] = {
        {"XYZ ", "XYZ"},    {"Lab ", "CIELAB"}, {"Luv ", "CIELUV"}, {"YCbr", "YCbCr"},
        {"Yxy ", "CIEYxy"}, {"RGB ", "RGB"},    {"GRAY", "Gray"},   {"HSV ", "HSV"},
        {"HLS ", "HLS"},    {"CMYK", "CMYK"},   {"CMY ", "CMY"}};
    static const char* const platforms[][2] = {{"APPL", "Apple Computer, Inc."},
                                               {"MSFT", "Microsoft Corporation"},
                                               {"SGI ", "Silicon Graphics, Inc."},
                                               {"SUNW", "Sun Microsystems, Inc."}};
    static const char* const intents[] = {"Perceptual", "Media-relative colorimetric", "Saturation",
                                          "ICC-absolute colorimetric"};
    auto sig = [&](size_t at) { return std::string(reinterpret_cast<const char*>(b + at), 4); };
    spec.attribute("ICCProfile:profile_size", be32(b));
    spec.attribute("ICCProfile:cmm_type", be32(b + 4));
    spec.attribute("ICCProfile:profile_version",
                   format("{:d}.{:d}.{}", b[8], b[9] >> 4, b[9] & 0xf));
    set_if(spec, "ICCProfile:device_class", pick(sig(12), classes, std::size(classes)));
    set_if(spec, "ICCProfile:color_space", pick(sig(16), spaces, std::size(spaces)));
    set_if(spec, "ICCProfile:profile_connection_space", pick(sig(20), spaces, std::size(spaces)));
    set_if(spec, "ICCProfile:platform_signature", pick(sig(40), platforms, std::size(platforms)));
    spec.attribute("ICCProfile:creation_date",
                   format("{:02d}:{:02d}:{:02d} {:02d}:{:02d}:{:02d}", be16(b + 24), be16(b + 26),
                          be16(b + 28), be16(b + 30), be16(b + 32), be16(b + 34)));
    const uint32_t flags = be32(b + 44), attrs = be32(b + 60), intent = be32(b + 64);
    spec.attribute("ICCProfile:flags", format("{}, {}", flags & 1 ? "Embedded " : "Not Embedded",
                                              flags & 2 ? "Dependent" : "Independent"));
    spec.attribute("ICCProfile:manufacturer", format("{:x}", be32(b + 48)));
    spec.attribute("ICCProfile:model", format("{:x}", be32(b + 52)));
    spec.attribute("ICCProfile:attributes",
                   format("{}, {}, {}, {}", attrs & 1 ? "Transparency " : "Reflective",
                          attrs & 2 ? "Matte" : "Glossy", attrs & 4 ? "Negative" : "Positive",
                          attrs & 8 ? "Black & White" : "Color"));
    spec.attribute("ICCProfile:rendering_intent", intent < 4 ? intents[intent] : "Unknown");
    spec.attribute("ICCProfile:creator_signature", format("{:x}", be32(b + 80)));
    static const char* const names[][2] = {{"targ", "characterization_target"},
                                           {"cprt", "copyright"},
                                           {"desc", "profile_description"},
                                           {"dmdd", "device_model_description"},
                                           {"dmnd", "device_manufacturer_description"},
                                           {"vued", "viewing_conditions_description"}};
    for (const auto& [tag, text] : s.texts) {
        const char* name = pick(tag, names, std::size(names));
        spec.attribute("ICCProfile:" + std::string(name ? name : tag.c_str()), text);
    }
    return true;
}

OIIO_NAMESPACE_END
