#include "base/csv_table.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ostream>
#include <sstream>

#include "base/bounded_read.h"
#include "base/error.h"
#include "base/text.h"

namespace spectex {

namespace {

constexpr size_t kMaxBytes = 64u << 20;  // a spectral table is kilobytes; refuse anything absurd
constexpr size_t kMaxColumns = 4096;

std::string trim(const std::string& s) {
    size_t a = s.find_first_not_of(" \t\r");
    if (a == std::string::npos) return "";
    size_t b = s.find_last_not_of(" \t\r");
    return s.substr(a, b - a + 1);
}

std::vector<std::string> split_commas(const std::string& line) {
    std::vector<std::string> out;
    std::string cur;
    for (char c : line) {
        if (c == ',') {
            out.push_back(trim(cur));
            cur.clear();
        } else {
            cur += c;
        }
    }
    out.push_back(trim(cur));
    return out;
}

bool to_double(const std::string& s, double* v) { return parse_finite(s, v); }

// "wavelength", "Wavelength (nm)", " WAVELENGTH(nm) ", "Wavelength [nm]", "wavelength_nm",
// "lambda", "nm", "wl": a name of the wavelength column, as the tables people export spell it.
bool names_wavelength(const std::string& field) {
    std::string f = lower_ascii(trim(field));
    for (const auto& [open_c, close_c] : {std::pair<char, char>{'(', ')'}, {'[', ']'}}) {
        if (!f.empty() && f.back() == close_c) {
            const size_t open = f.rfind(open_c);
            if (open == std::string::npos) return false;
            f = trim(f.substr(0, open));
            break;
        }
    }
    for (const char* unit : {"_nm", " nm", "-nm"})
        if (f.size() > 3 && f.compare(f.size() - 3, 3, unit) == 0)
            f = trim(f.substr(0, f.size() - 3));
    for (const char* name : {"wavelength", "wavelengths", "lambda", "\xce\xbb", "nm", "wl", "wave"})
        if (f == name) return true;
    return false;
}

// A line of finite numbers only: a table's first row when it has no header.
bool all_numbers(const std::vector<std::string>& fields) {
    for (const auto& f : fields) {
        double v;
        if (!parse_finite(f, &v)) return false;
    }
    return true;
}

// A header row's matches of `expected` (see CsvHeader).
bool header_matches(const std::vector<std::string>& fields,
                    const std::vector<std::string>& expected, CsvHeader header) {
    if (fields.size() != expected.size()) return false;
    if (header == CsvHeader::WavelengthFirst) {
        if (!names_wavelength(fields[0])) return false;
        for (size_t i = 1; i < fields.size(); ++i) {
            double v;
            if (fields[i].empty() || parse_finite(fields[i], &v)) return false;
        }
        return true;
    }
    for (size_t i = 0; i < fields.size(); ++i)
        if (lower_ascii(fields[i]) != lower_ascii(expected[i])) return false;
    return true;
}

}  // namespace

CsvTable parse_csv_table(const std::string& text, const std::string& source,
                         const std::vector<std::string>& expected, CsvHeader header) {
    if (text.size() > kMaxBytes) throw Error(source + ": file too large for a spectral table");
    CsvTable t;
    std::istringstream in(text);
    std::string line;
    size_t lineno = 0;
    bool have_header = false;
    while (std::getline(in, line)) {
        ++lineno;
        std::string s = trim(line);
        if (s.empty()) continue;
        if (s[0] == '#') {
            if (!have_header) t.comments.push_back(trim(s.substr(1)));
            continue;
        }
        auto fields = split_commas(s);
        std::string where = source + ":" + std::to_string(lineno) + ": ";
        if (!have_header && header == CsvHeader::WavelengthFirst &&
            fields.size() == expected.size() && all_numbers(fields)) {
            // No header: the columns are expected's, in its order, and this line is data.
            t.columns = expected;
            t.data.assign(expected.size(), {});
            have_header = true;
        }
        if (!have_header) {
            if (fields.size() < 2 || fields.size() > kMaxColumns)
                throw Error(where + "expected a header line such as 'wavelength,value'");
            if (!expected.empty()) {
                if (!header_matches(fields, expected, header)) {
                    std::string want;
                    for (size_t i = 0; i < expected.size(); ++i)
                        want += (i ? "," : "") + expected[i];
                    throw Error(where + "header is '" + s + "', expected '" + want + "'" +
                                (header == CsvHeader::WavelengthFirst
                                     ? " (a wavelength column, e.g. 'Wavelength (nm)', then " +
                                           std::to_string(expected.size() - 1) + " named column" +
                                           (expected.size() == 2 ? "" : "s") +
                                           "; or no header, rows of " +
                                           std::to_string(expected.size()) + " numbers)"
                                     : ""));
                }
            }
            t.columns = fields;
            t.data.assign(fields.size(), {});
            have_header = true;
            continue;
        }
        if (fields.size() != t.columns.size())
            throw Error(where + "expected " + std::to_string(t.columns.size()) + " values, found " +
                        std::to_string(fields.size()));
        for (size_t i = 0; i < fields.size(); ++i) {
            double v;
            if (!to_double(fields[i], &v))
                throw Error(where + "'" + fields[i] + "' is not a finite number");
            t.data[i].push_back(v);
        }
        const auto& wl = t.data[0];
        size_t n = wl.size();
        if (wl[n - 1] <= 0) throw Error(where + "wavelength must be positive");
        if (n > 1 && !(wl[n - 1] > wl[n - 2]))
            throw Error(where + "wavelengths must be strictly increasing");
    }
    if (!have_header) throw Error(source + ": no header line (empty or comment-only file)");
    if (t.rows() == 0) throw Error(source + ": no data rows");
    return t;
}

CsvTable read_csv_table(const std::string& path, const std::vector<std::string>& expected,
                        CsvHeader header) {
    // A regular file of bounded size, checked before it is read: never a device, FIFO or folder.
    static_assert(kMaxBytes == file_limits::kSpectralTable, "one limit for spectral tables");
    return parse_csv_table(read_file_bounded(path, file_limits::kSpectralTable, "a spectral table"),
                           path, expected, header);
}

void write_csv_table(std::ostream& out, const CsvTable& table) {
    for (const auto& c : table.comments) out << "# " << c << "\n";
    for (size_t i = 0; i < table.columns.size(); ++i) out << (i ? "," : "") << table.columns[i];
    out << "\n";
    char buf[64];
    for (size_t r = 0; r < table.rows(); ++r) {
        for (size_t c = 0; c < table.columns.size(); ++c) {
            double v = table.data[c][r];
            if (c == 0 && v == std::floor(v) && std::fabs(v) < 1e15)
                std::snprintf(buf, sizeof buf, "%.0f", v);
            else
                std::snprintf(buf, sizeof buf, "%.17g", v);
            out << (c ? "," : "") << buf;
        }
        out << "\n";
    }
}

}  // namespace spectex
