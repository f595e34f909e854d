// An attacker's fourth round on the newer commands: outputs that name streams or links, UDIM
// tiles of every column, values half cannot store, SVG text that is not UTF-8, strict numbers,
// per-file messages that name their file, and the smaller lies (exit codes, limits named wrongly,
// lists from pipes, messages a shell cannot read back).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

bool has(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

std::string make_png(const ScratchDir& d, const std::string& name, int w = 8, int h = 4) {
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>(i * 37 % 256);
    const std::string path = d / name;
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

bool is_link(const std::string& p) {
    struct stat st;
    return ::lstat(p.c_str(), &st) == 0 && S_ISLNK(st.st_mode);
}

std::string link_text(const std::string& p) {
    char buf[4096];
    const ssize_t n = ::readlink(p.c_str(), buf, sizeof buf);
    return n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string();
}

void write_bytes(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

}  // namespace

// Item: an output that is a link into /proc/self/fd (or /dev/stdout itself) used to be replaced
// by a regular file holding the report, which then never reached the stream.
TEST(HostileRound4, TextOutputsNamingAStreamAreWrittenThroughAndTheLinkStays) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png"), exr = d / "a.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    // Links of the scratch folder only: spelling /dev/stdout itself would let a regression
    // replace the machine's own link (as the attack did, run as root).
    const std::string out_link = d / "L", err_link = d / "E.svg", dev_out = d / "S",
                      dev_err = d / "R";
    ASSERT_EQ(::symlink("/proc/self/fd/1", out_link.c_str()), 0);
    ASSERT_EQ(::symlink("/proc/self/fd/2", err_link.c_str()), 0);
    ASSERT_EQ(::symlink("/dev/stdout", dev_out.c_str()), 0);  // a chain: S -> /dev/stdout -> fd 1
    ASSERT_EQ(::symlink("/dev/stderr", dev_err.c_str()), 0);
    struct Case {
        std::vector<std::string> args;
        std::string expect;  // what must reach the stream
        bool to_stderr;
    };
    const std::vector<Case> cases = {
        {{"verify", exr, "--json", out_link}, "\"schema_version\"", false},
        {{"verify", exr, "--json", dev_out}, "\"schema_version\"", false},
        {{"bake", png, "-o", d / "b.exr", "--json", out_link}, "\"status\":\"ok\"", false},
        {{"bake", png, "-o", d / "c.exr", "--json", dev_err}, "\"status\":\"ok\"", true},
        {{"plan", "--lights", "D65", "--max-de", "3", "--grids", "380:780:20", "--json", out_link},
         "\"lights\"",
         false},
        {{"plan", "--lights", "D65", "--max-de", "3", "--grids", "380:780:20", "--grid-file",
          err_link},
         "# spectex plan",
         true},
        {{"basis", "-q", "-o", out_link}, "wavelength,r,g,b", false},
        {{"plot", exr, "--pixel", "0,0", "-o", err_link}, "<svg", true},
    };
    for (const auto& c : cases) {
        RunResult r = run_spectex(c.args);
        EXPECT_EQ(r.status, 0) << c.args[0] << ": " << r.err;
        EXPECT_TRUE(has(c.to_stderr ? r.err : r.out, c.expect))
            << c.args[0] << " " << c.args.back() << ": the output never reached the stream\n"
            << r.out << r.err;
    }
    EXPECT_TRUE(is_link(out_link)) << "the link to standard output was replaced";
    EXPECT_TRUE(is_link(err_link)) << "the link to standard error was replaced";
    EXPECT_EQ(link_text(out_link), "/proc/self/fd/1");
    EXPECT_TRUE(is_link(dev_out) && is_link(dev_err));
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(HostileRound4, FileOutputsNamingAStreamAreRefusedAndTheLinkStays) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png"), exr = d / "a.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    const std::string exr_link = d / "out.exr", png_link = d / "out.png";
    ASSERT_EQ(::symlink("/proc/self/fd/1", exr_link.c_str()), 0);
    ASSERT_EQ(::symlink("/dev/stdout", png_link.c_str()), 0);
    RunResult b = run_spectex({"bake", png, "-o", exr_link});
    EXPECT_EQ(b.status, 2) << b.err;
    EXPECT_TRUE(has(b.err, "names a stream")) << b.err;
    RunResult r = run_spectex({"render", exr, "-o", png_link});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(has(r.err, "names a stream")) << r.err;
    EXPECT_TRUE(is_link(exr_link));
    EXPECT_TRUE(is_link(png_link));
    EXPECT_TRUE(r.out.empty() && b.out.empty()) << "bytes reached standard output";
}

// A link to a regular file: the rename lands on the target and the link keeps its text. A link
// to nothing or to itself is refused (following it would create a file nobody named).
TEST(HostileRound4, LinksToFilesAreWrittenThroughAndDanglingLinksRefused) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png");
    ASSERT_EQ(::mkdir((d / "store").c_str(), 0755), 0);
    write_bytes(d / "store/real.exr", "old");
    write_bytes(d / "store/real.json", "old");
    ASSERT_EQ(::symlink("store/real.exr", (d / "o.exr").c_str()), 0);
    ASSERT_EQ(::symlink("store/real.json", (d / "r.json").c_str()), 0);
    RunResult r = run_spectex({"bake", png, "-o", d / "o.exr", "--json", d / "r.json", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(is_link(d / "o.exr"));
    EXPECT_TRUE(is_link(d / "r.json"));
    EXPECT_EQ(link_text(d / "o.exr"), "store/real.exr");
    EXPECT_EQ(read_exr(d / "store/real.exr").width, 8) << "the target was not written";
    EXPECT_TRUE(has(read_file(d / "store/real.json"), "\"status\":\"ok\""));
    EXPECT_TRUE(temp_files_in(d.path()).empty());
    EXPECT_TRUE(temp_files_in(d / "store").empty());

    ASSERT_EQ(::symlink("nowhere/x.exr", (d / "dangling.exr").c_str()), 0);
    ASSERT_EQ(::symlink("loop.exr", (d / "loop.exr").c_str()), 0);
    for (const std::string& out : {d / "dangling.exr", d / "loop.exr"}) {
        RunResult x = run_spectex({"bake", png, "-o", out});
        EXPECT_EQ(x.status, 2) << x.err;
        EXPECT_TRUE(has(x.err, "refusing to write through it")) << x.err;
        EXPECT_TRUE(is_link(out));
        RunResult v = run_spectex({"verify", d / "store/real.exr", "--json", out});
        EXPECT_EQ(v.status, 2) << v.err;
    }
    EXPECT_FALSE(file_exists(d / "nowhere/x.exr"));
}

// UDIM = 1001 + u + 10 v, u in 0..9: 1010 and 1020 are the tenth column, 1100 is v = 9.
TEST(HostileRound4, UdimExpansionTakesEveryColumn) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "u").c_str(), 0755), 0);
    const std::vector<std::string> tiles = {"1001", "1002", "1005", "1010", "1011",
                                            "1020", "1100", "2000", "9999"};
    for (const auto& t : tiles) make_png(d, "u/wood." + t + ".png", 4, 4);
    for (const auto& t : {"1000", "0999", "10001", "abcd"})
        make_png(d, std::string("u/wood.") + t + ".png", 4, 4);
    RunResult r = run_spectex({"bake", d / "u/wood.<UDIM>.png", "-o", "{dir}/{stem}.exr", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    for (const auto& t : tiles)
        EXPECT_TRUE(file_exists(d / ("u/wood." + t + ".exr"))) << "tile " << t << " not baked";
    for (const auto& t : {"1000", "0999", "10001", "abcd"})
        EXPECT_FALSE(file_exists(d / (std::string("u/wood.") + t + ".exr")))
            << t << " is no UDIM tile";
}

// Item: --out-of-range keep with half output wrote infinities for values beyond 65504.
TEST(HostileRound4, KeepRefusesValuesHalfCannotStore) {
    ScratchDir d;
    std::vector<float> px(8 * 8 * 3, 0.5f);
    px[10] = 1e38f;
    px[40] = -7e4f;
    write_image(d / "hdr.exr", 8, 8, 3, OIIO::TypeDesc::FLOAT, px.data());
    RunResult r = run_spectex({"bake", d / "hdr.exr", "-o", d / "h.exr", "--out-of-range", "keep"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(has(r.err, "largest half value")) << r.err;
    EXPECT_TRUE(has(r.err, "--type float")) << r.err;
    EXPECT_FALSE(file_exists(d / "h.exr"));
    // Float stores them: every sample finite.
    RunResult f = run_spectex({"bake", d / "hdr.exr", "-o", d / "f.exr", "--out-of-range", "keep",
                               "--type", "float", "-q"});
    ASSERT_EQ(f.status, 0) << f.err;
    for (const auto& [name, plane] : read_exr(d / "f.exr").pixels)
        for (float v : plane) ASSERT_TRUE(std::isfinite(v)) << name;
    // Large values half can hold are kept, finite.
    std::vector<float> big(8 * 8 * 3, 60000.0f);
    write_image(d / "big.exr", 8, 8, 3, OIIO::TypeDesc::FLOAT, big.data());
    RunResult b =
        run_spectex({"bake", d / "big.exr", "-o", d / "b.exr", "--out-of-range", "keep", "-q"});
    ASSERT_EQ(b.status, 0) << b.err;
    size_t n = 0;
    for (const auto& [name, plane] : read_exr(d / "b.exr").pixels)
        for (float v : plane) {
            ASSERT_TRUE(std::isfinite(v)) << name;
            ++n;
        }
    EXPECT_GT(n, 0u);
}

// Item: plot wrote Latin-1 bytes (a file name, --title, a light's name) into an SVG declared UTF-8.
TEST(HostileRound4, PlotWritesWellFormedUtf8Xml) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png"), exr = d / "caf\xe9.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    std::ofstream(d / "l\xe9mpara.csv") << "wavelength,value\n380,1\n780,1\n";
    const std::vector<std::vector<std::string>> cases = {
        {}, {"--title", "caf\xe9 \x01<b>&"}, {"--light", d / "l\xe9mpara.csv"}};
    int k = 0;
    for (const auto& extra : cases) {
        const std::string svg = d / ("p" + std::to_string(k++) + ".svg");
        std::vector<std::string> args = {"plot", exr, "--pixel", "1,1", "-o", svg};
        args.insert(args.end(), extra.begin(), extra.end());
        RunResult r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << r.err;
        // An independent XML parser (Python's expat) must accept it.
        const int rc = std::system(("python3 -c 'import sys, xml.dom.minidom as m; "
                                    "m.parse(sys.argv[1])' '" +
                                    svg + "'")
                                       .c_str());
        EXPECT_EQ(rc, 0) << svg << " is not well-formed XML";
        EXPECT_TRUE(has(read_file(svg), "caf\\xe9")) << "the name's bytes are not shown";
    }
}

// Item: --shard 1/4294967297 acted as 1/1, and "+1/2" was taken.
TEST(HostileRound4, ShardAndOtherWholeNumbersParseStrictly) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png");
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

// Item: verify --source-from-header printed the source's error without the EXR it belongs to.
TEST(HostileRound4, EveryPerFileMessageNamesItsFile) {
    ScratchDir d;
    const std::string png = make_png(d, "gone.png");
    ASSERT_EQ(run_spectex({"bake", png, "-o", d / "h1.exr", "-q"}).status, 0);
    ASSERT_EQ(run_spectex({"bake", png, "-o", d / "h2.exr", "-q"}).status, 0);
    ASSERT_EQ(::unlink(png.c_str()), 0);
    RunResult r =
        run_spectex({"verify", d / "h1.exr", d / "h2.exr", "--source-from-header", "--jobs", "2"});
    EXPECT_EQ(r.status, 1) << r.err;
    for (const std::string exr : {d / "h1.exr", d / "h2.exr"})
        EXPECT_TRUE(has(r.err, "spectex: " + exr + ": ") || has(r.err, "(verifying " + exr + ")\n"))
            << "no line names " << exr << ":\n"
            << r.err;
}

// Item: a pixel coordinate was limited to +-1e9, below what a data window may hold.
TEST(HostileRound4, SampleTakesEveryCoordinateADataWindowMayHold) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png");
    ASSERT_EQ(run_spectex({"bake", png, "-o", d / "a.exr", "-q"}).status, 0);
    for (const std::string xy : {"2147483647,0", "0,-2147483648", "0,2147483647", "1000000006,1"}) {
        RunResult r = run_spectex({"sample", d / "a.exr", xy});
        EXPECT_EQ(r.status, 1) << xy << ": " << r.err;
        EXPECT_TRUE(has(r.err, "outside the data window")) << xy << ": " << r.err;
    }
    for (const std::string xy : {"2147483648,0", "+1,0", "0x1,0", "1,2,3"}) {
        RunResult r = run_spectex({"sample", d / "a.exr", xy});
        EXPECT_EQ(r.status, 2) << xy << ": " << r.err;
    }
    // A data window far from the origin: its pixels are found.
    std::vector<float> px(3 * 2 * 1, 0.25f);
    OIIO::ImageSpec spec(2, 1, 3, OIIO::TypeDesc::FLOAT);
    spec.x = 1000000005;
    spec.full_x = 1000000005;
    spec.channelnames = {"T.450nm", "T.550nm", "T.650nm"};
    spec.attribute("spectralLayoutVersion", "1.0");
    auto out = OIIO::ImageOutput::create(d / "far.exr");
    ASSERT_TRUE(out && out->open(d / "far.exr", spec) &&
                out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close());
    RunResult f = run_spectex({"sample", d / "far.exr", "1000000006,0"});
    EXPECT_EQ(f.status, 0) << f.err;
}

// The smaller items: limits named for what they are, exit codes that agree, lists from pipes,
// messages a shell can read back.
TEST(HostileRound4, HeaderSizesAreReportedForWhatTheyAre) {
    ScratchDir d;
    auto le32 = [](int32_t v) {
        std::string s(4, '\0');
        for (int i = 0; i < 4; ++i)
            s[i] = static_cast<char>((static_cast<uint32_t>(v) >> (8 * i)) & 0xff);
        return s;
    };
    const std::string magic = le32(20000630) + le32(2);
    auto attr = [&](const std::string& name, const std::string& type, int32_t size,
                    const std::string& value) {
        return name + std::string(1, '\0') + type + std::string(1, '\0') + le32(size) + value;
    };
    // A 70 MB attribute: past the header cap, whatever the file's size.
    write_bytes(d / "huge.exr", magic + attr("note", "string", 70 << 20, std::string(64, 'x')));
    RunResult h = run_spectex({"info", d / "huge.exr"});
    EXPECT_EQ(h.status, 1) << h.err;
    EXPECT_TRUE(has(h.err, "64 MiB")) << h.err;
    EXPECT_FALSE(has(h.err, "larger than the file")) << h.err;
    // An int whose size field says 2.
    write_bytes(d / "int2.exr", magic + attr("count", "int", 2, std::string(2, '\0')) +
                                    attr("dataWindow", "box2i", 16, std::string(16, '\0')) +
                                    std::string(1, '\0') + std::string(64, '\0'));
    RunResult i = run_spectex({"info", d / "int2.exr"});
    EXPECT_EQ(i.status, 1) << i.err;
    EXPECT_TRUE(has(i.err, "'count' of type int is 2 bytes, not 4")) << i.err;
    EXPECT_FALSE(has(i.err, "chunks")) << i.err;
}

TEST(HostileRound4, AnUnmetBudgetIsExitOneInPlanAndBake) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png");
    const std::vector<std::string> budget = {"--lights", "A",       "--max-de",
                                             "0.0001",   "--grids", "380:780:20"};
    std::vector<std::string> plan = {"plan"},
                             bake = {"bake", png, "-o", d / "o.exr", "--wavelengths", "auto"};
    plan.insert(plan.end(), budget.begin(), budget.end());
    bake.insert(bake.end(), budget.begin(), budget.end());
    RunResult p = run_spectex(plan), b = run_spectex(bake);
    EXPECT_EQ(p.status, 1) << p.err;
    EXPECT_EQ(b.status, p.status) << b.err;
    EXPECT_TRUE(has(b.err, "best achievable")) << b.err;
}

