// The one copy of each small text and path rule (spectral/text.h, io/paths.h), which the options,
// the wavelength grids, the CSV tables and the batch code all read through.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "io/paths.h"
#include "spectral/text.h"

using namespace spectex;

TEST(Text, ParseFiniteTakesWholeFiniteTokensOnly) {
    double v = -1;
    EXPECT_TRUE(parse_finite("0.5", &v));
    EXPECT_EQ(v, 0.5);
    EXPECT_TRUE(parse_finite("-2e-3", &v));
    EXPECT_EQ(v, -2e-3);
    EXPECT_TRUE(parse_finite("400", &v));
    EXPECT_EQ(v, 400.0);
    v = 7;
    for (const char* bad :
         {"", " 1", "1 ", "1x", "x", "inf", "-inf", "nan", "1e400", "0x", ",5", "1,5", "\t2"}) {
        EXPECT_FALSE(parse_finite(bad, &v)) << "'" << bad << "'";
        EXPECT_EQ(v, 7.0) << "'" << bad << "' changed the output";
    }
}

TEST(Text, EndsWithNocase) {
    EXPECT_TRUE(ends_with_nocase("a.EXR", ".exr"));
    EXPECT_TRUE(ends_with_nocase("a.exr", ".EXR"));
    EXPECT_TRUE(ends_with_nocase(".png", ".png"));
    EXPECT_FALSE(ends_with_nocase("png", ".png"));
    EXPECT_FALSE(ends_with_nocase("a.exr.tmp", ".exr"));
    EXPECT_FALSE(ends_with_nocase("", ".exr"));
}

TEST(Text, LowerAsciiLeavesOtherBytesAlone) {
    EXPECT_EQ(lower_ascii("sRGB - Texture"), "srgb - texture");
    EXPECT_EQ(lower_ascii("\xc3\x89T\xc3\x89"),
              "\xc3\x89t\xc3\x89");  // "ÉTÉ": only the ASCII T changes
}

TEST(Paths, FolderAndNameAsDirnameAndBasename) {
    EXPECT_EQ(folder_of("a.png"), ".");
    EXPECT_EQ(folder_of("/a.png"), "/");
    EXPECT_EQ(folder_of("x/y/a.png"), "x/y");
    EXPECT_EQ(folder_of("/abs/a.png"), "/abs");
    EXPECT_EQ(file_name_of("x/y/a.png"), "a.png");
    EXPECT_EQ(file_name_of("a.png"), "a.png");
    EXPECT_EQ(file_name_of("x/"), "");
    EXPECT_FALSE(executable_dir().empty());
    EXPECT_EQ(executable_dir().front(), '/');
}

TEST(Text, QuotePathOnlyWhenAShellOrTheMessageConventionNeedsIt) {
    EXPECT_EQ(quote_path("assets/a_b-c.1001.png"), "assets/a_b-c.1001.png");
    EXPECT_EQ(quote_path("/abs/t\xc3\xabxture.png"),
              "/abs/t\xc3\xabxture.png");  // UTF-8 stays as it is
    EXPECT_EQ(quote_path("my file.png"), "'my file.png'");
    EXPECT_EQ(quote_path(" lead.png"), "' lead.png'");
    EXPECT_EQ(quote_path("a: b.png"), "'a: b.png'");
    EXPECT_EQ(quote_path("it's.png"), "'it'\\''s.png'");
    EXPECT_EQ(quote_path("t.<UDIM>.png"), "'t.<UDIM>.png'");
    EXPECT_EQ(quote_path("$HOME.png"), "'$HOME.png'");
    EXPECT_EQ(quote_path(""), "''");
    EXPECT_EQ(quote_path("a\nb"), "'a\nb'");  // one_line escapes the byte afterwards
}
