// Messages are for people and logs: every line on stderr is one of ours ("spectex: ..." or
// "spectex <command>: ..."), one line per error, with bytes that are not printable escaped as \xNN,
// whatever a file's name holds or a library says (libpng and libjpeg through OpenImageIO, OCIO's
// own logging).
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;

namespace {

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

std::vector<std::string> lines(const std::string& s) {
    std::vector<std::string> v;
    std::istringstream in(s);
    for (std::string l; std::getline(in, l);) v.push_back(l);
    return v;
}

// Every line starts with "spectex" or "Try 'spectex", and holds only printable ASCII or UTF-8.
void expect_clean_stderr(const RunResult& r, const std::string& context) {
    for (const auto& l : lines(r.err)) {
        EXPECT_TRUE(l.rfind("spectex", 0) == 0 || l.rfind("Try 'spectex", 0) == 0)
            << context << ": a line that is not ours: " << l;
        for (unsigned char c : l)
            EXPECT_FALSE(c < 0x20 || c == 0x7f) << context << ": raw control byte in: " << l;
    }
}

void write_bytes(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

}  // namespace

TEST(Messages, FileNamesWithControlBytesAreEscaped) {
    ScratchDir d;
    const std::string name = d.path() + "/bad\x01\x1b[31mname\xff\xfe\n2.png";
    RunResult r = run_spectex({"bake", name, "-o", d / "o.exr"});
    EXPECT_EQ(r.status, 1) << r.err;
    expect_clean_stderr(r, "missing input with control bytes");
    // In bash's $'...' form, which a shell reads back as the same bytes.
    EXPECT_TRUE(contains(r.err, "$'" + d.path() + "/bad\\x01\\x1b[31mname\\xff\\xfe\\n2.png'"))
        << r.err;
    // A UTF-8 name is not mangled.
    RunResult u = run_spectex({"bake", d.path() + "/tëxture.png", "-o", d / "o.exr"});
    EXPECT_TRUE(contains(u.err, "tëxture.png")) << u.err;
}

TEST(Messages, LibraryErrorsAreOneLineWithOurPrefix) {
    ScratchDir d;
    std::vector<uint8_t> px(64 * 64 * 3, 100);
    write_image(d / "good.png", 64, 64, 3, OIIO::TypeDesc::UINT8, px.data());
    write_image(d / "good.jpg", 64, 64, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::string png = read_file(d / "good.png"), jpg = read_file(d / "good.jpg");
    // Broken files whose libraries have a lot to say: a PNG with a corrupt IHDR and with binary
    // garbage after the signature, a JPEG with garbage in its header, a file of random bytes
    // with a PNG name.
    std::string ihdr = png;
    ihdr[16] = '\xff';  // width 0xff000040: "Image width exceeds user limit" / CRC error
    write_bytes(d / "ihdr.png", ihdr);
    write_bytes(
        d / "garbage.png",
        png.substr(0, 8) + std::string("\x00\x01\x02\x1b[2J\xff\xfe\x07", 10) + png.substr(40));
    std::string j = jpg;
    for (size_t i = 20; i < 60 && i < j.size(); ++i) j[i] = static_cast<char>(i * 37);
    write_bytes(d / "header.jpg", j);
    std::string noise;
    for (int i = 0; i < 4096; ++i) noise += static_cast<char>((i * 7919) & 0xff);
    write_bytes(d / "noise.png", noise);
    for (const std::string f : {"ihdr.png", "garbage.png", "header.jpg", "noise.png"}) {
        RunResult r = run_spectex({"bake", d / f, "-o", d / "o.exr"});
        EXPECT_EQ(r.status, 1) << f << ": " << r.err;
        expect_clean_stderr(r, f);
        auto ls = lines(r.err);
        ASSERT_FALSE(ls.empty()) << f;
        EXPECT_EQ(ls.front().rfind("spectex: " + d / f + ": ", 0), 0u) << f << ": " << r.err;
        size_t errors = 0;
        for (const auto& l : ls) errors += l.rfind("spectex: " + d / f, 0) == 0;
        EXPECT_EQ(errors, 1u) << f << ": one error line per failure:\n" << r.err;
    }
}

TEST(Messages, OcioInfoAndDebugNeverReachStderrButWarningsDo) {
    ScratchDir d;
    std::vector<uint8_t> px(4 * 4 * 3, 100);
    write_image(d / "in.png", 4, 4, 3, OIIO::TypeDesc::UINT8, px.data());
    // OCIO logs through its own function (to std::cerr), at the level $OCIO_LOGGING_LEVEL asks:
    // our config and a bake give no warning, and info and debug chatter is not shown.
    for (const std::string level : {"debug", "info", "warning"}) {
        RunResult r =
            run_spectex({"bake", d / "in.png", "-o", d / "o.exr"}, {"OCIO_LOGGING_LEVEL=" + level});
        EXPECT_EQ(r.status, 0) << level << ": " << r.err;
        EXPECT_FALSE(contains(r.err, "OpenColorIO")) << level << ":\n" << r.err;
        expect_clean_stderr(r, "OCIO_LOGGING_LEVEL=" + level);
    }
    // A warning does reach the log, once, marked as the library's: OCIO complains about a bad
    // level on std::cerr directly, at its first use.
    RunResult bogus =
        run_spectex({"bake", d / "in.png", "-o", d / "o.exr"}, {"OCIO_LOGGING_LEVEL=bogus"});
    EXPECT_EQ(bogus.status, 0) << bogus.err;
    expect_clean_stderr(bogus, "OCIO_LOGGING_LEVEL=bogus");
    size_t shown = 0;
    for (const auto& l : lines(bogus.err))
        shown += l.rfind("spectex: library: [OpenColorIO Warning]", 0) == 0;
    EXPECT_EQ(shown, 1u) << bogus.err;
    // SPECTEX_LIBRARY_MESSAGES=0 drops it; =1 shows everything, debug included.
    RunResult none = run_spectex({"bake", d / "in.png", "-o", d / "o.exr"},
                                 {"OCIO_LOGGING_LEVEL=bogus", "SPECTEX_LIBRARY_MESSAGES=0"});
    EXPECT_FALSE(contains(none.err, "OpenColorIO")) << none.err;
    RunResult all = run_spectex({"bake", d / "in.png", "-o", d / "o.exr"},
                                {"OCIO_LOGGING_LEVEL=debug", "SPECTEX_LIBRARY_MESSAGES=1"});
    EXPECT_TRUE(contains(all.err, "spectex: library: [OpenColorIO Debug")) << all.err;
}

TEST(Messages, AFailedRunEndsWithTheCommandToRerun) {
    ScratchDir d;
    std::vector<uint8_t> px(4 * 4 * 3, 100);
    write_image(d / "in.png", 4, 4, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::string missing = d / "no such.png";
    RunResult r = run_spectex({"bake", d / "in.png", missing, "--output-dir", d / "out"});
    EXPECT_EQ(r.status, 1) << r.err;
    auto ls = lines(r.err);
    ASSERT_FALSE(ls.empty());
    // Last, once, shell-quoted so it can be pasted back.
    EXPECT_EQ(ls.back(), "spectex: the command was: spectex bake " + d / "in.png" + " '" + missing +
                             "' --output-dir " + d / "out")
        << r.err;
    size_t n = 0;
    for (const auto& l : ls) n += l.rfind("spectex: the command was:", 0) == 0;
    EXPECT_EQ(n, 1u) << r.err;
    // Not after a success, nor after a usage error (which says what to run instead).
    RunResult ok = run_spectex({"bake", d / "in.png", "-o", d / "o.exr"});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_FALSE(contains(ok.err, "the command was")) << ok.err;
    RunResult usage = run_spectex({"bake", "--no-such-option", d / "in.png"});
    EXPECT_EQ(usage.status, 2) << usage.err;
    EXPECT_FALSE(contains(usage.err, "the command was")) << usage.err;
}

TEST(Messages, PathsAShellWouldSplitAreQuotedInMessages) {
    ScratchDir d;
    // From a list (spaces around a path are the list's and dropped; inside it they are the name's),
    // and as arguments: the error names the file so that it can be pasted back into a shell.
    const std::string spaced = d / "my file.png", plain = d / "plain.png";
    std::ofstream(d / "list.txt") << "  " << spaced << "  \n" << plain << "\n";
    RunResult r = run_spectex({"bake", "--from-list", d / "list.txt", "--output-dir", d / "out"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(contains(r.err, "spectex: '" + spaced + "': No such file or directory\n")) << r.err;
    EXPECT_TRUE(contains(r.err, "spectex: " + plain + ": No such file or directory\n")) << r.err;
    expect_clean_stderr(r, "quoted paths");
    for (const char* cmd : {"info", "verify"}) {
        RunResult c = run_spectex({cmd, d / "no such.exr"});
        EXPECT_EQ(c.status, 1) << cmd << ": " << c.err;
        EXPECT_EQ(lines(c.err).front(),
                  "spectex: '" + d / "no such.exr" + "': No such file or directory")
            << cmd;
    }
    // A baked file's verbose lines quote it too.
    std::vector<uint8_t> px(4 * 4 * 3, 100);
    write_image(spaced, 4, 4, 3, OIIO::TypeDesc::UINT8, px.data());
    RunResult v = run_spectex({"bake", spaced, "-o", d / "o.exr", "-v"});
    EXPECT_EQ(v.status, 0) << v.err;
    EXPECT_TRUE(contains(v.err, "spectex: '" + spaced + "' -> " + d / "o.exr" + ": ")) << v.err;
}
