// The rule for the image and colour libraries' own messages (io/library_stderr.h): by default a
// farm log sees each distinct warning once, prefixed and on one printable line; errors (already in
// spectex's own error line) and OpenColorIO's info/debug chatter are left out.
#include <gtest/gtest.h>

#include <string>

#include "io/library_stderr.h"

using spectex::LibraryLineFilter;
using spectex::LibraryMessages;

TEST(LibraryMessages, WarningsAreShownOncePrefixedOnOneLine) {
    LibraryLineFilter f(LibraryMessages::warnings);
    EXPECT_EQ(f.pass("libpng warning: iCCP: known incorrect sRGB profile\n"),
              "spectex: library: libpng warning: iCCP: known incorrect sRGB profile\n");
    // The same line again (the next of 10,000 files): not repeated.
    EXPECT_EQ(f.pass("libpng warning: iCCP: known incorrect sRGB profile\n"), "");
    EXPECT_EQ(f.pass("libpng warning: iCCP: known incorrect sRGB profile\r\n"), "");
    // Another warning is.
    EXPECT_EQ(
        f.pass("TIFFReadDirectory: Warning, Unknown field with tag 50341 (0xc4a5) encountered.\n"),
        "spectex: library: TIFFReadDirectory: Warning, Unknown field with tag 50341 (0xc4a5) "
        "encountered.\n");
    EXPECT_EQ(f.pass("[OpenColorIO Warning]: Invalid $OCIO_LOGGING_LEVEL specified.\n"),
              "spectex: library: [OpenColorIO Warning]: Invalid $OCIO_LOGGING_LEVEL specified.\n");
}

TEST(LibraryMessages, ErrorsAndChatterAreLeftOutByDefault) {
    LibraryLineFilter f(LibraryMessages::warnings);
    EXPECT_EQ(f.pass("libpng error: IHDR: CRC error\n"), "");
    EXPECT_EQ(f.pass("ERROR: cannot open\n"), "");
    EXPECT_EQ(f.pass("[OpenColorIO Error]: Could not parse\n"), "");
    EXPECT_EQ(f.pass("[OpenColorIO Info]: Using config\n"), "");
    EXPECT_EQ(f.pass("[OpenColorIO Debug]: cache hit\n"), "");
    EXPECT_EQ(f.pass("   \n"), "");
    EXPECT_EQ(f.pass("\n"), "");
    EXPECT_EQ(f.pass("3 errors in IFD\n"), "");
    // The word, not the letters: a longer word that holds them does not make a line an error.
    EXPECT_NE(f.pass("Warning: terrorbytes of metadata ignored\n"), "");
    EXPECT_NE(f.pass("Warning: erroneous tag ignored\n"), "");
}

TEST(LibraryMessages, ControlBytesAndLongLinesAreMadeSafe) {
    LibraryLineFilter f(LibraryMessages::warnings);
    EXPECT_EQ(f.pass("Warning: tag \x1b[2J\xff seen\n"),
              "spectex: library: Warning: tag \\x1b[2J\\xff seen\n");
    const std::string out = f.pass("Warning: " + std::string(5000, 'x') + "\n");
    EXPECT_EQ(out.size(),
              std::string("spectex: library: ").size() + LibraryLineFilter::kMaxLine + 6 + 1)
        << out.size();
    EXPECT_EQ(out.substr(out.size() - 7), " [...]\n");
}

TEST(LibraryMessages, AllShowsEverythingAndNoneNothing) {
    LibraryLineFilter all(LibraryMessages::all), none(LibraryMessages::none);
    for (const char* l :
         {"libpng error: IHDR: CRC error\n", "[OpenColorIO Debug]: x\n", "Warning: w\n"}) {
        EXPECT_NE(all.pass(l), "") << l;
        EXPECT_EQ(none.pass(l), "") << l;
    }
    // "all" repeats what the library repeats.
    EXPECT_NE(all.pass("Warning: w\n"), "");
}

TEST(LibraryMessages, TheDistinctLinesRememberedAreBounded) {
    // A library printing endless distinct lines cannot grow memory without bound: past the limit a
    // line is still shown, just not remembered.
    LibraryLineFilter f(LibraryMessages::warnings);
    for (size_t i = 0; i < LibraryLineFilter::kMaxRemembered + 10; ++i)
        ASSERT_NE(f.pass("Warning: " + std::to_string(i) + "\n"), "") << i;
    EXPECT_EQ(f.pass("Warning: 0\n"), "");  // remembered
    EXPECT_NE(f.pass("Warning: " + std::to_string(LibraryLineFilter::kMaxRemembered + 5) + "\n"),
              "");  // not
}
