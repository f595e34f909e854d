// The one copy of each small text and path rule (base/text.h, io/paths.h), which the options,
// the wavelength grids, the CSV tables and the batch code all read through.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "base/text.h"
#include "io/paths.h"

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
         {"",   " 1",  "1 ",  "1x",   "x",     "inf",  "-inf",     "nan", "1e400", "0x",
          ",5", "1,5", "\t2", "0x10", "0X1p3", "-0x1", "infinity", ".",   "-",     "e5"}) {
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
    // Bytes one_line would escape: bash's $'...' form, printable and pasteable.
    EXPECT_EQ(quote_path("a\nb"), "$'a\\nb'");
    EXPECT_EQ(quote_path("caf\xe9.png"), "$'caf\\xe9.png'");
    EXPECT_EQ(quote_path("it's\x01"), "$'it\\'s\\x01'");
}

TEST(Text, ParseWholeIsStrictAndNeverWraps) {
    long long v = -7;
    EXPECT_TRUE(parse_whole("42", 0, 100, &v));
    EXPECT_EQ(v, 42);
    EXPECT_TRUE(parse_whole("-3", -5, 5, &v));
    EXPECT_EQ(v, -3);
    EXPECT_TRUE(parse_whole("2147483647", 0, 2147483647LL, &v));
    EXPECT_EQ(v, 2147483647LL);
    v = -7;
    for (const char* bad : {"", "+1", " 1", "1 ", "0x10", "1e3", "1.0", "-", "--1", "4294967297",
                            "99999999999999999999", "1/2"}) {
        EXPECT_FALSE(parse_whole(bad, -100, 1000000000, &v)) << "'" << bad << "'";
        EXPECT_EQ(v, -7) << "'" << bad << "' changed the output";
    }
    EXPECT_FALSE(parse_whole("-1", 0, 10, &v));
    EXPECT_FALSE(parse_whole("11", 0, 10, &v));
}

// What quote_path prints, pasted into bash, is the same bytes: the message can be acted on.
TEST(Text, QuotedPathsReadBackInBash) {
    const std::vector<std::string> names = {"plain.png",
                                            "my file.png",
                                            "it's.png",
                                            "a\nb",
                                            "caf\xe9.png",
                                            "\x01\x1b[31m",
                                            "tab\there",
                                            "back\\slash'",
                                            "\xe2\x80\xae.png",
                                            "$HOME.png",
                                            "\xff\xfe"
                                            "9",
                                            "t\xc3\xabxt",
                                            "a: b",
                                            ""};
    for (const auto& n : names) {
        const std::string cmd = "printf %s " + quote_path(n);
        FILE* p = ::popen(("LC_ALL=C.UTF-8 bash -c " + quote_path(cmd)).c_str(), "r");
        ASSERT_NE(p, nullptr);
        std::string got;
        char buf[256];
        for (size_t k; (k = std::fread(buf, 1, sizeof buf, p)) > 0;) got.append(buf, k);
        ::pclose(p);
        EXPECT_EQ(got, n) << quote_path(n);
        EXPECT_EQ(one_line(quote_path(n)), quote_path(n)) << "not printable: " << quote_path(n);
    }
}
