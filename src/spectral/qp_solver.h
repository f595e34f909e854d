// Convex quadratic programming with Eigen only.
//
//   minimise    0.5 x'Px + q'x
//   subject to  A x = b,   lower <= x <= upper
//
// P must be symmetric positive semi-definite (both triangles stored). Rows of A may be linearly
// dependent as long as they are consistent; bounds may be infinite.
//
// Method: Ruiz equilibration (power-of-two factors, so scaling is exact), a primal-dual
// Mehrotra predictor-corrector interior-point method on the regularised quasi-definite KKT
// system (SimplicialLDLT + iterative refinement against the unregularised system), then an
// active-set polish that solves the equality-constrained QP on the guessed free variables to
// rounding accuracy and verifies feasibility and multiplier signs in the original units.
// Infeasibility is confirmed by a phase-1 solve (min ||Ax - b||^2 over the box) and a Farkas
// certificate built from it.
// Single-threaded and deterministic: the same input gives the same bytes.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace spectex {

struct QpProblem {
    // minimise 0.5 x'Px + q'x  subject to  A x = b,  lower <= x <= upper
    Eigen::SparseMatrix<double> P;  // n x n, symmetric PSD, full storage (both triangles)
    Eigen::VectorXd q;              // n
    Eigen::SparseMatrix<double> A;  // m x n (m may be 0); rows may be dependent
    Eigen::VectorXd b;              // m
    Eigen::VectorXd lower, upper;   // n; entries may be -inf / +inf
};

struct QpOptions {
    // Relative accuracy demanded of a Solved result (see QpResult).
    double tolerance = 1e-13;
    // Interior-point iterations (the polish and the phase-1 check do not count).
    int max_iterations = 200;
    // Active-set polish of the interior-point solution.
    bool polish = true;
};

enum class QpStatus { Solved, Infeasible, MaxIterations, NumericalError };

struct QpResult {
    QpStatus status = QpStatus::NumericalError;
    Eigen::VectorXd x;        // primal solution (n)
    Eigen::VectorXd y;        // equality multipliers (m), stationarity uses -A'y
    Eigen::VectorXd z_lower;  // >= 0, multipliers of x >= lower (0 where lower = -inf)
    Eigen::VectorXd z_upper;  // >= 0, multipliers of x <= upper (0 where upper = +inf)
    int iterations = 0;       // interior-point iterations performed
    bool polished = false;    // true if x came from the active-set polish
    // Absolute residuals of the returned (x, y, z_lower, z_upper), infinity norms:
    //   primal_residual = max(||Ax - b||, max bound violation)
    //   dual_residual   = ||Px + q - A'y - z_lower + z_upper||
    //   complementarity = max_i max(z_lower_i (x_i - lower_i), z_upper_i (upper_i - x_i))
    // Solved means, with tol = QpOptions::tolerance and |.| taken elementwise (backward-error
    // scales, so that cancellation in Ax or Px cannot demand more than rounding allows):
    //   ||Ax - b|| <= tol * max(1, ||b||, || |A||x| ||) and no bound violation at all,
    //   dual_residual <= tol * max(1, ||q||, || |P||x| ||, || |A'||y| ||, ||z_lower||,
    //                              ||z_upper||),
    //   complementarity <= tol * max(1, |q|'|x|, |x|'|P||x|).
    double primal_residual = 0.0;
    double dual_residual = 0.0;
    double complementarity = 0.0;
};

// Throws std::invalid_argument if the dimensions do not match. Never returns NaN.
// Infeasible is reported only with evidence, from a phase-1 solve (min ||Ax - b||^2 over the
// box): normally a Farkas certificate y (returned in y) showing that every box point x' has
//   ||A x' - b||_inf >= (y'b - sup_box y'A x') / ||y||_1 > tolerance * scale;
// otherwise a phase-1 optimum whose residual exceeds sqrt(tolerance) * scale. x is then the
// phase-1 box point (closest to A x = b in the least-squares sense) and z are zero.
QpResult solve_qp(const QpProblem& problem, const QpOptions& options = {});

const char* to_string(QpStatus status);

}  // namespace spectex
