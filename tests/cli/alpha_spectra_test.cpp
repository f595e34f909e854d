// Alpha with every method: a half-transparent pixel's straight spectrum (T/A when the file is
// associated, T when it is not) is the spectrum of its straight colour, the one an opaque pixel of
// that colour gets, within [0, 1]: on level 0 and on every MIP level whose texels cover one colour.
// A method that is not linear (the lattice, Jakob-Hanika, the default) must premultiply spectra,
// not colours: its spectrum of A·rgb is not A times its spectrum of rgb.
#include <ImfTiledInputFile.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "cli_util.h"
#include "exr_read.h"

using namespace spectex_test;

namespace {

// 16 colours in 4x4 blocks of a 16x16 image, so that MIP levels 1 and 2 (8x8, 4x4) still have one
// colour per texel. Saturated primaries and corners are where a lattice's spectra reach 1.
const int kColours[16][3] = {{0, 0, 255},    {255, 0, 0},     {0, 255, 0},    {255, 255, 0},
                             {0, 255, 255},  {255, 0, 255},   {200, 100, 50}, {194, 150, 130},
                             {98, 122, 157}, {250, 250, 250}, {20, 20, 20},   {128, 128, 128},
                             {255, 128, 0},  {60, 0, 120},    {0, 90, 40},    {255, 200, 230}};
// Alphas within a block, row by row; the first is opaque (the block's reference pixel).
const int kAlphas[16] = {255, 192, 128, 64, 32, 8, 1, 0, 250, 200, 100, 50, 16, 4, 2, 255};

std::vector<uint8_t> rgba_pixels() {
    std::vector<uint8_t> px(16 * 16 * 4);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            const int c = (y / 4) * 4 + x / 4, a = kAlphas[(y % 4) * 4 + x % 4];
            uint8_t* p = &px[static_cast<size_t>(4 * (y * 16 + x))];
            for (int ch = 0; ch < 3; ++ch) p[ch] = static_cast<uint8_t>(kColours[c][ch]);
            p[3] = static_cast<uint8_t>(a);
        }
    return px;
}

struct Level {
    int w = 0, h = 0;
    std::vector<std::string> names;           // T channels by wavelength
    std::vector<std::vector<float>> spectra;  // per channel, w*h
    std::vector<float> alpha;
};

// Every MIP level of a tiled file (OpenEXR's own reader), or level 0 of a scanline file.
std::vector<Level> read_levels(const std::string& path) {
    std::vector<Level> out;
    const ExrImage img = read_exr(path);
    std::vector<std::string> names;
    for (const auto& [l, n] : spectral_channels(img)) names.push_back(n);
    if (!img.header.hasTileDescription()) {
        Level lv{img.width, img.height, names, {}, img.pixels.at("A")};
        for (const auto& n : names) lv.spectra.push_back(img.pixels.at(n));
        out.push_back(std::move(lv));
        return out;
    }
    Imf::TiledInputFile in(path.c_str());
    for (int l = 0; l < in.numLevels(); ++l) {
        const Imath::Box2i dw = in.dataWindowForLevel(l, l);
        Level lv;
        lv.w = dw.max.x - dw.min.x + 1;
        lv.h = dw.max.y - dw.min.y + 1;
        lv.names = names;
        const size_t n = static_cast<size_t>(lv.w) * static_cast<size_t>(lv.h);
        lv.spectra.assign(names.size(), std::vector<float>(n));
        lv.alpha.assign(n, 0.0f);
        Imf::FrameBuffer fb;
        auto slice = [&](std::vector<float>& v) {
            char* base = reinterpret_cast<char*>(v.data()) -
                         (static_cast<ptrdiff_t>(dw.min.y) * lv.w + dw.min.x) *
                             static_cast<ptrdiff_t>(sizeof(float));
            return Imf::Slice(Imf::FLOAT, base, sizeof(float),
                              sizeof(float) * static_cast<size_t>(lv.w));
        };
        for (size_t k = 0; k < names.size(); ++k) fb.insert(names[k], slice(lv.spectra[k]));
        fb.insert("A", slice(lv.alpha));
        in.setFrameBuffer(fb);
        in.readTiles(0, in.numXTiles(l) - 1, 0, in.numYTiles(l) - 1, l, l);
        out.push_back(std::move(lv));
    }
    return out;
}

