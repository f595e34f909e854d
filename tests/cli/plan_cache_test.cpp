// The plan's answer kept between runs (plan and bake --wavelengths auto), the search's progress,
// and the limit on a grid's bins. Every test points the cache into its scratch folder
// (SPECTEX_CACHE_DIR, XDG_CACHE_HOME or HOME): none touches the real ~/.cache/spectex.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "cli_util.h"
#include "exr_read.h"
#include "io/provenance_keys.h"
#include "pipeline/cached_answer.h"

using namespace spectex_test;

// The tests that bake with --wavelengths auto or search many plans are in PlanCacheSlow: the
// whole suite runs them, the sanitizer build (which runs the rest about four times slower) not.
// No test of this binary uses the real cache of the user running it (~/.cache/spectex): the
// run's own (cli_util.h) unless a test names a folder of its own.

namespace {

// Runs spectex with the environment changed for the run: "NAME=value" sets, "!NAME" removes.
RunResult run_env(const std::vector<std::string>& args, const std::vector<std::string>& env) {
    std::vector<std::pair<std::string, const char*>> saved;
    std::vector<std::string> old_values;
    old_values.reserve(env.size());
    for (const auto& e : env) {
        const std::string name = e[0] == '!' ? e.substr(1) : e.substr(0, e.find('='));
        const char* old = std::getenv(name.c_str());
        old_values.push_back(old ? old : "");
        saved.push_back({name, old ? old_values.back().c_str() : nullptr});
        if (e[0] == '!')
            ::unsetenv(name.c_str());
        else
            ::setenv(name.c_str(), e.substr(e.find('=') + 1).c_str(), 1);
    }
    RunResult r = run_spectex(args);
    for (auto it = saved.rbegin(); it != saved.rend(); ++it) {
        if (it->second)
            ::setenv(it->first.c_str(), it->second, 1);
        else
            ::unsetenv(it->first.c_str());
    }
    return r;
}

// A small, fast plan: one light, two coarse grids, a sparse sample (216 colours).
std::vector<std::string> quick_plan(const std::vector<std::string>& more = {}) {
    // The basis, named: plan's default (bake's) would also choose bits, whose entries are apart.
    std::vector<std::string> a = {
        "plan",     "--method", "basis",     "--grids", "380:780:20,380:780:10",
        "--lights", "D65",      "--colours", "sample",  "--sample-stride",
        "51",       "--max-de", "5"};
    a.insert(a.end(), more.begin(), more.end());
    return a;
}

std::string cache_env(const std::string& dir) { return "SPECTEX_CACHE_DIR=" + dir; }

// The cache's entries (plan-<hex>), temporary files left out.
std::vector<std::string> entries(const std::string& dir) {
    std::vector<std::string> out;
    for (const auto& name : list_dir(dir))
        if (name.rfind("plan-", 0) == 0) out.push_back(name);
    return out;
}

// The table without its last line (the time it took).
std::string table_without_time(const std::string& out) {
    const size_t at = out.rfind("  (");
    return at == std::string::npos ? out : out.substr(0, at);
}

const std::string kHit = "from the cache";

std::string make_png(const ScratchDir& dir, const std::string& name, int w, int h, int seed = 0) {
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 37 + seed) & 0xff);
    const std::string path = dir / name;
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

// A light as a CSV: D65-like flat table scaled by `v` over 300-830 nm.
void write_light(const std::string& path, double v) {
    std::string t = "wavelength,value\n";
    for (int l = 300; l <= 830; l += 10)
        t += std::to_string(l) + "," + std::to_string(v * (1.0 + (l % 50) / 100.0)) + "\n";
    write_text(path, t);
}

}  // namespace

