// verify's gates: which a file meets (from what it records and the thresholds given), the text of
// each, and the figures' wording. The measuring is verify.cpp's.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "base/text.h"
#include "pipeline/method_table.h"
#include "pipeline/verify.h"

namespace spectex {

std::string share_text(uint64_t count, uint64_t total) {
    if (total == 0 || count == 0) return "0%";
    if (count == total) return "100%";
    return number_text(100.0 * static_cast<double>(count) / static_cast<double>(total)) + "%";
}

namespace {

std::string fmt(double v, const char* f = "%.6g") { return number_text(v, f); }
std::string pct(uint64_t n, uint64_t total) { return share_text(n, total); }

struct Gate {
    std::string what;   // "non-finite samples", ...
    std::string limit;  // "none", "<= 0.5", ...
    bool passed = true;
    std::string measured;
};

// The gates of one report (VerifyGates' documented defaults, or the explicit thresholds).
std::vector<Gate> gates_of(const VerifyReport& r, const VerifyGates& g) {
    std::vector<Gate> out;
    if (g.report_only) return out;
    if (r.source_changed)
        out.push_back({"source", "unchanged since the bake (spectex:sourceSize, sourceHash)", false,
                       r.change.why});
    out.push_back({"non-finite samples", "none", r.nonfinite == 0,
                   std::to_string(r.nonfinite) + " (" + pct(r.nonfinite, r.samples) + ")"});
    if (r.out_of_range != "keep") {
        const uint64_t n = r.below_tol + r.above_tol;
        out.push_back({r.straight_range ? "samples divided by A outside [0, 1] by more than their "
                                          "rounding"
                                        : "samples outside [0, 1] by more than 1e-6",
                       "none", n == 0,
                       std::to_string(n) + " (" + pct(n, r.samples) + "; " +
                           std::to_string(r.below_tol) + " below, " + std::to_string(r.above_tol) +
                           " above)"});
    }
    if (!r.compared) return out;
    const bool exact = method_is_exact(r.method);
    const bool half = r.sample_type == "half" || r.sample_type == "mixed";
    const bool plain_half = half && r.half_rounding != "colour";
    if (g.de || exact) {
        const double lim = g.de ? g.max_de : kDefaultMaxDe;
        out.push_back({"CIEDE2000 max", "<= " + fmt(lim) + (g.de ? " (--max-de)" : ""),
                       r.de_max <= lim,
                       fmt(r.de_max) + " at (" + std::to_string(r.de_x) + ", " +
                           std::to_string(r.de_y) + ")"});
    }
    if (g.rgb) {
        out.push_back({"linear RGB error max", "<= " + fmt(g.max_rgb) + " (--max-rgb-error)",
                       r.rgb_error_max <= g.max_rgb,
                       fmt(r.rgb_error_max) + " at (" + std::to_string(r.rgb_error_x) + ", " +
                           std::to_string(r.rgb_error_y) + ")"});
    }
    const std::string share = r.code_match_available
                                  ? fmt(100.0 * r.code_match_share(), "%.6g") + "% (" +
                                        std::to_string(r.code_matched) + " of " +
                                        std::to_string(r.code_checked) + ")"
                                  : "n/a (" + r.code_match_note + ")";
    if (g.code) {
        out.push_back({"pixels that re-encode to their codes",
                       ">= " + fmt(g.min_code) + "% (--min-code-match)",
                       r.code_match_available && 100.0 * r.code_match_share() >= g.min_code,
                       share});
    } else if (exact && r.code_match_available && !(r.source_bits == 16 && half)) {
        const double need = plain_half ? 99.99 : 100.0;
        out.push_back(
            {"pixels that re-encode to their " + std::to_string(r.source_bits) + "-bit codes",
             ">= " + fmt(need) + "%" + (plain_half ? " (half with plain rounding)" : ""),
             100.0 * r.code_match_share() >= need, share});
    }
    if (exact && !g.rgb && r.source_bits == 16 && half && !r.source_float) {
        // Half's step (up to 6e-5 in linear RGB once integrated) is coarser than 16-bit codes (down
        // to 1.2e-6 near black): the colour error is gated instead of the codes.
        const double lim = plain_half ? 5e-4 : 1e-4;
        const bool coarse = std::any_of(r.precision_bits.begin(), r.precision_bits.end(),
                                        [](int b) { return b < 10; });
        if (coarse) {
            // The precision budget's coarser grids hold each channel to 2^-10 of its value where
            // that is more than 6.1e-5 (spectral/half_bits.h): the error beyond that share.
            out.push_back({"linear RGB error beyond 2^-10 of the value, max (coarser grids)",
                           "<= " + fmt(lim), r.rgb_error_beyond_relative_max <= lim,
                           fmt(r.rgb_error_beyond_relative_max)});
        } else {
            out.push_back({"linear RGB error max (half cannot keep 16-bit codes)", "<= " + fmt(lim),
                           r.rgb_error_max <= lim,
                           fmt(r.rgb_error_max) + " at (" + std::to_string(r.rgb_error_x) + ", " +
                               std::to_string(r.rgb_error_y) + ")"});
        }
    }
    return out;
}

}  // namespace

std::string stale_failure(const VerifyReport& r) {
    if (!r.source_changed) return "";
    return "the source " + quote_path(r.change.file) + " changed since this file was baked (" +
           r.change.why + ")";
}

std::string verify_result_word(const VerifyReport& r, const std::vector<std::string>& failures) {
    // --report-only leaves no failure, but a file whose source changed was still never compared.
    if (failures.empty()) return r.source_changed ? "STALE" : "ok";
    return r.source_changed && failures.front() == stale_failure(r) ? "STALE" : "FAILED";
}

std::vector<std::string> gate_failures(const VerifyReport& r, const VerifyGates& g) {
    std::vector<std::string> f;
    for (const Gate& x : gates_of(r, g))
        if (x.what == "source" && r.source_changed)
            f.push_back(stale_failure(r));
        else if (!x.passed)
            f.push_back(x.what + ": " + x.measured + ", gate " + x.limit +
                        (r.lossy_compression.empty()
                             ? ""
                             : " (the file's compression, " + r.lossy_compression +
                                   ", changed the samples)"));
    return f;
}

std::vector<std::string> gates_applied(const VerifyReport& r, const VerifyGates& g) {
    std::vector<std::string> a;
    for (const Gate& x : gates_of(r, g))
        a.push_back(x.what + " " + x.limit + ": " + x.measured + (x.passed ? "" : "  FAILED"));
    return a;
}

}  // namespace spectex
