// End-to-end tests of `spectex bake` on small generated inputs of every kind it reads (PNG 8/16
// bit, grey, grey+alpha, RGBA, float EXR, tiled TIFF, JPEG, TGA, odd sizes, data windows), with the
// output read back through OpenEXR's own C++ API and compared with spectra computed here,
// independently of spectex's code: the basis comes from config/spectral/basis_mallett2019.csv
// read by a small parser, the linearisation from the IEC 61966-2-1 sRGB formula.
//
// Tolerances (see spectral_tol):
//  - OCIO's sRGB curve differs from the IEC formula by up to 7.6e-7 absolute (kOcioVsIec);
//  - spectex works in single precision (8/16-bit -> float conversion, alpha products, the
//    3-term expansion with float basis coefficients): below 5e-7 absolute for values <= 1
//    (kFloatArith);
//  - the basis functions are non-negative, so an absolute error d on linear r, g, b gives at most
//    d * (S_r + S_g + S_b) on a bin;
//  - half output has 10 stored mantissa bits; the default colour-feedback rounding takes the
//    nearest half or its neighbour, so at most one ulp: 2^-10 relative error (kHalfRel), and 2^-24
//    absolute in the subnormal range.
#include <ImfOutputFile.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

constexpr double kOcioVsIec = 7.6e-7;
constexpr double kFloatArith = 5e-7;
constexpr double kHalfRel = 1.0 / 1024.0;          // 2^-10
constexpr double kHalfSubnormal = 1.0 / 16777216;  // 2^-24

using Rgb = std::array<double, 3>;

// Largest error allowed on a bin whose exact value is `e`: `lin_err` on each linear component
// (through basis coefficients summing to `coeff_sum`), single-precision arithmetic, then, for half
// output, rounding to half.
double spectral_tol(double e, double coeff_sum, double lin_err, bool half) {
    double d = lin_err * std::max(1.0, coeff_sum) + kFloatArith;
    return half ? kHalfRel * (std::fabs(e) + d) + d + kHalfSubnormal : d;
}

double srgb8(int v) { return srgb_to_linear(v / 255.0); }
double srgb16(int v) { return srgb_to_linear(v / 65535.0); }

// Runs `spectex bake in -o out --basis mallett2019 extra...` (the expected spectra below are built
// from the published table), throws (a test failure) unless it succeeds, reads the output.
ExrImage bake_and_read(const std::string& in, const std::string& out,
                       const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args{"bake", in, "-o", out, "--basis", "mallett2019"};
    args.insert(args.end(), extra.begin(), extra.end());
    RunResult r = run_spectex(args);
    if (r.status != 0)
        throw std::runtime_error("spectex bake " + in + " failed with status " +
                                 std::to_string(r.status) + ": " + r.err);
    return read_exr(out);
}

// Every T channel of every pixel against expected_spectrum(lin(x, y)) within spectral_tol.
// lin(x, y) gives the exact linear (r, g, b) that spectex should expand at data-window pixel (x,
// y), already multiplied by alpha when the output is associated.
::testing::AssertionResult spectra_match(const ExrImage& img,
                                         const std::function<Rgb(int, int)>& lin, double lin_err,
                                         bool half) {
    const TestBasis& basis = mallett_basis();
    auto chans = spectral_channels(img);
    if (chans.size() != basis.lambda.size())
        return ::testing::AssertionFailure()
               << chans.size() << " spectral channels, expected " << basis.lambda.size();
    int failures = 0;
    std::ostringstream msg;
    double worst = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            Rgb c = lin(x, y);
            std::vector<double> e = expected_spectrum(c[0], c[1], c[2]);
            for (size_t k = 0; k < chans.size(); ++k) {
                double got = img.at(chans[k].second, x, y);
                double tol =
                    spectral_tol(e[k], basis.r[k] + basis.g[k] + basis.b[k], lin_err, half);
                double err = std::fabs(got - e[k]);
                worst = std::max(worst, err / tol);
                if (!(err <= tol) && ++failures <= 5)
                    msg << "\n  pixel (" << x << ", " << y << ") " << chans[k].second << ": got "
                        << got << ", expected " << e[k] << " +- " << tol;
            }
        }
    if (failures)
        return ::testing::AssertionFailure()
               << failures << " samples out of tolerance:" << msg.str();
    return ::testing::AssertionSuccess() << "worst error " << worst << " of the tolerance";
}

