// Ruiz equilibration with power-of-two factors, and the residuals of a candidate in the user's
// units by which solve_qp judges it (see QpResult). The equilibration is Ruiz's iteration
// (D. Ruiz, "A scaling algorithm to equilibrate both rows and columns norms in matrices",
// RAL-TR-2001-034, 2001) on the infinity norms of the columns of [P; A] and the rows of A, then a
// scaling of the cost; the accumulated factors are rounded to powers of two, so that scaling and
// unscaling are exact.
#include <algorithm>
#include <cmath>

#include "spectral/qp_internal.h"

namespace spectex::qp_detail {

namespace {

// Closest power of two, so that scaling by it is exact in binary floating point.
double nearest_pow2(double v) {
    if (!(v > 0.0) || !std::isfinite(v)) return 1.0;
    int e = 0;
    const double mant = std::frexp(v, &e);  // v = mant * 2^e, mant in [0.5, 1)
    return std::ldexp(1.0, mant < std::sqrt(0.5) ? e - 1 : e);
}

}  // namespace

// ---- Residuals in the user's units -------------------------------------------------------------
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

}  // namespace spectex::qp_detail