TEST(PlanCache, SecondPlanComesFromTheCache) {
    ScratchDir dir;
    const std::string cache = dir / "cache";
    const RunResult first = run_env(quick_plan(), {cache_env(cache)});
    ASSERT_EQ(first.status, 0) << first.err;
    EXPECT_EQ(first.err.find(kHit), std::string::npos) << first.err;
    ASSERT_EQ(entries(cache).size(), 1u) << "the answer is kept";
    const RunResult second = run_env(quick_plan(), {cache_env(cache)});
    ASSERT_EQ(second.status, 0) << second.err;
    EXPECT_NE(second.err.find(kHit), std::string::npos) << second.err;
    EXPECT_EQ(table_without_time(second.out), table_without_time(first.out));
    EXPECT_EQ(entries(cache).size(), 1u);
    // --no-cache searches again and keeps nothing.
    const RunResult off = run_env(quick_plan({"--no-cache"}), {cache_env(dir / "other")});
    ASSERT_EQ(off.status, 0) << off.err;
    EXPECT_EQ(off.err.find(kHit), std::string::npos) << off.err;
    EXPECT_EQ(table_without_time(off.out), table_without_time(first.out));
    EXPECT_FALSE(file_exists(dir / "other"));
    // The JSON from the cache is the search's, bar the seconds.
    const RunResult json = run_env(quick_plan({"--json", "-"}), {cache_env(cache)});
    const RunResult json_off = run_spectex(quick_plan({"--json", "-", "--no-cache"}));
    auto without_seconds = [](std::string s) {
        const size_t a = s.find("\"seconds\":"), b = s.find(',', a);
        return a == std::string::npos ? s : s.erase(a, b - a);
    };
    EXPECT_EQ(without_seconds(json.out), without_seconds(json_off.out));
}

// plan --precision auto from the cache: the grids' answer is the cached one, and the chosen grid's
// bits are chosen again, so a hit still reports them (the cache holds no bits).
TEST(PlanCache, PrecisionIsReportedOnAHitToo) {
    ScratchDir dir;
    const std::string cache = dir / "cache";
    const std::vector<std::string> args = quick_plan({"--precision", "auto"});
    const RunResult first = run_env(args, {cache_env(cache)});
    ASSERT_EQ(first.status, 0) << first.err;
    const RunResult second = run_env(args, {cache_env(cache)});
    ASSERT_EQ(second.status, 0) << second.err;
    EXPECT_NE(second.err.find(kHit), std::string::npos) << second.err;
    EXPECT_NE(second.out.find("precision: "), std::string::npos) << second.out;
    EXPECT_EQ(table_without_time(second.out), table_without_time(first.out));
    // The same plan without --precision shares the entry and reports no bits.
    const RunResult plain = run_env(quick_plan(), {cache_env(cache)});
    EXPECT_NE(plain.err.find(kHit), std::string::npos) << plain.err;
    EXPECT_EQ(plain.out.find("precision: "), std::string::npos) << plain.out;
}

TEST(PlanCache, WhereTheCacheIs) {
    ScratchDir dir;
    // XDG_CACHE_HOME, when SPECTEX_CACHE_DIR is not set.
    const RunResult xdg =
        run_env(quick_plan(), {"!SPECTEX_CACHE_DIR", "XDG_CACHE_HOME=" + dir / "xdg"});
    ASSERT_EQ(xdg.status, 0) << xdg.err;
    EXPECT_EQ(entries(dir / "xdg/spectex").size(), 1u);
    // Else ~/.cache (HOME pointed into the scratch folder); a relative XDG_CACHE_HOME is ignored,
    // as the XDG convention says.
    ASSERT_EQ(::mkdir((dir / "home").c_str(), 0700), 0);
    const RunResult home = run_env(
        quick_plan(), {"!SPECTEX_CACHE_DIR", "XDG_CACHE_HOME=relative", "HOME=" + dir / "home"});
    ASSERT_EQ(home.status, 0) << home.err;
    EXPECT_EQ(entries(dir / "home/.cache/spectex").size(), 1u);
    EXPECT_FALSE(file_exists("relative"));
    // A HOME that does not exist (a service account's /nonexistent) is never made: no cache.
    const RunResult homeless =
        run_env(quick_plan(), {"!SPECTEX_CACHE_DIR", "!XDG_CACHE_HOME", "HOME=" + dir / "none"});
    ASSERT_EQ(homeless.status, 0) << homeless.err;
    EXPECT_FALSE(file_exists(dir / "none"));
    // SPECTEX_CACHE_DIR set and empty: no cache at all.
    const RunResult off = run_env(
        quick_plan(), {"SPECTEX_CACHE_DIR=", "HOME=" + dir / "h2", "XDG_CACHE_HOME=" + dir / "x2"});
    ASSERT_EQ(off.status, 0) << off.err;
    EXPECT_FALSE(file_exists(dir / "h2"));
    EXPECT_FALSE(file_exists(dir / "x2"));
}

