#include <algorithm>
#include <cstdio>
#include <iostream>

#include "base/error.h"
#include "base/text.h"
#include "cli/arg_parser.h"
#include "cli/bake_options.h"
#include "cli/batch_report.h"
#include "cli/commands.h"
#include "cli/output_check.h"
#include "io/atomic_file.h"
#include "io/data_dir.h"
#include "io/file_identity.h"
#include "io/library_stderr.h"
#include "io/ocio_config.h"
#include "pipeline/bake.h"
#include "pipeline/bake_batch.h"
#include "pipeline/bake_request.h"
#include "pipeline/batch_files.h"
#include "pipeline/plan.h"
#include "pipeline/plan_cache.h"
#include "pipeline/plan_report.h"
#include "spectral/precision.h"

namespace spectex {

namespace {

// Raised when something every file needs cannot be read before any work (exit 2, no usage hint).
class SetupFailure : public std::runtime_error {
  public:
    explicit SetupFailure(const std::string& what) : std::runtime_error(what) {}
};

// The batch's files: inputs listed, expanded and named, each with its output
// (pipeline/bake_batch). `whole` is the whole list; plan.files is this shard's part of it, taken
// by check_outputs_against_reads once every check of the whole list has passed.
BatchPlan plan_bake_files(BakeCli& c, const std::vector<std::string>& inputs,
                          std::vector<std::pair<std::string, std::string>>& whole) {
    BatchPlan plan;
    c.req.data_dir = find_data_dir();
    if (!c.base_dir.empty() && !is_directory(c.base_dir))
        throw UsageError("--base-dir: '" + c.base_dir + "' is not a folder");
    if (!c.output_dir.empty() && !c.output.empty() && !has_template_tokens(c.output))
        throw UsageError(
            "-o " + c.output +
            " names one file and --output-dir a folder for each input's output: give "
            "one, or an -o template inside the folder (e.g. -o '{stem}.spectral.exr')");
    const std::vector<std::string> listed = list_inputs(inputs, c.from_list);
    std::vector<std::string> expanded = expand_inputs(listed);
    const OutputNaming naming{c.output, c.output_dir, c.base_dir};
    if (expanded.size() > 1 && !naming.per_input())
        throw UsageError("several inputs need --output-dir DIR or an -o template with {stem}");
    // Every entry named, whichever shard it falls in: a name the template cannot make, or an input
    // outside --base-dir, refuses every shard as it refuses the whole list.
    try {
        whole = name_outputs(expanded, naming);
    } catch (const Error& e) {
        throw UsageError(e.what());
    }
    return plan;
}

// No output may be a file this command reads, whatever its spelling or links, nor the output of
// another input. Checked on the whole list, whatever --shard takes of it: shards run apart (farm
// tasks), so a clash between two entries of different shards is seen by neither shard's part,
// and the last task to finish would win; an output that is another shard's input would be
// overwritten while that shard reads it. Each shard is refused (exit 2) exactly when the whole
// list is; then plan.files is the shard's part.
void check_outputs_against_reads(const BakeCli& c, BatchPlan& plan,
                                 const std::vector<std::pair<std::string, std::string>>& whole) {
    ReadFiles reads;
    reads.add_data_dir(c.req.data_dir);
    for (const auto& file : whole) reads.add(file.first, "an input");
    reads.add(c.from_list, "--from-list");
    {
        const std::string config = ocio_config_path(c.req.data_dir, c.req.options.config);
        std::vector<std::string> files;
        try {
            files =
                ocio_config_files(config);  // a config that cannot be read fails every file: once
        } catch (const Error& e) {
            throw SetupFailure(e.what());
        }
        reads.add(files.front(), "the OCIO config");
        for (size_t i = 1; i < files.size(); ++i) reads.add(files[i], "a LUT file of " + config);
    }
    if (c.m.basis != "fit" && c.m.basis != "mallett2019") reads.add(c.m.basis, "--basis");
    reads.add(c.m.spec.fit.observer, "--observer");
    reads.add(c.m.spec.fit.illuminant, "--illuminant");
    reads.add(c.wavelengths_file, "--wavelengths-file");
    if (c.wavelengths == "auto")
        for (const auto& l : c.req.plan.lights) reads.add(l, "--lights");
    // Every collision, before any work: a batch that found them as it went had already baked the
    // first of each pair (and exited 1 after a long run).
    {
        const std::vector<std::string> clashes = output_clashes(whole);
        std::string list;
        size_t n = 0;
        for (const auto& c : clashes)
            if (!c.empty() && n++ < 5) list += (list.empty() ? "" : "; ") + c;
        if (n)
            throw UsageError(
                std::to_string(n) + " input" + (n == 1 ? "" : "s") +
                " would write an output another input writes: " + list + (n > 5 ? "; ..." : "") +
                ". Name the outputs apart: {ext} tells a.png from a.tif, and --base-dir DIR with "
                "{reldir} (or --output-dir) keeps each input's folder");
    }
    std::vector<OutputTarget> targets;
    for (const auto& [in, out] : whole) {
        check_output(out, "the output of " + in, reads, false, false);
        targets.push_back(output_target(out));
    }
    if (!c.json.empty() && c.json != "-") {
        check_output(c.json, "--json", reads, true);
        const OutputTarget report = output_target(c.json);
        for (size_t i = 0; i < targets.size(); ++i)
            if (report.same_as(targets[i]))
                throw UsageError("--json: " + c.json + " is also the output of " + whole[i].first);
    }
    if (c.shard.empty()) {
        plan.files = whole;
        return;
    }
    plan.files = select_shard(whole, Shard::parse(c.shard));
    plan.shard = c.shard;
    plan.listed = whole.size();
}

// What bake's set-up tells (pipeline/bake_request), printed as bake prints it: on stderr, warnings
// unless -q, the choices made unless -q, the rest under -v.
class SetupReport : public BakeSetupListener {
  public:
    SetupReport(const BakeCli& c, const BakeSettings& hashed) : c_(c), hashed_(hashed) {}

