// The batch kernel of the spectral lattice (SpectralLattice::expand). For a block of pixels, the
// four vertex rows of each pixel's Kuhn simplex are blended into a pixel-major scratch block
// (contiguous along wavelength, so the bin loop is plain vector code), and the block is then
// transposed into the bin planes. AVX (8 floats) when the CPU has it, chosen at run time as in
// expand.cpp (one binary for the farm); SSE2 otherwise. Both evaluate
// ((w0 a + w1 b) + w2 c) + w3 d per bin without FMA (-ffp-contract=off), so they give the same
// bits.
#include <algorithm>
#include <cstdint>
#include <vector>
#if defined(__SSE2__)
#include <xmmintrin.h>
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define SPECTEX_LATTICE_AVX 1
#endif

#include "spectral/lattice.h"

namespace spectex {

namespace {

struct Simplex {
    const float* row[4];
    float w[4];
};

// The Kuhn simplex of one pixel: the cell's low corner, then one step along each axis in order
// of decreasing local coordinate; weights 1 - t_a, t_a - t_b, t_b - t_c, t_c.
inline Simplex simplex(const AxisLocator& loc, const float* T, size_t ld, size_t n, float r,
                       float g, float b) {
    float ta, tb, tc;
    const size_t ir = static_cast<size_t>(loc.locate_fast(r, &ta));
    const size_t ig = static_cast<size_t>(loc.locate_fast(g, &tb));
    const size_t ib = static_cast<size_t>(loc.locate_fast(b, &tc));
    size_t sa = n * n, sb = n, sc = 1;
    if (ta < tb) std::swap(ta, tb), std::swap(sa, sb);
    if (tb < tc) std::swap(tb, tc), std::swap(sb, sc);
    if (ta < tb) std::swap(ta, tb), std::swap(sa, sb);
    const size_t v0 = (ir * n + ig) * n + ib;
    return {
        {T + v0 * ld, T + (v0 + sa) * ld, T + (v0 + sa + sb) * ld, T + (v0 + sa + sb + sc) * ld},
        {1.0f - ta, ta - tb, tb - tc, tc}};
}

void blend4(const Simplex& s, float* __restrict out, size_t ld) {
    const float* __restrict a = s.row[0], * __restrict b = s.row[1], * __restrict c = s.row[2], * __restrict d = s.row[3];
    const float w0 = s.w[0], w1 = s.w[1], w2 = s.w[2], w3 = s.w[3];
    for (size_t k = 0; k < ld; ++k) out[k] = w0 * a[k] + w1 * b[k] + w2 * c[k] + w3 * d[k];
}

// len pixel rows (row p at tmp + p * ld) -> planes out[k * stride + p], k < bins.
void transpose_sse(const float* tmp, size_t ld, size_t len, size_t bins, float* out,
                   size_t stride) {
    size_t k0 = 0;
#if defined(__SSE2__)
    for (; k0 + 4 <= bins; k0 += 4) {
        float* o = out + k0 * stride;
        size_t p = 0;
        for (; p + 4 <= len; p += 4) {
            __m128 r0 = _mm_load_ps(tmp + p * ld + k0), r1 = _mm_load_ps(tmp + (p + 1) * ld + k0);
            __m128 r2 = _mm_load_ps(tmp + (p + 2) * ld + k0),
                   r3 = _mm_load_ps(tmp + (p + 3) * ld + k0);
            _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
            _mm_storeu_ps(o + p, r0);
            _mm_storeu_ps(o + stride + p, r1);
            _mm_storeu_ps(o + 2 * stride + p, r2);
            _mm_storeu_ps(o + 3 * stride + p, r3);
        }
        for (; p < len; ++p)
            for (size_t j = 0; j < 4; ++j) o[j * stride + p] = tmp[p * ld + k0 + j];
    }
#endif
    for (; k0 < bins; ++k0)
        for (size_t p = 0; p < len; ++p) out[k0 * stride + p] = tmp[p * ld + k0];
}

#if defined(SPECTEX_LATTICE_AVX)
bool have_avx() {
    // libgcc's check includes the OS saving YMM state (XCR0).
    static const bool yes = __builtin_cpu_supports("avx");
    return yes;
}

__attribute__((target("avx"))) void blend4_avx(const Simplex& s, float* out, size_t ld) {
    const __m256 w0 = _mm256_set1_ps(s.w[0]), w1 = _mm256_set1_ps(s.w[1]),
                 w2 = _mm256_set1_ps(s.w[2]), w3 = _mm256_set1_ps(s.w[3]);
    for (size_t k = 0; k < ld; k += 8) {
        const __m256 x = _mm256_add_ps(
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(w0, _mm256_loadu_ps(s.row[0] + k)),
                                        _mm256_mul_ps(w1, _mm256_loadu_ps(s.row[1] + k))),
                          _mm256_mul_ps(w2, _mm256_loadu_ps(s.row[2] + k))),
            _mm256_mul_ps(w3, _mm256_loadu_ps(s.row[3] + k)));
        _mm256_store_ps(out + k, x);
    }
}

