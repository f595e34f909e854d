#pragma once
// "How many bins does my scene need?": the error of candidate wavelength grids under
// the scene's lights as a renderer sees them (spectral/grid_error.h), and the cheapest grid that
// meets an error budget under every light.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/method_table.h"
#include "spectral/grid_error.h"

namespace spectex {

struct PlanSpec {
    std::vector<std::string> lights = {"D65", "A", "FL11"};
    double max_de = 0.5;  // budget on the worst ΔE00 under every light
    Reconstruction reconstruction = Reconstruction::Linear;
    double range_start = 360, range_end = 830;  // the renderer's range, nm
    // method.kind: any row of the method table; method.fit: data dir, observer, the illuminant
    // the method is exact for, primaries, objective (its grid is set per candidate).
    MethodSpec method;
    bool half = true;
    std::vector<WavelengthGrid> candidates;  // empty: default_candidates()
    int threads = 0;                         // 0: hardware concurrency
    int sample_stride = 4;                   // the dense sample (code_sample)
    // Which colours decide (the basis only; other methods always use the sample): "auto" every row
    // on the sample and the chosen one on all 16,777,216 codes, "cube" every row on the cube,
    // "sample".
    std::string colours = "auto";
    // Also search non-uniform grids (plan_search.h; the basis only) and offer those that need fewer
    // bins than every uniform candidate.
    bool nonuniform = false;
    // --texture: the grid's error over this texture's colours (read and linearised as a bake does,
    // with --config and --colorspace) instead of the cube; at most texture_cap distinct colours.
    std::string texture, config, colorspace;
    uint64_t max_pixels = 268435456;
    size_t texture_cap = size_t(1) << 20;
    // Told how the search goes, on the calling thread: the stage ("building the method on each
    // grid", "measuring each grid", ...), the steps done and their total (0 when not known ahead).
    // Not part of the answer.
    std::function<void(const std::string& stage, size_t done, size_t total)> progress;
    // --precision auto (half): also choose the chosen grid's mantissa bits per bin as bake
    // --precision auto does (spectral/precision.h), within precision_de (0: max_de) under the
    // lights and the illuminant.
    bool precision = false;
    double precision_de = 0;
};

// Uniform steps 1, 2, 2.5, 4, 5, 10, 20 nm over 380:780, 400:700 and the renderer's range (a step
// that does not divide a range ends at the last bin inside it), the renderer's range first.
std::vector<WavelengthGrid> default_candidates(double range_start, double range_end);

// Bake time relative to the default 81 bins, modelled as a fixed part and a part proportional to
// the bins: 0.24 + 0.76 · bins / 81 (fitted to the 4K bakes at 81 and 401 bins in
// docs/performance.md).
double relative_bake_time(int bins);

struct LightError {
    std::string light;
    double worst = 0, p99 = 0;  // the figures the choice uses
    // Full cube (linear methods) or the sample; for half and a linear method, the cube's float
    // figures plus half_shift, the largest change of any sample colour's ΔE00 under half rounding.
    double half_shift = 0;
    std::array<int, 3> worst_code{{0, 0, 0}};
};

struct GridRow {
    WavelengthGrid grid;
    int bins = 0;
    int bytes_per_pixel = 0;  // spectral channels only (alpha not counted)
    double relative_time = 0;
    std::vector<LightError> lights;
    double worst = 0;  // over the lights
    std::string worst_light;
    bool ok = true;  // the method could be built on the grid
    bool passes = false;
    std::string colours;  // "cube" (all 8-bit codes) or "sample": what the figures are over
    std::string why;      // why it fails (or the note for the chosen grid)
};

struct PlanResult {
    std::vector<GridRow> rows;
    int chosen = -1;      // cheapest passing row, -1 when none
    int best = -1;        // lowest worst error
    std::string colours;  // how the colours were taken, for the report
    std::string method;   // the method and conditions
    std::string search;   // with --nonuniform: what the search found (plan_search.h)
    double seconds = 0;
    // --precision auto, for the chosen grid: bits per bin and the worst ΔE00 per light (rounded
    // against unrounded, over the sample bake uses); empty otherwise.
    std::vector<int> precision_bits;
    std::vector<std::string> precision_lights;
    std::vector<double> precision_worst;
    double precision_de = 0;
};

// A grid's name in the table: START:END:STEP, or "non-uniform N" (its wavelengths are listed
// under the table and in the JSON).
std::string grid_label(const WavelengthGrid& g);

// What a plan costs, known before any of it is done: for every candidate grid, its bins x the
// lights x the colours measured per row (the sample, or at most texture_cap for --texture), each a
// spectrum built, half-rounded and integrated. The default table (2,945 bins over its 21 grids,
// three lights, the 274,625-colour sample) is 2.4e9; a --texture at its 1,048,576-colour cap under
// three lights, 9.3e9.
uint64_t plan_cost(const PlanSpec& spec);
// The most plan_cost() may be: 2e10, twice the largest documented use (a texture at the cap under
// three lights) and 8 times the default table. Measured: --grids 360:830:0.01 (one grid of 47,001
// bins, 3.9e10) still ran after 90 s at 2.77 GB; the default table takes 43 s on 2 busy cores.
constexpr uint64_t kPlanCostLimit = 20000000000ull;
// Throws LimitError naming the option that weighs most against its default (--grids, --lights,
// --sample-stride or --texture), the figure and the limit, when plan_cost() is over
// kPlanCostLimit; and, for the lattice and Jakob-Hanika, when the tables of every candidate and
// the 1 nm reference, held together, are over kMethodTableLimit (method_table.h).
void check_plan_cost(const PlanSpec& spec);

// Throws Error when the lights, observer or range cannot be used, or the reference method cannot be
// built on the 1 nm range. A candidate grid the method cannot be built on is a failing row.
PlanResult plan_grids(const PlanSpec& spec);
// --precision auto: the chosen grid's mantissa bits per bin, into res (nothing without
// spec.precision, in float, or when no grid was chosen). plan_grids calls it without a cache; the
// plan cache keeps the grids' answer and calls it after with its folder, where the bits are kept
// under the key of the precision's request (pipeline/plan_cache.h), the entry bake --precision
// auto reads for the same method, grid, lights and budget.
void add_plan_precision(const PlanSpec& spec, PlanResult& res, const std::string& cache = "");

}  // namespace spectex

namespace spectex {

// "360:830" -> {360, 830}; whole nm, START < END. Throws Error.
std::pair<double, double> parse_plan_range(const std::string& spec);

}  // namespace spectex
