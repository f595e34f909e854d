#include "spectral/expand.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#if defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#endif

#include "base/half.h"
#include "spectral/half_bits.h"

namespace spectex {

namespace {
// Pixels per block: r, g, b of a block stay in L1 while every bin is written.
constexpr size_t kBlock = 512;

// float <-> half for a block. The x86-64 baseline has no F16C, so the instructions are chosen at
// run time (farm nodes run one binary); both paths round to nearest even and give the same bits
// (tests/unit/expand_test.cpp checks it on every half value and millions of floats).
void to_half_scalar(const float* in, uint16_t* out, size_t n) {
    for (size_t i = 0; i < n; ++i) out[i] = float_to_half(in[i]);
}
void from_half_scalar(const uint16_t* in, float* out, size_t n) {
    for (size_t i = 0; i < n; ++i) out[i] = half_to_float(in[i]);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("avx,f16c"))) void to_half_f16c(const float* in, uint16_t* out, size_t n) {
    size_t i = 0;
    for (; i + 8 <= n; i += 8)
        _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i),
                         _mm256_cvtps_ph(_mm256_loadu_ps(in + i),
                                         _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
    for (; i < n; ++i) out[i] = float_to_half(in[i]);
}
__attribute__((target("avx,f16c"))) void from_half_f16c(const uint16_t* in, float* out, size_t n) {
    size_t i = 0;
    for (; i + 8 <= n; i += 8)
        _mm256_storeu_ps(
            out + i, _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i))));
    for (; i < n; ++i) out[i] = half_to_float(in[i]);
}
bool have_f16c() {
    static const bool yes = [] {
        if (const char* e = std::getenv("SPECTEX_NO_F16C"); e && *e) return false;  // for tests
        // CPUID leaf 1: ECX bit 27 OSXSAVE, 28 AVX, 29 F16C; and the OS must save YMM state
        // (XCR0 bits 1 and 2). clang 14's __builtin_cpu_supports does not know "f16c".
        unsigned a = 0, b = 0, c = 0, d = 0;
        if (!__get_cpuid(1, &a, &b, &c, &d)) return false;
        if (!(c & (1u << 27)) || !(c & (1u << 28)) || !(c & (1u << 29))) return false;
        unsigned lo = 0, hi = 0;
        __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
        return (lo & 6u) == 6u;
    }();
    return yes;
}
#else
bool have_f16c() { return false; }
void to_half_f16c(const float* in, uint16_t* out, size_t n) { to_half_scalar(in, out, n); }
void from_half_f16c(const uint16_t* in, float* out, size_t n) { from_half_scalar(in, out, n); }
#endif

void to_half(const float* in, uint16_t* out, size_t n) {
    if (have_f16c())
        to_half_f16c(in, out, n);
    else
        to_half_scalar(in, out, n);
}
void from_half(const uint16_t* in, float* out, size_t n) {
    if (have_f16c())
        from_half_f16c(in, out, n);
    else
        from_half_scalar(in, out, n);
}

}  // namespace

void floats_to_half(const float* in, uint16_t* out, size_t n) { to_half(in, out, n); }
void half_to_floats(const uint16_t* in, float* out, size_t n) { from_half(in, out, n); }
bool expansion_uses_f16c() { return have_f16c(); }

ExpansionMatrix ExpansionMatrix::from_basis(const Basis& basis) {
    ExpansionMatrix m;
    m.bins = static_cast<int>(basis.size());
    m.coeff.resize(basis.size() * 3);
    for (size_t k = 0; k < basis.size(); ++k) {
        m.coeff[3 * k + 0] = static_cast<float>(basis.r[k]);
        m.coeff[3 * k + 1] = static_cast<float>(basis.g[k]);
        m.coeff[3 * k + 2] = static_cast<float>(basis.b[k]);
    }
    return m;
}

