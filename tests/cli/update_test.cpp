// bake --update: what it decides and what a run that decides "up to date" costs.
//
// What it decides: an output is kept when its header records the same settings hash
// (spectex:settingsHash: settings that change pixels or layout, not threads or jobs), the same
// colour transform (spectex:colorTransform: what the OCIO config does to the file, OpenColorIO's
// cache ID of the processor from its colour space to linear Rec.709, not the config's bytes) and
// the same source identity: spectex:sourceSize, spectex:sourceMtime and spectex:sourceHash
// (FNV-1a 64 of the source's bytes, computed here independently). A source replaced by an
// older-dated file is rebuilt; a source touched without a change is not; --force rebuilds all.
//
// What it costs: starting the tool does not load OpenImageIO (it lives in the module
// spectex-oiio.so, loaded by what decodes or writes an image), and an --update run whose files are
// all up to date reads only the outputs' headers and builds nothing. Checked by what the process
// used (peak RSS, page faults: robust on a loaded machine, where times are not) and by taking the
// module away (SPECTEX_MODULE_DIR naming an empty folder). tests/bench/bench_update_skip measures
// the times.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <utime.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

// Under AddressSanitizer (tests/sanitize/run.sh) every process maps its shadow memory and the
// instrumented code faults in more pages: the bounds on page faults and resident memory measure the
// sanitizer, not spectex, so they are scaled (what loads, and what is built, is still asserted).
const double kCostScale = kBinarySanitized ? 8.0 : 1.0;

namespace {

struct Usage {
    int status = -1;
    std::string err;
    double max_rss_mb = 0;
    long minor_faults = 0;
};

// Runs spectex with extra environment entries; its exit status, stderr and resource usage. The
// usage is measured by /usr/bin/time, which forks the command from its own small process: a peak
// RSS read by wait4 here would include this test's own (exec keeps the spawner's high-water mark).
Usage run_measured(const std::vector<std::string>& args,
                   const std::vector<std::string>& extra_env = {}) {
    ScratchDir tmp;
    const std::string err = tmp / "err", usage = tmp / "usage";
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<std::string> argv_s = {"/usr/bin/time", "-o", usage, "-f", "%M %R"};
    for (const auto& a : spectex_argv(args)) argv_s.push_back(a);
    std::vector<std::string> env_s = environment_with(extra_env);
    std::vector<char*> argv = c_array(argv_s), envp = c_array(env_s);
    Usage u;
    pid_t pid;
    if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), envp.data()) == 0) {
        int st = 0;
        waitpid(pid, &st, 0);
        u.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    }
    posix_spawn_file_actions_destroy(&fa);
    u.err = read_file(err);
    // time writes "Command exited with non-zero status N" first when the command failed.
    std::istringstream in(read_file(usage));
    std::string line, last;
    while (std::getline(in, line))
        if (!line.empty()) last = line;
    long kb = 0;
    if (std::sscanf(last.c_str(), "%ld %ld", &kb, &u.minor_faults) == 2)
        u.max_rss_mb = static_cast<double>(kb) / 1024.0;
    return u;
}

void copy_file(const std::string& from, const std::string& to,
               const struct timespec* mtime = nullptr) {
    const std::string bytes = read_file(from);
    FILE* f = std::fopen(to.c_str(), "wb");
    ASSERT_NE(f, nullptr) << to;
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    if (mtime) {
        struct timespec ts[2] = {*mtime, *mtime};
        ::utimensat(AT_FDCWD, to.c_str(), ts, 0);
    }
}

