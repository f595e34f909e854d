#include <iostream>
#include <sstream>

#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "io/spectral_exr_info.h"
#include "io/spectral_reader.h"
#include "pipeline/batch.h"
#include "spectral/error.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {


std::string levels_text(const SpectralExrInfo& info) {
    std::string out;
    auto size = [](int w, int h) { return std::to_string(w) + "x" + std::to_string(h); };
    if (info.level_mode == "mipmap") {
        out = "mipmap, " + std::to_string(info.levels.size()) + " levels (rounding " + info.level_rounding + "): ";
        for (size_t l = 0; l < info.levels.size(); ++l)
            out += (l ? ", " : "") + size(info.levels[l].first, info.levels[l].second);
    } else if (info.level_mode == "ripmap") {
        out = "ripmap, " + std::to_string(info.rip_x.size()) + " x " + std::to_string(info.rip_y.size()) +
              " levels (rounding " + info.level_rounding + "): widths";
        for (int v : info.rip_x) out += " " + std::to_string(v);
        out += ", heights";
        for (int v : info.rip_y) out += " " + std::to_string(v);
    } else {
        out = "1 (no MIP levels)";
    }
    return out;
}

std::string info_json(const SpectralExrInfo& info, const WavelengthGrid& grid) {
    std::ostringstream o;
    auto box = [](int a, int b, int c, int d) {
        return "[" + std::to_string(a) + "," + std::to_string(b) + "," + std::to_string(c) + "," + std::to_string(d) + "]";
    };
    o << "{\"schema_version\":1,\"file\":" << json_string(info.path) << ",\"width\":" << info.width
      << ",\"height\":" << info.height
      << ",\"data_window\":" << box(info.data_x0, info.data_y0, info.data_x1, info.data_y1)
      << ",\"display_window\":" << box(info.display_x0, info.display_y0, info.display_x1, info.display_y1)
      << ",\"layout_version\":" << (info.layout_version.empty() ? "null" : json_string(info.layout_version))
      << ",\"wavelength_grid\":" << json_string(grid.describe()) << ",\"wavelengths\":[";
    for (size_t k = 0; k < info.reflective.size(); ++k)
        o << (k ? "," : "") << format_wavelength(info.reflective[k].lambda);
    o << "],\"channels\":[";
    for (size_t k = 0; k < info.reflective.size(); ++k) o << (k ? "," : "") << json_string(info.reflective[k].channel);
    o << "],\"bins\":" << info.reflective.size() << ",\"sample_type\":" << json_string(info.sample_type)
      << ",\"compression\":" << json_string(info.compression)
      << ",\"storage\":" << json_string(info.tiled ? "tiled" : "scanline") << ",\"tiles\":";
    if (info.tiled)
        o << "{\"width\":" << info.tile_width << ",\"height\":" << info.tile_height << "}";
    else
        o << "null";
    o << ",\"levels\":{\"mode\":" << json_string(info.level_mode) << ",\"rounding\":"
      << json_string(info.level_rounding);
    if (info.level_mode == "ripmap") {
        o << ",\"x_widths\":[";
        for (size_t i = 0; i < info.rip_x.size(); ++i) o << (i ? "," : "") << info.rip_x[i];
        o << "],\"y_heights\":[";
        for (size_t i = 0; i < info.rip_y.size(); ++i) o << (i ? "," : "") << info.rip_y[i];
        o << "]";
    } else {
        const size_t n = info.levels.empty() ? 1 : info.levels.size();
        o << ",\"count\":" << n << ",\"sizes\":[";
        if (info.levels.empty())
            o << "[" << info.width << "," << info.height << "]";
        for (size_t l = 0; l < info.levels.size(); ++l)
            o << (l ? "," : "") << "[" << info.levels[l].first << "," << info.levels[l].second << "]";
        o << "]";
    }
    o << "},\"parts\":" << info.parts << ",\"alpha\":" << json_string(alpha_kind(info))
      << ",\"alpha_type\":" << (info.alpha ? json_string(info.alpha_type) : "null")
      << ",\"preview_rgb\":" << (info.preview ? "true" : "false")
      << ",\"emissive_channels\":" << info.emissive_channels << ",\"attributes\":[";
    for (size_t i = 0; i < info.header.size(); ++i)
        o << (i ? "," : "") << "{\"name\":" << json_string(info.header[i].name)
          << ",\"type\":" << json_string(info.header[i].type) << ",\"value\":" << json_string(info.header[i].value)
          << "}";
    o << "]}\n";
    return o.str();
}

}  // namespace

int run_info(const std::vector<std::string>& args) {
    ArgParser p("info", "spectex info FILE.exr...",
                "Prints the wavelength grid, bins, sample type, compression, size, alpha and the spectex:\n"
                "provenance of spectral OpenEXR files (Fichet 2021 layout, from spectex or any other tool).\n"
                "Tiled files also show their tile size and MIP levels (count and each level's size).\n"
                "Exits 1 when a file is not a spectral reflectance image.");
    bool json = false;
    p.flag("--json", "Print the whole header (every attribute, as text) and the derived facts: one JSON object per file, one per line.",
           [&] { json = true; });
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
            if (!info.complete)
                throw Error(f + ": incomplete: chunks of the pixel data are missing (a truncated or interrupted file)");
            std::vector<double> l;
            for (const auto& b : info.reflective) l.push_back(b.lambda);
            WavelengthGrid grid = WavelengthGrid::from_list(l);
            if (json) {
                std::cout << info_json(info, grid);
                continue;
            }
            // Names and attribute values come from the file: one printable line each (a header can
            // hold escape codes that would rewrite the terminal, or line breaks that forge lines).
            std::cout << one_line(f) << "\n";
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
            if (info.tiled) std::cout << "  levels:          " << levels_text(info) << "\n";
            std::cout << "  alpha:           " << (info.alpha ? "A (" + info.alpha_type + ")" : std::string("none"))
                      << "\n";
            std::cout << "  preview RGB:     " << (info.preview ? "yes" : "no") << "\n";
            if (info.emissive_channels) std::cout << "  emissive chans:  " << info.emissive_channels << "\n";
            for (const auto& [k, v] : info.attributes) {
                if (k.rfind("spectex:", 0) != 0) continue;
                if (k == "spectex:wavelengthList") continue;
                std::cout << "  " << one_line(k) << " " << one_line(v) << "\n";
            }
        } catch (const Error& e) {
            print_error(e.what());
            status = 1;
        }
    }
    return status;
}

}  // namespace spectex
