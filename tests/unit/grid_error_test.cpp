// The error of a wavelength grid as a renderer sees it: the reconstruction rules on
// hand-computed cases, the light's 1 nm weights, the histogram's percentiles, and the linear
// structure (the 3×3 maps of the full cube agree with spectra expanded and integrated).
#include "spectral/grid_error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "base/error.h"
#include "spectral/basis_fit.h"
#include "spectral/ciede2000.h"
#include "spectral/colorimetry.h"

using namespace spectex;

namespace {

std::vector<double> range(int lo, int hi) {
    std::vector<double> v;
    for (int l = lo; l <= hi; ++l) v.push_back(l);
    return v;
}

Eigen::VectorXd apply(const Eigen::MatrixXd& R, std::vector<double> s) {
    return R * Eigen::Map<Eigen::VectorXd>(s.data(), static_cast<Eigen::Index>(s.size()));
}

// A flat observer (x = y = z = 1) and a flat light over [lo, hi]: XYZ of s is its mean, X = Y = Z.
Observer flat_observer(double lo, double hi) {
    Spectrum one{"one", {lo, hi}, {1, 1}};
    return {"flat", one, one, one};
}

}  // namespace

TEST(GridError, LinearSpectrumIsReconstructedExactlyAndHeldPastTheEnds) {
    const std::vector<double> bins = {400, 410, 420};
    const Eigen::MatrixXd R = reconstruction_matrix(bins, range(395, 425), Reconstruction::Linear);
    const Eigen::VectorXd v = apply(R, {0.2, 0.4, 0.6});
    for (int l = 395; l <= 425; ++l) {
        const double expect = l <= 400 ? 0.2 : l >= 420 ? 0.6 : 0.2 + 0.02 * (l - 400);
        EXPECT_NEAR(v(l - 395), expect, 1e-12) << l;
    }
    for (auto rule : {Reconstruction::Linear, Reconstruction::Nearest, Reconstruction::Box}) {
        const Eigen::MatrixXd M = reconstruction_matrix(bins, range(380, 440), rule);
        for (Eigen::Index f = 0; f < M.rows(); ++f)
            EXPECT_NEAR(M.row(f).sum(), 1.0, 1e-12) << to_string(rule);
    }
}

TEST(GridError, StepSpectrumDiffersByRuleByComputableAmounts) {
    // s = (0, 0, 1) at 400, 410, 420, read at 400..420 nm:
    //   nearest: 1 from 416 (415 is a tie: the shorter bin, 0) -> 5 samples of 1, sum 5
    //   linear:  (l - 410) / 10 from 410 to 420 -> (0 + 1 + ... + 10) / 10 = 5.5
    //   box:     edge at 415: 416..420 are 1 and 415's cell [414.5, 415.5] is half in -> 5.5
    const std::vector<double> bins = {400, 410, 420};
    const auto fine = range(400, 420);
    const Eigen::VectorXd n =
        apply(reconstruction_matrix(bins, fine, Reconstruction::Nearest), {0, 0, 1});
    const Eigen::VectorXd l =
        apply(reconstruction_matrix(bins, fine, Reconstruction::Linear), {0, 0, 1});
    const Eigen::VectorXd b =
        apply(reconstruction_matrix(bins, fine, Reconstruction::Box), {0, 0, 1});
    EXPECT_DOUBLE_EQ(n.sum(), 5.0);
    EXPECT_DOUBLE_EQ(l.sum(), 5.5);
    EXPECT_DOUBLE_EQ(b.sum(), 5.5);
    EXPECT_DOUBLE_EQ(n(15), 0.0);  // 415
    EXPECT_DOUBLE_EQ(b(15), 0.5);
    EXPECT_DOUBLE_EQ(l(15), 0.5);
    EXPECT_DOUBLE_EQ(l(14), 0.4);
    EXPECT_DOUBLE_EQ(b(14), 0.0);
    EXPECT_DOUBLE_EQ(n(16), 1.0);

    // The error definition by hand: flat light, flat observer over 400..420 (21 samples of 1 nm),
    // so X = Y = Z = mean(s): neutral colours, a* = b* = 0, L* = 116 cbrt(Y) - 16, and ΔE00 between
    // two neutrals is |ΔL*| / S_L with S_L = 1 + 0.015 (L̄ - 50)^2 / sqrt(20 + (L̄ - 50)^2).
    const WavelengthGrid grid = renderer_grid(400, 420);
    const LightWeights lw =
        light_weights(flat_observer(400, 420), Spectrum{"flat", {400, 420}, {1, 1}}, grid);
    EXPECT_NEAR(lw.white(1), 1.0, 1e-12);
    EXPECT_NEAR(lw.W(1, 3), 1.0 / 21, 1e-15);
    Eigen::Matrix3Xd cand = lw.W * n, ref = lw.W * l;
    const DeltaEHistogram h = xyz_error(cand, ref, lw.white);
    const double L1 = 116 * std::cbrt(5.0 / 21) - 16, L2 = 116 * std::cbrt(5.5 / 21) - 16;
    const double lbar = 0.5 * (L1 + L2), d = (lbar - 50) * (lbar - 50);
    const double expect = std::fabs(L2 - L1) / (1 + 0.015 * d / std::sqrt(20 + d));
    EXPECT_NEAR(h.worst(), expect, 1e-9);
    EXPECT_GT(expect, 1.0);  // 65.0 against 67.2 L*: a visible difference
}

