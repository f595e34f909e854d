#include "pipeline/method_table.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "base/error.h"
#include "base/memo.h"
#include "spectral/colorimetry.h"
#include "spectral/spectrum.h"
#include "spectral/upsampling_methods.h"

namespace spectex {

namespace {

// The conditions a method is exact for (the basis fit's objective is not one of them).
std::string conditions(const FitSpec& f) {
    return f.primaries + " primaries, " + f.observer + ", " + f.illuminant + ", " +
           f.grid.describe();
}

Colorimetry colorimetry(const FitSpec& f) {
    return Colorimetry::make(fit_observer(f), fit_illuminant(f), f.grid,
                             primaries_by_name(f.primaries));
}

int no_table(const MethodSpec&) { return 0; }

std::string basis_head(const MethodSpec& s) {
    return "basis (fitted, " + to_string(s.fit.objective) + ")";
}

std::string basis_recipe(const MethodSpec& s) {
    return "basis fit, objective " + to_string(s.fit.objective) +
           (s.fit.allow_infeasible ? ", infeasible allowed" : "");
}

// The lattice and Jakob-Hanika tables have been identified by one sentence naming both kinds'
// options since their first bake.
std::string table_recipe(const MethodSpec& s) {
    return s.name() + " lattice " + std::to_string(s.lattice_size) + " prior " + s.vertex_prior +
           " jh " + std::to_string(s.jh_resolution);
}

MethodResult build_basis(const MethodSpec& s) {
    FitResult fit = fit_basis_for(s.fit);
    MethodResult r;
    if (!fit.certificate.feasible) {
        const auto& m = fit.certificate.colour_residual;
        char miss[32];
        std::snprintf(miss, sizeof miss, "%g", std::max({m[0], m[1], m[2]}));
        r.warning = "no exact basis exists for " + s.fit.describe() +
                    "; baking with the closest one, which misses the primaries by " + miss +
                    " in linear RGB (--allow-infeasible)";
    }
    r.method = std::make_shared<BasisMethod>(fit.basis, "fitted by spectex: " + s.fit.describe());
    return r;
}

std::string lattice_head(const MethodSpec& s) {
    char w[32];
    std::snprintf(w, sizeof w, "%g", s.blend);
    return "lattice " + std::to_string(s.lattice_size) + ", " + s.vertex_prior + " prior" +
           (s.vertex_prior == "blend" ? std::string(" (weight ") + w + ")" : std::string());
}

MethodResult build_lattice(const MethodSpec& s) {
    // A vertex with no exact spectrum in [0, 1] (a coarse grid, an illuminant whose gamut is not
    // sRGB's): the way out is the basis fitted closest, which --allow-infeasible takes (it belongs
    // to the basis, so without --method it chooses it).
    auto lattice = [&] {
        try {
            return SpectralLattice::build(colorimetry(s.fit), s.lattice_size,
                                          parse_vertex_prior(s.vertex_prior), s.blend);
        } catch (const LimitError&) {
            throw;
        } catch (const Error& e) {
            throw Error(std::string(e.what()) +
                        "; every vertex must be exact and in [0, 1]: --allow-infeasible bakes "
                        "the least-squares closest basis instead");
        }
    }();
    MethodResult r;
    r.method = std::make_shared<LatticeMethod>(std::move(lattice), s.fit.grid.lambda,
                                               conditions(s.fit), s.blend);
    return r;
}

std::string jh_head(const MethodSpec& s) {
    return "jakob-hanika table " + std::to_string(s.jh_resolution);
}

MethodResult build_jh(const MethodSpec& s) {
    MethodResult r;
    r.method = std::make_shared<JakobHanikaMethod>(
        JakobHanikaTable::build(colorimetry(s.fit), s.jh_resolution), s.fit.grid.lambda,
        conditions(s.fit));
    return r;
}

}  // namespace

const std::vector<MethodRow>& method_table() {
    static const std::vector<MethodRow> rows = {
        {MethodKind::Basis,
         "basis",
         "r·S_r + g·S_g + b·S_b, three spectra fitted on the grid (or a given table) exact under "
         "the illuminant",
         true,
         true,
         true,
         {"--basis", "--objective", "--allow-infeasible"},
         "",
         "",
         no_table,
         basis_head,
         basis_recipe,
         build_basis},
        {MethodKind::Lattice,
         "lattice",
         "exact vertex spectra on an N^3 lattice over linear RGB, tetrahedral interpolation "
         "(exact under the illuminant, natural under other light)",
         true,
         false,
         false,
         {"--lattice-size", "--vertex-prior"},
         "--lattice-size",
         "vertices",
         [](const MethodSpec& s) { return s.lattice_size; },
         lattice_head,
         table_recipe,
         build_lattice},
        {MethodKind::JakobHanika,
         "jakob-hanika",
         "pbrt-v4's sigmoid spectra (not exact: for comparison and render-time consistency)",
         false,
         false,
         false,
         {"--jh-resolution"},
         "--jh-resolution",
         "table nodes",
         [](const MethodSpec& s) { return s.jh_resolution; },
         jh_head,
         table_recipe,
         build_jh},
    };
    return rows;
}

const MethodRow& method_row(MethodKind kind) {
    for (const auto& row : method_table())
        if (row.kind == kind) return row;
    throw Error("a method kind with no row in the method table");
}

const MethodRow* find_method(const std::string& name) {
    for (const auto& row : method_table())
        if (row.name == name) return &row;
    return nullptr;
}

bool method_is_exact(const std::string& name) {
    const MethodRow* row = find_method(name);
    return !row || row->exact;
}

std::string method_names(const std::string& sep) {
    std::string out;
    for (const auto& row : method_table()) out += (out.empty() ? "" : sep) + row.name;
    return out;
}

const MethodRow* method_of_option(const std::string& option) {
    for (const auto& row : method_table())
        if (std::find(row.options.begin(), row.options.end(), option) != row.options.end())
            return &row;
    return nullptr;
}

const std::string& MethodSpec::name() const { return method_row(kind).name; }

std::string MethodSpec::head() const { return method_row(kind).head(*this); }

std::string MethodSpec::describe() const { return head() + ", " + conditions(fit); }

MethodResult make_method(const MethodSpec& spec) {
    static Memo<std::string, MethodResult> memo;
    check_method_cost(spec, spec.fit.grid.size(), std::to_string(spec.fit.grid.size()) + " bins");
    std::string key = spec.describe() + "|" + spec.fit.describe() + "|" + spec.fit.data_dir;
    for (double l : spec.fit.grid.lambda) key += "|" + format_wavelength(l);
    return memo.get(key, [&] {
        const auto t0 = std::chrono::steady_clock::now();
        MethodResult r = method_row(spec.kind).build(spec);
        r.build_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return r;
    });
}

uint64_t method_table_samples(const MethodSpec& spec, uint64_t bins) {
    const auto n = static_cast<uint64_t>(std::max(0, method_row(spec.kind).table_axis(spec)));
    return n * n * n * bins;
}

void check_method_cost(const MethodSpec& spec, uint64_t bins, const std::string& what) {
    const uint64_t samples = method_table_samples(spec, bins);
    if (samples <= kMethodTableLimit) return;
    const MethodRow& row = method_row(spec.kind);
    throw LimitError(row.table_option + ": " + std::to_string(row.table_axis(spec)) + "^3 " +
                     row.table_nodes + " x " + what + " = " + std::to_string(samples) +
                     " spectral samples to build, over the limit of " +
                     std::to_string(kMethodTableLimit) +
                     " (2^27, which holds the largest table on a 1 nm grid over 360:830); use a "
                     "smaller " +
                     row.table_option + " or fewer bins");
}

}  // namespace spectex
