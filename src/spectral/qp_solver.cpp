#include "spectral/qp_solver.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#ifdef QP_DEBUG
#include <cstdio>
#define QPLOG(...) std::fprintf(stderr, __VA_ARGS__)
#include <chrono>
struct QpTimer { double& acc; std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  ~QpTimer() { acc += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(); } };
static double g_t_factor, g_t_newton, g_t_polish, g_t_equil, g_t_total, g_t_init;
#define QPTIME(var) QpTimer qp_timer_##var{var}
#else
#define QPLOG(...) ((void)0)
#define QPTIME(var) ((void)0)
#endif

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
constexpr double kIpmRegPrimal = 1e-9;   // static regularisation of the (1,1) KKT block
constexpr double kIpmRegDual = 1e-9;     // static regularisation of the (2,2) KKT block
constexpr int kIpmRefineSteps = 6;       // iterative refinement of each Newton solve
constexpr double kStepFraction = 0.995;  // fraction to the boundary
constexpr double kPolishStart = 1e-6;    // try the polish once the IPM is this close
constexpr double kPolishRegPrimal = 1e-9;
constexpr double kPolishRegDual = 1e-9;
constexpr int kPolishRefineSteps = 60;
constexpr int kPolishRounds = 30;  // active-set corrections per polish attempt  // active-set corrections per polish attempt
constexpr int kRegRetries = 4;    // factorisation retries with 100x the regularisation

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
    r.scale_p = std::max({1.0, norm_inf(b), norm_inf(Ax)});
    r.scale_d = std::max({1.0, norm_inf(q), norm_inf(Px), norm_inf(Aty), norm_inf(zl), norm_inf(zu)});
    r.scale_c = std::max({1.0, std::abs(q.dot(x)), std::abs(x.dot(Px))});
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
    QPTIME(g_t_equil);
    const Index n = P.rows(), m = A.rows();
    Vec D = Vec::Ones(n), E = Vec::Ones(m);
    SpMat Ps = P, As = A;
    for (int it = 0; it < kRuizIterations; ++it) {
        Vec cn = Vec::Zero(n), rn = Vec::Zero(m);
        for (Index j = 0; j < n; ++j) {
            for (SpMat::InnerIterator e(Ps, j); e; ++e) cn[j] = std::max(cn[j], std::abs(e.value()));
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
// `d` holds the starting point; a correction is kept only while it reduces the residual.
template <class ApplyK>
void refine(const Ldlt& f, const ApplyK& apply_k, const Vec& rhs, Vec& d, int max_steps) {
    Vec res = rhs - apply_k(d);
    double rn = norm_inf(res);
    int k = 0;
    for (; k < max_steps && rn > 0.0; ++k) {
        Vec trial = d + f.solve(res);
        Vec tres = rhs - apply_k(trial);
        const double tn = norm_inf(tres);
        if (!(tn < rn)) break;
        const bool slow = tn > 0.9 * rn;
        d.swap(trial);
        res.swap(tres);
        rn = tn;
        if (slow) break;
    }
#ifdef QP_DEBUG
    static long calls = 0, total = 0;
    ++calls;
    QPLOG("    refine: %d steps residual %.2e (rhs %.2e)\n", k, rn, norm_inf(rhs));
#endif
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
    void newton_solve(const Vec& hd, const Vec& r1, const Vec& r2, Vec& dx, Vec& dy) const;
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
    SpMat K_;  // lower triangle of [P + diag + reg, A'; A, -reg]
    std::vector<Index> diag_pos_;
    Vec pdiag_;
    Ldlt ldlt_;
    double reg_p_ = kIpmRegPrimal, reg_d_ = kIpmRegDual;
    bool started_ = false;
    int iter_ = 0;
    int tiny_steps_ = 0;
    std::vector<double> rp_hist_;
    std::vector<signed char> last_cls_;  // last active-set guess tried
    double last_measure_ = 0.0;          // IPM accuracy measure at that attempt
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
    QPTIME(g_t_factor);
    for (int attempt = 0; attempt <= kRegRetries; ++attempt) {
        double* v = K_.valuePtr();
        for (Index j = 0; j < n_; ++j) v[diag_pos_[j]] = pdiag_[j] + hd[j] + reg_p_;
        for (Index i = 0; i < m_; ++i) v[diag_pos_[n_ + i]] = -reg_d_;
        ldlt_.factorize(K_);
        QPLOG("    factor n=%ld nnzK=%ld nnzL=%ld\n", long(K_.rows()), long(K_.nonZeros()), long(ldlt_.matrixL().nestedExpression().nonZeros()));
        if (ldlt_.info() == Eigen::Success) return true;
        reg_p_ *= 100.0;
        reg_d_ *= 100.0;
    }
    return false;
}

// Solves [P + diag(hd), A'; A, 0] [dx; -dy] = [r1; r2] by the regularised factorisation and
// iterative refinement against the unregularised matrix.
void InteriorPoint::newton_solve(const Vec& hd, const Vec& r1, const Vec& r2, Vec& dx,
                                 Vec& dy) const {
    QPTIME(g_t_newton);
    const Index n = n_, m = m_;
    auto apply_k = [&](const Vec& d) {
        Vec out(n + m);
        const auto dxv = d.head(n);
        const auto wv = d.tail(m);
        out.head(n) = s_.P * dxv + hd.cwiseProduct(dxv) + s_.A.transpose() * wv;
        out.tail(m) = s_.A * dxv;
        return out;
    };
    Vec rhs(n + m);
    rhs << r1, r2;
    Vec d = ldlt_.solve(rhs);
    refine(ldlt_, apply_k, rhs, d, kIpmRefineSteps);
    dx = d.head(n);
    dy = -d.tail(m);
}

bool InteriorPoint::initial_point() {
    QPTIME(g_t_init);
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
        const double rp_rel = norm_inf(rp) / std::max({1.0, norm_inf(s_.b), norm_inf(Ax)});
        const double rd_rel = norm_inf(rd) / std::max({1.0, norm_inf(s_.q), norm_inf(Px),
                                                       norm_inf(Aty), norm_inf(zl_), norm_inf(zu_)});
        const double c_rel =
            comp / std::max({1.0, std::abs(s_.q.dot(x_)), std::abs(x_.dot(Px))});
        if (!std::isfinite(rp_rel + rd_rel + c_rel)) return Outcome::NumericalError;
        QPLOG("it %d rp %.2e rd %.2e comp %.2e mu %.2e\n", iter_, rp_rel, rd_rel, c_rel, mu);

        const double tol = opt_.tolerance;
        const double measure = std::max({rp_rel, rd_rel, c_rel});
        if (opt_.polish && measure <= kPolishStart && try_polish(measure)) return Outcome::Accepted;
        if (rp_rel <= tol && rd_rel <= tol && c_rel <= tol && accept_(x_, y_, zl_, zu_, false))
            return Outcome::Accepted;
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
        auto direction = [&](const Vec& rcl, const Vec& rcu) {
            const Vec r1 = -rd - rcl.cwiseQuotient(sl) + rcu.cwiseQuotient(su);
            newton_solve(hd, r1, -rp, dx, dy);
            dzl = mL_.cwiseProduct((-rcl - zl_.cwiseProduct(dx)).cwiseQuotient(sl));
            dzu = mU_.cwiseProduct((-rcu + zu_.cwiseProduct(dx)).cwiseQuotient(su));
        };
        // Predictor (affine scaling).
        const Vec rcl0 = sl.cwiseProduct(zl_), rcu0 = su.cwiseProduct(zu_);
        direction(rcl0, rcu0);
        const double a_aff = max_step(sl, su, zl_, zu_, mL_, mU_, dx, dzl, dzu);
        const double mu_aff = ((sl + a_aff * dx).cwiseProduct(zl_ + a_aff * dzl).cwiseProduct(mL_).sum() +
                               (su - a_aff * dx).cwiseProduct(zu_ + a_aff * dzu).cwiseProduct(mU_).sum()) /
                              nb_;
        const double sigma = std::clamp(std::pow(std::max(mu_aff, 0.0) / mu, 3.0), 0.0, 1.0);
        // Corrector (second-order term and centring).
        const Vec rcl = rcl0 + mL_.cwiseProduct(dx.cwiseProduct(dzl)) - (sigma * mu) * mL_;
        const Vec rcu = rcu0 - mU_.cwiseProduct(dx.cwiseProduct(dzu)) - (sigma * mu) * mU_;
        direction(rcl, rcu);
        if (!(dx.allFinite() && dy.allFinite() && dzl.allFinite() && dzu.allFinite()))
            return Outcome::NumericalError;
        const double amax = max_step(sl, su, zl_, zu_, mL_, mU_, dx, dzl, dzu);
        const double alpha = std::min(1.0, kStepFraction * amax);
        tiny_steps_ = alpha < 1e-8 ? tiny_steps_ + 1 : 0;
        x_ += alpha * dx;
        y_ += alpha * dy;
        zl_ += alpha * dzl;
        zu_ += alpha * dzu;
        ++iter_;
    }
}

// Guess the active bounds ("slack < multiplier") and polish from there. A failed guess is
// retried only after the IPM has reduced its accuracy measure tenfold and the guess changed.
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
    if (cls == last_cls_) return false;
    last_cls_ = cls;
    last_measure_ = measure;
    return polish_from(std::move(cls));
}