TEST(GridError, LightIsDarkWhereItsTableStopsAndObserverMustCover) {
    const Observer obs = flat_observer(400, 420);
    const LightWeights lw =
        light_weights(obs, Spectrum{"short", {400, 410}, {1, 1}}, renderer_grid(400, 420));
    EXPECT_DOUBLE_EQ(lw.dark_nm, 10.0);
    EXPECT_DOUBLE_EQ(lw.W(1, 15), 0.0);
    EXPECT_NEAR(lw.W(1, 5), 1.0 / 11, 1e-15);
    EXPECT_THROW(light_weights(obs, Spectrum{"flat", {300, 900}, {1, 1}}, renderer_grid(390, 420)),
                 Error);
    EXPECT_THROW(renderer_grid(400.5, 420), Error);
    EXPECT_THROW(parse_reconstruction("cubic"), Error);
}

TEST(GridError, HistogramPercentiles) {
    DeltaEHistogram h;
    for (int i = 1; i <= 1000; ++i) h.add(i * 0.001, static_cast<uint64_t>(i));
    EXPECT_DOUBLE_EQ(h.worst(), 1.0);
    EXPECT_EQ(h.worst_index(), 1000u);
    EXPECT_NEAR(h.percentile(0.99), 0.990, 0.990 * 0.0011);
    EXPECT_GE(h.percentile(0.99), 0.990);
    EXPECT_NEAR(h.percentile(0.5), 0.500, 0.500 * 0.0011);
    EXPECT_NEAR(h.mean(), 0.5005, 1e-12);
    EXPECT_EQ(code_sample(4).size(), 65u * 65u * 65u);
}

TEST(GridError, BasisColoursAreThreeByThreeMapsOfRgb) {
    // A basis fitted on 380:780:10, reconstructed at 1 nm over 360:830 under A: the spectra
    // expanded and integrated give the same XYZ as W_A·R_G·B_G·rgb, and the full cube against
    // itself is 0.
    const std::string dir = SPECTEX_TEST_DATA_DIR;
    const Observer obs = load_observer(dir, "cie1931-2");
    const WavelengthGrid g = WavelengthGrid::parse("380:780:10");
    const Colorimetry c =
        Colorimetry::make(obs, load_illuminant(dir, "D65"), g, primaries_by_name("srgb"));
    const Basis basis = fit_basis({c, FitObjective::Smooth, false}).basis;
    const BasisMethod m(basis, "test");
    const WavelengthGrid fine = renderer_grid(360, 830);
    const LightWeights a = light_weights(obs, load_illuminant(dir, "A"), fine);
    EXPECT_DOUBLE_EQ(a.dark_nm, 50.0);  // A's table stops at 780 nm
    const Eigen::Matrix3Xd WR =
        a.W * reconstruction_matrix(g.lambda, fine.lambda, Reconstruction::Linear);
    Eigen::MatrixXd B(static_cast<Eigen::Index>(basis.size()), 3);
    for (size_t k = 0; k < basis.size(); ++k)
        B.row(static_cast<Eigen::Index>(k)) << basis.r[k], basis.g[k], basis.b[k];
    const Eigen::Matrix3d M = WR * B;
    const auto codes = code_sample(51);
    std::vector<float> r, gg, b;
    for (const auto& code : codes) {
        r.push_back(static_cast<float>(srgb_code_table()[code[0]]));
        gg.push_back(static_cast<float>(srgb_code_table()[code[1]]));
        b.push_back(static_cast<float>(srgb_code_table()[code[2]]));
    }
    const auto xyz = method_xyz(m, {WR}, r, gg, b, false, nullptr);
    for (size_t i = 0; i < codes.size(); ++i) {
        const Eigen::Vector3d rgb(r[i], gg[i], b[i]);
        EXPECT_LT((xyz[0].col(static_cast<Eigen::Index>(i)) - M * rgb).norm(), 1e-6);
    }
    const auto same = cube_error_linear({M}, M, a.white, 2);
    EXPECT_EQ(same[0].colours, 16777216u);
    EXPECT_LT(same[0].worst, 1e-9);  // the same map, summed in another order
}
