// The expansion kernel (spectrum = r·S_r + g·S_g + b·S_b per pixel, src/spectral/expand.h) on
// 65536-pixel strips, one thread: pixels per second per core (items_per_second), at 81 bins (the
// published mallett2019 table) and 401 bins (a basis fitted on 380:780:1), to half and to float.
//
// Every iteration also runs a naive scalar loop written here (pixel-major, one bin at a time,
// the way a first version would be written), timed separately with the same clock, so that
// `speedup_vs_naive` (naive time / kernel time) is measured interleaved in the same run and is
// not skewed by other load on a shared machine. The reported time is the kernel's alone.
//
// BM_ExpandColour times the colour-aware rounding (ExpansionMatrix::rgb_weight set, as every
// default bake) on random 8-bit sRGB codes decoded to linear, so that its fix-up runs as often as
// on real images; plain rounding of the same pixels with the same basis is timed in every
// iteration too, and `colour_cost_vs_plain` is the ratio of the two times.
//
//   ninja -C build bench_expand && build/tests/bench/bench_expand
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "base/half.h"
#include "spectral/basis.h"
#include "spectral/basis_fit.h"
#include "spectral/colorimetry.h"
#include "spectral/expand.h"
#include "spectral/jakob_hanika.h"
#include "spectral/lattice.h"

using namespace spectex;

namespace {

constexpr size_t kPixels = 65536;

const Basis& basis_for(int bins) {
    static const Basis b81 = load_basis(SPECTEX_TEST_DATA_DIR, "mallett2019");
    static const Basis b401 = [] {
        WavelengthGrid g = WavelengthGrid::uniform_grid(380, 780, 1);
        Observer o = load_observer(SPECTEX_TEST_DATA_DIR, "cie1931-2");
        Spectrum d65 = load_illuminant(SPECTEX_TEST_DATA_DIR, "D65");
        FitRequest req{Colorimetry::make(o, d65, g, primaries_by_name("srgb")),
                       FitObjective::Smooth, false};
        return fit_basis(req).basis;
    }();
    return bins == 401 ? b401 : b81;
}

// Linear RGB planes of a smooth, varied pattern in [0, 1] (no denormals, no constant runs).
struct Planes {
    std::vector<float> r, g, b;
    Planes() : r(kPixels), g(kPixels), b(kPixels) {
        uint32_t s = 12345;
        for (size_t i = 0; i < kPixels; ++i) {
            s = s * 1664525u + 1013904223u;
            r[i] = static_cast<float>((s >> 8) & 0xffff) / 65535.0f;
            g[i] = static_cast<float>((s >> 4) & 0xffff) / 65535.0f;
            b[i] = static_cast<float>((i * 2654435761u >> 16) & 0xffff) / 65535.0f;
        }
    }
};
const Planes& planes() {
    static const Planes p;
    return p;
}

// The naive reference: pixel-major, doubles from the Basis, one scalar conversion per sample.
template <typename T>
void naive(const Basis& B, const float* r, const float* g, const float* b, size_t n, T* out,
           size_t stride) {
    const size_t bins = B.size();
    for (size_t i = 0; i < n; ++i)
        for (size_t k = 0; k < bins; ++k) {
            const float v = static_cast<float>(B.r[k] * r[i] + B.g[k] * g[i] + B.b[k] * b[i]);
            if constexpr (sizeof(T) == 2)
                out[k * stride + i] = float_to_half(v);
            else
                out[k * stride + i] = v;
        }
}

template <typename T>
void BM_Expand(benchmark::State& state) {
    const int bins = static_cast<int>(state.range(0));
    const Basis& B = basis_for(bins);
    const ExpansionMatrix m = ExpansionMatrix::from_basis(B);
    const Planes& p = planes();
    std::vector<T> out(kPixels * static_cast<size_t>(bins)), ref(out.size());
    using clock = std::chrono::steady_clock;
    double kernel_s = 0, naive_s = 0;
    for (auto _ : state) {
        auto t0 = clock::now();
        if constexpr (sizeof(T) == 2)
            expand_to_half(m, p.r.data(), p.g.data(), p.b.data(), kPixels, out.data(), kPixels);
        else
            expand_to_float(m, p.r.data(), p.g.data(), p.b.data(), kPixels, out.data(), kPixels);
        benchmark::ClobberMemory();
        auto t1 = clock::now();
        naive(B, p.r.data(), p.g.data(), p.b.data(), kPixels, ref.data(), kPixels);
        benchmark::ClobberMemory();
        auto t2 = clock::now();
        const double k = std::chrono::duration<double>(t1 - t0).count();
        kernel_s += k;
        naive_s += std::chrono::duration<double>(t2 - t1).count();
        state.SetIterationTime(k);
    }
    // Agreement with the naive loop (float vs double accumulation: rounding-level differences).
    double max_diff = 0;
    for (size_t i = 0; i < out.size(); ++i) {
        if constexpr (sizeof(T) == 2)
            max_diff = std::max(max_diff, static_cast<double>(std::fabs(half_to_float(out[i]) -
                                                                        half_to_float(ref[i]))));
        else
            max_diff = std::max(max_diff, static_cast<double>(std::fabs(out[i] - ref[i])));
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) *
                            static_cast<int64_t>(kPixels));
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                            static_cast<int64_t>(kPixels) * bins * static_cast<int64_t>(sizeof(T)));
    state.counters["bins"] = bins;
    state.counters["speedup_vs_naive"] = kernel_s > 0 ? naive_s / kernel_s : 0;
    state.counters["naive_pixels_per_second"] =
        naive_s > 0 ? static_cast<double>(state.iterations()) * kPixels / naive_s : 0;
    state.counters["max_abs_diff_vs_naive"] = max_diff;
    state.SetLabel(sizeof(T) == 2 ? "half" : "float");
}

