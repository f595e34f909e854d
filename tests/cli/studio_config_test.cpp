// A studio config whose default file rule is a scene-linear space. With $OCIO set
// to an ACES-style config (reference ACES2065-1, default rule to it), an untagged 16-bit sRGB TIFF
// was read as ACES2065-1 and the only hint was a count of clamped pixels. Now the header records
// the config (path, where it came from, name, checksum) and how the colour space was chosen, the
// batch summary names each file's colour space, and one warning per batch names the default rule
// and suggests --colorspace when integer files fall to a scene-linear space through it.
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

bool has(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

size_t count(const std::string& h, const std::string& n) {
    size_t k = 0;
    for (size_t at = h.find(n); at != std::string::npos; at = h.find(n, at + 1)) ++k;
    return k;
}

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

void write_float_exr(const std::string& path) {
    std::vector<float> px(4 * 4 * 3, 0.25f);
    write_image(path, 4, 4, 3, OIIO::TypeDesc::FLOAT, px.data());
}

struct Studio {
    ScratchDir d;
    std::string config = d / "studio.ocio";
    Studio() { std::ofstream(config) << kStudioConfig; }
};

// The stderr lines that hold `needle`.
std::vector<std::string> lines_with(const std::string& err, const std::string& needle) {
    std::vector<std::string> out;
    size_t b = 0;
    while (b < err.size()) {
        size_t e = err.find('\n', b);
        if (e == std::string::npos) e = err.size();
        std::string line = err.substr(b, e - b);
        if (has(line, needle)) out.push_back(line);
        b = e + 1;
    }
    return out;
}

}  // namespace