void expect_spectral_type(const ExrImage& img, Imf::PixelType type) {
    for (const auto& [l, name] : spectral_channels(img))
        EXPECT_EQ(img.types.at(name), type) << name;
}

// Reads an 8- or 16-bit image back as stored (alpha not touched), to check the test's own input.
std::vector<int> read_stored(const std::string& path, OIIO::TypeDesc type) {
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) throw std::runtime_error("cannot reopen " + path + ": " + OIIO::geterror());
    const auto& s = in->spec();
    size_t n = static_cast<size_t>(s.width) * static_cast<size_t>(s.height) *
               static_cast<size_t>(s.nchannels);
    std::vector<int> v(n);
    if (type == OIIO::TypeDesc::UINT8) {
        std::vector<uint8_t> b(n);
        in->read_image(0, 0, 0, s.nchannels, type, b.data());
        for (size_t i = 0; i < n; ++i) v[i] = b[i];
    } else {
        std::vector<uint16_t> b(n);
        in->read_image(0, 0, 0, s.nchannels, type, b.data());
        for (size_t i = 0; i < n; ++i) v[i] = b[i];
    }
    in->close();
    return v;
}

// An 8-bit RGB test pattern: covers 0, 255, the linear toe (< 11) and everything in between.
std::vector<uint8_t> pattern8(int w, int h, int nch = 3) {
    std::vector<uint8_t> px(static_cast<size_t>(w) * static_cast<size_t>(h) *
                            static_cast<size_t>(nch));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < nch; ++c) {
                int i = (y * w + x) * nch + c;
                px[static_cast<size_t>(i)] =
                    static_cast<uint8_t>((37 * x + 91 * y + 73 * c + 5 * x * y) % 256);
            }
    if (!px.empty()) px[0] = 0;
    if (px.size() > 1) px[1] = 255;
    if (px.size() > 2) px[2] = 7;
    return px;
}

std::function<Rgb(int, int)> srgb8_lookup(const std::vector<uint8_t>& px, int w, int nch = 3) {
    return [&px, w, nch](int x, int y) {
        size_t i = static_cast<size_t>((y * w + x) * nch);
        return Rgb{srgb8(px[i]), srgb8(px[i + 1]), srgb8(px[i + 2])};
    };
}

// Every channel of two images bit for bit (as floats converted from the stored values).
void expect_same_pixels(const ExrImage& a, const ExrImage& b) {
    ASSERT_EQ(a.channel_names, b.channel_names);
    ASSERT_EQ(a.width, b.width);
    ASSERT_EQ(a.height, b.height);
    for (const auto& n : a.channel_names) {
        EXPECT_EQ(a.types.at(n), b.types.at(n)) << n;
        EXPECT_EQ(a.pixels.at(n), b.pixels.at(n)) << n;
    }
}

// Writes a float RGB OpenEXR with the given data and display windows (OpenEXR directly: the
// cli_util writer has no windows). pixel(x, y) gets absolute coordinates.
void write_windowed_exr(const std::string& path, const Imath::Box2i& display,
                        const Imath::Box2i& data, const std::function<Rgb(int, int)>& pixel) {
    Imf::Header h(display, data);
    for (const char* c : {"R", "G", "B"}) h.channels().insert(c, Imf::Channel(Imf::FLOAT));
    const int w = data.max.x - data.min.x + 1, ht = data.max.y - data.min.y + 1;
    std::vector<float> p[3];
    for (auto& v : p) v.resize(static_cast<size_t>(w * ht));
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x) {
            Rgb c = pixel(data.min.x + x, data.min.y + y);
            for (int k = 0; k < 3; ++k)
                p[k][static_cast<size_t>(y * w + x)] = static_cast<float>(c[k]);
        }
    Imf::OutputFile out(path.c_str(), h);
    Imf::FrameBuffer fb;
    const char* names[3] = {"R", "G", "B"};
    for (int k = 0; k < 3; ++k) {
        char* base = reinterpret_cast<char*>(p[k].data() -
                                             (static_cast<ptrdiff_t>(data.min.y) * w + data.min.x));
        fb.insert(names[k], Imf::Slice(Imf::FLOAT, base, sizeof(float),
                                       sizeof(float) * static_cast<size_t>(w)));
    }
    out.setFrameBuffer(fb);
    out.writePixels(ht);
}

