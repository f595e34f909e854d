// Tests of spectex::solve_qp (src/spectral/qp_solver.h).
//
// Optimality is checked independently of the solver's own residual fields: for a convex QP,
// primal feasibility + stationarity + complementarity + nonnegative bound multipliers
// (the KKT conditions) certify that x is a minimiser, so most tests recompute them here.
#include "spectral/qp_solver.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

namespace {

using spectex::QpOptions;
using spectex::QpProblem;
using spectex::QpResult;
using spectex::QpStatus;
using SpMat = Eigen::SparseMatrix<double>;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using Triplets = std::vector<Eigen::Triplet<double>>;

constexpr double kInf = std::numeric_limits<double>::infinity();

double inf_norm(const VectorXd& v) { return v.size() ? v.lpNorm<Eigen::Infinity>() : 0.0; }

SpMat sparse(int rows, int cols, const Triplets& t) {
    SpMat m(rows, cols);
    m.setFromTriplets(t.begin(), t.end());
    return m;
}

// KKT quantities of (x, y, z_lower, z_upper), recomputed from the problem data.
struct Kkt {
    double eq = 0, eq_scale = 1;      // ||Ax - b||, max(1, ||b||)
    double viol = 0;                  // max bound violation
    double stat = 0, stat_scale = 1;  // ||Px + q - A'y - zl + zu||, max(1, |terms|)
    double comp = 0, comp_scale = 1;  // max z_i * slack_i, max(1, |q'x|, x'Px)
    double min_z = 0;                 // most negative bound multiplier
    double z_off = 0;                 // largest multiplier on an infinite bound (must be 0)
};

Kkt kkt(const QpProblem& p, const QpResult& r) {
    Kkt k;
    const VectorXd Ax = p.A * r.x, Px = p.P * r.x, Aty = p.A.transpose() * r.y;
    k.eq = inf_norm(Ax - p.b);
    k.eq_scale = std::max(1.0, inf_norm(p.b));
    k.stat = inf_norm(Px + p.q - Aty - r.z_lower + r.z_upper);
    k.stat_scale = std::max({1.0, inf_norm(p.q), inf_norm(Px), inf_norm(Aty), inf_norm(r.z_lower),
                             inf_norm(r.z_upper)});
    k.comp_scale = std::max({1.0, std::abs(p.q.dot(r.x)), std::abs(r.x.dot(Px))});
    for (Eigen::Index i = 0; i < r.x.size(); ++i) {
        k.min_z = std::min({k.min_z, r.z_lower[i], r.z_upper[i]});
        if (std::isfinite(p.lower[i])) {
            k.viol = std::max(k.viol, p.lower[i] - r.x[i]);
            k.comp = std::max(k.comp, r.z_lower[i] * (r.x[i] - p.lower[i]));
        } else {
            k.z_off = std::max(k.z_off, std::abs(r.z_lower[i]));
        }
        if (std::isfinite(p.upper[i])) {
            k.viol = std::max(k.viol, r.x[i] - p.upper[i]);
            k.comp = std::max(k.comp, r.z_upper[i] * (p.upper[i] - r.x[i]));
        } else {
            k.z_off = std::max(k.z_off, std::abs(r.z_upper[i]));
        }
    }
    return k;
}

// The accuracy target of a polished solution: everything at the level of double rounding.
// 1e-12 relative leaves ~100 ulps of headroom for sums over ~1000 terms (||b|| ~ 200 for the
// colour rows at N = 941); the bounds are met exactly because the polish clips to them.
void expect_kkt_at_rounding_level(const QpProblem& p, const QpResult& r) {
    ASSERT_EQ(r.status, QpStatus::Solved) << spectex::to_string(r.status);
    ASSERT_EQ(r.x.size(), p.q.size());
    ASSERT_EQ(r.y.size(), p.b.size());
    ASSERT_TRUE(r.x.allFinite() && r.y.allFinite() && r.z_lower.allFinite() &&
                r.z_upper.allFinite());
    const Kkt k = kkt(p, r);
    EXPECT_LE(k.eq, 1e-12 * k.eq_scale) << "||Ax - b||_inf, rounding-level target";
    EXPECT_EQ(k.viol, 0.0) << "bounds must hold exactly (polished x is clipped)";
    EXPECT_LE(k.stat, 1e-12 * k.stat_scale) << "stationarity, rounding-level target";
    EXPECT_LE(k.comp, 1e-12 * k.comp_scale) << "complementarity, rounding-level target";
    EXPECT_GE(k.min_z, 0.0) << "bound multipliers are reported clamped to >= 0";
    EXPECT_EQ(k.z_off, 0.0) << "no multiplier on an infinite bound";
    // The solver's own residual fields describe the same (x, y, z): same quantities up to the
    // summation order, hence a loose relative agreement of 1e-12 of the scale.
    EXPECT_NEAR(r.primal_residual, std::max(k.eq, k.viol), 1e-12 * k.eq_scale);
    EXPECT_NEAR(r.dual_residual, k.stat, 1e-12 * k.stat_scale);
}

// ---- The spectral primary decomposition problem, built synthetically -------------------------
//
// N wavelengths over 380..780 nm, x = [S_r; S_g; S_b], 0 <= x <= 1,
//   N rows   S_r(i) + S_g(i) + S_b(i) = 1,
//   9 rows   sum_i W[c][i] S_k(i) = T[c][k]  (k in r,g,b; c in X,Y,Z),
// W = Gaussian bumps at 600/550/450 nm (sigma 40 nm), T = W S* for a feasible S* made of
// smoothsteps that is 0 or 1 on most of the range. Summing the colour rows over k gives W * 1,
// which the sum-to-one rows already imply: the N + 9 rows have rank N + 6, exactly like the
// real problem (and b is consistent with that only up to rounding).
enum class Objective { Norm, Smooth };

double smoothstep(double e0, double e1, double v) {
    const double t = std::clamp((v - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

struct Spectral {
    QpProblem qp;
    MatrixXd W;      // 3 x N
    MatrixXd S;      // N x 3, the feasible reference basis
    MatrixXd T;      // 3 x 3, T(c, k)
    VectorXd x_ref;  // S stacked as [S_r; S_g; S_b]
};

SpMat spectral_objective(int N, Objective obj) {
    Triplets t;
    for (int k = 0; k < 3; ++k) {
        for (int i = 0; i < N; ++i) {
            const int j = k * N + i;
            if (obj == Objective::Norm) {
                t.emplace_back(j, j, 1.0);
                continue;
            }
            // D'D for the first-difference matrix D: tridiagonal, constants in its null space.
            t.emplace_back(j, j, (i == 0 || i == N - 1) ? 1.0 : 2.0);
            if (i + 1 < N) {
                t.emplace_back(j, j + 1, -1.0);
                t.emplace_back(j + 1, j, -1.0);
            }
        }
    }
    return sparse(3 * N, 3 * N, t);
}

Spectral make_spectral(int N, Objective obj, double target_scale = 1.0) {
    Spectral s;
    s.W.resize(3, N);
    s.S.resize(N, 3);
    const double centre[3] = {600.0, 550.0, 450.0};
    for (int i = 0; i < N; ++i) {
        const double lambda = 380.0 + 400.0 * i / (N - 1);
        for (int c = 0; c < 3; ++c)
            s.W(c, i) = std::exp(-0.5 * std::pow((lambda - centre[c]) / 40.0, 2));
        s.S(i, 2) = 1.0 - smoothstep(440.0, 510.0, lambda);
        s.S(i, 0) = smoothstep(560.0, 630.0, lambda);
        s.S(i, 1) = 1.0 - s.S(i, 0) - s.S(i, 2);
    }
    s.T = s.W * s.S;
    s.x_ref.resize(3 * N);
    for (int k = 0; k < 3; ++k) s.x_ref.segment(k * N, N) = s.S.col(k);

    Triplets t;
    for (int i = 0; i < N; ++i)
        for (int k = 0; k < 3; ++k) t.emplace_back(i, k * N + i, 1.0);
    for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < N; ++i) t.emplace_back(N + 3 * k + c, k * N + i, s.W(c, i));
    s.qp.A = sparse(N + 9, 3 * N, t);
    s.qp.b.resize(N + 9);
    s.qp.b.head(N).setOnes();
    for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) s.qp.b[N + 3 * k + c] = target_scale * s.T(c, k);
    s.qp.P = spectral_objective(N, obj);
    s.qp.q = VectorXd::Zero(3 * N);
    s.qp.lower = VectorXd::Zero(3 * N);
    s.qp.upper = VectorXd::Ones(3 * N);
    return s;
}

double objective(const QpProblem& p, const VectorXd& x) {
    return 0.5 * x.dot(p.P * x) + p.q.dot(x);
}

// ---- Tests --------------------------------------------------------------------------------------

TEST(QpSolver, TinyHandSolvable) {
    // min 0.5||x - c||^2, c = (2, 0.75, -0.5), s.t. x1 + x2 + x3 = 1.25, 0 <= x <= 1.
    // KKT by hand: x = (1, 0.25, 0), y = -0.5, z_upper1 = 0.5, z_lower3 = 1 (strictly
    // complementary, unique since P = I). All values are exact binary fractions.
    QpProblem p;
    p.P = sparse(3, 3, {{0, 0, 1.0}, {1, 1, 1.0}, {2, 2, 1.0}});
    p.q = -VectorXd((VectorXd(3) << 2.0, 0.75, -0.5).finished());
    p.A = sparse(1, 3, {{0, 0, 1.0}, {0, 1, 1.0}, {0, 2, 1.0}});
    p.b = VectorXd::Constant(1, 1.25);
    p.lower = VectorXd::Zero(3);
    p.upper = VectorXd::Ones(3);
    const QpResult r = spectex::solve_qp(p);
    expect_kkt_at_rounding_level(p, r);
    EXPECT_TRUE(r.polished);
    // Polished values come from a linear solve with data of unit size: a few ulps.
    EXPECT_NEAR(r.x[0], 1.0, 4e-16);
    EXPECT_NEAR(r.x[1], 0.25, 4e-16);
    EXPECT_NEAR(r.x[2], 0.0, 4e-16);
    EXPECT_NEAR(r.y[0], -0.5, 4e-16);
    EXPECT_NEAR(r.z_upper[0], 0.5, 4e-16);
    EXPECT_NEAR(r.z_lower[2], 1.0, 4e-16);
    EXPECT_EQ(r.z_lower[0], 0.0);  // free or upper-active: exactly zero lower multipliers
    EXPECT_EQ(r.z_lower[1], 0.0);
    EXPECT_EQ(r.z_upper[1], 0.0);
}

TEST(QpSolver, SpectralNormObjective) {
    for (int N : {81, 401, 941}) {
        SCOPED_TRACE(N);
        const Spectral s = make_spectral(N, Objective::Norm);
        const QpResult r = spectex::solve_qp(s.qp);
        expect_kkt_at_rounding_level(s.qp, r);
        EXPECT_TRUE(r.polished);
        // S* is feasible, so the optimum cannot be worse (up to rounding of the objective).
        EXPECT_LE(objective(s.qp, r.x), objective(s.qp, s.x_ref) + 1e-12);
        // Many bounds are active at the optimum (that is what the polish must get right).
        const int at_bounds = static_cast<int>((r.x.array() == 0.0 || r.x.array() == 1.0).count());
        EXPECT_GT(at_bounds, N / 2);
    }
}

TEST(QpSolver, SpectralSmoothObjectivePsd) {
    // P = D'D per spectrum is only positive SEMI-definite (constants are in its null space).
    for (int N : {81, 401, 941}) {
        SCOPED_TRACE(N);
        const Spectral s = make_spectral(N, Objective::Smooth);
        const QpResult r = spectex::solve_qp(s.qp);
        expect_kkt_at_rounding_level(s.qp, r);
        EXPECT_TRUE(r.polished);
        EXPECT_LE(objective(s.qp, r.x), objective(s.qp, s.x_ref) + 1e-12);
    }
}

TEST(QpSolver, ManyActiveBoundsMatchClosedForm) {
    // Projection of c onto {sum x = s, 0 <= x <= 1}: x_i = clamp(c_i - tau, 0, 1) with tau
    // solving sum = s (found by bisection here, independently of the solver). With
    // c_i = 3 sin(i) most coordinates end up at 0 or 1.
    const int n = 300;
    VectorXd c(n);
    for (int i = 0; i < n; ++i) c[i] = 3.0 * std::sin(static_cast<double>(i));
    const double total = 70.0;
    Triplets tp, ta;
    for (int i = 0; i < n; ++i) tp.emplace_back(i, i, 1.0), ta.emplace_back(0, i, 1.0);
    QpProblem p;
    p.P = sparse(n, n, tp);
    p.q = -c;
    p.A = sparse(1, n, ta);
    p.b = VectorXd::Constant(1, total);
    p.lower = VectorXd::Zero(n);
    p.upper = VectorXd::Ones(n);

    double lo = -10.0, hi = 10.0;
    for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        const double sum = (c.array() - mid).max(0.0).min(1.0).sum();
        (sum > total ? lo : hi) = mid;
    }
    const double tau = 0.5 * (lo + hi);
    const VectorXd x_ref = (c.array() - tau).max(0.0).min(1.0).matrix();

    const QpResult r = spectex::solve_qp(p);
    expect_kkt_at_rounding_level(p, r);
    // Strictly convex: the minimiser is unique; bisection gives tau to ~1 ulp and the map
    // tau -> x is 1-Lipschitz, so 1e-14 (far above both errors, far below any real mistake).
    EXPECT_LE(inf_norm(r.x - x_ref), 1e-14);
    int active = 0;
    for (int i = 0; i < n; ++i) {
        const bool at_bound = r.x[i] == 0.0 || r.x[i] == 1.0;
        active += at_bound;
        // Complementarity coordinate by coordinate: a positive multiplier only at its bound
        // (exactly, since the polish fixes active variables at their bounds).
        if (r.z_lower[i] > 0) {
            EXPECT_EQ(r.x[i], 0.0) << i;
        }
        if (r.z_upper[i] > 0) {
            EXPECT_EQ(r.x[i], 1.0) << i;
        }
        // Multiplier of an active bound: z = -(x - c - y) with y = -tau, from O(1) data, so a
        // few ulps; 1e-13 also absorbs the bisection error in tau.
        if (r.x[i] == 0.0) {
            EXPECT_NEAR(r.z_lower[i], std::max(0.0, tau - c[i]), 1e-13) << i;
        }
        if (r.x[i] == 1.0) {
            EXPECT_NEAR(r.z_upper[i], std::max(0.0, c[i] - tau - 1.0), 1e-13) << i;
        }
    }
    EXPECT_GT(active, 2 * n / 3);
}

// Least-squares "closest" form with free residual variables:
//   min ||r||^2 + x_weight * 0.5 x'P_obj x  s.t.  C x - r = t,  sum-to-one rows,  0 <= x <= 1,
// r free. With x_weight = 0, P = diag(0, 2 I) is singular on x, so x is not unique; only KKT
// can be checked, plus r. (basis_fit's least-squares phase uses x_weight = 1e-9.)
QpProblem closest_form(const Spectral& s, int N, double target_scale, double x_weight = 0.0,
                       Objective obj = Objective::Norm) {
    QpProblem p;
    const int n = 3 * N + 9;
    Triplets tp, ta;
    if (x_weight > 0) {
        const SpMat Pobj = spectral_objective(N, obj);
        for (int j = 0; j < Pobj.outerSize(); ++j)
            for (SpMat::InnerIterator e(Pobj, j); e; ++e)
                tp.emplace_back(e.row(), j, x_weight * e.value());
    }
    for (int j = 3 * N; j < n; ++j) tp.emplace_back(j, j, 2.0);
    for (int i = 0; i < N; ++i)
        for (int k = 0; k < 3; ++k) ta.emplace_back(i, k * N + i, 1.0);
    for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) {
            const int row = N + 3 * k + c;
            for (int i = 0; i < N; ++i) ta.emplace_back(row, k * N + i, s.W(c, i));
            ta.emplace_back(row, 3 * N + 3 * k + c, -1.0);
        }
    p.P = sparse(n, n, tp);
    p.q = VectorXd::Zero(n);
    p.A = sparse(N + 9, n, ta);
    p.b.resize(N + 9);
    p.b.head(N).setOnes();
    for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) p.b[N + 3 * k + c] = target_scale * s.T(c, k);
    p.lower = VectorXd::Zero(n);
    p.upper = VectorXd::Ones(n);
    p.lower.tail(9).setConstant(-kInf);
    p.upper.tail(9).setConstant(kInf);
    return p;
}

