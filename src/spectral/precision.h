#pragma once
// The precision budget: how many of half's 10 mantissa bits each bin keeps, chosen so that the
// worst ΔE00 between the file's spectra and the method's own spectrum at 1 nm (the request's
// reference; without one, the unrounded spectra on the file's grid), under every light of the
// scene (and D65), stays within a budget on every 8-bit sRGB code, the bins seen as a renderer
// sees them (linear at 1 nm over 360-830 nm; docs/precision.md).
// Fewer bits in the bins a light barely sees make the file's ZIP smaller; the colour-aware
// correction on the coarser grids (round_spectra_to_bits) keeps every 8-bit colour's code under
// the rounding's colorimetry (D65) exact whatever the bits.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "spectral/spectral_method.h"
#include "spectral/spectrum.h"

namespace spectex {

// The sample bake and plan --precision auto search on before the whole cube checks their answer:
// codes 0, 8, … 248 and 255 per axis (33^3 = 35,937 colours).
constexpr int kPrecisionSampleStride = 8;

// The fewest mantissa bits the chooser gives a bin. Rounding with b bits moves a value by less
// than one step of its grid, 2^-b of it (or 2^-14 · 2^-b below half's normal range, 2^-14), and
// the colour-aware correction only ever moves a bin to the grid neighbour on the other side of
// its unrounded value: with 4 bits every stored value is within 1/16 of the unrounded one. Fewer
// bits saved bytes in bins the lights barely see but stored only powers of two there (0 bits:
// 0.5 inside a plateau of 1.0), which a plot, another observer or a camera's sensitivities show;
// coarser, fewer bins are the way to save those bytes.
constexpr int kMinMantissaBits = 4;

struct PrecisionRequest {
    const SpectralMethod* method = nullptr;
    Observer observer;
    std::vector<Spectrum> lights;  // the scene's lights (the caller includes D65)
    // The colour-aware rounding's weights (bins x 3, the bake's observer and illuminant): the
    // rounding is judged exactly as the bake will round. Null: nearest rounding.
    const std::vector<float>* rgb_weight = nullptr;
    // The same method built on the renderer's 1 nm grid (spectral/grid_error.h): when set, the
    // budget covers what a renderer sees of the file against the method's own spectrum, the grid's
    // error and the rounding together. Null: the rounded spectra against the unrounded ones on the
    // file's grid (the rounding alone), for a method that cannot be built at 1 nm (a given table).
    const SpectralMethod* reference = nullptr;
    // The linear value of each 8-bit code as a bake decodes it, channel by channel (codes[3 * i +
    // c] for code i in channel c; 768 values): what OpenColorIO makes of an 8-bit sRGB texture's
    // pixels through the config (srgb_code_values, io/linearizer.h). The rounding is not smooth:
    // the same code decoded by IEC 61966-2-1's formula (OpenColorIO's curve is continuous at its
    // knee: 12.9232 where the standard says 12.92, 2.5e-4 of the value for codes 1-10) is another
    // colour, rounded another way, and a code the chooser measured at 0.3932 under FL2 baked at
    // 0.3953. Empty: the formula's values (srgb_code_table).
    std::vector<float> codes;
    double max_de = 0.5;  // the budget: worst ΔE00 under each light
    int stride = 8;  // codes 0, stride, 2·stride, … and 255 on each axis (8: 35,937 colours)
    int threads = 1;
};

struct PrecisionChoice {
    std::vector<int> bits;           // per bin, kMinMantissaBits..10
    std::vector<std::string> light;  // the lights measured, in the request's order
    std::vector<double> worst_de;    // per light, of the chosen bits (choose: over every code)
    // choose: per light, the 8-bit sRGB code (0xRRGGBB) whose ΔE00 worst_de is (the lowest of
    // equal ones), so that anyone can bake that one colour and check the figure; else empty.
    std::vector<uint32_t> worst_code;
    size_t colours = 0;      // colours measured (choose: 16,777,216)
    size_t evaluations = 0;  // bit vectors measured to choose
};

// Half with bin k keeping bits[k] mantissa bits: expand_float, then round_spectra_to_bits (nearest
// on the coarser grid, then the colour-aware correction on that grid). Empty bits, or all 10, is
// method.expand_half, bit for bit. Returns the pixels that needed more bits to hold their colour.
size_t expand_half_bits(const SpectralMethod& method, const float* r, const float* g,
                        const float* b, size_t n, uint16_t* out, size_t plane_stride,
                        const std::vector<float>* rgb_weight, const std::vector<int>& bits);

// Premultiplied spectra of a method that is not linear: pixel i's spectrum of its straight colour
// (r, g, b) times alpha[i], in float, then rounded as expand_half_bits rounds (empty bits: as
// expand_half rounds). method(a * rgb) is not a * method(rgb) for such a method (a lattice can
// then exceed 1 once divided by alpha); a linear method may expand the premultiplied colour
// instead, with the same result. The colour-aware rounding holds each colour divided by its alpha
// (round_spectra_to_bits), so alpha should be the value the file stores. Returns what
// expand_half_bits returns.
size_t expand_half_premultiplied(const SpectralMethod& method, const float* r, const float* g,
                                 const float* b, const float* alpha, size_t n, uint16_t* out,
                                 size_t plane_stride, const std::vector<float>* rgb_weight,
                                 const std::vector<int>& bits);
void expand_float_premultiplied(const SpectralMethod& method, const float* r, const float* g,
                                const float* b, const float* alpha, size_t n, float* out,
                                size_t plane_stride);

// Per bin: the largest weight of the bin in X, Y or Z under any of the lights, relative to the
// largest of all bins (1 at the most visible bin). The chooser starts from 10 + log2 of it.
std::vector<double> bin_visibility(const Observer& observer, const std::vector<Spectrum>& lights,
                                   const std::vector<double>& lambda);

// Deterministic (the same bits for the same request, whatever the threads). Searches on a sample
// with half the codes per axis against 90 % of the budget: starts from the rule
// bits = ceil(10 + log2(visibility) + offset) (never below kMinMantissaBits), with the lowest
// whole offset <= 0 within it, then lowers bins one bit at a time, least visible first, down to
// kMinMantissaBits, keeping each step that stays within it.
// A bit vector counts as within only when at most 0.5 % of the sample's colours are left to full
// precision (round_spectra_to_bits). The result is measured on the request's sample, and the
// search's steps undone, last first, while it is over the budget there (all 10 when nothing
// fewer holds). Then on every 8-bit code: while a colour is over the budget, the colours above
// 70 % of it join the sample and the undoing runs again. worst_de is the cube's worst per light
// (raised by 1e-4 of itself for the float sums), colours 2^24. Throws Error on a budget that is
// not positive.
PrecisionChoice choose_precision(const PrecisionRequest& req);

// Worst ΔE00 per light of rounding to `bits` over the request's sample (for reports and tests).
PrecisionChoice measure_precision(const PrecisionRequest& req, const std::vector<int>& bits);

// "10 10 9 8 …": the bits as recorded in a header; parse_precision_bits reads it back (throws
// Error on anything else, naming what is wrong).
std::string format_precision_bits(const std::vector<int>& bits);
std::vector<int> parse_precision_bits(const std::string& text, size_t bins);

// What the recorded worst covers (spectex:precisionSample): with a reference, the file against
// the method's own spectrum at 1 nm; without, the rounding alone.
constexpr const char* kPrecisionCovers =
    "every 8-bit sRGB code (16777216 colours), opaque, reconstructed linearly at 1 nm over "
    "360-830 nm, against the method's own spectrum at 1 nm (the grid and the rounding together)";
constexpr const char* kPrecisionCoversRounding =
    "every 8-bit sRGB code (16777216 colours), opaque, reconstructed linearly at 1 nm over "
    "360-830 nm, rounded against unrounded on the file's grid";

// A ΔE00 figure rounded up to 3 significant digits ("0.49", "0.134"): a recorded worst stays an
// upper bound of the figure it rounds.
std::string format_de_up(double de);

// Sum of the bits over the bins, against 10 per bin: a rough measure of what the file keeps.
double kept_fraction(const std::vector<int>& bits);

}  // namespace spectex
