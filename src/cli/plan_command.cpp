#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <tuple>

#include "base/error.h"
#include "cli/arg_parser.h"
#include "cli/batch_report.h"
#include "cli/commands.h"
#include "cli/method_options.h"
#include "cli/output_check.h"
#include "io/atomic_file.h"
#include "io/data_dir.h"
#include "io/library_stderr.h"
#include "pipeline/light_list.h"
#include "pipeline/plan.h"
#include "pipeline/plan_cache.h"
#include "pipeline/plan_report.h"

namespace spectex {

// The options that plan and bake --wavelengths auto share.
void add_plan_options(ArgParser& p, PlanSpec& spec, bool& lights_given, bool& budget_given,
                      bool texture_option) {
    p.option("--lights", "LIST",
             "Lights of the scene, comma-separated: shipped names (D65, A, FL11...), colour "
             "temperatures (e.g. 3200K) or CSV files (plan's default D65,A,FL11). "
             "Each is "
             "integrated at 1 nm over --range; a light is dark where its table has no values.",
             [&](const std::string& v) {
                 spec.lights = split_list(v, "--lights");
                 lights_given = true;
             });
    p.option("--max-de", "DE",
             "Budget: the worst ΔE00 of any colour under every light (plan's default 0.5).",
             [&](const std::string& v) {
                 spec.max_de = parse_budget_de("--max-de", v);
                 budget_given = true;
             });
    p.option("--reconstruction", "linear|nearest|box",
             "How the renderer reads the spectrum between bins: linear (default; pbrt-v4, Mitsuba "
             "3), nearest, "
             "or box (bins as boxes between midpoints, averaged over each 1 nm); the end values "
             "are held beyond "
             "the grid.",
             [&](const std::string& v) {
                 try {
                     spec.reconstruction = parse_reconstruction(v);
                 } catch (const Error& e) {
                     throw UsageError(std::string("--reconstruction: ") + e.what());
                 }
             });
    p.option("--range", "START:END",
             "Wavelengths the renderer samples, whole nm (default 360:830).",
             [&](const std::string& v) {
                 try {
                     std::tie(spec.range_start, spec.range_end) = parse_plan_range(v);
                 } catch (const Error& e) {
                     throw UsageError(std::string("--range: ") + e.what());
                 }
             });
    p.flag(
        "--nonuniform",
        "Also search non-uniform grids (basis only): greedy removal of bins from uniform grids "
        "that hold, "
        "offered when one needs fewer bins than every uniform candidate (and is measured to hold).",
        [&] { spec.nonuniform = true; });
    p.option("--grids", "LIST",
             std::string("Candidate grids instead of the default ones (uniform 1, 2, 2.5, 4, 5, "
                         "10, 20 nm over 380:780, 400:700 and --range), e.g. the grids a "
                         "renderer supports: 380:780:5,400:700:10. The bins of all\ngrids x the "
                         "lights x the colours (the sample") +
                 (texture_option ? ", or 1,048,576 for --texture" : "") +
                 ") must stay within the limit\nof 2e10 (8 times the default table), and "
                 "for the lattice and jakob-hanika the tables within 2^27\nsamples; a grid has "
                 "at most 4701 bins (0.1 nm over 360:830): larger requests are usage\nerrors "
                 "(exit 2) before any work.",
             [&](const std::string& v) {
                 spec.candidates.clear();
                 for (const auto& g : split_list(v, "--grids")) {
                     try {
                         spec.candidates.push_back(WavelengthGrid::parse_exact(g));
                     } catch (const Error& e) {
                         throw UsageError("--grids: " + g + ": " + e.what());
                     }
                 }
             });
}

void add_cache_option(ArgParser& p, bool& no_cache) {
    p.flag("--no-cache",
           "Search the grids (and choose --precision auto's bits) even when the cache holds the "
           "answer, and keep nothing (the cache: "
           "$SPECTEX_CACHE_DIR,\nelse $XDG_CACHE_HOME/spectex, else ~/.cache/spectex; "
           "SPECTEX_CACHE_DIR= (empty) turns it off).",
           [&] { no_cache = true; });
}

std::function<void(const std::string&, size_t, size_t)> plan_progress(const std::string& prefix) {
    struct State {
        bool terminal = stderr_is_terminal();
        std::chrono::milliseconds period = progress_period(stderr_is_terminal());
        std::chrono::steady_clock::time_point last{};
        bool shown = false;
    };
    auto st = std::make_shared<State>();
    return [st, prefix](const std::string& stage, size_t done, size_t total) {
        const auto now = std::chrono::steady_clock::now();
        // The end of a stage and a step of no count are always shown; the rest at the cadence.
        const bool ends = total == 0 || done == total;
        if (st->shown && !ends && now - st->last < st->period) return;
        std::string line = prefix;
        if (total > 1) line += "[" + std::to_string(done) + "/" + std::to_string(total) + "] ";
        line += one_line(stage) + (total == 1 && done == 1 ? ": done" : "");
        if (st->terminal)
            std::cerr << "\r\033[K" << line << (ends ? "\n" : "") << std::flush;
        else
            std::cerr << utc_stamp() << " " << line << "\n" << std::flush;
        st->last = now;
        st->shown = true;
    };
}

PlanResult plan_with_cache(const PlanSpec& spec, bool no_cache, bool verbose, bool quiet,
                           bool* from_cache) {
    PlanCacheReport rep;
    PlanResult r = plan_grids_cached(spec, no_cache ? "" : cache_folder(), &rep);
    if (from_cache) *from_cache = rep.hit;
    report_plan_cache(spec, rep, verbose, quiet);
    return r;
}

void report_plan_cache(const PlanSpec& spec, const CacheReport& rep, bool verbose, bool quiet) {
    if (!rep.warning.empty() && !quiet)
        std::cerr << "spectex: warning: the plan's answer is not kept in the cache: "
                  << one_line(rep.warning)
                  << " (SPECTEX_CACHE_DIR moves the cache; --no-cache does without)\n";
    if (rep.hit && verbose)
        std::cerr << "spectex: the plan's answer from the cache: "
                  << one_line(quote_path(rep.entry)) << "\n";
    if (rep.hit && spec.progress) spec.progress("the answer from the cache", 0, 0);
}

void note_grid_cost(const std::string& command, const std::string& what, size_t bins,
                    int bytes_per_sample, bool quiet) {
    // Finer than 1 nm over 360-830 nm: worth a word before the run.
    if (quiet || bins <= 471) return;
    const double per_pixel = static_cast<double>(bins) * bytes_per_sample;
    // Measured: bake's memory is about 0.2 GB plus 190 bytes per bin per pixel of image width
    // (the strips in flight): 0.58 GB at 512 x 4,001 bins, 0.97 GB at 1,024 x 4,001, 4.0 GB at
    // 512 x 40,001.
    const double per_1000_wide = 190.0 * 1000.0 * static_cast<double>(bins);
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "spectex %s: %s: %zu bins (limit %zu): %.0f bytes per pixel before "
                  "compression (%.2f GB per megapixel), and about %.2f GB of memory per 1,000 "
                  "pixels of image width",
                  command.c_str(), what.c_str(), bins, kMaxGridBins, per_pixel, per_pixel / 1000.0,
                  per_1000_wide / 1e9);
    std::cerr << one_line(buf) << "\n";
}

