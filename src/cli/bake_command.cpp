#include <OpenEXR/ImfThreading.h>
#include <OpenImageIO/imageio.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <algorithm>
#include <iostream>
#include <thread>

#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "io/data_dir.h"
#include "io/library_stderr.h"
#include "io/atomic_file.h"
#include "pipeline/bake.h"
#include "pipeline/basis_cache.h"
#include "pipeline/batch.h"
#include "cli/batch_runner.h"
#include "spectral/error.h"

namespace spectex {

namespace {

struct BakeCli {
    std::string output, basis = "fit", wavelengths = "380:780:5", type = "half", compression = "zip";
    std::string alpha = "associated", range = "clamp", nan = "replace";
    std::string wavelengths_file;
    FitSpec fit;
    std::string output_dir, from_list, json, shard;
    int threads = 0, jobs = 1;
    bool quiet = false, verbose = false, progress = false, update = false, force = false, fail_fast = false;
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
    ArgParser p("bake", "spectex bake [options] INPUT... (-o OUTPUT.exr | -o TEMPLATE | --output-dir DIR)",
                "Turns textures into spectral reflectance OpenEXRs (Fichet 2021 layout, channels\n"
                "T.<wavelength>nm): read with OpenImageIO, linearise with OpenColorIO, expand each pixel\n"
                "with the spectral primary decomposition (Mallett & Yuksel 2019). Inputs may hold <UDIM> or\n"
                "<UVTILE>, expanded to the existing tiles. Exit status 0 only when every file succeeded.");
    p.section("Output");
    p.option("-o, --output", "FILE|TEMPLATE",
             "Output OpenEXR file, or a template with {dir}, {stem}, {ext} (e.g. '{dir}/{stem}.spectral.exr') "
             "for several inputs. Written atomically; never the input.",
             [&](const std::string& v) { c.output = v; });
    p.option("--output-dir", "DIR", "Write <DIR>/<stem>.exr for every input (or -o TEMPLATE inside DIR).",
             [&](const std::string& v) { c.output_dir = v; });
    p.option("--type", "half|float", "Sample type of the spectral channels (default half).",
             [&](const std::string& v) { c.type = v; });
    p.option("--compression", "NAME",
             "none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa or dwab (default zip).",
             [&](const std::string& v) { c.compression = v; });
    p.option("--zip-level", "L",
             "Deflate level of zip and zips, 1 (fastest) to 12 (smallest); default 4. Level 1 took 0.6x the "
             "CPU time of 4 for files about 5 % larger; 6 took 1.7x for 0.5 % smaller (see README).",
             [&](const std::string& v) {
                 char* end = nullptr;
                 long l = std::strtol(v.c_str(), &end, 10);
                 if (v.empty() || *end || l < 1 || l > 12)
                     throw UsageError("--zip-level: '" + v + "' is not a level from 1 to 12");
                 c.settings.zip_level = static_cast<int>(l);
             });
    p.flag("--preview", "Also write R, G, B channels (linear Rec.709) for image viewers.",
           [&] { c.settings.preview = true; });
    p.option("--tile", "W[xH]", "Write a tiled file with W x H tiles (maketx's default is 64x64).",
             [&](const std::string& v) {
                 int w = 0, h = 0;
                 char x = 0, extra = 0;
                 int got = std::sscanf(v.c_str(), "%d%c%d%c", &w, &x, &h, &extra);
                 if (got == 1) h = w;
                 if (!((got == 1) || (got == 3 && x == 'x')) || w < 1 || h < 1 || w > 4096 || h > 4096)
                     throw UsageError("--tile: '" + v + "' is not W or WxH with sizes from 1 to 4096");
                 c.settings.tile_width = w;
                 c.settings.tile_height = h;
             });
    p.flag("--mipmap", "Write a MIP-mapped tiled texture (64x64 tiles unless --tile) for renderers' texture systems; "
                       "levels are filtered on linear RGB before expansion.",
           [&] { c.settings.mipmap = true; });
    p.option("--half-rounding", "colour|nearest",
             "colour (default): round each half bin up or down so that the spectrum's integrated colour stays "
             "closest to the exact one (all 8-bit sRGB colours re-encode exactly); nearest: plain rounding.",
             [&](const std::string& v) {
                 if (v != "colour" && v != "nearest") throw UsageError("--half-rounding: '" + v + "' is not one of colour, nearest");
                 c.settings.colour_rounding = v == "colour";
             });
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
    p.section("Batches");
    p.option("--from-list", "FILE", "Read input paths from FILE, one per line ('-' = stdin), after those given.",
             [&](const std::string& v) { c.from_list = v; });
    p.option("--jobs", "N", "Bake N files at once (default 1); with --threads, N x threads in all.",
             [&](const std::string& v) { c.jobs = parse_int("--jobs", v, 1, 256); });
    p.option("--shard", "K/N",
             "Bake only file i (0-based, in the byte-sorted, tile-expanded input list) with i mod N = K-1.",
             [&](const std::string& v) { c.shard = v; });
    p.flag("--update", "Skip files whose output is newer than the input and was made with the same settings.",
           [&] { c.update = true; });
    p.flag("--force", "Rebuild every file even with --update.", [&] { c.force = true; });
    p.flag("--fail-fast", "Stop at the first failed file (default: bake the others and fail at the end).",
           [&] { c.fail_fast = true; });
    p.option("--json", "FILE", "Write one JSON record per file (JSON Lines, schema_version 1); '-' = stdout.",
             [&](const std::string& v) { c.json = v; });
    p.flag("--progress", "Show progress on stderr even when it is not a terminal.", [&] { c.progress = true; });
    p.section("Resources");
    p.option("--threads", "N", "Threads per file for OpenEXR compression and decoding (default: cores / jobs).",
             [&](const std::string& v) { c.threads = parse_int("--threads", v, 0, 1024); });
    p.option("--max-pixels", "N", "Refuse inputs with more pixels than this (default 268435456 = 16384^2).",
             [&](const std::string& v) { c.settings.max_pixels = parse_count("--max-pixels", v); });
    p.flag("-q, --quiet", "Print errors only.", [&] { c.quiet = true; });
    p.flag("-v, --verbose", "Print what was done for each file.", [&] { c.verbose = true; });

