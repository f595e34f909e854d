#include "spectral/lattice.h"

#include <gtest/gtest.h>

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include "base/error.h"
#include "spectral/basis_fit.h"
#include "spectral/colorimetry.h"
#include "spectral/jakob_hanika.h"
#include "spectral/lhtss.h"
#include "spectral/measured_prior.h"
#include "spectral/qp_solver.h"
#include "spectral/spectrum.h"
#include "spectral/srgb_axis.h"
#include "temp_dir.h"

using namespace spectex;

namespace {

const std::string kData = SPECTEX_TEST_DATA_DIR;

Colorimetry make(const std::string& grid, const std::string& observer = "cie1931-2",
                 const std::string& illuminant = "D65", const std::string& primaries = "srgb") {
    return Colorimetry::make(load_observer(kData, observer), load_illuminant(kData, illuminant),
                             WavelengthGrid::parse(grid), primaries_by_name(primaries));
}

const Colorimetry& d65() {
    static const Colorimetry c = make("380:780:5");
    return c;
}

// Vertex colours are exact to double rounding: a row of C sums N terms of size ~1/N.
constexpr double kVertexExact = 1e-12;

// Every vertex exact and bounded, black 0 and white 1, and the certificate agrees.
void expect_exact_vertices(const SpectralLattice& L, const Colorimetry& c,
                           const std::string& what) {
    const Eigen::Matrix3Xd C = c.rgb_weights();
    const int n = L.size();
    const size_t B = static_cast<size_t>(L.bins());
    ASSERT_EQ(L.table().size(), static_cast<size_t>(n) * n * n * B) << what;
    double worst = 0;
    for (int ir = 0; ir < n; ++ir)
        for (int ig = 0; ig < n; ++ig)
            for (int ib = 0; ib < n; ++ib) {
                const size_t idx = (static_cast<size_t>(ir) * n + ig) * n + ib;
                const Eigen::Map<const Eigen::VectorXd> s(&L.table_double()[idx * B],
                                                          static_cast<Eigen::Index>(B));
                const Eigen::Vector3d v(L.axis()[static_cast<size_t>(ir)],
                                        L.axis()[static_cast<size_t>(ig)],
                                        L.axis()[static_cast<size_t>(ib)]);
                const double res = (C * s - v).cwiseAbs().maxCoeff();
                worst = std::max(worst, res);
                ASSERT_LE(res, kVertexExact) << what << " vertex " << ir << "," << ig << "," << ib;
                ASSERT_GE(s.minCoeff(), 0.0) << what;
                ASSERT_LE(s.maxCoeff(), 1.0) << what;
            }
    const size_t white = (static_cast<size_t>(n) * n * n - 1) * B;
    for (size_t k = 0; k < B; ++k) {
        EXPECT_EQ(L.table_double()[k], 0.0) << what;
        EXPECT_EQ(L.table_double()[white + k], 1.0) << what;
    }
    EXPECT_EQ(L.max_colour_residual, worst) << what;
    EXPECT_GE(L.min_value, 0.0);
    EXPECT_LE(L.max_value, 1.0);
}

// Independent feasibility: the colour solid is convex, so the lattice is feasible iff the eight
// corners of the RGB cube are colours of reflectances in [0, 1]; asked of solve_qp (min ||s||²).
bool corners_feasible(const Colorimetry& c) {
    const Eigen::Matrix3Xd C = c.rgb_weights();
    const Eigen::Index N = C.cols();
    QpProblem p;
    std::vector<Eigen::Triplet<double>> ta, tp;
    for (Eigen::Index k = 0; k < N; ++k) {
        tp.emplace_back(k, k, 1.0);
        for (int r = 0; r < 3; ++r) ta.emplace_back(r, k, C(r, k));
    }
    p.P.resize(N, N);
    p.P.setFromTriplets(tp.begin(), tp.end());
    p.A.resize(3, N);
    p.A.setFromTriplets(ta.begin(), ta.end());
    p.q = Eigen::VectorXd::Zero(N);
    p.lower = Eigen::VectorXd::Zero(N);
    p.upper = Eigen::VectorXd::Ones(N);
    for (int corner = 1; corner < 7; ++corner) {
        p.b = Eigen::Vector3d((corner >> 2) & 1, (corner >> 1) & 1, corner & 1);
        const QpResult r = solve_qp(p);
        if (r.status == QpStatus::Infeasible) return false;
        EXPECT_EQ(r.status, QpStatus::Solved);
    }
    return true;
}

std::vector<Eigen::Vector3d> random_rgb(int count, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Eigen::Vector3d> out;
    for (int i = 0; i < count; ++i) out.emplace_back(u(rng), u(rng), u(rng));
    return out;
}

Eigen::VectorXd eval(const SpectralLattice& L, const Eigen::Vector3d& rgb) {
    Eigen::VectorXd s(L.bins());
    const double x[3] = {rgb[0], rgb[1], rgb[2]};
    L.spectrum(x, s.data());
    return s;
}

}  // namespace

TEST(LatticePrior, NamesRoundTrip) {
    for (VertexPrior p : {VertexPrior::JakobHanika, VertexPrior::Smooth, VertexPrior::Blend,
                          VertexPrior::Lhtss, VertexPrior::Measured})
        EXPECT_EQ(parse_vertex_prior(to_string(p)), p);
    EXPECT_EQ(parse_vertex_prior("JH"), VertexPrior::JakobHanika);
    EXPECT_THROW(parse_vertex_prior("sigmoid"), Error);
}

