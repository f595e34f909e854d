#pragma once
// The method options bake and plan share, declared once from the method table: --method and the
// options that belong to one method (--basis, --objective, --allow-infeasible, --lattice-size,
// --vertex-prior, --jh-resolution). Parsed straight into the MethodSpec both commands build with,
// so what plan measures and what bake builds are the same description.
#include <string>
#include <vector>

#include "pipeline/method_table.h"

namespace spectex {

class ArgParser;

struct MethodOptions {
    MethodSpec spec;
    std::string basis = "fit";  // --basis fit|mallett2019|FILE (bake only)
    // The options given that belong to one method, by long name, in order.
    std::vector<std::string> given;
    bool method_given = false;  // --method
    // Without --method: the option that chose the method (resolve_method), else empty.
    std::string chosen_by;
    bool given_any_of(const MethodRow& row) const;
};

// with_basis_table: also --basis (bake reads a basis table; plan fits one on each grid).
// default_help: what --method's help says of the method taken without it.
void add_method_options(ArgParser& p, MethodOptions& o, bool with_basis_table,
                        const std::string& default_help);
// Without --method, the method of the options given (--basis mallett2019 alone is the basis, as
// it always was), else the basis when `basis_only` (an option only the basis takes, such as
// --nonuniform), else bake's default (DefaultBake). True when bake's default was taken.
bool resolve_method(MethodOptions& o, bool basis_only);
// The method as the user asked for it, for errors: "--method lattice" when given, "--jh-resolution
// (the jakob-hanika method's option)" when an option of one method chose it, else "the default
// method (lattice)".
std::string method_words(const MethodOptions& o);
// An option given that belongs to another method than --method's: a UsageError naming both
// ("--jh-resolution belongs to --method jakob-hanika, not --method lattice").
void check_method_options(const MethodOptions& o);
// The conditions bake and plan share, once all options are read: --observer and --illuminant
// (its name made canonical, 3200k -> 3200K, as headers and reports record it) and each of
// --lights, tables that can be read. Throws UsageError naming the option.
void check_conditions(MethodSpec& spec, const std::vector<std::string>& lights);

}  // namespace spectex
