#include <iostream>
#include <sstream>
#include <utility>
#include <vector>

#include "base/error.h"
#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "cli/output_check.h"
#include "io/atomic_file.h"
#include "io/provenance_keys.h"
#include "io/spectral_exr_info.h"
#include "io/spectral_reader.h"
#include "pipeline/json_text.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

// The grid with its unit once: "380:780:5 nm", "list of 7 wavelengths 400-700 nm", "550 nm
// (1 wavelength)". WavelengthGrid::describe() names the unit only for lists (and is recorded as
// it is in spectex:wavelengths).
std::string grid_text(const WavelengthGrid& grid) {
    if (grid.size() == 1) return format_wavelength(grid.lambda[0]) + " nm (1 wavelength)";
    const std::string d = grid.describe();
    return d.size() >= 3 && d.compare(d.size() - 3, 3, " nm") == 0 ? d : d + " nm";
}

std::string levels_text(const SpectralExrInfo& info) {
    std::string out;
    auto size = [](int w, int h) { return std::to_string(w) + "x" + std::to_string(h); };
    if (info.level_mode == "mipmap") {
        out = "mipmap, " + std::to_string(info.levels.size()) + " levels (rounding " +
              info.level_rounding + "): ";
        for (size_t l = 0; l < info.levels.size(); ++l)
            out += (l ? ", " : "") + size(info.levels[l].first, info.levels[l].second);
    } else if (info.level_mode == "ripmap") {
        out = "ripmap, " + std::to_string(info.rip_x.size()) + " x " +
              std::to_string(info.rip_y.size()) + " levels (rounding " + info.level_rounding +
              "): widths";
        for (int v : info.rip_x) out += " " + std::to_string(v);
        out += ", heights";
        for (int v : info.rip_y) out += " " + std::to_string(v);
    } else {
        out = "1 (no MIP levels)";
    }
    return out;
}

std::string info_json(const SpectralExrInfo& info, const WavelengthGrid& grid) {
    Json j;
    j["schema_version"] = 1;
    put_text(j, "file", info.path);
    j["width"] = info.width;
    j["height"] = info.height;
    j["data_window"] = {info.data_x0, info.data_y0, info.data_x1, info.data_y1};
    j["display_window"] = {info.display_x0, info.display_y0, info.display_x1, info.display_y1};
    put_text_or_null(j, "layout_version", info.layout_version);
    put_text(j, "wavelength_grid", grid.describe());
    Json wavelengths = Json::array();
    std::vector<std::string> channels;
    for (const auto& bin : info.reflective) {
        wavelengths.push_back(json_number_text(format_wavelength(bin.lambda)));
        channels.push_back(bin.channel);
    }
    j["wavelengths"] = std::move(wavelengths);
    put_texts(j, "channels", channels);
    j["bins"] = info.reflective.size();
    put_text(j, "sample_type", info.sample_type);
    put_text(j, "compression", info.compression);
    j["storage"] = info.tiled ? "tiled" : "scanline";
    j["tiles"] =
        info.tiled ? Json{{"width", info.tile_width}, {"height", info.tile_height}} : Json(nullptr);
    Json levels;
    put_text(levels, "mode", info.level_mode);
    put_text(levels, "rounding", info.level_rounding);
    if (info.level_mode == "ripmap") {
        levels["x_widths"] = info.rip_x;
        levels["y_heights"] = info.rip_y;
    } else {
        Json sizes = Json::array();
        if (info.levels.empty()) sizes.push_back({info.width, info.height});
        for (const auto& [w, h] : info.levels) sizes.push_back({w, h});
        levels["count"] = sizes.size();
        levels["sizes"] = std::move(sizes);
    }
    j["levels"] = std::move(levels);
    j["parts"] = info.parts;
    j["alpha"] = to_string(alpha_kind(info));
    if (info.alpha)
        put_text(j, "alpha_type", info.alpha_type);
    else
        j["alpha_type"] = nullptr;
    j["preview_rgb"] = info.preview;
    j["emissive_channels"] = info.emissive_channels;
    Json attributes = Json::array();
    for (const auto& a : info.header) {
        Json attribute;
        put_text(attribute, "name", a.name);
        put_text(attribute, "type", a.type);
        put_text(attribute, "value", a.value);
        attributes.push_back(std::move(attribute));
    }
    j["attributes"] = std::move(attributes);
    return json_line(j);
}

}  // namespace

