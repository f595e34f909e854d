#include <iostream>

#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "io/spectral_exr_info.h"
#include "spectral/error.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

int run_info(const std::vector<std::string>& args) {
    ArgParser p("info", "spectex info FILE.exr...",
                "Prints the wavelength grid, bins, sample type, compression, size, alpha and the spectex:\n"
                "provenance of spectral OpenEXR files (Fichet 2021 layout, from spectex or any other tool).\n"
                "Exits 1 when a file is not a spectral reflectance image.");
    std::vector<std::string> files;
    try {
        if (p.parse_or_help(args, files)) return 0;
        if (files.empty()) throw UsageError("no input file");
    } catch (const UsageError& e) {
        return usage_error("info", e.what());
    }
    int status = 0;
    for (const auto& f : files) {
        try {
            SpectralExrInfo info = read_spectral_exr_info(f);
            std::vector<double> l;
            for (const auto& b : info.reflective) l.push_back(b.lambda);
            WavelengthGrid grid = WavelengthGrid::from_list(l);
            std::cout << f << "\n";
            std::cout << "  size:            " << info.width << " x " << info.height;
            if (info.data_x0 != info.display_x0 || info.data_y0 != info.display_y0 ||
                info.data_x1 != info.display_x1 || info.data_y1 != info.display_y1)
                std::cout << " (data window " << info.data_x0 << "," << info.data_y0 << " - " << info.data_x1 << ","
                          << info.data_y1 << "; display window " << info.display_x0 << "," << info.display_y0
                          << " - " << info.display_x1 << "," << info.display_y1 << ")";
            std::cout << "\n";
            std::cout << "  layout:          spectralLayoutVersion "
                      << (info.layout_version.empty() ? "(absent)" : info.layout_version) << ", reflective\n";
            std::cout << "  wavelengths:     " << grid.describe() << " nm\n";
            std::cout << "  bins:            " << info.reflective.size() << "\n";
            std::cout << "  sample type:     " << info.sample_type << "\n";
            std::cout << "  compression:     " << info.compression << "\n";
            std::cout << "  storage:         "
                      << (info.tiled ? "tiled " + std::to_string(info.tile_width) + "x" + std::to_string(info.tile_height)
                                     : std::string("scanline"))
                      << (info.parts > 1 ? ", " + std::to_string(info.parts) + " parts (first shown)" : "") << "\n";
            std::cout << "  alpha:           " << (info.alpha ? "A (" + info.alpha_type + ")" : std::string("none"))
                      << "\n";
            std::cout << "  preview RGB:     " << (info.preview ? "yes" : "no") << "\n";
            if (info.emissive_channels) std::cout << "  emissive chans:  " << info.emissive_channels << "\n";
            for (const auto& [k, v] : info.attributes) {
                if (k.rfind("spectex:", 0) != 0) continue;
                if (k == "spectex:wavelengthList") continue;
                std::cout << "  " << k << " " << v << "\n";
            }
        } catch (const Error& e) {
            print_error(e.what());
            status = 1;
        }
    }
    return status;
}

}  // namespace spectex
