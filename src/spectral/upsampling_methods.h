#pragma once
// The methods behind SpectralMethod besides the basis: the exact lattice and plain
// Jakob-Hanika sigmoids (not exact; for comparison and for consistency with pbrt-v4 / Mitsuba 3).
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "spectral/jakob_hanika.h"
#include "spectral/lattice.h"
#include "spectral/spectral_method.h"

namespace spectex {

// Tetrahedral interpolation of exact, bounded vertex spectra: exact under the colorimetry it was
// built for, in [0, 1], piecewise linear in RGB (not linear: filtering RGB before expanding keeps
// the colour under that light, not the spectrum). RGB outside [0, 1] is clamped.
class LatticeMethod : public SpectralMethod {
  public:
    LatticeMethod(SpectralLattice lattice, std::vector<double> lambda, std::string conditions,
                  double blend);
    const SpectralLattice& lattice() const { return lattice_; }

    std::string name() const override { return "lattice"; }
    const std::vector<double>& lambda() const override { return lambda_; }
    std::string checksum() const override { return lattice_.checksum(); }
    std::vector<std::pair<MethodFact, std::string>> provenance() const override;
    bool is_linear() const override { return false; }
    RebuildTable rebuild_table() const override {
        return {"lattice", lattice_.axis(), lattice_.table()};
    }
    void expand_float(const float* r, const float* g, const float* b, size_t n, float* out,
                      size_t plane_stride) const override {
        lattice_.expand(r, g, b, n, out, plane_stride);
    }
    std::shared_ptr<const SpectralMethod> weighted(const Eigen::MatrixXd& W) const override;

  private:
    SpectralLattice lattice_;
    std::vector<double> lambda_;
    std::string conditions_;
    double blend_;
};

// Jakob-Hanika 2019 sigmoids from pbrt-v4's coefficient table layout: smooth, in (0, 1), not
// exact (max_rgb_residual says by how much at the table's nodes).
class JakobHanikaMethod : public SpectralMethod {
  public:
    JakobHanikaMethod(JakobHanikaTable table, std::vector<double> lambda, std::string conditions);
    const JakobHanikaTable& table() const { return table_; }

    std::string name() const override { return "jakob-hanika"; }
    const std::vector<double>& lambda() const override { return lambda_; }
    std::string checksum() const override { return checksum_; }
    std::vector<std::pair<MethodFact, std::string>> provenance() const override;
    bool is_linear() const override { return false; }
    void expand_float(const float* r, const float* g, const float* b, size_t n, float* out,
                      size_t plane_stride) const override {
        table_.expand(r, g, b, n, out, plane_stride);
    }

  private:
    JakobHanikaTable table_;
    std::vector<double> lambda_;
    std::string conditions_, checksum_;
};

}  // namespace spectex
