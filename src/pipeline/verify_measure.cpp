// verify's measuring kernel: a band at a time, every pixel integrated under the check light and the
// other lights, its samples counted, compared with the source's pixel and re-encoded to its codes;
// the accumulators merged into the report. The set-up from what the file records is in
// pipeline/verify.cpp, the gates in pipeline/verify_gates.cpp.
#include "pipeline/verify_measure.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <functional>
#include <limits>

#include "base/error.h"
#include "base/task_pool.h"
#include "io/image_source.h"
#include "io/linearizer.h"
#include "io/spectral_exr_info.h"
#include "io/spectral_reader.h"
#include "pipeline/pixel_policy.h"
#include "spectral/ciede2000.h"
#include "spectral/colorimetry.h"
#include "spectral/half_bits.h"

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
    float clamped_excursion = 0;
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
    double rgb_excess_max = 0;  // the error beyond kCoarseRelativeTolerance of the source's value
    double de_max = -1, de_sum = 0;
    int de_x = 0, de_y = 0;
    ErrorHistogram hist;
    std::vector<LightStats> lights;
};

constexpr size_t kBlock = 256;  // pixels integrated together, so that the bins stream in order

// XYZ of pixels [i0, i0 + m) under each other light, adapted: lacc[(3 l + ch) kBlock + j].
void integrate_other_lights(const MeasureContext& c, const Band& b, size_t i0, size_t m,
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

// The samples of pixels [i0, i0 + m) of an associated file whose straight value T/A is outside
// [0, 1]: T > A (above 1), T > A (1 + tol) (above its bin's rounding), T < 0.
void count_straight_range(const MeasureContext& c, const Band& b, size_t i0, size_t m, Stats& st) {
    const float* a = b.alpha.data() + i0;
    uint64_t below0 = 0, above1 = 0, belowt = 0, abovet = 0;
    for (int k = 0; k < c.bins; ++k) {
        const float* p = b.planes.data() + static_cast<size_t>(k) * c.plane + i0;
        const float lim = 1.0f + c.straight_tol[static_cast<size_t>(k)];
        for (size_t j = 0; j < m; ++j) {
            const float v = p[j];
            // With A <= 0 nothing is seen and the stored sample must be 0 (to its rounding); each
            // sample is counted on one side at most (a negative A counted a positive sample on
            // both, and the share rose past 100 %).
            const bool seen = a[j] > 0.0f;
            below0 += v < 0.0f;
            belowt += v < -1e-6f * (seen ? a[j] : 1.0f);
            above1 += v > (seen ? a[j] : 0.0f);
            abovet += v > (seen ? a[j] * lim : 1e-6f);
        }
    }
    st.below_zero += below0;
    st.above_one += above1;
    st.below_tol += belowt;
    st.above_tol += abovet;
}

// Linear RGB of pixels [i0, i0 + m) into acc, and the samples outside [0, 1] or not finite
// (divided by A for an associated file).
void integrate_block(const MeasureContext& c, const Band& b, size_t i0, size_t m,
                     double (*acc)[kBlock], Stats& st) {
    for (int ch = 0; ch < 3; ++ch) std::fill(acc[ch], acc[ch] + m, 0.0);
    // Fast path: integrate and track the block's range; NaN fails both comparisons of the
    // range check below, Inf lands in it. Samples are counted one by one only when needed.
    float lo = 0.0f, hi = 1.0f;
    bool nan = false;
    const bool straight = c.associated && !c.straight_tol.empty();
    // Associated: the smallest margin A - T over the block (negative: some T/A above 1).
    float margin = 0.0f;
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
        if (straight) {
            const float* a = b.alpha.data() + i0;
            for (size_t j = 0; j < m; ++j) margin = std::min(margin, a[j] - p[j]);
        }
    }
    if (straight) {
        if (lo < 0.0f || margin < 0.0f) count_straight_range(c, b, i0, m, st);
        if (nan || hi > 1.0f) {
            uint64_t nonfin = 0;
            for (int k = 0; k < c.bins; ++k) {
                const float* p = b.planes.data() + static_cast<size_t>(k) * c.plane + i0;
                for (size_t j = 0; j < m; ++j) nonfin += !(std::fabs(p[j]) <= FLT_MAX);
            }
            st.nonfinite += nonfin;
        }
        return;
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
void add_other_lights(const MeasureContext& c, const std::vector<double>& lacc, size_t j,
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
void compare_with_source(const Band& b, const MeasureContext& c, size_t idx, const double* rgb,
                         bool finite, int px, int py, Stats& st) {
    ++st.compared;
    const float* src = &b.lin[4 * idx];
    if (!finite) {
        ++st.nonfinite_pixels;
        const double inf = std::numeric_limits<double>::infinity();
        if (st.rgb_err_max < inf) st.rgb_err_max = inf, st.rgb_err_x = px, st.rgb_err_y = py;
        st.rgb_excess_max = inf;
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
        st.rgb_excess_max =
            std::max(st.rgb_excess_max,
                     e - kCoarseRelativeTolerance * std::fabs(static_cast<double>(src[ch])));
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
void check_codes(const MeasureContext& c, const Band& b, float* enc, const size_t* enc_idx,
                 size_t nenc, Stats& st) {
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
void compute_range(const MeasureContext& c, const Band& b, size_t begin, size_t end, Stats& st) {
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
                                 const MeasureContext& ctx, int band_rows, const VerifySettings& s,
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
        b.clamped_excursion = counts.clamped_excursion;
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
            r.source_clamped_excursion =
                std::max(r.source_clamped_excursion, bands[slot].clamped_excursion);
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
        total.rgb_excess_max = std::max(total.rgb_excess_max, st.rgb_excess_max);
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
        r.rgb_error_beyond_relative_max = total.rgb_excess_max;
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

void measure_file(SpectralReader& reader, ImageSource* src, const Linearizer& lin,
                  const MeasureContext& ctx, int band_rows, const VerifySettings& s,
                  VerifyReport& r) {
    report_totals(merge_stats(measure_bands(reader, src, lin, ctx, band_rows, s, r)), r);
}

uint64_t verify_band_bytes(const std::string& exr_path, const VerifySettings& s) {
    try {
        const SpectralExrInfo info = read_spectral_exr_info(exr_path);
        const uint64_t image = static_cast<uint64_t>(std::max(0, info.width)) *
                               static_cast<uint64_t>(std::max(0, info.height)) *
                               info.reflective.size() * sizeof(float);
        return std::min<uint64_t>(s.band_bytes, image);
    } catch (const Error&) {
        return 0;  // the file's own error, before any band
    }
}

VerifyMemory verify_memory_estimate(size_t lights, int threads, int jobs, const VerifySettings& s,
                                    const std::vector<uint64_t>& band_bytes) {
    const uint64_t per_light = sizeof(LightStats) + kHistBins * sizeof(uint64_t) +
                               3 * kBlock * sizeof(double);  // histogram + XYZ block
    const uint64_t per_thread = sizeof(Stats) + kHistBins * sizeof(uint64_t) + per_light * lights;
    const size_t running = static_cast<size_t>(std::max(1, jobs));
    VerifyMemory m;
    // Two bands of spectral samples per job, and the source's pixels as read and linearised (RGBA
    // float, at most the same size again): the largest files' bands, as many as run at once.
    std::vector<uint64_t> bands = band_bytes;
    if (bands.empty()) bands.push_back(s.band_bytes);
    std::sort(bands.begin(), bands.end(), std::greater<uint64_t>());
    for (size_t k = 0; k < std::min(running, bands.size()); ++k) m.bands += 4 * bands[k];
    m.measurements = per_thread * static_cast<uint64_t>(std::max(1, threads)) * running;
    return m;
}

void check_verify_memory(size_t lights, int threads, int jobs, const VerifySettings& s,
                         const std::vector<uint64_t>& band_bytes) {
    const VerifyMemory m = verify_memory_estimate(lights, threads, jobs, s, band_bytes);
    if (m.total() <= kVerifyMemoryLimit) return;
    auto mib = [](uint64_t b) { return std::to_string((b + (1u << 20) - 1) >> 20); };
    const std::string bands = mib(m.bands) +
                              " MiB of bands (two bands of each file's samples and "
                              "its source's pixels, per job)";
    const std::string lights_text = mib(m.measurements) + " MiB of measurements (" +
                                    std::to_string(lights) + " lights x " +
                                    std::to_string(threads) + " threads x " + std::to_string(jobs) +
                                    " jobs, about 100 KB per light and thread)";
    const std::string limit =
        ", over the limit of " + std::to_string(kVerifyMemoryLimit >> 20) + " MiB (1 GiB); ";
    if (m.bands >= m.measurements)
        throw LimitError("--jobs: " + std::to_string(jobs) + " files at once need about " +
                         mib(m.total()) + " MiB: " + bands + " and " + lights_text + limit +
                         "give fewer --jobs");
    throw LimitError("--illuminant: " + std::to_string(lights) + " lights need about " +
                     mib(m.total()) + " MiB: " + lights_text + " and " + bands + limit +
                     "give fewer lights, --threads or --jobs");
}

}  // namespace spectex
