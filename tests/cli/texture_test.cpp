// A MIP-mapped spectral texture through OpenImageIO's TextureSystem: because the expansion is
// linear and the levels are filtered on linear RGB, a filtered lookup of the spectral channels must
// equal the basis applied to the same lookup of the RGB (preview) channels, at any MIP level.
#include <OpenImageIO/texture.h>
#include <gtest/gtest.h>

#include <cmath>

#include "cli/cli_util.h"
#include "cli/spectral_check.h"

using namespace spectex_test;

TEST(Texture, FilteredLookupsEqualTheExpansionOfTheRgbLookup) {
    ScratchDir d;
    const int w = 200, h = 120;  // not a power of two: levels round down, odd sizes appear
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                px[(static_cast<size_t>(y) * w + x) * 3 + c] = static_cast<uint8_t>(
                    127.5 + 127.5 * std::sin(0.11 * x * (c + 1) + 0.07 * y * (3 - c)));
    write_image(d / "tex.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::string basis =
        std::string(SPECTEX_TEST_DATA_DIR) + "/spectral/basis_fit_smooth_380-780-5.csv";
    auto r = run_spectex({"bake", d / "tex.png", "-o", d / "tex.exr", "--mipmap", "--tile", "32",
                          "--preview", "--type", "float", "--basis", basis});
    ASSERT_EQ(r.status, 0) << r.err;
    auto cols = read_columns(basis);

    // The shared texture system: never destroyed by us (OIIO 2.4's destroy trips ASan's
    // new/delete type check inside OIIO itself).
    OIIO::TextureSystem* ts = OIIO::TextureSystem::create(true);
    OIIO::ustring file((d / "tex.exr").c_str());
    const OIIO::ImageSpec* spec = ts->imagespec(file);
    ASSERT_NE(spec, nullptr) << ts->geterror();
    int rc = spec->channelindex("R"), gc = spec->channelindex("G"), bc = spec->channelindex("B");
    ASSERT_GE(rc, 0);
    ASSERT_EQ(gc, rc + 1);
    ASSERT_EQ(bc, rc + 2);
    const char* fmt = nullptr;
    ASSERT_TRUE(ts->get_texture_info(file, 0, OIIO::ustring("textureformat"),
                                     OIIO::TypeDesc::STRING, &fmt));
    EXPECT_STREQ(fmt, "Plain Texture");

    OIIO::TextureOpt opt;
    opt.mipmode = OIIO::TextureOpt::MipModeTrilinear;
    opt.interpmode = OIIO::TextureOpt::InterpBilinear;
    int checked = 0;
    double worst = 0, spread = 0;
    for (double footprint :
         {0.004, 0.013, 0.03, 0.07, 0.2}) {  // ~1 to ~40 texels: fractional levels 0..5
        for (int i = 0; i < 7; ++i) {
            float s = 0.1f + 0.12f * i, t = 0.15f + 0.1f * i;
            float rgb[3];
            opt.firstchannel = rc;
            ASSERT_TRUE(ts->texture(file, opt, s, t, static_cast<float>(footprint), 0, 0,
                                    static_cast<float>(footprint), 3, rgb));
            for (size_t k = 0; k < cols[0].size(); ++k) {
                std::string name = "T." + std::to_string(static_cast<int>(cols[0][k])) + "nm";
                int ch = spec->channelindex(name);
                ASSERT_GE(ch, 0) << name;
                opt.firstchannel = ch;
                float v;
                ASSERT_TRUE(ts->texture(file, opt, s, t, static_cast<float>(footprint), 0, 0,
                                        static_cast<float>(footprint), 1, &v));
                double want = cols[1][k] * rgb[0] + cols[2][k] * rgb[1] + cols[3][k] * rgb[2];
                worst = std::max(worst, std::fabs(v - want));
                spread = std::max(spread, std::fabs(want - 0.5));
                ++checked;
            }
        }
    }
    // Float storage and float filtering of the same weights: the two sides differ by the float
    // rounding of the expansion and of the filter sums, a few 1e-7; 1e-5 leaves margin while a
    // wrong level, a wrong filter or a missed premultiplication would be off by 1e-2 or more.
    EXPECT_LT(worst, 1e-5);
    EXPECT_GT(spread, 0.05);  // the texture is not constant
    EXPECT_EQ(checked, 5 * 7 * 81);
}
