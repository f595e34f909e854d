// The bits of --precision auto kept between runs (pipeline/plan_cache.h): a second bake with the
// same settings takes them from the cache instead of measuring ~100 bit vectors again, and gives
// the same file; an entry that is not a whole, valid answer never changes a bake. Every test points
// the cache into its scratch folder: none touches the real ~/.cache/spectex. The tests that choose
// the bits again for many entries (several passes over the whole 8-bit cube each) are Slow: the
// whole suite runs them; the sanitizer build runs the entry parser itself
// (tests/unit/precision_cache_text_test.cpp).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "cli_util.h"
#include "exr_read.h"
#include "pipeline/cached_answer.h"

using namespace spectex_test;

namespace {

// The bits' hit, said with -v (the lattice's table has a hit line of its own: MethodCache).
const std::string kHit = "the precision's bits from the cache";

struct Env {
    explicit Env(const std::string& cache) {
        const char* old = std::getenv("SPECTEX_CACHE_DIR");
        had_ = old != nullptr;
        if (had_) old_ = old;
        ::setenv("SPECTEX_CACHE_DIR", cache.c_str(), 1);
    }
    ~Env() {
        if (had_)
            ::setenv("SPECTEX_CACHE_DIR", old_.c_str(), 1);
        else
            ::unsetenv("SPECTEX_CACHE_DIR");
    }
    bool had_ = false;
    std::string old_;
};

// A small bake with a small grid (16 bins) under one light, with a budget the grid meets (its own
// worst is 1.07), so that the bits are a real choice (4 to 9 of half's 10) rather than all kept: a
// cache that lost them, or handed back full bits, changes the file. The chooser's passes over the
// cube take about 3 s (three lights took 8 s; the key's other inputs are PlanCacheSlow's).
RunResult bake(const ScratchDir& d, const std::string& out, const std::vector<std::string>& more) {
    std::vector<std::string> a = {"bake",          d / "in.png", "-o",  d / out,    "--precision",
                                  "auto",          "--lights",   "D65", "--max-de", "2",
                                  "--wavelengths", "400:700:20", "-v"};
    a.insert(a.end(), more.begin(), more.end());
    return run_spectex(a);
}

void make_input(const ScratchDir& d) {
    const int w = 23, h = 19;
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 53 + 11) & 0xff);
    write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
}

std::vector<std::string> precision_entries(const std::string& dir) {
    std::vector<std::string> out;
    for (const auto& name : list_dir(dir))
        if (name.rfind("precision-", 0) == 0) out.push_back(dir + "/" + name);
    return out;
}

// What the chooser decides, as the file records it, and the spectra.
struct Outcome {
    std::string bits, worst;
    std::map<std::string, std::vector<float>> pixels;
};

Outcome outcome(const std::string& path) {
    const ExrImage im = read_exr(path);
    return {im.attr("spectex:precisionBits"), im.attr("spectex:precisionWorstDe"), im.pixels};
}

}  // namespace

TEST(PrecisionCacheSlow, SecondBakeTakesTheBitsFromTheCacheAndGivesTheSameFile) {
    ScratchDir d;
    make_input(d);
    const Env env(d / "cache");
    const RunResult first = bake(d, "a.exr", {});
    ASSERT_EQ(first.status, 0) << first.err;
    EXPECT_EQ(first.err.find(kHit), std::string::npos) << first.err;
    ASSERT_EQ(precision_entries(d / "cache").size(), 1u);

    const RunResult second = bake(d, "b.exr", {});
    ASSERT_EQ(second.status, 0) << second.err;
    EXPECT_NE(second.err.find("--precision auto:"), std::string::npos) << second.err;
    EXPECT_NE(second.err.find(kHit), std::string::npos) << "the chooser ran again:\n" << second.err;

    const RunResult fresh = bake(d, "c.exr", {"--no-cache"});
    ASSERT_EQ(fresh.status, 0) << fresh.err;
    EXPECT_EQ(fresh.err.find(kHit), std::string::npos) << fresh.err;

    const Outcome a = outcome(d / "a.exr"), b = outcome(d / "b.exr"), c = outcome(d / "c.exr");
    ASSERT_FALSE(c.bits.empty());
    EXPECT_EQ(b.bits, c.bits);
    EXPECT_EQ(b.worst, c.worst);
    EXPECT_EQ(a.bits, c.bits);
    EXPECT_TRUE(b.pixels == c.pixels) << "the spectra differ";

    // Another budget is another key: chosen again, a second entry.
    const RunResult other = bake(d, "d.exr", {"--max-de", "1.5"});
    ASSERT_EQ(other.status, 0) << other.err;
    EXPECT_EQ(other.err.find(kHit), std::string::npos) << other.err;
    EXPECT_EQ(precision_entries(d / "cache").size(), 2u);
}

