#include "pipeline/look.h"

#include "base/error.h"
#include "spectral/adaptation.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

std::string label_of(const std::string& name) {
    std::string base =
        name.substr(name.find_last_of('/') == std::string::npos ? 0 : name.find_last_of('/') + 1);
    if (base.size() > 4 && base.compare(base.size() - 4, 4, ".csv") == 0)
        base.resize(base.size() - 4);
    if (base.rfind("illuminant_", 0) == 0 && base.size() > 11) base = base.substr(11);
    return base.empty() ? name : base;
}

}  // namespace

Viewer Viewer::make(const std::string& data_dir, const std::string& observer,
                    const std::vector<double>& lambdas, const std::vector<std::string>& lights) {
    Viewer v;
    v.observer = observer;
    const WavelengthGrid grid = WavelengthGrid::from_list(lambdas);
    const Observer obs = load_observer(data_dir, observer);
    const RgbPrimaries srgb = primaries_by_name("srgb");
    v.d65 = Colorimetry::make(obs, load_illuminant(data_dir, "D65"), grid, srgb);
    for (const auto& name : lights) {
        LightView l;
        l.name = name;
        l.label = label_of(name);
        l.col = Colorimetry::make(obs, load_illuminant(data_dir, name), grid, srgb);
        l.adapt = bradford_adaptation(l.col.white_xyz, v.d65.white_xyz);
        l.rgb_adapted = v.d65.xyz_to_rgb * l.adapt * l.col.W;
        l.rgb_unadapted = v.d65.xyz_to_rgb * l.col.W;
        // Exactly verify's weights under D65 (same product, same order).
        if (l.col.white_xyz == v.d65.white_xyz) l.rgb_adapted = v.d65.rgb_weights();
        v.lights.push_back(std::move(l));
    }
    return v;
}

PixelColour colour_of(const Viewer& v, const LightView& light, const float* values, double alpha) {
    (void)v;
    PixelColour c;
    if (!(alpha > 0)) {
        c.defined = false;
        return c;
    }
    // Integrate bin by bin in wavelength order, then divide by A: exactly as verify does.
    const Eigen::Index n = light.col.W.cols();
    double xyz[3] = {0, 0, 0}, rgb[3] = {0, 0, 0}, raw[3] = {0, 0, 0};
    for (Eigen::Index k = 0; k < n; ++k) {
        const double d = static_cast<double>(values[k]);
        for (int i = 0; i < 3; ++i) {
            xyz[i] += light.col.W(i, k) * d;
            rgb[i] += light.rgb_adapted(i, k) * d;
            raw[i] += light.rgb_unadapted(i, k) * d;
        }
    }
    for (int i = 0; i < 3; ++i) {
        c.xyz(i) = xyz[i] / alpha;
        c.rgb(i) = rgb[i] / alpha;
        c.rgb_unadapted(i) = raw[i] / alpha;
    }
    c.lab = lab_from_xyz(c.xyz, light.col.white_xyz);
    for (int i = 0; i < 3; ++i) {
        c.srgb[i] = srgb8(c.rgb(i));
        c.srgb_unadapted[i] = srgb8(c.rgb_unadapted(i));
    }
    return c;
}

}  // namespace spectex