namespace {

// What the command line said, parsed.
struct PlanOptions {
    PlanSpec spec;
    std::string type = "half", json, grid_file;
    MethodOptions m;  // --method and its options, copied into spec.method once all are read
    bool lights_given = false, budget_given = false, no_cache = false, progress = false,
         precision_given = false;
};

// --method and what builds it (method_options.h), --observer and --illuminant.
void add_method_and_conditions(ArgParser& p, PlanOptions& o) {
    add_method_options(p, o.m, false,
                       "Default: bake's, the lattice with --vertex-prior lhtss, and its bits "
                       "(--precision auto) with the grid; an option of one method without "
                       "--method takes that method, and --nonuniform the basis.");
    observer_option(p, "Observer of the method and of the error", o.m.spec.fit.observer);
    p.option("--illuminant", "NAME|FILE",
             "Illuminant the method is exact for (default D65), as in bake (a name, a colour "
             "temperature such as 3200K, or a CSV file).",
             [&](const std::string& v) { o.m.spec.fit.illuminant = v; });
}

// How the bake is measured and what is written: --type, --sample-stride, --colours, --grid-file,
// --texture, --colorspace, --config, --threads, --json.
void add_measure_options(ArgParser& p, PlanOptions& o) {
    PlanSpec& spec = o.spec;
    p.option("--type", "half|float",
             "Sample type of the bake (default half: its rounding is part of the error).",
             [&](const std::string& v) {
                 o.type = parse_word("--type", v, {"half", "float"});
             });
    p.option("--precision", "full|auto",
             "auto: also choose the chosen grid's mantissa bits per bin as bake --precision auto "
             "does (within --precision-de, default --max-de, under --lights and --illuminant), "
             "and print bins and bits together. Half only; default auto for bake's default "
             "method, else full.",
             [&](const std::string& v) {
                 spec.precision = parse_word("--precision", v, {"full", "auto"}) == "auto";
                 o.precision_given = true;
             });
    p.option(
        "--precision-de", "DE",
        "The budget of --precision auto, the file against the method at 1 nm (default --max-de).",
        [&](const std::string& v) { spec.precision_de = parse_budget_de("--precision-de", v); });
    p.option(
        "--sample-stride", "N",
        "The dense sample: every N-th 8-bit code and 255 per axis (default 4: 274,625 colours).",
        [&](const std::string& v) {
            spec.sample_stride = parse_int("--sample-stride", v, 1, 255);
        });
    p.option("--colours", "auto|cube|sample",
             "Which colours decide for the basis: auto (default) every grid on the sample and the "
             "chosen one on all "
             "16,777,216 8-bit codes; cube: every grid on all codes (about 2 CPU-s per grid and "
             "light); sample. "
             "Other methods always use the sample.",
             [&](const std::string& v) {
                 spec.colours = parse_word("--colours", v, {"auto", "cube", "sample"});
             });
    p.option(
        "--grid-file", "FILE",
        "Write the chosen grid's wavelengths, one per line, for bake --wavelengths-file (any grid, "
        "non-uniform ones included).",
        [&](const std::string& v) { o.grid_file = v; });
    p.option("--texture", "FILE",
             "Measure over this texture's colours (read and linearised as bake reads it; at most "
             "1,048,576 "
             "distinct colours, an even subset above that; pixels with alpha 0 left out) instead "
             "of the 8-bit cube.",
             [&](const std::string& v) { spec.texture = v; });
    p.option("--colorspace", "NAME", "With --texture: the texture's colour space, as in bake.",
             [&](const std::string& v) { spec.colorspace = v; });
    p.option("--config", "FILE",
             "With --texture: the OCIO config, as in bake (default $OCIO, else the shipped one).",
             [&](const std::string& v) { spec.config = v; });
    p.option("--threads", "N",
             "Threads (default: all cores; at most 4 per core, at least 8: the process's thread "
             "budget).",
             [&](const std::string& v) { spec.threads = parse_int("--threads", v, 0, 1024); });
    p.option("--json", "FILE",
             "Also write the table as JSON ('-' = stdout, instead of the text table).",
             [&](const std::string& v) { o.json = stdout_as_dash(v); });
    add_cache_option(p, o.no_cache);
    p.flag("--progress",
           "Show the search's progress (grids done / total) on stderr even when it is not a "
           "terminal.",
           [&] { o.progress = true; });
}

// The checks across options, once all are read; throws UsageError.
void check_plan_options(PlanOptions& o, const std::vector<std::string>& pos) {
    PlanSpec& spec = o.spec;
    if (!pos.empty()) throw UsageError("unexpected argument '" + pos[0] + "'");
    // As bake: its default method and bits, unless a method is named or implied (--nonuniform
    // searches with the basis' 3x3 maps only).
    const bool default_method = resolve_method(o.m, spec.nonuniform);
    if (default_method && !o.precision_given && o.type == "half") spec.precision = true;
    check_method_options(o.m);
    spec.method = o.m.spec;
    if (spec.nonuniform && !method_row(spec.method.kind).linear)
        throw UsageError("--nonuniform searches with a linear method's 3x3 maps: " +
                         method_words(o.m) + " is not linear (use --method basis)");
    spec.half = o.type == "half";
    if (spec.precision && !spec.half)
        throw UsageError("--precision auto chooses bits of half; --type float keeps every bit");
    if (spec.precision_de > 0 && !spec.precision)
        throw UsageError("--precision-de belongs to --precision auto");
    spec.lights = distinct_lights(spec.lights);
    check_conditions(spec.method, spec.lights);
    try {
        check_plan_cost(spec);
    } catch (const LimitError& e) {
        throw UsageError(e.what());
    }
    // Outputs are none of the files plan reads (tables given as files).
    std::vector<std::pair<std::string, std::string>> reads = {
        {spec.method.fit.observer, "--observer"}, {spec.method.fit.illuminant, "--illuminant"}};
    for (const auto& l : spec.lights) reads.push_back({l, "--lights"});
    if (!spec.texture.empty()) reads.push_back({spec.texture, "--texture"});
    if (!spec.config.empty()) reads.push_back({spec.config, "--config"});
    if ((!spec.colorspace.empty() || !spec.config.empty()) && spec.texture.empty())
        throw UsageError("--colorspace and --config read the colours of --texture");
    if (!o.json.empty() && o.json != "-") check_output_against(o.json, "--json", reads, true);
    if (!o.grid_file.empty()) {
        check_output_against(o.grid_file, "--grid-file", reads, true);
        if (o.grid_file == o.json) throw UsageError("--grid-file and --json name the same file");
    }
}

// The chosen grid's wavelengths, one per line, for bake --wavelengths-file.
void write_grid_file(const std::string& path, const WavelengthGrid& grid) {
    std::string text = "# spectex plan: " + grid_label(grid) + "\n";
    for (double l : grid.lambda) text += format_wavelength(l) + "\n";
    write_text_atomically(path, text);
}

// Plans, prints the table and writes the outputs; the exit status.
int plan_and_report(PlanOptions& o) {
    PlanSpec& spec = o.spec;
    const std::string& json = o.json;
    if (o.progress || stderr_is_terminal()) spec.progress = plan_progress("spectex plan: ");
    PlanResult r = plan_with_cache(spec, o.no_cache, true, false);
    if (json != "-") std::cout << plan_table(spec, r) << std::flush;
    if (!json.empty()) {
        if (json == "-")
            std::cout << plan_json(spec, r) << std::flush;
        else
            write_text_atomically(json, plan_json(spec, r));
    }
    if (r.chosen < 0) {
        print_error(plan_failure(spec, r));
        return 1;
    }
    if (!o.grid_file.empty())
        write_grid_file(o.grid_file, r.rows[static_cast<size_t>(r.chosen)].grid);
    return 0;
}

}  // namespace

