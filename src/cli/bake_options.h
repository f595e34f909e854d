#pragma once
// bake's command line: its options, parsed into a BakeCli (the request of the set-up,
// pipeline/bake_request, and what the command does with the batch), and the checks across them
// (usage errors, exit 2, before any file is read).
#include <string>
#include <vector>

#include "cli/arg_parser.h"
#include "cli/method_options.h"
#include "pipeline/bake_request.h"

namespace spectex {

struct BakeCli {
    std::string output, basis = "fit", wavelengths = "380:780:5", type = "half",
                        compression = ExrCompression::kDefault;
    std::string alpha = "associated", range = "clamp", nan = "replace";
    std::string wavelengths_file;
    // --method and the options of each method (method_options.h): what bake builds and what
    // --wavelengths auto plans with.
    MethodOptions m;
    bool allow_lossy = false;  // --allow-lossy: a compression that changes samples is wanted
    bool wavelengths_given = false;
    std::string output_dir, base_dir, from_list, json, shard;
    std::string wrap, swrap, twrap;  // --wrap MODE[,MODE], --swrap, --twrap
    bool wrap_given = false, swrap_given = false, twrap_given = false;
    int threads = 0, jobs = 1;
    bool quiet = false, verbose = false, progress = false, update = false, force = false,
         fail_fast = false, dry_run = false;
    // What the set-up is asked (pipeline/bake_request): the options, the grid, --wavelengths
    // auto's plan; the method (m.spec) and the precision request are copied in once all are read.
    BakeRequest req;
    bool plan_lights = false, plan_budget = false, no_cache = false, zip_level_given = false;
    // Neither --method nor an option of one method: the default bake (DefaultBake), its method,
    // and its precision budget where one can be kept.
    bool default_bake = false;
    // --precision full|auto and --precision-de (docs/precision.md); "" until resolved: auto for
    // the default bake (DefaultBake) where a budget can be kept, else full.
    std::string precision;
    bool precision_given = false;
    double precision_de = 0;  // 0: --max-de's
    bool precision_de_given = false;
};

// Every option of bake, filling `c` as they are parsed.
void declare_bake_options(ArgParser& p, BakeCli& c);
// Once all are read: what must be given and what goes with what, the method and its conditions
// (check_conditions), the grid, --precision, the cost of the options; then the request's values
// that are not parsed into it directly, and the options each output records. Throws UsageError.
void check_bake_options(BakeCli& c, const std::vector<std::string>& inputs,
                        const std::vector<ArgParser::Given>& given);

// A folder, links followed; false when it cannot be examined.
bool is_directory(const std::string& p);

}  // namespace spectex
