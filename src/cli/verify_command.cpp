// spectex verify: measure a spectral OpenEXR, alone or against the image it was baked from.
#include <OpenEXR/ImfThreading.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "base/error.h"
#include "base/task_pool.h"
#include "base/text.h"
#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "cli/output_check.h"
#include "io/atomic_file.h"
#include "io/data_dir.h"
#include "io/file_identity.h"
#include "io/image_library.h"
#include "io/linearizer.h"
#include "io/ocio_config.h"
#include "io/provenance_keys.h"
#include "io/spectral_exr_info.h"
#include "pipeline/batch_files.h"
#include "pipeline/light_list.h"
#include "pipeline/method_table.h"
#include "pipeline/verify.h"
#include "pipeline/verify_json.h"
#include "spectral/precision.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

std::string num(double v, const char* fmt = "%.6g") { return number_text(v, fmt); }
std::string percent(uint64_t count, uint64_t total) { return share_text(count, total); }

void print_text(const VerifyReport& r, const VerifyGates& g,
                const std::vector<std::string>& failures) {
    std::ostream& o = std::cout;
    o << r.file << "\n";
    o << "  size:                 " << r.width << " x " << r.height << " (" << r.pixels
      << " pixels)\n";
    o << "  wavelengths:          " << r.wavelengths << " nm, " << r.bins << " bins, "
      << format_wavelength(r.lambda_min) << "-" << format_wavelength(r.lambda_max) << " nm\n";
    o << "  samples:              " << r.sample_type << ", " << r.compression << ", " << r.storage
      << "\n";
    o << "  alpha:                "
      << (r.alpha == AlphaKind::None ? std::string("none")
                                     : std::string("A (") + to_string(r.alpha) + ")")
      << "\n";
    o << "  integrated under:     " << r.illuminant << ", observer " << r.observer << "\n";
    if (!r.method.empty()) o << "  method:               " << r.method << "\n";
    if (!r.precision.empty())
        o << "  precision:            " << r.precision << ": within " << r.precision_max_de
          << " ΔE00 of "
          << (r.precision_covers == kPrecisionCovers ? "the method's own spectrum at 1 nm"
                                                     : "the unrounded spectra")
          << " under " << r.precision_lights << " (recorded; worst " << r.precision_worst_de
          << "), codes exact under " << r.illuminant << "; mantissa bits per bin "
          << (r.precision_bits.empty() ? std::string("unreadable")
                                       : format_precision_bits(r.precision_bits))
          << "\n";
    // Associated alpha: the straight samples T/A, above 1 by more than each bin's rounding.
    const bool st = r.straight_range;
    o << (st ? "  T/A outside [0, 1]:   " : "  outside [0, 1]:       ")
      << r.below_zero + r.above_one << " samples ("
      << percent(r.below_zero + r.above_one, r.samples) << "): " << r.below_zero << " below 0, "
      << r.above_one << " above 1\n";
    o << (st ? "  beyond the rounding:  " : "  beyond 1e-6 of it:    ") << r.below_tol + r.above_tol
      << " samples (" << percent(r.below_tol + r.above_tol, r.samples) << "): " << r.below_tol
      << " below -1e-6, " << r.above_tol
      << (st ? " above 1 + the bin's step\n" : " above 1+1e-6\n");
    o << "  non-finite:           " << r.nonfinite << " samples ("
      << percent(r.nonfinite, r.samples) << ")\n";
    o << "  linear RGB range:     R " << num(r.rgb_min[0]) << " .. " << num(r.rgb_max[0]) << ", G "
      << num(r.rgb_min[1]) << " .. " << num(r.rgb_max[1]) << ", B " << num(r.rgb_min[2]) << " .. "
      << num(r.rgb_max[2]) << "\n";
    if (r.source_changed)
        o << "  source:               " << r.change.file << ": changed since this file was baked ("
          << r.change.why << "); colours not compared\n";
    if (r.compared) {
        o << "  source:               " << r.source << " ("
          << (r.source_float ? std::to_string(r.source_bits) + "-bit float"
                             : std::to_string(r.source_bits) + "-bit")
          << ", '" << r.source_colorspace << "' from " << r.source_colorspace_how << ")\n";
        o << "  compared pixels:      " << r.compared_pixels;
        if (r.transparent_pixels) o << " (" << r.transparent_pixels << " with A = 0 skipped)";
        if (r.nonfinite_pixels) o << " (" << r.nonfinite_pixels << " with a non-finite colour)";
        o << "\n";
        if (r.source_clamped || r.source_replaced)
            o << "  source clamped:       " << r.source_clamped << " pixels outside [0, 1]"
              << (r.source_clamped ? " (by up to " + num(r.source_clamped_excursion, "%.3g") + ")"
                                   : std::string())
              << ", " << r.source_replaced << " with NaN/Inf (bake's defaults)\n";
        o << "  linear RGB error:     max " << num(r.rgb_error_max) << " at (" << r.rgb_error_x
          << ", " << r.rgb_error_y << "), mean " << num(r.rgb_error_mean) << "\n";
        o << "  CIEDE2000:            max " << num(r.de_max) << " at (" << r.de_x << ", " << r.de_y
          << "), mean " << num(r.de_mean) << ", 99th percentile " << num(r.de_p99) << "\n";
        if (r.code_match_available)
            o << "  code match:           " << percent(r.code_matched, r.code_checked) << " ("
              << r.code_matched << " of " << r.code_checked << " pixels re-encode to their "
              << r.source_bits << "-bit codes"
              << (r.code_checked < r.compared_pixels ? "; pixels the bake clamped are not counted"
                                                     : "")
              << "; " << r.code_match_note << ")\n";
        else
            o << "  code match:           n/a (" << r.code_match_note << ")\n";
    }
    for (const auto& l : r.other_lights)
        o << "  under " << l.light << " (Bradford to " << r.illuminant
          << "'s white), CIEDE2000 from " << r.illuminant << ": mean " << num(l.de_mean)
          << ", 99th percentile " << num(l.de_p99) << ", max " << num(l.de_max) << " at (" << l.de_x
          << ", " << l.de_y << "); linear RGB R " << num(l.rgb_min[0]) << " .. "
          << num(l.rgb_max[0]) << ", G " << num(l.rgb_min[1]) << " .. " << num(l.rgb_max[1])
          << ", B " << num(l.rgb_min[2]) << " .. " << num(l.rgb_max[2])
          << " (reported, not gated)\n";
    o << "  time:                 " << num(r.seconds, "%.3f") << " s\n";
    if (g.report_only)
        o << "  gates:                none (--report-only)\n";
    else if (r.compared && !method_is_exact(r.method))
        o << "  gates:                colour gates off: " << r.method << " spectra are not exact\n";
    for (const auto& a : gates_applied(r, g)) o << "  gate:                 " << a << "\n";
    if (failures.empty() && r.source_changed)
        o << "  result:               STALE: " << stale_failure(r)
          << " (reported, not failed: --report-only)\n";
    else if (failures.empty())
        o << "  result:               ok\n";
    else
        for (const auto& f : failures)
            o << "  result:               " << (f == stale_failure(r) ? "STALE: " : "FAILED: ") << f
              << "\n";
}

