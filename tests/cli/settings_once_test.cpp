// Settings that are the same for every file of a batch (colour config and space, observer,
// illuminant, basis, grid, method) are checked once, before any input is read: one message and
// exit 2, however many inputs; a --basis that is a missing file says so, and a
// basis CSV's grid is the output grid when --wavelengths is not given.
#include <gtest/gtest.h>

#include <fstream>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

size_t count(const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
    return n;
}

size_t lines(const std::string& text) { return count(text, "\n"); }

std::vector<std::string> twenty_inputs(const ScratchDir& d) {
    std::vector<std::string> in;
    std::vector<uint8_t> px(8 * 8 * 3, 128);
    for (int i = 0; i < 20; ++i) {
        in.push_back(d / ("t" + std::to_string(i) + ".png"));
        write_image(in.back(), 8, 8, 3, OIIO::TypeDesc::UINT8, px.data());
    }
    return in;
}

RunResult bake_all(const ScratchDir& d, const std::vector<std::string>& inputs,
                   std::vector<std::string> extra) {
    std::vector<std::string> args = {"bake"};
    args.insert(args.end(), inputs.begin(), inputs.end());
    args.push_back("--output-dir");
    args.push_back(d / "out");
    args.insert(args.end(), extra.begin(), extra.end());
    return run_spectex(args);
}

}  // namespace

TEST(SettingsOnce, BadSettingsAreOneMessageAndExitTwoForAnyNumberOfFiles) {
    ScratchDir d;
    const auto in = twenty_inputs(d);
    const std::string bad_config = d / "bad.ocio";
    std::ofstream(bad_config) << "this is: [not an OCIO config\n";
    struct Case {
        std::vector<std::string> args;
        std::string says;
        // Observer and lights are checked as options: the usage-error form, "spectex bake:
        // <option>: <why>" then "Try 'spectex bake --help'.". The others: one "spectex: " line.
        bool usage_form = false;
    };
    const std::vector<Case> cases = {
        {{"--colorspace", "srgbtx"}, "unknown colour space 'srgbtx'"},
        {{"--config", bad_config}, bad_config},
        {{"--observer", "cie2000"}, "unknown observer 'cie2000'", true},
        {{"--illuminant", "D66"}, "D66", true},
        {{"--basis", d / "nosuch.csv"}, "No such file or directory"},
        {{"--wavelengths", "380:780:40"}, "--allow-infeasible"},
        {{"--method", "lattice", "--wavelengths", "380:780:40"}, "lattice"},
    };
    for (const auto& c : cases) {
        RunResult r = bake_all(d, in, c.args);
        EXPECT_EQ(r.status, 2) << c.args[0] << ": " << r.err;
        // One message however many inputs: the cause once, on one line (plus the Try line of the
        // usage-error form), never once per file.
        EXPECT_EQ(count(r.err, c.says), 1u) << c.args[0] << ": " << r.err;
        if (c.usage_form) {
            EXPECT_EQ(lines(r.err), 2u) << c.args[0] << ": " << r.err;
            EXPECT_EQ(r.err.rfind("spectex bake: " + c.args[0] + ": ", 0), 0u) << r.err;
            const std::string first = r.err.substr(0, r.err.find('\n') + 1);
            EXPECT_EQ(count(first, c.says), 1u) << r.err;
            EXPECT_EQ(r.err.substr(first.size()), "Try 'spectex bake --help'.\n") << r.err;
        } else {
            EXPECT_EQ(lines(r.err), 1u) << c.args[0] << ": " << r.err;
            EXPECT_EQ(r.err.rfind("spectex: ", 0), 0u) << r.err;
        }
        EXPECT_TRUE(list_dir(d / "out").empty()) << c.args[0];
    }
}

TEST(SettingsOnce, AMissingBasisFileIsNamedAsSuch) {
    ScratchDir d;
    const auto in = twenty_inputs(d);
    RunResult r = run_spectex({"bake", in[0], "-o", d / "o.exr", "--basis", "nosuch.csv"});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(r.err.find("nosuch.csv: cannot read the basis: No such file or directory") !=
                std::string::npos)
        << r.err;
    EXPECT_TRUE(r.err.find("unknown basis") == std::string::npos) << r.err;
    RunResult n = run_spectex({"bake", in[0], "-o", d / "o.exr", "--basis", "nosuch"});
    EXPECT_EQ(n.status, 2);
    EXPECT_TRUE(n.err.find("unknown basis 'nosuch'") != std::string::npos) << n.err;
}

TEST(SettingsOnce, ABasisCsvBringsItsGrid) {
    ScratchDir d;
    const auto in = twenty_inputs(d);
    const std::string csv = d / "b10.csv", exr = d / "o.exr";
    ASSERT_EQ(run_spectex({"basis", "--wavelengths", "400:700:10", "-o", csv, "-q"}).status, 0);
    RunResult r = run_spectex({"bake", in[0], "-o", exr, "--basis", csv});
    ASSERT_EQ(r.status, 0) << r.err;
    ExrImage img = read_exr(exr);
    EXPECT_EQ(img.attr("spectex:wavelengths"), "400:700:10");
    EXPECT_TRUE(img.has("T.400nm") && img.has("T.700nm") && !img.has("T.380nm"));
    // Given, --wavelengths must still agree with the basis.
    RunResult other =
        run_spectex({"bake", in[0], "-o", exr, "--basis", csv, "--wavelengths", "380:780:5"});
    EXPECT_EQ(other.status, 2) << other.err;
    EXPECT_TRUE(other.err.find("not on the output grid 380:780:5") != std::string::npos)
        << other.err;
}