static void expect_every_vertex_exact(std::initializer_list<int> sizes) {
    for (int n : sizes)
        for (VertexPrior p : {VertexPrior::JakobHanika, VertexPrior::Smooth, VertexPrior::Blend,
                              VertexPrior::Lhtss}) {
            const SpectralLattice L = SpectralLattice::build(d65(), n, p);
            const std::string what = "n " + std::to_string(n) + " " + to_string(p);
            expect_exact_vertices(L, d65(), what);
        }
}

// Every prior at the sizes whose vertices include the corners, edges and faces of the cube (2, 3)
// and the default (9); 17 (4,913 vertices a prior, a minute under the sanitizers) in a Slow suite.
TEST(Lattice, EveryVertexExactAllPriors) { expect_every_vertex_exact({2, 3, 5, 9}); }
TEST(LatticeSlow, EveryVertexExactAllPriorsAt17) { expect_every_vertex_exact({17}); }

TEST(Lattice, AxisIsSrgbSpaced) {
    const SpectralLattice L = SpectralLattice::build(d65(), 5, VertexPrior::Smooth);
    ASSERT_EQ(L.axis().size(), 5u);
    EXPECT_EQ(L.axis().front(), 0.0);
    EXPECT_EQ(L.axis().back(), 1.0);
    EXPECT_NEAR(L.axis()[2], std::pow((0.5 + 0.055) / 1.055, 2.4), 1e-15);
    EXPECT_NEAR(L.axis()[1], std::pow((0.25 + 0.055) / 1.055, 2.4), 1e-15);
}

TEST(Lattice, RandomColoursExactThroughSpectrumAndExpand) {
    const Eigen::Matrix3Xd C = d65().rgb_weights();
    for (VertexPrior prior : {VertexPrior::JakobHanika, VertexPrior::Smooth}) {
        const SpectralLattice L = SpectralLattice::build(d65(), 9, prior);
        const auto cols = random_rgb(3000, 12345);
        std::vector<float> r, g, b;
        for (const auto& c : cols)
            r.push_back(static_cast<float>(c[0])), g.push_back(static_cast<float>(c[1])),
                b.push_back(static_cast<float>(c[2]));
        const size_t m = cols.size(), B = static_cast<size_t>(L.bins());
        std::vector<float> out(m * B);
        L.expand(r.data(), g.data(), b.data(), m, out.data(), m);
        double worst_ref = 0, worst_fast = 0, worst_diff = 0;
        for (size_t i = 0; i < m; ++i) {
            // Double path: barycentric weights reproduce rgb; vertices within 1e-13, and a few
            // roundings in the weights: 1e-12.
            const Eigen::VectorXd s = eval(L, cols[i]);
            worst_ref = std::max(worst_ref, (C * s - cols[i]).cwiseAbs().maxCoeff());
            ASSERT_GE(s.minCoeff(), 0.0);
            ASSERT_LE(s.maxCoeff(), 1.0);
            // Float path, on the float inputs: float table (6e-8 relative) and float weights
            // (t to ~2e-7): colour within 1e-6, spectrum within 2e-6 of the double evaluation.
            const Eigen::Vector3d in(r[i], g[i], b[i]);
            const Eigen::VectorXd sd = eval(L, in);
            Eigen::VectorXd sf(static_cast<Eigen::Index>(B));
            for (size_t k = 0; k < B; ++k) {
                sf[static_cast<Eigen::Index>(k)] = out[k * m + i];
                ASSERT_GE(out[k * m + i], 0.0f);
                ASSERT_LE(out[k * m + i], 1.0f);
            }
            worst_fast = std::max(worst_fast, (C * sf - in).cwiseAbs().maxCoeff());
            worst_diff = std::max(worst_diff, (sf - sd).cwiseAbs().maxCoeff());
        }
        EXPECT_LE(worst_ref, 1e-12);
        EXPECT_LE(worst_fast, 1e-6);
        EXPECT_LE(worst_diff, 2e-6);
    }
}

TEST(Lattice, CellLocationAtAndAroundBreakpoints) {
    const SpectralLattice L = SpectralLattice::build(d65(), 9, VertexPrior::Smooth);
    const Eigen::Matrix3Xd C = d65().rgb_weights();
    const size_t B = static_cast<size_t>(L.bins());
    std::vector<double> probes = {0.0,
                                  1.0,
                                  1e-6,
                                  1 - 1e-7,
                                  -0.5,
                                  1.5,
                                  -0.0,
                                  std::numeric_limits<double>::infinity(),
                                  -std::numeric_limits<double>::infinity(),
                                  std::numeric_limits<double>::quiet_NaN()};
    for (double a : L.axis()) {
        probes.push_back(a);
        probes.push_back(std::nextafter(a, -1.0));
        probes.push_back(std::nextafter(a, 2.0));
        probes.push_back(static_cast<float>(a));
        probes.push_back(std::nextafter(static_cast<float>(a), -1.0f));
        probes.push_back(std::nextafter(static_cast<float>(a), 2.0f));
    }
    std::vector<float> r, g, b;
    for (double x : probes)
        for (double y : {0.0, 0.3, 1.0})
            r.push_back(static_cast<float>(x)), g.push_back(static_cast<float>(y)),
                b.push_back(static_cast<float>(1 - x));
    const size_t m = r.size();
    std::vector<float> out(m * B);
    L.expand(r.data(), g.data(), b.data(), m, out.data(), m);
    for (size_t i = 0; i < m; ++i) {
        auto clamp = [](double x) { return x > 0 ? std::min(x, 1.0) : 0.0; };  // NaN -> 0
        const Eigen::Vector3d want(clamp(r[i]), clamp(g[i]), clamp(b[i]));
        const Eigen::Vector3d in(r[i], g[i], b[i]);
        const Eigen::VectorXd s = eval(L, in);
        ASSERT_TRUE(s.allFinite()) << r[i];
        EXPECT_LE((C * s - want).cwiseAbs().maxCoeff(), 1e-12)
            << r[i] << " " << g[i] << " " << b[i];
        for (size_t k = 0; k < B; ++k) {
            ASSERT_TRUE(std::isfinite(out[k * m + i])) << r[i];
            EXPECT_NEAR(out[k * m + i], s[static_cast<Eigen::Index>(k)], 2e-6) << r[i];
        }
    }
    // Exactly on a breakpoint, both paths return the vertex spectrum itself.
    const double v[3] = {L.axis()[3], L.axis()[5], L.axis()[8]};
    Eigen::VectorXd s(static_cast<Eigen::Index>(B));
    L.spectrum(v, s.data());
    const size_t idx = (3u * 9 + 5) * 9 + 8;
    for (size_t k = 0; k < B; ++k)
        EXPECT_EQ(s[static_cast<Eigen::Index>(k)], L.table_double()[idx * B + k]);
}

