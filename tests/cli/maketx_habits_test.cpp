// What users of maketx and oiiotool expect of a texture tool, through the binary: bake --dry-run
// (each input -> output and what --update would do, from headers only, writing nothing), the
// wrap modes recorded as maketx records them (--wrap, --swrap, --twrap: the "wrapmodes"
// attribute OpenImageIO reads), and lights given by colour temperature ("3200K") in every
// command that takes a light.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <OpenImageIO/imageio.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;
using nlohmann::json;

namespace {

bool contains(const std::string& s, const std::string& sub) {
    return s.find(sub) != std::string::npos;
}

size_t count(const std::string& s, const std::string& sub) {
    size_t n = 0;
    for (size_t at = s.find(sub); at != std::string::npos; at = s.find(sub, at + 1)) ++n;
    return n;
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
}

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

// An 8-bit RGB PNG whose pixels depend on `seed`.
std::string make_png(const std::string& path, int seed = 0, int w = 8, int h = 8) {
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < px.size(); ++i)
        px[i] = static_cast<uint8_t>((i * 37 + 11 + static_cast<size_t>(seed) * 101) & 0xff);
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

// Every path below `dir` with its size and modification time: what a run that writes nothing
// leaves as it was.
std::string tree(const std::string& dir) {
    return run_shell("cd '" + dir + "' && find . -printf '%p %s %T@\\n' | sort").out;
}

// A string attribute of subimage 0, MIP level `level`, as OpenImageIO reads it ("" when absent).
std::string oiio_attribute(const std::string& path, const std::string& name, int level = 0) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) return "<unreadable: " + OIIO::geterror() + ">";
    if (level > 0 && !in->seek_subimage(0, level)) return "<no level>";
    return in->spec().get_string_attribute(name);
}

// Every MIP level of a file, as float, in OpenImageIO's order.
std::vector<std::vector<float>> all_levels(const std::string& path) {
    std::vector<std::vector<float>> out;
    auto in = OIIO::ImageInput::open(path);
    if (!in) return out;
    for (int level = 0; in->seek_subimage(0, level); ++level) {
        const OIIO::ImageSpec& s = in->spec();
        std::vector<float> px(s.image_pixels() * static_cast<size_t>(s.nchannels));
        if (!in->read_image(0, level, 0, s.nchannels, OIIO::TypeDesc::FLOAT, px.data())) break;
        out.push_back(std::move(px));
    }
    return out;
}

std::vector<json> parse_lines(const std::string& text) {
    std::vector<json> out;
    for (const auto& line : lines_of(text)) {
        try {
            out.push_back(json::parse(line));
        } catch (const json::exception& e) {
            ADD_FAILURE() << e.what() << ": " << line;
        }
    }
    return out;
}

}  // namespace

// The "wrapmodes" attribute as maketx writes it: "s,t"; black,black in every tiled file without
// --wrap, nothing in a scanline one; --swrap and --twrap over --wrap. OpenImageIO reads it (what
// `iinfo -v` prints), from both OpenEXR writers (zip: the core writer; piz: OpenEXR's Imf).
TEST(MaketxHabits, WrapModesAreRecordedAsMaketxRecordsThem) {
    ScratchDir d;
    const std::string a = make_png(d / "a.png", 1);
    struct Case {
        std::vector<std::string> args;
        std::string expected;  // "" absent
    };
    const std::vector<Case> cases = {
        {{"--mipmap"}, "black,black"},
        {{"--mipmap", "--wrap", "periodic"}, "periodic,periodic"},
        {{"--mipmap", "--wrap", "clamp,mirror"}, "clamp,mirror"},
        {{"--tile", "4", "--swrap", "periodic"}, "periodic,black"},
        {{"--mipmap", "--wrap", "clamp", "--twrap", "Mirror"}, "clamp,mirror"},
        {{"--mipmap", "--compression", "piz", "--wrap", "mirror"}, "mirror,mirror"},
        {{"--wrap", "periodic"}, "periodic,periodic"},
        {{"--compression", "piz", "--twrap", "clamp"}, "black,clamp"},
        {{}, ""},
    };
    for (const auto& c : cases) {
        std::string label;
        for (const auto& s : c.args) label += s + " ";
        SCOPED_TRACE(label);
        const std::string out = d / "out.exr";
        RunResult r = run_spectex(with({"bake", a, "-o", out, "-q"}, c.args));
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_EQ(oiio_attribute(out, "wrapmodes"), c.expected);
        EXPECT_EQ(read_exr(out).attr("wrapmodes"), c.expected);  // a string attribute
    }
}

