// The method seam: the basis behind SpectralMethod gives exactly the bytes of the basis kernel,
// and the generic colour-aware rounding that every other method uses (round what expand_float
// gives) is the same rule: on the basis' spectra it reproduces the basis kernel bit for bit.
#include "spectral/spectral_method.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <iterator>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "io/provenance_keys.h"
#include "spectral/basis_fit.h"
#include "spectral/colorimetry.h"
#include "spectral/spectrum.h"

using namespace spectex;

namespace {

struct FittedBasis {
    Basis basis;
    std::vector<float> weight;  // bins x 3
};

FittedBasis fitted(const std::string& grid) {
    const std::string dir = SPECTEX_TEST_DATA_DIR;
    Colorimetry c = Colorimetry::make(load_observer(dir, "cie1931-2"), load_illuminant(dir, "D65"),
                                      WavelengthGrid::parse(grid), primaries_by_name("srgb"));
    FittedBasis s{fit_basis({c, FitObjective::Smooth, false}).basis, {}};
    const Eigen::Matrix3Xd R = c.rgb_weights();
    for (Eigen::Index k = 0; k < R.cols(); ++k)
        for (int ch = 0; ch < 3; ++ch) s.weight.push_back(static_cast<float>(R(ch, k)));
    return s;
}

// Random linear RGB with the hard values mixed in: 0, 1, tiny, and 8-bit sRGB codes' values.
void pixels(size_t n, std::vector<float>& r, std::vector<float>& g, std::vector<float>& b) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const float special[] = {0.0f, 1.0f, 1e-7f, 0.5f, 0.0030352698f, 0.2140411f};
    r.resize(n), g.resize(n), b.resize(n);
    for (size_t i = 0; i < n; ++i) {
        r[i] = i % 5 == 0 ? special[i % 6] : u(rng);
        g[i] = i % 7 == 0 ? special[(i / 7) % 6] : u(rng);
        b[i] = u(rng);
    }
}

}  // namespace

TEST(SpectralMethod, BasisIsTheBasisKernelByteForByte) {
    for (const std::string grid : {"380:780:5", "380:780:10", "400:700:2.5"}) {
        FittedBasis s = fitted(grid);
        BasisMethod method(s.basis, "test");
        ExpansionMatrix m = ExpansionMatrix::from_basis(s.basis);
        const size_t n = 3000, bins = s.basis.size();
        std::vector<float> r, g, b;
        pixels(n, r, g, b);
        std::vector<float> f1(n * bins), f2(n * bins);
        expand_to_float(m, r.data(), g.data(), b.data(), n, f1.data(), n);
        method.expand_float(r.data(), g.data(), b.data(), n, f2.data(), n);
        EXPECT_EQ(f1, f2) << grid;
        std::vector<uint16_t> h1(n * bins), h2(n * bins);
        expand_to_half(m, r.data(), g.data(), b.data(), n, h1.data(), n);
        method.expand_half(r.data(), g.data(), b.data(), n, h2.data(), n, nullptr);
        EXPECT_EQ(h1, h2) << grid << ": nearest rounding";
        m.rgb_weight = s.weight;
        expand_to_half(m, r.data(), g.data(), b.data(), n, h1.data(), n);
        method.expand_half(r.data(), g.data(), b.data(), n, h2.data(), n, &s.weight);
        EXPECT_EQ(h1, h2) << grid << ": colour rounding";
    }
}

TEST(SpectralMethod, GenericColourRoundingIsTheBasisRule) {
    // The default expand_half (expand_float, then round_spectra_to_half) on the basis' spectra
    // gives the optimised basis kernel's bits: one rounding rule for every method.
    for (const std::string grid : {"380:780:5", "380:780:20", "360:830:1"}) {
        FittedBasis s = fitted(grid);
        BasisMethod method(s.basis, "test");
        const size_t n = 2500, bins = s.basis.size();
        std::vector<float> r, g, b;
        pixels(n, r, g, b);
        for (const std::vector<float>* w :
             std::vector<const std::vector<float>*>{nullptr, &s.weight}) {
            std::vector<uint16_t> fast(n * bins), generic(n * bins);
            method.expand_half(r.data(), g.data(), b.data(), n, fast.data(), n, w);
            method.SpectralMethod::expand_half(r.data(), g.data(), b.data(), n, generic.data(), n,
                                               w);
            size_t differ = 0;
            for (size_t i = 0; i < fast.size(); ++i) differ += fast[i] != generic[i];
            EXPECT_EQ(differ, 0u) << grid << (w ? ", colour rounding" : ", nearest");
        }
    }
}

TEST(SpectralMethod, BasisProvenanceIsTheBasisAttributes) {
    FittedBasis s = fitted("380:780:5");
    BasisMethod method(s.basis, "fitted by spectex: x");
    auto p = method.provenance();
    ASSERT_EQ(p.size(), 4u);
    EXPECT_EQ(p[0].first, MethodFact::Method);
    EXPECT_STREQ(method_fact_key(p[0].first), "spectex:method");
    EXPECT_EQ(p[0].second, "basis");
    EXPECT_EQ(p[1].first, MethodFact::Basis);
    EXPECT_STREQ(method_fact_key(p[1].first), "spectex:basis");
    EXPECT_STREQ(method_fact_key(p[2].first), "spectex:basisSource");
    EXPECT_STREQ(method_fact_key(p[3].first), "spectex:basisChecksum");
    EXPECT_EQ(p[2].second, "fitted by spectex: x");
    EXPECT_EQ(p[3].second, s.basis.checksum());
    EXPECT_EQ(method.checksum(), s.basis.checksum());
    EXPECT_TRUE(method.is_linear());
}

// The maths names what a method is (MethodFact); io/provenance_keys.h names the attribute: every
// fact has a key of its own, and it is one that the readers know (kAll).
TEST(SpectralMethod, EveryMethodFactHasItsOwnKnownKey) {
    const MethodFact facts[] = {MethodFact::Method,
                                MethodFact::Basis,
                                MethodFact::BasisSource,
                                MethodFact::BasisChecksum,
                                MethodFact::LatticeSize,
                                MethodFact::VertexPrior,
                                MethodFact::JhTableResolution,
                                MethodFact::MethodSource,
                                MethodFact::MethodChecksum};
    std::set<std::string> keys;
    for (MethodFact f : facts) {
        const std::string key = method_fact_key(f);
        EXPECT_TRUE(std::any_of(std::begin(provenance_key::kAll), std::end(provenance_key::kAll),
                                [&](const char* k) { return key == k; }))
            << key;
        keys.insert(key);
    }
    EXPECT_EQ(keys.size(), std::size(facts));
}
