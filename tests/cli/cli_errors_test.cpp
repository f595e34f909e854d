// End-to-end tests of spectex's exit statuses and messages: 0 success, 1 a failed file
// ("spectex: <file>: <cause>" on stderr), 2 a usage error. After every failed bake the output
// name must not exist and no temporary file (<output>.spectex-XXXXXX.tmp) may be left behind.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;

namespace {

bool is_dir(const std::string& p) {
    struct stat st;
    return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

// The checks made after every failing bake.
void expect_no_output(const std::string& output) {
    struct stat st;
    EXPECT_NE(::lstat(output.c_str(), &st), 0) << output << " exists after a failed bake";
    EXPECT_TRUE(temp_files_in(dir_of(output)).empty())
        << "temporary file left in " << dir_of(output) << ": "
        << temp_files_in(dir_of(output)).front();
}

// A small valid sRGB PNG.
void write_png(const std::string& path, int w = 4, int h = 3) {
    std::vector<uint8_t> px(static_cast<size_t>(w * h * 3));
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>(17 * i + 3);
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
}

bool contains(const std::string& haystack, const std::string& needle) {
    return haystack.find(needle) != std::string::npos;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Help and version

TEST(CliHelp, NoArgumentsIsUsageError) {
    RunResult r = run_spectex({});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "Usage: spectex")) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(CliHelp, UnknownCommandIsUsageError) {
    RunResult r = run_spectex({"bakee", "x.png"});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "unknown command 'bakee'")) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(CliHelp, TopLevelHelp) {
    for (const char* opt : {"--help", "-h"}) {
        RunResult r = run_spectex({opt});
        EXPECT_EQ(r.status, 0) << opt;
        EXPECT_TRUE(contains(r.out, "Usage: spectex")) << r.out;
        EXPECT_TRUE(contains(r.out, "bake")) << r.out;
        EXPECT_TRUE(contains(r.out, "info")) << r.out;
        EXPECT_TRUE(contains(r.out, "--version")) << r.out;
        EXPECT_TRUE(r.err.empty()) << r.err;
    }
}

TEST(CliHelp, BakeHelpListsOptions) {
    RunResult r = run_spectex({"bake", "--help"});
    EXPECT_EQ(r.status, 0);
    EXPECT_TRUE(r.err.empty()) << r.err;
    for (const char* opt :
         {"Usage: spectex bake", "--output", "--type", "--compression", "--preview", "--alpha",
          "--colorspace", "--config", "--out-of-range", "--nan", "--basis", "--wavelengths",
          "--threads", "--max-pixels", "--quiet", "--verbose"})
        EXPECT_TRUE(contains(r.out, opt)) << "bake --help does not mention " << opt << ":\n"
                                          << r.out;
}

// The options most runs need come first, under "Common options:", and every option is listed once
// (the sections by task below leave the common ones out), so a newcomer reads a screenful, not the
// whole table, before the first bake.
TEST(CliHelp, CommonOptionsComeFirstAndEachOptionOnce) {
    const std::vector<std::pair<std::string, std::string>> first = {
        {"bake", "  -o, --output"}, {"verify", "  --source "}, {"plan", "  --lights "}};
    for (const auto& [command, first_option] : first) {
        RunResult r = run_spectex({command, "--help"});
        ASSERT_EQ(r.status, 0) << command << ": " << r.err;
        std::istringstream in(r.out);
        std::string line, heading;
        std::vector<std::string> headings, options;
        bool next_is_first = false;
        std::string after_common;
        while (std::getline(in, line)) {
            if (!line.empty() && line[0] != ' ' && line.back() == ':') headings.push_back(line);
            if (line.rfind("  -", 0) == 0) {
                const std::string names = line.substr(0, line.find("  ", 2));
                options.push_back(names.substr(0, names.find(' ', names.find("--"))));
                if (next_is_first) after_common = line;
                next_is_first = false;
            }
            if (line == "Common options:") next_is_first = true;
        }
        ASSERT_FALSE(headings.empty()) << command << ":\n" << r.out;
        EXPECT_EQ(headings.front(), "Common options:") << command << ":\n" << r.out;
        EXPECT_EQ(after_common.rfind(first_option, 0), 0u) << command << ":\n" << r.out;
        std::vector<std::string> sorted = options;
        std::sort(sorted.begin(), sorted.end());
        EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end())
            << command << " --help lists an option twice:\n"
            << r.out;
        EXPECT_GT(options.size(), 10u) << command << ":\n" << r.out;
    }
}

