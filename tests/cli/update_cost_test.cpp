// What a no-op costs: starting the tool does not load OpenImageIO (it lives in
// the module spectex-oiio.so, loaded by what decodes or writes an image), and an --update run whose
// files are all up to date reads only the outputs' headers and builds nothing. Checked by what the
// process used (peak RSS, page faults: robust on a loaded machine, where times are not) and by
// taking the module away (SPECTEX_MODULE_DIR naming an empty folder). tests/bench/bench_update_skip
// measures the times.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdint>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;

// Under AddressSanitizer (tests/sanitize/run.sh) every process maps its shadow memory and the
// instrumented code faults in more pages: the bounds on page faults and resident memory measure the
// sanitizer, not spectex, so they are scaled (what loads, and what is built, is still asserted).
#if defined(__SANITIZE_ADDRESS__)
#define SPECTEX_COST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SPECTEX_COST_ASAN 1
#endif
#endif
#ifdef SPECTEX_COST_ASAN
constexpr double kCostScale = 8.0;
#else
constexpr double kCostScale = 1.0;
#endif

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

}  // namespace

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