TEST(Lattice, HardColoursExact) {
    for (VertexPrior prior : {VertexPrior::JakobHanika, VertexPrior::Lhtss}) {
        const SpectralLattice L = SpectralLattice::build(d65(), 9, prior);
        const Eigen::Matrix3Xd C = d65().rgb_weights();
        const Eigen::Vector3d cases[] = {
            {1, 0, 0},        {0, 1, 0},    {0, 0, 1},          {1, 1, 0},    {0, 1, 1},
            {1, 0, 1},        {1e-6, 0, 0}, {1e-6, 1e-6, 1e-6}, {0, 0, 1e-6}, {1, 1, 1 - 1e-6},
            {1 - 1e-6, 1, 1}, {0.5, 0, 0},  {1, 0.5, 0},        {0, 0.2, 1},  {0.999, 0.001, 0.5}};
        for (const auto& rgb : cases) {
            const Eigen::VectorXd s = eval(L, rgb);
            EXPECT_LE((C * s - rgb).cwiseAbs().maxCoeff(), 1e-12) << rgb.transpose();
            EXPECT_GE(s.minCoeff(), 0.0);
            EXPECT_LE(s.maxCoeff(), 1.0);
        }
        const Eigen::VectorXd black = eval(L, Eigen::Vector3d::Zero()),
                              white = eval(L, Eigen::Vector3d::Ones());
        EXPECT_EQ(black.cwiseAbs().maxCoeff(), 0.0);
        EXPECT_EQ((white.array() - 1.0).abs().maxCoeff(), 0.0);
    }
}

TEST(LatticeSlow, OtherGridsObserversIlluminants) {
    struct Case {
        std::string grid, observer, illuminant, primaries = "srgb";
    };
    // The last ones are meant to be infeasible (rec2020 green is outside the object colours;
    // a grid without short wavelengths cannot make blue), but the expectation comes from
    // corners_feasible(), not from this comment.
    const Case cases[] = {
        {"380:780:20", "cie1931-2", "D65"}, {"380:780:5", "cie1931-2", "D65"},
        {"360:830:1", "cie1931-2", "D65"},  {"380:780:5", "cie1964-10", "D65"},
        {"380:780:5", "cie1931-2", "A"},    {"400:700:10", "cie1931-2", "D65"},
        {"450:650:10", "cie1931-2", "D65"}, {"380:780:5", "cie1931-2", "D65", "rec2020"},
        {"480:700:10", "cie1931-2", "D65"}};
    int infeasible = 0;
    for (const auto& cs : cases) {
        const Colorimetry c = make(cs.grid, cs.observer, cs.illuminant, cs.primaries);
        const std::string what =
            cs.grid + " " + cs.observer + " " + cs.illuminant + " " + cs.primaries;
        infeasible += !corners_feasible(c);
        const bool feasible = corners_feasible(c);
        // fit_basis feasible (3 exact bounded spectra summing to 1) implies every colour of the
        // cube is feasible; the converse does not hold, so it is only checked one way.
        bool basis_ok = true;
        try {
            fit_basis(FitRequest{c, FitObjective::Smooth, false});
        } catch (const Error&) {
            basis_ok = false;
        }
        if (basis_ok) EXPECT_TRUE(feasible) << what;
        for (VertexPrior p : {VertexPrior::Smooth, VertexPrior::JakobHanika, VertexPrior::Lhtss}) {
            const int n = cs.grid == "360:830:1" ? 5 : 9;
            if (feasible) {
                const SpectralLattice L = SpectralLattice::build(c, n, p);
                expect_exact_vertices(L, c, what + " " + to_string(p));
            } else {
                try {
                    SpectralLattice::build(c, n, p);
                    ADD_FAILURE() << what << ": infeasible setting built a lattice";
                } catch (const Error& e) {
                    const std::string msg = e.what();
                    EXPECT_NE(msg.find("vertex"), std::string::npos) << msg;
                    EXPECT_NE(msg.find(c.grid.describe()), std::string::npos) << msg;
                }
            }
        }
    }
    EXPECT_GE(infeasible, 1) << "the error path was not exercised";
}