// One line per file when several are verified.
void print_line(const VerifyReport& r, const std::vector<std::string>& failures) {
    std::ostringstream o;
    o << r.file << ": " << verify_result_word(r, failures);
    o << " (" << r.bins << " bins, " << r.sample_type;
    if (r.nonfinite) o << ", " << r.nonfinite << " non-finite";
    if (r.below_tol + r.above_tol) o << ", " << r.below_tol + r.above_tol << " outside [0, 1]";
    if (r.compared) {
        o << ", CIEDE2000 max " << num(r.de_max);
        if (r.code_match_available) o << ", codes " << percent(r.code_matched, r.code_checked);
    }
    for (const auto& l : r.other_lights)
        o << ", under " << l.light << " mean " << num(l.de_mean, "%.3g");
    o << ")";
    for (const auto& f : failures) o << "; " << f;
    std::cout << one_line(o.str()) << "\n";
}

constexpr const char* kVerifyDescription =
    "Reads reflective spectral OpenEXRs (Fichet 2021 layout, channels T.<wavelength>nm, from "
    "spectex\n"
    "or any other tool) a band of rows at a time, integrates every pixel under the light the "
    "file\n"
    "was baked for (spectex:illuminant, else D65) with its observer, on the file's own bins "
    "(linear\n"
    "Rec.709 through the white-consistent matrix; spectra premultiplied by A are divided by it "
    "unless\n"
    "spectex:alpha says 'unassociated'), and checks it. With --source, it compares every pixel "
    "with\n"
    "the source image, linearised as the file records (input colour space, OCIO config, "
    "out-of-range\n"
    "and NaN policies): linear RGB error, CIEDE2000 (L*a*b* relative to the light's white) and "
    "the\n"
    "share of pixels that re-encode to the source's 8- or 16-bit codes through the config's "
    "inverse\n"
    "transform. Options given override what the file records (a warning says so).\n"
    "Default gates (a correct bake passes them, --report-only turns them off): no non-finite "
    "sample;\n"
    "no sample more than 1e-6 outside [0, 1] unless the file records --out-of-range keep; with "
    "a\n"
    "source, CIEDE2000 max <= 0.5 and every unchanged pixel re-encoding to its 8-bit code "
    "(half or\n"
    "float; 99.99 % for half with plain rounding) or 16-bit code (float; in half, which cannot "
    "keep\n"
    "16-bit codes, linear RGB error <= 1e-4, 5e-4 with plain rounding; with the precision\n"
    "budget's coarser bits, the error beyond 2^-10 of the value <= 1e-4). Files baked with\n"
    "--method jakob-hanika (not exact) get no colour gates unless thresholds are given.\n"
    "A file whose source changed since the bake (its size or bytes differ from the header's\n"
    "spectex:sourceSize and spectex:sourceHash) is STALE: its colours are not compared, and it\n"
    "fails (the JSON record's \"result\" is \"stale\", \"passed\" false); with --report-only it "
    "is\n"
    "still STALE and not passed, but does not fail the exit status.\n"
    "Exit status: 0 every file passed, 1 a gate failed, a file was stale or could not be read, 2 "
    "usage error.";

