// Work whose cost grows with what the user asks: threads bounded by the work and by one cap for
// the process, repeated lights merged in every command that takes a light list, and requests too
// large for any real scene (memory of verify's other lights, render's sheet, plan's table, the
// lattice and Jakob-Hanika tables) refused at once, as usage errors naming the option, the figure
// and the limit. Nothing here times anything: threads are counted in /proc while the child is
// held on a full pipe, and the large requests are refused before any work.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;

namespace {

std::string make_png(const ScratchDir& dir, const std::string& name, int w, int h) {
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 37) & 0xff);
    const std::string path = dir / name;
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

std::string bake(const ScratchDir& dir, const std::string& stem, int w, int h) {
    const std::string png = make_png(dir, stem + ".png", w, h), exr = dir / (stem + ".exr");
    const RunResult r = run_spectex({"bake", "-q", png, "-o", exr});
    EXPECT_EQ(r.status, 0) << r.err;
    return exr;
}

size_t count(const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

// A copy of a shipped illuminant table under another name: another light for spectex (a file is
// one light by identity), the same values.
std::string light_copy(const ScratchDir& dir, const std::string& name) {
    static const std::string text =
        read_file(std::string(SPECTEX_TEST_DATA_DIR) + "/spectral/illuminant_A.csv");
    const std::string path = dir / name;
    std::ofstream(path) << text;
    return path;
}

// The most threads spectex may start by the documented cap (4 per hardware thread, at least 8, in
// each of its task pool and the two image libraries' pools), plus its own few.
int thread_bound() {
    const int hw = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    return 3 * std::max(8, 4 * hw) + 8;
}

// Runs spectex with its standard output on a pipe of one page, reads the first byte (the command
// has done its work and started its report, so every thread it started exists: the pools never
// shrink), counts the child's threads in /proc while it is held on the full pipe, then drains the
// pipe. The report must be larger than two pages for the child to be held.
int threads_while_reporting(const std::vector<std::string>& args, RunResult& r) {
    int fds[2];
    if (pipe(fds) != 0) return -1;
    fcntl(fds[1], F_SETPIPE_SZ, 4096);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    std::vector<std::string> argv_s = spectex_argv(args), env_s = environment_with({});
    std::vector<char*> argv = c_array(argv_s), envp = c_array(env_s);
    pid_t pid;
    if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), envp.data()) != 0) return -1;
    posix_spawn_file_actions_destroy(&fa);
    close(fds[1]);
    char c;
    int threads = -1;
    if (read(fds[0], &c, 1) == 1) {
        r.out += c;
        std::ifstream status("/proc/" + std::to_string(pid) + "/status");
        for (std::string line; std::getline(status, line);)
            if (line.rfind("Threads:", 0) == 0) threads = std::atoi(line.c_str() + 8);
    }
    char buf[4096];
    for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) r.out.append(buf, size_t(n));
    close(fds[0]);
    int st = 0;
    waitpid(pid, &st, 0);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return threads;
}

}  // namespace

// --- Threads -------------------------------------------------------------------------------

TEST(RunawayCost, VerifyThreadsBoundedByWorkAndCap) {
    ScratchDir dir;
    std::vector<std::string> args = {
        "verify",    "--jobs",       "4",
        "--threads", "1024",         "--json",
        "-",         "--illuminant", "A,D50,D55,D75,FL1,FL2,FL3,FL4,FL5,FL6,FL7,FL8,FL9,FL10,FL11"};
    for (int i = 0; i < 4; ++i) args.push_back(bake(dir, "v" + std::to_string(i), 16, 16));
    RunResult r;
    const int threads = threads_while_reporting(args, r);
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(count(r.out, "\"passed\":true"), 4u);
    ASSERT_GT(threads, 0);
    EXPECT_LE(threads, thread_bound()) << "verify --jobs 4 --threads 1024 on four 16x16 files";
}

TEST(RunawayCost, BakeThreadsCapped) {
    ScratchDir dir;
    std::vector<std::string> args = {
        "bake", "--jobs", "4", "--threads", "1024", "--json", "-", "--output-dir", dir / "out"};
    for (int i = 0; i < 24; ++i)
        args.push_back(make_png(dir, "b" + std::to_string(i) + ".png", 16, 16));
    RunResult r;
    const int threads = threads_while_reporting(args, r);
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(count(r.out, "\"status\":\"ok\""), 24u);
    ASSERT_GT(threads, 0);
    EXPECT_LE(threads, thread_bound()) << "bake --jobs 4 --threads 1024";
}

// --- Repeated lights ------------------------------------------------------------------------

TEST(RunawayCost, VerifyMergesRepeatedLights) {
    ScratchDir dir;
    const std::string exr = bake(dir, "m", 16, 16);
    const std::string csv = light_copy(dir, "mine.csv");
    std::string many = "A";
    for (int i = 0; i < 500; ++i) many += i % 2 ? ",A" : ",a";
    const RunResult r =
        run_spectex({"verify", exr, "--json", "-", "--illuminant", many, "--illuminant",
                     csv + "," + dir.path() + "/./mine.csv", "--illuminant", "FL11,fl11"});
    ASSERT_EQ(r.status, 0) << r.err;
    // A, the CSV (one file, two spellings) and FL11: three lights, in the order first given.
    EXPECT_EQ(count(r.out, "\"adaptation\":\"bradford\""), 3u) << r.out.substr(0, 2000);
    EXPECT_LT(r.out.find("\"illuminant\":\"A\""), r.out.find("\"illuminant\":\"FL11\""));
}

