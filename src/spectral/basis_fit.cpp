#include "spectral/basis_fit.h"

#include <Eigen/SparseCore>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "base/error.h"
#include "spectral/qp_solver.h"

namespace spectex {

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

// Objective matrix P (3N x 3N) for one objective; q = 0.
Eigen::SparseMatrix<double> objective_matrix(FitObjective o, const WavelengthGrid& g) {
    const int n = static_cast<int>(g.size());
    Triplets t;
    if (o == FitObjective::Norm || n < 2) {
        for (int i = 0; i < 3 * n; ++i) t.emplace_back(i, i, 1.0);
    } else {
        // Sum over k of (S_{k+1} - S_k)^2, plain first differences on any grid. (Dividing by the
        // spacing would follow the slope more closely on uneven grids, but near-duplicate
        // wavelengths would then get weights of 1e6 and wreck the conditioning.)
        for (int s = 0; s < 3; ++s) {
            int o0 = s * n;
            for (int k = 0; k + 1 < n; ++k) {
                const double w = 2.0;  // 0.5 x'Px convention
                t.emplace_back(o0 + k, o0 + k, w);
                t.emplace_back(o0 + k + 1, o0 + k + 1, w);
                t.emplace_back(o0 + k, o0 + k + 1, -w);
                t.emplace_back(o0 + k + 1, o0 + k, -w);
            }
        }
    }
    Eigen::SparseMatrix<double> P(3 * n, 3 * n);
    P.setFromTriplets(t.begin(), t.end());
    return P;
}

// Equality rows: colour of S_r and S_g (6 rows), then N sum-to-one rows. The colour rows of S_b
// follow from these when the white is consistent (sum of the colour rows = RGB of the perfect
// reflector = (1,1,1)), so they are left out: the 9 + N rows have rank N + 6.
void equality_rows(const Eigen::Matrix3Xd& R, int n, Eigen::SparseMatrix<double>* A,
                   Eigen::VectorXd* b, bool all_nine) {
    const int colour_rows = all_nine ? 9 : 6;
    Triplets t;
    *b = Eigen::VectorXd::Zero(colour_rows + n);
    for (int s = 0; s < colour_rows / 3; ++s)
        for (int c = 0; c < 3; ++c) {
            int row = 3 * s + c;
            for (int k = 0; k < n; ++k)
                if (R(c, k) != 0) t.emplace_back(row, s * n + k, R(c, k));
            (*b)(row) = c == s ? 1.0 : 0.0;
        }
    for (int k = 0; k < n; ++k) {
        for (int s = 0; s < 3; ++s) t.emplace_back(colour_rows + k, s * n + k, 1.0);
        (*b)(colour_rows + k) = 1.0;
    }
    *A = Eigen::SparseMatrix<double>(colour_rows + n, 3 * n);
    A->setFromTriplets(t.begin(), t.end());
}

Basis to_basis(const Eigen::VectorXd& x, const WavelengthGrid& g, const std::string& name) {
    const size_t n = g.size();
    Basis b;
    b.name = name;
    b.lambda = g.lambda;
    b.r.assign(x.data(), x.data() + n);
    b.g.assign(x.data() + n, x.data() + 2 * n);
    b.b.assign(x.data() + 2 * n, x.data() + 3 * n);
    return b;
}

Eigen::VectorXd to_vector(const Basis& b) {
    const size_t n = b.size();
    Eigen::VectorXd x(3 * n);
    for (size_t k = 0; k < n; ++k) {
        x(k) = b.r[k];
        x(n + k) = b.g[k];
        x(2 * n + k) = b.b[k];
    }
    return x;
}

}  // namespace

FitObjective parse_objective(const std::string& name) {
    if (const auto o = kFitObjectiveNames.find(name)) return *o;
    throw Error("unknown objective '" + name + "' (known: " + kFitObjectiveNames.list() + ")");
}

std::string to_string(FitObjective o) { return kFitObjectiveNames.name(o); }

FitCertificate certify_basis(const Basis& basis, const Colorimetry& c) {
    FitCertificate cert;
    const Eigen::Matrix3Xd R = c.rgb_weights();
    const size_t n = basis.size();
    const std::vector<double>* s[3] = {&basis.r, &basis.g, &basis.b};
    for (int k = 0; k < 3; ++k) {
        Eigen::Map<const Eigen::VectorXd> v(s[k]->data(), static_cast<Eigen::Index>(n));
        Eigen::Vector3d rgb = R * v;
        rgb(k) -= 1.0;
        cert.colour_residual[k] = rgb.cwiseAbs().maxCoeff();
    }
    for (size_t i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) {
            double v = (*s[k])[i];
            cert.bound_violation = std::max({cert.bound_violation, -v, v - 1.0});
            cert.active_lower += v == 0.0;
            cert.active_upper += v == 1.0;
        }
        cert.sum_violation =
            std::max(cert.sum_violation, std::fabs(basis.r[i] + basis.g[i] + basis.b[i] - 1.0));
    }
    cert.stationarity = cert.complementarity = cert.dual_sign_violation =
        std::numeric_limits<double>::quiet_NaN();
    return cert;
}

