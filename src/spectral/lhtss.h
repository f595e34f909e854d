#pragma once
// The smoothest reflectance in log-hyperbolic-tangent space (Burns, "Numerical methods for
// smoothest reflectance reconstruction", Color Research & Application 45(1), 2020: "LHTSS"):
//
//   s(z) = (tanh(z) + 1) / 2,   minimise  sum_k (w_k (z[k+1] - z[k]))²  subject to  C s(z) = v,
//
// with w_k = 10 nm / Δλ_k (differences measured per 10 nm, so the answer does not depend on the
// grid's step). Every s lies strictly inside (0, 1) by construction; no training data. Solved by
// Newton's method on the Lagrange system (z and the three multipliers), with a backtracking line
// search on the residual; each step costs O(N): the tridiagonal block is eliminated (Gaussian
// elimination with partial pivoting) and the 3×3 Schur complement solved.
#include <Eigen/Dense>

#include "spectral/wavelength_grid.h"

namespace spectex {

struct LhtssResult {
    Eigen::VectorXd s;           // the reflectance, in (0, 1)
    Eigen::VectorXd z;           // its tanh-space coordinates: s = (tanh(z) + 1) / 2
    bool converged = false;      // colour residual <= tolerance and stationarity reached
    int iterations = 0;          // Newton steps
    double colour_residual = 0;  // max |C s - v|
};

// A learned prior on z (spectral/measured_prior.h), on the grid of the solve: z is Gaussian with
// this mean and covariance G + F F' (G: the inverse of the roughness
// sum_k (z[k+1] - z[k])² · 5 nm / Δλ_k). Its spectrum is the most probable z with the colour.
struct TanhPrior {
    Eigen::VectorXd mean;     // N
    Eigen::MatrixXd factors;  // F: N × m, m >= 0
};

// v must lie strictly inside the object-colour solid of C (black and white do not: their only
// bounded spectra are 0 and 1, which tanh reaches only in the limit). Never throws; a vertex that
// does not converge within the iteration limit comes back with converged = false.
LhtssResult lhtss_spectrum(const Eigen::Matrix3Xd& C, const WavelengthGrid& grid,
                           const Eigen::Vector3d& v, double tolerance = 1e-13);

// The same solve with a learned prior: min (z - mean)' (G + F F')⁻¹ (z - mean) subject to
// C s(z) = v, started at the mean; each Newton step is the tridiagonal solve plus an m × m one
// (Woodbury). prior = nullptr is lhtss_spectrum.
LhtssResult tanh_prior_spectrum(const Eigen::Matrix3Xd& C, const WavelengthGrid& grid,
                                const Eigen::Vector3d& v, const TanhPrior* prior,
                                double tolerance = 1e-13);

}  // namespace spectex