// The relative step of bin k's stored values: 2^-bits (the precision budget's bits when the header
// records them, else half's 10), the most the colour-aware rounding moves a value.
std::vector<double> steps(const ExrImage& img, size_t bins) {
    std::vector<double> s(bins, std::ldexp(1.0, -10));
    std::istringstream in(img.attr("spectex:precisionBits"));
    int b = 0;
    for (size_t k = 0; k < bins && (in >> b); ++k) s[k] = std::ldexp(1.0, -b);
    return s;
}

struct Case {
    std::string name;
    std::vector<std::string> args;
};

// How far a straight sample v is from the reference ref beyond what rounding allows (<= 0: within
// it). The tolerance: each value's step of its bin (at most one step, relative: 2 * step), A's half
// rounding (2^-11), 1e-6; and half's subnormals (below 2^-14), 2^-24 apart: absolute, so divided by
// A when the file is associated.
double gap_beyond_rounding(double v, double ref, double step, double a, bool assoc) {
    const double tol = 2 * step + std::ldexp(1.0, -11);
    const double floor = std::ldexp(1.0, -24) * (assoc ? 1 / a : 1);
    return std::fabs(v - ref) - (tol * ref + floor + 1e-6);
}

// The largest gap seen, and where (described only when it is the largest).
struct WorstGap {
    double gap = 0;
    std::string at;
    void see(double g, const std::function<std::string()>& where) {
        if (g > gap) gap = g, at = where();
    }
};

// Every method. Jakob-Hanika on a 9-node table: the method's shape is what matters here, not its
// accuracy.
const std::vector<Case> kMethods = {
    {"default", {}},
    {"basis", {"--method", "basis"}},
    {"lattice", {"--method", "lattice"}},
    {"jakob-hanika", {"--method", "jakob-hanika", "--jh-resolution", "9"}}};

}  // namespace

TEST(AlphaSpectra, EveryMethodKeepsTheStraightSpectrumOfTheColourOnEveryLevel) {
    ScratchDir d;
    const std::string in = d / "rgba.png";
    const std::vector<uint8_t> px = rgba_pixels();
    write_image(in, 16, 16, 4, OIIO::TypeDesc::UINT8, px.data(), {{"oiio:UnassociatedAlpha", "1"}});
    for (const Case& m : kMethods)
        for (const std::string alpha : {"associated", "unassociated"})
            for (const bool mip : {false, true}) {
                const std::string what = m.name + ", " + alpha + (mip ? ", MIP" : "");
                SCOPED_TRACE(what);
                const std::string out = d / (m.name + "-" + alpha + (mip ? "-mip" : "") + ".exr");
                std::vector<std::string> args{"bake", in, "-o", out, "--alpha", alpha};
                args.insert(args.end(), m.args.begin(), m.args.end());
                if (mip) args.push_back("--mipmap");
                const RunResult r = run_spectex(args);
                ASSERT_EQ(r.status, 0) << r.err;
                const ExrImage top = read_exr(out);
                const std::vector<Level> levels = read_levels(out);
                ASSERT_EQ(levels.size(), mip ? 5u : 1u);
                const size_t bins = levels[0].names.size();
                ASSERT_EQ(bins, m.name == "default" ? kDefaultBins : 81u);
                const std::vector<double> step = steps(top, bins);
                const bool assoc = alpha == "associated";
                // The reference spectrum of colour c: its block's opaque pixel on level 0.
                auto reference = [&](int c, size_t k) {
                    const int x = (c % 4) * 4, y = (c / 4) * 4;
                    return static_cast<double>(
                        levels[0].spectra[k][static_cast<size_t>(y * 16 + x)]);
                };
                double worst_over = 0;
                WorstGap worst;
                for (size_t l = 0; l < levels.size(); ++l) {
                    const Level& lv = levels[l];
                    const int span = 1 << l;  // level-0 pixels per texel along an axis
                    for (int y = 0; y < lv.h; ++y)
                        for (int x = 0; x < lv.w; ++x) {
                            const size_t i = static_cast<size_t>(y * lv.w + x);
                            const double a = lv.alpha[i];
                            if (!(a > 0)) {
                                // Nothing seen: a premultiplied spectrum is 0 there.
                                if (assoc)
                                    for (size_t k = 0; k < bins; ++k)
                                        EXPECT_EQ(lv.spectra[k][i], 0.0f);
                                continue;
                            }
                            const bool one_colour = span <= 4;
                            const int c = ((y * span) / 4) * 4 + (x * span) / 4;
                            for (size_t k = 0; k < bins; ++k) {
                                const double v = lv.spectra[k][i] / (assoc ? a : 1.0);
                                // Tolerance: T's step and the reference's (each at most one step
                                // of its bin, relative), A's half rounding (2^-11), 1e-6.
                                const double tol = 2 * step[k] + std::ldexp(1.0, -11);
                                worst_over = std::max(worst_over, v - (1 + tol));
                                EXPECT_GE(v, 0.0) << lv.names[k] << " level " << l;
                                if (!one_colour) continue;
                                const double ref = reference(c, k);
                                const double gap = gap_beyond_rounding(v, ref, step[k], a, assoc);
                                worst.see(gap, [&] {
                                    return lv.names[k] + " level " + std::to_string(l) + " (" +
                                           std::to_string(x) + ", " + std::to_string(y) +
                                           "): " + std::to_string(v) + " against " +
                                           std::to_string(ref) + " opaque, A " + std::to_string(a);
                                });
                            }
                        }
                }
                EXPECT_LE(worst_over, 0.0) << "a straight sample above 1 beyond its rounding";
                EXPECT_LE(worst.gap, 0.0) << "not the opaque pixel's spectrum: " << worst.at;
                // verify checks the same rule for associated files, with its own tolerance.
                if (assoc && !mip) {
                    const RunResult v = run_spectex({"verify", out});
                    EXPECT_EQ(v.status, 0) << v.out << v.err;
                }
            }
}

