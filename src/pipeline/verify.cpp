#include "pipeline/verify.h"

#include <sys/stat.h>

#include <algorithm>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>

#include "base/error.h"
#include "base/task_pool.h"
#include "base/text.h"
#include "io/exr_compression.h"
#include "io/file_identity.h"
#include "io/image_source.h"
#include "io/linearizer.h"
#include "io/ocio_config.h"
#include "io/provenance_keys.h"
#include "io/source_identity.h"
#include "io/spectral_exr_info.h"
#include "io/spectral_reader.h"
#include "pipeline/batch_files.h"
#include "pipeline/method_table.h"
#include "pipeline/pixel_policy.h"
#include "spectral/adaptation.h"
#include "spectral/ciede2000.h"
#include "spectral/colorimetry.h"
#include "spectral/precision.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

// ---------------------------------------------------------------------------------------------
// ErrorHistogram

namespace {
constexpr double kHistLo = 1e-8;
constexpr int kHistPerDecade = 1000;
constexpr int kHistDecades = 12;                              // 1e-8 .. 1e4
constexpr int kHistBins = kHistPerDecade * kHistDecades + 2;  // + [0, lo) and [1e4, inf]
}  // namespace

ErrorHistogram::ErrorHistogram() : bins_(kHistBins, 0) {}

void ErrorHistogram::add(double v) {
    int i;
    if (!(v >= kHistLo)) {
        i = std::isnan(v) ? kHistBins - 1 : 0;
    } else {
        double f = std::log10(v / kHistLo) * kHistPerDecade;
        i = f >= kHistPerDecade * kHistDecades ? kHistBins - 1 : 1 + static_cast<int>(f);
    }
    ++bins_[static_cast<size_t>(i)];
    ++n_;
}

void ErrorHistogram::merge(const ErrorHistogram& o) {
    for (size_t i = 0; i < bins_.size(); ++i) bins_[i] += o.bins_[i];
    n_ += o.n_;
}

double ErrorHistogram::percentile(double p, double max) const {
    if (n_ == 0) return 0.0;
    uint64_t rank = static_cast<uint64_t>(std::ceil(p / 100.0 * static_cast<double>(n_)));
    rank = std::max<uint64_t>(1, std::min(rank, n_));
    uint64_t cum = 0;
    for (int i = 0; i < kHistBins; ++i) {
        cum += bins_[static_cast<size_t>(i)];
        if (cum >= rank) {
            if (i == kHistBins - 1) return max;
            double upper = kHistLo * std::pow(10.0, static_cast<double>(i) / kHistPerDecade);
            return std::min(upper, max);
        }
    }
    return max;
}

// ---------------------------------------------------------------------------------------------

