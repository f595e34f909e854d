#pragma once
// The lattice and Jakob-Hanika methods built on demand for a grid and observing conditions,
// cached per process so that a batch builds each once (the basis has basis_cache).
#include <cstdint>
#include <memory>
#include <string>

#include "pipeline/basis_cache.h"
#include "spectral/spectral_method.h"

namespace spectex {

struct MethodSpec {
    std::string method = "lattice";  // lattice | jakob-hanika
    FitSpec fit;  // grid, observer, illuminant, primaries, data dir (objective unused)
    int lattice_size = 9;
    std::string vertex_prior = "jakob-hanika";
    double blend = 100;  // vertex prior "blend": weight of the smoothness term
    int jh_resolution = 33;

    std::string describe()
        const;  // "lattice 9, jakob-hanika prior, srgb primaries, cie1931-2, D65, 380:780:5"
};

struct MethodResult {
    std::shared_ptr<const SpectralMethod> method;
    double build_seconds = 0;
};

// Throws Error (with the cause: a vertex with no exact bounded spectrum on this grid, ...), and
// LimitError when the table is over kMethodTableLimit. Thread-safe.
MethodResult make_method(const MethodSpec& spec);

// What building the method costs: the spectral samples its table holds and computes, n^3 x bins
// for the lattice (a spectrum per vertex, each a QP over the bins) and res^3 x bins for the
// Jakob-Hanika table (each node fitted by integrating its sigmoid over the bins); 0 for the basis.
uint64_t method_table_samples(const MethodSpec& spec, uint64_t bins);
// The most method_table_samples() may be: 2^27 (134,217,728; 512 MiB as float). The largest table
// the options allow on the finest grid a renderer reads (1 nm over 360:830, 471 bins) fits it:
// --lattice-size 65 (65^3 x 471 = 129 million) and --jh-resolution 64 (123 million). Measured:
// lattice 65 at 801 bins (380:780:0.5, 220 million) took 54 s and 3.58 GB for a 16x16 image;
// past the limit the grid is finer than 1 nm or the lattice larger than anything baked.
constexpr uint64_t kMethodTableLimit = uint64_t(1) << 27;
// Throws LimitError ("--lattice-size: ..." or "--jh-resolution: ...", with the figure and the
// limit) when method_table_samples(spec, bins) is over kMethodTableLimit; `what` says what the
// bins are ("801 bins", "3416 bins of the candidates and the reference").
void check_method_cost(const MethodSpec& spec, uint64_t bins, const std::string& what);

}  // namespace spectex
