// Messages are for people and logs: every line on stderr is one of ours ("spectex: ..." or
// "spectex <command>: ..."), one line per error, with bytes that are not printable escaped as \xNN,
// whatever a file's name holds or a library says (libpng and libjpeg through OpenImageIO, OCIO's
// own logging).
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

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

TEST(Messages, InvisibleAndInvalidCharactersNeverReachTheTerminalRaw) {
    ScratchDir d;
    struct Case {
        std::string raw, shown;
    };
    const std::vector<Case> cases = {
        {"c1\xc2\x9b"
         "31m",
         "c1\\u009b31m"},  // C1 control: 8-bit CSI
        {"bidi\xe2\x80\xae"
         "gpj",
         "bidi\\u202egpj"},  // right-to-left override
        {"zw\xe2\x80\x8b"
         "sp",
         "zw\\u200bsp"},                            // zero-width space
        {"sur\xed\xa0\x80", "sur\\xed\\xa0\\x80"},  // a UTF-16 surrogate in UTF-8: invalid
        {"over\xc0\xaf", "over\\xc0\\xaf"},         // overlong '/'
    };
    for (const auto& c : cases) {
        const std::string path = d / (c.raw + ".exr");
        std::ofstream(path) << "not an exr";
        for (const char* cmd : {"info", "verify"}) {
            RunResult r = run_spectex({cmd, path});
            EXPECT_EQ(r.status, 1);
            EXPECT_TRUE(has_text(r.err, c.shown)) << cmd << ": " << r.err;
            EXPECT_FALSE(has_text(r.err, c.raw)) << cmd << ": raw bytes on stderr";
        }
    }
}

TEST(Messages, InfoPrintsHeaderTextAsOnePrintableLine) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 16, 8), exr = d / "a.exr",
                      forged = d / "forged.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "--type", "float", "-q"}).status, 0);
    ExrImage img = read_exr(exr);
    Imf::Header h = img.header;
    h.insert("spectex:source", Imf::StringAttribute("\x1b]0;pwned\x07\x1b[2J\nFAKE LINE"));
    {
        Imf::OutputFile out(forged.c_str(), h);
        Imf::FrameBuffer fb;
        for (const auto& name : img.channel_names)
            fb.insert(name, Imf::Slice::Make(Imf::FLOAT, img.pixels[name].data(), img.data_window));
        out.setFrameBuffer(fb);
        out.writePixels(img.height);
    }
    RunResult r = run_spectex({"info", forged});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(has_text(r.out, "\x1b")) << "escape codes on stdout";
    EXPECT_FALSE(has_text(r.out, "\nFAKE LINE")) << "a forged line on stdout";
    EXPECT_TRUE(has_text(r.out, "spectex:source \\x1b]0;pwned\\x07\\x1b[2J; FAKE LINE")) << r.out;
}

// In a batch, a message about a file another file refers to (verify --source-from-header's
// source) names the EXR it belongs to: otherwise a user cannot tell which output failed.
TEST(Messages, EveryPerFileMessageNamesItsFile) {
    ScratchDir d;
    const std::string png = pattern_png(d, "gone.png", 8, 4);
    ASSERT_EQ(run_spectex({"bake", png, "-o", d / "h1.exr", "-q"}).status, 0);
    ASSERT_EQ(run_spectex({"bake", png, "-o", d / "h2.exr", "-q"}).status, 0);
    ASSERT_EQ(::unlink(png.c_str()), 0);
    RunResult r =
        run_spectex({"verify", d / "h1.exr", d / "h2.exr", "--source-from-header", "--jobs", "2"});
    EXPECT_EQ(r.status, 1) << r.err;
    for (const std::string exr : {d / "h1.exr", d / "h2.exr"})
        EXPECT_TRUE(has_text(r.err, "spectex: " + exr + ": ") ||
                    has_text(r.err, "(verifying " + exr + ")\n"))
            << "no line names " << exr << ":\n"
            << r.err;
}

TEST(Messages, TheCommandWasCanBePastedBackIntoAShell) {
    ScratchDir d;
    const std::string missing = d / "caf\xe9 \x01.png";
    RunResult r = run_spectex({"bake", missing, "-o", d / "o.exr"});
    ASSERT_EQ(r.status, 1) << r.err;
    const std::string marker = "spectex: the command was: ";
    const size_t at = r.err.find(marker);
    ASSERT_NE(at, std::string::npos) << r.err;
    std::string line = r.err.substr(at + marker.size());
    line = line.substr(0, line.find('\n'));
    EXPECT_TRUE(has_text(line, "$'")) << line;
    // bash reads the line back as the same words: print the second argument's bytes.
    const std::string script = "set -- " + line.substr(line.find(' ') + 1) + "; printf %s \"$2\"";
    FILE* p = ::popen(("LC_ALL=C.UTF-8 bash -c \"$(cat)\" >" + d / "word").c_str(), "w");
    ASSERT_NE(p, nullptr);
    std::fwrite(script.data(), 1, script.size(), p);
    ::pclose(p);
    EXPECT_EQ(read_file(d / "word"), missing) << line;
}
