// spectex render: a spectral OpenEXR as an 8-bit sRGB PNG under one or more lights.
#include <OpenEXR/ImfThreading.h>

#include <algorithm>
#include <cctype>
#include <iostream>

#include "base/error.h"
#include "base/text.h"
#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "cli/output_check.h"
#include "io/atomic_file.h"
#include "io/data_dir.h"
#include "io/file_identity.h"
#include "pipeline/light_list.h"
#include "pipeline/look.h"
#include "pipeline/render.h"
#include "spectral/spectrum.h"

namespace spectex {

namespace {

bool ends_with_png(const std::string& p) { return ends_with_nocase(p, ".png"); }

}  // namespace

int run_render(const std::vector<std::string>& args) {
    RenderSettings s;
    s.illuminants.clear();
    std::string output;
    bool quiet = false;
    ArgParser p(
        "render", "spectex render [options] FILE.exr -o OUT.png",
        "Renders a spectral OpenEXR as it looks under a light, as an 8-bit sRGB PNG: every pixel "
        "is\n"
        "integrated under the light with the observer on the file's own bins (XYZ with the "
        "perfect\n"
        "reflector at Y = 1), white-balanced by a Bradford adaptation of the light's white to "
        "D65's, and\n"
        "encoded as sRGB through D65's white-consistent matrix (the one verify uses), so that a "
        "render\n"
        "under D65 of a spectex bake gives back the source's 8-bit codes. --no-adapt shows the "
        "light's\n"
        "colour cast instead (XYZ relative to the light, same matrix, no adaptation; clipped). "
        "Spectra\n"
        "premultiplied by A are divided by it; a file with A gives an RGBA PNG (straight colour).\n"
        "Several lights give a sheet: one panel per light, side by side, each under a strip with "
        "the\n"
        "light's name. The file is read a band of rows at a time; the PNG is written atomically.\n"
        "Exit status: 0 ok, 1 the work failed, 2 usage error.");
    p.option("-o,--output", "OUT.png", "The PNG to write (never a file this command reads).",
             [&](const std::string& v) { output = v; });
    p.section("Colorimetry");
    list_option(p, "--illuminant", "NAME[,NAME...]",
                "Light(s): " + shipped_illuminants_list("D65") + " (any case), " +
                    colour_temperature_help() +
                    ", or a CSV wavelength,value; repeatable; several make a sheet\n"
                    "(a light given twice, a name in any case or one CSV file, is one panel).",
                s.illuminants);
    observer_option(p, "Observer", s.observer);
    p.flag("--no-adapt", "No chromatic adaptation: show the light's colour cast.",
           [&] { s.adapt = false; });
    p.section("Resources");
    p.option("--max-pixels", "N",
             "Refuse files with more pixels than this (default 268435456 = 16384^2: the file "
             "fails, exit 1,\nas in bake), and a sheet (several lights: panels, gaps and label "
             "strip) with more (a usage\nerror, exit 2), before any pixel is read.",
             [&](const std::string& v) { s.max_pixels = parse_count("--max-pixels", v); });
    p.option("--threads", "N", "Threads integrating pixels (default: all cores).",
             [&](const std::string& v) { s.threads = parse_int("--threads", v, 0, 1024); });
    p.flag("-q,--quiet", "Print nothing on success.", [&] { quiet = true; });
    std::vector<std::string> files;
    try {
        if (p.parse_or_help(args, files)) return 0;
        require_one_input(files);
        if (output.empty()) throw UsageError("no output: give -o OUT.png");
        if (s.illuminants.empty()) s.illuminants.push_back("D65");
        s.illuminants = distinct_lights(s.illuminants);
        std::vector<std::pair<std::string, std::string>> reads = {{files[0], "the input"},
                                                                  {s.observer, "--observer"}};
        for (const auto& l : s.illuminants) reads.push_back({l, "--illuminant"});
        check_output_against(output, "-o", reads);
        check_observer_setting("--observer", s.observer);
        for (const auto& l : s.illuminants) check_illuminant_setting("--illuminant", l);
        if (!ends_with_png(output))
            throw UsageError("-o: '" + output + "' does not end in .png (render writes PNG)");
    } catch (const UsageError& e) {
        return usage_error("render", e.what());
    }
    return run_reporting("render", files[0], [&] {
        s.data_dir = find_data_dir();
        RenderReport r = render_file(files[0], output, s);
        if (!quiet) {
            std::cout << r.output << ": " << r.width << " x " << r.height << " sRGB"
                      << (r.channels == 4 ? "A" : "") << " PNG of " << r.file << " under";
            for (const auto& l : r.labels) std::cout << " " << l;
            std::cout << (s.adapt ? " (Bradford-adapted to D65)" : " (not adapted)") << "\n";
        }
    });
}

}  // namespace spectex