TEST(Lattice, ChecksumIsDeterministicAndTracksContent) {
    const SpectralLattice a = SpectralLattice::build(d65(), 5, VertexPrior::Blend, 0.5);
    const SpectralLattice b = SpectralLattice::build(d65(), 5, VertexPrior::Blend, 0.5);
    const SpectralLattice c = SpectralLattice::build(d65(), 5, VertexPrior::Blend, 2.0);
    EXPECT_EQ(a.checksum(), b.checksum());
    EXPECT_NE(a.checksum(), c.checksum());
    EXPECT_EQ(a.checksum().rfind("fnv1a64:", 0), 0u);
    EXPECT_EQ(a.checksum().size(), 8u + 16u);
}

TEST(Lattice, BlendIsBetweenPriors) {
    // Roughness of the vertex spectra: the blend is smoother than the plain projection of the
    // sigmoid and rougher than the smooth prior (at the same exact colours).
    auto rough = [](const SpectralLattice& L) {
        double sum = 0;
        const auto& t = L.table_double();
        const size_t B = static_cast<size_t>(L.bins());
        for (size_t v = 0; v < t.size() / B; ++v)
            for (size_t k = 0; k + 1 < B; ++k) sum += std::pow(t[v * B + k + 1] - t[v * B + k], 2);
        return sum;
    };
    const double jh = rough(SpectralLattice::build(d65(), 5, VertexPrior::JakobHanika));
    const double bl = rough(SpectralLattice::build(d65(), 5, VertexPrior::Blend, 4.0));
    const double sm = rough(SpectralLattice::build(d65(), 5, VertexPrior::Smooth));
    EXPECT_LT(bl, jh);
    EXPECT_GT(bl, sm);
}

TEST(Lattice, ExpandIsTheFloatFormulaBitForBit) {
    // The kernel (AVX or SSE2, whichever this CPU runs) against the plain float formula: cell from
    // AxisLocator::locate_fast, Kuhn weights, ((w0 a + w1 b) + w2 c) + w3 d on the float table.
    const SpectralLattice L = SpectralLattice::build(d65(), 9, VertexPrior::Smooth);
    const AxisLocator loc(9);
    const size_t B = static_cast<size_t>(L.bins()), n = 9;
    const size_t m = 1000 + 3;  // not a multiple of the kernel's block or vector width
    std::mt19937 rng(99);
    std::uniform_real_distribution<float> u(-0.1f, 1.1f);
    std::vector<float> r(m), g(m), b(m), out(m * B);
    for (size_t i = 0; i < m; ++i) r[i] = u(rng), g[i] = u(rng), b[i] = u(rng);
    L.expand(r.data(), g.data(), b.data(), m, out.data(), m);
    for (size_t i = 0; i < m; ++i) {
        float t[3];
        size_t c[3];
        const float in[3] = {r[i], g[i], b[i]};
        for (int a = 0; a < 3; ++a) c[a] = static_cast<size_t>(loc.locate_fast(in[a], &t[a]));
        int p[3] = {0, 1, 2};
        std::stable_sort(p, p + 3, [&](int x, int y) { return t[x] > t[y]; });
        const size_t stride[3] = {n * n, n, 1};
        size_t v[4];
        v[0] = (c[0] * n + c[1]) * n + c[2];
        for (int j = 0; j < 3; ++j) v[j + 1] = v[j] + stride[p[j]];
        const float w[4] = {1.0f - t[p[0]], t[p[0]] - t[p[1]], t[p[1]] - t[p[2]], t[p[2]]};
        for (size_t k = 0; k < B; ++k) {
            const float* T = L.table().data();
            const float want = w[0] * T[v[0] * B + k] + w[1] * T[v[1] * B + k] +
                               w[2] * T[v[2] * B + k] + w[3] * T[v[3] * B + k];
            ASSERT_EQ(out[k * m + i], want) << i << " bin " << k;
        }
    }
}

namespace {

// The documented objective of a prior as a QpProblem, for solve_qp (the independent solver).
QpProblem prior_problem(const Colorimetry& c, VertexPrior prior, double blend,
                        const Eigen::VectorXd& s_jh, const Eigen::Vector3d& v) {
    const Eigen::Matrix3Xd C = c.rgb_weights();
    const Eigen::Index N = C.cols();
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(N - 1, N);
    for (Eigen::Index k = 0; k + 1 < N; ++k) {
        const double w = 10.0 / (c.grid.lambda[static_cast<size_t>(k) + 1] -
                                 c.grid.lambda[static_cast<size_t>(k)]);
        D(k, k) = -w, D(k, k + 1) = w;
    }
    Eigen::MatrixXd P = D.transpose() * D;
    Eigen::VectorXd q(N);
    if (prior == VertexPrior::Smooth) {
        const double alpha = 1e-6 * D.cwiseAbs2().maxCoeff();
        P += alpha * Eigen::MatrixXd::Identity(N, N);
        q.setConstant(-0.5 * alpha);
    } else {
        P = (prior == VertexPrior::Blend ? blend : 0.0) * P + Eigen::MatrixXd::Identity(N, N);
        q = -s_jh;
    }
    QpProblem p;
    p.P = P.sparseView();
    p.A = Eigen::MatrixXd(C).sparseView();
    p.q = q;
    p.b = v;
    p.lower = Eigen::VectorXd::Zero(N);
    p.upper = Eigen::VectorXd::Ones(N);
    return p;
}

}  // namespace

