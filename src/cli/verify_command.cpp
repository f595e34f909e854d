// spectex verify: measure a spectral OpenEXR, alone or against the image it was baked from.
#include <OpenEXR/ImfThreading.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <thread>

#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "pipeline/batch.h"
#include "io/data_dir.h"
#include "pipeline/verify.h"
#include "spectral/error.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

int run_verify(const std::vector<std::string>& args);

namespace {

std::string num(double v, const char* fmt = "%.6g") {
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v);
    return buf;
}

// Share as a percentage with enough digits to show a single sample in a large image.
std::string percent(uint64_t count, uint64_t total) {
    if (total == 0) return "0%";
    double p = 100.0 * static_cast<double>(count) / static_cast<double>(total);
    if (count == 0) return "0%";
    if (count == total) return "100%";
    return num(p, "%.6g") + "%";
}

std::string json_string(const std::string& s) { return "\"" + json_escape(s) + "\""; }

// JSON has no Inf/NaN: those are written as null.
std::string json_number(double v) { return std::isfinite(v) ? num(v, "%.9g") : std::string("null"); }

double share(uint64_t count, uint64_t total) {
    return total ? static_cast<double>(count) / static_cast<double>(total) : 0.0;
}

struct Thresholds {
    bool de = false, rgb = false, code = false;
    double max_de = 0, max_rgb = 0, min_code = 0;  // min_code in percent
};

std::vector<std::string> check(const VerifyReport& r, const Thresholds& t) {
    std::vector<std::string> fail;
    if (t.de && !(r.de_max <= t.max_de))
        fail.push_back("max CIEDE2000 " + num(r.de_max) + " exceeds --max-de " + num(t.max_de));
    if (t.rgb && !(r.rgb_error_max <= t.max_rgb))
        fail.push_back("max linear RGB error " + num(r.rgb_error_max) + " exceeds --max-rgb-error " + num(t.max_rgb));
    if (t.code) {
        if (!r.code_match_available)
            fail.push_back("--min-code-match " + num(t.min_code) + "%: code match is n/a (" + r.code_match_note + ")");
        else if (!(100.0 * r.code_match_share() >= t.min_code))
            fail.push_back("code match " + num(100.0 * r.code_match_share()) + "% is below --min-code-match " +
                           num(t.min_code) + "%");
    }
    return fail;
}

