#pragma once
// Fitting a spectral primary decomposition basis (Mallett & Yuksel 2019, section 4): three spectra
// S_r, S_g, S_b on a grid with RGB(S_k) = e_k, 0 <= S <= 1 and S_r + S_g + S_b = 1, minimising
// an objective. A convex QP, solved by solve_qp() and certified from the basis it returns.
#include <string>

#include "base/enum_names.h"
#include "spectral/basis.h"
#include "spectral/colorimetry.h"

namespace spectex {

enum class FitObjective { Norm, Smooth };
inline constexpr EnumNames<FitObjective, 2> kFitObjectiveNames{
    {{{FitObjective::Norm, "norm"}, {FitObjective::Smooth, "smooth"}}}};
FitObjective parse_objective(const std::string& name);  // "norm" | "smooth"
std::string to_string(FitObjective o);

struct FitRequest {
    Colorimetry colorimetry;  // grid, weights and white-consistent matrix
    FitObjective objective = FitObjective::Smooth;
    bool allow_infeasible = false;  // return the least-squares closest basis instead of failing
};

// Recomputed from the returned basis (and the solver's multipliers), never copied from the
// solver's own residuals.
struct FitCertificate {
    bool feasible = false;
    double colour_residual[3] = {0, 0, 0};  // per primary: max_c |RGB(S_k)_c - e_k,c|
    double bound_violation = 0;             // max(0, -min S, max S - 1)
    double sum_violation = 0;               // max |S_r + S_g + S_b - 1|
    double stationarity = 0;     // ||P x + q - A'y - z_l + z_u||_inf (relative to ||P x||+||q||+1)
    double complementarity = 0;  // max z_l·(S - 0), z_u·(1 - S)
    double dual_sign_violation = 0;          // max(0, -min z)
    int active_lower = 0, active_upper = 0;  // bounds at 0 and at 1
    int iterations = 0;
    double seconds = 0;
    std::string solver_status;
    double objective = 0;
};

struct FitResult {
    Basis basis;
    FitCertificate certificate;
};

// Throws Error when infeasible (unless allow_infeasible) or when the solver fails.
FitResult fit_basis(const FitRequest& request);

// The certificate of any basis on the request's grid (multipliers optional: without them the
// KKT residuals are reported as NaN).
FitCertificate certify_basis(const Basis& basis, const Colorimetry& c);

}  // namespace spectex
