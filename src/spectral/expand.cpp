#include "spectral/expand.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#if defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#endif

#include "base/half.h"
#include "spectral/half_rounding_detail.h"

namespace spectex {

namespace half_rounding_detail {

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

}  // namespace half_rounding_detail

using namespace half_rounding_detail;

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
