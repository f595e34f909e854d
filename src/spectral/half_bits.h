#pragma once
// Half on coarser grids: bin k keeps bits[k] of half's 10 mantissa bits (the precision budget,
// spectral/precision.h). Kept apart from expand.h, which most of the tree includes.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace spectex {

// The precision budget's coarser grids (round_spectra_to_bits) hold a pixel's colour to 6.1e-5
// (as full half does) or to this share of each channel's own value, whichever is larger: 2^-10, at
// most half the distance from an 8-bit code to the next code's (sRGB 0.45 % of the value at code
// 255, linear 0.2 %, more below), so every 8-bit code of sRGB or of a linear encoding still
// re-encodes, while a grid of a few bits holds most colours with a move or two instead of many
// (each move is entropy the compressor pays for) or none (then the pixel is stored at full
// precision).
constexpr float kCoarseRelativeTolerance = 1.0f / 1024.0f;

// Reduced precision: bin k keeps bits[k] (0..10) of the half's 10 mantissa bits, i.e. its half
// code is a multiple of 2^(10 - bits[k]) (the coarser grid of values; 1.0 and 0 are on every grid,
// so values in [0, 1] stay there). Every bin is rounded to nearest on its grid (ties to the even
// grid point); with rgb_weight, a pixel whose integrated colour then misses by more than 6.1e-5 or
// kCoarseRelativeTolerance of its own value in some channel (the larger) has its fewest bins moved
// to their other neighbour on the same grid (up to 32 moves). A pixel that its grids cannot bring
// within that is rounded at full precision instead, exactly as round_spectra_to_half rounds it
// (within 6.1e-5). All bits 10 is round_spectra_to_half, bit for bit. Returns the
// number of pixels rounded at full precision.
// `alpha` (per pixel, or null): spectra premultiplied by it. Its colour is then held divided by
// alpha, as verify, a renderer and a compositor read it back: the absolute part of the tolerance
// (6.1e-5) is scaled by alpha_tolerance(alpha) (the relative part holds as it is, both sides
// scaling alike). Unscaled, a pixel at alpha 1/255 kept its colour to 6.1e-5 x 255 = 0.016 once
// divided, and 8-bit codes were lost up to alpha 94/255.
size_t round_spectra_to_bits(const float* spectra, size_t spectra_stride, size_t n, size_t bins,
                             const std::vector<float>* rgb_weight, const std::vector<int>& bits,
                             uint16_t* out, size_t plane_stride, const float* alpha = nullptr);
// The share of the colour tolerance a pixel premultiplied by `alpha` keeps: |alpha|, at most 1 (1
// for NaN; 0 for alpha 0, whose spectra are 0 and round exactly).
inline float alpha_tolerance(float alpha) {
    const float a = alpha < 0.0f ? -alpha : alpha;
    return a < 1.0f ? a : 1.0f;
}
// The nearest value to v whose half code is a multiple of 2^(10 - bits) (ties to the even
// multiple); bits 10 is float_to_half.
uint16_t round_half_to_bits(float v, int bits);
// Mantissa bits a half value needs: 10 minus the trailing zero bits of its code's mantissa
// field, counting the exponent's low bits for codes on coarser grids (0 for zero).
int half_mantissa_bits(uint16_t h);

}  // namespace spectex
