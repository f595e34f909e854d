#pragma once
// The command line's report of a batch: runs it (pipeline/bake_batch.h) and reports each file
// (stderr, JSON Lines), the progress and the summary; bake --dry-run's listing.
#include <string>

#include "pipeline/bake.h"
#include "pipeline/bake_batch.h"

namespace spectex {

// Returns the exit status: 0 when every file succeeded or was up to date, else 1.
int run_batch(const BatchPlan& plan, const BakeSettings& settings);

// bake --dry-run: each file's dry_run_file, listed on stdout (one line each: bake, skip or fail,
// input -> output, and why; not when the JSON report goes to stdout) and in the --json report, a
// summary on stderr. Returns 1 when a real run would fail a file, else 0.
int run_dry_run(const BatchPlan& plan, const BakeSettings& settings);

// "2026-12-02T03:59:01Z": the prefix of a progress line in a log.
std::string utc_stamp();

}  // namespace spectex
