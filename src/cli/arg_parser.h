#pragma once
// A small declarative option parser: every option is declared once, with its help text, and the
// same table drives parsing, --help and usage errors (exit status 2).
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "spectral/basis_fit.h"

namespace spectex {

class UsageError : public std::runtime_error {
  public:
    explicit UsageError(const std::string& what) : std::runtime_error(what) {}
};

class ArgParser {
  public:
    ArgParser(std::string command, std::string synopsis, std::string description);

    void section(const std::string& title);
    // The options most runs need, by one of their names, in the order --help lists them first (in
    // a section of their own, before the sections by task, which then leave them out).
    void common(std::vector<std::string> names);
    void flag(const std::string& names, const std::string& help, std::function<void()> on);
    void option(const std::string& names, const std::string& metavar, const std::string& help,
                std::function<void(const std::string&)> on);
    // An option whose value may be left out, for a flag that became an option (info --json, which
    // scripts give alone, is now --json FILE as in plan, verify and bake). The value is taken from
    // "--name=VALUE", or from the next argument when that is "-" or ends in one of `suffixes`
    // (".json": a file the option writes, never an input); else on(bare), the flag's old meaning.
    void option_or_flag(const std::string& names, const std::string& metavar,
                        const std::string& help, std::vector<std::string> suffixes,
                        std::string bare, std::function<void(const std::string&)> on);

    // Returns the positional arguments. Throws UsageError. Sets help_requested() on -h/--help.
    std::vector<std::string> parse(const std::vector<std::string>& args);
    bool help_requested() const { return help_; }
    // parse(), and on -h/--help prints help() to stdout and returns true: the command then exits 0.
    bool parse_or_help(const std::vector<std::string>& args, std::vector<std::string>& positional);
    std::string help() const;
    const std::string& command() const { return command_; }

    // The options parse() took, in order: each by its long name (the last name it is declared
    // with: "--output" for "-o, --output"), with its value when it takes one. A command rebuilds
    // a narrower command line from them (bake records, in each output, the options that make
    // that one file).
    struct Given {
        std::string name, value;
        bool has_value = false;
    };
    const std::vector<Given>& given() const { return given_; }
    // " (it followed NAME, ...)" when `arg` is the argument the option_or_flag NAME left as a
    // positional one because it was not its FILE (no suffix of it: "--json info.txt"), else "". A
    // command names it in the error the positional then causes.
    std::string declined_hint(const std::string& name, const std::string& arg) const;

  private:
    struct Entry {
        std::vector<std::string> names;
        std::string label, metavar, help;
        std::function<void()> on_flag;
        std::function<void(const std::string&)> on_value;
        bool is_section = false;
        bool value_optional = false;        // option_or_flag
        std::vector<std::string> suffixes;  // ... the next arguments it takes as its value
        std::string bare;                   // ... its value when none is given
    };
    const Entry* find(const std::string& name) const;
    void describe(std::ostringstream& o, const Entry& e) const;

    std::string command_, synopsis_, description_;
    std::vector<Entry> entries_;
    std::vector<std::string> common_;
    std::vector<Given> given_;
    std::vector<std::pair<std::string, std::string>> declined_;  // (option, argument)
    bool help_ = false;
};

// Typed parsing at the edge: "--threads 4" etc. Throw UsageError naming the option.
int parse_int(const std::string& option, const std::string& value, int min, int max);
double parse_number(const std::string& option, const std::string& value);
// One of `words`, in any case (same_word): the word as written in `words`; else a UsageError
// "<option>: '<value>' is not one of a, b, c".
std::string parse_word(const std::string& option, const std::string& value,
                       const std::vector<std::string>& words);
// A ΔE00 budget (--max-de, --precision-de): a finite number above 0.
double parse_budget_de(const std::string& option, const std::string& value);
uint64_t parse_count(const std::string& option, const std::string& value);
// A command that reads one file: "no input file" or "one file at a time (got N)" otherwise.
void require_one_input(const std::vector<std::string>& files);
// --objective of a fitted basis, parsed by the fitter's own names (spectral/basis_fit); an unknown
// name is a UsageError.
// --vertex-prior's value by its canonical name (spectral/lattice.h's names); throws UsageError.
std::string vertex_prior_option(const std::string& value);

FitObjective parse_objective_option(const std::string& value);
// "A,FL11, LED-B3" -> {"A", "FL11", "LED-B3"}; an empty item is a UsageError naming the option.
std::vector<std::string> split_list(const std::string& value, const std::string& option = "");
// An option whose value is a comma-separated list (split_list), appended to `items`; repeatable.
void list_option(ArgParser& p, const std::string& names, const std::string& metavar,
                 const std::string& help, std::vector<std::string>& items);
// --observer NAME|FILE for the commands whose default is cie1931-2: "<whose>: cie1931-2 (default),
// cie1964-10, or a CSV wavelength,x,y,z." (whose: "Observer", "Observer of the fitted basis"...).
void observer_option(ArgParser& p, const std::string& whose, std::string& observer);

// The one check of the observer and lights a command is given, made by every command before it
// reads any input: the table is loaded as the work will load it, and an unknown name, an unreadable
// or malformed table, or a singular one (an observer whose x, y and z are linearly dependent, a
// light with no power) is a UsageError "<option>: <why>". An empty name (the default, or the one a
// file records) is not checked here.
void check_observer_setting(const std::string& option, const std::string& name);
void check_illuminant_setting(const std::string& option, const std::string& name);
// How a light's colour temperature is written, for the help of every option that takes a light:
// "a colour temperature from 1000K to 25000K (e.g. 3200K; ...)".
std::string colour_temperature_help();
// {"D65", "A"} -> "D65, A".
std::string join_names(const std::vector<std::string>& names);
// "X,Y": two whole numbers (negative allowed: data windows may start below 0).
std::pair<int, int> parse_pixel(const std::string& option, const std::string& value);

}  // namespace spectex