TEST(MaketxHabits, UnknownWrapModeIsAUsageErrorNamingTheOption) {
    ScratchDir d;
    const std::string a = make_png(d / "a.png", 1);
    for (const auto& [option, value] :
         std::vector<std::pair<std::string, std::string>>{{"--wrap", "repeat"},
                                                          {"--wrap", "clamp,"},
                                                          {"--wrap", "clamp,periodic,black"},
                                                          {"--swrap", "edge"},
                                                          {"--twrap", "periodic,"}}) {
        RunResult r = run_spectex({"bake", a, "-o", d / "o.exr", option, value});
        EXPECT_EQ(r.status, 2) << option << " " << value << ": " << r.err;
        EXPECT_TRUE(contains(r.err, option + ": '")) << r.err;
        EXPECT_TRUE(contains(r.err, "black, clamp, periodic or mirror")) << r.err;
        EXPECT_FALSE(file_exists(d / "o.exr"));
    }
}

// The wrap mode is a setting --update compares (another mode rebuilds the file; --wrap black on a
// tiled file writes what no --wrap writes, and rebuilds nothing), and it changes no pixel of any
// MIP level: the box filter averages inside the image whatever the mode.
TEST(MaketxHabits, WrapIsASettingOfUpdateAndChangesNoPixel) {
    ScratchDir d;
    const std::string a = make_png(d / "a.png", 1, 13, 7);  // odd sizes: fractional boxes
    const std::string out = d / "t.exr";
    const std::vector<std::string> bake = {"bake", a, "-o", out, "--mipmap", "--type", "float",
                                           "--update", "--json", "-", "-q"};
    RunResult r = run_spectex(bake);
    ASSERT_EQ(r.status, 0) << r.err;
    const auto levels = all_levels(out);
    ASSERT_EQ(levels.size(), 4u);  // 13x7, 6x3, 3x1, 1x1
    r = run_spectex(with(bake, {"--wrap", "black"}));
    EXPECT_EQ(count(r.out, "\"status\":\"skipped\""), 1u) << r.out;
    r = run_spectex(with(bake, {"--wrap", "periodic"}));
    EXPECT_EQ(count(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_EQ(oiio_attribute(out, "wrapmodes"), "periodic,periodic");
    EXPECT_EQ(all_levels(out), levels);
    r = run_spectex(with(bake, {"--wrap", "periodic"}));
    EXPECT_EQ(count(r.out, "\"status\":\"skipped\""), 1u) << r.out;
    r = run_spectex(with(bake, {"--wrap", "periodic,clamp"}));
    EXPECT_EQ(count(r.out, "\"status\":\"ok\""), 1u) << r.out;
}

// A light by colour temperature, in every command that takes one; the name is canonical (3200K)
// in headers, reports and JSON, and 3200K and 3200k are one light.
TEST(MaketxHabits, ColourTemperaturesInEveryCommandThatTakesALight) {
    ScratchDir d;
    const std::string a = make_png(d / "a.png", 1);
    const std::string exr = d / "warm.exr";
    RunResult r = run_spectex({"bake", a, "-o", exr, "--type", "float", "-q", "--illuminant",
                               "3200 k"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_exr(exr).attr("spectex:illuminant"), "3200K");
    // verify integrates under the light the file records: exact under 3200 K.
    r = run_spectex({"verify", exr, "--source", a, "--max-de", "0.01", "--min-code-match", "100",
                     "--illuminant", "6500k,2700K,6500K"});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_TRUE(contains(r.out, "integrated under:     3200K")) << r.out;
    EXPECT_EQ(count(r.out, "under 6500K (Bradford"), 1u) << r.out;
    EXPECT_EQ(count(r.out, "under 2700K (Bradford"), 1u) << r.out;
    r = run_spectex({"verify", exr, "--check-illuminant", "3200K", "--source", a, "--max-de",
                     "0.01"});
    EXPECT_EQ(r.status, 0) << r.out << r.err;

    r = run_spectex({"sample", exr, "1,1", "--illuminant", "5000K,5000k", "--json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const json j = json::parse(r.out);
    ASSERT_EQ(j["illuminants"].size(), 2u) << r.out;  // D65 and 5000K
    EXPECT_EQ(j["illuminants"][1]["name"], "5000K") << r.out;

    r = run_spectex({"render", exr, "-o", d / "sheet.png", "--illuminant", "2700K,6500K"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(file_exists(d / "sheet.png"));
    r = run_spectex({"plot", exr, "--pixel", "0,0", "-o", d / "p.svg", "--light", "3200K"});
    EXPECT_EQ(r.status, 0) << r.err;
    r = run_spectex({"basis", "-q", "-o", d / "b.csv", "--illuminant", "2856K"});
    EXPECT_EQ(r.status, 0) << r.err;

    r = run_spectex({"plan", "--lights", "3200K,5000k,3200k", "--illuminant", "6504K", "--grids",
                     "380:780:20", "--colours", "sample", "--max-de", "100", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(json::parse(r.out)["lights"], json::array({"3200K", "5000K"})) << r.out;
    r = run_spectex({"bake", "--help"});
    EXPECT_TRUE(contains(r.out, "3200K")) << r.out;
}

// bake --wavelengths auto --lights: the plan measures the whole cube (some 15 s), hence Slow.
TEST(MaketxHabitsSlow, BakeAutoTakesColourTemperatureLights) {
    ScratchDir d;
    const std::string a = make_png(d / "a.png", 1);
    RunResult r = run_spectex({"bake", a, "-o", d / "auto.exr", "-q", "--wavelengths", "auto",
                               "--lights", "2700k", "--grids", "380:780:20", "--max-de", "100"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_exr(d / "auto.exr").attr("spectex:planLights"), "2700K");
}

// A temperature outside 1000K..25000K, or not whole kelvin, is a usage error naming the option,
// in every command.
TEST(MaketxHabits, ColourTemperatureOutsideTheRangeIsAUsageError) {
    ScratchDir d;
    const std::string a = make_png(d / "a.png", 1);
    const std::string exr = d / "o.exr";
    ASSERT_EQ(run_spectex({"bake", a, "-o", exr, "-q"}).status, 0);
    struct Case {
        std::vector<std::string> args;
        std::string option, value;
    };
    const std::vector<Case> cases = {
        {{"bake", a, "-o", d / "x.exr", "--illuminant", "500K"}, "--illuminant", "500K"},
        {{"bake", a, "-o", d / "x.exr", "--wavelengths", "auto", "--max-de", "1", "--lights",
          "30000K"},
         "--lights",
         "30000K"},
        {{"verify", exr, "--check-illuminant", "999K"}, "--check-illuminant", "999K"},
        {{"verify", exr, "--illuminant", "6500.5K"}, "--illuminant", "6500.5K"},
        {{"sample", exr, "0,0", "--illuminant", "26000K"}, "--illuminant", "26000K"},
        {{"render", exr, "-o", d / "x.png", "--illuminant", "-3200K"}, "--illuminant", "-3200K"},
        {{"plot", exr, "--pixel", "0,0", "-o", d / "x.svg", "--light", "40000K"}, "--light",
         "40000K"},
        {{"basis", "-o", d / "x.csv", "--illuminant", "900K"}, "--illuminant", "900K"},
        {{"plan", "--lights", "D65,500K"}, "--lights", "500K"},
        {{"plan", "--illuminant", "1e4K"}, "--illuminant", "1e4K"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.args[0] + " " + c.option + " " + c.value);
        RunResult r = run_spectex(c.args);
        EXPECT_EQ(r.status, 2) << r.err;
        EXPECT_TRUE(contains(r.err, c.option + ": '" + c.value + "' is not a colour temperature"))
            << r.err;
        EXPECT_TRUE(contains(r.err, "1000K to 25000K")) << r.err;
    }
    EXPECT_FALSE(file_exists(d / "x.exr"));
    EXPECT_FALSE(file_exists(d / "x.png"));
}