    void grid_planned(const PlanSpec& spec, const PlanResult& pr,
                      const PlanCacheReport& rep) override {
        report_plan_cache(spec, rep, c_.verbose, c_.quiet);
        if (c_.verbose) std::cerr << plan_table(spec, pr);
        if (pr.chosen < 0 || c_.quiet) return;
        const GridRow& row = pr.rows[static_cast<size_t>(pr.chosen)];
        char num[64];
        std::snprintf(num, sizeof num, "%.4g", row.worst);
        std::cerr << "spectex: --wavelengths auto: " << grid_label(row.grid) << " (" << row.bins
                  << " bins), worst " << num << " ΔE00 under " << row.worst_light << ", within "
                  << hashed_.plan.max_de << " under " << join_names(spec.lights) << " ("
                  << pr.seconds << " s" << (rep.hit ? ", from the cache" : "") << ")\n";
    }

    void grid_known(const WavelengthGrid& grid) override {
        note_grid_cost("bake",
                       c_.wavelengths == "auto" ? "--wavelengths auto chose " + grid_label(grid)
                       : c_.wavelengths_file.empty() ? "--wavelengths " + grid.describe()
                                                     : "--wavelengths-file " + c_.wavelengths_file,
                       grid.size(), hashed_.type == SampleType::Half ? 2 : 4, c_.quiet);
    }

    void method_built(const MethodSpec& spec, const MethodResult& made) override {
        if (!made.warning.empty()) warning(made.warning);
        const CacheReport& rep = made.cache;
        cache_warnings(rep, "the method's table is", "built again");
        if (c_.verbose)
            std::cerr << "spectex: " << spec.describe()
                      << (rep.hit ? ": read from the cache in " : ": built in ")
                      << made.build_seconds << " s"
                      << (rep.hit ? " (" + one_line(quote_path(rep.entry)) + ")" : "") << "\n";
    }

    void warning(const std::string& text) override {
        if (!c_.quiet) std::cerr << "spectex: warning: " << text << "\n";
    }

    // What a cache said that the user should know (printed unless -q): an answer it could not keep,
    // an entry it refused. `what` names the answer ("the precision's bits are"), `redo` what was
    // done instead.
    void cache_warnings(const CacheReport& rep, const std::string& what, const std::string& redo) {
        if (!rep.warning.empty() && !c_.quiet)
            std::cerr << "spectex: warning: " << what
                      << " not kept in the cache: " << one_line(rep.warning)
                      << " (SPECTEX_CACHE_DIR moves the cache; --no-cache does without)\n";
        if (rep.ignored && !c_.quiet)
            std::cerr << "spectex: warning: " << one_line(quote_path(rep.entry))
                      << ": not a valid entry of " << what.substr(0, what.rfind(' ')) << "; "
                      << redo << "\n";
    }

    void precision_chosen(const BakeSettings::Precision& rec, const PrecisionChoice& pc,
                          const PrecisionCacheReport& rep, double seconds) override {
        cache_warnings(rep, "the precision's bits are", "chosen again");
        if (rep.hit && c_.verbose)
            std::cerr << "spectex: the precision's bits from "
                      << (rep.shipped ? "spectex's data" : "the cache") << ": "
                      << one_line(quote_path(rep.entry)) << "\n";
        // The bits asked for are said; the default bake's own only with -v (its bake says nothing
        // more than any other, and a failed file's error stays the first line).
        if (c_.quiet || (c_.default_bake && !c_.precision_given && !c_.verbose)) return;
        double w = 0;
        for (double d : pc.worst_de) w = std::max(w, d);
        char num[64];
        std::snprintf(num, sizeof num, "%.0f%%", 100 * kept_fraction(pc.bits));
        std::cerr << "spectex: --precision auto: " << num << " of half's mantissa bits kept (bits "
                  << format_precision_bits(pc.bits) << "), worst " << format_de_up(w)
                  << " ΔE00 within " << rec.max_de << " under " << rec.lights
                  << " on every 8-bit colour (" << seconds << " s"
                  << (rep.shipped ? ", shipped with spectex"
                      : rep.hit   ? ", from the cache"
                                  : "")
                  << ")\n";
    }