TEST(CliHelp, BakeHelpWinsOverOtherArguments) {
    // --help is honoured even when the rest of the command line is incomplete.
    RunResult r = run_spectex({"bake", "--help", "-o"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.out, "--colorspace")) << r.out;
}

TEST(CliHelp, InfoHelp) {
    RunResult r = run_spectex({"info", "--help"});
    EXPECT_EQ(r.status, 0);
    EXPECT_TRUE(r.err.empty()) << r.err;
    EXPECT_TRUE(contains(r.out, "Usage: spectex info")) << r.out;
    EXPECT_TRUE(contains(r.out, "--help")) << r.out;
}

TEST(CliHelp, Version) {
    RunResult r = run_spectex({"--version"});
    EXPECT_EQ(r.status, 0);
    EXPECT_TRUE(r.err.empty()) << r.err;
    ASSERT_EQ(r.out.rfind("spectex ", 0), 0u) << r.out;
    // "spectex X.Y.Z\n"
    std::string v = r.out.substr(8);
    ASSERT_FALSE(v.empty());
    EXPECT_TRUE(v[0] >= '0' && v[0] <= '9') << r.out;
    EXPECT_EQ(v.back(), '\n');
}

// ---------------------------------------------------------------------------------------------
// Inputs that cannot be read (exit 1, "spectex: <input>: <cause>")

TEST(CliErrors, MissingInput) {
    ScratchDir d;
    std::string in = d / "nope.png", out = d / "out.exr";
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + in + ": ")) << r.err;
    EXPECT_TRUE(contains(r.err, "No such file")) << r.err;
    expect_no_output(out);
}

TEST(CliErrors, RandomBytesNamedPng) {
    ScratchDir d;
    std::string in = d / "x.png", out = d / "out.exr";
    {
        std::mt19937 rng(1234);
        std::string bytes(4096, '\0');
        for (auto& c : bytes) c = static_cast<char>(rng() & 0xff);
        bytes[0] = 'Z';  // never a PNG (0x89), JPEG (0xff) or EXR (0x76) signature
        std::ofstream(in, std::ios::binary) << bytes;
    }
    const std::string before = read_file(in);
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + in + ": ")) << r.err;
    EXPECT_EQ(read_file(in), before);
    expect_no_output(out);
}

TEST(CliErrors, EmptyInput) {
    ScratchDir d;
    std::string in = d / "empty.png", out = d / "out.exr";
    std::ofstream(in).close();
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + in + ": ")) << r.err;
    EXPECT_TRUE(contains(r.err, "empty")) << r.err;
    expect_no_output(out);
}

TEST(CliErrors, TruncatedPngLeavesNoPartialOutput) {
    // A valid header followed by too little pixel data: the failure happens after the output's
    // temporary file exists, which must then be removed.
    ScratchDir d;
    std::string full = d / "full.png", in = d / "cut.png", out = d / "out.exr";
    const int w = 64, h = 64;
    std::vector<uint8_t> px(static_cast<size_t>(w * h * 3));
    std::mt19937 rng(7);
    for (auto& v : px) v = static_cast<uint8_t>(rng() & 0xff);  // incompressible
    write_image(full, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    std::string bytes = read_file(full);
    ASSERT_GT(bytes.size(), 2000u);
    std::ofstream(in, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(contains(r.err, "spectex: " + in + ": ")) << r.err;
    expect_no_output(out);
}

TEST(CliErrors, DirectoryAsInput) {
    ScratchDir d;
    std::string in = d / "folder.png", out = d / "out.exr";
    ASSERT_EQ(::mkdir(in.c_str(), 0755), 0);
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + in + ": ")) << r.err;
    EXPECT_TRUE(contains(r.err, "directory")) << r.err;
    expect_no_output(out);
}