namespace {

// Colour-aware rounding. Round every bin to nearest (as plain half output does) and add up, per
// pixel, the linear-RGB error that rounding makes in the integrated colour. Only where that error
// exceeds kColourTolerance, flip single bins to the half on the other side of their exact value,
// each time the flip that shrinks the error most, until it is within tolerance. Few pixels and few
// bins change, so the file compresses like a plain-rounded one, and the colour error stays below
// the smallest half-step between 8-bit sRGB codes (1.5e-4 near black). Deterministic.
//
// The output is defined bit for bit by the straightforward implementation kept in
// tests/unit/expand_test.cpp (reference_feedback): the float sums below are evaluated in its order
// (per pixel, bins in increasing order; no FMA, whose single rounding would change them), and a
// flip goes to the lowest bin among those whose squared error is smallest.
constexpr float kColourTolerance = 1.0f / 16384.0f;  // 6.1e-5 linear
constexpr int kMaxFlips = 16;

uint16_t other_side(uint16_t h, float v, float s) {
    // The neighbouring half of h on the side of s (h itself when v == s or at the range's edge).
    if (v > s && (h & 0x7fffu) != 0)
        return (h & 0x8000u) ? static_cast<uint16_t>(h + 1) : static_cast<uint16_t>(h - 1);
    if (v < s && (h & 0x7fffu) < 0x7bffu)
        return (h & 0x8000u) ? static_cast<uint16_t>(h - 1) : static_cast<uint16_t>(h + 1);
    return h;
}

// The matrix as one plane per coefficient, zero-padded to a multiple of 8 bins. A padding bin has
// s = 0, which rounds exactly, so it never has a flip to offer.
struct FeedbackPlanes {
    size_t bins, padded;
    std::vector<float> data;
    const float *cr, *cg, *cb, *wr, *wg, *wb;  // into data
    FeedbackPlanes(const FeedbackPlanes&) = delete;
    FeedbackPlanes& operator=(const FeedbackPlanes&) = delete;
    explicit FeedbackPlanes(const ExpansionMatrix& m)
        : bins(static_cast<size_t>(m.bins)),
          padded((bins + 7) & ~size_t{7}),
          data(6 * padded, 0.0f) {
        for (size_t k = 0; k < bins; ++k)
            for (size_t c = 0; c < 3; ++c) {
                data[c * padded + k] = m.coeff[3 * k + c];
                data[(3 + c) * padded + k] = m.rgb_weight[3 * k + c];
            }
        cr = data.data(), cg = cr + padded, cb = cg + padded, wr = cb + padded, wg = wr + padded,
        wb = wg + padded;
    }
};

// A pixel's flips are held as delta[k], the value of other_side() minus the value of bin k's
// current half. A bin that cannot flip has delta 0, whose "flip" leaves the squared error exactly
// as it is; near or beyond the end of the half range (and for NaN) delta can be infinite or NaN,
// which makes the squared error infinite or NaN. Only strictly smaller squared errors are taken, so
// neither is ever chosen, and the F16C and scalar paths, which differ there, choose alike.
float squared(const float* e) { return e[0] * e[0] + e[1] * e[1] + e[2] * e[2]; }

float exact(const FeedbackPlanes& p, size_t k, float r, float g, float b) {
    return p.cr[k] * r + p.cg[k] * g + p.cb[k] * b;
}

float flip_delta(uint16_t cur, float s) {
    const float v = half_to_float(cur);
    return half_to_float(other_side(cur, v, s)) - v;
}

// The lowest bin whose flip (its move by delta[k], weighed by the colour weights wr, wg, wb) makes
// the squared error smallest and below e's, or bins if none does.
size_t best_flip(const float* wr, const float* wg, const float* wb, size_t bins, const float* delta,
                 const float* e) {
    size_t best = bins;
    float best_e2 = squared(e);
    for (size_t k = 0; k < bins; ++k) {
        const float x = e[0] + wr[k] * delta[k], y = e[1] + wg[k] * delta[k],
                    z = e[2] + wb[k] * delta[k];
        const float t = x * x + y * y + z * z;
        if (t < best_e2) best_e2 = t, best = k;
    }
    return best;
}

size_t best_flip_scalar(const FeedbackPlanes& p, const float* delta, const float* e) {
    return best_flip(p.wr, p.wg, p.wb, p.bins, delta, e);
}

// Fills delta for a pixel none of whose bins has flipped yet (each holds round(s)); returns the
// first flip to make.
size_t find_flips_scalar(const FeedbackPlanes& p, float r, float g, float b, const float* e,
                         float* delta) {
    for (size_t k = 0; k < p.padded; ++k) {
        const float s = exact(p, k, r, g, b);
        delta[k] = flip_delta(float_to_half(s), s);
    }
    return best_flip_scalar(p, delta, e);
}

// Rounds every bin of len pixels to out and adds the colour error that makes to er, eg, eb.
void round_block_scalar(const FeedbackPlanes& p, const float* r, const float* g, const float* b,
                        size_t len, uint16_t* out, size_t plane_stride, float* er, float* eg,
                        float* eb) {
    float tmp[kBlock], back[kBlock];
    for (size_t k = 0; k < p.bins; ++k) {
        uint16_t* dst = out + k * plane_stride;
        for (size_t i = 0; i < len; ++i) tmp[i] = p.cr[k] * r[i] + p.cg[k] * g[i] + p.cb[k] * b[i];
        to_half_scalar(tmp, dst, len);
        from_half_scalar(dst, back, len);
        for (size_t i = 0; i < len; ++i) {
            const float d = back[i] - tmp[i];
            er[i] += p.wr[k] * d;
            eg[i] += p.wg[k] * d;
            eb[i] += p.wb[k] * d;
        }
    }
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
// The same, sixteen pixels at a time through a run of bins with their errors in registers. Runs
// are short so that the planes written for a run of a block stay within L1 and the TLB.
constexpr size_t kBinRun = 16;

// Bin k (coefficients c = cr, cg, cb, wr, wg, wb) of eight pixels: rounds s to dst and adds the
// error to er, eg, eb.
__attribute__((target("avx,f16c"), always_inline)) inline void round8(
    const __m256* c, const float* r, const float* g, const float* b, uint16_t* dst, __m256& er,
    __m256& eg, __m256& eb) {
    const __m256 s = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(c[0], _mm256_loadu_ps(r)),
                                                 _mm256_mul_ps(c[1], _mm256_loadu_ps(g))),
                                   _mm256_mul_ps(c[2], _mm256_loadu_ps(b)));
    const __m128i h = _mm256_cvtps_ph(s, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), h);
    const __m256 d = _mm256_sub_ps(_mm256_cvtph_ps(h), s);
    er = _mm256_add_ps(er, _mm256_mul_ps(c[3], d));
    eg = _mm256_add_ps(eg, _mm256_mul_ps(c[4], d));
    eb = _mm256_add_ps(eb, _mm256_mul_ps(c[5], d));
}

__attribute__((target("avx,f16c"))) void round_block_f16c(const FeedbackPlanes& p, const float* r,
                                                          const float* g, const float* b,
                                                          size_t len, uint16_t* out,
                                                          size_t plane_stride, float* er, float* eg,
                                                          float* eb) {
    const size_t len16 = len & ~size_t{15};
    for (size_t k0 = 0; k0 < p.bins; k0 += kBinRun) {
        const size_t k1 = std::min(p.bins, k0 + kBinRun);
        for (size_t i = 0; i < len16; i += 16) {
            __m256 er0 = _mm256_loadu_ps(er + i), eg0 = _mm256_loadu_ps(eg + i),
                   eb0 = _mm256_loadu_ps(eb + i);
            __m256 er1 = _mm256_loadu_ps(er + i + 8), eg1 = _mm256_loadu_ps(eg + i + 8);
            __m256 eb1 = _mm256_loadu_ps(eb + i + 8);
            uint16_t* dst = out + k0 * plane_stride + i;
            for (size_t k = k0; k < k1; ++k, dst += plane_stride) {
                const __m256 c[6] = {_mm256_broadcast_ss(p.cr + k), _mm256_broadcast_ss(p.cg + k),
                                     _mm256_broadcast_ss(p.cb + k), _mm256_broadcast_ss(p.wr + k),
                                     _mm256_broadcast_ss(p.wg + k), _mm256_broadcast_ss(p.wb + k)};
                round8(c, r + i, g + i, b + i, dst, er0, eg0, eb0);
                round8(c, r + i + 8, g + i + 8, b + i + 8, dst + 8, er1, eg1, eb1);
            }
            _mm256_storeu_ps(er + i, er0), _mm256_storeu_ps(er + i + 8, er1);
            _mm256_storeu_ps(eg + i, eg0), _mm256_storeu_ps(eg + i + 8, eg1);
            _mm256_storeu_ps(eb + i, eb0), _mm256_storeu_ps(eb + i + 8, eb1);
        }
    }
    if (len16 < len)
        round_block_scalar(p, r + len16, g + len16, b + len16, len - len16, out + len16,
                           plane_stride, er + len16, eg + len16, eb + len16);
}

