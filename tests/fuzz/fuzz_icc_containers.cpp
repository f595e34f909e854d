// libFuzzer harness: an ICC profile embedded in the three containers that carry one to
// OpenImageIO's readers, and spectex's checks of it.
//  1. the bytes, as a profile, through check_icc_structure and read_icc_profile (io/icc_profile.h);
//     the texts they return must lie inside what they were given;
//  2. the bytes in a PNG iCCP chunk (written byte by byte: libpng's writer would check them
//     first), a TIFF ICCProfile tag and JPEG APP2 ICC_PROFILE segments (OpenImageIO's writers,
//     which store the bytes as given), each opened with OpenImageIO: every reader hands the
//     profile to decode_icc_profile, which this program defines as the tool's module does
//     (io/oiio/icc_decoder_oiio.cpp, exported with -rdynamic so that the library calls it), and
//     the profile the reader keeps is checked again as OiioImageSource checks it.
// A crash, an out-of-bounds read in our code, a leak or UB fails. Inputs are best started from
// corpus/fuzz_icc_containers (a sound profile with 'desc' and 'mluc' tags, and the hostile
// profiles of tests/cli/hostile_profiles_test.cpp).
#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "io/icc_profile.h"
#include "png_bytes.h"

namespace {

using Bytes = std::string;

std::string temp_path(const char* ext) {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir && *dir ? dir : "/tmp") + "/spectex-fuzz-icc-" +
           std::to_string(getpid()) + ext;
}

using png_bytes::be32;
using png_bytes::png_chunk;
using png_bytes::zlib_stored;

const uint8_t kPixels[4 * 4 * 3] = {10,  20,  30,  40,  50,  60,  70,  80,  90,  100, 110, 120,
                                    130, 140, 150, 160, 170, 180, 190, 200, 210, 220, 230, 240,
                                    250, 5,   15,  25,  35,  45,  55,  65,  75,  85,  95,  105,
                                    115, 125, 135, 145, 155, 165, 175, 185, 195, 205, 215, 225};

bool write_png(const std::string& path, const Bytes& icc) {
    Bytes raw;
    for (int y = 0; y < 4; ++y)
        raw += '\0' + Bytes(reinterpret_cast<const char*>(kPixels) + y * 12, 12);
    const Bytes ihdr = be32(4) + be32(4) + Bytes("\x08\x02\x00\x00\x00", 5);
    const Bytes png = "\x89PNG\r\n\x1a\n" + png_chunk("IHDR", ihdr) +
                      png_chunk("iCCP", Bytes("icc\0\0", 5) + zlib_stored(icc)) +
                      png_chunk("IDAT", zlib_stored(raw)) + png_chunk("IEND", "");
    std::ofstream out(path, std::ios::binary);
    out << png;
    return static_cast<bool>(out);
}

bool write_with_oiio(const std::string& path, const Bytes& icc) {
    OIIO::ImageSpec spec(4, 4, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("ICCProfile",
                   OIIO::TypeDesc(OIIO::TypeDesc::UINT8, static_cast<int>(icc.size())), icc.data());
    auto out = OIIO::ImageOutput::create(path);
    return out && out->open(path, spec) && out->write_image(OIIO::TypeDesc::UINT8, kPixels) &&
           out->close();
}

// What spectex reads of a profile: its structure and its description. Texts decoded from the
// profile can be no longer than it.
void check(const unsigned char* p, size_t n) {
    const spectex::IccStructure s = spectex::check_icc_structure(p, n);
    size_t text = 0;
    for (const auto& [sig, t] : s.texts) text += t.size();
    if (s.damage.empty() && text > 4 * n) std::abort();  // UTF-16 to UTF-8: at most 3 bytes per 2
    if (!s.is_profile && (!s.damage.empty() || !s.texts.empty())) std::abort();
    const spectex::IccProfileInfo info = spectex::read_icc_profile(p, n);
    if (info.description.size() > 4 * n) std::abort();
}

void open_and_check(const std::string& path) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        (void)OIIO::geterror();
        return;
    }
    const OIIO::ParamValue* p = in->spec().find_attribute("ICCProfile");
    if (p && p->type().basetype == OIIO::TypeDesc::UINT8)
        check(static_cast<const unsigned char*>(p->data()),
              p->type().basesize() * p->type().numelements());
    in->close();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    OIIO::attribute("threads", 1);
    std::atexit([] {
        for (const char* ext : {".png", ".tif", ".jpg"}) std::remove(temp_path(ext).c_str());
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    check(data, size);
    if (size == 0) return 0;
    const Bytes icc(reinterpret_cast<const char*>(data), size);
    static const std::string png = temp_path(".png"), tif = temp_path(".tif"),
                             jpg = temp_path(".jpg");
    if (write_png(png, icc)) open_and_check(png);
    if (write_with_oiio(tif, icc)) open_and_check(tif);
    if (write_with_oiio(jpg, icc)) open_and_check(jpg);
    (void)OIIO::geterror();
    return 0;
}
