// What a baked file's header says must be true of that file:
//  * verify tells a source that changed since the bake (its size or bytes differ from the recorded
//    spectex:sourceSize / spectex:sourceHash) from a bad bake, and says so in its own words (what
//    --update decides from the same records is in update_test.cpp);
//  * spectex:commandLine is a command that rebuilds this one file, whatever the batch it came from.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

// Single-quoted for bash.
std::string sh(const std::string& s) { return "'" + replace_all(s, "'", "'\\''") + "'"; }

}  // namespace

// ---------------------------------------------------------------------------------------------
// verify: a stale file is not a bad bake

TEST(ProvenanceTruth, VerifyReportsASourceReplacedSinceTheBakeAsChanged) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    // The texture is repainted after the bake (same size in pixels, other colours).
    write_pattern_png(d / "a.png", 7);
    RunResult r = run_spectex({"verify", d / "a.exr", "--source-from-header"});
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("result:               STALE: the source"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("changed since this file was baked"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("CIEDE2000 max"), std::string::npos) << "no colour verdict: " << r.out;
    EXPECT_NE(r.err.find("changed since this file was baked"), std::string::npos) << r.err;
    // The JSON record says so.
    r = run_spectex({"verify", d / "a.exr", "--source-from-header", "--json", "-"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.out.find("\"result\":\"stale\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"source_changed\":{"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"passed\":false"), std::string::npos) << r.out;
    // --source naming the same file: the same verdict.
    r = run_spectex({"verify", d / "a.exr", "--source", d / "a.png"});
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("STALE"), std::string::npos) << r.out;
}

