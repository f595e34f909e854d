#include "pipeline/plan.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <sstream>

#include "base/error.h"
#include "base/task_pool.h"
#include "base/text.h"
#include "io/linearizer.h"
#include "pipeline/json_text.h"
#include "pipeline/light_list.h"
#include "pipeline/plan_cache.h"
#include "pipeline/plan_colours.h"
#include "pipeline/plan_search.h"
#include "pipeline/plan_texture.h"
#include "pipeline/table_memo.h"
#include "spectral/colorimetry.h"
#include "spectral/precision.h"
#include "spectral/spectrum.h"
#include "spectral/srgb_axis.h"

namespace spectex {

namespace {

std::string fmt(double v, const char* f = "%.3g") { return number_text(v, f); }

// Progress of the search, when someone listens.
void tell(const PlanSpec& spec, const char* stage, size_t done, size_t total) {
    if (spec.progress) spec.progress(stage, done, total);
}

std::shared_ptr<const SpectralMethod> build_method(const PlanSpec& s, const WavelengthGrid& g) {
    MethodSpec m = s.method;
    m.fit.grid = g;
    return make_method(m).method;
}

// A linear method's spectra of the three primaries, as columns: the spectrum of any colour is this
// matrix times its linear RGB. A basis gives its table's values as they are (double); another
// linear method its float expansion of the primaries.
Eigen::MatrixXd basis_matrix(const SpectralMethod& m) {
    if (const auto* basis = dynamic_cast<const BasisMethod*>(&m)) {
        const Basis& b = basis->basis();
        Eigen::MatrixXd B(static_cast<Eigen::Index>(b.size()), 3);
        for (size_t k = 0; k < b.size(); ++k)
            B.row(static_cast<Eigen::Index>(k)) << b.r[k], b.g[k], b.b[k];
        return B;
    }
    const size_t bins = m.lambda().size();
    const float r[3] = {1, 0, 0}, g[3] = {0, 1, 0}, b[3] = {0, 0, 1};
    std::vector<float> out(3 * bins);
    m.expand_float(r, g, b, 3, out.data(), 3);
    Eigen::MatrixXd B(static_cast<Eigen::Index>(bins), 3);
    for (size_t k = 0; k < bins; ++k)
        for (int c = 0; c < 3; ++c)
            B(static_cast<Eigen::Index>(k), c) = out[k * 3 + static_cast<size_t>(c)];
    return B;
}

}  // namespace

std::string grid_label(const WavelengthGrid& g) {
    return g.uniform ? g.describe() : "non-uniform " + std::to_string(g.size());
}

std::vector<WavelengthGrid> default_candidates(double range_start, double range_end) {
    std::vector<std::pair<double, double>> ranges = {{range_start, range_end}};
    for (auto r : {std::make_pair(380.0, 780.0), std::make_pair(400.0, 700.0)})
        if (r != ranges.front()) ranges.push_back(r);
    std::vector<WavelengthGrid> out;
    for (const auto& [lo, hi] : ranges)
        for (double step : {1.0, 2.0, 2.5, 4.0, 5.0, 10.0, 20.0}) {
            const double last = lo + std::floor((hi - lo) / step + 1e-9) * step;
            out.push_back(WavelengthGrid::uniform_grid(lo, last, step));
        }
    return out;
}

double relative_bake_time(int bins) { return 0.24 + 0.76 * bins / 81.0; }

namespace {

// The method on the renderer's 1 nm range, which every candidate is measured against.
std::shared_ptr<const SpectralMethod> build_reference(const PlanSpec& spec,
                                                      const WavelengthGrid& fine) {
    try {
        return build_method(spec, fine);
    } catch (const Error& e) {
        throw Error("the reference (the method on " + fine.describe() +
                    ", the renderer's range at 1 nm): " + e.what());
    }
}

// The method and the conditions it is built for, for the report (without a grid: each row has its
// own).
std::string method_text(const PlanSpec& spec) {
    const FitSpec& f = spec.method.fit;
    return spec.method.head() + ", " + f.primaries + " primaries, " + f.observer +
           (method_row(spec.method.kind).exact ? ", exact under " : ", built for ") + f.illuminant;
}

// The candidates (with --nonuniform, the search's grids added), fewest bins first.
std::vector<WavelengthGrid> candidate_grids(const PlanSpec& spec, const PlanScene& scene,
                                            const SpectralMethod& ref, bool linear, int threads,
                                            std::string* search_note) {
    std::vector<WavelengthGrid> grids = spec.candidates.empty()
                                            ? default_candidates(spec.range_start, spec.range_end)
                                            : spec.candidates;
    if (spec.nonuniform) {
        if (!linear)
            throw Error("--nonuniform searches with the basis' 3x3 maps: it needs --method basis");
        tell(spec, "searching non-uniform grids", 0, 1);
        const NonuniformSearch found = search_nonuniform(
            spec, scene.observer,
            *illuminant_table(spec.method.fit.data_dir, spec.method.fit.illuminant), scene.fine,
            scene.lights, basis_matrix(ref), grids, threads);
        for (const auto& g : found.grids)
            if (std::none_of(grids.begin(), grids.end(), [&](const WavelengthGrid& u) {
                    return same_wavelengths(u.lambda, g.lambda);
                }))
                grids.push_back(g);
        *search_note = found.note;
        tell(spec, "searching non-uniform grids", 1, 1);
    }
    std::sort(grids.begin(), grids.end(), [](const WavelengthGrid& a, const WavelengthGrid& b) {
        return a.size() != b.size() ? a.size() < b.size() : a.lambda.front() < b.lambda.front();
    });
    return grids;
}

// The candidates being measured, one per row.
struct Candidates {
    std::vector<WavelengthGrid> grids;
    std::vector<std::shared_ptr<const SpectralMethod>> methods;  // null: cannot be built
    std::vector<std::vector<Eigen::Matrix3Xd>> recon;            // per row, per light: W_L·R_G
};

// A row per grid, with the method built on it; a grid the method cannot be built on fails.
std::vector<GridRow> build_rows(const PlanSpec& spec, Candidates& cand) {
    std::vector<GridRow> rows;
    cand.methods.resize(cand.grids.size());
    for (size_t i = 0; i < cand.grids.size(); ++i) {
        tell(spec, "building the method on each grid", i, cand.grids.size());
        GridRow row;
        row.grid = cand.grids[i];
        row.bins = static_cast<int>(cand.grids[i].size());
        row.bytes_per_pixel = row.bins * (spec.half ? 2 : 4);
        row.relative_time = relative_bake_time(row.bins);
        try {
            cand.methods[i] = build_method(spec, cand.grids[i]);
        } catch (const Error& e) {
            row.ok = false;
            row.why = std::string("cannot build the method on this grid: ") + e.what();
        }
        rows.push_back(row);
    }
    tell(spec, "building the method on each grid", cand.grids.size(), cand.grids.size());
    return rows;
}

// Each light's weights after the renderer's reconstruction from a row's grid to 1 nm.
void reconstruct_lights(const PlanSpec& spec, const PlanScene& scene, Candidates& cand,
                        std::vector<GridRow>& rows) {
    for (auto& row : rows) row.lights.resize(scene.lights.size());
    cand.recon.resize(rows.size());
    for (size_t i = 0; i < rows.size(); ++i) {
        if (!cand.methods[i]) continue;
        const Eigen::MatrixXd R =
            reconstruction_matrix(cand.grids[i].lambda, scene.fine.lambda, spec.reconstruction);
        for (const auto& lw : scene.lights) cand.recon[i].push_back(lw.W * R);
        for (size_t j = 0; j < scene.lights.size(); ++j)
            rows[i].lights[j].light = scene.lights[j].name;
    }
}

// Half rounding as a bake does it: colour-aware, under the conditions the method is exact for.
std::vector<float> rgb_weight_for(const PlanSpec& spec, const Observer& obs,
                                  const WavelengthGrid& g) {
    const Colorimetry c = Colorimetry::make(
        obs, *illuminant_table(spec.method.fit.data_dir, spec.method.fit.illuminant), g,
        primaries_by_name(spec.method.fit.primaries));
    const Eigen::Matrix3Xd R = c.rgb_weights();
    std::vector<float> w(3 * g.size());
    for (size_t k = 0; k < g.size(); ++k)
        for (int ch = 0; ch < 3; ++ch)
            w[3 * k + static_cast<size_t>(ch)] =
                static_cast<float>(R(ch, static_cast<Eigen::Index>(k)));
    return w;
}

// A row's verdict from its figures.
void judge(GridRow& row, double max_de) {
    row.worst = 0;
    row.worst_light.clear();
    std::string over;
    for (const auto& le : row.lights) {
        if (le.worst >= row.worst) {
            row.worst = le.worst;
            row.worst_light = le.light;
        }
        if (le.worst > max_de) over += (over.empty() ? "" : ", ") + le.light + " " + fmt(le.worst);
    }
    row.passes = over.empty();
    row.why = row.passes ? "" : "fails: " + over + " > " + fmt(max_de);
    if (row.passes || row.colours != "cube") return;
    row.why += " on the full cube";
}

void set_figures(LightError& le, const ErrorStats& st) {
    le.worst = st.worst;
    le.p99 = st.p99;
    le.worst_code = st.worst_code;
}

// What a measurement of the rows needs.
struct Measure {
    const PlanSpec& spec;
    const PlanScene& scene;
    const PlanColours& colours;
    const Candidates& cand;
    const SpectralMethod& ref;
    int threads;
    const char* row_colours;  // what a row measured on the colours is over: sample or texture
};

// Colour is a 3×3 map of linear RGB: M_G = W_L·R_G·B_G for the candidate, W_L·B_1nm for the
// reference.
struct LinearMaps {
    std::vector<Eigen::Matrix3d> ref;                // per light
    std::vector<std::vector<Eigen::Matrix3d>> rows;  // per row, per light
};

// A row's figures on the sample through its 3×3 maps, with the real half rounding; keeps the
// largest change half rounding made to any colour's error for the cube.
void linear_row_on_sample(const Measure& m, size_t i, LinearMaps& maps, GridRow& row) {
    const PlanColours& c = m.colours;
    const auto& lights = m.scene.lights;
    const Eigen::MatrixXd B = basis_matrix(*m.cand.methods[i]);
    for (size_t j = 0; j < lights.size(); ++j) maps.rows[i].push_back(m.cand.recon[i][j] * B);
    std::vector<Eigen::Matrix3Xd> half_xyz;
    if (m.spec.half) {
        const std::vector<float> w = rgb_weight_for(m.spec, m.scene.observer, m.cand.grids[i]);
        half_xyz = method_xyz(*m.cand.methods[i], m.cand.recon[i], c.sr, c.sg, c.sb, true, &w);
    }
    for (size_t j = 0; j < lights.size(); ++j) {
        const Eigen::Matrix3Xd ref_xyz = maps.ref[j] * c.srgb;
        std::vector<double> de_float, de_half;
        const DeltaEHistogram hf =
            xyz_error(maps.rows[i][j] * c.srgb, ref_xyz, lights[j].white, &de_float);
        LightError& le = row.lights[j];
        ErrorStats st = stats_of(hf, &c.codes);
        if (m.spec.half) {
            st = stats_of(xyz_error(half_xyz[j], ref_xyz, lights[j].white, &de_half), &c.codes);
            for (size_t k = 0; k < de_half.size(); ++k)
                le.half_shift = std::max(le.half_shift, std::fabs(de_half[k] - de_float[k]));
        }
        set_figures(le, st);
    }
    row.colours = m.row_colours;
}

// The figures of some rows over all 16,777,216 codes (float maps, plus the half shift).
void linear_rows_on_cube(const Measure& m, const LinearMaps& maps, const std::vector<size_t>& which,
                         std::vector<GridRow>& rows) {
    const auto& lights = m.scene.lights;
    for (size_t j = 0; j < lights.size(); ++j) {
        std::vector<Eigen::Matrix3d> cand;
        for (size_t i : which) cand.push_back(maps.rows[i][j]);
        const auto stats = cube_error_linear(cand, maps.ref[j], lights[j].white, m.threads);
        for (size_t c = 0; c < which.size(); ++c) {
            LightError& le = rows[which[c]].lights[j];
            le.worst = stats[c].worst + le.half_shift;
            le.p99 = stats[c].p99 + le.half_shift;
            le.worst_code = stats[c].worst_code;
        }
    }
    for (size_t i : which) rows[i].colours = "cube";
}

// With "auto": the cheapest row that passes on the sample is checked on the cube, until one holds.
void verify_cheapest_on_cube(const Measure& m, const LinearMaps& maps, std::vector<GridRow>& rows) {
    while (true) {
        int pick = -1;
        for (size_t i = 0; i < rows.size(); ++i) {
            const GridRow& row = rows[i];
            if (!row.passes || row.colours == "cube") continue;
            if (pick < 0 || row.bins < rows[static_cast<size_t>(pick)].bins ||
                (row.bins == rows[static_cast<size_t>(pick)].bins &&
                 row.worst < rows[static_cast<size_t>(pick)].worst))
                pick = static_cast<int>(i);
        }
        bool verified = false;
        for (const auto& row : rows)
            if (row.passes && row.colours == "cube" &&
                (pick < 0 || row.bins <= rows[static_cast<size_t>(pick)].bins))
                verified = true;
        if (pick < 0 || verified) break;
        tell(m.spec,
             ("checking " + grid_label(rows[static_cast<size_t>(pick)].grid) +
              " on all 16,777,216 colours")
                 .c_str(),
             0, 1);
        linear_rows_on_cube(m, maps, {static_cast<size_t>(pick)}, rows);
        tell(m.spec,
             ("checking " + grid_label(rows[static_cast<size_t>(pick)].grid) +
              " on all 16,777,216 colours")
                 .c_str(),
             1, 1);
        judge(rows[static_cast<size_t>(pick)], m.spec.max_de);
    }
}

std::string linear_colours_text(const PlanSpec& spec, const std::string& mode,
                                const std::string& sample_text) {
    std::string text =
        mode == "sample"
            ? sample_text
            : "all " + thousands(16777216) + " 8-bit sRGB colours" +
                  std::string(mode == "auto" ? " for the chosen grid, " : " for every grid") +
                  (mode == "auto" ? sample_text + " for the others" : "");
    if (spec.half && mode != "sample")
        text += "; on the cube, half rounding's largest change of a sample colour's error is added";
    return text;
}

// A linear method (the basis): every row on the sample; the full cube for every row with "cube",
// for the chosen row with "auto".
void measure_linear(const Measure& m, const std::string& mode, PlanResult& res) {
    LinearMaps maps;
    maps.rows.resize(res.rows.size());
    const Eigen::MatrixXd Bref = basis_matrix(m.ref);
    for (const auto& lw : m.scene.lights) maps.ref.push_back(lw.W * Bref);
    for (size_t i = 0; i < res.rows.size(); ++i) {
        tell(m.spec, "measuring each grid", i, res.rows.size());
        if (m.cand.methods[i]) linear_row_on_sample(m, i, maps, res.rows[i]);
    }
    tell(m.spec, "measuring each grid", res.rows.size(), res.rows.size());
    if (mode == "cube") {
        std::vector<size_t> all;
        for (size_t i = 0; i < res.rows.size(); ++i)
            if (m.cand.methods[i]) all.push_back(i);
        tell(m.spec, "every grid on all 16,777,216 colours", 0, 1);
        linear_rows_on_cube(m, maps, all, res.rows);
        tell(m.spec, "every grid on all 16,777,216 colours", 1, 1);
    }
    res.colours = linear_colours_text(m.spec, mode, m.colours.text);
    for (auto& row : res.rows)
        if (row.ok) judge(row, m.spec.max_de);
    if (mode == "auto") verify_cheapest_on_cube(m, maps, res.rows);
}

// Another method: every row on the sample, spectra built per colour.
void measure_nonlinear(const Measure& m, PlanResult& res) {
    const PlanColours& c = m.colours;
    const auto& lights = m.scene.lights;
    std::vector<Eigen::Matrix3Xd> ref_w;
    for (const auto& lw : lights) ref_w.push_back(lw.W);
    const auto ref_xyz = method_xyz(m.ref, ref_w, c.sr, c.sg, c.sb, false, nullptr);
    for (size_t i = 0; i < res.rows.size(); ++i) {
        tell(m.spec, "measuring each grid", i, res.rows.size());
        if (!m.cand.methods[i]) continue;
        std::vector<float> w;
        if (m.spec.half) w = rgb_weight_for(m.spec, m.scene.observer, m.cand.grids[i]);
        const auto xyz = method_xyz(*m.cand.methods[i], m.cand.recon[i], c.sr, c.sg, c.sb,
                                    m.spec.half, m.spec.half ? &w : nullptr);
        for (size_t j = 0; j < lights.size(); ++j)
            set_figures(res.rows[i].lights[j],
                        stats_of(xyz_error(xyz[j], ref_xyz[j], lights[j].white), &c.codes));
        res.rows[i].colours = m.row_colours;
        judge(res.rows[i], m.spec.max_de);
    }
    tell(m.spec, "measuring each grid", res.rows.size(), res.rows.size());
    res.colours = c.text + " (the method is not linear in RGB: no 3x3 map of the cube)";
}

// The best row (lowest worst error) and the chosen one: rows are sorted by bins (bytes and time
// grow with them), so the first that passes, and among equal bins the smaller error; with "auto",
// only a row checked on the full cube.
void choose_row(bool cube_only, PlanResult& res) {
    for (size_t i = 0; i < res.rows.size(); ++i)
        if (res.rows[i].ok &&
            (res.best < 0 || res.rows[i].worst < res.rows[static_cast<size_t>(res.best)].worst))
            res.best = static_cast<int>(i);
    for (size_t i = 0; i < res.rows.size(); ++i) {
        const GridRow& row = res.rows[i];
        if (!row.passes || (cube_only && row.colours != "cube")) continue;
        if (res.chosen < 0) {
            res.chosen = static_cast<int>(i);
        } else {
            const GridRow& c = res.rows[static_cast<size_t>(res.chosen)];
            if (row.bins == c.bins && row.worst < c.worst) res.chosen = static_cast<int>(i);
        }
    }
}

// The verdict of the chosen row and of the rows that pass but were not chosen.
void explain_choice(double max_de, PlanResult& res) {
    for (size_t i = 0; i < res.rows.size(); ++i) {
        GridRow& row = res.rows[i];
        if (static_cast<int>(i) == res.chosen)
            row.why = "chosen: the fewest bins within " + fmt(max_de) + " under every light";
        else if (row.passes && res.chosen >= 0)
            row.why = "meets the budget, but " +
                      (row.bins > res.rows[static_cast<size_t>(res.chosen)].bins
                           ? std::string("more bins")
                           : std::string("a larger error")) +
                      " than " + grid_label(res.rows[static_cast<size_t>(res.chosen)].grid);
    }
}

}  // namespace

namespace {

// --precision auto on the chosen grid: the bits bake --precision auto would keep (its lights: the
// plan's and the illuminant the method is exact for; its sample of the cube).
void plan_precision(const PlanSpec& spec, const Observer& observer, const WavelengthGrid& grid,
                    int threads, const std::string& cache, PlanResult& res) {
    const std::shared_ptr<const SpectralMethod> method = build_method(spec, grid);
    // Against the method at 1 nm over the renderer's range, as bake --precision auto judges it (the
    // same request, the same cache entry).
    const std::shared_ptr<const SpectralMethod> reference =
        build_reference(spec, observed_renderer_grid(observer));
    std::vector<std::string> names = spec.lights;
    names.push_back(spec.method.fit.illuminant);
    names = distinct_lights(names);
    PrecisionRequest req;
    req.method = method.get();
    req.reference = reference.get();
    req.observer = observer;
    for (const auto& l : names)
        req.lights.push_back(*illuminant_table(spec.method.fit.data_dir, l));
    const std::vector<float> w = rgb_weight_for(spec, observer, grid);
    req.rgb_weight = &w;
    // The colours an 8-bit texture bakes, as bake asks it (the same cache entry).
    req.codes = srgb_code_values(spec.method.fit.data_dir, spec.config);
    req.max_de = spec.precision_de > 0 ? spec.precision_de : spec.max_de;
    req.stride = kPrecisionSampleStride;
    req.threads = threads;
    // The same cache entries as bake --precision auto: the same request, the same bits.
    const PrecisionChoice c = choose_precision_cached(req, cache, nullptr);
    res.precision_bits = c.bits;
    res.precision_lights = names;
    res.precision_worst = c.worst_de;
    res.precision_de = req.max_de;
}

}  // namespace

PlanResult plan_grids(const PlanSpec& spec) {
    const auto t0 = std::chrono::steady_clock::now();
    if (spec.lights.empty()) throw Error("no lights to plan for");
    if (!(spec.max_de > 0)) throw Error("the budget must be a positive ΔE00");
    check_plan_cost(spec);
    const PlanScene scene = load_plan_scene(spec);
    const PlanColours colours = plan_colours(spec);
    // A texture's colours are all there is: no cube.
    const std::string mode = spec.texture.empty() ? spec.colours : "sample";
    const int threads =
        std::min(spec.threads > 0 ? spec.threads : hardware_threads(), thread_budget());
    const std::shared_ptr<const SpectralMethod> ref = build_reference(spec, scene.fine);
    const bool linear = method_row(spec.method.kind).linear;

    PlanResult res;
    res.method = method_text(spec);
    Candidates cand;
    cand.grids = candidate_grids(spec, scene, *ref, linear, threads, &res.search);
    res.rows = build_rows(spec, cand);
    reconstruct_lights(spec, scene, cand, res.rows);

    const Measure m{
        spec, scene, colours, cand, *ref, threads, spec.texture.empty() ? "sample" : "texture"};
    if (linear)
        measure_linear(m, mode, res);
    else
        measure_nonlinear(m, res);
    choose_row(linear && mode == "auto", res);
    explain_choice(spec.max_de, res);
    add_plan_precision(spec, res);
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return res;
}

void add_plan_precision(const PlanSpec& spec, PlanResult& res, const std::string& cache) {
    if (!spec.precision || !spec.half || res.chosen < 0) return;
    const int threads =
        std::min(spec.threads > 0 ? spec.threads : hardware_threads(), thread_budget());
    plan_precision(spec, *observer_table(spec.method.fit.data_dir, spec.method.fit.observer),
                   res.rows[static_cast<size_t>(res.chosen)].grid, threads, cache, res);
}

}  // namespace spectex

namespace spectex {

std::pair<double, double> parse_plan_range(const std::string& spec) {
    const size_t colon = spec.find(':');
    if (colon == std::string::npos || spec.find(':', colon + 1) != std::string::npos)
        throw Error("'" + spec + "' is not START:END in nm");
    const std::string a = spec.substr(0, colon), b = spec.substr(colon + 1);
    double lo = 0, hi = 0;
    if (!parse_finite(a, &lo) || !parse_finite(b, &hi))
        throw Error("'" + spec + "' is not START:END in nm");
    renderer_grid(lo, hi);  // whole nm, START < END
    return {lo, hi};
}

}  // namespace spectex