// The basis and colorimetry of a default bake: the shipped smooth fit on 380:780:5, or the fit on
// 380:780:1; rgb_weight as src/pipeline/bake.cpp fills it (cie1931-2, D65, sRGB).
ExpansionMatrix colour_matrix(int bins) {
    const double step = bins == 401 ? 1 : 5;
    const Basis B = bins == 401 ? basis_for(401)
                                : load_basis(SPECTEX_TEST_DATA_DIR,
                                             std::string(SPECTEX_TEST_DATA_DIR) +
                                                 "/spectral/basis_fit_smooth_380-780-5.csv");
    ExpansionMatrix m = ExpansionMatrix::from_basis(B);
    const Colorimetry c =
        Colorimetry::make(load_observer(SPECTEX_TEST_DATA_DIR, "cie1931-2"),
                          load_illuminant(SPECTEX_TEST_DATA_DIR, "D65"),
                          WavelengthGrid::uniform_grid(380, 780, step), primaries_by_name("srgb"));
    const Eigen::Matrix3Xd R = c.rgb_weights();
    m.rgb_weight.resize(3 * static_cast<size_t>(m.bins));
    for (int k = 0; k < m.bins; ++k)
        for (int ch = 0; ch < 3; ++ch)
            m.rgb_weight[3 * static_cast<size_t>(k) + ch] = static_cast<float>(R(ch, k));
    return m;
}

