#include "pipeline/method_cache.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>

#include "base/error.h"
#include "spectral/colorimetry.h"
#include "spectral/spectrum.h"
#include "spectral/upsampling_methods.h"

namespace spectex {

namespace {

// The conditions a method is exact for (the basis fit's objective is not one of them).
std::string conditions(const FitSpec& f) {
    return f.primaries + " primaries, " + f.observer + ", " + f.illuminant + ", " +
           f.grid.describe();
}

}  // namespace

std::string MethodSpec::describe() const {
    if (method == "lattice") {
        char w[32];
        std::snprintf(w, sizeof w, "%g", blend);
        return "lattice " + std::to_string(lattice_size) + ", " + vertex_prior + " prior" +
               (vertex_prior == "blend" ? std::string(" (weight ") + w + ")" : std::string()) +
               ", " + conditions(fit);
    }
    if (method == "jakob-hanika")
        return "jakob-hanika table " + std::to_string(jh_resolution) + ", " + conditions(fit);
    return method + ", " + conditions(fit);
}

MethodResult make_method(const MethodSpec& spec) {
    static std::mutex mutex;
    check_method_cost(spec, spec.fit.grid.size(), std::to_string(spec.fit.grid.size()) + " bins");
    static std::map<std::string, MethodResult> cache;
    std::string key = spec.describe() + "|" + spec.fit.data_dir;
    for (double l : spec.fit.grid.lambda) key += "|" + format_wavelength(l);
    std::lock_guard<std::mutex> lock(mutex);
    if (auto it = cache.find(key); it != cache.end()) return it->second;
    const auto t0 = std::chrono::steady_clock::now();
    Colorimetry c = Colorimetry::make(load_observer(spec.fit.data_dir, spec.fit.observer),
                                      load_illuminant(spec.fit.data_dir, spec.fit.illuminant),
                                      spec.fit.grid, primaries_by_name(spec.fit.primaries));
    MethodResult r;
    if (spec.method == "lattice") {
        SpectralLattice lattice = SpectralLattice::build(
            c, spec.lattice_size, parse_vertex_prior(spec.vertex_prior), spec.blend);
        r.method = std::make_shared<LatticeMethod>(std::move(lattice), spec.fit.grid.lambda,
                                                   conditions(spec.fit), spec.blend);
    } else if (spec.method == "jakob-hanika") {
        r.method =
            std::make_shared<JakobHanikaMethod>(JakobHanikaTable::build(c, spec.jh_resolution),
                                                spec.fit.grid.lambda, conditions(spec.fit));
    } else {
        throw Error("unknown method '" + spec.method + "' (basis, lattice, jakob-hanika)");
    }
    r.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    cache.emplace(key, r);
    return r;
}

uint64_t method_table_samples(const MethodSpec& spec, uint64_t bins) {
    uint64_t n = 0;
    if (spec.method == "lattice")
        n = static_cast<uint64_t>(std::max(0, spec.lattice_size));
    else if (spec.method == "jakob-hanika")
        n = static_cast<uint64_t>(std::max(0, spec.jh_resolution));
    return n * n * n * bins;
}

void check_method_cost(const MethodSpec& spec, uint64_t bins, const std::string& what) {
    const uint64_t samples = method_table_samples(spec, bins);
    if (samples <= kMethodTableLimit) return;
    const bool lattice = spec.method == "lattice";
    const int n = lattice ? spec.lattice_size : spec.jh_resolution;
    throw LimitError(std::string(lattice ? "--lattice-size: " : "--jh-resolution: ") +
                     std::to_string(n) + "^3 " + (lattice ? "vertices" : "table nodes") + " x " +
                     what + " = " + std::to_string(samples) +
                     " spectral samples to build, over the limit of " +
                     std::to_string(kMethodTableLimit) +
                     " (2^27, which holds the largest table on a 1 nm grid over 360:830); use a "
                     "smaller " +
                     (lattice ? "--lattice-size" : "--jh-resolution") + " or fewer bins");
}

}  // namespace spectex