// Primal-dual active-set iterations starting from the guess `cls` (-1 lower, +1 upper, 0 free).
bool InteriorPoint::polish_from(std::vector<signed char> cls) {
    QPTIME(g_t_polish);
    std::vector<std::vector<signed char>> seen;
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
        bool changed = false;
        for (Index i = 0; i < n_; ++i) {
            switch (cls[i]) {
                case 0:
                    // Allow a few ulps of overshoot (clipped below); more means "active".
                    if (mL_[i] > 0 && xp[i] < l0_[i] - 8 * kEps * std::max(1.0, std::abs(l0_[i])))
                        cls[i] = -1, changed = true;
                    else if (mU_[i] > 0 &&
                             xp[i] > u0_[i] + 8 * kEps * std::max(1.0, std::abs(u0_[i])))
                        cls[i] = 1, changed = true;
                    break;
                case -1:
                    zl[i] = g[i];
                    if (zl[i] < -ztol) cls[i] = 0, changed = true;
                    break;
                default:
                    zu[i] = -g[i];
                    if (zu[i] < -ztol) cls[i] = 0, changed = true;
                    break;
            }
        }
#ifdef QP_DEBUG
        {
            int nfree = 0, nl = 0, nu = 0;
            for (Index i = 0; i < n_; ++i) nfree += cls[i] == 0, nl += cls[i] < 0, nu += cls[i] > 0;
            double worst_v = 0, worst_z = 0;
            for (Index i = 0; i < n_; ++i) {
                if (mL_[i] > 0) worst_v = std::max(worst_v, l0_[i] - xp[i]);
                if (mU_[i] > 0) worst_v = std::max(worst_v, xp[i] - u0_[i]);
                worst_z = std::min({worst_z, zl[i], zu[i]});
            }
            int nch = 0;
            for (Index i = 0; i < n_; ++i) {
                if (cls[i] == 0) nch += (mL_[i] > 0 && xp[i] < l0_[i] - 8 * kEps * std::max(1.0, std::abs(l0_[i]))) || (mU_[i] > 0 && xp[i] > u0_[i] + 8 * kEps * std::max(1.0, std::abs(u0_[i])));
                else if (cls[i] < 0) nch += zl[i] < -ztol; else nch += zu[i] < -ztol;
            }
            QPLOG("  polish round %d nchanges %d changed %d free %d L %d U %d %d L %d U %d worst viol %.2e worst z %.2e ztol %.2e\n", round, nch, int(changed), nfree, nl, nu, worst_v, worst_z, ztol);
        }
#endif
#ifdef QP_DEBUG
        if (round == 0 && getenv("QPDUMP")) {
            int shown = 0;
            for (Index i = 0; i < n_ && shown < 40; ++i) {
                bool bad = (cls[i] == 0 && (zl[i] < -ztol || zu[i] < -ztol)) || (cls[i] != 0 && ((mL_[i] > 0 && xp[i] < l0_[i] - 1e-15) || (mU_[i] > 0 && xp[i] > u0_[i] + 1e-15)));
                if (bad) { ++shown; QPLOG("    bad %ld (cls now %d) x_ipm %.3e zl %.3e zu %.3e | xp %.3e g %.3e\n", long(i), cls[i], x_[i], zl_[i], zu_[i], xp[i], g[i]); }
            }
        }
#endif
        if (changed) continue;
        for (Index i = 0; i < n_; ++i) {
            if (mL_[i] > 0) xp[i] = std::max(xp[i], l0_[i]);
            if (mU_[i] > 0) xp[i] = std::min(xp[i], u0_[i]);
        }
        return accept_(xp, yp, zl.cwiseMax(0.0), zu.cwiseMax(0.0), true);
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

    auto build = [&](double reg_p, double reg_d) {
        std::vector<Triplet> t;
        for (Index j = 0; j < n_; ++j) {
            const Index c = fpos[j];
            if (c < 0) continue;
            t.emplace_back(c, c, reg_p);
            for (SpMat::InnerIterator e(s_.P, j); e; ++e)
                if (fpos[e.row()] >= c) t.emplace_back(fpos[e.row()], c, e.value());
            for (SpMat::InnerIterator e(s_.A, j); e; ++e)
                t.emplace_back(nf + rpos[e.row()], c, e.value());
        }
        for (Index i = 0; i < mr; ++i) t.emplace_back(nf + i, nf + i, -reg_d);
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
        double reg = 1.0;
        for (int attempt = 0;; ++attempt, reg *= 100.0) {
            f.compute(build(reg * kPolishRegPrimal, reg * kPolishRegDual));
            if (f.info() == Eigen::Success) break;
            if (attempt == kRegRetries) return false;
        }
        auto apply_k = [&](const Vec& v) {
            Vec xf = Vec::Zero(n_), wf = Vec::Zero(m_);
            for (Index i = 0; i < n_; ++i)
                if (fpos[i] >= 0) xf[i] = v[fpos[i]];
            for (Index i = 0; i < m_; ++i)
                if (rpos[i] >= 0) wf[i] = v[nf + rpos[i]];
            const Vec top = s_.P * xf + s_.A.transpose() * wf;
            const Vec bot = s_.A * xf;
            Vec out(nf + mr);
            for (Index i = 0; i < n_; ++i)
                if (fpos[i] >= 0) out[fpos[i]] = top[i];
            for (Index i = 0; i < m_; ++i)
                if (rpos[i] >= 0) out[nf + rpos[i]] = bot[i];
            return out;
        };
        refine(f, apply_k, rhs, d, kPolishRefineSteps);
        for (Index i = 0; i < n_; ++i)
            if (fpos[i] >= 0) xp[i] = d[fpos[i]];
        for (Index i = 0; i < m_; ++i)
            if (rpos[i] >= 0) yp[i] = -d[nf + rpos[i]];
    }
    return xp.allFinite() && yp.allFinite();
}