  private:
    const BakeCli& c_;
    const BakeSettings& hashed_;
};

// The settings every file is baked with (pipeline/bake_request). Those that are the same for
// every file (grid, colour config and space, observer, illuminant, basis, method) are checked
// once, before any input is read: one message, exit 2. The settings hash is known before anything
// expensive is built (a basis fit, a lattice or Jakob-Hanika table, --wavelengths auto's search,
// an OCIO processor), so that --update checks the outputs' headers first and a run whose files
// are all up to date builds nothing (its settings then carry no method), and a dry run lists the
// files from the hash and the headers. Throws Error (exit 2), UnmetBudget (exit 1).
BakeSettings prepare_settings(const BakeCli& c, BatchPlan& plan) {
    const BakeSetup setup(c.req);
    if (c.dry_run) {
        setup.check_colour_space();
        return setup.hashed();
    }
    bool all_up_to_date = false;
    if (c.update && !c.force) {
        all_up_to_date = true;
        for (const auto& [in, out] : plan.files) {
            plan.prechecked.push_back(check_update(in, out, setup.hashed()));
            all_up_to_date = all_up_to_date && plan.prechecked.back().up_to_date;
        }
    }
    if (all_up_to_date) return setup.hashed();
    SetupReport report(c, setup.hashed());
    return setup.finish(report);
}
// Threads, and how the batch runs and reports.
void finish_batch_plan(const BakeCli& c, BatchPlan& plan) {
    size_batch_threads(plan, c.jobs, c.threads);
    plan.update = c.update && !c.force;
    plan.make_folders = OutputNaming{c.output, c.output_dir, c.base_dir}.per_input();
    plan.fail_fast = c.fail_fast;
    plan.quiet = c.quiet;
    plan.verbose = c.verbose;
    plan.progress = c.progress || (!c.quiet && stderr_is_terminal());
    plan.progress_terminal = stderr_is_terminal();
    plan.json = c.json;
}

}  // namespace

int run_bake(const std::vector<std::string>& args) {
    BakeCli c;
    ArgParser p(
        "bake", "spectex bake [options] INPUT... (-o OUTPUT.exr | -o TEMPLATE | --output-dir DIR)",
        "Turns textures into spectral reflectance OpenEXRs (Fichet 2021 layout, channels\n"
        "T.<wavelength>nm): read with OpenImageIO, linearise with OpenColorIO, expand each pixel\n"
        "to a spectrum (by default the LHTSS lattice with a precision budget: see --method and\n"
        "--precision). Inputs may hold <UDIM> or <UVTILE>, expanded to the existing tiles. Exit\n"
        "status 0 only when every file succeeded.");
    declare_bake_options(p, c);

    std::vector<std::string> inputs;
    try {
        if (p.parse_or_help(args, inputs)) return 0;
        check_bake_options(c, inputs, p.given());
    } catch (const UsageError& e) {
        return usage_error("bake", e.what());
    }

    // Inputs and outputs first: every mistake in them is reported before any work (a basis fit).
    BatchPlan plan;
    try {
        std::vector<std::pair<std::string, std::string>> whole;
        plan = plan_bake_files(c, inputs, whole);
        check_outputs_against_reads(c, plan, whole);
    } catch (const SetupFailure& e) {
        print_error(e.what());  // a config that cannot be read fails every file: once
        return 2;
    } catch (const UsageError& e) {
        return usage_error("bake", e.what());
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }

    BakeSettings settings;
    try {
        settings = prepare_settings(c, plan);
    } catch (const UnmetBudget& e) {
        print_error(e.what());
        return 1;
    } catch (const LimitError& e) {
        return usage_error("bake", e.what());  // a --wavelengths-file too fine for the method
    } catch (const Error& e) {
        print_error(e.what());
        return 2;
    }
    finish_batch_plan(c, plan);
    if (c.dry_run) return run_dry_run(plan, settings);
    // --output-dir is created (with its parents) when missing, like mkdir -p, once the command is
    // known to run (a usage error leaves no folder behind); the folders below it (a mirrored
    // tree, a template's folders) as each file is baked.
    try {
        make_folders(c.output_dir);
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }
    return run_batch(plan, settings);
}

}  // namespace spectex
