// bake --precision auto end to end: the bits per bin recorded in the header and the settings hash,
// every stored value on its bin's coarser grid (but for the few pixels that needed more bits to
// hold their colour), the file smaller than full half, every 8-bit code still re-encoding under
// D65 (verify's code gate), verify and plan reporting the precision, and the usage errors. Tests
// whose bakes choose bits of their own (each several passes over the whole 8-bit cube) are in
// PrecisionSlow: the whole suite runs them, the sanitizer build not; it runs the chooser in the
// default bake's overrides and the threads test.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli/cli_util.h"
#include "cli/exr_read.h"
#include "io/provenance_keys.h"

using namespace spectex_test;
namespace key = spectex::provenance_key;

namespace {

bool has(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

// 512 x 512 pixels: every 8-bit sRGB code whose channels are multiples of 4 plus 3 (3, 7, … 255;
// 64^3 colours), in an order with no smooth runs (like a photograph's noise, not a gradient).
std::string cube_png(const ScratchDir& d) {
    std::vector<uint8_t> px(512 * 512 * 3);
    for (uint32_t i = 0; i < 512u * 512u; ++i) {
        const uint32_t j = (i * 2654435761u) & 0x3ffffu;  // a permutation of 0 .. 2^18 - 1
        px[3 * i + 0] = static_cast<uint8_t>(4 * (j >> 12) + 3);
        px[3 * i + 1] = static_cast<uint8_t>(4 * ((j >> 6) & 63) + 3);
        px[3 * i + 2] = static_cast<uint8_t>(4 * (j & 63) + 3);
    }
    const std::string path = d / "cube.png";
    write_image(path, 512, 512, 3, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

// Half code of a value read back as float (exact: every half is a float).
uint16_t half_code(float f) {
    uint32_t x;
    std::memcpy(&x, &f, 4);
    if (f == 0.0f) return static_cast<uint16_t>((x >> 16) & 0x8000u);
    const int e = static_cast<int>((x >> 23) & 0xff) - 127;
    if (e >= -14) return static_cast<uint16_t>(((e + 15) << 10) | ((x >> 13) & 0x3ffu));
    return static_cast<uint16_t>(std::lround(std::fabs(f) * 16777216.0f));  // subnormal
}

int mantissa_bits(uint16_t h) {
    uint32_t m = h & 0x7fffu;
    if (m == 0) return 0;
    int zeros = 0;
    while (zeros < 10 && !(m & 1u)) m >>= 1, ++zeros;
    return 10 - zeros;
}

std::vector<int> bits_of(const std::string& text) {
    std::istringstream in(text);
    std::vector<int> v;
    for (int b; in >> b;) v.push_back(b);
    return v;
}

uint64_t file_size(const std::string& p) {
    struct stat st;
    return ::stat(p.c_str(), &st) == 0 ? static_cast<uint64_t>(st.st_size) : 0;
}

}  // namespace

TEST(PrecisionSlow, AutoBakeKeepsTheChosenBitsRecordsThemAndStaysExactUnderD65) {
    ScratchDir d;
    const std::string png = cube_png(d), full = d / "full.exr", autob = d / "auto.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", full, "-q", "--method", "basis"}).status, 0);
    const RunResult r = run_spectex({"bake", png, "-o", autob, "--method", "basis", "--precision",
                                     "auto", "--lights", "D65,A,FL11", "--max-de", "0.5"});
    // The bits said name what they cover.
    EXPECT_TRUE(has(r.err, "on every 8-bit colour")) << r.err;
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has(r.err, "--precision auto:")) << r.err;
    const ExrImage img = read_exr(autob);
    EXPECT_EQ(img.attr(key::kPrecision), "auto");
    EXPECT_EQ(img.attr(key::kPrecisionMaxDe), "0.5");
    EXPECT_EQ(img.attr(key::kPrecisionLights), "D65,A,FL11");
    EXPECT_TRUE(has(img.attr(key::kPrecisionSample), "every 8-bit sRGB code (16777216 colours)"))
        << img.attr(key::kPrecisionSample);
    const std::vector<int> bits = bits_of(img.attr(key::kPrecisionBits));
    const auto channels = spectral_channels(img);
    ASSERT_EQ(bits.size(), channels.size());
    int total = 0;
    for (int b : bits) {
        EXPECT_GE(b, 0);
        EXPECT_LE(b, 10);
        total += b;
    }
    EXPECT_LT(total, 10 * static_cast<int>(bits.size()) * 9 / 10) << "fewer bits than full";
    // Values on their bin's grid, in [0, 1]; a pixel may keep more bits only to hold its colour
    // (at most 1 % of them here).
    const size_t n = static_cast<size_t>(img.width) * static_cast<size_t>(img.height);
    std::vector<bool> over(n, false);
    for (size_t k = 0; k < channels.size(); ++k) {
        const auto& v = img.pixels.at(channels[k].second);
        for (size_t i = 0; i < n; ++i) {
            ASSERT_GE(v[i], 0.0f);
            ASSERT_LE(v[i], 1.0f);
            if (mantissa_bits(half_code(v[i])) > bits[k]) over[i] = true;
        }
    }
    size_t widened = 0;
    for (bool o : over) widened += o;
    EXPECT_LE(widened, n / 100);
    EXPECT_LT(file_size(autob), file_size(full) * 9 / 10)
        << file_size(autob) << " vs " << file_size(full);
    // verify knows the file: every code re-encodes under D65 (its default gate for colour-rounded
    // half), and it reports the recorded budget and bits.
    const RunResult v = run_spectex({"verify", autob, "--source", png});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
    EXPECT_TRUE(has(v.out, "precision:")) << v.out;
    // The budget is the file against the method at 1 nm (the grid and the rounding together).
    EXPECT_TRUE(has(v.out, "within 0.5 ΔE00 of the method's own spectrum at 1 nm under D65,A,FL11"))
        << v.out;
    EXPECT_TRUE(has(v.out, "100% (262144 of 262144)")) << v.out;
    const RunResult vj = run_spectex({"verify", autob, "--source", png, "--json", "-"});
    ASSERT_EQ(vj.status, 0) << vj.err;
    const auto j = nlohmann::json::parse(vj.out.substr(0, vj.out.find('\n')));
    EXPECT_EQ(j["precision"]["bits"].get<std::vector<int>>(), bits);
    EXPECT_TRUE(
        has(j["precision"]["covers"].get<std::string>(), "against the method's own spectrum"))
        << vj.out;
    // Full precision writes no precision attribute.
    EXPECT_FALSE(read_exr(full).has_attr(key::kPrecision));
}

