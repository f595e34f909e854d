// Internals of solve_qp (qp_solver.h), shared by the files that implement it:
//   qp_scaling.cpp         Ruiz equilibration and the residuals in the user's units
//   qp_interior_point.cpp  Mehrotra predictor-corrector interior-point method (InteriorPoint)
//   qp_polish.cpp          active-set polish of an interior-point iterate (InteriorPoint)
//   qp_infeasibility.cpp   phase-1 solve and Farkas certificate of infeasibility
//   qp_solver.cpp          the driver: checks, fixed variables, scaling, IPM, verdict
// Private to those files; everything else uses qp_solver.h.
#pragma once

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "spectral/qp_solver.h"

namespace spectex::qp_detail {

using Eigen::Index;
using SpMat = Eigen::SparseMatrix<double>;
using Vec = Eigen::VectorXd;
using Triplet = Eigen::Triplet<double>;
using Ldlt = Eigen::SimplicialLDLT<SpMat, Eigen::Lower, Eigen::AMDOrdering<int>>;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();

// ---- Tuning constants (all for the equilibrated problem) ---------------------------------------
constexpr int kRuizIterations = 15;
constexpr double kRuizMin = 1e-4, kRuizMax = 1e4;  // per-iteration clamp of a Ruiz factor
// Static regularisation of the KKT matrices. The (1,1) block gets kRegRelative times its own
// diagonal plus kRegFloor, so that variables with a small but real curvature are not swamped
// (refinement contracts like reg / (curvature + reg)); only variables without any curvature
// (LP-like) see the floor. The (2,2) block gets -kRegDual. All are raised 100x at a time when a
// factorisation fails or is too inaccurate, up to kRegRetries times.
constexpr double kRegRelative = 1e-10;
constexpr double kRegFloor = 1e-12;
constexpr double kRegDual = 1e-9;
constexpr int kRegRetries = 4;
constexpr int kIpmRefineSteps = 20;      // iterative refinement of a Newton solve (cap)
constexpr double kNewtonEta = 1e-12;     // normwise backward error of a Newton solve: fine
constexpr double kNewtonEtaMax = 1e-6;   // ... and the worst one still used
constexpr double kStepFraction = 0.995;  // fraction to the boundary
constexpr double kPolishStart = 1e-6;    // try the polish once the IPM measure is this small
constexpr int kPolishRefineSteps = 60;   // refinement (proximal) steps of a reduced solve (cap)
constexpr double kPolishEta = 1e-14;     // backward error after which no larger reg is tried
constexpr int kPolishRounds = 30;        // active-set corrections per polish attempt
constexpr int kPolishPatience = 4;       // rounds without a new fewest-changes record

inline double norm_inf(const Vec& v) { return v.size() == 0 ? 0.0 : v.lpNorm<Eigen::Infinity>(); }

// M restricted to the rows/columns whose map entry is >= 0, renumbered by the maps.
SpMat extract(const SpMat& M, const std::vector<Index>& row_map, Index rows,
              const std::vector<Index>& col_map, Index cols);

// ---- Residuals in the user's units -------------------------------------------------------------
struct Metrics {
    double eq = 0, viol = 0, dual = 0, comp = 0;   // absolute
    double scale_p = 1, scale_d = 1, scale_c = 1;  // for the relative test
    bool meets(double tol) const {
        return std::isfinite(eq) && std::isfinite(dual) && std::isfinite(comp) && viol == 0.0 &&
               eq <= tol * scale_p && dual <= tol * scale_d && comp <= tol * scale_c;
    }
};

Metrics evaluate(const SpMat& P, const Vec& q, const SpMat& A, const Vec& b, const Vec& l,
                 const Vec& u, const Vec& x, const Vec& y, const Vec& zl, const Vec& zu);

// ---- Ruiz equilibration with power-of-two factors ----------------------------------------------
// x = D xs, rows scaled by E, cost by c:  Ps = c D P D, qs = c D q, As = E A D, bs = E b,
// ls = l / D, us = u / D.  Back: y = E ys / c, z = zs / (c D).  All exact (powers of two).
struct Scaled {
    SpMat P, A;
    Vec q, b, l, u;
    Vec D, E;
    double c = 1.0;
};

Scaled equilibrate(const SpMat& P, const Vec& q, const SpMat& A, const Vec& b, const Vec& l,
                   const Vec& u);

// Iterative refinement of K d = rhs with a factorisation of a (regularised) approximation of K.
// `d` holds the starting point. Progress is measured by the componentwise backward error
//   omega = max_i |rhs - K d|_i / (|K| |d| + |rhs|)_i,
// so that every row, however small its terms, is solved to rounding relative to them.
// apply(d, kd, kabs) must set kd = K d and kabs = |K| |d|. A step is kept only if omega drops.
struct SolveQuality {
    double omega;  // componentwise backward error
    double eta;    // normwise backward error ||res|| / (|| |K||d| || + ||rhs||)
};

template <class Apply>
SolveQuality refine(const Ldlt& f, const Apply& apply, const Vec& rhs, Vec& d, int max_steps) {
    Vec kd, kabs;
    auto omega = [&](const Vec& x, Vec& res) {
        apply(x, kd, kabs);
        res = rhs - kd;
        double w = 0.0;
        for (Index i = 0; i < res.size(); ++i) {
            const double den = kabs[i] + std::abs(rhs[i]);
            if (res[i] != 0.0) w = std::max(w, den > 0.0 ? std::abs(res[i]) / den : kInf);
        }
        return w;
    };
    Vec res, tres;
    double w = omega(d, res), rn = norm_inf(res);
    int k = 0;
    for (; k < max_steps && w > kEps; ++k) {
        Vec trial = d + f.solve(res);
        const double tw = omega(trial, tres), tn = norm_inf(tres);
        // Also accept a large normwise gain: if the system is inconsistent in some rows (an
        // unbounded reduced problem during the active-set search), omega cannot improve but
        // the consistent part still converges.
        if (!(tw < w || tn < 0.5 * rn)) break;
        const bool slow = tw > 0.9 * w && tn > 0.9 * rn;
        d.swap(trial);
        res.swap(tres);
        w = tw;
        rn = tn;
        if (slow) break;
    }
    apply(d, kd, kabs);
    const double den = norm_inf(kabs) + norm_inf(rhs);
    const SolveQuality quality{w, den > 0 ? rn / den : (rn > 0 ? kInf : 0.0)};
    return quality;
}

// Called with a scaled candidate (x, y, z_lower, z_upper, polished); returns true if it meets
// the tolerance in the user's units (and then keeps it).
using AcceptFn = std::function<bool(const Vec&, const Vec&, const Vec&, const Vec&, bool)>;

enum class Outcome { Accepted, MaxIterations, NumericalError, SuspectInfeasible };

// Mehrotra predictor-corrector IPM on the equilibrated problem, with the active-set polish.
class InteriorPoint {
  public:
    InteriorPoint(const Scaled& s, const QpOptions& opt, AcceptFn accept);

