#pragma once
// The answer of a plan kept between runs: `spectex plan` and `bake --wavelengths auto` search the
// same candidates again in every process (51 s for the default table on 2 busy cores, paid again by
// every farm shard). The whole PlanResult is kept in the cache folder (io/data_dir: cache_folder)
// under a key that hashes everything the answer depends on, so a hit gives the same table, the
// same chosen grid and the same figures (spectex:planWorstDe) as the search.
#include <string>

#include "pipeline/cached_answer.h"
#include "pipeline/plan.h"
#include "spectral/precision.h"

namespace spectex {

// The cache format; a change of what an entry holds or means changes it, and every older entry
// misses.
constexpr int kPlanCacheFormat = 2;
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

// What became of the entry (pipeline/cached_answer.h): folder, entry, hit, ignored, warning.
using PlanCacheReport = CacheReport;

// plan_grids(spec) through the cache in `folder` ("" = no cache): an entry that cannot be read or
// parsed (corrupt, truncated, a link, a folder, too large) is a miss, recomputed and replaced;
// an answer that cannot be stored sets report->warning. r.seconds is this call's time.
PlanResult plan_grids_cached(const PlanSpec& spec, const std::string& folder,
                             PlanCacheReport* report);

// The body of an entry (pipeline/cached_answer.h seals it) and back; parse returns false on
// anything that is not a whole, well-formed body for `key` and an answer the search could have
// given for `spec` (every candidate grid once, the spec's lights, figures and verdicts that agree).
std::string plan_cache_text(const std::string& key, const PlanResult& r);
bool parse_plan_cache_text(const std::string& text, const std::string& key, const PlanSpec& spec,
                           PlanResult* r);

// The bits of --precision auto kept between runs: choose_precision measures about a hundred bit
// vectors on the cube sample (4 s for the basis, 10-26 s for the lattice on 2 busy cores), paid
// again by every bake with the same settings. The entry holds the chosen bits and the worst ΔE00
// per light, with its code, under a key that hashes everything the choice depends on.
// Format 2: bits below kMinMantissaBits are no answer the chooser gives (format 1's entries could
// hold 0-bit bins). Format 3: each light's worst 8-bit code beside its worst ΔE00.
constexpr int kPrecisionCacheFormat = 3;
constexpr size_t kPrecisionCacheEntryLimit = size_t(1) << 20;

// The chooser's own version: what its answers depend on besides the request (the judge's
// colorimetry, the whole-cube check, the search). Raised with every change to them, so that an
// answer shipped with the data (config/spectral/precision/) is never taken for another chooser's.
// 2: every 8-bit colour checked, colours reconstructed as a renderer does.
// 3: against the method's own spectrum at 1 nm (the grid's error and the rounding together).
// 4: the coarser grids hold a colour to 2^-10 of its value where that is more than 6.1e-5.
constexpr int kPrecisionChooserVersion = 4;

// What choose_precision(req) depends on besides the build, hashed: the cache format, the
// chooser's version, the method (name, checksum of its tables, provenance, wavelengths and
// weights of its bins), the observer's tables, every light's name and table (the bake's
// illuminant among them), the colour-aware rounding's weights (or nearest rounding), the
// reference (its checksum and wavelengths, or none), the budget
// and the sample stride. Not the threads (the choice does not depend on them).
// "precision-<32 hex digits>": the name of an answer shipped in config/spectral/precision/.
std::string precision_answer_key(const PrecisionRequest& req);
// The cache's key: precision_answer_key and this build of spectex (version and executable).
std::string precision_cache_key(const PrecisionRequest& req);
// <data dir>/spectral/precision: the answers shipped with spectex (the default bake's bits, so
// that no first bake pays for the whole-cube check).
std::string shipped_precision_folder();

using PrecisionCacheReport = CacheReport;

// choose_precision(req): the answer shipped for this request if there is one (whatever `folder`),
// else through the cache in `folder` ("" = no cache). An entry that cannot be
// read or is not a whole, valid answer for this request (bits per bin 0..10, one per bin, the
// request's lights in order, finite errors) is a miss: the bits are chosen again and the entry
// replaced, so a corrupt or hostile entry never changes a bake.
PrecisionChoice choose_precision_cached(const PrecisionRequest& req, const std::string& folder,
                                        PrecisionCacheReport* report);

// The body of an entry (pipeline/cached_answer.h seals it) and back.
std::string precision_cache_text(const std::string& key, const PrecisionChoice& c);
bool parse_precision_cache_text(const std::string& text, const std::string& key,
                                const PrecisionRequest& req, PrecisionChoice* c);

}  // namespace spectex