TEST(HostileRound4, AListFromAPipeIsReadLikeStandardInput) {
    ScratchDir d;
    make_png(d, "a.png");
    make_png(d, "b.png");
    RunResult r =
        run_shell("cd " + d.path() + " && " + spectex_binary() +
                  " bake --from-list <(printf \"a.png\\nb.png\\n\") -o {dir}/{stem}.exr -q");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_TRUE(file_exists(d / "a.exr"));
    EXPECT_TRUE(file_exists(d / "b.exr"));
}

TEST(HostileRound4, TheCommandWasCanBePastedBackIntoAShell) {
    ScratchDir d;
    const std::string missing = d / "caf\xe9 \x01.png";
    RunResult r = run_spectex({"bake", missing, "-o", d / "o.exr"});
    ASSERT_EQ(r.status, 1) << r.err;
    const std::string marker = "spectex: the command was: ";
    const size_t at = r.err.find(marker);
    ASSERT_NE(at, std::string::npos) << r.err;
    std::string line = r.err.substr(at + marker.size());
    line = line.substr(0, line.find('\n'));
    EXPECT_TRUE(has(line, "$'")) << line;
    // bash reads the line back as the same words: print the second argument's bytes.
    const std::string script = "set -- " + line.substr(line.find(' ') + 1) + "; printf %s \"$2\"";
    FILE* p = ::popen(("LC_ALL=C.UTF-8 bash -c \"$(cat)\" >" + d / "word").c_str(), "w");
    ASSERT_NE(p, nullptr);
    std::fwrite(script.data(), 1, script.size(), p);
    ::pclose(p);
    EXPECT_EQ(read_file(d / "word"), missing) << line;
}

