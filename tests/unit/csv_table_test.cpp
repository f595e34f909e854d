#include "base/csv_table.h"

#include <gtest/gtest.h>

#include <sstream>

#include "base/error.h"
#include "spectral/basis.h"

using namespace spectex;

TEST(CsvTable, ParsesCommentsHeaderAndRows) {
    auto t = parse_csv_table(
        "# source: test\n# second\nwavelength,r,g,b\n380,0.1,0.2,0.7\n385, 0.5 ,0.25,0.25\n", "mem",
        {"wavelength", "r", "g", "b"});
    ASSERT_EQ(t.rows(), 2u);
    EXPECT_EQ(t.comments.size(), 2u);
    EXPECT_EQ(t.comments[0], "source: test");
    EXPECT_DOUBLE_EQ(t.data[1][1], 0.5);
    EXPECT_DOUBLE_EQ(t.data[0][1], 385);
}

TEST(CsvTable, MalformedInputIsAnError) {
    const std::vector<std::string> hdr{"wavelength", "r", "g", "b"};
    for (const char* bad : {
             "",                                          // empty
             "# only comments\n",                         // no header
             "wavelength,r,g\n380,1,2\n",                 // wrong header
             "wavelength,r,g,b\n",                        // no rows
             "wavelength,r,g,b\n380,1,2\n",               // short row
             "wavelength,r,g,b\n380,1,2,3,4\n",           // long row
             "wavelength,r,g,b\n380,a,2,3\n",             // not a number
             "wavelength,r,g,b\n380,nan,2,3\n",           // not finite
             "wavelength,r,g,b\n380,1,2,3\n380,1,2,3\n",  // not increasing
             "wavelength,r,g,b\n-5,1,2,3\n",              // negative wavelength
             "wavelength,r,g,b\n380,1e999,2,3\n",         // overflow
         }) {
        EXPECT_THROW(parse_csv_table(bad, "mem", hdr), Error) << bad;
    }
}

TEST(CsvTable, ErrorNamesFileAndLine) {
    try {
        parse_csv_table("wavelength,value\n380,1\n385,x\n", "table.csv", {"wavelength", "value"});
        FAIL();
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("table.csv:3"), std::string::npos) << e.what();
    }
}

TEST(CsvTable, BasisWriteReadIsExact) {
    Basis b{"t", {380, 382.5}, {0.1, 1.0 / 3.0}, {0.2, 2.0 / 3.0}, {0.7, 1e-17}};
    std::ostringstream out;
    write_basis_csv(out, b);
    EXPECT_EQ(out.str().rfind("wavelength,r,g,b\n", 0), 0u)
        << "the header row comes first (generic CSV readers)";
    auto t = parse_csv_table(out.str(), "mem", {"wavelength", "r", "g", "b"});
    Basis back{"t", t.data[0], t.data[1], t.data[2], t.data[3]};
    EXPECT_EQ(back.checksum(), b.checksum());  // 17 significant digits round-trip doubles exactly
    EXPECT_EQ(back.r[1], 1.0 / 3.0);
}

TEST(CsvTable, BasisWithTheOlderCommentPreambleStillReads) {
    const std::string old =
        "# spectral primary decomposition basis, fitted by spectex\n# checksum: fnv1a64:0\n"
        "wavelength,r,g,b\n380,0.1,0.2,0.7\n385,0.2,0.2,0.6\n";
    auto t = parse_csv_table(old, "old.csv", {"wavelength", "r", "g", "b"});
    EXPECT_EQ(t.rows(), 2u);
    EXPECT_EQ(t.comments.size(), 2u);
    EXPECT_EQ(t.data[3][1], 0.6);
}

// Light and observer tables as people export them: the wavelength column under any of its usual
// names, with or without a unit; or no header at all.
TEST(CsvTable, WavelengthFirstTakesTheUsualNamesAndNoHeader) {
    const std::vector<std::string> light{"wavelength", "value"};
    for (const char* name : {"wavelength", "Wavelength (nm)", "WAVELENGTH(nm)", "Wavelength [nm]",
                             "wavelength_nm", "Wavelength nm", "wavelengths", "lambda",
                             "Lambda (nm)", "\xce\xbb (nm)", "nm", "wl", "wave"}) {
        const std::string text = std::string(name) + ",Relative Power\n400,1\n410,2\n";
        const CsvTable t = parse_csv_table(text, "light.csv", light, CsvHeader::WavelengthFirst);
        ASSERT_EQ(t.rows(), 2u) << name;
        EXPECT_DOUBLE_EQ(t.data[0][1], 410) << name;
        EXPECT_DOUBLE_EQ(t.data[1][1], 2) << name;
    }
    // No header: the first row is data, the columns take the expected names.
    const CsvTable bare = parse_csv_table("# a comment\n400,1\n410,2.5\n", "light.csv", light,
                                          CsvHeader::WavelengthFirst);
    ASSERT_EQ(bare.rows(), 2u);
    EXPECT_EQ(bare.columns, light);
    EXPECT_DOUBLE_EQ(bare.data[0][0], 400);
    EXPECT_DOUBLE_EQ(bare.data[1][1], 2.5);
    const CsvTable observer =
        parse_csv_table("400,0.01,0.002,0.05\n410,0.04,0.001,0.2\n", "obs.csv",
                        {"wavelength", "x", "y", "z"}, CsvHeader::WavelengthFirst);
    EXPECT_EQ(observer.rows(), 2u);
    // Still refused: a first column that names something else, a number as a column's name, a
    // headerless row of the wrong width, and a headerless table for the exact headers (the basis).
    for (const char* bad : {"intensity,value\n400,1\n", "wavelength,5\n400,1\n",
                            "colour,value\n400,1\n", "400,1,2\n410,1,2\n", "nmx,value\n400,1\n"})
        EXPECT_THROW(parse_csv_table(bad, "light.csv", light, CsvHeader::WavelengthFirst), Error)
            << bad;
    EXPECT_THROW(parse_csv_table("380,0.1,0.2,0.7\n", "basis.csv", {"wavelength", "r", "g", "b"}),
                 Error);
    try {
        parse_csv_table("intensity,value\n400,1\n", "light.csv", light, CsvHeader::WavelengthFirst);
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("or no header, rows of 2 numbers"), std::string::npos)
            << e.what();
    }
}
