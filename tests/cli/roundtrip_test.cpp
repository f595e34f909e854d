// Round trip: sRGB codes -> spectex bake -> spectral EXR -> independent integration under D65 with
// CIE 1931 2° on the file's bins -> linear sRGB, compared with the IEC formula's decoding of the
// codes.
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <OpenColorIO/OpenColorIO.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "cli/cli_util.h"
#include "cli/spectral_check.h"

using namespace spectex_test;

namespace OCIO = OCIO_NAMESPACE;
namespace {

const std::string kData = SPECTEX_TEST_DATA_DIR;

struct Stats {
    uint64_t pixels = 0, over_bound = 0, code_match = 0;
    double max_err = 0, sum_err = 0, max_bound = 0;
};

// Tolerance per pixel and channel, derived rather than guessed:
//  - each bin is rounded to half: |error| <= max(|s|·2^-10, 2^-24) for half files (one ulp: the
//    default colour-error-feedback rounding may take the neighbour of the nearest half), |s|·2^-24
//    for float files; the expansion in float adds <= 4 ulps of 1 (5e-7);
//    these propagate through |rgb_weight|, whose rows sum to about 2-3;
//  - the published basis reproduces the primaries to 3.5e-8, and OCIO's sRGB curve
//    differs from the IEC formula by up to 7.6e-7: 1e-6 absolute covers both.
// Linear value of each 8-bit code through the shipped OCIO config (OCIO directly, not spectex).
std::array<double, 256> ocio_decode_table() {
    auto cfg = OCIO::Config::CreateFromFile((kData + "/spectex.ocio").c_str());
    auto cpu = cfg->getProcessor("srgb_tx", "lin_srgb")->getDefaultCPUProcessor();
    std::array<double, 256> t;
    for (int c = 0; c < 256; ++c) {
        float px[3] = {static_cast<float>(c / 255.0), 0, 0};
        cpu->applyRGB(px);
        t[c] = px[0];
    }
    return t;
}

// reference: linear value of an 8-bit code; the IEC formula unless given.
Stats check(const std::string& exr, const std::function<std::array<int, 3>(int, int)>& codes_at,
            const std::array<double, 256>* reference = nullptr, double extra_tolerance = 1e-6) {
    Imf::InputFile probe(exr.c_str());
    auto chans = spectral_channels(probe.header());
    const bool half = probe.header().channels().begin().channel().type == Imf::HALF;
    std::vector<double> lambda;
    for (auto& c : chans) lambda.push_back(c.first);
    Colorimeter col(lambda, kData);
    Stats st;
    for_each_spectrum(exr, [&](int x, int y, const std::vector<float>& s, float) {
        auto codes = codes_at(x, y);
        double rgb[3] = {0, 0, 0}, bound[3] = {extra_tolerance, extra_tolerance, extra_tolerance};
        for (size_t k = 0; k < s.size(); ++k) {
            double e = half ? std::max(std::fabs(s[k]) * std::ldexp(1.0, -10), std::ldexp(1.0, -24))
                            : std::fabs(s[k]) * std::ldexp(1.0, -24);
            e += 5e-7;
            for (int c = 0; c < 3; ++c) {
                rgb[c] += col.rgb_weight[k][c] * s[k];
                bound[c] += std::fabs(col.rgb_weight[k][c]) * e;
            }
        }
        bool ok = true, match = true;
        for (int c = 0; c < 3; ++c) {
            double want = reference ? (*reference)[codes[c]] : iec_srgb_to_linear(codes[c] / 255.0);
            double err = std::fabs(rgb[c] - want);
            st.max_err = std::max(st.max_err, err);
            st.sum_err += err;
            st.max_bound = std::max(st.max_bound, bound[c]);
            ok = ok && err <= bound[c];
            match = match && iec_linear_to_code(rgb[c]) == codes[c];
        }
        st.over_bound += !ok;
        st.code_match += match;
        ++st.pixels;
    });
    return st;
}

void write_codes_png(const std::string& path, int w, int h,
                     const std::function<std::array<int, 3>(int, int)>& f) {
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            auto c = f(x, y);
            for (int i = 0; i < 3; ++i)
                px[(static_cast<size_t>(y) * w + x) * 3 + i] = static_cast<uint8_t>(c[i]);
        }
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data(), {{"png:compressionLevel", "1"}});
}

