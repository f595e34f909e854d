#include "spectral/vertex_qp.h"

#include <gtest/gtest.h>

#include <Eigen/SparseCore>
#include <algorithm>
#include <random>
#include <string>

#include "base/error.h"
#include "spectral/colorimetry.h"
#include "spectral/qp_solver.h"
#include "spectral/spectrum.h"

using namespace spectex;

namespace {

const Eigen::Matrix3Xd& weights() {
    static const Eigen::Matrix3Xd C =
        Colorimetry::make(load_observer(SPECTEX_TEST_DATA_DIR, "cie1931-2"),
                          load_illuminant(SPECTEX_TEST_DATA_DIR, "D65"),
                          WavelengthGrid::parse("380:780:10"), primaries_by_name("srgb"))
            .rgb_weights();
    return C;
}

Eigen::VectorXd reference(const Eigen::Matrix3Xd& C, const TridiagonalHessian& H,
                          const Eigen::VectorXd& q, const Eigen::Vector3d& v) {
    const Eigen::Index N = C.cols();
    Eigen::MatrixXd P = Eigen::MatrixXd::Zero(N, N);
    for (Eigen::Index k = 0; k < N; ++k) {
        P(k, k) = H.diag(k);
        if (!H.d.empty() && k + 1 < N) P(k, k + 1) = P(k + 1, k) = H.off(k);
    }
    QpProblem p;
    p.P = P.sparseView();
    p.A = Eigen::MatrixXd(C).sparseView();
    p.q = q;
    p.b = v;
    p.lower = Eigen::VectorXd::Zero(N);
    p.upper = Eigen::VectorXd::Ones(N);
    const QpResult r = solve_qp(p);
    EXPECT_EQ(r.status, QpStatus::Solved);
    return r.x;
}

}  // namespace

// Random targets (s0 anywhere in [-0.5, 1.5], so many bounds are active) and random colours
// inside the cube: both fast solvers against solve_qp. Tolerances: colour at double rounding
// (1e-13, the build's own demand), solution within 1e-9 of solve_qp (unique minimiser; both
// polish on the same free set, so in practice ~1e-15).
TEST(LatticeVertexQp, DualNewtonProjectionMatchesSolveQp) {
    const Eigen::Matrix3Xd& C = weights();
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    TridiagonalHessian I;
    I.size = C.cols();
    for (int i = 0; i < 100; ++i) {
        Eigen::VectorXd s0(C.cols());
        for (Eigen::Index k = 0; k < s0.size(); ++k) s0[k] = 2 * u(rng) - 0.5;
        const Eigen::Vector3d v(u(rng), u(rng), u(rng));
        Eigen::VectorXd s;
        int it = 0;
        ASSERT_TRUE(project_dual_newton(C, s0, v, s, &it));
        EXPECT_LE((C * s - v).cwiseAbs().maxCoeff(), 1e-13);
        EXPECT_GE(s.minCoeff(), 0.0);
        EXPECT_LE(s.maxCoeff(), 1.0);
        EXPECT_LE((s - reference(C, I, -s0, v)).cwiseAbs().maxCoeff(), 1e-9);
        EXPECT_LT(it, 20);  // semismooth Newton: superlinear; measured max 6
    }
}

TEST(LatticeVertexQp, ActiveSetMatchesSolveQp) {
    const Eigen::Matrix3Xd& C = weights();
    std::mt19937 rng(12);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (double alpha : {1.0, 1e-4}) {
        TridiagonalHessian H;
        H.size = C.cols();
        H.alpha = alpha;
        H.d.assign(static_cast<size_t>(C.cols()) - 1, 1.0);
        std::vector<char> warm;
        for (int i = 0; i < 100; ++i) {
            Eigen::VectorXd q(C.cols());
            for (Eigen::Index k = 0; k < q.size(); ++k) q[k] = -alpha * (2 * u(rng) - 0.5);
            const Eigen::Vector3d v(u(rng), u(rng), u(rng));
            VertexQpStats st;
            const Eigen::VectorXd s = solve_vertex_qp(C, H, q, v, 1e-13, "test", &st, &warm);
            EXPECT_FALSE(st.used_fallback);
            EXPECT_LE((C * s - v).cwiseAbs().maxCoeff(), 1e-13);
            EXPECT_LE((s - reference(C, H, q, v)).cwiseAbs().maxCoeff(), 1e-9) << alpha;
        }
    }
}

TEST(LatticeVertexQp, InfeasibleColourThrowsWithTheCaller) {
    // Green above 1 in one channel with the others 0 is beyond any reflectance: Error, naming it.
    const Eigen::Matrix3Xd& C = weights();
    TridiagonalHessian I;
    I.size = C.cols();
    const Eigen::VectorXd q = Eigen::VectorXd::Constant(C.cols(), -0.5);
    try {
        solve_vertex_qp(C, I, q, Eigen::Vector3d(0, 1.5, 0), 1e-13, "vertex X");
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("vertex X: no reflectance", 0), 0u) << e.what();
    }
}
