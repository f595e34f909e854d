#include "spectral/qp_solver.h"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseQR>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace spectex {
namespace {

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

double norm_inf(const Vec& v) { return v.size() == 0 ? 0.0 : v.lpNorm<Eigen::Infinity>(); }

// Closest power of two, so that scaling by it is exact in binary floating point.
double nearest_pow2(double v) {
    if (!(v > 0.0) || !std::isfinite(v)) return 1.0;
    int e = 0;
    const double mant = std::frexp(v, &e);  // v = mant * 2^e, mant in [0.5, 1)
    return std::ldexp(1.0, mant < std::sqrt(0.5) ? e - 1 : e);
}

bool all_finite(const SpMat& M) {
    for (Index k = 0; k < M.nonZeros(); ++k)
        if (!std::isfinite(M.valuePtr()[k])) return false;
    return true;
}

// M restricted to the rows/columns whose map entry is >= 0, renumbered by the maps.
SpMat extract(const SpMat& M, const std::vector<Index>& row_map, Index rows,
              const std::vector<Index>& col_map, Index cols) {
    std::vector<Triplet> t;
    t.reserve(static_cast<size_t>(M.nonZeros()));
    for (Index j = 0; j < M.outerSize(); ++j) {
        if (col_map[j] < 0) continue;
        for (SpMat::InnerIterator it(M, j); it; ++it)
            if (row_map[it.row()] >= 0) t.emplace_back(row_map[it.row()], col_map[j], it.value());
    }
    SpMat out(rows, cols);
    out.setFromTriplets(t.begin(), t.end());
    return out;
}

// ---- Residuals in the user's units -------------------------------------------------------------
struct Metrics {
    double eq = 0, viol = 0, dual = 0, comp = 0;  // absolute
    double scale_p = 1, scale_d = 1, scale_c = 1;  // for the relative test
    bool meets(double tol) const {
        return std::isfinite(eq) && std::isfinite(dual) && std::isfinite(comp) && viol == 0.0 &&
               eq <= tol * scale_p && dual <= tol * scale_d && comp <= tol * scale_c;
    }
};

Metrics evaluate(const SpMat& P, const Vec& q, const SpMat& A, const Vec& b, const Vec& l,
                 const Vec& u, const Vec& x, const Vec& y, const Vec& zl, const Vec& zu) {
    Metrics r;
    const Vec Ax = A * x, Px = P * x, Aty = A.transpose() * y;
    r.eq = norm_inf(Ax - b);
    r.dual = norm_inf(Px + q - Aty - zl + zu);
    for (Index i = 0; i < x.size(); ++i) {
        if (std::isfinite(l[i])) {
            r.viol = std::max(r.viol, l[i] - x[i]);
            r.comp = std::max(r.comp, zl[i] * (x[i] - l[i]));
        }
        if (std::isfinite(u[i])) {
            r.viol = std::max(r.viol, x[i] - u[i]);
            r.comp = std::max(r.comp, zu[i] * (u[i] - x[i]));
        }
    }
    // Backward-error scales: the size of the terms summed, so that cancellation in A x or P x
    // cannot demand more than rounding allows.
    const Vec ax = x.cwiseAbs(), ay = y.cwiseAbs();
    const SpMat absP = P.cwiseAbs(), absA = A.cwiseAbs();
    const Vec absPx = absP * ax;
    r.scale_p = std::max({1.0, norm_inf(b), norm_inf(absA * ax)});
    r.scale_d = std::max({1.0, norm_inf(q), norm_inf(absPx), norm_inf(absA.transpose() * ay),
                          norm_inf(zl), norm_inf(zu)});
    r.scale_c = std::max({1.0, q.cwiseAbs().dot(ax), ax.dot(absPx)});
    return r;
}

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
                   const Vec& u) {
    const Index n = P.rows(), m = A.rows();
    Vec D = Vec::Ones(n), E = Vec::Ones(m);
    SpMat Ps = P, As = A;
    for (int it = 0; it < kRuizIterations; ++it) {
        Vec cn = Vec::Zero(n), rn = Vec::Zero(m);
        for (Index j = 0; j < n; ++j) {
            for (SpMat::InnerIterator e(Ps, j); e; ++e)
                cn[j] = std::max(cn[j], std::abs(e.value()));
            for (SpMat::InnerIterator e(As, j); e; ++e) {
                cn[j] = std::max(cn[j], std::abs(e.value()));
                rn[e.row()] = std::max(rn[e.row()], std::abs(e.value()));
            }
        }
        Vec dj(n), ei(m);
        for (Index j = 0; j < n; ++j)
            dj[j] = cn[j] > 0 ? std::clamp(1.0 / std::sqrt(cn[j]), kRuizMin, kRuizMax) : 1.0;
        for (Index i = 0; i < m; ++i)
            ei[i] = rn[i] > 0 ? std::clamp(1.0 / std::sqrt(rn[i]), kRuizMin, kRuizMax) : 1.0;
        Ps = dj.asDiagonal() * Ps * dj.asDiagonal();
        As = ei.asDiagonal() * As * dj.asDiagonal();
        D = D.cwiseProduct(dj);
        E = E.cwiseProduct(ei);
    }
    Scaled s;
    s.D = D.unaryExpr([](double v) { return nearest_pow2(v); });
    s.E = E.unaryExpr([](double v) { return nearest_pow2(v); });
    s.P = s.D.asDiagonal() * P * s.D.asDiagonal();
    s.A = s.E.asDiagonal() * A * s.D.asDiagonal();
    Vec Dq = s.D.cwiseProduct(q);
    double pcol = 0.0;
    for (Index j = 0; j < n; ++j) {
        double mx = 0.0;
        for (SpMat::InnerIterator e(s.P, j); e; ++e) mx = std::max(mx, std::abs(e.value()));
        pcol += mx;
    }
    pcol = n > 0 ? pcol / static_cast<double>(n) : 0.0;
    const double cost = std::max(pcol, norm_inf(Dq));
    s.c = cost > 0 ? nearest_pow2(std::clamp(1.0 / cost, kRuizMin, kRuizMax)) : 1.0;
    s.P *= s.c;
    s.q = s.c * Dq;
    s.b = s.E.cwiseProduct(b);
    s.l = l.cwiseQuotient(s.D);
    s.u = u.cwiseQuotient(s.D);
    return s;
}

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
    InteriorPoint(const Scaled& s, const QpOptions& opt, AcceptFn accept)
        : s_(s), opt_(opt), accept_(std::move(accept)), n_(s.P.rows()), m_(s.A.rows()) {
        mL_ = Vec::Zero(n_);
        mU_ = Vec::Zero(n_);
        l0_ = Vec::Zero(n_);
        u0_ = Vec::Zero(n_);
        for (Index i = 0; i < n_; ++i) {
            if (std::isfinite(s.l[i])) mL_[i] = 1.0, l0_[i] = s.l[i];
            if (std::isfinite(s.u[i])) mU_[i] = 1.0, u0_[i] = s.u[i];
        }
        nb_ = mL_.sum() + mU_.sum();
        absP_ = s.P.cwiseAbs();
        absA_ = s.A.cwiseAbs();
        x_ = Vec::Zero(n_);
        y_ = Vec::Zero(m_);
        zl_ = Vec::Zero(n_);
        zu_ = Vec::Zero(n_);
    }

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
    SpMat absP_, absA_;  // |P|, |A|, for the relative accuracy measures
    SpMat K_;            // lower triangle of [P + diag + reg, A'; A, -reg]
    std::vector<Index> diag_pos_;  // positions of the diagonal entries in K_'s values
    Vec pdiag_;                    // diagonal of P
    Ldlt ldlt_;
    double reg_scale_ = 1.0;  // multiplies the regularisation; raised when a solve is poor
    bool started_ = false;
    int iter_ = 0;
    int tiny_steps_ = 0;
    std::vector<double> rp_hist_;
    double last_measure_ = 0.0;  // IPM accuracy measure at the last polish attempt
};

