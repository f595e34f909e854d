#include "spectral/vertex_qp.h"

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "base/error.h"
#include "spectral/qp_solver.h"

namespace spectex {

double TridiagonalHessian::diag(Eigen::Index k) const {
    double h = alpha;
    if (!d.empty()) {
        if (k > 0) h += d[static_cast<size_t>(k) - 1] * d[static_cast<size_t>(k) - 1];
        if (k + 1 < size) h += d[static_cast<size_t>(k)] * d[static_cast<size_t>(k)];
    }
    return h;
}

Eigen::VectorXd TridiagonalHessian::times(const Eigen::VectorXd& s) const {
    Eigen::VectorXd out(s.size());
    for (Eigen::Index k = 0; k < s.size(); ++k) {
        double h = diag(k) * s[k];
        if (!d.empty()) {
            if (k > 0) h += off(k - 1) * s[k - 1];
            if (k + 1 < s.size()) h += off(k) * s[k + 1];
        }
        out[k] = h;
    }
    return out;
}

namespace {

// The equality-constrained QP on a free set F, the other variables fixed at their values in s:
//   H_FF s_F = -(q_F + H_FA s_A) + C_F' mu,   C_F s_F = v - C_A s_A.
// Thomas elimination of the tridiagonal H_FF (diagonally dominant: no pivoting needed), then the
// 3×3 Schur complement for mu; two rounds of refinement against the full residuals make the
// colour exact to rounding even when H_FF is ill-conditioned (the Smooth prior's small alpha).
class FreeSystem {
  public:
    FreeSystem(const Eigen::Matrix3Xd& C, const TridiagonalHessian& H,
               const std::vector<char>& free)
        : C_(C) {
        for (Eigen::Index k = 0; k < C.cols(); ++k)
            if (free[static_cast<size_t>(k)]) F_.push_back(k);
        const size_t m = F_.size();
        cp_.assign(m, 0.0);
        den_.assign(m, 0.0);
        sub_.assign(m, 0.0);
        for (size_t j = 0; j < m; ++j) {
            const Eigen::Index k = F_[j];
            const double upper = (j + 1 < m && F_[j + 1] == k + 1 && !H.d.empty()) ? H.off(k) : 0.0;
            sub_[j] = (j > 0 && F_[j - 1] == k - 1 && !H.d.empty()) ? H.off(k - 1) : 0.0;
            den_[j] = H.diag(k) - (j > 0 ? sub_[j] * cp_[j - 1] : 0.0);
            cp_[j] = upper / den_[j];
        }
        XC_.resize(static_cast<Eigen::Index>(m), 3);
        for (int c = 0; c < 3; ++c) {
            std::vector<double> x(m);
            for (size_t j = 0; j < m; ++j) x[j] = C(c, F_[j]);
            solve_tri(x);
            for (size_t j = 0; j < m; ++j) XC_(static_cast<Eigen::Index>(j), c) = x[j];
        }
        Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
        for (size_t j = 0; j < m; ++j) S += C_.col(F_[j]) * XC_.row(static_cast<Eigen::Index>(j));
        lu_.compute(S);
    }

    bool ok() const {
        if (F_.empty() || lu_.rank() < 3) return false;
        for (double d : den_)
            if (!(d > 0)) return false;
        return true;
    }

    // Solves for s_F and mu given the fixed part of s; refines twice.
    void solve(const TridiagonalHessian& H, const Eigen::VectorXd& q, const Eigen::Vector3d& v,
               Eigen::VectorXd& s, Eigen::Vector3d& mu) const {
        mu.setZero();
        for (size_t j = 0; j < F_.size(); ++j) s[F_[j]] = 0;
        for (int round = 0; round < 3; ++round) {
            // Residuals of the current (s, mu): stationarity on F and the colour.
            const Eigen::VectorXd g = H.times(s) + q - C_.transpose() * mu;
            const Eigen::Vector3d r2 = v - C_ * s;
            std::vector<double> x(F_.size());
            for (size_t j = 0; j < F_.size(); ++j) x[j] = -g[F_[j]];
            solve_tri(x);
            Eigen::Vector3d cx = Eigen::Vector3d::Zero();
            for (size_t j = 0; j < F_.size(); ++j) cx += C_.col(F_[j]) * x[j];
            const Eigen::Vector3d dmu = lu_.solve(r2 - cx);
            for (size_t j = 0; j < F_.size(); ++j)
                s[F_[j]] += x[j] + XC_.row(static_cast<Eigen::Index>(j)).dot(dmu);
            mu += dmu;
        }
    }

  private:
    const Eigen::Matrix3Xd& C_;
    std::vector<Eigen::Index> F_;
    std::vector<double> cp_, den_, sub_;
    Eigen::Matrix<double, Eigen::Dynamic, 3> XC_;
    Eigen::FullPivLU<Eigen::Matrix3d> lu_;