int run_info(const std::vector<std::string>& args) {
    ArgParser p(
        "info", "spectex info FILE.exr...",
        "Prints the wavelength grid, bins, sample type, compression, size, alpha and the spectex:\n"
        "provenance of spectral OpenEXR files (Fichet 2021 layout, from spectex or any other "
        "tool).\n"
        "Tiled files also show their tile size and MIP levels (count and each level's size).\n"
        "Exits 1 when a file is not a spectral reflectance image.");
    std::string json_out;  // "" text, "-" standard output, else a file
    p.option_or_flag(
        "--json", "FILE",
        "Write the whole header (every attribute, as text) and the derived facts as JSON Lines, "
        "one object per file, to FILE ('-' = stdout, instead of the text), as plan, verify and "
        "bake do. --json alone is '-' (its old spelling); a FILE must end in .json or .jsonl "
        "(or be given as --json=FILE).",
        {".json", ".jsonl"}, "-", [&](const std::string& v) { json_out = stdout_as_dash(v); });
    std::vector<std::string> files;
    try {
        if (p.parse_or_help(args, files)) return 0;
        if (files.empty()) throw UsageError("no input file");
        if (!json_out.empty() && json_out != "-") {
            std::vector<std::pair<std::string, std::string>> reads;
            for (const auto& f : files) reads.push_back({f, "input"});
            check_output_against(json_out, "--json", reads, true);
        }
    } catch (const UsageError& e) {
        return usage_error("info", e.what());
    }
    const bool json = !json_out.empty();
    std::ostringstream records_stream;  // for a --json file: written at the end, atomically
    int status = 0;
    for (const auto& f : files) {
        try {
            SpectralExrInfo info = read_spectral_exr_info(f);
            if (!info.complete)
                throw Error(f +
                            ": incomplete: chunks of the pixel data are missing (a truncated or "
                            "interrupted file)");
            std::vector<double> l;
            for (const auto& b : info.reflective) l.push_back(b.lambda);
            WavelengthGrid grid = WavelengthGrid::from_list(l);
            if (json) {
                (json_out == "-" ? std::cout : records_stream) << info_json(info, grid);
                continue;
            }
            // Names and attribute values come from the file: one printable line each (a header can
            // hold escape codes that would rewrite the terminal, or line breaks that forge lines).
            std::cout << one_line(f) << "\n";
            std::cout << "  size:            " << info.width << " x " << info.height;
            if (info.data_x0 != info.display_x0 || info.data_y0 != info.display_y0 ||
                info.data_x1 != info.display_x1 || info.data_y1 != info.display_y1)
                std::cout << " (data window " << info.data_x0 << "," << info.data_y0 << " - "
                          << info.data_x1 << "," << info.data_y1 << "; display window "
                          << info.display_x0 << "," << info.display_y0 << " - " << info.display_x1
                          << "," << info.display_y1 << ")";
            std::cout << "\n";
            std::cout << "  layout:          spectralLayoutVersion "
                      << (info.layout_version.empty() ? "(absent)" : info.layout_version)
                      << ", reflective\n";
            std::cout << "  wavelengths:     " << grid_text(grid) << "\n";
            std::cout << "  bins:            " << info.reflective.size() << "\n";
            std::cout << "  sample type:     " << info.sample_type << "\n";
            std::cout << "  compression:     " << info.compression << "\n";
            std::cout << "  storage:         "
                      << (info.tiled ? "tiled " + std::to_string(info.tile_width) + "x" +
                                           std::to_string(info.tile_height)
                                     : std::string("scanline"))
                      << (info.parts > 1
                              ? ", " + std::to_string(info.parts) + " parts (first shown)"
                              : "")
                      << "\n";
            if (info.tiled) std::cout << "  levels:          " << levels_text(info) << "\n";
            std::cout << "  alpha:           "
                      << (info.alpha ? "A (" + info.alpha_type + ")" : std::string("none")) << "\n";
            std::cout << "  preview RGB:     " << (info.preview ? "yes" : "no") << "\n";
            if (info.emissive_channels)
                std::cout << "  emissive chans:  " << info.emissive_channels << "\n";
            for (const auto& [k, v] : info.attributes) {
                if (k.rfind(provenance_key::kPrefix, 0) != 0) continue;
                if (k == provenance_key::kWavelengthList) continue;
                if (k == provenance_key::kRebuildTable || k == provenance_key::kRebuildToRgb ||
                    k == provenance_key::kRebuildAxis) {
                    // Thousands of numbers: their size, not their text (--json has it whole).
                    std::cout << "  " << k << " (" << v.size() << " characters)\n";
                    continue;
                }
                std::cout << "  " << one_line(k) << " " << one_line(v) << "\n";
            }
        } catch (const Error& e) {
            print_error(name_file(f, e.what()) + p.declined_hint("--json", f));
            status = 1;
        }
    }
    // The records of the files that could be read, as the text output has them.
    if (json && json_out != "-") {
        try {
            write_text_atomically(json_out, records_stream.str());
        } catch (const Error& e) {
            print_error(std::string(e.what()) + " (--json)");
            return 1;
        }
    }
    return status;
}

}  // namespace spectex
