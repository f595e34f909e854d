#include "spectral/lhtss.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace spectex {

namespace {

// |z| past this gives s within 1e-16 of 0 or 1 (tanh(18.5) = 1 - 1.7e-16): a larger step only
// loses the derivative the Newton system needs.
constexpr double kZMax = 18.5;
constexpr int kMaxIterations = 100;

// Solves the tridiagonal system T X = B in place (B: N×m, column-major in an Eigen matrix) by
// Gaussian elimination with partial pivoting (LAPACK's dgtsv): lower, diag, upper hold T's
// subdiagonal (lower[i] = T(i+1, i)), diagonal and superdiagonal and are overwritten. False on a
// zero pivot.
bool solve_tridiagonal(std::vector<double> lower, std::vector<double> diag,
                       std::vector<double> upper, Eigen::MatrixXd& B) {
    const Eigen::Index n = static_cast<Eigen::Index>(diag.size());
    std::vector<double> upper2(diag.size(), 0.0);  // the second superdiagonal fill-in
    for (Eigen::Index i = 0; i + 1 < n; ++i) {
        const size_t u = static_cast<size_t>(i);
        if (std::fabs(diag[u]) >= std::fabs(lower[u])) {
            if (diag[u] == 0) return false;
            const double f = lower[u] / diag[u];
            diag[u + 1] -= f * upper[u];
            B.row(i + 1) -= f * B.row(i);
        } else {
            const double f = diag[u] / lower[u];
            diag[u] = lower[u];
            const double t = diag[u + 1];
            diag[u + 1] = upper[u] - f * t;
            if (i + 2 < n) {
                upper2[u] = upper[u + 1];
                upper[u + 1] = -f * upper2[u];
            }
            upper[u] = t;
            const Eigen::RowVectorXd row = B.row(i);
            B.row(i) = B.row(i + 1);
            B.row(i + 1) = row - f * B.row(i + 1);
        }
    }
    if (diag[static_cast<size_t>(n - 1)] == 0) return false;
    for (Eigen::Index i = n - 1; i >= 0; --i) {
        const size_t u = static_cast<size_t>(i);
        if (i + 1 < n) B.row(i) -= upper[u] * B.row(i + 1);
        if (i + 2 < n) B.row(i) -= upper2[u] * B.row(i + 2);
        B.row(i) /= diag[u];
    }
    return B.allFinite();
}

}  // namespace

LhtssResult lhtss_spectrum(const Eigen::Matrix3Xd& C, const WavelengthGrid& grid,
                           const Eigen::Vector3d& v, double tolerance) {
    return tanh_prior_spectrum(C, grid, v, nullptr, tolerance);
}