void InteriorPoint::build_pattern() {
    std::vector<Triplet> t;
    t.reserve(static_cast<size_t>(s_.P.nonZeros() + s_.A.nonZeros() + n_ + m_));
    pdiag_ = Vec::Zero(n_);
    for (Index j = 0; j < n_; ++j) {
        t.emplace_back(j, j, 0.0);
        for (SpMat::InnerIterator e(s_.P, j); e; ++e) {
            if (e.row() > j) t.emplace_back(e.row(), j, e.value());
            if (e.row() == j) pdiag_[j] += e.value();
        }
        for (SpMat::InnerIterator e(s_.A, j); e; ++e) t.emplace_back(n_ + e.row(), j, e.value());
    }
    for (Index i = 0; i < m_; ++i) t.emplace_back(n_ + i, n_ + i, 0.0);
    K_.resize(n_ + m_, n_ + m_);
    K_.setFromTriplets(t.begin(), t.end());
    K_.makeCompressed();
    diag_pos_.assign(static_cast<size_t>(n_ + m_), 0);
    for (Index j = 0; j < n_ + m_; ++j) {
        for (Index k = K_.outerIndexPtr()[j]; k < K_.outerIndexPtr()[j + 1]; ++k)
            if (K_.innerIndexPtr()[k] == j) diag_pos_[j] = k;
    }
    ldlt_.analyzePattern(K_);
}

bool InteriorPoint::factor(const Vec& hd) {
    for (int attempt = 0; attempt <= kRegRetries; ++attempt) {
        double* v = K_.valuePtr();
        for (Index j = 0; j < n_; ++j) {
            const double h = pdiag_[j] + hd[j];
            v[diag_pos_[j]] = h + reg_scale_ * (kRegRelative * std::abs(h) + kRegFloor);
        }
        for (Index i = 0; i < m_; ++i) v[diag_pos_[n_ + i]] = -reg_scale_ * kRegDual;
        ldlt_.factorize(K_);
        if (ldlt_.info() == Eigen::Success) return true;
        reg_scale_ *= 100.0;
    }
    return false;
}

// Solves [P + diag(hd), A'; A, 0] [dx; -dy] = [r1; r2] by the regularised factorisation and
// iterative refinement against the unregularised matrix.
SolveQuality InteriorPoint::newton_solve(const Vec& hd, const Vec& r1, const Vec& r2, Vec& dx,
                                         Vec& dy) const {
    const Index n = n_, m = m_;
    auto apply_k = [&](const Vec& d, Vec& kd, Vec& kabs) {
        const auto dxv = d.head(n);
        const auto wv = d.tail(m);
        const Vec adx = dxv.cwiseAbs(), aw = wv.cwiseAbs();
        kd.resize(n + m);
        kabs.resize(n + m);
        kd.head(n) = s_.P * dxv + hd.cwiseProduct(dxv) + s_.A.transpose() * wv;
        kd.tail(m) = s_.A * dxv;
        kabs.head(n) = absP_ * adx + hd.cwiseProduct(adx) + absA_.transpose() * aw;
        kabs.tail(m) = absA_ * adx;
    };
    Vec rhs(n + m);
    rhs << r1, r2;
    Vec d = ldlt_.solve(rhs);
    const SolveQuality quality = refine(ldlt_, apply_k, rhs, d, kIpmRefineSteps);
    dx = d.head(n);
    dy = -d.tail(m);
    return quality;
}

