#pragma once
// Tabulated spectra (illuminants, observers) and their linear interpolation onto a grid.
#include <string>
#include <vector>

#include "spectral/wavelength_grid.h"

namespace spectex {

struct Spectrum {
    std::string name;
    std::vector<double> lambda;  // nm, strictly increasing
    std::vector<double> value;

    // Linear interpolation; throws when the grid leaves the table's range (no extrapolation).
    std::vector<double> sample(const WavelengthGrid& grid) const;
};

struct Observer {
    std::string name;            // "cie1931-2", "cie1964-10"
    Spectrum x, y, z;
};

// Loaders for the CSV formats of config/spectral/ ("wavelength,value" and "wavelength,x,y,z").
Spectrum load_illuminant_csv(const std::string& path, const std::string& name);
Observer load_observer_csv(const std::string& path, const std::string& name);

// Named data shipped in <data_dir>/spectral/: observers "cie1931-2", "cie1964-10"; illuminants
// "D65", "A", "FL11" (case-insensitive). A name that is an existing file is read as a CSV.
Observer load_observer(const std::string& data_dir, const std::string& name);
Spectrum load_illuminant(const std::string& data_dir, const std::string& name_or_file);
std::vector<std::string> shipped_observers();
std::vector<std::string> shipped_illuminants();

}  // namespace spectex
