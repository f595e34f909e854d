// The precision budget's spectral core: rounding to k mantissa bits per bin on the coarser grid of
// half values, the colour-aware correction on that grid (every 8-bit colour still re-encodes to
// its code under the rounding's colorimetry), full precision being today's rounding bit for bit,
// and the chooser keeping the worst ΔE00 under each light within the budget.
#include "spectral/precision.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "base/error.h"
#include "base/half.h"
#include "spectral/basis_fit.h"
#include "spectral/colorimetry.h"
#include "spectral/expand.h"
#include "spectral/grid_error.h"
#include "spectral/half_bits.h"
#include "spectral/spectrum.h"

using namespace spectex;

namespace {

const std::string kDir = SPECTEX_TEST_DATA_DIR;

struct Fitted {
    std::unique_ptr<BasisMethod> method;
    std::vector<float> weight;  // bins x 3, D65 colour-aware rounding weights
};

Fitted fitted(const std::string& grid) {
    Colorimetry c =
        Colorimetry::make(load_observer(kDir, "cie1931-2"), load_illuminant(kDir, "D65"),
                          WavelengthGrid::parse(grid), primaries_by_name("srgb"));
    Fitted f{
        std::make_unique<BasisMethod>(fit_basis({c, FitObjective::Smooth, false}).basis, "test"),
        {}};
    const Eigen::Matrix3Xd R = c.rgb_weights();
    for (Eigen::Index k = 0; k < R.cols(); ++k)
        for (int ch = 0; ch < 3; ++ch) f.weight.push_back(static_cast<float>(R(ch, k)));
    return f;
}

int srgb_code(double linear) {
    const double v =
        linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
    return static_cast<int>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
}

// Bits that fall steeply away from the middle of the visible range: 10 at 550 nm, down to 2.
std::vector<int> steep_bits(const std::vector<double>& lambda) {
    std::vector<int> bits;
    for (double l : lambda)
        bits.push_back(std::clamp(10 - static_cast<int>(std::fabs(l - 550) / 25), 2, 10));
    return bits;
}

}  // namespace

TEST(Precision, RoundHalfToBitsIsNearestOnTheCoarserGrid) {
    // Against brute force over every half code of the grid: nearest, ties to the even grid point;
    // values in [0, 1] stay in [0, 1].
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int bits = 0; bits <= 10; ++bits) {
        const uint32_t step = 1u << (10 - bits);
        for (int t = 0; t < 4000; ++t) {
            float v =
                t < 8 ? std::vector<float>{0.0f, 1.0f, 1e-7f, 6e-5f, 0.5f, 0.999f, 1e-3f, 0.25f}[t]
                      : u(rng) * (t % 3 == 0 ? 0.01f : 1.0f);
            const uint16_t h = round_half_to_bits(v, bits);
            EXPECT_LE(half_mantissa_bits(h), bits) << v;
            EXPECT_GE(half_to_float(h), 0.0f);
            EXPECT_LE(half_to_float(h), 1.0f);
            double best = 1e9;
            uint32_t best_code = 0;
            for (uint32_t c = 0; c <= 0x3c00u; c += step) {
                const double d =
                    std::fabs(static_cast<double>(half_to_float(static_cast<uint16_t>(c))) - v);
                if (d < best || (d == best && ((c / step) & 1u) == 0)) best = d, best_code = c;
            }
            EXPECT_EQ(h, best_code) << "bits " << bits << " v " << v;
        }
    }
    for (uint32_t c = 0; c < 0x7c00u; ++c)  // full precision is plain half
        EXPECT_EQ(round_half_to_bits(half_to_float(static_cast<uint16_t>(c)) * 1.0001f, 10),
                  float_to_half(half_to_float(static_cast<uint16_t>(c)) * 1.0001f));
}

TEST(Precision, AllTenBitsIsTodaysRoundingBitForBit) {
    Fitted f = fitted("380:780:5");
    const size_t n = 5000, bins = static_cast<size_t>(f.method->bins());
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> r(n), g(n), b(n);
    for (size_t i = 0; i < n; ++i) r[i] = u(rng), g[i] = u(rng), b[i] = u(rng);
    std::vector<uint16_t> h1(n * bins), h2(n * bins);
    f.method->expand_half(r.data(), g.data(), b.data(), n, h1.data(), n, &f.weight);
    EXPECT_EQ(expand_half_bits(*f.method, r.data(), g.data(), b.data(), n, h2.data(), n, &f.weight,
                               std::vector<int>(bins, 10)),
              0u);
    EXPECT_EQ(h1, h2);
    expand_half_bits(*f.method, r.data(), g.data(), b.data(), n, h2.data(), n, &f.weight, {});
    EXPECT_EQ(h1, h2);
}

