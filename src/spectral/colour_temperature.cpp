#include "spectral/colour_temperature.h"

#include <cmath>
#include <vector>

#include "base/error.h"
#include "base/text.h"

namespace spectex {

namespace {

// CIE daylight components S0, S1, S2 on 300..830 nm every 5 nm: CIE 015:2018, table of the
// components of the daylight illuminants (the 5 nm values are the CIE's linear interpolation of its
// 10 nm ones), as transcribed by colour-science 0.4.7
// (DATA_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES).
constexpr double kDaylightStart = 300, kDaylightStep = 5;
// One wavelength a line, as the CIE tabulates them.
// clang-format off
constexpr double kDaylightComponents[][3] = {
    {0.04, 0.02, 0.0},  // 300 nm
    {3.02, 2.26, 1.0},  // 305 nm
    {6.0, 4.5, 2.0},  // 310 nm
    {17.8, 13.45, 3.0},  // 315 nm
    {29.6, 22.4, 4.0},  // 320 nm
    {42.45, 32.2, 6.25},  // 325 nm
    {55.3, 42.0, 8.5},  // 330 nm
    {56.3, 41.3, 8.15},  // 335 nm
    {57.3, 40.6, 7.8},  // 340 nm
    {59.55, 41.1, 7.25},  // 345 nm
    {61.8, 41.6, 6.7},  // 350 nm
    {61.65, 39.8, 6.0},  // 355 nm
    {61.5, 38.0, 5.3},  // 360 nm
    {65.15, 40.2, 5.7},  // 365 nm
    {68.8, 42.4, 6.1},  // 370 nm
    {66.1, 40.45, 4.55},  // 375 nm
    {63.4, 38.5, 3.0},  // 380 nm
    {64.6, 36.75, 2.1},  // 385 nm
    {65.8, 35.0, 1.2},  // 390 nm
    {80.3, 39.2, 0.05},  // 395 nm
    {94.8, 43.4, -1.1},  // 400 nm
    {99.8, 44.85, -0.8},  // 405 nm
    {104.8, 46.3, -0.5},  // 410 nm
    {105.35, 45.1, -0.6},  // 415 nm
    {105.9, 43.9, -0.7},  // 420 nm
    {101.35, 40.5, -0.95},  // 425 nm
    {96.8, 37.1, -1.2},  // 430 nm
    {105.35, 36.9, -1.9},  // 435 nm
    {113.9, 36.7, -2.6},  // 440 nm
    {119.75, 36.3, -2.75},  // 445 nm
    {125.6, 35.9, -2.9},  // 450 nm
    {125.55, 34.25, -2.85},  // 455 nm
    {125.5, 32.6, -2.8},  // 460 nm
    {123.4, 30.25, -2.7},  // 465 nm
    {121.3, 27.9, -2.6},  // 470 nm
    {121.3, 26.1, -2.6},  // 475 nm
    {121.3, 24.3, -2.6},  // 480 nm
    {117.4, 22.2, -2.2},  // 485 nm
    {113.5, 20.1, -1.8},  // 490 nm
    {113.3, 18.15, -1.65},  // 495 nm
    {113.1, 16.2, -1.5},  // 500 nm
    {111.95, 14.7, -1.4},  // 505 nm
    {110.8, 13.2, -1.3},  // 510 nm
    {108.65, 10.9, -1.25},  // 515 nm
    {106.5, 8.6, -1.2},  // 520 nm
    {107.65, 7.35, -1.1},  // 525 nm
    {108.8, 6.1, -1.0},  // 530 nm
    {107.05, 5.15, -0.75},  // 535 nm
    {105.3, 4.2, -0.5},  // 540 nm
    {104.85, 3.05, -0.4},  // 545 nm
    {104.4, 1.9, -0.3},  // 550 nm
    {102.2, 0.95, -0.15},  // 555 nm
    {100.0, 0.0, 0.0},  // 560 nm
    {98.0, -0.8, 0.1},  // 565 nm
    {96.0, -1.6, 0.2},  // 570 nm
    {95.55, -2.55, 0.35},  // 575 nm
    {95.1, -3.5, 0.5},  // 580 nm
    {92.1, -3.5, 1.3},  // 585 nm
    {89.1, -3.5, 2.1},  // 590 nm
    {89.8, -4.65, 2.65},  // 595 nm
    {90.5, -5.8, 3.2},  // 600 nm
    {90.4, -6.5, 3.65},  // 605 nm
    {90.3, -7.2, 4.1},  // 610 nm
    {89.35, -7.9, 4.4},  // 615 nm
    {88.4, -8.6, 4.7},  // 620 nm
    {86.2, -9.05, 4.9},  // 625 nm
    {84.0, -9.5, 5.1},  // 630 nm
    {84.55, -10.2, 5.9},  // 635 nm
    {85.1, -10.9, 6.7},  // 640 nm
    {83.5, -10.8, 7.0},  // 645 nm
    {81.9, -10.7, 7.3},  // 650 nm
    {82.25, -11.35, 7.95},  // 655 nm
    {82.6, -12.0, 8.6},  // 660 nm
    {83.75, -13.0, 9.2},  // 665 nm
    {84.9, -14.0, 9.8},  // 670 nm
    {83.1, -13.8, 10.0},  // 675 nm
    {81.3, -13.6, 10.2},  // 680 nm
    {76.6, -12.8, 9.25},  // 685 nm
    {71.9, -12.0, 8.3},  // 690 nm
    {73.1, -12.65, 8.95},  // 695 nm
    {74.3, -13.3, 9.6},  // 700 nm
    {75.35, -13.1, 9.05},  // 705 nm
    {76.4, -12.9, 8.5},  // 710 nm
    {69.85, -11.75, 7.75},  // 715 nm
    {63.3, -10.6, 7.0},  // 720 nm
    {67.5, -11.1, 7.3},  // 725 nm
    {71.7, -11.6, 7.6},  // 730 nm
    {74.35, -11.9, 7.8},  // 735 nm
    {77.0, -12.2, 8.0},  // 740 nm
    {71.1, -11.2, 7.35},  // 745 nm
    {65.2, -10.2, 6.7},  // 750 nm
    {56.45, -9.0, 5.95},  // 755 nm
    {47.7, -7.8, 5.2},  // 760 nm
    {58.15, -9.5, 6.3},  // 765 nm
    {68.6, -11.2, 7.4},  // 770 nm
    {66.8, -10.8, 7.1},  // 775 nm
    {65.0, -10.4, 6.8},  // 780 nm
    {65.5, -10.5, 6.9},  // 785 nm
    {66.0, -10.6, 7.0},  // 790 nm
    {63.5, -10.15, 6.7},  // 795 nm
    {61.0, -9.7, 6.4},  // 800 nm
    {57.15, -9.0, 5.95},  // 805 nm
    {53.3, -8.3, 5.5},  // 810 nm
    {56.1, -8.8, 5.8},  // 815 nm
    {58.9, -9.3, 6.1},  // 820 nm
    {60.4, -9.55, 6.3},  // 825 nm
    {61.9, -9.8, 6.5},  // 830 nm
};
// clang-format on

std::string range_text() {
    return std::to_string(kMinColourTemperature) + "K to " + std::to_string(kMaxColourTemperature) +
           "K";
}

}  // namespace

std::optional<int> colour_temperature_of(const std::string& name) {
    if (name.size() < 2 || (name.back() != 'K' && name.back() != 'k')) return std::nullopt;
    std::string number = name.substr(0, name.size() - 1);
    if (!number.empty() && number.back() == ' ') number.pop_back();
    // Written as a number: digits, perhaps a sign, a point or an exponent. Anything else ("FL2K",
    // "my/light_3200K") is a table name or a file.
    const char first = number.empty() ? 0 : number[0];
    if (!((first >= '0' && first <= '9') || first == '-' || first == '+' || first == '.') ||
        number.find_first_not_of("0123456789.+-eE") != std::string::npos)
        return std::nullopt;
    long long kelvin = 0;
    if (!parse_whole(number, kMinColourTemperature, kMaxColourTemperature, &kelvin) ||
        number[0] == '-')
        throw Error("'" + name +
                    "' is not a colour temperature spectex knows: a whole number of kelvin from " +
                    range_text() + " (Planckian radiator below " +
                    std::to_string(kDaylightFromTemperature) +
                    "K, CIE daylight from it), e.g. 3200K");
    return static_cast<int>(kelvin);
}

std::string colour_temperature_name(int kelvin) { return std::to_string(kelvin) + "K"; }

Spectrum planckian_radiator(double kelvin) {
    if (!(kelvin > 0) || !std::isfinite(kelvin))
        throw Error("a Planckian radiator needs a positive temperature");
    Spectrum s;
    s.name = "Planckian radiator";
    // M(λ) ∝ λ^-5 / (exp(c2 / λT) - 1), relative to its value at 560 nm.
    const double l0 = 560e-9;
    const double at560 = 1.0 / (std::pow(l0, 5) * std::expm1(kPlanckC2 / (l0 * kelvin)));
    for (int nm = 300; nm <= 830; ++nm) {
        const double l = nm * 1e-9;
        s.lambda.push_back(nm);
        s.value.push_back(100.0 / (std::pow(l, 5) * std::expm1(kPlanckC2 / (l * kelvin))) / at560);
    }
    return s;
}

Spectrum cie_daylight(double kelvin) {
    if (!(kelvin >= kDaylightFromTemperature && kelvin <= kMaxColourTemperature))
        throw Error("CIE daylight is defined from " + std::to_string(kDaylightFromTemperature) +
                    "K to " + std::to_string(kMaxColourTemperature) + "K");
    const double t = kelvin, t2 = t * t, t3 = t2 * t;
    const double x = t <= 7000 ? -4.6070e9 / t3 + 2.9678e6 / t2 + 0.09911e3 / t + 0.244063
                               : -2.0064e9 / t3 + 1.9018e6 / t2 + 0.24748e3 / t + 0.237040;
    const double y = -3.000 * x * x + 2.870 * x - 0.275;
    const double m = 0.0241 + 0.2562 * x - 0.7341 * y;
    const double m1 = std::round((-1.3515 - 1.7703 * x + 5.9114 * y) / m * 1000) / 1000;
    const double m2 = std::round((0.0300 - 31.4424 * x + 30.0717 * y) / m * 1000) / 1000;
    Spectrum s;
    s.name = "CIE daylight";
    size_t k = 0;
    for (const auto& c : kDaylightComponents) {
        s.lambda.push_back(kDaylightStart + kDaylightStep * static_cast<double>(k++));
        // At least 0.0099 (300 nm, 4000 K) over the whole range: never negative.
        s.value.push_back(c[0] + m1 * c[1] + m2 * c[2]);
    }
    return s;
}

Spectrum colour_temperature_light(int kelvin) {
    Spectrum s =
        kelvin < kDaylightFromTemperature ? planckian_radiator(kelvin) : cie_daylight(kelvin);
    s.name = colour_temperature_name(kelvin);
    return s;
}

}  // namespace spectex
