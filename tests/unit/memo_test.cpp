// base/memo.h: one build per key, shared by every caller; builds of different keys at the same
// time; a failed build's exception shared; a bounded memo starts afresh.
#include "base/memo.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace spectex {
namespace {

TEST(Memo, BuildsEachKeyOnceForEveryCaller) {
    Memo<std::string, int> memo;
    std::atomic<int> builds{0};
    std::vector<std::thread> threads;
    std::vector<int> got(8, 0);
    for (size_t i = 0; i < got.size(); ++i)
        threads.emplace_back([&, i] {
            got[i] = memo.get("k", [&] {
                ++builds;
                std::this_thread::sleep_for(std::chrono::milliseconds(20));
                return 42;
            });
        });
    for (auto& t : threads) t.join();
    EXPECT_EQ(builds.load(), 1);
    for (int v : got) EXPECT_EQ(v, 42);
}

// Key "a"'s build waits (up to 10 s) for key "b"'s build to start: with one lock held over every
// build, "b" could not start and "a" would time out.
TEST(Memo, DifferentKeysBuildAtTheSameTime) {
    Memo<std::string, int> memo;
    std::mutex m;
    std::condition_variable cv;
    bool b_started = false, a_saw_b = false;
    std::thread a([&] {
        memo.get("a", [&] {
            std::unique_lock<std::mutex> lock(m);
            a_saw_b = cv.wait_for(lock, std::chrono::seconds(10), [&] { return b_started; });
            return 1;
        });
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // let "a" take its key first
    std::thread b([&] {
        memo.get("b", [&] {
            {
                std::lock_guard<std::mutex> lock(m);
                b_started = true;
            }
            cv.notify_all();
            return 2;
        });
    });
    a.join();
    b.join();
    EXPECT_TRUE(a_saw_b);
}

TEST(Memo, AFailedBuildIsTheSameFailureForLaterCallers) {
    Memo<int, int> memo;
    int builds = 0;
    auto fail = [&]() -> int {
        ++builds;
        throw std::runtime_error("no exact spectrum");
    };
    EXPECT_THROW(memo.get(1, fail), std::runtime_error);
    EXPECT_THROW(memo.get(1, fail), std::runtime_error);
    EXPECT_EQ(builds, 1);
}

TEST(Memo, ABoundedMemoStartsAfreshWhenFull) {
    Memo<int, int> memo(2);
    int builds = 0;
    auto build = [&] { return ++builds; };
    EXPECT_EQ(memo.get(1, build), 1);
    EXPECT_EQ(memo.get(2, build), 2);
    EXPECT_EQ(memo.get(1, build), 1);  // kept
    EXPECT_EQ(memo.get(3, build), 3);  // over capacity: 1 and 2 forgotten
    EXPECT_EQ(memo.get(1, build), 4);
}

}  // namespace
}  // namespace spectex
