#pragma once
// The spectral lattice: a spectrum at every vertex of an
// n³ lattice over linear RGB [0, 1]³, each reproducing its vertex colour exactly under the
// colorimetry's light and lying in [0, 1]; tetrahedral (Kuhn) interpolation between them. The
// barycentric weights reproduce the RGB, so every colour is exact and every spectrum is a convex
// combination of bounded ones. The vertex spectra (the prior) decide the colour under other light.
#include <Eigen/Dense>
#include <cstddef>
#include <string>
#include <vector>

#include "base/enum_names.h"
#include "spectral/colorimetry.h"
#include "spectral/measured_prior.h"
#include "spectral/srgb_axis.h"

namespace spectex {

// JakobHanika: the Jakob-Hanika sigmoid spectrum of the vertex colour, projected (least squares)
//   onto the exact bounded set {C s = v, 0 <= s <= 1}.
// Smooth: the smoothest exact bounded spectrum, min sum_k ((s[k+1] - s[k]) · 10 nm / Δλ_k)²
//   (plus 1e-6 times that scale × ||s - 1/2||² as a tie-break that keeps the solves well posed).
// Blend: min ||s - s_JH||² + blend · sum_k ((s[k+1] - s[k]) · 10 nm / Δλ_k)²; blend is
//   dimensionless: differences are measured per 10 nm, so the balance does not depend on the
//   grid step (blend = 1: a 10 nm step of size x costs as much as a deviation x from the
//   sigmoid at one bin).
// Lhtss: the smoothest spectrum in log-hyperbolic-tangent space (spectral/lhtss.h, Burns 2020),
//   bounded in (0, 1) by construction, then projected like the sigmoid (a no-op to rounding when
//   its Newton solve converged, and the guarantee of exactness when it did not).
// Measured: the most probable spectrum with the vertex colour under a Gaussian model of measured
//   reflectances in LHTSS's tanh space (spectral/measured_prior.h: a learned mean and covariance;
//   the vertices on the RGB cube's faces take the table's face mean when it has one), bounded in
//   (0, 1) by construction, then projected like LHTSS.
enum class VertexPrior { JakobHanika, Smooth, Blend, Lhtss, Measured };
// Canonical words first; "jh" and "jakob_hanika" are read too.
inline constexpr EnumNames<VertexPrior, 7> kVertexPriorNames{
    {{{VertexPrior::JakobHanika, "jakob-hanika"},
      {VertexPrior::Smooth, "smooth"},
      {VertexPrior::Blend, "blend"},
      {VertexPrior::Lhtss, "lhtss"},
      {VertexPrior::Measured, "measured"},
      {VertexPrior::JakobHanika, "jh"},
      {VertexPrior::JakobHanika, "jakob_hanika"}}}};
std::string to_string(VertexPrior p);  // "jakob-hanika" | "smooth" | "blend" | "lhtss" | "measured"
VertexPrior parse_vertex_prior(const std::string&);  // the same names (and "jh"); throws Error

class SpectralLattice {
  public:
    // n >= 2 breakpoints per axis: v_i = sRGB_decode(i / (n - 1)). Throws Error naming the vertex
    // and the grid when a vertex colour has no spectrum in [0, 1] (never returns a wrong table).
    // The measured prior needs its table (`measured`); the others ignore it.
    static SpectralLattice build(const Colorimetry& c, int n, VertexPrior prior, double blend = 0.5,
                                 const MeasuredPrior* measured = nullptr);

    // The lattice of a table built before (a cache entry of build()'s table_double()): the same
    // lattice, checksum and spectra as that build. Throws Error unless the table is one build()
    // could have made for this colorimetry: n^3 x bins finite values in [0, 1], black and white
    // exact, and every vertex colour reproduced within kStoredVertexTolerance. The certificate's
    // solver figures (iterations, fallbacks) are not known and stay 0.
    static SpectralLattice from_table(const Colorimetry& c, int n, VertexPrior prior,
                                      std::vector<double> table);
    // The lattice whose vertex values are W times the vertex spectra (W: rows x bins): its
    // expansion is W times this lattice's spectrum for every colour (the barycentric weights are
    // the same), a colour under W.rows() / 3 lights for the price of W.rows() bins. Not a table of
    // spectra: no certificate, never stored.
    SpectralLattice projected(const Eigen::MatrixXd& W) const;
    // build() demands 1e-13 of every vertex; a stored table is held to 1e-12 (the unit tests'
    // figure), so a table from this build is always taken and one that is not exact never is.
    static constexpr double kStoredVertexTolerance = 1e-12;

    int size() const { return n_; }
    int bins() const { return bins_; }
    const std::vector<double>& axis() const { return locator_.axis(); }
    VertexPrior prior() const { return prior_; }
    // Vertex spectra, layout ((ir*n + ig)*n + ib)*bins + k (ir: red index).
    const std::vector<float>& table() const { return table_; }
    const std::vector<double>& table_double() const { return table_d_; }
    // "fnv1a64:<16 hex>" over n and the float table's bytes.
    std::string checksum() const;

    // Certificate, measured on the double vertex spectra before float storage.
    double max_colour_residual = 0;  // max over vertices of ||C s_v - v||_inf
    double min_value = 0, max_value = 0;
    double build_seconds = 0;
    int fallback_vertices = 0;   // vertices the fast solver left to solve_qp
    int prior_unconverged = 0;   // lhtss: vertices whose Newton solve stopped short (projected)
    long solver_iterations = 0;  // Newton / active-set iterations over all vertices

    // Reference evaluation in double (inputs clamped to [0, 1], NaN to 0); out has bins() values.
    void spectrum(const double rgb[3], double* out) const;
    // Batch kernel on the float table: bin k of pixel i goes to out[k * plane_stride + i]. Same
    // clamping; colour exact to float rounding (~1e-7). Const and thread-safe (own scratch).
    void expand(const float* r, const float* g, const float* b, size_t n, float* out,
                size_t plane_stride) const;

  private:
    void make_float_tables();

    int n_ = 0, bins_ = 0;
    VertexPrior prior_ = VertexPrior::Smooth;
    AxisLocator locator_;
    std::vector<double> table_d_;
    std::vector<float> table_;
    // The kernel's copy: rows padded with zeros to a multiple of 8 floats, so every row is read in
    // whole 8-float vectors.
    std::vector<float> padded_;
    size_t padded_ld_ = 0;
};

}  // namespace spectex
