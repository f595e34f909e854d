// spectex verify, end to end: files baked by spectex, altered copies, files written here with
// OpenEXR the way another tool would (comma channel names, float, tiled, premultiplied alpha, no
// spectex attributes), non-spectral files, usage errors, and the peak memory of a 2K, 81-bin run.
#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfTiledOutputFile.h>
#include <OpenImageIO/imagebuf.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <random>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

// A number in the one-line JSON of `verify --json`: the first "key": after `object` (a key path
// prefix such as "\"ciede2000\":{"). NaN when absent or null.
double json_number(const std::string& json, const std::string& object, const std::string& key) {
    size_t at = object.empty() ? 0 : json.find(object);
    if (at == std::string::npos) return std::nan("");
    size_t k = json.find("\"" + key + "\":", at);
    if (k == std::string::npos) return std::nan("");
    const char* s = json.c_str() + k + key.size() + 3;
    if (std::string(s, 4) == "null") return std::nan("");
    return std::strtod(s, nullptr);
}

// An 8-bit sRGB image of w x h random codes (fixed seed), with the pure primaries, black and white
// in its first pixels; nch = 3 or 4 (alpha codes random too, never 0).
std::vector<uint8_t> random_codes(int w, int h, int nch, unsigned seed = 7) {
    std::mt19937 rng(seed);
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * nch);
    for (auto& v : px) v = static_cast<uint8_t>(rng() & 0xff);
    const uint8_t fixed[5][3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {0, 0, 0}, {255, 255, 255}};
    for (int i = 0; i < 5 && i < w * h; ++i)
        for (int c = 0; c < 3; ++c) px[static_cast<size_t>(i) * nch + c] = fixed[i][c];
    if (nch == 4)
        for (size_t i = 0; i < px.size(); i += 4)
            px[i + 3] = static_cast<uint8_t>(std::max(1, int(px[i + 3])));
    return px;
}

std::string make_png(const ScratchDir& dir, const std::string& name, int w, int h, int nch = 3) {
    std::string path = dir / name;
    auto px = random_codes(w, h, nch);
    write_image(path, w, h, nch, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

// Copies an EXR (all channels as float) with one channel scaled.
void write_scaled_copy(const std::string& in, const std::string& out, const std::string& channel,
                       float k) {
    ExrImage img = read_exr(in);
    ASSERT_TRUE(img.has(channel)) << channel;
    for (float& v : img.pixels[channel]) v *= k;
    Imf::Header h = img.header;
    Imf::OutputFile file(out.c_str(), h);
    Imf::FrameBuffer fb;
    const auto& dw = img.data_window;
    // Write each channel in its own type: half channels through a half buffer.
    std::map<std::string, std::vector<half>> halves;
    for (const auto& name : img.channel_names) {
        const auto& v = img.pixels[name];
        if (img.types[name] == Imf::HALF) {
            auto& hv = halves[name];
            hv.assign(v.begin(), v.end());
            fb.insert(name, Imf::Slice::Make(Imf::HALF, hv.data(), dw));
        } else {
            fb.insert(name, Imf::Slice::Make(Imf::FLOAT, v.data(), dw));
        }
    }
    file.setFrameBuffer(fb);
    file.writePixels(img.height);
}

// Runs spectex and returns its exit status with the peak RSS (KiB) of that child alone (wait4).
struct Measured {
    int status = -1;
    long max_rss_kib = 0;
    double seconds = 0;
};
Measured run_measured(const std::vector<std::string>& args) {
    std::vector<std::string> argv_s = spectex_argv(args);
    std::vector<char*> argv = c_array(argv_s);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    Measured m;
    auto t0 = std::chrono::steady_clock::now();
    pid_t pid;
    if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) == 0) {
        int st = 0;
        struct rusage ru {};
        wait4(pid, &st, 0, &ru);
        m.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        m.max_rss_kib = ru.ru_maxrss;
    }
    m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    posix_spawn_file_actions_destroy(&fa);
    return m;
}

