// Batches: several inputs, templates, UDIM tiles, lists (bounded, trimmed, from a pipe), shards,
// JSON Lines, failures. What --update skips is in update_test.cpp.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstring>
#include <fstream>
#include <map>
#include <set>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

void write_small_png(const std::string& path, int seed) {
    std::vector<uint8_t> px(8 * 4 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 37 + seed * 11) & 255);
    write_image(path, 8, 4, 3, OIIO::TypeDesc::UINT8, px.data());
}

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

size_t count_lines(const std::string& s, const std::string& needle) {
    size_t n = 0;
    std::istringstream in(s);
    for (std::string line; std::getline(in, line);) n += contains(line, needle);
    return n;
}

}  // namespace

TEST(Batch, OutputDirAndTemplateAndFailuresDoNotStopOthers) {
    ScratchDir d;
    write_small_png(d / "a.png", 1);
    write_small_png(d / "b.png", 2);
    std::ofstream(d / "broken.png") << "not an image";
    auto r = run_spectex({"bake", d / "a.png", d / "broken.png", d / "b.png", "--output-dir",
                          d / "out", "--json", "-"});
    EXPECT_EQ(r.status, 1) << r.err;  // one failed: the batch fails, the others are baked
    EXPECT_TRUE(file_exists(d / "out/a.exr"));
    EXPECT_TRUE(file_exists(d / "out/b.exr"));
    EXPECT_FALSE(file_exists(d / "out/broken.exr"));
    EXPECT_EQ(count_lines(r.out, "\"schema_version\":2"), 3u);
    EXPECT_EQ(count_lines(r.out, "\"status\":\"ok\""), 2u);
    EXPECT_EQ(count_lines(r.out, "\"status\":\"failed\""), 1u);
    EXPECT_TRUE(contains(r.err, "2 baked, 0 up to date, 1 failed of 3")) << r.err;

    auto t =
        run_spectex({"bake", d / "a.png", d / "b.png", "-o", "{dir}/{stem}_{ext}.spectral.exr"});
    EXPECT_EQ(t.status, 0) << t.err;
    EXPECT_TRUE(file_exists(d / "a_png.spectral.exr"));
    EXPECT_TRUE(file_exists(d / "b_png.spectral.exr"));

    // Several inputs with a plain -o: a usage error, nothing written.
    auto u = run_spectex({"bake", d / "a.png", d / "b.png", "-o", d / "one.exr"});
    EXPECT_EQ(u.status, 2);
    EXPECT_FALSE(file_exists(d / "one.exr"));
}

// Options that name one thing twice are usage errors, and a usage error creates nothing: -o FILE
// beside --output-dir was dropped without a word (the output landed as DIR/<stem>.exr), one grid
// from --wavelengths and another from --wavelengths-file kept the file's, and --output-dir's
// folders were made before the checks that refused the command (two inputs writing one output).
TEST(Batch, OptionsNamingOneThingTwiceAreRefusedAndCreateNothing) {
    ScratchDir d;
    write_small_png(d / "a.png", 1);
    write_small_png(d / "b.png", 2);
    std::ofstream(d / "grid.txt") << "400\n500\n600\n700\n";
    auto refused = [&](const std::vector<std::string>& args, const std::string& says) {
        const RunResult r = run_spectex(args);
        EXPECT_EQ(r.status, 2) << args[0] << " " << says << ": " << r.err;
        EXPECT_TRUE(contains(r.err, says)) << r.err;
    };
    refused({"bake", d / "a.png", "-o", d / "r.exr", "--output-dir", d / "od"},
            "names one file and --output-dir a folder");
    EXPECT_FALSE(file_exists(d / "r.exr"));
    EXPECT_FALSE(file_exists(d / "od"));
    refused({"bake", d / "a.png", d / "b.png", d / "./a.png", "--output-dir", d / "nd/deeper"},
            "would write an output another input writes");
    EXPECT_FALSE(file_exists(d / "nd"));
    // One file under two spellings is said to be that, not two inputs to name apart.
    refused({"bake", d / "a.png", d / "./a.png", "--output-dir", d / "nd"},
            "the same file, given twice; list it once");
    for (const auto& order : {std::vector<std::string>{"--wavelengths", "400:700:20",
                                                       "--wavelengths-file", d / "grid.txt"},
                              std::vector<std::string>{"--wavelengths-file", d / "grid.txt",
                                                       "--wavelengths", "400:700:20"}}) {
        std::vector<std::string> bake = {"bake", d / "a.png", "-o", d / "w.exr"};
        bake.insert(bake.end(), order.begin(), order.end());
        refused(bake, "--wavelengths and --wavelengths-file are two grids");
        std::vector<std::string> basis = {"basis", "-o", d / "w.csv"};
        basis.insert(basis.end(), order.begin(), order.end());
        refused(basis, "--wavelengths and --wavelengths-file are two grids");
    }
    EXPECT_FALSE(file_exists(d / "w.exr"));
    EXPECT_FALSE(file_exists(d / "w.csv"));
    // A template inside the folder is the way to name outputs there; the folder is made then.
    const RunResult t = run_spectex(
        {"bake", d / "a.png", "-o", "{stem}.t.exr", "--output-dir", d / "od", "--method", "basis"});
    EXPECT_EQ(t.status, 0) << t.err;
    EXPECT_TRUE(file_exists(d / "od/a.t.exr"));
}

