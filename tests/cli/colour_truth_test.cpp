// The colour space is told truthfully and found where the user expects.
//
// An Adobe RGB-tagged PNG baked as sRGB, labelled "file metadata (sRGB)": the embedded ICC profile
// was ignored and the label was OpenImageIO's default for PNG, not anything the file said. Now an
// ICC profile the config can name is used, one it cannot name is a warning (under -q too) that
// names it and suggests --colorspace, a damaged one never crashes, and the origin label says what
// chose the space: the profile, OpenEXR chromaticities, a tag in the file, a config rule, or
// OpenImageIO's default for the format.
//
// And verify, when the config a file records is gone and $OCIO is unset, said nothing and failed
// with "unknown colour space 'sRGB Encoded Rec.709 (sRGB)' ... (did you mean 'Linear Rec.709
// (sRGB)'?)": it now warns (naming the recorded config and the one used instead) even when it then
// fails, the shipped config knows the ACES 2.x names, and suggestions keep encoded with encoded.
//
// Every file is made here: the ICC profiles are written byte by byte (a v2 display profile with a
// description, white point, colorants and gamma curves; no binary is committed).
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;
using nlohmann::json;

namespace {

bool has(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

void put32(std::vector<unsigned char>& b, uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<unsigned char>(v >> s));
}
void put_s15(std::vector<unsigned char>& b, double v) {
    put32(b, static_cast<uint32_t>(static_cast<int32_t>(std::lround(v * 65536))));
}
void put_sig(std::vector<unsigned char>& b, const char* s) { b.insert(b.end(), s, s + 4); }

// A small ICC v2 display profile: 'desc' (textDescriptionType), 'wtpt', the colorants (rough
// Adobe RGB values: only the description matters to spectex) and pure gamma curves.
std::vector<unsigned char> icc_profile(const std::string& description) {
    std::vector<std::pair<std::string, std::vector<unsigned char>>> tags;
    std::vector<unsigned char> desc;
    put_sig(desc, "desc");
    put32(desc, 0);
    put32(desc, static_cast<uint32_t>(description.size() + 1));
    desc.insert(desc.end(), description.begin(), description.end());
    desc.push_back(0);
    desc.resize(desc.size() + 4 + 4 + 2 + 1 + 67, 0);  // no Unicode, no ScriptCode text
    tags.emplace_back("desc", desc);
    auto xyz = [](double x, double y, double z) {
        std::vector<unsigned char> t;
        put_sig(t, "XYZ ");
        put32(t, 0);
        put_s15(t, x);
        put_s15(t, y);
        put_s15(t, z);
        return t;
    };
    tags.emplace_back("wtpt", xyz(0.9642, 1.0, 0.8249));
    tags.emplace_back("rXYZ", xyz(0.6097, 0.3111, 0.0195));
    tags.emplace_back("gXYZ", xyz(0.2053, 0.6257, 0.0609));
    tags.emplace_back("bXYZ", xyz(0.1492, 0.0632, 0.7446));
    std::vector<unsigned char> curv;
    put_sig(curv, "curv");
    put32(curv, 0);
    put32(curv, 1);
    curv.push_back(2);  // u8Fixed8 2.199
    curv.push_back(51);
    curv.push_back(0);
    curv.push_back(0);
    for (const char* t : {"rTRC", "gTRC", "bTRC"}) tags.emplace_back(t, curv);

    std::vector<unsigned char> table, data;
    const uint32_t first = 128 + 4 + 12 * static_cast<uint32_t>(tags.size());
    put32(table, static_cast<uint32_t>(tags.size()));
    for (auto& [sig, t] : tags) {
        while (t.size() % 4) t.push_back(0);
        put_sig(table, sig.c_str());
        put32(table, first + static_cast<uint32_t>(data.size()));
        put32(table, static_cast<uint32_t>(t.size()));
        data.insert(data.end(), t.begin(), t.end());
    }
    std::vector<unsigned char> p;
    put32(p, static_cast<uint32_t>(128 + table.size() + data.size()));
    put_sig(p, "none");
    p.insert(p.end(), {2, 0x10, 0, 0});
    put_sig(p, "mntr");
    put_sig(p, "RGB ");
    put_sig(p, "XYZ ");
    p.resize(36, 0);  // date
    put_sig(p, "acsp");
    p.resize(68, 0);  // platform, flags, device, attributes, intent
    put_s15(p, 0.9642);
    put_s15(p, 1.0);
    put_s15(p, 0.8249);
    p.resize(128, 0);
    p.insert(p.end(), table.begin(), table.end());
    p.insert(p.end(), data.begin(), data.end());
    return p;
}

// A 4x4 8-bit RGB image of one colour, with an ICC profile (when not empty) and string attributes.
void write_tagged(const std::string& path, const std::vector<unsigned char>& icc,
                  const std::vector<std::pair<std::string, std::string>>& attrs = {},
                  const unsigned char rgb[3] = nullptr) {
    OIIO::ImageSpec spec(4, 4, 3, OIIO::TypeDesc::UINT8);
    if (!icc.empty())
        spec.attribute("ICCProfile",
                       OIIO::TypeDesc(OIIO::TypeDesc::UINT8, static_cast<int>(icc.size())),
                       icc.data());
    for (const auto& [k, v] : attrs) spec.attribute(k, v);
    std::vector<unsigned char> px(4 * 4 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = rgb ? rgb[i % 3] : 128;
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out && out->open(path, spec) &&
                out->write_image(OIIO::TypeDesc::UINT8, px.data()) && out->close())
        << OIIO::geterror();
}

// The one JSON Lines record of a one-file bake.
json bake_record(const RunResult& r) {
    const size_t nl = r.out.find('\n');
    return json::parse(r.out.substr(0, nl));
}

RunResult bake_json(const std::string& in, const std::string& out,
                    std::vector<std::string> extra = {},
                    const std::vector<std::string>& env = {"OCIO="}) {
    std::vector<std::string> args = {"bake", in, "-o", out, "--json", "-", "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_spectex(args, env);
}

// Bit-exact CRC-32 of PNG chunks (ISO 3309), for hand-made chunks.
uint32_t crc32(const unsigned char* p, size_t n) {
    uint32_t c = 0xffffffffu;
    for (size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return ~c;
}

// `png` with a chunk of `type` and `body` inserted after IHDR.
std::string with_chunk(const std::string& png, const std::string& type, const std::string& body) {
    std::vector<unsigned char> c;
    put32(c, static_cast<uint32_t>(body.size()));
    c.insert(c.end(), type.begin(), type.end());
    c.insert(c.end(), body.begin(), body.end());
    put32(c, crc32(c.data() + 4, c.size() - 4));
    const size_t after_ihdr = 8 + 12 + 13;
    return png.substr(0, after_ihdr) + std::string(c.begin(), c.end()) + png.substr(after_ihdr);
}

}  // namespace

// An Adobe RGB profile, in a PNG, a TIFF and a JPEG: the space the config names for it, labelled
// with the profile; the pixels decoded by Adobe RGB's curve and primaries, not sRGB's.
TEST(ColourTruth, IccProfileTheConfigNamesIsUsedAndNamed) {
    ScratchDir d;
    const unsigned char rgb[3] = {150, 120, 100};
    std::vector<std::string> args = {"bake", "--output-dir", d / "out", "--json", "-",
                                     "-q",   "--preview",    "--type",  "float"};
    for (const char* ext : {"png", "tif", "jpg"}) {
        args.push_back(d / (std::string("adobe_") + ext + "." + ext));
        write_tagged(args.back(), icc_profile("Adobe RGB (1998)"), {}, rgb);
    }
    args.push_back(d / "p3.png");
    write_tagged(args.back(), icc_profile("Display P3"));
    RunResult r = run_spectex(args, {"OCIO="});
    ASSERT_EQ(r.status, 0) << r.err;
    std::map<std::string, json> records;  // by input: records come as files finish
    for (size_t b = 0, e; b < r.out.size(); b = e + 1) {
        e = r.out.find('\n', b);
        const json j = json::parse(r.out.substr(b, e - b));
        records[j["input"]] = j;
    }
    for (const char* ext : {"png", "tif", "jpg"}) {
        const std::string stem = std::string("adobe_") + ext;
        SCOPED_TRACE(stem);
        const json& j = records[d / (stem + "." + ext)];
        EXPECT_EQ(j["colorspace"], "Gamma 2.2 Encoded AdobeRGB") << r.out;
        EXPECT_EQ(j["colorspace_from"], "ICC profile 'Adobe RGB (1998)'") << r.out;
        EXPECT_TRUE(j["warnings"].empty()) << r.out;
        const ExrImage e = read_exr(d / ("out/" + stem + ".exr"));
        EXPECT_EQ(e.attr("spectex:inputColorSpace"), "Gamma 2.2 Encoded AdobeRGB");
        EXPECT_EQ(e.attr("spectex:inputColorSpaceFrom"), "ICC profile 'Adobe RGB (1998)'");
        if (std::string(ext) == "jpg") continue;  // lossy codes: the label is what counts
        // Adobe RGB (1998): codes^(563/256), then its primaries to Rec.709's (colour-science
        // 0.4.7 matrix_RGB_to_RGB). sRGB's decoding of the same codes gives R 0.305, 0.054 away;
        // the preview channels are floats of OCIO's result: 1e-4 covers float rounding.
        const double a[3] = {std::pow(150 / 255.0, 2.19921875), std::pow(120 / 255.0, 2.19921875),
                             std::pow(100 / 255.0, 2.19921875)};
        const double m[3][3] = {{1.398208596, -0.39829809, -3.9774e-05},
                                {0.000136554, 0.999946439, -6.455e-06},
                                {3.3869e-05, -0.042926418, 1.042971631}};
        const char* ch[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(e.at(ch[c], 1, 1), m[c][0] * a[0] + m[c][1] * a[1] + m[c][2] * a[2], 1e-4)
                << ch[c];
    }
    // Display P3 too.
    EXPECT_EQ(records[d / "p3.png"]["colorspace"], "sRGB Encoded P3-D65 - Texture") << r.out;
    EXPECT_EQ(records[d / "p3.png"]["colorspace_from"], "ICC profile 'Display P3'") << r.out;
}

// A profile the config cannot name: a warning that survives -q, names the profile and suggests
// --colorspace; the pixels are read as the fallback and the JSON record says both.
TEST(ColourTruth, IccProfileTheConfigCannotNameIsAWarningUnderQuiet) {
    ScratchDir d;
    const std::string in = d / "prophoto.png";
    write_tagged(in, icc_profile("ProPhoto RGB"));
    RunResult r = bake_json(in, in + ".exr");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has(r.err, "'ProPhoto RGB'")) << r.err;
    EXPECT_TRUE(has(r.err, "--colorspace")) << r.err;
    EXPECT_TRUE(has(r.err, "prophoto.png")) << r.err;
    const json j = bake_record(r);
    EXPECT_EQ(j["colorspace"], "sRGB - Texture") << r.out;
    const std::string from = j["colorspace_from"];
    EXPECT_TRUE(has(from, "OpenImageIO's default for png files (sRGB)")) << from;
    EXPECT_TRUE(has(from, "not the embedded ICC profile 'ProPhoto RGB'")) << from;
    ASSERT_EQ(j["warnings"].size(), 1u) << r.out;
    EXPECT_TRUE(has(j["warnings"][0], "ProPhoto RGB")) << r.out;
    // --colorspace settles it: no warning.
    RunResult given = bake_json(in, d / "given.exr", {"--colorspace", "lin_srgb"});
    ASSERT_EQ(given.status, 0) << given.err;
    EXPECT_FALSE(has(given.err, "ProPhoto")) << given.err;
}

// Damaged ICC blocks (garbage, cut short, a PNG iCCP chunk libpng refuses): never a crash, a
// warning that says what is wrong, and the fallback. A profile whose tag table or description
// lies about where it is (past the profile's end) is damage, and the file is refused, never read
// out of bounds (tests/cli/hostile_profiles_test.cpp has every container and command).
TEST(ColourTruth, DamagedIccBlocksNeverCrash) {
    ScratchDir d;
    const std::vector<unsigned char> good = icc_profile("Adobe RGB (1998)");
    std::vector<std::vector<unsigned char>> bad, lying;
    bad.emplace_back(300, 0xa5);                         // garbage
    bad.emplace_back(good.begin(), good.begin() + 131);  // cut inside the header
    lying.push_back(good);
    lying.back()[131] = 0xff;  // tag count: millions
    lying.push_back(good);
    lying.back()[132 + 11] = 0xff;  // the desc tag's length: past the end
    lying.push_back(good);
    // The description's count: 0x7fffffff (the desc tag starts after the table of 8 tags).
    const size_t desc_at = 128 + 4 + 12 * 8;
    for (int k = 0; k < 4; ++k)
        lying.back()[desc_at + 8 + static_cast<size_t>(k)] = k ? 0xff : 0x7f;
    // One batch (one start-up) for all of them: each file's record and warning.
    std::vector<std::string> args = {"bake", "--output-dir", d / "out", "--json", "-", "-q"};
    int n = 0;
    std::vector<std::string> refused;
    for (const auto* set : {&bad, &lying})
        for (const auto& b : *set)
            for (const char* ext : {"tif", "jpg"}) {
                args.push_back(d / ("bad" + std::to_string(n++) + "." + ext));
                write_tagged(args.back(), b);
                if (set == &lying) refused.push_back(args.back());
            }
    // A PNG whose iCCP chunk holds no zlib stream: libpng drops it; spectex says so.
    const std::string plain = d / "plain.png";
    write_tagged(plain, {});
    const std::string png =
        with_chunk(read_file(plain), "iCCP", std::string("Broken\0\0", 8) + std::string(40, 'x'));
    args.push_back(d / "iccp.png");
    std::ofstream(args.back(), std::ios::binary) << png;
    RunResult r = run_spectex(args, {"OCIO="});
    ASSERT_EQ(r.status, 1) << r.err;  // the lying ones failed, the others baked
    size_t records = 0;
    for (size_t b = 0, e; b < r.out.size(); b = e + 1) {
        e = r.out.find('\n', b);
        if (e == std::string::npos) e = r.out.size();
        const json j = json::parse(r.out.substr(b, e - b));
        ++records;
        const std::string input = j["input"];
        SCOPED_TRACE(input);
        if (std::find(refused.begin(), refused.end(), input) != refused.end()) {
            EXPECT_EQ(j["status"], "failed");
            EXPECT_TRUE(has(r.err, "spectex: " + input + ": ICC profile: ")) << r.err;
            continue;
        }
        EXPECT_EQ(j["status"], "ok");
        EXPECT_EQ(j["colorspace"], "sRGB - Texture");
        ASSERT_EQ(j["warnings"].size(), 1u) << j.dump();
        EXPECT_TRUE(has(j["warnings"][0], "ICC profile")) << j.dump();
        EXPECT_TRUE(has(j["warnings"][0], "--colorspace")) << j.dump();
        EXPECT_TRUE(has(r.err, input + ": an embedded ICC profile spectex cannot read (")) << r.err;
    }
    EXPECT_EQ(records, static_cast<size_t>(n) + 1) << r.out;
    EXPECT_EQ(refused.size(), 6u);
}

// Each origin labelled as what it is: a tag the file carries, OpenImageIO's default for the format,
// the config's rules (an explicit one beats OpenImageIO's guess), OpenEXR chromaticities.
TEST(ColourTruth, OriginLabelsSayWhatChoseTheSpace) {
    ScratchDir d;
    write_tagged(d / "untagged.png", {});
    write_tagged(d / "tagged.png", {}, {{"oiio:ColorSpace", "sRGB"}});  // an sRGB chunk
    write_tagged(d / "untagged_tiff.tif", {});
    std::vector<float> px(4 * 4 * 3, 0.25f);
    const std::vector<uint16_t> codes(4 * 4 * 3, 20000);
    write_image(d / "lin_dpx.dpx", 4, 4, 3, OIIO::TypeDesc::UINT16, codes.data(),
                {{"oiio:ColorSpace", "Linear"}});  // DPX transfer: linear
    write_image(d / "plain.exr", 4, 4, 3, OIIO::TypeDesc::FLOAT, px.data());
    {
        OIIO::ImageSpec spec(4, 4, 3, OIIO::TypeDesc::FLOAT);
        const float ap1[8] = {0.713f, 0.293f, 0.165f, 0.830f, 0.128f, 0.044f, 0.32168f, 0.33767f};
        spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), ap1);
        auto out = OIIO::ImageOutput::create(d / "acescg.exr");
        ASSERT_TRUE(out && out->open(d / "acescg.exr", spec) &&
                    out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close());
    }
    // A config rule for normal maps: not overridden by OpenImageIO's guess for PNG.
    std::string cfg = read_file(std::string(SPECTEX_TEST_DATA_DIR) + "/spectex.ocio");
    const std::string rules = "file_rules:\n";
    cfg.replace(cfg.find(rules), rules.size(),
                rules +
                    "  - !<Rule> {name: Normals, pattern: \"*_nrm\", extension: \"png\", "
                    "colorspace: Raw}\n");
    std::ofstream(d / "nrm.ocio") << cfg;
    write_tagged(d / "wall_nrm.png", {});

