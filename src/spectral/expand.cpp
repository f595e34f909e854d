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

void expand_to_half(const ExpansionMatrix& m, const float* r, const float* g, const float* b, size_t n,
                    uint16_t* out, size_t plane_stride) {
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
