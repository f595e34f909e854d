#pragma once
// Numeric CSV tables: optional '#' provenance lines, a header line, then rows of numbers.
// The first column is a wavelength in nm, strictly increasing (DESIGN.md, "Conventions: CSV").
#include <iosfwd>
#include <string>
#include <vector>

namespace spectex {

struct CsvTable {
    std::vector<std::string> comments;      // provenance lines, without the leading '#'
    std::vector<std::string> columns;       // header names
    std::vector<std::vector<double>> data;  // data[column][row]

    size_t rows() const { return data.empty() ? 0 : data[0].size(); }
};

// Parses text; `source` names the file in error messages. When `expected` is not empty the header
// must equal it (case-insensitive, surrounding blanks ignored).
CsvTable parse_csv_table(const std::string& text, const std::string& source,
                         const std::vector<std::string>& expected = {});
CsvTable read_csv_table(const std::string& path, const std::vector<std::string>& expected = {});

// Writes comments as "# ..." lines, the header, and values with 17 significant digits.
void write_csv_table(std::ostream& out, const CsvTable& table);

}  // namespace spectex
