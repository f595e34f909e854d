#include "base/task_pool.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace spectex {

struct Task::State {
    std::function<void()> fn;
    std::atomic<bool> claimed{false};  // a thread has begun (or finished) running fn
    std::mutex mu;
    std::condition_variable cv;
    bool done = false;  // guarded by mu
    std::exception_ptr error;

    // Runs the task if nobody has claimed it; returns whether this call ran it.
    bool run() {
        if (claimed.exchange(true, std::memory_order_acq_rel)) return false;
        std::exception_ptr e;
        try {
            fn();
        } catch (...) {
            e = std::current_exception();
        }
        fn = nullptr;  // release what the task captured before anyone is woken
        {
            std::lock_guard<std::mutex> lock(mu);
            error = e;
            done = true;
        }
        cv.notify_all();
        return true;
    }
};

void Task::wait() {
    if (!state_) return;
    if (!state_->run()) {
        std::unique_lock<std::mutex> lock(state_->mu);
        state_->cv.wait(lock, [&] { return state_->done; });
    }
    if (state_->error) std::rethrow_exception(state_->error);
}

struct TaskPool::Impl {
    mutable std::mutex mu;
    std::condition_variable cv;
    std::deque<std::shared_ptr<Task::State>> queue;
    std::vector<std::thread> threads;
    bool stopping = false;

    void work() {
        for (;;) {
            std::shared_ptr<Task::State> t;
            {
                std::unique_lock<std::mutex> lock(mu);
                cv.wait(lock, [&] { return stopping || !queue.empty(); });
                if (queue.empty()) return;
                t = std::move(queue.front());
                queue.pop_front();
            }
            t->run();  // false: a waiter ran it already
        }
    }

    void grow_locked(int n) {
        while (static_cast<int>(threads.size()) < n) threads.emplace_back([this] { work(); });
    }
};

TaskPool& TaskPool::shared() {
    // Never destroyed: workers idle in their wait when the process exits, and no static
    // destructor can join a worker that some other static's destructor still needs.
    static TaskPool* pool = new TaskPool(hardware_threads());
    return *pool;
}

TaskPool::TaskPool(int workers) : impl_(std::make_unique<Impl>()) {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->grow_locked(std::max(0, workers));
}

TaskPool::~TaskPool() {
    {
        std::lock_guard<std::mutex> lock(impl_->mu);
        impl_->stopping = true;
    }
    impl_->cv.notify_all();
    for (auto& t : impl_->threads) t.join();
}

Task TaskPool::submit(std::function<void()> f) {
    Task task;
    task.state_ = std::make_shared<Task::State>();
    task.state_->fn = std::move(f);
    {
        std::lock_guard<std::mutex> lock(impl_->mu);
        impl_->queue.push_back(task.state_);
    }
    impl_->cv.notify_one();
    return task;
}

void TaskPool::parallel_for(size_t n, int threads, const std::function<void(size_t)>& f) {
    if (n == 0) return;
    const size_t helpers = std::min(n, static_cast<size_t>(std::max(1, threads))) - 1;
    if (helpers == 0) {
        for (size_t i = 0; i < n; ++i) f(i);
        return;
    }
    reserve(static_cast<int>(helpers));
    std::atomic<size_t> next{0};
    std::atomic<bool> failed{false};
    std::mutex error_mu;
    std::exception_ptr first;
    auto loop = [&] {
        for (size_t i; !failed.load(std::memory_order_relaxed) && (i = next++) < n;) {
            try {
                f(i);
            } catch (...) {
                std::lock_guard<std::mutex> lock(error_mu);
                if (!first) first = std::current_exception();
                failed = true;
            }
        }
    };
    std::vector<Task> tasks;
    tasks.reserve(helpers);
    for (size_t t = 0; t < helpers; ++t) tasks.push_back(submit(loop));
    loop();
    for (Task& t : tasks) t.wait();  // loop() never throws: errors are kept in `first`
    if (first) std::rethrow_exception(first);
}

void TaskPool::reserve(int workers) {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->grow_locked(std::min(workers, thread_budget()));
}

int TaskPool::workers() const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    return static_cast<int>(impl_->threads.size());
}

double produce_consume_strips(size_t count, const std::function<void(size_t k, int slot)>& produce,
                              const std::function<void(size_t k, int slot)>& consume) {
    using Clock = std::chrono::steady_clock;
    double waited = 0;
    if (count == 0) return waited;
    produce(0, 0);
    for (size_t k = 0; k < count; ++k) {
        const int slot = static_cast<int>(k % 2);
        Task next;
        if (k + 1 < count) next = TaskPool::shared().submit([&, k] { produce(k + 1, 1 - slot); });
        try {
            consume(k, slot);
        } catch (...) {
            try {
                next.wait();  // never leave the producer running on the caller's buffers
            } catch (...) {
            }
            throw;
        }
        const auto t0 = Clock::now();
        next.wait();  // rethrows the producer's error
        waited += std::chrono::duration<double>(Clock::now() - t0).count();
    }
    return waited;
}

int hardware_threads() {
    return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

int thread_budget() { return std::max(8, 4 * hardware_threads()); }

}  // namespace spectex