TEST(Lattice, VertexSpectraAreTheOptimaOfTheirPriors) {
    // Every 7th vertex of n = 9 against solve_qp on the same objective (rebuilt here from the
    // documentation in lattice.h): the minimiser is unique (strictly convex on C s = v), so the two
    // must agree up to the solvers' accuracy. Both finish on an exact equality solve over the same
    // free set (measured: 7e-16 JH, 1.4e-14 smooth, whose tie-break of 1e-6 makes H
    // ill-conditioned).
    for (VertexPrior prior : {VertexPrior::JakobHanika, VertexPrior::Smooth, VertexPrior::Blend}) {
        const SpectralLattice L = SpectralLattice::build(d65(), 9, prior, 0.5);
        const std::vector<JHCoefficients> jh = fit_jakob_hanika_nodes(d65(), L.axis());
        const size_t B = static_cast<size_t>(L.bins());
        double worst = 0;
        for (size_t idx = 1; idx + 1 < 729; idx += 7) {
            const Eigen::Vector3d v(L.axis()[idx / 81], L.axis()[idx / 9 % 9], L.axis()[idx % 9]);
            const QpResult r =
                solve_qp(prior_problem(d65(), prior, 0.5, jh_spectrum(d65(), jh[idx]), v));
            ASSERT_EQ(r.status, QpStatus::Solved);
            const Eigen::Map<const Eigen::VectorXd> s(&L.table_double()[idx * B],
                                                      static_cast<Eigen::Index>(B));
            worst = std::max(worst, (s - r.x).cwiseAbs().maxCoeff());
        }
        EXPECT_LE(worst, 1e-10) << to_string(prior);
    }
}

TEST(Lattice, SpectrumIsContinuousAcrossCellsAndSimplices) {
    // Kuhn simplices of neighbouring cells share faces, so the interpolant is continuous: a step
    // of 1e-9 moves the spectrum by at most L·1e-9, L <= (max vertex difference = 1) / (smallest
    // gap, axis[1] = 0.0144 at n = 9), i.e. 7e-8; probes on breakpoints and on t_r = t_g ties.
    const SpectralLattice L = SpectralLattice::build(d65(), 9, VertexPrior::JakobHanika);
    const double bound = 1e-9 / L.axis()[1] * 1.05;
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> cell(0, 8);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    double worst = 0;
    for (int i = 0; i < 2000; ++i) {
        Eigen::Vector3d p(u(rng), u(rng), u(rng));
        p[i % 3] = L.axis()[static_cast<size_t>(cell(rng))];  // on a breakpoint
        if (i % 2) p[(i + 1) % 3] = p[i % 3];                 // and often on a tie
        for (int axis = 0; axis < 3; ++axis)
            for (double step : {-1e-9, 1e-9}) {
                Eigen::Vector3d q = p;
                q[axis] = std::clamp(q[axis] + step, 0.0, 1.0);
                const double d = (eval(L, p) - eval(L, q)).cwiseAbs().maxCoeff();
                worst = std::max(worst, d);
                ASSERT_LE(d, bound) << p.transpose() << " axis " << axis;
            }
    }
}

// The LHTSS prior (Burns 2020) on its own: its Newton solve converges at every vertex but black
// and white (which lie on the object-colour solid's boundary and are set exactly), on the grids,
// observers and lights the basis fit accepts; the stored spectrum is the prior's (the projection
// moves it by rounding only), and the prior's answer satisfies its own optimality condition,
// checked here rather than trusted from the solver: the roughness gradient K z lies in the span of
// diag(s') C' (the three constraint normals).
TEST(Lattice, LhtssVerticesConvergeAndAreTheirPriorsOptima) {
    struct Case {
        std::string grid, observer, illuminant;
    };
    const Case cases[] = {{"380:780:5", "cie1931-2", "D65"},  {"380:780:10", "cie1931-2", "D65"},
                          {"400:700:20", "cie1931-2", "D65"}, {"380:780:5", "cie1964-10", "D65"},
                          {"380:780:5", "cie1931-2", "D50"},  {"360:830:1", "cie1931-2", "D65"}};
    for (const auto& cs : cases) {
        const Colorimetry c = make(cs.grid, cs.observer, cs.illuminant);
        const int n = cs.grid == "360:830:1" ? 5 : 9;
        const SpectralLattice L = SpectralLattice::build(c, n, VertexPrior::Lhtss);
        const std::string what = cs.grid + " " + cs.observer + " " + cs.illuminant;
        expect_exact_vertices(L, c, what);
        EXPECT_EQ(L.prior_unconverged, 0) << what;
        // Optimality at every interior vertex: the least-squares residual of K z against the three
        // constraint normals, in units of the roughness scale max w² (|K z| itself is of order
        // max w² for a coloured vertex, and near 0 for greys). 1e-6: the solver stops at 1e-9 of
        // that scale and its tie-break adds 1e-9 max w² |z| (|z| <= 18.5); the spectrum of another
        // prior (the JH projection) fails the comparison with the prior's own answer above.
        const Eigen::Matrix3Xd C = c.rgb_weights();
        const size_t B = static_cast<size_t>(L.bins());
        double worst = 0, wmax = 0;
        for (size_t k = 0; k + 1 < c.grid.size(); ++k)
            wmax = std::max(wmax, std::pow(10.0 / (c.grid.lambda[k + 1] - c.grid.lambda[k]), 2));
        for (size_t idx = 1; idx + 1 < static_cast<size_t>(n) * n * n; ++idx) {
            const Eigen::VectorXd stored = Eigen::Map<const Eigen::VectorXd>(
                &L.table_double()[idx * B], static_cast<Eigen::Index>(B));
            const size_t ir = idx / (static_cast<size_t>(n) * n), ig = idx / n % n, ib = idx % n;
            const Eigen::Vector3d v(L.axis()[ir], L.axis()[ig], L.axis()[ib]);
            const LhtssResult lh = lhtss_spectrum(C, c.grid, v);
            ASSERT_TRUE(lh.converged) << what << " vertex " << idx;
            // 1e-12: the projection corrects a colour residual of at most 1e-11 (the solver's
            // acceptance), spread over the bins.
            ASSERT_LE((stored - lh.s).cwiseAbs().maxCoeff(), 1e-12) << what << " vertex " << idx;
            const Eigen::VectorXd& s = lh.s;
            ASSERT_GT(s.minCoeff(), 0.0) << what << " vertex " << idx << " touches 0";
            ASSERT_LT(s.maxCoeff(), 1.0) << what << " vertex " << idx << " touches 1";
            const Eigen::VectorXd& z = lh.z;
            Eigen::VectorXd kz = Eigen::VectorXd::Zero(z.size());
            for (Eigen::Index k = 0; k + 1 < z.size(); ++k) {
                const double w = 10.0 / (c.grid.lambda[static_cast<size_t>(k) + 1] -
                                         c.grid.lambda[static_cast<size_t>(k)]);
                const double f = w * w * (z[k + 1] - z[k]);
                kz[k] -= f;
                kz[k + 1] += f;
            }
            const Eigen::VectorXd sp = (0.5 * (1 - z.array().tanh().square())).matrix();
            const Eigen::MatrixX3d A = sp.asDiagonal() * C.transpose();
            const Eigen::Vector3d lam = A.colPivHouseholderQr().solve(kz);
            worst = std::max(worst, (A * lam - kz).cwiseAbs().maxCoeff() / wmax);
        }
        EXPECT_LE(worst, 1e-6) << what;
    }
}

