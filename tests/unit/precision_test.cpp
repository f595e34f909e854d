// The precision budget's spectral core: rounding to k mantissa bits per bin on the coarser grid of
// half values, the colour-aware correction on that grid (every 8-bit colour still re-encodes to
// its code under the rounding's colorimetry), full precision being today's rounding bit for bit,
// and the chooser keeping the worst ΔE00 under each light within the budget.
#include "spectral/precision.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "base/error.h"
#include "base/half.h"
#include "spectral/basis_fit.h"
#include "spectral/ciede2000.h"
#include "spectral/colorimetry.h"
#include "spectral/expand.h"
#include "spectral/grid_error.h"
#include "spectral/half_bits.h"
#include "spectral/lattice.h"
#include "spectral/spectrum.h"
#include "spectral/upsampling_methods.h"

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

// A request for a fitted basis under the named lights (CIE 1931 2°, D65's colour-aware rounding,
// 2 threads); the budget and the sample are the caller's.
PrecisionRequest request_for(const Fitted& f, const std::vector<const char*>& lights) {
    PrecisionRequest req;
    req.method = f.method.get();
    req.observer = load_observer(kDir, "cie1931-2");
    for (const char* l : lights) req.lights.push_back(load_illuminant(kDir, l));
    req.rgb_weight = &f.weight;
    req.threads = 2;
    return req;
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
    // Codes 0, 5, 10, … 255 on each axis (140,608 colours), of two 8-bit encodings: sRGB's and
    // linear (whose code step at the top, 0.39 %, is the smallest share of the value of any
    // encoding: the coarse grids' relative tolerance, 2^-10, is half its half step). (A pure power
    // law's codes near black are closer than full half's own 6.1e-5, so none keeps those.) The
    // decoded colour under the rounding's colorimetry must give back the 8-bit code of every
    // channel; values keep at most the asked bits except in the pixels the grids could not hold
    // (rounded at full precision, reported).
    Fitted f = fitted("380:780:5");
    const size_t bins = static_cast<size_t>(f.method->bins());
    const auto codes = code_sample(5);
    const auto& table = srgb_code_table();
    struct Encoding {
        const char* name;
        std::function<double(int)> decode;
        std::function<int(double)> encode;
    };
    auto nearest = [](double x) {
        return static_cast<int>(std::lround(std::clamp(x, 0.0, 1.0) * 255));
    };
    const Encoding encodings[] = {
        {"sRGB", [&](int c) { return table[c]; },
         [](double v) { return static_cast<int>(srgb_code(v)); }},
        {"linear", [](int c) { return c / 255.0; }, [&](double v) { return nearest(v); }},
    };
    const size_t n = codes.size();
    for (const Encoding& enc : encodings) {
        std::vector<float> r(n), g(n), b(n);
        for (size_t i = 0; i < n; ++i)
            r[i] = static_cast<float>(enc.decode(codes[i][0])),
            g[i] = static_cast<float>(enc.decode(codes[i][1])),
            b[i] = static_cast<float>(enc.decode(codes[i][2]));
        for (const std::vector<int>& bits :
             {steep_bits(f.method->lambda()), std::vector<int>(bins, 6),
              std::vector<int>(bins, 9)}) {
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
                for (int c = 0; c < 3; ++c) wrong += enc.encode(rgb[c]) != codes[i][c];
            }
            EXPECT_EQ(wrong, 0u) << enc.name << ": " << format_precision_bits(bits);
            EXPECT_LE(over_bits, widened) << enc.name << ": " << format_precision_bits(bits);
            // Few pixels are left to full precision (at most 1 %; 6 bits everywhere, the hardest
            // of these, left 0.2 % with an absolute tolerance alone: the pair moves find what
            // single moves cannot).
            EXPECT_LE(widened, n / 100) << enc.name << ": " << format_precision_bits(bits);
        }
    }
}

