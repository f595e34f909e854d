#pragma once
// Colorimetry on a wavelength grid: spectrum -> XYZ -> RGB, with the RGB<->XYZ matrix derived from
// the primaries and from the white of the illuminant integrated on the same grid, so that the
// perfect reflector maps exactly to RGB (1,1,1).
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

struct Chromaticity {
    double x = 0, y = 0;
};

struct RgbPrimaries {
    std::string name;
    Chromaticity r, g, b;
    Chromaticity white;  // nominal white of the colour space (for the nominal matrix only)
};

// "srgb" / "rec709", "p3" (Display P3, D65), "rec2020", or "xr,yr,xg,yg,xb,yb" (D65 nominal white).
RgbPrimaries primaries_by_name(const std::string& name);

// RGB->XYZ whose columns are the primaries' XYZ scaled so that RGB (1,1,1) maps to white_xyz.
Eigen::Matrix3d rgb_to_xyz_matrix(const RgbPrimaries& p, const Eigen::Vector3d& white_xyz);
Eigen::Vector3d xyz_from_chromaticity(Chromaticity c, double Y = 1.0);

struct Colorimetry {
    WavelengthGrid grid;
    Eigen::Matrix3Xd W;  // 3×N: XYZ of a reflectance S is W·S; the perfect reflector has Y = 1
    Eigen::Vector3d white_xyz;   // W·1
    Eigen::Matrix3d rgb_to_xyz;  // white-consistent
    Eigen::Matrix3d xyz_to_rgb;
    Eigen::Matrix3d nominal_xyz_to_rgb;  // from the colour space's nominal white, for reporting

    static Colorimetry make(const Observer& obs, const Spectrum& illuminant,
                            const WavelengthGrid& grid, const RgbPrimaries& primaries);
    // 3×N: linear RGB of a reflectance S is rgb_weights()·S.
    Eigen::Matrix3Xd rgb_weights() const { return xyz_to_rgb * W; }
};

}  // namespace spectex