void print_text(const VerifyReport& r, const std::vector<std::string>& failures) {
    std::ostream& o = std::cout;
    o << r.file << "\n";
    o << "  size:                 " << r.width << " x " << r.height << " (" << r.pixels << " pixels)\n";
    o << "  wavelengths:          " << r.wavelengths << " nm, " << r.bins << " bins, "
      << format_wavelength(r.lambda_min) << "-" << format_wavelength(r.lambda_max) << " nm\n";
    o << "  samples:              " << r.sample_type << ", " << r.compression << ", " << r.storage << "\n";
    o << "  alpha:                " << (r.alpha == "none" ? std::string("none") : "A (" + r.alpha + ")") << "\n";
    o << "  integrated under:     " << r.illuminant << ", observer " << r.observer << "\n";
    o << "  outside [0, 1]:       " << r.below_zero + r.above_one << " samples ("
      << percent(r.below_zero + r.above_one, r.samples) << "): " << r.below_zero << " below 0, " << r.above_one
      << " above 1\n";
    o << "  beyond 1e-6 of it:    " << r.below_tol + r.above_tol << " samples ("
      << percent(r.below_tol + r.above_tol, r.samples) << "): " << r.below_tol << " below -1e-6, " << r.above_tol
      << " above 1+1e-6\n";
    o << "  non-finite:           " << r.nonfinite << " samples (" << percent(r.nonfinite, r.samples) << ")\n";
    o << "  linear RGB range:     R " << num(r.rgb_min[0]) << " .. " << num(r.rgb_max[0]) << ", G "
      << num(r.rgb_min[1]) << " .. " << num(r.rgb_max[1]) << ", B " << num(r.rgb_min[2]) << " .. "
      << num(r.rgb_max[2]) << "\n";
    if (r.compared) {
        o << "  source:               " << r.source << " ("
          << (r.source_float ? std::to_string(r.source_bits) + "-bit float" : std::to_string(r.source_bits) + "-bit")
          << ", '" << r.source_colorspace << "' from " << r.source_colorspace_how << ")\n";
        o << "  compared pixels:      " << r.compared_pixels;
        if (r.transparent_pixels) o << " (" << r.transparent_pixels << " with A = 0 skipped)";
        if (r.nonfinite_pixels) o << " (" << r.nonfinite_pixels << " with a non-finite colour)";
        o << "\n";
        if (r.source_clamped || r.source_replaced)
            o << "  source clamped:       " << r.source_clamped << " pixels outside [0, 1], " << r.source_replaced
              << " with NaN/Inf (bake's defaults)\n";
        o << "  linear RGB error:     max " << num(r.rgb_error_max) << " at (" << r.rgb_error_x << ", "
          << r.rgb_error_y << "), mean " << num(r.rgb_error_mean) << "\n";
        o << "  CIEDE2000:            max " << num(r.de_max) << " at (" << r.de_x << ", " << r.de_y << "), mean "
          << num(r.de_mean) << ", 99th percentile " << num(r.de_p99) << "\n";
        if (r.code_match_available)
            o << "  code match:           " << percent(r.code_matched, r.compared_pixels) << " (" << r.code_matched
              << " of " << r.compared_pixels << " pixels re-encode to their " << r.source_bits << "-bit codes; "
              << r.code_match_note << ")\n";
        else
            o << "  code match:           n/a (" << r.code_match_note << ")\n";
    }
    o << "  time:                 " << num(r.seconds, "%.3f") << " s\n";
    if (failures.empty())
        o << "  result:               ok\n";
    else
        for (const auto& f : failures) o << "  result:               FAILED: " << f << "\n";
}