// --report-only turns the gates off, not the facts: a file whose source changed was never
// compared, and a script reading "result" or "passed" must not take it for a good bake.
TEST(ProvenanceTruth, ReportOnlyStillCallsAStaleFileStaleAndNotPassedButExitsZero) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    write_pattern_png(d / "b.png", 2);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", d / "b.png", "--output-dir", d / "out"}).status, 0);
    write_pattern_png(d / "a.png", 7);
    RunResult r = run_spectex({"verify", d / "out/a.exr", "--source-from-header", "--report-only"});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("result:               STALE: the source"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("(reported, not failed: --report-only)"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("result:               ok"), std::string::npos) << r.out;
    r = run_spectex({"verify", d / "out/a.exr", d / "out/b.exr", "--source-from-header",
                     "--report-only", "--json", "-"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"result\":\"stale\""), 1u) << r.out;
    EXPECT_EQ(occurrences(r.out, "\"passed\":false"), 1u) << r.out;
    EXPECT_EQ(occurrences(r.out, "\"result\":\"ok\""), 1u) << r.out;
    // Several files: the per-file line and the summary say it too.
    r = run_spectex(
        {"verify", d / "out/a.exr", d / "out/b.exr", "--source-from-header", "--report-only"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("a.exr: STALE"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("2 files: 1 passed, 0 failed, 1 stale (not compared, not failed: "
                         "--report-only), 0 unreadable"),
              std::string::npos)
        << r.out;
}

TEST(ProvenanceTruth, VerifyTellsASameSizeReplacementByItsBytesAndIgnoresATouch) {
    ScratchDir d;
    write_pattern_ppm(d / "a.ppm", 1);
    write_pattern_ppm(d / "b.ppm", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.ppm", d / "b.ppm", "--output-dir", d / "out"}).status, 0);
    write_pattern_ppm(d / "a.ppm", 2);  // same byte size, other bytes
    struct timespec ts[2] = {{946684800, 0}, {946684800, 0}};
    ASSERT_EQ(::utimensat(AT_FDCWD, (d / "b.ppm").c_str(), ts, 0), 0);  // a touch: same bytes
    const RunResult r = run_spectex(
        {"verify", d / "out/a.exr", d / "out/b.exr", "--source-from-header", "--json", "-"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"result\":\"stale\""), 1u) << r.out;
    EXPECT_EQ(occurrences(r.out, "\"result\":\"ok\""), 1u) << r.out;
    EXPECT_NE(r.out.find("b.exr\",\"width\""), std::string::npos) << r.out;
}

TEST(ProvenanceTruth, VerifyStillCallsABadBakeOfTheRightSourceAColourFailure) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    // The source is the one recorded; its colours are read as something else than at the bake:
    // the colours differ, and that is a colour failure, not a stale file.
    const RunResult r = run_spectex(
        {"verify", d / "a.exr", "--source-from-header", "--colorspace", "lin_srgb", "--json", "-"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.out.find("CIEDE2000 max"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"result\":\"failed\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"source_changed\":null"), std::string::npos) << r.out;
}

TEST(ProvenanceTruth, VerifyOfAFileThatRecordsNoIdentityComparesColoursAsBefore) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    hide_attributes(d / "a.exr", {"spectex:sourceHash", "spectex:sourceSize"});
    write_pattern_png(d / "a.png", 7);
    const RunResult r = run_spectex({"verify", d / "a.exr", "--source-from-header"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.out.find("result:               FAILED: CIEDE2000 max"), std::string::npos)
        << r.out;
    EXPECT_EQ(r.out.find("STALE"), std::string::npos) << r.out;
}

// ---------------------------------------------------------------------------------------------
// spectex:commandLine: this file's command, not the batch's

TEST(ProvenanceTruth, EachOutputOfABatchRecordsACommandThatRebuildsItAlone) {
    ScratchDir d;
    const std::string bin = spectex_binary();
    ASSERT_EQ(::mkdir((d / "tex").c_str(), 0755), 0);
    std::string list;
    const int n = 60;
    for (int i = 0; i < n; ++i) {
        char name[32];
        std::snprintf(name, sizeof name, "tex/t%03d.png", i);
        write_pattern_png(d / name, i, 4, 4);
        list += std::string(name) + "\n";
    }
    // Names a shell must be told about: a space and a quote, and a leading dash.
    write_pattern_png(d / "tex/it's a tile.png", 3, 4, 4);
    write_pattern_png(d / "tex/-dash.png", 4, 4, 4);
    list += "tex/it's a tile.png\ntex/-dash.png\n";
    write_text(d / "list.txt", list);
    const RunResult r = run_shell("cd " + sh(d.path()) + " && " + sh(bin) +
                                  " bake --from-list list.txt --shard 1/1 --jobs 2 --json "
                                  "report.json -q --output-dir out --zip-level 5 --type float");
    ASSERT_EQ(r.status, 0) << r.out;

    size_t size = 0;
    for (int i = 0; i < n; ++i) {
        char name[32];
        std::snprintf(name, sizeof name, "out/t%03d.exr", i);
        const std::string cmd = read_exr(d / name).attr("spectex:commandLine");
        if (i == 0) size = cmd.size();
        // Constant size: one input and one output of the same length each time.
        EXPECT_EQ(cmd.size(), size) << cmd;
        char want[128];
        std::snprintf(want, sizeof want, "spectex bake tex/t%03d.png -o out/t%03d.exr", i, i);
        EXPECT_EQ(cmd.rfind(want, 0), 0u) << cmd;
        for (const char* batch_only : {"--from-list", "--shard", "--jobs", "--json", "list.txt",
                                       "--output-dir", "t001.png t002"})
            EXPECT_EQ(cmd.find(batch_only), std::string::npos) << batch_only << " in " << cmd;
        EXPECT_NE(cmd.find("--zip-level 5"), std::string::npos) << cmd;
        EXPECT_NE(cmd.find("--type float"), std::string::npos) << cmd;
        EXPECT_LT(cmd.size(), 200u) << cmd;
    }
    // Run in a shell, each recorded command rebuilds its file byte for byte.
    for (const std::string name : {"out/t007.exr", "out/it's a tile.exr", "out/-dash.exr"}) {
        const std::string before = read_file(d / name);
        ASSERT_FALSE(before.empty()) << name;
        const std::string cmd = read_exr(d / name).attr("spectex:commandLine");
        ASSERT_EQ(cmd.rfind("spectex ", 0), 0u) << cmd;
        ASSERT_EQ(::unlink((d / name).c_str()), 0);
        const RunResult again = run_shell("cd " + sh(d.path()) + " && " + sh(bin) + cmd.substr(7));
        ASSERT_EQ(again.status, 0) << cmd << "\n" << again.out;
        EXPECT_TRUE(read_file(d / name) == before) << name << " rebuilt differently by: " << cmd;
    }
}
