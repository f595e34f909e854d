// Benchmarks of spectex::solve_qp on the spectral primary decomposition problem, built
// synthetically (same construction as tests/unit/qp_solver_test.cpp): N wavelengths over
// 380..780 nm, x = [S_r; S_g; S_b] in [0, 1], N sum-to-one rows and 9 colour rows of rank N + 6.
//   BM_QpNorm/N    P = I
//   BM_QpSmooth/N  P = D'D per spectrum (first differences; only positive semi-definite)
// Counters: IPM iterations, whether the result was polished, and the relative residuals.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <vector>

#include "spectral/qp_solver.h"

namespace {

using spectex::QpProblem;
using spectex::QpResult;
using Triplets = std::vector<Eigen::Triplet<double>>;

double smoothstep(double e0, double e1, double v) {
    const double t = std::clamp((v - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

QpProblem spectral_problem(int N, bool smooth) {
    Eigen::MatrixXd W(3, N), S(N, 3);
    const double centre[3] = {600.0, 550.0, 450.0};
    for (int i = 0; i < N; ++i) {
        const double lambda = 380.0 + 400.0 * i / (N - 1);
        for (int c = 0; c < 3; ++c)
            W(c, i) = std::exp(-0.5 * std::pow((lambda - centre[c]) / 40.0, 2));
        S(i, 2) = 1.0 - smoothstep(440.0, 510.0, lambda);
        S(i, 0) = smoothstep(560.0, 630.0, lambda);
        S(i, 1) = 1.0 - S(i, 0) - S(i, 2);
    }
    const Eigen::MatrixXd T = W * S;  // feasible targets
    QpProblem p;
    Triplets t;
    for (int i = 0; i < N; ++i)
        for (int k = 0; k < 3; ++k) t.emplace_back(i, k * N + i, 1.0);
    for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < N; ++i) t.emplace_back(N + 3 * k + c, k * N + i, W(c, i));
    p.A.resize(N + 9, 3 * N);
    p.A.setFromTriplets(t.begin(), t.end());
    p.b.resize(N + 9);
    p.b.head(N).setOnes();
    for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) p.b[N + 3 * k + c] = T(c, k);
    t.clear();
    for (int k = 0; k < 3; ++k) {
        for (int i = 0; i < N; ++i) {
            const int j = k * N + i;
            if (!smooth) {
                t.emplace_back(j, j, 1.0);
                continue;
            }
            t.emplace_back(j, j, (i == 0 || i == N - 1) ? 1.0 : 2.0);
            if (i + 1 < N) {
                t.emplace_back(j, j + 1, -1.0);
                t.emplace_back(j + 1, j, -1.0);
            }
        }
    }
    p.P.resize(3 * N, 3 * N);
    p.P.setFromTriplets(t.begin(), t.end());
    p.q = Eigen::VectorXd::Zero(3 * N);
    p.lower = Eigen::VectorXd::Zero(3 * N);
    p.upper = Eigen::VectorXd::Ones(3 * N);
    return p;
}

void run(benchmark::State& state, bool smooth) {
    const int N = static_cast<int>(state.range(0));
    const QpProblem p = spectral_problem(N, smooth);
    QpResult r;
    for (auto _ : state) {
        r = spectex::solve_qp(p);
        benchmark::DoNotOptimize(r.x.data());
    }
    if (r.status != spectex::QpStatus::Solved) {
        state.SkipWithError(spectex::to_string(r.status));
        return;
    }
    state.counters["iterations"] = r.iterations;
    state.counters["polished"] = r.polished ? 1 : 0;
    state.counters["primal_rel"] = r.primal_residual / std::max(1.0, p.b.lpNorm<Eigen::Infinity>());
    state.counters["dual_abs"] = r.dual_residual;
    state.counters["unknowns"] = 3 * N;
}

void BM_QpNorm(benchmark::State& state) { run(state, false); }
void BM_QpSmooth(benchmark::State& state) { run(state, true); }

// 81: 5 nm, 401: 1 nm, 941: 0.5 nm-like sampling of 380..780 (N = 941 is the brief's size).
BENCHMARK(BM_QpNorm)->Arg(81)->Arg(401)->Arg(941)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_QpSmooth)->Arg(81)->Arg(401)->Arg(941)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