TEST(QpSolver, FreeVariablesLeastSquaresClosestForm) {
    const int N = 81;
    const Spectral s = make_spectral(N, Objective::Norm);
    {
        // Reachable targets: the optimum has r = 0 (S* attains it).
        const QpProblem p = closest_form(s, N, 1.0);
        const QpResult r = spectex::solve_qp(p);
        expect_kkt_at_rounding_level(p, r);
        // r = Cx - t is a residual of data of size ||t|| ~ 30: rounding level is ~1e-14.
        EXPECT_LE(inf_norm(r.x.tail(9)), 1e-12 * inf_norm(p.b));
    }
    {
        // Unreachable targets (3x): r != 0 at the optimum, and the solution is still exact.
        const QpProblem p = closest_form(s, N, 3.0);
        const QpResult r = spectex::solve_qp(p);
        expect_kkt_at_rounding_level(p, r);
        EXPECT_GT(inf_norm(r.x.tail(9)), 1.0);  // far from reachable: residual of order ||T||
        // Stationarity in the free r_j (column -1 in colour row N + j): 2 r_j + y_{N+j} = 0,
        // checked to the same rounding-level tolerance as the rest of the KKT system.
        for (int j = 0; j < 9; ++j)
            EXPECT_NEAR(2.0 * r.x[3 * N + j] + r.y[N + j], 0.0, 1e-12 * inf_norm(p.b));
        // Optimality against the feasible point (S*, r = C S* - 3T).
        VectorXd x0(3 * N + 9);
        x0.head(3 * N) = s.x_ref;
        for (int k = 0; k < 3; ++k)
            for (int c = 0; c < 3; ++c) x0[3 * N + 3 * k + c] = s.T(c, k) - 3.0 * s.T(c, k);
        EXPECT_LE(objective(p, r.x), objective(p, x0));
    }
}