TEST(CliErrors, UnknownColourSpaceSuggestsClosest) {
    ScratchDir d;
    std::string in = d / "in.png", out = d / "out.exr";
    write_png(in);
    RunResult r = run_spectex({"bake", in, "-o", out, "--colorspace", "srgbtx"});
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err.rfind("spectex: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, "unknown colour space 'srgbtx'")) << r.err;
    EXPECT_TRUE(contains(r.err, "srgb_tx")) << r.err;
    expect_no_output(out);
}

// ---------------------------------------------------------------------------------------------
// Outputs that cannot be written

TEST(CliErrors, OutputFolderDoesNotExist) {
    ScratchDir d;
    std::string in = d / "in.png", out = d / "no/such/folder/out.exr";
    write_png(in);
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + out + ": ")) << r.err;
    EXPECT_FALSE(is_dir(d / "no")) << "spectex created the output's folder";
    expect_no_output(out);
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(CliErrors, OutputFolderNotWritable) {
    // Tests run as root, for whom a chmod 0555 folder is still writable: /proc refuses new files
    // to everyone.
    ScratchDir d;
    std::string in = d / "in.png", out = "/proc/spectex-cli-test-out.exr";
    write_png(in);
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + out + ": ")) << r.err;
    expect_no_output(out);
}

TEST(CliErrors, OutputIsTheInput) {
    ScratchDir d;
    std::string in =
        d / "in.exr";  // an .exr input: -o passes the name check, then the identity one
    write_png(in);
    const std::string before = read_file(in);
    RunResult r = run_spectex({"bake", in, "-o", in});
    EXPECT_EQ(r.status, 2)
        << "naming an input as the output is a usage error, found before any work";
    EXPECT_TRUE(contains(r.err, "spectex bake: " + in + ": ")) << r.err;
    EXPECT_TRUE(contains(r.err, "input")) << r.err;
    EXPECT_EQ(read_file(in), before) << "the input was modified";
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(CliErrors, OutputIsTheInputThroughAnotherPath) {
    // Same file, spelled differently ("dir/./in.exr").
    ScratchDir d;
    std::string in = d / "in.exr", out = d.path() + "/./in.exr";
    write_png(in);
    const std::string before = read_file(in);
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "spectex bake: " + out + ": ")) << r.err;
    EXPECT_EQ(read_file(in), before);
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(CliErrors, OutputIsASymlinkToTheInput) {
    ScratchDir d;
    std::string in = d / "in.png", out = d / "link.exr";
    write_png(in);
    ASSERT_EQ(::symlink(in.c_str(), out.c_str()), 0);
    const std::string before = read_file(in);
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "spectex bake: " + out + ": ")) << r.err;
    EXPECT_EQ(read_file(in), before) << "the input was modified";
    struct stat st;
    ASSERT_EQ(::lstat(out.c_str(), &st), 0);
    EXPECT_TRUE(S_ISLNK(st.st_mode)) << "the symlink was replaced";
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(CliErrors, OutputIsAHardLinkToTheInput) {
    ScratchDir d;
    std::string in = d / "in.png", out = d / "hard.exr";
    write_png(in);
    ASSERT_EQ(::link(in.c_str(), out.c_str()), 0);
    const std::string before = read_file(in);
    struct stat si;
    ASSERT_EQ(::stat(in.c_str(), &si), 0);
    RunResult r = run_spectex({"bake", in, "-o", out});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "spectex bake: " + out + ": ")) << r.err;
    EXPECT_EQ(read_file(in), before) << "the input was modified";
    struct stat so;
    ASSERT_EQ(::stat(out.c_str(), &so), 0);
    EXPECT_EQ(so.st_ino, si.st_ino) << "the hard link was replaced";
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

// ---------------------------------------------------------------------------------------------
// Bad option values: usage errors (exit 2) naming the option

namespace {

void expect_usage_error(const std::vector<std::string>& extra, const std::string& option) {
    ScratchDir d;
    std::string in = d / "in.png", out = d / "out.exr";
    write_png(in);
    std::vector<std::string> args{"bake", in, "-o", out};
    args.insert(args.end(), extra.begin(), extra.end());
    RunResult r = run_spectex(args);
    EXPECT_EQ(r.status, 2) << option << ": " << r.err;
    EXPECT_EQ(r.err.rfind("spectex bake: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, option)) << "message does not name " << option << ": " << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    expect_no_output(out);
}

}  // namespace

TEST(CliErrors, BadType) { expect_usage_error({"--type", "double"}, "--type"); }
TEST(CliErrors, BadCompression) { expect_usage_error({"--compression", "lzma"}, "--compression"); }
TEST(CliErrors, NegativeThreads) { expect_usage_error({"--threads", "-1"}, "--threads"); }
TEST(CliErrors, WavelengthsWithoutStep) {
    expect_usage_error({"--wavelengths", "380:780"}, "--wavelengths");
}
TEST(CliErrors, UnknownOption) { expect_usage_error({"--frobnicate"}, "--frobnicate"); }
TEST(CliErrors, BadAlpha) { expect_usage_error({"--alpha", "straight"}, "--alpha"); }
TEST(CliErrors, OptionWithoutValue) { expect_usage_error({"--type"}, "--type"); }

TEST(CliErrors, BakeWithoutOutputIsUsageError) {
    ScratchDir d;
    std::string in = d / "in.png";
    write_png(in);
    RunResult r = run_spectex({"bake", in});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "-o")) << r.err;
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(CliErrors, BakeWithoutInputIsUsageError) {
    ScratchDir d;
    std::string out = d / "out.exr";
    RunResult r = run_spectex({"bake", "-o", out});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "no input")) << r.err;
    expect_no_output(out);
}