TEST(PrecisionSlow, LatticeWithTheLhtssPriorHoldsItsCodesToo) {
    ScratchDir d;
    const std::string png = cube_png(d), out = d / "lattice.exr";
    const RunResult r = run_spectex({"bake", png, "-o", out, "--method", "lattice",
                                     "--vertex-prior", "lhtss", "--precision", "auto", "--lights",
                                     "D65,A,FL2,FL11,D50,LED-B3", "--max-de", "0.5", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_exr(out).attr(key::kPrecision), "auto");
    const RunResult v = run_spectex({"verify", out, "--source", png});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
    EXPECT_TRUE(has(v.out, "100% (262144 of 262144)")) << v.out;
}

TEST(PrecisionSlow, TheBudgetAndBitsAreInTheSettingsHash) {
    ScratchDir d;
    std::vector<uint8_t> px(64 * 64 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>(i * 101 % 256);
    const std::string png = d / "small.png", out = d / "a.exr";
    write_image(png, 64, 64, 3, OIIO::TypeDesc::UINT8, px.data());
    // 16 bins: each budget below is a choice of its own over every 8-bit colour, 5 times cheaper
    // than on 81 bins, and the hash keeps a budget on any grid.
    const std::vector<std::string> base = {"bake",          png,         "-o", out, "--update",
                                           "--wavelengths", "400:700:20"};
    auto bake = [&](std::vector<std::string> extra) {
        std::vector<std::string> a = base;
        a.insert(a.end(), extra.begin(), extra.end());
        return run_spectex(a);
    };
    const std::vector<std::string> auto05 = {"--precision", "auto",     "--lights",
                                             "D65,A",       "--max-de", "0.5"};
    ASSERT_EQ(bake({"--precision", "full"}).status, 0);
    const std::string h_full = read_exr(out).attr(key::kSettingsHash);
    RunResult r = bake(auto05);
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string h_auto = read_exr(out).attr(key::kSettingsHash);
    EXPECT_NE(h_full, h_auto) << "full and auto hash alike: --update would keep the wrong file";
    r = bake(auto05);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(has(r.err, "--precision auto:")) << "an up-to-date file chose its bits again";
    r = bake({"--precision", "auto", "--lights", "D65,A", "--max-de", "1"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(read_exr(out).attr(key::kSettingsHash), h_auto);
    EXPECT_EQ(read_exr(out).attr(key::kPrecisionMaxDe), "1");
    // --precision-de overrides --max-de for the bits.
    r = bake({"--precision", "auto", "--lights", "D65,A", "--precision-de", "0.25"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_exr(out).attr(key::kPrecisionMaxDe), "0.25");
}

// --precision auto asked of a named method takes the default bake's lights and budget unless
// --lights or --max-de are given, as the default bake does: the same defaults whenever the same
// option is asked (the lattice once demanded --lights). The level stays the method's own. Four
// choices of their own: Slow (the sanitizer build runs the option checks in the test above).
TEST(PrecisionSlow, AutoTakesTheDefaultsLightsAndBudgetWithAnyMethod) {
    ScratchDir d;
    std::vector<uint8_t> px(12, 128);
    write_image(d / "in.png", 2, 2, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::string in = d / "in.png", out = d / "o.exr";
    for (const char* method : {"basis", "lattice"}) {
        // 16 bins: each is a choice of its own, several passes over the whole cube.
        RunResult r = run_spectex({"bake", in, "-o", out, "-q", "--method", method, "--precision",
                                   "auto", "--wavelengths", "400:700:20"});
        ASSERT_EQ(r.status, 0) << method << ": " << r.err;
        ExrImage img = read_exr(out);
        EXPECT_EQ(img.attr(key::kPrecisionLights), "D65,A,FL2,FL11,D50,LED-B3") << method;
        EXPECT_EQ(img.attr(key::kPrecisionMaxDe), "0.5") << method;
        EXPECT_EQ(img.attr(key::kZipLevel), "4") << method;
        // One of the two given: the other stays the default's.
        r = run_spectex({"bake", in, "-o", out, "-q", "--method", method, "--precision", "auto",
                         "--wavelengths", "400:700:20", "--lights", "A"});
        ASSERT_EQ(r.status, 0) << method << ": " << r.err;
        img = read_exr(out);
        EXPECT_EQ(img.attr(key::kPrecisionLights), "A,D65") << method;
        EXPECT_EQ(img.attr(key::kPrecisionMaxDe), "0.5") << method;
    }
}

// The default's lights on a grid that reaches past some of their tables (A and FL2 end at 780 nm):
// they are dark there, as plan takes them, instead of "800 nm lies outside the A table" (exit 2).
TEST(PrecisionSlow, TheDefaultBakesOnAGridPastItsLightsTables) {
    ScratchDir d;
    write_pattern_png(d / "in.png", 3);
    const std::string out = d / "o.exr";
    const RunResult r =
        run_spectex({"bake", d / "in.png", "-o", out, "--wavelengths", "400:800:20"});
    ASSERT_EQ(r.status, 0) << r.err;
    const ExrImage img = read_exr(out);
    EXPECT_EQ(img.attr(key::kPrecisionLights), "D65,A,FL2,FL11,D50,LED-B3");
    EXPECT_EQ(bits_of(img.attr(key::kPrecisionBits)).size(), 21u) << img.attr(key::kPrecisionBits);
    const RunResult v = run_spectex({"verify", out, "--source", d / "in.png"});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
}

TEST(Precision, UsageErrorsAreRefusedBeforeAnyWork) {
    ScratchDir d;
    std::vector<uint8_t> px(12, 128);
    write_image(d / "in.png", 2, 2, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::string in = d / "in.png", out = d / "o.exr";
    struct Case {
        std::vector<std::string> args;
        std::string says;
    };
    const std::vector<Case> cases = {
        {{"--precision", "half"}, "is not one of full, auto"},
        {{"--precision", "auto", "--lights", "A", "--max-de", "1", "--type", "float"},
         "--type float keeps every bit"},
        {{"--precision-de", "0.5"}, "--precision-de belongs to --precision auto"},
        {{"--precision", "auto", "--lights", "A", "--max-de", "1", "--half-rounding", "nearest"},
         "--half-rounding nearest would lose them"},
        {{"--precision", "auto", "--lights", "A", "--precision-de", "0"}, "not a positive"},
        {{"--lights", "A", "--max-de", "1"}, "choose the grid of --wavelengths auto"},
    };
    // A method named: its --precision is what is given (the default bake's own: below).
    for (const auto& c : cases) {
        std::vector<std::string> a = {"bake", in, "-o", out, "--method", "basis"};
        a.insert(a.end(), c.args.begin(), c.args.end());
        const RunResult r = run_spectex(a);
        EXPECT_EQ(r.status, 2) << c.says << ": " << r.err;
        EXPECT_TRUE(has(r.err, c.says)) << r.err;
        EXPECT_FALSE(file_exists(out));
    }
}

// The default bake (no method option) keeps a budget where one can be kept: under six lights within
// 0.5, deflated by size, unless --lights, --max-de, --zip-level or --precision say otherwise;
// full where a budget cannot be kept (float, nearest rounding, a lossy compression). Its bits are
// said only with -v, and a bake that asked for them says them.
TEST(PrecisionSlow, TheDefaultBakeKeepsABudgetWhereItCan) {
    ScratchDir d;
    std::vector<uint8_t> px(12, 128);
    write_image(d / "in.png", 2, 2, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::string in = d / "in.png", out = d / "o.exr";
    auto bake = [&](std::vector<std::string> extra) {
        std::vector<std::string> a = {"bake", in, "-o", out};
        a.insert(a.end(), extra.begin(), extra.end());
        return run_spectex(a);
    };
    RunResult r = bake({});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(has(r.err, "--precision auto")) << r.err;
    ExrImage img = read_exr(out);
    EXPECT_EQ(img.attr(key::kPrecision), "auto");
    EXPECT_EQ(img.attr(key::kPrecisionLights), "D65,A,FL2,FL11,D50,LED-B3");
    EXPECT_EQ(img.attr(key::kPrecisionMaxDe), "0.5");
    EXPECT_EQ(img.attr(key::kZipLevel), "6");  // by size: 2 x 2 pixels (batch_test.cpp)
    r = bake({"-v"});
    EXPECT_TRUE(has(r.err, "--precision auto: ")) << r.err;
    r = bake({"--precision", "auto"});
    EXPECT_TRUE(has(r.err, "--precision auto: ")) << r.err;

    // The scene's lights and budget (--precision-de over --max-de for the bits), and another
    // level; on a coarse grid, as the choice is one of its own (passes over the whole cube).
    // The grid alone is over 0.25 against the method at 1 nm: every bit is kept, and said.
    r = bake({"--lights", "A,FL11", "--max-de", "1", "--precision-de", "0.25", "--zip-level", "6",
              "--wavelengths", "400:700:20"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has(r.err, "the grid 400:700:20 is itself over the budget")) << r.err;
    img = read_exr(out);
    EXPECT_EQ(img.attr(key::kPrecisionLights), "A,FL11,D65");  // and the light it is exact for
    EXPECT_EQ(img.attr(key::kPrecisionMaxDe), "0.25");
    EXPECT_EQ(img.attr(key::kZipLevel), "6");

    // Where no budget can be kept, or none is wanted: full, at level 4.
    for (const auto& extra : std::vector<std::vector<std::string>>{
             {"--precision", "full"},
             {"--type", "float"},
             {"--half-rounding", "nearest"},
             {"--compression", "b44", "--allow-lossy"},
             {"--compression", "none"},
             {"--method", "lattice", "--vertex-prior", "lhtss"}}) {
        r = bake(extra);
        ASSERT_EQ(r.status, 0) << extra.front() << ": " << r.err;
        img = read_exr(out);
        EXPECT_FALSE(img.has_attr(key::kPrecision)) << extra.front();
        EXPECT_EQ(img.attr(key::kMethod), "lattice") << extra.front();
        if (extra.front() != "--compression")  // b44 and none have no level
            EXPECT_EQ(img.attr(key::kZipLevel), "4") << extra.front();
    }
    // Still refused: a budget asked of what cannot keep one.
    r = bake({"--precision", "auto", "--type", "float"});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(has(r.err, "--type float keeps every bit")) << r.err;
}

// The default bake's stored values are never coarser than 1/16 of the unrounded value (or, below
// half's normal range 2^-14, than 2^-14/16): with too few mantissa bits a bin stores only powers of
// two, and a plateau of 1.0 showed notches to 0.5 (pure blue at 385 nm, pure red at 735 nm).
// The unrounded values are the same bake in float (the method's spectra before any rounding).
TEST(Precision, TheDefaultBakeStoresEveryValueWithinASixteenthOfItsSpectrum) {
    ScratchDir d;
    // The primaries, the secondaries, white, greys and a few saturated colours (4 x 4 pixels).
    const std::vector<uint8_t> px = {255, 0,   0,   0,   255, 0,   0,   0,   255, 255, 255, 0,
                                     0,   255, 255, 255, 0,   255, 255, 255, 255, 128, 128, 128,
                                     10,  10,  10,  200, 30,  10,  20,  40,  220, 30,  200, 60,
                                     250, 120, 0,   90,  0,   160, 1,   2,   3,   240, 240, 250};
    write_image(d / "in.png", 4, 4, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::string in = d / "in.png", half = d / "half.exr", flt = d / "float.exr";
    const RunResult r = run_spectex({"bake", in, "-o", half, "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    ASSERT_EQ(run_spectex({"bake", in, "-o", flt, "-q", "--type", "float"}).status, 0);
    const ExrImage h = read_exr(half), f = read_exr(flt);
    ASSERT_EQ(h.attr(key::kPrecision), "auto");
    const std::vector<int> bits = bits_of(h.attr(key::kPrecisionBits));
    for (int b : bits) EXPECT_GE(b, 4) << h.attr(key::kPrecisionBits);
    const auto channels = spectral_channels(h);
    ASSERT_EQ(channels.size(), spectral_channels(f).size());
    double worst = 0;
    std::string where;
    for (const auto& ch : channels) {
        const auto& hv = h.pixels.at(ch.second);
        const auto& fv = f.pixels.at(ch.second);
        ASSERT_EQ(hv.size(), fv.size());
        for (size_t i = 0; i < hv.size(); ++i) {
            // Relative to the grid's step: 1/16 of the value, 2^-18 below 2^-14.
            const double step = std::max(static_cast<double>(fv[i]), std::ldexp(1.0, -14)) / 16;
            const double rel = std::fabs(static_cast<double>(hv[i]) - fv[i]) / step;
            if (rel > worst) worst = rel, where = ch.second + " pixel " + std::to_string(i);
        }
    }
    EXPECT_LE(worst, 1.0) << "at " << where;
}

// The default bake's bits come with spectex (config/spectral/precision/): no first bake pays for
// choosing them on every 8-bit colour (some 30 s on 2 cores). A change to the lattice, the
// rounding or the chooser changes the request's key and fails this test until the answer is made
// again (config/spectral/precision/make_default.sh); PrecisionSlow checks that the shipped answer
// is the one the chooser gives.
TEST(Precision, TheDefaultBakesBitsComeWithSpectex) {
    ScratchDir d;
    std::vector<uint8_t> px(12, 200);
    write_image(d / "in.png", 2, 2, 3, OIIO::TypeDesc::UINT8, px.data());
    const RunResult r = run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "-v"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has(r.err, "the precision's bits from spectex's data: ")) << r.err;
    EXPECT_TRUE(has(r.err, "shipped with spectex")) << r.err;
    const ExrImage img = read_exr(d / "o.exr");
    EXPECT_TRUE(has(img.attr(key::kPrecisionSample), "every 8-bit sRGB code (16777216 colours)"))
        << img.attr(key::kPrecisionSample);
}

// The shipped answer is what the chooser gives (made afresh with the answers left out of a copy of
// the data, and an empty cache), byte for byte; and a damaged shipped answer (one bit lowered, its
// seal unchanged) is no answer: the bits are chosen again, and they are the shipped ones.
TEST(PrecisionSlow, TheShippedAnswerIsTheChoosersAndADamagedOneIsNot) {
    ScratchDir d;
    namespace fs = std::filesystem;
    const fs::path shipped = fs::path(SPECTEX_TEST_DATA_DIR) / "spectral" / "precision";
    // Four shipped answers: the default's grid (31 bins) and 380:780:5 (81), the grid it stored
    // before, each for the 8-bit codes as the shipped config decodes them and as IEC 61966-2-1's
    // formula does (a config whose sRGB mixes channels, or that has none). The default grid's two
    // are checked against the chooser here; the others are taken as they are.
    std::vector<std::string> names, texts;
    int answers = 0;
    for (const auto& e : fs::directory_iterator(shipped))
        if (e.path().filename().string().rfind("precision-", 0) == 0) {
            ++answers;
            const std::string t = read_file(e.path().string());
            if (t.find("\nbits " + std::to_string(kDefaultBins) + " ") == std::string::npos)
                continue;
            names.push_back(e.path().filename().string());
            texts.push_back(t);
        }
    EXPECT_EQ(answers, 4);
    ASSERT_EQ(names.size(), 2u) << "two shipped answers for the default's grid";
    fs::copy(SPECTEX_TEST_DATA_DIR, d / "config", fs::copy_options::recursive);
    // One bin's bits lowered by one, in both.
    for (size_t i = 0; i < names.size(); ++i) {
        std::string damaged = texts[i];
        const size_t at = damaged.find("bits ");
        ASSERT_NE(at, std::string::npos);
        const size_t digit = damaged.find_first_of("56789", damaged.find(' ', at + 5) + 1);
        ASSERT_NE(digit, std::string::npos);
        --damaged[digit];
        write_text(d / "config" + "/spectral/precision/" + names[i], damaged);
    }
    std::vector<uint8_t> px(12, 90);
    write_image(d / "in.png", 2, 2, 3, OIIO::TypeDesc::UINT8, px.data());
    // A config with no sRGB (tests/ocio/not_srgb.ocio): its question measures the formula's codes.
    const std::string no_srgb = std::string(SPECTEX_TEST_SOURCE_DIR) + "/tests/ocio/not_srgb.ocio";
    std::vector<std::string> found;
    for (const std::string config : {"", "no_srgb"}) {
        SCOPED_TRACE(config.empty() ? "the shipped config" : "a config with no sRGB");
        const std::string cache = d / ("cache" + config);
        std::vector<std::string> args{"bake", d / "in.png", "-o", d / "o.exr", "-v"};
        if (!config.empty()) args.insert(args.end(), {"--config", no_srgb});
        const RunResult r = run_spectex(
            args, {"SPECTEX_DATA_DIR=" + (d / "config"), "SPECTEX_CACHE_DIR=" + cache, "OCIO="});
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_FALSE(has(r.err, "from spectex's data")) << r.err;
        // The answer kept in the cache is one of the shipped ones, byte for byte.
        int entries = 0;
        for (const auto& e : fs::directory_iterator(cache))
            if (e.path().filename().string().rfind("precision-", 0) == 0) {
                ++entries;
                const std::string t = read_file(e.path().string());
                EXPECT_TRUE(t == texts[0] || t == texts[1])
                    << "config/spectral/precision/" << names[0] << " or " << names[1]
                    << " is not the chooser's answer: run "
                       "config/spectral/precision/make_default.sh";
                found.push_back(t);
            }
        EXPECT_EQ(entries, 1);
    }
    ASSERT_EQ(found.size(), 2u);
    EXPECT_NE(found[0], found[1]) << "the two configs' questions got one answer";
    // The way back to the default's grid before is answered from the data too: no search.
    const RunResult back =
        run_spectex({"bake", d / "in.png", "-o", d / "o81.exr", "-v", "--wavelengths", "380:780:5"},
                    {"SPECTEX_CACHE_DIR=" + (d / "cache81")});
    ASSERT_EQ(back.status, 0) << back.err;
    EXPECT_TRUE(has(back.err, "from spectex's data")) << back.err;
}

TEST(PrecisionSlow, PlanPrintsBitsWithTheGrid) {
    const RunResult r =
        run_spectex({"plan", "--grids", "380:780:10", "--lights", "D65,A", "--max-de", "2",
                     "--colours", "sample", "--sample-stride", "17", "--precision", "auto"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has(r.out, "precision: 41 bins, mantissa bits ")) << r.out;
    const RunResult j = run_spectex({"plan", "--grids", "380:780:10", "--lights", "D65,A",
                                     "--max-de", "2", "--colours", "sample", "--sample-stride",
                                     "17", "--precision", "auto", "--json", "-"});
    ASSERT_EQ(j.status, 0) << j.err;
    const auto pj = nlohmann::json::parse(j.out.substr(0, j.out.find('\n')));
    EXPECT_EQ(pj["precision"]["bits"].size(), 41u);
    EXPECT_EQ(run_spectex({"plan", "--precision", "auto", "--type", "float"}).status, 2);
}

TEST(PrecisionSlow, AutoBakeIsTheSameWhateverTheThreads) {
    // The coarse rounding works per pixel in blocks of the producer's strips, and the chooser's
    // passes over the cube in tasks: neither the bits, the worst figures and their codes, nor the
    // stored values may depend on how many threads there are. The budget is one the grid meets (its
    // worst is 1.38 under A), so the bits are a choice, not all kept. Slow: the chooser's passes
    // under ASan took 40 s.
    ScratchDir d;
    std::vector<uint8_t> px(96 * 80 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 2654435761u) >> 24);
    const std::string png = d / "noise.png", one = d / "one.exr", three = d / "three.exr";
    write_image(png, 96, 80, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::vector<std::string> a = {"--precision", "auto",      "--lights",      "D65,A",
                                        "--max-de",    "2",         "--wavelengths", "400:700:20",
                                        "-q",          "--no-cache"};  // each bake chooses its bits
    std::vector<std::string> c1 = {"bake", png, "-o", one, "--threads", "1"};
    std::vector<std::string> c3 = {"bake", png, "-o", three, "--threads", "3"};
    c1.insert(c1.end(), a.begin(), a.end());
    c3.insert(c3.end(), a.begin(), a.end());
    ASSERT_EQ(run_spectex(c1).status, 0);
    ASSERT_EQ(run_spectex(c3).status, 0);
    const ExrImage x = read_exr(one), y = read_exr(three);
    ASSERT_EQ(x.attr(key::kPrecisionBits), y.attr(key::kPrecisionBits));
    EXPECT_EQ(x.attr(key::kPrecisionWorstDe), y.attr(key::kPrecisionWorstDe));
    EXPECT_EQ(x.attr(key::kPrecisionWorstCode), y.attr(key::kPrecisionWorstCode));
    const std::vector<int> bits = bits_of(x.attr(key::kPrecisionBits));
    EXPECT_TRUE(std::any_of(bits.begin(), bits.end(), [](int b) { return b < 10; }))
        << "every bit kept: " << x.attr(key::kPrecisionBits);
    ASSERT_FALSE(spectral_channels(x).empty());
    for (const auto& ch : spectral_channels(x))
        EXPECT_TRUE(x.pixels.at(ch.second) == y.pixels.at(ch.second)) << ch.second;
}

TEST(Precision, ASixteenBitSourceKeepsEachChannelWithinItsShare) {
    // The coarser grids hold a colour to 2^-10 of each channel's value (or 6.1e-5): finer than an
    // 8-bit code's step, coarser than a 16-bit one's. verify's gate for a 16-bit source in half
    // is then the error beyond that share (at most 1e-4, as full half's absolute error is); a
    // file at full precision keeps the absolute gate. Both must pass on a correct bake.
    ScratchDir d;
    const int w = 96, h = 64;
    std::vector<uint16_t> px(static_cast<size_t>(w * h * 3));
    uint32_t x = 12345;
    for (size_t i = 0; i < px.size(); ++i) {
        x = x * 1664525u + 1013904223u;
        // Half the pixels smooth ramps, half random 16-bit codes.
        px[i] =
            (i / 3) % 2 ? static_cast<uint16_t>(x >> 16) : static_cast<uint16_t>((i * 977) % 65536);
    }
    const std::string in = d / "in16.png";
    write_image(in, w, h, 3, OIIO::TypeDesc::UINT16, px.data());
    for (const char* precision : {"auto", "full"}) {
        SCOPED_TRACE(precision);
        const std::string out = d / (std::string(precision) + ".exr");
        const RunResult b = run_spectex({"bake", in, "-o", out, "-q", "--precision", precision});
        ASSERT_EQ(b.status, 0) << b.err;
        const RunResult v = run_spectex({"verify", out, "--source", in});
        EXPECT_EQ(v.status, 0) << v.out << v.err;
        const bool coarse = std::string(precision) == "auto";
        EXPECT_EQ(has(v.out, "linear RGB error beyond 2^-10 of the value, max (coarser grids)"),
                  coarse)
            << v.out;
        EXPECT_EQ(has(v.out, "linear RGB error max (half cannot keep 16-bit codes)"), !coarse)
            << v.out;
    }
}

TEST(PrecisionSlow, TheScenesLightsPlanTheDefaultsGridToo) {
    // --lights or --max-de without a grid make the default bake plan its grid for the scene, as
    // --wavelengths auto does (the bits with it, on every 8-bit colour), once: a second task
    // with the same settings (another shard, another machine sharing the cache) takes both
    // answers from the cache. Candidates 400:700:20 and 400:700:10 keep the search short.
    ScratchDir d;
    std::vector<uint8_t> px(8 * 8 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>(i * 37 % 256);
    write_image(d / "in.png", 8, 8, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::vector<std::string> env = {"SPECTEX_CACHE_DIR=" + (d / "cache")};
    auto bake = [&](const std::string& out, std::vector<std::string> extra) {
        std::vector<std::string> a = {"bake", d / "in.png", "-o", d / out, "-v"};
        a.insert(a.end(), extra.begin(), extra.end());
        return run_spectex(a, env);
    };
    // A budget the 20 nm grid holds under A (1.4 on the plan's sample): 16 bins.
    const std::vector<std::string> scene = {"--lights", "A",       "--max-de",
                                            "2",        "--grids", "400:700:20,400:700:10"};
    RunResult r = bake("a.exr", scene);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has(r.err, "--wavelengths auto: 400:700:20 (16 bins)")) << r.err;
    ExrImage a = read_exr(d / "a.exr");
    EXPECT_EQ(a.attr(key::kWavelengths), "400:700:20");
    EXPECT_EQ(a.attr(key::kPlanLights), "A");
    EXPECT_EQ(a.attr(key::kPrecisionLights), "A,D65");
    EXPECT_EQ(a.attr(key::kPrecisionMaxDe), "2");
    EXPECT_EQ(spectral_channels(a).size(), 16u);
    r = bake("b.exr", scene);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has(r.err, "the plan's answer from the cache")) << r.err;
    EXPECT_TRUE(has(r.err, "the precision's bits from the cache")) << r.err;
    const ExrImage b = read_exr(d / "b.exr");
    EXPECT_EQ(b.attr(key::kPrecisionBits), a.attr(key::kPrecisionBits));
    // verify knows the file is within its recorded budget under its recorded lights.
    const RunResult v = run_spectex({"verify", d / "b.exr", "--source", d / "in.png"});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
    // A budget alone keeps the default's lights; the lights alone its budget.
    r = bake("c.exr", {"--max-de", "2", "--grids", "400:700:20,400:700:10"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_exr(d / "c.exr").attr(key::kPlanLights), "D65,A,FL2,FL11,D50,LED-B3");
    // Naming a grid keeps it: no plan.
    r = bake("e.exr", {"--lights", "A", "--max-de", "2", "--wavelengths", "400:700:20"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(read_exr(d / "e.exr").has_attr(key::kPlanLights));
}
