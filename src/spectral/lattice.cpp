#include "spectral/lattice.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "base/error.h"
#include "base/fnv1a.h"
#include "base/text.h"
#include "spectral/jakob_hanika.h"
#include "spectral/lhtss.h"
#include "spectral/vertex_qp.h"

namespace spectex {

std::string to_string(VertexPrior p) { return kVertexPriorNames.name(p); }

VertexPrior parse_vertex_prior(const std::string& s) {
    if (const auto p = kVertexPriorNames.find(lower_ascii(s))) return *p;
    throw Error("unknown vertex prior '" + s + "' (expected " +
                kVertexPriorNames.list(", ", " or ") + ")");
}

namespace {

// The vertex colour residual the build demands (the unit tests check 1e-12): rows of C sum N
// terms of size ~1/N, so double rounding leaves ~1e-16; 1e-13 leaves room for 401+ bins.
constexpr double kVertexTolerance = 1e-13;
constexpr double kSmoothTieBreak = 1e-6;

// Roughness weights d_k = 10 nm / Δλ_k (differences measured per 10 nm), times sqrt(scale).
std::vector<double> roughness(const WavelengthGrid& g, double scale) {
    std::vector<double> d(g.size() - 1);
    for (size_t k = 0; k + 1 < g.size(); ++k)
        d[k] = std::sqrt(scale) * 10.0 / (g.lambda[k + 1] - g.lambda[k]);
    return d;
}

}  // namespace

SpectralLattice SpectralLattice::build(const Colorimetry& c, int n, VertexPrior prior, double blend,
                                       const MeasuredPrior* measured) {
    const auto t0 = std::chrono::steady_clock::now();
    if (n < 2)
        throw Error("spectral lattice needs at least 2 breakpoints per axis, got " +
                    std::to_string(n));
    if (c.grid.size() < 3)
        throw Error("spectral lattice needs at least 3 wavelengths, got " + c.grid.describe());
    if (prior == VertexPrior::Blend && !(blend >= 0 && std::isfinite(blend)))
        throw Error("blend weight must be finite and >= 0");
    if (prior == VertexPrior::Measured && !measured)
        throw Error("the measured vertex prior needs its table (vertex_prior_measured.csv)");
    SpectralLattice L;
    L.n_ = n;
    L.bins_ = static_cast<int>(c.grid.size());
    L.prior_ = prior;
    L.locator_ = AxisLocator(n);
    const std::vector<double>& ax = L.locator_.axis();
    const Eigen::Index N = L.bins_;
    const Eigen::Matrix3Xd C = c.rgb_weights();

    std::vector<JHCoefficients> jh;
    if (prior == VertexPrior::JakobHanika || prior == VertexPrior::Blend)
        jh = fit_jakob_hanika_nodes(c, ax);

    TanhPrior learned, learned_face;  // inside the RGB cube, on its faces
    if (prior == VertexPrior::Measured) {
        learned = measured_prior_on_grid(*measured, c.grid);
        learned_face = measured_prior_on_grid(*measured, c.grid, true);
    }

    TridiagonalHessian H;
    H.size = N;
    if (prior == VertexPrior::Smooth) {
        H.d = roughness(c.grid, 1.0);
        double dmax = 0;
        for (double d : H.d) dmax = std::max(dmax, d * d);
        H.alpha = kSmoothTieBreak * dmax;
    } else if (prior == VertexPrior::Blend && blend > 0) {
        H.d = roughness(c.grid, blend);
    }

    const size_t verts = static_cast<size_t>(n) * n * n;
    L.table_d_.assign(verts * static_cast<size_t>(N), 0.0);
    L.min_value = 1, L.max_value = 0;
    Eigen::VectorXd q(N);
    std::vector<char> warm;  // PDAS active set of the previous vertex (a neighbour along blue)
    for (int ir = 0; ir < n; ++ir)
        for (int ig = 0; ig < n; ++ig)
            for (int ib = 0; ib < n; ++ib) {
                const size_t idx = (static_cast<size_t>(ir) * n + ig) * n + ib;
                const Eigen::Vector3d v(ax[static_cast<size_t>(ir)], ax[static_cast<size_t>(ig)],
                                        ax[static_cast<size_t>(ib)]);
                Eigen::VectorXd s;
                if (ir == 0 && ig == 0 && ib == 0) {
                    s = Eigen::VectorXd::Zero(N);  // black: the only bounded answer, exactly
                } else if (ir == n - 1 && ig == n - 1 && ib == n - 1) {
                    s = Eigen::VectorXd::Ones(N);  // white: the perfect reflector
                } else {
                    if (prior == VertexPrior::Smooth) {
                        q.setConstant(-0.5 * H.alpha);
                    } else if (prior == VertexPrior::Lhtss || prior == VertexPrior::Measured) {
                        const bool face = ir == 0 || ig == 0 || ib == 0 || ir == n - 1 ||
                                          ig == n - 1 || ib == n - 1;
                        const TanhPrior* data = prior != VertexPrior::Measured ? nullptr
                                                : face                         ? &learned_face
                                                                               : &learned;
                        const LhtssResult lh =
                            tanh_prior_spectrum(C, c.grid, v, data, kVertexTolerance);
                        L.prior_unconverged += !lh.converged;
                        L.solver_iterations += lh.iterations;
                        q = -lh.s;
                    } else {
                        for (Eigen::Index k = 0; k < N; ++k)
                            q[k] = -jh_eval(jh[idx], c.grid.lambda[static_cast<size_t>(k)]);
                    }
                    char what[200];
                    std::snprintf(what, sizeof what,
                                  "spectral lattice (n = %d, %s prior) vertex (%d, %d, %d) = "
                                  "linear RGB (%.9g, %.9g, %.9g) on grid %s",
                                  n, to_string(prior).c_str(), ir, ig, ib, v[0], v[1], v[2],
                                  c.grid.describe().c_str());
                    VertexQpStats st;
                    s = solve_vertex_qp(C, H, q, v, kVertexTolerance, what, &st, &warm);
                    L.fallback_vertices += st.used_fallback;
                    L.solver_iterations += st.iterations;
                }
                L.max_colour_residual =
                    std::max(L.max_colour_residual, (C * s - v).cwiseAbs().maxCoeff());
                L.min_value = std::min(L.min_value, s.minCoeff());
                L.max_value = std::max(L.max_value, s.maxCoeff());
                std::copy(s.data(), s.data() + N,
                          L.table_d_.begin() + static_cast<std::ptrdiff_t>(idx * N));
            }
    L.make_float_tables();
    L.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return L;
}

void SpectralLattice::make_float_tables() {
    const size_t N = static_cast<size_t>(bins_);
    const size_t verts = static_cast<size_t>(n_) * n_ * n_;
    table_.assign(table_d_.begin(), table_d_.end());
    padded_ld_ = (N + 7) & ~size_t{7};
    padded_.assign(verts * padded_ld_, 0.0f);
    for (size_t v = 0; v < verts; ++v) std::copy_n(&table_[v * N], N, &padded_[v * padded_ld_]);
}

SpectralLattice SpectralLattice::from_table(const Colorimetry& c, int n, VertexPrior prior,
                                            std::vector<double> table) {
    const auto t0 = std::chrono::steady_clock::now();
    if (n < 2 || c.grid.size() < 3) throw Error("stored lattice: too small");
    const size_t N = c.grid.size();
    const size_t verts = static_cast<size_t>(n) * n * n;
    if (table.size() != verts * N) throw Error("stored lattice: wrong number of values");
    SpectralLattice L;
    L.n_ = n;
    L.bins_ = static_cast<int>(N);
    L.prior_ = prior;
    L.locator_ = AxisLocator(n);
    const std::vector<double>& ax = L.locator_.axis();
    const Eigen::Matrix3Xd C = c.rgb_weights();
    L.min_value = 1, L.max_value = 0;
    for (int ir = 0; ir < n; ++ir)
        for (int ig = 0; ig < n; ++ig)
            for (int ib = 0; ib < n; ++ib) {
                const size_t idx = (static_cast<size_t>(ir) * n + ig) * n + ib;
                const Eigen::Map<const Eigen::VectorXd> s(&table[idx * N],
                                                          static_cast<Eigen::Index>(N));
                for (size_t k = 0; k < N; ++k)
                    if (!(s[static_cast<Eigen::Index>(k)] >= 0 &&
                          s[static_cast<Eigen::Index>(k)] <= 1))
                        throw Error("stored lattice: a value outside [0, 1]");
                const bool black = ir == 0 && ig == 0 && ib == 0;
                const bool white = ir == n - 1 && ig == n - 1 && ib == n - 1;
                if ((black && s.maxCoeff() != 0) || (white && s.minCoeff() != 1))
                    throw Error("stored lattice: black or white is not exact");
                const Eigen::Vector3d v(ax[static_cast<size_t>(ir)], ax[static_cast<size_t>(ig)],
                                        ax[static_cast<size_t>(ib)]);
                const double residual = (C * s - v).cwiseAbs().maxCoeff();
                if (!(residual <= kStoredVertexTolerance))
                    throw Error("stored lattice: a vertex colour is not reproduced");
                L.max_colour_residual = std::max(L.max_colour_residual, residual);
                L.min_value = std::min(L.min_value, s.minCoeff());
                L.max_value = std::max(L.max_value, s.maxCoeff());
            }
    L.table_d_ = std::move(table);
    L.make_float_tables();
    L.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return L;
}

SpectralLattice SpectralLattice::projected(const Eigen::MatrixXd& W) const {
    if (W.cols() != bins_) throw Error("lattice projection: weights on another grid");
    const size_t N = static_cast<size_t>(bins_), R = static_cast<size_t>(W.rows());
    const size_t verts = static_cast<size_t>(n_) * n_ * n_;
    SpectralLattice L;
    L.n_ = n_;
    L.bins_ = static_cast<int>(R);
    L.prior_ = prior_;
    L.locator_ = locator_;
    L.table_d_.resize(verts * R);
    for (size_t v = 0; v < verts; ++v) {
        const Eigen::Map<const Eigen::VectorXd> s(&table_d_[v * N], static_cast<Eigen::Index>(N));
        Eigen::Map<Eigen::VectorXd>(&L.table_d_[v * R], static_cast<Eigen::Index>(R)) = W * s;
    }
    L.make_float_tables();
    return L;
}

std::string SpectralLattice::checksum() const {
    Fnv1a64 h;
    const int32_t n = n_;
    h.add(&n, sizeof n);
    h.add(table_.data(), table_.size() * sizeof(float));
    return h.text();
}

void SpectralLattice::spectrum(const double rgb[3], double* out) const {
    int i[3];
    double t[3];
    for (int c = 0; c < 3; ++c) i[c] = locator_.locate(rgb[c], &t[c]);
    // Kuhn simplex: walk from the cell's low corner along the axes in order of decreasing t.
    int p[3] = {0, 1, 2};
    std::stable_sort(p, p + 3, [&](int a, int b) { return t[a] > t[b]; });
    const size_t stride[3] = {static_cast<size_t>(n_) * n_, static_cast<size_t>(n_), 1};
    size_t v[4];
    v[0] = (static_cast<size_t>(i[0]) * n_ + i[1]) * n_ + i[2];
    for (int j = 0; j < 3; ++j) v[j + 1] = v[j] + stride[p[j]];
    const double w[4] = {1 - t[p[0]], t[p[0]] - t[p[1]], t[p[1]] - t[p[2]], t[p[2]]};
    const size_t B = static_cast<size_t>(bins_);
    const double *s0 = &table_d_[v[0] * B], *s1 = &table_d_[v[1] * B], *s2 = &table_d_[v[2] * B],
                 *s3 = &table_d_[v[3] * B];
    for (size_t k = 0; k < B; ++k)
        out[k] = w[0] * s0[k] + w[1] * s1[k] + w[2] * s2[k] + w[3] * s3[k];
}

}  // namespace spectex