// The header says which config was used, where it came from ($OCIO), what it calls itself and its
// checksum, and how the colour space was chosen (the default file rule, by name).
TEST(StudioConfig, HeaderRecordsTheConfigAndHowTheSpaceWasChosen) {
    Studio s;
    write_tiff16(s.d / "albedo.tif");
    RunResult r =
        run_spectex({"bake", s.d / "albedo.tif", "-o", s.d / "albedo.exr"}, {"OCIO=" + s.config});
    ASSERT_EQ(r.status, 0) << r.err;
    ExrImage img = read_exr(s.d / "albedo.exr");
    EXPECT_EQ(img.attr("spectex:inputColorSpace"), "ACES2065-1");
    EXPECT_EQ(img.attr("spectex:inputColorSpaceFrom"), "config file rule 'Default'");
    EXPECT_EQ(img.attr("spectex:config"), s.config);
    EXPECT_EQ(img.attr("spectex:configFrom"), "$OCIO");
    EXPECT_EQ(img.attr("spectex:configName"),
              "studio-test: A small ACES-style studio config for spectex's tests");
    EXPECT_EQ(img.attr("spectex:configChecksum"), fnv1a64_file(s.config));

    // --config, and the shipped config, say so; --colorspace is how the space was chosen.
    ASSERT_EQ(run_spectex({"bake", s.d / "albedo.tif", "-o", s.d / "given.exr", "--config",
                           s.config, "--colorspace", "sRGB Encoded Rec.709 (sRGB)"})
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
    ASSERT_EQ(
        run_spectex({"bake", s.d / "albedo.tif", "-o", s.d / "flag.exr", "--config", s.config})
            .status,
        0);
    ExrImage flag = read_exr(s.d / "flag.exr");
    ASSERT_EQ(flag.pixels.size(), img.pixels.size());
    for (const auto& [name, values] : img.pixels) EXPECT_EQ(flag.pixels.at(name), values) << name;
}

// Integer files that fall to a scene-linear space through the default rule get one warning per
// batch, naming the rule, the space and the files, and suggesting --colorspace with the config's
// own sRGB texture space (found by its transform, not its name). Files chosen by an explicit rule,
// float files, and --colorspace are not warned about. The summary names every file's space.
TEST(StudioConfig, DefaultRuleToSceneLinearWarnsOncePerBatch) {
    Studio s;
    write_tiff16(s.d / "a.tif");
    write_tiff16(s.d / "b.tif", 30000);
    write_tiff16(s.d / "c_lin.tif");
    write_float_exr(s.d / "d.exr");
    RunResult r = run_spectex({"bake", s.d / "a.tif", s.d / "b.tif", s.d / "c_lin.tif",
                               s.d / "d.exr", "--output-dir", s.d / "out", "--jobs", "2"},
                              {"OCIO=" + s.config});
    ASSERT_EQ(r.status, 0) << r.err;
    const auto warnings = lines_with(r.err, "warning:");
    ASSERT_EQ(warnings.size(), 1u) << r.err;
    const std::string& w = warnings[0];
    EXPECT_TRUE(has(w, "2 integer")) << w;
    EXPECT_TRUE(has(w, "'ACES2065-1'")) << w;
    EXPECT_TRUE(has(w, "scene-linear")) << w;
    EXPECT_TRUE(has(w, "default file rule 'Default'")) << w;
    EXPECT_TRUE(has(w, s.config)) << w;
    EXPECT_TRUE(has(w, "$OCIO")) << w;
    EXPECT_TRUE(has(w, "a.tif")) << w;
    EXPECT_TRUE(has(w, "b.tif")) << w;
    EXPECT_FALSE(has(w, "c_lin.tif")) << "chosen by an explicit rule: " << w;
    EXPECT_FALSE(has(w, "d.exr")) << "a float file: " << w;
    EXPECT_TRUE(has(w, "--colorspace 'sRGB Encoded Rec.709 (sRGB)'")) << w;

    // The summary: every file with its colour space and how it was chosen, one line per space and
    // way, in input order (the float EXR is linear to OpenImageIO, which assumes it of every
    // OpenEXR file: its "Linear" is the scene_linear role, labelled as OpenImageIO's default).
    const auto spaces = lines_with(r.err, "colour space '");
    ASSERT_EQ(spaces.size(), 3u) << r.err;
    EXPECT_TRUE(has(spaces[0], "colour space 'ACES2065-1' (config file rule 'Default'): " +
                                   s.d / "a.tif" + ", " + s.d / "b.tif"))
        << spaces[0];
    EXPECT_TRUE(has(spaces[1], "colour space 'ACES2065-1' (config file rule 'LinearTiffs'): " +
                                   s.d / "c_lin.tif"))
        << spaces[1];
    EXPECT_TRUE(has(spaces[2],
                    "colour space 'ACES2065-1' (OpenImageIO's default for openexr files "
                    "(Linear)): " +
                        s.d / "d.exr"))
        << spaces[2];

    // --colorspace: no warning; -q: no warning and no summary.
    RunResult given = run_spectex({"bake", s.d / "a.tif", s.d / "b.tif", "--output-dir",
                                   s.d / "given", "--colorspace", "sRGB Encoded Rec.709 (sRGB)"},
                                  {"OCIO=" + s.config});
    ASSERT_EQ(given.status, 0) << given.err;
    EXPECT_FALSE(has(given.err, "warning")) << given.err;
    EXPECT_EQ(count(given.err, "(--colorspace)"), 1u) << given.err;
    RunResult quiet =
        run_spectex({"bake", s.d / "a.tif", s.d / "b.tif", "--output-dir", s.d / "quiet", "-q"},
                    {"OCIO=" + s.config});
    ASSERT_EQ(quiet.status, 0) << quiet.err;
    // --quiet silences the summary and the colour-space lines (information), not the warnings
    // about the data: the once-per-batch warning and each file's clamped pixels stay.
    EXPECT_FALSE(has(quiet.err, "baked")) << quiet.err;
    EXPECT_FALSE(has(quiet.err, "colour space '")) << quiet.err;
    EXPECT_EQ(lines_with(quiet.err, "warning: 2 integer").size(), 1u) << quiet.err;
    EXPECT_EQ(lines_with(quiet.err, "were clamped").size(), 2u) << quiet.err;
}

// One file is a batch too: the warning comes without a summary; an explicit rule, a float file and
// the shipped config's default rule (to an sRGB texture space, not scene-linear) give none.
TEST(StudioConfig, OneFileAndTheCasesThatDoNotWarn) {
    Studio s;
    write_tiff16(s.d / "a.tif");
    write_tiff16(s.d / "c_lin.tif");
    write_float_exr(s.d / "d.exr");
    RunResult one = run_spectex({"bake", s.d / "a.tif", "-o", s.d / "a.exr"}, {"OCIO=" + s.config});
    ASSERT_EQ(one.status, 0) << one.err;
    EXPECT_EQ(count(one.err, "warning:"), 1u) << one.err;
    EXPECT_TRUE(has(one.err, "1 integer (display-referred) file was read as 'ACES2065-1'"))
        << one.err;
    for (const char* f : {"c_lin.tif", "d.exr"}) {
        RunResult r = run_spectex({"bake", s.d / f, "-o", s.d / (std::string(f) + ".exr")},
                                  {"OCIO=" + s.config});
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_FALSE(has(r.err, "warning")) << f << ": " << r.err;
    }
    RunResult shipped = run_spectex({"bake", s.d / "a.tif", "-o", s.d / "shipped.exr"}, {"OCIO="});
    ASSERT_EQ(shipped.status, 0) << shipped.err;
    EXPECT_FALSE(has(shipped.err, "warning")) << shipped.err;
}

// --quiet silences progress and information, not warnings about the data: the studio-config
// warning and the clamped pixels still reach stderr, and the JSON record carries how the colour
// space was chosen and the warnings given.
TEST(StudioConfig, WarningsAboutTheDataSurviveQuietAndReachTheJsonRecord) {
    Studio s;
    write_tiff16(s.d / "tex16.tif");
    RunResult r = run_spectex(
        {"bake", s.d / "tex16.tif", "-o", s.d / "q16.exr", "-q", "--json", s.d / "r.jsonl"},
        {"OCIO=" + s.config});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(lines_with(r.err, "warning: 1 integer (display-referred) file").size(), 1u) << r.err;
    const std::string json = read_file(s.d / "r.jsonl");
    EXPECT_TRUE(has(json, "\"colorspace_from\":\"config file rule 'Default'\"")) << json;
    EXPECT_TRUE(has(json, "\"warnings\":[")) << json;
    EXPECT_TRUE(has(json, "only because the OCIO config's default file rule 'Default' names it"))
        << json;
    // A file with nothing to report has an empty list, and -q prints nothing for it.
    write_float_exr(s.d / "f.exr");
    RunResult q = run_spectex(
        {"bake", s.d / "f.exr", "-o", s.d / "f_out.exr", "-q", "--json", s.d / "f.jsonl"},
        {"OCIO=" + s.config});
    ASSERT_EQ(q.status, 0) << q.err;
    EXPECT_EQ(q.err, "");
    EXPECT_TRUE(has(read_file(s.d / "f.jsonl"), "\"warnings\":[]")) << read_file(s.d / "f.jsonl");
}

// Configs written as published configs write them (tests/ocio/): the ACES 1.x style, whose sRGB
// texture space is the curve then a 7-digit sRGB -> AP0 matrix, and the OCIO 2 studio style, whose
// conversions are OpenColorIO's builtins, both bridged to the shipped config through ACES2065-1.
// Their sRGB texture spaces decode sRGB codes within 2.1e-4 of the IEC 61966-2-1 curve (the
// rounding of the published matrices): they are suggested. The spaces near sRGB that are not it
// (Rec.709 at gamma 2.4 or 2.2, the sRGB curve on P3 primaries, ACEScg) are not.
TEST(StudioConfig, PublishedConfigsSrgbTextureSpaceIsSuggested) {
    ScratchDir d;
    write_tiff16(d / "a.tif");
    const std::string ocio = std::string(SPECTEX_TEST_SOURCE_DIR) + "/tests/ocio/";
    const std::pair<const char*, const char*> cases[] = {
        {"aces1x_style.ocio", "--colorspace 'Utility - sRGB - Texture'"},
        {"builtin_style.ocio", "--colorspace 'sRGB Encoded Rec.709 (sRGB)'"},
        {"not_srgb.ocio", "--colorspace NAME (the config has no space that decodes as sRGB does)"},
    };
    for (const auto& [config, says] : cases) {
        RunResult r = run_spectex({"bake", d / "a.tif", "-o", d / "a.exr", "--config",
                                   ocio + config, "--method", "basis"});
        ASSERT_EQ(r.status, 0) << config << ": " << r.err;
        const auto warnings = lines_with(r.err, "warning: 1 integer");
        ASSERT_EQ(warnings.size(), 1u) << config << ": " << r.err;
        EXPECT_TRUE(has(warnings[0], says)) << config << ": " << warnings[0];
    }
}
