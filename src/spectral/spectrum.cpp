#include "spectral/spectrum.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "base/bounded_read.h"
#include "base/csv_table.h"
#include "base/error.h"
#include "spectral/colour_temperature.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

// A power or a colour-matching value is finite, not negative and at most 1e12, as
// Colorimetry::make checks it on a grid: checked on the table when it is loaded, so that a bad
// value is reported as such (not as a singular observer or a dark light) before any work.
void check_table_values(const std::vector<double>& lambda, const std::vector<double>& v,
                        const std::string& what) {
    for (size_t k = 0; k < v.size(); ++k)
        if (!std::isfinite(v[k]) || v[k] < 0 || v[k] > 1e12) {
            char buf[160];
            std::snprintf(buf, sizeof buf,
                          " has the value %.9g at %s nm: values must be finite, not negative and "
                          "below 1e12",
                          v[k], format_wavelength(lambda[k]).c_str());
            throw Error(what + buf);
        }
}

std::string upper(std::string s) {
    for (char& c : s)
        if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
    return s;
}

}  // namespace

std::vector<double> Spectrum::sample(const WavelengthGrid& grid) const {
    std::vector<double> out(grid.size());
    const double tol = 1e-6;
    if (lambda.empty()) throw Error(name + ": empty table");
    for (size_t k = 0; k < grid.size(); ++k) {
        double l = grid.lambda[k];
        if (l < lambda.front() - tol || l > lambda.back() + tol)
            throw Error("wavelength " + format_wavelength(l) + " nm lies outside the " + name +
                        " table (" + format_wavelength(lambda.front()) + "-" +
                        format_wavelength(lambda.back()) + " nm)");
        // Snap to a node only when the grid point is that node up to rounding: a grid point 1e-6 nm
        // away (a near-duplicate wavelength) must be interpolated like any other.
        const double node_tol = 1e-9;
        auto it = std::lower_bound(lambda.begin(), lambda.end(), l - node_tol);
        size_t i = static_cast<size_t>(it - lambda.begin());
        if (i < lambda.size() && std::abs(lambda[i] - l) <= node_tol) {
            out[k] = value[i];  // on a table node: exact, no interpolation rounding
            continue;
        }
        if (i == 0) i = 1;
        if (i >= lambda.size()) i = lambda.size() - 1;
        double t = (l - lambda[i - 1]) / (lambda[i] - lambda[i - 1]);
        out[k] = value[i - 1] + t * (value[i] - value[i - 1]);
    }
    return out;
}

double Spectrum::at_or_dark(double l) const {
    if (lambda.empty() || l < lambda.front() || l > lambda.back()) return 0;
    const size_t k =
        static_cast<size_t>(std::upper_bound(lambda.begin(), lambda.end(), l) - lambda.begin());
    if (k >= lambda.size()) return value.back();
    if (k == 0) return value.front();
    const double t = (l - lambda[k - 1]) / (lambda[k] - lambda[k - 1]);
    return (1 - t) * value[k - 1] + t * value[k];
}

Spectrum load_illuminant_csv(const std::string& path, const std::string& name) {
    CsvTable t = read_csv_table(path, {"wavelength", "value"}, CsvHeader::WavelengthFirst);
    // A user's file is named once ("ill.csv: illuminant has ..."), a shipped one by its path and
    // its name.
    const std::string illuminant = path + ": illuminant" + (name == path ? "" : " " + name);
    check_table_values(t.data[0], t.data[1], illuminant);
    // No light at all: every colour under it would be black and its white undefined.
    if (std::none_of(t.data[1].begin(), t.data[1].end(), [](double v) { return v != 0; }))
        throw Error(illuminant + " has zero power at every wavelength");
    return Spectrum{name, t.data[0], t.data[1]};
}