TEST(Batch, FailFastStops) {
    ScratchDir d;
    std::ofstream(d / "0_broken.png") << "x";
    write_small_png(d / "1.png", 1);
    auto r = run_spectex(
        {"bake", d / "0_broken.png", d / "1.png", "--output-dir", d / "out", "--fail-fast"});
    EXPECT_EQ(r.status, 1);
    EXPECT_FALSE(file_exists(d / "out/1.exr"));
    EXPECT_TRUE(contains(r.err, "not attempted")) << r.err;
}

TEST(Batch, UdimTilesAndListFromStdinFile) {
    ScratchDir d;
    for (int t : {1001, 1002, 1011}) write_small_png(d / ("wood." + std::to_string(t) + ".png"), t);
    write_small_png(d / "wood.999.png", 0);  // not a UDIM tile
    auto r = run_spectex({"bake", d / "wood.<UDIM>.png", "--output-dir", d / "out"});
    EXPECT_EQ(r.status, 0) << r.err;
    auto names = list_dir(d / "out");
    EXPECT_EQ(std::set<std::string>(names.begin(), names.end()),
              (std::set<std::string>{"wood.1001.exr", "wood.1002.exr", "wood.1011.exr"}));
    std::ofstream(d / "list.txt") << "# inputs\n"
                                  << (d / "wood.1001.png") << "\n\n"
                                  << (d / "wood.999.png") << "\n";
    auto l = run_spectex({"bake", "--from-list", d / "list.txt", "--output-dir", d / "out2"});
    EXPECT_EQ(l.status, 0) << l.err;
    EXPECT_EQ(list_dir(d / "out2").size(), 2u);
    auto none = run_spectex({"bake", d / "stone.<UDIM>.png", "--output-dir", d / "out3"});
    EXPECT_EQ(none.status, 1);
    EXPECT_TRUE(contains(none.err, "no existing tiles")) << none.err;
}

TEST(Batch, ShardsCoverEveryInputExactlyOnce) {
    ScratchDir d;
    std::vector<std::string> inputs;
    for (int i = 0; i < 11; ++i) {
        inputs.push_back(d / ("t" + std::to_string(i) + ".png"));
        write_small_png(inputs.back(), i);
    }
    std::map<std::string, int> baked;
    const int n = 3;
    for (int k = 1; k <= n; ++k) {
        std::vector<std::string> args{"bake"};
        args.insert(args.end(), inputs.rbegin(), inputs.rend());  // order given must not matter
        args.insert(args.end(), {"--output-dir", d / "out", "--shard",
                                 std::to_string(k) + "/" + std::to_string(n), "--json", "-"});
        auto r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << r.err;
        std::istringstream in(r.out);
        for (std::string line; std::getline(in, line);) {
            auto a = line.find("\"input\":\"") + 9;
            baked[line.substr(a, line.find('"', a) - a)]++;
        }
    }
    ASSERT_EQ(baked.size(), inputs.size());
    for (const auto& [in, times] : baked) EXPECT_EQ(times, 1) << in;
    EXPECT_EQ(list_dir(d / "out").size(), inputs.size());
    // A farm log says which shard ran and what it held, even a shard of one file or none (more
    // shards than files): a silent task cannot be told from one that never started.
    for (const std::string shard : {"1/20", "20/20"}) {
        const auto r = run_spectex(
            {"bake", inputs[0], inputs[1], "--output-dir", d / "few", "--shard", shard});
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_TRUE(contains(r.err, "failed of ")) << r.err;
        EXPECT_TRUE(contains(r.err, "(shard " + shard + " of 2 listed files)")) << r.err;
    }
    EXPECT_EQ(run_spectex({"bake", inputs[0], "--output-dir", d / "o", "--shard", "4/3"}).status,
              2);
    EXPECT_EQ(run_spectex({"bake", inputs[0], "--output-dir", d / "o", "--shard", "0/3"}).status,
              2);
}