// best_flip_scalar, eight bins at a time. Each lane keeps the first of its smallest squared errors
// (minps is t < best ? t : best); the lowest bin among the lanes holding the overall smallest is
// the first bin that has it. Selections use and/or rather than blendv: GCC 12 turns blendv into a
// vector condition that it lowers lane by lane without AVX2.
struct BestFlip8 {
    __m256 ex, ey, ez, best, best_k, k;
};

__attribute__((target("avx"), always_inline)) inline BestFlip8 best_flip8_start(const float* e,
                                                                                float e2) {
    return {_mm256_set1_ps(e[0]), _mm256_set1_ps(e[1]),  _mm256_set1_ps(e[2]),
            _mm256_set1_ps(e2),   _mm256_set1_ps(-1.0f), _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7)};
}

// Bins k..k+7 (the lanes' numbers in bf.k) with weights wr, wg, wb and deltas d.
__attribute__((target("avx"), always_inline)) inline void best_flip8_step(BestFlip8& bf, __m256 wr,
                                                                          __m256 wg, __m256 wb,
                                                                          __m256 d) {
    const __m256 x = _mm256_add_ps(bf.ex, _mm256_mul_ps(wr, d));
    const __m256 y = _mm256_add_ps(bf.ey, _mm256_mul_ps(wg, d));
    const __m256 z = _mm256_add_ps(bf.ez, _mm256_mul_ps(wb, d));
    const __m256 t =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)), _mm256_mul_ps(z, z));
    const __m256 lt = _mm256_cmp_ps(t, bf.best, _CMP_LT_OQ);
    bf.best = _mm256_min_ps(t, bf.best);
    bf.best_k = _mm256_or_ps(_mm256_and_ps(lt, bf.k), _mm256_andnot_ps(lt, bf.best_k));
    bf.k = _mm256_add_ps(bf.k, _mm256_set1_ps(8.0f));
}

__attribute__((target("avx"), always_inline)) inline __m256 min8(__m256 v) {
    v = _mm256_min_ps(v, _mm256_permute_ps(v, 0xb1));
    v = _mm256_min_ps(v, _mm256_permute_ps(v, 0x4e));
    return _mm256_min_ps(v, _mm256_permute2f128_ps(v, v, 1));
}

__attribute__((target("avx"), always_inline)) inline size_t best_flip8_end(const BestFlip8& bf,
                                                                           float e2, size_t none) {
    // No lane is NaN unless e2 is, and then nothing is below it.
    const __m256 m = min8(bf.best);
    const __m256 at_m = _mm256_cmp_ps(bf.best, m, _CMP_EQ_OQ);
    const __m256 k =
        min8(_mm256_or_ps(_mm256_and_ps(at_m, bf.best_k),
                          _mm256_andnot_ps(at_m, _mm256_set1_ps(static_cast<float>(none)))));
    return _mm256_cvtss_f32(m) < e2 ? static_cast<size_t>(_mm256_cvtss_f32(k)) : none;
}

__attribute__((target("avx"))) size_t best_flip_avx(const FeedbackPlanes& p, const float* delta,
                                                    const float* e) {
    const float e2 = squared(e);
    BestFlip8 bf = best_flip8_start(e, e2);
    for (size_t k = 0; k < p.padded; k += 8)
        best_flip8_step(bf, _mm256_loadu_ps(p.wr + k), _mm256_loadu_ps(p.wg + k),
                        _mm256_loadu_ps(p.wb + k), _mm256_loadu_ps(delta + k));
    return best_flip8_end(bf, e2, p.bins);
}

// find_flips_scalar, eight bins at a time, with the first choice made on the way. The halves below
// and above s (s rounded towards -Inf and +Inf) are round(s) and its other side, so
// delta = (down - round) + (up - round), exactly (one term is 0), with no bit twiddling. Where
// other_side() has no flip this gives delta 0 (s is a half) or, at the range's end, an infinite or
// NaN one, except for -0, which other_side() does not move further down: a negative s that rounds
// to -0 is masked to delta 0.
__attribute__((target("avx,f16c"))) size_t find_flips_f16c(const FeedbackPlanes& p, float r,
                                                           float g, float b, const float* e,
                                                           float* delta) {
    const __m256 vr = _mm256_set1_ps(r), vg = _mm256_set1_ps(g), vb = _mm256_set1_ps(b);
    const __m256 zero = _mm256_setzero_ps();
    const float *cr = p.cr, *cg = p.cg, *cb = p.cb, *wr = p.wr, *wg = p.wg, *wb = p.wb;
    const float e2 = squared(e);
    BestFlip8 bf = best_flip8_start(e, e2);
    for (size_t k = 0; k < p.padded; k += 8) {
        const __m256 s = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_loadu_ps(cr + k), vr),
                                                     _mm256_mul_ps(_mm256_loadu_ps(cg + k), vg)),
                                       _mm256_mul_ps(_mm256_loadu_ps(cb + k), vb));
        const __m256 v =
            _mm256_cvtph_ps(_mm256_cvtps_ph(s, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
        const __m256 down =
            _mm256_cvtph_ps(_mm256_cvtps_ph(s, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC));
        const __m256 up =
            _mm256_cvtph_ps(_mm256_cvtps_ph(s, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC));
        const __m256 below_zero =
            _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_EQ_OQ), _mm256_cmp_ps(s, zero, _CMP_LT_OQ));
        const __m256 d = _mm256_andnot_ps(
            below_zero, _mm256_add_ps(_mm256_sub_ps(down, v), _mm256_sub_ps(up, v)));
        _mm256_storeu_ps(delta + k, d);
        best_flip8_step(bf, _mm256_loadu_ps(wr + k), _mm256_loadu_ps(wg + k),
                        _mm256_loadu_ps(wb + k), d);
    }
    return best_flip8_end(bf, e2, p.bins);
}
#else
void round_block_f16c(const FeedbackPlanes& p, const float* r, const float* g, const float* b,
                      size_t len, uint16_t* out, size_t plane_stride, float* er, float* eg,
                      float* eb) {
    round_block_scalar(p, r, g, b, len, out, plane_stride, er, eg, eb);
}
size_t best_flip_avx(const FeedbackPlanes& p, const float* delta, const float* e) {
    return best_flip_scalar(p, delta, e);
}
size_t find_flips_f16c(const FeedbackPlanes& p, float r, float g, float b, const float* e,
                       float* delta) {
    return find_flips_scalar(p, r, g, b, e, delta);
}
#endif