TEST(QpSolver, LeastSquaresPhaseWithTinyCurvature) {
    // The shape of basis_fit's fallback when the exact fit is infeasible: ||r||^2 plus 1e-9 of
    // the fitting objective on x (to pick one minimiser). The x curvature is 1e-9 of everything
    // else, which a fixed regularisation of the same size would swamp (this failed once).
    for (int N : {11, 41, 81, 401}) {
        for (Objective obj : {Objective::Norm, Objective::Smooth}) {
            SCOPED_TRACE(testing::Message()
                         << "N=" << N << (obj == Objective::Norm ? " norm" : " smooth"));
            const Spectral s = make_spectral(N, obj);
            const QpProblem p = closest_form(s, N, 3.0, 1e-9, obj);
            const QpResult r = spectex::solve_qp(p);
            expect_kkt_at_rounding_level(p, r);
            EXPECT_TRUE(r.polished);
            EXPECT_GT(inf_norm(r.x.tail(9)), 1.0);  // the 3x targets stay unreachable
        }
    }
}

TEST(QpSolver, InfeasibleColourTargets) {
    // T scaled by 3: the colour rows summed over k ask W*1 = 3 W*1, impossible.
    for (Objective obj : {Objective::Norm, Objective::Smooth}) {
        const Spectral s = make_spectral(81, obj, 3.0);
        const QpResult r = spectex::solve_qp(s.qp);
        EXPECT_EQ(r.status, QpStatus::Infeasible) << spectex::to_string(r.status);
        ASSERT_TRUE(r.x.allFinite() && r.y.allFinite());
        EXPECT_TRUE(r.z_lower.allFinite() && r.z_upper.allFinite());
        // The returned x is the box point closest to A x = b: inside the box, far from b.
        EXPECT_GE(r.x.minCoeff(), 0.0);
        EXPECT_LE(r.x.maxCoeff(), 1.0);
        EXPECT_GT(r.primal_residual, 1.0);
        EXPECT_TRUE(std::isfinite(r.dual_residual) && std::isfinite(r.complementarity));
        // y is a Farkas certificate; verify it independently: for every S in the box [0, 1],
        //   ||A S - b||_inf >= (y'b - sum_i max(0, (A'y)_i)) / ||y||_1.
        // A positive bound of order one (the targets are off by 2 T) proves infeasibility
        // with a margin far above any rounding in these sums (~1e-13).
        const VectorXd aty = s.qp.A.transpose() * r.y;
        const double h = r.y.dot(s.qp.b) - aty.cwiseMax(0.0).sum();
        EXPECT_GT(h / r.y.lpNorm<1>(), 1e-3);
    }
}