    // One batch: what each file's record says.
    const std::vector<std::pair<std::string, std::string>> expected = {
        {"untagged.png", "sRGB - Texture | OpenImageIO's default for png files (sRGB)"},
        {"tagged.png", "sRGB - Texture | file metadata: sRGB chunk (sRGB)"},
        {"untagged_tiff.tif", "sRGB - Texture | config file rule 'Default'"},
        {"lin_dpx.dpx", "Linear Rec.709 (sRGB) | file metadata: DPX transfer (Linear)"},
        {"plain.exr", "Linear Rec.709 (sRGB) | config file rule 'OpenEXR'"},
        {"acescg.exr", "ACEScg | OpenEXR chromaticities (ACES AP1)"},
        {"wall_nrm.png", "Raw | config file rule 'Normals'"},
    };
    std::vector<std::string> args = {"bake", "--output-dir", d / "out",  "--json",
                                     "-",    "-q",           "--config", d / "nrm.ocio"};
    for (const auto& e : expected) args.push_back(d / e.first);
    RunResult r = run_spectex(args, {"OCIO="});
    ASSERT_EQ(r.status, 0) << r.err;
    std::map<std::string, std::string> got;  // records come as files finish: keyed by input
    for (size_t b = 0, e; b < r.out.size(); b = e + 1) {
        e = r.out.find('\n', b);
        const json j = json::parse(r.out.substr(b, e - b));
        got[j["input"]] = std::string(j["colorspace"]) + " | " + std::string(j["colorspace_from"]);
    }
    for (const auto& [name, label] : expected) EXPECT_EQ(got[d / name], label) << name;
    // --colorspace says so.
    RunResult given =
        bake_json(d / "untagged_tiff.tif", d / "given.exr", {"--colorspace", "srgb_tx"});
    ASSERT_EQ(given.status, 0) << given.err;
    EXPECT_EQ(bake_record(given)["colorspace_from"], "--colorspace");
}

