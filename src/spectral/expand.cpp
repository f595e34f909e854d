#include "spectral/expand.h"

#include <algorithm>

#include "spectral/half.h"

namespace spectex {

namespace {
// Pixels per block: r, g, b of a block stay in L1 while every bin is written.
constexpr size_t kBlock = 512;
}  // namespace

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

// Error-feedback rounding: bins in wavelength order; for each, of the two halves around the exact
// value (the nearest and its neighbour on the other side) take the one that leaves the running
// integrated colour error (a linear RGB 3-vector per pixel) smallest. Plain rounding lets the
// bins' errors add up; this keeps the sum near one bin's error. Deterministic, pixel by pixel.
void expand_to_half_feedback(const ExpansionMatrix& m, const float* r, const float* g, const float* b, size_t n,
                             uint16_t* out, size_t plane_stride) {
    float er[kBlock], eg[kBlock], eb[kBlock];
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        std::fill(er, er + len, 0.0f);
        std::fill(eg, eg + len, 0.0f);
        std::fill(eb, eb + len, 0.0f);
        for (int k = 0; k < m.bins; ++k) {
            const float cr = m.coeff[3 * k], cg = m.coeff[3 * k + 1], cb = m.coeff[3 * k + 2];
            const float wr = m.rgb_weight[3 * k], wg = m.rgb_weight[3 * k + 1], wb = m.rgb_weight[3 * k + 2];
            uint16_t* dst = out + static_cast<size_t>(k) * plane_stride + i0;
            for (size_t i = 0; i < len; ++i) {
                const float s = cr * r[i0 + i] + cg * g[i0 + i] + cb * b[i0 + i];
                const uint16_t h0 = float_to_half(s);
                const float v0 = half_to_float(h0);
                uint16_t h1 = h0;
                // The neighbour on the other side of s (same sign region; never crosses to NaN/Inf).
                if (v0 > s && (h0 & 0x7fffu) != 0) h1 = (h0 & 0x8000u) ? h0 + 1 : h0 - 1;
                else if (v0 < s && (h0 & 0x7fffu) < 0x7bffu) h1 = (h0 & 0x8000u) ? h0 - 1 : h0 + 1;
                const float d0 = v0 - s, d1 = half_to_float(h1) - s;
                const float r0 = er[i] + wr * d0, g0 = eg[i] + wg * d0, b0 = eb[i] + wb * d0;
                const float r1 = er[i] + wr * d1, g1 = eg[i] + wg * d1, b1 = eb[i] + wb * d1;
                const bool take1 = r1 * r1 + g1 * g1 + b1 * b1 < r0 * r0 + g0 * g0 + b0 * b0;
                dst[i] = take1 ? h1 : h0;
                er[i] = take1 ? r1 : r0;
                eg[i] = take1 ? g1 : g0;
                eb[i] = take1 ? b1 : b0;
            }
        }
    }
}

}  // namespace

void expand_to_half(const ExpansionMatrix& m, const float* r, const float* g, const float* b, size_t n,
                    uint16_t* out, size_t plane_stride) {
    if (!m.rgb_weight.empty()) {
        expand_to_half_feedback(m, r, g, b, n, out, plane_stride);
        return;
    }
    float tmp[kBlock];
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        for (int k = 0; k < m.bins; ++k) {
            const float cr = m.coeff[3 * k], cg = m.coeff[3 * k + 1], cb = m.coeff[3 * k + 2];
            for (size_t i = 0; i < len; ++i) tmp[i] = cr * r[i0 + i] + cg * g[i0 + i] + cb * b[i0 + i];
            uint16_t* dst = out + static_cast<size_t>(k) * plane_stride + i0;
            for (size_t i = 0; i < len; ++i) dst[i] = float_to_half(tmp[i]);
        }
    }
}

void expand_to_float(const ExpansionMatrix& m, const float* r, const float* g, const float* b, size_t n,
                     float* out, size_t plane_stride) {
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        for (int k = 0; k < m.bins; ++k) {
            const float cr = m.coeff[3 * k], cg = m.coeff[3 * k + 1], cb = m.coeff[3 * k + 2];
            float* dst = out + static_cast<size_t>(k) * plane_stride + i0;
            for (size_t i = 0; i < len; ++i) dst[i] = cr * r[i0 + i] + cg * g[i0 + i] + cb * b[i0 + i];
        }
    }
}

}  // namespace spectex
