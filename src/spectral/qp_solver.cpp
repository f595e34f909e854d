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

void check_shapes(const QpProblem& pr) {
    const Index n = pr.q.size(), m = pr.b.size();
    if (pr.P.rows() != n || pr.P.cols() != n)
        throw std::invalid_argument("solve_qp: P must be n x n with n = q.size()");
    if (pr.A.rows() != m || (pr.A.cols() != n && !(m == 0 && pr.A.cols() == 0)))
        throw std::invalid_argument("solve_qp: A must be m x n with m = b.size()");
    if (pr.lower.size() != n || pr.upper.size() != n)
        throw std::invalid_argument("solve_qp: lower/upper must have size n");
}

// The data check: bounds may be infinite but not NaN, and must leave a nonempty box. Sets the
// starting x (a finite bound, else 0).
struct DataCheck {
    bool data_ok = true, box_ok = true;
};

DataCheck check_data(const QpProblem& pr, const SpMat& A, QpResult& res) {
    DataCheck c;
    c.data_ok = all_finite(pr.P) && all_finite(A) && pr.q.allFinite() && pr.b.allFinite();
    for (Index i = 0; i < pr.q.size(); ++i) {
        const double l = pr.lower[i], u = pr.upper[i];
        if (std::isnan(l) || std::isnan(u))
            c.data_ok = false;
        else if (l > u || l == kInf || u == -kInf)
            c.box_ok = false;
        res.x[i] = std::isfinite(l) ? l : (std::isfinite(u) ? u : 0.0);
    }
    return c;
}

// The problem without its fixed variables (lower == upper) and the rows they leave empty.
struct Reduced {
    std::vector<Index> cmap, rmap;  // user's column/row -> kept one, -1 when eliminated
    std::vector<Index> keep, rows;  // kept columns/rows in the user's numbering
    Index nk = 0, mk = 0;
    Vec xfix;   // the fixed values (0 for the free variables)
    Vec bfull;  // b less the fixed variables' part
    SpMat Pk, Ak;
    Vec qk, lk, uk, bk;
};

Reduced eliminate_fixed(const QpProblem& pr, const SpMat& Psym, const SpMat& A) {
    const Index n = pr.q.size(), m = pr.b.size();
    Reduced r;
    r.cmap.assign(static_cast<size_t>(n), -1);
    r.rmap.assign(static_cast<size_t>(m), -1);
    r.xfix = Vec::Zero(n);
    for (Index i = 0; i < n; ++i) {
        if (pr.lower[i] == pr.upper[i])
            r.xfix[i] = pr.lower[i];
        else
            r.cmap[i] = static_cast<Index>(r.keep.size()), r.keep.push_back(i);
    }
    r.nk = static_cast<Index>(r.keep.size());
    for (Index j = 0; j < n; ++j)
        if (r.cmap[j] >= 0)
            for (SpMat::InnerIterator e(A, j); e; ++e) r.rmap[e.row()] = 0;
    for (Index i = 0; i < m; ++i)
        if (r.rmap[i] == 0) r.rmap[i] = static_cast<Index>(r.rows.size()), r.rows.push_back(i);
    r.mk = static_cast<Index>(r.rows.size());
    r.Pk = extract(Psym, r.cmap, r.nk, r.cmap, r.nk);
    r.Ak = extract(A, r.rmap, r.mk, r.cmap, r.nk);
    const Vec qfull = pr.q + Psym * r.xfix;
    r.bfull = pr.b - A * r.xfix;
    r.qk.resize(r.nk);
    r.lk.resize(r.nk);
    r.uk.resize(r.nk);
    r.bk.resize(r.mk);
    for (Index i = 0; i < r.nk; ++i)
        r.qk[i] = qfull[r.keep[i]], r.lk[i] = pr.lower[r.keep[i]], r.uk[i] = pr.upper[r.keep[i]];
    for (Index i = 0; i < r.mk; ++i) r.bk[i] = r.bfull[r.rows[i]];
    return r;
}

// A row left without free columns is either satisfied by the fixed values or infeasible.
bool fixed_row_violated(const QpProblem& pr, const SpMat& A, const Reduced& r,
                        const QpOptions& opt) {
    const Vec fixed_mag = A.cwiseAbs() * r.xfix.cwiseAbs();
    for (Index i = 0; i < pr.b.size(); ++i) {
        const double scale = std::max({1.0, norm_inf(pr.b), fixed_mag[i]});
        if (r.rmap[i] < 0 && std::abs(r.bfull[i]) > opt.tolerance * scale) return true;
    }
    return false;
}

// The problem as the solve sees it: the user's, the reduced one and its equilibration.
struct Setting {
    const QpProblem& pr;
    const QpOptions& opt;
    const SpMat& A;     // the user's, with n columns
    const SpMat& Psym;  // the symmetric part of P
    const Reduced& red;
    const Scaled& s;
};

// Sets the residuals of r in the user's units; returns them.
Metrics record_residuals(const SpMat& Psym, const QpProblem& pr, const SpMat& A, QpResult& r) {
    const Metrics mt =
        evaluate(Psym, pr.q, A, pr.b, pr.lower, pr.upper, r.x, r.y, r.z_lower, r.z_upper);
    r.primal_residual = std::max(mt.eq, mt.viol);
    r.dual_residual = mt.dual;
    r.complementarity = mt.comp;
    return mt;
}