TEST(QpSolver, InfeasibleBox) {
    // x1 + x2 = 3 with 0 <= x <= 1: consistent equations, empty intersection with the box.
    QpProblem p;
    p.P = sparse(2, 2, {{0, 0, 1.0}, {1, 1, 1.0}});
    p.q = VectorXd::Zero(2);
    p.A = sparse(1, 2, {{0, 0, 1.0}, {0, 1, 1.0}});
    p.b = VectorXd::Constant(1, 3.0);
    p.lower = VectorXd::Zero(2);
    p.upper = VectorXd::Ones(2);
    QpResult r = spectex::solve_qp(p);
    EXPECT_EQ(r.status, QpStatus::Infeasible);
    ASSERT_TRUE(r.x.allFinite());
    // Closest box point is (1, 1) with residual exactly 1 (polished phase 1: exact values).
    EXPECT_NEAR(r.x[0], 1.0, 1e-15);
    EXPECT_NEAR(r.x[1], 1.0, 1e-15);
    EXPECT_NEAR(r.primal_residual, 1.0, 1e-15);

    // An empty box (lower > upper) is infeasible without any iteration.
    p.lower[1] = 2.0;
    r = spectex::solve_qp(p);
    EXPECT_EQ(r.status, QpStatus::Infeasible);
    EXPECT_TRUE(r.x.allFinite());
}

