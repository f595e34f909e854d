// --method: the option's rules, and what the file records about the method that made it.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

void write_png(const std::string& path) {
    std::vector<uint8_t> px = {255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 64, 32};
    write_image(path, 2, 2, 3, OIIO::TypeDesc::UINT8, px.data());
}

}  // namespace

TEST(Methods, OptionsThatDoNotBelongToTheMethodAreUsageErrors) {
    ScratchDir d;
    write_png(d / "in.png");
    const std::vector<std::pair<std::vector<std::string>, std::string>> bad = {
        {{"--method", "lattic"}, "--method"},
        {{"--method", "lattice", "--basis", "mallett2019"}, "--basis"},
        {{"--method", "jakob-hanika", "--objective", "norm"}, "--objective"},
        {{"--method", "lattice", "--allow-infeasible"}, "--allow-infeasible"},
        {{"--vertex-prior", "smooth", "--basis", "mallett2019"},
         "--vertex-prior belongs to --method lattice, --basis to --method basis; give --method"},
        {{"--method", "jakob-hanika", "--vertex-prior", "smooth"}, "--vertex-prior"},
        {{"--method", "lattice", "--lattice-size", "1"}, "--lattice-size"},
        {{"--method", "lattice", "--vertex-prior", "gauss"}, "--vertex-prior"},
        {{"--method", "lattice", "--out-of-range", "keep"}, "keep"},
    };
    for (const auto& [extra, what] : bad) {
        std::vector<std::string> args = {"bake", d / "in.png", "-o", d / "o.exr"};
        args.insert(args.end(), extra.begin(), extra.end());
        RunResult r = run_spectex(args);
        EXPECT_EQ(r.status, 2) << extra.back() << ": " << r.err;
        EXPECT_TRUE(contains(r.err, what)) << r.err;
    }
    EXPECT_FALSE(file_exists(d / "o.exr"));
}

// Without --method, an option of one method takes that method as it always was, at full precision
// (scripts written before the default changed keep their output); nothing takes bake's default.
TEST(Methods, AnOptionOfOneMethodTakesThatMethod) {
    ScratchDir d;
    write_png(d / "in.png");
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"--basis", "mallett2019"}, "basis"},
        {{"--objective", "norm"}, "basis"},
        {{"--lattice-size", "5"}, "lattice"},
        {{"--jh-resolution", "5"}, "jakob-hanika"},
        {{"--out-of-range", "keep", "--type", "float"}, "basis"},
        {{}, "lattice"},
    };
    for (const auto& [extra, method] : cases) {
        std::vector<std::string> args = {"bake", d / "in.png", "-o", d / "o.exr", "-q"};
        args.insert(args.end(), extra.begin(), extra.end());
        const RunResult r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << r.err;
        const ExrImage img = read_exr(d / "o.exr");
        EXPECT_EQ(img.attr("spectex:method"), method) << extra.size();
        // Only the default bake keeps fewer bits; a method taken from its options keeps all.
        EXPECT_EQ(img.has_attr("spectex:precision"), extra.empty()) << method;
        if (method == "lattice")
            EXPECT_EQ(img.attr("spectex:vertexPrior"), extra.empty() ? "lhtss" : "jakob-hanika");
    }
}

// In a *Slow* suite: the whole suite runs it; the sanitizer run (minutes of its time under ASan)
// not: every method's bake is sanitized in other tests; this one compares their headers.
TEST(MethodsSlow, TheHeaderAndTheSettingsHashRecordTheMethod) {
    ScratchDir d;
    write_png(d / "in.png");
    struct Case {
        std::vector<std::string> args;
        std::string method, size, prior;
    };
    const std::vector<Case> cases = {
        {{"--method", "basis"}, "basis", "", ""},
        {{}, "lattice", "9", "lhtss"},  // the default bake
        {{"--method", "lattice"}, "lattice", "9", "jakob-hanika"},
        {{"--method", "lattice", "--lattice-size", "5"}, "lattice", "5", "jakob-hanika"},
        {{"--method", "lattice", "--vertex-prior", "smooth"}, "lattice", "9", "smooth"},
        {{"--method", "lattice", "--vertex-prior", "LHTSS", "--lattice-size", "5"},
         "lattice",
         "5",
         "lhtss"},
        {{"--method", "jakob-hanika"}, "jakob-hanika", "", ""},
    };
    std::vector<std::string> hashes, checksums;
    for (const auto& c : cases) {
        std::vector<std::string> args = {"bake", d / "in.png", "-o", d / "o.exr"};
        args.insert(args.end(), c.args.begin(), c.args.end());
        RunResult r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << r.err;
        ExrImage img = read_exr(d / "o.exr");
        EXPECT_EQ(img.attr("spectex:method"), c.method);
        EXPECT_EQ(img.attr("spectex:latticeSize"), c.size);
        EXPECT_EQ(img.attr("spectex:vertexPrior"), c.prior);
        const std::string sum = c.method == "basis" ? img.attr("spectex:basisChecksum")
                                                    : img.attr("spectex:methodChecksum");
        EXPECT_EQ(sum.rfind("fnv1a64:", 0), 0u) << sum;
        if (c.method == "jakob-hanika")
            EXPECT_TRUE(contains(img.attr("spectex:methodSource"), "not exact"));
        hashes.push_back(img.attr("spectex:settingsHash"));
        checksums.push_back(sum);
        // info shows what the header records.
        RunResult info = run_spectex({"info", d / "o.exr"});
        EXPECT_TRUE(contains(info.out, "spectex:method " + c.method)) << info.out;
    }
    for (size_t i = 0; i < hashes.size(); ++i)
        for (size_t j = i + 1; j < hashes.size(); ++j) {
            EXPECT_NE(hashes[i], hashes[j]) << i << " " << j;
            EXPECT_NE(checksums[i], checksums[j]) << i << " " << j;
        }
    // --update rebuilds when only the method changed.
    ASSERT_EQ(run_spectex({"bake", d / "in.png", "-o", d / "u.exr", "--method", "lattice"}).status,
              0);
    RunResult same = run_spectex(
        {"bake", d / "in.png", "-o", d / "u.exr", "--method", "lattice", "--update", "-v"});
    EXPECT_TRUE(contains(same.err, "up to date")) << same.err;
    RunResult other = run_spectex(
        {"bake", d / "in.png", "-o", d / "u.exr", "--method", "basis", "--update", "-v"});
    EXPECT_FALSE(contains(other.err, "up to date")) << other.err;
    EXPECT_EQ(read_exr(d / "u.exr").attr("spectex:method"), "basis");
    // The default bake's lattice (the LHTSS prior, budgeted) is not the JH-prior lattice either.
    RunResult dflt = run_spectex({"bake", d / "in.png", "-o", d / "u.exr", "--update", "-v"});
    EXPECT_FALSE(contains(dflt.err, "up to date")) << dflt.err;
    EXPECT_EQ(read_exr(d / "u.exr").attr("spectex:vertexPrior"), "lhtss");
}

TEST(Methods, ALatticeVertexWithoutAnExactSpectrumIsAClearFailure) {
    // 380:780:40 has no exact bounded spectrum for some colours of the cube (as for the basis).
    ScratchDir d;
    write_png(d / "in.png");
    RunResult r = run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--method", "lattice",
                               "--wavelengths", "380:780:40"});
    EXPECT_EQ(r.status, 2) << r.err;  // a setting of every file: checked once, before any input
    EXPECT_TRUE(contains(r.err, "vertex")) << r.err;
    EXPECT_TRUE(contains(r.err, "380:780:40")) << r.err;
    EXPECT_FALSE(file_exists(d / "o.exr"));
}
