#pragma once
// How spectra look under lights: the one colorimetry path of `sample`, `render` and `plot`.
//
// Under a light L, with observer O, on the file's own bins: XYZ = W_L · S, where the perfect
// reflector has Y = 1 (Colorimetry). L*a*b* is relative to L's white W_L · 1. The displayed colour
// is linear Rec.709 through D65's white-consistent matrix (the matrix verify uses) after a Bradford
// adaptation of L's white to D65's (both integrated on the same bins), so the perfect reflector is
// RGB (1,1,1) under every light; under D65 the adaptation is the identity and the colour is
// exactly verify's. Unadapted, XYZ relative to L goes through the same D65 matrix (the colour
// cast).
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "spectral/ciede2000.h"
#include "spectral/colorimetry.h"

namespace spectex {

struct LightView {
    std::string name;                // as asked ("A", "D65", a CSV path)
    std::string label;               // for display: the name, or a CSV's base name without ".csv"
    Colorimetry col;                 // under this light
    Eigen::Matrix3d adapt;           // Bradford, this light's white -> D65's
    Eigen::Matrix3Xd rgb_adapted;    // 3 x bins: linear Rec.709 of a reflectance, white-balanced
    Eigen::Matrix3Xd rgb_unadapted;  // 3 x bins: linear Rec.709, no adaptation
};

struct Viewer {
    std::string observer;
    Colorimetry d65;
    std::vector<LightView> lights;

    // Throws Error for unknown lights/observers and for bins outside their tables.
    static Viewer make(const std::string& data_dir, const std::string& observer,
                       const std::vector<double>& lambdas, const std::vector<std::string>& lights);
};

struct PixelColour {
    bool defined = true;           // false for premultiplied pixels with A <= 0
    Eigen::Vector3d xyz{0, 0, 0};  // relative to the light (perfect reflector Y = 1)
    Lab lab;                       // relative to the light's white
    Eigen::Vector3d rgb{0, 0, 0};  // linear Rec.709, adapted to D65 (not clipped)
    Eigen::Vector3d rgb_unadapted{0, 0, 0};
    int srgb[3] = {0, 0, 0};  // 8-bit sRGB codes of rgb (clipped)
    int srgb_unadapted[3] = {0, 0, 0};
};

// The colour of `values` (one per bin) under `light`; with associated alpha the colour is of
// values / alpha (undefined when alpha <= 0); pass alpha = 1 otherwise.
PixelColour colour_of(const Viewer& v, const LightView& light, const float* values, double alpha);

}  // namespace spectex