// ---------------------------------------------------------------------------------------------
// Spectral settings that cannot be honoured (exit 2: checked once, before any input)

TEST(CliErrors, WavelengthsNotOnTheBasisGrid) {
    ScratchDir d;
    std::string in = d / "in.png", out = d / "out.exr";
    write_png(in);
    // The published table exists on 380:780:5 only; the default fitted basis works on any grid.
    RunResult r = run_spectex(
        {"bake", in, "-o", out, "--wavelengths", "400:700:10", "--basis", "mallett2019"});
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err.rfind("spectex: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, "400:700:10")) << r.err;
    EXPECT_TRUE(contains(r.err, "not on the output grid")) << r.err;
    expect_no_output(out);
}

TEST(CliErrors, BasisFileMissing) {
    ScratchDir d;
    std::string in = d / "in.png", out = d / "out.exr", basis = d / "missing.csv";
    write_png(in);
    RunResult r = run_spectex({"bake", in, "-o", out, "--basis", basis});
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err.rfind("spectex: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, basis)) << r.err;
    expect_no_output(out);
}

// OpenColorIO 2.1 has no built-in configs (ocio://default and the other ocio:// names came with
// 2.2). Such a name, from --config or $OCIO, is not reported as a missing file but answered with
// what to use instead, as any config that cannot be read is: one line, exit 2.
TEST(CliErrors, BuiltinConfigNamesSayWhatToUseInstead) {
    ScratchDir d;
    std::string in = d / "in.png", out = d / "out.exr";
    write_png(in);
    const RunResult runs[] = {
        run_spectex({"bake", in, "-o", out, "--config", "ocio://default"}),
        run_spectex({"bake", in, "-o", out}, {"OCIO=ocio://cg-config-latest"}),
    };
    for (const RunResult& r : runs) {
        EXPECT_EQ(r.status, 2) << r.err;
        EXPECT_EQ(r.err.rfind("spectex: ocio://", 0), 0u) << r.err;
        EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
        EXPECT_TRUE(contains(r.err, "no built-in configs")) << r.err;
        EXPECT_TRUE(contains(r.err, "config file")) << r.err;
        EXPECT_FALSE(contains(r.err, "No such file")) << r.err;
        expect_no_output(out);
    }
    // verify and plan --texture fail on it as on a config file that is not there, and say why.
    ASSERT_EQ(run_spectex({"bake", in, "-o", out, "--method", "basis", "-q"}).status, 0);
    for (const std::vector<std::string> args :
         {std::vector<std::string>{"verify", out, "--source", in, "--config"},
          std::vector<std::string>{"plan", "--texture", in, "--config"}}) {
        std::vector<std::string> missing = args, builtin = args;
        missing.push_back(d / "none.ocio");
        builtin.push_back("ocio://default");
        const RunResult m = run_spectex(missing), b = run_spectex(builtin);
        EXPECT_NE(m.status, 0) << args[0] << ": " << m.err;
        EXPECT_EQ(b.status, m.status) << args[0] << ": " << b.err;
        EXPECT_TRUE(contains(b.err, "ocio://default: ")) << args[0] << ": " << b.err;
        EXPECT_TRUE(contains(b.err, "no built-in configs")) << args[0] << ": " << b.err;
    }
}

// ---------------------------------------------------------------------------------------------
// info on files that are not spectral

TEST(CliErrors, InfoOnNonExr) {
    ScratchDir d;
    std::string in = d / "in.png";
    write_png(in);
    RunResult r = run_spectex({"info", in});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + in + ": ")) << r.err;
    EXPECT_TRUE(contains(r.err, "not an OpenEXR file") || contains(r.err, "not a spectral"))
        << r.err;
}

