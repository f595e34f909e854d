#pragma once
// Bases fitted on demand for a grid and observing conditions, cached per process so that a batch
// fits once per distinct setting.
#include <memory>
#include <string>

#include "spectral/basis_fit.h"
#include "spectral/spectrum.h"
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
    // The observer's and illuminant's tables when the caller has read them already (a bake's set-up
    // reads each once, pipeline/bake_request); null: read here by name from data_dir. Not part of
    // what identifies the build (the names are).
    std::shared_ptr<const Observer> observer_table;
    std::shared_ptr<const Spectrum> illuminant_table;

    // "srgb primaries, cie1931-2, D65, 380:780:5, smooth"
    std::string describe() const;
};

// The observer and illuminant of `spec`: its tables when given, else read by name.
Observer fit_observer(const FitSpec& spec);
Spectrum fit_illuminant(const FitSpec& spec);

// Loads the tables, builds the colorimetry and fits (or returns the cached fit). Thread-safe.
FitResult fit_basis_for(const FitSpec& spec);

}  // namespace spectex