// Checks that concern the whole list look at the whole list before the shard is taken: two inputs
// of the same name in different folders collide under --output-dir, and an output that is another
// entry's input would overwrite it. Without --shard the list is refused (exit 2); each shard must
// be refused too, even when the two entries fall into different shards (where each shard alone
// sees no clash and the last task to finish would win).
TEST(Batch, EveryShardIsRefusedForAClashInTheWholeList) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "chair").c_str(), 0755), 0);
    ASSERT_EQ(::mkdir((d / "table").c_str(), 0755), 0);
    write_small_png(d / "chair/diffuse.png", 1);
    write_small_png(d / "table/diffuse.png", 2);
    std::ofstream(d / "list.txt") << d / "chair/diffuse.png"
                                  << "\n"
                                  << d / "table/diffuse.png"
                                  << "\n";
    const RunResult whole = run_spectex(
        {"bake", "--from-list", d / "list.txt", "--output-dir", d / "out", "--method", "basis"});
    EXPECT_EQ(whole.status, 2) << whole.err;
    for (const char* shard : {"1/2", "2/2"}) {
        for (bool dry : {false, true}) {
            std::vector<std::string> args{"bake",         "--from-list", d / "list.txt",
                                          "--output-dir", d / "out",     "--method",
                                          "basis",        "--shard",     shard};
            if (dry) args.push_back("--dry-run");
            const RunResult r = run_spectex(args);
            EXPECT_EQ(r.status, 2)
                << "--shard " << shard << (dry ? " --dry-run" : "") << ": " << r.err;
            EXPECT_TRUE(contains(r.err, "chair/diffuse.png") &&
                        contains(r.err, "table/diffuse.png"))
                << r.err;
        }
    }
    EXPECT_FALSE(file_exists(d / "out/diffuse.exr"));

    // An output that is another entry's input: with -o {dir}/{stem}_{ext}.exr, c.png (shard 1 of
    // 2, byte order) writes c_png.exr, which is the input of shard 2's entry.
    write_small_png(d / "c.png", 3);
    std::ofstream(d / "c_png.exr") << "another entry's input, never overwritten";
    const std::string before = read_file(d / "c_png.exr");
    for (const char* shard : {"", "1/2", "2/2"}) {
        std::vector<std::string> args{
            "bake",     d / "c.png", d / "c_png.exr", "-o", d / "{stem}_{ext}.exr",
            "--method", "basis"};
        if (*shard) args.insert(args.end(), {"--shard", shard});
        const RunResult r = run_spectex(args);
        EXPECT_EQ(r.status, 2) << "--shard " << shard << ": " << r.err;
    }
    EXPECT_TRUE(read_file(d / "c_png.exr") == before) << "an input of the list was overwritten";
}

TEST(Batch, JobsGiveTheSameBytesAsOneJob) {
    ScratchDir d;
    std::vector<std::string> args1{"bake"}, args2{"bake"};
    for (int i = 0; i < 4; ++i) {
        std::string p = d / ("t" + std::to_string(i) + ".png");
        write_small_png(p, i);
        args1.push_back(p);
        args2.push_back(p);
    }
    // Same command line except the folder and --jobs: compare everything after the header.
    args1.insert(args1.end(), {"-o", "{dir}/j1/{stem}.exr", "--jobs", "1"});
    args2.insert(args2.end(), {"-o", "{dir}/j2/{stem}.exr", "--jobs", "2"});
    mkdir((d / "j1").c_str(), 0777);
    mkdir((d / "j2").c_str(), 0777);
    ASSERT_EQ(run_spectex(args1).status, 0);
    ASSERT_EQ(run_spectex(args2).status, 0);
    for (int i = 0; i < 4; ++i) {
        std::string a = read_file(d / ("j1/t" + std::to_string(i) + ".exr"));
        std::string b = read_file(d / ("j2/t" + std::to_string(i) + ".exr"));
        ASSERT_FALSE(a.empty());
        // Only spectex:commandLine differs ("1" vs "2", "j1" vs "j2": same length), so the bytes do
        // not move: compare the pixel data after the header.
        ASSERT_EQ(a.size(), b.size());
        size_t header_end = a.find("spectex:version");
        ASSERT_NE(header_end, std::string::npos);
        EXPECT_EQ(a.substr(header_end), b.substr(header_end)) << i;
    }
}

