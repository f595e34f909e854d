// Fit time of the default basis problem on grids from 10 nm to 0.5 nm (one core). The issue's
// floor: 401 bins (1 nm) in under one second.
#include <benchmark/benchmark.h>

#include "spectral/basis_fit.h"

using namespace spectex;

static void BM_FitBasis(benchmark::State& state) {
    const double step = state.range(0) / 10.0;
    const bool smooth = state.range(1) != 0;
    WavelengthGrid g = WavelengthGrid::uniform_grid(380, 780, step);
    Observer o = load_observer(SPECTEX_TEST_DATA_DIR, "cie1931-2");
    Spectrum d65 = load_illuminant(SPECTEX_TEST_DATA_DIR, "D65");
    FitRequest req{Colorimetry::make(o, d65, g, primaries_by_name("srgb")),
                   smooth ? FitObjective::Smooth : FitObjective::Norm, false};
    int iterations = 0;
    for (auto _ : state) {
        FitResult r = fit_basis(req);
        iterations = r.certificate.iterations;
        benchmark::DoNotOptimize(r.basis.r.data());
    }
    state.counters["bins"] = static_cast<double>(g.size());
    state.counters["qp_iterations"] = iterations;
    state.counters["fraction_of_1s_floor"] = benchmark::Counter(
        1.0, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_FitBasis)->ArgsProduct({{100, 50, 10, 5}, {0, 1}})->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
