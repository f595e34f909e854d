// Progress: within a file, not only between files; on a terminal one line
// rewritten a few times a second; in a log (--progress, not a terminal) plain timestamped lines
// with no control codes, every SPECTEX_PROGRESS_SECONDS (default 10).
#include <gtest/gtest.h>

#include <regex>

#include "cli/cli_util.h"

using namespace spectex_test;

namespace {

void write_big_png(const std::string& path, int w, int h) {
    std::vector<unsigned char> px(static_cast<size_t>(w) * static_cast<size_t>(h) * 3);
    for (size_t i = 0; i < px.size(); ++i)
        px[i] = static_cast<unsigned char>((i * 2654435761u) >> 24);
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
}

}  // namespace

// In a *Slow* suite: the whole suite runs it; the sanitizer run (minutes of its time under ASan)
// not: a bake long enough to report progress, 4 times longer there. Every bit is kept: bits of
// their own for 401 bins would be chosen on every 8-bit colour (200 s), and progress is the same.
TEST(ProgressSlow, ALogGetsTimestampedLinesWithRowsAndNoControlCodes) {
    ScratchDir d;
    write_big_png(d / "big.png", 512, 512);
    write_big_png(d / "small.png", 16, 16);
    RunResult r = run_spectex(
        {"bake", d / "big.png", d / "small.png", "--output-dir", d / "out", "--progress",
         "--wavelengths", "380:780:1", "--precision", "full", "--jobs", "1"},
        {"SPECTEX_PROGRESS_SECONDS=0.05"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\033'), std::string::npos) << r.err;
    // Within the big file: "rows N/512 (P%)" before it is done, on a timestamped line.
    const std::regex within(
        R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ spectex: \[0/2\] 0 failed; big\.png: rows \d+/512 \(\d+%\))");
    EXPECT_TRUE(std::regex_search(r.err, within)) << r.err;
    // After each file, a line that counts it.
    EXPECT_TRUE(std::regex_search(r.err, std::regex(R"(Z spectex: \[1/2\] 0 failed)"))) << r.err;
    EXPECT_TRUE(std::regex_search(r.err, std::regex(R"(Z spectex: \[2/2\] 0 failed)"))) << r.err;
    // Every progress line is a whole line.
    for (size_t at = r.err.find("spectex: ["); at != std::string::npos;
         at = r.err.find("spectex: [", at + 1))
        EXPECT_NE(r.err.find('\n', at), std::string::npos);
}

TEST(Progress, WithoutProgressALogGetsNone) {
    ScratchDir d;
    write_big_png(d / "big.png", 256, 256);
    RunResult r = run_spectex({"bake", d / "big.png", "-o", d / "out.exr"},
                              {"SPECTEX_PROGRESS_SECONDS=0.05"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err.find("rows"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("spectex: ["), std::string::npos) << r.err;
}

// In a *Slow* suite: the whole suite runs it; the sanitizer run (minutes of its time under ASan)
// not: a bake long enough to report progress, 4 times longer there. Every bit is kept: bits of
// their own for 401 bins would be chosen on every 8-bit colour (200 s), and progress is the same.
TEST(ProgressSlow, ATerminalGetsOneRewrittenLineWithinTheFile) {
    if (std::system("command -v script >/dev/null 2>&1") != 0)
        GTEST_FAIL() << "script(1) (util-linux) is missing";
    ScratchDir d;
    write_big_png(d / "big.png", 512, 512);
    // script(1) gives spectex a pseudo-terminal; its output is the terminal's bytes.
    const std::string cmd = "script -qec \"'" + spectex_binary() + "' bake '" + d / "big.png" +
                            "' -o '" + d / "out.exr" +
                            "' --wavelengths 380:780:1 --precision full\" /dev/null > '" +
                            d / "tty.txt" + "' 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    const std::string tty = read_file(d / "tty.txt");
    EXPECT_NE(tty.find("\r\033[Kspectex: [0/1] 0 failed; big.png: rows "), std::string::npos)
        << tty;
    EXPECT_EQ(tty.find("Z spectex: ["), std::string::npos)
        << tty;  // no log timestamps on a terminal
}