bool within_tolerance(const float* e) {
    return std::max({std::fabs(e[0]), std::fabs(e[1]), std::fabs(e[2])}) <= kColourTolerance;
}

// The greedy flips of the pixel (r, g, b) whose error e is over tolerance, from the first choice
// best onwards; px points to its bin 0, and a flipped bin's delta is recomputed from its new half.
void settle(const FeedbackPlanes& p, float* delta, size_t best, float* e, float r, float g, float b,
            uint16_t* px, size_t plane_stride, bool avx) {
    for (int flip = 1; best < p.bins; ++flip) {
        uint16_t& h = px[best * plane_stride];
        const float s = exact(p, best, r, g, b);
        h = other_side(h, half_to_float(h), s);
        e[0] += p.wr[best] * delta[best];
        e[1] += p.wg[best] * delta[best];
        e[2] += p.wb[best] * delta[best];
        if (flip == kMaxFlips || within_tolerance(e)) break;
        delta[best] = flip_delta(h, s);
        best = avx ? best_flip_avx(p, delta, e) : best_flip_scalar(p, delta, e);
    }
}

void expand_to_half_feedback(const ExpansionMatrix& m, const float* r, const float* g,
                             const float* b, size_t n, uint16_t* out, size_t plane_stride) {
    const bool f16c = have_f16c();
    const FeedbackPlanes p(m);
    std::vector<float> delta(p.padded);
    float er[kBlock], eg[kBlock], eb[kBlock];
    uint16_t todo[kBlock];
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        std::fill(er, er + len, 0.0f);
        std::fill(eg, eg + len, 0.0f);
        std::fill(eb, eb + len, 0.0f);
        if (f16c)
            round_block_f16c(p, r + i0, g + i0, b + i0, len, out + i0, plane_stride, er, eg, eb);
        else
            round_block_scalar(p, r + i0, g + i0, b + i0, len, out + i0, plane_stride, er, eg, eb);
        // The pixels over tolerance, listed without a branch per pixel (often a quarter of them).
        size_t over = 0;
        for (size_t i = 0; i < len; ++i) {
            const float e[3] = {er[i], eg[i], eb[i]};
            todo[over] = static_cast<uint16_t>(i);
            over += !within_tolerance(e);
        }
        for (size_t j = 0; j < over; ++j) {
            const size_t i = todo[j];
            float e[3] = {er[i], eg[i], eb[i]};
            const float pr = r[i0 + i], pg = g[i0 + i], pb = b[i0 + i];
            const size_t best = f16c ? find_flips_f16c(p, pr, pg, pb, e, delta.data())
                                     : find_flips_scalar(p, pr, pg, pb, e, delta.data());
            settle(p, delta.data(), best, e, pr, pg, pb, out + i0 + i, plane_stride, f16c);
        }
    }
}

}  // namespace

void round_spectra_to_half(const float* spectra, size_t spectra_stride, size_t n, size_t bins,
                           const std::vector<float>* rgb_weight, uint16_t* out,
                           size_t plane_stride) {
    if (!rgb_weight) {
        for (size_t k = 0; k < bins; ++k)
            to_half(spectra + k * spectra_stride, out + k * plane_stride, n);
        return;
    }
    // The same rounding as the basis kernel's (round to nearest, then greedy flips of the pixels
    // whose colour misses by more than kColourTolerance), on spectra given as values.
    std::vector<float> w[3];
    for (size_t c = 0; c < 3; ++c) {
        w[c].resize(bins);
        for (size_t k = 0; k < bins; ++k) w[c][k] = (*rgb_weight)[3 * k + c];
    }
    std::vector<float> delta(bins);
    float er[kBlock], eg[kBlock], eb[kBlock], back[kBlock];
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        std::fill(er, er + len, 0.0f);
        std::fill(eg, eg + len, 0.0f);
        std::fill(eb, eb + len, 0.0f);
        for (size_t k = 0; k < bins; ++k) {
            const float* src = spectra + k * spectra_stride + i0;
            uint16_t* dst = out + k * plane_stride + i0;
            to_half(src, dst, len);
            from_half(dst, back, len);
            for (size_t i = 0; i < len; ++i) {
                const float d = back[i] - src[i];
                er[i] += w[0][k] * d;
                eg[i] += w[1][k] * d;
                eb[i] += w[2][k] * d;
            }
        }
        for (size_t i = 0; i < len; ++i) {
            float e[3] = {er[i], eg[i], eb[i]};
            if (within_tolerance(e)) continue;
            const float* s = spectra + i0 + i;
            uint16_t* px = out + i0 + i;
            for (size_t k = 0; k < bins; ++k)
                delta[k] = flip_delta(px[k * plane_stride], s[k * spectra_stride]);
            for (int flip = 1; flip <= kMaxFlips; ++flip) {
                const size_t best =
                    best_flip(w[0].data(), w[1].data(), w[2].data(), bins, delta.data(), e);
                if (best == bins) break;
                uint16_t& h = px[best * plane_stride];
                const float sk = s[best * spectra_stride];
                h = other_side(h, half_to_float(h), sk);
                e[0] += w[0][best] * delta[best];
                e[1] += w[1][best] * delta[best];
                e[2] += w[2][best] * delta[best];
                if (within_tolerance(e)) break;
                delta[best] = flip_delta(h, sk);
            }
        }
    }
}