int run_plan(const std::vector<std::string>& args) {
    PlanOptions o;
    ArgParser p(
        "plan", "spectex plan [options]",
        "Chooses the wavelength grid for a scene: for candidate grids (uniform steps 1, 2, 2.5, 4, "
        "5, 10\n"
        "and 20 nm over 380:780, 400:700 and the renderer's range), the worst and 99th-percentile\n"
        "ΔE00 under each light between the spectrum baked on the grid, as the renderer "
        "reconstructs it\n"
        "at 1 nm, and the method's spectrum built on 1 nm; over all 16,777,216 8-bit sRGB colours "
        "for\n"
        "the basis, a dense sample for the other methods. Marks the cheapest grid within --max-de\n"
        "under every light. Exit status 1 when no grid meets the budget (with the best "
        "achievable).\n"
        "The answer is kept in the cache ($SPECTEX_CACHE_DIR, else $XDG_CACHE_HOME/spectex, else\n"
        "~/.cache/spectex) under a hash of everything it depends on: the same plan again, or bake\n"
        "--wavelengths auto with the same settings, takes it from there (--no-cache: search "
        "again).");
    add_plan_options(p, o.spec, o.lights_given, o.budget_given, true);
    add_method_and_conditions(p, o);
    add_measure_options(p, o);
    p.common({"--lights", "--max-de", "--method", "--nonuniform", "--texture", "--grid-file",
              "--json", "--help"});
    try {
        std::vector<std::string> pos;
        if (p.parse_or_help(args, pos)) return 0;
        check_plan_options(o, pos);
    } catch (const UsageError& e) {
        return usage_error("plan", e.what());
    }
    try {
        o.spec.method.fit.data_dir = find_data_dir();
        return plan_and_report(o);
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }
}

}  // namespace spectex
