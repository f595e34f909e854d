#pragma once
// bake's set-up, from what the command line asked to the settings every file of a batch is baked
// with: the tables read once (observer, illuminant, lights, a basis file, a wavelength file), the
// grid given or planned, the method built through the method table, --precision auto's bits chosen,
// and the recipe and settings hash that --update compares. Two steps, because --update and
// --dry-run need the settings hash before anything expensive is built: BakeSetup (cheap: tables,
// recipe, hash) and BakeSetup::finish (the plan, the method, the bits). prepare_bake does both.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "base/error.h"
#include "pipeline/bake.h"
#include "pipeline/method_table.h"
#include "pipeline/plan.h"
#include "pipeline/plan_cache.h"
#include "spectral/basis.h"
#include "spectral/precision.h"
#include "spectral/spectrum.h"

namespace spectex {

// The default bake, taken when neither --method nor an option that belongs to one method is given:
// the lattice with the LHTSS vertex prior, in half with --precision auto under six lights within
// 0.5 ΔE00, deflated at level 1. Measured against the basis at full precision (the default before
// it) on a 4096² photograph-like texture: about the same bytes and 1.2x the time, and about 0.6x
// the basis' mean ΔE00 under A, FL2, FL11, D50 and LED-B3 on held-out measured reflectances
// (docs/methods.md, "The default"). Level 1, because the budget's zeroed low bits make deflate's
// level 4 search longer for little: 1.16x the CPU of the basis at 0.98x its bytes, against 1.6x.
struct DefaultBake {
    static MethodSpec method();  // the lattice, vertex prior lhtss
    // The default's grid, without --wavelengths: the bins its lights need and no more. `spectex
    // plan --lights D65,A,FL2,FL11,D50,LED-B3 --max-de 0.5` chooses it (0.379 under FL2 from the
    // grid on its sample); with the bits, 0.428 (FL11) on every 8-bit code against the lattice at
    // 1 nm. Against 380:780:5, the default before (`--wavelengths 380:780:5` restores it):
    // 0.54-0.59x the basis' bytes instead of 1.13-1.42x, and the held-out charts' mean ΔE00
    // under A, FL2, FL11, D50 and LED-B3 +0.011 (docs/methods.md, "The default").
    static constexpr const char* grid = "400:700:10";
    static const std::vector<std::string>& lights();  // D65, A, FL2, FL11, D50, LED-B3
    static constexpr double max_de = 0.5;
    // Deflate level by the file's size (BakeOptions::zip_level 0): level 1 keeps a large
    // texture's bake at about half the basis' time, where deflate is most of it; a file of at most
    // small_pixels is bound by start-up instead (its deflate at level 6 took 0.14 s more on the
    // 512x256 chart, whose bake took 0.39 s), and level 6 makes it 0.89x the size of level 1.
    static constexpr int zip_level = 0;
    static constexpr int large_zip_level = 1;
    static constexpr int small_zip_level = 6;
    static constexpr uint64_t small_pixels = uint64_t(1) << 18;  // 512 x 512
};

// What bake was asked, as values parsed once from the command line (cli/bake_command).
struct BakeRequest {
    std::string data_dir;
    // --method and its options, and the conditions it is exact for (method.fit: --observer,
    // --illuminant, canonical names); its grid is the output grid, set by the set-up. The same
    // value is what --wavelengths auto plans with.
    MethodSpec method;
    std::string basis = "fit";  // --basis fit|mallett2019|FILE (with --method basis)
    // The output grid: `grid` (--wavelengths, or its default), read from `grid_file`
    // (--wavelengths-file), or planned (auto_grid: --wavelengths auto). Without --wavelengths
    // (grid_given false), a basis table brings its own grid.
    WavelengthGrid grid;
    bool grid_given = false;
    std::string grid_file;
    bool auto_grid = false;
    // --wavelengths auto's search: lights, budget, reconstruction, range, candidates, --nonuniform
    // (its method, half and threads are the request's: bake_plan_spec). The lights and budget are
    // also --precision auto's.
    PlanSpec plan;
    // --precision auto and its budget (0: plan.max_de).
    bool precision_auto = false;
    double precision_de = 0;
    // Colour, layout and policies of every output, as given.
    BakeOptions options;
    int threads = 0;        // --threads: the searches' threads (0: every core)
    bool no_cache = false;  // --no-cache: neither the plan's nor the precision's cache
};

// --wavelengths auto found no grid within the budget: the work's answer (exit 1 as in plan; the
// settings themselves were valid).
class UnmetBudget : public Error {
  public:
    explicit UnmetBudget(const std::string& what) : Error(what) {}
};

// The tables a bake is set up with, each read once (BakeSetup).
struct BakeTables {
    Observer observer;
    Spectrum illuminant;
    // --lights (with --wavelengths auto) and --precision auto's lights, by the name they were
    // asked by, each once.
    std::vector<std::pair<std::string, Spectrum>> lights;
    std::shared_ptr<const Basis> basis;  // --basis mallett2019|FILE; null otherwise
    // The table of `name`: a light, else the illuminant. Throws Error for a name not read.
    const Spectrum& light(const std::string& name) const;
};

// Told how the set-up goes, on the calling thread, so that the command can print it.
class BakeSetupListener {
  public:
    virtual ~BakeSetupListener() = default;
    // --wavelengths auto: the search's answer and the cache's report (also when no grid meets
    // the budget, before UnmetBudget is thrown).
    virtual void grid_planned(const PlanSpec&, const PlanResult&, const PlanCacheReport&) {}
    // The output grid, once known (given, read or planned), before the method is built.
    virtual void grid_known(const WavelengthGrid&) {}
    // The method built (or found in the process' memo) through the method table.
    virtual void method_built(const MethodSpec&, const MethodResult&) {}
    // Something wrong with what the files will be baked with (a given basis that misses the
    // primaries), in a sentence.
    virtual void warning(const std::string&) {}
    // --precision auto: the bits chosen (recorded as `rec`), the cache's report, the seconds taken.
    virtual void precision_chosen(const BakeSettings::Precision&, const PrecisionChoice&,
                                  const PrecisionCacheReport&, double) {}
};

// The search --wavelengths auto runs: the request's plan with its method (data dir included),
// sample type and threads. Also what bake checks the plan's cost with.
PlanSpec bake_plan_spec(const BakeRequest& request);

// The set-up's first step: tables read, conditions and grid decided, recipe and settings hash
// made; nothing expensive built (no fit, table, search or OCIO processor).
class BakeSetup {
  public:
    // Throws Error (a table that cannot be read, a basis on another grid, an OCIO config that
    // cannot be read) and LimitError (a wavelength file or basis over the grid limit, named).
    explicit BakeSetup(BakeRequest request);

    // The settings as --update and --dry-run compare them: hashes set, no method, and with
    // --wavelengths auto no grid yet.
    const BakeSettings& hashed() const { return settings_; }
    const BakeTables& tables() const { return tables_; }
    const BakeRequest& request() const { return request_; }

    // --colorspace checked against the config (a dry run's check; finish makes it too).
    void check_colour_space() const;
    // The second step: plans the grid (--wavelengths auto), builds the method, chooses the bits
    // (--precision auto). Throws UnmetBudget, Error, LimitError.
    BakeSettings finish(BakeSetupListener& listener) const;

  private:
    BakeRequest request_;
    BakeTables tables_;
    BakeSettings settings_;
};

// Both steps: the finished settings of a batch.
BakeSettings prepare_bake(const BakeRequest& request, BakeSetupListener& listener);

}  // namespace spectex