namespace {

// A renderer's view of a file's bins, computed here apart from spectral/precision.cpp: the bins
// reconstructed linearly at 1 nm over 360-830 nm (ends held), times the light and the observer
// at each nm (linear between table rows, 0 outside a table), Y of white 1.
double table_at(const Spectrum& s, double l) {
    if (l < s.lambda.front() || l > s.lambda.back()) return 0;
    size_t k = 1;
    while (k + 1 < s.lambda.size() && s.lambda[k] < l) ++k;
    const double t = (l - s.lambda[k - 1]) / (s.lambda[k] - s.lambda[k - 1]);
    return (1 - t) * s.value[k - 1] + t * s.value[k];
}

struct RendererView {
    std::vector<std::array<double, 3>> w;  // per bin
    std::array<double, 3> white{};
};
RendererView renderer_view(const Observer& obs, const Spectrum& light,
                           const std::vector<double>& bins) {
    RendererView v;
    v.w.assign(bins.size(), {0, 0, 0});
    double norm = 0;
    for (int nm = 360; nm <= 830; ++nm) {
        const double l = nm;
        const double e = table_at(light, l);
        const double xyz[3] = {e * table_at(obs.x, l), e * table_at(obs.y, l),
                               e * table_at(obs.z, l)};
        // The hat functions of the two bins around nm (or the end bin, held).
        size_t k = 0;
        while (k + 1 < bins.size() && bins[k + 1] <= l) ++k;
        double t = 0;
        if (l <= bins.front())
            k = 0, t = 0;
        else if (k + 1 >= bins.size())
            t = 0;
        else
            t = (l - bins[k]) / (bins[k + 1] - bins[k]);
        for (int c = 0; c < 3; ++c) {
            v.w[k][static_cast<size_t>(c)] += (1 - t) * xyz[c];
            if (t > 0) v.w[k + 1][static_cast<size_t>(c)] += t * xyz[c];
            v.white[static_cast<size_t>(c)] += xyz[c];
        }
        norm += xyz[1];
    }
    for (auto& w : v.w)
        for (double& x : w) x /= norm;
    for (double& x : v.white) x /= norm;
    return v;
}

// ΔE00 under `view` between pixel i of two bins x n planes.
double de_of(const RendererView& view, const float* a, const float* b, size_t n, size_t i) {
    Eigen::Vector3d xa = Eigen::Vector3d::Zero(), xb = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < view.w.size(); ++k)
        for (int c = 0; c < 3; ++c) {
            xa(c) += view.w[k][static_cast<size_t>(c)] * a[k * n + i];
            xb(c) += view.w[k][static_cast<size_t>(c)] * b[k * n + i];
        }
    const Eigen::Vector3d white(view.white[0], view.white[1], view.white[2]);
    return ciede2000(lab_from_xyz(xa, white), lab_from_xyz(xb, white));
}

}  // namespace

