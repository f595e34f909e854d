// spectex plot: an SVG plot of the spectra of some pixels.
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
#include "pipeline/plot.h"
#include "spectral/spectrum.h"

namespace spectex {

int run_plot(const std::vector<std::string>& args) {
    PlotSettings s;
    std::string output;
    std::vector<std::pair<int, int>> xy;
    bool quiet = false;
    ArgParser p("plot", "spectex plot [options] FILE.exr --pixel X,Y [--pixel X,Y ...] -o OUT.svg",
                "Writes an SVG 1.1 plot of the spectra of the chosen pixels (data window "
                "coordinates, as for\n"
                "sample; samples as stored): wavelength in nm against reflectance from 0 (to 1, or "
                "higher when a\n"
                "sample is), each line in the pixel's 8-bit sRGB colour under D65 over a dark "
                "outline, a legend\n"
                "with each pixel's coordinates and colour, and with --light a light's spectrum "
                "scaled to the plot\n"
                "height in light grey behind. Only the rows holding the pixels are read; the SVG "
                "is written\n"
                "atomically. (SVG only; convert it with any SVG tool for a bitmap.)\n"
                "Exit status: 0 ok, 1 the work failed (e.g. a pixel outside the data window), 2 "
                "usage error.");
    p.option("--pixel", "X,Y", "A pixel to plot (repeatable).",
             [&](const std::string& v) { xy.push_back(parse_pixel("--pixel", v)); });
    p.option("-o,--output", "OUT.svg",
             "The SVG to write; the name ends in .svg (never a file this command reads).",
             [&](const std::string& v) { output = v; });
    p.option("--light", "NAME|FILE",
             "Draw this light's spectrum behind the spectra: " + shipped_illuminants_list() +
                 " (any case), " + colour_temperature_help() + ", or a CSV wavelength,value.",
             [&](const std::string& v) { s.light = v; });
    observer_option(p, "Observer of the line colours", s.observer);
    p.option("--title", "TEXT", "Title above the plot (default: the file name as given).",
             [&](const std::string& v) { s.title = v; });
    p.option("--size", "WxH", "Size of the SVG in px: W 500-10000, H 200-10000 (default 820x440).",
             [&](const std::string& v) {
                 const size_t x = v.find('x');
                 if (x == std::string::npos) throw UsageError("--size: '" + v + "' is not WxH");
                 s.width = parse_int("--size", v.substr(0, x), 500, 10000);
                 s.height = parse_int("--size", v.substr(x + 1), 200, 10000);
             });
    p.flag("-q,--quiet", "Print nothing on success.", [&] { quiet = true; });
    std::vector<std::string> files;
    try {
        if (p.parse_or_help(args, files)) return 0;
        require_one_input(files);
        if (xy.empty()) throw UsageError("no --pixel X,Y given");
        if (output.empty()) throw UsageError("no output: give -o OUT.svg");
        if (!ends_with_nocase(output, ".svg"))
            throw UsageError("-o: '" + output + "' does not end in .svg (plot writes SVG)");
        check_output_against(
            output, "-o",
            {{files[0], "the input"}, {s.light, "--light"}, {s.observer, "--observer"}}, true);
        check_observer_setting("--observer", s.observer);
        check_illuminant_setting("--light", s.light);
        s.light = light_name(s.light);
    } catch (const UsageError& e) {
        return usage_error("plot", e.what());
    }
    return run_reporting("plot", files[0], [&] {
        s.data_dir = find_data_dir();
        PlotReport r = plot_file(files[0], output, xy, s);
        if (!quiet && stream_fd_of(output) != 1)  // the SVG itself went to standard output
            std::cout << r.output << ": SVG plot of " << r.curves
                      << (r.curves == 1 ? " spectrum" : " spectra") << " of " << r.file << "\n";
    });
}

}  // namespace spectex