TEST(Precision, EveryCodeOfADenseCubeReencodesUnderD65OnCoarseGrids) {
    // Codes 0, 5, 10, … 255 on each axis (140,608 colours). The decoded colour under the rounding's
    // colorimetry must give back the 8-bit code of every channel; values keep at most the asked
    // bits except in the pixels the grids could not hold (rounded at full precision, reported).
    Fitted f = fitted("380:780:5");
    const size_t bins = static_cast<size_t>(f.method->bins());
    const auto codes = code_sample(5);
    const auto& table = srgb_code_table();
    const size_t n = codes.size();
    std::vector<float> r(n), g(n), b(n);
    for (size_t i = 0; i < n; ++i)
        r[i] = static_cast<float>(table[codes[i][0]]),
        g[i] = static_cast<float>(table[codes[i][1]]),
        b[i] = static_cast<float>(table[codes[i][2]]);
    for (const std::vector<int>& bits :
         {steep_bits(f.method->lambda()), std::vector<int>(bins, 6), std::vector<int>(bins, 9)}) {
        std::vector<uint16_t> h(n * bins);
        const size_t widened = expand_half_bits(*f.method, r.data(), g.data(), b.data(), n,
                                                h.data(), n, &f.weight, bits);
        size_t over_bits = 0, wrong = 0;
        for (size_t i = 0; i < n; ++i) {
            double rgb[3] = {0, 0, 0};
            bool over = false;
            for (size_t k = 0; k < bins; ++k) {
                const uint16_t v = h[k * n + i];
                over = over || half_mantissa_bits(v) > bits[k];
                EXPECT_GE(half_to_float(v), 0.0f);
                EXPECT_LE(half_to_float(v), 1.0f);
                for (int c = 0; c < 3; ++c) rgb[c] += f.weight[3 * k + c] * half_to_float(v);
            }
            over_bits += over;
            for (int c = 0; c < 3; ++c) wrong += srgb_code(rgb[c]) != codes[i][c];
        }
        EXPECT_EQ(wrong, 0u) << format_precision_bits(bits);
        EXPECT_LE(over_bits, widened) << format_precision_bits(bits);
        // Few pixels are left to full precision (at most 1 %; 6 bits everywhere, the hardest of
        // these, left 0.2 % when this was written: the pair moves find what single moves cannot).
        EXPECT_LE(widened, n / 100) << format_precision_bits(bits);
    }
}

TEST(Precision, ChooserHoldsTheBudgetUnderEachLightAndSavesBits) {
    Fitted f = fitted("380:780:5");
    PrecisionRequest req;
    req.method = f.method.get();
    req.observer = load_observer(kDir, "cie1931-2");
    for (const char* l : {"D65", "A", "FL11"}) req.lights.push_back(load_illuminant(kDir, l));
    req.rgb_weight = &f.weight;
    req.max_de = 0.5;
    req.stride = kPrecisionSampleStride;  // bake's sample
    req.threads = 2;
    const PrecisionChoice c = choose_precision(req);
    ASSERT_EQ(c.bits.size(), static_cast<size_t>(f.method->bins()));
    ASSERT_EQ(c.worst_de.size(), 3u);
    for (double de : c.worst_de) EXPECT_LE(de, 0.5);
    EXPECT_LT(kept_fraction(c.bits), 0.9) << format_precision_bits(c.bits);
    // Measured again on a denser sample than it chose on (codes 0, 5, … 255: 140,608 colours):
    // within the budget with a margin of 50 % (the sample misses colours between its codes).
    req.stride = 5;
    const PrecisionChoice m = measure_precision(req, c.bits);
    for (double de : m.worst_de) EXPECT_LE(de, 0.75);
    // Deterministic, whatever the threads.
    req.stride = kPrecisionSampleStride;
    req.threads = 1;
    EXPECT_EQ(choose_precision(req).bits, c.bits);
    // A tighter budget keeps at least as many bits in total.
    req.max_de = 0.1;
    const PrecisionChoice t = choose_precision(req);
    for (double de : t.worst_de) EXPECT_LE(de, 0.1);
    EXPECT_GE(kept_fraction(t.bits), kept_fraction(c.bits));
}

TEST(Precision, BitsRoundTripThroughTheirHeaderText) {
    const std::vector<int> bits = {10, 9, 0, 4, 10};
    EXPECT_EQ(format_precision_bits(bits), "10 9 0 4 10");
    EXPECT_EQ(parse_precision_bits("10 9 0 4 10", 5), bits);
    EXPECT_THROW(parse_precision_bits("10 9 0 4", 5), Error);
    EXPECT_THROW(parse_precision_bits("10 9 0 4 11", 5), Error);
    EXPECT_THROW(parse_precision_bits("10 9 -1 4 10", 5), Error);
    EXPECT_THROW(parse_precision_bits("10 9 0x1 4 10", 5), Error);
}