void print_json(const VerifyReport& r, const Thresholds& t, const std::vector<std::string>& failures) {
    std::ostringstream o;
    o << "{\"schema_version\":1";
    o << ",\"file\":" << json_string(r.file);
    o << ",\"width\":" << r.width << ",\"height\":" << r.height << ",\"pixels\":" << r.pixels;
    o << ",\"bins\":" << r.bins << ",\"wavelength_min\":" << json_number(r.lambda_min)
      << ",\"wavelength_max\":" << json_number(r.lambda_max) << ",\"wavelengths\":" << json_string(r.wavelengths);
    o << ",\"sample_type\":" << json_string(r.sample_type) << ",\"compression\":" << json_string(r.compression)
      << ",\"storage\":" << json_string(r.storage) << ",\"alpha\":" << json_string(r.alpha);
    o << ",\"illuminant\":" << json_string(r.illuminant) << ",\"observer\":" << json_string(r.observer);
    o << ",\"samples\":" << r.samples;
    o << ",\"outside_unit_interval\":{\"count\":" << r.below_zero + r.above_one
      << ",\"share\":" << json_number(share(r.below_zero + r.above_one, r.samples)) << ",\"below\":" << r.below_zero
      << ",\"above\":" << r.above_one << "}";
    o << ",\"outside_tolerance\":{\"tolerance\":1e-6,\"count\":" << r.below_tol + r.above_tol
      << ",\"share\":" << json_number(share(r.below_tol + r.above_tol, r.samples)) << ",\"below\":" << r.below_tol
      << ",\"above\":" << r.above_tol << "}";
    o << ",\"nonfinite\":{\"count\":" << r.nonfinite << ",\"share\":" << json_number(share(r.nonfinite, r.samples))
      << "}";
    o << ",\"rgb_range\":{\"min\":[" << json_number(r.rgb_min[0]) << "," << json_number(r.rgb_min[1]) << ","
      << json_number(r.rgb_min[2]) << "],\"max\":[" << json_number(r.rgb_max[0]) << "," << json_number(r.rgb_max[1])
      << "," << json_number(r.rgb_max[2]) << "]}";
    if (r.compared) {
        o << ",\"source\":{\"file\":" << json_string(r.source) << ",\"colorspace\":" << json_string(r.source_colorspace)
          << ",\"colorspace_how\":" << json_string(r.source_colorspace_how) << ",\"bits\":" << r.source_bits
          << ",\"float\":" << (r.source_float ? "true" : "false") << ",\"compared_pixels\":" << r.compared_pixels
          << ",\"transparent_pixels\":" << r.transparent_pixels << ",\"nonfinite_pixels\":" << r.nonfinite_pixels
          << ",\"clamped_pixels\":" << r.source_clamped << ",\"replaced_pixels\":" << r.source_replaced
          << ",\"rgb_error\":{\"max\":" << json_number(r.rgb_error_max) << ",\"mean\":" << json_number(r.rgb_error_mean)
          << ",\"max_at\":[" << r.rgb_error_x << "," << r.rgb_error_y << "]}"
          << ",\"ciede2000\":{\"max\":" << json_number(r.de_max) << ",\"mean\":" << json_number(r.de_mean)
          << ",\"p99\":" << json_number(r.de_p99) << ",\"max_at\":[" << r.de_x << "," << r.de_y << "]}"
          << ",\"code_match\":";
        if (r.code_match_available)
            o << "{\"share\":" << json_number(r.code_match_share()) << ",\"matched\":" << r.code_matched
              << ",\"encoding\":" << json_string(r.code_match_note) << "}";
        else
            o << "{\"share\":null,\"note\":" << json_string(r.code_match_note) << "}";
        o << "}";
    } else {
        o << ",\"source\":null";
    }
    o << ",\"thresholds\":{\"max_de\":" << (t.de ? json_number(t.max_de) : "null")
      << ",\"max_rgb_error\":" << (t.rgb ? json_number(t.max_rgb) : "null")
      << ",\"min_code_match_percent\":" << (t.code ? json_number(t.min_code) : "null") << "}";
    o << ",\"failures\":[";
    for (size_t i = 0; i < failures.size(); ++i) o << (i ? "," : "") << json_string(failures[i]);
    o << "],\"passed\":" << (failures.empty() ? "true" : "false");
    o << ",\"seconds\":" << json_number(r.seconds) << "}\n";
    std::cout << o.str();
}

}  // namespace