LhtssResult tanh_prior_spectrum(const Eigen::Matrix3Xd& C, const WavelengthGrid& grid,
                                const Eigen::Vector3d& v, const TanhPrior* prior,
                                double tolerance) {
    const Eigen::Index N = C.cols();
    const size_t n = static_cast<size_t>(N);
    // LHTSS: K = D'WD, (w_k (z[k+1] - z[k]))² summed, w_k = 10 nm / Δλ_k. A tiny multiple of the
    // identity (1e-9 of the largest weight) makes the tridiagonal block invertible at the start,
    // where s'' = 0 and K alone is singular along constant z; it moves the optimum by ~1e-9.
    // A learned prior: the roughness of Brownian motion along λ, (z[k+1] - z[k])² · 5 nm / Δλ_k
    // (the grid-independent form its covariance was fitted with), minus V V' (below).
    std::vector<double> kd(n, 0.0), ko(n > 0 ? n - 1 : 0, 0.0);
    double wmax = 0;
    for (size_t k = 0; k + 1 < n; ++k) {
        const double step = grid.lambda[k + 1] - grid.lambda[k];
        const double w2 = prior ? 5.0 / step : (10.0 / step) * (10.0 / step);
        wmax = std::max(wmax, w2);
        kd[k] += w2;
        kd[k + 1] += w2;
        ko[k] = -w2;
    }
    const double eps = 1e-9 * wmax;
    auto times_k = [&](const Eigen::VectorXd& z) {
        Eigen::VectorXd out(N);
        for (Eigen::Index k = 0; k < N; ++k) {
            const size_t u = static_cast<size_t>(k);
            double x = (kd[u] + eps) * z[k];
            if (k > 0) x += ko[u - 1] * z[k - 1];
            if (k + 1 < N) x += ko[u] * z[k + 1];
            out[k] = x;
        }
        return out;
    };
    // The learned prior's precision (G + F F')⁻¹ = K - K F (I + F'KF)⁻¹ F'K = K - V V', with
    // V = K F L⁻ᵀ and L L' = I + F'KF (Woodbury): the Newton block stays tridiagonal plus rank m.
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(N);
    Eigen::MatrixXd V(N, 0);
    if (prior) {
        mean = prior->mean;
        const Eigen::Index m = prior->factors.cols();
        if (m > 0) {
            Eigen::MatrixXd KF(N, m);
            for (Eigen::Index j = 0; j < m; ++j) KF.col(j) = times_k(prior->factors.col(j));
            const Eigen::MatrixXd A =
                Eigen::MatrixXd::Identity(m, m) + prior->factors.transpose() * KF;
            const Eigen::LLT<Eigen::MatrixXd> llt(A);
            V = llt.matrixU().solve<Eigen::OnTheRight>(KF);  // K F U⁻¹, U = L'
        }
    }
    const Eigen::Index m = V.cols();
    auto times_p = [&](const Eigen::VectorXd& x) {
        Eigen::VectorXd out = times_k(x);
        if (m > 0) out.noalias() -= V * (V.transpose() * x);
        return out;
    };
    Eigen::VectorXd z = mean, t, s, sp, g;
    Eigen::Vector3d lam = Eigen::Vector3d::Zero();
    Eigen::VectorXd r1;
    Eigen::Vector3d r2;
    auto evaluate = [&](const Eigen::VectorXd& zz, const Eigen::Vector3d& ll) {
        t = zz.array().tanh().matrix();
        s = (0.5 * (t.array() + 1.0)).matrix();
        sp = (0.5 * (1.0 - t.array().square())).matrix();
        g = C.transpose() * ll;
        r1 = times_p(zz - mean) - sp.cwiseProduct(g);
        r2 = C * s - v;
        return r1.squaredNorm() + r2.squaredNorm();
    };
    LhtssResult out;
    // Stationarity is asked to 1e-9 of the roughness scale: past that the prior's spectrum moves
    // by less than the projection that follows it corrects.
    const double stationary = 1e-9 * std::max(1.0, wmax);
    auto done = [&] {
        return r2.cwiseAbs().maxCoeff() <= tolerance && r1.cwiseAbs().maxCoeff() <= stationary;
    };
    double merit = evaluate(z, lam);
    for (int it = 0; it < kMaxIterations && !done(); ++it) {
        ++out.iterations;
        // Newton on [P (z - mean) - s'∘(C'λ); C s - v] = 0: the z block is tridiagonal (K plus
        // the diagonal -s''∘(C'λ), s'' = -2 t s') minus V V', bordered by -diag(s') C' and
        // C diag(s').
        std::vector<double> lower(ko.begin(), ko.end()), upper(ko.begin(), ko.end()), diag(n);
        for (size_t k = 0; k < n; ++k) {
            const Eigen::Index i = static_cast<Eigen::Index>(k);
            diag[k] = kd[k] + eps + 2.0 * t[i] * sp[i] * g[i];
        }
        Eigen::MatrixXd X(N, 4 + m);
        X.col(0) = -r1;
        for (int j = 0; j < 3; ++j) X.col(j + 1) = -sp.cwiseProduct(C.row(j).transpose());
        if (m > 0) X.rightCols(m) = V;
        if (!solve_tridiagonal(lower, diag, upper, X)) break;
        if (m > 0) {
            // (T - V V')⁻¹ B = T⁻¹B + T⁻¹V (I - V'T⁻¹V)⁻¹ V'T⁻¹B
            const Eigen::MatrixXd TV = X.rightCols(m);
            const Eigen::MatrixXd S = Eigen::MatrixXd::Identity(m, m) - V.transpose() * TV;
            const Eigen::MatrixXd corr = S.fullPivLu().solve(V.transpose() * X.leftCols(4));
            X.leftCols(4) += TV * corr;
        }
        const Eigen::VectorXd x0 = X.col(0);
        const Eigen::MatrixXd Y = X.middleCols(1, 3);  // J11^-1 J12
        const Eigen::Matrix3Xd J21 = C * sp.asDiagonal();
        const Eigen::Matrix3d S = J21 * Y;
        const Eigen::Vector3d dlam = S.fullPivLu().solve(J21 * x0 + r2);
        const Eigen::VectorXd dz = x0 - Y * dlam;
        if (!dz.allFinite() || !dlam.allFinite()) break;
        // Backtracking on the residual's squared norm.
        double step = 1.0;
        bool moved = false;
        for (int k = 0; k < 40; ++k, step *= 0.5) {
            const Eigen::VectorXd zn = (z + step * dz).cwiseMax(-kZMax).cwiseMin(kZMax);
            const Eigen::Vector3d ln = lam + step * dlam;
            const double m = evaluate(zn, ln);
            if (m < merit * (1.0 - 1e-4 * step) || m == 0.0) {
                z = zn;
                lam = ln;
                merit = m;
                moved = true;
                break;
            }
        }
        if (!moved) {
            evaluate(z, lam);
            break;
        }
    }
    // Rounding can stop the line search a hair short of the colour tolerance: within 100 times
    // it (1e-11 for the lattice's 1e-13) the Newton solve has done its work.
    out.colour_residual = r2.cwiseAbs().maxCoeff();
    out.converged =
        out.colour_residual <= 100 * tolerance && r1.cwiseAbs().maxCoeff() <= 100 * stationary;
    out.s = s;
    out.z = z;
    return out;
}

}  // namespace spectex
