// The shipped CIE illuminants through the binary: listed by --help of every command that takes
// --illuminant, usable by name (any case) in bake, basis and verify, and an unknown name refused
// with the list.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

// Mirrors shipped_illuminants() (src/spectral/spectrum.cpp): the binary's help must name them all.
const std::vector<std::string> kShipped = {
    "D65",    "D50",    "D55",    "D75",    "A",       "FL1",      "FL2",    "FL3",   "FL4",
    "FL5",    "FL6",    "FL7",    "FL8",    "FL9",     "FL10",     "FL11",   "FL12",  "LED-B1",
    "LED-B2", "LED-B3", "LED-B4", "LED-B5", "LED-BH1", "LED-RGB1", "LED-V1", "LED-V2"};

bool contains(const std::string& s, const std::string& sub) {
    return s.find(sub) != std::string::npos;
}

// The --illuminant entry of a command's help, its wrapped lines joined with single spaces.
std::string illuminant_help(const std::string& command) {
    RunResult r = run_spectex({command, "--help"});
    EXPECT_EQ(r.status, 0) << r.err;
    size_t at = r.out.find("--illuminant");
    if (at == std::string::npos) return "";
    size_t end = r.out.find("\n  -", at);  // the next option
    std::string entry = r.out.substr(at, end == std::string::npos ? std::string::npos : end - at);
    std::string joined;
    bool space = false;
    for (char c : entry) {
        if (c == ' ' || c == '\n') {
            space = true;
            continue;
        }
        if (space && !joined.empty()) joined += ' ';
        space = false;
        joined += c;
    }
    return joined;
}

std::string make_png(const ScratchDir& d, const std::string& name, int w, int h) {
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 37 + 11) & 0xff);
    const uint8_t fixed[5][3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {0, 0, 0}, {255, 255, 255}};
    for (int i = 0; i < 5; ++i)
        for (int c = 0; c < 3; ++c) px[static_cast<size_t>(i) * 3 + c] = fixed[i][c];
    std::string path = d / name;
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

}  // namespace

TEST(Illuminants, HelpOfBakeBasisAndVerifyListsEveryShippedName) {
    for (const char* command : {"bake", "basis", "verify"}) {
        std::string h = illuminant_help(command);
        SCOPED_TRACE(command);
        ASSERT_FALSE(h.empty());
        EXPECT_TRUE(contains(h, "D65 (default), D50, D55, D75, A, FL1, FL2,")) << h;
        EXPECT_TRUE(contains(h, "LED-B3,")) << h;
        EXPECT_TRUE(contains(h, "FL2,")) << h;
        for (const auto& name : kShipped)
            EXPECT_TRUE(contains(h, " " + name + ",") || contains(h, " " + name + " "))
                << name << " missing from: " << h;
        EXPECT_TRUE(contains(h, "or a CSV")) << h;
    }
}

TEST(Illuminants, BakeUnderD50IsExactUnderD50) {
    ScratchDir d;
    std::string png = make_png(d, "in.png", 8, 4);
    std::string exr = d / "out.exr";
    RunResult b =
        run_spectex({"bake", png, "-o", exr, "--type", "float", "-q", "--illuminant", "D50"});
    ASSERT_EQ(b.status, 0) << b.err;
    ExrImage img = read_exr(exr);
    EXPECT_EQ(img.attr("spectex:illuminant"), "D50");
    EXPECT_EQ(spectral_channels(img).size(), kDefaultBins);
    // The basis was fitted under D50: integrated under D50 every pixel is the source colour.
    RunResult v = run_spectex({"verify", exr, "--source", png, "--illuminant", "D50", "--max-de",
                               "0.01", "--min-code-match", "100"});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
}

TEST(Illuminants, NamesWorkInAnyCaseInBakeAndBasis) {
    ScratchDir d;
    std::string png = make_png(d, "in.png", 4, 4);
    // --precision full: under another illuminant the default's bits are a choice of their own
    // (whole-cube passes), which is not what this test is about.
    RunResult b = run_spectex(
        {"bake", png, "-o", d / "o.exr", "-q", "--illuminant", "led-rgb1", "--precision", "full"});
    EXPECT_EQ(b.status, 0) << b.err;
    RunResult f = run_spectex({"basis", "-q", "-o", d / "b.csv", "--illuminant", "fl12"});
    EXPECT_EQ(f.status, 0) << f.err;
    EXPECT_TRUE(file_exists(d / "b.csv"));
}

