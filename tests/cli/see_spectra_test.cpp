// sample, render, plot and info's levels/--json, end to end: the real binary on bakes of a
// generated chart and of examples/textures/colour_chart.png, checked against the EXR read with
// OpenEXR directly and against an integration written here (own CSV reading, own matrices).
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

const std::string kChart =
    std::string(SPECTEX_TEST_SOURCE_DIR) + "/examples/textures/colour_chart.png";

// A w x h 8-bit sRGB chart of random codes (fixed seed) with white, black and the primaries first.
std::vector<uint8_t> chart_codes(int w, int h) {
    std::mt19937 rng(12);
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
    for (auto& v : px) v = static_cast<uint8_t>(rng() & 0xff);
    const uint8_t fixed[5][3] = {{255, 255, 255}, {0, 0, 0}, {255, 0, 0}, {0, 255, 0}, {0, 0, 255}};
    for (int i = 0; i < 5; ++i)
        for (int c = 0; c < 3; ++c) px[static_cast<size_t>(i) * 3 + c] = fixed[i][c];
    return px;
}

struct Png {
    int w = 0, h = 0, nch = 0;
    std::vector<uint8_t> px;
    const uint8_t* at(int x, int y) const { return &px[(static_cast<size_t>(y) * w + x) * nch]; }
};

// The stored codes (alpha left unassociated, as bake reads PNG).
Png read_png(const std::string& path) {
    Png p;
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) throw std::runtime_error("cannot read " + path + ": " + OIIO::geterror());
    p.w = in->spec().width;
    p.h = in->spec().height;
    p.nch = in->spec().nchannels;
    p.px.resize(static_cast<size_t>(p.w) * p.h * p.nch);
    in->read_image(0, 0, 0, p.nch, OIIO::TypeDesc::UINT8, p.px.data());
    in->close();
    return p;
}

// Bakes the colour chart once for the whole test binary.
const std::string& chart_exr() {
    static ScratchDir dir;  // kept for the process (removed at exit): several tests read it
    static std::string exr = [] {
        std::string e = dir / "chart.exr";
        RunResult r = run_spectex({"bake", kChart, "-o", e, "-q"});
        if (r.status != 0) throw std::runtime_error("bake failed: " + r.err);
        return e;
    }();
    return exr;
}

// Runs python3 with a script and arguments; returns {exit status, stdout}. Status 127: no python3.
std::pair<int, std::string> run_python(const std::string& script,
                                       const std::vector<std::string>& args) {
    ScratchDir d;
    write_text(d / "s.py", script);
    std::string cmd = "python3 '" + (d / "s.py") + "'";
    for (const auto& a : args) cmd += " '" + a + "'";
    cmd += " > '" + (d / "out") + "' 2>&1";
    int st = std::system(cmd.c_str());
    return {WIFEXITED(st) ? WEXITSTATUS(st) : 128, read_file(d / "out")};
}

// Test's own table reader: "wavelength,v1[,v2,v3]" rows, '#' comments, an optional header line.
std::map<long, std::vector<double>> read_table(const std::string& path) {
    std::ifstream in(path);
    std::map<long, std::vector<double>> t;
    std::string line;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#' || !(std::isdigit(static_cast<unsigned char>(line[0]))))
            continue;
        std::stringstream ss(line);
        std::string f;
        std::vector<double> v;
        while (std::getline(ss, f, ',')) v.push_back(std::strtod(f.c_str(), nullptr));
        t[std::lround(v[0] * 1000)] = std::vector<double>(v.begin() + 1, v.end());
    }
    return t;
}

int encode8(double l) {
    l = std::min(1.0, std::max(0.0, l));
    double v = l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1 / 2.4) - 0.055;
    return static_cast<int>(std::lround(v * 255));
}

// The independent reference: XYZ under `light` (perfect reflector Y = 1) of a spectrum on
// `lambda`, Bradford to D65's white, sRGB through D65's white-consistent matrix, 8-bit codes.
struct Reference {
    std::vector<double> lambda;
    Eigen::Matrix3Xd w_light, w_d65;
    Eigen::Vector3d white_light, white_d65;
    Eigen::Matrix3d xyz_to_rgb, bradford;