TEST(PrecisionCacheSlow, DamagedOrHostileEntriesNeverChangeTheOutput) {
    ScratchDir d;
    make_input(d);
    const Env env(d / "cache");
    ASSERT_EQ(bake(d, "ref.exr", {"--no-cache"}).status, 0);
    const Outcome ref = outcome(d / "ref.exr");
    ASSERT_EQ(bake(d, "first.exr", {}).status, 0);
    const auto found = precision_entries(d / "cache");
    ASSERT_EQ(found.size(), 1u);
    const std::string entry = found[0];
    const std::string text = read_file(entry);
    ASSERT_NE(text.find("bits 16 "), std::string::npos) << text;
    // A real choice, not every bit kept: an entry ignored in favour of full bits would show.
    ASSERT_EQ(text.find("bits 16 10 10 10 10 10 10 10 10 10 10 10 10 10 10 10 10"),
              std::string::npos)
        << text;

    int n = 0;
    auto same_as_fresh = [&](const std::string& what) {
        const std::string out = "out" + std::to_string(n++) + ".exr";
        const RunResult r = bake(d, out, {});
        EXPECT_EQ(r.status, 0) << what << ": " << r.err;
        EXPECT_EQ(r.err.find(kHit), std::string::npos) << what << " was trusted:\n" << r.err;
        const Outcome o = outcome(d / out);
        EXPECT_EQ(o.bits, ref.bits) << what;
        EXPECT_TRUE(o.pixels == ref.pixels) << what << ": the spectra differ";
        return r;
    };
    // Replaces the bits line's words with `bits` (keeping everything else, the check included).
    auto with_bits = [&](const std::string& bits) {
        std::string t = text;
        const size_t at = t.find("bits ");
        t.replace(at, t.find('\n', at) - at, "bits " + bits);
        return t;
    };

    // Each case chooses the bits again (a pass over the whole 8-bit cube): one of each kind of
    // refusal is run end to end here; every damaged body (every truncation, bits above 10, a bin
    // too few, another key) is refused by the entry's parser itself in
    // tests/unit/precision_cache_text_test.cpp.
    write_text(entry, "spectex-precision-cache 1\ngarbage\n");
    const RunResult corrupt = same_as_fresh("a corrupt entry");
    EXPECT_NE(corrupt.err.find("warning"), std::string::npos) << corrupt.err;
    write_text(entry, with_bits("16 11 11 11 11 11 11 11 11 11 11 11 11 11 11 11 11"));
    same_as_fresh("bits above 10");
    write_text(entry, with_bits("16 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0"));
    same_as_fresh("other bits in range, the check not matching");
    // A link to a valid copy: not followed, not written through.
    write_text(d / "elsewhere", text);
    ::unlink(entry.c_str());
    ASSERT_EQ(::symlink((d / "elsewhere").c_str(), entry.c_str()), 0);
    same_as_fresh("a link");
    EXPECT_EQ(read_file(d / "elsewhere"), text);
    // (A FIFO, a folder or a huge file in the entry's place: the plan cache's tests, same reader.)
    // The entry is whole again afterwards, and a hit.
    ::unlink(entry.c_str());
    ASSERT_EQ(bake(d, "again.exr", {}).status, 0);
    const RunResult hit = bake(d, "hit.exr", {});
    EXPECT_NE(hit.err.find(kHit), std::string::npos) << hit.err;
    EXPECT_EQ(outcome(d / "hit.exr").bits, ref.bits);
}

