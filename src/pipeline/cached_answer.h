#pragma once
// An answer kept between runs in the cache folder (io/data_dir: cache_folder), one file per key:
// the one way every cached answer (the plan's, the precision's bits, a built method's table) is
// kept. The entry is read by read_small_regular_file (regular files only, no link followed, at
// most `limit` bytes), its seal is checked (below), and it is taken only when `parse` then accepts
// all of its body for this key; anything else is a miss, recomputed and replaced by
// store_file_in_folder (temporary file, fsync, rename). A store that fails is a warning: the
// answer is still good.
//
// The seal: every entry ends with "check fnv1a64:<16 hex>\nend\n", the hash of every byte before
// it. A parser only sees whether an entry is well formed; a damaged entry can be well formed (one
// wavelength of a plan's grid lowered by 1 nm, one figure changed), and only a check over the
// whole entry tells it from the answer that was stored. It guards against damage (a disk, a
// half-synced copy, an editor), not against someone who can write the cache and recompute the
// hash: that person can write the user's files too.
#include <filesystem>
#include <string>
#include <system_error>

#include "base/fnv1a.h"
#include "io/atomic_file.h"

namespace spectex {

// The entry's text for a body: the body, then its seal.
inline std::string sealed_entry(const std::string& body) {
    Fnv1a64 h;
    h.add(body.data(), body.size());
    return body + "check " + h.text() + "\nend\n";
}

// The body of a sealed entry into *body; false when the seal is missing or does not match.
inline bool unseal_entry(const std::string& text, std::string* body) {
    const size_t at = text.rfind("check ");
    if (at == std::string::npos) return false;
    Fnv1a64 h;
    h.add(text.data(), at);
    if (text.compare(at, std::string::npos, "check " + h.text() + "\nend\n") != 0) return false;
    *body = text.substr(0, at);
    return true;
}

struct CacheReport {
    std::string folder;    // "" when the cache is off
    std::string entry;     // the entry's path
    bool hit = false;      // the answer came from the entry
    bool shipped = false;  // ... an entry shipped with spectex's data, not the cache
    bool ignored = false;  // an entry was there but not a valid answer: computed again, replaced
    std::string warning;   // the entry could not be stored (the answer is still good)
};

// The answer under `key` in `folder`: parse(body, &answer) -> bool on the body of an entry whose
// seal holds, else compute() -> T, stored as sealed_entry(text(answer)). Fills rep's entry, hit,
// ignored and warning.
template <class T, class Parse, class Compute, class Text>
T cached_answer(const std::string& folder, const std::string& key, size_t limit, Parse parse,
                Compute compute, Text text, CacheReport& rep) {
    rep.entry = folder + "/" + key;
    std::string stored, body;
    T answer;
    if (read_small_regular_file(rep.entry, limit, &stored) && unseal_entry(stored, &body) &&
        parse(body, &answer)) {
        rep.hit = true;
        return answer;
    }
    std::error_code ec;
    rep.ignored = std::filesystem::symlink_status(rep.entry, ec).type() !=
                  std::filesystem::file_type::not_found;
    answer = compute();
    rep.warning = store_file_in_folder(folder, key, sealed_entry(text(answer)));
    return answer;
}

}  // namespace spectex