// A linear value in [0, 1] that float holds exactly (k/1024).
double lin_pattern(int x, int y, int c) { return ((x * 131 + y * 71 + c * 311) % 1025) / 1024.0; }

}  // namespace

// ---------------------------------------------------------------------------------------------

TEST(BakeInputs, Rgb8Png) {
    ScratchDir d;
    const int w = 5, h = 4;
    auto px = pattern8(w, h);
    write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    ExrImage img = bake_and_read(d / "in.png", d / "out.exr");
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.height, h);
    EXPECT_EQ(img.channel_names.size(), 81u) << "only the T channels by default (no A, no preview)";
    EXPECT_FALSE(img.has("A"));
    EXPECT_FALSE(img.has("R"));
    expect_spectral_type(img, Imf::HALF);
    EXPECT_EQ(img.attr("spectex:inputColorSpace"), "sRGB - Texture");
    EXPECT_TRUE(spectra_match(img, srgb8_lookup(px, w), kOcioVsIec, true));
}

TEST(BakeInputs, HeaderAttributesAndChannelNames) {
    ScratchDir d;
    auto px = pattern8(3, 2);
    std::string in = d / "in.png";
    write_image(in, 3, 2, 3, OIIO::TypeDesc::UINT8, px.data());
    ExrImage img = bake_and_read(in, d / "out.exr");

    // Channel names parse back to 380, 385, ..., 780 nm.
    auto chans = spectral_channels(img);
    ASSERT_EQ(chans.size(), 81u);
    for (size_t k = 0; k < chans.size(); ++k)
        EXPECT_EQ(chans[k].first, 380.0 + 5.0 * static_cast<double>(k));
    EXPECT_EQ(chans.front().second, "T.380nm");
    EXPECT_EQ(chans.back().second, "T.780nm");

    EXPECT_EQ(img.attr("spectralLayoutVersion"), "1.0");
    RunResult v = run_spectex({"--version"});
    ASSERT_EQ(v.status, 0);
    std::string version = v.out.substr(8);  // "spectex X.Y.Z\n"
    while (!version.empty() && version.back() == '\n') version.pop_back();
    EXPECT_EQ(img.attr("spectex:version"), version);
    EXPECT_EQ(img.attr("spectex:basis"), "mallett2019");
    EXPECT_EQ(img.attr("spectex:basisChecksum"), basis_fnv1a64(mallett_basis()));
    EXPECT_EQ(img.attr("spectex:wavelengths"), "380:780:5");
    EXPECT_EQ(img.attr("spectex:observer"), "cie1931-2");
    EXPECT_EQ(img.attr("spectex:illuminant"), "D65");
    EXPECT_EQ(img.attr("spectex:inputColorSpace"), "sRGB - Texture");
    const std::string cl = img.attr("spectex:commandLine");
    EXPECT_EQ(cl.rfind("spectex bake ", 0), 0u) << cl;
    EXPECT_NE(cl.find(in), std::string::npos) << cl;
    EXPECT_NE(cl.find(d / "out.exr"), std::string::npos) << cl;
}

TEST(BakeInputs, Rgba16PngAlphaIsExactFloat) {
    ScratchDir d;
    const int w = 3, h = 2;
    // R, G, B, A per pixel.
    std::vector<uint16_t> px = {
        0,     65535, 1000,  65535,  //
        65535, 30000, 12,    32768,  //
        40000, 20000, 50000, 1,      //
        123,   4567,  65000, 12345,  //
        65535, 65535, 65535, 65534,  //
        9999,  22222, 33333, 40000,
    };
    std::string in = d / "in16.png";
    write_image(in, w, h, 4, OIIO::TypeDesc::UINT16, px.data(), {{"oiio:UnassociatedAlpha", "1"}});
    ASSERT_EQ(read_stored(in, OIIO::TypeDesc::UINT16), std::vector<int>(px.begin(), px.end()))
        << "test input not stored as written";
    ExrImage img = bake_and_read(in, d / "out.exr");
    ASSERT_TRUE(img.has("A"));
    EXPECT_EQ(img.types.at("A"), Imf::FLOAT) << "a 16-bit alpha does not fit in half";
    expect_spectral_type(img, Imf::HALF);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            int a = px[static_cast<size_t>((y * w + x) * 4 + 3)];
            EXPECT_EQ(img.at("A", x, y), static_cast<float>(a) / 65535.0f)
                << "alpha " << a << " at " << x << "," << y;
        }
    // Associated (the default): spectrum of the straight colour times alpha.
    EXPECT_TRUE(spectra_match(
        img,
        [&](int x, int y) {
            const uint16_t* p = &px[static_cast<size_t>((y * w + x) * 4)];
            double a = p[3] / 65535.0;
            return Rgb{a * srgb16(p[0]), a * srgb16(p[1]), a * srgb16(p[2])};
        },
        kOcioVsIec, true));
}