Observer load_observer_csv(const std::string& path, const std::string& name) {
    CsvTable t = read_csv_table(path, {"wavelength", "x", "y", "z"}, CsvHeader::WavelengthFirst);
    const std::string observer =
        path + ": observer" + (name == path ? "" : " " + name);  // as above
    for (int i = 1; i <= 3; ++i)
        check_table_values(t.data[0], t.data[static_cast<size_t>(i)],
                           observer + " (" + "xyz"[i - 1] + ")");
    Observer o{name, Spectrum{name + " x", t.data[0], t.data[1]},
               Spectrum{name + " y", t.data[0], t.data[2]},
               Spectrum{name + " z", t.data[0], t.data[3]}};
    check_observer_independent(o.x.value, o.y.value, o.z.value, observer, "its table");
    return o;
}

void check_observer_independent(const std::vector<double>& x, const std::vector<double>& y,
                                const std::vector<double>& z, const std::string& what,
                                const std::string& where) {
    // Fewer than three wavelengths cannot hold three independent functions: say so plainly.
    if (x.size() < 3)
        throw Error(what + " on " + where + ": colours need at least 3 wavelengths to be told " +
                    "apart (got " + std::to_string(x.size()) + ")");
    // x, y and z must span three dimensions, or XYZ -> RGB has no inverse and every colour maps
    // to a line or plane. The Gram matrix's eigenvalues relative to its largest say how close
    // to dependent they are; 1e-12 is far below any real observer's (the CIE's are above 1e-3).
    Eigen::Matrix3d g = Eigen::Matrix3d::Zero();
    const std::vector<double>* v[3] = {&x, &y, &z};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (size_t k = 0; k < x.size(); ++k) g(i, j) += (*v[i])[k] * (*v[j])[k];
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(g).eigenvalues();
    if (!(ev.maxCoeff() > 0) || !(ev.minCoeff() > 1e-12 * ev.maxCoeff()))
        throw Error(what + " is singular on " + where +
                    ": its x, y and z are linearly dependent, so colours cannot be told apart");
}

std::vector<std::string> shipped_observers() { return {"cie1931-2", "cie1964-10"}; }

std::vector<std::string> shipped_illuminants() {
    // D65 first (the default), then daylight, incandescent, fluorescent, LED.
    return {"D65",    "D50",     "D55",      "D75",    "A",      "FL1",    "FL2",
            "FL3",    "FL4",     "FL5",      "FL6",    "FL7",    "FL8",    "FL9",
            "FL10",   "FL11",    "FL12",     "LED-B1", "LED-B2", "LED-B3", "LED-B4",
            "LED-B5", "LED-BH1", "LED-RGB1", "LED-V1", "LED-V2"};
}

std::string shipped_illuminants_list(const std::string& default_name) {
    std::string out;
    for (const auto& i : shipped_illuminants()) {
        if (!out.empty()) out += ", ";
        out += i;
        if (!default_name.empty() && upper(i) == upper(default_name)) out += " (default)";
    }
    return out;
}

Observer load_observer(const std::string& data_dir, const std::string& name) {
    for (const auto& o : shipped_observers())
        if (o == name) return load_observer_csv(data_dir + "/spectral/observer_" + o + ".csv", o);
    // A name that is not a shipped table is a file when something exists at that path: it is then
    // read (and refused when it is not a regular file of bounded size) by read_csv_table.
    if (path_exists(name)) return load_observer_csv(name, name);
    throw Error("unknown observer '" + printable_excerpt(name, 200) +
                "' (known: cie1931-2, cie1964-10, or a CSV file)");
}

Spectrum load_illuminant(const std::string& data_dir, const std::string& name_or_file) {
    for (const auto& i : shipped_illuminants())
        if (upper(name_or_file) == upper(i))
            return load_illuminant_csv(data_dir + "/spectral/illuminant_" + i + ".csv", i);
    // A name written as a temperature is one, whatever files exist ("./3200K" names such a file).
    if (const auto kelvin = colour_temperature_of(name_or_file))
        return colour_temperature_light(*kelvin);
    if (path_exists(name_or_file)) return load_illuminant_csv(name_or_file, name_or_file);
    // The name may come from a file's header (verify): an excerpt, one printable line.
    throw Error("unknown illuminant '" + printable_excerpt(name_or_file, 200) +
                "' (known: " + shipped_illuminants_list() +
                ", a colour temperature such as 3200K, or a CSV file)");
}

}  // namespace spectex
