#pragma once
// Runs a batch of bakes with --jobs workers, reporting per file (stderr, JSON Lines) and overall.
#include <string>
#include <utility>
#include <vector>

#include "pipeline/bake.h"
#include "pipeline/batch.h"

namespace spectex {

struct BatchPlan {
    std::vector<std::pair<std::string, std::string>> files;  // (input, output), in order
    int jobs = 1, threads = 1;
    bool update = false, fail_fast = false, quiet = false, verbose = false, progress = false;
    std::string json;  // "" none, "-" stdout, else a file
    bool progress_terminal =
        false;  // progress as one rewritten line (a terminal), else timestamped lines
    bool make_folders = false;  // outputs named by a template or --output-dir: create their folders
    // With update: each file's check_update, made before the set-up (empty: checked by the
    // workers). When every file is up to date, the settings carry no method: nothing is baked.
    std::vector<UpdateCheck> prechecked;
};

// Returns the exit status: 0 when every file succeeded or was up to date, else 1.
int run_batch(const BatchPlan& plan, const BakeSettings& settings);

}  // namespace spectex