TEST(BakeInputs, Grey8PngExpandsToRgb) {
    ScratchDir d;
    std::vector<uint8_t> grey = {0, 5, 10, 11, 64, 128, 200, 254, 255};
    const int w = 3, h = 3;
    std::vector<uint8_t> rgb;
    for (uint8_t v : grey) rgb.insert(rgb.end(), {v, v, v});
    write_image(d / "grey.png", w, h, 1, OIIO::TypeDesc::UINT8, grey.data());
    write_image(d / "rgb.png", w, h, 3, OIIO::TypeDesc::UINT8, rgb.data());
    ExrImage g = bake_and_read(d / "grey.png", d / "grey.exr");
    ExrImage c = bake_and_read(d / "rgb.png", d / "rgb.exr");
    EXPECT_FALSE(g.has("A"));
    expect_same_pixels(g, c);
    EXPECT_TRUE(spectra_match(
        g,
        [&](int x, int y) {
            double v = srgb8(grey[static_cast<size_t>(y * w + x)]);
            return Rgb{v, v, v};
        },
        kOcioVsIec, true));
}

TEST(BakeInputs, GreyAlpha8PngExpandsToRgba) {
    ScratchDir d;
    const int w = 4, h = 2;
    std::vector<uint8_t> ga = {0,   255, 5,   128, 64,  1,   128, 0,
                               200, 77,  254, 254, 255, 255, 100, 200};
    std::vector<uint8_t> rgba;
    for (size_t i = 0; i < ga.size(); i += 2)
        rgba.insert(rgba.end(), {ga[i], ga[i], ga[i], ga[i + 1]});
    write_image(d / "ga.png", w, h, 2, OIIO::TypeDesc::UINT8, ga.data(),
                {{"oiio:UnassociatedAlpha", "1"}});
    write_image(d / "rgba.png", w, h, 4, OIIO::TypeDesc::UINT8, rgba.data(),
                {{"oiio:UnassociatedAlpha", "1"}});
    ASSERT_EQ(read_stored(d / "ga.png", OIIO::TypeDesc::UINT8),
              std::vector<int>(ga.begin(), ga.end()));
    ASSERT_EQ(read_stored(d / "rgba.png", OIIO::TypeDesc::UINT8),
              std::vector<int>(rgba.begin(), rgba.end()));
    ExrImage g = bake_and_read(d / "ga.png", d / "ga.exr");
    ExrImage c = bake_and_read(d / "rgba.png", d / "rgba.exr");
    ASSERT_TRUE(g.has("A"));
    EXPECT_EQ(g.types.at("A"), Imf::HALF);
    expect_same_pixels(g, c);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            EXPECT_EQ(std::lround(g.at("A", x, y) * 255.0),
                      ga[static_cast<size_t>((y * w + x) * 2 + 1)]);
    EXPECT_TRUE(spectra_match(
        g,
        [&](int x, int y) {
            const uint8_t* p = &ga[static_cast<size_t>((y * w + x) * 2)];
            double v = (p[1] / 255.0) * srgb8(p[0]);
            return Rgb{v, v, v};
        },
        kOcioVsIec, true));
}