__attribute__((target("avx"))) void transpose_avx(const float* tmp, size_t ld, size_t len,
                                                  size_t bins, float* out, size_t stride) {
    size_t k0 = 0;
    for (; k0 + 8 <= bins; k0 += 8) {
        float* o = out + k0 * stride;
        size_t p = 0;
        for (; p + 8 <= len; p += 8) {
            const float* t = tmp + p * ld + k0;
            const __m256 r0 = _mm256_load_ps(t), r1 = _mm256_load_ps(t + ld),
                         r2 = _mm256_load_ps(t + 2 * ld), r3 = _mm256_load_ps(t + 3 * ld),
                         r4 = _mm256_load_ps(t + 4 * ld), r5 = _mm256_load_ps(t + 5 * ld),
                         r6 = _mm256_load_ps(t + 6 * ld), r7 = _mm256_load_ps(t + 7 * ld);
            const __m256 u0 = _mm256_unpacklo_ps(r0, r1), u1 = _mm256_unpackhi_ps(r0, r1);
            const __m256 u2 = _mm256_unpacklo_ps(r2, r3), u3 = _mm256_unpackhi_ps(r2, r3);
            const __m256 u4 = _mm256_unpacklo_ps(r4, r5), u5 = _mm256_unpackhi_ps(r4, r5);
            const __m256 u6 = _mm256_unpacklo_ps(r6, r7), u7 = _mm256_unpackhi_ps(r6, r7);
            const __m256 v0 = _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(1, 0, 1, 0));
            const __m256 v1 = _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(3, 2, 3, 2));
            const __m256 v2 = _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(1, 0, 1, 0));
            const __m256 v3 = _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(3, 2, 3, 2));
            const __m256 v4 = _mm256_shuffle_ps(u4, u6, _MM_SHUFFLE(1, 0, 1, 0));
            const __m256 v5 = _mm256_shuffle_ps(u4, u6, _MM_SHUFFLE(3, 2, 3, 2));
            const __m256 v6 = _mm256_shuffle_ps(u5, u7, _MM_SHUFFLE(1, 0, 1, 0));
            const __m256 v7 = _mm256_shuffle_ps(u5, u7, _MM_SHUFFLE(3, 2, 3, 2));
            _mm256_storeu_ps(o + p, _mm256_permute2f128_ps(v0, v4, 0x20));
            _mm256_storeu_ps(o + stride + p, _mm256_permute2f128_ps(v1, v5, 0x20));
            _mm256_storeu_ps(o + 2 * stride + p, _mm256_permute2f128_ps(v2, v6, 0x20));
            _mm256_storeu_ps(o + 3 * stride + p, _mm256_permute2f128_ps(v3, v7, 0x20));
            _mm256_storeu_ps(o + 4 * stride + p, _mm256_permute2f128_ps(v0, v4, 0x31));
            _mm256_storeu_ps(o + 5 * stride + p, _mm256_permute2f128_ps(v1, v5, 0x31));
            _mm256_storeu_ps(o + 6 * stride + p, _mm256_permute2f128_ps(v2, v6, 0x31));
            _mm256_storeu_ps(o + 7 * stride + p, _mm256_permute2f128_ps(v3, v7, 0x31));
        }
        for (; p < len; ++p)
            for (size_t j = 0; j < 8; ++j) o[j * stride + p] = tmp[p * ld + k0 + j];
    }
    if (k0 < bins) transpose_sse(tmp + k0, ld, len, bins - k0, out + k0 * stride, stride);
}
#else
bool have_avx() { return false; }
void blend4_avx(const Simplex& s, float* out, size_t ld) { blend4(s, out, ld); }
void transpose_avx(const float* tmp, size_t ld, size_t len, size_t bins, float* out,
                   size_t stride) {
    transpose_sse(tmp, ld, len, bins, out, stride);
}
#endif

}  // namespace

void SpectralLattice::expand(const float* r, const float* g, const float* b, size_t n, float* out,
                             size_t plane_stride) const {
    const size_t B = static_cast<size_t>(bins_), ld = padded_ld_;
    // Pixels per block (a multiple of 8): the scratch block stays within ~16 KiB of L1, leaving
    // room for the vertex rows being read.
    size_t block = 64;
    while (block > 8 && block * ld * sizeof(float) > 16 * 1024) block /= 2;
    std::vector<float> buf(block * ld + 8);  // aligned to 32 bytes by hand below
    float* tmp = buf.data();
    while (reinterpret_cast<uintptr_t>(tmp) % 32 != 0) ++tmp;
    const bool avx = have_avx();
    const float* T = padded_.data();
    const size_t nn = static_cast<size_t>(n_);
    for (size_t i0 = 0; i0 < n; i0 += block) {
        const size_t len = std::min(block, n - i0);
        for (size_t p = 0; p < len; ++p) {
            const Simplex s = simplex(locator_, T, ld, nn, r[i0 + p], g[i0 + p], b[i0 + p]);
            if (avx)
                blend4_avx(s, tmp + p * ld, ld);
            else
                blend4(s, tmp + p * ld, ld);
        }
        if (avx)
            transpose_avx(tmp, ld, len, B, out + i0, plane_stride);
        else
            transpose_sse(tmp, ld, len, B, out + i0, plane_stride);
    }
}

}  // namespace spectex
