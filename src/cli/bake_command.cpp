#include <OpenEXR/ImfThreading.h>
#include <OpenImageIO/imageio.h>

#include <iostream>
#include <thread>

#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "io/data_dir.h"
#include "io/atomic_file.h"
#include "pipeline/bake.h"
#include "pipeline/basis_cache.h"
#include "spectral/error.h"

namespace spectex {

namespace {

struct BakeCli {
    std::string output, basis = "fit", wavelengths = "380:780:5", type = "half", compression = "zip";
    std::string alpha = "associated", range = "clamp", nan = "replace";
    std::string wavelengths_file;
    FitSpec fit;
    int threads = 0;
    bool quiet = false, verbose = false;
    BakeSettings settings;
};

template <typename T>
T pick(const std::string& option, const std::string& value, std::initializer_list<std::pair<const char*, T>> choices) {
    std::string list;
    for (const auto& [name, v] : choices) {
        if (value == name) return v;
        list += (list.empty() ? "" : ", ") + std::string(name);
    }
    throw UsageError(option + ": '" + value + "' is not one of " + list);
}

}  // namespace

int run_bake(const std::vector<std::string>& args, const std::string& command_line) {
    BakeCli c;
    ArgParser p("bake", "spectex bake [options] INPUT -o OUTPUT.exr",
                "Turns a texture into a spectral reflectance OpenEXR (Fichet 2021 layout, channels\n"
                "T.<wavelength>nm): read with OpenImageIO, linearise with OpenColorIO, expand each pixel\n"
                "with the spectral primary decomposition (Mallett & Yuksel 2019).");
    p.section("Output");
    p.option("-o, --output", "FILE", "Output OpenEXR file (required). Written atomically; never the input.",
             [&](const std::string& v) { c.output = v; });
    p.option("--type", "half|float", "Sample type of the spectral channels (default half).",
             [&](const std::string& v) { c.type = v; });
    p.option("--compression", "NAME",
             "none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa or dwab (default zip).",
             [&](const std::string& v) { c.compression = v; });
    p.flag("--preview", "Also write R, G, B channels (linear Rec.709) for image viewers.",
           [&] { c.settings.preview = true; });
    p.option("--alpha", "associated|unassociated",
             "Whether the spectral channels are premultiplied by A (default associated, OpenEXR's convention).",
             [&](const std::string& v) { c.alpha = v; });
    p.section("Colour");
    p.option("--colorspace", "NAME",
             "Colour space of the input (an OCIO name or alias, e.g. srgb_tx, lin_srgb, acescg, raw). "
             "Default: the file's own metadata when the config knows it, else the config's file rules.",
             [&](const std::string& v) { c.settings.colorspace = v; });
    p.option("--config", "FILE", "OCIO config to use instead of $OCIO or the shipped config/spectex.ocio.",
             [&](const std::string& v) { c.settings.config = v; });
    p.option("--out-of-range", "clamp|keep|error",
             "Linear values outside [0, 1]: clamp per channel (default), keep (spectra may leave [0, 1]), or fail.",
             [&](const std::string& v) { c.range = v; });
    p.option("--nan", "replace|error", "NaN and infinite values: replace with 0 (default) or fail.",
             [&](const std::string& v) { c.nan = v; });
    p.section("Spectra");
    p.option("--wavelengths", "START:END:STEP", "Output wavelength grid in nm (default 380:780:5).",
             [&](const std::string& v) { c.wavelengths = v; });
    p.option("--wavelengths-file", "FILE", "Output wavelengths, one per line (any strictly increasing list).",
             [&](const std::string& v) { c.wavelengths_file = v; });
    p.option("--basis", "fit|mallett2019|FILE",
             "fit (default): a basis fitted on the output grid by 'spectex basis' rules, exact on any grid; "
             "mallett2019: the published table (380:780:5 only); or a CSV wavelength,r,g,b on the output grid.",
             [&](const std::string& v) { c.basis = v; });
    p.option("--objective", "smooth|norm", "Objective of the fitted basis (default smooth; see spectex basis).",
             [&](const std::string& v) { c.fit.objective = v; });
    p.option("--observer", "NAME|FILE", "Observer of the fitted basis: cie1931-2 (default), cie1964-10, or a CSV.",
             [&](const std::string& v) { c.fit.observer = v; });
    p.option("--illuminant", "NAME|FILE", "Illuminant under which the fitted basis is exact: D65 (default), or a CSV.",
             [&](const std::string& v) { c.fit.illuminant = v; });
    p.section("Resources");
    p.option("--threads", "N", "Threads for OpenEXR compression and decoding (default: all cores).",
             [&](const std::string& v) { c.threads = parse_int("--threads", v, 0, 1024); });
    p.option("--max-pixels", "N", "Refuse inputs with more pixels than this (default 268435456 = 16384^2).",
             [&](const std::string& v) { c.settings.max_pixels = parse_count("--max-pixels", v); });
    p.flag("-q, --quiet", "Print errors only.", [&] { c.quiet = true; });
    p.flag("-v, --verbose", "Print what was done for each file.", [&] { c.verbose = true; });

    std::vector<std::string> inputs;
    try {
        inputs = p.parse(args);
        if (p.help_requested()) {
            std::cout << p.help();
            return 0;
        }
        if (inputs.empty()) throw UsageError("no input file");
        if (inputs.size() > 1) throw UsageError("one input file at a time (got " + std::to_string(inputs.size()) + ")");
        if (c.output.empty()) throw UsageError("no output file (-o OUTPUT.exr)");
        c.settings.type = pick<SampleType>("--type", c.type, {{"half", SampleType::Half}, {"float", SampleType::Float}});
        c.settings.alpha = pick<AlphaMode>("--alpha", c.alpha,
                                           {{"associated", AlphaMode::Associated}, {"unassociated", AlphaMode::Unassociated}});
        c.settings.range = pick<RangePolicy>("--out-of-range", c.range,
                                             {{"clamp", RangePolicy::Clamp}, {"keep", RangePolicy::Keep}, {"error", RangePolicy::Error}});
        c.settings.nan = pick<NanPolicy>("--nan", c.nan, {{"replace", NanPolicy::Replace}, {"error", NanPolicy::Error}});
        try {
            c.settings.compression = ExrCompression::parse(c.compression);
        } catch (const Error& e) {
            throw UsageError(std::string("--compression: ") + e.what());
        }
        if (c.fit.objective != "smooth" && c.fit.objective != "norm")
            throw UsageError("--objective: '" + c.fit.objective + "' is not one of smooth, norm");
        if (c.wavelengths_file.empty()) {
            try {
                c.settings.grid = WavelengthGrid::parse(c.wavelengths);
            } catch (const Error& e) {
                throw UsageError(std::string("--wavelengths: ") + e.what());
            }
        }
    } catch (const UsageError& e) {
        return usage_error("bake", e.what());
    }

    const std::string& input = inputs[0];
    try {
        c.settings.data_dir = find_data_dir();
        if (!c.wavelengths_file.empty()) c.settings.grid = WavelengthGrid::from_file(c.wavelengths_file);
        c.settings.observer = c.fit.observer;
        c.settings.illuminant = c.fit.illuminant;
        if (c.basis == "fit") {
            c.fit.data_dir = c.settings.data_dir;
            c.fit.grid = c.settings.grid;
            FitResult fit = fit_basis_for(c.fit);
            c.settings.basis = fit.basis;
            c.settings.basis_source = "fitted by spectex: " + c.fit.describe();
        } else {
            c.settings.basis = load_basis(c.settings.data_dir, c.basis);
            c.settings.basis_source = c.basis == "mallett2019" ? "published table (Mallett & Yuksel 2019)" : "file";
            // A given basis is exact for the conditions it was made for; the default ones are recorded.
            if (c.basis == "mallett2019") c.settings.observer = "cie1931-2", c.settings.illuminant = "D65";
            WavelengthGrid basis_grid = WavelengthGrid::from_list(c.settings.basis.lambda);
            if (!same_wavelengths(c.settings.grid.lambda, basis_grid.lambda))
                throw Error("basis " + c.basis + " is on " + basis_grid.describe() + ", not on the output grid " +
                            c.settings.grid.describe() + " (the default --basis fit works on any grid)");
        }
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }
    c.settings.command_line = command_line;
    unsigned hw = std::max(1u, std::thread::hardware_concurrency());
    int threads = c.threads > 0 ? c.threads : static_cast<int>(hw);
    Imf::setGlobalThreadCount(threads);
    OIIO::attribute("threads", threads);

    try {
        BakeResult r = bake_file(input, c.output, c.settings);
        if (!c.quiet) {
            for (const auto& n : r.notes) std::cerr << "spectex: " << input << ": note: " << n << "\n";
            if (r.clamped_pixels)
                std::cerr << "spectex: " << input << ": " << r.clamped_pixels
                          << " pixels had linear values outside [0, 1] and were clamped\n";
            if (r.replaced_pixels)
                std::cerr << "spectex: " << input << ": " << r.replaced_pixels
                          << " pixels had NaN/Inf values replaced with 0\n";
        }
        if (c.verbose)
            std::cerr << "spectex: " << input << " -> " << r.output << ": " << r.pixels << " pixels, " << r.bins
                      << " bins, colour space '" << r.colorspace << "' (" << r.colorspace_how << "), "
                      << r.bytes << " bytes, " << r.seconds << " s\n";
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    } catch (const std::exception& e) {
        print_error(input + ": " + e.what());
        return 1;
    }
    return 0;
}

}  // namespace spectex
