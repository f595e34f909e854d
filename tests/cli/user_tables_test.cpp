// User tables are data from outside: a --basis, --observer or --illuminant CSV must hold finite
// values in range on the output grid, or the run fails naming the table; a basis that does not
// reproduce the primaries gets a warning with the size of the miss; and the infeasible-grid
// message of bake names an option that bake accepts.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

void write_png(const std::string& path) {
    std::vector<uint8_t> px = {255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128};
    write_image(path, 2, 2, 3, OIIO::TypeDesc::UINT8, px.data());
}

// wavelength,r,g,b on 380:780:5 with each row from f(lambda).
template <typename F>
void write_basis(const std::string& path, F f) {
    std::ofstream o(path);
    o << "wavelength,r,g,b\n";
    for (int l = 380; l <= 780; l += 5) o << l << "," << f(l) << "\n";
}

// An observer with x = y = z at every wavelength: its colours lie on one line.
std::string write_degenerate_observer(const ScratchDir& d) {
    std::string t = "wavelength,x,y,z\n";
    for (int l = 360; l <= 830; l += 5) t += std::to_string(l) + ",0.5,0.5,0.5\n";
    write_text(d / "flat_observer.csv", t);
    return d / "flat_observer.csv";
}

// A light of zero power at every wavelength.
std::string write_dark_light(const ScratchDir& d) {
    std::string t = "wavelength,value\n";
    for (int l = 300; l <= 830; l += 5) t += std::to_string(l) + ",0\n";
    write_text(d / "dark.csv", t);
    return d / "dark.csv";
}

}  // namespace

TEST(UserTables, BasisValuesOutsideZeroOneAreRefused) {
    ScratchDir d;
    write_png(d / "in.png");
    const std::vector<std::pair<std::string, std::string>> bad = {{"1e308", "1e308,0,0"},
                                                                  {"-0.5", "-0.5,0.5,1"},
                                                                  {"1.5", "1.5,0,0"},
                                                                  {"1e-300 then 2", "2,0,0"}};
    for (const auto& [what, row_text] : bad) {
        const std::string row =
            row_text;  // a lambda may not capture a structured binding in C++17 (clang refuses)
        write_basis(d / "b.csv", [&](int) { return row; });
        RunResult r =
            run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--basis", d / "b.csv"});
        EXPECT_EQ(r.status, 2) << what << ": " << r.err;
        EXPECT_TRUE(contains(r.err, "b.csv")) << r.err;
        EXPECT_TRUE(contains(r.err, "[0, 1]")) << r.err;
        EXPECT_FALSE(file_exists(d / "o.exr")) << what;
    }
}

TEST(UserTables, ABasisThatMissesThePrimariesIsReported) {
    ScratchDir d;
    write_png(d / "in.png");
    // Flat thirds: every texture would bake grey. Valid values, wrong colours: a warning with the
    // miss (2/3 in linear RGB), and the bake still does what it was told.
    write_basis(d / "flat.csv", [](int) { return "0.3333333333,0.3333333333,0.3333333334"; });
    RunResult r = run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--basis", d / "flat.csv"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.err, "warning: basis")) << r.err;
    EXPECT_TRUE(contains(r.err, "misses the sRGB primaries by 0.666")) << r.err;
    // The shipped published table is exact to 4e-8: no warning.
    std::string table = std::string(SPECTEX_TEST_DATA_DIR) + "/spectral/basis_mallett2019.csv";
    RunResult ok = run_spectex({"bake", d / "in.png", "-o", d / "p.exr", "--basis", table});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_FALSE(contains(ok.err, "warning")) << ok.err;
}

