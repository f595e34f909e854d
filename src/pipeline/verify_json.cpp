// verify's JSON record (JSON Lines, schema_version 2; docs/verify.md): one object per file, built
// here as bake's records (pipeline/batch_files) and plan's (pipeline/plan_report) are.
#include "pipeline/verify_json.h"

#include <cctype>
#include <utility>

#include "pipeline/json_text.h"

namespace spectex {

namespace {

// JSON numbers to 9 significant digits; null for Inf/NaN, which JSON has not.
Json json_num(double v) { return json_number(v, "%.9g"); }
Json json_rgb(const double* v) { return {json_num(v[0]), json_num(v[1]), json_num(v[2])}; }

double share(uint64_t count, uint64_t total) {
    return total ? static_cast<double>(count) / static_cast<double>(total) : 0.0;
}

// A count and its share of a total.
Json count_share(uint64_t count, uint64_t total) {
    return {{"count", count}, {"share", json_num(share(count, total))}};
}

// The comparison with the source: its colour space, the errors, the code match.
Json source_json(const VerifyReport& r) {
    Json src;
    put_text(src, "file", r.source);
    put_text(src, "colorspace", r.source_colorspace);
    put_text(src, "colorspace_how", r.source_colorspace_how);
    src["bits"] = r.source_bits;
    src["float"] = r.source_float;
    src["compared_pixels"] = r.compared_pixels;
    src["transparent_pixels"] = r.transparent_pixels;
    src["nonfinite_pixels"] = r.nonfinite_pixels;
    src["clamped_pixels"] = r.source_clamped;
    src["clamped_excursion"] = json_num(r.source_clamped_excursion);
    src["replaced_pixels"] = r.source_replaced;
    src["rgb_error"] = {{"max", json_num(r.rgb_error_max)},
                        {"mean", json_num(r.rgb_error_mean)},
                        {"max_at", {r.rgb_error_x, r.rgb_error_y}}};
    src["ciede2000"] = {{"max", json_num(r.de_max)},
                        {"mean", json_num(r.de_mean)},
                        {"p99", json_num(r.de_p99)},
                        {"max_at", {r.de_x, r.de_y}}};
    Json codes;
    if (r.code_match_available) {
        codes["share"] = json_num(r.code_match_share());
        codes["matched"] = r.code_matched;
        codes["checked"] = r.code_checked;
        put_text(codes, "encoding", r.code_match_note);
    } else {
        codes["share"] = nullptr;
        put_text(codes, "note", r.code_match_note);
    }
    src["code_match"] = std::move(codes);
    return src;
}

}  // namespace

std::string verify_json(const VerifyReport& r, const VerifyGates& t,
                        const std::vector<std::string>& failures) {
    Json j;
    j["schema_version"] = 2;
    put_text(j, "file", r.file);
    j["width"] = r.width;
    j["height"] = r.height;
    j["pixels"] = r.pixels;
    j["bins"] = r.bins;
    j["wavelength_min"] = json_num(r.lambda_min);
    j["wavelength_max"] = json_num(r.lambda_max);
    put_text(j, "wavelengths", r.wavelengths);
    put_text(j, "sample_type", r.sample_type);
    put_text(j, "compression", r.compression);
    put_text(j, "storage", r.storage);
    put_text(j, "alpha", to_string(r.alpha));
    put_text(j, "illuminant", r.illuminant);
    put_text(j, "observer", r.observer);
    put_text_or_null(j, "method", r.method);
    if (!r.precision.empty()) {
        Json pj;
        put_text(pj, "mode", r.precision);
        put_text(pj, "max_de", r.precision_max_de);
        put_text(pj, "lights", r.precision_lights);
        put_text(pj, "worst_de", r.precision_worst_de);
        put_text(pj, "covers", r.precision_covers);
        pj["bits"] = r.precision_bits;
        j["precision"] = std::move(pj);
    }
    put_text(j, "out_of_range", r.out_of_range);
    put_text(j, "nan", r.nan);
    put_texts(j, "warnings", r.warnings);
    Json others = Json::array();
    for (const auto& l : r.other_lights) {
        Json o;
        put_text(o, "illuminant", l.light);
        o["adaptation"] = "bradford";
        o["pixels"] = l.pixels;
        o["ciede2000"] = {{"mean", json_num(l.de_mean)},
                          {"p99", json_num(l.de_p99)},
                          {"max", json_num(l.de_max)},
                          {"max_at", {l.de_x, l.de_y}}};
        o["rgb_range"] = {{"min", json_rgb(l.rgb_min)}, {"max", json_rgb(l.rgb_max)}};
        others.push_back(std::move(o));
    }
    j["other_lights"] = std::move(others);
    j["samples"] = r.samples;
    j["outside_unit_interval"] = count_share(r.below_zero + r.above_one, r.samples);
    j["outside_unit_interval"]["below"] = r.below_zero;
    j["outside_unit_interval"]["above"] = r.above_one;
    // Associated files: the counts are of T/A, and "above" tolerates each bin's rounding step.
    j["outside_unit_interval"]["divided_by_alpha"] = r.straight_range;
    Json tolerance = {
        {"tolerance", r.straight_range ? Json("rounding step of each bin") : Json(1e-6)}};
    tolerance.update(count_share(r.below_tol + r.above_tol, r.samples));
    tolerance["below"] = r.below_tol;
    tolerance["above"] = r.above_tol;
    j["outside_tolerance"] = std::move(tolerance);
    j["nonfinite"] = count_share(r.nonfinite, r.samples);
    j["rgb_range"] = {{"min", json_rgb(r.rgb_min)}, {"max", json_rgb(r.rgb_max)}};
    j["source"] = r.compared ? source_json(r) : Json(nullptr);
    if (r.source_changed) {
        Json c;
        put_text(c, "file", r.change.file);
        put_text(c, "why", r.change.why);
        put_text(c, "recorded_size", r.change.recorded_size);
        put_text(c, "size", r.change.size);
        put_text_or_null(c, "recorded_hash", r.change.recorded_hash);
        put_text_or_null(c, "hash", r.change.hash);
        j["source_changed"] = std::move(c);
    } else {
        j["source_changed"] = nullptr;
    }
    j["thresholds"] = {{"max_de", t.de ? json_num(t.max_de) : Json(nullptr)},
                       {"max_rgb_error", t.rgb ? json_num(t.max_rgb) : Json(nullptr)},
                       {"min_code_match_percent", t.code ? json_num(t.min_code) : Json(nullptr)}};
    j["report_only"] = t.report_only;
    put_texts(j, "gates", gates_applied(r, t));
    put_texts(j, "failures", failures);
    j["passed"] = failures.empty() && !r.source_changed;  // a stale file was not compared
    std::string word = verify_result_word(r, failures);
    for (char& ch : word) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    j["result"] = word;  // "ok", "failed" or "stale"
    j["seconds"] = json_num(r.seconds);
    return json_line(j);
}

// A file that could not be verified: its error, which is also its one failure.
std::string verify_error_json(const std::string& file, const std::string& error,
                              const std::vector<std::string>& warnings) {
    Json j;
    j["schema_version"] = 2;
    put_text(j, "file", file);
    put_text(j, "error", error);
    put_texts(j, "warnings", warnings);
    put_texts(j, "failures", {error});
    j["passed"] = false;
    return json_line(j);
}

}  // namespace spectex