TEST(RunawayCost, RenderMergesRepeatedLights) {
    ScratchDir dir;
    const std::string exr = bake(dir, "r", 16, 16);
    const RunResult r = run_spectex(
        {"render", exr, "--illuminant", "A,a,A", "--illuminant", "A", "-o", dir / "r.png"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find(": 16 x 16 sRGB PNG"), std::string::npos) << r.out;  // one panel
}

TEST(RunawayCost, SampleMergesRepeatedLights) {
    ScratchDir dir;
    const std::string exr = bake(dir, "s", 16, 16);
    const RunResult r =
        run_spectex({"sample", exr, "1,1", "--json", "--illuminant", "A,a,FL11,A,fl11"});
    ASSERT_EQ(r.status, 0) << r.err;
    // The pixel's colour under D65 and each distinct light once.
    EXPECT_EQ(count(r.out, "\"illuminant\":\"A\""), 1u) << r.out;
    EXPECT_EQ(count(r.out, "\"illuminant\":\"FL11\""), 1u) << r.out;
}

TEST(RunawayCost, PlanMergesRepeatedLights) {
    // --precision full: bits for these lights would be chosen on every 8-bit colour, and the
    // merge is the same either way.
    const RunResult r =
        run_spectex({"plan", "--lights", "A,a,A,D65,d65", "--grids", "380:780:10", "--colours",
                     "sample", "--sample-stride", "51", "--precision", "full", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("\"lights\":[\"A\",\"D65\"]"), std::string::npos) << r.out;
}

// --- Refused before the work -----------------------------------------------------------------

TEST(RunawayCost, VerifyRefusesLightsBeyondMemoryLimit) {
    ScratchDir dir;
    const std::string exr = bake(dir, "big", 16, 16);
    std::vector<std::string> args = {"verify", exr, "--threads", "1"};
    // 12,000 distinct lights (distinct files) at about 100 KB of accumulators each: over 1 GiB.
    std::string list;
    for (int i = 0; i < 12000; ++i) {
        const std::string name = "l" + std::to_string(i) + ".csv";
        light_copy(dir, name);  // a copy each: hard links would be one light
        list += (list.empty() ? "" : ",") + dir / name;
        if (list.size() > 60000) {
            args.insert(args.end(), {"--illuminant", list});
            list.clear();
        }
    }
    if (!list.empty()) args.insert(args.end(), {"--illuminant", list});
    const RunResult r = run_spectex(args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("spectex verify: --illuminant: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("12000 lights"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("limit"), std::string::npos) << r.err;
    EXPECT_EQ(r.out, "");
}

TEST(RunawayCost, RenderSheetObeysMaxPixels) {
    ScratchDir dir;
    const std::string exr = bake(dir, "sheet", 64, 64);
    // The file (4,096 pixels) is within --max-pixels, the sheet of three panels is not.
    const RunResult r = run_spectex({"render", exr, "--illuminant", "A,D65,FL11", "--max-pixels",
                                     "10000", "-o", dir / "sheet_out.png"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("spectex render: --max-pixels: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("10000"), std::string::npos) << r.err;
    EXPECT_FALSE(file_exists(dir / "sheet_out.png"));
    // One light within the limit still renders.
    const RunResult one = run_spectex(
        {"render", exr, "--illuminant", "A", "--max-pixels", "10000", "-o", dir / "one.png"});
    EXPECT_EQ(one.status, 0) << one.err;
}

TEST(RunawayCost, PlanRefusesTableBeyondLimit) {
    const RunResult r = run_spectex({"plan", "--grids", "360:830:0.01", "--lights", "D65,A,FL11"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("spectex plan: --grids: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("47001"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("limit"), std::string::npos) << r.err;
}

TEST(RunawayCost, PlanManyDistinctLightsRefused) {
    ScratchDir dir;
    std::string lights;
    for (int i = 0; i < 100; ++i)
        lights += (lights.empty() ? "" : ",") + light_copy(dir, "p" + std::to_string(i) + ".csv");
    const RunResult r = run_spectex({"plan", "--lights", lights});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("spectex plan: --lights: "), std::string::npos) << r.err;
}

TEST(RunawayCost, LatticeAndTableCostRefused) {
    ScratchDir dir;
    const std::string png = make_png(dir, "l.png", 16, 16);
    const RunResult lattice = run_spectex({"bake", png, "-o", dir / "l.exr", "--method", "lattice",
                                           "--lattice-size", "65", "--wavelengths", "380:780:0.5"});
    EXPECT_EQ(lattice.status, 2) << lattice.err;
    EXPECT_NE(lattice.err.find("spectex bake: --lattice-size: "), std::string::npos) << lattice.err;
    EXPECT_NE(lattice.err.find("801 bins"), std::string::npos) << lattice.err;
    EXPECT_FALSE(file_exists(dir / "l.exr"));
    const RunResult jh = run_spectex({"bake", png, "-o", dir / "j.exr", "--method", "jakob-hanika",
                                      "--jh-resolution", "64", "--wavelengths", "360:830:0.25"});
    EXPECT_EQ(jh.status, 2) << jh.err;
    EXPECT_NE(jh.err.find("spectex bake: --jh-resolution: "), std::string::npos) << jh.err;
    const RunResult plan = run_spectex(
        {"plan", "--method", "lattice", "--lattice-size", "65", "--grids", "380:780:0.5"});
    EXPECT_EQ(plan.status, 2) << plan.err;
    EXPECT_NE(plan.err.find("spectex plan: --lattice-size: "), std::string::npos) << plan.err;
}

TEST(RunawayCost, LimitsAreInTheHelp) {
    for (const auto& [command, word] : std::vector<std::pair<std::string, std::string>>{
             {"verify", "1 GiB"}, {"render", "sheet"}, {"plan", "limit"}, {"bake", "limit"}}) {
        const RunResult r = run_spectex({command, "--help"});
        EXPECT_EQ(r.status, 0);
        EXPECT_NE(r.out.find(word), std::string::npos) << command;
    }
}
