#pragma once
// "Linear RGB in, spectrum on the grid out": the one interface that every spectral upsampling
// method implements (the three-spectrum basis of Mallett & Yuksel, the lattice, Jakob-Hanika).
// The pipeline expands strips through it, the half rounding works on what it gives, and the
// header and the settings hash record it.
#include <Eigen/Dense>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "spectral/basis.h"
#include "spectral/expand.h"

namespace spectex {

// What a method records of itself in a baked file's header (provenance()). The maths says what it
// is; the name of the attribute each fact is written under belongs to the file's side
// (io/provenance_keys.h, method_fact_key), so that spectral/ knows nothing of file formats.
enum class MethodFact {
    Method,             // "basis", "lattice", "jakob-hanika"
    Basis,              // the basis' name
    BasisSource,        // where the basis came from
    BasisChecksum,      // of the basis' tables
    LatticeSize,        // vertices per axis
    VertexPrior,        // the lattice's vertex prior
    JhTableResolution,  // nodes per axis of the Jakob-Hanika table
    MethodSource,       // how the lattice or table was built
    MethodChecksum,     // of the lattice or table
};

// What a renderer needs to rebuild a method's spectra from the linear RGB they reproduce under the
// illuminant the method is exact for (docs/file-format.md, "Rebuilding spectra from RGB"): the
// rule, its breakpoints and its table, as the method itself evaluates them. An empty rule: the
// method cannot be rebuilt from RGB (Jakob-Hanika is not exact, so a file's colour does not give
// back the RGB its spectra were made from).
struct RebuildTable {
    // "basis": spectrum = r·S_r + g·S_g + b·S_b, RGB taken as it is; table S_r, S_g, S_b (3 x
    // bins). "lattice": RGB clamped to [0, 1] (NaN to 0), Kuhn-tetrahedral interpolation between
    // the breakpoints `axis` on each axis; table ((ir·n + ig)·n + ib)·bins + k.
    std::string rule;
    std::vector<double> axis;
    std::vector<float> table;
};

class SpectralMethod {
  public:
    virtual ~SpectralMethod() = default;

    virtual std::string name() const = 0;  // "basis", "lattice", "jakob-hanika"
    virtual const std::vector<double>& lambda() const = 0;
    int bins() const { return static_cast<int>(lambda().size()); }
    // Of everything that decides the spectra (tables, sizes): "fnv1a64:<hex>".
    virtual std::string checksum() const = 0;
    // The facts that describe the method, in a fixed order (the header's attributes keep it).
    virtual std::vector<std::pair<MethodFact, std::string>> provenance() const = 0;
    // spectrum(a·x + b·y) = a·spectrum(x) + b·spectrum(y): filtering linear RGB before expanding is
    // then the same as filtering spectra (MIP levels).
    virtual bool is_linear() const = 0;
    // The rule and table a renderer rebuilds the method's spectra with (empty rule: none).
    virtual RebuildTable rebuild_table() const { return {}; }

    // Bin k of pixel i goes to out[k * plane_stride + i]; r, g, b are planes of n linear values.
    virtual void expand_float(const float* r, const float* g, const float* b, size_t n, float* out,
                              size_t plane_stride) const = 0;
    // A shortcut to the colours of the method's spectra under linear weights W (rows x bins): a
    // method whose expansion on W.rows() "bins" is W times this method's spectrum for every colour
    // (to float rounding), far cheaper than expanding every bin when W has few rows; null when
    // the method has none (the caller expands). The basis and the lattice have one: their spectra
    // are linear in a table.
    virtual std::shared_ptr<const SpectralMethod> weighted(const Eigen::MatrixXd& W) const {
        (void)W;
        return nullptr;
    }
    // Half. With rgb_weight (bins x 3, the linear RGB of a unit spectrum at each bin, under the
    // observer and illuminant the method is exact for), the colour-aware rounding: every bin is
    // rounded to nearest, and where the integrated colour then misses by more than 6.1e-5 the
    // fewest bins move to their other neighbouring half. The default rounds what expand_float
    // gives; a method may do the same faster.
    virtual void expand_half(const float* r, const float* g, const float* b, size_t n,
                             uint16_t* out, size_t plane_stride,
                             const std::vector<float>* rgb_weight) const;
};

// The three-spectrum basis: spectrum = r·S_r + g·S_g + b·S_b.
class BasisMethod : public SpectralMethod {
  public:
    // source: how the basis was obtained, for the header ("fitted by spectex: ...", "file").
    BasisMethod(Basis basis, std::string source);
    const Basis& basis() const { return basis_; }

    std::string name() const override { return "basis"; }
    const std::vector<double>& lambda() const override { return basis_.lambda; }
    std::string checksum() const override { return basis_.checksum(); }
    std::vector<std::pair<MethodFact, std::string>> provenance() const override;
    bool is_linear() const override { return true; }
    RebuildTable rebuild_table() const override;
    void expand_float(const float* r, const float* g, const float* b, size_t n, float* out,
                      size_t plane_stride) const override;
    void expand_half(const float* r, const float* g, const float* b, size_t n, uint16_t* out,
                     size_t plane_stride, const std::vector<float>* rgb_weight) const override;
    std::shared_ptr<const SpectralMethod> weighted(const Eigen::MatrixXd& W) const override;

  private:
    Basis basis_;
    std::string source_;
    ExpansionMatrix m_;
};

}  // namespace spectex
