#include "spectral/wavelength_grid.h"

#include <gtest/gtest.h>

#include "base/error.h"

using namespace spectex;

TEST(WavelengthGrid, DefaultGridHas81Bins) {
    auto g = WavelengthGrid::parse("380:780:5");
    ASSERT_EQ(g.size(), 81u);
    EXPECT_EQ(g.lambda.front(), 380.0);
    EXPECT_EQ(g.lambda.back(), 780.0);
    EXPECT_TRUE(g.uniform);
    EXPECT_EQ(g.describe(), "380:780:5");
}

TEST(WavelengthGrid, EndIncludedOnlyWhenOnGrid) {
    EXPECT_EQ(WavelengthGrid::parse("380:780:3.7").size(), 109u);  // 380 + 108*3.7 = 779.6
    EXPECT_EQ(WavelengthGrid::parse("400:700:2.5").size(), 121u);
    EXPECT_EQ(WavelengthGrid::parse("500:500:10").size(), 1u);
    // 0.1 steps accumulate rounding if added up; multiplication keeps END exactly on the grid.
    auto g = WavelengthGrid::parse("380:390:0.1");
    ASSERT_EQ(g.size(), 101u);
    EXPECT_NEAR(g.lambda.back(), 390.0, 1e-9);
}

TEST(WavelengthGrid, MalformedSpecsAreErrors) {
    for (const char* bad :
         {"", "380", "380:780", "380:780:5:1", "a:780:5", "380:780:0", "380:780:-5", "780:380:5",
          "380:780:nan", "380:780:inf", "0:780:5", "380 :780:5", "380:780:5x", "1:1e9:0.001"}) {
        EXPECT_THROW(WavelengthGrid::parse(bad), Error) << bad;
    }
}

TEST(WavelengthGrid, ListGetsTrapezoidWeights) {
    auto g = WavelengthGrid::from_list({400, 410, 430});
    EXPECT_FALSE(g.uniform);
    EXPECT_DOUBLE_EQ(g.weight[0], 5);
    EXPECT_DOUBLE_EQ(g.weight[1], 15);
    EXPECT_DOUBLE_EQ(g.weight[2], 10);
    auto u = WavelengthGrid::from_list({400, 405, 410});
    EXPECT_TRUE(u.uniform);
    EXPECT_DOUBLE_EQ(u.weight[1], 5);
    EXPECT_THROW(WavelengthGrid::from_list({400, 400}), Error);
    EXPECT_THROW(WavelengthGrid::from_list({}), Error);
}

TEST(ChannelNames, FormatAndParse) {
    EXPECT_EQ(reflective_channel_name(380), "T.380nm");
    EXPECT_EQ(reflective_channel_name(383.7), "T.383,7nm");
    EXPECT_EQ(reflective_channel_name(400.25), "T.400,25nm");
    EXPECT_EQ(reflective_channel_name(380 + 1e-9), "T.380nm");
    double l = 0;
    ASSERT_TRUE(parse_reflective_channel("T.383,7nm", &l));
    EXPECT_DOUBLE_EQ(l, 383.7);
    ASSERT_TRUE(parse_reflective_channel("T.380,000000nm", &l));
    EXPECT_DOUBLE_EQ(l, 380);
    ASSERT_TRUE(parse_reflective_channel("T.555.5nm", &l));
    EXPECT_DOUBLE_EQ(l, 555.5);
    for (const char* bad : {"T.nm", "T.380", "S0.380nm", "T.38,0,0nm", "T.-380nm", "T.,5nm",
                            "T.5,nm", "R", "T.1e3nm", "T.380 nm", "T.0nm"})
        EXPECT_FALSE(parse_reflective_channel(bad, &l)) << bad;
}

TEST(ChannelNames, EveryGridRoundTrips) {
    for (const char* spec :
         {"380:780:5", "360:830:1", "380:780:3.7", "400:700:2.5", "380:780:0.1"}) {
        auto g = WavelengthGrid::parse(spec);
        for (double l : g.lambda) {
            double back = 0;
            ASSERT_TRUE(parse_reflective_channel(reflective_channel_name(l), &back));
            EXPECT_NEAR(back, l, 1e-6) << spec;
        }
    }
}