const std::string kFittedBasis =
    std::string(SPECTEX_TEST_DATA_DIR) + "/spectral/basis_fit_smooth_380-780-5.csv";

}  // namespace

TEST(Verify, FloatBakeRoundTripsWithinHundredthOfDeltaE) {
    ScratchDir d;
    std::string png = make_png(d, "in.png", 61, 37);
    std::string exr = d / "out.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "--type", "float", "-q"}).status, 0);
    RunResult r = run_spectex({"verify", exr, "--source", png, "--json", "-", "--max-de", "0.01",
                               "--min-code-match", "100"});
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_EQ(json_number(r.out, "", "schema_version"), 2.0);
    EXPECT_EQ(json_number(r.out, "", "pixels"), 61.0 * 37.0);
    EXPECT_EQ(json_number(r.out, "", "bins"), double(kDefaultBins));
    EXPECT_EQ(json_number(r.out, "", "wavelength_min"), 400.0);
    EXPECT_EQ(json_number(r.out, "", "wavelength_max"), 700.0);
    const double de_max = json_number(r.out, "\"ciede2000\":{", "max");
    EXPECT_LT(de_max, 0.01);
    EXPECT_GE(de_max, 0.0);
    EXPECT_LE(json_number(r.out, "\"ciede2000\":{", "p99"), de_max);
    EXPECT_LE(json_number(r.out, "\"ciede2000\":{", "mean"), de_max);
    EXPECT_LT(json_number(r.out, "\"rgb_error\":{", "max"), 1e-5);
    EXPECT_EQ(json_number(r.out, "\"code_match\":{", "share"), 1.0);
    EXPECT_EQ(json_number(r.out, "\"nonfinite\":{", "count"), 0.0);
    EXPECT_NE(r.out.find("\"passed\":true"), std::string::npos);

    // The text report says the same.
    RunResult t = run_spectex({"verify", exr, "--source", png});
    ASSERT_EQ(t.status, 0) << t.err;
    EXPECT_NE(t.out.find("CIEDE2000"), std::string::npos);
    EXPECT_NE(t.out.find("result:               ok"), std::string::npos);
    EXPECT_NE(t.out.find(kDefaultGrid), std::string::npos);
}

TEST(Verify, HalfBakeFailsMaxDeZeroAndPassesAReasonableOne) {
    ScratchDir d;
    std::string png = make_png(d, "in.png", 64, 48);
    std::string exr = d / "half.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    RunResult ok = run_spectex({"verify", exr, "--source", png, "--json", "-", "--max-de", "0.5"});
    ASSERT_EQ(ok.status, 0) << ok.out << ok.err;
    const double de_max = json_number(ok.out, "\"ciede2000\":{", "max");
    EXPECT_GT(de_max, 0.0);  // half rounding is visible to a strict threshold
    EXPECT_LT(de_max, 0.5);
    RunResult bad = run_spectex({"verify", exr, "--source", png, "--max-de", "0"});
    EXPECT_EQ(bad.status, 1) << bad.out << bad.err;
    EXPECT_NE(bad.err.find("--max-de"), std::string::npos) << bad.err;
    EXPECT_NE(bad.err.find("spectex: " + exr + ": "), std::string::npos) << bad.err;
    EXPECT_NE(bad.out.find("FAILED"), std::string::npos) << bad.out;
    RunResult rgb = run_spectex({"verify", exr, "--source", png, "--max-rgb-error", "0"});
    EXPECT_EQ(rgb.status, 1);
    EXPECT_NE(rgb.err.find("--max-rgb-error"), std::string::npos) << rgb.err;
}