// Newton solve with a quality check on the normwise backward error (the componentwise one is
// O(1) in dependent rows, whose right-hand side is consistent only up to rounding). If it is
// above kNewtonEta the factorisation may be too inaccurate (tiny pivots): refactorise with 100x
// the regularisation and keep whichever direction is better (more regularisation can also slow
// refinement down). A direction worse than kNewtonEtaMax is refused: it would wreck the iterate.
bool InteriorPoint::direction_solve(const Vec& hd, const Vec& r1, const Vec& r2, Vec& dx,
                                    Vec& dy) {
    double best = newton_solve(hd, r1, r2, dx, dy).eta;
    if (best <= kNewtonEta) return true;
    Vec tdx, tdy;
    double best_scale = reg_scale_;
    for (int attempt = 0; attempt < kRegRetries; ++attempt) {
        reg_scale_ *= 100.0;
        if (!factor(hd)) break;
        const double eta = newton_solve(hd, r1, r2, tdx, tdy).eta;
        if (eta < best) best = eta, best_scale = reg_scale_, dx.swap(tdx), dy.swap(tdy);
        if (best <= kNewtonEta) break;
    }
    if (reg_scale_ != best_scale) {  // keep the factorisation that produced the direction
        reg_scale_ = best_scale;
        if (!factor(hd)) return false;
    }
    return best <= kNewtonEtaMax;
}

bool InteriorPoint::initial_point() {
    build_pattern();
    // x0: minimiser of 0.5x'Px + q'x + 0.5||x - centre||^2 subject to Ax = b, pushed inside.
    Vec centre = Vec::Zero(n_);
    for (Index i = 0; i < n_; ++i) {
        if (mL_[i] > 0 && mU_[i] > 0) centre[i] = 0.5 * (l0_[i] + u0_[i]);
        else if (mL_[i] > 0) centre[i] = l0_[i] + 1.0;
        else if (mU_[i] > 0) centre[i] = u0_[i] - 1.0;
    }
    const Vec ones = Vec::Ones(n_);
    if (!factor(ones)) return false;
    Vec dx, dy;
    newton_solve(ones, centre - s_.q, s_.b, dx, dy);
    x_ = dx;
    y_ = dy;
    for (Index i = 0; i < n_; ++i) {
        if (mL_[i] > 0 && mU_[i] > 0) {
            const double w = u0_[i] - l0_[i];
            x_[i] = std::clamp(x_[i], l0_[i] + 0.1 * w, u0_[i] - 0.1 * w);
        } else if (mL_[i] > 0) {
            x_[i] = std::max(x_[i], l0_[i] + 1.0);
        } else if (mU_[i] > 0) {
            x_[i] = std::min(x_[i], u0_[i] - 1.0);
        }
    }
    const Vec g = s_.P * x_ + s_.q - s_.A.transpose() * y_;
    for (Index i = 0; i < n_; ++i) {
        zl_[i] = mL_[i] * (std::max(g[i], 0.0) + 1.0);
        zu_[i] = mU_[i] * (std::max(-g[i], 0.0) + 1.0);
    }
    return x_.allFinite() && y_.allFinite();
}

// Largest step in (0, 1] keeping slacks and multipliers nonnegative (before the fraction).
double max_step(const Vec& sl, const Vec& su, const Vec& zl, const Vec& zu, const Vec& mL,
                const Vec& mU, const Vec& dx, const Vec& dzl, const Vec& dzu) {
    double a = 1.0;
    for (Index i = 0; i < dx.size(); ++i) {
        if (mL[i] > 0) {
            if (dx[i] < 0) a = std::min(a, -sl[i] / dx[i]);
            if (dzl[i] < 0) a = std::min(a, -zl[i] / dzl[i]);
        }
        if (mU[i] > 0) {
            if (dx[i] > 0) a = std::min(a, su[i] / dx[i]);
            if (dzu[i] < 0) a = std::min(a, -zu[i] / dzu[i]);
        }
    }
    return a;
}

