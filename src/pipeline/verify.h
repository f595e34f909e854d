#pragma once
// `spectex verify`: reads a reflective spectral OpenEXR (Fichet 2021 layout, from spectex or any
// other tool) a band of rows at a time, integrates every pixel under an illuminant with an observer
// on the file's own bins, and measures it: samples outside [0, 1] and non-finite samples always;
// with a source image, the round-trip error against it (linear RGB, CIEDE2000, code re-encoding).
// Memory is bounded by the band size, never by the image size.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "base/error.h"
#include "io/alpha_kind.h"

namespace spectex {

// Every setting left empty is taken from what the file records (its spectex:* provenance), and
// from the defaults when the file records nothing (a file from another tool): a bake is checked
// under the conditions it was made for without repeating them. A setting given here overrides the
// file's, and the report says so (warnings).
struct VerifySettings {
    std::string source;  // --source ("" = no comparison)
    std::string
        illuminant;  // the light the file is checked under: name or CSV ("" = file's, else D65)
    std::string observer;  // name or CSV ("" = file's, else cie1931-2)
    std::string
        colorspace;  // of the source ("" = file's input colour space, else metadata, file rules)
    std::string config;  // OCIO config ("" = the file's when it is still there unchanged, else
                         // $OCIO, then the shipped config)
    std::vector<std::string>
        other_lights;  // --illuminant: reported next to the check light, never gated
    std::string data_dir;
    uint64_t max_pixels = 268435456;  // refuse larger sources (as bake does)
    size_t band_bytes = 8u << 20;  // float spectral samples per band buffer (two buffers are used)
    int threads = 0;               // compute threads (0 = all cores)
};

// The bytes of one band of a file's spectral samples as verify reads them (float): s.band_bytes,
// or the whole image when it is smaller (an 8x8 file needs 8 rows, not 8 MiB). 0 for a file whose
// header cannot be read: it fails on its own before any band is allocated.
uint64_t verify_band_bytes(const std::string& exr_path, const VerifySettings& s);
// What verify keeps in memory: every job has two bands of its file (and the source's pixels, at
// most the same size again), and each of its threads has, per light, a ΔE00 histogram
// (ErrorHistogram, 96 KB) and its XYZ block (6 KB). The estimate, made before any pixel is read,
// for `lights` other lights, `threads` per file (after thread_budget()), `jobs` at once and the
// files' band_bytes (verify_band_bytes): the `jobs` largest bands at once.
struct VerifyMemory {
    uint64_t bands = 0;         // the bands and source pixels of the jobs running at once
    uint64_t measurements = 0;  // the threads' histograms and blocks, with the lights'
    uint64_t total() const { return bands + measurements; }
};
VerifyMemory verify_memory_estimate(size_t lights, int threads, int jobs, const VerifySettings& s,
                                    const std::vector<uint64_t>& band_bytes);
// The most verify_memory_estimate() may be: 1 GiB. A 4K, 81-bin file with all 26 shipped lights
// on 64 threads needs about 190 MB of it; 32 jobs of files with full bands (8 MiB each) need 1 GiB.
constexpr uint64_t kVerifyMemoryLimit = uint64_t(1) << 30;
// Throws LimitError when the estimate exceeds kVerifyMemoryLimit, naming first the option that
// costs most (--jobs when the bands do, --illuminant when the lights do) and what takes the
// memory, with the figures and the limit.
void check_verify_memory(size_t lights, int threads, int jobs, const VerifySettings& s,
                         const std::vector<uint64_t>& band_bytes);

// ΔE values are binned on a logarithmic scale (1000 bins per decade from 1e-8 to 1e4) so that a
// percentile costs no per-pixel storage; its relative resolution is 0.23 %.
class ErrorHistogram {
  public:
    ErrorHistogram();
    void add(double v);
    void merge(const ErrorHistogram& o);
    uint64_t count() const { return n_; }
    // Nearest-rank percentile p in (0, 100]: the upper edge of the bin holding it, at most `max`.
    double percentile(double p, double max) const;