TEST(PrecisionCacheSlow, PlanAndBakeShareTheBits) {
    // plan --precision auto on a fixed grid asks the same question as bake on that grid.
    ScratchDir d;
    make_input(d);
    const Env env(d / "cache");
    const RunResult plan = run_spectex({"plan", "--grids", "400:700:20", "--lights", "D65",
                                        "--colours", "sample", "--sample-stride", "51", "--max-de",
                                        "5", "--precision", "auto", "--precision-de", "2"});
    ASSERT_EQ(plan.status, 0) << plan.err;
    ASSERT_EQ(precision_entries(d / "cache").size(), 1u) << plan.out;
    const RunResult b = bake(d, "a.exr", {});
    ASSERT_EQ(b.status, 0) << b.err;
    EXPECT_NE(b.err.find(kHit), std::string::npos) << b.err;
    EXPECT_EQ(precision_entries(d / "cache").size(), 1u);
}

// The default bake's lattice (9^3 vertices, each a QP) is built once per settings and kept in the
// cache beside the bits: a second bake reads it (-v says so) and writes the same spectra as a
// bake that builds it; an entry that is damaged, or sealed again around a table that is not
// exact, is a warning and a rebuild, never a table baked.
TEST(MethodCache, TheLatticeIsBuiltOnceAndADamagedTableIsBuiltAgain) {
    ScratchDir d;
    make_input(d);
    const Env env(d / "cache");
    auto lattice_bake = [&](const std::string& out, const std::vector<std::string>& more) {
        std::vector<std::string> a = {"bake",           d / "in.png", "-o",
                                      d / out,          "--method",   "lattice",
                                      "--vertex-prior", "lhtss",      "--wavelengths",
                                      "400:700:20",     "-v"};
        a.insert(a.end(), more.begin(), more.end());
        return run_spectex(a);
    };
    const RunResult fresh = lattice_bake("ref.exr", {"--no-cache"});
    ASSERT_EQ(fresh.status, 0) << fresh.err;
    EXPECT_TRUE(list_dir(d / "cache").empty()) << "--no-cache keeps nothing";
    const RunResult first = lattice_bake("first.exr", {});
    ASSERT_EQ(first.status, 0) << first.err;
    EXPECT_EQ(first.err.find("read from the cache"), std::string::npos) << first.err;
    std::vector<std::string> found;
    for (const auto& name : list_dir(d / "cache"))
        if (name.rfind("method-", 0) == 0) found.push_back(d / "cache" + "/" + name);
    ASSERT_EQ(found.size(), 1u);
    const std::string entry = found[0], text = read_file(entry);
    const Outcome ref = outcome(d / "ref.exr");
    EXPECT_TRUE(outcome(d / "first.exr").pixels == ref.pixels);

    const RunResult hit = lattice_bake("hit.exr", {});
    ASSERT_EQ(hit.status, 0) << hit.err;
    EXPECT_NE(hit.err.find("read from the cache"), std::string::npos) << hit.err;
    EXPECT_TRUE(outcome(d / "hit.exr").pixels == ref.pixels) << "the spectra differ";

    int n = 0;
    auto rebuilt = [&](const std::string& what) {
        const std::string out = "out" + std::to_string(n++) + ".exr";
        const RunResult r = lattice_bake(out, {});
        EXPECT_EQ(r.status, 0) << what << ": " << r.err;
        EXPECT_EQ(r.err.find("read from the cache"), std::string::npos) << what << " was trusted";
        EXPECT_NE(r.err.find("not a valid entry of the method's table"), std::string::npos)
            << what << ": " << r.err;
        EXPECT_TRUE(outcome(d / out).pixels == ref.pixels) << what << ": the spectra differ";
    };
    // The values line after "values N\n": its first value is black's first bin, 0 ("0x0p+0").
    const size_t values = text.find('\n', text.find("\nvalues ") + 1) + 1;
    write_text(entry, text.substr(0, text.size() / 2));
    rebuilt("a truncated entry");
    std::string bad = text;
    bad.replace(values, 6, "0x1p-1");  // black's first bin 0 -> 0.5, seal unchanged
    write_text(entry, bad);
    rebuilt("a changed value");
    write_text(entry, spectex::sealed_entry(bad.substr(0, bad.rfind("check "))));
    rebuilt("a resealed table whose black is not black");
}