void write_png(const std::string& path) {
    std::vector<uint8_t> px(4 * 4 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>(i * 37 + 11);
    write_image(path, 4, 4, 3, OIIO::TypeDesc::UINT8, px.data());
}

std::string shipped_config() {
    return read_file(std::string(SPECTEX_TEST_DATA_DIR) + "/spectex.ocio");
}

// Bakes a.png and b.png with config `cfg` into out/, then rewrites the config as `edited` and runs
// --update: returns its JSON Lines.
std::string update_after_edit(const ScratchDir& d, const std::string& edited) {
    write_pattern_png(d / "a.png", 1);
    write_pattern_png(d / "b.png", 2);
    write_text(d / "c.ocio", shipped_config());
    // Every bit kept: an edited sRGB curve is another precision question (the codes it decodes
    // to), whose chooser would run for a minute here and ten under the sanitizers; what is tested
    // is whether the edit is seen.
    const std::vector<std::string> bake = {"bake",     d / "a.png",   d / "b.png",
                                           "--config", d / "c.ocio",  "--output-dir",
                                           d / "out",  "--precision", "full"};
    RunResult r = run_spectex(bake);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(read_exr(d / "out/a.exr").attr("spectex:colorTransform").empty());
    write_text(d / "c.ocio", edited);
    std::vector<std::string> update = bake;
    update.insert(update.end(), {"--update", "--json", "-"});
    r = run_spectex(update);
    EXPECT_EQ(r.status, 0) << r.err;
    return r.out;
}

void write_small_png(const std::string& path, int seed) {
    std::vector<uint8_t> px(8 * 4 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 37 + seed * 11) & 255);
    write_image(path, 8, 4, 3, OIIO::TypeDesc::UINT8, px.data());
}

size_t count_lines(const std::string& s, const std::string& needle) {
    size_t n = 0;
    std::istringstream in(s);
    for (std::string line; std::getline(in, line);) n += has_text(line, needle);
    return n;
}

std::string fnv1a64_of_file(const std::string& path) {
    const std::string bytes = read_file(path);
    uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : bytes) h = (h ^ c) * 0x100000001b3ull;
    char buf[32];
    std::snprintf(buf, sizeof buf, "fnv1a64:%016llx", static_cast<unsigned long long>(h));
    return buf;
}

std::string mtime_of(const std::string& path) {
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) return "";
    char buf[48];
    std::snprintf(buf, sizeof buf, "%lld.%09ld", static_cast<long long>(st.st_mtim.tv_sec),
                  st.st_mtim.tv_nsec);
    return buf;
}

