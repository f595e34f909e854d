// Issue 14, item 2: a studio config whose default file rule is a scene-linear space. With $OCIO set
// to an ACES-style config (reference ACES2065-1, default rule to it), an untagged 16-bit sRGB TIFF
// was read as ACES2065-1 and the only hint was a count of clamped pixels. Now the header records
// the config (path, where it came from, name, checksum) and how the colour space was chosen.
//
// The config is written here: its spaces carry no `encoding`, so what makes ACES2065-1 scene-linear
// for spectex must be OCIO's transform (a matrix), not a name or a tag; the sRGB space is named as
// the ACES Studio config names it, which no name list of spectex's knows.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

// The ACES2065-1 -> linear Rec.709 matrix of the shipped config (Bradford to D65), here the
// transform from this config's reference (ACES2065-1) to its sRGB texture space's linear part.
const char* kStudioConfig = R"(ocio_profile_version: 2

environment: {}
search_path: ""
strictparsing: true
luma: [0.2126, 0.7152, 0.0722]
name: studio-test
description: A small ACES-style studio config for spectex's tests

roles:
  aces_interchange: ACES2065-1
  default: ACES2065-1
  scene_linear: ACES2065-1
  data: Raw

file_rules:
  - !<Rule> {name: LinearTiffs, pattern: "*_lin", extension: "tif", colorspace: ACES2065-1}
  - !<Rule> {name: Default, colorspace: ACES2065-1}

displays:
  sRGB:
    - !<View> {name: Raw, colorspace: Raw}

colorspaces:
  - !<ColorSpace>
    name: ACES2065-1
    family: ACES
    isdata: false

  - !<ColorSpace>
    name: sRGB Encoded Rec.709 (sRGB)
    family: Utility
    isdata: false
    from_scene_reference: !<GroupTransform>
      children:
        - !<MatrixTransform> {matrix: [2.521400888578221, -1.1339957493827464, -0.3875618567688676, 0, -0.2762140615617483, 1.3725955663040894, -0.0962823557364662, 0, -0.015320200077478606, -0.15299256180069862, 1.1683871996193156, 0, 0, 0, 0, 1]}
        - !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055, direction: inverse}

  - !<ColorSpace>
    name: Raw
    family: Utility
    isdata: true
)";

// "fnv1a64:<hex>" of a file's bytes as spectex:configChecksum is documented: FNV-1a 64 over the
// bytes, then the separator byte 0xff.
std::string fnv1a64_file(const std::string& path) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : read_file(path)) {
        h ^= c;
        h *= 0x100000001b3ull;
    }
    h ^= 0xff;
    h *= 0x100000001b3ull;
    char buf[32];
    std::snprintf(buf, sizeof buf, "fnv1a64:%016llx", static_cast<unsigned long long>(h));
    return buf;
}

// An untagged 16-bit RGB TIFF of sRGB-looking codes (what a texture painter exports).
void write_tiff16(const std::string& path, uint16_t base = 20000) {
    std::vector<uint16_t> px(6 * 4 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint16_t>(base + 997 * i);
    write_image(path, 6, 4, 3, OIIO::TypeDesc::UINT16, px.data());
}

struct Studio {
    ScratchDir d;
    std::string config = d / "studio.ocio";
    Studio() { std::ofstream(config) << kStudioConfig; }
};

}  // namespace

// The header says which config was used, where it came from ($OCIO), what it calls itself and its
// checksum, and how the colour space was chosen (the default file rule, by name).
TEST(StudioConfig, HeaderRecordsTheConfigAndHowTheSpaceWasChosen) {
    Studio s;
    write_tiff16(s.d / "albedo.tif");
    RunResult r = run_spectex({"bake", s.d / "albedo.tif", "-o", s.d / "albedo.exr"}, {"OCIO=" + s.config});
    ASSERT_EQ(r.status, 0) << r.err;
    ExrImage img = read_exr(s.d / "albedo.exr");
    EXPECT_EQ(img.attr("spectex:inputColorSpace"), "ACES2065-1");
    EXPECT_EQ(img.attr("spectex:inputColorSpaceFrom"), "config file rule 'Default'");
    EXPECT_EQ(img.attr("spectex:config"), s.config);
    EXPECT_EQ(img.attr("spectex:configFrom"), "$OCIO");
    EXPECT_EQ(img.attr("spectex:configName"), "studio-test: A small ACES-style studio config for spectex's tests");
    EXPECT_EQ(img.attr("spectex:configChecksum"), fnv1a64_file(s.config));

    // --config, and the shipped config, say so; --colorspace is how the space was chosen.
    ASSERT_EQ(run_spectex({"bake", s.d / "albedo.tif", "-o", s.d / "given.exr", "--config", s.config, "--colorspace",
                           "sRGB Encoded Rec.709 (sRGB)"})
                  .status,
              0);
    ExrImage given = read_exr(s.d / "given.exr");
    EXPECT_EQ(given.attr("spectex:configFrom"), "--config");
    EXPECT_EQ(given.attr("spectex:inputColorSpace"), "sRGB Encoded Rec.709 (sRGB)");
    EXPECT_EQ(given.attr("spectex:inputColorSpaceFrom"), "--colorspace");
    RunResult sh = run_spectex({"bake", s.d / "albedo.tif", "-o", s.d / "shipped.exr"}, {"OCIO="});
    ASSERT_EQ(sh.status, 0) << sh.err;
    ExrImage shipped = read_exr(s.d / "shipped.exr");
    EXPECT_EQ(shipped.attr("spectex:configFrom"), "shipped");
    EXPECT_EQ(shipped.attr("spectex:configName"),
              "spectex: spectex texture colour spaces (linear Rec.709 reference)");
    EXPECT_EQ(shipped.attr("spectex:configChecksum"),
              fnv1a64_file(std::string(SPECTEX_TEST_DATA_DIR) + "/spectex.ocio"));
    EXPECT_EQ(shipped.attr("spectex:inputColorSpace"), "sRGB - Texture");
    EXPECT_EQ(shipped.attr("spectex:inputColorSpaceFrom"), "config file rule 'Default'");

    // $OCIO and --config of the same file give the same pixels: only provenance differs.
    ASSERT_EQ(run_spectex({"bake", s.d / "albedo.tif", "-o", s.d / "flag.exr", "--config", s.config}).status, 0);
    ExrImage flag = read_exr(s.d / "flag.exr");
    ASSERT_EQ(flag.pixels.size(), img.pixels.size());
    for (const auto& [name, values] : img.pixels) EXPECT_EQ(flag.pixels.at(name), values) << name;
}
