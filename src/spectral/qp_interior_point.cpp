// The interior-point method of solve_qp: Mehrotra's primal-dual predictor-corrector
// (S. Mehrotra, "On the implementation of a primal-dual interior point method", SIAM J. Optim.
// 2(4), 1992) on the equilibrated problem, with each Newton system solved through the
// regularised quasi-definite KKT matrix (SimplicialLDLT) and iterative refinement against the
// unregularised one. The polish it hands over to is in qp_polish.cpp.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "spectral/qp_internal.h"

namespace spectex::qp_detail {

InteriorPoint::InteriorPoint(const Scaled& s, const QpOptions& opt, AcceptFn accept)
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
bool InteriorPoint::direction_solve(const Vec& hd, const Vec& r1, const Vec& r2, Vec& dx, Vec& dy) {
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
        if (mL_[i] > 0 && mU_[i] > 0)
            centre[i] = 0.5 * (l0_[i] + u0_[i]);
        else if (mL_[i] > 0)
            centre[i] = l0_[i] + 1.0;
        else if (mU_[i] > 0)
            centre[i] = u0_[i] - 1.0;
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

namespace {

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

}  // namespace

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
        const double rp_rel = norm_inf(rp) / std::max({1.0, norm_inf(s_.b), norm_inf(absA_ * ax)});
        const double rd_rel = norm_inf(rd) / std::max({1.0, norm_inf(s_.q), norm_inf(absPx),
                                                       norm_inf(absA_.transpose() * y_.cwiseAbs()),
                                                       norm_inf(zl_), norm_inf(zu_)});
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

}  // namespace spectex::qp_detail
