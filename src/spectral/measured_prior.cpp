#include "spectral/measured_prior.h"

#include <algorithm>
#include <cmath>

#include "base/csv_table.h"
#include "base/error.h"
#include "base/fnv1a.h"

namespace spectex {

namespace {

double interpolate(const std::vector<double>& x, const std::vector<double>& y, double at) {
    if (at <= x.front()) return y.front();
    if (at >= x.back()) return y.back();
    const size_t i = static_cast<size_t>(std::upper_bound(x.begin(), x.end(), at) - x.begin());
    const double t = (at - x[i - 1]) / (x[i] - x[i - 1]);
    return y[i - 1] + t * (y[i] - y[i - 1]);
}

}  // namespace

std::string measured_prior_path(const std::string& data_dir) {
    return data_dir + "/spectral/vertex_prior_measured.csv";
}

MeasuredPrior read_measured_prior_csv(const std::string& path) {
    const CsvTable t = read_csv_table(path);
    const std::string what = path + ": measured vertex prior";
    if (t.columns.size() < 2 || t.columns[0] != "wavelength" || t.columns[1] != "mean")
        throw Error(what + ": the header must be wavelength,mean[,face_mean],f1,...,fm");
    const size_t first = t.columns.size() > 2 && t.columns[2] == "face_mean" ? 3 : 2;
    for (size_t j = first; j < t.columns.size(); ++j)
        if (t.columns[j] != "f" + std::to_string(j - first + 1))
            throw Error(what + ": column " + std::to_string(j + 1) + " is '" + t.columns[j] +
                        "', expected f" + std::to_string(j - first + 1));
    if (t.rows() < 2) throw Error(what + ": needs at least 2 wavelengths");
    // Each direction costs the vertex solve an m × m system per Newton step; the shipped table
    // has a handful.
    if (t.columns.size() - first > 64) throw Error(what + ": more than 64 directions");
    MeasuredPrior p;
    p.lambda = t.data[0];
    p.mean = t.data[1];
    if (first == 3) p.face_mean = t.data[2];
    p.factors.assign(t.data.begin() + static_cast<std::ptrdiff_t>(first), t.data.end());
    // Largest |value| per column: the wavelengths any (the table checked them); a mean past
    // |z| = 20 is a reflectance within 1e-17 of 0 or 1, no measured one; a direction past 1e3
    // would make the covariance of z dwarf the roughness's ~1 by 1e6: no data-driven model, and
    // a Newton system that loses its digits.
    auto limit = [first](size_t column) {
        return column == 0 ? HUGE_VAL : column < first ? 20.0 : 1e3;
    };
    Fnv1a64 h;
    for (size_t j = 0; j < t.data.size(); ++j)
        for (size_t k = 0; k < t.data[j].size(); ++k) {
            const double v = t.data[j][k];
            const bool bad = !std::isfinite(v) || std::fabs(v) > limit(j);
            if (bad)
                throw Error(what + ": value " + std::to_string(v) + " at " +
                            std::to_string(t.data[0][k]) + " nm is not a usable number");
            h.add(&v, sizeof v);
        }
    p.checksum = h.text();
    return p;
}

TanhPrior measured_prior_on_grid(const MeasuredPrior& p, const WavelengthGrid& grid, bool face) {
    const std::vector<double>& mean = face && !p.face_mean.empty() ? p.face_mean : p.mean;
    const Eigen::Index N = static_cast<Eigen::Index>(grid.size());
    const Eigen::Index m = static_cast<Eigen::Index>(p.factors.size());
    TanhPrior out{Eigen::VectorXd(N), Eigen::MatrixXd(N, m)};
    for (Eigen::Index k = 0; k < N; ++k) {
        const double l = grid.lambda[static_cast<size_t>(k)];
        out.mean[k] = interpolate(p.lambda, mean, l);
        for (Eigen::Index j = 0; j < m; ++j)
            out.factors(k, j) = interpolate(p.lambda, p.factors[static_cast<size_t>(j)], l);
    }
    return out;
}

}  // namespace spectex