std::array<int, 3> all_colours(int x, int y) {
    uint32_t i = static_cast<uint32_t>(y) * 4096u + static_cast<uint32_t>(x);
    return {static_cast<int>(i >> 16), static_cast<int>((i >> 8) & 255u),
            static_cast<int>(i & 255u)};
}

// A 256x256 sample spread over the whole cube (an odd multiplier visits codes far apart).
std::array<int, 3> sample_colours(int x, int y) {
    uint32_t i = (static_cast<uint32_t>(y) * 256u + static_cast<uint32_t>(x)) * 2654435761u;
    i &= 0xffffffu;
    return {static_cast<int>(i >> 16), static_cast<int>((i >> 8) & 255u),
            static_cast<int>(i & 255u)};
}

// Writes a basis CSV derived from the published one by `edit(r, g, b)` per row.
std::string edited_basis(const ScratchDir& dir, const std::string& name,
                         const std::function<void(double&, double&, double&)>& edit) {
    auto cols = read_columns(kData + "/spectral/basis_mallett2019.csv");
    std::string path = dir / name;
    std::ofstream out(path);
    out << "wavelength,r,g,b\n";
    char buf[256];
    for (size_t i = 0; i < cols[0].size(); ++i) {
        double r = cols[1][i], g = cols[2][i], b = cols[3][i];
        edit(r, g, b);
        std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g\n", cols[0][i], r, g, b);
        out << buf;
    }
    return path;
}

}  // namespace

TEST(RoundTripSlow, EveryEightBitColourHalfPublishedBasis) {
    ScratchDir dir;
    write_codes_png(dir / "all.png", 4096, 4096, all_colours);
    auto r = run_spectex({"bake", dir / "all.png", "-o", dir / "all.exr", "--compression", "none",
                          "--basis", "mallett2019"});
    ASSERT_EQ(r.status, 0) << r.err;
    Stats st = check(dir / "all.exr", all_colours);
    EXPECT_EQ(st.pixels, 16777216u);
    EXPECT_EQ(st.over_bound, 0u);
    std::printf(
        "round trip, 16777216 colours, mallett2019, half: max |err| %.3g, mean %.3g, per-pixel "
        "bound <= %.3g, "
        "8-bit codes re-encoded exactly: %llu (%.6f%%)\n",
        st.max_err, st.sum_err / (3.0 * st.pixels), st.max_bound,
        static_cast<unsigned long long>(st.code_match), 100.0 * st.code_match / st.pixels);
    // Half rounding may move a colour by one code at most in a handful of cases; not more than
    // 1e-4.
    EXPECT_GT(st.code_match, st.pixels - st.pixels / 10000);
}

TEST(RoundTripSlow, EveryEightBitColourHalfFittedBasis) {
    // The default: fitted basis, half. Every pixel within its derived half-rounding bound (the
    // basis itself is exact; the extra 1e-6 covers OCIO's curve against the IEC formula).
    ScratchDir dir;
    write_codes_png(dir / "all.png", 4096, 4096, all_colours);
    auto r = run_spectex({"bake", dir / "all.png", "-o", dir / "all.exr", "--compression", "none"});
    ASSERT_EQ(r.status, 0) << r.err;
    Stats st = check(dir / "all.exr", all_colours);
    std::printf(
        "round trip, 16777216 colours, fitted smooth basis, half: max |err| %.3g, mean %.3g, bound "
        "<= %.3g, "
        "codes exact: %llu of %llu\n",
        st.max_err, st.sum_err / (3.0 * st.pixels), st.max_bound,
        static_cast<unsigned long long>(st.code_match), static_cast<unsigned long long>(st.pixels));
    EXPECT_EQ(st.over_bound, 0u);
    // Plain rounding leaves one colour of the 16,777,216 a code off; the default colour-error
    // feedback rounding keeps every one exact.
    EXPECT_EQ(st.code_match, st.pixels);
}

