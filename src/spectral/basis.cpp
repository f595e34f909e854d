#include "spectral/basis.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ostream>
#include <string>

#include "base/bounded_read.h"
#include "base/csv_table.h"
#include "base/error.h"
#include "base/fnv1a.h"

namespace spectex {

// FNV-1a over the grid and the three spectra, each double's bytes as stored (little-endian IEEE).
std::string Basis::checksum() const {
    Fnv1a64 h;
    for (const std::vector<double>* v : {&lambda, &r, &g, &b})
        h.add(v->data(), v->size() * sizeof(double));
    return h.text();
}

Basis read_basis_csv(const std::string& path, const std::string& name) {
    CsvTable t = read_csv_table(path, {"wavelength", "r", "g", "b"});
    return Basis{name, t.data[0], t.data[1], t.data[2], t.data[3]};
}

void write_basis_csv(std::ostream& out, const Basis& basis) {
    // The header row first, no '#' lines: Python's csv module, numpy.genfromtxt(names=True) and
    // colour-science's read_sds_from_csv_file read it as it is. Provenance goes to a sidecar
    // (basis_provenance_path); reading still accepts the older files that start with '#' lines.
    CsvTable t;
    t.columns = {"wavelength", "r", "g", "b"};
    t.data = {basis.lambda, basis.r, basis.g, basis.b};
    write_csv_table(out, t);
}

std::string basis_provenance_path(const std::string& csv_path) { return csv_path + ".provenance"; }

std::vector<std::string> shipped_bases() { return {"mallett2019"}; }

Basis load_basis(const std::string& data_dir, const std::string& name_or_file) {
    for (const auto& b : shipped_bases())
        if (b == name_or_file) return read_basis_csv(data_dir + "/spectral/basis_" + b + ".csv", b);
    int err = 0;
    if (path_exists(name_or_file, &err)) return read_basis_csv(name_or_file, name_or_file);
    // A name that looks like a path is a missing file, not an unknown name.
    const bool path_like =
        name_or_file.find('/') != std::string::npos || name_or_file.find('.') != std::string::npos;
    if (path_like)
        throw Error(name_or_file + ": cannot read the basis: " + std::strerror(err) +
                    " (--basis takes fit, mallett2019 or a wavelength,r,g,b CSV file)");
    throw Error("unknown basis '" + name_or_file + "' (known: fit, mallett2019, or a CSV file)");
}

}  // namespace spectex

namespace spectex {

void check_basis_values(const Basis& b) {
    const std::vector<double>* cols[3] = {&b.r, &b.g, &b.b};
    const char* names = "rgb";
    for (int c = 0; c < 3; ++c)
        for (size_t k = 0; k < b.size(); ++k) {
            const double v = (*cols[c])[k];
            if (!std::isfinite(v) || v < -kBasisValueTolerance || v > 1 + kBasisValueTolerance) {
                char buf[160];
                std::snprintf(buf, sizeof buf,
                              ": %c is %.9g at %.9g nm; a reflectance basis holds values in [0, 1]",
                              names[c], v, b.lambda[k]);
                throw Error("basis " + b.name + buf);
            }
        }
}

}  // namespace spectex