TEST(BakeInputs, FloatRgbExrIsLinear) {
    ScratchDir d;
    const int w = 6, h = 5;
    std::vector<float> px(static_cast<size_t>(w * h * 3));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                px[static_cast<size_t>((y * w + x) * 3 + c)] =
                    static_cast<float>(lin_pattern(x, y, c));
    write_image(d / "lin.exr", w, h, 3, OIIO::TypeDesc::FLOAT, px.data());
    auto lookup = [&](int x, int y) {
        const float* p = &px[static_cast<size_t>((y * w + x) * 3)];
        return Rgb{p[0], p[1], p[2]};
    };
    // The shipped config's file rules make *.exr linear Rec.709: no transfer function, so the
    // only errors are the float expansion and (for the default half output) half rounding.
    ExrImage img = bake_and_read(d / "lin.exr", d / "half.exr");
    EXPECT_EQ(img.attr("spectex:inputColorSpace"), "Linear Rec.709 (sRGB)");
    EXPECT_TRUE(spectra_match(img, lookup, 0.0, true));
    ExrImage f = bake_and_read(d / "lin.exr", d / "float.exr", {"--type", "float"});
    expect_spectral_type(f, Imf::FLOAT);
    EXPECT_TRUE(spectra_match(f, lookup, 0.0, false));
}

namespace {

// Bakes a tiled input (tiles of 16, a size that is not a multiple of it) and checks the result.
void check_tiled_input(const std::string& ext, OIIO::TypeDesc format, bool srgb) {
    ScratchDir d;
    const int w = 40, h = 21;
    auto px = pattern8(w, h);
    std::string in = d / ("in." + ext), out = d / "out.exr";
    if (format == OIIO::TypeDesc::UINT8) {
        write_image(in, w, h, 3, format, px.data(), {}, 16);
    } else {
        std::vector<float> f(px.begin(), px.end());
        for (auto& v : f) v /= 255.0f;
        write_image(in, w, h, 3, format, f.data(), {}, 16);
    }
    {
        auto src = OIIO::ImageInput::open(in);
        ASSERT_TRUE(src);
        ASSERT_EQ(src->spec().tile_width, 16) << "test input is not tiled";
    }
    RunResult r = run_spectex({"bake", in, "-o", out, "--basis", "mallett2019"});
    EXPECT_EQ(r.status, 0) << "spectex bake " << in << " -o " << out << " (a tiled " << ext
                           << "): status " << r.status
                           << (r.status > 128 ? " (killed by a signal)" : "")
                           << ", stderr: " << r.err;
    EXPECT_TRUE(temp_files_in(d.path()).empty())
        << "temporary file left behind: " << temp_files_in(d.path()).front();
    if (r.status != 0) return;
    ExrImage img = read_exr(out);
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.height, h);
    if (srgb) {
        EXPECT_EQ(img.attr("spectex:inputColorSpace"), "sRGB - Texture");
        EXPECT_TRUE(spectra_match(img, srgb8_lookup(px, w), kOcioVsIec, true));
    } else {
        EXPECT_EQ(img.attr("spectex:inputColorSpace"), "Linear Rec.709 (sRGB)");
        // The input holds float(v) / 255 exactly: only expansion and half rounding errors.
        EXPECT_TRUE(spectra_match(
            img,
            [&](int x, int y) {
                const uint8_t* p = &px[static_cast<size_t>((y * w + x) * 3)];
                return Rgb{p[0] / 255.0f, p[1] / 255.0f, p[2] / 255.0f};
            },
            0.0, true));
    }
}

}  // namespace

TEST(BakeInputs, TiledTiff) { check_tiled_input("tif", OIIO::TypeDesc::UINT8, true); }

TEST(BakeInputs, TiledExr) { check_tiled_input("exr", OIIO::TypeDesc::FLOAT, false); }

TEST(BakeInputs, Jpeg) {
    ScratchDir d;
    const int w = 16, h = 8;
    std::vector<uint8_t> px(static_cast<size_t>(w * h * 3));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            uint8_t* p = &px[static_cast<size_t>((y * w + x) * 3)];
            p[0] = static_cast<uint8_t>(16 * x);
            p[1] = static_cast<uint8_t>(30 * y);
            p[2] = 128;
        }
    write_image(d / "in.jpg", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    // JPEG is lossy: the expectation is built from the decoded pixels.
    std::vector<int> decoded = read_stored(d / "in.jpg", OIIO::TypeDesc::UINT8);
    ASSERT_EQ(decoded.size(), px.size());
    ExrImage img = bake_and_read(d / "in.jpg", d / "out.exr");
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.height, h);
    EXPECT_EQ(img.attr("spectex:inputColorSpace"), "sRGB - Texture");
    EXPECT_TRUE(spectra_match(
        img,
        [&](int x, int y) {
            const int* p = &decoded[static_cast<size_t>((y * w + x) * 3)];
            return Rgb{srgb8(p[0]), srgb8(p[1]), srgb8(p[2])};
        },
        kOcioVsIec, true));
}

