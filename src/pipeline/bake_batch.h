#pragma once
// A batch from its inputs to its outputs: the plan (inputs listed, tile-expanded, sorted, sharded
// and named), the threads it may use, and the workers that bake it, each file handed to a
// listener (the command's report) as it is done.
#include <chrono>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/bake.h"
#include "pipeline/batch_files.h"

namespace spectex {

struct BatchPlan {
    std::vector<std::pair<std::string, std::string>> files;  // (input, output), in order
    int jobs = 1, threads = 1;
    bool update = false, fail_fast = false, quiet = false, verbose = false, progress = false;
    std::string json;  // "" none, "-" stdout, else a file
    bool progress_terminal =
        false;  // progress as one rewritten line (a terminal), else timestamped lines
    bool make_folders = false;  // outputs named by a template or --output-dir: create their folders
    // --shard "i/n" when files is one shard of a list of `listed` files ("" the whole list): the
    // summary says so, even of a shard that holds one file or none.
    std::string shard;
    size_t listed = 0;
    // With update: each file's check_update, made before the set-up (empty: checked by the
    // workers). When every file is up to date, the settings carry no method: nothing is baked.
    std::vector<UpdateCheck> prechecked;
};

// Where outputs go: -o (one file or a template), --output-dir, --base-dir.
struct OutputNaming {
    std::string output, output_dir, base_dir;
    // Named per input (a template or --output-dir), not one -o file: their folders are created.
    bool per_input() const;
};

// The inputs given, then those of the list `from_list` ("" none, "-" stdin; read_list). Throws
// Error when the list names no file and no input was given.
std::vector<std::string> list_inputs(const std::vector<std::string>& given,
                                     const std::string& from_list);
// <UDIM> and <UVTILE> expanded (expand_tiles), byte-sorted, each file once. Throws Error.
std::vector<std::string> expand_inputs(const std::vector<std::string>& listed);
// (input, output) for each input, in order: the one -o file, or output_for's name. Throws Error
// for an input outside --base-dir or a name the template cannot make.
std::vector<std::pair<std::string, std::string>> name_outputs(
    const std::vector<std::string>& inputs, const OutputNaming& naming);

// `jobs` files at once with `threads` threads each (0: the cores shared among the jobs). Sizes
// OpenEXR's global pool for all jobs together and the image decoders' threads.
// Two inputs must never race for one output: outputs compared by where they land (folders
// resolved, links followed), not by how they are spelt. Per file: "" or why it is not baked
// ("<input>: its output ... is also the output of ..."). bake checks the whole list before any
// work; the batch checks again as it goes.
std::vector<std::string> output_clashes(
    const std::vector<std::pair<std::string, std::string>>& files);

void size_batch_threads(BatchPlan& plan, int jobs, int threads);

// How often progress is reported: on a terminal every 250 ms (one line rewritten); in a log every
// SPECTEX_PROGRESS_SECONDS (default 10; 0.01 to 86400).
std::chrono::milliseconds progress_period(bool terminal);

// What one job is baking, for a progress line.
struct JobSlot {
    std::string input;  // "" when idle (guarded by the batch's lock)
    std::chrono::steady_clock::time_point start;
    BakeProgress rows;
};

struct BatchCounts {
    size_t total = 0, done = 0, ok = 0, skipped = 0, failed = 0;
    // Files stopped inside their bake by a termination request (not done: no record, no output).
    size_t interrupted = 0;
};

// Told of a batch as it runs, always with the batch's lock held (one call at a time).
class BatchListener {
  public:
    virtual ~BatchListener() = default;
    // One file's record, as its worker finishes it (before the counts include it).
    virtual void file_done(const FileRecord& r) = 0;
    // With plan.progress: after each file, and while a job is inside a file, a few times a second
    // on a terminal or every SPECTEX_PROGRESS_SECONDS (default 10) in a log.
    virtual void progress(const BatchCounts& counts, const std::vector<JobSlot>& slots) = 0;
};

struct BatchOutcome {
    BatchCounts counts;
    // Per input, in input order: its bake's result (baked files only, was_baked), for a summary.
    std::vector<BakeResult> baked;
    std::vector<bool> was_baked;
    // The termination request (io/atomic_file.h termination_requested) that stopped the batch, or
    // 0: the files after it were not started, those being baked were stopped (counts.interrupted).
    int signal = 0;
};

// bake --dry-run of file i of the plan: what --update finds (the output's header, and the source's
// bytes only when its time changed, as --update reads them), then, unless plan.update skips it,
// the checks a real run makes before its first pixel: the output's folder can be written or
// created, the input opens and its header is valid (size within settings.max_pixels, colour
// channels), its colour space can be chosen. No pixel is decoded; nothing is written or created.
DryRunFile dry_run_file(const BatchPlan& plan, size_t i, const BakeSettings& settings);

// Bakes plan.files with plan.jobs workers (skipping those --update finds up to date, failing
// those whose output is another input's, stopping after a failure with fail_fast, or at a
// termination request: no new file is started, the files being baked stop at their next strip and
// are neither recorded nor counted as done; each finished file was handed to the listener as it
// finished).
BatchOutcome bake_batch(const BatchPlan& plan, const BakeSettings& settings,
                        BatchListener& listener);

}  // namespace spectex