TEST(QpSolver, RedundantDuplicatedRows) {
    // Duplicate every row, and add 2x and -0.5x copies of some rows: consistent redundancy.
    const int N = 81;
    for (Objective obj : {Objective::Norm, Objective::Smooth}) {
        const Spectral s = make_spectral(N, obj);
        const QpResult base = spectex::solve_qp(s.qp);
        ASSERT_EQ(base.status, QpStatus::Solved);

        const int m = static_cast<int>(s.qp.b.size());
        Triplets t;
        for (int j = 0; j < s.qp.A.outerSize(); ++j)
            for (SpMat::InnerIterator e(s.qp.A, j); e; ++e) {
                t.emplace_back(e.row(), j, e.value());
                t.emplace_back(m + e.row(), j, e.value());
                if (e.row() % 7 == 0) t.emplace_back(2 * m + e.row() / 7, j, 2.0 * e.value());
                if (e.row() >= N)
                    t.emplace_back(2 * m + m / 7 + 1 + (e.row() - N), j, -0.5 * e.value());
            }
        const int rows = 2 * m + m / 7 + 1 + 9;
        QpProblem p = s.qp;
        p.A = sparse(rows, 3 * N, t);
        p.b.resize(rows);
        p.b.head(m) = s.qp.b;
        p.b.segment(m, m) = s.qp.b;
        for (int i = 0; i < m; i += 7) p.b[2 * m + i / 7] = 2.0 * s.qp.b[i];
        for (int i = 0; i < 9; ++i) p.b[2 * m + m / 7 + 1 + i] = -0.5 * s.qp.b[N + i];

        const QpResult r = spectex::solve_qp(p);
        expect_kkt_at_rounding_level(p, r);
        // Same (unique) minimiser as without the copies. The smooth objective is ill-
        // conditioned (smallest nonzero eigenvalue of D'D ~ (pi/N)^2 ~ 1e-3) and the optimum is
        // degenerate, so x is determined to ~cond * eps; 1e-9 leaves a wide margin and still
        // catches any wrong active set (those move x by >> 1e-6).
        EXPECT_LE(inf_norm(r.x - base.x), 1e-9);
    }
}