// A file baked under an ACES 2.x studio config whose config is gone, $OCIO unset: verify warns,
// naming the recorded config and the shipped one it uses instead, and the shipped config knows the
// ACES 2.x names. A name it does not know fails, still after the warning, with encoded suggestions
// for an encoded name.
TEST(ColourTruth, VerifyWarnsWhenTheRecordedConfigIsGone) {
    ScratchDir d;
    const std::string studio = R"(ocio_profile_version: 2
environment: {}
search_path: ""
roles:
  default: sRGB Encoded Rec.709 (sRGB)
  scene_linear: Linear Rec.709 (sRGB)
file_rules:
  - !<Rule> {name: Default, colorspace: sRGB Encoded Rec.709 (sRGB)}
displays:
  sRGB:
    - !<View> {name: Raw, colorspace: Linear Rec.709 (sRGB)}
colorspaces:
  - !<ColorSpace>
    name: Linear Rec.709 (sRGB)
    encoding: scene-linear
  - !<ColorSpace>
    name: sRGB Encoded Rec.709 (sRGB)
    encoding: sdr-video
    from_scene_reference: !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055, direction: inverse}
  - !<ColorSpace>
    name: sRGB Encoded Rec.2020
    encoding: sdr-video
    from_scene_reference: !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055, direction: inverse}
)";
    const std::string config = d / "studio.ocio";
    std::ofstream(config) << studio;
    const std::string src = d / "albedo.tif";
    write_tagged(src, {});
    ASSERT_EQ(run_spectex({"bake", src, "-o", d / "a.exr"}, {"OCIO=" + config}).status, 0);
    ASSERT_EQ(run_spectex({"bake", src, "-o", d / "b.exr", "--colorspace", "sRGB Encoded Rec.2020"},
                          {"OCIO=" + config})
                  .status,
              0);
    std::remove(config.c_str());

    RunResult ok = run_spectex({"verify", d / "a.exr", "--source", src}, {"OCIO="});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_TRUE(has(ok.err, "warning:")) << ok.err;
    EXPECT_TRUE(has(ok.err, config + ") is not there")) << ok.err;
    EXPECT_TRUE(has(ok.err, "the shipped config " + std::string(SPECTEX_TEST_DATA_DIR))) << ok.err;

    RunResult bad = run_spectex({"verify", d / "b.exr", "--source", src}, {"OCIO="});
    EXPECT_EQ(bad.status, 1) << bad.err;
    EXPECT_TRUE(has(bad.err, config + ") is not there")) << bad.err;
    const size_t mean = bad.err.find("(did you mean '");
    ASSERT_NE(mean, std::string::npos) << bad.err;
    const std::string first = bad.err.substr(mean + 15, bad.err.find('\'', mean + 15) - mean - 15);
    EXPECT_FALSE(has(first, "Linear") || has(first, "lin_")) << bad.err;
}

// Suggestions for an unknown name keep its kind: encoded for encoded, linear for linear.
TEST(ColourTruth, UnknownNamesSuggestSpacesOfTheirKind) {
    ScratchDir d;
    write_tagged(d / "a.png", {});
    auto first = [&](const std::string& name) {
        RunResult r =
            run_spectex({"bake", d / "a.png", "-o", d / "a.exr", "--colorspace", name}, {"OCIO="});
        EXPECT_EQ(r.status, 2) << r.err;
        const size_t at = r.err.find("(did you mean '");
        if (at == std::string::npos) return std::string("none: ") + r.err;
        return r.err.substr(at + 15, r.err.find('\'', at + 15) - at - 15);
    };
    for (const char* encoded : {"sRGB Encoded Rec.2020", "Gamma 2.2 Encoded Rec.2020"}) {
        const std::string f = first(encoded);
        EXPECT_FALSE(has(f, "Linear") || has(f, "lin_") || has(f, "none")) << encoded << ": " << f;
    }
    const std::string f = first("Linear Rec.2100");
    EXPECT_TRUE(has(f, "Linear") || has(f, "lin_")) << f;
}