Outcome InteriorPoint::run(bool watch_infeasibility) {
    if (!started_) {
        started_ = true;
        if (nb_ == 0) {
            // No inequality at all: the polish is the exact equality-constrained solve.
            return polish_from(std::vector<signed char>(static_cast<size_t>(n_), 0))
                       ? Outcome::Accepted
                       : Outcome::NumericalError;
        }
        if (!initial_point()) return Outcome::NumericalError;
    }
    if (nb_ == 0) return Outcome::NumericalError;
    const Vec oneL = Vec::Ones(n_) - mL_, oneU = Vec::Ones(n_) - mU_;
    while (true) {
        // Slacks are 1 where a bound is absent (their multipliers are 0 there).
        const Vec sl = mL_.cwiseProduct(x_ - l0_) + oneL;
        const Vec su = mU_.cwiseProduct(u0_ - x_) + oneU;
        const Vec Ax = s_.A * x_, Px = s_.P * x_, Aty = s_.A.transpose() * y_;
        const Vec rp = Ax - s_.b;
        const Vec rd = Px + s_.q - Aty - zl_ + zu_;
        const double mu = (sl.dot(zl_) + su.dot(zu_)) / nb_;
        const double comp =
            std::max(norm_inf(sl.cwiseProduct(zl_)), norm_inf(su.cwiseProduct(zu_)));
        const Vec ax = x_.cwiseAbs(), absPx = absP_ * ax;
        const double rp_rel =
            norm_inf(rp) / std::max({1.0, norm_inf(s_.b), norm_inf(absA_ * ax)});
        const double rd_rel =
            norm_inf(rd) / std::max({1.0, norm_inf(s_.q), norm_inf(absPx),
                                     norm_inf(absA_.transpose() * y_.cwiseAbs()), norm_inf(zl_),
                                     norm_inf(zu_)});
        const double c_rel = comp / std::max({1.0, s_.q.cwiseAbs().dot(ax), ax.dot(absPx)});
        if (!std::isfinite(rp_rel + rd_rel + c_rel)) {
            if (iter_ > 0) x_ = prev_x_, y_ = prev_y_, zl_ = prev_zl_, zu_ = prev_zu_;
            return Outcome::NumericalError;
        }

        const double tol = opt_.tolerance;
        const double measure = std::max({rp_rel, rd_rel, c_rel});
        if (opt_.polish && measure <= kPolishStart && try_polish(measure)) return Outcome::Accepted;
        // The equilibrated measures only approximate the user's: let the acceptance decide.
        if (measure <= 10 * tol && accept_(x_, y_, zl_, zu_, false)) return Outcome::Accepted;
        if (iter_ >= opt_.max_iterations) return Outcome::MaxIterations;

        // Infeasibility suspicion: the primal residual stops shrinking or the steps vanish.
        rp_hist_.push_back(rp_rel);
        const size_t k = rp_hist_.size();
        if (watch_infeasibility && rp_rel > 1e-8 &&
            ((k > 8 && rp_rel > 0.5 * rp_hist_[k - 6]) || tiny_steps_ >= 3))
            return Outcome::SuspectInfeasible;
        if (tiny_steps_ >= 5) return Outcome::NumericalError;

        // Newton systems.
        const Vec hd = zl_.cwiseQuotient(sl) + zu_.cwiseQuotient(su);
        if (!factor(hd)) return Outcome::NumericalError;
        Vec dx, dy, dzl, dzu;
        bool solved = true;
        auto direction = [&](const Vec& rcl, const Vec& rcu) {
            const Vec r1 = -rd - rcl.cwiseQuotient(sl) + rcu.cwiseQuotient(su);
            solved = direction_solve(hd, r1, -rp, dx, dy) && solved;
            dzl = mL_.cwiseProduct((-rcl - zl_.cwiseProduct(dx)).cwiseQuotient(sl));
            dzu = mU_.cwiseProduct((-rcu + zu_.cwiseProduct(dx)).cwiseQuotient(su));
        };
        // Predictor (affine scaling).
        const Vec rcl0 = sl.cwiseProduct(zl_), rcu0 = su.cwiseProduct(zu_);
        direction(rcl0, rcu0);
        const double a_aff = max_step(sl, su, zl_, zu_, mL_, mU_, dx, dzl, dzu);
        const double mu_aff =
            ((sl + a_aff * dx).cwiseProduct(zl_ + a_aff * dzl).cwiseProduct(mL_).sum() +
             (su - a_aff * dx).cwiseProduct(zu_ + a_aff * dzu).cwiseProduct(mU_).sum()) /
            nb_;
        const double sigma = std::clamp(std::pow(std::max(mu_aff, 0.0) / mu, 3.0), 0.0, 1.0);
        // Corrector (second-order term and centring).
        const Vec rcl = rcl0 + mL_.cwiseProduct(dx.cwiseProduct(dzl)) - (sigma * mu) * mL_;
        const Vec rcu = rcu0 - mU_.cwiseProduct(dx.cwiseProduct(dzu)) - (sigma * mu) * mU_;
        direction(rcl, rcu);
        if (!solved || !(dx.allFinite() && dy.allFinite() && dzl.allFinite() && dzu.allFinite()))
            return Outcome::NumericalError;
        const double amax = max_step(sl, su, zl_, zu_, mL_, mU_, dx, dzl, dzu);
        const double alpha = std::min(1.0, kStepFraction * amax);
        tiny_steps_ = alpha < 1e-8 ? tiny_steps_ + 1 : 0;
        prev_x_ = x_, prev_y_ = y_, prev_zl_ = zl_, prev_zu_ = zu_;
        x_ += alpha * dx;
        y_ += alpha * dy;
        zl_ += alpha * dzl;
        zu_ += alpha * dzu;
        ++iter_;
    }
}

// Guess the active bounds ("slack < multiplier") and polish from there, each time the IPM has
// reduced its accuracy measure tenfold (even with the same guess: the reduced solves start from
// the current IPM point, so a later attempt can succeed where an earlier one failed).
// (Tapia's indicators were tried and are less reliable here: on obstacle-like problems such as
// the smooth spectral fit, slack and multiplier both vanish near the contact boundaries.)
bool InteriorPoint::try_polish(double measure) {
    if (last_measure_ > 0 && measure > 0.1 * last_measure_) return false;
    std::vector<signed char> cls(static_cast<size_t>(n_), 0);
    for (Index i = 0; i < n_; ++i) {
        const double sl = mL_[i] > 0 ? x_[i] - l0_[i] : kInf;
        const double su = mU_[i] > 0 ? u0_[i] - x_[i] : kInf;
        const bool lo = mL_[i] > 0 && sl < zl_[i];
        const bool up = mU_[i] > 0 && su < zu_[i];
        if (lo && (!up || sl <= su)) cls[i] = -1;
        else if (up) cls[i] = 1;
    }
    last_measure_ = measure;
    return polish_from(std::move(cls));
}

