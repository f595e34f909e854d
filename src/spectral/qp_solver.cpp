// solve_qp (qp_solver.h): the driver. Checks the data, eliminates fixed variables, equilibrates
// (qp_scaling.cpp), runs the interior-point method with its polish (qp_interior_point.cpp,
// qp_polish.cpp), maps candidates back to the user's units to accept them, and turns to phase 1
// (qp_infeasibility.cpp) when the constraints look infeasible.
#include "spectral/qp_solver.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "spectral/qp_internal.h"

namespace spectex {
namespace qp_detail {

namespace {

bool all_finite(const SpMat& M) {
    for (Index k = 0; k < M.nonZeros(); ++k)
        if (!std::isfinite(M.valuePtr()[k])) return false;
    return true;
}

}  // namespace

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
        if (std::isnan(l) || std::isnan(u))
            data_ok = false;
        else if (l > u || l == kInf || u == -kInf)
            box_ok = false;
        res.x[i] = std::isfinite(l) ? l : (std::isfinite(u) ? u : 0.0);
    }
    if (!data_ok) {
        res.status = QpStatus::NumericalError;
        res.primal_residual = res.dual_residual = res.complementarity = kInf;
        return res;
    }
    const SpMat Psym = 0.5 * (pr.P + SpMat(pr.P.transpose()));  // exact if P is symmetric
    auto finish = [&](QpResult& r) {
        const Metrics mt =
            evaluate(Psym, pr.q, A, pr.b, pr.lower, pr.upper, r.x, r.y, r.z_lower, r.z_upper);
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
        if (pr.lower[i] == pr.upper[i])
            xfix[i] = pr.lower[i];
        else
            cmap[i] = static_cast<Index>(keep.size()), keep.push_back(i);
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
    if (nk > 0)
        unscale(ipm.x(), ipm.y(), ipm.zl(), ipm.zu());
    else
        cand.x = xfix;
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

}  // namespace qp_detail

QpResult solve_qp(const QpProblem& problem, const QpOptions& options) {
    return qp_detail::solve_impl(problem, options, true);
}

const char* to_string(QpStatus status) {
    switch (status) {
        case QpStatus::Solved:
            return "solved";
        case QpStatus::Infeasible:
            return "infeasible";
        case QpStatus::MaxIterations:
            return "max iterations";
        case QpStatus::NumericalError:
            return "numerical error";
    }
    return "unknown";
}

}  // namespace spectex