TEST(RoundTripSlow, EveryEightBitColourHalfNearestRoundingIsMeasured) {
    // Plain round-to-nearest, for the record: within the bound, and nearly every code exact.
    ScratchDir dir;
    write_codes_png(dir / "all.png", 4096, 4096, all_colours);
    auto r = run_spectex({"bake", dir / "all.png", "-o", dir / "all.exr", "--compression", "none",
                          "--half-rounding", "nearest"});
    ASSERT_EQ(r.status, 0) << r.err;
    Stats st = check(dir / "all.exr", all_colours);
    std::printf(
        "round trip, 16777216 colours, fitted smooth basis, half, nearest rounding: max |err| "
        "%.3g, mean %.3g, "
        "codes exact: %llu of %llu\n",
        st.max_err, st.sum_err / (3.0 * st.pixels), static_cast<unsigned long long>(st.code_match),
        static_cast<unsigned long long>(st.pixels));
    EXPECT_EQ(st.over_bound, 0u);
    EXPECT_GT(st.code_match, st.pixels - st.pixels / 10000);
}

// Bakes all 16,777,216 8-bit colours as float with `extra` options and checks every colour against
// the linear value that went in (OCIO's decoding of its code): within the float bound (see
// check(): the float rounding of each bin and of the expansion through the weights, ~3e-7), below
// 1e-6, and every code re-encoding exactly.
static void expect_every_colour_exact_in_float(const std::vector<std::string>& extra,
                                               const char* label) {
    ScratchDir dir;
    write_codes_png(dir / "all.png", 4096, 4096, all_colours);
    std::vector<std::string> args = {"bake",          dir / "all.png", "-o",     dir / "all.exr",
                                     "--compression", "none",          "--type", "float"};
    args.insert(args.end(), extra.begin(), extra.end());
    auto r = run_spectex(args);
    ASSERT_EQ(r.status, 0) << r.err;
    auto table = ocio_decode_table();
    Stats st = check(dir / "all.exr", all_colours, &table, 0.0);
    std::printf(
        "round trip, 16777216 colours, %s, float: max |err| %.3g, mean %.3g, bound <= %.3g, codes "
        "exact: "
        "%llu\n",
        label, st.max_err, st.sum_err / (3.0 * st.pixels), st.max_bound,
        static_cast<unsigned long long>(st.code_match));
    EXPECT_EQ(st.over_bound, 0u);
    EXPECT_LT(st.max_err, 1e-6);
    EXPECT_EQ(st.code_match, st.pixels);
}

TEST(RoundTripSlow, EveryEightBitColourFloatFittedBasis) {
    // The default (fitted) basis: exact to 1e-15, so no tolerance beyond the float bound.
    expect_every_colour_exact_in_float({}, "fitted smooth basis");
}

TEST(RoundTrip, SampleOfColoursFloatAndHalf) {
    ScratchDir dir;
    write_codes_png(dir / "s.png", 256, 256, sample_colours);
    for (const char* type : {"half", "float"}) {
        std::string out = dir / (std::string("s_") + type + ".exr");
        auto r = run_spectex(
            {"bake", dir / "s.png", "-o", out, "--type", type, "--basis", "mallett2019"});
        ASSERT_EQ(r.status, 0) << r.err;
        Stats st = check(out, sample_colours);
        EXPECT_EQ(st.over_bound, 0u) << type << " max err " << st.max_err;
        if (std::string(type) == "float") {
            // Float: the published basis (3.5e-8) + OCIO vs IEC (7.6e-7) + float arithmetic.
            EXPECT_LT(st.max_err, 1.5e-6);
            EXPECT_EQ(st.code_match, st.pixels);
        }
    }
}