TEST(Verify, AlteredSpectraAreDetected) {
    ScratchDir d;
    std::string png = make_png(d, "in.png", 40, 30);
    std::string exr = d / "out.exr", altered = d / "altered.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "--type", "float", "-q"}).status, 0);
    write_scaled_copy(exr, altered, "T.550nm", 1.2f);
    RunResult a = run_spectex({"verify", exr, "--source", png, "--json", "-"});
    RunResult b = run_spectex({"verify", altered, "--source", png, "--json", "-", "--report-only"});
    ASSERT_EQ(a.status, 0) << a.err;
    ASSERT_EQ(b.status, 0) << b.err;
    // The default gates fail it: its codes no longer re-encode.
    RunResult gated = run_spectex({"verify", altered, "--source", png});
    EXPECT_EQ(gated.status, 1) << gated.out << gated.err;
    EXPECT_NE(gated.err.find("re-encode"), std::string::npos) << gated.err;
    const double de_a = json_number(a.out, "\"ciede2000\":{", "max"),
                 de_b = json_number(b.out, "\"ciede2000\":{", "max");
    EXPECT_GT(de_b, 0.1);
    EXPECT_GT(de_b, 100 * de_a);
    EXPECT_GT(json_number(b.out, "\"rgb_error\":{", "max"), 1e-3);
    EXPECT_LT(json_number(b.out, "\"code_match\":{", "share"), 1.0);
    EXPECT_EQ(run_spectex({"verify", altered, "--source", png, "--max-de", "0.05"}).status, 1);
    // Scaling a bin of white (1.0) by 1.2 puts samples above 1.
    EXPECT_GT(json_number(b.out, "\"outside_unit_interval\":{", "above"), 0.0);
    EXPECT_EQ(json_number(a.out, "\"outside_tolerance\":{", "count"), 0.0);
}

// A file another tool would write: "T.380,000000nm" float channels, tiled, PIZ, premultiplied A,
// no spectralLayoutVersion and no spectex attributes; spectra = fitted basis x linear RGB.
TEST(Verify, ForeignTiledFileWithPremultipliedAlpha) {
    ScratchDir d;
    const int w = 45, h = 33;
    auto codes = random_codes(w, h, 4, 11);
    std::string png = d / "src.png";
    write_image(png, w, h, 4, OIIO::TypeDesc::UINT8, codes.data(),
                {{"oiio:UnassociatedAlpha", "1"}});
    TestBasis basis = read_test_basis(kFittedBasis);
    ASSERT_EQ(basis.lambda.size(), 81u);

    Imf::Header hdr(w, h);
    hdr.compression() = Imf::PIZ_COMPRESSION;
    hdr.setTileDescription(Imf::TileDescription(16, 16, Imf::ONE_LEVEL));
    std::vector<std::string> names;
    for (double l : basis.lambda) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "T.%.6fnm", l);
        std::string n = buf;
        std::replace(n.begin(), n.end(), '.', ',');
        n[1] = '.';  // "T.380,000000nm"
        names.push_back(n);
        hdr.channels().insert(n, Imf::Channel(Imf::FLOAT));
    }
    EXPECT_EQ(names.front(), "T.380,000000nm");
    hdr.channels().insert("A", Imf::Channel(Imf::FLOAT));
    const size_t n = static_cast<size_t>(w) * h;
    std::vector<std::vector<float>> planes(basis.lambda.size(), std::vector<float>(n));
    std::vector<float> alpha(n);
    for (size_t i = 0; i < n; ++i) {
        double a = codes[4 * i + 3] / 255.0;
        auto s = expected_spectrum(srgb_to_linear(codes[4 * i] / 255.0),
                                   srgb_to_linear(codes[4 * i + 1] / 255.0),
                                   srgb_to_linear(codes[4 * i + 2] / 255.0), basis);
        for (size_t k = 0; k < s.size(); ++k) planes[k][i] = static_cast<float>(s[k] * a);
        alpha[i] = static_cast<float>(a);
    }
    std::string exr = d / "foreign.exr";
    {
        Imf::TiledOutputFile out(exr.c_str(), hdr);
        Imf::FrameBuffer fb;
        for (size_t k = 0; k < names.size(); ++k)
            fb.insert(names[k], Imf::Slice::Make(Imf::FLOAT, planes[k].data(), hdr.dataWindow()));
        fb.insert("A", Imf::Slice::Make(Imf::FLOAT, alpha.data(), hdr.dataWindow()));
        out.setFrameBuffer(fb);
        out.writeTiles(0, out.numXTiles() - 1, 0, out.numYTiles() - 1);
    }
    RunResult r = run_spectex({"verify", exr, "--source", png, "--json", "-", "--max-de", "0.01",
                               "--min-code-match", "100"});
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("\"alpha\":\"associated\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"storage\":\"tiled 16x16\""), std::string::npos) << r.out;
    EXPECT_LT(json_number(r.out, "\"rgb_error\":{", "max"), 1e-5);
    EXPECT_EQ(json_number(r.out, "\"source\":{", "compared_pixels"), static_cast<double>(n));
    // Band size does not matter: one thread, and a file read in many bands, give the same numbers.
    RunResult one = run_spectex({"verify", exr, "--source", png, "--json", "-", "--threads", "1"});
    ASSERT_EQ(one.status, 0);
    EXPECT_EQ(json_number(one.out, "\"ciede2000\":{", "max"),
              json_number(r.out, "\"ciede2000\":{", "max"));
    EXPECT_EQ(json_number(one.out, "\"ciede2000\":{", "mean"),
              json_number(r.out, "\"ciede2000\":{", "mean"));

    // Without a source: alpha is reported as associated (OpenEXR's convention, no spectex:alpha).
    RunResult nosrc = run_spectex({"verify", exr});
    EXPECT_EQ(nosrc.status, 0) << nosrc.err;
    EXPECT_NE(nosrc.out.find("A (associated)"), std::string::npos) << nosrc.out;
}

