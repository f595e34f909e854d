// The cached-answer helper the plan and precision caches share (pipeline/cached_answer.h): a miss
// computes and stores, a hit computes nothing, an entry its parser refuses is a miss that is said
// (ignored) and replaced, and a link in the entry's place is not followed.
#include "pipeline/cached_answer.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "temp_dir.h"

using namespace spectex;
using spectex_test::TempDir;

namespace {

std::string read(const std::string& path) {
    std::ifstream in(path);
    std::ostringstream o;
    o << in.rdbuf();
    return o.str();
}

// An answer of 42 stored as "answer 42\n"; the parser takes exactly that form.
int ask(const std::string& folder, int* computed, CacheReport& rep) {
    return cached_answer<int>(
        folder, "answer-key", 1024,
        [](const std::string& text, int* out) {
            if (text.rfind("answer ", 0) != 0 || text.back() != '\n') return false;
            *out = std::atoi(text.c_str() + 7);
            return true;
        },
        [computed] {
            ++*computed;
            return 42;
        },
        [](int v) { return "answer " + std::to_string(v) + "\n"; }, rep);
}

}  // namespace

TEST(CachedAnswer, MissStoresAndHitComputesNothing) {
    TempDir d;
    int computed = 0;
    CacheReport first;
    EXPECT_EQ(ask(d.path, &computed, first), 42);
    EXPECT_FALSE(first.hit);
    EXPECT_FALSE(first.ignored);
    EXPECT_EQ(first.warning, "");
    EXPECT_EQ(first.entry, d / "answer-key");
    EXPECT_EQ(read(d / "answer-key"), sealed_entry("answer 42\n"));
    CacheReport second;
    EXPECT_EQ(ask(d.path, &computed, second), 42);
    EXPECT_TRUE(second.hit);
    EXPECT_EQ(computed, 1);
}

TEST(CachedAnswer, RefusedEntryIsIgnoredAndReplaced) {
    TempDir d;
    std::ofstream(d / "answer-key") << "answer 7";  // no line break: not a whole entry
    int computed = 0;
    CacheReport rep;
    EXPECT_EQ(ask(d.path, &computed, rep), 42);
    EXPECT_FALSE(rep.hit);
    EXPECT_TRUE(rep.ignored);
    EXPECT_EQ(computed, 1);
    EXPECT_EQ(read(d / "answer-key"), sealed_entry("answer 42\n"));
}

// The parser sees only the body of an entry whose seal holds: a body changed into another answer
// its parser would take (42 into 41), or an entry with no seal, is a miss and is replaced.
TEST(CachedAnswer, AnEntryWhoseSealDoesNotHoldIsAMiss) {
    TempDir d;
    std::string sealed = sealed_entry("answer 42\n");
    sealed[8] = '1';
    for (const std::string& text :
         {sealed, std::string("answer 42\n"), sealed_entry("answer 42\n") + "x"}) {
        std::ofstream(d / "answer-key") << text;
        int computed = 0;
        CacheReport rep;
        EXPECT_EQ(ask(d.path, &computed, rep), 42) << text;
        EXPECT_FALSE(rep.hit) << text;
        EXPECT_TRUE(rep.ignored) << text;
        EXPECT_EQ(computed, 1) << text;
        EXPECT_EQ(read(d / "answer-key"), sealed_entry("answer 42\n"));
    }
}

TEST(CachedAnswer, LinkInTheEntrysPlaceIsNotFollowed) {
    TempDir d;
    std::ofstream(d / "elsewhere") << sealed_entry("answer 7\n");
    ASSERT_EQ(::symlink((d / "elsewhere").c_str(), (d / "answer-key").c_str()), 0);
    int computed = 0;
    CacheReport rep;
    EXPECT_EQ(ask(d.path, &computed, rep), 42);  // not the 7 behind the link
    EXPECT_TRUE(rep.ignored);
    EXPECT_EQ(read(d / "elsewhere"),
              sealed_entry("answer 7\n"));  // the link's target is left alone
}