// What cannot be seen is not filtered in: a checkerboard of opaque red and fully transparent
// green (and one 4x4 block of transparent cyan) has, on every MIP level, the straight spectrum of
// red wherever anything is seen, whether the file stores spectra premultiplied or straight
// (--alpha unassociated): its levels are filtered on the premultiplied colour and divided by the
// filtered alpha, as maketx does. Filtering the straight colour alone gave yellow at level 1.
TEST(AlphaSpectra, TransparentColoursNeverBleedIntoMipLevels) {
    ScratchDir d;
    const std::string in = d / "checker.png";
    std::vector<uint8_t> px(16 * 16 * 4);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            uint8_t* p = &px[static_cast<size_t>(4 * (y * 16 + x))];
            const bool hidden_block = x >= 12 && y < 4;
            const bool red = !hidden_block && (x + y) % 2 == 0;
            p[0] = red ? 255 : 0;
            p[1] = red ? 0 : 255;
            p[2] = hidden_block ? 255 : 0;
            p[3] = red ? 255 : 0;
        }
    write_image(in, 16, 16, 4, OIIO::TypeDesc::UINT8, px.data(), {{"oiio:UnassociatedAlpha", "1"}});
    for (const Case& m : kMethods)
        for (const std::string alpha : {"associated", "unassociated"}) {
            SCOPED_TRACE(m.name + ", " + alpha);
            const std::string out = d / (m.name + "-" + alpha + ".exr");
            std::vector<std::string> args{"bake", in, "-o", out, "--alpha", alpha, "--mipmap"};
            args.insert(args.end(), m.args.begin(), m.args.end());
            const RunResult r = run_spectex(args);
            ASSERT_EQ(r.status, 0) << r.err;
            const std::vector<Level> levels = read_levels(out);
            ASSERT_EQ(levels.size(), 5u);
            const size_t bins = levels[0].names.size();
            const std::vector<double> step = steps(read_exr(out), bins);
            const bool assoc = alpha == "associated";
            WorstGap worst;
            size_t seen = 0;
            for (size_t l = 1; l < levels.size(); ++l) {
                const Level& lv = levels[l];
                for (size_t i = 0; i < lv.alpha.size(); ++i) {
                    const double a = lv.alpha[i];
                    if (!(a > 0)) continue;
                    ++seen;
                    for (size_t k = 0; k < bins; ++k) {
                        const double v = lv.spectra[k][i] / (assoc ? a : 1.0);
                        const double ref = levels[0].spectra[k][0];  // pixel (0, 0): opaque red
                        const double gap = gap_beyond_rounding(v, ref, step[k], a, assoc);
                        worst.see(gap, [&] {
                            return lv.names[k] + " level " + std::to_string(l) + " texel " +
                                   std::to_string(i) + ": " + std::to_string(v) +
                                   " against red's " + std::to_string(ref) + ", A " +
                                   std::to_string(a);
                        });
                    }
                }
            }
            EXPECT_GT(seen, 50u);
            EXPECT_LE(worst.gap, 0.0) << "a hidden colour bled in: " << worst.at;
        }
}