int run_verify(const std::vector<std::string>& args) {
    VerifySettings s;
    Thresholds t;
    bool json = false;
    ArgParser p("verify", "spectex verify [options] FILE.exr",
                "Reads a reflective spectral OpenEXR (Fichet 2021 layout, channels T.<wavelength>nm, from spectex\n"
                "or any other tool) a band of rows at a time, integrates every pixel under an illuminant with an\n"
                "observer on the file's own bins (linear Rec.709 through the white-consistent matrix; spectra\n"
                "premultiplied by A are divided by it unless spectex:alpha says 'unassociated'), and reports the\n"
                "samples outside [0, 1] and the non-finite ones. With --source, it also compares every pixel with\n"
                "the source image, linearised and clamped as 'spectex bake' does by default: linear RGB error,\n"
                "CIEDE2000 (L*a*b* relative to the illuminant's white) max, mean and 99th percentile, and the\n"
                "share of pixels that re-encode to the source's 8- or 16-bit codes.\n"
                "Exit status: 0 all thresholds met, 1 a threshold exceeded or the file unreadable, 2 usage error.");
    p.section("Comparison");
    p.option("--source", "FILE", "The image the EXR was baked from (anything OpenImageIO reads); same size.",
             [&](const std::string& v) { s.source = v; });
    p.option("--colorspace", "NAME", "Colour space of the source (as for bake). Default: metadata, then file rules.",
             [&](const std::string& v) { s.colorspace = v; });
    p.option("--config", "FILE", "OCIO config for the source instead of $OCIO or the shipped config/spectex.ocio.",
             [&](const std::string& v) { s.config = v; });
    p.section("Colorimetry");
    p.option("--illuminant", "NAME|FILE",
             "Illuminant: " + shipped_illuminants_list(VerifySettings().illuminant) +
                 " (any case), or a CSV wavelength,value.",
             [&](const std::string& v) { s.illuminant = v; });
    p.option("--observer", "NAME|FILE", "Observer: cie1931-2 (default), cie1964-10, or a CSV wavelength,x,y,z.",
             [&](const std::string& v) { s.observer = v; });
    p.section("Thresholds (need --source; exit 1 when not met)");
    p.option("--max-de", "X", "Largest CIEDE2000 allowed.", [&](const std::string& v) {
        t.max_de = parse_number("--max-de", v);
        if (!(t.max_de >= 0)) throw UsageError("--max-de: must be >= 0");
        t.de = true;
    });
    p.option("--max-rgb-error", "X", "Largest absolute linear RGB error allowed.", [&](const std::string& v) {
        t.max_rgb = parse_number("--max-rgb-error", v);
        if (!(t.max_rgb >= 0)) throw UsageError("--max-rgb-error: must be >= 0");
        t.rgb = true;
    });
    p.option("--min-code-match", "PERCENT", "Smallest share of pixels, in percent, that re-encode to the source codes.",
             [&](const std::string& v) {
                 t.min_code = parse_number("--min-code-match", v);
                 if (!(t.min_code >= 0 && t.min_code <= 100)) throw UsageError("--min-code-match: must be in [0, 100]");
                 t.code = true;
             });
    p.section("Output");
    p.flag("--json", "Print one JSON object (schema_version 1) instead of text.", [&] { json = true; });
    p.option("--threads", "N", "Threads measuring pixels (default: all cores); decoding runs in one more thread.",
             [&](const std::string& v) { s.threads = parse_int("--threads", v, 0, 1024); });

    std::vector<std::string> files;
    try {
        if (p.parse_or_help(args, files)) return 0;
        if (files.empty()) throw UsageError("no input file");
        if (files.size() > 1) throw UsageError("one file at a time (got " + std::to_string(files.size()) + ")");
        if (s.source.empty()) {
            if (t.de) throw UsageError("--max-de needs --source");
            if (t.rgb) throw UsageError("--max-rgb-error needs --source");
            if (t.code) throw UsageError("--min-code-match needs --source");
            if (!s.colorspace.empty()) throw UsageError("--colorspace needs --source");
            if (!s.config.empty()) throw UsageError("--config needs --source");
        }
    } catch (const UsageError& e) {
        return usage_error("verify", e.what());
    }

    unsigned hw = std::max(1u, std::thread::hardware_concurrency());
    int threads = s.threads > 0 ? s.threads : static_cast<int>(hw);
    // OpenEXR decodes in verify's own reading thread, overlapped with the measuring threads: its
    // thread pool would hold two decoded chunks per thread (21 MB each at 4K, 81 bins, ZIP), so
    // memory would grow with the core count.
    Imf::setGlobalThreadCount(0);
    OIIO::attribute("threads", threads);

    VerifyReport r;
    try {
        s.data_dir = find_data_dir();
        r = verify_file(files[0], s);
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    } catch (const std::exception& e) {
        print_error(files[0] + ": " + e.what());
        return 1;
    }
    std::vector<std::string> failures = check(r, t);
    if (json)
        print_json(r, t, failures);
    else
        print_text(r, failures);
    std::cout.flush();
    for (const auto& f : failures) print_error(r.file + ": " + f);
    return failures.empty() ? 0 : 1;
}

}  // namespace spectex