TEST(QpSolver, DeterministicBytes) {
    const Spectral s = make_spectral(401, Objective::Smooth);
    const QpResult a = spectex::solve_qp(s.qp);
    const QpResult b = spectex::solve_qp(s.qp);
    ASSERT_EQ(a.status, QpStatus::Solved);
    ASSERT_EQ(a.status, b.status);
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.polished, b.polished);
    auto same_bytes = [](const VectorXd& u, const VectorXd& v) {
        return u.size() == v.size() &&
               std::memcmp(u.data(), v.data(), sizeof(double) * static_cast<size_t>(u.size())) == 0;
    };
    EXPECT_TRUE(same_bytes(a.x, b.x));
    EXPECT_TRUE(same_bytes(a.y, b.y));
    EXPECT_TRUE(same_bytes(a.z_lower, b.z_lower));
    EXPECT_TRUE(same_bytes(a.z_upper, b.z_upper));
    EXPECT_EQ(std::memcmp(&a.primal_residual, &b.primal_residual, sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(&a.dual_residual, &b.dual_residual, sizeof(double)), 0);
}

TEST(QpSolver, EqualityOnlyMatchesDenseKkt) {
    // No finite bound: one linear solve. Compare with a dense LU of the KKT matrix.
    const int n = 6, m = 2;
    MatrixXd Pd = MatrixXd::Zero(n, n);
    for (int i = 0; i < n; ++i) {
        Pd(i, i) = 2.0 + i;
        if (i + 1 < n) Pd(i, i + 1) = Pd(i + 1, i) = -1.0;
    }
    MatrixXd Ad(m, n);
    Ad << 1, 1, 1, 1, 1, 1, 1, -1, 2, 0, 0.5, 3;
    QpProblem p;
    p.P = Pd.sparseView();
    p.A = Ad.sparseView();
    p.q = VectorXd::LinSpaced(n, -1.0, 1.5);
    p.b = (VectorXd(m) << 2.0, -1.0).finished();
    p.lower = VectorXd::Constant(n, -kInf);
    p.upper = VectorXd::Constant(n, kInf);
    MatrixXd K = MatrixXd::Zero(n + m, n + m);
    K.topLeftCorner(n, n) = Pd;
    K.topRightCorner(n, m) = -Ad.transpose();
    K.bottomLeftCorner(m, n) = Ad;
    VectorXd rhs(n + m);
    rhs << -p.q, p.b;
    const VectorXd sol = K.fullPivLu().solve(rhs);
    const QpResult r = spectex::solve_qp(p);
    expect_kkt_at_rounding_level(p, r);
    // Well-conditioned 8x8 system (cond ~ 50): both solutions agree to ~cond * eps.
    EXPECT_LE(inf_norm(r.x - sol.head(n)), 1e-13);
    EXPECT_LE(inf_norm(r.y - sol.tail(m)), 1e-13);
}