uint16_t round_half_to_bits(float v, int bits) {
    const uint16_t h = float_to_half(v);
    if (bits >= 10) return h;
    const uint16_t step = static_cast<uint16_t>(1u << (10 - std::max(bits, 0)));
    const uint16_t sign = h & 0x8000u, mag = h & 0x7fffu;
    if (mag >= 0x7c00u) return h;  // Inf and NaN stay as they are
    // h is the nearest half to v, so the grid points around |v| are the multiple of step at or
    // below h and the next one (or, when h is on the grid and above |v|, the one below and h).
    const float av = std::fabs(v);
    uint16_t lo = static_cast<uint16_t>(mag & ~(step - 1u));
    if (lo == mag && lo >= step && half_to_float(lo) > av) lo = static_cast<uint16_t>(lo - step);
    const uint32_t hi = static_cast<uint32_t>(lo) + step;
    if (hi > 0x7bffu) return static_cast<uint16_t>(sign | lo);
    const double dlo = static_cast<double>(av) - half_to_float(lo);
    const double dhi = static_cast<double>(half_to_float(static_cast<uint16_t>(hi))) - av;
    uint16_t m = lo;
    if (dhi < dlo || (dhi == dlo && ((lo / step) & 1u))) m = static_cast<uint16_t>(hi);
    return static_cast<uint16_t>(sign | m);
}

int half_mantissa_bits(uint16_t h) {
    uint32_t mag = h & 0x7fffu;
    if (mag == 0) return 0;
    int zeros = 0;
    while (zeros < 10 && !(mag & 1u)) mag >>= 1, ++zeros;
    return 10 - zeros;
}

