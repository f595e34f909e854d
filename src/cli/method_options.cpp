#include "cli/method_options.h"

#include <algorithm>

#include "base/text.h"
#include "cli/arg_parser.h"
#include "pipeline/bake_request.h"
#include "pipeline/light_list.h"

namespace spectex {

bool MethodOptions::given_any_of(const MethodRow& row) const {
    for (const auto& g : given)
        if (std::find(row.options.begin(), row.options.end(), g) != row.options.end()) return true;
    return false;
}

void add_method_options(ArgParser& p, MethodOptions& o, bool with_basis_table,
                        const std::string& default_help) {
    auto note = [&o](const std::string& option) {
        if (std::find(o.given.begin(), o.given.end(), option) == o.given.end())
            o.given.push_back(option);
    };
    std::string help = "How a linear RGB becomes a spectrum.";
    for (const auto& row : method_table()) help += " " + row.name + ": " + row.help + ".";
    help += " " + default_help;
    p.option("--method", method_names("|"), help, [&o](const std::string& v) {
        const MethodRow* row = find_method(v);
        if (!row) throw UsageError("--method: '" + v + "' is not one of " + method_names(", "));
        o.spec.kind = row->kind;
        o.method_given = true;
    });
    if (with_basis_table)
        p.option("--basis", "fit|mallett2019|FILE",
                 "fit (default): a basis fitted on the output grid by 'spectex basis' rules, exact "
                 "on any grid; mallett2019: the published table (380:780:5 only); or a CSV "
                 "wavelength,r,g,b on the output grid.",
                 [&o, note](const std::string& v) {
                     // The two words in any case, as every option's words; else a file.
                     o.basis = same_word(v, "fit")           ? "fit"
                               : same_word(v, "mallett2019") ? "mallett2019"
                                                             : v;
                     note("--basis");
                 });
    p.flag("--allow-infeasible",
           "When no exact basis exists on the grid, use the least-squares closest one (colours "
           "are then not exact; a warning gives the miss and a bake's header records it).",
           [&o, note] {
               o.spec.fit.allow_infeasible = true;
               note("--allow-infeasible");
           });
    p.option("--objective", "smooth|norm",
             "Objective of the fitted basis (default smooth; see spectex basis).",
             [&o, note](const std::string& v) {
                 o.spec.fit.objective = parse_objective_option(v);
                 note("--objective");
             });
    p.option("--lattice-size", "N",
             "Breakpoints per axis of the lattice (default 9; 2 to 65). N^3 x bins is limited to "
             "2^27\n(134,217,728: 65 on a 1 nm grid over 360:830 fits); more is a usage error "
             "before any work.",
             [&o, note](const std::string& v) {
                 o.spec.lattice_size = parse_int("--lattice-size", v, 2, 65);
                 note("--lattice-size");
             });
    p.option("--vertex-prior", "jakob-hanika|smooth|blend|lhtss|measured",
             "What the lattice's vertex spectra are closest to while exact: jakob-hanika (default: "
             "the sigmoid spectrum, projected), smooth (least first differences), blend (both, "
             "smoothness weight 100), lhtss (the smoothest spectrum in tanh space, Burns 2020: "
             "bounded by construction), measured (the most probable spectrum under a Gaussian "
             "model of 301 measured reflectances in that tanh space: "
             "config/spectral/vertex_prior_measured.csv).",
             [&o, note](const std::string& v) {
                 o.spec.vertex_prior = vertex_prior_option(v);
                 note("--vertex-prior");
             });
    p.option("--jh-resolution", "N",
             "Nodes per axis of the jakob-hanika coefficient table (default 33; pbrt-v4 uses 64, "
             "which takes about 6 s to build; 3 to 64; N^3 x bins within the same 2^27 limit as "
             "the lattice).",
             [&o, note](const std::string& v) {
                 o.spec.jh_resolution = parse_int("--jh-resolution", v, 3, 64);
                 note("--jh-resolution");
             });
}

bool resolve_method(MethodOptions& o, bool basis_only) {
    if (o.method_given) return false;
    const MethodRow* owner = nullptr;
    std::string first;  // the first option given of owner's
    for (const auto& option : o.given) {
        const MethodRow* row = method_of_option(option);
        if (!row) continue;
        if (owner && owner != row)
            throw UsageError(first + " belongs to --method " + owner->name + ", " + option +
                             " to --method " + row->name + "; give --method");
        if (!owner) first = option;
        owner = row;
    }
    if (owner) {
        o.spec.kind = owner->kind;
        o.chosen_by = first;
        return false;
    }
    // The method and its options' values, the conditions (observer, illuminant) as given.
    const FitSpec fit = o.spec.fit;
    o.spec = basis_only ? MethodSpec{} : DefaultBake::method();
    o.spec.fit = fit;
    return !basis_only;
}

std::string method_words(const MethodOptions& o) {
    const std::string name = o.spec.name();
    if (o.method_given) return "--method " + name;
    if (!o.chosen_by.empty()) return o.chosen_by + " (an option of --method " + name + ")";
    return "the default method (" + name + ")";
}

void check_method_options(const MethodOptions& o) {
    for (const auto& option : o.given) {
        const MethodRow* owner = method_of_option(option);
        if (owner && owner->kind != o.spec.kind)
            throw UsageError(option + " belongs to --method " + owner->name + ", not --method " +
                             o.spec.name());
    }
}

void check_conditions(MethodSpec& spec, const std::vector<std::string>& lights) {
    check_observer_setting("--observer", spec.fit.observer);
    check_illuminant_setting("--illuminant", spec.fit.illuminant);
    spec.fit.illuminant = light_name(spec.fit.illuminant);  // recorded: 3200K, however written
    for (const auto& l : lights) check_illuminant_setting("--lights", l);
}

}  // namespace spectex
