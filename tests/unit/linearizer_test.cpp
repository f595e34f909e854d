#include "io/linearizer.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <vector>

#include "base/error.h"
#include "temp_dir.h"

using namespace spectex;

namespace {

const std::string kData = SPECTEX_TEST_DATA_DIR;

// IEC 61966-2-1 sRGB decoding, written out here so the test shares nothing with the config.
double iec_srgb_to_linear(double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

Linearizer make(const std::string& cs, const std::string& config = "",
                const std::string& file = "x.png", const std::string& hint = "") {
    ColourTags tags;
    tags.format = file.substr(file.find_last_of('.') + 1);
    tags.hint = hint;  // as OpenImageIO assumes it for the format (no tag in the file)
    return Linearizer::make(ColourRequest{kData, config, cs, file, tags});
}

std::vector<float> linearize(const Linearizer& lin, const std::vector<float>& grey) {
    std::vector<float> rgba;
    for (float v : grey) rgba.insert(rgba.end(), {v, v, v, 1.0f});
    lin.apply_rgba(rgba.data(), static_cast<long>(grey.size()));
    std::vector<float> out;
    for (size_t i = 0; i < grey.size(); ++i) out.push_back(rgba[4 * i]);
    return out;
}

struct UnsetOcio {
    UnsetOcio() { unsetenv("OCIO"); }
};
UnsetOcio unset_ocio;

}  // namespace

TEST(Linearizer, ShippedSrgbMatchesIecFormulaOnAll8BitCodes) {
    Linearizer lin = make("srgb_tx");
    std::vector<float> codes;
    for (int c = 0; c < 256; ++c) codes.push_back(static_cast<float>(c / 255.0));
    auto lin_values = linearize(lin, codes);
    double worst = 0;
    for (int c = 0; c < 256; ++c)
        worst = std::max(worst, std::fabs(lin_values[c] - iec_srgb_to_linear(c / 255.0)));
    // OCIO 2.1's ExponentWithLinear uses toe slope 12.923 (not 12.92): up to 7.6e-7 absolute at
    // code 10, plus float rounding of ~6e-8. 1e-6 absolute bounds both.
    EXPECT_LT(worst, 1e-6);
    EXPECT_GT(worst, 0.0);  // and it is OCIO doing the work, not a copy of the formula
}

TEST(Linearizer, ShippedSrgbMatchesIecFormulaOn16BitSpotChecks) {
    Linearizer lin = make("sRGB - Texture");
    std::vector<float> codes;
    for (int c : {0, 1, 100, 2650, 2651, 10000, 32768, 50000, 65534, 65535})
        codes.push_back(static_cast<float>(c / 65535.0));
    auto v = linearize(lin, codes);
    for (size_t i = 0; i < codes.size(); ++i)
        EXPECT_NEAR(v[i], iec_srgb_to_linear(codes[i]), 1e-6) << codes[i];
}

TEST(Linearizer, AliasesAndRulesPickTheRightSpace) {
    EXPECT_EQ(make("lin_srgb").input_space(), "Linear Rec.709 (sRGB)");
    EXPECT_TRUE(make("lin_srgb").is_identity());
    EXPECT_TRUE(make("raw").is_identity());
    EXPECT_EQ(make("acescg").input_space(), "ACEScg");
    // No --colorspace: file metadata the config knows wins, else the file rules.
    EXPECT_EQ(make("", "", "a.png", "sRGB").input_space(), "sRGB - Texture");
    EXPECT_EQ(make("", "", "a.exr", "Linear").input_space(), "Linear Rec.709 (sRGB)");
    EXPECT_EQ(make("", "", "a.exr", "").input_space(), "Linear Rec.709 (sRGB)");
    EXPECT_EQ(make("", "", "a.EXR", "").input_space(), "Linear Rec.709 (sRGB)");
    EXPECT_EQ(make("", "", "a.tif", "").input_space(), "sRGB - Texture");
    EXPECT_EQ(make("", "", "a.png", "SomethingOdd").input_space(), "sRGB - Texture");
}

TEST(Linearizer, UnknownSpaceSuggestsCloseNames) {
    try {
        make("srgbtx");
        FAIL();
    } catch (const Error& e) {
        std::string m = e.what();
        EXPECT_NE(m.find("unknown colour space 'srgbtx'"), std::string::npos) << m;
        EXPECT_NE(m.find("srgb_tx"), std::string::npos) << m;
    }
}

TEST(Linearizer, AnotherConfigChangesTheResultAsItSays) {
    // A copy of the shipped config whose sRGB texture space is a pure 2.2 power: the output must
    // follow it, so no sRGB formula is hard-wired anywhere.
    std::ifstream in(kData + "/spectex.ocio");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string from =
        "from_scene_reference: !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055, "
        "direction: inverse}";
    size_t pos = text.find(from);
    ASSERT_NE(pos, std::string::npos);
    text.replace(pos, from.size(),
                 "from_scene_reference: !<ExponentTransform> {value: 2.2, style: pass_thru, "
                 "direction: inverse}");
    char tmpl[] = "/tmp/spectex-ocio-XXXXXX";
    std::string dir = mkdtemp(tmpl);
    std::string path = dir + "/g22.ocio";
    std::ofstream(path) << text;

    std::vector<float> codes{0.1f, 0.5f, 0.9f};
    auto v = linearize(make("srgb_tx", path), codes);
    for (size_t i = 0; i < codes.size(); ++i) EXPECT_NEAR(v[i], std::pow(codes[i], 2.2), 1e-6);
    // $OCIO does the same when --config is absent...
    setenv("OCIO", path.c_str(), 1);
    auto w = linearize(make("srgb_tx"), codes);
    // ...and --config wins over $OCIO.
    auto x = linearize(make("srgb_tx", kData + "/spectex.ocio"), codes);
    unsetenv("OCIO");
    for (size_t i = 0; i < codes.size(); ++i) {
        EXPECT_NEAR(w[i], std::pow(codes[i], 2.2), 1e-6);
        EXPECT_NEAR(x[i], iec_srgb_to_linear(codes[i]), 1e-6);
    }
    std::remove(path.c_str());
    rmdir(dir.c_str());
}

TEST(Linearizer, WideGamutSpacesGiveNegativeRec709) {
    // Pure ACEScg green lies outside Rec.709: its red and blue come out negative.
    Linearizer lin = make("acescg");
    std::vector<float> rgba{0, 1, 0, 1};
    lin.apply_rgba(rgba.data(), 1);
    EXPECT_LT(rgba[0], 0.0f);
    EXPECT_LT(rgba[2], 0.0f);
    EXPECT_NEAR(rgba[1], 1.1407357748225044, 1e-6);  // the config's matrix entry (float precision)
}

TEST(Linearizer, BrokenConfigIsAClearError) {
    try {
        make("srgb_tx", "/nonexistent/config.ocio");
        FAIL();
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent/config.ocio"), std::string::npos);
    }
}

TEST(Linearizer, CodeTableGivesOcioBitsForEveryCodeAndAnyOtherValue) {
    // 8-bit and 16-bit tables against OCIO itself: all codes as OpenImageIO converts them
    // (c / 255 and c / 65535 in float, plus the float one ulp either side, which must miss the
    // table and still be exact), random floats, negatives, > 1, NaN; RGB differing per pixel.
    for (int bits : {8, 16}) {
        SCOPED_TRACE(bits);
        Linearizer plain = make("srgb_tx");
        Linearizer table = make("srgb_tx");
        ASSERT_TRUE(table.use_code_table(bits));
        const int top = (1 << bits) - 1;
        std::vector<float> rgba;
        std::mt19937 rng(bits);
        std::uniform_real_distribution<float> u(-0.5f, 1.5f);
        for (int c = 0; c <= top; ++c) {
            const float v = static_cast<float>(c) / static_cast<float>(top);
            const float w = static_cast<float>(top - c) / static_cast<float>(top);
            rgba.insert(rgba.end(), {v, w, std::nextafter(v, 2.0f), 0.25f});
            rgba.insert(rgba.end(), {std::nextafter(v, -1.0f), v, u(rng), 0.5f});
        }
        rgba.insert(rgba.end(), {std::nanf(""), 0.5f, -0.0f, 1.0f});
        std::vector<float> a = rgba, b = rgba;
        plain.apply_rgba(a.data(), static_cast<long>(a.size() / 4));
        table.apply_rgba(b.data(), static_cast<long>(b.size() / 4));
        size_t differ = 0;
        for (size_t i = 0; i < a.size(); ++i)
            differ += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
        EXPECT_EQ(differ, 0u);
    }
    // A transform with crosstalk (P3 primaries -> Rec.709) cannot use a per-channel table.
    Linearizer p3 = make("sRGB Encoded P3-D65 - Texture");
    EXPECT_FALSE(p3.use_code_table(8));
}

TEST(Linearizer, AConfigEditedBetweenFilesIsReadAnew) {
    // Configs are parsed once per process for the same path and bytes (a batch of small files);
    // a config whose file changes under the same path must still be parsed again.
    std::ifstream in(kData + "/spectex.ocio");
    const std::string shipped((std::istreambuf_iterator<char>(in)),
                              std::istreambuf_iterator<char>());
    const std::string from =
        "from_scene_reference: !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055, "
        "direction: inverse}";
    ASSERT_NE(shipped.find(from), std::string::npos);
    std::string g22 = shipped;
    g22.replace(g22.find(from), from.size(),
                "from_scene_reference: !<ExponentTransform> {value: 2.2, style: pass_thru, "
                "direction: inverse}");
    char tmpl[] = "/tmp/spectex-ocio-XXXXXX";
    const std::string dir = mkdtemp(tmpl), path = dir + "/edited.ocio";
    const std::vector<float> codes{0.1f, 0.5f, 0.9f};
    for (int round = 0; round < 2; ++round) {  // twice: the second time both versions are cached
        std::ofstream(path, std::ios::trunc) << shipped;
        auto a = linearize(make("srgb_tx", path), codes);
        std::ofstream(path, std::ios::trunc) << g22;
        auto b = linearize(make("srgb_tx", path), codes);
        for (size_t i = 0; i < codes.size(); ++i) {
            EXPECT_NEAR(a[i], iec_srgb_to_linear(codes[i]), 1e-6) << round;
            EXPECT_NEAR(b[i], std::pow(codes[i], 2.2), 1e-6) << round;
        }
    }
    std::remove(path.c_str());
    rmdir(dir.c_str());
}

// A config's sRGB texture space is found by what it does, within the rounding of the matrices
// published configs use (tests/ocio/): written as ACES 1.x writes it (the curve, then the 7-digit
// sRGB -> AP0 matrix) and as the OCIO 2 studio configs do (OpenColorIO's builtins through AP1),
// both bridged to the shipped config through ACES2065-1, they decode within 2.1e-4 of the IEC
// curve. Spaces near it that are not it (Rec.709 at gamma 2.4 or 2.2, the sRGB curve on P3
// primaries, ACEScg) are never taken for it, before the real one or without it.
TEST(Linearizer, SrgbTextureSpaceIsFoundThroughPublishedMatrices) {
    const std::string ocio = std::string(SPECTEX_TEST_SOURCE_DIR) + "/tests/ocio/";
    EXPECT_EQ(srgb_texture_space(kData, ""), "sRGB - Texture");
    EXPECT_EQ(srgb_texture_space(kData, ocio + "aces1x_style.ocio"), "Utility - sRGB - Texture");
    EXPECT_EQ(srgb_texture_space(kData, ocio + "builtin_style.ocio"),
              "sRGB Encoded Rec.709 (sRGB)");
    EXPECT_EQ(srgb_texture_space(kData, ocio + "not_srgb.ocio"), "");

    auto read = [](const std::string& path) {
        std::ifstream in(path);
        return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    };
    const std::string aces = read(ocio + "aces1x_style.ocio");
    const size_t at = aces.find("  - !<ColorSpace>\n    name: Utility - sRGB - Texture\n");
    ASSERT_NE(at, std::string::npos);
    spectex_test::TempDir t;
    std::ofstream(t / "both.ocio") << read(ocio + "not_srgb.ocio") << "\n" << aces.substr(at);
    EXPECT_EQ(srgb_texture_space(kData, t / "both.ocio"), "Utility - sRGB - Texture");
}

// kConfigArithmeticTolerance keeps its margin on both sides: every colour of a 17^3 grid of codes
// decodes within half of it through the published configs' matrices (tests/ocio/), and a space
// that is not sRGB, however near (a 2.2 power on Rec.709), is more than ten times it away.
TEST(Linearizer, ConfigArithmeticToleranceKeepsItsMargins) {
    const std::string ocio = std::string(SPECTEX_TEST_SOURCE_DIR) + "/tests/ocio/";
    auto worst = [](const std::string& config, const std::string& space) {
        std::vector<float> rgba;
        const int n = 17;
        for (int r = 0; r < n; ++r)
            for (int g = 0; g < n; ++g)
                for (int b = 0; b < n; ++b)
                    rgba.insert(rgba.end(), {r / 16.0f, g / 16.0f, b / 16.0f, 1.0f});
        const std::vector<float> codes = rgba;
        make(space, config).apply_rgba(rgba.data(), static_cast<long>(rgba.size() / 4));
        double w = 0;
        for (size_t i = 0; i < rgba.size(); ++i)
            if (i % 4 != 3) w = std::max(w, std::fabs(rgba[i] - iec_srgb_to_linear(codes[i])));
        return w;
    };
    EXPECT_LE(worst(ocio + "aces1x_style.ocio", "Utility - sRGB - Texture"),
              kConfigArithmeticTolerance / 2);
    EXPECT_LE(worst(ocio + "builtin_style.ocio", "sRGB Encoded Rec.709 (sRGB)"),
              kConfigArithmeticTolerance / 2);
    EXPECT_GE(worst(ocio + "not_srgb.ocio", "Utility - Gamma 2.2 - Rec.709 - Texture"),
              10 * kConfigArithmeticTolerance);
}

// The precision budget measures the colours a bake gives 8-bit sRGB codes: OpenColorIO's, through
// the config, bit for bit (its rounding is not smooth: the formula's colours are other colours).
TEST(Linearizer, SrgbCodeValuesAreWhatABakeDecodes) {
    const std::vector<float> v = srgb_code_values(kData, "");
    ASSERT_EQ(v.size(), 3u * 256u);
    Linearizer lin = make("srgb_tx");
    ASSERT_TRUE(lin.use_code_table(8));
    std::vector<float> rgba;
    for (int c = 0; c < 256; ++c) {  // the floats OpenImageIO reads an 8-bit file's codes as
        const unsigned char code = static_cast<unsigned char>(c);
        float x = 0;
        ASSERT_TRUE(
            OIIO::convert_pixel_values(OIIO::TypeDesc::UINT8, &code, OIIO::TypeDesc::FLOAT, &x, 1));
        rgba.insert(rgba.end(), {x, x, x, 1.0f});
    }
    lin.apply_rgba(rgba.data(), 256);
    size_t differ_from_formula = 0;
    for (size_t c = 0; c < 256; ++c)
        for (size_t ch = 0; ch < 3; ++ch) {
            EXPECT_EQ(v[3 * c + ch], rgba[4 * c + ch]) << c << " " << ch;  // exact: the same bits
            differ_from_formula +=
                v[3 * c + ch] != static_cast<float>(iec_srgb_to_linear(c / 255.0));
        }
    // Code 1: 1/255/12.9232 (OpenColorIO's continuous knee), not 1/255/12.92.
    EXPECT_LT(v[3], static_cast<float>(iec_srgb_to_linear(1 / 255.0)));
    EXPECT_GT(differ_from_formula, 0u);

    // A config that cannot name sRGB: no values (the budget then measures the formula's).
    EXPECT_TRUE(
        srgb_code_values(kData, std::string(SPECTEX_TEST_SOURCE_DIR) + "/tests/ocio/not_srgb.ocio")
            .empty());
}
