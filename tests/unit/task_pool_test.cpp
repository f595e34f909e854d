// The task facility: every index runs once, errors come back, waits run unstarted work, and
// nesting deeper than the pool is wide finishes (a deadlock would hang the test: ctest's timeout
// turns a hang into a failure).
#include "base/task_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

using namespace spectex;

TEST(TaskPool, ParallelForRunsEveryIndexOnce) {
    TaskPool pool(3);
    for (int threads : {1, 2, 4, 16}) {
        std::vector<std::atomic<int>> seen(1000);
        pool.parallel_for(seen.size(), threads, [&](size_t i) { seen[i]++; });
        for (size_t i = 0; i < seen.size(); ++i)
            ASSERT_EQ(seen[i].load(), 1) << "index " << i << " with " << threads << " threads";
    }
}

TEST(TaskPool, ParallelForUsesAtMostTheThreadsAskedFor) {
    TaskPool pool(8);
    std::atomic<int> running{0}, peak{0};
    pool.parallel_for(64, 3, [&](size_t) {
        const int now = ++running;
        int p = peak.load();
        while (now > p && !peak.compare_exchange_weak(p, now)) {
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        --running;
    });
    EXPECT_LE(peak.load(), 3);
    EXPECT_GE(peak.load(), 1);
}

TEST(TaskPool, ParallelForWithOneThreadRunsInOrderOnTheCaller) {
    TaskPool pool(2);
    std::vector<size_t> order;
    const auto caller = std::this_thread::get_id();
    pool.parallel_for(10, 1, [&](size_t i) {
        EXPECT_EQ(std::this_thread::get_id(), caller);
        order.push_back(i);
    });
    ASSERT_EQ(order.size(), 10u);
    for (size_t i = 0; i < order.size(); ++i) EXPECT_EQ(order[i], i);
}

TEST(TaskPool, ParallelForRethrowsAndStopsStartingIndices) {
    TaskPool pool(2);
    std::atomic<int> ran{0};
    // Every other index takes 50 us, so that all of them would take over a second: with empty
    // bodies the other two participants once ran every index while the throwing thread, preempted
    // on a loaded machine between its throw and its catch, had not yet told them to stop.
    EXPECT_THROW(pool.parallel_for(100000, 3,
                                   [&](size_t i) {
                                       ++ran;
                                       if (i == 5) throw std::runtime_error("index 5");
                                       std::this_thread::sleep_for(std::chrono::microseconds(50));
                                   }),
                 std::runtime_error);
    // Every participant stops at its next index once one call has thrown; a few calls may already
    // be under way, but nowhere near all of them.
    EXPECT_LT(ran.load(), 100000);
}

TEST(TaskPool, SubmitRunsOnAWorkerAndWaitRethrows) {
    TaskPool pool(1);
    std::atomic<bool> ran{false};
    Task ok = pool.submit([&] { ran = true; });
    ok.wait();
    EXPECT_TRUE(ran.load());
    Task bad = pool.submit([] { throw std::runtime_error("boom"); });
    EXPECT_THROW(bad.wait(), std::runtime_error);
    EXPECT_THROW(bad.wait(), std::runtime_error) << "a second wait gives the same error";
    Task none;
    EXPECT_FALSE(none.valid());
    none.wait();  // an empty task is done
}

TEST(TaskPool, WaitRunsATaskNoWorkerHasStarted) {
    TaskPool pool(0);  // no workers at all: only waits run tasks
    std::thread::id ran_on;
    Task t = pool.submit([&] { ran_on = std::this_thread::get_id(); });
    t.wait();
    EXPECT_EQ(ran_on, std::this_thread::get_id());
}

TEST(TaskPool, WaitBlocksUntilAWorkerFinishesATaskItStarted) {
    TaskPool pool(1);
    std::mutex mu;
    std::condition_variable cv;
    bool started = false;
    std::atomic<bool> finished{false};
    Task t = pool.submit([&] {
        {
            std::lock_guard<std::mutex> lock(mu);
            started = true;
        }
        cv.notify_all();
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        finished = true;
    });
    {
        std::unique_lock<std::mutex> lock(mu);
        cv.wait(lock, [&] { return started; });
    }
    t.wait();
    EXPECT_TRUE(finished.load());
}

TEST(TaskPool, NestingDeeperThanThePoolFinishes) {
    // One worker; every outer task submits inner tasks and waits for them, as a batch job waits
    // for its strips and a strip for its chunks. Waits run the unstarted inner tasks themselves.
    TaskPool pool(1);
    std::atomic<int> inner{0};
    pool.parallel_for(8, 4, [&](size_t) {
        std::vector<Task> tasks;
        for (int k = 0; k < 4; ++k)
            tasks.push_back(
                pool.submit([&] { pool.parallel_for(4, 4, [&](size_t) { ++inner; }); }));
        for (Task& t : tasks) t.wait();
    });
    EXPECT_EQ(inner.load(), 8 * 4 * 4);
}

TEST(TaskPool, ReserveGrowsAndNeverShrinks) {
    TaskPool pool(1);
    EXPECT_EQ(pool.workers(), 1);
    pool.reserve(3);
    EXPECT_EQ(pool.workers(), 3);
    pool.reserve(2);
    EXPECT_EQ(pool.workers(), 3);
    EXPECT_GE(hardware_threads(), 1);
}

TEST(TaskPool, DestructorFinishesQueuedTasks) {
    std::atomic<int> ran{0};
    {
        TaskPool pool(1);
        for (int i = 0; i < 50; ++i) pool.submit([&] { ++ran; });
    }
    EXPECT_EQ(ran.load(), 50);
}