  private:
    std::vector<uint64_t> bins_;
    uint64_t n_ = 0;
};

// The colour under another light, next to the check light: every pixel's colour under `light`,
// adapted from its white to the check light's white (Bradford), against its colour under the check
// light, as CIEDE2000 (Lab relative to the check light's white). How far a texture's colours move
// under that light: methods that give the same D65 colour can differ here.
struct OtherLightReport {
    std::string light;
    uint64_t pixels = 0;
    double de_mean = 0, de_p99 = 0, de_max = 0;
    int de_x = 0, de_y = 0;
    double rgb_min[3] = {0, 0, 0}, rgb_max[3] = {0, 0, 0};  // linear RGB under the light, adapted
};

struct VerifyReport {
    std::string file;
    int width = 0, height = 0;
    uint64_t pixels = 0;
    int bins = 0;
    double lambda_min = 0, lambda_max = 0;
    std::string wavelengths;  // WavelengthGrid::describe()
    std::string sample_type, compression, storage;
    AlphaKind alpha = AlphaKind::None;
    std::string illuminant, observer;
    int band_rows = 0;
    // What the file records (spectex:*; "" when absent) and what was used.
    std::string method;  // spectex:method ("" for other tools' files)
    std::string out_of_range = "clamp",
                nan = "replace";  // the bake's policies (defaults when absent)
    std::string half_rounding;    // spectex:halfRounding ("colour", "nearest", "n/a", "")
    // The file's compression when it changes samples of the file's type ("b44 (lossy for half)",
    // from spectex:lossyCompression or the header's compression); "" when lossless.
    std::string lossy_compression;
    // --precision auto (spectex:precision*): the bake kept bits[k] of half's mantissa in bin k,
    // chosen so that the rounding costs at most max_de ΔE00 against the unrounded spectra under
    // `lights`; the colour-aware rounding still holds every 8-bit code under the illuminant
    // (the code gate applies as to any half file). Empty precision: full half.
    std::string precision, precision_max_de, precision_lights, precision_worst_de;
    // What the recorded worst covers (spectex:precisionSample): the file against the method's own
    // spectrum at 1 nm, or (files baked before, a given basis) the rounding alone.
    std::string precision_covers;
    std::vector<int> precision_bits;
    std::vector<std::string>
        warnings;  // settings given that differ from the file's, config not found, ...
    std::vector<OtherLightReport> other_lights;

    // Spectral samples (pixels x bins), as stored.
    uint64_t samples = 0;
    uint64_t below_zero = 0, above_one = 0;  // strictly outside [0, 1]
    uint64_t below_tol = 0, above_tol = 0;   // < -1e-6 or > 1 + 1e-6
    // Associated alpha: the four counts above are of the straight samples T/A (pixels with A > 0),
    // "above" tolerating each bin's rounding step instead of 1e-6 (verify.cpp,
    // straight_tolerances). A method that is not linear expands the straight colour, so a
    // premultiplied expansion (method(A rgb)) shows here.
    bool straight_range = false;
    uint64_t nonfinite = 0;  // NaN or Inf
    // Integrated linear RGB (straight colour) over the pixels with finite values.
    double rgb_min[3] = {0, 0, 0}, rgb_max[3] = {0, 0, 0};

    // The source is not the one this file was baked from: its size, or else its bytes (FNV-1a 64),
    // differ from what the header records (spectex:sourceSize, spectex:sourceHash; its date is not
    // looked at: a touch or a checkout of the same bytes changes nothing). Its colours are then not
    // compared: the file is stale, not a bad bake (a failed gate of its own). Not checked when the
    // header records no identity (files baked before spectex recorded it, other tools' files).
    struct SourceChange {
        std::string file;                 // the source looked at
        std::string why;                  // "its size is ... bytes, ..." / "same size, other bytes"
        std::string recorded_size, size;  // bytes, in decimal
        std::string recorded_hash, hash;  // "fnv1a64:<hex>"; hash "" when the size told already
    };
    bool source_changed = false;
    SourceChange change;

    // With a source.
    bool compared = false;
    std::string source, source_colorspace, source_colorspace_how;
    int source_bits = 0;
    bool source_float = false;
    uint64_t compared_pixels = 0;  // pixels whose colour was compared
    uint64_t transparent_pixels =
        0;                          // associated alpha with A <= 0: colour not recoverable, skipped
    uint64_t nonfinite_pixels = 0;  // compared pixels whose integrated colour is not finite
    uint64_t source_clamped = 0, source_replaced = 0;  // as bake's default policies would report
    double rgb_error_max = 0, rgb_error_mean = 0;      // absolute, linear RGB, over pixels x 3
    int rgb_error_x = 0, rgb_error_y = 0;              // where the max is (data window coordinates)
    // The largest linear RGB error beyond 2^-10 of the source's value (kCoarseRelativeTolerance):
    // what the precision budget's coarser grids hold besides their share of each channel.
    double rgb_error_beyond_relative_max = 0;
    double de_max = 0, de_mean = 0, de_p99 = 0;  // CIEDE2000
    int de_x = 0, de_y = 0;
    // With source_clamped, as bake reports it: the farthest outside [0, 1] a clamped value was.
    float source_clamped_excursion = 0;
    bool code_match_available = false;
    std::string code_match_note;  // why not available, or which encoding was used
    uint64_t code_checked = 0;  // compared pixels the bake's policies left unchanged (not clamped,
                                // not replaced): only those can re-encode to their codes
    uint64_t code_matched = 0;  // of code_checked
    double code_match_share() const {
        return code_checked ? static_cast<double>(code_matched) / static_cast<double>(code_checked)
                            : 1.0;
    }

