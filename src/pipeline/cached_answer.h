#pragma once
// An answer kept between runs in the cache folder (io/data_dir: cache_folder), one file per key:
// the shape the plan's and the precision's caches (pipeline/plan_cache) share. The entry is read
// by read_small_regular_file (regular files only, no link followed, at most `limit` bytes) and
// taken only when `parse` accepts all of it for this key; anything else is a miss, recomputed and
// replaced by store_file_in_folder (temporary file, fsync, rename). A store that fails is a
// warning: the answer is still good.
#include <filesystem>
#include <string>
#include <system_error>

#include "io/atomic_file.h"

namespace spectex {

struct CacheReport {
    std::string folder;    // "" when the cache is off
    std::string entry;     // the entry's path
    bool hit = false;      // the answer came from the entry
    bool ignored = false;  // an entry was there but not a valid answer: computed again, replaced
    std::string warning;   // the entry could not be stored (the answer is still good)
};

// The answer under `key` in `folder`: parse(text, &answer) -> bool on the entry's text, else
// compute() -> T, stored as text(answer). Fills rep's entry, hit, ignored and warning.
template <class T, class Parse, class Compute, class Text>
T cached_answer(const std::string& folder, const std::string& key, size_t limit, Parse parse,
                Compute compute, Text text, CacheReport& rep) {
    rep.entry = folder + "/" + key;
    std::string stored;
    T answer;
    if (read_small_regular_file(rep.entry, limit, &stored) && parse(stored, &answer)) {
        rep.hit = true;
        return answer;
    }
    std::error_code ec;
    rep.ignored = std::filesystem::symlink_status(rep.entry, ec).type() !=
                  std::filesystem::file_type::not_found;
    answer = compute();
    rep.warning = store_file_in_folder(folder, key, text(answer));
    return answer;
}

}  // namespace spectex
