// libFuzzer harness: the numeric CSV reader behind --basis FILE, --observer FILE and
// --illuminant FILE, with the basis header wavelength,r,g,b. Rejections are spectex::Error only;
// accepted tables must be rectangular with a strictly increasing first column.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "base/csv_table.h"
#include "base/error.h"

static void check(const spectex::CsvTable& t) {
    if (t.data.size() != t.columns.size()) std::abort();
    for (const auto& col : t.data)
        if (col.size() != t.rows()) std::abort();
    if (!t.data.empty())
        for (size_t i = 1; i < t.data[0].size(); ++i)
            if (!(t.data[0][i] > t.data[0][i - 1])) std::abort();
    // What we write, we read back.
    std::ostringstream out;
    spectex::write_csv_table(out, t);
    spectex::CsvTable back = spectex::parse_csv_table(out.str(), "roundtrip");
    if (back.rows() != t.rows() || back.columns.size() != t.columns.size()) std::abort();
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        check(spectex::parse_csv_table(text, "fuzz.csv", {"wavelength", "r", "g", "b"}));
    } catch (const spectex::Error&) {
    }
    try {
        check(spectex::parse_csv_table(text, "fuzz.csv"));
    } catch (const spectex::Error&) {
    }
    return 0;
}
