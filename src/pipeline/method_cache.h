#pragma once
// The lattice and Jakob-Hanika methods built on demand for a grid and observing conditions,
// cached per process so that a batch builds each once (the basis has basis_cache).
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

// Throws Error (with the cause: a vertex with no exact bounded spectrum on this grid, ...).
// Thread-safe.
MethodResult make_method(const MethodSpec& spec);

}  // namespace spectex
