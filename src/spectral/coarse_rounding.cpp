// The precision budget's coarser grids (half_bits.h): a bin rounded to a multiple of 2^(10 - bits)
// of half's code, and the colour-aware moves on those grids (single moves, then pair moves), with
// full half for a pixel they cannot hold.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "base/half.h"
#include "spectral/half_bits.h"
#include "spectral/half_rounding_detail.h"

namespace spectex {

using namespace half_rounding_detail;

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

// The coarse grids' tolerance of a pixel whose exact colour is c, per channel: kColourTolerance
// times `share` (alpha_tolerance of a premultiplied pixel's alpha, else 1) or
// kCoarseRelativeTolerance of the channel's value, whichever is larger.
void coarse_tolerance(const float* c, float share, float* tau) {
    for (size_t j = 0; j < 3; ++j)
        tau[j] = std::max(kColourTolerance * share, kCoarseRelativeTolerance * std::fabs(c[j]));
}

bool within_coarse(const float* e, const float* tau) {
    return std::fabs(e[0]) <= tau[0] && std::fabs(e[1]) <= tau[1] && std::fabs(e[2]) <= tau[2];
}

// The greedy moves of one pixel (bin k at s[k * spectra_stride], out at px[k * plane_stride])
// already rounded to nearest on the grids of steps[k] with colour error e: the single moves of
// round_spectra_to_half (in its order and with its float sums), then, past kMaxFlips, pair moves;
// true when the colour ends within tau (coarse_tolerance).
bool settle_on_grid(const float* s, size_t spectra_stride, const std::vector<uint16_t>& steps,
                    int max_flips, const float* delta0, float* e, const float* tau, uint16_t* px,
                    size_t plane_stride, GridScratch& g, bool avx) {
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
        if (within_coarse(e, tau)) return true;
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
        if (within_coarse(e, tau)) return true;
    }
    return false;
}

}  // namespace

size_t round_spectra_to_bits(const float* spectra, size_t spectra_stride, size_t n, size_t bins,
                             const std::vector<float>* rgb_weight, const std::vector<int>& bits,
                             uint16_t* out, size_t plane_stride, const float* alpha) {
    bool full = true;
    for (size_t k = 0; k < bins; ++k) full = full && (k >= bits.size() || bits[k] >= 10);
    if (full) {
        round_spectra_to_half(spectra, spectra_stride, n, bins, rgb_weight, out, plane_stride,
                              alpha);
        return 0;
    }
    std::vector<uint16_t> steps(bins);
    for (size_t k = 0; k < bins; ++k) {
        const int b = std::clamp(k < bits.size() ? bits[k] : 10, 0, 10);
        steps[k] = static_cast<uint16_t>(1u << (10 - b));
    }
    const bool f16c = have_f16c();
    auto round_bin = f16c ? round_bin_on_grid_f16c : round_bin_on_grid_scalar;
    float er[kBlock], eg[kBlock], eb[kBlock], cr[kBlock], cg[kBlock], cb[kBlock];
    // A coarse grid moves the colour by more per flip, so it is given more flips than full half.
    constexpr int kMaxCoarseFlips = 32;
    // Without colour weights, every bin to nearest on its grid and nothing else: the same loop
    // with weights 0 (the errors it sums are then not looked at).
    const std::vector<float> no_weight(rgb_weight ? 0 : 3 * bins, 0.0f);
    GridScratch g(rgb_weight ? *rgb_weight : no_weight, bins);
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
        if (rgb_weight) {
            // Each bin's first move to its other grid neighbour, a plane at a time.
            for (size_t k = 0; k < bins; ++k)
                grid_deltas(spectra + k * spectra_stride + i0, local.data() + k * len, len,
                            steps[k], deltas.data() + k * len);
            // Each pixel's exact colour (its tolerance), summed over the bins in increasing order.
            std::fill(cr, cr + len, 0.0f);
            std::fill(cg, cg + len, 0.0f);
            std::fill(cb, cb + len, 0.0f);
            for (size_t k = 0; k < bins; ++k) {
                const float* s = spectra + k * spectra_stride + i0;
                const float wr = g.w[0][k], wg = g.w[1][k], wb = g.w[2][k];
                for (size_t i = 0; i < len; ++i) {
                    cr[i] += wr * s[i];
                    cg[i] += wg * s[i];
                    cb[i] += wb * s[i];
                }
            }
            for (size_t i = 0; i < len; ++i) {
                float e[3] = {er[i], eg[i], eb[i]};
                const float c[3] = {cr[i], cg[i], cb[i]};
                float tau[3];
                coarse_tolerance(c, alpha ? alpha_tolerance(alpha[i0 + i]) : 1.0f, tau);
                if (within_coarse(e, tau)) continue;
                const float* s = spectra + i0 + i;
                uint16_t* px = local.data() + i;
                if (settle_on_grid(s, spectra_stride, steps, kMaxCoarseFlips, deltas.data() + i, e,
                                   tau, px, len, g, f16c))
                    continue;
                // Full half, exactly as round_spectra_to_half rounds this pixel.
                ++widened;
                round_spectra_to_half(s, spectra_stride, 1, bins, rgb_weight, px, len,
                                      alpha ? alpha + i0 + i : nullptr);
            }
        }
        for (size_t k = 0; k < bins; ++k)
            std::copy(local.data() + k * len, local.data() + (k + 1) * len,
                      out + k * plane_stride + i0);
    }
    return widened;
}

}  // namespace spectex