TEST(Verify, OtherIlluminantAndObserver) {
    ScratchDir d;
    std::string png = make_png(d, "in.png", 20, 20);
    std::string exr = d / "out.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "--type", "float", "-q"}).status, 0);
    // Checked under A, the baked spectra are not exact metamers of the source colours any more: the
    // default gates fail, and a warning says the file was baked for D65.
    RunResult a =
        run_spectex({"verify", exr, "--source", png, "--check-illuminant", "A", "--json", "-"});
    ASSERT_EQ(a.status, 1) << a.err;
    EXPECT_NE(a.out.find("\"illuminant\":\"A\""), std::string::npos);
    EXPECT_GT(json_number(a.out, "\"ciede2000\":{", "max"), 0.1);
    EXPECT_NE(a.err.find("warning: " + exr + ": --check-illuminant 'A' overrides the file's 'D65'"),
              std::string::npos)
        << a.err;
    // --illuminant A reports the colours under A next to D65, and gates nothing more.
    RunResult rep =
        run_spectex({"verify", exr, "--source", png, "--illuminant", "A", "--json", "-"});
    ASSERT_EQ(rep.status, 0) << rep.err;
    EXPECT_NE(rep.out.find("\"illuminant\":\"D65\""), std::string::npos);
    EXPECT_GT(json_number(rep.out, "\"other_lights\":[{", "mean"), 0.1) << rep.out;
    RunResult o = run_spectex({"verify", exr, "--observer", "cie1964-10"});
    EXPECT_EQ(o.status, 0) << o.err;
    // An unknown light is a setting, refused before the file is read: a usage error (exit 2) that
    // names the option rather than the file.
    RunResult bad = run_spectex({"verify", exr, "--illuminant", "nope"});
    EXPECT_EQ(bad.status, 2) << bad.err;
    EXPECT_EQ(bad.err.rfind("spectex verify: --illuminant: unknown illuminant 'nope'", 0), 0u)
        << bad.err;
    EXPECT_EQ(bad.err.find(exr), std::string::npos) << bad.err;
}