// A table stored by a cache and read back makes the same lattice (checksum, spectra); a table that
// build() could not have made for the colorimetry (a vertex no longer exact, a value outside
// [0, 1], black or white moved, the wrong size) is refused, so a damaged cache entry is rebuilt
// rather than baked.
TEST(Lattice, FromTableTakesOnlyATableTheBuildCouldHaveMade) {
    const Colorimetry& c = d65();
    const SpectralLattice built = SpectralLattice::build(c, 5, VertexPrior::Lhtss);
    const SpectralLattice again =
        SpectralLattice::from_table(c, 5, VertexPrior::Lhtss, built.table_double());
    EXPECT_EQ(again.checksum(), built.checksum());
    EXPECT_EQ(again.table(), built.table());
    const double rgb[3] = {0.3, 0.7, 0.1};
    std::vector<double> a(static_cast<size_t>(built.bins())), b(a.size());
    built.spectrum(rgb, a.data());
    again.spectrum(rgb, b.data());
    EXPECT_EQ(a, b);
    EXPECT_LE(again.max_colour_residual, SpectralLattice::kStoredVertexTolerance);

    const size_t N = static_cast<size_t>(built.bins());
    const size_t mid = (static_cast<size_t>(2) * 5 + 3) * 5 + 1;  // an inner vertex
    auto refused = [&](std::vector<double> t, const char* what) {
        EXPECT_THROW(SpectralLattice::from_table(c, 5, VertexPrior::Lhtss, std::move(t)), Error)
            << what;
    };
    std::vector<double> t = built.table_double();
    t[mid * N + 40] += 1e-3;  // in [0, 1] still, but the vertex's colour moves by ~1e-5
    refused(t, "a vertex no longer exact");
    t = built.table_double();
    t[mid * N + 3] = 1.5;
    refused(t, "a value above 1");
    t = built.table_double();
    t[mid * N + 3] = std::numeric_limits<double>::quiet_NaN();
    refused(t, "NaN");
    t = built.table_double();
    t[3] = 1e-300;
    refused(t, "black not exactly zero");
    t = built.table_double();
    t.pop_back();
    refused(t, "one value short");
    // The wrong lattice size for the same values.
    EXPECT_THROW(SpectralLattice::from_table(c, 4, VertexPrior::Lhtss, built.table_double()),
                 Error);
}

namespace {

const MeasuredPrior& shipped_measured() {
    static const MeasuredPrior p = read_measured_prior_csv(measured_prior_path(kData));
    return p;
}

// A prior with learned directions (the shipped table may have none): two smooth bumps in z, so
// the Woodbury path of the solve is exercised on every grid.
MeasuredPrior with_directions() {
    MeasuredPrior p = shipped_measured();
    p.factors.assign(2, std::vector<double>(p.lambda.size()));
    for (size_t k = 0; k < p.lambda.size(); ++k) {
        const double x = (p.lambda[k] - 580.0) / 100.0;
        p.factors[0][k] = 0.8 * std::exp(-x * x);
        p.factors[1][k] = 0.5 * x;
    }
    p.checksum = "test";
    return p;
}

// The learned prior's precision on the lattice's grid, made the long way: the roughness
// K (+1e-9 max weight · I, as the solver), inverted densely, plus F F', inverted again.
Eigen::MatrixXd dense_precision(const MeasuredPrior& p, const WavelengthGrid& g) {
    const Eigen::Index N = static_cast<Eigen::Index>(g.size());
    Eigen::MatrixXd K = Eigen::MatrixXd::Zero(N, N);
    double wmax = 0;
    for (Eigen::Index k = 0; k + 1 < N; ++k) {
        const double w =
            5.0 / (g.lambda[static_cast<size_t>(k) + 1] - g.lambda[static_cast<size_t>(k)]);
        wmax = std::max(wmax, w);
        K(k, k) += w;
        K(k + 1, k + 1) += w;
        K(k, k + 1) -= w;
        K(k + 1, k) -= w;
    }
    K += 1e-9 * wmax * Eigen::MatrixXd::Identity(N, N);
    const TanhPrior t = measured_prior_on_grid(p, g);
    if (t.factors.cols() == 0) return K;
    const Eigen::MatrixXd G = K.inverse();
    return (G + t.factors * t.factors.transpose()).inverse();
}

}  // namespace

