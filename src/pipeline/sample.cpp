#include "pipeline/sample.h"

#include "base/error.h"

namespace spectex {

SampleReport sample_pixels(const std::string& exr_path, const std::vector<std::pair<int, int>>& xy,
                           const SampleSettings& s) {
    SpectralReader reader(exr_path);
    SampleReport r;
    r.file = exr_path;
    r.wavelengths = reader.wavelengths();
    r.alpha = reader.alpha();
    r.observer = s.observer;
    std::vector<std::string> lights{"D65"};
    for (const auto& l : s.illuminants)
        if (l != "D65" && l != "d65") lights.push_back(l);  // D65 is always shown first
    Viewer v;
    try {
        v = Viewer::make(s.data_dir, s.observer, r.wavelengths, lights);
    } catch (const Error& e) {
        throw Error(exr_path + ": " + e.what());
    }
    r.pixels = reader.read_pixels(xy);
    const bool divide = r.alpha == AlphaKind::Associated;
    for (const auto& p : r.pixels) {
        std::vector<PixelColour> c;
        for (const auto& l : v.lights)
            c.push_back(colour_of(v, l, p.values.data(), divide ? p.alpha : 1.0));
        r.colours.push_back(std::move(c));
    }
    r.lights = std::move(v.lights);
    return r;
}

}  // namespace spectex
