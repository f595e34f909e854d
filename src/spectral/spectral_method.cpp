#include "spectral/spectral_method.h"

#include <algorithm>

#include "base/error.h"

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

RebuildTable BasisMethod::rebuild_table() const {
    RebuildTable t;
    t.rule = "basis";
    for (const auto* row : {&basis_.r, &basis_.g, &basis_.b})
        for (double v : *row) t.table.push_back(static_cast<float>(v));
    return t;
}

std::shared_ptr<const SpectralMethod> BasisMethod::weighted(const Eigen::MatrixXd& W) const {
    const size_t N = basis_.size();
    if (static_cast<size_t>(W.cols()) != N)
        throw Error("basis projection: weights on another grid");
    Basis p;
    p.name = "weighted " + basis_.name;
    for (Eigen::Index row = 0; row < W.rows(); ++row) {
        p.lambda.push_back(static_cast<double>(row));
        double r = 0, g = 0, b = 0;
        for (size_t k = 0; k < N; ++k) {
            const double w = W(row, static_cast<Eigen::Index>(k));
            r += w * basis_.r[k], g += w * basis_.g[k], b += w * basis_.b[k];
        }
        p.r.push_back(r), p.g.push_back(g), p.b.push_back(b);
    }
    return std::make_shared<BasisMethod>(std::move(p), "weighted");
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
