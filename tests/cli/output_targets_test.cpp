// Where outputs go when their names are not plain new files: devices, FIFOs and links to them are
// never replaced; a link to a regular file is written through (the link keeps its text) and a
// dangling or looping link is refused; a report naming a stream the shell passed (/proc/self/fd/N,
// /dev/stdout, /dev/stderr, or a link to one) reaches that stream, while an EXR, PNG or SVG
// naming a stream is refused; output lost on a full standard output is a failure (exit 1); names
// too long for the file system are refused before any work.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

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

TEST(OutputTargets, DevicesFifosAndLinksToThemAreNeverReplaced) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 16, 8);
    const std::string fifo = d / "fifo.exr", dev = d / "null.exr", link = d / "link.exr";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
    const bool made_device =
        ::mknod(dev.c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0;  // /dev/null's numbers (root)
    ASSERT_EQ(::symlink("/dev/null", link.c_str()), 0);
    std::vector<std::string> targets = {fifo, link};
    if (made_device) targets.push_back(dev);
    for (const auto& t : targets) {
        for (const auto& args :
             std::vector<std::vector<std::string>>{{"bake", png, "-o", t},
                                                   {"bake", png, "-o", d / "ok.exr", "--json", t},
                                                   {"basis", "-q", "-o", t}}) {
            RunResult r = run_spectex(args);
            EXPECT_EQ(r.status, 2) << args[0] << " -> " << t << ": " << r.err;
            EXPECT_TRUE(has_text(r.err, "refusing to replace it")) << r.err;
        }
        struct stat st;
        ASSERT_EQ(::lstat(t.c_str(), &st), 0);
        EXPECT_FALSE(S_ISREG(st.st_mode)) << t << " was replaced by a regular file";
    }
    EXPECT_TRUE(temp_files_in(d.path()).empty());
    // render and plot write outputs too.
    const std::string exr = d / "a.exr", png_fifo = d / "fifo.png", svg_link = d / "link.svg";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    ASSERT_EQ(::mkfifo(png_fifo.c_str(), 0644), 0);
    ASSERT_EQ(::symlink("/dev/null", svg_link.c_str()), 0);
    RunResult r = run_spectex({"render", exr, "-o", png_fifo});
    EXPECT_EQ(r.status, 2) << r.err;
    RunResult p = run_spectex({"plot", exr, "--pixel", "0,0", "-o", svg_link});
    EXPECT_EQ(p.status, 2) << p.err;
    struct stat st;
    ASSERT_EQ(::lstat(png_fifo.c_str(), &st), 0);
    EXPECT_TRUE(S_ISFIFO(st.st_mode));
    ASSERT_EQ(::lstat(svg_link.c_str(), &st), 0);
    EXPECT_TRUE(S_ISLNK(st.st_mode));
}

TEST(OutputTargets, OutputThatNeverReachedStandardOutputIsAFailure) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 16, 8), exr = d / "a.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    for (const auto& args :
         std::vector<std::vector<std::string>>{{"info", exr},
                                               {"basis", "-q", "-o", "-"},
                                               {"verify", exr},
                                               {"verify", exr, "--json", "-"},
                                               {"bake", png, "-o", d / "b.exr", "--json", "-"},
                                               {"--help"}}) {
        RunResult r = run_spectex_io(args, "/dev/null", "/dev/full");
        EXPECT_EQ(r.status, 1) << args[0] << ": " << r.err;
        EXPECT_TRUE(has_text(r.err, "standard output")) << r.err;
    }
}

TEST(OutputTargets, NamesTooLongAreRefusedBeforeAnyWork) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 16, 8);
    const std::string long_name = d / (std::string(252, 'n') + ".exr");  // 256 bytes
    RunResult r = run_spectex({"bake", png, "-o", long_name});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(has_text(r.err, "256 bytes, longer than the 255")) << r.err;
    RunResult t = run_spectex({"bake", png, "-o", d / (std::string(250, 't') + "{stem}.exr")});
    EXPECT_EQ(t.status, 2) << t.err;
    RunResult j =
        run_spectex({"bake", png, "-o", d / "a.exr", "--json", d / std::string(256, 'j')});
    EXPECT_EQ(j.status, 2) << j.err;
    EXPECT_FALSE(file_exists(d / "a.exr"));
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

