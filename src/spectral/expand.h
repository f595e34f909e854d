#pragma once
// The expansion kernel: spectrum = r·S_r + g·S_g + b·S_b for every pixel of a strip.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "spectral/basis.h"

namespace spectex {

struct ExpansionMatrix {
    int bins = 0;
    std::vector<float> coeff;  // bins×3, row k = (S_r, S_g, S_b) at bin k
    // Optional, bins×3: linear RGB of a unit spectrum at bin k (the colorimetry the basis is exact
    // for). When set, half output rounds to nearest and then, only in pixels whose integrated
    // colour error exceeds 6.1e-5, moves the fewest bins to their other neighbouring half.
    std::vector<float> rgb_weight;

    static ExpansionMatrix from_basis(const Basis& basis);
};

// r, g, b: planes of n linear values. Bin k of pixel i goes to out[k * plane_stride + i].
// Half: round to nearest even, or with colour error feedback when m.rgb_weight is set.
void expand_to_half(const ExpansionMatrix& m, const float* r, const float* g, const float* b,
                    size_t n, uint16_t* out, size_t plane_stride);
// Block conversions (F16C when the CPU has it, else the scalar code of half.h: the same bits).
void floats_to_half(const float* in, uint16_t* out, size_t n);
void half_to_floats(const uint16_t* in, float* out, size_t n);
bool expansion_uses_f16c();

// Rounds n spectra (bin k of pixel i at spectra[k * spectra_stride + i]) to half, to nearest, or
// with the colour error feedback of expand_to_half when rgb_weight (bins x 3) is given: the same
// rule for any method's spectra. `alpha` (per pixel, or null): the spectra are premultiplied by
// it, and the colour is held where it is seen, divided by alpha: the tolerance is alpha_tolerance
// times kColourTolerance (half_bits.h).
void round_spectra_to_half(const float* spectra, size_t spectra_stride, size_t n, size_t bins,
                           const std::vector<float>* rgb_weight, uint16_t* out, size_t plane_stride,
                           const float* alpha = nullptr);

void expand_to_float(const ExpansionMatrix& m, const float* r, const float* g, const float* b,
                     size_t n, float* out, size_t plane_stride);

}  // namespace spectex
