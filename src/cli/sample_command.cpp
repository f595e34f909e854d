// spectex sample: the spectra of a few pixels, and their colour under D65 and other lights.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "spectral/spectrum.h"
#include "io/data_dir.h"
#include "pipeline/batch.h"
#include "pipeline/sample.h"
#include "spectral/error.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

std::string num(double v, const char* fmt = "%.9g") {
    if (!std::isfinite(v)) return "null";
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v);
    return buf;
}

std::string triple(double a, double b, double c, const char* sep, const char* fmt = "%.6g") {
    return num(a, fmt) + sep + num(b, fmt) + sep + num(c, fmt);
}


std::string json_vec(const Eigen::Vector3d& v) { return "[" + triple(v(0), v(1), v(2), ",", "%.9g") + "]"; }
std::string json_codes(const int* c) {
    return "[" + std::to_string(c[0]) + "," + std::to_string(c[1]) + "," + std::to_string(c[2]) + "]";
}

void print_csv(const SampleReport& r) {
    std::ostringstream o;
    o << "x,y,wavelength,value\n";
    for (size_t i = 0; i < r.pixels.size(); ++i) {
        const PixelSpectrum& p = r.pixels[i];
        const std::string xy = std::to_string(p.x) + "," + std::to_string(p.y);
        for (size_t k = 0; k < r.wavelengths.size(); ++k)
            o << xy << "," << format_wavelength(r.wavelengths[k]) << "," << num(p.values[k]) << "\n";
        if (r.alpha == "associated")
            o << "# pixel " << xy << ": A " << num(p.alpha, "%.6g")
              << (p.alpha > 0 ? " (premultiplied): the colours are of the spectrum divided by A\n"
                              : ": transparent, its colour is not defined\n");
        else if (r.alpha == "unassociated")
            o << "# pixel " << xy << ": A " << num(p.alpha, "%.6g") << " (unassociated: not applied)\n";
        for (size_t l = 0; l < r.lights.size(); ++l) {
            const PixelColour& c = r.colours[i][l];
            if (!c.defined) continue;
            const std::string& name = r.lights[l].name;
            o << "# pixel " << xy << " under " << name << (l == 0 ? "" : " adapted to D65 (Bradford)") << ": "
              << "linear Rec.709 " << triple(c.rgb(0), c.rgb(1), c.rgb(2), " ") << "; sRGB 8-bit " << c.srgb[0]
              << " " << c.srgb[1] << " " << c.srgb[2] << "; L*a*b* " << triple(c.lab.L, c.lab.a, c.lab.b, " ", "%.4f");
            if (l != 0)
                o << " (white " << name << "); unadapted sRGB 8-bit " << c.srgb_unadapted[0] << " "
                  << c.srgb_unadapted[1] << " " << c.srgb_unadapted[2];
            o << "\n";
        }
    }
    std::cout << o.str();
}

