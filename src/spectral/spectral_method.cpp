#include "spectral/spectral_method.h"

#include <algorithm>

namespace spectex {

void SpectralMethod::expand_half(const float* r, const float* g, const float* b, size_t n,
                                 uint16_t* out, size_t plane_stride,
                                 const std::vector<float>* rgb_weight) const {
    // Blocks small enough for their float spectra to stay in cache while they are rounded.
    constexpr size_t kBlock = 256;
    const size_t k_bins = static_cast<size_t>(bins());
    std::vector<float> spectra(k_bins * kBlock);
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        expand_float(r + i0, g + i0, b + i0, len, spectra.data(), kBlock);
        round_spectra_to_half(spectra.data(), kBlock, len, k_bins, rgb_weight, out + i0,
                              plane_stride);
    }
}

BasisMethod::BasisMethod(Basis basis, std::string source)
    : basis_(std::move(basis)),
      source_(std::move(source)),
      m_(ExpansionMatrix::from_basis(basis_)) {}

std::vector<std::pair<MethodFact, std::string>> BasisMethod::provenance() const {
    return {{MethodFact::Method, "basis"},
            {MethodFact::Basis, basis_.name},
            {MethodFact::BasisSource, source_},
            {MethodFact::BasisChecksum, checksum()}};
}

void BasisMethod::expand_float(const float* r, const float* g, const float* b, size_t n, float* out,
                               size_t plane_stride) const {
    expand_to_float(m_, r, g, b, n, out, plane_stride);
}

void BasisMethod::expand_half(const float* r, const float* g, const float* b, size_t n,
                              uint16_t* out, size_t plane_stride,
                              const std::vector<float>* rgb_weight) const {
    // The basis' own kernel: the same rounding, with the exact values recomputed from the matrix.
    if (!rgb_weight) {
        expand_to_half(m_, r, g, b, n, out, plane_stride);
        return;
    }
    ExpansionMatrix m = m_;
    m.rgb_weight = *rgb_weight;
    expand_to_half(m, r, g, b, n, out, plane_stride);
}

}  // namespace spectex