// The chooser checks every 8-bit code (not a sample) and records the worst it found: no colour
// may be above the recorded figure. Checked here, apart from the chooser's own arithmetic, on a
// million random codes and on the sample's neighbours; a sample-only chooser records figures that
// these colours exceed (1.4-1.9x on the default lattice, 1.2x on this basis when this was written).
// Several whole-cube passes per choice: Slow.
TEST(PrecisionSlow, ChooserHoldsTheBudgetOnEveryCodeUnderEachLight) {
    Fitted f = fitted("380:780:5");
    PrecisionRequest req = request_for(f, {"D65", "A", "FL11"});
    req.max_de = 0.5;
    req.stride = kPrecisionSampleStride;  // bake's sample
    const PrecisionChoice c = choose_precision(req);
    ASSERT_EQ(c.bits.size(), static_cast<size_t>(f.method->bins()));
    ASSERT_EQ(c.worst_de.size(), 3u);
    EXPECT_EQ(c.colours, size_t(1) << 24);
    for (double de : c.worst_de) EXPECT_LE(de, 0.5);
    EXPECT_LT(kept_fraction(c.bits), 0.9) << format_precision_bits(c.bits);

    // A million random codes, expanded and rounded as a bake does, measured by this file's own
    // colorimetry (double precision throughout). Tolerance: none beyond the recorded figure's own
    // margin (it is raised by 1e-4 relative over the chooser's float sums).
    const size_t n = size_t(1) << 20;
    std::mt19937 rng(20261206);
    std::vector<float> r(n), g(n), b(n);
    const auto& lin = srgb_code_table();
    for (size_t i = 0; i < n; ++i) {
        const uint32_t code = rng() & 0xffffffu;
        r[i] = static_cast<float>(lin[code >> 16]);
        g[i] = static_cast<float>(lin[(code >> 8) & 255]);
        b[i] = static_cast<float>(lin[code & 255]);
    }
    const size_t bins = static_cast<size_t>(f.method->bins());
    std::vector<float> exact(bins * n), stored(bins * n);
    std::vector<uint16_t> h(bins * n);
    f.method->expand_float(r.data(), g.data(), b.data(), n, exact.data(), n);
    expand_half_bits(*f.method, r.data(), g.data(), b.data(), n, h.data(), n, &f.weight, c.bits);
    half_to_floats(h.data(), stored.data(), h.size());
    std::vector<double> worst(3, 0.0);
    for (size_t j = 0; j < 3; ++j) {
        const RendererView view = renderer_view(req.observer, req.lights[j], f.method->lambda());
        for (size_t i = 0; i < n; ++i)
            worst[j] = std::max(worst[j], de_of(view, exact.data(), stored.data(), n, i));
        EXPECT_LE(worst[j], c.worst_de[j]) << req.lights[j].name;
        // The recorded figure is the cube's worst, not a loose bound: these random codes reach
        // at least half of it.
        EXPECT_GE(worst[j], 0.5 * c.worst_de[j]) << req.lights[j].name;
    }

    // And the code recorded with each figure has that figure, measured here in double. Tolerance:
    // the margin the figure carries (1e-4 of itself) and as much again for the chooser's float
    // sums (about 1e-6 relative; the margin is their bound).
    ASSERT_EQ(c.worst_code.size(), 3u);
    for (size_t j = 0; j < 3; ++j) {
        const uint32_t code = c.worst_code[j];
        ASSERT_LE(code, 0xffffffu);
        float cr = static_cast<float>(lin[code >> 16]),
              cg = static_cast<float>(lin[(code >> 8) & 255]),
              cb = static_cast<float>(lin[code & 255]);
        std::vector<float> e(bins), st(bins);
        std::vector<uint16_t> hh(bins);
        f.method->expand_float(&cr, &cg, &cb, 1, e.data(), 1);
        expand_half_bits(*f.method, &cr, &cg, &cb, 1, hh.data(), 1, &f.weight, c.bits);
        half_to_floats(hh.data(), st.data(), hh.size());
        const RendererView view = renderer_view(req.observer, req.lights[j], f.method->lambda());
        const double de = de_of(view, e.data(), st.data(), 1, 0);
        EXPECT_NEAR(de, c.worst_de[j] / 1.0001, 2e-4 * c.worst_de[j])
            << req.lights[j].name << " code " << std::hex << code;
    }

    // (That the bits and the codes do not depend on the threads: a bake's search with one and with
    // three, PrecisionSlow.AutoBakeIsTheSameWhateverTheThreads.)
    // A tighter budget keeps at least as many bits in total.
    req.max_de = 0.1;
    const PrecisionChoice t = choose_precision(req);
    for (double de : t.worst_de) EXPECT_LE(de, 0.1);
    EXPECT_GE(kept_fraction(t.bits), kept_fraction(c.bits));
}

