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
    // Linear interpolation at l; 0 outside the table (a light is dark where it has no values, as
    // plan and the renderer's colour take it).
    double at_or_dark(double l) const;
};

struct Observer {
    std::string name;  // "cie1931-2", "cie1964-10"
    Spectrum x, y, z;
};

// Loaders for the CSV formats of config/spectral/ ("wavelength,value" and "wavelength,x,y,z").
Spectrum load_illuminant_csv(const std::string& path, const std::string& name);
Observer load_observer_csv(const std::string& path, const std::string& name);
// Throws Error("<what> is singular on <where>: ...") when x, y and z (sampled alike) are linearly
// dependent: the one check of an observer, made by load_observer_csv on its table and by
// Colorimetry::make on a grid.
void check_observer_independent(const std::vector<double>& x, const std::vector<double>& y,
                                const std::vector<double>& z, const std::string& what,
                                const std::string& where);

// Named data shipped in <data_dir>/spectral/: observers "cie1931-2", "cie1964-10"; illuminants as
// listed by shipped_illuminants(), matched case-insensitively ("led-b3" is LED-B3; the Spectrum
// gets the shipped spelling); a colour temperature ("3200K", spectral/colour_temperature.h); else
// a name that is an existing file is read as a CSV.
Observer load_observer(const std::string& data_dir, const std::string& name);
Spectrum load_illuminant(const std::string& data_dir, const std::string& name_or_file);
std::vector<std::string> shipped_observers();
// The CIE illuminants of config/spectral/illuminant_<name>.csv (see config/spectral/README.md):
// D65, D50, D55, D75, A, FL1-FL12, LED-B1-B5, LED-BH1, LED-RGB1, LED-V1, LED-V2.
std::vector<std::string> shipped_illuminants();
// shipped_illuminants() as "D65, D50, ..., LED-V2", with " (default)" after default_name when it
// is one of them: the one list that help texts and error messages print.
std::string shipped_illuminants_list(const std::string& default_name = "");

}  // namespace spectex