TEST(PlanCacheSlow, EveryInputOfTheAnswerIsInTheKey) {
    ScratchDir dir;
    const std::string cache = dir / "cache";
    write_light(dir / "light.csv", 1.0);
    const std::string tex = make_png(dir, "t.png", 8, 8, 1);
    const std::vector<std::string> env = {cache_env(cache)};
    ASSERT_EQ(run_env(quick_plan(), env).status, 0);
    size_t n = entries(cache).size();
    ASSERT_EQ(n, 1u);
    // Each change alone is a miss: a new entry, and no "from the cache".
    auto misses = [&](const std::vector<std::string>& args, const std::string& what) {
        const RunResult r = run_env(args, env);
        // 1: no grid meets the budget, an answer like any other.
        EXPECT_TRUE(r.status == 0 || r.status == 1) << what << ": " << r.err;
        EXPECT_EQ(r.err.find(kHit), std::string::npos) << what << " was served from the cache";
        EXPECT_EQ(entries(cache).size(), ++n) << what;
    };
    misses(quick_plan({"--max-de", "4"}), "--max-de");
    misses({"plan", "--grids", "380:780:20,380:780:10", "--lights", "A", "--colours", "sample",
            "--sample-stride", "51", "--max-de", "5"},
           "--lights");
    misses({"plan", "--grids", "380:780:20,400:700:10", "--lights", "D65", "--colours", "sample",
            "--sample-stride", "51", "--max-de", "5"},
           "--grids");
    misses(quick_plan({"--reconstruction", "nearest"}), "--reconstruction");
    misses(quick_plan({"--range", "380:780"}), "--range");
    misses(quick_plan({"--type", "float"}), "--type");
    misses(quick_plan({"--objective", "norm"}), "--objective");
    misses(quick_plan({"--observer", "cie1964-10"}), "--observer");
    misses(quick_plan({"--illuminant", "D50"}), "--illuminant");
    misses(quick_plan({"--sample-stride", "85"}), "--sample-stride");
    misses(quick_plan({"--colours", "auto"}), "--colours");
    // A light's contents, under the same name.
    const std::vector<std::string> with_light = {
        "plan",      "--grids", "380:780:20,380:780:10", "--lights", dir / "light.csv",
        "--colours", "sample",  "--sample-stride",       "51",       "--max-de",
        "5"};
    misses(with_light, "a light file");
    write_light(dir / "light.csv", 0.5);
    misses(with_light, "a light file's contents");
    // A texture's contents, under the same name.
    misses(quick_plan({"--texture", tex}), "--texture");
    make_png(dir, "t.png", 8, 8, 2);
    misses(quick_plan({"--texture", tex}), "a texture's contents");
    // Another build of spectex (a copy of the binary: another executable).
    const std::string copy = dir / "spectex-copy";
    ASSERT_EQ(run_shell("cp '" + spectex_binary() + "' '" + copy + "'").status, 0);
    {
        std::vector<std::string> args = quick_plan();
        std::string line = "SPECTEX_CACHE_DIR='" + cache + "' SPECTEX_DATA_DIR='" +
                           std::string(SPECTEX_TEST_DATA_DIR) + "' '" + copy + "'";
        for (const auto& a : args) line += " '" + a + "'";
        const RunResult other = run_shell(line);
        EXPECT_EQ(other.status, 0) << other.out;
        EXPECT_EQ(other.out.find(kHit), std::string::npos) << "another build was served";
        EXPECT_EQ(entries(cache).size(), ++n);
    }
    // And the first settings still hit.
    const RunResult again = run_env(quick_plan(), env);
    EXPECT_NE(again.err.find(kHit), std::string::npos) << again.err;
}