// The chooser's whole-cube pass computes ΔE00 only where 2.1214 x ΔE76 could beat its running
// worst: the bound must hold for every pair of colours. Pairs near and far, dark and saturated,
// around every hue (where R_T and the a' scaling are largest). No tolerance: it is a bound.
TEST(Precision, De00IsNeverAboveSqrtFourPointFiveTimesDe76) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> L(0, 100), ab(-128, 128), unit(-1, 1);
    double most = 0;
    for (int i = 0; i < 2000000; ++i) {
        const Lab p{L(rng), ab(rng) * (i % 3 == 0 ? 0.1 : 1), ab(rng) * (i % 3 == 0 ? 0.1 : 1)};
        const double scale = std::pow(10.0, -3 + (i % 5));  // steps from 1e-3 to 10
        const Lab q{p.L + scale * unit(rng), p.a + scale * unit(rng), p.b + scale * unit(rng)};
        const double de76 = std::sqrt((p.L - q.L) * (p.L - q.L) + (p.a - q.a) * (p.a - q.a) +
                                      (p.b - q.b) * (p.b - q.b));
        if (de76 == 0) continue;
        const double ratio = ciede2000(p, q) / de76;
        most = std::max(most, ratio);
        ASSERT_LE(ratio, 2.1214) << p.L << " " << p.a << " " << p.b << " / " << q.L << " " << q.a
                                 << " " << q.b;
    }
    // The bound is not idle: some pairs come near it (a' = 1.5 a near the neutral axis).
    EXPECT_GT(most, 1.4);
}

// lab_from_xyz_fast replaces libm's cube root by Halley's method: the same L*a*b* to 1e-11 (each
// cube root within 1e-14 relative, measured 6.4e-15; a* is 500 times the difference of two roots
// up to 1.07; libm's own cbrt is within an ulp). Three Newton steps, 1e-12 each, failed this.
TEST(Precision, FastLabIsLabFromXyz) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0, 1.2);
    const Eigen::Vector3d white(0.95047, 1.0, 1.08883);
    for (int i = 0; i < 1000000; ++i) {
        const double s = std::pow(10.0, -(i % 8));  // down to 1e-7 of white
        const Eigen::Vector3d xyz(u(rng) * s, u(rng) * s, u(rng) * s);
        const Lab a = lab_from_xyz(xyz, white), b = lab_from_xyz_fast(xyz, white);
        ASSERT_NEAR(a.L, b.L, 1e-11);
        ASSERT_NEAR(a.a, b.a, 1e-11);
        ASSERT_NEAR(a.b, b.b, 1e-11);
    }
}

// The recorded worst is rounded up, never to nearest: it stays an upper bound of the figure.
TEST(Precision, AFigureIsRoundedUpToThreeDigits) {
    EXPECT_EQ(format_de_up(0.49), "0.49");
    EXPECT_EQ(format_de_up(0.4900001), "0.491");
    EXPECT_EQ(format_de_up(0.13449), "0.135");
    EXPECT_EQ(format_de_up(1.0), "1");
    EXPECT_EQ(format_de_up(0.0999999), "0.1");
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-6, 2);
    for (int i = 0; i < 100000; ++i) {
        const double v = std::pow(10.0, u(rng));
        const double up = std::stod(format_de_up(v));
        ASSERT_GE(up, v);
        ASSERT_LE(up, v * (1 + 1e-2) + 1e-300) << v;  // one unit of the third digit at most
    }
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