    std::vector<std::string> inputs;
    try {
        if (p.parse_or_help(args, inputs)) return 0;
        if (inputs.empty() && c.from_list.empty()) throw UsageError("no input file");
        if (c.output.empty() && c.output_dir.empty()) throw UsageError("no output (-o OUTPUT.exr, -o TEMPLATE or --output-dir DIR)");
        if (!c.shard.empty()) {
            try {
                Shard::parse(c.shard);
            } catch (const Error& e) {
                throw UsageError(e.what());
            }
        }
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
        // Reads the colour config (checked: a regular file of bounded size), so inside the try.
        c.settings.command_line = command_line;
        c.settings.settings_hash = settings_hash(c.settings);
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }

    BatchPlan plan;
    try {
        // --output-dir is created (with its parents) when missing, like mkdir -p.
        if (!c.output_dir.empty()) {
            std::string partial;
            for (size_t pos = 0; pos != std::string::npos;) {
                pos = c.output_dir.find('/', pos + 1);
                partial = c.output_dir.substr(0, pos);
                if (!partial.empty() && ::mkdir(partial.c_str(), 0777) != 0 && errno != EEXIST)
                    throw Error(c.output_dir + ": cannot create the output folder: " + std::strerror(errno));
            }
        }
        std::vector<std::string> listed = inputs;
        if (!c.from_list.empty()) {
            auto more = read_list(c.from_list);
            if (more.empty() && inputs.empty())
                throw Error((c.from_list == "-" ? std::string("standard input (--from-list -)") : c.from_list) +
                            ": the input list names no files, and no input was given");
            listed.insert(listed.end(), more.begin(), more.end());
        }
        std::vector<std::string> expanded;
        for (const auto& in : listed) {
            auto tiles = expand_tiles(in);
            expanded.insert(expanded.end(), tiles.begin(), tiles.end());
        }
        std::sort(expanded.begin(), expanded.end());
        expanded.erase(std::unique(expanded.begin(), expanded.end()), expanded.end());
        if (expanded.size() > 1 && c.output_dir.empty() && !has_template_tokens(c.output))
            throw UsageError("several inputs need --output-dir DIR or an -o template with {stem}");
        if (!c.shard.empty()) expanded = select_shard(expanded, Shard::parse(c.shard));
        for (const auto& in : expanded)
            plan.files.push_back({in, c.output_dir.empty() && !has_template_tokens(c.output)
                                          ? c.output
                                          : output_for(in, c.output, c.output_dir)});
    } catch (const UsageError& e) {
        return usage_error("bake", e.what());
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }

    unsigned hw = std::max(1u, std::thread::hardware_concurrency());
    plan.jobs = c.jobs;
    plan.threads = c.threads > 0 ? c.threads : std::max(1, static_cast<int>(hw) / c.jobs);
    // OpenEXR's pool is global to the process: size it for all jobs together.
    Imf::setGlobalThreadCount(plan.jobs * plan.threads);
    OIIO::attribute("threads", plan.threads);
    c.settings.threads = plan.threads;
    plan.update = c.update && !c.force;
    plan.fail_fast = c.fail_fast;
    plan.quiet = c.quiet;
    plan.verbose = c.verbose;
    plan.progress = c.progress || (!c.quiet && stderr_is_terminal());
    plan.json = c.json;
    return run_batch(plan, c.settings);
}

}  // namespace spectex