    Outcome run(bool watch_infeasibility);
    int iterations() const { return iter_; }
    const Vec& x() const { return x_; }
    const Vec& y() const { return y_; }
    const Vec& zl() const { return zl_; }
    const Vec& zu() const { return zu_; }

  private:
    void build_pattern();
    bool factor(const Vec& hd);
    SolveQuality newton_solve(const Vec& hd, const Vec& r1, const Vec& r2, Vec& dx, Vec& dy) const;
    bool direction_solve(const Vec& hd, const Vec& r1, const Vec& r2, Vec& dx, Vec& dy);
    bool initial_point();
    bool try_polish(double measure);
    bool polish_from(std::vector<signed char> cls);
    bool solve_reduced(const std::vector<signed char>& cls, Vec& xp, Vec& yp) const;

    const Scaled& s_;
    QpOptions opt_;
    AcceptFn accept_;
    Index n_, m_;
    Vec mL_, mU_, l0_, u0_;  // bound masks, bounds with infinities replaced by 0
    double nb_ = 0;          // number of finite bounds
    Vec x_, y_, zl_, zu_;
    Vec prev_x_, prev_y_, prev_zl_, prev_zu_;  // restored if a step turns non-finite
    SpMat absP_, absA_;                        // |P|, |A|, for the relative accuracy measures
    SpMat K_;                                  // lower triangle of [P + diag + reg, A'; A, -reg]
    std::vector<Index> diag_pos_;              // positions of the diagonal entries in K_'s values
    Vec pdiag_;                                // diagonal of P
    Ldlt ldlt_;
    double reg_scale_ = 1.0;  // multiplies the regularisation; raised when a solve is poor
    bool started_ = false;
    int iter_ = 0;
    int tiny_steps_ = 0;
    std::vector<double> rp_hist_;
    double last_measure_ = 0.0;  // IPM accuracy measure at the last polish attempt
};

// The whole solve; phase 1 (prove_infeasible) calls it again on its own problem, without phase 1.
QpResult solve_impl(const QpProblem& pr, const QpOptions& opt, bool allow_phase1);

// Phase 1 and the Farkas certificate (qp_infeasibility.cpp): true, with `out` filled, if every
// box point misses A x = b by more than the tolerance.
bool prove_infeasible(const QpProblem& pr, const SpMat& Psym, const QpOptions& opt, QpResult& out);

}  // namespace spectex::qp_detail