    Reference(const std::vector<double>& l, const std::string& light) : lambda(l) {
        const std::string dir = std::string(SPECTEX_TEST_DATA_DIR) + "/spectral/";
        auto obs = read_table(dir + "observer_cie1931-2.csv");
        auto e = read_table(dir + "illuminant_" + light + ".csv");
        auto d65 = read_table(dir + "illuminant_D65.csv");
        auto weights = [&](std::map<long, std::vector<double>>& ill) {
            Eigen::Matrix3Xd w(3, static_cast<Eigen::Index>(l.size()));
            double norm = 0;
            for (size_t k = 0; k < l.size(); ++k) {
                const long key = std::lround(l[k] * 1000);
                const double p = ill.at(key)[0];
                const auto& o = obs.at(key);
                for (int i = 0; i < 3; ++i)
                    w(i, static_cast<Eigen::Index>(k)) = p * o[static_cast<size_t>(i)];
                norm += p * o[1];
            }
            return Eigen::Matrix3Xd(w / norm);
        };
        w_light = weights(e);
        w_d65 = weights(d65);
        white_light = w_light.rowwise().sum();
        white_d65 = w_d65.rowwise().sum();
        // sRGB primaries scaled so that RGB 1,1,1 is D65's white on this grid.
        const double xy[3][2] = {{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}};
        Eigen::Matrix3d P;
        for (int i = 0; i < 3; ++i)
            P.col(i) << xy[i][0] / xy[i][1], 1.0, (1 - xy[i][0] - xy[i][1]) / xy[i][1];
        const Eigen::Vector3d s = P.inverse() * white_d65;
        xyz_to_rgb = (P * s.asDiagonal()).inverse();
        Eigen::Matrix3d m;
        m << 0.8951, 0.2664, -0.1614, -0.7502, 1.7135, 0.0367, 0.0389, -0.0685, 1.0296;
        const Eigen::Vector3d ratio = (m * white_d65).cwiseQuotient(m * white_light);
        bradford = m.inverse() * ratio.asDiagonal() * m;
    }
    std::array<int, 3> codes(const std::vector<double>& spectrum, bool adapt) const {
        Eigen::VectorXd sv = Eigen::Map<const Eigen::VectorXd>(
            spectrum.data(), static_cast<Eigen::Index>(spectrum.size()));
        Eigen::Vector3d xyz = w_light * sv;
        Eigen::Vector3d rgb = xyz_to_rgb * (adapt ? Eigen::Vector3d(bradford * xyz) : xyz);
        return {encode8(rgb(0)), encode8(rgb(1)), encode8(rgb(2))};
    }
};

// The spectrum of pixel (x, y) of an EXR read with OpenEXR, and its wavelengths.
std::vector<double> exr_spectrum(const ExrImage& img, int x, int y,
                                 std::vector<double>* lambda = nullptr) {
    std::vector<double> s;
    if (lambda) lambda->clear();
    for (const auto& [l, name] : spectral_channels(img)) {
        s.push_back(img.at(name, x, y));
        if (lambda) lambda->push_back(l);
    }
    return s;
}