// A file baked with a relative source path is verified from another working folder, and after the
// source and output trees moved together (to another mount or machine).
TEST(FilesThatTravel, TheRecordedSourceIsFoundFromAnywhere) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "proj").c_str(), 0755), 0);
    ASSERT_EQ(::mkdir((d / "proj/img").c_str(), 0755), 0);
    ASSERT_EQ(::mkdir((d / "proj/t6").c_str(), 0755), 0);
    make_png(d, "proj/img/albedo.png");
    // Bake from inside proj/t6 with a relative source, as a studio's script did.
    RunResult b = run_shell("cd " + d.path() + "/proj/t6 && " + spectex_binary() +
                            " bake ../img/albedo.png -o albedo.exr -q");
    ASSERT_EQ(b.status, 0) << b.out;
    const ExrImage img = read_exr(d / "proj/t6/albedo.exr");
    EXPECT_EQ(img.attr("spectex:source"), "../img/albedo.png");
    EXPECT_EQ(img.attr("spectex:sourceAbsolute"), d.path() + "/proj/img/albedo.png");
    EXPECT_EQ(img.attr("spectex:sourceFromOutput"), "../img/albedo.png");
    // From another working folder.
    RunResult v = run_shell("cd / && " + spectex_binary() + " verify " + d.path() +
                            "/proj/t6/albedo.exr --source-from-header -q");
    EXPECT_EQ(v.status, 0) << v.out;
    // The whole tree moved: the absolute path is gone, the relative one holds.
    ASSERT_EQ(::rename((d / "proj").c_str(), (d / "moved").c_str()), 0);
    RunResult m = run_shell("cd / && " + spectex_binary() + " verify " + d.path() +
                            "/moved/t6/albedo.exr --source-from-header -q");
    EXPECT_EQ(m.status, 0) << m.out;
    // Nowhere to be found: the EXR is named, with every place tried.
    ASSERT_EQ(::unlink((d / "moved/img/albedo.png").c_str()), 0);
    RunResult g = run_spectex({"verify", d / "moved/t6/albedo.exr", "--source-from-header"});
    EXPECT_EQ(g.status, 1) << g.err;
    EXPECT_TRUE(has(g.err, "spectex: " + d.path() +
                               "/moved/t6/albedo.exr: the source it records "
                               "is not found (tried "))
        << g.err;
}

