// Hostile embedded ICC profiles: a profile whose tags, or the text records inside them, claim
// lengths and offsets outside the profile (0xFFFFFFF0 bytes, an offset that wraps in 32 bits, a
// tag too short for its own type), embedded in a PNG iCCP chunk, a TIFF ICCProfile tag or JPEG
// APP2 ICC_PROFILE segments. OpenImageIO decodes a profile into ICCProfile:* attributes when it
// opens a file; its 2.4 decoder reads such tags out of bounds and the process died with SIGSEGV.
// Every command that opens a texture must instead refuse the file ("spectex: <file>: ICC profile:
// <cause>", exit 1) and a batch must go on with its other files.
//
// The files are made here byte by byte (PNG) or with OpenImageIO's writers, which store the
// profile's bytes as given (TIFF, JPEG): 8x8 pixels, so that each run costs little.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "png_bytes.h"

using namespace spectex_test;

namespace {

using Bytes = std::string;

void put32(Bytes& b, size_t at, uint32_t v) { b.replace(at, 4, png_bytes::be32(v)); }
using png_bytes::be32;

// An ICC profile of one tag `sig` whose table entry says (offset, length) and whose data `body`
// follows the 144-byte header and table: the header's size is the profile's true size.
Bytes profile(const char* sig, const Bytes& body, uint32_t offset, uint32_t length) {
    Bytes b(144, '\0');
    b += body;
    while (b.size() % 4) b += '\0';
    put32(b, 0, static_cast<uint32_t>(b.size()));
    std::memcpy(&b[36], "acsp", 4);
    std::memcpy(&b[12], "mntr", 4);
    std::memcpy(&b[16], "RGB ", 4);
    std::memcpy(&b[20], "XYZ ", 4);
    put32(b, 128, 1);
    std::memcpy(&b[132], sig, 4);
    put32(b, 136, offset);
    put32(b, 140, length);
    return b;
}
// textDescriptionType (ICC v2): "desc", 4 reserved, the ASCII count, the text.
Bytes desc_tag(const std::string& text) {
    Bytes d = "desc" + Bytes(4, '\0') + be32(static_cast<uint32_t>(text.size() + 1)) + text + '\0';
    return d + Bytes(79, '\0');  // the Unicode and ScriptCode parts, empty
}
// multiLocalizedUnicodeType (ICC v4): one English record of (length, offset) from the tag's start.
Bytes mluc_tag(uint32_t length, uint32_t offset) {
    Bytes m =
        "mluc" + Bytes(4, '\0') + be32(1) + be32(12) + "en" + "US" + be32(length) + be32(offset);
    for (char c : std::string("sRGB")) m += Bytes(1, '\0') + c;  // UTF-16BE
    return m;
}

struct Hostile {
    const char* name;
    Bytes icc;
};

// The ways a profile lies about where its text is. Each one killed OpenImageIO 2.4's decoder.
std::vector<Hostile> hostile_profiles() {
    const Bytes desc = desc_tag("Hostile");
    const Bytes text = "text" + Bytes(4, '\0') + "Copyright" + Bytes(3, '\0');
    return {
        {"desc tag of length 0xFFFFFFF0", profile("desc", desc, 144, 0xFFFFFFF0u)},
        {"desc tag whose offset wraps", profile("desc", desc, 0xFFFFFFF0u, 0x20)},
        {"desc tag shorter than its header", profile("desc", desc, 144, 4)},
        {"text tag shorter than its header", profile("cprt", text, 144, 4)},
        {"mluc record of length 0xFFFFFFF0", profile("desc", mluc_tag(0xFFFFFFF0u, 28), 144, 36)},
        {"mluc record whose offset wraps", profile("desc", mluc_tag(8, 0xFFFFFFF0u), 144, 36)},
        {"mluc record far past its tag", profile("desc", mluc_tag(8, 0x7FFFFFF0u), 144, 36)},
    };
}

using png_bytes::png_chunk;
using png_bytes::zlib_stored;

// 8x8 RGB pixels, the same pattern in every container.
std::vector<uint8_t> pixels() {
    std::vector<uint8_t> px(8 * 8 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>(40 + (i * 37) % 170);
    return px;
}

// A PNG with the profile in an iCCP chunk (or none when `icc` is empty), written byte by byte.
void write_png_with_profile(const std::string& path, const Bytes& icc) {
    const std::vector<uint8_t> px = pixels();
    Bytes raw;
    for (int y = 0; y < 8; ++y) {
        raw += '\0';  // filter: none
        raw.append(reinterpret_cast<const char*>(px.data()) + y * 24, 24);
    }
    Bytes ihdr = be32(8) + be32(8) + Bytes("\x08\x02\x00\x00\x00", 5);
    Bytes png = "\x89PNG\r\n\x1a\n" + png_chunk("IHDR", ihdr);
    if (!icc.empty()) png += png_chunk("iCCP", Bytes("icc\0\0", 5) + zlib_stored(icc));
    png += png_chunk("IDAT", zlib_stored(raw)) + png_chunk("IEND", "");
    std::ofstream(path, std::ios::binary) << png;
}

// A TIFF or JPEG (by `path`'s extension) with the profile's bytes in its ICCProfile metadata.
void write_oiio_with_profile(const std::string& path, const Bytes& icc) {
    const std::vector<uint8_t> px = pixels();
    OIIO::ImageSpec spec(8, 8, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("ICCProfile",
                   OIIO::TypeDesc(OIIO::TypeDesc::UINT8, static_cast<int>(icc.size())), icc.data());
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out && out->open(path, spec) &&
                out->write_image(OIIO::TypeDesc::UINT8, px.data()) && out->close())
        << path;
}

void write_with_profile(const std::string& path, const Bytes& icc) {
    if (path.size() > 4 && path.compare(path.size() - 4, 4, ".png") == 0)
        write_png_with_profile(path, icc);
    else
        write_oiio_with_profile(path, icc);
}

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

// The refusal: exit 1 (never a signal), the file named first, the profile named as the cause.
void expect_profile_refused(const std::string& what, const RunResult& r, const std::string& file) {
    SCOPED_TRACE(what);
    ASSERT_LT(r.status, 128) << "killed by signal " << r.status - 128 << ":\n" << r.err;
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_EQ(first_line(r.err).rfind("spectex: " + file + ": ICC profile: ", 0), 0u) << r.err;
}

const char* const kContainers[] = {"png", "tif", "jpg"};

}  // namespace

// A valid profile in each container still reads and names its colour space (the control: the
// guard refuses lies, not profiles).
TEST(HostileProfiles, ValidProfilesInEveryContainerStillBake) {
    ScratchDir d;
    const Bytes icc = profile("desc", desc_tag("sRGB IEC61966-2.1"), 144, 91 + 18);
    for (const char* ext : kContainers) {
        const std::string in = d / (std::string("ok.") + ext),
                          out = d / (std::string(ext) + ".exr");
        write_with_profile(in, icc);
        RunResult r = run_spectex({"bake", in, "-o", out, "--method", "basis", "--json", "-"});
        EXPECT_EQ(r.status, 0) << ext << ": " << r.err;
        EXPECT_TRUE(file_exists(out)) << ext;
        EXPECT_TRUE(contains(r.out, "ICC profile 'sRGB IEC61966-2.1'")) << ext << ": " << r.out;
    }
}

// Every hostile profile in every container, and each command that opens a texture.
TEST(HostileProfiles, LyingProfilesAreRefusedByEveryCommandThatOpensATexture) {
    ScratchDir d;
    write_png_with_profile(d / "good.png", "");
    ASSERT_EQ(
        run_spectex({"bake", d / "good.png", "-o", d / "good.exr", "--method", "basis"}).status, 0);
    const std::vector<Hostile> hostile = hostile_profiles();
    for (const Hostile& h : hostile) {
        for (const char* ext : kContainers) {
            const std::string in = d / (std::string("hostile.") + ext);
            const std::string label = std::string(h.name) + " in ." + ext;
            write_with_profile(in, h.icc);
            const std::string out = d / "out.exr";
            std::remove(out.c_str());
            const std::vector<std::vector<std::string>> commands = {
                {"bake", in, "-o", out, "--method", "basis"},
                {"bake", in, "-o", out, "--method", "basis", "--dry-run"},
                {"verify", d / "good.exr", "--source", in},
                {"plan", "--texture", in, "--method", "basis", "--lights", "D65", "--grids",
                 "380:780:20", "--max-de", "5"}};
            RunResult bake = run_spectex(commands[0]);
            // A PNG's profile whose tag table itself points outside it never leaves libpng, which
            // checks that much and drops the chunk: that file is read as one without a profile,
            // with the documented warning (docs/colour-spaces.md), and no command fails on it.
            const bool dropped = std::string(ext) == "png" && bake.status == 0 &&
                                 contains(bake.err, "libpng refused its iCCP chunk as malformed");
            // Every command opens the texture the same way: all of them on one profile (an mluc
            // record out of bounds, which every container passes on), bake on the others.
            const size_t runs = &h == &hostile[4] ? commands.size() : 1;
            for (size_t c = 0; c < runs; ++c) {
                const std::vector<std::string>& args = commands[c];
                const std::string what =
                    args[0] + (args.back() == "--dry-run" ? " --dry-run: " : ": ") + label;
                RunResult r = c == 0 ? bake : run_spectex(args);
                if (dropped) {
                    std::printf("  %s: libpng dropped the chunk\n", what.c_str());
                    EXPECT_EQ(r.status, 0) << what << ": " << r.err;
                } else {
                    expect_profile_refused(what, r, in);
                    EXPECT_FALSE(file_exists(out)) << what;
                }
            }
        }
    }
}

// A batch goes on past a file that fails: both good outputs, a JSON record for each of the three
// files, exit 1, the bad file named.
TEST(HostileProfiles, BatchSurvivesAHostileProfile) {
    for (const char* ext : kContainers) {
        ScratchDir d;
        const std::string bad = d / (std::string("hostile.") + ext);
        write_png_with_profile(d / "good.png", "");
        write_png_with_profile(d / "good2.png", "");
        write_with_profile(bad, hostile_profiles()[4].icc);
        RunResult r = run_spectex({"bake", d / "good.png", bad, d / "good2.png", "--output-dir",
                                   d / "out", "--method", "basis", "--json", "-"});
        ASSERT_LT(r.status, 128) << ext << ": killed by signal " << r.status - 128;
        EXPECT_EQ(r.status, 1) << ext << ": " << r.err;
        EXPECT_TRUE(file_exists(d / "out/good.exr")) << ext;
        EXPECT_TRUE(file_exists(d / "out/good2.exr")) << ext;
        EXPECT_FALSE(file_exists(d / "out/hostile.exr")) << ext;
        size_t records = 0, failed = 0;
        for (size_t at = r.out.find("\"schema_version\""); at != std::string::npos;
             at = r.out.find("\"schema_version\"", at + 1))
            ++records;
        for (size_t at = r.out.find("\"status\":\"failed\""); at != std::string::npos;
             at = r.out.find("\"status\":\"failed\"", at + 1))
            ++failed;
        EXPECT_EQ(records, 3u) << ext << ": " << r.out;
        EXPECT_EQ(failed, 1u) << ext << ": " << r.out;
        EXPECT_TRUE(contains(r.err, "spectex: " + bad + ": ICC profile: ")) << ext << ": " << r.err;
    }
}