// Maps a scaled candidate back to the user's problem (the fixed variables' multipliers from the
// gradient).
void unscale(const Setting& c, const Vec& xs, const Vec& ys, const Vec& zls, const Vec& zus,
             QpResult& cand) {
    const Reduced& r = c.red;
    const Scaled& s = c.s;
    const Index n = c.pr.q.size();
    cand.x = r.xfix;
    cand.y.setZero();
    cand.z_lower.setZero();
    cand.z_upper.setZero();
    for (Index i = 0; i < r.nk; ++i) {
        cand.x[r.keep[i]] = s.D[i] * xs[i];
        cand.z_lower[r.keep[i]] = zls[i] / (s.c * s.D[i]);
        cand.z_upper[r.keep[i]] = zus[i] / (s.c * s.D[i]);
    }
    for (Index i = 0; i < r.mk; ++i) cand.y[r.rows[i]] = s.E[i] * ys[i] / s.c;
    if (r.nk < n) {
        const Vec g = c.Psym * cand.x + c.pr.q - c.A.transpose() * cand.y;
        for (Index i = 0; i < n; ++i) {
            if (r.cmap[i] >= 0) continue;
            cand.z_lower[i] = std::max(g[i], 0.0);
            cand.z_upper[i] = std::max(-g[i], 0.0);
        }
    }
}

// No candidate met the tolerance: the last iterate in the user's units (the starting x where it
// is not finite), with the outcome's status.
QpResult failed_result(const Setting& c, const InteriorPoint& ipm, Outcome outcome,
                       const QpResult& res, QpResult cand) {
    if (c.red.nk > 0)
        unscale(c, ipm.x(), ipm.y(), ipm.zl(), ipm.zu(), cand);
    else
        cand.x = c.red.xfix;
    if (!(cand.x.allFinite() && cand.y.allFinite() && cand.z_lower.allFinite() &&
          cand.z_upper.allFinite())) {
        cand.x = res.x;
        cand.y.setZero();
        cand.z_lower.setZero();
        cand.z_upper.setZero();
    }
    QpResult out = cand;
    out.polished = false;
    out.status =
        outcome == Outcome::MaxIterations ? QpStatus::MaxIterations : QpStatus::NumericalError;
    out.iterations = ipm.iterations();
    record_residuals(c.Psym, c.pr, c.A, out);
    return out;
}

// The interior-point method with its polish on the equilibrated problem; a candidate is kept when
// it meets the tolerance in the user's units. Phase 1 when the constraints look infeasible.
QpResult solve_scaled(const Setting& c, bool allow_phase1, QpResult res) {
    QpResult cand = res;
    bool accepted = false;
    AcceptFn accept = [&](const Vec& xs, const Vec& ys, const Vec& zls, const Vec& zus,
                          bool polished) {
        unscale(c, xs, ys, zls, zus, cand);
        cand.polished = polished;
        const Metrics mt = record_residuals(c.Psym, c.pr, c.A, cand);
        if (!mt.meets(c.opt.tolerance)) return false;
        cand.status = QpStatus::Solved;
        res = cand;
        accepted = true;
        return true;
    };

    InteriorPoint ipm(c.s, c.opt, accept);
    Outcome outcome = Outcome::NumericalError;
    bool watch = allow_phase1;
    bool phase1_done = false;
    while (true) {
        outcome = ipm.run(watch);
        if (outcome != Outcome::SuspectInfeasible) break;
        watch = false;
        phase1_done = true;
        if (prove_infeasible(c.pr, c.Psym, c.opt, res)) {
            res.iterations = ipm.iterations();
            return res;
        }
    }
    if (accepted) {
        res.iterations = ipm.iterations();
        return res;
    }
    // The last iterate may still meet the tolerance in the user's units.
    if (c.red.nk > 0 && ipm.x().allFinite() &&
        accept(ipm.x(), ipm.y(), ipm.zl(), ipm.zu(), false)) {
        res.iterations = ipm.iterations();
        return res;
    }
    // Failure: report the last iterate, unless phase 1 shows the problem is infeasible.
    if (allow_phase1 && !phase1_done && prove_infeasible(c.pr, c.Psym, c.opt, res)) {
        res.iterations = ipm.iterations();
        return res;
    }
    return failed_result(c, ipm, outcome, res, cand);
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
    check_shapes(pr);
    const Index n = pr.q.size(), m = pr.b.size();
    QpResult res;
    res.x = Vec::Zero(n);
    res.y = Vec::Zero(m);
    res.z_lower = Vec::Zero(n);
    res.z_upper = Vec::Zero(n);
    SpMat A = pr.A;
    if (A.cols() != n) A.resize(m, n);

    const DataCheck data = check_data(pr, A, res);
    if (!data.data_ok) {
        res.status = QpStatus::NumericalError;
        res.primal_residual = res.dual_residual = res.complementarity = kInf;
        return res;
    }
    const SpMat Psym = 0.5 * (pr.P + SpMat(pr.P.transpose()));  // exact if P is symmetric
    if (!data.box_ok) {
        res.status = QpStatus::Infeasible;
        record_residuals(Psym, pr, A, res);
        return res;
    }

    const Reduced red = eliminate_fixed(pr, Psym, A);
    if (fixed_row_violated(pr, A, red, opt)) {
        if (allow_phase1 && prove_infeasible(pr, Psym, opt, res)) return res;
        res.status = QpStatus::Infeasible;  // phase 1 unavailable: the row itself is proof
        record_residuals(Psym, pr, A, res);
        return res;
    }

    const Scaled s = equilibrate(red.Pk, red.qk, red.Ak, red.bk, red.lk, red.uk);
    return solve_scaled(Setting{pr, opt, A, Psym, red, s}, allow_phase1, res);
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
