#include "pipeline/bake_request.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <sstream>
#include <tuple>

#include "base/fnv1a.h"
#include "base/task_pool.h"
#include "io/data_dir.h"
#include "io/linearizer.h"
#include "pipeline/batch_files.h"
#include "pipeline/light_list.h"
#include "pipeline/plan_cache.h"
#include "pipeline/plan_report.h"
#include "spectral/basis_fit.h"
#include "spectral/colorimetry.h"

namespace spectex {

namespace {

// A user basis must reproduce the primaries to a third of the darkest 8-bit sRGB step in linear
// (1/255/12.92 = 3.0e-4); the shipped tables do to 4e-8.
constexpr double kBasisPrimaryTolerance = 1e-4;

bool given_basis(const BakeRequest& r) {
    return r.method.kind == MethodKind::Basis && r.basis != "fit";
}

// --wavelengths-file, the limit named by its option.
WavelengthGrid grid_from_file(const std::string& file) {
    try {
        return WavelengthGrid::from_file(file);
    } catch (const LimitError& e) {
        throw LimitError(std::string("--wavelengths-file: ") + e.what());
    }
}

// --wavelengths auto: how the grid is chosen, recorded in the header (and hashed).
BakeSettings::Plan auto_plan_record(const PlanSpec& plan) {
    BakeSettings::Plan rec;
    char num[64];
    for (const auto& l : plan.lights) rec.lights += (rec.lights.empty() ? "" : ",") + l;
    std::snprintf(num, sizeof num, "%g", plan.max_de);
    rec.max_de = num;
    rec.reconstruction = to_string(plan.reconstruction);
    std::snprintf(num, sizeof num, "%g:%g", plan.range_start, plan.range_end);
    rec.range = num;
    rec.nonuniform = plan.nonuniform;
    return rec;
}

// --basis mallett2019 or FILE (with --method basis): read once, checked against the output grid
// `*grid`, which it sets without --wavelengths.
std::shared_ptr<const Basis> load_given_basis(const BakeRequest& r, WavelengthGrid* grid) {
    Basis basis = load_basis(r.data_dir, r.basis);
    WavelengthGrid basis_grid;
    try {
        basis_grid = WavelengthGrid::from_list(basis.lambda);
    } catch (const LimitError& e) {
        throw LimitError("--basis: " + r.basis + ": " + e.what());
    }
    // Without --wavelengths, the output is on the basis' own grid.
    if (!r.grid_given && r.grid_file.empty()) *grid = basis_grid;
    if (!same_wavelengths(grid->lambda, basis_grid.lambda))
        throw Error("basis " + r.basis + " is on " + basis_grid.describe() +
                    ", not on the output grid " + grid->describe() +
                    " (the default --basis fit works on any grid)");
    check_basis_values(basis);
    return std::make_shared<const Basis>(std::move(basis));
}

// --precision auto's budget: --precision-de, else --max-de.
double precision_budget(const BakeRequest& r) {
    return r.precision_de > 0 ? r.precision_de : r.plan.max_de;
}

// --precision auto's lights: --lights, then the illuminant the rounding is exact for, each once.
std::vector<std::string> precision_lights(const BakeRequest& r, const std::string& illuminant) {
    std::vector<std::string> names = r.plan.lights;
    names.push_back(illuminant);
    return distinct_lights(names);
}

// The lights the set-up uses, each read once: --wavelengths auto's (hashed into the recipe), then
// --precision auto's (the illuminant's table is the one read already).
std::vector<std::pair<std::string, Spectrum>> read_lights(const BakeRequest& r,
                                                          const std::string& illuminant,
                                                          const Spectrum& illuminant_table) {
    std::vector<std::string> names;
    if (r.auto_grid) names = r.plan.lights;
    if (r.precision_auto)
        for (const auto& l : precision_lights(r, illuminant)) names.push_back(l);
    std::vector<std::pair<std::string, Spectrum>> lights;
    for (const auto& name : names) {
        const bool read = std::any_of(lights.begin(), lights.end(),
                                      [&](const auto& l) { return l.first == name; });
        if (read) continue;
        lights.emplace_back(
            name, name == illuminant ? illuminant_table : load_illuminant(r.data_dir, name));
    }
    return lights;
}

// The method's recipe: what builds it, the tables' values included (a user table that changes
// under the same name changes the hash). Never reworded: --update compares it with old files.
std::string method_recipe(const BakeRequest& r, const BakeTables& t) {
    Fnv1a64 h;
    auto add = [&](const std::string& s) { h.add(s.data(), s.size() + 1); };
    auto add_values = [&](const std::vector<double>& v) {
        h.add(v.data(), v.size() * sizeof(double));
    };
    if (t.basis)
        add("basis " + t.basis->checksum());
    else
        add(method_row(r.method.kind).recipe(r.method));
    add_values(t.observer.x.lambda);
    add_values(t.observer.x.value);
    add_values(t.observer.y.value);
    add_values(t.observer.z.value);
    add_values(t.illuminant.lambda);
    add_values(t.illuminant.value);
    if (r.auto_grid) {
        // The grid is chosen later from these (and this version): the choice is hashed by its
        // inputs. The words "half stride 4 colours auto" are those of the plan's defaults as
        // first hashed (the sample type is hashed apart, with the settings).
        for (const auto& l : r.plan.lights) {
            const Spectrum& light = t.light(l);
            add("light " + l);
            add_values(light.lambda);
            add_values(light.value);
        }
        for (const auto& g : r.plan.candidates) {
            add("candidate");
            add_values(g.lambda);
        }
        add(std::string(r.plan.half ? "half" : "float") + " stride " +
            std::to_string(r.plan.sample_stride) + " colours " + r.plan.colours);
    }
    return h.text();
}

// What chooses the bits of --precision auto, hashed into the settings (known before the method is
// built, so that --update builds nothing for files that are up to date): budget, sample, and each
// light's table. Empty without --precision auto.
BakeSettings::Precision precision_record(const BakeRequest& r, const BakeTables& t,
                                         const std::string& illuminant) {
    BakeSettings::Precision rec;
    if (!r.precision_auto) return rec;
    char num[64];
    std::snprintf(num, sizeof num, "%g", precision_budget(r));
    rec.max_de = num;
    const std::vector<std::string> lights = precision_lights(r, illuminant);
    for (const auto& l : lights) rec.lights += (rec.lights.empty() ? "" : ",") + l;
    rec.sample = given_basis(r) ? kPrecisionCoversRounding : kPrecisionCovers;
    Fnv1a64 h;
    auto add = [&](const std::string& s) { h.add(s.data(), s.size() + 1); };
    // The chooser's version: files whose bits were chosen by an earlier chooser (on a sample
    // only) are baked again by --update.
    add("auto " + rec.max_de + " stride " + std::to_string(kPrecisionSampleStride) + " chooser " +
        std::to_string(kPrecisionChooserVersion));
    for (const auto& l : lights) {
        const Spectrum& light = t.light(l);
        add("light " + l);
        h.add(light.lambda.data(), light.lambda.size() * sizeof(double));
        h.add(light.value.data(), light.value.size() * sizeof(double));
    }
    rec.recipe = h.text();
    return rec;
}

// The linear sRGB of a unit spectrum at each bin of the output grid (3 x bins, row-major).
std::vector<double> bin_rgb(const BakeSettings& s, const BakeTables& t) {
    const Colorimetry cm =
        Colorimetry::make(t.observer, t.illuminant, s.grid, primaries_by_name("srgb"));
    const Eigen::Matrix3Xd R = cm.rgb_weights();
    std::vector<double> w;
    for (int ch = 0; ch < 3; ++ch)
        for (Eigen::Index k = 0; k < R.cols(); ++k) w.push_back(R(ch, k));
    return w;
}

// Half's colour-aware rounding weights (bins x 3) from bin_rgb: empty for float or nearest
// rounding.
std::vector<float> half_rgb_weight(const BakeSettings& s) {
    std::vector<float> w;
    if (s.type != SampleType::Half || !s.colour_rounding) return w;
    const size_t bins = s.bin_rgb.size() / 3;
    for (size_t k = 0; k < bins; ++k)
        for (size_t ch = 0; ch < 3; ++ch) w.push_back(static_cast<float>(s.bin_rgb[ch * bins + k]));
    return w;
}

// --wavelengths auto: the grid chosen once per batch (every file of it gets the same grid), and
// its worst ΔE00 as recorded.
std::pair<WavelengthGrid, std::string> plan_grid(const BakeRequest& r,
                                                 BakeSetupListener& listener) {
    const PlanSpec spec = bake_plan_spec(r);
    PlanCacheReport rep;
    const PlanResult pr = plan_grids_cached(spec, r.no_cache ? "" : cache_folder(), &rep);
    listener.grid_planned(spec, pr, rep);
    if (pr.chosen < 0) throw UnmetBudget(plan_failure(spec, pr));
    const GridRow& row = pr.rows[static_cast<size_t>(pr.chosen)];
    char num[64];
    std::snprintf(num, sizeof num, "%.4g", row.worst);
    return {row.grid, num};
}

// The request's method on `grid`, with the tables read once.
MethodSpec method_spec_on(const BakeRequest& r, const BakeTables& t, const WavelengthGrid& grid) {
    MethodSpec spec = r.method;
    spec.fit.data_dir = r.data_dir;
    spec.fit.grid = grid;
    spec.fit.observer_table = std::make_shared<const Observer>(t.observer);
    spec.fit.illuminant_table = std::make_shared<const Spectrum>(t.illuminant);
    return spec;
}

// The spectral method every file is baked with: built through the method table on the output
// grid with the tables read once, or the given basis, checked against the colorimetry it is used
// with.
std::shared_ptr<const SpectralMethod> build_method(const BakeRequest& r, const BakeTables& t,
                                                   const BakeSettings& s,
                                                   BakeSetupListener& listener) {
    if (!t.basis) {
        const MethodSpec spec = method_spec_on(r, t, s.grid);
        const MethodResult made = make_method(spec, r.no_cache ? "" : cache_folder());
        listener.method_built(spec, made);
        return made.method;
    }
    // How far the basis is from reproducing the primaries under the colorimetry it is used with:
    // a wrong table (another observer, a flat one) bakes wrong colours without a word.
    const Colorimetry cm =
        Colorimetry::make(t.observer, t.illuminant, s.grid, primaries_by_name("srgb"));
    const FitCertificate cert = certify_basis(*t.basis, cm);
    const double miss =
        std::max({cert.colour_residual[0], cert.colour_residual[1], cert.colour_residual[2]});
    if (miss > kBasisPrimaryTolerance) {
        std::ostringstream w;
        w << "basis " << r.basis << " misses the sRGB primaries by " << miss
          << " in linear RGB under " << s.observer << " and " << s.illuminant << " (tolerance "
          << kBasisPrimaryTolerance << "): baked colours will be off by up to that";
        listener.warning(w.str());
    }
    return std::make_shared<BasisMethod>(
        *t.basis, r.basis == "mallett2019" ? "published table (Mallett & Yuksel 2019)" : "file");
}

// --precision auto: the bits chosen once per batch for the built method (every file of it gets
// the same bits), into the record.
void choose_precision_bits(const BakeRequest& r, const BakeTables& t, BakeSettings& s,
                           BakeSetupListener& listener) {
    const auto t0 = std::chrono::steady_clock::now();
    PrecisionRequest req;
    req.method = s.method.get();
    // The budget covers the file against the method's own spectrum at 1 nm (the grid and the
    // rounding together) whenever the method can be built there; a given basis table cannot.
    std::shared_ptr<const SpectralMethod> reference;
    if (!t.basis) {
        const MethodSpec spec = method_spec_on(r, t, observed_renderer_grid(t.observer));
        try {
            reference = make_method(spec, r.no_cache ? "" : cache_folder()).method;
        } catch (const Error& e) {
            throw Error("--precision auto: the reference (the method on " +
                        spec.fit.grid.describe() + ", the renderer's range at 1 nm): " + e.what());
        }
        req.reference = reference.get();
    }
    req.observer = t.observer;
    for (const auto& l : precision_lights(r, s.illuminant)) req.lights.push_back(t.light(l));
    if (!s.half_rgb_weight.empty()) req.rgb_weight = &s.half_rgb_weight;
    req.codes = srgb_code_values(s.data_dir, s.config);  // the colours an 8-bit texture bakes
    req.max_de = precision_budget(r);
    req.stride = kPrecisionSampleStride;
    req.threads = r.threads > 0 ? r.threads : hardware_threads();
    PrecisionCacheReport rep;
    const PrecisionChoice pc = choose_precision_cached(req, r.no_cache ? "" : cache_folder(), &rep);
    s.precision.bits = pc.bits;
    std::string worst, codes;
    for (size_t j = 0; j < pc.light.size(); ++j) {
        const std::string sep = j ? ", " : "";
        worst += sep + pc.light[j] + " " + format_de_up(pc.worst_de[j]);
        if (j < pc.worst_code.size()) {
            char hex[16];
            std::snprintf(hex, sizeof hex, "#%06x",
                          static_cast<unsigned>(pc.worst_code[j] & 0xffffff));
            codes += sep + pc.light[j] + " " + hex;
        }
    }
    s.precision.worst_de = worst;
    s.precision.worst_code = codes;
    // The grid's own error over the budget: every bit is kept, and the file is still that far from
    // the method at 1 nm. Said, with the way out; the header records the figure.
    if (!pc.worst_de.empty() &&
        *std::max_element(pc.worst_de.begin(), pc.worst_de.end()) > req.max_de)
        listener.warning(
            "--precision auto: the grid " + s.grid.describe() + " is itself over the budget of " +
            format_de_up(req.max_de) + " ΔE00 against the method at 1 nm (worst " + worst +
            "), so every bit is kept; --wavelengths auto plans a grid for these lights and budget");
    listener.precision_chosen(
        s.precision, pc, rep,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

}  // namespace

MethodSpec DefaultBake::method() {
    MethodSpec m;
    m.kind = MethodKind::Lattice;
    m.vertex_prior = "lhtss";
    return m;
}

const std::vector<std::string>& DefaultBake::lights() {
    static const std::vector<std::string> names = {"D65", "A", "FL2", "FL11", "D50", "LED-B3"};
    return names;
}

const Spectrum& BakeTables::light(const std::string& name) const {
    for (const auto& l : lights)
        if (l.first == name) return l.second;
    throw Error("the light " + name + " was not read with the bake's tables");
}

PlanSpec bake_plan_spec(const BakeRequest& r) {
    PlanSpec spec = r.plan;
    spec.lights = distinct_lights(spec.lights);
    spec.method = r.method;
    spec.method.fit.data_dir = r.data_dir;
    spec.half = r.options.type == SampleType::Half;
    spec.threads = r.threads;
    return spec;
}

BakeSetup::BakeSetup(BakeRequest request) : request_(std::move(request)) {
    BakeRequest& r = request_;
    r.plan.lights = distinct_lights(r.plan.lights);
    WavelengthGrid grid = r.grid_file.empty() ? r.grid : grid_from_file(r.grid_file);
    if (r.auto_grid) grid = WavelengthGrid{};  // chosen by finish; none in the hash
    // A given basis is exact for the conditions it was made for; the published table's are
    // recorded.
    std::string observer = r.method.fit.observer, illuminant = r.method.fit.illuminant;
    if (given_basis(r)) {
        tables_.basis = load_given_basis(r, &grid);
        if (r.basis == "mallett2019") observer = "cie1931-2", illuminant = "D65";
    }
    tables_.observer = load_observer(r.data_dir, observer);
    tables_.illuminant = load_illuminant(r.data_dir, illuminant);
    tables_.lights = read_lights(r, illuminant, tables_.illuminant);

    BakeSettings& s = settings_;
    static_cast<BakeOptions&>(s) = r.options;
    s.data_dir = r.data_dir;
    s.observer = observer;
    s.illuminant = illuminant;
    s.grid = grid;
    if (r.auto_grid) s.plan = auto_plan_record(r.plan);
    s.method_recipe = method_recipe(r, tables_);
    s.precision = precision_record(r, tables_, illuminant);
    // Reads the colour config (checked: a regular file of bounded size): an Error.
    s.settings_hash = settings_hash(s);
    s.legacy_settings_hash = legacy_settings_hash(s);
}

void BakeSetup::check_colour_space() const {
    const BakeSettings& s = settings_;
    if (!s.colorspace.empty())
        (void)Linearizer::make(ColourRequest{s.data_dir, s.config, s.colorspace, "", ColourTags{}});
}

BakeSettings BakeSetup::finish(BakeSetupListener& listener) const {
    BakeSettings s = settings_;
    if (request_.auto_grid) std::tie(s.grid, s.plan.worst_de) = plan_grid(request_, listener);
    listener.grid_known(s.grid);
    check_colour_space();
    s.method = build_method(request_, tables_, s, listener);
    s.bin_rgb = bin_rgb(s, tables_);
    s.half_rgb_weight = half_rgb_weight(s);
    if (request_.precision_auto) choose_precision_bits(request_, tables_, s, listener);
    return s;
}

BakeSettings prepare_bake(const BakeRequest& request, BakeSetupListener& listener) {
    return BakeSetup(request).finish(listener);
}

}  // namespace spectex
