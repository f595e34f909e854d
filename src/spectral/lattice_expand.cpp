// The batch kernel of the spectral lattice (SpectralLattice::expand). Pixel by pixel, the four
// vertex rows of its Kuhn simplex are blended into a pixel-major block (contiguous along
// wavelength, so the bin loop vectorises), then the block is transposed into the bin planes.
#include <algorithm>
#include <cstdint>
#include <vector>
#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

#include "spectral/lattice.h"

namespace spectex {

namespace {

// out[k] = w0 a[k] + w1 b[k] + w2 c[k] + w3 d[k]; no aliasing, so GCC vectorises it.
void blend4(const float* __restrict a, const float* __restrict b, const float* __restrict c,
            const float* __restrict d, const float w[4], float* __restrict out, size_t bins) {
    const float w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3];
    for (size_t k = 0; k < bins; ++k) out[k] = w0 * a[k] + w1 * b[k] + w2 * c[k] + w3 * d[k];
}

// Block of len pixel rows (row p at tmp + p * ld) -> planes out[k * stride + p].
void transpose_block(const float* tmp, size_t ld, size_t len, size_t bins, float* out, size_t stride) {
    size_t k0 = 0;
#if defined(__SSE2__)
    for (; k0 + 4 <= bins; k0 += 4) {
        float* o = out + k0 * stride;
        size_t p = 0;
        for (; p + 4 <= len; p += 4) {
            __m128 r0 = _mm_load_ps(tmp + p * ld + k0), r1 = _mm_load_ps(tmp + (p + 1) * ld + k0);
            __m128 r2 = _mm_load_ps(tmp + (p + 2) * ld + k0), r3 = _mm_load_ps(tmp + (p + 3) * ld + k0);
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

}  // namespace

void SpectralLattice::expand(const float* r, const float* g, const float* b, size_t n, float* out,
                             size_t plane_stride) const {
    const size_t B = static_cast<size_t>(bins_);
    const size_t ld = (B + 3) & ~size_t{3};  // 16-byte aligned rows
    // Pixels per block: the block (len × ld floats) stays within ~24 KiB of L1.
    size_t block = 64;
    while (block > 4 && block * ld * sizeof(float) > 24 * 1024) block /= 2;
    // Over-allocate by 3 floats and align by hand: std::vector<float> is only 8-byte aligned by
    // guarantee on some ABIs.
    std::vector<float> buf(block * ld + 4);
    float* tmp = buf.data();
    while (reinterpret_cast<uintptr_t>(tmp) % 16 != 0) ++tmp;
    const float* T = table_.data();
    const size_t n2 = static_cast<size_t>(n_) * n_, n1 = static_cast<size_t>(n_);
    for (size_t i0 = 0; i0 < n; i0 += block) {
        const size_t len = std::min(block, n - i0);
        for (size_t p = 0; p < len; ++p) {
            float t0, t1, t2;
            const size_t ir = static_cast<size_t>(locator_.locate_fast(r[i0 + p], &t0));
            const size_t ig = static_cast<size_t>(locator_.locate_fast(g[i0 + p], &t1));
            const size_t ib = static_cast<size_t>(locator_.locate_fast(b[i0 + p], &t2));
            // Sort (t, stride) by decreasing t: the Kuhn simplex containing the point.
            float ta = t0, tb = t1, tc = t2;
            size_t sa = n2, sb = n1, sc = 1;
            if (ta < tb) std::swap(ta, tb), std::swap(sa, sb);
            if (tb < tc) std::swap(tb, tc), std::swap(sb, sc);
            if (ta < tb) std::swap(ta, tb), std::swap(sa, sb);
            const size_t v0 = ir * n2 + ig * n1 + ib, v1 = v0 + sa, v2 = v1 + sb, v3 = v2 + sc;
            const float w[4] = {1.0f - ta, ta - tb, tb - tc, tc};
            blend4(T + v0 * B, T + v1 * B, T + v2 * B, T + v3 * B, w, tmp + p * ld, B);
        }
        transpose_block(tmp, ld, len, B, out + i0, plane_stride);
    }
}

}  // namespace spectex