// Primal-dual active-set iterations starting from the guess `cls` (-1 lower, +1 upper, 0 free):
// solve with the guessed bounds fixed, then free the bounds whose multiplier has the wrong sign
// and fix the free variables that left the box. Stops when nothing changes (the candidate is
// then checked in the user's units), when a guess repeats, or when the number of changes has
// not reached a new minimum for kPolishPatience rounds (the guess was too far off; the IPM
// will provide a better one).
bool InteriorPoint::polish_from(std::vector<signed char> cls) {
    std::vector<std::vector<signed char>> seen;
    Index best_changes = n_ + 1;
    int since_best = 0;
    for (int round = 0; round < kPolishRounds; ++round) {
        if (std::find(seen.begin(), seen.end(), cls) != seen.end()) return false;  // cycling
        seen.push_back(cls);
        Vec xp, yp;
        if (!solve_reduced(cls, xp, yp)) return false;
        const Vec Px = s_.P * xp, Aty = s_.A.transpose() * yp;
        const Vec g = Px + s_.q - Aty;
        const double ztol =
            opt_.tolerance * std::max({1.0, norm_inf(s_.q), norm_inf(Px), norm_inf(Aty)});
        Vec zl = Vec::Zero(n_), zu = Vec::Zero(n_);
        Index changes = 0;
        for (Index i = 0; i < n_; ++i) {
            const signed char before = cls[i];
            if (before == 0) {
                // A few ulps of overshoot are clipped below; more means "active".
                if (mL_[i] > 0 && xp[i] < l0_[i] - 8 * kEps * std::max(1.0, std::abs(l0_[i])))
                    cls[i] = -1;
                else if (mU_[i] > 0 &&
                         xp[i] > u0_[i] + 8 * kEps * std::max(1.0, std::abs(u0_[i])))
                    cls[i] = 1;
            } else if (before < 0) {
                zl[i] = g[i];
                if (zl[i] < -ztol) cls[i] = 0;
            } else {
                zu[i] = -g[i];
                if (zu[i] < -ztol) cls[i] = 0;
            }
            changes += cls[i] != before;
        }
        // A row whose columns are all fixed cannot be repaired by the reduced solve: if the
        // fixed values miss it, release the fixed variables that can move its residual to 0.
        {
            std::vector<char> has_free(static_cast<size_t>(m_), 0);
            for (Index j = 0; j < n_; ++j)
                if (cls[j] == 0)
                    for (SpMat::InnerIterator e(s_.A, j); e; ++e) has_free[e.row()] = 1;
            const Vec r = s_.A * xp - s_.b;
            const Vec mag = absA_ * xp.cwiseAbs();
            std::vector<char> bad(static_cast<size_t>(m_), 0);
            bool any = false;
            for (Index i = 0; i < m_; ++i)
                if (!has_free[i] &&
                    std::abs(r[i]) > opt_.tolerance * std::max({1.0, std::abs(s_.b[i]), mag[i]}))
                    bad[i] = 1, any = true;
            for (Index j = 0; any && j < n_; ++j) {
                if (cls[j] == 0) continue;
                for (SpMat::InnerIterator e(s_.A, j); e; ++e) {
                    if (!bad[e.row()]) continue;
                    // Moving x_j off its bound changes row i by sign(-cls_j) * a_ij.
                    if (r[e.row()] * e.value() * cls[j] > 0) {
                        cls[j] = 0;
                        ++changes;
                        break;
                    }
                }
            }
        }
        if (changes == 0) {
            for (Index i = 0; i < n_; ++i) {
                if (mL_[i] > 0) xp[i] = std::max(xp[i], l0_[i]);
                if (mU_[i] > 0) xp[i] = std::min(xp[i], u0_[i]);
            }
            return accept_(xp, yp, zl.cwiseMax(0.0), zu.cwiseMax(0.0), true);
        }
        if (changes < best_changes) best_changes = changes, since_best = 0;
        else if (++since_best >= kPolishPatience) return false;
    }
    return false;
}

// Equality-constrained QP on the free variables (active ones fixed at their bounds):
//   [P_FF, A_RF'; A_RF, 0] [x_F; -y_R] = [-q_F - P_FA x_A; b_R - A_RA x_A],
// R = rows touching a free variable (the others keep the IPM's y; their residual is checked by
// the acceptance).
// Solved by LDL' of the regularised matrix and iterative refinement started from the IPM point,
// i.e. proximal-point iterations: the regularisation costs no accuracy, dependent rows only
// make y non-unique, and a PSD P_FF keeps x near the IPM point along its null space.
bool InteriorPoint::solve_reduced(const std::vector<signed char>& cls, Vec& xp, Vec& yp) const {
    std::vector<Index> fpos(static_cast<size_t>(n_), -1), rpos(static_cast<size_t>(m_), -1);
    Index nf = 0, mr = 0;
    Vec xa = Vec::Zero(n_);
    for (Index i = 0; i < n_; ++i) {
        if (cls[i] == 0) fpos[i] = nf++;
        else xa[i] = cls[i] < 0 ? l0_[i] : u0_[i];
    }
    std::vector<char> used(static_cast<size_t>(m_), 0);
    for (Index j = 0; j < n_; ++j)
        if (fpos[j] >= 0)
            for (SpMat::InnerIterator e(s_.A, j); e; ++e) used[e.row()] = 1;
    for (Index i = 0; i < m_; ++i)
        if (used[i]) rpos[i] = mr++;

    auto build = [&](double reg) {
        std::vector<Triplet> t;
        for (Index j = 0; j < n_; ++j) {
            const Index c = fpos[j];
            if (c < 0) continue;
            t.emplace_back(c, c, reg * kRegFloor);
            for (SpMat::InnerIterator e(s_.P, j); e; ++e) {
                if (fpos[e.row()] < c) continue;
                const double v = e.row() == j ? e.value() * (1.0 + reg * kRegRelative) : e.value();
                t.emplace_back(fpos[e.row()], c, v);
            }
            for (SpMat::InnerIterator e(s_.A, j); e; ++e)
                t.emplace_back(nf + rpos[e.row()], c, e.value());
        }
        for (Index i = 0; i < mr; ++i) t.emplace_back(nf + i, nf + i, -reg * kRegDual);
        SpMat M(nf + mr, nf + mr);
        M.setFromTriplets(t.begin(), t.end());
        return M;
    };

    const Vec qa = s_.q + s_.P * xa;
    const Vec ba = s_.b - s_.A * xa;
    Vec rhs(nf + mr), d(nf + mr);
    for (Index i = 0; i < n_; ++i)
        if (fpos[i] >= 0) rhs[fpos[i]] = -qa[i], d[fpos[i]] = x_[i];
    for (Index i = 0; i < m_; ++i)
        if (rpos[i] >= 0) rhs[nf + rpos[i]] = ba[i], d[nf + rpos[i]] = -y_[i];

    xp = xa;
    // Rows without free columns do not enter the reduced system; their multipliers only
    // shift the multipliers of the active bounds, so keep the IPM's (sign-consistent) values.
    yp = y_;
    if (nf + mr > 0) {
        Ldlt f;
        auto apply_k = [&](const Vec& v, Vec& kd, Vec& kabs) {
            Vec xf = Vec::Zero(n_), wf = Vec::Zero(m_);
            for (Index i = 0; i < n_; ++i)
                if (fpos[i] >= 0) xf[i] = v[fpos[i]];
            for (Index i = 0; i < m_; ++i)
                if (rpos[i] >= 0) wf[i] = v[nf + rpos[i]];
            const Vec axf = xf.cwiseAbs(), awf = wf.cwiseAbs();
            const Vec top = s_.P * xf + s_.A.transpose() * wf;
            const Vec bot = s_.A * xf;
            const Vec atop = absP_ * axf + absA_.transpose() * awf;
            const Vec abot = absA_ * axf;
            kd.resize(nf + mr);
            kabs.resize(nf + mr);
            for (Index i = 0; i < n_; ++i)
                if (fpos[i] >= 0) kd[fpos[i]] = top[i], kabs[fpos[i]] = atop[i];
            for (Index i = 0; i < m_; ++i)
                if (rpos[i] >= 0) kd[nf + rpos[i]] = bot[i], kabs[nf + rpos[i]] = abot[i];
        };
        // Regularisation as small as possible (fast proximal convergence), raised if the
        // factorisation is too inaccurate for refinement to reach rounding level (normwise:
        // rows whose terms all but vanish can keep a large componentwise error).
        const Vec d0 = d;
        double best = kInf;
        double reg = 1.0;
        for (int attempt = 0; attempt <= kRegRetries; ++attempt, reg *= 100.0) {
            f.compute(build(reg));
            if (f.info() != Eigen::Success) continue;
            Vec trial = d0;
            const double eta = refine(f, apply_k, rhs, trial, kPolishRefineSteps).eta;
            if (eta < best) best = eta, d = trial;
            if (best <= kPolishEta) break;
        }
        if (!(best < kInf)) return false;
        for (Index i = 0; i < n_; ++i)
            if (fpos[i] >= 0) xp[i] = d[fpos[i]];
        for (Index i = 0; i < m_; ++i)
            if (rpos[i] >= 0) yp[i] = -d[nf + rpos[i]];
    }
    return xp.allFinite() && yp.allFinite();
}

