#include "spectral/colorimetry.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "base/error.h"
#include "base/text.h"

namespace spectex {

namespace {
constexpr Chromaticity kD65{0.3127, 0.3290};

}  // namespace

RgbPrimaries primaries_by_name(const std::string& name) {
    std::string n = lower_ascii(name);
    if (n == "srgb" || n == "rec709" || n == "bt709")
        return {"srgb", {0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}, kD65};
    if (n == "p3" || n == "display-p3" || n == "p3-d65")
        return {"p3", {0.680, 0.320}, {0.265, 0.690}, {0.150, 0.060}, kD65};
    if (n == "rec2020" || n == "bt2020")
        return {"rec2020", {0.708, 0.292}, {0.170, 0.797}, {0.131, 0.046}, kD65};
    // "xr,yr,xg,yg,xb,yb"
    std::vector<double> v;
    const char* s = name.c_str();
    while (*s) {
        char* end = nullptr;
        double d = std::strtod(s, &end);
        if (end == s || !std::isfinite(d)) {
            v.clear();
            break;
        }
        v.push_back(d);
        s = end;
        if (*s == ',')
            ++s;
        else if (*s) {
            v.clear();
            break;
        }
    }
    if (v.size() != 6)
        throw Error("unknown primaries '" + name +
                    "' (known: srgb, rec709, p3, rec2020, or xr,yr,xg,yg,xb,yb)");
    for (int i = 0; i < 6; i += 2)
        if (!(v[i] > 0 && v[i + 1] > 0 && v[i] + v[i + 1] <= 1))
            throw Error("primaries '" + name +
                        "': chromaticities must satisfy x, y > 0 and x + y <= 1");
    return {name, {v[0], v[1]}, {v[2], v[3]}, {v[4], v[5]}, kD65};
}

Eigen::Vector3d xyz_from_chromaticity(Chromaticity c, double Y) {
    return Eigen::Vector3d(c.x / c.y * Y, Y, (1.0 - c.x - c.y) / c.y * Y);
}

Eigen::Matrix3d rgb_to_xyz_matrix(const RgbPrimaries& p, const Eigen::Vector3d& white_xyz) {
    Eigen::Matrix3d P;
    P.col(0) = xyz_from_chromaticity(p.r);
    P.col(1) = xyz_from_chromaticity(p.g);
    P.col(2) = xyz_from_chromaticity(p.b);
    Eigen::FullPivLU<Eigen::Matrix3d> lu(P);
    if (!lu.isInvertible()) throw Error("primaries '" + p.name + "' are collinear");
    Eigen::Vector3d s = lu.solve(white_xyz);
    return P * s.asDiagonal();
}

Colorimetry Colorimetry::make(const Observer& obs, const Spectrum& illuminant,
                              const WavelengthGrid& grid, const RgbPrimaries& primaries) {
    Colorimetry c;
    c.grid = grid;
    const size_t n = grid.size();
    std::vector<double> e = illuminant.sample(grid), x = obs.x.sample(grid), y = obs.y.sample(grid),
                        z = obs.z.sample(grid);
    // User tables: a spectral power or a colour-matching value is finite and not negative.
    auto check = [&](const std::vector<double>& v, const std::string& what) {
        for (size_t k = 0; k < n; ++k)
            if (!std::isfinite(v[k]) || v[k] < 0 || v[k] > 1e12) {
                char buf[160];
                std::snprintf(buf, sizeof buf,
                              " has the value %.9g at %s nm: values must be finite, not negative "
                              "and below 1e12",
                              v[k], format_wavelength(grid.lambda[k]).c_str());
                throw Error(what + buf);
            }
    };
    check(e, "illuminant " + illuminant.name);
    check(x, "observer " + obs.name + " (x)");
    check(y, "observer " + obs.name + " (y)");
    check(z, "observer " + obs.name + " (z)");
    c.W.resize(3, static_cast<Eigen::Index>(n));
    double norm = 0;
    for (size_t k = 0; k < n; ++k) norm += e[k] * y[k] * grid.weight[k];
    if (!(norm > 0))
        throw Error("illuminant " + illuminant.name + " times the observer's y is zero on " +
                    grid.describe());
    for (size_t k = 0; k < n; ++k) {
        double w = e[k] * grid.weight[k] / norm;
        c.W(0, k) = w * x[k];
        c.W(1, k) = w * y[k];
        c.W(2, k) = w * z[k];
    }
    check_observer_independent(x, y, z, "observer " + obs.name, grid.describe());
    c.white_xyz = c.W.rowwise().sum();
    if (!(c.white_xyz.minCoeff() > 0))
        throw Error("illuminant white has a non-positive XYZ component");
    c.rgb_to_xyz = rgb_to_xyz_matrix(primaries, c.white_xyz);
    c.xyz_to_rgb = c.rgb_to_xyz.inverse();
    c.nominal_xyz_to_rgb =
        rgb_to_xyz_matrix(primaries, xyz_from_chromaticity(primaries.white)).inverse();
    return c;
}

}  // namespace spectex
