#pragma once
// Numeric CSV tables: optional '#' provenance lines, a header line, then rows of numbers.
// The first column is a wavelength in nm, strictly increasing.
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

// How a header must match `expected`.
enum class CsvHeader {
    Exact,  // every name equals expected's (case-insensitive, surrounding blanks ignored)
    // The first column names a wavelength ("wavelength", "lambda", "nm", "wl", any case,
    // optionally with a unit: "Wavelength (nm)", "Wavelength [nm]", "wavelength_nm") and the
    // others are any text that is not a number, as many as expected has: the tables people
    // export ("Wavelength (nm),Relative Power"). Or no header at all: the first line is then as
    // many finite numbers as expected has columns, and the columns take expected's names.
    WavelengthFirst,
};

// Parses text; `source` names the file in error messages. When `expected` is not empty the header
// must match it as `header` says.
CsvTable parse_csv_table(const std::string& text, const std::string& source,
                         const std::vector<std::string>& expected = {},
                         CsvHeader header = CsvHeader::Exact);
CsvTable read_csv_table(const std::string& path, const std::vector<std::string>& expected = {},
                        CsvHeader header = CsvHeader::Exact);

// Writes comments as "# ..." lines, the header, and values with 17 significant digits.
void write_csv_table(std::ostream& out, const CsvTable& table);

}  // namespace spectex