TEST(BakeInputs, Tga) {
    ScratchDir d;
    const int w = 7, h = 5;
    auto px = pattern8(w, h);
    write_image(d / "in.tga", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    ASSERT_EQ(read_stored(d / "in.tga", OIIO::TypeDesc::UINT8),
              std::vector<int>(px.begin(), px.end()));
    ExrImage img = bake_and_read(d / "in.tga", d / "out.exr");
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.height, h);
    EXPECT_TRUE(spectra_match(img, srgb8_lookup(px, w), kOcioVsIec, true));
}

TEST(BakeInputs, DataWindowDiffersFromDisplayWindow) {
    struct Case {
        Imath::Box2i display, data;
    };
    const Case cases[] = {
        {Imath::Box2i({0, 0}, {9, 7}), Imath::Box2i({3, 2}, {7, 5})},  // inside the display window
        {Imath::Box2i({0, 0}, {4, 3}),
         Imath::Box2i({-2, -1}, {6, 2})},  // overscan, negative origin
        {Imath::Box2i({10, 20}, {13, 22}), Imath::Box2i({11, 21}, {11, 21})},  // one pixel
    };
    for (const auto& c : cases) {
        ScratchDir d;
        auto pixel = [](int x, int y) {
            return Rgb{lin_pattern(x + 50, y + 50, 0), lin_pattern(x + 50, y + 50, 1),
                       lin_pattern(x + 50, y + 50, 2)};
        };
        write_windowed_exr(d / "in.exr", c.display, c.data, pixel);
        ExrImage img = bake_and_read(d / "in.exr", d / "out.exr", {"--type", "float"});
        EXPECT_EQ(img.data_window.min, c.data.min);
        EXPECT_EQ(img.data_window.max, c.data.max);
        EXPECT_EQ(img.display_window.min, c.display.min);
        EXPECT_EQ(img.display_window.max, c.display.max);
        // Pixels stay at their absolute coordinates.
        EXPECT_TRUE(spectra_match(
            img, [&](int x, int y) { return pixel(c.data.min.x + x, c.data.min.y + y); }, 0.0,
            false));
    }
}

TEST(BakeInputs, TinyImages) {
    for (auto [w, h] : {std::pair<int, int>{1, 1}, {1, 7}, {7, 1}}) {
        ScratchDir d;
        auto px = pattern8(w, h);
        write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
        ExrImage img = bake_and_read(d / "in.png", d / "out.exr");
        EXPECT_EQ(img.width, w);
        EXPECT_EQ(img.height, h);
        EXPECT_EQ(img.data_window.min, Imath::V2i(0, 0));
        EXPECT_EQ(img.display_window, img.data_window);
        EXPECT_TRUE(spectra_match(img, srgb8_lookup(px, w), kOcioVsIec, true)) << w << "x" << h;
    }
}

TEST(BakeInputs, Odd33x17) {
    ScratchDir d;
    const int w = 33, h = 17;
    auto px = pattern8(w, h);
    write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    for (const char* comp : {"zip", "piz"}) {  // 16- and 32-line chunks, neither divides 17
        ExrImage img =
            bake_and_read(d / "in.png", d / (std::string(comp) + ".exr"), {"--compression", comp});
        EXPECT_EQ(img.width, w);
        EXPECT_EQ(img.height, h);
        EXPECT_TRUE(spectra_match(img, srgb8_lookup(px, w), kOcioVsIec, true)) << comp;
    }
}

// ---------------------------------------------------------------------------------------------
// Alpha