// ---- The driver --------------------------------------------------------------------------------
QpResult solve_impl(const QpProblem& pr, const QpOptions& opt, bool allow_phase1);

// Farkas certificate for {A x = b, lower <= x <= upper} being empty: for any x in the box,
//   y'(b - A x) >= h := y'b - sup_{box} (A'y)'x,   hence   ||A x - b||_inf >= h / ||y||_1.
// Returns that lower bound on the infeasibility (0 if y proves nothing). The test is backward
// stable: entries of A'y that a relative perturbation of kCertNoise * eps of y could cancel
// count as zero, and h must exceed the effect of such a perturbation plus rounding.
constexpr double kCertNoise = 1024.0;

double farkas_bound(const SpMat& A, const Vec& b, const Vec& l, const Vec& u, const Vec& y) {
    const Vec aty = A.transpose() * y;
    const double ymax = norm_inf(y);
    double sup = 0.0, err = b.lpNorm<1>();
    for (Index i = 0; i < aty.size(); ++i) {
        const double a = aty[i];
        const double col = A.col(i).cwiseAbs().sum();
        const double noise = kCertNoise * kEps * col * ymax;
        const double m = std::max(std::isfinite(l[i]) ? std::abs(l[i]) : 0.0,
                                  std::isfinite(u[i]) ? std::abs(u[i]) : 0.0);
        err += col * m;
        if (std::abs(a) <= noise) continue;
        const double bound = a > 0 ? u[i] : l[i];
        if (!std::isfinite(bound)) return 0.0;  // sup is +inf: no certificate
        sup += a * bound;
    }
    const double h = y.dot(b) - sup;
    err *= kCertNoise * kEps * ymax;
    const double y1 = y.lpNorm<1>();
    return (h > err && y1 > 0) ? h / y1 : 0.0;
}

// Makes a certificate candidate usable: (A'y)_i must vanish wherever its sign points to an
// infinite bound. Projects y onto the orthogonal complement of those columns of A (least
// squares by sparse QR), a few passes since the projection can move other columns.
void repair_certificate(const SpMat& A, const Vec& l, const Vec& u, Vec& y) {
    const Index n = A.cols(), m = A.rows();
    std::vector<Index> col_map(static_cast<size_t>(n), -1);
    Index nf = 0;
    for (int pass = 0; pass < 4; ++pass) {
        const Vec aty = A.transpose() * y;
        const double ymax = norm_inf(y);
        bool added = false;
        for (Index i = 0; i < n; ++i) {
            const double a = aty[i];
            const double noise = kCertNoise * kEps * A.col(i).cwiseAbs().sum() * ymax;
            if (col_map[i] < 0 && std::abs(a) > noise && !std::isfinite(a > 0 ? u[i] : l[i]))
                col_map[i] = nf++, added = true;
        }
        if (!added) return;
        std::vector<Index> rows(static_cast<size_t>(m));
        for (Index i = 0; i < m; ++i) rows[i] = i;
        SpMat AF = extract(A, rows, m, col_map, nf);
        AF.makeCompressed();
        Eigen::SparseQR<SpMat, Eigen::COLAMDOrdering<int>> qr(AF);
        if (qr.info() != Eigen::Success) return;
        const Vec w = qr.solve(y);
        if (!w.allFinite()) return;
        y -= AF * w;
    }
}