std::string one_attr_after(const std::string& text, const std::string& key) {
    size_t at = text.find(key);
    if (at == std::string::npos) return "";
    size_t end = text.find_first_of(";\n(", at + key.size());
    return text.substr(at + key.size(), end - at - key.size());
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// sample

TEST(Sample, PrintsTheStoredSpectrumAndTheSourceCodesUnderD65) {
    ScratchDir d;
    const int w = 23, h = 11;
    auto px = chart_codes(w, h);
    write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    ASSERT_EQ(run_spectex({"bake", d / "in.png", "-o", d / "in.exr", "-q"}).status, 0);
    ExrImage img = read_exr(d / "in.exr");
    const std::vector<std::pair<int, int>> pixels = {{0, 0}, {7, 3}, {22, 10}, {4, 0}};
    std::vector<std::string> args = {"sample", d / "in.exr"};
    for (auto [x, y] : pixels) args.push_back(std::to_string(x) + "," + std::to_string(y));
    RunResult r = run_spectex(args);
    ASSERT_EQ(r.status, 0) << r.err;

    // Long CSV: header, then x,y,wavelength,value rows; '#' lines carry the colours.
    std::stringstream ss(r.out);
    std::string line;
    std::getline(ss, line);
    EXPECT_EQ(line, "x,y,wavelength,value");
    std::map<std::pair<int, int>, std::vector<std::pair<double, double>>> rows;
    std::map<std::pair<int, int>, std::string> d65_line;
    while (std::getline(ss, line)) {
        if (line[0] == '#') {
            int x, y;
            char under[8] = {0};
            if (std::sscanf(line.c_str(), "# pixel %d,%d under %3s", &x, &y, under) == 3 &&
                std::string(under) == "D65")
                d65_line[{x, y}] = line;
            continue;
        }
        int x, y;
        double l, v;
        ASSERT_EQ(std::sscanf(line.c_str(), "%d,%d,%lf,%lf", &x, &y, &l, &v), 4) << line;
        rows[{x, y}].push_back({l, v});
    }
    ASSERT_EQ(rows.size(), pixels.size());
    for (auto [x, y] : pixels) {
        std::vector<double> lambda;
        std::vector<double> want = exr_spectrum(img, x, y, &lambda);
        const auto& got = rows[{x, y}];
        ASSERT_EQ(got.size(), want.size());
        for (size_t k = 0; k < want.size(); ++k) {
            EXPECT_DOUBLE_EQ(got[k].first, lambda[k]);
            EXPECT_FLOAT_EQ(static_cast<float>(got[k].second), static_cast<float>(want[k]))
                << x << "," << y;
        }
        // The D65 colour re-encodes to the source's codes.
        ASSERT_TRUE(d65_line.count({x, y})) << r.out;
        int c[3];
        ASSERT_EQ(std::sscanf(one_attr_after(d65_line[{x, y}], "sRGB 8-bit ").c_str(), "%d %d %d",
                              &c[0], &c[1], &c[2]),
                  3)
            << d65_line[{x, y}];
        const uint8_t* src = &px[(static_cast<size_t>(y) * w + x) * 3];
        for (int i = 0; i < 3; ++i) EXPECT_EQ(c[i], src[i]) << x << "," << y << " channel " << i;
    }
    // The white pixel: L* 100 under D65.
    EXPECT_NEAR(std::strtod(one_attr_after(d65_line[{0, 0}], "L*a*b* ").c_str(), nullptr), 100.0,
                0.01)
        << d65_line[{0, 0}];
}

TEST(Sample, OtherLightsAndJsonAgreeWithTheIndependentIntegration) {
    const std::string& exr = chart_exr();
    ExrImage img = read_exr(exr);
    RunResult r =
        run_spectex({"sample", exr, "--json", "--illuminant", "A,FL11", "300,250", "10,200"});
    ASSERT_EQ(r.status, 0) << r.err;
    auto [st, out] = run_python(
        "import json,sys\n"
        "j=json.loads(open(sys.argv[1]).read())\n"
        "assert [l['name'] for l in j['illuminants']]==['D65','A','FL11']\n"
        "for p in j['pixels']:\n"
        "  print(p['x'],p['y'],' '.join(' '.join(map(str,c['srgb8']))+' '+' "
        "'.join(map(str,c['srgb8_unadapted'])) for c in p['colours']))\n",
        {[&] {
            static ScratchDir jd;
            write_text(jd / "s.json", r.out);
            return jd / "s.json";
        }()});
    if (st == 127) GTEST_SKIP() << "no python3";
    ASSERT_EQ(st, 0) << out;
    std::stringstream ss(out);
    std::vector<double> lambda;
    exr_spectrum(img, 0, 0, &lambda);
    Reference ref_a(lambda, "A"), ref_f(lambda, "FL11");
    for (int i = 0; i < 2; ++i) {
        int x, y, c[18];
        ss >> x >> y;
        for (int& v : c) ss >> v;
        ASSERT_TRUE(ss) << out;
        std::vector<double> s = exr_spectrum(img, x, y);
        auto a = ref_a.codes(s, true), a_raw = ref_a.codes(s, false), f = ref_f.codes(s, true);
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(c[6 + k], a[static_cast<size_t>(k)], 1) << "A, pixel " << x << "," << y;
            EXPECT_NEAR(c[9 + k], a_raw[static_cast<size_t>(k)], 1)
                << "A unadapted, pixel " << x << "," << y;
            EXPECT_NEAR(c[12 + k], f[static_cast<size_t>(k)], 1) << "FL11, pixel " << x << "," << y;
        }
    }
}

