#include "spectral/upsampling_methods.h"

#include <cstdint>
#include <cstdio>
#include <cstring>

#include "base/fnv1a.h"

namespace spectex {

namespace {

std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
}

}  // namespace

LatticeMethod::LatticeMethod(SpectralLattice lattice, std::vector<double> lambda,
                             std::string conditions, double blend)
    : lattice_(std::move(lattice)),
      lambda_(std::move(lambda)),
      conditions_(std::move(conditions)),
      blend_(blend) {}

std::shared_ptr<const SpectralMethod> LatticeMethod::weighted(const Eigen::MatrixXd& W) const {
    std::vector<double> rows(static_cast<size_t>(W.rows()));
    for (size_t i = 0; i < rows.size(); ++i) rows[i] = static_cast<double>(i);
    return std::make_shared<LatticeMethod>(lattice_.projected(W), std::move(rows), "weighted",
                                           blend_);
}

std::vector<std::pair<MethodFact, std::string>> LatticeMethod::provenance() const {
    std::string prior = to_string(lattice_.prior());
    if (lattice_.prior() == VertexPrior::Blend) prior += " (weight " + number(blend_) + ")";
    return {{MethodFact::Method, "lattice"},
            {MethodFact::LatticeSize, std::to_string(lattice_.size())},
            {MethodFact::VertexPrior, prior},
            {MethodFact::MethodSource, "built by spectex: " + conditions_},
            {MethodFact::MethodChecksum, checksum()}};
}

JakobHanikaMethod::JakobHanikaMethod(JakobHanikaTable table, std::vector<double> lambda,
                                     std::string conditions)
    : table_(std::move(table)), lambda_(std::move(lambda)), conditions_(std::move(conditions)) {
    // FNV-1a over the resolution and every node's coefficients (little-endian IEEE doubles).
    Fnv1a64 h;
    auto add = [&h](const void* p, size_t n) { h.add(p, n); };
    const int res = table_.res();
    add(&res, sizeof res);
    for (double l : lambda_) add(&l, sizeof l);
    for (int l = 0; l < 3; ++l)
        for (int z = 0; z < res; ++z)
            for (int y = 0; y < res; ++y)
                for (int x = 0; x < res; ++x) {
                    const JHCoefficients k = table_.node(l, z, y, x);
                    add(&k.c0, sizeof k.c0), add(&k.c1, sizeof k.c1), add(&k.c2, sizeof k.c2);
                }
    checksum_ = h.text();
}

std::vector<std::pair<MethodFact, std::string>> JakobHanikaMethod::provenance() const {
    return {{MethodFact::Method, "jakob-hanika"},
            {MethodFact::JhTableResolution, std::to_string(table_.res())},
            {MethodFact::MethodSource,
             "built by spectex: " + conditions_ +
                 " (not exact: largest linear RGB residual at the table's nodes " +
                 number(table_.max_rgb_residual) + ")"},
            {MethodFact::MethodChecksum, checksum()}};
}

}  // namespace spectex