void print_json(const SampleReport& r) {
    std::ostringstream o;
    o << "{\"schema_version\":1,\"file\":" << json_string(r.file) << ",\"observer\":" << json_string(r.observer)
      << ",\"alpha\":" << json_string(r.alpha) << ",\"wavelengths\":[";
    for (size_t k = 0; k < r.wavelengths.size(); ++k) o << (k ? "," : "") << format_wavelength(r.wavelengths[k]);
    o << "],\"illuminants\":[";
    for (size_t l = 0; l < r.lights.size(); ++l)
        o << (l ? "," : "") << "{\"name\":" << json_string(r.lights[l].name)
          << ",\"white_xyz\":" << json_vec(r.lights[l].col.white_xyz) << "}";
    o << "],\"pixels\":[";
    for (size_t i = 0; i < r.pixels.size(); ++i) {
        const PixelSpectrum& p = r.pixels[i];
        o << (i ? "," : "") << "{\"x\":" << p.x << ",\"y\":" << p.y << ",\"alpha\":"
          << (r.alpha == "none" ? std::string("null") : num(p.alpha)) << ",\"values\":[";
        for (size_t k = 0; k < p.values.size(); ++k) o << (k ? "," : "") << num(p.values[k]);
        o << "],\"colours\":[";
        for (size_t l = 0; l < r.lights.size(); ++l) {
            const PixelColour& c = r.colours[i][l];
            o << (l ? "," : "") << "{\"illuminant\":" << json_string(r.lights[l].name);
            if (!c.defined) {
                o << ",\"defined\":false}";
                continue;
            }
            o << ",\"defined\":true,\"xyz\":" << json_vec(c.xyz) << ",\"lab\":[" << num(c.lab.L) << "," << num(c.lab.a)
              << "," << num(c.lab.b) << "],\"linear_rgb\":" << json_vec(c.rgb) << ",\"srgb8\":" << json_codes(c.srgb)
              << ",\"adaptation\":" << json_string(l == 0 ? "none" : "bradford")
              << ",\"linear_rgb_unadapted\":" << json_vec(c.rgb_unadapted)
              << ",\"srgb8_unadapted\":" << json_codes(c.srgb_unadapted) << "}";
        }
        o << "]}";
    }
    o << "]}\n";
    std::cout << o.str();
}

}  // namespace

int run_sample(const std::vector<std::string>& args) {
    SampleSettings s;
    bool json = false;
    ArgParser p("sample", "spectex sample [options] FILE.exr X,Y [X,Y ...]",
                "Prints the spectrum of each pixel X,Y of a spectral OpenEXR (data window coordinates, as stored in\n"
                "the file: a spectex bake's data window starts at 0,0, the top-left pixel) as CSV with the header\n"
                "x,y,wavelength,value (one row per bin, samples as stored), each pixel followed by '#' comment\n"
                "lines with its colour under D65: linear Rec.709 through the white-consistent matrix (as verify\n"
                "integrates), the 8-bit sRGB code and CIE L*a*b*; and under each --illuminant: L*a*b* relative to\n"
                "that light's white, and the sRGB colour after a Bradford adaptation of its white to D65's (and\n"
                "without it). Spectra premultiplied by A (A present, spectex:alpha not 'unassociated') are divided\n"
                "by A for the colour. Only the rows holding the pixels are read. Put '--' before negative X.\n"
                "Exit status: 0 ok, 1 unreadable or non-spectral file or a pixel outside the data window, 2 usage.");
    p.section("Colorimetry");
    p.option("--illuminant", "NAME[,NAME...]",
             "Also show the colour under these lights (repeatable): " + shipped_illuminants_list() +
                 " (any case), or a CSV wavelength,value.",
             [&](const std::string& v) {
                 for (const auto& n : split_list(v, "--illuminant")) {
                     s.illuminants.push_back(n);
                 }
             });
    p.option("--observer", "NAME|FILE", "Observer: cie1931-2 (default), cie1964-10, or a CSV wavelength,x,y,z.",
             [&](const std::string& v) { s.observer = v; });
    p.section("Output");
    p.flag("--json", "Print one JSON object (schema_version 1) instead of CSV.", [&] { json = true; });
    std::vector<std::string> pos;
    std::vector<std::pair<int, int>> xy;
    try {
        if (p.parse_or_help(args, pos)) return 0;
        if (pos.empty()) throw UsageError("no input file");
        if (pos.size() < 2) throw UsageError("no pixel X,Y given");
        for (size_t i = 1; i < pos.size(); ++i) xy.push_back(parse_pixel("", pos[i]));
    } catch (const UsageError& e) {
        return usage_error("sample", e.what());
    }
    return run_reporting(pos[0], [&] {
        s.data_dir = find_data_dir();
        SampleReport r = sample_pixels(pos[0], xy, s);
        if (json)
            print_json(r);
        else
            print_csv(r);
    });
}

}  // namespace spectex