FitResult fit_basis(const FitRequest& req) {
    auto t0 = std::chrono::steady_clock::now();
    const Colorimetry& c = req.colorimetry;
    const WavelengthGrid& g = c.grid;
    const int n = static_cast<int>(g.size());
    if (n < 3) throw Error("a basis needs at least 3 wavelengths (got " + std::to_string(n) + ")");
    const Eigen::Matrix3Xd R = c.rgb_weights();

    QpProblem qp;
    qp.P = objective_matrix(req.objective, g);
    qp.q = Eigen::VectorXd::Zero(3 * n);
    equality_rows(R, n, &qp.A, &qp.b, false);
    qp.lower = Eigen::VectorXd::Zero(3 * n);
    qp.upper = Eigen::VectorXd::Ones(3 * n);
    QpResult r = solve_qp(qp);

    std::string name = "fit:" + to_string(req.objective);
    FitResult out;
    bool feasible = r.status == QpStatus::Solved;
    if (r.status == QpStatus::Infeasible) {
        // Closest basis in the least-squares sense: the colour error over all nine rows is
        // minimised with free residuals r = R S_k - e_k; its minimum tells how far off we are.
        QpProblem ls;
        const int m = 9;
        Eigen::SparseMatrix<double> A9;
        Eigen::VectorXd b9;
        equality_rows(R, n, &A9, &b9, true);
        Triplets t;
        for (int k = 0; k < A9.outerSize(); ++k)
            for (Eigen::SparseMatrix<double>::InnerIterator it(A9, k); it; ++it)
                t.emplace_back(static_cast<int>(it.row()), static_cast<int>(it.col()), it.value());
        for (int i = 0; i < m; ++i) t.emplace_back(i, 3 * n + i, -1.0);  // R S - r = e
        ls.A = Eigen::SparseMatrix<double>(m + n, 3 * n + m);
        ls.A.setFromTriplets(t.begin(), t.end());
        ls.b = b9;
        // Minimise |r|^2, plus a tiny share of the objective to pick one basis among the
        // minimisers.
        Eigen::SparseMatrix<double> P = objective_matrix(req.objective, g);
        Triplets pt;
        for (int k = 0; k < P.outerSize(); ++k)
            for (Eigen::SparseMatrix<double>::InnerIterator it(P, k); it; ++it)
                pt.emplace_back(static_cast<int>(it.row()), static_cast<int>(it.col()),
                                1e-9 * it.value());
        for (int i = 0; i < m; ++i) pt.emplace_back(3 * n + i, 3 * n + i, 1.0);
        ls.P = Eigen::SparseMatrix<double>(3 * n + m, 3 * n + m);
        ls.P.setFromTriplets(pt.begin(), pt.end());
        ls.q = Eigen::VectorXd::Zero(3 * n + m);
        ls.lower = Eigen::VectorXd::Zero(3 * n + m);
        ls.upper = Eigen::VectorXd::Ones(3 * n + m);
        ls.lower.tail(m).setConstant(-std::numeric_limits<double>::infinity());
        ls.upper.tail(m).setConstant(std::numeric_limits<double>::infinity());
        QpResult lr = solve_qp(ls);
        if (lr.status != QpStatus::Solved)
            throw Error("basis fit: the least-squares phase failed (" +
                        std::string(to_string(lr.status)) + ")");
        Basis closest = to_basis(lr.x.head(3 * n), g, name + " (least-squares, infeasible)");
        FitCertificate cert = certify_basis(closest, c);
        double worst =
            std::max({cert.colour_residual[0], cert.colour_residual[1], cert.colour_residual[2]});
        if (!req.allow_infeasible) {
            char buf[256];
            std::snprintf(
                buf, sizeof buf,
                "no basis reproduces these primaries with 0 <= S <= 1 on this grid (infeasible: "
                "the "
                "closest basis misses by %.3g in linear RGB); --allow-infeasible writes it",
                worst);
            throw Error(buf);
        }
        out.basis = closest;
        out.certificate = cert;
        out.certificate.iterations = r.iterations + lr.iterations;
        out.certificate.solver_status = "infeasible; least-squares closest";
        r = lr;
        r.x.conservativeResize(3 * n);
    } else if (!feasible) {
        throw Error(std::string("basis fit: the QP solver did not converge (") +
                    to_string(r.status) + ")");
    } else {
        out.basis = to_basis(r.x, g, name);
        out.certificate = certify_basis(out.basis, c);
        out.certificate.iterations = r.iterations;
        out.certificate.solver_status = r.polished ? "solved (polished)" : "solved";
    }
    out.certificate.feasible = feasible;

    // KKT residuals, recomputed here from the basis and the multipliers.
    if (feasible) {
        const Eigen::VectorXd x = to_vector(out.basis);
        Eigen::VectorXd grad = qp.P * x + qp.q;
        Eigen::VectorXd resid = grad - qp.A.transpose() * r.y - r.z_lower + r.z_upper;
        double scale = 1.0 + grad.cwiseAbs().maxCoeff();
        out.certificate.stationarity = resid.cwiseAbs().maxCoeff() / scale;
        double comp = 0, sign = 0;
        for (int i = 0; i < 3 * n; ++i) {
            comp = std::max(
                {comp, std::fabs(r.z_lower(i) * x(i)), std::fabs(r.z_upper(i) * (1.0 - x(i)))});
            sign = std::max({sign, -r.z_lower(i), -r.z_upper(i)});
        }
        out.certificate.complementarity = comp;
        out.certificate.dual_sign_violation = sign;
        out.certificate.objective = 0.5 * x.dot(qp.P * x);
    }
    out.certificate.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
}

}  // namespace spectex
