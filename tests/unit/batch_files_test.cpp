// The pure functions that name and select a batch's files (pipeline/batch_files.h), without the
// binary: output_for (an input's output name from -o's template, --output-dir and --base-dir) and
// --shard's Shard::parse and select_shard. The CLI tests check the same rules through bake; here
// each edge is one assertion, so that a failure names the rule it broke.
#include "pipeline/batch_files.h"

#include <gtest/gtest.h>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

using namespace spectex;

namespace {

// The message output_for or Shard::parse throws ("" when it does not throw).
template <class F>
std::string error_of(F f) {
    try {
        f();
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "";
}

bool has(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// output_for

TEST(OutputFor, TemplateTokensTakeTheInputsFolderStemAndExtension) {
    EXPECT_EQ(output_for("a/b/tex.png", "{dir}/{stem}.exr", ""), "a/b/tex.exr");
    EXPECT_EQ(output_for("/abs/tex.png", "{dir}/{stem}.exr", ""), "/abs/tex.exr");
    EXPECT_EQ(output_for("a/tex.png", "out/{stem}_{ext}.exr", ""), "out/tex_png.exr");
    // A template without tokens is the one output itself.
    EXPECT_EQ(output_for("a/tex.png", "fixed.exr", ""), "fixed.exr");
}

TEST(OutputFor, OnlyTheLastDotStartsTheExtension) {
    EXPECT_EQ(output_for("a/tex.v2.final.png", "{dir}/{stem}.exr", ""), "a/tex.v2.final.exr");
    EXPECT_EQ(output_for("a/tex.v2.png", "{dir}/{stem}.{ext}.exr", ""), "a/tex.v2.png.exr");
    // A name without a dot, or whose only dot leads it (a hidden file), is all stem.
    EXPECT_EQ(output_for("a/noext", "{dir}/{stem}.exr", ""), "a/noext.exr");
    EXPECT_EQ(output_for("a/.hidden", "{dir}/{stem}.exr", ""), "a/.hidden.exr");
    EXPECT_EQ(output_for("a/.hidden", "{dir}/{stem}_{ext}.exr", ""), "a/.hidden_.exr");
    // Dots in folder names are not the file's.
    EXPECT_EQ(output_for("v1.2/tex", "{dir}/{stem}.exr", ""), "v1.2/tex.exr");
}

TEST(OutputFor, OutputDirTakesTheStemWithOrWithoutATrailingSlash) {
    EXPECT_EQ(output_for("x/y/tex.png", "", "out"), "out/tex.exr");
    EXPECT_EQ(output_for("x/y/tex.png", "", "out/"), "out/tex.exr");
    EXPECT_EQ(output_for("x/y/tex.png", "", "out//"), "out/tex.exr");
    EXPECT_EQ(output_for("tex.png", "", "/"), "/tex.exr");
    // A template under --output-dir is a path inside it.
    EXPECT_EQ(output_for("x/tex.png", "{stem}_s.exr", "out"), "out/tex_s.exr");
}

TEST(OutputFor, DirUnderOutputDirStaysInsideIt) {
    EXPECT_EQ(output_for("/abs/x/tex.png", "{dir}/{stem}.exr", "out"), "out/abs/x/tex.exr");
    EXPECT_EQ(output_for("x/tex.png", "{dir}/{stem}.exr", "out"), "out/x/tex.exr");
    for (const std::string in : {"../x/tex.png", "a/../../tex.png", "a/../b/tex.png"}) {
        const std::string e = error_of([&] { output_for(in, "{dir}/{stem}.exr", "out"); });
        EXPECT_TRUE(has(e, "would climb out of --output-dir")) << in << ": " << e;
    }
}

TEST(OutputFor, BaseDirMirrorsTheTreeBelowIt) {
    EXPECT_EQ(output_for("/src/a/b/t.png", "", "out", "/src"), "out/a/b/t.exr");
    EXPECT_EQ(output_for("/src/a/b/t.png", "", "out", "/src/"), "out/a/b/t.exr");
    // A file at the top of the base: no "./" in its output name.
    EXPECT_EQ(output_for("/src/t.png", "", "out", "/src"), "out/t.exr");
    EXPECT_EQ(output_for("/src/a/t.png", "{reldir}/{stem}_lin.exr", "out", "/src"),
              "out/a/t_lin.exr");
    // Outside the base (beside it, above it, a name that only starts like it): refused, naming
    // both.
    for (const std::string in : {"/other/t.png", "/t.png", "/src2/t.png", "/src/../t.png"}) {
        const std::string e = error_of([&] { output_for(in, "", "out", "/src"); });
        EXPECT_TRUE(has(e, "not below the --base-dir /src")) << in << ": " << e;
    }
    const std::string e = error_of([] { output_for("/src/t.png", "{reldir}/{stem}.exr", ""); });
    EXPECT_TRUE(has(e, "needs --base-dir")) << e;
}

TEST(OutputFor, AnInputsNameNeverAddsAnEmptyDotOrDotDotComponent) {
    // "..png" has the stem ".", "...png" the stem "..": as a whole path component of the
    // template's making, either would leave the folder the template names.
    for (const std::string in : {"a/..png", "a/...png"}) {
        const std::string e = error_of([&] { output_for(in, "out/{stem}/x.exr", ""); });
        EXPECT_TRUE(has(e, "makes the path component")) << in << ": " << e;
        const std::string s = error_of([&] { output_for(in, "out/{stem}", ""); });
        EXPECT_TRUE(has(s, "makes the path component")) << in << ": " << s;
    }
    // A name with no extension makes {ext} empty: as a whole component, refused too.
    const std::string e = error_of([] { output_for("a/noext", "out/{ext}/{stem}.exr", ""); });
    EXPECT_TRUE(has(e, "makes the path component ''")) << e;
    // Within a component the same names are only text.
    EXPECT_EQ(output_for("a/...png", "out/{stem}.exr", ""), "out/...exr");
}

// ---------------------------------------------------------------------------------------------
// --shard K/N

TEST(ShardParse, TakesKOfNForEveryKFromOneToN) {
    const Shard first = Shard::parse("1/4"), last = Shard::parse("4/4");
    EXPECT_EQ(first.k, 1);
    EXPECT_EQ(first.n, 4);
    EXPECT_EQ(last.k, 4);
    EXPECT_EQ(last.n, 4);
    const Shard big = Shard::parse("1000000000/1000000000");  // the largest accepted
    EXPECT_EQ(big.k, 1000000000);
    EXPECT_EQ(big.n, 1000000000);
}

TEST(ShardParse, RefusesWhatIsNotKOfN) {
    // K = 0 or K > N, N = 0; numbers past the limit or that wrap a 32-bit int (4294967297 is not
    // 1); signs, spaces and hex; a missing or extra part.
    for (const std::string bad : {"0/4",
                                  "5/4",
                                  "1/0",
                                  "0/0",
                                  "1/1000000001",
                                  "1/4294967297",
                                  "4294967297/4294967298",
                                  "99999999999999999999/1",
                                  "-1/2",
                                  "1/-2",
                                  "+1/2",
                                  "1/+2",
                                  " 1/2",
                                  "1/2 ",
                                  "0x1/2",
                                  "1/",
                                  "/2",
                                  "1",
                                  "",
                                  "1/2/3",
                                  "1.0/2",
                                  "1//2"}) {
        const std::string e = error_of([&] { Shard::parse(bad); });
        EXPECT_TRUE(has(e, "--shard '" + bad + "': expected K/N")) << "'" << bad << "': " << e;
    }
}

TEST(ShardParse, TheShardsOfNCoverEveryInputExactlyOnce) {
    std::vector<std::string> inputs;
    for (int i = 0; i < 10; ++i) inputs.push_back("t" + std::to_string(i) + ".png");
    EXPECT_EQ(select_shard(inputs, Shard::parse("3/4")),
              (std::vector<std::string>{"t2.png", "t6.png"}));
    std::multiset<std::string> seen;
    for (int k = 1; k <= 4; ++k)
        for (const auto& f : select_shard(inputs, Shard::parse(std::to_string(k) + "/4")))
            seen.insert(f);
    EXPECT_EQ(seen, std::multiset<std::string>(inputs.begin(), inputs.end()));
    // More shards than inputs: the later shards are empty, not an error.
    EXPECT_TRUE(select_shard(inputs, Shard::parse("11/12")).empty());
    EXPECT_EQ(select_shard(inputs, Shard::parse("1/1")), inputs);
}
