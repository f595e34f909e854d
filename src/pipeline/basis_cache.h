#pragma once
// Bases fitted on demand for a grid and observing conditions, cached per process so that a batch
// fits once per distinct setting.
#include <string>

#include "spectral/basis_fit.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

struct FitSpec {
    std::string data_dir;
    WavelengthGrid grid = WavelengthGrid::parse("380:780:5");
    std::string observer = "cie1931-2";
    std::string illuminant = "D65";
    std::string primaries = "srgb";
    FitObjective objective = FitObjective::Smooth;  // parsed where the option is read
    bool allow_infeasible = false;

    // "srgb primaries, cie1931-2, D65, 380:780:5, smooth"
    std::string describe() const;
};

// Loads the tables, builds the colorimetry and fits (or returns the cached fit). Thread-safe.
FitResult fit_basis_for(const FitSpec& spec);

}  // namespace spectex