void set_mtime(const std::string& path, time_t sec, long nsec = 0) {
    struct timespec ts[2] = {{sec, nsec}, {sec, nsec}};
    ASSERT_EQ(::utimensat(AT_FDCWD, path.c_str(), ts, 0), 0) << path;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// What --update decides: settings

TEST(Update, SkipsOnlyWhatIsCurrent) {
    ScratchDir d;
    write_small_png(d / "a.png", 1);
    write_small_png(d / "b.png", 2);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", d / "b.png", "--output-dir", d / "out"}).status, 0);
    auto r = run_spectex(
        {"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update", "--json", "-"});
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(count_lines(r.out, "\"status\":\"skipped\""), 2u) << r.out;
    // A skipped record says why.
    EXPECT_EQ(count_lines(
                  r.out,
                  "\"reason\":\"up to date: same settings hash, source size and modification time"),
              2u)
        << r.out;
    // Threads and jobs do not change pixels: still up to date.
    r = run_spectex({"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update",
                     "--jobs", "2", "--threads", "1", "--json", "-"});
    EXPECT_EQ(count_lines(r.out, "\"status\":\"skipped\""), 2u) << r.out;
    // A setting that changes pixels rebuilds both.
    r = run_spectex({"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update",
                     "--type", "float", "--json", "-"});
    EXPECT_EQ(count_lines(r.out, "\"status\":\"ok\""), 2u) << r.out;
    // A changed input rebuilds that one only, whatever its date (the identity tests below).
    write_small_png(d / "a.png", 3);
    struct utimbuf past {
        946684800, 946684800
    };
    utime((d / "a.png").c_str(), &past);
    r = run_spectex({"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update",
                     "--type", "float", "--json", "-"});
    EXPECT_EQ(count_lines(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_EQ(count_lines(r.out, "\"status\":\"skipped\""), 1u) << r.out;
    // --force rebuilds everything.
    r = run_spectex({"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update",
                     "--force", "--type", "float", "--json", "-"});
    EXPECT_EQ(count_lines(r.out, "\"status\":\"ok\""), 2u) << r.out;
}

// ---------------------------------------------------------------------------------------------
// What --update decides: the source's identity

TEST(Update, HeaderRecordsTheSourcesSizeTimeAndHash) {
    ScratchDir d;
    // PNG and JPEG read in order; TIFF and EXR readers seek (directories, offset tables), and a
    // tiled TIFF is read whole: the hash must still be of the bytes in file order.
    write_pattern_png(d / "a.png", 1, 40, 30);
    std::vector<uint8_t> px(64 * 48 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 7) & 255);
    write_image(d / "b.tif", 64, 48, 3, OIIO::TypeDesc::UINT8, px.data());
    write_image(d / "c.tif", 64, 48, 3, OIIO::TypeDesc::UINT8, px.data(), {}, 16);
    write_image(d / "d.jpg", 64, 48, 3, OIIO::TypeDesc::UINT8, px.data());
    std::vector<float> fpx(px.begin(), px.end());
    for (float& v : fpx) v /= 255.0f;
    write_image(d / "e.exr", 64, 48, 3, OIIO::TypeDesc::FLOAT, fpx.data());
    write_image(d / "f.tga", 64, 48, 3, OIIO::TypeDesc::UINT8, px.data());
    write_pattern_ppm(d / "g.ppm", 1);
    for (const char* name : {"a.png", "b.tif", "c.tif", "d.jpg", "e.exr", "f.tga", "g.ppm"}) {
        const std::string in = d / name, out = d / (std::string(name) + ".spectral.exr");
        const RunResult r = run_spectex({"bake", in, "-o", out});
        ASSERT_EQ(r.status, 0) << name << ": " << r.err;
        const ExrImage img = read_exr(out);
        struct stat st;
        ASSERT_EQ(::stat(in.c_str(), &st), 0);
        EXPECT_EQ(img.attr("spectex:sourceSize"), std::to_string(st.st_size)) << name;
        EXPECT_EQ(img.attr("spectex:sourceMtime"), mtime_of(in)) << name;
        EXPECT_EQ(img.attr("spectex:sourceHash"), fnv1a64_of_file(in)) << name;
    }
}

TEST(Update, ASourceReplacedByAnOlderDatedFileIsRebuilt) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    const std::string before = read_exr(d / "a.exr").attr("spectex:sourceHash");
    // A restore (or rsync -t, a checkout) puts other bytes in place with a date older than the
    // output.
    write_pattern_png(d / "a.png", 2);
    set_mtime(d / "a.png", 946684800);  // 2000-01-01
    const RunResult r =
        run_spectex({"bake", d / "a.png", "-o", d / "a.exr", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"ok\""), 1u) << r.out;
    const ExrImage img = read_exr(d / "a.exr");
    EXPECT_NE(img.attr("spectex:sourceHash"), before);
    EXPECT_EQ(img.attr("spectex:sourceHash"), fnv1a64_of_file(d / "a.png"));
    EXPECT_EQ(img.attr("spectex:sourceMtime"), "946684800.000000000");
}

TEST(Update, AReplacementOfTheSameSizeAndAnOlderDateIsRebuilt) {
    ScratchDir d;
    write_pattern_ppm(d / "a.ppm", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.ppm", "-o", d / "a.exr"}).status, 0);
    write_pattern_ppm(d / "a.ppm", 2);
    ASSERT_EQ(read_file(d / "a.ppm").size(), 59u);
    set_mtime(d / "a.ppm", 946684800);
    const RunResult r =
        run_spectex({"bake", d / "a.ppm", "-o", d / "a.exr", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_EQ(read_exr(d / "a.exr").attr("spectex:sourceSize"), "59");
    EXPECT_EQ(read_exr(d / "a.exr").attr("spectex:sourceHash"), fnv1a64_of_file(d / "a.ppm"));
}

TEST(Update, ATouchedSourceWithTheSameBytesIsUpToDate) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    write_pattern_png(d / "b.png", 2);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", d / "b.png", "--output-dir", d / "out"}).status, 0);
    RunResult r = run_spectex(
        {"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(
        occurrences(
            r.out,
            "\"reason\":\"up to date: same settings hash, source size and modification time\""),
        2u)
        << r.out;
    // A checkout rewrites a with the same bytes and a new date; older or newer, it stays up to
    // date.
    set_mtime(d / "a.png", time(nullptr) + 100);
    set_mtime(d / "b.png", 946684800);
    r = run_spectex(
        {"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"skipped\""), 2u) << r.out;
    EXPECT_EQ(occurrences(r.out, "its modification time changed"), 2u) << r.out;
    EXPECT_NE(r.err.find("0 baked, 2 up to date"), std::string::npos) << r.err;
}

TEST(Update, AnOutputThatDoesNotRecordItsSourceIsRebuilt) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    // An output made before the identity was recorded: rename the attributes in place (same
    // length), so that the header no longer holds them.
    {
        std::string bytes = read_file(d / "a.exr");
        for (const std::string key :
             {"spectex:sourceHash", "spectex:sourceSize", "spectex:sourceMtime"}) {
            const size_t at = bytes.find(key + std::string(1, '\0'));
            ASSERT_NE(at, std::string::npos) << key;
            bytes[at + key.size() - 1] = 'X';
        }
        FILE* f = std::fopen((d / "a.exr").c_str(), "wb");
        ASSERT_NE(f, nullptr);
        std::fwrite(bytes.data(), 1, bytes.size(), f);
        std::fclose(f);
    }
    ASSERT_FALSE(read_exr(d / "a.exr").has_attr("spectex:sourceHash"));
    const RunResult r =
        run_spectex({"bake", d / "a.png", "-o", d / "a.exr", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_TRUE(read_exr(d / "a.exr").has_attr("spectex:sourceHash"));
}

// A copy cut short keeps its header, and with it the bake's settings hash and the source's
// identity: --update judged such an output by its header alone and kept it, broken, on every
// run. The chunk tables are read too, so a scanline and a tiled (MIP) output missing their last
// bytes are baked again, and a dry run says why.
TEST(Update, AnOutputCutShortIsBakedAgain) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    write_pattern_png(d / "b.png", 2);
    const std::vector<std::string> a_bake = {"bake", d / "a.png", "-o", d / "a.exr"};
    const std::vector<std::string> b_bake = {"bake", d / "b.png", "-o", d / "b.exr", "--mipmap"};
    auto with = [](std::vector<std::string> v, const std::vector<std::string>& more) {
        v.insert(v.end(), more.begin(), more.end());
        return v;
    };
    ASSERT_EQ(run_spectex(a_bake).status, 0);
    ASSERT_EQ(run_spectex(b_bake).status, 0);
    const std::string a_whole = read_file(d / "a.exr"), b_whole = read_file(d / "b.exr");
    auto cut = [&] {
        write_text(d / "a.exr", a_whole.substr(0, a_whole.size() - 100));
        write_text(d / "b.exr", b_whole.substr(0, b_whole.size() - 100));
    };
    cut();
    for (const auto& bake : {a_bake, b_bake}) {
        const RunResult n = run_spectex(with(bake, {"--update", "-n"}));
        EXPECT_EQ(n.status, 0) << n.err;
        EXPECT_TRUE(has_text(n.out + n.err, "not up to date: the output is incomplete")) << n.out;
        const RunResult r = run_spectex(with(bake, {"--update", "--json", "-"}));
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_EQ(occurrences(r.out, "\"status\":\"ok\""), 1u) << r.out;
        EXPECT_EQ(run_spectex({"verify", bake[3]}).status, 0) << bake[3];
    }
    // Whole again: up to date.
    for (const auto& bake : {a_bake, b_bake}) {
        const RunResult r = run_spectex(with(bake, {"--update", "--json", "-"}));
        EXPECT_EQ(occurrences(r.out, "\"status\":\"skipped\""), 1u) << r.out;
    }
}

// ---------------------------------------------------------------------------------------------
// What --update decides: the OCIO config by what it does to the files

TEST(Update, KeepsOutputsWhenTheConfigOnlyGainsACommentOrAnUnusedSpace) {
    ScratchDir d;
    std::string cfg = "# edited by the show's colour team\n" + shipped_config();
    cfg = replace_all(cfg, "description: spectex texture colour spaces",
                      "description: the show's texture colour spaces");
    cfg +=
        "\n  - !<ColorSpace>\n    name: show_log\n    isdata: false\n"
        "    from_scene_reference: !<ExponentTransform> {value: 1.8, style: pass_thru, "
        "direction: inverse}\n";
    // A transform the files do not use changes too (gamma 2.2 space).
    cfg = replace_all(cfg, "{value: 2.2, style: pass_thru", "{value: 2.3, style: pass_thru");
    const std::string out = update_after_edit(d, cfg);
    EXPECT_EQ(occurrences(out, "\"status\":\"skipped\""), 2u) << out;
}

TEST(Update, RebakesWhenTheTransformTheFilesUseChanges) {
    ScratchDir d;
    const std::string cfg =
        replace_all(shipped_config(), "gamma: 2.4, offset: 0.055", "gamma: 2.5, offset: 0.055");
    ASSERT_NE(cfg, shipped_config());
    const std::string out = update_after_edit(d, cfg);
    EXPECT_EQ(occurrences(out, "\"status\":\"ok\""), 2u) << out;
    EXPECT_EQ(occurrences(out, "\"status\":\"skipped\""), 0u) << out;
}

TEST(Update, RebakesAnOutputThatRecordsNoColourTransformOnce) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    write_text(d / "c.ocio", shipped_config());
    const std::vector<std::string> bake = {"bake",      d / "a.png", "--config", d / "c.ocio", "-o",
                                           d / "a.exr", "--update",  "--json",   "-"};
    ASSERT_EQ(run_spectex(bake).status, 0);
    ASSERT_TRUE(read_exr(d / "a.exr").has_attr("spectex:colorTransform"));
    // As an output made before the key was recorded (its settings hash included the config's
    // bytes): not taken as up to date on the new key's absence.
    hide_attributes(d / "a.exr", {"spectex:colorTransform"});
    RunResult r = run_spectex(bake);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_TRUE(read_exr(d / "a.exr").has_attr("spectex:colorTransform"));
    r = run_spectex(bake);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"skipped\""), 1u) << r.out;
}

// ---------------------------------------------------------------------------------------------
// What --update costs when every file is up to date

TEST(UpdateCost, StartingTheToolLoadsNoImageLibrary) {
    if (!file_exists("/usr/bin/time")) GTEST_SKIP() << "needs /usr/bin/time (Debian package time)";
    ScratchDir d;
    write_png(d / "a.png");
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    const std::string no_module = "SPECTEX_MODULE_DIR=" + d.path();  // holds no spectex-oiio.so
    const Usage v = run_measured({"--version"}, {no_module});
    EXPECT_EQ(v.status, 0) << v.err;
    // OpenImageIO's ~260 libraries made this 132 MB and 12,600 page faults.
    EXPECT_LT(v.max_rss_mb, 40 * kCostScale) << "spectex --version";
    EXPECT_LT(v.minor_faults, 3000 * kCostScale) << "spectex --version";
    for (const std::vector<std::string>& args : {std::vector<std::string>{"info", d / "a.exr"},
                                                 {"basis", "-q", "-o", d / "b.csv"},
                                                 {"verify", d / "a.exr", "--report-only"},
                                                 {"sample", d / "a.exr", "1,1"}}) {
        const Usage u = run_measured(args, {no_module});
        EXPECT_EQ(u.status, 0) << args[0] << ": " << u.err;
        EXPECT_LT(u.max_rss_mb, 60 * kCostScale) << args[0];
    }
    // What decodes an image needs the module, and says so when it is missing.
    const Usage bake = run_measured({"bake", d / "a.png", "-o", d / "c.exr"}, {no_module});
    EXPECT_EQ(bake.status, 1);
    EXPECT_NE(bake.err.find("cannot load spectex's image module"), std::string::npos) << bake.err;
}

TEST(UpdateCost, AnUpToDateBatchReadsHeadersAndBuildsNothing) {
    if (!file_exists("/usr/bin/time")) GTEST_SKIP() << "needs /usr/bin/time (Debian package time)";
    ScratchDir d;
    write_png(d / "tex.png");
    ASSERT_EQ(run_spectex({"bake", d / "tex.png", "-o", d / "tex.exr"}).status, 0);
    struct stat st;
    ASSERT_EQ(::stat((d / "tex.png").c_str(), &st), 0);
    mkdir((d / "src").c_str(), 0777);
    mkdir((d / "out").c_str(), 0777);
    const int n = 300;
    std::string list;
    for (int i = 0; i < n; ++i) {
        const std::string s = d / ("src/t" + std::to_string(i) + ".png");
        copy_file(d / "tex.png", s, &st.st_mtim);
        copy_file(d / "tex.exr", d / ("out/t" + std::to_string(i) + ".exr"));
        list += s + "\n";
    }
    {
        FILE* f = std::fopen((d / "list.txt").c_str(), "w");
        std::fputs(list.c_str(), f);
        std::fclose(f);
    }
    const std::vector<std::string> args = {"bake",         "--from-list", d / "list.txt",
                                           "--output-dir", d / "out",     "--update"};
    // Without the module: nothing needs it.
    const Usage u = run_measured(args, {"SPECTEX_MODULE_DIR=" + d.path()});
    ASSERT_EQ(u.status, 0) << u.err;
    EXPECT_NE(u.err.find("0 baked, 300 up to date, 0 failed"), std::string::npos) << u.err;
    // The summary's time is the whole run's: measured from when the process started, not from
    // when the report was made after the list and the header checks (it said 0.1 s of a 0.5 s
    // run of 2,000 files). Tolerance: the run's wall time as seen from here also holds the spawn
    // of /usr/bin/time and of spectex and their exits, and the summary rounds to 0.1 s.
    {
        const auto t0 = std::chrono::steady_clock::now();
        const RunResult timed = run_spectex(args);
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        ASSERT_EQ(timed.status, 0) << timed.err;
        const size_t at = timed.err.find(" in ", timed.err.find("up to date"));
        ASSERT_NE(at, std::string::npos) << timed.err;
        const double said = std::atof(timed.err.c_str() + at + 4);
        EXPECT_GE(said + 0.05, 0.7 * wall) << timed.err << "wall " << wall << " s";
        EXPECT_LE(said, wall + 0.05) << timed.err << "wall " << wall << " s";
    }
    // Each skip read a 64 MiB buffer's worth of zeroed pages before (16k page faults a file).
    EXPECT_LT(u.minor_faults, (3000 + 20 * n) * kCostScale);
    EXPECT_LT(u.max_rss_mb, 60 * kCostScale);
    // One stale file (another source, older date): now the bake needs the module ...
    write_png(d / "other.png");
    {
        std::vector<uint8_t> px(4 * 4 * 3, 7);
        write_image(d / "src/t7.png", 4, 4, 3, OIIO::TypeDesc::UINT8, px.data());
        struct timespec old = {946684800, 0};
        struct timespec ts[2] = {old, old};
        ::utimensat(AT_FDCWD, (d / "src/t7.png").c_str(), ts, 0);
    }
    const Usage missing = run_measured(args, {"SPECTEX_MODULE_DIR=" + d.path()});
    EXPECT_EQ(missing.status, 1);
    EXPECT_NE(missing.err.find("cannot load spectex's image module"), std::string::npos)
        << missing.err;
    // ... and with it, bakes that one only.
    const Usage with = run_measured(args);
    EXPECT_EQ(with.status, 0) << with.err;
    EXPECT_NE(with.err.find("1 baked, 299 up to date, 0 failed"), std::string::npos) << with.err;
}

TEST(UpdateCost, AnUpToDateFileIsCheckedBeforeTheMethodIsBuilt) {
    ScratchDir d;
    write_png(d / "a.png");
    // A Jakob-Hanika table takes seconds to build: a skip must not build it.
    const std::vector<std::string> bake = {
        "bake",         d / "a.png",       "-o", d / "a.exr", "--method",
        "jakob-hanika", "--jh-resolution", "16", "-v"};
    const RunResult first = run_spectex(bake);
    ASSERT_EQ(first.status, 0) << first.err;
    EXPECT_NE(first.err.find("built in"), std::string::npos) << first.err;
    std::vector<std::string> again = bake;
    again.push_back("--update");
    const RunResult second = run_spectex(again);
    ASSERT_EQ(second.status, 0) << second.err;
    EXPECT_EQ(second.err.find("built in"), std::string::npos) << second.err;
    EXPECT_NE(second.err.find("up to date"), std::string::npos) << second.err;
    // Another setting of the method is another recipe: rebuilt.
    std::vector<std::string> other = {
        "bake", d / "a.png", "-o",     d / "a.exr", "--method", "jakob-hanika", "--jh-resolution",
        "17",   "--update",  "--json", "-"};
    const RunResult third = run_spectex(other);
    ASSERT_EQ(third.status, 0) << third.err;
    EXPECT_NE(third.out.find("\"status\":\"ok\""), std::string::npos) << third.out;
}