TEST(Batch, OutputRespectsUmask) {
    ScratchDir d;
    write_small_png(d / "a.png", 1);
    // The child inherits our umask.
    mode_t old = umask(027);
    auto r = run_spectex({"bake", d / "a.png", "-o", d / "a.exr"});
    umask(old);
    ASSERT_EQ(r.status, 0) << r.err;
    struct stat st;
    ASSERT_EQ(stat((d / "a.exr").c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0640u);
}

TEST(Batch, TwoTasksWritingOneOutputLeaveAValidFile) {
    // Two farm tasks baking to the same name at once: each writes its own temporary file and
    // renames it, so the survivor is one complete file and no temporary file is left.
    ScratchDir d;
    std::vector<uint8_t> px(512 * 256 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 7919) >> 3);
    write_image(d / "in.png", 512, 256, 3, OIIO::TypeDesc::UINT8, px.data());
    std::string cmd =
        spectex_binary() + " bake " + (d / "in.png") + " -o " + (d / "out.exr") + " -q";
    int st = std::system(("(" + cmd + " & " + cmd + " & wait) ; exit 0").c_str());
    ASSERT_EQ(st, 0);
    auto names = list_dir(d.path());
    EXPECT_EQ(std::set<std::string>(names.begin(), names.end()),
              (std::set<std::string>{"in.png", "out.exr"}));
    auto info = run_spectex({"info", d / "out.exr"});
    EXPECT_EQ(info.status, 0) << info.err;
    auto v =
        run_spectex({"verify", d / "out.exr", "--source", d / "in.png", "--min-code-match", "100"});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
}

TEST(Batch, JsonReportsStagesAndTheWriter) {
    // The stages of --json: every one present and not negative, the writer named (core for zip,
    // scanline or tiled; imf for piz), and a failed file has no stages.
    ScratchDir d;
    write_small_png(d / "a.png", 1);
    auto stages_of = [&](const std::vector<std::string>& extra) {
        std::vector<std::string> args{"bake",    d / "a.png", "-o", d / "a.exr",
                                      "--force", "--json",    "-"};
        args.insert(args.end(), extra.begin(), extra.end());
        auto r = run_spectex(args);
        EXPECT_EQ(r.status, 0) << r.err;
        return r.out;
    };
    const std::string zip = stages_of({});
    EXPECT_TRUE(contains(zip, "\"stages\":{\"writer\":\"core\"")) << zip;
    for (const char* k : {"read_s", "colour_s", "expand_s", "pack_s", "encoder_wait_s",
                          "producer_wait_s", "compress_cpu_s", "finish_s"}) {
        const size_t at = zip.find(std::string("\"") + k + "\":");
        ASSERT_NE(at, std::string::npos) << k;
        EXPECT_GE(std::stod(zip.substr(at + std::strlen(k) + 3)), 0.0) << k;
    }
    EXPECT_TRUE(contains(stages_of({"--compression", "piz"}), "\"writer\":\"imf\""));
    EXPECT_TRUE(contains(stages_of({"--tile", "4", "--mipmap"}), "\"writer\":\"core\""));
    auto bad = run_spectex({"bake", d / "missing.png", "-o", d / "m.exr", "--json", "-"});
    EXPECT_EQ(bad.status, 1);
    EXPECT_FALSE(contains(bad.out, "\"stages\"")) << bad.out;
}

