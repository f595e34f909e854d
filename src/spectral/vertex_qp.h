#pragma once
// The small QPs of the spectral lattice: one per vertex colour v,
//
//   minimise 0.5 s'Hs + q's   subject to   C s = v,  0 <= s <= 1,
//
// with C the 3×N RGB weights and H = alpha I + w D'D tridiagonal (D: first differences along
// wavelength). Three equality constraints and simple bounds: solved in O(N) per iteration, far
// cheaper than the general solve_qp, which stays the fallback and the judge of infeasibility.
#include <Eigen/Dense>
#include <string>
#include <vector>

namespace spectex {

// H = alpha I + D'D with D row k = d[k] (s[k+1] - s[k]) (d holds the weights, already including
// any overall factor); an empty d means H = alpha I.
struct TridiagonalHessian {
    double alpha = 1.0;
    std::vector<double> d;
    Eigen::Index size = 0;
    double diag(Eigen::Index k) const;
    double off(Eigen::Index k) const {
        return -d[static_cast<size_t>(k)] * d[static_cast<size_t>(k)];
    }  // H(k, k+1)
    Eigen::VectorXd times(const Eigen::VectorXd& s) const;
};

struct VertexQpStats {
    int iterations = 0;
    bool used_fallback = false;
};

// Euclidean projection of s0 onto {C s = v, 0 <= s <= 1} (H = I, q = -s0): semismooth Newton on
// the 3 dual variables, s(mu) = clamp(s0 + C'mu, 0, 1), with generalised Jacobian C diag(free) C'
// and an Armijo line search on the (concave) dual function; then the equality system is re-solved
// on the final free set, with one step of refinement, so the colour is exact to rounding.
// Returns false when it does not converge (e.g. infeasible v).
bool project_dual_newton(const Eigen::Matrix3Xd& C, const Eigen::VectorXd& s0,
                         const Eigen::Vector3d& v, Eigen::VectorXd& s, int* iterations);

// General H (tridiagonal): primal-dual active set (Hintermüller-Ito-Kunisch; a semismooth Newton
// method on the complementarity conditions). Each iteration solves the equality-constrained QP on
// the free set: tridiagonal solves (Thomas) for 4 right-hand sides and a 3×3 Schur complement.
// Returns false when it does not converge or an equality system is singular. active (optional):
// in, a starting guess of the bounds' states (0 free, 1 at 0, 2 at 1; ignored unless of size N);
// out, the final states. Neighbouring vertices have nearly the same active sets.
bool solve_pdas(const Eigen::Matrix3Xd& C, const TridiagonalHessian& H, const Eigen::VectorXd& q,
                const Eigen::Vector3d& v, Eigen::VectorXd& s, int* iterations,
                std::vector<char>* active = nullptr);

// Tries the fast method (projection when H = alpha I with alpha = 1 and no D, else PDAS), checks
// the answer, and falls back to solve_qp. Throws Error (with what) when solve_qp finds v infeasible
// or no method reaches a colour residual <= tolerance with exact bounds.
Eigen::VectorXd solve_vertex_qp(const Eigen::Matrix3Xd& C, const TridiagonalHessian& H,
                                const Eigen::VectorXd& q, const Eigen::Vector3d& v,
                                double tolerance, const std::string& what,
                                VertexQpStats* stats = nullptr, std::vector<char>* warm = nullptr);

}  // namespace spectex