// ---- The driver --------------------------------------------------------------------------------
QpResult solve_impl(const QpProblem& pr, const QpOptions& opt, bool allow_phase1);

// Phase 1: min 0.5||r||^2  s.t.  A x - r = b,  lower <= x <= upper  (always feasible).
// Returns true (and fills `out`) if it proves that no x in the box meets A x = b to tolerance.
bool prove_infeasible(const QpProblem& pr, const SpMat& Psym, const QpOptions& opt,
                      QpResult& out) {
    const Index n = pr.q.size(), m = pr.b.size();
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
    if (r1.status != QpStatus::Solved) return false;
    const Vec x = r1.x.head(n);
    const Vec Ax = pr.A * x;
    const double gap = norm_inf(Ax - pr.b);
    if (!(gap > opt.tolerance * std::max({1.0, norm_inf(pr.b), norm_inf(Ax)}))) return false;
    // Infeasible: report the closest box point and the phase-1 multipliers (y = b - Ax is a
    // Farkas certificate: A'y lies in the normal cone of the box at x while y'(b - Ax) > 0).
    out.status = QpStatus::Infeasible;
    out.x = x;
    out.y = r1.y;
    out.z_lower = r1.z_lower.head(n);
    out.z_upper = r1.z_upper.head(n);
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
    for (Index i = 0; i < m; ++i) {
        if (rmap[i] < 0 && std::abs(bfull[i]) > opt.tolerance * std::max(1.0, norm_inf(pr.b))) {
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
            for (Index i = 0; i < n; ++i)
                if (cmap[i] < 0) cand.z_lower[i] = std::max(g[i], 0.0), cand.z_upper[i] = std::max(-g[i], 0.0);
        }
    };
    bool accepted = false;
    AcceptFn accept = [&](const Vec& xs, const Vec& ys, const Vec& zls, const Vec& zus,
                          bool polished) {
        unscale(xs, ys, zls, zus);
        cand.polished = polished;
        const Metrics mt = finish(cand);
        QPLOG("  accept? pol %d eq %.2e/%.2e viol %.2e dual %.2e/%.2e comp %.2e/%.2e\n", int(polished), mt.eq, mt.scale_p, mt.viol, mt.dual, mt.scale_d, mt.comp, mt.scale_c);
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
#ifdef QP_DEBUG
    g_t_factor = g_t_newton = g_t_polish = g_t_equil = g_t_total = g_t_init = 0;
    QpResult r;
    { QPTIME(g_t_total); r = solve_impl(problem, options, true); }
    QPLOG("TIME total %.2f equil %.2f init %.2f factor %.2f newton %.2f polish %.2f\n", g_t_total, g_t_equil, g_t_init, g_t_factor, g_t_newton, g_t_polish);
    return r;
#endif
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