namespace {

// The coarse-grid rounding as it was first written, one pixel at a time and scalar: the vectorised
// round_spectra_to_bits must give these bytes bit for bit (its initial rounding, single moves and
// pair moves; docs/precision.md).
// A pixel's colour is held to kTol, or to kRel of each channel's value where that is larger.
constexpr float kTol = 1.0f / 16384.0f;
constexpr float kRel = 1.0f / 1024.0f;

uint16_t ref_other_side(uint16_t h, float v, float s) {
    if (v > s && (h & 0x7fffu) != 0)
        return (h & 0x8000u) ? static_cast<uint16_t>(h + 1) : static_cast<uint16_t>(h - 1);
    if (v < s && (h & 0x7fffu) < 0x7bffu)
        return (h & 0x8000u) ? static_cast<uint16_t>(h - 1) : static_cast<uint16_t>(h + 1);
    return h;
}

uint16_t ref_other_side_step(uint16_t h, float v, float s, uint16_t step) {
    if (step == 1) return ref_other_side(h, v, s);
    const uint16_t sign = h & 0x8000u, mag = h & 0x7fffu;
    if (v > s) {
        if (mag == 0) return h;
        return sign ? static_cast<uint16_t>(h + step) : static_cast<uint16_t>(h - step);
    }
    if (v < s) {
        if (sign) return mag == 0 ? step : static_cast<uint16_t>(h - step);
        if (static_cast<uint32_t>(mag) + step <= 0x7bffu) return static_cast<uint16_t>(h + step);
    }
    return h;
}

bool ref_within(const float* e, const float* c) {
    for (int j = 0; j < 3; ++j)
        if (!(std::fabs(e[j]) <= std::max(kTol, kRel * std::fabs(c[j])))) return false;
    return true;
}

size_t ref_best_flip(const std::vector<float>* w, size_t bins, const float* delta, const float* e) {
    size_t best = bins;
    float best_e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    for (size_t k = 0; k < bins; ++k) {
        const float x = e[0] + w[0][k] * delta[k], y = e[1] + w[1][k] * delta[k],
                    z = e[2] + w[2][k] * delta[k];
        const float t = x * x + y * y + z * z;
        if (t < best_e2) best_e2 = t, best = k;
    }
    return best;
}

bool ref_round_pixel(const float* s, size_t ss, size_t bins, const std::vector<float>* w,
                     const std::vector<uint16_t>& steps, float* delta, uint16_t* px, size_t ps) {
    float e[3] = {0, 0, 0}, c[3] = {0, 0, 0};
    for (size_t k = 0; k < bins; ++k) {
        const float v = s[k * ss];
        const uint16_t h =
            steps[k] == 1 ? float_to_half(v) : round_half_to_bits(v, 10 - __builtin_ctz(steps[k]));
        px[k * ps] = h;
        const float d = half_to_float(h) - v;
        e[0] += w[0][k] * d;
        e[1] += w[1][k] * d;
        e[2] += w[2][k] * d;
        c[0] += w[0][k] * v;
        c[1] += w[1][k] * v;
        c[2] += w[2][k] * v;
    }
    if (ref_within(e, c)) return true;
    for (size_t k = 0; k < bins; ++k) {
        const float hv = half_to_float(px[k * ps]);
        delta[k] = half_to_float(ref_other_side_step(px[k * ps], hv, s[k * ss], steps[k])) - hv;
    }
    auto move = [&](size_t k) {
        uint16_t& h = px[k * ps];
        h = ref_other_side_step(h, half_to_float(h), s[k * ss], steps[k]);
        e[0] += w[0][k] * delta[k];
        e[1] += w[1][k] * delta[k];
        e[2] += w[2][k] * delta[k];
        const float hv = half_to_float(h);
        delta[k] = half_to_float(ref_other_side_step(h, hv, s[k * ss], steps[k])) - hv;
    };
    for (int flip = 1; flip <= 32; ++flip) {
        const size_t best = ref_best_flip(w, bins, delta, e);
        if (best == bins) break;
        move(best);
        if (ref_within(e, c)) return true;
    }
    std::vector<float> v(3 * bins);
    for (int pair = 0; pair < 16; ++pair) {
        for (size_t k = 0; k < bins; ++k)
            for (size_t c = 0; c < 3; ++c) v[3 * k + c] = w[c][k] * delta[k];
        size_t ba = bins, bb = bins;
        float best_e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
        for (size_t a = 0; a < bins; ++a) {
            if (delta[a] == 0) continue;
            const float xa = e[0] + v[3 * a], ya = e[1] + v[3 * a + 1], za = e[2] + v[3 * a + 2];
            for (size_t b = a + 1; b < bins; ++b) {
                const float x = xa + v[3 * b], y = ya + v[3 * b + 1], z = za + v[3 * b + 2];
                const float t = x * x + y * y + z * z;
                if (t < best_e2) best_e2 = t, ba = a, bb = b;
            }
        }
        if (ba == bins) return false;
        move(ba);
        move(bb);
        if (ref_within(e, c)) return true;
    }
    return false;
}

size_t ref_round_spectra_to_bits(const float* spectra, size_t ss, size_t n, size_t bins,
                                 const std::vector<float>& rgb_weight, const std::vector<int>& bits,
                                 uint16_t* out, size_t ps) {
    std::vector<uint16_t> steps(bins);
    for (size_t k = 0; k < bins; ++k) steps[k] = static_cast<uint16_t>(1u << (10 - bits[k]));
    std::vector<float> w[3];
    for (size_t c = 0; c < 3; ++c)
        for (size_t k = 0; k < bins; ++k) w[c].push_back(rgb_weight[3 * k + c]);
    std::vector<float> delta(bins);
    size_t widened = 0;
    for (size_t i = 0; i < n; ++i) {
        if (ref_round_pixel(spectra + i, ss, bins, w, steps, delta.data(), out + i, ps)) continue;
        ++widened;
        round_spectra_to_half(spectra + i, ss, 1, bins, &rgb_weight, out + i, ps);
    }
    return widened;
}

}  // namespace

