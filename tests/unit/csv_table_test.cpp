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