// Phase 1: min 0.5||r||^2  s.t.  A x - r = b,  lower <= x <= upper  (always feasible). Its x
// gives y = b - A x, checked as a Farkas certificate. Returns true (and fills `out`) if every
// box point misses A x = b by more than the tolerance.
bool prove_infeasible(const QpProblem& pr, const SpMat& Psym, const QpOptions& opt,
                      QpResult& out) {
    const Index n = pr.q.size(), m = pr.b.size();
    if (m == 0) return false;
    QpProblem p1;
    std::vector<Triplet> t;
    for (Index i = 0; i < m; ++i) t.emplace_back(n + i, n + i, 1.0);
    p1.P.resize(n + m, n + m);
    p1.P.setFromTriplets(t.begin(), t.end());
    t.clear();
    for (Index j = 0; j < pr.A.outerSize(); ++j)
        for (SpMat::InnerIterator e(pr.A, j); e; ++e) t.emplace_back(e.row(), j, e.value());
    for (Index i = 0; i < m; ++i) t.emplace_back(i, n + i, -1.0);
    p1.A.resize(m, n + m);
    p1.A.setFromTriplets(t.begin(), t.end());
    p1.q = Vec::Zero(n + m);
    p1.b = pr.b;
    p1.lower = Vec::Constant(n + m, -kInf);
    p1.upper = Vec::Constant(n + m, kInf);
    p1.lower.head(n) = pr.lower;
    p1.upper.head(n) = pr.upper;
    QpOptions o1 = opt;
    o1.max_iterations = std::max(opt.max_iterations, 100);
    const QpResult r1 = solve_impl(p1, o1, false);
    Vec x = r1.x.head(n);
    if (!x.allFinite()) return false;
    for (Index i = 0; i < n; ++i) x[i] = std::clamp(x[i], pr.lower[i], pr.upper[i]);
    Vec y = pr.b - pr.A * x;
    repair_certificate(pr.A, pr.lower, pr.upper, y);
    const double scale =
        std::max({1.0, norm_inf(pr.b), norm_inf(pr.A.cwiseAbs() * x.cwiseAbs())});
    // Proof: a Farkas bound above the tolerance. Failing that (free columns make exact
    // certificates fragile in floating point), a phase-1 optimum solved to `tolerance` whose
    // residual exceeds sqrt(tolerance): KKT accuracy eps bounds the residual's error by
    // ~sqrt(eps) (objective-gap argument), so the problem is not feasible to tolerance either.
    const double gap = norm_inf(pr.b - pr.A * x);
    const bool proven = farkas_bound(pr.A, pr.b, pr.lower, pr.upper, y) > opt.tolerance * scale;
    const bool evident = r1.status == QpStatus::Solved && gap > std::sqrt(opt.tolerance) * scale;
    if (!proven && !evident) return false;
    // Infeasible: report the closest box point found, with the certificate (y = b - A x,
    // repaired) as the equality multipliers and no bound multipliers.
    out.status = QpStatus::Infeasible;
    out.x = x;
    out.y = y;
    out.z_lower = Vec::Zero(n);
    out.z_upper = Vec::Zero(n);
    const Metrics mt = evaluate(Psym, pr.q, pr.A, pr.b, pr.lower, pr.upper, out.x, out.y,
                                out.z_lower, out.z_upper);
    out.primal_residual = std::max(mt.eq, mt.viol);
    out.dual_residual = mt.dual;
    out.complementarity = mt.comp;
    out.polished = false;
    return true;
}

