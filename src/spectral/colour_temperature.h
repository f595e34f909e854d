#pragma once
// Lights given by their colour temperature ("3200K"), as CIE 015:2018 defines them: a Planckian
// (black-body) radiator below 4000 K, CIE daylight (S0 + M1·S1 + M2·S2) from 4000 K to 25000 K.
// Relative spectral power, 100 at 560 nm like the shipped CIE tables (spectex normalises every
// light itself, so only the shape matters).
#include <optional>
#include <string>

#include "spectral/spectrum.h"

namespace spectex {

// The range a colour temperature may take, in kelvin. Daylight's chromaticity formulas are
// defined from 4000 K to 25000 K; below 4000 K the light is a Planckian radiator, down to
// 1000 K (a candle flame is about 1900 K; below 1000 K almost no visible light is left).
constexpr int kMinColourTemperature = 1000;
constexpr int kDaylightFromTemperature = 4000;
constexpr int kMaxColourTemperature = 25000;

// The second radiation constant c2 of CIE 015:2018 (and of ITS-90), in m·K.
constexpr double kPlanckC2 = 1.4388e-2;

// Whether `name` is a colour temperature: whole kelvin followed by K or k, with at most one space
// between ("3200K", "3200k", "3200 K"). Returns the kelvin, or nothing when the name is not written
// as one (it is then a table name or a file). Throws Error when it is written as one but is not a
// whole number within kMinColourTemperature..kMaxColourTemperature ("6500.5K", "500K", "-3K").
std::optional<int> colour_temperature_of(const std::string& name);

// The canonical name of a temperature ("3200K"), as headers and reports record it.
std::string colour_temperature_name(int kelvin);

// Planck's law, relative to 560 nm (= 100), on 300..830 nm every 1 nm.
Spectrum planckian_radiator(double kelvin);

// CIE daylight at a correlated colour temperature from 4000 to 25000 K (throws Error outside):
// x_D by CIE 015:2018's formula for 4000-7000 K or for 7000-25000 K, y_D = -3 x_D² + 2.87 x_D -
// 0.275, M1 and M2 rounded to three decimals as the CIE recommends (its D tables were computed so),
// S0, S1, S2 tabulated on 300..830 nm every 5 nm (S1 and S2 are 0 at 560 nm, S0 is 100).
Spectrum cie_daylight(double kelvin);

// The light of a temperature: planckian_radiator below kDaylightFromTemperature, cie_daylight from
// it; named colour_temperature_name(kelvin).
Spectrum colour_temperature_light(int kelvin);

}  // namespace spectex