namespace {

// One band of rows: the spectral planes (bin-major, as float), alpha, and the source's pixels.
struct Band {
    int y0 = 0, rows = 0;          // rows of the data window, 0-based
    std::vector<float> planes;     // bins x (w * band_rows)
    std::vector<float> alpha;      // w * band_rows
    std::vector<float> raw, lin;   // source RGBA as read, and linearised + sanitised
    std::vector<uint8_t> changed;  // the bake's policies changed this source pixel (clamp, NaN)
    uint64_t clamped = 0, replaced = 0;
};

// Accumulators of one other light (OtherLightReport).
struct LightStats {
    uint64_t pixels = 0;
    double de_max = -1, de_sum = 0;
    int de_x = 0, de_y = 0;
    double rgb_min[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, rgb_max[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    ErrorHistogram hist;
};

// Per-thread accumulators, merged at the end.
struct Stats {
    uint64_t below_zero = 0, above_one = 0, below_tol = 0, above_tol = 0, nonfinite = 0;
    double rgb_min[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, rgb_max[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    uint64_t compared = 0, transparent = 0, nonfinite_pixels = 0, code_checked = 0,
             code_matched = 0;
    double rgb_err_max = -1, rgb_err_sum = 0;
    int rgb_err_x = 0, rgb_err_y = 0;
    double de_max = -1, de_sum = 0;
    int de_x = 0, de_y = 0;
    ErrorHistogram hist;
    std::vector<LightStats> lights;
};

// Another light: XYZ weights already adapted to the check light's white (Bradford), so that the
// adapted XYZ of a spectrum S is xyz_weights · S.
struct OtherLight {
    Eigen::Matrix3Xd xyz_weights;
};

struct Context {
    size_t w = 0, plane = 0;  // plane = w * band_rows
    int bins = 0;
    int x0 = 0, y0 = 0;            // data window origin, for reported coordinates
    const double* wrgb = nullptr;  // 3 x bins, column-major (Eigen)
    Eigen::Matrix3d rgb_to_xyz, xyz_to_rgb;
    Eigen::Vector3d white;
    bool has_alpha = false, associated = false, compare = false;
    const Linearizer* encoder =
        nullptr;  // re-encodes linear Rec.709 to the source's space (code check)
    double max_code = 255;
    bool source_associated = false;
    std::vector<OtherLight> lights;
};

constexpr size_t kBlock = 256;  // pixels integrated together, so that the bins stream in order

// XYZ of pixels [i0, i0 + m) under each other light, adapted: lacc[(3 l + ch) kBlock + j].
void integrate_other_lights(const Context& c, const Band& b, size_t i0, size_t m,
                            std::vector<double>& lacc) {
    std::fill(lacc.begin(), lacc.end(), 0.0);
    for (size_t l = 0; l < c.lights.size(); ++l) {
        const Eigen::Matrix3Xd& Wl = c.lights[l].xyz_weights;
        double* a = &lacc[l * 3 * kBlock];
        for (int k = 0; k < c.bins; ++k) {
            const float* p = b.planes.data() + static_cast<size_t>(k) * c.plane + i0;
            const double w0 = Wl(0, k), w1 = Wl(1, k), w2 = Wl(2, k);
            for (size_t j = 0; j < m; ++j) {
                const double d = p[j];
                a[j] += w0 * d;
                a[kBlock + j] += w1 * d;
                a[2 * kBlock + j] += w2 * d;
            }
        }
    }
}

// Linear RGB of pixels [i0, i0 + m) into acc, and the samples outside [0, 1] or not finite.
void integrate_block(const Context& c, const Band& b, size_t i0, size_t m, double (*acc)[kBlock],
                     Stats& st) {
    for (int ch = 0; ch < 3; ++ch) std::fill(acc[ch], acc[ch] + m, 0.0);
    // Fast path: integrate and track the block's range; NaN fails both comparisons of the
    // range check below, Inf lands in it. Samples are counted one by one only when needed.
    float lo = 0.0f, hi = 1.0f;
    bool nan = false;
    for (int k = 0; k < c.bins; ++k) {
        const float* p = b.planes.data() + static_cast<size_t>(k) * c.plane + i0;
        const double w0 = c.wrgb[3 * k], w1 = c.wrgb[3 * k + 1], w2 = c.wrgb[3 * k + 2];
        for (size_t j = 0; j < m; ++j) {
            const float v = p[j];
            const double d = v;
            acc[0][j] += w0 * d;
            acc[1][j] += w1 * d;
            acc[2][j] += w2 * d;
            lo = v < lo ? v : lo;
            hi = v > hi ? v : hi;
            nan |= v != v;
        }
    }
    if (!(lo < 0.0f || hi > 1.0f || nan)) return;
    const float hi_tol = 1.0f + 1e-6f;
    uint64_t below0 = 0, above1 = 0, belowt = 0, abovet = 0, nonfin = 0;
    for (int k = 0; k < c.bins; ++k) {
        const float* p = b.planes.data() + static_cast<size_t>(k) * c.plane + i0;
        for (size_t j = 0; j < m; ++j) {
            const float v = p[j];
            below0 += v < 0.0f;
            above1 += v > 1.0f;
            belowt += v < -1e-6f;
            abovet += v > hi_tol;
            nonfin += !(std::fabs(v) <= FLT_MAX);
        }
    }
    st.below_zero += below0;
    st.above_one += above1;
    st.below_tol += belowt;
    st.above_tol += abovet;
    st.nonfinite += nonfin;
}

// Pixel j of the block under each other light (XYZ in lacc, still premultiplied by alpha when
// inv_a != 1) against its colour rgb under the check light.
void add_other_lights(const Context& c, const std::vector<double>& lacc, size_t j,
                      const double* rgb, double inv_a, int px, int py, Stats& st) {
    const Eigen::Vector3d ref = c.rgb_to_xyz * Eigen::Vector3d(rgb[0], rgb[1], rgb[2]);
    const Lab ref_lab = lab_from_xyz(ref, c.white);
    for (size_t l = 0; l < c.lights.size(); ++l) {
        const double* a = &lacc[l * 3 * kBlock];
        const Eigen::Vector3d xyz(a[j] * inv_a, a[kBlock + j] * inv_a, a[2 * kBlock + j] * inv_a);
        if (!xyz.allFinite()) continue;
        LightStats& ls = st.lights[l];
        ++ls.pixels;
        const double de = ciede2000(lab_from_xyz(xyz, c.white), ref_lab);
        ls.de_sum += de;
        if (de > ls.de_max) ls.de_max = de, ls.de_x = px, ls.de_y = py;
        ls.hist.add(de);
        const Eigen::Vector3d lrgb = c.xyz_to_rgb * xyz;
        for (int ch = 0; ch < 3; ++ch) {
            ls.rgb_min[ch] = std::min(ls.rgb_min[ch], lrgb[ch]);
            ls.rgb_max[ch] = std::max(ls.rgb_max[ch], lrgb[ch]);
        }
    }
}

// Pixel idx (colour rgb) against the source's linearised pixel: linear RGB error and CIEDE2000.
void compare_with_source(const Band& b, const Context& c, size_t idx, const double* rgb,
                         bool finite, int px, int py, Stats& st) {
    ++st.compared;
    const float* src = &b.lin[4 * idx];
    if (!finite) {
        ++st.nonfinite_pixels;
        const double inf = std::numeric_limits<double>::infinity();
        if (st.rgb_err_max < inf) st.rgb_err_max = inf, st.rgb_err_x = px, st.rgb_err_y = py;
        if (st.de_max < inf) st.de_max = inf, st.de_x = px, st.de_y = py;
        st.rgb_err_sum = inf;
        st.de_sum = inf;
        st.hist.add(inf);
        return;
    }
    double emax = 0;
    for (int ch = 0; ch < 3; ++ch) {
        const double e = std::fabs(rgb[ch] - static_cast<double>(src[ch]));
        st.rgb_err_sum += e;
        emax = std::max(emax, e);
    }
    if (emax > st.rgb_err_max) st.rgb_err_max = emax, st.rgb_err_x = px, st.rgb_err_y = py;
    const Eigen::Vector3d v1(rgb[0], rgb[1], rgb[2]);
    const Eigen::Vector3d v2(src[0], src[1], src[2]);
    double de = 0;
    if (v1 != v2)
        de = ciede2000(lab_from_xyz(c.rgb_to_xyz * v1, c.white),
                       lab_from_xyz(c.rgb_to_xyz * v2, c.white));
    st.de_sum += de;
    if (de > st.de_max) st.de_max = de, st.de_x = px, st.de_y = py;
    st.hist.add(de);
}

// Code check of nenc pixels: their colours (enc, RGBA) re-encoded through the config's inverse
// transform and rounded to the source's codes, against the codes the source holds.
void check_codes(const Context& c, const Band& b, float* enc, const size_t* enc_idx, size_t nenc,
                 Stats& st) {
    c.encoder->encode_rgba(enc, static_cast<long>(nenc));
    for (size_t e = 0; e < nenc; ++e) {
        const float* raw = &b.raw[4 * enc_idx[e]];
        const double k = c.source_associated ? static_cast<double>(raw[3]) : 1.0;
        bool match = true;
        for (int ch = 0; ch < 3 && match; ++ch) {
            const double v = std::min(1.0, std::max(0.0, static_cast<double>(enc[4 * e + ch])));
            const long expect = std::lround(v * k * c.max_code);
            const long have = std::lround(static_cast<double>(raw[ch]) * c.max_code);
            match = expect == have;
        }
        ++st.code_checked;
        st.code_matched += match;
    }
}

// Measures pixels [begin, end) of band b into st.
void compute_range(const Context& c, const Band& b, size_t begin, size_t end, Stats& st) {
    double acc[3][kBlock];
    const size_t nl = c.lights.size();
    std::vector<double> lacc(nl * 3 * kBlock);  // XYZ under each other light, adapted
    float enc[4 * kBlock];                      // colours to re-encode (code check)
    size_t enc_idx[kBlock];
    if (st.lights.size() < nl) st.lights.resize(nl);
    for (size_t i0 = begin; i0 < end; i0 += kBlock) {
        const size_t m = std::min(kBlock, end - i0);
        integrate_other_lights(c, b, i0, m, lacc);
        integrate_block(c, b, i0, m, acc, st);
        size_t nenc = 0;
        for (size_t j = 0; j < m; ++j) {
            const size_t idx = i0 + j;
            double rgb[3] = {acc[0][j], acc[1][j], acc[2][j]};
            if (c.associated) {
                const double a = b.alpha[idx];
                if (!(a > 0)) {
                    if (c.compare) ++st.transparent;
                    continue;
                }
                for (double& v : rgb) v /= a;
            }
            const bool finite =
                std::isfinite(rgb[0]) && std::isfinite(rgb[1]) && std::isfinite(rgb[2]);
            if (finite)
                for (int ch = 0; ch < 3; ++ch) {
                    st.rgb_min[ch] = std::min(st.rgb_min[ch], rgb[ch]);
                    st.rgb_max[ch] = std::max(st.rgb_max[ch], rgb[ch]);
                }
            const int px = c.x0 + static_cast<int>(idx % c.w);
            const int py = c.y0 + b.y0 + static_cast<int>(idx / c.w);
            if (finite && nl)
                add_other_lights(c, lacc, j, rgb,
                                 c.associated ? 1.0 / static_cast<double>(b.alpha[idx]) : 1.0, px,
                                 py, st);
            if (!c.compare) continue;
            compare_with_source(b, c, idx, rgb, finite, px, py, st);
            if (finite && c.encoder && !b.changed[idx]) {
                for (int ch = 0; ch < 3; ++ch) enc[4 * nenc + ch] = static_cast<float>(rgb[ch]);
                enc[4 * nenc + 3] = 1.0f;
                enc_idx[nenc++] = idx;
            }
        }
        if (nenc) check_codes(c, b, enc, enc_idx, nenc, st);
    }
}

// The file's size, bins and storage, as the report states them.
VerifyReport describe_file(const std::string& exr_path, const SpectralExrInfo& info) {
    VerifyReport r;
    r.file = exr_path;
    r.width = info.width;
    r.height = info.height;
    r.pixels = static_cast<uint64_t>(info.width) * static_cast<uint64_t>(info.height);
    r.bins = static_cast<int>(info.reflective.size());
    r.lambda_min = info.reflective.front().lambda;
    r.lambda_max = info.reflective.back().lambda;
    r.sample_type = info.sample_type;
    r.compression = info.compression;
    r.storage = info.tiled ? "tiled " + std::to_string(info.tile_width) + "x" +
                                 std::to_string(info.tile_height)
                           : std::string("scanline");
    r.samples = r.pixels * static_cast<uint64_t>(r.bins);
    return r;
}

// What the file records, and what is used: a setting given overrides the file's, with a warning.
class Recorded {
  public:
    Recorded(const SpectralExrInfo& info, std::vector<std::string>& warnings)
        : info_(info), warnings_(warnings) {}
    std::string operator()(const std::string& key) const {
        for (const auto& [k, v] : info_.attributes)
            if (k == key) return v;
        return std::string();
    }
    std::string choose(const std::string& given, const std::string& key,
                       const std::string& fallback, const std::string& option) const {
        const std::string rec = (*this)(key);
        if (given.empty()) return rec.empty() ? fallback : rec;
        if (!rec.empty() && lower_ascii(given) != lower_ascii(rec))
            warnings_.push_back(option + " '" + given + "' overrides the file's '" + rec + "' (" +
                                key + ")");
        return given;
    }

  private:
    const SpectralExrInfo& info_;
    std::vector<std::string>& warnings_;
};

// The bake's settings the file records, or those given instead.
void read_recorded_settings(const Recorded& recorded, const VerifySettings& s, VerifyReport& r) {
    r.method = recorded(provenance_key::kMethod);
    // spectex before 0.1's methods recorded only the basis.
    if (r.method.empty() && !recorded(provenance_key::kBasis).empty()) r.method = "basis";
    if (const std::string v = recorded(provenance_key::kOutOfRange); !v.empty()) r.out_of_range = v;
    if (const std::string v = recorded(provenance_key::kNan); !v.empty()) r.nan = v;
    r.half_rounding = recorded(provenance_key::kHalfRounding);
    r.precision = recorded(provenance_key::kPrecision);
    if (!r.precision.empty()) {
        r.precision_max_de = recorded(provenance_key::kPrecisionMaxDe);
        r.precision_lights = recorded(provenance_key::kPrecisionLights);
        r.precision_worst_de = recorded(provenance_key::kPrecisionWorstDe);
        try {
            r.precision_bits = parse_precision_bits(recorded(provenance_key::kPrecisionBits),
                                                    static_cast<size_t>(r.bins));
        } catch (const Error& e) {
            r.warnings.push_back(std::string(provenance_key::kPrecisionBits) + ": " + e.what());
        }
    }
    r.lossy_compression = recorded(provenance_key::kLossyCompression);
    if (r.lossy_compression.empty())
        if (const ExrCompression* c = ExrCompression::find(r.compression)) {
            const bool half = r.sample_type == "half" || r.sample_type == "mixed";
            if (c->lossy_for(half) || (r.sample_type == "mixed" && c->lossy_for(false)))
                r.lossy_compression = c->name + " (" + c->lossy_text() + ")";
        }
    r.illuminant =
        recorded.choose(s.illuminant, provenance_key::kIlluminant, "D65", "--check-illuminant");
    r.observer = recorded.choose(s.observer, provenance_key::kObserver, "cie1931-2", "--observer");
}

// The check light's colorimetry on the file's own bins; the other lights, adapted to its white,
// go to ctx.
Colorimetry file_colorimetry(const std::string& exr_path, const SpectralExrInfo& info,
                             const VerifySettings& s, VerifyReport& r, Context& ctx) {
    std::vector<double> lambdas;
    for (const auto& b : info.reflective) lambdas.push_back(b.lambda);
    try {
        WavelengthGrid grid = WavelengthGrid::from_list(lambdas);
        r.wavelengths = grid.describe();
        Observer obs = load_observer(s.data_dir, r.observer);
        Colorimetry col = Colorimetry::make(obs, load_illuminant(s.data_dir, r.illuminant), grid,
                                            primaries_by_name("srgb"));
        for (const auto& name : s.other_lights) {
            const Colorimetry cl = Colorimetry::make(obs, load_illuminant(s.data_dir, name), grid,
                                                     primaries_by_name("srgb"));
            ctx.lights.push_back({bradford_adaptation(cl.white_xyz, col.white_xyz) * cl.W});
            OtherLightReport lr;
            lr.light = name;
            r.other_lights.push_back(lr);
        }
        return col;
    } catch (const Error& e) {
        throw Error(exr_path + ": " + e.what());
    }
}

// The OCIO config for the source: the one given, else the one the bake used when it is still
// there; a missing config is warned about, and a changed one when the file records no colour
// transform (open_source compares the transform itself when it does).
std::string choose_config(const Recorded& recorded, const VerifySettings& s, VerifyReport& r) {
    std::string config = s.config;
    const std::string rec_config = recorded(provenance_key::kConfig),
                      rec_sum = recorded(provenance_key::kColorTransform).empty()
                                    ? recorded(provenance_key::kConfigChecksum)
                                    : std::string();
    if (config.empty() && !rec_config.empty()) {
        if (file_id(rec_config)) {
            config = rec_config;
            if (!rec_sum.empty() && config_checksum(rec_config) != rec_sum)
                r.warnings.push_back("the OCIO config the file records (" + rec_config +
                                     ") has changed since the bake");
        } else {
            const char* env = std::getenv("OCIO");
            r.warnings.push_back(
                "the OCIO config the file records (" + rec_config + ") is not there; using " +
                (env && *env ? "$OCIO's " : "the shipped config ") +
                ocio_config_path(s.data_dir, "") + " instead (--config FILE chooses another)");
        }
    } else if (!config.empty() && !rec_sum.empty() && config_checksum(config) != rec_sum) {
        r.warnings.push_back("--config " + config + " differs from the config the file records (" +
                             rec_config + ")");
    }
    return config;
}

// Whether `source` names the file the header records as its source (found as recorded_source finds
// it): the same file, links followed.
bool is_recorded_source(const std::string& exr, const SpectralExrInfo& info,
                        const std::string& source) {
    try {
        std::error_code ec;
        return std::filesystem::equivalent(recorded_source(exr, info.attributes), source, ec);
    } catch (const Error&) {
        return false;  // the header records no source, or it is not found
    }
}

// Whether `source` is the file the header records: its size first (a stat), then its bytes' hash
// (read, not decoded). Sets r.source_changed and r.change when it is not; nothing when the header
// records no identity. Throws Error naming the source when it cannot be read.
void check_source_identity(const std::string& source, const Recorded& recorded, VerifyReport& r) {
    VerifyReport::SourceChange c;
    c.file = source;
    c.recorded_size = recorded(provenance_key::kSourceSize);
    c.recorded_hash = recorded(provenance_key::kSourceHash);
    if (c.recorded_size.empty() && c.recorded_hash.empty()) return;
    struct stat st;
    if (::stat(source.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return;  // open_source says why
    c.size = SourceIdentity::of(st).size_text();
    if (!c.recorded_size.empty() && c.size != c.recorded_size) {
        c.why = "it has " + c.size + " bytes; it had " + c.recorded_size + " when this was baked";
    } else if (!c.recorded_hash.empty()) {
        c.hash = hash_file(source);
        if (c.hash == c.recorded_hash) return;
        c.why = "same size, other bytes: " + c.hash + ", not the " + c.recorded_hash +
                " this was baked from";
    } else {
        return;
    }
    r.source_changed = true;
    r.change = c;
}

// The code check, when the source's codes can be checked: what the report says of it, and the
// encoder it needs in ctx.
void plan_code_check(const SourceInfo& si, const Linearizer& lin, VerifyReport& r, Context& ctx) {
    if (si.is_float) {
        r.code_match_note = "float source: no codes to match";
    } else if (si.bits != 8 && si.bits != 16) {
        r.code_match_note =
            std::to_string(si.bits) + "-bit source: only 8- and 16-bit codes are checked";
    } else if (!lin.can_encode()) {
        r.code_match_note = "the config cannot invert the transform of '" + lin.input_space() + "'";
    } else {
        ctx.encoder = &lin;
        r.code_match_note =
            "re-encoded through the config's inverse transform to '" + lin.input_space() + "'";
    }
    r.code_match_available = ctx.encoder != nullptr;
    ctx.max_code = si.bits == 16 ? 65535.0 : 255.0;
}

// The source, opened and checked before any pixel is read, with the linearisation the file
// records (or the one given).
std::unique_ptr<ImageSource> open_source(const std::string& exr_path, const SpectralExrInfo& info,
                                         const VerifySettings& s, const Recorded& recorded,
                                         VerifyReport& r, Linearizer& lin, Context& ctx) {
    auto src = ImageSource::open(s.source, s.max_pixels);
    const SourceInfo& si = src->info();
    if (si.width != info.width || si.height != info.height)
        throw Error(exr_path + ": data window " + std::to_string(info.width) + "x" +
                    std::to_string(info.height) + " differs from the source's " +
                    std::to_string(si.width) + "x" + std::to_string(si.height) + " (" + s.source +
                    ")");
    const std::string config = choose_config(recorded, s, r);
    const std::string rec_space = recorded(provenance_key::kInputColorSpace);
    ColourRequest req{s.data_dir, config, s.colorspace.empty() ? rec_space : s.colorspace, s.source,
                      si.colour};
    lin = Linearizer::make(req);
    // What the config does to the source, against what it did at the bake: a comment or a colour
    // space the file does not use is no change.
    const std::string rec_transform = recorded(provenance_key::kColorTransform);
    if (!rec_transform.empty() && lin.input_space() == rec_space &&
        lin.transform_id() != rec_transform)
        r.warnings.push_back("the OCIO config " + lin.config_path() + " transforms '" + rec_space +
                             "' otherwise than the one this file was baked with (" +
                             provenance_key::kColorTransform + ")");
    if (!s.colorspace.empty() && !rec_space.empty() && lin.input_space() != rec_space)
        r.warnings.push_back("--colorspace '" + s.colorspace + "' ('" + lin.input_space() +
                             "') overrides the file's '" + rec_space + "' (" +
                             provenance_key::kInputColorSpace + ")");
    r.compared = true;
    r.source = s.source;
    r.source_colorspace = lin.input_space();
    r.source_colorspace_how = s.colorspace.empty() && !rec_space.empty()
                                  ? std::string("the file's ") + provenance_key::kInputColorSpace
                                  : lin.how_chosen();
    r.source_bits = si.bits;
    r.source_float = si.is_float;
    ctx.compare = true;
    ctx.source_associated = si.alpha == AlphaKind::Associated;
    plan_code_check(si, lin, r, ctx);
    return src;
}

// The ranges a band is cut into, one thread and one accumulator each: what --threads asks, but no
// more than the band's blocks of kBlock pixels (a 16x16 file is one block: more threads would
// only hold empty accumulators) nor thread_budget().
int measuring_threads(const VerifySettings& s, size_t band_pixels) {
    const size_t blocks = std::max<size_t>(1, (band_pixels + kBlock - 1) / kBlock);
    const int asked = s.threads > 0 ? s.threads : hardware_threads();
    return static_cast<int>(
        std::min<size_t>(blocks, static_cast<size_t>(std::min(asked, thread_budget()))));
}

// Reads the file (and the source) a band at a time, the next band while this one is measured;
// returns one accumulator per range of a band.
std::vector<Stats> measure_bands(SpectralReader& reader, ImageSource* src, const Linearizer& lin,
                                 const Context& ctx, int band_rows, const VerifySettings& s,
                                 VerifyReport& r) {
    const SpectralExrInfo& info = reader.info();
    const size_t w = ctx.w;
    Band bands[2];
    for (Band& b : bands) {
        b.planes.resize(ctx.plane * static_cast<size_t>(r.bins));
        if (info.alpha) b.alpha.resize(ctx.plane);
        if (src) {
            b.raw.resize(ctx.plane * 4);
            b.lin.resize(ctx.plane * 4);
            b.changed.resize(ctx.plane);
        }
    }
    const PixelPolicy policy{src && src->info().alpha == AlphaKind::Associated, NanPolicy::Replace,
                             r.out_of_range == "keep" ? RangePolicy::Keep : RangePolicy::Clamp};

    auto read_band = [&](Band& b, int y0) {
        b.y0 = y0;
        b.rows = std::min(band_rows, info.height - y0);
        reader.read_rows(y0, b.rows, b.planes.data(), ctx.plane,
                         info.alpha ? b.alpha.data() : nullptr);
        if (!src) return;
        const size_t n = w * static_cast<size_t>(b.rows);
        src->read_rgba(y0, y0 + b.rows, b.raw.data());
        std::copy(b.raw.begin(), b.raw.begin() + static_cast<std::ptrdiff_t>(4 * n), b.lin.begin());
        // The bake's policies, as the file records them: NaN/Inf -> 0 (a bake with --nan error
        // had none), values outside [0, 1] clamped unless --out-of-range keep.
        const PolicedCounts counts =
            police_rgba(b.lin.data(), n, lin, policy, r.source, w, y0, b.changed.data());
        b.replaced = counts.replaced;
        b.clamped = counts.clamped;
    };

    const int nthreads = measuring_threads(s, ctx.plane);
    std::vector<Stats> stats(static_cast<size_t>(nthreads));
    // Each band is cut into nthreads ranges, one accumulator each, so the sums do not depend on
    // which thread ran which range.
    auto compute_band = [&](const Band& b) {
        const size_t n = w * static_cast<size_t>(b.rows);
        const size_t per = (n + static_cast<size_t>(nthreads) - 1) / static_cast<size_t>(nthreads);
        TaskPool::shared().parallel_for(static_cast<size_t>(nthreads), nthreads, [&](size_t t) {
            const size_t begin = std::min(n, per * t), end = std::min(n, begin + per);
            if (begin < end) compute_range(ctx, b, begin, end, stats[t]);
        });
    };

    const size_t band_count = static_cast<size_t>((info.height + band_rows - 1) / band_rows);
    produce_consume_strips(
        band_count,
        [&](size_t k, int slot) { read_band(bands[slot], static_cast<int>(k) * band_rows); },
        [&](size_t, int slot) {
            compute_band(bands[slot]);
            r.source_clamped += bands[slot].clamped;
            r.source_replaced += bands[slot].replaced;
        });
    return stats;
}

// The accumulators of all ranges as one.
Stats merge_stats(const std::vector<Stats>& stats) {
    Stats total;
    for (const Stats& st : stats) {
        total.below_zero += st.below_zero;
        total.above_one += st.above_one;
        total.below_tol += st.below_tol;
        total.above_tol += st.above_tol;
        total.nonfinite += st.nonfinite;
        for (int c = 0; c < 3; ++c) {
            total.rgb_min[c] = std::min(total.rgb_min[c], st.rgb_min[c]);
            total.rgb_max[c] = std::max(total.rgb_max[c], st.rgb_max[c]);
        }
        total.compared += st.compared;
        total.transparent += st.transparent;
        total.nonfinite_pixels += st.nonfinite_pixels;
        total.code_checked += st.code_checked;
        total.code_matched += st.code_matched;
        if (total.lights.size() < st.lights.size()) total.lights.resize(st.lights.size());
        for (size_t l = 0; l < st.lights.size(); ++l) {
            LightStats& T = total.lights[l];
            const LightStats& L = st.lights[l];
            T.pixels += L.pixels;
            T.de_sum += L.de_sum;
            if (L.de_max > T.de_max || (L.de_max == T.de_max &&
                                        (L.de_y < T.de_y || (L.de_y == T.de_y && L.de_x < T.de_x))))
                T.de_max = L.de_max, T.de_x = L.de_x, T.de_y = L.de_y;
            for (int c = 0; c < 3; ++c) {
                T.rgb_min[c] = std::min(T.rgb_min[c], L.rgb_min[c]);
                T.rgb_max[c] = std::max(T.rgb_max[c], L.rgb_max[c]);
            }
            T.hist.merge(L.hist);
        }
        total.rgb_err_sum += st.rgb_err_sum;
        total.de_sum += st.de_sum;
        // Each thread keeps its first maximum; across threads, ties go to the first pixel in
        // reading order, so the reported location does not depend on the thread count.
        auto earlier = [](int y, int x, int ty, int tx) { return y < ty || (y == ty && x < tx); };
        if (st.rgb_err_max > total.rgb_err_max ||
            (st.rgb_err_max == total.rgb_err_max &&
             earlier(st.rgb_err_y, st.rgb_err_x, total.rgb_err_y, total.rgb_err_x)))
            total.rgb_err_max = st.rgb_err_max, total.rgb_err_x = st.rgb_err_x,
            total.rgb_err_y = st.rgb_err_y;
        if (st.de_max > total.de_max ||
            (st.de_max == total.de_max && earlier(st.de_y, st.de_x, total.de_y, total.de_x)))
            total.de_max = st.de_max, total.de_x = st.de_x, total.de_y = st.de_y;
        total.hist.merge(st.hist);
    }
    return total;
}

// The report's figures from the merged accumulators.
void report_totals(const Stats& total, VerifyReport& r) {
    r.below_zero = total.below_zero;
    r.above_one = total.above_one;
    r.below_tol = total.below_tol;
    r.above_tol = total.above_tol;
    r.nonfinite = total.nonfinite;
    for (int c = 0; c < 3; ++c) {
        r.rgb_min[c] = total.rgb_min[c] <= total.rgb_max[c] ? total.rgb_min[c] : 0.0;
        r.rgb_max[c] = total.rgb_min[c] <= total.rgb_max[c] ? total.rgb_max[c] : 0.0;
    }
    if (r.compared) {
        r.compared_pixels = total.compared;
        r.transparent_pixels = total.transparent;
        r.nonfinite_pixels = total.nonfinite_pixels;
        r.code_checked = total.code_checked;
        r.code_matched = total.code_matched;
        const double n = static_cast<double>(total.compared);
        r.rgb_error_max = std::max(0.0, total.rgb_err_max);
        r.rgb_error_x = total.rgb_err_x;
        r.rgb_error_y = total.rgb_err_y;
        r.rgb_error_mean = total.compared ? total.rgb_err_sum / (3.0 * n) : 0.0;
        r.de_max = std::max(0.0, total.de_max);
        r.de_x = total.de_x;
        r.de_y = total.de_y;
        r.de_mean = total.compared ? total.de_sum / n : 0.0;
        r.de_p99 = total.hist.percentile(99.0, r.de_max);
    }
    for (size_t l = 0; l < r.other_lights.size() && l < total.lights.size(); ++l) {
        OtherLightReport& o = r.other_lights[l];
        const LightStats& L = total.lights[l];
        o.pixels = L.pixels;
        o.de_max = std::max(0.0, L.de_max);
        o.de_x = L.de_x;
        o.de_y = L.de_y;
        o.de_mean = L.pixels ? L.de_sum / static_cast<double>(L.pixels) : 0.0;
        o.de_p99 = L.hist.percentile(99.0, o.de_max);
        for (int c = 0; c < 3; ++c) {
            o.rgb_min[c] = L.rgb_min[c] <= L.rgb_max[c] ? L.rgb_min[c] : 0.0;
            o.rgb_max[c] = L.rgb_min[c] <= L.rgb_max[c] ? L.rgb_max[c] : 0.0;
        }
    }
}

}  // namespace

VerifyReport verify_file(const std::string& exr_path, const VerifySettings& s) {
    const auto t0 = std::chrono::steady_clock::now();
    SpectralReader reader(exr_path);  // throws "<path>: <cause>"
    const SpectralExrInfo& info = reader.info();
    // A truncated file can still decode its first level (verify reads level 0): its other levels,
    // or later chunks, are missing.
    if (!info.complete)
        throw Error(
            exr_path +
            ": incomplete: chunks of the pixel data are missing (a truncated or interrupted file)");

    VerifyReport r = describe_file(exr_path, info);
    const Recorded recorded(info, r.warnings);
    read_recorded_settings(recorded, s, r);
    r.alpha = reader.alpha();  // "associated" is OpenEXR's convention when nothing says otherwise

    Context ctx;
    const Colorimetry col = file_colorimetry(exr_path, info, s, r, ctx);
    const Eigen::Matrix3Xd wrgb = col.rgb_weights();
    std::unique_ptr<ImageSource> src;
    Linearizer lin;
    if (!s.source.empty()) {
        // The source the header records, changed since the bake, is not compared: the file is
        // stale, whatever the colours would say. Another file given with --source (a conversion
        // of the source, say) is compared as given.
        if (is_recorded_source(exr_path, info, s.source))
            check_source_identity(s.source, recorded, r);
        if (!r.source_changed) {
            try {
                src = open_source(exr_path, info, s, recorded, r, lin, ctx);
            } catch (const Error& e) {
                throw VerifyError(e.what(), r.warnings);
            }
        }
    }

    try {
        // Whole chunks (or tile rows) per band when they fit the budget, so that no chunk is
        // decoded twice; for very wide files a band may be part of a chunk (OpenEXR keeps the
        // decoded chunk).
        const int band_rows = reader.band_rows(s.band_bytes);
        r.band_rows = band_rows;
        ctx.w = static_cast<size_t>(info.width);
        ctx.plane = ctx.w * static_cast<size_t>(band_rows);
        ctx.bins = r.bins;
        ctx.x0 = info.data_x0;
        ctx.y0 = info.data_y0;
        ctx.wrgb = wrgb.data();
        ctx.rgb_to_xyz = col.rgb_to_xyz;
        ctx.xyz_to_rgb = col.xyz_to_rgb;
        ctx.white = col.white_xyz;
        ctx.has_alpha = info.alpha;
        ctx.associated = r.alpha == AlphaKind::Associated;
        report_totals(merge_stats(measure_bands(reader, src.get(), lin, ctx, band_rows, s, r)), r);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(exr_path + ": cannot read the pixels: " + e.what());
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

uint64_t verify_memory_estimate(size_t lights, int threads, int jobs, const VerifySettings& s) {
    const uint64_t per_light = sizeof(LightStats) + kHistBins * sizeof(uint64_t) +
                               3 * kBlock * sizeof(double);  // histogram + XYZ block
    const uint64_t per_thread = sizeof(Stats) + kHistBins * sizeof(uint64_t) + per_light * lights;
    // Two bands of spectral samples, and the source's pixels as read and linearised (RGBA float,
    // at most the same size again).
    const uint64_t per_job = 4 * static_cast<uint64_t>(s.band_bytes) +
                             per_thread * static_cast<uint64_t>(std::max(1, threads));
    return per_job * static_cast<uint64_t>(std::max(1, jobs));
}

void check_verify_memory(size_t lights, int threads, int jobs, const VerifySettings& s) {
    const uint64_t need = verify_memory_estimate(lights, threads, jobs, s);
    if (need <= kVerifyMemoryLimit) return;
    throw LimitError("--illuminant: " + std::to_string(lights) + " lights x " +
                     std::to_string(threads) + " threads x " + std::to_string(jobs) +
                     " jobs need about " + std::to_string(need >> 20) +
                     " MiB (about 100 KB per light and thread), over the limit of " +
                     std::to_string(kVerifyMemoryLimit >> 20) +
                     " MiB (1 GiB); give fewer lights, --threads or --jobs");
}

std::string recorded_source(const std::string& exr,
                            const std::vector<std::pair<std::string, std::string>>& attributes) {
    namespace fs = std::filesystem;
    std::string given, absolute, from_output;
    for (const auto& [k, v] : attributes) {
        if (k == provenance_key::kSource) given = v;
        if (k == provenance_key::kSourceAbsolute) absolute = v;
        if (k == provenance_key::kSourceFromOutput) from_output = v;
    }
    if (given.empty() && absolute.empty() && from_output.empty())
        throw Error(exr + ": the header records no " + provenance_key::kSource);
    std::vector<std::string> tried;
    if (!from_output.empty())
        tried.push_back((fs::path(exr).parent_path() / from_output).lexically_normal().string());
    if (!absolute.empty()) tried.push_back(absolute);
    if (!given.empty()) tried.push_back(given);
    for (const auto& p : tried) {
        std::error_code ec;
        if (fs::exists(p, ec)) return p;
    }
    std::string list;
    for (const auto& p : tried) list += (list.empty() ? "" : ", ") + quote_path(p);
    throw Error(exr + ": the source it records is not found (tried " + list + ")");
}

std::vector<VerifyOutcome> verify_files(const std::vector<std::string>& files,
                                        const VerifySettings& s, const VerifyGates& g,
                                        bool source_from_header, int jobs) {
    std::vector<VerifyOutcome> outcomes(files.size());
    // Per job: the file's measuring ranges and its band producer, as many threads as they had of
    // their own before the pool.
    const int threads = std::min(s.threads > 0 ? s.threads : hardware_threads(), thread_budget());
    TaskPool::shared().reserve(std::max(1, jobs) * (threads + 1) - 1);
    TaskPool::shared().parallel_for(files.size(), jobs, [&](size_t i) {
        VerifyOutcome& o = outcomes[i];
        VerifySettings fs = s;
        try {
            if (source_from_header)
                fs.source = recorded_source(files[i], read_spectral_exr_info(files[i]).attributes);
            o.report = verify_file(files[i], fs);
            o.failures = gate_failures(o.report, g);
            o.readable = true;
        } catch (const VerifyError& e) {
            o.error = e.what();
            o.warnings = e.warnings;
        } catch (const Error& e) {
            o.error = e.what();
        } catch (const std::exception& e) {
            o.error = files[i] + ": " + e.what();
        }
    });
    return outcomes;
}

}  // namespace spectex