// The measured prior's hard cases: on every grid, observer and illuminant the LHTSS test covers,
// with the shipped table and with one that has learned directions, every vertex is exact and
// bounded, the Newton solve converged at every vertex (none left to the projection: the saturated
// corners and faces included), and each vertex but black and white is the optimum of its own
// objective: P (z - mean) lies in the span of the constraint normals diag(s') C', P made densely
// here, mean the table's face mean on the RGB cube's faces.
TEST(LatticeSlow, MeasuredVerticesConvergeAndAreTheirPriorsOptima) {
    struct Case {
        std::string grid, observer, illuminant;
    };
    const Case cases[] = {{"380:780:5", "cie1931-2", "D65"},  {"380:780:10", "cie1931-2", "D65"},
                          {"400:700:20", "cie1931-2", "D65"}, {"400:700:10", "cie1931-2", "D65"},
                          {"380:780:5", "cie1964-10", "D65"}, {"380:780:5", "cie1931-2", "D50"},
                          {"380:780:5", "cie1931-2", "A"},    {"360:830:1", "cie1931-2", "D65"}};
    for (const MeasuredPrior& prior : {shipped_measured(), with_directions()}) {
        for (const auto& cs : cases) {
            const Colorimetry c = make(cs.grid, cs.observer, cs.illuminant);
            const int n = cs.grid == "360:830:1" ? 5 : 9;
            const SpectralLattice L =
                SpectralLattice::build(c, n, VertexPrior::Measured, 0.5, &prior);
            const std::string what = cs.grid + " " + cs.observer + " " + cs.illuminant + " m " +
                                     std::to_string(prior.factors.size());
            expect_exact_vertices(L, c, what);
            EXPECT_EQ(L.prior_unconverged, 0) << what;
            const Eigen::MatrixXd P = dense_precision(prior, c.grid);
            const TanhPrior t = measured_prior_on_grid(prior, c.grid);
            const TanhPrior tf = measured_prior_on_grid(prior, c.grid, true);
            const Eigen::Matrix3Xd C = c.rgb_weights();
            const size_t B = static_cast<size_t>(L.bins());
            double worst = 0;
            for (size_t idx = 1; idx + 1 < static_cast<size_t>(n) * n * n; ++idx) {
                const size_t N = static_cast<size_t>(n), ir = idx / (N * N), ig = idx / N % N,
                             ib = idx % N;
                const bool face = std::min({ir, ig, ib}) == 0 || std::max({ir, ig, ib}) == N - 1;
                const Eigen::VectorXd s = Eigen::Map<const Eigen::VectorXd>(
                    &L.table_double()[idx * B], static_cast<Eigen::Index>(B));
                ASSERT_GT(s.minCoeff(), 0.0) << what << " vertex " << idx << " touches 0";
                ASSERT_LT(s.maxCoeff(), 1.0) << what << " vertex " << idx << " touches 1";
                const Eigen::VectorXd z = (2.0 * s.array() - 1.0).atanh().matrix();
                const Eigen::VectorXd pz = P * (z - (face ? tf.mean : t.mean));
                const Eigen::VectorXd sp = (0.5 * (1 - z.array().tanh().square())).matrix();
                const Eigen::MatrixX3d A = sp.asDiagonal() * C.transpose();
                const Eigen::Vector3d lam = A.colPivHouseholderQr().solve(pz);
                worst = std::max(worst, (A * lam - pz).cwiseAbs().maxCoeff());
            }
            // 1e-6 of the roughness scale (max weight 5 at 1 nm, 1 at 5 nm): the solver stops at
            // 1e-9 of it; z recovered from the stored s by atanh loses digits near 0 and 1, which
            // 1e-6 allows for. A spectrum of another prior (LHTSS's) misses by ~1e-2.
            EXPECT_LE(worst, 1e-6) << what;
        }
    }
}

// The objective above is not satisfied by any exact spectrum: LHTSS's, for one, fails it. (The
// check that the previous test's tolerance can fail.)
TEST(Lattice, MeasuredPriorDiffersFromLhtss) {
    const SpectralLattice a = SpectralLattice::build(d65(), 5, VertexPrior::Lhtss);
    const SpectralLattice b =
        SpectralLattice::build(d65(), 5, VertexPrior::Measured, 0.5, &shipped_measured());
    double diff = 0;
    for (size_t i = 0; i < a.table_double().size(); ++i)
        diff = std::max(diff, std::fabs(a.table_double()[i] - b.table_double()[i]));
    EXPECT_GT(diff, 1e-3);
    EXPECT_NE(a.checksum(), b.checksum());
    EXPECT_THROW(SpectralLattice::build(d65(), 5, VertexPrior::Measured), Error);
}

