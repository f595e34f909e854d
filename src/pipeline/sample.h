#pragma once
// `spectex sample`: the spectra of a few pixels of a spectral OpenEXR and their colour under D65
// and other lights (pipeline/look.h). Reads only the rows that hold the pixels.
#include <string>
#include <utility>
#include <vector>

#include "io/spectral_reader.h"
#include "pipeline/look.h"

namespace spectex {

struct SampleSettings {
    std::string data_dir;
    std::string observer = "cie1931-2";
    std::vector<std::string> illuminants;  // besides D65, which always comes first
};

struct SampleReport {
    std::string file;
    std::vector<double> wavelengths;
    AlphaKind alpha = AlphaKind::None;  // alpha_kind()
    std::string observer;
    std::vector<LightView> lights;  // D65 first
    std::vector<PixelSpectrum> pixels;
    std::vector<std::vector<PixelColour>> colours;  // [pixel][light]
};

// Throws Error("<file>: <cause>"): unreadable or non-spectral file, a pixel outside the data
// window, unknown lights or observers.
SampleReport sample_pixels(const std::string& exr_path, const std::vector<std::pair<int, int>>& xy,
                           const SampleSettings& s);

}  // namespace spectex