TEST(Precision, VectorisedCoarseRoundingIsTheScalarOneBitForBit) {
    // Nearest on the grid, a plane at a time, against round_half_to_bits value by value: random
    // values over the whole half range and both signs, every grid point and the midpoints between
    // neighbours (the ties), subnormals, values past the largest half, Inf and NaN.
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<float> vals;
    for (int t = 0; t < 6000; ++t) vals.push_back(u(rng) * std::ldexp(1.0f, t % 40 - 28));
    for (uint32_t c = 0; c < 0x7c00u; c += 7) {
        const float a = half_to_float(static_cast<uint16_t>(c));
        const float b = half_to_float(static_cast<uint16_t>(c + 1));
        vals.insert(vals.end(), {a, -a, (a + b) / 2, -(a + b) / 2, std::nextafter(a, 1e9f)});
    }
    vals.insert(vals.end(), {0.0f, -0.0f, 65504.0f, 65519.0f, 65520.0f, 1e6f, -1e6f, 1e-45f,
                             INFINITY, -INFINITY, NAN});
    for (int bits = 0; bits <= 9; ++bits) {
        // A grid's midpoints too (its ties): the even grid point wins.
        std::vector<float> v = vals;
        const uint32_t step = 1u << (10 - bits);
        for (uint32_t c = 0; c + step < 0x7c00u; c += step * 3)
            v.push_back((half_to_float(static_cast<uint16_t>(c)) +
                         half_to_float(static_cast<uint16_t>(c + step))) /
                        2);
        std::vector<uint16_t> out(v.size());
        round_spectra_to_bits(v.data(), v.size(), v.size(), 1, nullptr, {bits}, out.data(),
                              v.size());
        for (size_t i = 0; i < v.size(); ++i)
            ASSERT_EQ(out[i], round_half_to_bits(v[i], bits)) << "bits " << bits << " v " << v[i];
        // The same edge values with colour weights on two bins: the moves' first deltas
        // (negative values, zeros of both signs, the range's end, Inf and NaN) as the reference's.
        const size_t m = v.size();
        std::vector<float> two(2 * m);
        std::copy(v.begin(), v.end(), two.begin());
        std::copy(v.rbegin(), v.rend(), two.begin() + static_cast<std::ptrdiff_t>(m));
        const std::vector<float> w2 = {0.5f, 0.3f, 0.2f, 0.1f, 0.6f, 0.3f};
        for (const std::vector<int>& b2 : {std::vector<int>{bits, bits}, {bits, 10}}) {
            std::vector<uint16_t> got(2 * m), want(2 * m);
            const size_t wg = round_spectra_to_bits(two.data(), m, m, 2, &w2, b2, got.data(), m);
            const size_t ww =
                ref_round_spectra_to_bits(two.data(), m, m, 2, w2, b2, want.data(), m);
            EXPECT_EQ(wg, ww) << "bits " << bits;
            EXPECT_TRUE(got == want) << "bits " << bits;
        }
    }

    // With the colour-aware correction: random colours, dense-cube colours and out-of-gamut ones,
    // steep bits and bits of 0 to 3 (pair moves and widened pixels), against the reference.
    Fitted f = fitted("380:780:5");
    const size_t bins = static_cast<size_t>(f.method->bins());
    std::vector<float> r, g, b;
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    for (int i = 0; i < 3000; ++i)
        r.push_back(u01(rng)), g.push_back(u01(rng)), b.push_back(u01(rng));
    for (int i = 0; i < 500; ++i)
        r.push_back(u01(rng) * 1.4f - 0.2f), g.push_back(u01(rng) * 0.01f), b.push_back(u01(rng));
    const size_t n = r.size();
    std::vector<float> spectra(n * bins);
    f.method->expand_float(r.data(), g.data(), b.data(), n, spectra.data(), n);
    for (const std::vector<int>& bits :
         {steep_bits(f.method->lambda()), std::vector<int>(bins, 3), std::vector<int>(bins, 0)}) {
        std::vector<uint16_t> got(n * bins), want(n * bins);
        const size_t wg =
            round_spectra_to_bits(spectra.data(), n, n, bins, &f.weight, bits, got.data(), n);
        const size_t ww =
            ref_round_spectra_to_bits(spectra.data(), n, n, bins, f.weight, bits, want.data(), n);
        EXPECT_EQ(wg, ww);
        EXPECT_TRUE(got == want) << "bits " << format_precision_bits(bits);
    }
    // The scalar path (machines without F16C) too, in a process of its own.
    if (!std::getenv("SPECTEX_NO_F16C")) {
        char self[4096];
        const ssize_t len = ::readlink("/proc/self/exe", self, sizeof self - 1);
        ASSERT_GT(len, 0);
        self[len] = 0;
        const int st = std::system(
            ("SPECTEX_NO_F16C=1 '" + std::string(self) +
             "' --gtest_filter=Precision.VectorisedCoarseRoundingIsTheScalarOneBitForBit "
             ">/dev/null")
                .c_str());
        EXPECT_EQ(st, 0) << "the scalar path (SPECTEX_NO_F16C=1) differs from the reference";
    }
}

