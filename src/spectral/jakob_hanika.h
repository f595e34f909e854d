#pragma once
// Jakob & Hanika 2019, "A Low-Dimensional Function Space for Efficient Spectral Upsampling":
// a reflectance s(λ) = S(c0 λ² + c1 λ + c2) with S(x) = 1/2 + x / (2 sqrt(1 + x²)), fitted to an
// RGB colour. Smooth and bounded in (0, 1), but not exact: colours at the edges of the RGB cube
// need coefficients that diverge, and the fit is capped there (see fit_jakob_hanika).
#include <Eigen/Dense>
#include <cstddef>
#include <vector>

#include "spectral/colorimetry.h"
#include "spectral/srgb_axis.h"

namespace spectex {

// Coefficients for λ in nm.
struct JHCoefficients {
    double c0 = 0, c1 = 0, c2 = 0;
};

double jh_sigmoid(double x);
double jh_eval(const JHCoefficients& c, double lambda_nm);

// Fit diagnostics of the last fit_jakob_hanika call that asked for them.
struct JHFitInfo {
    double lab_residual = 0;  // ||Lab(C s) - Lab(rgb)||_2 (CIELAB units, ΔE76)
    double rgb_residual = 0;  // ||C s - rgb||_inf (linear RGB)
    int iterations = 0;
    bool capped = false;  // the coefficients hit the cap (colour outside the sigmoid gamut)
};

// Levenberg-Marquardt on the CIELAB difference (as pbrt-v4's rgb2spec_opt, with analytic
// Jacobian), in a normalised wavelength u = (λ - λ_first) / (λ_last - λ_first) of the colorimetry
// grid. CIELAB rather than linear RGB because it weights dark colours by what is visible (a
// linear residual is dominated by bright colours and leaves near-black fits loose), and this fit
// only has to be perceptually close: the lattice projects it onto the exact colour afterwards.
// The coefficients in u are capped at |c| <= kJHCoefficientCap (scaled down together, which keeps
// the spectrum's shape): at black, white and on the faces of the cube the optimum is at infinity
// and the best bounded answer is returned. start (nm coefficients) warm-starts the iteration.
// Never returns NaN; rgb is clamped to [0, 1] (NaN to 0).
// Residuals reached (CIE 1931 2°, D65, sRGB, 380:780:5; tests/unit/jakob_hanika_test.cpp): ΔE76
// ~1e-12 inside the cube, sRGB primaries and secondaries included (the sigmoid gamut covers sRGB
// here); capped: black ΔE76 2.3e-4 (linear 2.5e-7), white 1e-5 (2.5e-7), and very dark saturated
// colours such as (0, 3.8e-4, 0) ΔE76 0.025 (linear 3.3e-5).
constexpr double kJHCoefficientCap = 1000.0;
JHCoefficients fit_jakob_hanika(const Colorimetry& c, const Eigen::Vector3d& rgb,
                                const JHCoefficients* start = nullptr, JHFitInfo* info = nullptr);

// Fits a list of colours in order, colour i warm-started from the coefficients of colour
// start_from[i] (< i), or cold when start_from[i] < 0; the largest residuals if asked.
std::vector<JHCoefficients> fit_jakob_hanika_path(const Colorimetry& c,
                                                  const std::vector<Eigen::Vector3d>& rgb,
                                                  const std::vector<int>& start_from,
                                                  double* max_rgb_residual = nullptr,
                                                  double* max_lab_residual = nullptr);

// Coefficients in the normalised wavelength u = (λ - λ_first) / (λ_last - λ_first) of c's grid:
// p(u) = a[0] u² + a[1] u + a[2] (the fit's own variables; tables interpolate these).
Eigen::Vector3d jh_unit_coefficients(const WavelengthGrid& g, const JHCoefficients& k);

// Fits at every node of axis³ (layout (ir*n + ig)*n + ib), each warm-started from the fitted
// neighbour one step nearer the centre node; the largest residuals over the nodes if asked.
std::vector<JHCoefficients> fit_jakob_hanika_nodes(const Colorimetry& c,
                                                   const std::vector<double>& axis,
                                                   double* max_rgb_residual = nullptr,
                                                   double* max_lab_residual = nullptr);

// The spectrum of coefficients on the colorimetry's grid.
Eigen::VectorXd jh_spectrum(const Colorimetry& c, const JHCoefficients& k);

// pbrt-v4's RGBToSpectrumTable, on this colorimetry: for each channel l holding the maximum
// component m = rgb[l], a res³ table over (m, x = rgb[l+1]/m, y = rgb[l+2]/m) (channels mod 3) of
// fitted coefficients, m at smoothstep(smoothstep(i/(res-1))) (dense near 0 and 1, where the
// coefficients run to the cap) and x, y uniform; trilinear interpolation of the coefficients.
// Greys (r = g = b) get the exact constant spectrum S(c2) = v. Fitted along paths in m from
// m_{res/5}, each node warm-started from its neighbour. The sigmoid of interpolated coefficients
// is smooth and in (0, 1), but not colour-exact: max_rgb_residual at the nodes, and between
// nodes (2000 random colours, D65, 81 bins) max 0.027 / mean 0.0033 linear at res 17, max 0.0077
// / mean 0.0008 at res 33. Build: 3 res³ fits, ~0.1 s at res 17, ~0.7 s at res 33 (81 bins,
// one core), ~6 s at res 64 (pbrt's size; over the 2 s budget: use res <= 33 here). expand() is
// thread-safe (const, own scratch).
class JakobHanikaTable {
  public:
    static JakobHanikaTable build(const Colorimetry& c, int res);  // res >= 3

    int res() const { return res_; }
    int bins() const { return static_cast<int>(u_.size()); }
    const std::vector<double>& scale() const { return scale_; }  // the res node values of m
    // Node (l, zi, yi, xi): its linear RGB and fitted coefficients (nm).
    Eigen::Vector3d node_rgb(int l, int zi, int yi, int xi) const;
    JHCoefficients node(int l, int zi, int yi, int xi) const;

    void spectrum(const float rgb[3], float* out) const;
    // Bin k of pixel i goes to out[k * plane_stride + i] (the layout of expand_to_float).
    void expand(const float* r, const float* g, const float* b, size_t n, float* out,
                size_t plane_stride) const;

    double max_rgb_residual = 0;  // max over nodes of ||C s(node fit) - node rgb||_inf (linear)
    double max_lab_residual = 0;  // the same in CIELAB ΔE76
    double build_seconds = 0;

  private:
    int res_ = 0;
    std::vector<double> scale_;
    std::vector<float> scale_f_;
    std::vector<float> u_;      // normalised wavelength of each bin
    std::vector<float> coeff_;  // 3 per node, in u units, layout ((l*res + zi)*res + yi)*res + xi
    std::vector<JHCoefficients> nm_;
    float grey_cap_ = 0;
    void coefficients(const float rgb[3], float k[3]) const;
};

}  // namespace spectex