// The command line of verify, parsed.
struct VerifyArgs {
    VerifySettings s;
    VerifyGates t;
    std::string json, from_list;
    bool source_from_header = false, quiet = false;
    int jobs = 1;
};

void declare_verify_options(ArgParser& p, VerifyArgs& a) {
    p.section("Inputs");
    p.option("--from-list", "FILE",
             "Read more files to verify from FILE, one per line ('-' = stdin).",
             [&](const std::string& v) { a.from_list = v; });
    p.section("Comparison");
    p.option("--source", "FILE",
             "The image the EXR was baked from (anything OpenImageIO reads); same size. One file.",
             [&](const std::string& v) { a.s.source = v; });
    p.flag("--source-from-header",
           "Compare each file with the source its header records (spectex:source); one whose "
           "size or bytes changed since the bake is STALE, not compared.",
           [&] { a.source_from_header = true; });
    p.option("--colorspace", "NAME",
             "Colour space of the source. Default: the file's spectex:inputColorSpace.",
             [&](const std::string& v) { a.s.colorspace = v; });
    p.option("--config", "FILE",
             "OCIO config for the source. Default: the file's spectex:config if unchanged.",
             [&](const std::string& v) { a.s.config = v; });
    p.section("Colorimetry");
    p.option("--check-illuminant", "NAME|FILE",
             "The light the file is checked under: the file's by default, else D65; the names "
             "listed below, or a colour temperature such as 3200K.",
             [&](const std::string& v) { a.s.illuminant = v; });
    list_option(
        p, "--illuminant", "NAME[,NAME...]",
        "Also report each pixel's colour under these lights (Bradford-adapted), next to the "
        "check light's;\n"
        "never gated. Repeatable; a light given twice (a name in any case, one CSV file) counts\n"
        "once. Names: " +
            shipped_illuminants_list("D65") + " (any case), " + colour_temperature_help() +
            ", or a CSV wavelength,value. About 100 KB of memory per light and\n"
            "measuring thread: past 1 GiB in all (some 10,000 lights on one thread) it is refused.",
        a.s.other_lights);
    p.option("--observer", "NAME|FILE",
             "Observer: the file's, else cie1931-2; cie1964-10, or a CSV wavelength,x,y,z.",
             [&](const std::string& v) { a.s.observer = v; });
    p.section("Gates (exit 1 when not met)");
    p.option("--max-de", "X", "Largest CIEDE2000 allowed (default 0.5; needs a source).",
             [&](const std::string& v) {
                 a.t.max_de = parse_number("--max-de", v);
                 if (!(a.t.max_de >= 0)) throw UsageError("--max-de: must be >= 0");
                 a.t.de = true;
             });
    p.option("--max-rgb-error", "X", "Largest absolute linear RGB error allowed (needs a source).",
             [&](const std::string& v) {
                 a.t.max_rgb = parse_number("--max-rgb-error", v);
                 if (!(a.t.max_rgb >= 0)) throw UsageError("--max-rgb-error: must be >= 0");
                 a.t.rgb = true;
             });
    p.option("--min-code-match", "PERCENT",
             "Smallest share of pixels, in percent, that re-encode to the source codes.",
             [&](const std::string& v) {
                 a.t.min_code = parse_number("--min-code-match", v);
                 if (!(a.t.min_code >= 0 && a.t.min_code <= 100))
                     throw UsageError("--min-code-match: must be in [0, 100]");
                 a.t.code = true;
             });
    p.flag("--report-only",
           "Measure and report, gate nothing (exit 0 unless a file cannot be read).",
           [&] { a.t.report_only = true; });
    p.section("Output");
    p.option(
        "--json", "FILE",
        "Write one JSON object per file (JSON Lines, schema_version 2) to FILE ('-' = stdout).",
        [&](const std::string& v) { a.json = stdout_as_dash(v); });
    p.flag("-q, --quiet", "Print nothing but errors and failed gates.", [&] { a.quiet = true; });
    p.option("--jobs", "N", "Verify N files at once (default 1, at most the number of files).",
             [&](const std::string& v) { a.jobs = parse_int("--jobs", v, 1, 256); });
    p.option(
        "--threads", "N",
        "Threads measuring pixels per file (default: cores / jobs); decoding runs in one more. "
        "At most\none per 256 pixels of a band, and --jobs x --threads within the process's "
        "thread budget of\n4 per core (at least 8).",
        [&](const std::string& v) { a.s.threads = parse_int("--threads", v, 0, 1024); });
}

