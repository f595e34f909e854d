#include "spectral/basis_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "base/csv_table.h"
#include "base/error.h"
#include "pipeline/basis_cache.h"

using namespace spectex;

namespace {

const std::string kData = SPECTEX_TEST_DATA_DIR;

FitResult fit(const std::string& grid, const std::string& objective = "smooth",
              const std::string& primaries = "srgb", const std::string& observer = "cie1931-2",
              bool allow = false) {
    FitSpec s;
    s.data_dir = kData;
    s.grid = WavelengthGrid::parse(grid);
    s.objective = parse_objective(objective);
    s.primaries = primaries;
    s.observer = observer;
    s.allow_infeasible = allow;
    return fit_basis_for(s);
}

// Residuals at the level of double rounding: the colour rows sum N terms of size ~1/N.
constexpr double kExact = 1e-12;

void expect_exact(const FitResult& f, const std::string& what) {
    const auto& c = f.certificate;
    EXPECT_TRUE(c.feasible) << what;
    for (double r : c.colour_residual) EXPECT_LE(r, kExact) << what;
    EXPECT_EQ(c.bound_violation, 0.0) << what;
    EXPECT_LE(c.sum_violation, kExact) << what;
    EXPECT_LE(c.stationarity, 1e-9) << what;
    EXPECT_LE(c.dual_sign_violation, 1e-9) << what;
    EXPECT_LE(c.complementarity, 1e-9) << what;
}

}  // namespace

TEST(BasisFit, DefaultGridBothObjectivesAreExact) {
    expect_exact(fit("380:780:5", "smooth"), "smooth");
    expect_exact(fit("380:780:5", "norm"), "norm");
}

TEST(BasisFit, ManyActiveBoundsAndComplementarity) {
    // 400:700:2.5 cuts the spectrum where the primaries need all their range: many bounds active.
    FitResult f = fit("400:700:2.5", "norm");
    expect_exact(f, "400:700:2.5");
    EXPECT_GT(f.certificate.active_lower + f.certificate.active_upper, 100);
}

TEST(BasisFit, InfeasibleIsDetectedAndLeastSquaresIsFinite) {
    EXPECT_THROW(fit("380:780:5", "smooth", "rec2020"), Error);
    FitResult f = fit("380:780:5", "smooth", "rec2020", "cie1931-2", true);
    EXPECT_FALSE(f.certificate.feasible);
    for (size_t k = 0; k < f.basis.size(); ++k)
        for (double v : {f.basis.r[k], f.basis.g[k], f.basis.b[k]}) {
            ASSERT_TRUE(std::isfinite(v));
            EXPECT_GE(v, -1e-12);
            EXPECT_LE(v, 1 + 1e-12);
        }
    // Rec.2020 green is far outside what [0,1] reflectances reach under D65: a visible residual.
    EXPECT_GT(std::max({f.certificate.colour_residual[0], f.certificate.colour_residual[1],
                        f.certificate.colour_residual[2]}),
              1e-3);
    EXPECT_THROW(fit("500:505:5"), Error);  // fewer than 3 bins
}

TEST(BasisFit, DeterministicBytes) {
    FitSpec s;
    s.data_dir = kData;
    s.grid = WavelengthGrid::parse("380:780:7");
    Observer o = load_observer(kData, "cie1931-2");
    Spectrum d65 = load_illuminant(kData, "D65");
    FitRequest req{Colorimetry::make(o, d65, s.grid, primaries_by_name("srgb")),
                   FitObjective::Smooth, false};
    EXPECT_EQ(fit_basis(req).basis.checksum(), fit_basis(req).basis.checksum());
}

TEST(BasisFit, ShippedDefaultBasisEqualsAFreshFit) {
    // config/spectral/basis_fit_smooth_380-780-5.csv is regenerated with
    //   spectex basis -q -o config/spectral/basis_fit_smooth_380-780-5.csv
    CsvTable t = read_csv_table(kData + "/spectral/basis_fit_smooth_380-780-5.csv",
                                {"wavelength", "r", "g", "b"});
    Basis shipped{"shipped", t.data[0], t.data[1], t.data[2], t.data[3]};
    FitResult f = fit("380:780:5", "smooth");
    EXPECT_EQ(shipped.checksum(), f.basis.checksum())
        << "regenerate the shipped basis (see the comment above)";
}

TEST(BasisFit, PublishedBasisCertificate) {
    // The published table: colour residual ~3.5e-8 and sum-to-one only within 1e-5.
    Basis b = load_basis(kData, "mallett2019");
    auto grid = WavelengthGrid::from_list(b.lambda);
    auto c = certify_basis(
        b, Colorimetry::make(load_observer(kData, "cie1931-2"), load_illuminant(kData, "D65"), grid,
                             primaries_by_name("srgb")));
    EXPECT_LT(c.colour_residual[0], 1e-7);
    EXPECT_GT(c.sum_violation, 1e-6);
    EXPECT_LT(c.sum_violation, 2e-5);
}
