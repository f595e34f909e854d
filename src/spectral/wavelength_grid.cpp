#include "spectral/wavelength_grid.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "base/bounded_read.h"
#include "base/error.h"
#include "base/text.h"

namespace spectex {

namespace {

constexpr double kOnGridTolerance = 1e-6;  // nm

// "<label>: 40001 bins, over the limit of 4701 ...": a grid too fine to be worth its cost.
[[noreturn]] void refuse_bins(const std::string& label, double bins) {
    char figure[32];
    std::snprintf(figure, sizeof figure, "%.0f", bins);
    throw LimitError(label + ": " + figure + " bins, over the limit of " +
                     std::to_string(kMaxGridBins) +
                     " (0.1 nm over 360-830 nm, the finest grid a renderer samples; time, memory "
                     "and file size grow with the bins)");
}

bool parse_double(const std::string& s, double* out) { return parse_finite(s, out); }

// Every bin must get a channel name that reads back as its wavelength, and no two bins one name.
void check_names(const std::vector<double>& lambda, const std::string& label) {
    std::string prev;
    for (size_t k = 0; k < lambda.size(); ++k) {
        std::string name = reflective_channel_name(lambda[k]);
        double back = 0;
        if (!parse_reflective_channel(name, &back) ||
            std::fabs(back - lambda[k]) > kOnGridTolerance)
            throw Error(
                label + ": wavelength " + std::to_string(lambda[k]) +
                " nm cannot be named as a channel (T.<nm>nm to 1e-6 nm; use 1e-6 to 1e9 nm)");
        if (name == prev)
            throw Error(label + ": wavelengths " + std::to_string(lambda[k - 1]) + " and " +
                        std::to_string(lambda[k]) +
                        " nm are closer than 1e-6 nm (one channel name)");
        prev = name;
    }
}

}  // namespace

std::string WavelengthGrid::describe() const {
    if (lambda.empty()) return "empty grid";
    if (uniform && lambda.size() > 1) {
        return format_wavelength(lambda.front()) + ":" + format_wavelength(lambda.back()) + ":" +
               format_wavelength(step);
    }
    return "list of " + std::to_string(lambda.size()) + " wavelengths " +
           format_wavelength(lambda.front()) + "-" + format_wavelength(lambda.back()) + " nm";
}

namespace {

WavelengthGrid make_uniform(double start, double end, double step, const std::string& label) {
    if (!(std::isfinite(start) && std::isfinite(end) && std::isfinite(step)))
        throw Error(label + ": values must be finite numbers");
    if (start <= 0) throw Error(label + ": START must be positive");
    if (end < start) throw Error(label + ": END must not be below START");
    if (step <= 0) throw Error(label + ": STEP must be positive");
    double count = std::floor((end - start) / step + kOnGridTolerance / step);
    if (count + 1 > static_cast<double>(kMaxGridBins)) refuse_bins(label, count + 1);
    WavelengthGrid g;
    size_t n = static_cast<size_t>(count) + 1;
    g.lambda.resize(n);
    // Multiplication, not accumulation, so that no rounding error builds up along the grid.
    for (size_t k = 0; k < n; ++k) g.lambda[k] = start + static_cast<double>(k) * step;
    g.weight.assign(n, step);
    g.uniform = true;
    g.step = step;
    check_names(g.lambda, label);
    return g;
}

}  // namespace

WavelengthGrid WavelengthGrid::uniform_grid(double start, double end, double step) {
    return make_uniform(start, end, step, "wavelength grid");
}

WavelengthGrid WavelengthGrid::parse(const std::string& spec) {
    std::vector<std::string> parts;
    std::string cur;
    for (char c : spec) {
        if (c == ':') {
            parts.push_back(cur);
            cur.clear();
        } else {
            cur += c;
        }
    }
    parts.push_back(cur);
    if (parts.size() != 3)
        throw Error("wavelength grid '" + spec + "': expected START:END:STEP, e.g. 380:780:5");
    double v[3];
    for (int i = 0; i < 3; ++i) {
        if (!parse_double(parts[i], &v[i]))
            throw Error("wavelength grid '" + spec + "': '" + parts[i] + "' is not a number");
    }
    return make_uniform(v[0], v[1], v[2], "wavelength grid '" + spec + "'");
}

WavelengthGrid WavelengthGrid::parse_exact(const std::string& spec) {
    WavelengthGrid g = parse(spec);
    double v[3] = {0, 0, 0};  // parse() has checked all three
    size_t a = spec.find(':'), b = spec.find(':', a + 1);
    parse_double(spec.substr(0, a), &v[0]);
    parse_double(spec.substr(a + 1, b - a - 1), &v[1]);
    parse_double(spec.substr(b + 1), &v[2]);
    // END must be a bin: silently stopping short (400:700:7 ending at 694) hides a typo.
    if (std::fabs(g.lambda.back() - v[1]) > kOnGridTolerance)
        throw Error("wavelength grid '" + spec + "': END " + format_wavelength(v[1]) +
                    " is not on the grid " + format_wavelength(v[0]) + " + k*" +
                    format_wavelength(v[2]) + " (its last bin would be " +
                    format_wavelength(g.lambda.back()) + "): use " + format_wavelength(v[0]) + ":" +
                    format_wavelength(g.lambda.back()) + ":" + format_wavelength(v[2]) +
                    ", or a STEP that divides END - START");
    return g;
}

WavelengthGrid WavelengthGrid::from_list(std::vector<double> lambdas) {
    if (lambdas.empty()) throw Error("wavelength list is empty");
    if (lambdas.size() > kMaxGridBins)
        refuse_bins("wavelength list", static_cast<double>(lambdas.size()));
    for (size_t i = 0; i < lambdas.size(); ++i) {
        if (!std::isfinite(lambdas[i]) || lambdas[i] <= 0)
            throw Error("wavelength list: entry " + std::to_string(i + 1) +
                        " is not a positive number");
        if (i > 0 && !(lambdas[i] > lambdas[i - 1]))
            throw Error("wavelength list: wavelengths must be strictly increasing (entry " +
                        std::to_string(i + 1) + ")");
    }
    check_names(lambdas, "wavelength list");
    WavelengthGrid g;
    g.lambda = std::move(lambdas);
    size_t n = g.lambda.size();
    // Uniform within rounding? Then it is a uniform grid with equal weights.
    bool uniform = n > 1;
    double step = n > 1 ? (g.lambda.back() - g.lambda.front()) / static_cast<double>(n - 1) : 0.0;
    for (size_t k = 0; uniform && k < n; ++k)
        uniform = std::fabs(g.lambda[k] - (g.lambda.front() + static_cast<double>(k) * step)) <=
                  kOnGridTolerance;
    g.uniform = uniform;
    g.step = step;
    g.weight.assign(n, 0.0);
    if (n == 1) {
        g.weight[0] = 1.0;
    } else if (uniform) {
        g.weight.assign(n, step);
    } else {
        for (size_t k = 0; k + 1 < n; ++k) {
            double h = g.lambda[k + 1] - g.lambda[k];
            g.weight[k] += 0.5 * h;
            g.weight[k + 1] += 0.5 * h;
        }
    }
    return g;
}

WavelengthGrid WavelengthGrid::from_file(const std::string& path) {
    // A regular file of bounded size, checked before it is read: never a device, FIFO or folder.
    std::istringstream in(
        read_file_bounded(path, file_limits::kWavelengthFile, "a wavelength file"));
    std::vector<double> values;
    std::string line;
    size_t lineno = 0;
    while (std::getline(in, line)) {
        ++lineno;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        size_t a = line.find_first_not_of(" \t");
        if (a == std::string::npos || line[a] == '#') continue;
        size_t b = line.find_last_not_of(" \t");
        double v;
        if (!parse_double(line.substr(a, b - a + 1), &v))
            throw Error(path + ":" + std::to_string(lineno) + ": not a wavelength: '" +
                        printable_excerpt(line, 60) + "'");
        values.push_back(v);
    }
    try {
        return from_list(std::move(values));
    } catch (const LimitError& e) {
        throw LimitError(path + ": " + e.what());
    } catch (const Error& e) {
        throw Error(path + ": " + e.what());
    }
}

std::string format_wavelength(double lambda_nm) {
    // Round to 1e-6 nm, then drop trailing zeros.
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", lambda_nm);
    std::string s(buf);
    size_t dot = s.find('.');
    if (dot != std::string::npos) {
        while (!s.empty() && s.back() == '0') s.pop_back();
        if (!s.empty() && s.back() == '.') s.pop_back();
    }
    if (s == "-0") s = "0";
    return s;
}

std::string reflective_channel_name(double lambda_nm) {
    std::string s = format_wavelength(lambda_nm);
    for (char& c : s)
        if (c == '.') c = ',';
    return "T." + s + "nm";
}

bool parse_reflective_channel(const std::string& name, double* lambda_nm) {
    if (name.size() < 5 || name.compare(0, 2, "T.") != 0) return false;
    if (name.compare(name.size() - 2, 2, "nm") != 0) return false;
    std::string num = name.substr(2, name.size() - 4);
    if (num.empty() || num.size() > 32) return false;
    int seps = 0;
    for (char& c : num) {
        if (c == ',' || c == '.') {
            c = '.';
            ++seps;
        } else if (c < '0' || c > '9') {
            return false;
        }
    }
    if (seps > 1 || num.front() == '.' || num.back() == '.') return false;
    double v;
    if (!parse_double(num, &v) || v <= 0) return false;
    *lambda_nm = v;
    return true;
}

bool same_wavelengths(const std::vector<double>& a, const std::vector<double>& b, double tol) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i)
        if (std::fabs(a[i] - b[i]) > tol) return false;
    return true;
}

}  // namespace spectex
