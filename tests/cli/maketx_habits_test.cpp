// What users of maketx and oiiotool expect of a texture tool, through the binary: bake --dry-run
// (each input -> output and what --update would do, from headers only, writing nothing), the
// wrap modes recorded as maketx records them (--wrap, --swrap, --twrap: the "wrapmodes"
// attribute OpenImageIO reads), and lights given by colour temperature ("3200K") in every
// command that takes a light.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

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

// --dry-run lists each input -> output, what would be done and what --update would say, and
// creates nothing: no output, no --output-dir, no temporary file.
TEST(MaketxHabits, DryRunListsEachInputAndWritesNothing) {
    ScratchDir d;
    run_shell("mkdir '" + d / "in" + "'");
    const std::string a = make_png(d / "in/a.png", 1), b = make_png(d / "in/b.png", 2);
    const std::string before = tree(d.path());
    RunResult r = run_spectex({"bake", a, b, "--output-dir", d / "out", "--dry-run"});
    ASSERT_EQ(r.status, 0) << r.err;
    const auto lines = lines_of(r.out);
    ASSERT_EQ(lines.size(), 2u) << r.out;
    EXPECT_EQ(lines[0].rfind("bake " + a + " -> " + d / "out/a.exr" + ": 8x8, 3 channels, png, " +
                                 "colour space '",
                             0),
              0u)
        << lines[0];
    EXPECT_TRUE(contains(lines[0], "--update would bake it: no readable output")) << lines[0];
    EXPECT_EQ(lines[1].rfind("bake " + b + " -> " + d / "out/b.exr", 0), 0u) << lines[1];
    EXPECT_TRUE(contains(r.err,
                         "dry run: 2 would be baked, 0 skipped as up to date, 0 would "
                         "fail, of 2"))
        << r.err;
    EXPECT_FALSE(file_exists(d / "out"));
    EXPECT_EQ(tree(d.path()), before);

    // -n, as oiiotool spells it, with a template whose folders a real run would create.
    r = run_spectex({"bake", a, "-o", d / "new/{stem}.spectral.exr", "-n", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out.rfind("bake " + a + " -> " + d / "new/a.spectral.exr" + ": ", 0), 0u) << r.out;
    EXPECT_EQ(r.err, "");  // -q: the listing only
    EXPECT_EQ(tree(d.path()), before);
}

// No pixel is read: an OpenEXR whose header is valid but whose pixel data is destroyed fails a
// real bake and dry-runs as one that would be baked.
TEST(MaketxHabits, DryRunReadsHeadersOnly) {
    ScratchDir d;
    const int w = 256, h = 256;
    std::vector<float> px(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < px.size(); ++i)
        px[i] = 0.5f + 0.4f * std::sin(0.01f * static_cast<float>(i % 977) + (i % 3));
    const std::string in = d / "damaged.exr";
    write_image(in, w, h, 3, OIIO::TypeDesc::FLOAT, px.data(), {{"compression", "zip"}});
    struct stat st;
    ASSERT_EQ(::stat(in.c_str(), &st), 0);
    ASSERT_GT(st.st_size, 20000);  // the pixel data is most of the file
    {
        // The last half of the file: compressed pixel data, well past the header and offsets.
        std::fstream f(in, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(st.st_size / 2);
        const std::string junk(static_cast<size_t>(st.st_size - st.st_size / 2), '\x5a');
        f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
    }
    RunResult real = run_spectex({"bake", in, "-o", d / "real.exr", "-q"});
    EXPECT_EQ(real.status, 1) << real.err;  // the data really is unreadable
    EXPECT_FALSE(file_exists(d / "real.exr"));
    RunResult dry = run_spectex({"bake", in, "-o", d / "dry.exr", "--dry-run"});
    EXPECT_EQ(dry.status, 0) << dry.err;
    EXPECT_EQ(
        dry.out.rfind(
            "bake " + in + " -> " + d / "dry.exr" + ": 256x256, 3 channels, " + "openexr, ", 0),
        0u)
        << dry.out;
    EXPECT_FALSE(file_exists(d / "dry.exr"));
}

// With --update, each file is skipped or baked for the reason --update gives: up to date, its
// source changed, no output, other settings. Nothing is touched.
TEST(MaketxHabits, DryRunSaysWhatUpdateWouldDoAndWhy) {
    ScratchDir d;
    run_shell("mkdir '" + d / "in" + "'");
    const std::string a = make_png(d / "in/a.png", 1), b = make_png(d / "in/b.png", 2),
                      c = make_png(d / "in/c.png", 3);
    const std::vector<std::string> bake = {"bake", a, b, c, "--output-dir", d / "out", "-q"};
    ASSERT_EQ(run_spectex(bake).status, 0);
    make_png(b, 7);  // another picture under the same name
    ASSERT_EQ(std::remove((d / "out/c.exr").c_str()), 0);
    const std::string before = tree(d.path());

    RunResult r = run_spectex(with(bake, {"--update", "--dry-run"}));
    ASSERT_EQ(r.status, 0) << r.err;
    auto lines = lines_of(r.out);
    ASSERT_EQ(lines.size(), 3u) << r.out;
    EXPECT_EQ(lines[0], "skip " + a + " -> " + d / "out/a.exr" +
                            ": up to date: same settings hash, source size and modification time");
    EXPECT_EQ(lines[1].rfind("bake " + b + " -> " + d / "out/b.exr", 0), 0u) << lines[1];
    EXPECT_TRUE(contains(lines[1], "; not up to date: the source's")) << lines[1];
    EXPECT_TRUE(contains(lines[2], "; not up to date: no readable output")) << lines[2];

    // Without --update every file would be baked; the listing says what --update would do.
    r = run_spectex(with(bake, {"--dry-run"}));
    ASSERT_EQ(r.status, 0) << r.err;
    lines = lines_of(r.out);
    ASSERT_EQ(lines.size(), 3u) << r.out;
    EXPECT_EQ(lines[0].rfind("bake " + a, 0), 0u) << lines[0];
    EXPECT_TRUE(contains(lines[0], "; --update would skip it: up to date")) << lines[0];
    EXPECT_TRUE(contains(lines[1], "; --update would bake it: the source's")) << lines[1];

    // Other settings: every file.
    r = run_spectex(with(bake, {"--update", "--dry-run", "--zip-level", "6"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(count(r.out, "; not up to date: other settings\n"), 2u) << r.out;
    EXPECT_TRUE(contains(r.out, "; not up to date: no readable output")) << r.out;
    EXPECT_EQ(tree(d.path()), before);
}

// The checks of a real run, with its exit status: two inputs for one output is a usage error
// (2) before any file; a missing input or an output folder that cannot be made fails that file
// (1), named on stderr as a real run names it, the other files listed.
TEST(MaketxHabits, DryRunChecksAsARealRun) {
    ScratchDir d;
    const std::string a = make_png(d / "a.png", 1);
    std::vector<uint8_t> px(8 * 8 * 3, 100);
    write_image(d / "a.tif", 8, 8, 3, OIIO::TypeDesc::UINT8, px.data());
    RunResult r = run_spectex({"bake", a, d / "a.tif", "--output-dir", d / "out", "--dry-run"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "would write an output another input writes")) << r.err;
    EXPECT_EQ(r.out, "");

    const std::string missing = d / "missing.png";
    RunResult real = run_spectex({"bake", a, missing, "--output-dir", d / "real", "-q"});
    r = run_spectex({"bake", a, missing, "--output-dir", d / "out", "--dry-run"});
    EXPECT_EQ(real.status, 1);
    EXPECT_EQ(r.status, 1) << r.err;
    auto lines = lines_of(r.out);
    ASSERT_EQ(lines.size(), 2u) << r.out;
    EXPECT_EQ(lines[0].rfind("bake " + a, 0), 0u) << lines[0];
    EXPECT_EQ(lines[1].rfind("fail " + missing + " -> " + d / "out/missing.exr" + ": ", 0), 0u)
        << lines[1];
    EXPECT_TRUE(contains(r.err, "spectex: " + missing)) << r.err;
    EXPECT_TRUE(contains(r.err, "1 would be baked, 0 skipped as up to date, 1 would fail"))
        << r.err;
    EXPECT_FALSE(file_exists(d / "out"));

    // One -o into a folder that does not exist (a real run does not create it) and one below a
    // file (no folder can be made there).
    r = run_spectex({"bake", a, "-o", d / "nowhere/a.exr", "--dry-run"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(contains(r.out, "the output's folder does not exist")) << r.out;
    r = run_spectex({"bake", a, "-o", d / "a.png/x/{stem}.exr", "--dry-run"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(contains(r.out, "cannot create the output folder")) << r.out;

    // Usage errors are usage errors.
    EXPECT_EQ(run_spectex({"bake", a, "--dry-run"}).status, 2);
}

// --json: one record per file, "dry_run": true, a status that cannot be taken for a real run's,
// and nothing else on stdout.
TEST(MaketxHabits, DryRunJsonRecords) {
    ScratchDir d;
    const std::string a = make_png(d / "a.png", 1), b = make_png(d / "b.png", 2);
    ASSERT_EQ(run_spectex({"bake", a, "-o", d / "{stem}.exr", "-q"}).status, 0);
    RunResult r =
        run_spectex({"bake", a, b, "-o", d / "{stem}.exr", "--update", "--dry-run", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    const auto records = parse_lines(r.out);
    ASSERT_EQ(records.size(), 2u) << r.out;
    EXPECT_EQ(records[0]["dry_run"], true);
    EXPECT_EQ(records[0]["status"], "would_skip");
    EXPECT_EQ(records[0]["update_would_skip"], true);
    EXPECT_EQ(records[0]["input"], a);
    EXPECT_EQ(records[1]["status"], "would_bake");
    EXPECT_EQ(records[1]["reason"], "no readable output");
    EXPECT_EQ(records[1]["width"], 8);
    EXPECT_EQ(records[1]["channels"], 3);
    EXPECT_FALSE(records[1]["colorspace"].get<std::string>().empty());
    EXPECT_EQ(records[1]["error"], nullptr);
    EXPECT_FALSE(file_exists(d / "b.exr"));
}

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
    const std::vector<std::string> bake = {"bake",  a,          "-o",     out, "--mipmap", "--type",
                                           "float", "--update", "--json", "-", "-q"};
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
    RunResult r =
        run_spectex({"bake", a, "-o", exr, "--type", "float", "-q", "--illuminant", "3200 k"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_exr(exr).attr("spectex:illuminant"), "3200K");
    // verify integrates under the light the file records: exact under 3200 K.
    r = run_spectex({"verify", exr, "--source", a, "--max-de", "0.01", "--min-code-match", "100",
                     "--illuminant", "6500k,2700K,6500K"});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_TRUE(contains(r.out, "integrated under:     3200K")) << r.out;
    EXPECT_EQ(count(r.out, "under 6500K (Bradford"), 1u) << r.out;
    EXPECT_EQ(count(r.out, "under 2700K (Bradford"), 1u) << r.out;
    r = run_spectex(
        {"verify", exr, "--check-illuminant", "3200K", "--source", a, "--max-de", "0.01"});
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
                     "380:780:20", "--colours", "sample", "--max-de", "100", "--precision", "full",
                     "--json", "-"});
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
        {{"plot", exr, "--pixel", "0,0", "-o", d / "x.svg", "--light", "40000K"},
         "--light",
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