TEST(PlanCache, BadEntriesAreRecomputedNeverTrusted) {
    ScratchDir dir;
    const std::string cache = dir / "cache";
    const std::vector<std::string> env = {cache_env(cache)};
    const RunResult good = run_env(quick_plan(), env);
    ASSERT_EQ(good.status, 0) << good.err;
    ASSERT_EQ(entries(cache).size(), 1u);
    const std::string entry = cache + "/" + entries(cache)[0];
    const std::string text = read_file(entry);
    ASSERT_GT(text.size(), 100u);
    // Each is a miss that gives the same table, and the entry is whole again afterwards.
    auto recomputed = [&](const std::string& what) {
        const RunResult r = run_env(quick_plan(), env);
        EXPECT_EQ(r.status, 0) << what << ": " << r.err;
        EXPECT_EQ(r.err.find(kHit), std::string::npos) << what << " was trusted";
        EXPECT_EQ(table_without_time(r.out), table_without_time(good.out)) << what;
        return r;
    };
    write_text(entry, text.substr(0, text.size() / 2));
    recomputed("a truncated entry");
    const RunResult whole = run_env(quick_plan(), env);
    EXPECT_NE(whole.err.find(kHit), std::string::npos) << "the entry was stored again";
    write_text(entry, "spectex-plan-cache 2\ngarbage\n");
    recomputed("a corrupt entry");
    // Well formed but impossible: the chosen row out of range.
    {
        std::string bad = text;
        const size_t at = bad.find("chosen ");
        bad.replace(at, bad.find(' ', at + 7) - at, "chosen 99");
        write_text(entry, bad);
        recomputed("a chosen row out of range");
    }
    // Well formed and plausible, but not what the search measured: the chosen grid's first
    // wavelength lowered by 1 nm (380 nm is 0x1.7cp+8 in the entry's exact numbers), and a
    // light's worst error changed. Only a check over the whole entry tells these from an answer.
    {
        std::string bad = text;
        const size_t at = bad.find("0x1.7cp+8", bad.find("\nrow "));
        ASSERT_NE(at, std::string::npos) << text;
        bad.replace(at, 9, "0x1.7bp+8");
        write_text(entry, bad);
        recomputed("a grid the search never measured");
        // Sealed again (as a bug, or an entry of other settings, would be): the grid is still
        // none of the candidates the search measures, and is not taken.
        write_text(entry, spectex::sealed_entry(bad.substr(0, bad.rfind("check "))));
        recomputed("a resealed grid the search never measured");
    }
    {
        std::string bad = text;
        const size_t at = bad.find("\nlight ");
        ASSERT_NE(at, std::string::npos) << text;
        const size_t num = bad.find(" 0x", at);
        bad.replace(num, 3, " -0x");
        write_text(entry, bad);
        recomputed("a light's error changed");
    }
    // A link to a valid copy elsewhere: not followed, and the copy is not written through.
    write_text(dir / "elsewhere", text + "\n");
    ::unlink(entry.c_str());
    ASSERT_EQ(::symlink((dir / "elsewhere").c_str(), entry.c_str()), 0);
    recomputed("a link");
    EXPECT_EQ(read_file(dir / "elsewhere"), text + "\n");
    struct stat st;
    ASSERT_EQ(::lstat(entry.c_str(), &st), 0);
    EXPECT_TRUE(S_ISREG(st.st_mode)) << "the link is replaced by an entry, not written through";
    // A FIFO: never waited on.
    ::unlink(entry.c_str());
    ASSERT_EQ(::mkfifo(entry.c_str(), 0600), 0);
    recomputed("a FIFO");
    // Huge (sparse, 100 MB): not read.
    ::unlink(entry.c_str());
    write_text(entry, text);
    ASSERT_EQ(::truncate(entry.c_str(), 100 << 20), 0);
    recomputed("a huge entry");
    EXPECT_LT(read_file(entry).size(), 100000u);
    // A folder in the entry's place: the answer cannot be kept, a warning, not a failure.
    ::unlink(entry.c_str());
    ASSERT_EQ(::mkdir(entry.c_str(), 0700), 0);
    const RunResult folder = recomputed("a folder");
    EXPECT_NE(folder.err.find("warning"), std::string::npos) << folder.err;
    EXPECT_TRUE(list_dir(entry).empty());
    for (const auto& name : list_dir(cache)) EXPECT_EQ(name[0] == '.', false) << name;
}