TEST(CliErrors, InfoOnRgbExr) {
    ScratchDir d;
    std::string in = d / "rgb.exr";
    std::vector<float> px(4 * 3 * 3, 0.25f);
    write_image(in, 4, 3, 3, OIIO::TypeDesc::FLOAT, px.data());
    RunResult r = run_spectex({"info", in});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + in + ": ")) << r.err;
    EXPECT_TRUE(contains(r.err, "not a spectral reflectance image")) << r.err;
}

TEST(CliErrors, InfoOnMissingFile) {
    ScratchDir d;
    std::string in = d / "nope.exr";
    RunResult r = run_spectex({"info", in});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "spectex: " + in + ": ")) << r.err;
    EXPECT_TRUE(contains(r.err, "No such file")) << r.err;
}

TEST(CliErrors, InfoWithoutFileIsUsageError) {
    RunResult r = run_spectex({"info"});
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err.rfind("spectex info: ", 0), 0u) << r.err;
}

TEST(CliErrors, InfoReportsEveryFailedFileAndFailsOverall) {
    // One good file and one bad: the good one is described, the bad one named, exit 1.
    ScratchDir d;
    std::string png = d / "in.png", good = d / "good.exr", bad = d / "nope.exr";
    write_png(png);
    RunResult b = run_spectex({"bake", png, "-o", good});
    ASSERT_EQ(b.status, 0) << b.err;
    RunResult r = run_spectex({"info", good, bad});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.out, good)) << r.out;
    EXPECT_TRUE(contains(r.err, "spectex: " + bad + ": ")) << r.err;
}

TEST(CliErrors, HostileExrHeadersAreRefusedBeforeOpenExrAllocates) {
    // OpenEXR 3.1 sizes its chunk tables from the header; the fuzzer found a header that made it
    // allocate past 2 GB. exr_preflight refuses such headers first (info and verify share it).
    ScratchDir d;
    const std::string seed =
        std::string(SPECTEX_TEST_SOURCE_DIR) +
        "/tests/fuzz/corpus/fuzz_exr_header/regress_oom_header_without_datawindow";
    RunResult r = run_spectex({"info", seed});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "corrupt OpenEXR header")) << r.err;
    // A well-formed header claiming 2^20 x 2^20 pixels in 1x1 tiles.
    std::string h;
    auto put32 = [&](int32_t v) { h.append(reinterpret_cast<const char*>(&v), 4); };
    auto attr = [&](const std::string& name, const std::string& type, const std::string& value) {
        h += name;
        h += '\0';
        h += type;
        h += '\0';
        put32(static_cast<int32_t>(value.size()));
        h += value;
    };
    put32(20000630);
    put32(2 | 0x200);
    std::string box;
    for (int32_t v : {0, 0, (1 << 20) - 1, (1 << 20) - 1})
        box.append(reinterpret_cast<const char*>(&v), 4);
    std::string tiles;
    for (int32_t v : {1, 1}) tiles.append(reinterpret_cast<const char*>(&v), 4);
    tiles += '\0';
    attr("dataWindow", "box2i", box);
    attr("displayWindow", "box2i", box);
    attr("tiles", "tiledesc", tiles);
    h += '\0';
    std::ofstream(d / "huge.exr", std::ios::binary) << h;
    r = run_spectex({"info", d / "huge.exr"});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "refusing")) << r.err;
    r = run_spectex({"verify", d / "huge.exr"});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "refusing")) << r.err;

    // A small, well-formed image whose string vector has an element of 2^31 - 1 bytes, or whose
    // preview claims 65535 x 65535 pixels, in a few bytes: OpenEXR sizes the value from those
    // fields before reading it (2 GB and 17 GB). Or whose channel list ends before its size:
    // OpenEXR reads a list by its content, so it would read the next attribute from inside this
    // one, out of step with the check. Refused by name, before OpenEXR opens the file.
    for (const std::string which : {"stringvector", "preview", "chlist"}) {
        h.clear();
        put32(20000630);
        put32(2);
        box.clear();
        for (int32_t v : {0, 0, 3, 3}) box.append(reinterpret_cast<const char*>(&v), 4);
        attr("channels", "chlist",
             std::string("T.500nm\0", 8) + std::string(16, '\0') + '\0' +
                 (which == "chlist" ? std::string("\x07\x00\x00\x70", 4) : std::string()));
        attr("compression", "compression", std::string(1, '\0'));
        attr("dataWindow", "box2i", box);
        attr("displayWindow", "box2i", box);
        attr("lineOrder", "lineOrder", std::string(1, '\0'));
        std::string value;
        auto put = [&](int32_t v) { value.append(reinterpret_cast<const char*>(&v), 4); };
        if (which == "chlist") {
            // (the channel list above carries the extra bytes)
        } else if (which == "stringvector") {
            put(2);
            value += "ok";
            put(0x7fffffff);
            attr("names", "stringvector", value);
        } else {
            put(65535);
            put(65535);
            value += std::string(4, '\x7f');
            attr("preview", "preview", value);
        }
        h += '\0';
        const std::string f = d / (which + ".exr");
        std::ofstream(f, std::ios::binary) << h << std::string(64, '\0');
        for (const char* cmd : {"info", "verify"}) {
            r = run_spectex({cmd, f});
            EXPECT_EQ(r.status, 1) << cmd << " " << which << ": " << r.err;
            const std::string attribute = which == "stringvector" ? "names"
                                          : which == "preview"    ? "preview"
                                                                  : "channels";
            EXPECT_TRUE(
                contains(r.err, f + ": corrupt OpenEXR header: attribute '" + attribute + "'"))
                << cmd << " " << which << ": " << r.err;
        }
    }
}