namespace {

// other_side() on the grid of multiples of step: the grid neighbour of h on the side of s.
uint16_t other_side_step(uint16_t h, float v, float s, uint16_t step) {
    if (step == 1) return other_side(h, v, s);
    const uint16_t sign = h & 0x8000u, mag = h & 0x7fffu;
    if (v > s) {
        if (mag == 0) return h;
        return sign ? static_cast<uint16_t>(h + step) : static_cast<uint16_t>(h - step);
    }
    if (v < s) {
        if (sign) return mag == 0 ? step : static_cast<uint16_t>(h - step);
        if (static_cast<uint32_t>(mag) + step <= 0x7bffu) return static_cast<uint16_t>(h + step);
    }
    return h;
}

// Step 1 of the coarse rounding for a run of one bin's pixels: each value rounded to nearest on
// the grid of multiples of step (round_half_to_bits; float_to_half for step 1) into dst, and the
// colour error it makes added to er, eg, eb (weights wr, wg, wb), in the order
// round_pixel_on_grid adds it (bins in increasing order, no FMA).
void round_bin_on_grid_scalar(const float* src, size_t len, uint16_t step, float wr, float wg,
                              float wb, uint16_t* dst, float* er, float* eg, float* eb) {
    const int bits = 10 - __builtin_ctz(step);
    for (size_t i = 0; i < len; ++i) {
        const float v = src[i];
        const uint16_t h = step == 1 ? float_to_half(v) : round_half_to_bits(v, bits);
        dst[i] = h;
        const float d = half_to_float(h) - v;
        er[i] += wr * d;
        eg[i] += wg * d;
        eb[i] += wb * d;
    }
}

// The first move of each pixel of a run of one bin, just after step 1: delta[i], the value of
// other_side_step() of h[i] minus h[i]'s (settle_on_grid's starting deltas).
void grid_deltas_scalar(const float* src, const uint16_t* h, size_t len, uint16_t step,
                        float* delta) {
    for (size_t i = 0; i < len; ++i) {
        const float hv = half_to_float(h[i]);
        delta[i] = half_to_float(other_side_step(h[i], hv, src[i], step)) - hv;
    }
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
// Eight 32-bit lane masks as eight 16-bit ones.
__attribute__((target("avx"), always_inline)) inline __m128i mask16(__m256 m) {
    return _mm_packs_epi32(_mm_castps_si128(_mm256_castps256_ps128(m)),
                           _mm_castps_si128(_mm256_extractf128_ps(m, 1)));
}

// round_bin_on_grid_scalar, eight pixels at a time, with the same result bit for bit. The half
// codes are handled as round_half_to_bits handles them (lo, the multiple of step at or below the
// nearest half, and hi = lo + step); the choice between lo and hi compares |v| with their
// midpoint, which is exact in float (two halves of at most 12 significant bits and a common
// unit), so it decides as round_half_to_bits' exact differences in double do: hi above the
// midpoint, lo below, the even multiple at it.
__attribute__((target("avx,f16c"))) void round_bin_on_grid_f16c(const float* src, size_t len,
                                                                uint16_t step, float wr, float wg,
                                                                float wb, uint16_t* dst, float* er,
                                                                float* eg, float* eb) {
    const __m256 cw[3] = {_mm256_set1_ps(wr), _mm256_set1_ps(wg), _mm256_set1_ps(wb)};
    const __m128i vstep = _mm_set1_epi16(static_cast<short>(step));
    const __m128i step_less = _mm_set1_epi16(static_cast<short>(step - 1));
    const __m128i grid = _mm_set1_epi16(static_cast<short>(~(step - 1u)));
    const __m128i sign_bit = _mm_set1_epi16(static_cast<short>(0x8000));
    const __m128i mag_bits = _mm_set1_epi16(0x7fff);
    const __m128i largest = _mm_set1_epi16(0x7bff);
    const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256 half_ = _mm256_set1_ps(0.5f);
    size_t i = 0;
    for (; i + 8 <= len; i += 8) {
        const __m256 v = _mm256_loadu_ps(src + i);
        const __m128i h = _mm256_cvtps_ph(v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
        __m128i out = h;
        if (step != 1) {
            const __m128i sign = _mm_and_si128(h, sign_bit), mag = _mm_and_si128(h, mag_bits);
            const __m256 av = _mm256_and_ps(v, abs_mask);
            __m128i lo = _mm_and_si128(mag, grid);
            // On the grid and above |v|: the grid point below it is the lower neighbour.
            const __m128i adjust = _mm_and_si128(
                _mm_and_si128(_mm_cmpeq_epi16(lo, mag), _mm_cmpgt_epi16(lo, step_less)),
                mask16(_mm256_cmp_ps(_mm256_cvtph_ps(lo), av, _CMP_GT_OQ)));
            lo = _mm_sub_epi16(lo, _mm_and_si128(adjust, vstep));
            const __m128i hi = _mm_add_epi16(lo, vstep);
            const __m128i over = _mm_cmpgt_epi16(hi, largest);
            const __m256 mid =
                _mm256_mul_ps(_mm256_add_ps(_mm256_cvtph_ps(lo), _mm256_cvtph_ps(hi)), half_);
            const __m128i above = mask16(_mm256_cmp_ps(av, mid, _CMP_GT_OQ));
            const __m128i tie = mask16(_mm256_cmp_ps(av, mid, _CMP_EQ_OQ));
            const __m128i odd = _mm_cmpeq_epi16(_mm_and_si128(lo, vstep), vstep);
            const __m128i up = _mm_andnot_si128(over, _mm_or_si128(above, _mm_and_si128(tie, odd)));
            const __m128i m =
                _mm_or_si128(sign, _mm_or_si128(_mm_and_si128(up, hi), _mm_andnot_si128(up, lo)));
            const __m128i inf_nan = _mm_cmpgt_epi16(mag, largest);  // stay as they are
            out = _mm_or_si128(_mm_and_si128(inf_nan, h), _mm_andnot_si128(inf_nan, m));
        }
        _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + i), out);
        const __m256 d = _mm256_sub_ps(_mm256_cvtph_ps(out), v);
        _mm256_storeu_ps(er + i, _mm256_add_ps(_mm256_loadu_ps(er + i), _mm256_mul_ps(cw[0], d)));
        _mm256_storeu_ps(eg + i, _mm256_add_ps(_mm256_loadu_ps(eg + i), _mm256_mul_ps(cw[1], d)));
        _mm256_storeu_ps(eb + i, _mm256_add_ps(_mm256_loadu_ps(eb + i), _mm256_mul_ps(cw[2], d)));
    }
    if (i < len)
        round_bin_on_grid_scalar(src + i, len - i, step, wr, wg, wb, dst + i, er + i, eg + i,
                                 eb + i);
}

// grid_deltas_scalar, eight pixels at a time, bit for bit: other_side_step's cases as masks on
// the codes (other_side()'s for step 1), the values converted exactly by F16C.
__attribute__((target("avx,f16c"))) void grid_deltas_f16c(const float* src, const uint16_t* h,
                                                          size_t len, uint16_t step, float* delta) {
    const __m128i vstep = _mm_set1_epi16(static_cast<short>(step));
    const __m128i sign_bit = _mm_set1_epi16(static_cast<short>(0x8000));
    const __m128i mag_bits = _mm_set1_epi16(0x7fff);
    const __m128i zero = _mm_setzero_si128();
    // Moving up stays finite: mag + step <= 0x7bff, i.e. mag <= 0x7bff - step (no overflow).
    const __m128i up_limit = _mm_set1_epi16(static_cast<short>(0x7bff - step));
    const __m128i below_largest = _mm_set1_epi16(0x7bff);
    size_t i = 0;
    for (; i + 8 <= len; i += 8) {
        const __m128i c = _mm_loadu_si128(reinterpret_cast<const __m128i*>(h + i));
        const __m256 v = _mm256_cvtph_ps(c), sv = _mm256_loadu_ps(src + i);
        const __m128i gt = mask16(_mm256_cmp_ps(v, sv, _CMP_GT_OQ));
        const __m128i lt = mask16(_mm256_cmp_ps(v, sv, _CMP_LT_OQ));
        const __m128i neg = _mm_cmpeq_epi16(_mm_and_si128(c, sign_bit), sign_bit);
        const __m128i mag = _mm_and_si128(c, mag_bits);
        const __m128i mag0 = _mm_cmpeq_epi16(mag, zero);
        const __m128i plus = _mm_add_epi16(c, vstep), minus = _mm_sub_epi16(c, vstep);
        // v > s: the code unchanged at magnitude 0, else plus when negative, minus when positive.
        const __m128i on_gt = _mm_or_si128(_mm_and_si128(neg, plus), _mm_andnot_si128(neg, minus));
        const __m128i gt_moves = _mm_andnot_si128(mag0, gt);
        __m128i lt_neg, lt_neg_moves, lt_pos_moves;
        if (step == 1) {
            // other_side(): minus when negative and mag < 0x7bff; plus when positive and the same.
            const __m128i small = _mm_cmpgt_epi16(below_largest, mag);
            lt_neg = minus;
            lt_neg_moves = _mm_and_si128(lt, _mm_and_si128(neg, small));
            lt_pos_moves = _mm_and_si128(lt, _mm_andnot_si128(neg, small));
        } else {
            // Negative: step at magnitude 0, else minus; positive: plus while it stays finite.
            lt_neg = _mm_or_si128(_mm_and_si128(mag0, vstep), _mm_andnot_si128(mag0, minus));
            lt_neg_moves = _mm_and_si128(lt, neg);
            lt_pos_moves = _mm_andnot_si128(_mm_or_si128(neg, _mm_cmpgt_epi16(mag, up_limit)), lt);
        }
        __m128i o = c;
        o = _mm_or_si128(_mm_and_si128(gt_moves, on_gt), _mm_andnot_si128(gt_moves, o));
        o = _mm_or_si128(_mm_and_si128(lt_neg_moves, lt_neg), _mm_andnot_si128(lt_neg_moves, o));
        o = _mm_or_si128(_mm_and_si128(lt_pos_moves, plus), _mm_andnot_si128(lt_pos_moves, o));
        _mm256_storeu_ps(delta + i, _mm256_sub_ps(_mm256_cvtph_ps(o), v));
    }
    if (i < len) grid_deltas_scalar(src + i, h + i, len - i, step, delta + i);
}

// best_flip over planes padded to a multiple of 8 bins (weights and deltas 0 past bins).
__attribute__((target("avx"))) size_t best_flip_padded_avx(const float* wr, const float* wg,
                                                           const float* wb, size_t bins,
                                                           size_t padded, const float* delta,
                                                           const float* e) {
    const float e2 = squared(e);
    BestFlip8 bf = best_flip8_start(e, e2);
    for (size_t k = 0; k < padded; k += 8)
        best_flip8_step(bf, _mm256_loadu_ps(wr + k), _mm256_loadu_ps(wg + k),
                        _mm256_loadu_ps(wb + k), _mm256_loadu_ps(delta + k));
    return best_flip8_end(bf, e2, bins);
}

// The best partner b > a of bin a for a pair move: the lowest b whose squared error
// |(xa, ya, za) + v_b|^2 is smallest and below *best_e2 (then *best_e2 is set to it), or bins.
// vx, vy, vz hold w·delta per bin and +Inf for at least 8 entries past bins, which no lane takes.
__attribute__((target("avx"))) size_t best_partner_avx(const float* vx, const float* vy,
                                                       const float* vz, size_t a, size_t bins,
                                                       float xa, float ya, float za,
                                                       float* best_e2) {
    const __m256 ex = _mm256_set1_ps(xa), ey = _mm256_set1_ps(ya), ez = _mm256_set1_ps(za);
    __m256 best = _mm256_set1_ps(*best_e2), best_k = _mm256_set1_ps(-1.0f);
    __m256 k = _mm256_add_ps(_mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7),
                             _mm256_set1_ps(static_cast<float>(a + 1)));
    for (size_t b = a + 1; b < bins; b += 8) {
        const __m256 x = _mm256_add_ps(ex, _mm256_loadu_ps(vx + b));
        const __m256 y = _mm256_add_ps(ey, _mm256_loadu_ps(vy + b));
        const __m256 z = _mm256_add_ps(ez, _mm256_loadu_ps(vz + b));
        const __m256 t = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)),
                                       _mm256_mul_ps(z, z));
        const __m256 lt = _mm256_cmp_ps(t, best, _CMP_LT_OQ);
        best = _mm256_min_ps(t, best);
        best_k = _mm256_or_ps(_mm256_and_ps(lt, k), _mm256_andnot_ps(lt, best_k));
        k = _mm256_add_ps(k, _mm256_set1_ps(8.0f));
    }
    BestFlip8 bf{ex, ey, ez, best, best_k, k};
    const size_t found = best_flip8_end(bf, *best_e2, bins);
    if (found < bins) *best_e2 = _mm256_cvtss_f32(min8(best));
    return found;
}
#else
void grid_deltas_f16c(const float* src, const uint16_t* h, size_t len, uint16_t step,
                      float* delta) {
    grid_deltas_scalar(src, h, len, step, delta);
}
void round_bin_on_grid_f16c(const float* src, size_t len, uint16_t step, float wr, float wg,
                            float wb, uint16_t* dst, float* er, float* eg, float* eb) {
    round_bin_on_grid_scalar(src, len, step, wr, wg, wb, dst, er, eg, eb);
}
size_t best_flip_padded_avx(const float* wr, const float* wg, const float* wb, size_t bins, size_t,
                            const float* delta, const float* e) {
    return best_flip(wr, wg, wb, bins, delta, e);
}
size_t best_partner_avx(const float* vx, const float* vy, const float* vz, size_t a, size_t bins,
                        float xa, float ya, float za, float* best_e2) {
    size_t found = bins;
    for (size_t b = a + 1; b < bins; ++b) {
        const float x = xa + vx[b], y = ya + vy[b], z = za + vz[b];
        const float t = x * x + y * y + z * z;
        if (t < *best_e2) *best_e2 = t, found = b;
    }
    return found;
}
#endif

