#pragma once
// A spectral basis: three reflectance spectra S_r, S_g, S_b on a wavelength grid.
#include <iosfwd>
#include <string>
#include <vector>

namespace spectex {

struct Basis {
    std::string name;            // "mallett2019", a file path, or a fitted basis' description
    std::vector<double> lambda;  // nm
    std::vector<double> r, g, b;

    size_t size() const { return lambda.size(); }
    // "fnv1a64:<16 hex digits>" over the little-endian IEEE bytes of lambda, r, g, b in that order.
    std::string checksum() const;
};

// CSV with header "wavelength,r,g,b". Written with the header row first
// and nothing else, so that generic CSV readers load it; read with or without leading '#' lines
// (files written before carry their provenance there).
Basis read_basis_csv(const std::string& path, const std::string& name);
void write_basis_csv(std::ostream& out, const Basis& basis);
// Where `spectex basis -o FILE` writes the provenance of FILE (command, fit, checksum,
// certificate), one "key: value" line each: FILE + ".provenance".
std::string basis_provenance_path(const std::string& csv_path);

// "mallett2019" (the published table shipped in <data_dir>/spectral/), or a CSV file path.
Basis load_basis(const std::string& data_dir, const std::string& name_or_file);
std::vector<std::string> shipped_bases();

// A reflectance basis holds finite values in [0, 1]; the tolerance admits the published table's
// rounding (its spectra sum to one within 1e-5 and stay inside [0, 1]). Throws Error naming the
// first value outside.
constexpr double kBasisValueTolerance = 1e-6;
void check_basis_values(const Basis& basis);

}  // namespace spectex