TEST(Verify, RejectsNonSpectralFilesMismatchedSourcesAndBadUsage) {
    ScratchDir d;
    std::string png = make_png(d, "in.png", 16, 8);
    std::string rgb_exr = d / "rgb.exr";
    std::vector<float> px(16 * 8 * 3, 0.5f);
    write_image(rgb_exr, 16, 8, 3, OIIO::TypeDesc::FLOAT, px.data());
    RunResult r = run_spectex({"verify", rgb_exr});
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("spectex: " + rgb_exr + ": not a spectral"), std::string::npos) << r.err;
    RunResult p = run_spectex({"verify", png});
    EXPECT_EQ(p.status, 1);
    EXPECT_NE(p.err.find("spectex: " + png + ": "), std::string::npos) << p.err;
    RunResult missing = run_spectex({"verify", d / "missing.exr"});
    EXPECT_EQ(missing.status, 1);

    std::string exr = d / "out.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    std::string other = make_png(d, "other.png", 8, 16);
    RunResult mm = run_spectex({"verify", exr, "--source", other});
    EXPECT_EQ(mm.status, 1);
    EXPECT_NE(mm.err.find("16x8"), std::string::npos) << mm.err;
    EXPECT_NE(mm.err.find("8x16"), std::string::npos) << mm.err;

    EXPECT_EQ(run_spectex({"verify"}).status, 2);
    EXPECT_EQ(run_spectex({"verify", exr, "--source", png, exr}).status,
              2);  // --source compares one file
    EXPECT_EQ(run_spectex({"verify", exr, "--max-de", "0.1"}).status, 2);  // needs --source
    EXPECT_EQ(run_spectex({"verify", exr, "--source", png, "--max-de", "abc"}).status, 2);
    EXPECT_EQ(run_spectex({"verify", exr, "--source", png, "--min-code-match", "101"}).status, 2);
    EXPECT_EQ(run_spectex({"verify", exr, "--bogus"}).status, 2);
    RunResult help = run_spectex({"verify", "--help"});
    EXPECT_EQ(help.status, 0);
    EXPECT_NE(help.out.find("--max-de"), std::string::npos);
    EXPECT_NE(help.out.find("--min-code-match"), std::string::npos);
}

// verify streams: a 2048 x 2048, 81-bin half file (1.3 GB of float samples if loaded whole) is
// measured in bands, with the source compared. The process itself (OpenImageIO, OpenColorIO and
// OpenEXR loaded, the OCIO config read) peaks near 150 MB on a tiny file, so the bound is on what
// the image adds to that baseline, measured the same way in the same run: under 48 MB, and well
// under 150 MB above it in absolute terms.
TEST(VerifySlow, BoundedMemoryOnA2KFile) {
    ScratchDir d;
    std::string small = make_png(d, "small.png", 64, 64);
    std::string small_exr = d / "small.exr";
    ASSERT_EQ(run_spectex({"bake", small, "-o", small_exr, "-q"}).status, 0);
    std::string png = make_png(d, "big.png", 2048, 2048);
    std::string exr = d / "big.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    Measured base = run_measured({"verify", small_exr, "--source", small, "--max-de", "0.5"});
    ASSERT_EQ(base.status, 0);
    Measured m = run_measured(
        {"verify", exr, "--source", png, "--max-de", "0.5", "--min-code-match", "99.99"});
    EXPECT_EQ(m.status, 0);
    EXPECT_GT(m.max_rss_kib, 0);
    const long added = m.max_rss_kib - base.max_rss_kib;
    // Under AddressSanitizer allocations carry redzones and quarantine: allow 4x there.
    const long limit = std::getenv("ASAN_OPTIONS") ? 4 * 48 * 1024 : 48 * 1024;
    EXPECT_LT(added, limit) << "peak RSS " << m.max_rss_kib << " KiB, baseline " << base.max_rss_kib
                            << " KiB";
    EXPECT_LT(m.max_rss_kib, base.max_rss_kib + 150 * 1024);
    std::printf(
        "verify 2048x2048x81 half with --source: %.2f s, peak RSS %.1f MiB (64x64 baseline %.1f "
        "MiB, "
        "+%.1f MiB)\n",
        m.seconds, m.max_rss_kib / 1024.0, base.max_rss_kib / 1024.0, added / 1024.0);
}

