// Infeasibility of solve_qp's constraints, reported only with evidence: a phase-1 solve
// (min ||Ax - b||^2 over the box, by solve_qp's own method) gives the closest box point x, and
// y = b - A x, repaired by a sparse-QR projection, is checked as a Farkas certificate
// (Farkas' lemma: y'(b - A x) > 0 for every box point x proves A x = b has no solution there).
#include <Eigen/OrderingMethods>
#include <Eigen/SparseQR>
#include <algorithm>
#include <cmath>
#include <vector>

#include "spectral/qp_internal.h"

namespace spectex::qp_detail {

namespace {

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

}  // namespace

// Phase 1: min 0.5||r||^2  s.t.  A x - r = b,  lower <= x <= upper  (always feasible). Its x
// gives y = b - A x, checked as a Farkas certificate. Returns true (and fills `out`) if every
// box point misses A x = b by more than the tolerance.
bool prove_infeasible(const QpProblem& pr, const SpMat& Psym, const QpOptions& opt, QpResult& out) {
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
    const double scale = std::max({1.0, norm_inf(pr.b), norm_inf(pr.A.cwiseAbs() * x.cwiseAbs())});
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

}  // namespace spectex::qp_detail
