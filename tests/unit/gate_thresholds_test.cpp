// verify's gates (pipeline/verify.h gate_failures) on reports made here, without a file: each gate
// passes at its threshold and fails just past it, the default gates apply only where their premise
// holds (an exact method, codes a half file can keep), --report-only gates nothing, and a changed
// source or a lossy compression is said in the failure. The CLI tests
// (tests/cli/verify_gates_test.cpp, verify_test.cpp) reach the same gates through real files; here
// every threshold is exact.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "pipeline/verify.h"

using namespace spectex;

namespace {

// A report every default gate passes: a spectex bake of an 8-bit source into float, compared with
// its source, no sample out of range, every code re-encoding.
VerifyReport clean_report() {
    VerifyReport r;
    r.method = "mallett2019";
    r.sample_type = "float";
    r.out_of_range = "clamp";
    r.samples = 1000;
    r.compared = true;
    r.source_bits = 8;
    r.code_match_available = true;
    r.code_checked = 10000;
    r.code_matched = 10000;
    return r;
}

bool has(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

// The single failure of a report ("" when it passes; a test failure when more than one fails).
std::string only_failure(const VerifyReport& r, const VerifyGates& g = {}) {
    const std::vector<std::string> f = gate_failures(r, g);
    EXPECT_LE(f.size(), 1u) << (f.empty() ? "" : f[0] + " | " + f[1]);
    return f.empty() ? "" : f[0];
}

}  // namespace

TEST(VerifyGateFailures, ACleanReportPassesEveryDefaultGate) {
    EXPECT_TRUE(gate_failures(clean_report(), {}).empty());
    // A file not compared with a source has only the sample gates.
    VerifyReport r = clean_report();
    r.compared = false;
    r.de_max = 99;
    r.code_matched = 0;
    EXPECT_TRUE(gate_failures(r, {}).empty());
}

TEST(VerifyGateFailures, NonFiniteSamplesFailFromTheFirst) {
    VerifyReport r = clean_report();
    r.nonfinite = 1;
    const std::string f = only_failure(r);
    EXPECT_TRUE(has(f, "non-finite samples: 1 (")) << f;
    EXPECT_TRUE(has(f, ", gate none")) << f;
}

TEST(VerifyGateFailures, SamplesOutsideZeroOneFailUnlessTheBakeKeptThem) {
    VerifyReport r = clean_report();
    r.below_tol = 2;
    r.above_tol = 1;
    const std::string f = only_failure(r);
    EXPECT_TRUE(has(f, "samples outside [0, 1] by more than 1e-6: 3 (")) << f;
    EXPECT_TRUE(has(f, "2 below, 1 above")) << f;
    // Within the tolerance (below_zero/above_one only) passes.
    VerifyReport within = clean_report();
    within.below_zero = 5;
    within.above_one = 5;
    EXPECT_EQ(only_failure(within), "");
    // --out-of-range keep: the values are the data, not a fault.
    r.out_of_range = "keep";
    EXPECT_EQ(only_failure(r), "");
}

TEST(VerifyGateFailures, TheDefaultColourGateIsHalfADeltaEForExactMethodsOnly) {
    VerifyReport r = clean_report();
    r.de_max = kDefaultMaxDe;  // at the threshold: passes
    EXPECT_EQ(only_failure(r), "");
    r.de_max = 0.5000001;
    EXPECT_TRUE(has(only_failure(r), "CIEDE2000 max: 0.5 at (0, 0), gate <= 0.5"))
        << only_failure(r);
    // jakob-hanika spectra are not exact: no colour gate unless one is asked for.
    r.method = "jakob-hanika";
    r.de_max = 5;
    r.code_matched = 0;
    EXPECT_EQ(only_failure(r), "");
}

TEST(VerifyGateFailures, MaxDeReplacesTheDefaultThreshold) {
    VerifyReport r = clean_report();
    VerifyGates g;
    g.de = true;
    g.max_de = 2;
    r.de_max = 2;
    EXPECT_EQ(only_failure(r, g), "");
    r.de_max = 2.001;
    r.de_x = 3;
    r.de_y = 4;
    EXPECT_EQ(only_failure(r, g), "CIEDE2000 max: 2.001 at (3, 4), gate <= 2 (--max-de)");
    // Asked for, it gates a method that is not exact too.
    r.method = "jakob-hanika";
    r.code_matched = 0;
    EXPECT_TRUE(has(only_failure(r, g), "CIEDE2000 max")) << only_failure(r, g);
}

TEST(VerifyGateFailures, MaxRgbErrorGatesOnlyWhenGiven) {
    VerifyReport r = clean_report();
    r.rgb_error_max = 0.25;
    EXPECT_EQ(only_failure(r), "");
    VerifyGates g;
    g.rgb = true;
    g.max_rgb = 0.25;
    EXPECT_EQ(only_failure(r, g), "");
    r.rgb_error_max = 0.2500001;
    EXPECT_TRUE(has(only_failure(r, g), "linear RGB error max: 0.25 at (0, 0), gate <= 0.25"))
        << only_failure(r, g);
}

TEST(VerifyGateFailures, EveryCodeMustReEncodeByDefaultAndHalfWithPlainRoundingMayMissOneIn10k) {
    VerifyReport r = clean_report();
    r.code_matched = 9999;  // one code of 10000 missed: float keeps every code
    EXPECT_TRUE(has(only_failure(r),
                    "pixels that re-encode to their 8-bit codes: 99.99% (9999 of "
                    "10000), gate >= 100%"))
        << only_failure(r);
    r.sample_type = "half";
    r.half_rounding = "nearest";
    EXPECT_EQ(only_failure(r), "");  // 99.99% is half's plain-rounding threshold
    r.code_matched = 9998;
    EXPECT_TRUE(has(only_failure(r), "gate >= 99.99% (half with plain rounding)"))
        << only_failure(r);
    // Half with colour-aware rounding holds every code, as float does.
    r.half_rounding = "colour";
    r.code_matched = 9999;
    EXPECT_TRUE(has(only_failure(r), "gate >= 100%")) << only_failure(r);
    // No code check available (another tool's file, a source of floats): no default code gate.
    r.code_match_available = false;
    EXPECT_EQ(only_failure(r), "");
}

TEST(VerifyGateFailures, MinCodeMatchReplacesTheDefaultAndNeedsTheCheck) {
    VerifyReport r = clean_report();
    VerifyGates g;
    g.code = true;
    g.min_code = 99;
    r.code_matched = 9900;
    EXPECT_EQ(only_failure(r, g), "");
    r.code_matched = 9899;
    EXPECT_TRUE(has(only_failure(r, g), "gate >= 99% (--min-code-match)")) << only_failure(r, g);
    // Asked for where no code check is possible: a failure, never a silent pass.
    r.code_matched = 9900;
    r.code_match_available = false;
    r.code_match_note = "the source is not 8 or 16 bits";
    EXPECT_TRUE(has(only_failure(r, g), "n/a (the source is not 8 or 16 bits)"))
        << only_failure(r, g);
}

TEST(VerifyGateFailures, HalfFromSixteenBitSourcesIsGatedOnLinearRgbInstead) {
    VerifyReport r = clean_report();
    r.sample_type = "half";
    r.half_rounding = "colour";
    r.source_bits = 16;
    r.code_matched = 0;  // half cannot keep 16-bit codes: not gated
    r.rgb_error_max = 1e-4;
    EXPECT_EQ(only_failure(r), "");
    r.rgb_error_max = 1.01e-4;
    EXPECT_TRUE(has(only_failure(r), "linear RGB error max (half cannot keep 16-bit codes)"))
        << only_failure(r);
    // Plain rounding's threshold is 5e-4.
    r.half_rounding = "nearest";
    r.rgb_error_max = 5e-4;
    EXPECT_EQ(only_failure(r), "");
    r.rgb_error_max = 5.01e-4;
    EXPECT_TRUE(has(only_failure(r), "gate <= 0.0005")) << only_failure(r);
    // Float keeps 16-bit codes: the code gate applies, not this one.
    r.sample_type = "float";
    r.code_matched = r.code_checked;
    EXPECT_EQ(only_failure(r), "");
}

TEST(VerifyGateFailures, ReportOnlyGatesNothing) {
    VerifyReport r = clean_report();
    r.nonfinite = 3;
    r.above_tol = 3;
    r.de_max = 9;
    r.code_matched = 0;
    r.source_changed = true;
    EXPECT_EQ(gate_failures(r, {}).size(), 5u);  // source, non-finite, range, ΔE, codes
    VerifyGates g;
    g.report_only = true;
    EXPECT_TRUE(gate_failures(r, g).empty());
}

TEST(VerifyGateFailures, AChangedSourceComesFirstAndSaysWhy) {
    VerifyReport r = clean_report();
    r.nonfinite = 1;
    r.source_changed = true;
    r.change.file = "/tex/albedo.png";
    r.change.why = "same size, other bytes";
    const std::vector<std::string> f = gate_failures(r, {});
    ASSERT_EQ(f.size(), 2u);
    EXPECT_EQ(f[0], stale_failure(r));
    EXPECT_EQ(f[0],
              "the source /tex/albedo.png changed since this file was baked (same size, other "
              "bytes)");
    EXPECT_TRUE(has(f[1], "non-finite samples")) << f[1];
}

TEST(VerifyGateFailures, ALossyCompressionIsNamedInEveryFailure) {
    VerifyReport r = clean_report();
    r.lossy_compression = "b44 (lossy for half)";
    EXPECT_EQ(only_failure(r), "");  // named only where a gate failed
    r.above_tol = 1;
    EXPECT_TRUE(has(only_failure(r),
                    "(the file's compression, b44 (lossy for half), changed the "
                    "samples)"))
        << only_failure(r);
}