TEST(RoundTrip, CheckFailsWhenTheBasisIsPerturbedOrSwapped) {
    ScratchDir dir;
    write_codes_png(dir / "s.png", 256, 256, sample_colours);
    auto perturbed = edited_basis(dir, "p.csv", [](double& r, double&, double&) { r *= 1.01; });
    auto swapped =
        edited_basis(dir, "w.csv", [](double& r, double&, double& b) { std::swap(r, b); });
    for (const auto& basis : {perturbed, swapped}) {
        auto r = run_spectex({"bake", dir / "s.png", "-o", dir / "bad.exr", "--basis", basis});
        ASSERT_EQ(r.status, 0) << r.err;
        Stats st = check(dir / "bad.exr", sample_colours);
        EXPECT_GT(st.over_bound, st.pixels / 2) << basis;
    }
}

TEST(RoundTrip, CheckFailsWhenAChannelIsDropped) {
    ScratchDir dir;
    write_codes_png(dir / "s.png", 256, 256, sample_colours);
    ASSERT_EQ(run_spectex({"bake", dir / "s.png", "-o", dir / "ok.exr", "--type", "float",
                           "--basis", "mallett2019"})
                  .status,
              0);
    ASSERT_EQ(check(dir / "ok.exr", sample_colours).over_bound, 0u);
    // Copy every channel but T.550nm with OpenEXR.
    Imf::InputFile in((dir / "ok.exr").c_str());
    Imf::Header h = in.header();
    Imf::Header h2(h.displayWindow(), h.dataWindow());
    auto chans = spectral_channels(h);
    const int w = 256, hgt = 256;
    std::vector<std::vector<float>> planes;
    Imf::FrameBuffer fb_in, fb_out;
    for (auto& c : chans) {
        planes.emplace_back(static_cast<size_t>(w) * hgt);
        fb_in.insert(c.second, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(planes.back().data()),
                                          4, 4 * w));
        if (c.second != "T.550nm") {
            h2.channels().insert(c.second, Imf::Channel(Imf::FLOAT));
            fb_out.insert(
                c.second,
                Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(planes.back().data()), 4, 4 * w));
        }
    }
    in.setFrameBuffer(fb_in);
    in.readPixels(0, hgt - 1);
    {
        Imf::OutputFile out((dir / "dropped.exr").c_str(), h2);
        out.setFrameBuffer(fb_out);
        out.writePixels(hgt);
    }
    Stats st = check(dir / "dropped.exr", sample_colours);
    EXPECT_GT(st.over_bound, st.pixels / 2);
}

// ---------------------------------------------------------------------------------------------
// The lattice method: exact under D65 by construction (the barycentric weights
// reproduce the RGB), so the same bounds hold as for the fitted basis; Jakob-Hanika is not exact
// and is measured, never hidden.

TEST(RoundTripSlow, EveryEightBitColourHalfLattice) {
    ScratchDir dir;
    write_codes_png(dir / "all.png", 4096, 4096, all_colours);
    auto r = run_spectex({"bake", dir / "all.png", "-o", dir / "all.exr", "--compression", "none",
                          "--method", "lattice"});
    ASSERT_EQ(r.status, 0) << r.err;
    Stats st = check(dir / "all.exr", all_colours);
    std::printf(
        "round trip, 16777216 colours, lattice 9 (jakob-hanika prior), half: max |err| %.3g, mean "
        "%.3g, "
        "bound <= %.3g, codes exact: %llu of %llu\n",
        st.max_err, st.sum_err / (3.0 * st.pixels), st.max_bound,
        static_cast<unsigned long long>(st.code_match), static_cast<unsigned long long>(st.pixels));
    EXPECT_EQ(st.over_bound, 0u);
    EXPECT_EQ(st.code_match, st.pixels);  // the colour-aware rounding works on any method's spectra
}

