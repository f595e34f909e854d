#include "pipeline/method_table.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "base/error.h"
#include "base/memo.h"
#include "base/text.h"
#include "io/data_dir.h"
#include "pipeline/cache_text.h"
#include "pipeline/table_memo.h"
#include "spectex/version.h"
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

// The learned prior's table, from the spec's data folder (a spec whose observer and illuminant
// came as tables may not name one: the shipped folder's).
std::shared_ptr<const MeasuredPrior> measured_prior_of(const MethodSpec& s) {
    return measured_prior_table(s.fit.data_dir.empty() ? find_data_dir() : s.fit.data_dir);
}

std::string basis_head(const MethodSpec& s) {
    return "basis (fitted, " + to_string(s.fit.objective) + ")";
}

std::string basis_recipe(const MethodSpec& s) {
    return "basis fit, objective " + to_string(s.fit.objective) +
           (s.fit.allow_infeasible ? ", infeasible allowed" : "");
}

// The lattice and Jakob-Hanika tables have been identified by one sentence naming both kinds'
// options since their first bake.
// A learned prior adds its table's checksum: a retrained table is another method.
std::string table_recipe(const MethodSpec& s) {
    return s.name() + " lattice " + std::to_string(s.lattice_size) + " prior " + s.vertex_prior +
           " jh " + std::to_string(s.jh_resolution) + vertex_prior_data(s);
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
            const VertexPrior prior = parse_vertex_prior(s.vertex_prior);
            std::shared_ptr<const MeasuredPrior> data;
            if (prior == VertexPrior::Measured) data = measured_prior_of(s);
            return SpectralLattice::build(colorimetry(s.fit), s.lattice_size, prior, s.blend,
                                          data.get());
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

std::vector<double> lattice_table(const SpectralMethod& m) {
    return static_cast<const LatticeMethod&>(m).lattice().table_double();
}

MethodResult lattice_from_table(const MethodSpec& s, std::vector<double> table) {
    MethodResult r;
    r.method = std::make_shared<LatticeMethod>(
        SpectralLattice::from_table(colorimetry(s.fit), s.lattice_size,
                                    parse_vertex_prior(s.vertex_prior), std::move(table)),
        s.fit.grid.lambda, conditions(s.fit), s.blend);
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

std::string vertex_prior_data(const MethodSpec& s) {
    if (s.kind != MethodKind::Lattice || s.vertex_prior != "measured") return "";
    return " data " + measured_prior_of(s)->checksum;
}

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
         build_basis,
         nullptr,
         nullptr},
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
         build_lattice,
         lattice_table,
         lattice_from_table},
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
         build_jh,
         nullptr,
         nullptr},
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
        if (same_word(row.name, name)) return &row;
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

std::string method_cache_key(const MethodSpec& spec) {
    using cache_text::KeyHash;
    KeyHash k;
    k.text("spectex " SPECTEX_VERSION);
    k.text(executable_identity());
    k.text("method");
    k.number(kMethodCacheFormat);
    const MethodRow& row = method_row(spec.kind);
    k.text(row.name);
    k.text(row.recipe(spec));
    k.text(spec.describe());
    k.number(spec.blend);
    const Observer obs = fit_observer(spec.fit);
    k.spectrum(obs.x);
    k.spectrum(obs.y);
    k.spectrum(obs.z);
    k.spectrum(fit_illuminant(spec.fit));
    k.grid(spec.fit.grid);
    return "method-" + k.hex();
}

namespace {

// An entry: the format, the key, the number of values and every value exactly ("%a").
constexpr size_t kMethodCacheEntryLimit = size_t(64) << 20;

std::string method_cache_text(const std::string& key, const std::vector<double>& t) {
    std::string o = "spectex-method-cache " + std::to_string(kMethodCacheFormat) + "\nkey " + key +
                    "\nvalues " + std::to_string(t.size()) + "\n";
    o.reserve(o.size() + t.size() * 24);
    for (size_t i = 0; i < t.size(); ++i) o += cache_text::exact(t[i]) + (i % 8 == 7 ? "\n" : " ");
    return o + "\nend\n";
}

bool parse_method_cache_text(const std::string& text, const std::string& key,
                             const MethodSpec& spec, MethodResult* out) {
    cache_text::Words w(text);
    w.expect("spectex-method-cache");
    w.expect(std::to_string(kMethodCacheFormat));
    w.expect("key");
    w.expect(key);
    w.expect("values");
    const auto want = static_cast<long long>(method_table_samples(spec, spec.fit.grid.size()));
    if (w.whole(0, want) != want || !w.ok()) return false;
    std::vector<double> t(static_cast<size_t>(want));
    for (double& x : t) x = w.number();
    w.expect("end");
    if (!w.ok() || !w.at_end()) return false;
    try {
        *out = method_row(spec.kind).from_stored_table(spec, std::move(t));
    } catch (const Error&) {
        return false;  // not a table the build could have made: built again
    }
    return true;
}

MethodResult build_timed(const MethodSpec& spec, const std::string& folder) {
    const auto t0 = std::chrono::steady_clock::now();
    const MethodRow& row = method_row(spec.kind);
    MethodResult r;
    if (!folder.empty() && row.stored_table &&
        method_table_samples(spec, spec.fit.grid.size()) <= kMethodCacheSamples) {
        const std::string key = method_cache_key(spec);
        CacheReport rep;
        rep.folder = folder;
        r = cached_answer<MethodResult>(
            folder, key, kMethodCacheEntryLimit,
            [&](const std::string& body, MethodResult* m) {
                return parse_method_cache_text(body, key, spec, m);
            },
            [&] { return row.build(spec); },
            [&](const MethodResult& m) {
                return method_cache_text(key, row.stored_table(*m.method));
            },
            rep);
        r.cache = rep;
    } else {
        r = row.build(spec);
    }
    r.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

}  // namespace

MethodResult make_method(const MethodSpec& spec, const std::string& cache_folder) {
    static Memo<std::string, MethodResult> memo;
    check_method_cost(spec, spec.fit.grid.size(), std::to_string(spec.fit.grid.size()) + " bins");
    std::string key = spec.describe() + "|" + spec.fit.describe() + "|" + spec.fit.data_dir;
    for (double l : spec.fit.grid.lambda) key += "|" + format_wavelength(l);
    // The folder is not part of the memo's key: a method read from the cache is the build's.
    return memo.get(key, [&] { return build_timed(spec, cache_folder); });
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