TEST(QpSolver, FixedVariablesAndEmptiedRows) {
    // Fix S_g = S* (lower == upper): the sum-to-one rows keep free columns, and a row touching
    // only fixed variables (added here) must be satisfied, not break the solve.
    const int N = 81;
    Spectral s = make_spectral(N, Objective::Norm);
    s.qp.lower.segment(N, N) = s.S.col(1);
    s.qp.upper.segment(N, N) = s.S.col(1);
    QpProblem p = s.qp;
    Triplets t;
    for (int j = 0; j < p.A.outerSize(); ++j)
        for (SpMat::InnerIterator e(p.A, j); e; ++e) t.emplace_back(e.row(), j, e.value());
    const int m = static_cast<int>(p.b.size());
    t.emplace_back(m, N + 5, 1.0);
    t.emplace_back(m, N + 6, 1.0);
    p.A = sparse(m + 1, 3 * N, t);
    p.b.conservativeResize(m + 1);
    p.b[m] = s.S(5, 1) + s.S(6, 1);
    const QpResult r = spectex::solve_qp(p);
    expect_kkt_at_rounding_level(p, r);
    EXPECT_TRUE((r.x.segment(N, N).array() == s.S.col(1).array()).all());  // exactly fixed
}

TEST(QpSolver, InteriorPointWithoutPolish) {
    // Without the polish the IPM must reach the requested (looser) tolerance on its own.
    const Spectral s = make_spectral(401, Objective::Norm);
    QpOptions opt;
    opt.polish = false;
    opt.tolerance = 1e-9;
    const QpResult r = spectex::solve_qp(s.qp, opt);
    ASSERT_EQ(r.status, QpStatus::Solved);
    EXPECT_FALSE(r.polished);
    const Kkt k = kkt(s.qp, r);
    // Relative tolerance 1e-9 as requested; x is strictly interior (IPM iterate).
    EXPECT_LE(k.eq, 1e-9 * std::max(k.eq_scale, inf_norm(s.qp.A * r.x)));
    EXPECT_EQ(k.viol, 0.0);
    EXPECT_LE(k.stat, 1e-9 * k.stat_scale);
    EXPECT_LE(k.comp, 1e-9 * k.comp_scale);
    EXPECT_GE(k.min_z, 0.0);
}