// Random 8-bit sRGB codes, decoded to linear: what a bake of an 8-bit texture expands.
struct SrgbPlanes {
    std::vector<float> r, g, b;
    SrgbPlanes() : r(kPixels), g(kPixels), b(kPixels) {
        float lut[256];
        for (int c = 0; c < 256; ++c) {
            const double v = c / 255.0;
            lut[c] =
                static_cast<float>(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
        }
        uint32_t s = 2024;
        for (size_t i = 0; i < kPixels; ++i) {
            s = s * 1664525u + 1013904223u;
            r[i] = lut[(s >> 24) & 0xff];
            g[i] = lut[(s >> 16) & 0xff];
            b[i] = lut[(s >> 8) & 0xff];
        }
    }
};

void BM_ExpandColour(benchmark::State& state) {
    const int bins = static_cast<int>(state.range(0));
    const ExpansionMatrix m = colour_matrix(bins);
    ExpansionMatrix plain = m;
    plain.rgb_weight.clear();
    static const SrgbPlanes p;
    std::vector<uint16_t> out(kPixels * static_cast<size_t>(bins)), ref(out.size());
    using clock = std::chrono::steady_clock;
    double colour_s = 0, plain_s = 0;
    for (auto _ : state) {
        auto t0 = clock::now();
        expand_to_half(m, p.r.data(), p.g.data(), p.b.data(), kPixels, out.data(), kPixels);
        benchmark::ClobberMemory();
        auto t1 = clock::now();
        expand_to_half(plain, p.r.data(), p.g.data(), p.b.data(), kPixels, ref.data(), kPixels);
        benchmark::ClobberMemory();
        auto t2 = clock::now();
        const double c = std::chrono::duration<double>(t1 - t0).count();
        colour_s += c;
        plain_s += std::chrono::duration<double>(t2 - t1).count();
        state.SetIterationTime(c);
    }
    // How much work the fix-up had: pixels and samples that differ from plain rounding.
    std::vector<bool> pixel_changed(kPixels);
    size_t samples_changed = 0;
    for (size_t i = 0; i < out.size(); ++i)
        if (out[i] != ref[i]) ++samples_changed, pixel_changed[i % kPixels] = true;
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) *
                            static_cast<int64_t>(kPixels));
    state.counters["bins"] = bins;
    state.counters["plain_pixels_per_second"] =
        plain_s > 0 ? static_cast<double>(state.iterations()) * kPixels / plain_s : 0;
    state.counters["colour_cost_vs_plain"] = plain_s > 0 ? colour_s / plain_s : 0;
    state.counters["pixels_changed"] =
        static_cast<double>(std::count(pixel_changed.begin(), pixel_changed.end(), true)) / kPixels;
    state.counters["samples_changed"] =
        static_cast<double>(samples_changed) / static_cast<double>(out.size());
    state.SetLabel("half, colour rounding");
}

// The colorimetry of a default bake on 380:780:5 (81 bins) or 380:780:1 (401 bins).
const Colorimetry& colorimetry_for(int bins) {
    static const auto make = [](double step) {
        return Colorimetry::make(load_observer(SPECTEX_TEST_DATA_DIR, "cie1931-2"),
                                 load_illuminant(SPECTEX_TEST_DATA_DIR, "D65"),
                                 WavelengthGrid::uniform_grid(380, 780, step),
                                 primaries_by_name("srgb"));
    };
    static const Colorimetry c81 = make(5), c401 = make(1);
    return bins == 401 ? c401 : c81;
}

// Times `expand(r, g, b, n, out, stride)` of a method on the planes of BM_Expand, with
// expand_to_float of the basis of the same bin count timed in every iteration too (so that load
// on the machine falls on both): `ratio_vs_basis` = method time / basis time.
template <class Expand>
void expand_against_basis(benchmark::State& state, int bins, const Expand& expand,
                          const char* label) {
    const ExpansionMatrix m = ExpansionMatrix::from_basis(basis_for(bins));
    const Planes& p = planes();
    std::vector<float> out(kPixels * static_cast<size_t>(bins)), ref(out.size());
    using clock = std::chrono::steady_clock;
    double method_s = 0, basis_s = 0;
    for (auto _ : state) {
        auto t0 = clock::now();
        expand(p.r.data(), p.g.data(), p.b.data(), kPixels, out.data(), kPixels);
        benchmark::ClobberMemory();
        auto t1 = clock::now();
        expand_to_float(m, p.r.data(), p.g.data(), p.b.data(), kPixels, ref.data(), kPixels);
        benchmark::ClobberMemory();
        auto t2 = clock::now();
        const double k = std::chrono::duration<double>(t1 - t0).count();
        method_s += k;
        basis_s += std::chrono::duration<double>(t2 - t1).count();
        state.SetIterationTime(k);
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) *
                            static_cast<int64_t>(kPixels));
    state.counters["bins"] = bins;
    state.counters["ratio_vs_basis"] = basis_s > 0 ? method_s / basis_s : 0;
    state.counters["basis_pixels_per_second"] =
        basis_s > 0 ? static_cast<double>(state.iterations()) * kPixels / basis_s : 0;
    state.SetLabel(label);
}