// The shortcut the whole-cube pass takes the reference's colours by: a basis' and a lattice's
// weighted() method expands to W times their spectrum, for any colour (clamped alike). Tolerance
// 1e-5 of the largest value: float tables and sums over 31 bins.
TEST(Precision, AWeightedMethodGivesTheColoursOfItsSpectra) {
    const WavelengthGrid grid = WavelengthGrid::parse("400:700:10");
    const Colorimetry c =
        Colorimetry::make(load_observer(kDir, "cie1931-2"), load_illuminant(kDir, "D65"), grid,
                          primaries_by_name("srgb"));
    Fitted f = fitted("400:700:10");
    const LatticeMethod lattice(SpectralLattice::build(c, 5, VertexPrior::Smooth), grid.lambda,
                                "test", 0.5);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-0.1, 1.1);
    Eigen::MatrixXd W(6, grid.size());
    for (Eigen::Index i = 0; i < W.size(); ++i) W.data()[i] = u(rng);
    const size_t n = 4096, bins = grid.size();
    std::vector<float> r(n), g(n), b(n);
    for (size_t i = 0; i < n; ++i)
        r[i] = static_cast<float>(u(rng)), g[i] = static_cast<float>(u(rng)),
        b[i] = static_cast<float>(u(rng));
    for (const SpectralMethod* m : {static_cast<const SpectralMethod*>(f.method.get()),
                                    static_cast<const SpectralMethod*>(&lattice)}) {
        const auto w = m->weighted(W);
        ASSERT_TRUE(w) << m->name();
        ASSERT_EQ(w->bins(), 6);
        std::vector<float> s(bins * n), x(6 * n);
        m->expand_float(r.data(), g.data(), b.data(), n, s.data(), n);
        w->expand_float(r.data(), g.data(), b.data(), n, x.data(), n);
        double worst = 0;
        for (size_t i = 0; i < n; ++i)
            for (Eigen::Index row = 0; row < 6; ++row) {
                double want = 0;
                for (size_t k = 0; k < bins; ++k)
                    want += W(row, static_cast<Eigen::Index>(k)) * s[k * n + i];
                worst = std::max(worst, std::fabs(want - x[static_cast<size_t>(row) * n + i]));
            }
        EXPECT_LT(worst, 1e-5 * W.cwiseAbs().rowwise().sum().maxCoeff()) << m->name();
    }
}