QpResult solve_impl(const QpProblem& pr, const QpOptions& opt, bool allow_phase1) {
    const Index n = pr.q.size(), m = pr.b.size();
    if (pr.P.rows() != n || pr.P.cols() != n)
        throw std::invalid_argument("solve_qp: P must be n x n with n = q.size()");
    if (pr.A.rows() != m || (pr.A.cols() != n && !(m == 0 && pr.A.cols() == 0)))
        throw std::invalid_argument("solve_qp: A must be m x n with m = b.size()");
    if (pr.lower.size() != n || pr.upper.size() != n)
        throw std::invalid_argument("solve_qp: lower/upper must have size n");

    QpResult res;
    res.x = Vec::Zero(n);
    res.y = Vec::Zero(m);
    res.z_lower = Vec::Zero(n);
    res.z_upper = Vec::Zero(n);
    SpMat A = pr.A;
    if (A.cols() != n) A.resize(m, n);

    // Data check. Bounds may be infinite but not NaN, and must leave a nonempty box.
    bool data_ok = all_finite(pr.P) && all_finite(A) && pr.q.allFinite() && pr.b.allFinite();
    bool box_ok = true;
    for (Index i = 0; i < n; ++i) {
        const double l = pr.lower[i], u = pr.upper[i];
        if (std::isnan(l) || std::isnan(u)) data_ok = false;
        else if (l > u || l == kInf || u == -kInf) box_ok = false;
        res.x[i] = std::isfinite(l) ? l : (std::isfinite(u) ? u : 0.0);
    }
    if (!data_ok) {
        res.status = QpStatus::NumericalError;
        res.primal_residual = res.dual_residual = res.complementarity = kInf;
        return res;
    }
    const SpMat Psym = 0.5 * (pr.P + SpMat(pr.P.transpose()));  // exact if P is symmetric
    auto finish = [&](QpResult& r) {
        const Metrics mt = evaluate(Psym, pr.q, A, pr.b, pr.lower, pr.upper, r.x, r.y,
                                    r.z_lower, r.z_upper);
        r.primal_residual = std::max(mt.eq, mt.viol);
        r.dual_residual = mt.dual;
        r.complementarity = mt.comp;
        return mt;
    };
    if (!box_ok) {
        res.status = QpStatus::Infeasible;
        finish(res);
        return res;
    }

    // Eliminate fixed variables (lower == upper) and the rows they leave empty.
    std::vector<Index> cmap(static_cast<size_t>(n), -1), rmap(static_cast<size_t>(m), -1);
    std::vector<Index> keep;
    Vec xfix = Vec::Zero(n);
    for (Index i = 0; i < n; ++i) {
        if (pr.lower[i] == pr.upper[i]) xfix[i] = pr.lower[i];
        else cmap[i] = static_cast<Index>(keep.size()), keep.push_back(i);
    }
    const Index nk = static_cast<Index>(keep.size());
    std::vector<Index> rows;
    for (Index j = 0; j < n; ++j)
        if (cmap[j] >= 0)
            for (SpMat::InnerIterator e(A, j); e; ++e) rmap[e.row()] = 0;
    for (Index i = 0; i < m; ++i)
        if (rmap[i] == 0) rmap[i] = static_cast<Index>(rows.size()), rows.push_back(i);
    const Index mk = static_cast<Index>(rows.size());
    const SpMat Pk = extract(Psym, cmap, nk, cmap, nk);
    const SpMat Ak = extract(A, rmap, mk, cmap, nk);
    const Vec qfull = pr.q + Psym * xfix, bfull = pr.b - A * xfix;
    Vec qk(nk), lk(nk), uk(nk), bk(mk);
    for (Index i = 0; i < nk; ++i)
        qk[i] = qfull[keep[i]], lk[i] = pr.lower[keep[i]], uk[i] = pr.upper[keep[i]];
    for (Index i = 0; i < mk; ++i) bk[i] = bfull[rows[i]];

    // A row left without free columns is either satisfied by the fixed values or infeasible.
    const Vec fixed_mag = A.cwiseAbs() * xfix.cwiseAbs();
    for (Index i = 0; i < m; ++i) {
        const double scale = std::max({1.0, norm_inf(pr.b), fixed_mag[i]});
        if (rmap[i] < 0 && std::abs(bfull[i]) > opt.tolerance * scale) {
            if (allow_phase1 && prove_infeasible(pr, Psym, opt, res)) return res;
            res.status = QpStatus::Infeasible;  // phase 1 unavailable: the row itself is proof
            finish(res);
            return res;
        }
    }

    const Scaled s = equilibrate(Pk, qk, Ak, bk, lk, uk);

    // Map a scaled candidate back to the user's problem; keep it if it meets the tolerance.
    QpResult cand = res;
    auto unscale = [&](const Vec& xs, const Vec& ys, const Vec& zls, const Vec& zus) {
        cand.x = xfix;
        cand.y.setZero();
        cand.z_lower.setZero();
        cand.z_upper.setZero();
        for (Index i = 0; i < nk; ++i) {
            cand.x[keep[i]] = s.D[i] * xs[i];
            cand.z_lower[keep[i]] = zls[i] / (s.c * s.D[i]);
            cand.z_upper[keep[i]] = zus[i] / (s.c * s.D[i]);
        }
        for (Index i = 0; i < mk; ++i) cand.y[rows[i]] = s.E[i] * ys[i] / s.c;
        if (nk < n) {
            const Vec g = Psym * cand.x + pr.q - A.transpose() * cand.y;
            for (Index i = 0; i < n; ++i) {
                if (cmap[i] >= 0) continue;
                cand.z_lower[i] = std::max(g[i], 0.0);
                cand.z_upper[i] = std::max(-g[i], 0.0);
            }
        }
    };
    bool accepted = false;
    AcceptFn accept = [&](const Vec& xs, const Vec& ys, const Vec& zls, const Vec& zus,
                          bool polished) {
        unscale(xs, ys, zls, zus);
        cand.polished = polished;
        const Metrics mt = finish(cand);
        if (!mt.meets(opt.tolerance)) return false;
        cand.status = QpStatus::Solved;
        res = cand;
        accepted = true;
        return true;
    };

    InteriorPoint ipm(s, opt, accept);
    Outcome outcome = Outcome::NumericalError;
    bool watch = allow_phase1;
    bool phase1_done = false;
    while (true) {
        outcome = ipm.run(watch);
        if (outcome != Outcome::SuspectInfeasible) break;
        watch = false;
        phase1_done = true;
        if (prove_infeasible(pr, Psym, opt, res)) {
            res.iterations = ipm.iterations();
            return res;
        }
    }
    if (accepted) {
        res.iterations = ipm.iterations();
        return res;
    }
    // The last iterate may still meet the tolerance in the user's units.
    if (nk > 0 && ipm.x().allFinite() && accept(ipm.x(), ipm.y(), ipm.zl(), ipm.zu(), false)) {
        res.iterations = ipm.iterations();
        return res;
    }
    // Failure: report the last iterate, unless phase 1 shows the problem is infeasible.
    if (allow_phase1 && !phase1_done && prove_infeasible(pr, Psym, opt, res)) {
        res.iterations = ipm.iterations();
        return res;
    }
    if (nk > 0) unscale(ipm.x(), ipm.y(), ipm.zl(), ipm.zu());
    else cand.x = xfix;
    if (!(cand.x.allFinite() && cand.y.allFinite() && cand.z_lower.allFinite() &&
          cand.z_upper.allFinite())) {
        cand.x = res.x;
        cand.y.setZero();
        cand.z_lower.setZero();
        cand.z_upper.setZero();
    }
    res = cand;
    res.polished = false;
    res.status =
        outcome == Outcome::MaxIterations ? QpStatus::MaxIterations : QpStatus::NumericalError;
    res.iterations = ipm.iterations();
    finish(res);
    return res;
}

}  // namespace

QpResult solve_qp(const QpProblem& problem, const QpOptions& options) {
    return solve_impl(problem, options, true);
}

const char* to_string(QpStatus status) {
    switch (status) {
        case QpStatus::Solved: return "solved";
        case QpStatus::Infeasible: return "infeasible";
        case QpStatus::MaxIterations: return "max iterations";
        case QpStatus::NumericalError: return "numerical error";
    }
    return "unknown";
}

}  // namespace spectex
