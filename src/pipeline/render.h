#pragma once
// `spectex render`: a spectral OpenEXR as it looks under one or more lights, as an 8-bit sRGB PNG
// (pipeline/look.h for the colour). Several lights give a sheet: one panel per light, side by
// side, each under a strip with the light's name. The file is read a band of rows at a time and
// the PNG written row by row, atomically (temporary file in the destination folder, then rename).
#include <cstdint>
#include <string>
#include <vector>

namespace spectex {

struct RenderSettings {
    std::string data_dir;
    std::string observer = "cie1931-2";
    std::vector<std::string> illuminants{"D65"};
    bool adapt = true;                // Bradford to D65; false shows the light's colour cast
    uint64_t max_pixels = 268435456;  // refuse larger files (as bake does)
    size_t band_bytes = 8u << 20;     // float spectral samples per band
    int threads = 0;                  // 0 = all cores
};

struct RenderReport {
    std::string file, output;
    int width = 0, height = 0;  // of the PNG
    int panel_width = 0, panel_height = 0, label_height = 0, gap = 0;
    int channels = 3;  // 4 when the file has alpha (straight colour, A as 8-bit)
    std::vector<std::string> labels;
};

// Sheet layout, with s = clamp(width / 128, 1, 4): panels 4s pixels apart under a label strip 11s
// pixels high (labels in the 5x7 font scaled by s); one light gives the file's size, no strip.
// Throws Error("<file>: <cause>") or Error("<output>: <cause>").
RenderReport render_file(const std::string& exr_path, const std::string& png_path,
                         const RenderSettings& s);

}  // namespace spectex