// With the method at 1 nm as the reference, the budget covers the grid's error: on 400:700:20 it
// is most of the error (plan: about 1.1 to 1.6 under these lights), where the rounding alone is
// hundredths. Measured on bake's sample; the bounds are an order of magnitude from the figures.
TEST(Precision, TheReferenceBringsTheGridsErrorIntoTheBudget) {
    Fitted coarse = fitted("400:700:20"), fine = fitted("360:830:1");
    PrecisionRequest req = request_for(coarse, {"D65", "A", "FL11"});
    req.stride = 32;
    const std::vector<int> full(static_cast<size_t>(coarse.method->bins()), 10);
    const PrecisionChoice alone = measure_precision(req, full);
    req.reference = fine.method.get();
    const PrecisionChoice with_grid = measure_precision(req, full);
    for (size_t j = 0; j < 3; ++j) {
        EXPECT_LT(alone.worst_de[j], 0.05) << req.lights[j].name;
        EXPECT_GT(with_grid.worst_de[j], 0.3) << req.lights[j].name;
    }
}

// A grid over the budget by itself: no bits can meet it, so all 10 are kept at once (one sample
// measure and one cube pass, not a search undone a pass at a time) and the recorded worst is the
// cube's, over the budget.
TEST(PrecisionSlow, AGridOverTheBudgetKeepsEveryBitAtOnce) {
    Fitted coarse = fitted("400:700:20"), fine = fitted("360:830:1");
    PrecisionRequest req = request_for(coarse, {"D65", "FL11"});
    req.reference = fine.method.get();
    req.max_de = 0.25;
    const PrecisionChoice c = choose_precision(req);
    EXPECT_EQ(c.bits, std::vector<int>(static_cast<size_t>(coarse.method->bins()), 10));
    EXPECT_GT(*std::max_element(c.worst_de.begin(), c.worst_de.end()), 0.25);
    EXPECT_LE(c.evaluations, 2u);
}

// A grid may reach past a light's table (380:830 against A's 300-780 nm, FL2's 380-780): the light
// is dark there, as plan and the renderer's colour take it; the default bake on such a grid threw
// "785 nm lies outside the A table". Inside the tables the visibility is each bin's XYZ weight
// under the light (Colorimetry's) relative to the light's largest, to rounding.
TEST(Precision, BinVisibilityTakesALightAsDarkBeyondItsTable) {
    const Observer obs = load_observer(kDir, "cie1931-2");
    const Spectrum a = load_illuminant(kDir, "A"), d65 = load_illuminant(kDir, "D65");
    std::vector<double> wide;
    for (double l = 380; l <= 830; l += 10) wide.push_back(l);
    const std::vector<double> vis_a = bin_visibility(obs, {a}, wide);
    ASSERT_EQ(vis_a.size(), wide.size());
    double top = 0;
    for (size_t k = 0; k < wide.size(); ++k) {
        top = std::max(top, vis_a[k]);
        if (wide[k] > a.lambda.back())
            EXPECT_EQ(vis_a[k], 0.0) << wide[k];
        else
            EXPECT_GT(vis_a[k], 0.0) << wide[k];
    }
    EXPECT_DOUBLE_EQ(top, 1.0);
    const std::vector<double> vis_both = bin_visibility(obs, {a, d65}, wide);
    EXPECT_GT(vis_both.back(), 0.0) << "D65's table reaches 830 nm";
    std::vector<double> inside;
    for (double l = 400; l <= 700; l += 10) inside.push_back(l);
    const Colorimetry c =
        Colorimetry::make(obs, d65, WavelengthGrid::from_list(inside), primaries_by_name("srgb"));
    const std::vector<double> vis = bin_visibility(obs, {d65}, inside);
    const double peak = c.W.cwiseAbs().maxCoeff();
    for (size_t k = 0; k < inside.size(); ++k)
        EXPECT_NEAR(vis[k], c.W.col(static_cast<Eigen::Index>(k)).cwiseAbs().maxCoeff() / peak,
                    1e-12)
            << inside[k];
}