// Options that make no sense together, or without a source; a --json that cannot be written.
void validate_verify_args(const VerifyArgs& a, const std::vector<std::string>& files) {
    const bool any_source = !a.s.source.empty() || a.source_from_header;
    if (!a.s.source.empty() && a.source_from_header)
        throw UsageError("--source and --source-from-header exclude each other");
    if (!a.s.source.empty() && files.size() > 1)
        throw UsageError("--source compares one file (got " + std::to_string(files.size()) +
                         "); use --source-from-header for several");
    if (!any_source) {
        if (a.t.de) throw UsageError("--max-de needs --source");
        if (a.t.rgb) throw UsageError("--max-rgb-error needs --source");
        if (a.t.code) throw UsageError("--min-code-match needs --source");
        if (!a.s.colorspace.empty()) throw UsageError("--colorspace needs --source");
        if (!a.s.config.empty()) throw UsageError("--config needs --source");
    }
    // The files it reads are known once their headers are read (report_clash).
    if (!a.json.empty() && a.json != "-") check_output(a.json, "--json", ReadFiles{}, true);
}

// The report is never a file this command reads: the files, their sources (given or recorded),
// the list, the OCIO configs (given or recorded) and their LUTs, the tables. Names the clash, or
// returns "".
std::string report_clash(const VerifyArgs& a, const std::vector<std::string>& files) {
    if (a.json.empty() || a.json == "-") return "";
    ReadFiles reads;
    reads.add_data_dir(a.s.data_dir);
    reads.add(a.from_list, "--from-list");
    reads.add(a.s.source, "--source");
    reads.add(a.s.observer, "--observer");
    reads.add(a.s.illuminant, "--check-illuminant");
    for (const auto& l : a.s.other_lights) reads.add(l, "--illuminant");
    std::vector<std::string> configs = {ocio_config_path(a.s.data_dir, a.s.config)};
    for (const auto& f : files) {
        reads.add(f, "a file to verify");
        try {
            const auto attributes = read_spectral_exr_info(f).attributes;
            if (a.source_from_header) {
                try {
                    reads.add(recorded_source(f, attributes), "the source " + f + " records");
                } catch (const Error&) {
                    // No source found: reported when the file is verified.
                }
            }
            for (const auto& [k, v] : attributes) {
                if (k == provenance_key::kConfig && a.s.config.empty()) configs.push_back(v);
                if (k == provenance_key::kObserver || k == provenance_key::kIlluminant)
                    reads.add(v, "a table " + f + " records");
            }
        } catch (const Error&) {
            // An unreadable file is reported when it is verified.
        }
    }
    for (const auto& cfg : configs) {
        try {
            const auto lut = ocio_config_files(cfg);
            for (size_t i = 0; i < lut.size(); ++i)
                reads.add(lut[i], i ? "a LUT file of " + cfg : "an OCIO config");
        } catch (const Error&) {
            // A config that cannot be read is reported when it is used.
        }
    }
    return reads.clash(a.json, "--json");
}

