// The basis CSV that `spectex basis -o` writes: the header row first and
// nothing but the table, so that Python's csv module, numpy.genfromtxt(names=True) and
// colour-science's read_sds_from_csv_file load it without options; the provenance (command, fit,
// checksum, certificate) in a sidecar FILE.provenance. Files in the older format, with '#' lines
// before the header, still load.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;

namespace {

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> v;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);) v.push_back(l);
    return v;
}

// What a plain CSV reader does: the first line names the columns, every other line holds as many
// numbers.
void expect_plain_csv(const std::string& path) {
    const auto lines = lines_of(read_file(path));
    ASSERT_FALSE(lines.empty()) << path;
    EXPECT_EQ(lines[0], "wavelength,r,g,b") << path;
    for (size_t i = 1; i < lines.size(); ++i) {
        std::istringstream row(lines[i]);
        int fields = 0;
        for (std::string f; std::getline(row, f, ',');) {
            char* end = nullptr;
            std::strtod(f.c_str(), &end);
            EXPECT_TRUE(!f.empty() && *end == 0)
                << path << ":" << i + 1 << ": '" << f << "' is not a number";
            ++fields;
        }
        EXPECT_EQ(fields, 4) << path << ":" << i + 1;
    }
}

std::string line_starting(const std::string& text, const std::string& prefix) {
    for (const auto& l : lines_of(text))
        if (l.rfind(prefix, 0) == 0) return l;
    return "";
}

}  // namespace

TEST(BasisCsv, HeaderRowFirstAndProvenanceInASidecar) {
    ScratchDir d;
    const RunResult r =
        run_spectex({"basis", "-q", "--wavelengths", "400:700:10", "-o", d / "b.csv"});
    ASSERT_EQ(r.status, 0) << r.err;
    expect_plain_csv(d / "b.csv");
    EXPECT_EQ(lines_of(read_file(d / "b.csv")).size(), 32u);  // header + 31 bins
    ASSERT_TRUE(file_exists(d / "b.csv.provenance"));
    const std::string prov = read_file(d / "b.csv.provenance");
    EXPECT_NE(line_starting(prov, "checksum: fnv1a64:"), "") << prov;
    EXPECT_NE(line_starting(prov, "command: spectex basis"), "") << prov;
    EXPECT_NE(line_starting(prov, "fit: "), "") << prov;
    EXPECT_NE(line_starting(prov, "certificate: feasible:"), "") << prov;
    // The CSV alone to standard output.
    const RunResult s = run_spectex({"basis", "-q", "--wavelengths", "400:700:10", "-o", "-"});
    ASSERT_EQ(s.status, 0) << s.err;
    EXPECT_EQ(s.out, read_file(d / "b.csv"));
}

TEST(BasisCsv, ShippedDefaultBasisIsAPlainCsvAsTheToolWritesIt) {
    const std::string shipped =
        std::string(SPECTEX_TEST_DATA_DIR) + "/spectral/basis_fit_smooth_380-780-5.csv";
    expect_plain_csv(shipped);
    ScratchDir d;
    const RunResult r = run_spectex({"basis", "-q", "-o", d / "fresh.csv"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_file(shipped), read_file(d / "fresh.csv"))
        << "regenerate: spectex basis -q -o " << shipped;
    const std::string checksum = line_starting(read_file(d / "fresh.csv.provenance"), "checksum: ");
    EXPECT_NE(checksum, "");
    EXPECT_EQ(line_starting(read_file(shipped + ".provenance"), "checksum: "), checksum);
}

TEST(BasisCsv, OlderFilesWithACommentPreambleStillLoad) {
    ScratchDir d;
    ASSERT_EQ(run_spectex({"basis", "-q", "-o", d / "new.csv"}).status, 0);
    {
        std::ofstream old(d / "old.csv");
        old << "# spectral primary decomposition basis (Mallett & Yuksel 2019), fitted by spectex\n"
               "# checksum: fnv1a64:0000000000000000\n"
            << read_file(d / "new.csv");
    }
    std::vector<unsigned char> px = {200, 30, 40, 10, 220, 90, 0, 0, 255, 128, 128, 128};
    write_image(d / "in.png", 2, 2, 3, OIIO::TypeDesc::UINT8, px.data());
    for (const char* b : {"old.csv", "new.csv"}) {
        const RunResult r = run_spectex(
            {"bake", d / "in.png", "-o", d / (std::string(b) + ".exr"), "--basis", d / b});
        EXPECT_EQ(r.status, 0) << b << ": " << r.err;
    }
    // Same table, same pixels.
    const RunResult a = run_spectex({"sample", d / "old.csv.exr", "1,1"}),
                    n = run_spectex({"sample", d / "new.csv.exr", "1,1"});
    EXPECT_EQ(a.status, 0) << a.err;
    EXPECT_EQ(a.out, n.out);
}
