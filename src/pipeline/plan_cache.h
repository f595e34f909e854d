#pragma once
// The answer of a plan kept between runs: `spectex plan` and `bake --wavelengths auto` search the
// same candidates again in every process (51 s for the default table on 2 busy cores, paid again by
// every farm shard). The whole PlanResult is kept in the cache folder (io/data_dir: cache_folder)
// under a key that hashes everything the answer depends on, so a hit gives the same table, the
// same chosen grid and the same figures (spectex:planWorstDe) as the search.
#include <string>

#include "pipeline/plan.h"

namespace spectex {

// The cache format; a change of what an entry holds or means changes it, and every older entry
// misses.
constexpr int kPlanCacheFormat = 1;
// An entry larger than this is not read (a hostile or broken file): the largest real one, 21 rows
// of 4,701 bins with their weights, is about 5 MB.
constexpr size_t kPlanCacheEntryLimit = size_t(64) << 20;

// What the answer of plan_grids(spec) depends on, hashed: this build of spectex (version and
// executable), the cache format, the method and its options, the observer's and every light's and
// illuminant's table contents (by value, whatever their names), the budget, reconstruction,
// range, sample type, candidate grids, colours, sample stride, --nonuniform, and with --texture
// the texture's bytes, its colour space, the OCIO config's files and the limits. Not the threads
// (the answer does not depend on them). "plan-<32 hex digits>". Throws Error when a table or the
// texture cannot be read (as plan_grids would).
std::string plan_cache_key(const PlanSpec& spec);

struct PlanCacheReport {
    std::string folder;   // "" when the cache is off
    std::string entry;    // the entry's path
    bool hit = false;     // the answer came from the entry
    std::string warning;  // the entry could not be stored (the answer is still good)
};

// plan_grids(spec) through the cache in `folder` ("" = no cache): an entry that cannot be read or
// parsed (corrupt, truncated, a link, a folder, too large) is a miss, recomputed and replaced;
// an answer that cannot be stored sets report->warning. r.seconds is this call's time.
PlanResult plan_grids_cached(const PlanSpec& spec, const std::string& folder,
                             PlanCacheReport* report);

// The text of an entry and back (for the tests of the format); parse returns false on anything
// that is not a whole, well-formed entry for `key`.
std::string plan_cache_text(const std::string& key, const PlanResult& r);
bool parse_plan_cache_text(const std::string& text, const std::string& key, PlanResult* r);

}  // namespace spectex
