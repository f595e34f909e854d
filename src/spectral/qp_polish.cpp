// The active-set polish of solve_qp: from an interior-point iterate, guess the active bounds,
// solve the equality-constrained QP on the free variables to rounding accuracy (proximal
// iterative refinement), and correct the guess by primal-dual active-set iterations
// (M. Hintermüller, K. Ito, K. Kunisch, "The primal-dual active set strategy as a semismooth
// Newton method", SIAM J. Optim. 13(3), 2002) until it is consistent; the driver then verifies
// feasibility and multiplier signs in the user's units. Members of InteriorPoint
// (qp_interior_point.cpp), whose iterate they start from.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "spectral/qp_internal.h"

namespace spectex::qp_detail {

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
        if (lo && (!up || sl <= su))
            cls[i] = -1;
        else if (up)
            cls[i] = 1;
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
                else if (mU_[i] > 0 && xp[i] > u0_[i] + 8 * kEps * std::max(1.0, std::abs(u0_[i])))
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
        if (changes < best_changes)
            best_changes = changes, since_best = 0;
        else if (++since_best >= kPolishPatience)
            return false;
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
        if (cls[i] == 0)
            fpos[i] = nf++;
        else
            xa[i] = cls[i] < 0 ? l0_[i] : u0_[i];
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

}  // namespace spectex::qp_detail
