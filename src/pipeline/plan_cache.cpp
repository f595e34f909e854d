#include "pipeline/plan_cache.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "base/error.h"
#include "base/fnv1a.h"
#include "io/atomic_file.h"
#include "io/data_dir.h"
#include "io/linearizer.h"
#include "io/ocio_config.h"
#include "io/provenance_keys.h"
#include "io/source_identity.h"
#include "pipeline/cache_text.h"
#include "pipeline/cached_answer.h"
#include "pipeline/table_memo.h"
#include "spectex/version.h"
#include "spectral/spectrum.h"

namespace spectex {

using namespace cache_text;

std::string plan_cache_key(const PlanSpec& spec) {
    KeyHash k;
    k.text("spectex " SPECTEX_VERSION);
    k.text(executable_identity());
    k.number(kPlanCacheFormat);
    const MethodSpec& m = spec.method;
    const std::string& dir = m.fit.data_dir;
    k.text(m.name());
    k.number(m.lattice_size);
    k.text(m.vertex_prior + vertex_prior_data(m));
    k.number(m.blend);
    k.number(m.jh_resolution);
    k.text(m.fit.observer);
    k.text(m.fit.illuminant);
    k.text(m.fit.primaries);
    k.text(to_string(m.fit.objective));
    k.text(m.fit.allow_infeasible ? "infeasible allowed" : "exact");
    const Observer obs = *observer_table(dir, m.fit.observer);
    k.spectrum(obs.x);
    k.spectrum(obs.y);
    k.spectrum(obs.z);
    k.spectrum(*illuminant_table(dir, m.fit.illuminant));
    k.number(static_cast<double>(spec.lights.size()));
    for (const auto& l : spec.lights) {
        k.text(l);
        k.spectrum(*illuminant_table(dir, l));
    }
    k.number(spec.max_de);
    k.text(to_string(spec.reconstruction));
    k.number(spec.range_start);
    k.number(spec.range_end);
    k.text(spec.half ? "half" : "float");
    k.number(static_cast<double>(spec.candidates.size()));
    for (const auto& g : spec.candidates) k.grid(g);
    k.number(spec.sample_stride);
    k.text(spec.colours);
    k.text(spec.nonuniform ? "nonuniform" : "uniform only");
    k.text(spec.texture);
    if (!spec.texture.empty()) {
        k.text(hash_file(spec.texture));
        k.text(spec.colorspace);
        k.text(spec.config);
        for (const auto& f : ocio_config_files(ocio_config_path(dir, spec.config))) {
            k.text(f);
            k.text(hash_file(f));
        }
        k.number(static_cast<double>(spec.max_pixels));
        k.number(static_cast<double>(spec.texture_cap));
    }
    return "plan-" + k.hex();
}

namespace {

constexpr long long kMaxRows = 100000, kMaxLights = 100000;

bool read_grid(Words& w, WavelengthGrid* g) {
    const long long n = w.whole(1, static_cast<long long>(kMaxGridBins));
    if (!w.ok()) return false;
    std::vector<double> lambda, weight;
    for (long long i = 0; i < n && w.ok(); ++i) lambda.push_back(w.number());
    for (long long i = 0; i < n && w.ok(); ++i) weight.push_back(w.number());
    const bool uniform = w.flag();
    const double step = w.number();
    if (!w.ok()) return false;
    try {
        *g = WavelengthGrid::from_list(lambda);  // checks the wavelengths
    } catch (const Error&) {
        return false;
    }
    for (double x : weight)
        if (!(x > 0)) return false;
    g->weight = std::move(weight);
    g->uniform = uniform;
    g->step = step;
    return true;
}

}  // namespace

std::string plan_cache_text(const std::string& key, const PlanResult& r) {
    std::ostringstream o;
    o << "spectex-plan-cache " << kPlanCacheFormat << "\n"
      << "key " << key << "\n";
    o << "chosen " << r.chosen << " best " << r.best << "\n";
    o << "colours " << hex_text(r.colours) << "\nmethod " << hex_text(r.method) << "\nsearch "
      << hex_text(r.search) << "\nseconds " << exact(r.seconds) << "\n";
    o << "rows " << r.rows.size() << "\n";
    for (const GridRow& row : r.rows) {
        o << "row " << row.grid.size();
        for (double x : row.grid.lambda) o << ' ' << exact(x);
        for (double x : row.grid.weight) o << ' ' << exact(x);
        o << ' ' << (row.grid.uniform ? 1 : 0) << ' ' << exact(row.grid.step);
        o << ' ' << row.bins << ' ' << row.bytes_per_pixel << ' ' << exact(row.relative_time) << ' '
          << exact(row.worst) << ' ' << hex_text(row.worst_light) << ' ' << (row.ok ? 1 : 0) << ' '
          << (row.passes ? 1 : 0) << ' ' << hex_text(row.colours) << ' ' << hex_text(row.why) << ' '
          << row.lights.size() << "\n";
        for (const LightError& le : row.lights)
            o << "light " << hex_text(le.light) << ' ' << exact(le.worst) << ' ' << exact(le.p99)
              << ' ' << exact(le.half_shift) << ' ' << le.worst_code[0] << ' ' << le.worst_code[1]
              << ' ' << le.worst_code[2] << "\n";
    }
    o << "end\n";
    return o.str();
}

namespace {

bool same_grid(const WavelengthGrid& a, const WavelengthGrid& b) {
    return a.lambda == b.lambda && a.weight == b.weight && a.uniform == b.uniform;
}

// Whether a well-formed answer is one the search could have given for `spec`: every candidate grid
// measured and no other grid (but those of the non-uniform search), each row's figures for
// the spec's lights in order, its worst and verdict those of its figures. The seal already tells
// a damaged entry; this keeps an entry made for other settings (or by a bug) from being taken.
bool plausible_plan(const PlanSpec& spec, const PlanResult& r) {
    const std::vector<WavelengthGrid> cand =
        spec.candidates.empty() ? default_candidates(spec.range_start, spec.range_end)
                                : spec.candidates;
    std::vector<int> seen(cand.size(), 0);
    for (const GridRow& row : r.rows) {
        bool found = false;
        for (size_t i = 0; i < cand.size(); ++i)
            if (same_grid(row.grid, cand[i])) {
                ++seen[i];
                found = true;
            }
        if (!found && !spec.nonuniform) return false;
        if (!row.ok) continue;
        if (row.lights.size() != spec.lights.size()) return false;
        double worst = 0;
        bool over = false;
        for (size_t j = 0; j < row.lights.size(); ++j) {
            const LightError& le = row.lights[j];
            if (le.light != spec.lights[j] || !(le.worst >= 0) || !(le.p99 >= 0) ||
                !(le.p99 <= le.worst) || !(le.half_shift >= 0))
                return false;
            worst = std::max(worst, le.worst);
            over = over || le.worst > spec.max_de;
        }
        if (row.worst != worst || row.passes == over) return false;
    }
    for (int n : seen)
        if (n == 0) return false;
    return spec.nonuniform || r.rows.size() == cand.size();
}

}  // namespace

bool parse_plan_cache_text(const std::string& text, const std::string& key, const PlanSpec& spec,
                           PlanResult* out) {
    Words w(text);
    w.expect("spectex-plan-cache");
    w.expect(std::to_string(kPlanCacheFormat));
    w.expect("key");
    w.expect(key);
    PlanResult r;
    w.expect("chosen");
    r.chosen = static_cast<int>(w.whole(-1, kMaxRows));
    w.expect("best");
    r.best = static_cast<int>(w.whole(-1, kMaxRows));
    w.expect("colours");
    r.colours = w.text();
    w.expect("method");
    r.method = w.text();
    w.expect("search");
    r.search = w.text();
    w.expect("seconds");
    r.seconds = w.number();
    w.expect("rows");
    const long long rows = w.whole(0, kMaxRows);
    for (long long i = 0; i < rows && w.ok(); ++i) {
        GridRow row;
        w.expect("row");
        if (!read_grid(w, &row.grid)) return false;
        row.bins = static_cast<int>(w.whole(1, static_cast<long long>(kMaxGridBins)));
        row.bytes_per_pixel =
            static_cast<int>(w.whole(0, 4 * static_cast<long long>(kMaxGridBins)));
        row.relative_time = w.number();
        row.worst = w.number();
        row.worst_light = w.text();
        row.ok = w.flag();
        row.passes = w.flag();
        row.colours = w.text();
        row.why = w.text();
        const long long lights = w.whole(0, kMaxLights);
        for (long long j = 0; j < lights && w.ok(); ++j) {
            LightError le;
            w.expect("light");
            le.light = w.text();
            le.worst = w.number();
            le.p99 = w.number();
            le.half_shift = w.number();
            for (int c = 0; c < 3; ++c) le.worst_code[c] = static_cast<int>(w.whole(0, 255));
            row.lights.push_back(std::move(le));
        }
        if (!w.ok() || row.bins != static_cast<int>(row.grid.size())) return false;
        r.rows.push_back(std::move(row));
    }
    w.expect("end");
    if (!w.ok() || !w.at_end()) return false;
    const int n = static_cast<int>(r.rows.size());
    if (r.chosen >= n || r.best >= n) return false;
    if (r.chosen >= 0 && !r.rows[static_cast<size_t>(r.chosen)].passes) return false;
    if (!plausible_plan(spec, r)) return false;
    *out = std::move(r);
    return true;
}

PlanResult plan_grids_cached(const PlanSpec& spec, const std::string& folder,
                             PlanCacheReport* report) {
    PlanCacheReport local;
    PlanCacheReport& rep = report ? *report : local;
    rep = PlanCacheReport{};
    rep.folder = folder;
    if (folder.empty()) return plan_grids(spec);
    if (spec.precision) {
        // The grids' answer is cached, and the bits of the chosen grid are kept in the cache of
        // the precision's bits (bake --precision auto shares those entries).
        PlanSpec grids_only = spec;
        grids_only.precision = false;
        grids_only.precision_de = 0;
        PlanResult r = plan_grids_cached(grids_only, folder, report);
        add_plan_precision(spec, r, folder);
        return r;
    }
    const auto t0 = std::chrono::steady_clock::now();
    // The checks plan_grids makes first, so that a hit refuses what a search would.
    if (spec.lights.empty()) throw Error("no lights to plan for");
    if (!(spec.max_de > 0)) throw Error("the budget must be a positive ΔE00");
    check_plan_cost(spec);
    const std::string key = plan_cache_key(spec);
    PlanResult r = cached_answer<PlanResult>(
        folder, key, kPlanCacheEntryLimit,
        [&](const std::string& text, PlanResult* out) {
            return parse_plan_cache_text(text, key, spec, out);
        },
        [&] { return plan_grids(spec); },
        [&](const PlanResult& answer) { return plan_cache_text(key, answer); }, rep);
    if (rep.hit)
        r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

std::string precision_answer_key(const PrecisionRequest& req) {
    if (!req.method) throw Error("precision: no method");
    KeyHash k;
    k.text("precision");
    k.number(kPrecisionCacheFormat);
    k.number(kPrecisionChooserVersion);
    const SpectralMethod& m = *req.method;
    k.text(m.name());
    k.text(m.checksum());
    const auto prov = m.provenance();
    k.number(static_cast<double>(prov.size()));
    for (const auto& [fact, value] : prov) {
        k.text(method_fact_key(fact));
        k.text(value);
    }
    k.values(m.lambda());
    k.spectrum(req.observer.x);
    k.spectrum(req.observer.y);
    k.spectrum(req.observer.z);
    k.number(static_cast<double>(req.lights.size()));
    for (const Spectrum& l : req.lights) {
        k.text(l.name);
        k.spectrum(l);
    }
    if (req.rgb_weight) {
        k.text("colour-aware rounding");
        std::vector<double> w(req.rgb_weight->begin(), req.rgb_weight->end());
        k.values(w);
    } else {
        k.text("nearest rounding");
    }
    if (const SpectralMethod* ref = req.reference) {
        k.text("against the method at 1 nm");
        k.text(ref->checksum());
        k.values(ref->lambda());
    } else {
        k.text("against the unrounded spectra");
    }
    if (!req.codes.empty()) {  // else IEC 61966-2-1's values, as before there was a choice
        k.text("8-bit codes as decoded");
        k.values(std::vector<double>(req.codes.begin(), req.codes.end()));
    }
    k.number(req.max_de);
    k.number(req.stride);
    return "precision-" + k.hex();
}

std::string precision_cache_key(const PrecisionRequest& req) {
    KeyHash k;
    k.text("spectex " SPECTEX_VERSION);
    k.text(executable_identity());
    k.text(precision_answer_key(req));
    return "precision-" + k.hex();
}

std::string shipped_precision_folder() { return find_data_dir() + "/spectral/precision"; }

std::string precision_cache_text(const std::string& key, const PrecisionChoice& c) {
    std::ostringstream o;
    o << "spectex-precision-cache " << kPrecisionCacheFormat << "\n"
      << "key " << key << "\n";
    o << "bits " << c.bits.size();
    for (int b : c.bits) o << ' ' << b;
    o << "\nlights " << c.light.size() << "\n";
    for (size_t j = 0; j < c.light.size(); ++j)
        o << "light " << hex_text(c.light[j]) << ' '
          << exact(j < c.worst_de.size() ? c.worst_de[j] : 0.0) << ' '
          << (j < c.worst_code.size() ? c.worst_code[j] : 0u) << "\n";
    o << "colours " << c.colours << " evaluations " << c.evaluations << "\n";
    return o.str();
}

bool parse_precision_cache_text(const std::string& text, const std::string& key,
                                const PrecisionRequest& req, PrecisionChoice* out) {
    if (!req.method) return false;
    Words w(text);
    w.expect("spectex-precision-cache");
    w.expect(std::to_string(kPrecisionCacheFormat));
    w.expect("key");
    w.expect(key);
    PrecisionChoice c;
    w.expect("bits");
    const long long bins = w.whole(0, static_cast<long long>(kMaxGridBins));
    if (!w.ok() || bins != req.method->bins()) return false;
    for (long long k = 0; k < bins && w.ok(); ++k)
        c.bits.push_back(static_cast<int>(w.whole(kMinMantissaBits, 10)));
    w.expect("lights");
    const long long lights = w.whole(0, kMaxLights);
    if (!w.ok() || lights != static_cast<long long>(req.lights.size())) return false;
    for (long long j = 0; j < lights && w.ok(); ++j) {
        w.expect("light");
        const std::string name = w.text();
        const double worst = w.number();
        const long long code = w.whole(0, 0xffffff);
        if (!w.ok() || name != req.lights[static_cast<size_t>(j)].name || !(worst >= 0))
            return false;
        c.light.push_back(name);
        c.worst_de.push_back(worst);
        c.worst_code.push_back(static_cast<uint32_t>(code));
    }
    w.expect("colours");
    c.colours = static_cast<size_t>(w.whole(0, 1LL << 40));
    w.expect("evaluations");
    c.evaluations = static_cast<size_t>(w.whole(0, 1LL << 40));
    if (!w.ok() || !w.at_end()) return false;
    *out = std::move(c);
    return true;
}

PrecisionChoice choose_precision_cached(const PrecisionRequest& req, const std::string& folder,
                                        PrecisionCacheReport* report) {
    PrecisionCacheReport local;
    PrecisionCacheReport& rep = report ? *report : local;
    rep = PrecisionCacheReport{};
    rep.folder = folder;
    // A request choose_precision refuses is refused the same way, cache or not.
    if (!(req.max_de > 0) || !std::isfinite(req.max_de) || req.lights.empty())
        return choose_precision(req);
    // An entry's body names the request's own key (precision_answer_key), so that the cache's
    // entry for the default bake, copied to the data under that name, is the shipped answer
    // (config/spectral/precision/README.md). A damaged or foreign file is no answer.
    const std::string key = precision_answer_key(req);
    auto parse = [&](const std::string& text, PrecisionChoice* out) {
        return parse_precision_cache_text(text, key, req, out);
    };
    {
        const std::string entry = shipped_precision_folder() + "/" + key;
        std::string stored, body;
        PrecisionChoice shipped;
        if (read_small_regular_file(entry, kPrecisionCacheEntryLimit, &stored) &&
            unseal_entry(stored, &body) && parse(body, &shipped)) {
            rep.hit = true;
            rep.shipped = true;
            rep.entry = entry;
            return shipped;
        }
    }
    if (folder.empty()) return choose_precision(req);
    return cached_answer<PrecisionChoice>(
        folder, precision_cache_key(req), kPrecisionCacheEntryLimit, parse,
        [&] { return choose_precision(req); },
        [&](const PrecisionChoice& answer) { return precision_cache_text(key, answer); }, rep);
}

}  // namespace spectex
