#pragma once
// One function per subcommand: parse options, call the library, report. Return the exit status
// (0 ok, 1 failed work, 2 usage error).
#include <functional>
#include <string>
#include <vector>

#include "base/text.h"  // one_line

namespace spectex {

int run_bake(const std::vector<std::string>& args);
int run_info(const std::vector<std::string>& args);
int run_basis(const std::vector<std::string>& args, const std::string& command_line);
int run_verify(const std::vector<std::string>& args);
int run_sample(const std::vector<std::string>& args);
int run_render(const std::vector<std::string>& args);
int run_plot(const std::vector<std::string>& args);
int run_plan(const std::vector<std::string>& args);

struct PlanSpec;
class ArgParser;
// The options that `plan` and `bake --wavelengths auto` share: --lights, --max-de,
// --reconstruction, --range, --grids (plan_command.cpp). The flags say whether lights and a budget
// were given.
// texture_option: the command has plan's --texture (bake measures the sample only).
void add_plan_options(ArgParser& p, PlanSpec& spec, bool& lights_given, bool& budget_given,
                      bool texture_option);
// --no-cache, which plan and bake --wavelengths auto share.
void add_cache_option(ArgParser& p, bool& no_cache);
// Progress of the grid search on stderr, in the batch's style: "<prefix>[5/21] measuring each
// grid" rewritten in place on a terminal every 250 ms, else a UTC-stamped line every
// SPECTEX_PROGRESS_SECONDS (default 10) and one when each stage ends.
std::function<void(const std::string&, size_t, size_t)> plan_progress(const std::string& prefix);
struct PlanResult;
// plan_grids through the cache (pipeline/plan_cache.h) unless `no_cache`: the cache's warnings
// (a folder that cannot be written) on stderr, and under `verbose` whether the answer came from it.
// *from_cache (when given) says whether it did.
PlanResult plan_with_cache(const PlanSpec& spec, bool no_cache, bool verbose, bool quiet,
                           bool* from_cache = nullptr);
struct CacheReport;
// What plan_with_cache says of the cache, for a plan made elsewhere (bake's set-up).
void report_plan_cache(const PlanSpec& spec, const CacheReport& rep, bool verbose, bool quiet);
// Before a long run: what a grid finer than 1 nm over 360-830 nm costs (bins, bytes per pixel
// uncompressed, memory per 1,000 pixels of image width), on stderr unless `quiet`.
void note_grid_cost(const std::string& command, const std::string& what, size_t bins,
                    int bytes_per_sample, bool quiet);

// `message` with its leading "<file>: " named as quote_path() names it, so that
// "spectex: 'my file.png': No such file or directory" is unambiguous and can be pasted back. A
// message about another file (the cause is in a source or config that `file` records) keeps that
// file first and, when `doing` is given, ends with "(<doing> <file>)", e.g. "(verifying a.exr)".
std::string name_file(const std::string& file, const std::string& message,
                      const std::string& doing = "");
// Prints "spectex: <message>" to stderr, as one_line().
void print_error(const std::string& message);
// Runs a command's work on `file`: 0 when it returns, else the error printed as
// "spectex: <cause>" (an Error names its file) or "spectex: <file>: <cause>", and 1; a LimitError
// (a request over a documented limit, found before the work) is a usage error of `command`, 2.
int run_reporting(const std::string& command, const std::string& file,
                  const std::function<void()>& work);
// Prints "spectex <command>: <message>" and a hint to run --help; returns 2.
int usage_error(const std::string& command, const std::string& message);

}  // namespace spectex
