#include "cli/bake_options.h"

#include <filesystem>
#include <set>

#include "base/error.h"
#include "base/text.h"
#include "cli/commands.h"
#include "io/atomic_file.h"
#include "io/exr_compression.h"
#include "io/library_stderr.h"
#include "pipeline/batch_files.h"
#include "pipeline/light_list.h"
#include "pipeline/plan.h"

namespace spectex {

namespace {

template <typename T>
T pick(const std::string& option, const std::string& value,
       std::initializer_list<std::pair<const char*, T>> choices) {
    std::string list;
    for (const auto& [name, v] : choices) {
        if (same_word(value, name)) return v;
        list += (list.empty() ? "" : ", ") + std::string(name);
    }
    throw UsageError(option + ": '" + value + "' is not one of " + list);
}

// The value an enum's table (base/enum_names.h) gives `value`; a usage error listing its words.
template <typename E, size_t N>
E pick_name(const std::string& option, const std::string& value, const EnumNames<E, N>& names) {
    if (const auto v = names.find(value)) return *v;
    throw UsageError(option + ": '" + value + "' is not one of " + names.list());
}

bool ends_with_exr(const std::string& s) { return ends_with_nocase(s, ".exr"); }

// Something that is not a folder (links followed): a file, a device, a FIFO...
bool exists_not_directory(const std::string& p) {
    std::error_code ec;
    const std::filesystem::file_status st = std::filesystem::status(p, ec);
    return std::filesystem::exists(st) && !std::filesystem::is_directory(st);
}

// What -o and --output-dir name, checked before any work (exit 2): a folder, a name without .exr
// (the file is an OpenEXR whatever it is called) and unknown template tokens are mistakes.
void check_output_option(const std::string& output, const std::string& output_dir) {
    std::string tokens;
    for (const auto& t : template_tokens()) tokens += (tokens.empty() ? "" : ", ") + t;
    if (!output.empty()) {
        if (std::string bad = unknown_template_token(output); !bad.empty())
            throw UsageError("-o: unknown template token '" + bad + "' in '" + output +
                             "' (tokens: " + tokens + ")");
        if (output.back() == '/' || is_directory(output))
            throw UsageError("-o: '" + output +
                             "' is a folder; give a file name, or use --output-dir DIR");
        const bool templ = has_template_tokens(output);
        if (!ends_with_exr(output) && (templ || output_dir.empty()))
            throw UsageError("-o: '" + output +
                             "' does not end in .exr; spectex writes OpenEXR files");
    }
    if (!output_dir.empty()) {
        if (std::string bad = unknown_template_token(output_dir);
            !bad.empty() || has_template_tokens(output_dir))
            throw UsageError("--output-dir: '" + output_dir +
                             "' is a folder, not a template (tokens go in -o)");
        if (exists_not_directory(output_dir))
            throw UsageError("--output-dir: '" + output_dir + "' exists and is not a folder");
    }
}

void declare_output_options(ArgParser& p, BakeCli& c) {
    p.section("Output file");
    p.option("-o, --output", "FILE|TEMPLATE",
             "Output OpenEXR file, or a template with {dir}, {reldir} (with --base-dir), {stem}, "
             "{ext} (e.g. "
             "'{dir}/{stem}.spectral.exr') for several inputs; a template's folders are created. "
             "Written "
             "atomically; never the input.",
             [&](const std::string& v) { c.output = v; });
    p.option("--output-dir", "DIR",
             "Write <DIR>/<stem>.exr for every input (or -o TEMPLATE inside DIR); with --base-dir, "
             "<DIR>/{reldir}/<stem>.exr: the tree mirrored. Folders are created as needed.",
             [&](const std::string& v) { c.output_dir = v; });
    p.option("--base-dir", "DIR",
             "The top of an asset tree: {reldir} is an input's folder relative to DIR, and inputs "
             "outside "
             "DIR are refused.",
             [&](const std::string& v) { c.base_dir = v; });
    p.option("--type", "half|float", "Sample type of the spectral channels (default half).",
             [&](const std::string& v) { c.type = v; });
    p.option("--compression", "NAME",
             ExrCompression::list(", ", " or ") + " (default " + c.compression +
                 "). A lossy one (it changes samples of the --type written) is refused unless "
                 "--allow-lossy.",
             [&](const std::string& v) { c.compression = v; });
    p.flag("--allow-lossy",
           "Accept a lossy --compression: samples may leave [0, 1] and colours change, the file "
           "records spectex:lossyCompression and verify's failures name it.",
           [&] { c.allow_lossy = true; });
    p.option(
        "--zip-level", "L",
        "Deflate level of zip and zips, 1 (fastest) to 12 (smallest); default 4, or for the "
        "default bake by size: 6 for a file of at most 512x512 pixels (start-up, not deflate, "
        "is most of its time), else 1 (deflate is most of a large file's). Level 1 took 0.6x the "
        "CPU time of 4 for files about 5 % larger (10 % with --precision auto, whose zeroed low "
        "bits slow level 4 down); 6 took 1.7x for 0.5 % smaller (docs/performance.md).",
        [&](const std::string& v) {
            long long l = 0;
            if (!parse_whole(v, 1, 12, &l))
                throw UsageError("--zip-level: '" + v + "' is not a level from 1 to 12");
            c.req.options.zip_level = static_cast<int>(l);
            c.zip_level_given = true;
        });
    p.flag("--preview", "Also write R, G, B channels (linear Rec.709) for image viewers.",
           [&] { c.req.options.preview = true; });
    p.option(
        "--tile", "W[xH]", "Write a tiled file with W x H tiles (maketx's default is 64x64).",
        [&](const std::string& v) {
            const size_t x = v.find('x');
            long long w = 0, h = 0;
            const bool ok = v[0] != '-' && parse_whole(v.substr(0, x), 1, 4096, &w) &&
                            (x == std::string::npos ? (h = w, true)
                                                    : parse_whole(v.substr(x + 1), 1, 4096, &h));
            if (!ok)
                throw UsageError("--tile: '" + v + "' is not W or WxH with sizes from 1 to 4096");
            c.req.options.tile_width = static_cast<int>(w);
            c.req.options.tile_height = static_cast<int>(h);
        });
    p.flag("--mipmap",
           "Write a MIP-mapped tiled texture (64x64 tiles unless --tile) for renderers' texture "
           "systems; "
           "levels are filtered on linear RGB before expansion.",
           [&] { c.req.options.mipmap = true; });
    p.option("--wrap", "MODE[,MODE]",
             "Record the texture wrap mode, maketx's: black, clamp, periodic or mirror, one for "
             "both directions or s,t (e.g. periodic,clamp); written as the wrapmodes attribute "
             "OpenImageIO's texture system reads. Tiled outputs record black,black without it, "
             "scanline ones nothing. It changes no pixel (MIP levels are box-filtered inside the "
             "image whatever the mode).",
             [&](const std::string& v) {
                 c.wrap = v;
                 c.wrap_given = true;
             });
    p.option("--swrap", "MODE", "The wrap mode in s (horizontally) only, as maketx's --swrap.",
             [&](const std::string& v) {
                 c.swrap = v;
                 c.swrap_given = true;
             });
    p.option("--twrap", "MODE", "The wrap mode in t (vertically) only, as maketx's --twrap.",
             [&](const std::string& v) {
                 c.twrap = v;
                 c.twrap_given = true;
             });
    p.option("--half-rounding", "colour|nearest",
             "colour (default): round each half bin up or down so that the spectrum's integrated "
             "colour stays "
             "closest to the exact one (all 8-bit sRGB colours re-encode exactly); nearest: plain "
             "rounding.",
             [&](const std::string& v) {
                 c.req.options.colour_rounding =
                     parse_word("--half-rounding", v, {"colour", "nearest"}) == "colour";
             });
    p.option("--precision", "full|auto",
             "Half's mantissa bits per bin. full: all 10 in every bin. auto (the default without "
             "--method, where the output is half, colour-rounded and compressed losslessly, "
             "deflated by size unless --zip-level is given; else full): under "
             "D65,A,FL2,FL11,D50,LED-B3 within 0.5 "
             "unless --lights or --max-de are given, whatever the method; per bin, "
             "the fewest that keep the worst ΔE00 between the file's spectra as a renderer sees "
             "them and the method's own spectrum at 1 nm (the grid's error and the rounding "
             "together) within --precision-de (default --max-de) under every one of --lights and "
             "the light "
             "the method is exact for, on every 8-bit colour; the colour-aware "
             "rounding keeps every 8-bit colour's code under that light (smaller ZIP files; "
             "recorded as spectex:precision*; half only). The bits are kept in the cache for the "
             "next bake with the same settings (see --no-cache); the default's ship with spectex.",
             [&](const std::string& v) {
                 c.precision = parse_word("--precision", v, {"full", "auto"});
                 c.precision_given = true;
             });
    p.option("--precision-de", "DE",
             "The budget of --precision auto when it differs from --max-de (the grid's budget "
             "with --wavelengths auto): the worst ΔE00 of the file against the method at 1 nm.",
             [&](const std::string& v) {
                 c.precision_de = parse_budget_de("--precision-de", v);
                 c.precision_de_given = true;
             });
    p.option("--alpha", "associated|unassociated",
             "Whether the spectral channels are premultiplied by A (default associated, OpenEXR's "
             "convention).",
             [&](const std::string& v) { c.alpha = v; });
}

void declare_colour_options(ArgParser& p, BakeCli& c) {
    p.section("Colour");
    p.option(
        "--colorspace", "NAME",
        "Colour space of the input (an OCIO name or alias, e.g. srgb_tx, lin_srgb, acescg, raw). "
        "Default: what the file states (its ICC profile, OpenEXR chromaticities, a tag such as "
        "PNG's sRGB chunk) when the config can name it, else the config's file rules; a profile "
        "it cannot name is a warning.",
        [&](const std::string& v) { c.req.options.colorspace = v; });
    p.option("--config", "FILE",
             "OCIO config to use instead of $OCIO or the shipped config/spectex.ocio.",
             [&](const std::string& v) { c.req.options.config = v; });
    p.option("--out-of-range", "clamp|keep|error",
             "Linear values outside [0, 1]: clamp per channel (default), keep (spectra may leave "
             "[0, 1]; in half, a value beyond 65504 fails the file), or fail.",
             [&](const std::string& v) { c.range = v; });
    p.option("--nan", "replace|error", "NaN and infinite values: replace with 0 (default) or fail.",
             [&](const std::string& v) { c.nan = v; });
}

void declare_spectra_options(ArgParser& p, BakeCli& c) {
    p.section("Wavelength grid");
    p.option("--wavelengths", "START:END:STEP|auto",
             "Output wavelength grid in nm (default 400:700:10 for the default bake, the bins its "
             "lights need,\nand auto when --lights or --max-de make it a scene's; 380:780:5 with "
             "--method, and the way to\nthe default's grid before; at most 4701 bins, 0.1 nm "
             "over 360:830: more is a usage error; a grid\nfiner than 1 nm over 360:830 says what "
             "it costs first). auto: the cheapest grid within --max-de\nunder every one of "
             "--lights (the default's for the one not given), chosen once per batch as\n'spectex "
             "plan' does, with --precision auto's bits (recorded in the header; the answer is kept "
             "in\nthe cache for the next run and shard, see --no-cache).",
             [&](const std::string& v) {
                 c.wavelengths = same_word(v, "auto") ? "auto" : v;
                 c.wavelengths_given = true;
             });
    p.option("--wavelengths-file", "FILE",
             "Output wavelengths, one per line (any strictly increasing list, at most 4701).",
             [&](const std::string& v) { c.wavelengths_file = v; });
    add_plan_options(p, c.req.plan, c.plan_lights, c.plan_budget, false);
    add_cache_option(p, c.no_cache);
    p.section("Method");
    add_method_options(
        p, c.m, true,
        "Default: the lattice with --vertex-prior lhtss, in half with --precision auto (see "
        "there); an option of one method without --method (--basis, --lattice-size...) takes "
        "that method, at full precision.");
    observer_option(p, "Observer of the fitted basis", c.m.spec.fit.observer);
    p.option("--illuminant", "NAME|FILE",
             "Illuminant under which the fitted basis is exact: " +
                 shipped_illuminants_list(FitSpec().illuminant) + " (any case), " +
                 colour_temperature_help() + ", or a CSV wavelength,value.",
             [&](const std::string& v) { c.m.spec.fit.illuminant = v; });
}

void declare_batch_options(ArgParser& p, BakeCli& c) {
    p.section("Batches and farms");
    p.option("--from-list", "FILE",
             "Read input paths from FILE, one per line ('-' = stdin; a pipe such as <(find ...) "
             "too), after those given.",
             [&](const std::string& v) { c.from_list = v; });
    p.option("--jobs", "N",
             "Bake N files at once (default 1, at most the number of files); with --threads, N x "
             "threads in all.",
             [&](const std::string& v) { c.jobs = parse_int("--jobs", v, 1, 256); });
    p.option("--shard", "K/N",
             "Bake only file i (0-based, in the byte-sorted, tile-expanded input list) with i mod "
             "N = K-1 (K, N whole numbers from 1 to 10^9).",
             [&](const std::string& v) { c.shard = v; });
    p.flag("-n, --dry-run",
           "List each input -> output and what this command would do with it (bake, skip as up "
           "to date with --update, fail, and why; without --update, whether --update would skip "
           "it), on stdout, after the same checks as a real run (usage, collisions: exit 2; a "
           "file that would fail: exit 1). Reads headers only: no pixel is decoded, the method "
           "is not built, and nothing is written or created but the --json report.",
           [&] { c.dry_run = true; });
    p.flag("--update",
           "Skip files whose output was made from this same source (size, modification time, "
           "content hash) with the same settings and the same colour transform (what the OCIO "
           "config does to the file, spectex:colorTransform: a comment in the config rebuilds "
           "nothing).",
           [&] { c.update = true; });
    p.flag("--force", "Rebuild every file even with --update.", [&] { c.force = true; });
    p.flag("--fail-fast",
           "Stop at the first failed file (default: bake the others and fail at the end).",
           [&] { c.fail_fast = true; });
    p.option("--json", "FILE",
             "Write one JSON record per file (JSON Lines, schema_version " +
                 std::to_string(kJsonSchemaVersion) +
                 "); '-' = stdout; a stream such as "
                 "/dev/stderr is written through.",
             [&](const std::string& v) { c.json = stdout_as_dash(v); });
    p.flag("--progress",
           "Show progress on stderr even when it is not a terminal (and that of --wavelengths "
           "auto's search).",
           [&] { c.progress = true; });
    p.section("Resources");
    p.option("--threads", "N",
             "Threads per file for OpenEXR compression and decoding (default: cores / jobs). "
             "--jobs x --threads\nis held within the process's thread budget, 4 threads per "
             "core (at least 8): more only share\nthe same cores, and the kernel limits the "
             "threads of a process.",
             [&](const std::string& v) { c.threads = parse_int("--threads", v, 0, 1024); });
    p.option(
        "--max-pixels", "N",
        "Refuse inputs with more pixels than this (default 268435456 = 16384^2).",
        [&](const std::string& v) { c.req.options.max_pixels = parse_count("--max-pixels", v); });
    p.flag("-q, --quiet",
           "Print errors and warnings about the data only (clamped or replaced pixels, a level "
           "or subimage left out, a colour space chosen by a config's default rule).",
           [&] { c.quiet = true; });
    p.flag("-v, --verbose", "Print what was done for each file.", [&] { c.verbose = true; });
}

// What must be given, and what goes with what (throws UsageError).
void check_given_options(const BakeCli& c, const std::vector<std::string>& inputs) {
    if (inputs.empty() && c.from_list.empty()) throw UsageError("no input file");
    if (c.output.empty() && c.output_dir.empty())
        throw UsageError("no output (-o OUTPUT.exr, -o TEMPLATE or --output-dir DIR)");
    check_output_option(c.output, c.output_dir);
    if (!c.shard.empty()) {
        try {
            Shard::parse(c.shard);
        } catch (const Error& e) {
            throw UsageError(e.what());
        }
    }
}

// One of maketx's wrap modes, in any case, as maketx writes it (lower case). Throws UsageError
// naming the option.
std::string wrap_mode(const std::string& option, const std::string& value) {
    const std::string m = lower_ascii(value);
    for (const char* known : {"black", "clamp", "periodic", "mirror"})
        if (m == known) return m;
    throw UsageError(option + ": '" + value +
                     "' is not a wrap mode (black, clamp, periodic or mirror)");
}

// --wrap MODE[,MODE], --swrap, --twrap as the "s,t" maketx records (--swrap and --twrap over
// --wrap, a direction given no mode black); "" when none was given. Throws UsageError.
std::string wrap_modes(const BakeCli& c) {
    if (!c.wrap_given && !c.swrap_given && !c.twrap_given) return "";
    std::string s = "black", t = "black";
    if (c.wrap_given) {
        const size_t comma = c.wrap.find(',');
        s = wrap_mode("--wrap", c.wrap.substr(0, comma));
        t = comma == std::string::npos ? s : wrap_mode("--wrap", c.wrap.substr(comma + 1));
    }
    if (c.swrap_given) s = wrap_mode("--swrap", c.swrap);
    if (c.twrap_given) t = wrap_mode("--twrap", c.twrap);
    return s + "," + t;
}

// Sample type, alpha, range and NaN policies, compression; the options of each method.
void check_method_options(BakeCli& c) {
    c.req.options.wrapmodes = wrap_modes(c);
    c.req.options.type = pick<SampleType>(
        "--type", c.type, {{"half", SampleType::Half}, {"float", SampleType::Float}});
    c.req.options.alpha =
        pick<AlphaKind>("--alpha", c.alpha,
                        {{to_string(AlphaKind::Associated), AlphaKind::Associated},
                         {to_string(AlphaKind::Unassociated), AlphaKind::Unassociated}});
    c.req.options.range = pick_name("--out-of-range", c.range, kRangePolicyNames);
    c.req.options.nan = pick_name("--nan", c.nan, kNanPolicyNames);
    // Taken in any case; compared below, recorded and reported as their lower-case words.
    c.type = lower_ascii(c.type);
    c.alpha = lower_ascii(c.alpha);
    c.range = lower_ascii(c.range);
    c.nan = lower_ascii(c.nan);
    try {
        c.req.options.compression = ExrCompression::parse(c.compression);
    } catch (const Error& e) {
        throw UsageError(std::string("--compression: ") + e.what());
    }
    const ExrCompression& z = c.req.options.compression;
    if (z.lossy_for(c.req.options.type == SampleType::Half) && !c.allow_lossy)
        throw UsageError("--compression: " + z.name + " is " + z.lossy_text() +
                         ": OpenEXR changes " + c.type +
                         " samples with it (values leave [0, 1], colours shift); use a lossless "
                         "one (" +
                         ExrCompression::lossless_list(", ", " or ") +
                         "), or add --allow-lossy to accept the loss");
    // Without --method: bake's default, unless an option says which method (one of its own, or
    // --out-of-range keep and --nonuniform, which only the basis takes).
    c.default_bake = resolve_method(c.m, c.range == "keep" || c.req.plan.nonuniform);
    check_method_options(c.m);
    const MethodRow& row = method_row(c.m.spec.kind);
    if (!row.takes_out_of_range && c.range == "keep")
        throw UsageError("--out-of-range keep needs a method defined outside [0, 1] (--method " +
                         method_table().front().name + "): " + method_words(c.m) +
                         " is defined on linear RGB in [0, 1] only");
}

// --precision not given: full, but for the default bake where a budget can be kept and pays (half,
// the colour-aware rounding, a compression that keeps the samples): auto. The default bake's budget
// is under DefaultBake's lights and within its ΔE00 unless --lights or --max-de say otherwise,
// deflated at DefaultBake's level unless --zip-level says.
void resolve_precision(BakeCli& c) {
    if (!c.precision_given) {
        // Zeroed low bits are smaller only where a compression keeps the samples and sees them.
        const ExrCompression& z = c.req.options.compression;
        const bool keeps = c.type == "half" && c.req.options.colour_rounding && z.name != "none" &&
                           !z.lossy_for(true);
        c.precision = c.default_bake && keeps ? "auto" : "full";
    }
    if (c.precision != "auto") return;
    // --precision auto's lights and budget are the default bake's unless given, whatever the
    // method: the same defaults whenever the same option is asked.
    if (!c.plan_lights) c.req.plan.lights = DefaultBake::lights();
    if (!c.plan_budget) c.req.plan.max_de = DefaultBake::max_de;
    if (c.default_bake && !c.zip_level_given) c.req.options.zip_level = DefaultBake::zip_level;
}

// --precision auto: half, colour-rounded.
void check_precision_options(const BakeCli& c) {
    if (c.precision != "auto") {
        if (c.precision_de_given) throw UsageError("--precision-de belongs to --precision auto");
        return;
    }
    if (c.type != "half")
        throw UsageError("--precision auto chooses bits of half; --type " + c.type +
                         " keeps every bit");
    if (!c.req.options.colour_rounding)
        throw UsageError(
            "--precision auto keeps every 8-bit code through the colour-aware rounding; "
            "--half-rounding nearest would lose them on the coarser grids");
    // Its lights and budget: given, or the default bake's (resolve_precision).
}

// The output grid: given, read from a file, or chosen by --wavelengths auto.
void check_grid_options(BakeCli& c) {
    resolve_precision(c);
    // The default bake for the user's scene (--lights or --max-de, no grid given): its grid is
    // the cheapest within the budget under those lights, planned as --wavelengths auto plans it
    // (cached, and the same for every task of a farm), as 400:700:10 is the default's for its own
    // lights. The one not given is the default's.
    const bool scene_default = c.default_bake && !c.wavelengths_given &&
                               c.wavelengths_file.empty() && (c.plan_lights || c.plan_budget);
    if (scene_default) {
        c.wavelengths = "auto";
        if (!c.plan_lights) c.req.plan.lights = DefaultBake::lights();
        if (!c.plan_budget) c.req.plan.max_de = DefaultBake::max_de;
    }
    const bool automatic = c.wavelengths == "auto";
    // Two grids: neither may win in silence.
    if (c.wavelengths_given && !c.wavelengths_file.empty())
        throw UsageError(std::string("--wavelengths") + (automatic ? " auto" : "") +
                         " and --wavelengths-file are two grids; give one");
    if (automatic) {
        if (!scene_default && (!c.plan_lights || !c.plan_budget))
            throw UsageError(
                "--wavelengths auto needs --lights and --max-de (the scene's lights and the "
                "error budget)");
        if (c.m.spec.kind == MethodKind::Basis && c.m.basis != "fit")
            throw UsageError("--wavelengths auto fits the basis on the chosen grid; --basis " +
                             c.m.basis + " has a grid of its own");
        if (c.req.plan.nonuniform && !method_row(c.m.spec.kind).linear)
            throw UsageError("--nonuniform searches with a linear method's 3x3 maps: " +
                             method_words(c.m) + " is not linear (use --method basis)");
    } else if (((c.plan_lights || c.plan_budget) && c.precision != "auto") ||
               !c.req.plan.candidates.empty() || c.req.plan.nonuniform) {
        throw UsageError(
            "--lights, --max-de, --grids and --nonuniform choose the grid of --wavelengths "
            "auto (--lights and --max-de also the bits of --precision auto)");
    }
    check_precision_options(c);
    // The default bake's grid unless one is given (the option's own default is the full grid the
    // other methods take).
    if (c.default_bake && !c.wavelengths_given && c.wavelengths_file.empty() && !automatic)
        c.wavelengths = DefaultBake::grid;
    if (c.wavelengths_file.empty() && !automatic) {
        try {
            c.req.grid = WavelengthGrid::parse_exact(c.wavelengths);
        } catch (const Error& e) {
            throw UsageError(std::string("--wavelengths: ") + e.what());
        }
    }
}

// The request's values that are not parsed into it directly: the method (its options and
// conditions, once all are read and checked) and the grid's and precision's requests.
void fill_request(BakeCli& c) {
    BakeRequest& r = c.req;
    r.method = c.m.spec;
    r.basis = c.m.basis;
    r.grid_given = c.wavelengths_given;
    r.grid_file = c.wavelengths_file;
    r.auto_grid = c.wavelengths == "auto";
    r.precision_auto = c.precision == "auto";
    r.precision_de = c.precision_de_given ? c.precision_de : 0;
    r.threads = c.threads;
    r.no_cache = c.no_cache;
    if (c.progress || (!c.quiet && stderr_is_terminal()))
        r.plan.progress = plan_progress("spectex: --wavelengths auto: ");
}

// What the options cost, refused before any work when over a documented limit: the method's
// table on the grid given (method_table.h), or with --wavelengths auto the plan (plan.h), its
// lights each once.
void check_cost_options(const BakeCli& c) {
    try {
        if (c.wavelengths == "auto") {
            check_plan_cost(bake_plan_spec(c.req));
        } else if (c.wavelengths_file.empty()) {
            check_method_cost(c.m.spec, c.req.grid.size(),
                              std::to_string(c.req.grid.size()) + " bins");
        }
    } catch (const LimitError& e) {
        throw UsageError(e.what());
    }
}

// The options given that make each file what it is, shell-quoted, each after a space, for the
// command line each output records (file_command_line): every option but those that list, name,
// select, skip or report the batch's files, or only say how much to print. The one input and its
// output take the place of the batch's.
std::string file_options(const std::vector<ArgParser::Given>& given) {
    static const std::set<std::string> batch_only = {
        "--output", "--output-dir", "--base-dir",  "--from-list", "--shard", "--jobs",    "--json",
        "--update", "--force",      "--fail-fast", "--progress",  "--quiet", "--verbose", "--help"};
    std::string out;
    for (const auto& g : given) {
        if (batch_only.count(g.name)) continue;
        out += " " + quote_path(g.name);
        if (g.has_value) out += " " + quote_path(g.value);
    }
    return out;
}

}  // namespace

void declare_bake_options(ArgParser& p, BakeCli& c) {
    declare_output_options(p, c);
    declare_colour_options(p, c);
    declare_spectra_options(p, c);
    declare_batch_options(p, c);
    // What most runs set; everything else is in the sections by task below them.
    p.common({"--output", "--output-dir", "--colorspace", "--method", "--wavelengths", "--type",
              "--update", "--jobs", "--json", "--quiet", "--verbose", "--help"});
}

bool is_directory(const std::string& p) {
    std::error_code ec;
    return std::filesystem::is_directory(p, ec);
}

void check_bake_options(BakeCli& c, const std::vector<std::string>& inputs,
                        const std::vector<ArgParser::Given>& given) {
    check_given_options(c, inputs);
    check_method_options(c);
    check_conditions(c.m.spec, c.req.plan.lights);
    check_grid_options(c);
    fill_request(c);
    check_cost_options(c);
    c.req.options.file_options = file_options(given);
}

}  // namespace spectex