// Out-of-range and non-finite samples are counted exactly (strictly and beyond 1e-6), and a pixel
// whose colour is not finite fails any threshold (JSON null for the infinite error).
TEST(Verify, CountsOutOfRangeAndNonFiniteSamples) {
    ScratchDir d;
    const int w = 4, h = 2;
    TestBasis basis = read_test_basis(kFittedBasis);
    const size_t bins = basis.lambda.size(), n = static_cast<size_t>(w) * h;
    const double grey = srgb_to_linear(188 / 255.0);
    auto s = expected_spectrum(grey, grey, grey, basis);
    std::vector<std::vector<float>> planes(bins, std::vector<float>(n));
    for (size_t k = 0; k < bins; ++k)
        for (size_t i = 0; i < n; ++i) planes[k][i] = static_cast<float>(s[k]);
    planes[10][0] = std::nanf("");
    planes[20][1] = 1.5f;
    planes[30][2] = -0.5f;
    planes[40][3] = 1.0000005f;   // outside [0, 1], within 1e-6 of it
    planes[41][3] = -0.0000005f;  // likewise
    Imf::Header hdr(w, h);
    std::vector<std::string> names;
    for (double l : basis.lambda) {
        names.push_back("T." + std::to_string(static_cast<int>(l)) + "nm");
        hdr.channels().insert(names.back(), Imf::Channel(Imf::FLOAT));
    }
    std::string exr = d / "odd.exr";
    {
        Imf::OutputFile out(exr.c_str(), hdr);
        Imf::FrameBuffer fb;
        for (size_t k = 0; k < bins; ++k)
            fb.insert(names[k], Imf::Slice::Make(Imf::FLOAT, planes[k].data(), hdr.dataWindow()));
        out.setFrameBuffer(fb);
        out.writePixels(h);
    }
    RunResult r = run_spectex({"verify", exr, "--json", "-", "--report-only"});
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    // The default gates name both problems.
    RunResult gated = run_spectex({"verify", exr});
    EXPECT_EQ(gated.status, 1) << gated.out << gated.err;
    EXPECT_NE(gated.err.find("non-finite samples: 1 "), std::string::npos) << gated.err;
    EXPECT_NE(gated.err.find("samples outside [0, 1] by more than 1e-6: 2 "), std::string::npos)
        << gated.err;
    EXPECT_EQ(json_number(r.out, "", "samples"), static_cast<double>(n * bins));
    EXPECT_EQ(json_number(r.out, "\"nonfinite\":{", "count"), 1.0);
    EXPECT_EQ(json_number(r.out, "\"outside_unit_interval\":{", "count"), 4.0);
    EXPECT_EQ(json_number(r.out, "\"outside_unit_interval\":{", "below"), 2.0);
    EXPECT_EQ(json_number(r.out, "\"outside_unit_interval\":{", "above"), 2.0);
    EXPECT_EQ(json_number(r.out, "\"outside_tolerance\":{", "count"), 2.0);
    EXPECT_EQ(json_number(r.out, "\"outside_tolerance\":{", "below"), 1.0);
    EXPECT_EQ(json_number(r.out, "\"outside_tolerance\":{", "above"), 1.0);
    EXPECT_NE(r.out.find("\"alpha\":\"none\""), std::string::npos);

    std::vector<uint8_t> px(n * 3, 188);
    std::string png = d / "grey.png";
    write_image(png, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    RunResult c = run_spectex({"verify", exr, "--source", png, "--json", "-", "--max-de", "100"});
    EXPECT_EQ(c.status, 1) << c.out << c.err;
    EXPECT_EQ(json_number(c.out, "\"source\":{", "nonfinite_pixels"), 1.0);
    EXPECT_NE(c.out.find("\"ciede2000\":{\"max\":null"), std::string::npos) << c.out;
    // The four untouched pixels re-encode to 188; the four altered ones do not.
    EXPECT_EQ(json_number(c.out, "\"code_match\":{", "matched"), 4.0);
}

// A file baked with a relative source path is verified from another working folder, and after the
// source and output trees moved together (to another mount or machine).
TEST(Verify, TheRecordedSourceIsFoundFromAnywhere) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "proj").c_str(), 0755), 0);
    ASSERT_EQ(::mkdir((d / "proj/img").c_str(), 0755), 0);
    ASSERT_EQ(::mkdir((d / "proj/t6").c_str(), 0755), 0);
    pattern_png(d, "proj/img/albedo.png", 8, 4);
    // Bake from inside proj/t6 with a relative source, as a script run in the output folder does.
    RunResult b = run_shell("cd " + d.path() + "/proj/t6 && " + spectex_binary() +
                            " bake ../img/albedo.png -o albedo.exr -q");
    ASSERT_EQ(b.status, 0) << b.out;
    const ExrImage img = read_exr(d / "proj/t6/albedo.exr");
    EXPECT_EQ(img.attr("spectex:source"), "../img/albedo.png");
    EXPECT_EQ(img.attr("spectex:sourceAbsolute"), d.path() + "/proj/img/albedo.png");
    EXPECT_EQ(img.attr("spectex:sourceFromOutput"), "../img/albedo.png");
    // From another working folder.
    RunResult v = run_shell("cd / && " + spectex_binary() + " verify " + d.path() +
                            "/proj/t6/albedo.exr --source-from-header -q");
    EXPECT_EQ(v.status, 0) << v.out;
    // The whole tree moved: the absolute path is gone, the relative one holds.
    ASSERT_EQ(::rename((d / "proj").c_str(), (d / "moved").c_str()), 0);
    RunResult m = run_shell("cd / && " + spectex_binary() + " verify " + d.path() +
                            "/moved/t6/albedo.exr --source-from-header -q");
    EXPECT_EQ(m.status, 0) << m.out;
    // Nowhere to be found: the EXR is named, with every place tried.
    ASSERT_EQ(::unlink((d / "moved/img/albedo.png").c_str()), 0);
    RunResult g = run_spectex({"verify", d / "moved/t6/albedo.exr", "--source-from-header"});
    EXPECT_EQ(g.status, 1) << g.err;
    EXPECT_TRUE(has_text(g.err, "spectex: " + d.path() +
                                    "/moved/t6/albedo.exr: the source it records "
                                    "is not found (tried "))
        << g.err;
}

