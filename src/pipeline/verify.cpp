#include "pipeline/verify.h"

#include <algorithm>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <future>
#include <limits>
#include <memory>
#include <thread>

#include "io/image_source.h"
#include "io/linearizer.h"
#include "io/spectral_exr_info.h"
#include "io/spectral_reader.h"
#include "spectral/ciede2000.h"
#include "spectral/colorimetry.h"
#include "spectral/error.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

// ---------------------------------------------------------------------------------------------
// ErrorHistogram

namespace {
constexpr double kHistLo = 1e-8;
constexpr int kHistPerDecade = 1000;
constexpr int kHistDecades = 12;  // 1e-8 .. 1e4
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

enum class Encoding { None, Srgb, Linear, Gamma22 };

double encode(Encoding e, double l) {
    double v;
    switch (e) {
        case Encoding::Srgb: v = l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055; break;
        case Encoding::Gamma22: v = l > 0 ? std::pow(l, 1.0 / 2.2) : 0.0; break;
        default: v = l; break;
    }
    return std::min(1.0, std::max(0.0, v));
}

// One band of rows: the spectral planes (bin-major, as float), alpha, and the source's pixels.
struct Band {
    int y0 = 0, rows = 0;              // rows of the data window, 0-based
    std::vector<float> planes;         // bins x (w * band_rows)
    std::vector<float> alpha;          // w * band_rows
    std::vector<float> raw, lin;       // source RGBA as read, and linearised + sanitised
    uint64_t clamped = 0, replaced = 0;
};

// Per-thread accumulators, merged at the end.
struct Stats {
    uint64_t below_zero = 0, above_one = 0, below_tol = 0, above_tol = 0, nonfinite = 0;
    double rgb_min[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, rgb_max[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    uint64_t compared = 0, transparent = 0, nonfinite_pixels = 0, code_matched = 0;
    double rgb_err_max = -1, rgb_err_sum = 0;
    int rgb_err_x = 0, rgb_err_y = 0;
    double de_max = -1, de_sum = 0;
    int de_x = 0, de_y = 0;
    ErrorHistogram hist;
};

struct Context {
    size_t w = 0, plane = 0;           // plane = w * band_rows
    int bins = 0;
    int x0 = 0, y0 = 0;                // data window origin, for reported coordinates
    const double* wrgb = nullptr;      // 3 x bins, column-major (Eigen)
    Eigen::Matrix3d rgb_to_xyz;
    Eigen::Vector3d white;
    bool has_alpha = false, associated = false, compare = false;
    Encoding enc = Encoding::None;
    double max_code = 255;
    bool source_associated = false;
};

void compute_range(const Context& c, const Band& b, size_t begin, size_t end, Stats& st) {
    constexpr size_t kBlock = 256;
    double acc[3][kBlock];
    const float hi_tol = 1.0f + 1e-6f;
    for (size_t i0 = begin; i0 < end; i0 += kBlock) {
        const size_t m = std::min(kBlock, end - i0);
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
        if (lo < 0.0f || hi > 1.0f || nan) {
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
            const bool finite = std::isfinite(rgb[0]) && std::isfinite(rgb[1]) && std::isfinite(rgb[2]);
            if (finite)
                for (int ch = 0; ch < 3; ++ch) {
                    st.rgb_min[ch] = std::min(st.rgb_min[ch], rgb[ch]);
                    st.rgb_max[ch] = std::max(st.rgb_max[ch], rgb[ch]);
                }
            if (!c.compare) continue;
            ++st.compared;
            const float* src = &b.lin[4 * idx];
            const int px = c.x0 + static_cast<int>(idx % c.w);
            const int py = c.y0 + b.y0 + static_cast<int>(idx / c.w);
            if (!finite) {
                ++st.nonfinite_pixels;
                const double inf = std::numeric_limits<double>::infinity();
                if (st.rgb_err_max < inf) st.rgb_err_max = inf, st.rgb_err_x = px, st.rgb_err_y = py;
                if (st.de_max < inf) st.de_max = inf, st.de_x = px, st.de_y = py;
                st.rgb_err_sum = inf;
                st.de_sum = inf;
                st.hist.add(inf);
                continue;
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
                de = ciede2000(lab_from_xyz(c.rgb_to_xyz * v1, c.white), lab_from_xyz(c.rgb_to_xyz * v2, c.white));
            st.de_sum += de;
            if (de > st.de_max) st.de_max = de, st.de_x = px, st.de_y = py;
            st.hist.add(de);
            if (c.enc != Encoding::None) {
                const float* raw = &b.raw[4 * idx];
                const double k = c.source_associated ? static_cast<double>(raw[3]) : 1.0;
                bool match = true;
                for (int ch = 0; ch < 3 && match; ++ch) {
                    const long expect = std::lround(encode(c.enc, rgb[ch]) * k * c.max_code);
                    const long have = std::lround(static_cast<double>(raw[ch]) * c.max_code);
                    match = expect == have;
                }
                st.code_matched += match;
            }
        }
    }
}

}  // namespace

VerifyReport verify_file(const std::string& exr_path, const VerifySettings& s) {
    const auto t0 = std::chrono::steady_clock::now();
    SpectralReader reader(exr_path);  // throws "<path>: <cause>"
    const SpectralExrInfo& info = reader.info();

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
    r.storage = info.tiled ? "tiled " + std::to_string(info.tile_width) + "x" + std::to_string(info.tile_height)
                           : std::string("scanline");
    r.illuminant = s.illuminant;
    r.observer = s.observer;
    r.alpha = reader.alpha();  // "associated" is OpenEXR's convention when nothing says otherwise

    std::vector<double> lambdas;
    for (const auto& b : info.reflective) lambdas.push_back(b.lambda);
    Colorimetry col;
    try {
        WavelengthGrid grid = WavelengthGrid::from_list(lambdas);
        r.wavelengths = grid.describe();
        Observer obs = load_observer(s.data_dir, s.observer);
        Spectrum ill = load_illuminant(s.data_dir, s.illuminant);
        col = Colorimetry::make(obs, ill, grid, primaries_by_name("srgb"));
    } catch (const Error& e) {
        throw Error(exr_path + ": " + e.what());
    }
    const Eigen::Matrix3Xd wrgb = col.rgb_weights();

    // The source, opened and checked before any pixel is read.
    std::unique_ptr<ImageSource> src;
    Linearizer lin;
    Context ctx;
    if (!s.source.empty()) {
        src = ImageSource::open(s.source, s.max_pixels);
        const SourceInfo& si = src->info();
        if (si.width != info.width || si.height != info.height)
            throw Error(exr_path + ": data window " + std::to_string(info.width) + "x" + std::to_string(info.height) +
                        " differs from the source's " + std::to_string(si.width) + "x" + std::to_string(si.height) +
                        " (" + s.source + ")");
        ColourRequest req{s.data_dir, s.config, s.colorspace, s.source, si.colorspace_hint};
        lin = Linearizer::make(req);
        r.compared = true;
        r.source = s.source;
        r.source_colorspace = lin.input_space();
        r.source_colorspace_how = lin.how_chosen();
        r.source_bits = si.bits;
        r.source_float = si.is_float;
        ctx.compare = true;
        ctx.source_associated = si.alpha == AlphaKind::Associated;
        const std::string& cs = lin.input_space();
        if (si.is_float) {
            r.code_match_note = "float source: no codes to match";
        } else if (si.bits != 8 && si.bits != 16) {
            r.code_match_note = std::to_string(si.bits) + "-bit source: only 8- and 16-bit codes are checked";
        } else if (cs == "sRGB - Texture") {
            ctx.enc = Encoding::Srgb;
            r.code_match_note = "IEC 61966-2-1 sRGB encoding";
        } else if (cs == "Linear Rec.709 (sRGB)" || cs == "Raw" || lin.is_identity()) {
            ctx.enc = Encoding::Linear;
            r.code_match_note = "linear (no encoding)";
        } else if (cs == "Gamma 2.2 Rec.709 - Texture") {
            ctx.enc = Encoding::Gamma22;
            r.code_match_note = "gamma 2.2 encoding";
        } else {
            r.code_match_note = "re-encoding to '" + cs + "' is not supported";
        }
        r.code_match_available = ctx.enc != Encoding::None;
        ctx.max_code = si.bits == 16 ? 65535.0 : 255.0;
    }

    try {
        const size_t w = static_cast<size_t>(info.width);
        // Whole chunks (or tile rows) per band when they fit the budget, so that no chunk is decoded
        // twice; for very wide files a band may be part of a chunk (OpenEXR keeps the decoded chunk).
        const int band_rows = reader.band_rows(s.band_bytes);
        r.band_rows = band_rows;

        ctx.w = w;
        ctx.plane = w * static_cast<size_t>(band_rows);
        ctx.bins = r.bins;
        ctx.x0 = info.data_x0;
        ctx.y0 = info.data_y0;
        ctx.wrgb = wrgb.data();
        ctx.rgb_to_xyz = col.rgb_to_xyz;
        ctx.white = col.white_xyz;
        ctx.has_alpha = info.alpha;
        ctx.associated = r.alpha == "associated";

        Band bands[2];
        for (Band& b : bands) {
            b.planes.resize(ctx.plane * static_cast<size_t>(r.bins));
            if (info.alpha) b.alpha.resize(ctx.plane);
            if (src) {
                b.raw.resize(ctx.plane * 4);
                b.lin.resize(ctx.plane * 4);
            }
        }
        const bool straighten = src && src->info().alpha == AlphaKind::Associated;

        auto read_band = [&](Band& b, int y0) {
            b.y0 = y0;
            b.rows = std::min(band_rows, info.height - y0);
            reader.read_rows(y0, b.rows, b.planes.data(), ctx.plane, info.alpha ? b.alpha.data() : nullptr);
            if (!src) return;
            const size_t n = w * static_cast<size_t>(b.rows);
            src->read_rgba(y0, y0 + b.rows, b.raw.data());
            std::copy(b.raw.begin(), b.raw.begin() + static_cast<std::ptrdiff_t>(4 * n), b.lin.begin());
            float* p = b.lin.data();
            if (straighten)
                for (size_t i = 0; i < n; ++i) {
                    const float al = p[4 * i + 3];
                    if (al > 0 && al != 1)
                        for (int c = 0; c < 3; ++c) p[4 * i + c] /= al;
                }
            lin.apply_rgba(p, static_cast<long>(n));
            // bake's defaults: NaN/Inf -> 0 (--nan replace), clamp to [0, 1] (--out-of-range clamp)
            b.clamped = b.replaced = 0;
            for (size_t i = 0; i < n; ++i) {
                float* q = p + 4 * i;
                bool bad = false, out = false;
                for (int c = 0; c < 4; ++c)
                    if (!std::isfinite(q[c])) q[c] = 0.0f, bad = true;
                for (int c = 0; c < 3; ++c)
                    if (q[c] < 0.0f || q[c] > 1.0f) q[c] = std::min(1.0f, std::max(0.0f, q[c])), out = true;
                b.replaced += bad;
                b.clamped += out;
            }
        };

        unsigned hw = std::max(1u, std::thread::hardware_concurrency());
        const int nthreads = s.threads > 0 ? s.threads : static_cast<int>(hw);
        std::vector<Stats> stats(static_cast<size_t>(nthreads));

        auto compute_band = [&](const Band& b) {
            const size_t n = w * static_cast<size_t>(b.rows);
            const size_t per = (n + static_cast<size_t>(nthreads) - 1) / static_cast<size_t>(nthreads);
            std::vector<std::thread> pool;
            for (int t = 1; t < nthreads; ++t) {
                const size_t begin = std::min(n, per * static_cast<size_t>(t)), end = std::min(n, begin + per);
                if (begin < end)
                    pool.emplace_back([&, begin, end, t] { compute_range(ctx, b, begin, end, stats[static_cast<size_t>(t)]); });
            }
            compute_range(ctx, b, 0, std::min(n, per), stats[0]);
            for (auto& th : pool) th.join();
        };

        // Double buffering: the next band is decoded while this one is measured.
        int cur = 0;
        read_band(bands[0], 0);
        for (int y0 = 0; y0 < info.height; y0 += band_rows) {
            const int next = y0 + band_rows;
            std::future<void> pending;
            if (next < info.height)
                pending = std::async(std::launch::async, [&, next, cur] { read_band(bands[1 - cur], next); });
            try {
                compute_band(bands[cur]);
            } catch (...) {
                if (pending.valid()) pending.wait();
                throw;
            }
            r.source_clamped += bands[cur].clamped;
            r.source_replaced += bands[cur].replaced;
            if (pending.valid()) pending.get();
            cur = 1 - cur;
        }

        // Merge.
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
            total.code_matched += st.code_matched;
            total.rgb_err_sum += st.rgb_err_sum;
            total.de_sum += st.de_sum;
            // Each thread keeps its first maximum; across threads, ties go to the first pixel in
            // reading order, so the reported location does not depend on the thread count.
            auto earlier = [](int y, int x, int ty, int tx) { return y < ty || (y == ty && x < tx); };
            if (st.rgb_err_max > total.rgb_err_max ||
                (st.rgb_err_max == total.rgb_err_max &&
                 earlier(st.rgb_err_y, st.rgb_err_x, total.rgb_err_y, total.rgb_err_x)))
                total.rgb_err_max = st.rgb_err_max, total.rgb_err_x = st.rgb_err_x, total.rgb_err_y = st.rgb_err_y;
            if (st.de_max > total.de_max ||
                (st.de_max == total.de_max && earlier(st.de_y, st.de_x, total.de_y, total.de_x)))
                total.de_max = st.de_max, total.de_x = st.de_x, total.de_y = st.de_y;
            total.hist.merge(st.hist);
        }
        r.samples = r.pixels * static_cast<uint64_t>(r.bins);
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
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(exr_path + ": cannot read the pixels: " + e.what());
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

}  // namespace spectex