// Under LED-B3 (and FL1-FL6, FL9, LED-B1-B5) no reflectance basis reproduces the sRGB primaries on
// 380:780:5: bake says so, and --allow-infeasible bakes the closest one.
TEST(Illuminants, InfeasibleIlluminantIsReportedAndAllowInfeasibleBakes) {
    ScratchDir d;
    std::string png = make_png(d, "in.png", 4, 4);
    RunResult r = run_spectex(
        {"bake", png, "-o", d / "o.exr", "-q", "--method", "basis", "--illuminant", "LED-B3"});
    EXPECT_EQ(r.status, 2);  // a setting no file can be baked with: checked once, before any input
    EXPECT_TRUE(contains(r.err, "no basis reproduces these primaries")) << r.err;
    EXPECT_TRUE(contains(r.err, "--allow-infeasible")) << r.err;
    // The default lattice has vertices no reflectance reaches there either, and says the same way
    // out (--allow-infeasible belongs to the basis, so it takes it).
    r = run_spectex({"bake", png, "-o", d / "o.exr", "-q", "--illuminant", "LED-B3"});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "no reflectance in [0, 1] has this colour")) << r.err;
    EXPECT_TRUE(contains(r.err, "--allow-infeasible")) << r.err;
    RunResult a = run_spectex(
        {"bake", png, "-o", d / "o.exr", "-q", "--illuminant", "LED-B3", "--allow-infeasible"});
    EXPECT_EQ(a.status, 0) << a.err;
    EXPECT_TRUE(file_exists(d / "o.exr"));
}

TEST(Illuminants, UnknownNameIsRefusedWithTheList) {
    ScratchDir d;
    RunResult r = run_spectex({"basis", "-q", "-o", d / "b.csv", "--illuminant", "FL13"});
    EXPECT_NE(r.status, 0);
    EXPECT_TRUE(contains(r.err, "unknown illuminant 'FL13'")) << r.err;
    EXPECT_TRUE(contains(r.err, "LED-V2")) << r.err;
    EXPECT_TRUE(contains(r.err, "FL12")) << r.err;
    EXPECT_FALSE(file_exists(d / "b.csv"));
}

// An unknown illuminant or observer name is a usage error (exit 2) naming the option, in every
// command: a setting, not the file, is at fault.
TEST(Illuminants, UnknownIlluminantIsAUsageErrorNamingTheOption) {
    ScratchDir d;
    const std::string exr = bake_albedo(d), in = d / "albedo.png";
    const std::vector<std::pair<std::vector<std::string>, std::string>> runs = {
        {{"bake", in, "-o", d / "o.exr", "--illuminant", "Tungsten"}, "--illuminant"},
        {{"render", exr, "-o", d / "r.png", "--illuminant", "Tungsten"}, "--illuminant"},
        {{"verify", exr, "--check-illuminant", "Tungsten"}, "--check-illuminant"},
        {{"verify", exr, "--illuminant", "Tungsten"}, "--illuminant"},
        {{"plan", "--illuminant", "Tungsten"}, "--illuminant"},
        {{"plan", "--lights", "Tungsten"}, "--lights"},
        {{"sample", exr, "1,1", "--illuminant", "Tungsten"}, "--illuminant"},
        {{"plot", exr, "--pixel", "1,1", "-o", d / "p.svg", "--light", "Tungsten"}, "--light"},
        {{"basis", "-o", d / "basis.csv", "--illuminant", "Tungsten"}, "--illuminant"},
        {{"render", exr, "-o", d / "r.png", "--observer", "cie2020"}, "--observer"},
    };
    for (const auto& [args, option] : runs) {
        RunResult r = run_spectex(args);
        EXPECT_EQ(r.status, 2) << args[0] << ": " << r.err;
        EXPECT_NE(r.err.find(option + ": unknown"), std::string::npos) << args[0] << ": " << r.err;
        EXPECT_EQ(r.err.find(exr + ":"), std::string::npos) << "blames the file: " << r.err;
    }
}
