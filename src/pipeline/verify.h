#pragma once
// `spectex verify`: reads a reflective spectral OpenEXR (Fichet 2021 layout, from spectex or any
// other tool) a band of rows at a time, integrates every pixel under an illuminant with an observer
// on the file's own bins, and measures it: samples outside [0, 1] and non-finite samples always;
// with a source image, the round-trip error against it (linear RGB, CIEDE2000, code re-encoding).
// Memory is bounded by the band size, never by the image size.
#include <cstdint>
#include <string>
#include <vector>

namespace spectex {

struct VerifySettings {
    std::string source;                 // --source ("" = no comparison)
    std::string illuminant = "D65";     // name or CSV file
    std::string observer = "cie1931-2"; // name or CSV file
    std::string colorspace;             // --colorspace of the source ("" = metadata, then file rules)
    std::string config;                 // --config ("" = $OCIO, then the shipped config)
    std::string data_dir;
    uint64_t max_pixels = 268435456;    // refuse larger sources (as bake does)
    size_t band_bytes = 8u << 20;       // float spectral samples per band buffer (two buffers are used)
    int threads = 0;                    // compute threads (0 = all cores)
};

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

struct VerifyReport {
    std::string file;
    int width = 0, height = 0;
    uint64_t pixels = 0;
    int bins = 0;
    double lambda_min = 0, lambda_max = 0;
    std::string wavelengths;           // WavelengthGrid::describe()
    std::string sample_type, compression, storage;
    std::string alpha = "none";        // "none", "associated", "unassociated"
    std::string illuminant, observer;
    int band_rows = 0;

    // Spectral samples (pixels x bins), as stored.
    uint64_t samples = 0;
    uint64_t below_zero = 0, above_one = 0;       // strictly outside [0, 1]
    uint64_t below_tol = 0, above_tol = 0;        // < -1e-6 or > 1 + 1e-6
    uint64_t nonfinite = 0;                       // NaN or Inf
    // Integrated linear RGB (straight colour) over the pixels with finite values.
    double rgb_min[3] = {0, 0, 0}, rgb_max[3] = {0, 0, 0};

    // With a source.
    bool compared = false;
    std::string source, source_colorspace, source_colorspace_how;
    int source_bits = 0;
    bool source_float = false;
    uint64_t compared_pixels = 0;      // pixels whose colour was compared
    uint64_t transparent_pixels = 0;   // associated alpha with A <= 0: colour not recoverable, skipped
    uint64_t nonfinite_pixels = 0;     // compared pixels whose integrated colour is not finite
    uint64_t source_clamped = 0, source_replaced = 0;  // as bake's default policies would report
    double rgb_error_max = 0, rgb_error_mean = 0;      // absolute, linear RGB, over pixels x 3
    int rgb_error_x = 0, rgb_error_y = 0;              // where the max is (data window coordinates)
    double de_max = 0, de_mean = 0, de_p99 = 0;        // CIEDE2000
    int de_x = 0, de_y = 0;
    bool code_match_available = false;
    std::string code_match_note;       // why not available, or which encoding was used
    uint64_t code_matched = 0;         // of compared_pixels
    double code_match_share() const {
        return compared_pixels ? static_cast<double>(code_matched) / static_cast<double>(compared_pixels) : 1.0;
    }

    double seconds = 0;
};

// Throws Error("<file>: <cause>") for unreadable or non-spectral files, a source whose data window
// differs in size, unknown illuminants/observers/colour spaces, or a grid outside their tables.
VerifyReport verify_file(const std::string& exr_path, const VerifySettings& s);

}  // namespace spectex