TEST(PlanCache, AFolderThatCannotBeMadeIsAWarning) {
    ScratchDir dir;
    write_text(dir / "file", "x");
    const RunResult r = run_env(quick_plan(), {cache_env(dir / "file/cache")});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("spectex: warning: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("SPECTEX_CACHE_DIR"), std::string::npos) << r.err;
    // Named as what it is: it said "the output folder", which is not the cache.
    EXPECT_NE(r.err.find("cannot create the cache folder"), std::string::npos) << r.err;
    EXPECT_NE(r.out.find("* 380:780:"), std::string::npos) << r.out;
}

TEST(PlanCache, ConcurrentShardsShareOneWholeEntry) {
    ScratchDir dir;
    const std::string cache = dir / "cache";
    std::string script = "export SPECTEX_CACHE_DIR='" + cache + "'; ";
    for (int i = 0; i < 3; ++i) {
        script += "'" + spectex_binary() + "'";
        for (const auto& a : quick_plan()) script += " '" + a + "'";
        script += " > '" + dir / ("out" + std::to_string(i)) + "' 2>&1 & ";
    }
    script += "wait";
    ASSERT_EQ(run_shell(script).status, 0);
    for (int i = 0; i < 3; ++i) {
        const std::string out = read_file(dir / ("out" + std::to_string(i)));
        EXPECT_NE(out.find("* 380:780:"), std::string::npos) << out;
    }
    EXPECT_EQ(entries(cache).size(), 1u);
    EXPECT_EQ(list_dir(cache).size(), 1u) << "no temporary file left";
    const RunResult after = run_env(quick_plan(), {cache_env(cache)});
    EXPECT_NE(after.err.find(kHit), std::string::npos) << after.err;
}

TEST(PlanCacheSlow, BakeAutoFromTheCacheIsTheSameFile) {
    ScratchDir dir;
    const std::string cache = dir / "cache";
    const std::string png = make_png(dir, "in.png", 8, 8);
    auto bake = [&](const std::string& out, const std::vector<std::string>& more) {
        std::vector<std::string> a = {"bake",          png,    "-o",       dir / out,
                                      "--wavelengths", "auto", "--lights", "D65",
                                      "--max-de",      "3",    "--grids",  "380:780:20,380:780:10"};
        a.insert(a.end(), more.begin(), more.end());
        return run_env(a, {cache_env(cache)});
    };
    const RunResult miss = bake("a.exr", {});
    ASSERT_EQ(miss.status, 0) << miss.err;
    EXPECT_EQ(miss.err.find(kHit), std::string::npos) << miss.err;
    const RunResult hit = bake("b.exr", {});
    ASSERT_EQ(hit.status, 0) << hit.err;
    EXPECT_NE(hit.err.find(kHit), std::string::npos) << hit.err;
    const RunResult none = bake("c.exr", {"--no-cache"});
    ASSERT_EQ(none.status, 0) << none.err;
    EXPECT_EQ(none.err.find(kHit), std::string::npos) << none.err;
    const ExrImage a = read_exr(dir / "a.exr"), b = read_exr(dir / "b.exr"),
                   c = read_exr(dir / "c.exr");
    ASSERT_FALSE(a.attr(spectex::provenance_key::kPlanWorstDe).empty());
    for (const ExrImage* x : {&b, &c}) {
        EXPECT_EQ(x->channel_names, a.channel_names);
        EXPECT_EQ(x->pixels, a.pixels);
        for (const char* key :
             {spectex::provenance_key::kPlanWorstDe, spectex::provenance_key::kPlanLights,
              spectex::provenance_key::kPlanMaxDe, spectex::provenance_key::kPlanRange})
            EXPECT_EQ(x->attr(key), a.attr(key)) << key;
    }
}

TEST(PlanCacheSlow, ProgressOfTheSearch) {
    ScratchDir dir;
    // A cache of its own: the test run's may hold this plan already (another test's), and then
    // there is no search to report.
    const std::vector<std::string> own = {cache_env(dir / "cache")};
    const RunResult plan = run_spectex(quick_plan({"--progress"}), own);
    ASSERT_EQ(plan.status, 0) << plan.err;
    EXPECT_NE(plan.err.find("spectex plan: [2/2] building the method on each grid"),
              std::string::npos)
        << plan.err;
    EXPECT_NE(plan.err.find("spectex plan: [2/2] measuring each grid"), std::string::npos)
        << plan.err;
    // Not asked for and not a terminal: nothing.
    const RunResult quiet = run_spectex(quick_plan({"--no-cache"}), own);
    EXPECT_EQ(quiet.err.find("measuring each grid"), std::string::npos) << quiet.err;
    const std::string png = make_png(dir, "in.png", 4, 4);
    const RunResult bake =
        run_spectex({"bake", png, "-o", dir / "o.exr", "--wavelengths", "auto", "--lights", "D65",
                     "--max-de", "3", "--grids", "380:780:20,380:780:10", "--progress"},
                    own);
    ASSERT_EQ(bake.status, 0) << bake.err;
    EXPECT_NE(bake.err.find("spectex: --wavelengths auto: [2/2] measuring each grid"),
              std::string::npos)
        << bake.err;
}

TEST(GridLimit, TooManyBinsAreRefusedWhereverTheGridComesFrom) {
    ScratchDir dir;
    const std::string png = make_png(dir, "in.png", 4, 4);
    // --wavelengths: exit 2, the option, the figure and the limit; nothing written.
    const RunResult fine =
        run_spectex({"bake", png, "-o", dir / "o.exr", "--wavelengths", "380:780:0.01"});
    EXPECT_EQ(fine.status, 2) << fine.err;
    EXPECT_NE(fine.err.find("spectex bake: --wavelengths: "), std::string::npos) << fine.err;
    EXPECT_NE(fine.err.find("40001 bins"), std::string::npos) << fine.err;
    EXPECT_NE(fine.err.find("limit of 4701"), std::string::npos) << fine.err;
    EXPECT_FALSE(file_exists(dir / "o.exr"));
    // One bin over the limit.
    const RunResult over =
        run_spectex({"bake", png, "-o", dir / "o.exr", "--wavelengths", "360:830.1:0.1"});
    EXPECT_EQ(over.status, 2) << over.err;
    EXPECT_NE(over.err.find("4702 bins"), std::string::npos) << over.err;
    // A wavelength file.
    std::string list;
    for (int i = 0; i < 4702; ++i) list += std::to_string(360.0 + i * 0.1) + "\n";
    write_text(dir / "w.txt", list);
    const RunResult file =
        run_spectex({"bake", png, "-o", dir / "o.exr", "--wavelengths-file", dir / "w.txt"});
    EXPECT_EQ(file.status, 2) << file.err;
    EXPECT_NE(file.err.find("--wavelengths-file: "), std::string::npos) << file.err;
    EXPECT_NE(file.err.find("4702 bins"), std::string::npos) << file.err;
    // A basis CSV.
    std::string basis = "wavelength,r,g,b\n";
    for (int i = 0; i < 4702; ++i) basis += std::to_string(360.0 + i * 0.1) + ",0.3,0.3,0.3\n";
    write_text(dir / "b.csv", basis);
    const RunResult csv = run_spectex({"bake", png, "-o", dir / "o.exr", "--basis", dir / "b.csv"});
    EXPECT_EQ(csv.status, 2) << csv.err;
    EXPECT_NE(csv.err.find("--basis: "), std::string::npos) << csv.err;
    EXPECT_NE(csv.err.find("4702 bins"), std::string::npos) << csv.err;
    // plan --grids and basis --wavelengths.
    const RunResult plan = run_spectex({"plan", "--grids", "380:780:0.01"});
    EXPECT_EQ(plan.status, 2) << plan.err;
    EXPECT_NE(plan.err.find("spectex plan: --grids: "), std::string::npos) << plan.err;
    EXPECT_NE(plan.err.find("limit of 4701"), std::string::npos) << plan.err;
    const RunResult b =
        run_spectex({"basis", "--wavelengths", "380:780:0.01", "-o", dir / "x.csv"});
    EXPECT_EQ(b.status, 2) << b.err;
    EXPECT_NE(b.err.find("spectex basis: --wavelengths: "), std::string::npos) << b.err;
    // A spectral EXR whose header lists more bins: the file fails, named.
    {
        std::vector<std::string> names;
        for (int i = 0; i < 4702; ++i) {
            char n[32];
            std::snprintf(n, sizeof n, "T.%.1fnm", 360.0 + i * 0.1);
            names.push_back(n);
        }
        // Written with OpenEXR itself (OpenImageIO refuses so many channels).
        Imf::Header header(1, 1);
        for (const auto& n : names) header.channels().insert(n, Imf::Channel(Imf::FLOAT));
        std::vector<float> px(names.size(), 0.25f);
        Imf::FrameBuffer fb;
        for (size_t i = 0; i < names.size(); ++i)
            fb.insert(names[i], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&px[i]),
                                           sizeof(float), sizeof(float)));
        {
            Imf::OutputFile out((dir / "many.exr").c_str(), header);
            out.setFrameBuffer(fb);
            out.writePixels(1);
        }
        const RunResult v = run_spectex({"verify", dir / "many.exr"});
        EXPECT_NE(v.status, 0) << v.err;
        EXPECT_NE(v.err.find("many.exr"), std::string::npos) << v.err;
        EXPECT_NE(v.err.find("limit of 4701"), std::string::npos) << v.err;
    }
}

