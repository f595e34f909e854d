#pragma once
// Non-uniform wavelength grids for `spectex plan --nonuniform`.
//
// The layout allows any wavelengths, so a grid may place its bins where the scene needs them. The
// search is greedy removal, with the real basis fitted on every trial grid:
//   - colours: a coarse sample of the 8-bit cube (every 17th code: 16³ = 4,096 colours, the
//     corners, where the error peaks, included), in double, without half rounding;
//   - a trial's error: the worst ΔE00 over those colours and every light, with the same
//     definition as the plan (basis fitted on the trial grid, reconstructed at 1 nm by the
//     renderer's rule, against the basis fitted on 1 nm over the renderer's range);
//   - starts: for each range (400:700, 380:780 and the renderer's), the coarsest uniform grid of
//     10, 5, 4 and 2.5 nm that holds the budget, and the next finer one (at most 64 bins);
//   - step: remove the bin whose loss raises the worst error least, while the budget holds;
//   - result: the last grids of each trail that held (the final one and up to `trail` before it)
//     with fewer bins than the cheapest uniform candidate that holds on the same colours; the
//     plan's full evaluation, with the real half rounding and the dense sample or the cube,
//     decides which of them holds.
// Greedy insertion from a coarse start was tried first and lost to the uniform grids (0.94 ΔE00
// with 30 bins against 0.35 with 31 under D65, A, FL11): it places bins for the colour that is
// worst now and never undoes them.
// Every trial is a 3×3 map per light (colour under a light is linear in the spectrum, and the
// basis' spectrum linear in RGB), so a trial costs a fit (well under a millisecond at these sizes)
// and 4,096 ΔE00 per light.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "pipeline/plan.h"
#include "spectral/spectrum.h"

namespace spectex {

struct NonuniformSearch {
    // Grids on the greedy trails whose search error is within the budget (the first of each trail
    // and up to `trail` more bins), fewer bins than the cheapest passing uniform grid.
    std::vector<WavelengthGrid> grids;
    int uniform_bins =
        0;  // the cheapest uniform candidate within the budget on the search colours (0: none)
    int best_bins = 0;      // the fewest bins a trail reached within the budget (0: none)
    double best_worst = 0;  // its search error
    long trials = 0;        // basis fits and evaluations
    double seconds = 0;
    std::string note;  // one line for the report: what the search found, or why it found nothing
};

// `lights` are the scene's 1 nm weights over `fine` (the renderer's range), `reference` the basis
// fitted on `fine` (fine.size() × 3). `exact_under` is the illuminant the basis is exact for.
// `uniform` are the plan's uniform candidates (their search error sets the bins to beat).
NonuniformSearch search_nonuniform(const PlanSpec& spec, const Observer& observer,
                                   const Spectrum& exact_under, const WavelengthGrid& fine,
                                   const std::vector<LightWeights>& lights,
                                   const Eigen::MatrixXd& reference,
                                   const std::vector<WavelengthGrid>& uniform, int threads,
                                   int trail = 3);

// The search's error of one grid: the worst ΔE00 over the search colours and the lights, or +inf
// when no exact basis exists on the grid. Exposed for the tests.
double search_error(const PlanSpec& spec, const Observer& observer, const Spectrum& exact_under,
                    const WavelengthGrid& fine, const std::vector<LightWeights>& lights,
                    const Eigen::MatrixXd& reference, const WavelengthGrid& grid);

}  // namespace spectex