TEST(RoundTripSlow, EveryEightBitColourTheDefaultAsItShips) {
    // The default bake with nothing asked: 31 bins, its shipped bits (coarser grids in most bins,
    // each colour held to 2^-10 of its value or 6.1e-5), zip. Every 8-bit code must re-encode; the
    // tests above bake with --compression none, where the default keeps every bit.
    ScratchDir dir;
    write_codes_png(dir / "all.png", 4096, 4096, all_colours);
    auto r = run_spectex({"bake", dir / "all.png", "-o", dir / "all.exr", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    Imf::InputFile probe((dir / "all.exr").c_str());
    const auto* bits_attr =
        probe.header().findTypedAttribute<Imf::StringAttribute>("spectex:precisionBits");
    ASSERT_NE(bits_attr, nullptr);
    const std::string bits = bits_attr->value();
    ASSERT_NE(bits.find_first_of("456789"), std::string::npos) << "no coarse bin: " << bits;
    Stats st = check(dir / "all.exr", all_colours);
    std::printf(
        "round trip, 16777216 colours, the default (bits %s): max |err| %.3g, mean %.3g, "
        "codes exact: %llu of %llu\n",
        bits.c_str(), st.max_err, st.sum_err / (3.0 * st.pixels),
        static_cast<unsigned long long>(st.code_match), static_cast<unsigned long long>(st.pixels));
    EXPECT_EQ(st.pixels, 16777216u);
    EXPECT_EQ(st.code_match, st.pixels);
    // 2^-10 of the brightest channel (1.0), with float's margin.
    EXPECT_LE(st.max_err, std::ldexp(1.0, -10) * 1.001);
}

TEST(RoundTripSlow, EveryEightBitColourFloatLattice) {
    // The vertex spectra are exact to 2e-15 in double; the float table (rounding of each vertex
    // value, 6e-8 relative) and the float interpolation stay inside the float bound.
    expect_every_colour_exact_in_float({"--method", "lattice"}, "lattice 9");
}

TEST(RoundTripSlow, LatticeSamplesExactOnOtherGridsObserversAndSizes) {
    // Sizes, priors, a 1 nm grid and a coarse one, CIE 1964 10° and illuminant A: every pixel of a
    // cube-wide sample inside the float bound of its conditions' own colorimetry.
    ScratchDir dir;
    write_codes_png(dir / "s.png", 256, 256, sample_colours);
    const std::vector<std::vector<std::string>> cases = {
        {"--lattice-size", "5"},
        {"--lattice-size", "17", "--vertex-prior", "smooth"},
        {"--vertex-prior", "blend"},
        {"--wavelengths", "360:830:1"},
        {"--wavelengths", "380:780:20"},
        {"--vertex-prior", "lhtss"},
        {"--vertex-prior", "lhtss", "--wavelengths", "380:780:20"},
    };
    auto table = ocio_decode_table();
    for (const auto& extra : cases) {
        std::vector<std::string> args = {"bake",   dir / "s.png", "-o",       dir / "s.exr",
                                         "--type", "float",       "--method", "lattice"};
        args.insert(args.end(), extra.begin(), extra.end());
        auto r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << extra.back() << ": " << r.err;
        Stats st = check(dir / "s.exr", sample_colours, &table, 0.0);
        EXPECT_EQ(st.over_bound, 0u) << extra.back() << ": max err " << st.max_err;
        EXPECT_EQ(st.code_match, st.pixels) << extra.back();
    }
}

TEST(RoundTripSlow, JakobHanikaIsMeasuredNotExact) {
    // Plain Jakob-Hanika spectra do not reproduce every colour: the residual is there to be seen
    // (the header says so too), so this test pins that it is small but not zero.
    ScratchDir dir;
    write_codes_png(dir / "s.png", 256, 256, sample_colours);
    auto r = run_spectex({"bake", dir / "s.png", "-o", dir / "s.exr", "--type", "float", "--method",
                          "jakob-hanika"});
    ASSERT_EQ(r.status, 0) << r.err;
    auto table = ocio_decode_table();
    Stats st = check(dir / "s.exr", sample_colours, &table, 0.0);
    std::printf(
        "jakob-hanika, 65536 sampled colours, float: max |err| %.3g, mean %.3g, codes exact %llu "
        "of %llu\n",
        st.max_err, st.sum_err / (3.0 * st.pixels), static_cast<unsigned long long>(st.code_match),
        static_cast<unsigned long long>(st.pixels));
    EXPECT_GT(st.over_bound, 0u);
    EXPECT_LT(st.max_err,
              0.05);  // the table's interpolation error: 0.0077 max between nodes at res 33
}