// The memory verify reserves is the bands of the files being read: a small file's band is its
// whole image (8x8x81 floats, 20 KB), so many small files at once are well within the limit.
TEST(Verify, ManySmallFilesAtOnceNeedOnlySmallBands) {
    ScratchDir d;
    make_png(d, "in.png", 8, 8);
    ASSERT_EQ(
        run_spectex({"bake", d / "in.png", "-o", d / "a0.exr", "--method", "basis", "-q"}).status,
        0);
    std::vector<std::string> args = {"verify", "-q", "--jobs", "40"};
    for (int k = 0; k < 40; ++k) {
        const std::string f = d / ("a" + std::to_string(k) + ".exr");
        if (k) std::filesystem::copy_file(d / "a0.exr", f);
        args.push_back(f);
    }
    const RunResult r = run_spectex(args);
    EXPECT_EQ(r.status, 0) << r.err;
}

// Past the limit, the refusal names the option whose cost it is (--jobs: each job reads two bands
// of its file, 8 MiB each, and its source's pixels) with what takes the memory. 33 jobs of a file
// whose band is full (256x128x81 floats, over 8 MiB) need 33 x 32 MiB = 1056 MiB, over 1 GiB.
TEST(Verify, TooManyLargeFilesAtOnceNameJobsAndTheirBands) {
    ScratchDir d;
    make_png(d, "in.png", 256, 128);
    ASSERT_EQ(
        run_spectex({"bake", d / "in.png", "-o", d / "big.exr", "--method", "basis", "-q"}).status,
        0);
    std::vector<std::string> args = {"verify", "--jobs", "33", "--threads", "1"};
    for (int k = 0; k < 33; ++k) {
        const std::string f = d / ("b" + std::to_string(k) + ".exr");
        std::filesystem::create_symlink(d / "big.exr", f);
        args.push_back(f);
    }
    const RunResult r = run_spectex(args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(has_text(r.err, "--jobs: 33 files at once need about 10")) << r.err;
    EXPECT_TRUE(has_text(r.err, "1056 MiB of bands")) << r.err;
    EXPECT_FALSE(has_text(r.err, "--illuminant:")) << r.err;
}

// A header's recorded settings are names, paths and numbers: a 100,000-character value (damage or
// a forgery) was printed whole in verify's errors and warnings, or refused the file. It is ignored
// with one warning naming the key, verify falls back as for a file that records nothing, and no
// line it prints is longer than a path.
TEST(Verify, AnAbsurdlyLongRecordedSettingIsIgnoredWithAWarning) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 4);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    for (const std::string key : {"spectex:illuminant", "spectex:observer",
                                  "spectex:inputColorSpace", "spectex:config", "spectex:method"}) {
        SCOPED_TRACE(key);
        const std::string out = d / "long.exr";
        {
            OIIO::ImageBuf buf(d / "a.exr");
            ASSERT_TRUE(buf.read());
            buf.specmod().attribute(key, std::string(100000, 'x'));
            ASSERT_TRUE(buf.write(out)) << buf.geterror();
        }
        const RunResult r = run_spectex({"verify", out, "--source", d / "a.png"});
        EXPECT_EQ(r.status, 0) << r.out << r.err.substr(0, 400);
        EXPECT_NE(
            r.err.find(key + " is 100000 characters long, not a value spectex writes: ignored"),
            std::string::npos)
            << r.err.substr(0, 400);
        std::istringstream lines(r.out + r.err);
        size_t longest = 0;
        for (std::string line; std::getline(lines, line);) longest = std::max(longest, line.size());
        EXPECT_LT(longest, 1000u);
    }
}