// A /proc/self/fd/N the shell passed is a stream; one spectex would open itself (an output being
// written, a library's file) is not: a report written there could land inside another output.
TEST(HostileRound4, OnlyDescriptorsTheShellPassedAreStreams) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png"), exr = d / "a.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    RunResult given = run_shell(spectex_binary() + " verify " + exr +
                                " -q --json /proc/self/fd/9 9>" + d.path() + "/report.json");
    EXPECT_EQ(given.status, 0) << given.out;
    EXPECT_TRUE(has(read_file(d / "report.json"), "\"schema_version\"")) << given.out;
    // Descriptors 20 and 250 are not open when spectex starts: refused before any work.
    for (const std::string fd : {"20", "250"}) {
        RunResult r = run_spectex({"verify", exr, "--json", "/proc/self/fd/" + fd});
        EXPECT_EQ(r.status, 2) << fd << ": " << r.err;
        EXPECT_TRUE(has(r.err, "which spectex was not given")) << r.err;
        RunResult b = run_spectex(
            {"bake", png, "-o", d / "b.exr", "--jobs", "1", "--json", "/proc/self/fd/" + fd});
        EXPECT_EQ(b.status, 2) << fd << ": " << b.err;
        EXPECT_FALSE(file_exists(d / "b.exr"));
    }
}