TEST(Sample, ErrorsNameThePixelTheWindowOrTheFile) {
    ScratchDir d;
    const int w = 5, h = 4;
    auto px = chart_codes(w, h);
    write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    ASSERT_EQ(run_spectex({"bake", d / "in.png", "-o", d / "in.exr", "-q"}).status, 0);

    RunResult r = run_spectex({"sample", d / "in.exr", "1,1", "5,2"});
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("spectex: " + (d / "in.exr") +
                         ": pixel 5,2 is outside the data window 0,0 - 4,3"),
              std::string::npos)
        << r.err;
    r = run_spectex({"sample", d / "in.exr", "--", "-1,0"});
    EXPECT_EQ(r.status, 1) << r.err;
    for (const std::string bad : {"1;1", "1,", ",1", "a,b", "1,2,3", "1.5,2", "1"}) {
        r = run_spectex({"sample", d / "in.exr", bad});
        EXPECT_EQ(r.status, 2) << bad << ": " << r.err;
        EXPECT_NE(r.err.find("is not a pixel X,Y"), std::string::npos) << r.err;
    }
    EXPECT_EQ(run_spectex({"sample", d / "in.exr"}).status, 2);
    // An unknown light is a setting, checked before the file is read: a usage error naming the
    // option.
    r = run_spectex({"sample", d / "in.exr", "1,1", "--illuminant", "nosuchlight"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(r.err.rfind("spectex sample: --illuminant: unknown illuminant 'nosuchlight'", 0), 0u)
        << r.err;

    // Not spectral: an RGB OpenEXR, and a PNG.
    std::vector<float> rgb(static_cast<size_t>(w) * h * 3, 0.5f);
    write_image(d / "rgb.exr", w, h, 3, OIIO::TypeDesc::FLOAT, rgb.data());
    r = run_spectex({"sample", d / "rgb.exr", "1,1"});
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("spectex: " + (d / "rgb.exr") + ": not a spectral"), std::string::npos)
        << r.err;
    r = run_spectex({"sample", d / "in.png", "1,1"});
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("not an OpenEXR file"), std::string::npos) << r.err;

    r = run_spectex({"sample", "--help"});
    EXPECT_EQ(r.status, 0);
    EXPECT_NE(r.out.find("x,y,wavelength,value"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// info

TEST(InfoLevels, ShowsTilesAndMipLevelsAndJsonHoldsTheWholeHeader) {
    ScratchDir d;
    const int w = 40, h = 24;
    auto px = chart_codes(w, h);
    write_image(d / "in.png", w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    ASSERT_EQ(
        run_spectex({"bake", d / "in.png", "-o", d / "m.exr", "--mipmap", "--tile", "16", "-q"})
            .status,
        0);
    RunResult r = run_spectex({"info", d / "m.exr"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("storage:         tiled 16x16"), std::string::npos) << r.out;
    EXPECT_NE(
        r.out.find(
            "levels:          mipmap, 6 levels (rounding down): 40x24, 20x12, 10x6, 5x3, 2x1, 1x1"),
        std::string::npos)
        << r.out;

    r = run_spectex({"info", "--json", d / "m.exr"});
    ASSERT_EQ(r.status, 0) << r.err;
    write_text(d / "info.json", r.out);
    auto [st, out] = run_python(
        "import json,sys\n"
        "j=json.loads(open(sys.argv[1]).read())\n"
        "assert j['bins']==31 and len(j['wavelengths'])==31 and j['wavelengths'][0]==400, "
        "j['wavelengths'][:3]\n"
        "assert j['tiles']=={'width':16,'height':16}, j['tiles']\n"
        "assert j['levels']['mode']=='mipmap' and j['levels']['count']==6 and "
        "j['levels']['sizes'][3]==[5,3]\n"
        "assert j['alpha']=='none' and j['sample_type']=='half' and j['compression']=='zip'\n"
        "a={x['name']:x for x in j['attributes']}\n"
        "for k in "
        "['channels','compression','dataWindow','displayWindow','lineOrder','tiles','"
        "spectralLayoutVersion',"
        "'spectex:version','spectex:commandLine']:\n"
        "  assert k in a, k\n"
        "assert a['dataWindow']['value']=='0,0 - 39,23', a['dataWindow']\n"
        "assert a['tiles']['type']=='tiledesc' and a['tiles']['value'].startswith('16x16, "
        "mipmap'), a['tiles']\n"
        "assert 'T.400nm half' in a['channels']['value'] or 'T.400,000000nm half' in "
        "a['channels']['value'], a['channels']['value'][:80]\n"
        "print('ok')\n",
        {d / "info.json"});
    if (st == 127) GTEST_SKIP() << "no python3";
    EXPECT_EQ(st, 0) << out << "\n" << r.out.substr(0, 2000);

    // A scanline file: no levels line; its JSON says tiles null and one level.
    ASSERT_EQ(run_spectex({"bake", d / "in.png", "-o", d / "s.exr", "-q"}).status, 0);
    r = run_spectex({"info", d / "s.exr"});
    EXPECT_EQ(r.out.find("levels:"), std::string::npos) << r.out;
    r = run_spectex({"info", "--json", d / "s.exr"});
    EXPECT_NE(r.out.find("\"tiles\":null"), std::string::npos);
    EXPECT_NE(
        r.out.find(
            "\"levels\":{\"mode\":\"one\",\"rounding\":\"down\",\"count\":1,\"sizes\":[[40,24]]}"),
        std::string::npos)
        << r.out;
}

// ---------------------------------------------------------------------------------------------
// render

TEST(Render, UnderD65ABakeGivesBackTheSourceCodes) {
    ScratchDir d;
    RunResult r = run_spectex({"render", chart_exr(), "-o", d / "d65.png"});
    ASSERT_EQ(r.status, 0) << r.err;
    Png src = read_png(kChart), out = read_png(d / "d65.png");
    ASSERT_EQ(out.w, src.w);
    ASSERT_EQ(out.h, src.h);
    ASSERT_EQ(out.nch, 3);
    int worst = 0;
    for (int y = 0; y < src.h; ++y)
        for (int x = 0; x < src.w; ++x)
            for (int c = 0; c < 3; ++c)
                worst = std::max(worst, std::abs(int(out.at(x, y)[c]) - int(src.at(x, y)[c])));
    EXPECT_LE(worst, 1);
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(Render, UnderAMatchesAnIndependentIntegrationWithinOneCode) {
    ScratchDir d;
    const std::string& exr = chart_exr();
    ASSERT_EQ(run_spectex({"render", exr, "--illuminant", "A", "-o", d / "a.png", "-q"}).status, 0);
    ASSERT_EQ(
        run_spectex({"render", exr, "--illuminant", "A", "--no-adapt", "-o", d / "a_raw.png", "-q"})
            .status,
        0);
    Png a = read_png(d / "a.png"), raw = read_png(d / "a_raw.png");
    ExrImage img = read_exr(exr);
    std::vector<double> lambda;
    exr_spectrum(img, 0, 0, &lambda);
    Reference ref(lambda, "A");
    // Hue sweep, greys, primaries, ColorChecker-like patches: tolerance 1 code (rounding at .5).
    const std::vector<std::pair<int, int>> pixels = {{5, 5},     {100, 40},  {256, 64},  {400, 100},
                                                     {30, 150},  {120, 150}, {470, 170}, {40, 200},
                                                     {200, 230}, {480, 250}};
    int differing = 0;
    for (auto [x, y] : pixels) {
        std::vector<double> s = exr_spectrum(img, x, y);
        auto want = ref.codes(s, true), want_raw = ref.codes(s, false);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(a.at(x, y)[c], want[static_cast<size_t>(c)], 1)
                << "adapted " << x << "," << y << " ch " << c;
            EXPECT_NEAR(raw.at(x, y)[c], want_raw[static_cast<size_t>(c)], 1)
                << "raw " << x << "," << y << " ch " << c;
            differing += a.at(x, y)[c] != raw.at(x, y)[c];
        }
    }
    EXPECT_GT(differing, 0) << "adaptation changed nothing";
    // White stays white when adapted; under A unadapted it is yellowish (blue well below red).
    EXPECT_EQ(int(a.at(0, 0)[0]), 255);
    EXPECT_GT(int(raw.at(0, 0)[0]) - int(raw.at(0, 0)[2]), 60);
}

TEST(Render, SeveralLightsMakeALabelledSheet) {
    ScratchDir d;
    const std::string& exr = chart_exr();
    ASSERT_EQ(run_spectex({"render", exr, "--illuminant", "D65,A", "--illuminant", "FL11", "-o",
                           d / "sheet.png", "-q"})
                  .status,
              0);
    ASSERT_EQ(run_spectex({"render", exr, "-o", d / "d65.png", "-q"}).status, 0);
    Png s = read_png(d / "sheet.png"), one = read_png(d / "d65.png");
    // Layout (man page): scale = clamp(w / 128, 1, 4); panels 4*scale apart under a strip 11*scale
    // high.
    const int w = 512, h = 256, scale = 4, gap = 4 * scale, strip = 11 * scale;
    ASSERT_EQ(s.w, 3 * w + 2 * gap);
    ASSERT_EQ(s.h, h + strip);
    for (int p = 0; p < 3; ++p) {
        int ink = 0;
        for (int y = 0; y < strip; ++y)
            for (int x = p * (w + gap); x < p * (w + gap) + w; ++x) ink += s.at(x, y)[0] > 128;
        EXPECT_GT(ink, 50) << "no label drawn in panel " << p;
    }
    // The first panel is the D65 render.
    int diff = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) diff += s.at(x, y + strip)[c] != one.at(x, y)[c];
    EXPECT_EQ(diff, 0);
}

TEST(Render, RefusesToOverwriteItsInputAndBadArguments) {
    ScratchDir d;
    std::string cmd = "cp '" + chart_exr() + "' '" + (d / "a.exr") + "'";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    const std::string before = read_file(d / "a.exr");
    RunResult r = run_spectex({"render", d / "a.exr", "-o", d / "a.exr"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("refusing to overwrite"), std::string::npos) << r.err;
    EXPECT_TRUE(read_file(d / "a.exr") == before);
    // Through another spelling, and plot too.
    r = run_spectex({"render", d / "a.exr", "-o", d.path() + "/./a.exr"});
    EXPECT_EQ(r.status, 2);
    r = run_spectex({"plot", d / "a.exr", "--pixel", "1,1", "-o", d / "a.exr"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(read_file(d / "a.exr") == before);
    EXPECT_TRUE(temp_files_in(d.path()).empty());

    EXPECT_EQ(run_spectex({"render", d / "a.exr"}).status, 2);                     // no -o
    EXPECT_EQ(run_spectex({"render", d / "a.exr", "-o", d / "x.jpg"}).status, 2);  // not .png
    EXPECT_EQ(run_spectex({"render", d / "a.exr", "-o", d / "x.png", "--illuminant", "A,"}).status,
              2);
    r = run_spectex({"render", d / "a.exr", "-o", d / "x.png", "--max-pixels", "1000"});
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("(--max-pixels)"), std::string::npos) << r.err;
    EXPECT_FALSE(file_exists(d / "x.png"));
    r = run_spectex({"render", d / "a.exr", "-o", d / "x.png", "--illuminant", "nosuchlight"});
    EXPECT_EQ(r.status, 2) << r.err;  // a setting: a usage error naming the option
    EXPECT_EQ(r.err.rfind("spectex render: --illuminant: unknown illuminant 'nosuchlight'", 0), 0u)
        << r.err;
    EXPECT_FALSE(file_exists(d / "x.png"));
    EXPECT_TRUE(temp_files_in(d.path()).empty());
    EXPECT_EQ(run_spectex({"render", "--help"}).status, 0);
}

// ---------------------------------------------------------------------------------------------
// plot

TEST(Plot, WritesValidSvgWithOnePathPerPixelAxesAndLegend) {
    ScratchDir d;
    const std::string& exr = chart_exr();
    RunResult r = run_spectex({"plot", exr, "--pixel", "40,200", "--pixel", "0,0", "--pixel",
                               "300,250", "--light", "A", "-o", d / "p.svg"});
    ASSERT_EQ(r.status, 0) << r.err;
    auto [st, out] = run_python(
        "import sys, xml.etree.ElementTree as E\n"
        "ns='{http://www.w3.org/2000/svg}'\n"
        "root=E.parse(sys.argv[1]).getroot()\n"
        "assert root.tag==ns+'svg' and root.get('version')=='1.1'\n"
        "paths=root.findall('.//'+ns+'path')\n"
        "spectra=[p for p in paths if p.get('class')=='spectrum']\n"
        "print(len(spectra), len([p for p in paths if p.get('class')=='light']))\n"
        "print(' '.join(p.get('stroke') for p in spectra))\n"
        "texts=[t.text for t in root.iter(ns+'text')]\n"
        "print('|'.join(texts))\n",
        {d / "p.svg"});
    if (st == 127) GTEST_SKIP() << "no python3";
    ASSERT_EQ(st, 0) << out;
    EXPECT_EQ(out.substr(0, 4), "3 1\n") << out;
    // Line colours are the D65 sRGB codes: the source codes of the bake.
    Png src = read_png(kChart);
    char hex[3][16];
    int i = 0;
    for (auto [x, y] : std::vector<std::pair<int, int>>{{40, 200}, {0, 0}, {300, 250}}) {
        std::snprintf(hex[i++], 16, "#%02x%02x%02x", src.at(x, y)[0], src.at(x, y)[1],
                      src.at(x, y)[2]);
    }
    EXPECT_NE(out.find(std::string(hex[0]) + " " + hex[1] + " " + hex[2]), std::string::npos)
        << out;
    EXPECT_NE(out.find("Wavelength (nm)"), std::string::npos);
    EXPECT_NE(out.find("Reflectance"), std::string::npos);
    EXPECT_NE(out.find("|400|"), std::string::npos) << out;
    EXPECT_NE(out.find("pixel 40,200  sRGB"), std::string::npos) << out;
    EXPECT_NE(out.find("A (power, scaled)"), std::string::npos) << out;
    EXPECT_TRUE(temp_files_in(d.path()).empty());

    r = run_spectex({"plot", exr, "--pixel", "9999,1", "-o", d / "q.svg"});
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("pixel 9999,1 is outside the data window 0,0 - 511,255"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(file_exists(d / "q.svg"));
    EXPECT_EQ(run_spectex({"plot", exr, "--pixel", "1x1", "-o", d / "q.svg"}).status, 2);
    EXPECT_EQ(run_spectex({"plot", exr, "-o", d / "q.svg"}).status, 2);
    EXPECT_EQ(run_spectex({"plot", "--help"}).status, 0);
}

// ---------------------------------------------------------------------------------------------
// Premultiplied alpha: colours are of the spectrum divided by A, in sample and render.

TEST(Render, PremultipliedSpectraAreDividedByAlphaAndAlphaIsKept) {
    ScratchDir d;
    const int w = 17, h = 9;
    std::mt19937 rng(5);
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 4);
    for (size_t i = 0; i < px.size(); ++i)
        px[i] = static_cast<uint8_t>(i % 4 == 3 ? 128 + (rng() & 127) : rng() & 255);
    px[3] = 0;  // pixel 0,0 fully transparent
    write_image(d / "in.png", w, h, 4, OIIO::TypeDesc::UINT8, px.data());
    ASSERT_EQ(run_spectex({"bake", d / "in.png", "-o", d / "in.exr", "-q"}).status,
              0);                    // associated (default)
    px = read_png(d / "in.png").px;  // the codes as stored (OIIO's writer may have altered them)

    RunResult r = run_spectex({"render", d / "in.exr", "-o", d / "out.png", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    Png out = read_png(d / "out.png");
    ASSERT_EQ(out.nch, 4);
    int worst = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const uint8_t* s = &px[(static_cast<size_t>(y) * w + x) * 4];
            const uint8_t* o = out.at(x, y);
            EXPECT_EQ(o[3], s[3]) << x << "," << y;
            if (s[3] == 0) {
                EXPECT_EQ(o[0] + o[1] + o[2], 0);
                continue;
            }
            for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(o[c]) - int(s[c])));
        }
    EXPECT_LE(worst, 1);

    r = run_spectex({"sample", d / "in.exr", "0,0", "5,4"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("# pixel 0,0: A 0: transparent"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("# pixel 0,0 under"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("# pixel 5,4: A "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("(premultiplied): the colours are of the spectrum divided by A"),
              std::string::npos);
    int c[3];
    ASSERT_EQ(std::sscanf(one_attr_after(r.out, "# pixel 5,4 under D65: ").c_str(),
                          "linear Rec.709 %*f %*f %*f"),
              0);
    ASSERT_EQ(
        std::sscanf(one_attr_after(r.out.substr(r.out.find("# pixel 5,4 under D65")), "sRGB 8-bit ")
                        .c_str(),
                    "%d %d %d", &c[0], &c[1], &c[2]),
        3);
    const uint8_t* s = &px[(static_cast<size_t>(4) * w + 5) * 4];
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(c[i], s[i], 1);
}

// An SVG declared UTF-8 holds only UTF-8, whatever bytes a file name, --title or a light's name
// holds: others are shown escaped, so that every XML parser reads the plot.
TEST(Plot, WritesWellFormedUtf8Xml) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 8, 4), exr = d / "caf\xe9.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    std::ofstream(d / "l\xe9mpara.csv") << "wavelength,value\n380,1\n780,1\n";
    const std::vector<std::vector<std::string>> cases = {
        {}, {"--title", "caf\xe9 \x01<b>&"}, {"--light", d / "l\xe9mpara.csv"}};
    int k = 0;
    for (const auto& extra : cases) {
        const std::string svg = d / ("p" + std::to_string(k++) + ".svg");
        std::vector<std::string> args = {"plot", exr, "--pixel", "1,1", "-o", svg};
        args.insert(args.end(), extra.begin(), extra.end());
        RunResult r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << r.err;
        // An independent XML parser (Python's expat) must accept it.
        const int rc = std::system(("python3 -c 'import sys, xml.dom.minidom as m; "
                                    "m.parse(sys.argv[1])' '" +
                                    svg + "'")
                                       .c_str());
        EXPECT_EQ(rc, 0) << svg << " is not well-formed XML";
        EXPECT_TRUE(has_text(read_file(svg), "caf\\xe9")) << "the name's bytes are not shown";
    }
}

// A pixel coordinate takes every int an OpenEXR data window may hold (a lower limit would
// refuse pixels of a legal file); outside the window is exit 1, a malformed number exit 2.
TEST(Sample, TakesEveryCoordinateADataWindowMayHold) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 8, 4);
    ASSERT_EQ(run_spectex({"bake", png, "-o", d / "a.exr", "-q"}).status, 0);
    for (const std::string xy : {"2147483647,0", "0,-2147483648", "0,2147483647", "1000000006,1"}) {
        RunResult r = run_spectex({"sample", d / "a.exr", xy});
        EXPECT_EQ(r.status, 1) << xy << ": " << r.err;
        EXPECT_TRUE(has_text(r.err, "outside the data window")) << xy << ": " << r.err;
    }
    for (const std::string xy : {"2147483648,0", "+1,0", "0x1,0", "1,2,3"}) {
        RunResult r = run_spectex({"sample", d / "a.exr", xy});
        EXPECT_EQ(r.status, 2) << xy << ": " << r.err;
    }
    // A data window far from the origin: its pixels are found.
    std::vector<float> px(3 * 2 * 1, 0.25f);
    OIIO::ImageSpec spec(2, 1, 3, OIIO::TypeDesc::FLOAT);
    spec.x = 1000000005;
    spec.full_x = 1000000005;
    spec.channelnames = {"T.450nm", "T.550nm", "T.650nm"};
    spec.attribute("spectralLayoutVersion", "1.0");
    auto out = OIIO::ImageOutput::create(d / "far.exr");
    ASSERT_TRUE(out && out->open(d / "far.exr", spec) &&
                out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close());
    RunResult f = run_spectex({"sample", d / "far.exr", "1000000006,0"});
    EXPECT_EQ(f.status, 0) << f.err;
}

// sample's CSV gives the samples as stored: a NaN and an infinity were both written "null", so
// the two could not be told apart. The CSV says nan, inf and -inf (what CSV readers parse); the
// JSON, which has no word for them, keeps null.
TEST(Sample, NonFiniteSamplesAreNamedInTheCsv) {
    ScratchDir d;
    const float nan = std::numeric_limits<float>::quiet_NaN(),
                inf = std::numeric_limits<float>::infinity();
    std::vector<float> px = {nan, inf, -inf, 0.5f};
    OIIO::ImageSpec spec(1, 1, 4, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"T.450nm", "T.550nm", "T.650nm", "T.700nm"};
    spec.attribute("spectralLayoutVersion", "1.0");
    write_image(d / "nf.exr", spec, OIIO::TypeDesc::FLOAT, px.data());
    const RunResult r = run_spectex({"sample", d / "nf.exr", "0,0"});
    EXPECT_EQ(r.status, 0) << r.err;
    for (const char* line : {"0,0,450,nan\n", "0,0,550,inf\n", "0,0,650,-inf\n", "0,0,700,0.5\n"})
        EXPECT_TRUE(has_text(r.out, line)) << line << " in\n" << r.out;
    EXPECT_FALSE(has_text(r.out, "null")) << r.out;
    const RunResult j = run_spectex({"sample", d / "nf.exr", "0,0", "--json"});
    EXPECT_EQ(j.status, 0) << j.err;
    EXPECT_TRUE(has_text(j.out, "null")) << j.out;
}

// The spectral reader decodes scanline ZIP, ZIPS and uncompressed files itself (one inflation,
// its own un-interleaving and half conversion) and the rest through OpenEXR's InputFile. Every
// sample it hands sample must be the one OpenEXR's own reader gives, bit for bit (sample prints 9
// significant digits: a float's exact value), for each compression, on a file that takes each
// path's corner cases: an odd width (a float line at an offset not a multiple of 4 after a half
// one), half and float channels mixed, a channel the reader does not want (R) between them, alpha,
// a data window whose origin is not 0 (chunks count from its top row), a last chunk short of 16
// rows.
TEST(Sample, EverySampleIsOpenExrsOwnReadWhateverTheCompression) {
    ScratchDir d;
    const int w = 37, h = 21;
    for (const char* compression : {"zip", "zips", "none", "piz", "rle"}) {
        SCOPED_TRACE(compression);
        const std::string path = d / (std::string(compression) + ".exr");
        OIIO::ImageSpec spec(w, h, 6, OIIO::TypeDesc::FLOAT);
        spec.x = 3;
        spec.y = -5;
        spec.channelnames = {"A", "R", "T.450nm", "T.550nm", "T.650nm", "T.700nm"};
        spec.channelformats = {OIIO::TypeDesc::HALF, OIIO::TypeDesc::HALF,  OIIO::TypeDesc::FLOAT,
                               OIIO::TypeDesc::HALF, OIIO::TypeDesc::FLOAT, OIIO::TypeDesc::UINT};
        spec.alpha_channel = 0;
        spec.attribute("spectralLayoutVersion", "1.0");
        spec.attribute("compression", compression);
        std::vector<float> px(static_cast<size_t>(w) * h * 6);
        for (size_t i = 0; i < px.size(); ++i)
            px[i] = static_cast<float>((i * 2654435761u) % 100003) / 100003.0f;
        write_image(path, spec, OIIO::TypeDesc::FLOAT, px.data());
        const ExrImage want = read_exr(path);
        std::vector<std::string> args = {"sample", path, "--json", "--"};
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                args.push_back(std::to_string(3 + x) + "," + std::to_string(y - 5));
        const RunResult r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << r.err;
        const nlohmann::json j = nlohmann::json::parse(r.out);
        ASSERT_EQ(j["pixels"].size(), static_cast<size_t>(w * h));
        size_t differ = 0;
        for (const auto& p : j["pixels"]) {
            const int x = p["x"].get<int>() - 3, y = p["y"].get<int>() + 5;
            const auto& values = p["values"];
            ASSERT_EQ(values.size(), 4u);
            const char* bins[] = {"T.450nm", "T.550nm", "T.650nm", "T.700nm"};
            for (size_t k = 0; k < 4; ++k)
                differ += static_cast<float>(values[k].get<double>()) != want.at(bins[k], x, y);
            differ += static_cast<float>(p["alpha"].get<double>()) != want.at("A", x, y);
        }
        EXPECT_EQ(differ, 0u);
    }
}

TEST(Plot, RefusesAnOutputThatIsNotSvgAndCountsRight) {
    ScratchDir d;
    const std::string exr = bake_albedo(d);
    RunResult r = run_spectex({"plot", exr, "--pixel", "1,1", "-o", d / "p.png"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find(".svg"), std::string::npos) << r.err;
    EXPECT_FALSE(file_exists(d / "p.png"));
    RunResult ok = run_spectex({"plot", exr, "--pixel", "1,1", "-o", d / "p.svg"});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_NE(ok.out.find("1 spectrum "), std::string::npos) << ok.out;
}

TEST(Info, NamesTheUnitOnceForEveryGridKind) {
    ScratchDir d;
    const std::string in = write_albedo(d);
    write_text(d / "list.txt", "400\n450\n520\n610\n700\n");
    write_text(d / "one.txt", "550\n");
    struct Case {
        std::vector<std::string> grid;
        std::string want;
    };
    const std::vector<Case> cases = {
        {{"--wavelengths", "400:700:10"}, "400:700:10 nm"},
        {{"--wavelengths-file", d / "list.txt", "--allow-infeasible"}, "400-700 nm"},
    };
    for (const auto& c : cases) {
        const std::string exr = d / "g.exr";
        // Every bit kept: bits of their own for each grid would be chosen on every 8-bit colour.
        std::vector<std::string> args = {"bake", in, "-o", exr, "-q", "--precision", "full"};
        args.insert(args.end(), c.grid.begin(), c.grid.end());
        RunResult b = run_spectex(args);
        ASSERT_EQ(b.status, 0) << b.err;
        RunResult i = run_spectex({"info", exr});
        EXPECT_NE(i.out.find(c.want + "\n"), std::string::npos) << i.out;
        EXPECT_EQ(i.out.find("nm nm"), std::string::npos) << i.out;
    }
}