    void solve_tri(std::vector<double>& x) const {
        const size_t m = x.size();
        for (size_t j = 0; j < m; ++j) x[j] = (x[j] - (j > 0 ? sub_[j] * x[j - 1] : 0.0)) / den_[j];
        for (size_t j = m; j-- > 1;) x[j - 1] -= cp_[j - 1] * x[j];
    }
};

double colour_residual(const Eigen::Matrix3Xd& C, const Eigen::VectorXd& s,
                       const Eigen::Vector3d& v) {
    return (C * s - v).cwiseAbs().maxCoeff();
}

}  // namespace

bool project_dual_newton(const Eigen::Matrix3Xd& C, const Eigen::VectorXd& s0,
                         const Eigen::Vector3d& v, Eigen::VectorXd& s, int* iterations) {
    const Eigen::Index N = C.cols();
    Eigen::Vector3d mu = Eigen::Vector3d::Zero();
    auto primal = [&](const Eigen::Vector3d& m) {
        return (s0 + C.transpose() * m).cwiseMax(0.0).cwiseMin(1.0).eval();
    };
    // Dual function (concave, maximised): min over the box of the Lagrangian.
    auto dual = [&](const Eigen::Vector3d& m, const Eigen::VectorXd& sm) {
        return 0.5 * (sm - s0).squaredNorm() - m.dot(C * sm - v);
    };
    const double cscale = C.cwiseAbs().rowwise().sum().maxCoeff();
    s = primal(mu);
    double theta = dual(mu, s);
    int it = 0;
    bool converged = false;
    // Stop at |F| <= 1e-12 (the polish below takes it to rounding: near the solution the dual
    // function is flat to double precision, so the line search cannot see further progress), or
    // after a full Newton step that kept the free set (that step solved the final linear system).
    std::vector<char> free_prev;
    bool full_step = false;
    for (; it < 100; ++it) {
        const Eigen::Vector3d F = C * s - v;
        const Eigen::VectorXd z = s0 + C.transpose() * mu;
        std::vector<char> free(static_cast<size_t>(N));
        for (Eigen::Index k = 0; k < N; ++k) free[static_cast<size_t>(k)] = z[k] > 0 && z[k] < 1;
        if (F.cwiseAbs().maxCoeff() <= 1e-12 * std::max(1.0, cscale) ||
            (full_step && free == free_prev)) {
            converged = true;
            break;
        }
        free_prev = free;
        Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
        for (Eigen::Index k = 0; k < N; ++k)
            if (free[static_cast<size_t>(k)]) J += C.col(k) * C.col(k).transpose();
        // A free set too small for rank 3 (or empty): regularise; the line search keeps it safe.
        const double reg = 1e-12 * std::max(J.trace(), 1e-300) + 1e-300;
        const Eigen::Vector3d d = (J + reg * Eigen::Matrix3d::Identity()).ldlt().solve(-F);
        const double slope = -F.dot(d);  // directional derivative of the dual (its gradient is -F)
        if (!d.allFinite() || !(slope > 0)) break;
        double t = 1;
        bool moved = false;
        for (int ls = 0; ls < 60; ++ls, t *= 0.5) {
            const Eigen::Vector3d mt = mu + t * d;
            const Eigen::VectorXd st = primal(mt);
            const double th = dual(mt, st);
            if (th >= theta + 1e-4 * t * slope) {
                mu = mt, s = st, theta = th, moved = true, full_step = ls == 0;
                break;
            }
        }
        if (!moved) break;
    }
    if (iterations) *iterations += it;
    // Polish: the equality system on the final free set (a Newton step with the exact Jacobian
    // lands on the solution only up to rounding of mu; re-solving for s_F directly gives
    // rounding-level colour error).
    const Eigen::VectorXd z = s0 + C.transpose() * mu;
    std::vector<char> free(static_cast<size_t>(N));
    for (Eigen::Index k = 0; k < N; ++k) free[static_cast<size_t>(k)] = z[k] > 0 && z[k] < 1;
    TridiagonalHessian I;
    I.size = N;
    FreeSystem sys(C, I, free);
    if (sys.ok()) {
        Eigen::VectorXd sp = s;
        Eigen::Vector3d m;
        sys.solve(I, -s0, v, sp, m);
        sp = sp.cwiseMax(0.0).cwiseMin(1.0);
        if (colour_residual(C, sp, v) <= colour_residual(C, s, v)) s = sp;
    }
    return converged || colour_residual(C, s, v) <= 1e-13;
}

bool solve_pdas(const Eigen::Matrix3Xd& C, const TridiagonalHessian& H, const Eigen::VectorXd& q,
                const Eigen::Vector3d& v, Eigen::VectorXd& s, int* iterations,
                std::vector<char>* active) {
    const Eigen::Index N = C.cols();
    double maxdiag = 0;
    for (Eigen::Index k = 0; k < N; ++k) maxdiag = std::max(maxdiag, H.diag(k));
    const double c = 1.0 / maxdiag;
    std::vector<char> state(static_cast<size_t>(N), 0);  // 0 free, 1 at 0, 2 at 1
    if (active && active->size() == state.size()) state = *active;
    s = Eigen::VectorXd::Zero(N);
    for (int it = 0; it < 80; ++it) {
        std::vector<char> free(static_cast<size_t>(N));
        for (Eigen::Index k = 0; k < N; ++k) {
            free[static_cast<size_t>(k)] = state[static_cast<size_t>(k)] == 0;
            if (state[static_cast<size_t>(k)] == 1) s[k] = 0;
            if (state[static_cast<size_t>(k)] == 2) s[k] = 1;
        }
        const FreeSystem sys(C, H, free);
        if (!sys.ok()) return false;
        Eigen::Vector3d mu;
        sys.solve(H, q, v, s, mu);
        if (iterations) ++*iterations;
        const Eigen::VectorXd g = H.times(s) + q - C.transpose() * mu;
        bool changed = false;
        for (Eigen::Index k = 0; k < N; ++k) {
            const double y = s[k] - c * g[k];
            const char ns = y < 0 ? 1 : (y > 1 ? 2 : 0);
            changed |= ns != state[static_cast<size_t>(k)];
            state[static_cast<size_t>(k)] = ns;
        }
        if (!changed) {
            s = s.cwiseMax(0.0).cwiseMin(1.0);
            if (active) *active = state;
            return true;
        }
    }
    return false;
}

Eigen::VectorXd solve_vertex_qp(const Eigen::Matrix3Xd& C, const TridiagonalHessian& H,
                                const Eigen::VectorXd& q, const Eigen::Vector3d& v,
                                double tolerance, const std::string& what, VertexQpStats* stats,
                                std::vector<char>* warm) {
    const Eigen::Index N = C.cols();
    Eigen::VectorXd s;
    int it = 0;
    const bool projection = H.d.empty() && H.alpha == 1.0;
    bool ok = false;
    if (projection) {
        ok = project_dual_newton(C, -q, v, s, &it);
    } else {
        ok = solve_pdas(C, H, q, v, s, &it, warm);
        if (!ok && warm && !warm->empty()) {  // a poor warm start: once more from all free
            warm->clear();
            ok = solve_pdas(C, H, q, v, s, &it, warm);
        }
    }
    if (stats) stats->iterations += it;
    auto good = [&](const Eigen::VectorXd& x) {
        return x.size() == N && x.allFinite() && x.minCoeff() >= 0 && x.maxCoeff() <= 1 &&
               colour_residual(C, x, v) <= tolerance;
    };
    if (ok && good(s)) return s;

    // Fallback: the general solver, which also certifies infeasibility.
    if (stats) stats->used_fallback = true;
    QpProblem p;
    std::vector<Eigen::Triplet<double>> tp, ta;
    for (Eigen::Index k = 0; k < N; ++k) {
        tp.emplace_back(k, k, H.diag(k));
        if (!H.d.empty() && k + 1 < N)
            tp.emplace_back(k, k + 1, H.off(k)), tp.emplace_back(k + 1, k, H.off(k));
        for (int c = 0; c < 3; ++c) ta.emplace_back(c, k, C(c, k));
    }
    p.P.resize(N, N);
    p.P.setFromTriplets(tp.begin(), tp.end());
    p.A.resize(3, N);
    p.A.setFromTriplets(ta.begin(), ta.end());
    p.q = q;
    p.b = v;
    p.lower = Eigen::VectorXd::Zero(N);
    p.upper = Eigen::VectorXd::Ones(N);
    const QpResult r = solve_qp(p);
    char buf[160];
    if (r.status == QpStatus::Infeasible) {
        std::snprintf(buf, sizeof buf,
                      ": no reflectance in [0, 1] has this colour (least-squares miss %.3g)",
                      colour_residual(C, r.x, v));
        throw Error(what + buf);
    }
    if (r.status == QpStatus::Solved) {
        Eigen::VectorXd x = r.x.cwiseMax(0.0).cwiseMin(1.0);
        if (good(x)) return x;
    }
    std::snprintf(buf, sizeof buf,
                  ": no exact vertex spectrum (fast method %s, solve_qp %s, residual %.3g)",
                  ok ? "inexact" : "failed", to_string(r.status),
                  r.x.size() == N ? colour_residual(C, r.x, v) : -1.0);
    throw Error(what + buf);
}

}  // namespace spectex