TEST(QpSolver, IterationLimitIsReported) {
    const Spectral s = make_spectral(81, Objective::Smooth);
    QpOptions opt;
    opt.max_iterations = 2;
    const QpResult r = spectex::solve_qp(s.qp, opt);
    EXPECT_EQ(r.status, QpStatus::MaxIterations);
    EXPECT_EQ(r.iterations, 2);
    EXPECT_TRUE(r.x.allFinite() && r.y.allFinite());
}

TEST(QpSolver, RejectsMismatchedDimensions) {
    QpProblem p;
    p.P = sparse(2, 2, {{0, 0, 1.0}, {1, 1, 1.0}});
    p.q = VectorXd::Zero(3);
    p.A = SpMat(0, 2);
    p.b = VectorXd(0);
    p.lower = VectorXd::Zero(2);
    p.upper = VectorXd::Ones(2);
    EXPECT_THROW(spectex::solve_qp(p), std::invalid_argument);
}

TEST(QpSolver, StatusNames) {
    EXPECT_STREQ(spectex::to_string(QpStatus::Solved), "solved");
    EXPECT_STREQ(spectex::to_string(QpStatus::Infeasible), "infeasible");
    EXPECT_STREQ(spectex::to_string(QpStatus::MaxIterations), "max iterations");
    EXPECT_STREQ(spectex::to_string(QpStatus::NumericalError), "numerical error");
}

}  // namespace