// The weights of the coarse rounding as planes padded to a multiple of 8 bins with zeros, and the
// pixel's scratch: deltas (0 past bins) and the pair moves' w·delta planes (+Inf past bins).
struct GridScratch {
    size_t bins, padded;
    std::vector<float> w[3];
    std::vector<float> delta;
    std::vector<float> v[3];
    GridScratch(const std::vector<float>& rgb_weight, size_t n_bins)
        : bins(n_bins), padded((n_bins + 7) & ~size_t{7}), delta(padded, 0.0f) {
        for (size_t c = 0; c < 3; ++c) {
            w[c].assign(padded, 0.0f);
            for (size_t k = 0; k < bins; ++k) w[c][k] = rgb_weight[3 * k + c];
            v[c].assign(bins + 8, std::numeric_limits<float>::infinity());
        }
    }
};

size_t best_flip_grid(const GridScratch& g, const float* e, bool avx) {
    return avx ? best_flip_padded_avx(g.w[0].data(), g.w[1].data(), g.w[2].data(), g.bins, g.padded,
                                      g.delta.data(), e)
               : best_flip(g.w[0].data(), g.w[1].data(), g.w[2].data(), g.bins, g.delta.data(), e);
}

// The pair whose moves leave the smallest squared error below *best_e2 (first pair in bin order
// among equals): *ba, *bb, or false when none does.
bool best_pair(const GridScratch& g, const float* e, bool avx, size_t* ba, size_t* bb) {
    const size_t bins = g.bins;
    const float *vx = g.v[0].data(), *vy = g.v[1].data(), *vz = g.v[2].data();
    float best_e2 = squared(e);
    bool found = false;
    for (size_t a = 0; a < bins; ++a) {
        if (g.delta[a] == 0) continue;
        const float xa = e[0] + vx[a], ya = e[1] + vy[a], za = e[2] + vz[a];
        if (avx) {
            const size_t b = best_partner_avx(vx, vy, vz, a, bins, xa, ya, za, &best_e2);
            if (b < bins) *ba = a, *bb = b, found = true;
            continue;
        }
        for (size_t b = a + 1; b < bins; ++b) {
            const float x = xa + vx[b], y = ya + vy[b], z = za + vz[b];
            const float t = x * x + y * y + z * z;
            if (t < best_e2) best_e2 = t, *ba = a, *bb = b, found = true;
        }
    }
    return found;
}

// The greedy moves of one pixel (bin k at s[k * spectra_stride], out at px[k * plane_stride])
// already rounded to nearest on the grids of steps[k] with colour error e: the single moves of
// round_spectra_to_half (in its order and with its float sums), then, past kMaxFlips, pair moves;
// true when the colour ends within kColourTolerance.
bool settle_on_grid(const float* s, size_t spectra_stride, const std::vector<uint16_t>& steps,
                    int max_flips, const float* delta0, float* e, uint16_t* px, size_t plane_stride,
                    GridScratch& g, bool avx) {
    const size_t bins = g.bins;
    const std::vector<float>* w = g.w;
    float* delta = g.delta.data();
    // The pixel's moves as step 1 left them (grid_deltas), a plane_stride apart.
    for (size_t k = 0; k < bins; ++k) delta[k] = delta0[k * plane_stride];
    auto move = [&](size_t k) {
        uint16_t& h = px[k * plane_stride];
        const float sk = s[k * spectra_stride];
        h = other_side_step(h, half_to_float(h), sk, steps[k]);
        e[0] += w[0][k] * delta[k];
        e[1] += w[1][k] * delta[k];
        e[2] += w[2][k] * delta[k];
        const float hv = half_to_float(h);
        delta[k] = half_to_float(other_side_step(h, hv, sk, steps[k])) - hv;
    };
    for (int flip = 1; flip <= max_flips; ++flip) {
        const size_t best = best_flip_grid(g, e, avx);
        if (best == bins) break;
        move(best);
        if (within_tolerance(e)) return true;
    }
    if (max_flips <= kMaxFlips) return false;
    // Coarse steps: single moves overshoot, but two bins moved in opposite directions can change
    // the colour by little. Up to max_flips / 2 pair moves, each the pair whose moves leave the
    // smallest squared error (first pair in bin order among equals), while it shrinks.
    for (int pair = 0; pair < max_flips / 2; ++pair) {
        for (size_t c = 0; c < 3; ++c)
            for (size_t k = 0; k < bins; ++k) g.v[c][k] = w[c][k] * delta[k];
        size_t ba = bins, bb = bins;
        if (!best_pair(g, e, avx, &ba, &bb)) return false;
        move(ba);
        move(bb);
        if (within_tolerance(e)) return true;
    }
    return false;
}

}  // namespace

