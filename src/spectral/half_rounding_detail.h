#pragma once
// What spectral/expand.cpp (the expansion, float <-> half), spectral/half_rounding.cpp (the
// colour-aware full-half rounding) and spectral/coarse_rounding.cpp (the precision budget's coarser
// grids) share: the block size, the half conversions chosen at run time, and the greedy flip's
// pieces. Internal to spectral/; the public interfaces are expand.h and half_bits.h.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "base/half.h"
#include "spectral/expand.h"

namespace spectex {
namespace half_rounding_detail {

// Pixels per block: r, g, b of a block stay in L1 while every bin is written.
constexpr size_t kBlock = 512;

// float <-> half for a block (expand.cpp): F16C when the processor has it, else scalar; the same
// bits either way.
void to_half_scalar(const float* in, uint16_t* out, size_t n);
void from_half_scalar(const uint16_t* in, float* out, size_t n);
void to_half(const float* in, uint16_t* out, size_t n);
void from_half(const uint16_t* in, float* out, size_t n);
bool have_f16c();

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

inline uint16_t other_side(uint16_t h, float v, float s) {
    // The neighbouring half of h on the side of s (h itself when v == s or at the range's edge).
    if (v > s && (h & 0x7fffu) != 0)
        return (h & 0x8000u) ? static_cast<uint16_t>(h + 1) : static_cast<uint16_t>(h - 1);
    if (v < s && (h & 0x7fffu) < 0x7bffu)
        return (h & 0x8000u) ? static_cast<uint16_t>(h - 1) : static_cast<uint16_t>(h + 1);
    return h;
}

// A pixel's flips are held as delta[k], the value of other_side() minus the value of bin k's
// current half. A bin that cannot flip has delta 0, whose "flip" leaves the squared error exactly
// as it is; near or beyond the end of the half range (and for NaN) delta can be infinite or NaN,
// which makes the squared error infinite or NaN. Only strictly smaller squared errors are taken, so
// neither is ever chosen, and the F16C and scalar paths, which differ there, choose alike.
inline float squared(const float* e) { return e[0] * e[0] + e[1] * e[1] + e[2] * e[2]; }

inline float flip_delta(uint16_t cur, float s) {
    const float v = half_to_float(cur);
    return half_to_float(other_side(cur, v, s)) - v;
}

// The lowest bin whose flip (its move by delta[k], weighed by the colour weights wr, wg, wb) makes
// the squared error smallest and below e's, or bins if none does.
inline size_t best_flip(const float* wr, const float* wg, const float* wb, size_t bins,
                        const float* delta, const float* e) {
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

inline bool within_tolerance(const float* e, float tolerance = kColourTolerance) {
    return std::max({std::fabs(e[0]), std::fabs(e[1]), std::fabs(e[2])}) <= tolerance;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
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
#endif

// The colour-aware rounding of the basis kernel (half_rounding.cpp): expand_to_half with weights.
void expand_to_half_feedback(const ExpansionMatrix& m, const float* r, const float* g,
                             const float* b, size_t n, uint16_t* out, size_t plane_stride);

}  // namespace half_rounding_detail
}  // namespace spectex
