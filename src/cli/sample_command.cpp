// spectex sample: the spectra of a few pixels, and their colour under D65 and other lights.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "base/error.h"
#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "cli/output_check.h"
#include "io/atomic_file.h"
#include "io/data_dir.h"
#include "pipeline/json_text.h"
#include "pipeline/light_list.h"
#include "pipeline/sample.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

// A sample as stored: a NaN or an infinity is written as such (nan, inf, -inf), as every CSV
// reader (Python's float, NumPy, pandas) reads it; JSON has no word for them (null there).
std::string num(double v, const char* fmt = "%.9g") {
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v);
    return buf;
}

std::string triple(double a, double b, double c, const char* sep, const char* fmt = "%.6g") {
    return num(a, fmt) + sep + num(b, fmt) + sep + num(c, fmt);
}

// JSON numbers to 9 significant digits, as the CSV's samples: a float sample comes back exactly.
Json json_num(double v) { return json_number(v, "%.9g"); }
Json json_vec(const Eigen::Vector3d& v) { return {json_num(v(0)), json_num(v(1)), json_num(v(2))}; }
Json json_codes(const int* c) { return {c[0], c[1], c[2]}; }

void print_csv(const SampleReport& r) {
    std::ostringstream o;
    o << "x,y,wavelength,value\n";
    for (size_t i = 0; i < r.pixels.size(); ++i) {
        const PixelSpectrum& p = r.pixels[i];
        const std::string xy = std::to_string(p.x) + "," + std::to_string(p.y);
        for (size_t k = 0; k < r.wavelengths.size(); ++k)
            o << xy << "," << format_wavelength(r.wavelengths[k]) << "," << num(p.values[k])
              << "\n";
        if (r.alpha == AlphaKind::Associated)
            o << "# pixel " << xy << ": A " << num(p.alpha, "%.6g")
              << (p.alpha > 0 ? " (premultiplied): the colours are of the spectrum divided by A\n"
                              : ": transparent, its colour is not defined\n");
        else if (r.alpha == AlphaKind::Unassociated)
            o << "# pixel " << xy << ": A " << num(p.alpha, "%.6g")
              << " (unassociated: not applied)\n";
        for (size_t l = 0; l < r.lights.size(); ++l) {
            const PixelColour& c = r.colours[i][l];
            if (!c.defined) continue;
            const std::string& name = r.lights[l].name;
            o << "# pixel " << xy << " under " << name
              << (l == 0 ? "" : " adapted to D65 (Bradford)") << ": "
              << "linear Rec.709 " << triple(c.rgb(0), c.rgb(1), c.rgb(2), " ") << "; sRGB 8-bit "
              << c.srgb[0] << " " << c.srgb[1] << " " << c.srgb[2] << "; L*a*b* "
              << triple(c.lab.L, c.lab.a, c.lab.b, " ", "%.4f");
            if (l != 0)
                o << " (white " << name << "); unadapted sRGB 8-bit " << c.srgb_unadapted[0] << " "
                  << c.srgb_unadapted[1] << " " << c.srgb_unadapted[2];
            o << "\n";
        }
    }
    std::cout << o.str();
}

std::string sample_json(const SampleReport& r) {
    Json j;
    j["schema_version"] = 1;
    put_text(j, "file", r.file);
    put_text(j, "observer", r.observer);
    j["alpha"] = to_string(r.alpha);
    Json wavelengths = Json::array();
    for (double l : r.wavelengths) wavelengths.push_back(json_number_text(format_wavelength(l)));
    j["wavelengths"] = std::move(wavelengths);
    Json illuminants = Json::array();
    for (const auto& light : r.lights) {
        Json l;
        put_text(l, "name", light.name);
        l["white_xyz"] = json_vec(light.col.white_xyz);
        illuminants.push_back(std::move(l));
    }
    j["illuminants"] = std::move(illuminants);
    Json pixels = Json::array();
    for (size_t i = 0; i < r.pixels.size(); ++i) {
        const PixelSpectrum& p = r.pixels[i];
        Json pixel;
        pixel["x"] = p.x;
        pixel["y"] = p.y;
        pixel["alpha"] = r.alpha == AlphaKind::None ? Json(nullptr) : json_num(p.alpha);
        Json values = Json::array();
        for (double v : p.values) values.push_back(json_num(v));
        pixel["values"] = std::move(values);
        Json colours = Json::array();
        for (size_t l = 0; l < r.lights.size(); ++l) {
            const PixelColour& c = r.colours[i][l];
            Json colour;
            put_text(colour, "illuminant", r.lights[l].name);
            colour["defined"] = c.defined;
            if (c.defined) {
                colour["xyz"] = json_vec(c.xyz);
                colour["lab"] = {json_num(c.lab.L), json_num(c.lab.a), json_num(c.lab.b)};
                colour["linear_rgb"] = json_vec(c.rgb);
                colour["srgb8"] = json_codes(c.srgb);
                colour["adaptation"] = l == 0 ? "none" : "bradford";
                colour["linear_rgb_unadapted"] = json_vec(c.rgb_unadapted);
                colour["srgb8_unadapted"] = json_codes(c.srgb_unadapted);
            }
            colours.push_back(std::move(colour));
        }
        pixel["colours"] = std::move(colours);
        pixels.push_back(std::move(pixel));
    }
    j["pixels"] = std::move(pixels);
    return json_line(j);
}

}  // namespace