TEST(Batch, ZipLevelChangesTheStreamNotThePixels) {
    // --zip-level is recorded, changes the bytes (level 1 deflates less) and the settings hash,
    // and never the pixels; out-of-range levels are usage errors (exit 2).
    ScratchDir d;
    std::vector<uint8_t> px(64 * 64 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * i / 7 + i / 64) & 255);
    write_image(d / "a.png", 64, 64, 3, OIIO::TypeDesc::UINT8, px.data());
    // The default bake deflates by size: at level 6 up to 512 x 512 pixels, 1 above (a 513 x 512
    // texture); level 4 asked for.
    ASSERT_EQ(
        run_spectex({"bake", d / "a.png", "-o", d / "l4.exr", "-q", "--zip-level", "4"}).status, 0);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "l1.exr", "-q"}).status, 0);
    ExrImage a = read_exr(d / "l4.exr"), b = read_exr(d / "l1.exr");
    EXPECT_EQ(a.attr("spectex:zipLevel"), "4");
    EXPECT_EQ(b.attr("spectex:zipLevel"), "6");
    for (const auto& [w, level] : {std::pair<int, const char*>{512, "6"}, {513, "1"}}) {
        std::vector<uint8_t> big(static_cast<size_t>(w) * 512 * 3, 128);
        write_image(d / "big.png", w, 512, 3, OIIO::TypeDesc::UINT8, big.data());
        ASSERT_EQ(run_spectex({"bake", d / "big.png", "-o", d / "big.exr", "-q"}).status, 0);
        EXPECT_EQ(read_exr(d / "big.exr").attr("spectex:zipLevel"), level) << w << " x 512";
        // The same settings hash either way: the rule is the setting, not the level it gives.
        EXPECT_EQ(read_exr(d / "big.exr").attr("spectex:settingsHash"),
                  b.attr("spectex:settingsHash"));
    }
    EXPECT_NE(a.attr("spectex:settingsHash"), b.attr("spectex:settingsHash"));
    EXPECT_NE(read_file(d / "l4.exr").size(), read_file(d / "l1.exr").size());
    ASSERT_EQ(a.pixels.size(), b.pixels.size());
    for (const auto& [name, v] : a.pixels) EXPECT_EQ(v, b.pixels.at(name)) << name;
    for (const char* bad : {"0", "13", "x", ""})
        EXPECT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "x.exr", "--zip-level", bad}).status,
                  2)
            << bad;
}

TEST(Batch, ListsAreBoundedInPathsAndTrimmed) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 16, 8);
    {
        std::ofstream big(d / "big.txt");
        for (int i = 0; i < (1 << 20) + 1; ++i) big << "a\n";
    }
    RunResult r = run_spectex({"bake", "--from-list", d / "big.txt", "-o", d / "{stem}.exr"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(has_text(r.err, "line 1048577: more than 1048576 paths")) << r.err;
    std::ofstream(d / "spaced.txt") << "  " << png << " \t\n";
    RunResult t = run_spectex({"bake", "--from-list", d / "spaced.txt", "-o", d / "t.exr", "-q"});
    EXPECT_EQ(t.status, 0) << t.err;
    EXPECT_TRUE(file_exists(d / "t.exr"));
}

TEST(Batch, AListFromAPipeIsReadLikeStandardInput) {
    ScratchDir d;
    pattern_png(d, "a.png", 8, 4);
    pattern_png(d, "b.png", 8, 4);
    RunResult r =
        run_shell("cd " + d.path() + " && " + spectex_binary() +
                  " bake --from-list <(printf \"a.png\\nb.png\\n\") -o {dir}/{stem}.exr -q");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_TRUE(file_exists(d / "a.exr"));
    EXPECT_TRUE(file_exists(d / "b.exr"));
}

// UDIM = 1001 + u + 10 v, u in 0..9: 1010 and 1020 are the tenth column, 1100 is v = 9.
TEST(Batch, UdimExpansionTakesEveryColumn) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "u").c_str(), 0755), 0);
    const std::vector<std::string> tiles = {"1001", "1002", "1005", "1010", "1011",
                                            "1020", "1100", "2000", "9999"};
    for (const auto& t : tiles) pattern_png(d, "u/wood." + t + ".png", 4, 4);
    for (const auto& t : {"1000", "0999", "10001", "abcd"})
        pattern_png(d, std::string("u/wood.") + t + ".png", 4, 4);
    RunResult r = run_spectex({"bake", d / "u/wood.<UDIM>.png", "-o", "{dir}/{stem}.exr", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    for (const auto& t : tiles)
        EXPECT_TRUE(file_exists(d / ("u/wood." + t + ".exr"))) << "tile " << t << " not baked";
    for (const auto& t : {"1000", "0999", "10001", "abcd"})
        EXPECT_FALSE(file_exists(d / (std::string("u/wood.") + t + ".exr")))
            << t << " is no UDIM tile";
}