TEST(UserTables, ObserverAndIlluminantValuesAreChecked) {
    ScratchDir d;
    write_png(d / "in.png");
    // A table on 360:830:5 whose row at 550 nm (line 40) is `row_at_550` and whose other rows are
    // valid: a constant light, or an observer whose x, y and z are linearly independent (a
    // constant one would be singular and refused for that instead).
    auto write_table = [&](const std::string& path, bool observer, const std::string& row_at_550) {
        std::ofstream o(path);
        o << (observer ? "wavelength,x,y,z" : "wavelength,value") << "\n";
        for (int l = 360; l <= 830; l += 5) {
            const double t = (l - 360) / 470.0;
            o << l << ",";
            if (l == 550)
                o << row_at_550;
            else if (observer)
                o << t << "," << 1 - t << "," << t * t;
            else
                o << "100";
            o << "\n";
        }
    };
    for (const std::string v : {"1e308", "-1", "inf"}) {
        // Tables are settings of every file, checked once before any input: a usage error (exit 2)
        // naming the option, the file and where the bad value is (the line of a non-number, the
        // wavelength of a number out of range; never reported as a singular observer).
        write_table(d / "ill.csv", false, v);
        RunResult r =
            run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--illuminant", d / "ill.csv"});
        EXPECT_EQ(r.status, 2) << v << ": " << r.err;
        const std::string shown = v == "1e308" ? "1e+308" : v;  // as %g prints it
        const std::string at = v == "inf" ? ":40: " : ": illuminant has the value " + shown;
        EXPECT_TRUE(contains(r.err, "--illuminant: " + (d / "ill.csv") + at)) << r.err;
        write_table(d / "obs.csv", true, v + ",0.5,0.5");
        r = run_spectex({"basis", "-o", d / "b.csv", "--observer", d / "obs.csv"});
        EXPECT_EQ(r.status, 2) << v << ": " << r.err;
        const std::string at_x = v == "inf" ? ":40: " : ": observer (x) has the value " + shown;
        EXPECT_TRUE(contains(r.err, "--observer: " + (d / "obs.csv") + at_x)) << r.err;
        EXPECT_FALSE(contains(r.err, "singular")) << r.err;
        EXPECT_FALSE(file_exists(d / "o.exr"));
        EXPECT_FALSE(file_exists(d / "b.csv"));
    }
}

TEST(UserTables, TheInfeasibleGridHintIsTrue) {
    // 380:780:40 with CIE 1931 2° has no exact basis. bake's message names
    // --allow-infeasible, and bake accepts it: the closest basis, with a warning giving the miss.
    ScratchDir d;
    write_png(d / "in.png");
    RunResult r =
        run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--wavelengths", "380:780:40"});
    EXPECT_EQ(r.status, 2) << r.err;
    ASSERT_TRUE(contains(r.err, "--allow-infeasible")) << r.err;
    RunResult ok = run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--wavelengths",
                                "380:780:40", "--allow-infeasible"});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_TRUE(contains(ok.err, "warning: no exact basis")) << ok.err;
    EXPECT_TRUE(file_exists(d / "o.exr"));
    ExrImage img = read_exr(d / "o.exr");
    EXPECT_TRUE(contains(img.attr("spectex:basisSource"), "infeasible allowed"));
}

// Singular observers and lights (colours on one line, zero power) are refused by every command
// that takes them, naming the table once.
TEST(UserTables, SingularObserverAndDarkLightAreRefusedEverywhere) {
    ScratchDir d;
    const std::string exr = bake_albedo(d), in = d / "albedo.png";
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

TEST(UserTables, TablesWithADescriptiveHeaderAreRead) {
    ScratchDir d;
    const std::string exr = bake_albedo(d);
    std::string light = "Wavelength (nm),Relative Power\n";
    for (int l = 300; l <= 830; l += 5)
        light += std::to_string(l) + "," + (l < 500 ? "1" : "2") + "\n";
    write_text(d / "light.csv", light);
    RunResult r = run_spectex({"render", exr, "-o", d / "r.png", "--illuminant", d / "light.csv"});
    EXPECT_EQ(r.status, 0) << r.err;
    // The same table without a header, and under another usual name of the wavelength column:
    // the same light, so the same picture.
    // (The pictures' pixel chunks are compared: their text names the light's file.)
    auto pixels = [](const std::string& png) {
        const size_t at = png.find("IDAT");
        return at == std::string::npos ? std::string() : png.substr(at);
    };
    write_text(d / "bare.csv", light.substr(light.find('\n') + 1));
    write_text(d / "lambda.csv", "lambda [nm],W\n" + light.substr(light.find('\n') + 1));
    for (const std::string& same : {"bare.csv", "lambda.csv"}) {
        const std::string png = d / (same + ".png");
        RunResult s = run_spectex({"render", exr, "-o", png, "--illuminant", d / same});
        EXPECT_EQ(s.status, 0) << same << ": " << s.err;
        EXPECT_FALSE(pixels(read_file(png)).empty()) << same;
        EXPECT_EQ(pixels(read_file(png)), pixels(read_file(d / "r.png"))) << same;
    }
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