TEST(GridLimit, AFineGridSaysWhatItCosts) {
    ScratchDir dir;
    const std::string png = make_png(dir, "in.png", 2, 2);
    // The basis: the cost line is the grid's, whatever the method, and the default's lattice on
    // 801 bins took 50 s to build (8 minutes under the sanitizers) for a test of one line.
    const RunResult r = run_spectex(
        {"bake", png, "-o", dir / "o.exr", "--wavelengths", "380:780:0.5", "--method", "basis"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("801 bins (limit 4701): 1602 bytes per pixel"), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("GB of memory per 1,000 pixels of image width"), std::string::npos)
        << r.err;
    const RunResult q = run_spectex({"bake", "-q", png, "-o", dir / "q.exr", "--wavelengths",
                                     "380:780:0.5", "--method", "basis"});
    EXPECT_EQ(q.err.find("801 bins"), std::string::npos) << q.err;
    // The default grid says nothing.
    const RunResult d = run_spectex({"bake", png, "-o", dir / "d.exr"});
    EXPECT_EQ(d.err.find("bytes per pixel"), std::string::npos) << d.err;
}

// examples/farm/warm_cache.sh, run once with an array's options, leaves in the cache every answer
// the tasks' bakes need: a bake of another texture with the same options searches nothing (its
// grid and its precision's bits come from the cache).
TEST(PlanCacheSlow, TheFarmsWarmUpFillsWhatTheTasksRead) {
    ScratchDir dir;
    const std::string cache = dir / "cache";
    const std::vector<std::string> opts = {
        "--wavelengths", "auto", "--lights", "D65,A",
        "--max-de",      "3",    "--grids",  "380:780:20,380:780:10"};
    std::string line = "SPECTEX='" + spectex_binary() + "' SPECTEX_CACHE_DIR='" + cache + "' '" +
                       SPECTEX_TEST_SOURCE_DIR + "/examples/farm/warm_cache.sh'";
    for (const auto& o : opts) line += " '" + o + "'";
    const RunResult warm = run_shell(line);
    ASSERT_EQ(warm.status, 0) << warm.out;
    const std::string png = make_png(dir, "in.png", 4, 4);
    std::vector<std::string> args = {"bake", png, "-o", dir / "o.exr", "-v"};
    args.insert(args.end(), opts.begin(), opts.end());
    const RunResult task = run_spectex(args, {cache_env(cache)});
    ASSERT_EQ(task.status, 0) << task.err;
    EXPECT_NE(task.err.find("the plan's answer from the cache"), std::string::npos) << task.err;
    EXPECT_NE(task.err.find("the precision's bits from the cache"), std::string::npos) << task.err;
    EXPECT_EQ(task.err.find("measuring each grid"), std::string::npos) << task.err;
}