// The face mean: the vertices on the RGB cube's faces are those of a prior whose mean is the face
// mean everywhere, and the others those of the prior without one; with a face mean of 0 and no
// directions the faces are LHTSS's spectra on a uniform grid (the same optimum: the two roughness
// weights differ by a constant factor there). 1e-12: the same solve twice; 1e-6: the solver's
// stationarity tolerance, scaled.
TEST(Lattice, MeasuredFacesTakeTheFaceMean) {
    const int n = 5;
    MeasuredPrior p = shipped_measured(), zero = shipped_measured();
    zero.face_mean.assign(p.mean.size(), 0.0);
    p.face_mean.assign(p.mean.size(), 0.0);
    for (size_t k = 0; k < p.lambda.size(); ++k)  // a face mean of its own, not LHTSS's
        p.face_mean[k] = 0.4 * std::sin((p.lambda[k] - 380.0) / 60.0);
    MeasuredPrior inside = p, faces = p;
    inside.face_mean.clear();
    faces.mean = p.face_mean;
    faces.face_mean.clear();
    const Colorimetry c = d65();
    const SpectralLattice L = SpectralLattice::build(c, n, VertexPrior::Measured, 0.5, &p);
    const SpectralLattice Li = SpectralLattice::build(c, n, VertexPrior::Measured, 0.5, &inside);
    const SpectralLattice Lf = SpectralLattice::build(c, n, VertexPrior::Measured, 0.5, &faces);
    const SpectralLattice Ls = SpectralLattice::build(c, n, VertexPrior::Measured, 0.5, &zero);
    const SpectralLattice Lh = SpectralLattice::build(c, n, VertexPrior::Lhtss);
    const size_t B = static_cast<size_t>(L.bins()), N = n;
    double face_vs_inside = 0, lhtss_faces = 0;
    for (size_t idx = 0; idx < N * N * N; ++idx) {
        const size_t ir = idx / (N * N), ig = idx / N % N, ib = idx % N;
        const bool face = std::min({ir, ig, ib}) == 0 || std::max({ir, ig, ib}) == N - 1;
        const SpectralLattice& want = face ? Lf : Li;
        for (size_t k = 0; k < B; ++k) {
            const size_t at = idx * B + k;
            EXPECT_NEAR(L.table_double()[at], want.table_double()[at], 1e-12) << idx << " " << k;
            face_vs_inside =
                std::max(face_vs_inside, std::fabs(Li.table_double()[at] - Lf.table_double()[at]));
            if (face)
                lhtss_faces =
                    std::max(lhtss_faces, std::fabs(Ls.table_double()[at] - Lh.table_double()[at]));
        }
    }
    EXPECT_GT(face_vs_inside, 1e-3);  // the two means give other spectra: the check can fail
    EXPECT_LE(lhtss_faces, 1e-6);
}

// The shipped table keeps LHTSS on the faces (a face mean of 0, which the test above shows gives
// LHTSS's spectra there), and its own mean inside: what docs/methods.md says it is.
TEST(MeasuredPrior, TheShippedTableKeepsLhtssOnTheFaces) {
    const MeasuredPrior& p = shipped_measured();
    ASSERT_EQ(p.face_mean.size(), p.mean.size());
    EXPECT_EQ(*std::max_element(p.face_mean.begin(), p.face_mean.end()), 0.0);
    EXPECT_EQ(*std::min_element(p.face_mean.begin(), p.face_mean.end()), 0.0);
    double largest = 0;
    for (double z : p.mean) largest = std::max(largest, std::fabs(z));
    EXPECT_GT(largest, 0.1);
    EXPECT_TRUE(p.factors.empty());
}

// A damaged or hostile table is refused with the file's name and the cause, never used.
TEST(MeasuredPrior, DamagedTablesAreRefused) {
    spectex_test::TempDir dir;
    const std::string good = "wavelength,mean,f1\n380,-0.2,0.1\n780,0.3,0.2\n";
    const struct {
        std::string text, cause;
    } bad[] = {
        {"wavelength,value\n380,0\n780,0\n", "header"},
        {"wavelength,mean,g1\n380,0,0\n780,0,0\n", "expected f1"},
        {"wavelength,mean\n380,nan\n780,0\n", "finite"},
        {"wavelength,mean\n380,25\n780,0\n", "not a usable number"},
        {"wavelength,mean,f1\n380,0,5000\n780,0,0\n", "not a usable number"},
        {"wavelength,mean,face_mean\n380,0,25\n780,0,0\n", "not a usable number"},
        {"wavelength,mean,f1,face_mean\n380,0,0,0\n780,0,0,0\n", "expected f2"},
        {"wavelength,mean\n380,0\n", "at least 2"},
        {"wavelength,mean\n780,0\n380,0\n", "increasing"},
    };
    const std::string path = dir / "prior.csv";
    auto write = [&](const std::string& text) { std::ofstream(path) << text; };
    write(good);
    const MeasuredPrior p = read_measured_prior_csv(path);
    EXPECT_EQ(p.factors.size(), 1u);
    EXPECT_EQ(p.mean[1], 0.3);
    EXPECT_TRUE(p.face_mean.empty());
    write("wavelength,mean,face_mean,f1\n380,-0.2,0,0.1\n780,0.3,0.05,0.2\n");
    const MeasuredPrior pf = read_measured_prior_csv(path);
    EXPECT_EQ(pf.factors.size(), 1u);
    EXPECT_EQ(pf.face_mean[1], 0.05);
    EXPECT_EQ(pf.factors[0][1], 0.2);
    EXPECT_NE(pf.checksum, p.checksum);
    for (const auto& b : bad) {
        write(b.text);
        try {
            read_measured_prior_csv(path);
            ADD_FAILURE() << "accepted: " << b.text;
        } catch (const Error& e) {
            const std::string msg = e.what();
            EXPECT_NE(msg.find(path), std::string::npos) << msg;
            EXPECT_NE(msg.find(b.cause), std::string::npos) << msg;
        }
    }
    // The checksum follows the values: one changed digit, another checksum.
    write("wavelength,mean,f1\n380,-0.2,0.1\n780,0.3,0.21\n");
    EXPECT_NE(read_measured_prior_csv(path).checksum, p.checksum);
}