// BM_ExpandLattice: SpectralLattice::expand (n breakpoints, smooth prior; the prior does not change
// the kernel's cost).
void BM_ExpandLattice(benchmark::State& state) {
    const int bins = static_cast<int>(state.range(0)), n = static_cast<int>(state.range(1));
    const SpectralLattice L = SpectralLattice::build(colorimetry_for(bins), n, VertexPrior::Smooth);
    state.counters["n"] = n;
    expand_against_basis(
        state, bins,
        [&](const float* r, const float* g, const float* b, size_t k, float* out, size_t stride) {
            L.expand(r, g, b, k, out, stride);
        },
        "float, lattice");
}

// BM_ExpandJakobHanika: the sigmoid table's expand (res 33).
void BM_ExpandJakobHanika(benchmark::State& state) {
    const int bins = static_cast<int>(state.range(0));
    const JakobHanikaTable t = JakobHanikaTable::build(colorimetry_for(bins), 33);
    expand_against_basis(
        state, bins,
        [&](const float* r, const float* g, const float* b, size_t k, float* out, size_t stride) {
            t.expand(r, g, b, k, out, stride);
        },
        "float, jakob-hanika table");
}

// Build times (one build per run; single thread): lattice at n breakpoints with each prior, and
// the Jakob-Hanika table at res 33.
void BM_BuildLattice(benchmark::State& state) {
    const int bins = static_cast<int>(state.range(0)), n = static_cast<int>(state.range(1));
    const VertexPrior prior = static_cast<VertexPrior>(state.range(2));
    for (auto _ : state) {
        const SpectralLattice L = SpectralLattice::build(colorimetry_for(bins), n, prior);
        state.SetIterationTime(L.build_seconds);
        state.counters["max_colour_residual"] = L.max_colour_residual;
        state.counters["fallback_vertices"] = L.fallback_vertices;
        state.counters["iterations_per_vertex"] =
            static_cast<double>(L.solver_iterations) / (static_cast<double>(n) * n * n);
    }
    state.counters["bins"] = bins;
    state.counters["n"] = n;
    state.SetLabel(to_string(prior));
}

void BM_BuildJakobHanikaTable(benchmark::State& state) {
    const int bins = static_cast<int>(state.range(0)), res = static_cast<int>(state.range(1));
    for (auto _ : state) {
        const JakobHanikaTable t = JakobHanikaTable::build(colorimetry_for(bins), res);
        state.SetIterationTime(t.build_seconds);
        state.counters["max_rgb_residual"] = t.max_rgb_residual;
        state.counters["max_lab_residual"] = t.max_lab_residual;
    }
    state.counters["bins"] = bins;
    state.counters["res"] = res;
}

}  // namespace

BENCHMARK(BM_ExpandLattice)
    ->Args({81, 9})
    ->Args({81, 17})
    ->Args({401, 17})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ExpandJakobHanika)->Arg(81)->Arg(401)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_BuildLattice)
    ->ArgsProduct({{81, 401}, {9, 17}, {0, 1, 2}})
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BuildJakobHanikaTable)
    ->ArgsProduct({{81, 401}, {17, 33, 64}})
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Expand, uint16_t)
    ->Arg(81)
    ->Arg(401)
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Expand, float)
    ->Arg(81)
    ->Arg(401)
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ExpandColour)->Arg(81)->Arg(401)->UseManualTime()->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
