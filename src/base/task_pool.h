#pragma once
// The one task facility of spectex: a process-wide pool of worker threads. Every parallel stage
// uses it: the strip pipeline of bake and verify (a producer task per strip), the EXR writer's
// compression (a task per chunk, under its own bounded, ordered queue), verify's and the grid
// error's parallel loops, render, plan's search and the batch's jobs.
//
// A thread that waits for a task runs it itself if no worker has started it yet, so a wait never
// depends on a free worker: tasks may nest (a batch job submits strips, a strip submits chunks)
// and nothing deadlocks, whatever the size of the pool. A pool too small only serialises.
#include <cstddef>
#include <functional>
#include <memory>

namespace spectex {

// One unit of work handed to the pool, and the right to wait for it.
class Task {
  public:
    Task() = default;
    bool valid() const { return state_ != nullptr; }
    // Returns once the task has run (running it here if no worker has begun it); rethrows what it
    // threw. May be called again: it returns, or rethrows the same error.
    void wait();

    struct State;

  private:
    friend class TaskPool;
    std::shared_ptr<State> state_;
};

class TaskPool {
  public:
    // The process's pool: as many workers as hardware threads at first; reserve() adds more.
    static TaskPool& shared();

    explicit TaskPool(int workers);
    ~TaskPool();  // finishes the queued tasks, then joins the workers
    TaskPool(const TaskPool&) = delete;
    TaskPool& operator=(const TaskPool&) = delete;

    // Queues f; a worker runs it, or whoever waits for it first.
    Task submit(std::function<void()> f);

    // Runs f(i) for every i in [0, n), at most `threads` at once, the calling thread being one of
    // them; returns when every call has returned. If a call throws, no further index starts and
    // the first exception is rethrown here. threads <= 1 runs the loop on the caller, in order.
    void parallel_for(size_t n, int threads, const std::function<void(size_t)>& f);

    // Grows the pool to at least `workers` threads, never past thread_budget() (never shrinks
    // it): callers that promise a level of concurrency (--jobs, --threads) ask for it here.
    void reserve(int workers);
    int workers() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// The bounded producer/consumer of strips that bake and verify share: produce(k, slot) fills
// slot k % 2 with strip k, consume(k, slot) uses it. Strip k + 1 is produced on the pool while the
// caller consumes strip k, so at most two strips are in memory; produce calls run one at a time,
// in order (the producer alone may touch the reader). An exception from either side stops the
// pipeline once the other side has let go of its slot, and reaches the caller. Returns the
// seconds the consumer spent waiting for the producer.
double produce_consume_strips(size_t count, const std::function<void(size_t k, int slot)>& produce,
                              const std::function<void(size_t k, int slot)>& consume);

// The machine's hardware threads, at least 1: the default of every --threads.
int hardware_threads();

// The most threads spectex starts in one pool, whatever --jobs x --threads asks: 4 per hardware
// thread, at least 8. Work that waits (the writer, decoding) gains from a few threads more than
// cores; beyond 4 per core threads only share the same cores, and --jobs 256 --threads 1024 would
// otherwise start more threads than the kernel allows a process. The task pool never grows past
// it, and OpenEXR's and OpenImageIO's pools are sized within it (so a process holds at most three
// such pools, plus its stderr reader, a progress ticker and the main thread).
int thread_budget();

}  // namespace spectex
