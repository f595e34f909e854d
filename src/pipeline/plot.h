#pragma once
// `spectex plot`: an SVG 1.1 plot of the spectra of some pixels of a spectral OpenEXR, each line in
// the pixel's sRGB colour under D65 (pipeline/look.h) over a dark outline so that white lines stay
// visible, with labelled axes, ticks, a legend, and optionally a light's spectrum scaled to the
// plot height in light grey behind. Written atomically; reads only the rows holding the pixels.
#include <string>
#include <utility>
#include <vector>

namespace spectex {

struct PlotSettings {
    std::string data_dir;
    std::string observer = "cie1931-2";
    std::string light;              // "" = none
    std::string title;              // "" = the file's name as given
    int width = 820, height = 440;  // SVG user units (px)
};

struct PlotReport {
    std::string file, output;
    int curves = 0;
    double y_max = 1;  // top of the reflectance axis
};

// The SVG text (no file written); throws Error("<file>: <cause>").
std::string plot_svg(const std::string& exr_path, const std::vector<std::pair<int, int>>& xy,
                     const PlotSettings& s, PlotReport* report);
// plot_svg() written atomically to svg_path.
PlotReport plot_file(const std::string& exr_path, const std::string& svg_path,
                     const std::vector<std::pair<int, int>>& xy, const PlotSettings& s);

}  // namespace spectex
