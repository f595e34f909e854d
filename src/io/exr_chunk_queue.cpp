#include "io/exr_chunk_queue.h"

#include <algorithm>
#include <chrono>
#include <utility>

#include "base/error.h"

namespace spectex {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

}  // namespace

ExrChunkQueue::ExrChunkQueue(std::string name, int max_buffers, size_t max_chunk_bytes,
                             std::unique_ptr<DeflaterPool> deflaters, WriteChunk write)
    : name_(std::move(name)),
      max_buffers_(max_buffers),
      max_chunk_bytes_(max_chunk_bytes),
      deflaters_(std::move(deflaters)),
      write_(std::move(write)) {}

ExrChunkQueue::~ExrChunkQueue() { drain(); }

// Writes every compressed chunk that is next in line. Any thread may call it.
void ExrChunkQueue::write_ready() {
    std::lock_guard<std::mutex> wl(write_mu_);
    for (;;) {
        ExrChunk* c = nullptr;
        {
            std::lock_guard<std::mutex> lock(mu_);
            auto it = done_.find(next_write_);
            if (it == done_.end() || error_) return;
            c = it->second;
            done_.erase(it);
        }
        std::exception_ptr e;
        try {
            write_(*c);
        } catch (...) {
            e = std::current_exception();
        }
        std::lock_guard<std::mutex> lock(mu_);
        if (e && !error_) error_ = e;
        ++next_write_;
        free_.push_back(c);
        if (error_) return;
    }
}

// One task of the pool: compresses chunk c, then writes whatever is next in line. Never
// throws: a failure is kept in `error_` for the caller's thread.
void ExrChunkQueue::compress_task(ExrChunk* c) {
    auto t0 = Clock::now();
    try {
        bool raw = false;
        c->bytes = deflaters_->compress(c->data.data(), c->raw_bytes, &raw);
        if (raw) {
            std::lock_guard<std::mutex> lock(stats_mu_);
            ++stats_.raw_chunks;
        }
    } catch (...) {
        std::lock_guard<std::mutex> lock(mu_);
        if (!error_) error_ = std::current_exception();
        return;
    }
    {
        std::lock_guard<std::mutex> lock(stats_mu_);
        stats_.compress_seconds += since(t0);
    }
    {
        std::lock_guard<std::mutex> lock(mu_);
        done_[c->index] = c;
    }
    write_ready();
}

// Waits for the oldest compression still pending (running it here if no worker has begun it).
// Once it has returned, every chunk up to it is written and its buffer is free again.
bool ExrChunkQueue::finish_oldest() {
    if (pending_.empty()) return false;
    Task t = std::move(pending_.front());
    pending_.pop_front();
    t.wait();
    return true;
}

void ExrChunkQueue::drain() {
    while (finish_oldest()) {
    }
}

void ExrChunkQueue::rethrow() {
    std::lock_guard<std::mutex> lock(mu_);
    if (error_) std::rethrow_exception(error_);
}

int ExrChunkQueue::written() const {
    std::lock_guard<std::mutex> lock(mu_);
    return next_write_;
}

ExrChunk& ExrChunkQueue::acquire() {
    auto t0 = Clock::now();
    std::unique_lock<std::mutex> lock(mu_);
    while (!error_ && free_.empty() && static_cast<int>(all_.size()) >= max_buffers_) {
        lock.unlock();
        if (!finish_oldest()) throw Error(name_ + ": internal: no chunk buffer can come free");
        lock.lock();
    }
    if (error_) std::rethrow_exception(error_);
    ExrChunk* c;
    if (!free_.empty()) {
        c = free_.back();
        free_.pop_back();
    } else {
        all_.push_back(std::make_unique<ExrChunk>());
        c = all_.back().get();
        std::lock_guard<std::mutex> stats_lock(stats_mu_);
        ++stats_.buffers;
    }
    lock.unlock();
    c->index = next_chunk_++;
    c->filled = 0;
    if (c->data.size() < max_chunk_bytes_) c->data.resize(max_chunk_bytes_);
    std::lock_guard<std::mutex> stats_lock(stats_mu_);
    stats_.wait_seconds += since(t0);
    return *c;
}

void ExrChunkQueue::submit(ExrChunk& c) {
    {
        std::lock_guard<std::mutex> stats_lock(stats_mu_);
        stats_.chunk_bytes = std::max(stats_.chunk_bytes, c.raw_bytes);
    }
    if (deflaters_) {
        ExrChunk* p = &c;
        pending_.push_back(TaskPool::shared().submit([this, p] { compress_task(p); }));
        return;
    }
    std::unique_lock<std::mutex> lock(mu_);
    c.bytes = c.raw_bytes;
    done_[c.index] = &c;
    lock.unlock();
    write_ready();
}

SpectralExrWriter::Timing ExrChunkQueue::timing() const {
    std::lock_guard<std::mutex> lock(stats_mu_);
    return stats_;
}

}  // namespace spectex