int run_sample(const std::vector<std::string>& args) {
    SampleSettings s;
    std::string json;  // "" CSV, "-" standard output, else a file
    ArgParser p("sample", "spectex sample [options] FILE.exr X,Y [X,Y ...]",
                "Prints the spectrum of each pixel X,Y of a spectral OpenEXR (data window "
                "coordinates, as stored in\n"
                "the file: a spectex bake's data window starts at 0,0, the top-left pixel) as CSV "
                "with the header\n"
                "x,y,wavelength,value (one row per bin, samples as stored), each pixel followed by "
                "'#' comment\n"
                "lines with its colour under D65: linear Rec.709 through the white-consistent "
                "matrix (as verify\n"
                "integrates), the 8-bit sRGB code and CIE L*a*b*; and under each --illuminant: "
                "L*a*b* relative to\n"
                "that light's white, and the sRGB colour after a Bradford adaptation of its white "
                "to D65's (and\n"
                "without it). Spectra premultiplied by A (A present, spectex:alpha not "
                "'unassociated') are divided\n"
                "by A for the colour. Only the rows holding the pixels are read. Put '--' before "
                "negative X.\n"
                "Exit status: 0 ok, 1 unreadable or non-spectral file or a pixel outside the data "
                "window, 2 usage.");
    p.section("Colorimetry");
    list_option(
        p, "--illuminant", "NAME[,NAME...]",
        "Also show the colour under these lights (repeatable; a light given twice, a name in "
        "any case or one CSV file, is shown once): " +
            shipped_illuminants_list() + " (any case), " + colour_temperature_help() +
            ", or a CSV wavelength,value.",
        s.illuminants);
    observer_option(p, "Observer", s.observer);
    p.section("Output");
    p.option_or_flag("--json", "FILE",
                     "Write one JSON object (schema_version 1) to FILE instead of the CSV ('-' = "
                     "stdout), as plan, verify and bake do. --json alone is '-' (its old "
                     "spelling); a FILE must end in .json or .jsonl (or be given as --json=FILE).",
                     {".json", ".jsonl"}, "-",
                     [&](const std::string& v) { json = stdout_as_dash(v); });
    std::vector<std::string> pos;
    std::vector<std::pair<int, int>> xy;
    try {
        if (p.parse_or_help(args, pos)) return 0;
        if (pos.empty()) throw UsageError("no input file");
        if (pos.size() < 2) throw UsageError("no pixel X,Y given");
        for (size_t i = 1; i < pos.size(); ++i) {
            try {
                xy.push_back(parse_pixel("", pos[i]));
            } catch (const UsageError& e) {
                throw UsageError(e.what() + p.declined_hint("--json", pos[i]));
            }
        }
        s.illuminants = distinct_lights(s.illuminants);
        check_observer_setting("--observer", s.observer);
        for (const auto& l : s.illuminants) check_illuminant_setting("--illuminant", l);
        if (!json.empty() && json != "-")
            check_output_against(json, "--json", {{pos[0], "input"}}, true);
    } catch (const UsageError& e) {
        return usage_error("sample", e.what());
    }
    return run_reporting("sample", pos[0], [&] {
        s.data_dir = find_data_dir();
        SampleReport r = sample_pixels(pos[0], xy, s);
        if (json == "-")
            std::cout << sample_json(r);
        else if (!json.empty())
            write_text_atomically(json, sample_json(r));
        else
            print_csv(r);
    });
}

}  // namespace spectex
