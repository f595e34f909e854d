// End-to-end checks of what a studio trial found: lossy compressions taken silently, singular
// observers and lights accepted by some commands, small untruths in output and the man page, and
// settings errors blamed on the file with the exit status of a failed file.
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "cli_util.h"

using namespace spectex_test;

namespace {

// A 16x16 8-bit sRGB ramp: saturated and dark colours, the ones b44 moves most.
std::string write_albedo(const ScratchDir& d) {
    std::vector<unsigned char> px(16 * 16 * 3);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            unsigned char* p = &px[(y * 16 + x) * 3];
            p[0] = static_cast<unsigned char>(x * 17);
            p[1] = static_cast<unsigned char>(y * 17);
            p[2] = static_cast<unsigned char>(((x + y) % 3) * 120);
        }
    const std::string path = d / "albedo.png";
    write_image(path, 16, 16, 3, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

std::string bake_default(const ScratchDir& d) {
    const std::string exr = d / "b.exr";
    RunResult r = run_spectex({"bake", write_albedo(d), "-o", exr, "-q"});
    if (r.status != 0) ADD_FAILURE() << r.err;
    return exr;
}

void write_text(const std::string& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

// An observer with x = y = z at every wavelength: its colours lie on one line.
std::string write_degenerate_observer(const ScratchDir& d) {
    std::string t = "wavelength,x,y,z\n";
    for (int l = 360; l <= 830; l += 5) t += std::to_string(l) + ",0.5,0.5,0.5\n";
    write_text(d / "flat_observer.csv", t);
    return d / "flat_observer.csv";
}

std::string write_dark_light(const ScratchDir& d) {
    std::string t = "wavelength,value\n";
    for (int l = 300; l <= 830; l += 5) t += std::to_string(l) + ",0\n";
    write_text(d / "dark.csv", t);
    return d / "dark.csv";
}

}  // namespace

// 1. Lossy compressions.
TEST(StudioTrial, LossyCompressionIsRefusedUnlessAllowed) {
    ScratchDir d;
    const std::string in = write_albedo(d);
    for (const std::string& c : {"b44", "b44a", "dwaa", "dwab"}) {
        RunResult r = run_spectex({"bake", in, "-o", d / (c + ".exr"), "--compression", c});
        EXPECT_EQ(r.status, 2) << c << ": " << r.err;
        EXPECT_NE(r.err.find("--compression"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("lossy"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("--allow-lossy"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("zip"), std::string::npos) << "suggests a lossless one: " << r.err;
        EXPECT_FALSE(file_exists(d / (c + ".exr"))) << c;
    }
    // Float: pxr24 rounds float samples, so it is refused there; b44 keeps float whole.
    RunResult f =
        run_spectex({"bake", in, "-o", d / "p.exr", "--type", "float", "--compression", "pxr24"});
    EXPECT_EQ(f.status, 2) << f.err;
    // Lossless for half: pxr24 keeps half samples exactly.
    RunResult h = run_spectex({"bake", in, "-o", d / "h.exr", "--compression", "pxr24", "-q"});
    EXPECT_EQ(h.status, 0) << h.err;
}

TEST(StudioTrial, AllowedLossyCompressionIsRecordedAndNamedByVerify) {
    ScratchDir d;
    const std::string in = write_albedo(d), exr = d / "b.exr";
    RunResult b = run_spectex({"bake", in, "-o", exr, "--compression", "b44", "--allow-lossy"});
    ASSERT_EQ(b.status, 0) << b.err;
    RunResult i = run_spectex({"info", exr});
    EXPECT_NE(i.out.find("spectex:lossyCompression"), std::string::npos) << i.out;
    EXPECT_NE(i.out.find("b44 (lossy for half)"), std::string::npos) << i.out;
    RunResult v = run_spectex({"verify", exr, "--source", in});
    EXPECT_EQ(v.status, 1) << v.out << v.err;  // b44 moves samples out of [0, 1]
    EXPECT_NE(v.out.find("FAILED"), std::string::npos) << v.out;
    EXPECT_NE(v.out.find("compression, b44 (lossy for half), changed the samples"),
              std::string::npos)
        << v.out;
}

TEST(StudioTrial, HelpMarksLossyCompressions) {
    RunResult r = run_spectex({"bake", "--help"});
    EXPECT_NE(r.out.find("pxr24 (lossy for float)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("dwaa (lossy)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--allow-lossy"), std::string::npos) << r.out;
}

// 2. Singular observers and lights, refused by every command that takes them.
TEST(StudioTrial, SingularObserverAndDarkLightAreRefusedEverywhere) {
    ScratchDir d;
    const std::string exr = bake_default(d), in = d / "albedo.png";
    const std::string obs = write_degenerate_observer(d), dark = write_dark_light(d);
    const std::vector<std::vector<std::string>> runs = {
        {"bake", in, "-o", d / "o.exr", "--observer", obs},
        {"verify", exr, "--observer", obs},
        {"basis", "-o", d / "basis.csv", "--observer", obs},
        {"plan", "--observer", obs},
        {"sample", exr, "1,1", "--observer", obs},
        {"render", exr, "-o", d / "r.png", "--observer", obs},
        {"plot", exr, "--pixel", "1,1", "-o", d / "p.svg", "--observer", obs},
        {"bake", in, "-o", d / "o.exr", "--illuminant", dark},
        {"verify", exr, "--check-illuminant", dark},
        {"render", exr, "-o", d / "r.png", "--illuminant", dark},
        {"sample", exr, "1,1", "--illuminant", dark},
        {"plot", exr, "--pixel", "1,1", "-o", d / "p.svg", "--light", dark},
    };
    for (const auto& args : runs) {
        RunResult r = run_spectex(args);
        EXPECT_EQ(r.status, 2) << args[0] << " " << args[args.size() - 2] << ": " << r.out << r.err;
        const bool names = r.err.find("singular") != std::string::npos ||
                           r.err.find("zero power") != std::string::npos;
        EXPECT_TRUE(names) << args[0] << ": " << r.err;
        // The table is named once: "<option>: <file>: observer is singular ...".
        const std::string& table = args.back();
        size_t n = 0;
        for (size_t p = r.err.find(table); p != std::string::npos; p = r.err.find(table, p + 1))
            ++n;
        EXPECT_EQ(n, 1u) << args[0] << ": " << r.err;
    }
}

// 3. Small untruths.
TEST(StudioTrial, PlotRefusesAnOutputThatIsNotSvgAndCountsRight) {
    ScratchDir d;
    const std::string exr = bake_default(d);
    RunResult r = run_spectex({"plot", exr, "--pixel", "1,1", "-o", d / "p.png"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find(".svg"), std::string::npos) << r.err;
    EXPECT_FALSE(file_exists(d / "p.png"));
    RunResult ok = run_spectex({"plot", exr, "--pixel", "1,1", "-o", d / "p.svg"});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_NE(ok.out.find("1 spectrum "), std::string::npos) << ok.out;
}

TEST(StudioTrial, InfoNamesTheUnitOnceForEveryGridKind) {
    ScratchDir d;
    const std::string in = write_albedo(d);
    write_text(d / "list.txt", "400\n450\n520\n610\n700\n");
    write_text(d / "one.txt", "550\n");
    struct Case {
        std::vector<std::string> grid;
        std::string want;
    };
    const std::vector<Case> cases = {
        {{"--wavelengths", "400:700:10"}, "400:700:10 nm"},
        {{"--wavelengths-file", d / "list.txt", "--allow-infeasible"}, "400-700 nm"},
    };
    for (const auto& c : cases) {
        const std::string exr = d / "g.exr";
        std::vector<std::string> args = {"bake", in, "-o", exr, "-q"};
        args.insert(args.end(), c.grid.begin(), c.grid.end());
        RunResult b = run_spectex(args);
        ASSERT_EQ(b.status, 0) << b.err;
        RunResult i = run_spectex({"info", exr});
        EXPECT_NE(i.out.find(c.want + "\n"), std::string::npos) << i.out;
        EXPECT_EQ(i.out.find("nm nm"), std::string::npos) << i.out;
    }
}

TEST(StudioTrial, ManPageJoinsNoCommandNames) {
    std::string src = __FILE__;  // <source>/tests/cli/studio_trial_test.cpp
    src = src.substr(0, src.rfind("/tests/cli/"));
    const std::string cmd = "man -l '" + src +
                            "/man/spectex.1' 2>/dev/null | grep -c -E "
                            "'spectex(sample|render|plot|info|bake|verify|plan|basis)'";
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    char buf[64] = {0};
    fgets(buf, sizeof buf, p);
    pclose(p);
    EXPECT_EQ(std::string(buf), "0\n");
}

// 4. Settings errors: usage errors naming the option, in every command.
TEST(StudioTrial, UnknownIlluminantIsAUsageErrorNamingTheOption) {
    ScratchDir d;
    const std::string exr = bake_default(d), in = d / "albedo.png";
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

TEST(StudioTrial, TablesWithADescriptiveHeaderAreRead) {
    ScratchDir d;
    const std::string exr = bake_default(d);
    std::string light = "Wavelength (nm),Relative Power\n";
    for (int l = 300; l <= 830; l += 5)
        light += std::to_string(l) + "," + (l < 500 ? "1" : "2") + "\n";
    write_text(d / "light.csv", light);
    RunResult r = run_spectex({"render", exr, "-o", d / "r.png", "--illuminant", d / "light.csv"});
    EXPECT_EQ(r.status, 0) << r.err;
    // Still refused: a header whose first column is not a wavelength, a number as a column name,
    // binary data.
    write_text(d / "bad1.csv", "Energy,Power\n400,1\n700,1\n");
    write_text(d / "bad2.csv", "wavelength (nm),5\n400,1\n700,1\n");
    write_text(d / "bad3.csv", std::string("wavelength,value\n\x01\x02\xff,\x00\n", 20));
    for (const std::string& bad : {"bad1.csv", "bad2.csv", "bad3.csv"}) {
        RunResult b = run_spectex({"render", exr, "-o", d / "r.png", "--illuminant", d / bad});
        EXPECT_EQ(b.status, 2) << bad << ": " << b.err;
        EXPECT_NE(b.err.find("--illuminant: "), std::string::npos) << b.err;
    }
}