// A mistyped option names the closest one; an empty argument is a usage error, not a missing file.
TEST(CliErrors, MistypedOptionsAndEmptyArguments) {
    RunResult r = run_spectex({"bake", "x.png", "-o", "y.exr", "--wavelenghts", "400:700:5"});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(has_text(r.err, "unknown option '--wavelenghts' (did you mean --wavelengths?)"))
        << r.err;
    RunResult v = run_spectex({"verify", "--sorce", "a.png", "a.exr"});
    EXPECT_EQ(v.status, 2);
    EXPECT_TRUE(has_text(v.err, "(did you mean --source?)")) << v.err;
    for (const char* cmd : {"bake", "verify", "info"}) {
        RunResult e = run_spectex({cmd, ""});
        EXPECT_EQ(e.status, 2) << cmd << ": " << e.err;
        EXPECT_TRUE(has_text(e.err, "an empty argument")) << e.err;
    }
}

// Whole numbers parse strictly: a value that wraps (--shard 1/4294967297 read as 1/1), a sign,
// spaces or a hex prefix is a usage error, not a different number.
TEST(CliErrors, ShardAndOtherWholeNumbersParseStrictly) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 8, 4);
    for (const std::string bad : {"1/4294967297", "4294967297/4294967298", "+1/2", "1/+2", " 1/2",
                                  "1/2 ", "0x1/2", "1/2/3", "-1/2", "1/0", "3/2", "1/"}) {
        RunResult r = run_spectex({"bake", png, "-o", d / "o.exr", "--shard", bad});
        EXPECT_EQ(r.status, 2) << "--shard '" << bad << "': " << r.err;
        EXPECT_FALSE(file_exists(d / "o.exr")) << "--shard '" << bad << "' baked";
    }
    EXPECT_EQ(run_spectex({"bake", png, "-o", d / "o.exr", "--shard", "1/1", "-q"}).status, 0);
    // The same strictness for every number an option takes.
    const std::vector<std::vector<std::string>> bad_numbers = {
        {"plan", "--lights", "D65", "--max-de", "0x10"},
        {"plan", "--lights", "D65", "--max-de", "0x1p-3"},
        {"bake", png, "-o", d / "z.exr", "--zip-level", "+4"},
        {"bake", png, "-o", d / "z.exr", "--zip-level", "0x4"},
        {"bake", png, "-o", d / "z.exr", "--tile", "0x40"},
        {"bake", png, "-o", d / "z.exr", "--tile", "+64"},
        {"bake", png, "-o", d / "z.exr", "--tile", "64x+64"},
        {"bake", png, "-o", d / "z.exr", "--threads", "4294967297"},
    };
    for (const auto& args : bad_numbers) {
        RunResult r = run_spectex(args);
        EXPECT_EQ(r.status, 2) << args[args.size() - 2] << " " << args.back() << ": " << r.err;
    }
}

TEST(CliHelp, ManPageJoinsNoCommandNames) {
    const std::string src = SPECTEX_TEST_SOURCE_DIR;
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
