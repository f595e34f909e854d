#pragma once
// A per-process memo of expensive, deterministic builds (a fitted basis, a lattice, a parsed
// colour config): the first caller of a key builds it outside the lock, later callers of the same
// key wait for that build and share its value (or its exception), and builds of different keys
// run at the same time.
#include <cstddef>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <utility>

namespace spectex {

template <typename Key, typename Value>
class Memo {
  public:
    // capacity > 0: at most that many keys are kept; the memo starts afresh when a new key would
    // pass it (callers waiting on a build keep their own share of it).
    explicit Memo(size_t capacity = 0) : capacity_(capacity) {}

    Value get(const Key& key, const std::function<Value()>& build) {
        std::promise<Value> promise;
        std::shared_future<Value> future;
        bool builder = false;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            auto it = entries_.find(key);
            if (it == entries_.end()) {
                if (capacity_ > 0 && entries_.size() >= capacity_) entries_.clear();
                future = promise.get_future().share();
                entries_.emplace(key, future);
                builder = true;
            } else {
                future = it->second;
            }
        }
        if (builder) {
            try {
                promise.set_value(build());
            } catch (...) {
                promise.set_exception(std::current_exception());
            }
        }
        return future.get();
    }

  private:
    size_t capacity_;
    std::mutex mutex_;
    std::map<Key, std::shared_future<Value>> entries_;
};

}  // namespace spectex