namespace {

// 2x1 RGBA: (200, 100, 50, 128) and an opaque pixel.
const std::vector<uint8_t> kRgba = {200, 100, 50, 128, 10, 240, 90, 255};

std::string write_rgba8(const ScratchDir& d) {
    std::string in = d / "rgba.png";
    write_image(in, 2, 1, 4, OIIO::TypeDesc::UINT8, kRgba.data(),
                {{"oiio:UnassociatedAlpha", "1"}});
    return in;
}

}  // namespace

TEST(BakeInputs, AlphaAssociatedByDefault) {
    ScratchDir d;
    std::string in = write_rgba8(d);
    ASSERT_EQ(read_stored(in, OIIO::TypeDesc::UINT8), std::vector<int>(kRgba.begin(), kRgba.end()))
        << "test input not stored as written (straight colour)";
    ExrImage img = bake_and_read(in, d / "out.exr");
    ASSERT_TRUE(img.has("A"));
    EXPECT_EQ(img.types.at("A"), Imf::HALF) << "8-bit alpha is stored as half";
    EXPECT_EQ(std::lround(img.at("A", 0, 0) * 255.0), 128);
    EXPECT_EQ(img.at("A", 1, 0), 1.0f);
    EXPECT_EQ(img.attr("spectex:alpha"), "associated");
    // Spectral channel = alpha x spectrum of the straight colour (half precision).
    EXPECT_TRUE(spectra_match(
        img,
        [](int x, int) {
            const uint8_t* p = &kRgba[static_cast<size_t>(4 * x)];
            double a = p[3] / 255.0;
            return Rgb{a * srgb8(p[0]), a * srgb8(p[1]), a * srgb8(p[2])};
        },
        kOcioVsIec, true));
}

TEST(BakeInputs, AlphaUnassociated) {
    ScratchDir d;
    std::string in = write_rgba8(d);
    ExrImage img = bake_and_read(in, d / "out.exr", {"--alpha", "unassociated"});
    ASSERT_TRUE(img.has("A"));
    EXPECT_EQ(img.types.at("A"), Imf::HALF);
    EXPECT_EQ(std::lround(img.at("A", 0, 0) * 255.0), 128);
    EXPECT_EQ(img.attr("spectex:alpha"), "unassociated");
    EXPECT_TRUE(spectra_match(
        img,
        [](int x, int) {
            const uint8_t* p = &kRgba[static_cast<size_t>(4 * x)];
            return Rgb{srgb8(p[0]), srgb8(p[1]), srgb8(p[2])};
        },
        kOcioVsIec, true));
}

// ---------------------------------------------------------------------------------------------
// Output options

TEST(BakeInputs, TypeFloat) {
    ScratchDir d;
    const int w = 6, h = 3;
    auto px = pattern8(w, h);
    write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    ExrImage img = bake_and_read(d / "in.png", d / "out.exr", {"--type", "float"});
    expect_spectral_type(img, Imf::FLOAT);
    EXPECT_EQ(img.channel_names.size(), 81u);
    EXPECT_TRUE(spectra_match(img, srgb8_lookup(px, w), kOcioVsIec, false));
}

TEST(BakeInputs, PreviewAddsRgb) {
    ScratchDir d;
    const int w = 4, h = 3;
    auto px = pattern8(w, h);
    write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    for (const char* type : {"half", "float"}) {
        ExrImage img = bake_and_read(d / "in.png", d / (std::string(type) + ".exr"),
                                     {"--preview", "--type", type});
        const bool half = std::string(type) == "half";
        EXPECT_EQ(img.channel_names.size(), 84u);
        for (const char* c : {"R", "G", "B"}) {
            ASSERT_TRUE(img.has(c)) << c;
            EXPECT_EQ(img.types.at(c), half ? Imf::HALF : Imf::FLOAT) << c;
        }
        // The preview is the linear Rec.709 colour.
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                for (int c = 0; c < 3; ++c) {
                    double e = srgb8(px[static_cast<size_t>((y * w + x) * 3 + c)]);
                    double tol = spectral_tol(e, 1.0, kOcioVsIec, half);
                    EXPECT_NEAR(img.at(std::string(1, "RGB"[c]), x, y), e, tol)
                        << type << " " << x << "," << y;
                }
        EXPECT_TRUE(spectra_match(img, srgb8_lookup(px, w), kOcioVsIec, half)) << type;
    }
}