// spectex:alpha says how A relates to the spectra; a value spectex never writes was taken as
// associated without a word (an edited or foreign header changes what verify measures). It is
// still taken as OpenEXR's convention, and verify says so.
TEST(Verify, AnUnknownRecordedAlphaIsAWarning) {
    ScratchDir d;
    const std::string leaf =
        std::string(SPECTEX_TEST_SOURCE_DIR) + "/examples/textures/leaf_rgba.png";
    ASSERT_EQ(run_spectex({"bake", leaf, "-o", d / "a.exr", "--method", "basis", "--wavelengths",
                           "400:700:20", "--alpha", "unassociated"})
                  .status,
              0);
    const RunResult clean = run_spectex({"verify", d / "a.exr"});
    EXPECT_EQ(clean.status, 0) << clean.err;
    EXPECT_EQ(clean.err.find("is neither associated nor unassociated"), std::string::npos);
    {
        OIIO::ImageBuf buf(d / "a.exr");
        ASSERT_TRUE(buf.read());
        buf.specmod().attribute("spectex:alpha", "straight");
        ASSERT_TRUE(buf.write(d / "b.exr")) << buf.geterror();
    }
    const RunResult r = run_spectex({"verify", d / "b.exr"});
    EXPECT_TRUE(has_text(r.err,
                         "spectex:alpha 'straight' is neither associated nor unassociated: "
                         "A is taken as associated"))
        << r.err;
}