size_t round_spectra_to_bits(const float* spectra, size_t spectra_stride, size_t n, size_t bins,
                             const std::vector<float>* rgb_weight, const std::vector<int>& bits,
                             uint16_t* out, size_t plane_stride) {
    bool full = true;
    for (size_t k = 0; k < bins; ++k) full = full && (k >= bits.size() || bits[k] >= 10);
    if (full) {
        round_spectra_to_half(spectra, spectra_stride, n, bins, rgb_weight, out, plane_stride);
        return 0;
    }
    std::vector<uint16_t> steps(bins);
    for (size_t k = 0; k < bins; ++k) {
        const int b = std::clamp(k < bits.size() ? bits[k] : 10, 0, 10);
        steps[k] = static_cast<uint16_t>(1u << (10 - b));
    }
    const bool f16c = have_f16c();
    auto round_bin = f16c ? round_bin_on_grid_f16c : round_bin_on_grid_scalar;
    float er[kBlock], eg[kBlock], eb[kBlock];
    if (!rgb_weight) {
        for (size_t i0 = 0; i0 < n; i0 += kBlock) {
            const size_t len = std::min(kBlock, n - i0);
            std::fill(er, er + len, 0.0f);
            std::fill(eg, eg + len, 0.0f);
            std::fill(eb, eb + len, 0.0f);
            for (size_t k = 0; k < bins; ++k)
                round_bin(spectra + k * spectra_stride + i0, len, steps[k], 0, 0, 0,
                          out + k * plane_stride + i0, er, eg, eb);
        }
        return 0;
    }
    // A coarse grid moves the colour by more per flip, so it is given more flips than full half.
    constexpr int kMaxCoarseFlips = 32;
    GridScratch g(*rgb_weight, bins);
    size_t widened = 0;
    // The block is rounded into planes of its own length and copied out at the end: the output's
    // planes are a strip apart (whole ZIP chunks of rows: a large power-of-two multiple for common
    // widths), so one pixel's bins there can all fall in one cache set, and the moves below would
    // fetch each from beyond L2.
    std::vector<uint16_t> local(bins * std::min(kBlock, n));
    std::vector<float> deltas(local.size());
    auto grid_deltas = f16c ? grid_deltas_f16c : grid_deltas_scalar;
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        std::fill(er, er + len, 0.0f);
        std::fill(eg, eg + len, 0.0f);
        std::fill(eb, eb + len, 0.0f);
        // Every bin to nearest on its grid, a plane at a time; each pixel's error is summed over
        // the bins in increasing order, as one pixel at a time would sum it.
        for (size_t k = 0; k < bins; ++k)
            round_bin(spectra + k * spectra_stride + i0, len, steps[k], g.w[0][k], g.w[1][k],
                      g.w[2][k], local.data() + k * len, er, eg, eb);
        // Each bin's first move to its other grid neighbour, a plane at a time.
        for (size_t k = 0; k < bins; ++k)
            grid_deltas(spectra + k * spectra_stride + i0, local.data() + k * len, len, steps[k],
                        deltas.data() + k * len);
        for (size_t i = 0; i < len; ++i) {
            float e[3] = {er[i], eg[i], eb[i]};
            if (within_tolerance(e)) continue;
            const float* s = spectra + i0 + i;
            uint16_t* px = local.data() + i;
            if (settle_on_grid(s, spectra_stride, steps, kMaxCoarseFlips, deltas.data() + i, e, px,
                               len, g, f16c))
                continue;
            // Full half, exactly as round_spectra_to_half rounds this pixel.
            ++widened;
            round_spectra_to_half(s, spectra_stride, 1, bins, rgb_weight, px, len);
        }
        for (size_t k = 0; k < bins; ++k)
            std::copy(local.data() + k * len, local.data() + (k + 1) * len,
                      out + k * plane_stride + i0);
    }
    return widened;
}

void expand_to_half(const ExpansionMatrix& m, const float* r, const float* g, const float* b,
                    size_t n, uint16_t* out, size_t plane_stride) {
    if (!m.rgb_weight.empty()) {
        expand_to_half_feedback(m, r, g, b, n, out, plane_stride);
        return;
    }
    float tmp[kBlock];
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        for (int k = 0; k < m.bins; ++k) {
            const float cr = m.coeff[3 * k], cg = m.coeff[3 * k + 1], cb = m.coeff[3 * k + 2];
            for (size_t i = 0; i < len; ++i)
                tmp[i] = cr * r[i0 + i] + cg * g[i0 + i] + cb * b[i0 + i];
            to_half(tmp, out + static_cast<size_t>(k) * plane_stride + i0, len);
        }
    }
}

void expand_to_float(const ExpansionMatrix& m, const float* r, const float* g, const float* b,
                     size_t n, float* out, size_t plane_stride) {
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        for (int k = 0; k < m.bins; ++k) {
            const float cr = m.coeff[3 * k], cg = m.coeff[3 * k + 1], cb = m.coeff[3 * k + 2];
            float* dst = out + static_cast<size_t>(k) * plane_stride + i0;
            for (size_t i = 0; i < len; ++i)
                dst[i] = cr * r[i0 + i] + cg * g[i0 + i] + cb * b[i0 + i];
        }
    }
}

}  // namespace spectex