// Prints each file's result and failed gates, writes the JSON report; returns the exit status.
int report_outcomes(const VerifyArgs& a, const std::vector<std::string>& files,
                    const std::vector<VerifyOutcome>& outcomes) {
    const bool json_stdout = a.json == "-";
    std::string json_text;
    size_t failed = 0, unreadable = 0, stale = 0, stale_reported = 0;
    for (size_t i = 0; i < files.size(); ++i) {
        const VerifyOutcome& o = outcomes[i];
        if (!o.readable) {
            ++unreadable;
            for (const auto& w : o.warnings)
                print_error("warning: " + quote_path(files[i]) + ": " + w);
            print_error(name_file(files[i], o.error, "verifying"));
            json_text += verify_error_json(files[i], o.error, o.warnings);
            continue;
        }
        for (const auto& w : o.report.warnings)
            print_error("warning: " + quote_path(files[i]) + ": " + w);
        if (!o.failures.empty()) ++failed;
        if (verify_result_word(o.report, o.failures) == "STALE")
            ++(o.failures.empty() ? stale_reported : stale);
        if (!json_stdout && !a.quiet) {
            if (files.size() == 1)
                print_text(o.report, a.t, o.failures);
            else
                print_line(o.report, o.failures);
        }
        json_text += verify_json(o.report, a.t, o.failures);
        for (const auto& f : o.failures) print_error(quote_path(o.report.file) + ": " + f);
    }
    if (files.size() > 1 && !json_stdout && !a.quiet)
        std::cout << files.size()
                  << " files: " << files.size() - failed - unreadable - stale_reported
                  << " passed, " << failed << " failed"
                  << (stale ? " (" + std::to_string(stale) + " with a changed source)" : "")
                  << (stale_reported ? ", " + std::to_string(stale_reported) +
                                           " stale (not compared, not failed: --report-only)"
                                     : "")
                  << ", " << unreadable << " unreadable\n";
    std::cout.flush();
    int status = failed || unreadable ? 1 : 0;
    if (json_stdout) {
        std::cout << json_text;
        std::cout.flush();
        if (!std::cout) {
            print_error("standard output: cannot write the JSON report");
            status = 1;
        }
    } else if (!a.json.empty()) {
        try {
            write_text_atomically(a.json, json_text);
        } catch (const std::exception& e) {
            print_error(std::string(e.what()) + " (--json); no report was written");
            status = 1;
        }
    }
    return status;
}

}  // namespace

int run_verify(const std::vector<std::string>& args) {
    VerifyArgs a;
    ArgParser p("verify", "spectex verify [options] FILE.exr [FILE.exr ...]", kVerifyDescription);
    declare_verify_options(p, a);
    p.common({"--source", "--source-from-header", "--from-list", "--illuminant", "--report-only",
              "--json", "--jobs", "--quiet", "--help"});
    std::vector<std::string> files;
    try {
        if (p.parse_or_help(args, files)) return 0;
        if (!a.from_list.empty()) {
            auto more = read_list(a.from_list);
            files.insert(files.end(), more.begin(), more.end());
        }
        if (files.empty())
            throw UsageError(a.from_list.empty() ? "no input file"
                                                 : "the input list names no files");
        validate_verify_args(a, files);
        check_observer_setting("--observer", a.s.observer);
        check_illuminant_setting("--check-illuminant", a.s.illuminant);
        a.s.illuminant = light_name(a.s.illuminant);
        for (const auto& l : a.s.other_lights) check_illuminant_setting("--illuminant", l);
    } catch (const UsageError& e) {
        return usage_error("verify", e.what());
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }

    // Threads by what the work can use: no more jobs than files, and --jobs x --threads within
    // the process's thread budget (each file then uses no more than its bands' blocks: verify.h).
    a.jobs = std::min<int>(a.jobs, static_cast<int>(files.size()));
    if (a.s.threads <= 0) a.s.threads = std::max(1, hardware_threads() / a.jobs);
    a.s.threads = std::min(a.s.threads, std::max(1, thread_budget() / a.jobs));
    a.s.other_lights = distinct_lights(a.s.other_lights);
    try {
        // Each file's band by its size: many small files at once need little.
        std::vector<uint64_t> bands;
        bands.reserve(files.size());
        for (const auto& f : files) bands.push_back(verify_band_bytes(f, a.s));
        check_verify_memory(a.s.other_lights.size(), a.s.threads, a.jobs, a.s, bands);
    } catch (const LimitError& e) {
        return usage_error("verify", e.what());
    }
    // OpenEXR decodes in verify's own reading thread, overlapped with the measuring threads: its
    // thread pool would hold two decoded chunks per thread (21 MB each at 4K, 81 bins, ZIP), so
    // memory would grow with the core count.
    Imf::setGlobalThreadCount(0);
    set_image_threads(a.s.threads);  // applied if and when a source is decoded
    try {
        a.s.data_dir = find_data_dir();
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }
    if (std::string clash = report_clash(a, files); !clash.empty())
        return usage_error("verify", clash);
    return report_outcomes(a, files, verify_files(files, a.s, a.t, a.source_from_header, a.jobs));
}

}  // namespace spectex
