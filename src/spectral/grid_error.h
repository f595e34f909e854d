#pragma once
// How far a baked wavelength grid is from what a renderer sees. A renderer samples
// wavelengths continuously and reconstructs the reflectance between the file's bins; outside the
// grid it holds the end values. The error of a grid G for a colour c under a light L is ΔE00
// between
//   - the reference: the method's spectrum for c built on a 1 nm grid over the renderer's range,
//   - the candidate: the spectrum baked on G (half-rounded when the output is half), reconstructed
//     at 1 nm over the same range by the renderer's rule,
// both integrated under L with the observer at 1 nm, L*a*b* relative to L's own white.
// Colour under a light is linear in the spectrum, so everything here is a matrix: the 1 nm
// reconstruction R_G (fine × bins), the light's XYZ weights W_L (3 × fine), and for a linear
// method its basis B_G (bins × 3): candidate XYZ = W_L·R_G·B_G·rgb, reference XYZ = W_L·B_1nm·rgb.
#include <Eigen/Dense>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "base/enum_names.h"
#include "spectral/spectral_method.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

// linear: interpolation between bin centres (pbrt-v4's PiecewiseLinearSpectrum, Mitsuba 3's
// regular/irregular spectra); nearest: the value of the nearest bin centre at the wavelength (a tie
// goes to the shorter bin); box: bins are boxes with edges halfway between centres, and each 1 nm
// sample is the box function's mean over [λ - 0.5, λ + 0.5] (differs from nearest only in the 1 nm
// cells that straddle an edge). All hold the end values beyond the first and last bin.
enum class Reconstruction { Linear, Nearest, Box };
inline constexpr EnumNames<Reconstruction, 3> kReconstructionNames{
    {{{Reconstruction::Linear, "linear"},
      {Reconstruction::Nearest, "nearest"},
      {Reconstruction::Box, "box"}}}};
Reconstruction parse_reconstruction(const std::string& name);  // throws Error naming the choices
std::string to_string(Reconstruction r);

// fine.size() × bins.size(): the reconstructed value at fine[f] is Σ_k R(f, k)·s_k. Every row sums
// to 1 (a constant spectrum stays constant).
Eigen::MatrixXd reconstruction_matrix(const std::vector<double>& bins,
                                      const std::vector<double>& fine, Reconstruction r);

// The wavelengths a renderer samples by default (nm): the CIE observers' tables' range.
constexpr double kRendererStart = 360, kRendererEnd = 830;

// The renderer's grid: every integer wavelength from start to end (both included; integers).
// Throws Error when start/end are not integers or end <= start.
WavelengthGrid renderer_grid(double start, double end);

// The renderer's grid kRendererStart..kRendererEnd clipped to the observer's tables (whole nm):
// where the file's colour under a light is judged, and the reference method's grid.
WavelengthGrid observed_renderer_grid(const Observer& observer);

// XYZ weights of a reflectance at 1 nm under a light: XYZ = W·s for s on the fine grid, scaled
// so that the perfect reflector has Y = 1; white = W·1. Each fine sample weighs 1 nm. The light is
// zero where its table has no values (FL11's table stops at 780 nm); the observer must cover the
// grid (throws Error otherwise).
struct LightWeights {
    std::string name;
    Eigen::Matrix3Xd W;
    Eigen::Vector3d white;
    double dark_nm = 0;  // nm of the fine grid outside the light's table (taken as 0)
};
LightWeights light_weights(const Observer& observer, const Spectrum& light,
                           const WavelengthGrid& fine);

// The distribution of ΔE00 over a set of colours: worst (with its index), mean, and percentiles
// from a histogram with 1000 bins per decade from 1e-9 to 1e3 (a percentile is reported as the
// upper edge of its bin: at most 0.23 % above the exact value; values below 1e-9 count as 1e-9).
class DeltaEHistogram {
  public:
    DeltaEHistogram();
    void add(double de, uint64_t index);
    void merge(const DeltaEHistogram& o);
    double percentile(
        double q) const;  // q in (0, 1]: the smallest v with at least q of the colours <= v
    double worst() const { return worst_; }
    uint64_t worst_index() const { return worst_index_; }
    uint64_t count() const { return count_; }
    double mean() const { return count_ ? sum_ / static_cast<double>(count_) : 0; }

  private:
    std::vector<uint64_t> bins_;
    double worst_ = 0, sum_ = 0;
    uint64_t worst_index_ = 0, count_ = 0;
};

struct ErrorStats {
    double worst = 0, p99 = 0, mean = 0;
    uint64_t colours = 0;
    std::array<int, 3> worst_code{{0, 0, 0}};  // 8-bit sRGB code of the worst colour
};
ErrorStats stats_of(const DeltaEHistogram& h,
                    const std::vector<std::array<uint8_t, 3>>* codes = nullptr);

// The linear RGB of 8-bit sRGB code i (IEC 61966-2-1 decode), in double.
const std::array<double, 256>& srgb_code_table();

// For a linear method, over all 16,777,216 8-bit sRGB codes: ΔE00 between ref·rgb and cand[i]·rgb
// (XYZ), relative to white, for every candidate at once (the reference's L*a*b* is computed once
// per colour). Code (r, g, b) has index (r << 16) | (g << 8) | b. threads >= 1.
std::vector<ErrorStats> cube_error_linear(const std::vector<Eigen::Matrix3d>& cand,
                                          const Eigen::Matrix3d& ref, const Eigen::Vector3d& white,
                                          int threads);

// The dense sample of the cube: codes 0, stride, 2·stride, … and 255 on each axis (stride 4: 65
// values, 274,625 colours, every face of the cube included).
std::vector<std::array<uint8_t, 3>> code_sample(int stride);

// XYZ (3 × n) under each light of n linear RGB colours: spectra from m on its own grid (rounded to
// half as a bake does when half is set, with rgb_weight as the colour-aware rounding's weights, or
// nearest when it is null), times light_recon[j] = W_L·R_G (3 × bins). Works in chunks.
std::vector<Eigen::Matrix3Xd> method_xyz(const SpectralMethod& m,
                                         const std::vector<Eigen::Matrix3Xd>& light_recon,
                                         const std::vector<float>& r, const std::vector<float>& g,
                                         const std::vector<float>& b, bool half,
                                         const std::vector<float>* rgb_weight);

// ΔE00 between two XYZ lists (3 × n each) relative to white; also a per-colour copy when `each`.
DeltaEHistogram xyz_error(const Eigen::Matrix3Xd& cand, const Eigen::Matrix3Xd& ref,
                          const Eigen::Vector3d& white, std::vector<double>* each = nullptr);

}  // namespace spectex