// A report whose name is a link into /proc/self/fd (or /dev/stdout itself) goes to that stream:
// replacing the link by a regular file would keep the report from ever reaching it.
TEST(OutputTargets, TextOutputsNamingAStreamAreWrittenThroughAndTheLinkStays) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 8, 4), exr = d / "a.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    // Links of the scratch folder only: spelling /dev/stdout itself would let a regression
    // replace the machine's own link (a test run as root could).
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
    // The plans keep every bit: bits of their own would be chosen on every 8-bit colour.
    const std::vector<Case> cases = {
        {{"verify", exr, "--json", out_link}, "\"schema_version\"", false},
        {{"verify", exr, "--json", dev_out}, "\"schema_version\"", false},
        {{"bake", png, "-o", d / "b.exr", "--json", out_link}, "\"status\":\"ok\"", false},
        {{"bake", png, "-o", d / "c.exr", "--json", dev_err}, "\"status\":\"ok\"", true},
        {{"plan", "--lights", "D65", "--max-de", "3", "--grids", "380:780:20", "--precision",
          "full", "--json", out_link},
         "\"lights\"",
         false},
        {{"plan", "--lights", "D65", "--max-de", "3", "--grids", "380:780:20", "--precision",
          "full", "--grid-file", err_link},
         "# spectex plan",
         true},
        {{"basis", "-q", "-o", out_link}, "wavelength,r,g,b", false},
        {{"plot", exr, "--pixel", "0,0", "-o", err_link}, "<svg", true},
    };
    for (const auto& c : cases) {
        RunResult r = run_spectex(c.args);
        EXPECT_EQ(r.status, 0) << c.args[0] << ": " << r.err;
        EXPECT_TRUE(has_text(c.to_stderr ? r.err : r.out, c.expect))
            << c.args[0] << " " << c.args.back() << ": the output never reached the stream\n"
            << r.out << r.err;
    }
    EXPECT_TRUE(is_link(out_link)) << "the link to standard output was replaced";
    EXPECT_TRUE(is_link(err_link)) << "the link to standard error was replaced";
    EXPECT_EQ(link_text(out_link), "/proc/self/fd/1");
    EXPECT_TRUE(is_link(dev_out) && is_link(dev_err));
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(OutputTargets, FileOutputsNamingAStreamAreRefusedAndTheLinkStays) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 8, 4), exr = d / "a.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    const std::string exr_link = d / "out.exr", png_link = d / "out.png";
    ASSERT_EQ(::symlink("/proc/self/fd/1", exr_link.c_str()), 0);
    ASSERT_EQ(::symlink("/dev/stdout", png_link.c_str()), 0);
    RunResult b = run_spectex({"bake", png, "-o", exr_link});
    EXPECT_EQ(b.status, 2) << b.err;
    EXPECT_TRUE(has_text(b.err, "names a stream")) << b.err;
    RunResult r = run_spectex({"render", exr, "-o", png_link});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(has_text(r.err, "names a stream")) << r.err;
    EXPECT_TRUE(is_link(exr_link));
    EXPECT_TRUE(is_link(png_link));
    EXPECT_TRUE(r.out.empty() && b.out.empty()) << "bytes reached standard output";
}

// A link to a regular file: the rename lands on the target and the link keeps its text. A link
// to nothing or to itself is refused (following it would create a file nobody named).
TEST(OutputTargets, LinksToFilesAreWrittenThroughAndDanglingLinksRefused) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 8, 4);
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
    EXPECT_TRUE(has_text(read_file(d / "store/real.json"), "\"status\":\"ok\""));
    EXPECT_TRUE(temp_files_in(d.path()).empty());
    EXPECT_TRUE(temp_files_in(d / "store").empty());

    ASSERT_EQ(::symlink("nowhere/x.exr", (d / "dangling.exr").c_str()), 0);
    ASSERT_EQ(::symlink("loop.exr", (d / "loop.exr").c_str()), 0);
    for (const std::string& out : {d / "dangling.exr", d / "loop.exr"}) {
        RunResult x = run_spectex({"bake", png, "-o", out});
        EXPECT_EQ(x.status, 2) << x.err;
        EXPECT_TRUE(has_text(x.err, "refusing to write through it")) << x.err;
        EXPECT_TRUE(is_link(out));
        RunResult v = run_spectex({"verify", d / "store/real.exr", "--json", out});
        EXPECT_EQ(v.status, 2) << v.err;
    }
    EXPECT_FALSE(file_exists(d / "nowhere/x.exr"));
}

// A /proc/self/fd/N the shell passed is a stream; one spectex would open itself (an output being
// written, a library's file) is not: a report written there could land inside another output.
TEST(OutputTargets, OnlyDescriptorsTheShellPassedAreStreams) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 8, 4), exr = d / "a.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    RunResult given = run_shell(spectex_binary() + " verify " + exr +
                                " -q --json /proc/self/fd/9 9>" + d.path() + "/report.json");
    EXPECT_EQ(given.status, 0) << given.out;
    EXPECT_TRUE(has_text(read_file(d / "report.json"), "\"schema_version\"")) << given.out;
    // Descriptors 20 and 250 are not open when spectex starts: refused before any work.
    for (const std::string fd : {"20", "250"}) {
        RunResult r = run_spectex({"verify", exr, "--json", "/proc/self/fd/" + fd});
        EXPECT_EQ(r.status, 2) << fd << ": " << r.err;
        EXPECT_TRUE(has_text(r.err, "which spectex was not given")) << r.err;
        RunResult b = run_spectex(
            {"bake", png, "-o", d / "b.exr", "--jobs", "1", "--json", "/proc/self/fd/" + fd});
        EXPECT_EQ(b.status, 2) << fd << ": " << b.err;
        EXPECT_FALSE(file_exists(d / "b.exr"));
    }
}