    double seconds = 0;
};

// Throws Error("<file>: <cause>") for unreadable or non-spectral files, a source whose data window
// differs in size, unknown illuminants/observers/colour spaces, or a grid outside their tables.
VerifyReport verify_file(const std::string& exr_path, const VerifySettings& s);

// The gates a report must pass. Defaults (report_only false, nothing explicit) are ones a correct
// bake always passes and a wrong one fails:
//   * no non-finite sample;
//   * no sample more than 1e-6 outside [0, 1] unless the file records --out-of-range keep
//     (half and float store 0 and 1 exactly; the colour-aware rounding never leaves [0, 1]);
//   * with a source, for methods that are exact (not jakob-hanika):
//       - codes: every pixel the bake left unchanged re-encodes to its 8-bit code, in half and in
//         float (99.99 % for half written with plain rounding, which can miss one colour in
//         millions); 16-bit codes likewise in float; in half, which cannot keep 16-bit codes, the
//         linear RGB error instead (1e-4 with the colour-aware rounding, 5e-4 with plain rounding);
//       - CIEDE2000 max <= 0.5 (a correct bake measures below 0.05; 1 is about a just-visible
//         difference).
// Explicit thresholds replace the matching default.
struct VerifyGates {
    bool report_only = false;
    bool de = false, rgb = false, code = false;
    double max_de = 0, max_rgb = 0, min_code = 0;  // min_code in percent
};
constexpr double kDefaultMaxDe = 0.5;
// One line per failed gate, naming it and by how much it failed; empty when all pass. A changed
// source is the first line, stale_failure(r).
std::vector<std::string> gate_failures(const VerifyReport& r, const VerifyGates& g);
// "the source <file> changed since this file was baked (<why>)" ("" when it did not).
std::string stale_failure(const VerifyReport& r);
// A file's result: "ok", "FAILED", or "STALE" when the source changed since the bake (a failure of
// its own kind).
std::string verify_result_word(const VerifyReport& r, const std::vector<std::string>& failures);

// One file of a verify run: its report and the gates it failed, or why it could not be verified.
struct VerifyOutcome {
    bool readable = false;
    VerifyReport report;
    std::string error;
    std::vector<std::string> failures;
    // An unreadable file's warnings found before its error (a recorded config not there): they
    // often say why it failed, so they are printed before it.
    std::vector<std::string> warnings;
};
// A file verify_file could not check, with the warnings it had given by then.
class VerifyError : public Error {
  public:
    VerifyError(const std::string& what, std::vector<std::string> warnings)
        : Error(what), warnings(std::move(warnings)) {}
    std::vector<std::string> warnings;
};
// Verifies `files`, `jobs` at once, each against s.source or, with source_from_header, the source
// its header records; the outcomes are in the files' order. Never throws for a file: its error is
// in its outcome.
// The source that the header of `exr` records (`attributes`: its attributes as read), found from
// wherever the command runs: relative to the EXR's folder (spectex:sourceFromOutput: the source
// and output trees moved together), then absolute (spectex:sourceAbsolute), then as given at bake
// time (spectex:source, relative to this working folder): the first that exists. Throws Error
// naming the EXR and every place tried when none does, or when the header records no source.
std::string recorded_source(const std::string& exr,
                            const std::vector<std::pair<std::string, std::string>>& attributes);

std::vector<VerifyOutcome> verify_files(const std::vector<std::string>& files,
                                        const VerifySettings& s, const VerifyGates& g,
                                        bool source_from_header, int jobs);
// Report text: a share as a percentage with enough digits to show one sample of a large image ("0%"
// and "100%" exactly when none or all); numbers are base/text's number_text.
std::string share_text(uint64_t count, uint64_t total);
// The gates that were applied, as text ("non-finite samples: none", ...), for the report.
std::vector<std::string> gates_applied(const VerifyReport& r, const VerifyGates& g);

}  // namespace spectex