// A file whose spectra are not premultiplied but says they are (as a bake that expanded A·rgb
// leaves T/A above 1): verify's range gate divides by A and fails it.
TEST(AlphaSpectra, VerifyFailsStraightSamplesAboveOneOnceDividedByAlpha) {
    ScratchDir d;
    const std::string in = d / "rgba.png";
    const std::vector<uint8_t> px = rgba_pixels();
    write_image(in, 16, 16, 4, OIIO::TypeDesc::UINT8, px.data(), {{"oiio:UnassociatedAlpha", "1"}});
    const std::string out = d / "straight.exr";
    const RunResult b =
        run_spectex({"bake", in, "-o", out, "--alpha", "unassociated", "--method", "lattice"});
    ASSERT_EQ(b.status, 0) << b.err;
    const RunResult ok = run_spectex({"verify", out});
    EXPECT_EQ(ok.status, 0) << "straight spectra stored as such are within [0, 1]: " << ok.out
                            << ok.err;
    // Without spectex:alpha the file reads as associated (OpenEXR's convention).
    hide_attributes(out, {"spectex:alpha"});
    const RunResult v = run_spectex({"verify", out});
    EXPECT_NE(v.status, 0) << v.out;
    EXPECT_TRUE(has_text(v.out + v.err,
                         "samples divided by A outside [0, 1] by more than their "
                         "rounding"))
        << v.out << v.err;
    EXPECT_TRUE(has_text(v.out, "T/A outside [0, 1]")) << v.out;
}

// Every 8-bit code re-encodes from T/A whatever its alpha, as it does opaque: the colour-aware
// rounding holds the colour divided by A (what verify, a renderer and a compositor read back),
// and spectra are multiplied by the alpha the file stores (its half), not by the float one. Held
// to 6.1e-5 of the premultiplied colour instead, a pixel at A = 1/255 kept its colour to 0.016 once
// divided: the default bake lost codes up to A = 94/255 (0,255,0 came back 0,255,1) and failed
// its own verify. Rows: colours with channels at 0, near 0 and near 255 (where a code is nearest
// the next one in linear terms), and mid greys; columns: every alpha 1..255.
TEST(AlphaSpectra, EveryCodeReEncodesWhateverItsAlpha) {
    ScratchDir d;
    const int levels[] = {0, 1, 4, 6, 60, 128, 200, 254, 255};
    std::vector<std::array<int, 3>> colours;
    for (int r : levels)
        for (int g : levels)
            for (int b : {0, 3, 255}) colours.push_back({r, g, b});
    const int w = 255, h = static_cast<int>(colours.size());
    std::vector<uint8_t> px(static_cast<size_t>(w * h * 4));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            uint8_t* p = &px[static_cast<size_t>(4 * (y * w + x))];
            for (int c = 0; c < 3; ++c) p[c] = static_cast<uint8_t>(colours[size_t(y)][size_t(c)]);
            p[3] = static_cast<uint8_t>(x + 1);
        }
    const std::string in = d / "alphas.png";
    write_image(in, w, h, 4, OIIO::TypeDesc::UINT8, px.data(), {{"oiio:UnassociatedAlpha", "1"}});
    const std::vector<std::vector<std::string>> bakes = {
        {},                       // the default: lattice, precision budget, associated
        {"--mipmap"},             // its level 0 through the MIP path
        {"--precision", "full"},  // every bit
        {"--method", "basis"},    // a linear method
        {"--alpha", "unassociated"},
    };
    for (const auto& opts : bakes) {
        std::string what = "bake";
        for (const auto& o : opts) what += " " + o;
        SCOPED_TRACE(what);
        const std::string out = d / "out.exr";
        std::vector<std::string> args{"bake", in, "-o", out, "-q"};
        args.insert(args.end(), opts.begin(), opts.end());
        const RunResult b = run_spectex(args);
        ASSERT_EQ(b.status, 0) << b.err;
        const RunResult v = run_spectex({"verify", out, "--source", in});
        EXPECT_EQ(v.status, 0) << v.out << v.err;
        EXPECT_TRUE(has_text(v.out, "code match:           100% (")) << v.out;
    }
}
