// The colour-aware rounding to full half: every bin to nearest, then greedy flips of the pixels
// whose integrated colour misses by more than kColourTolerance; from the basis kernel's
// coefficients (expand_to_half_feedback) or from spectra given as values (round_spectra_to_half).
#include <algorithm>
#include <cmath>
#include <vector>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "base/half.h"
#include "spectral/half_bits.h"
#include "spectral/half_rounding_detail.h"

namespace spectex {

using namespace half_rounding_detail;

namespace {

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

float exact(const FeedbackPlanes& p, size_t k, float r, float g, float b) {
    return p.cr[k] * r + p.cg[k] * g + p.cb[k] * b;
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

}  // namespace

namespace half_rounding_detail {

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

}  // namespace half_rounding_detail

void round_spectra_to_half(const float* spectra, size_t spectra_stride, size_t n, size_t bins,
                           const std::vector<float>* rgb_weight, uint16_t* out, size_t plane_stride,
                           const float* alpha) {
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
            const float tol =
                alpha ? kColourTolerance * alpha_tolerance(alpha[i0 + i]) : kColourTolerance;
            if (within_tolerance(e, tol)) continue;
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
                if (within_tolerance(e, tol)) break;
                delta[best] = flip_delta(h, sk);
            }
        }
    }
}

}  // namespace spectex
