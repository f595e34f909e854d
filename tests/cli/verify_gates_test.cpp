// spectex verify, right by default: it checks a file under what the file
// records (colour space, illuminant, observer, config, policies) without repeating options; its
// default gates pass every correct bake and fail wrong, out-of-range and NaN files, naming the
// gate; it takes many files, lists and JSON Lines like bake; other lights are reported, never
// gated.
#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

// 8-bit codes: random (fixed seed), with saturated primaries and black and white first.
std::string make_png(const ScratchDir& d, const std::string& name, int w, int h, int bits = 8,
                     unsigned seed = 3) {
    std::mt19937 rng(seed);
    const std::string path = d / name;
    if (bits == 8) {
        std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3);
        for (auto& v : px) v = static_cast<uint8_t>(rng() & 0xff);
        const uint8_t fixed[5][3] = {
            {255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {0, 0, 0}, {255, 255, 255}};
        for (int i = 0; i < 5; ++i)
            for (int c = 0; c < 3; ++c) px[static_cast<size_t>(i) * 3 + c] = fixed[i][c];
        write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    } else {
        std::vector<uint16_t> px(static_cast<size_t>(w) * h * 3);
        for (auto& v : px) v = static_cast<uint16_t>(rng() & 0xffff);
        write_image(path, w, h, 3, OIIO::TypeDesc::UINT16, px.data());
    }
    return path;
}

// Copies an EXR (channels as float, written back in their own types), letting the caller change the
// header (e.g. drop or set spectex:* attributes) and the spectral samples.
void rewrite(const std::string& in, const std::string& out,
             const std::function<void(Imf::Header&)>& header,
             const std::function<void(const std::string&, std::vector<float>&)>& pixels = nullptr) {
    ExrImage img = read_exr(in);
    Imf::Header h = img.header;
    header(h);
    std::map<std::string, std::vector<half>> halves;
    Imf::FrameBuffer fb;
    for (const auto& name : img.channel_names) {
        auto& v = img.pixels[name];
        if (pixels && name.rfind("T.", 0) == 0) pixels(name, v);
        if (img.types[name] == Imf::HALF) {
            auto& hv = halves[name];
            hv.assign(v.begin(), v.end());
            fb.insert(name, Imf::Slice::Make(Imf::HALF, hv.data(), img.data_window));
        } else {
            fb.insert(name, Imf::Slice::Make(Imf::FLOAT, v.data(), img.data_window));
        }
    }
    Imf::OutputFile file(out.c_str(), h);
    file.setFrameBuffer(fb);
    file.writePixels(img.height);
}

// A header without the spectex:* attributes, rebuilt rather than erased from (OpenEXR 3.1's
// Header::erase leaks the attribute: the sanitizer build caught it).
void drop_provenance(Imf::Header& h) {
    Imf::Header clean(h.displayWindow(), h.dataWindow(), h.pixelAspectRatio(),
                      h.screenWindowCenter(), h.screenWindowWidth(), h.lineOrder(),
                      h.compression());
    for (auto it = h.begin(); it != h.end(); ++it)
        if (std::string(it.name()).rfind("spectex:", 0) != 0)
            clean.insert(it.name(), it.attribute());
    h = clean;
}

bool has(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

}  // namespace

// A P3 bake and an illuminant-A bake verify clean without repeating their options; given
// options override the header, with one warning line each.
TEST(VerifyGates, UsesWhatTheFileRecords) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png", 48, 32);
    const std::string p3 = d / "p3.exr", a = d / "a.exr";
    // Every bit kept: bits of their own for these conditions would be chosen on every 8-bit
    // colour, and what the file records of its space and light is the same either way.
    ASSERT_EQ(run_spectex({"bake", png, "-o", p3, "--colorspace", "display_p3_tx", "--precision",
                           "full", "-q"})
                  .status,
              0);
    ASSERT_EQ(run_spectex({"bake", png, "-o", a, "--illuminant", "A", "--precision", "full", "-q"})
                  .status,
              0);

    RunResult v = run_spectex({"verify", p3, "--source", png});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
    EXPECT_TRUE(has(v.out, "sRGB Encoded P3-D65 - Texture")) << v.out;
    EXPECT_TRUE(has(v.out, "from the file's spectex:inputColorSpace")) << v.out;
    EXPECT_TRUE(v.err.empty()) << v.err;
    RunResult va = run_spectex({"verify", a, "--source", png});
    EXPECT_EQ(va.status, 0) << va.out << va.err;
    EXPECT_TRUE(has(va.out, "integrated under:     A,")) << va.out;

    // Overrides: the file is then checked as told, and fails, with one warning line naming both.
    RunResult wrong = run_spectex({"verify", p3, "--source", png, "--colorspace", "srgb_tx"});
    EXPECT_EQ(wrong.status, 1) << wrong.out << wrong.err;
    EXPECT_TRUE(has(wrong.err, "spectex: warning: " + p3 + ": --colorspace 'srgb_tx'"))
        << wrong.err;
    EXPECT_TRUE(has(wrong.err, "overrides the file's 'sRGB Encoded P3-D65 - Texture'"))
        << wrong.err;
    RunResult wa = run_spectex({"verify", a, "--source", png, "--check-illuminant", "D65"});
    EXPECT_EQ(wa.status, 1);
    EXPECT_TRUE(has(wa.err, "--check-illuminant 'D65' overrides the file's 'A'")) << wa.err;
    // The same name in another case is no mismatch.
    RunResult same = run_spectex({"verify", a, "--source", png, "--check-illuminant", "a"});
    EXPECT_EQ(same.status, 0) << same.err;
    EXPECT_FALSE(has(same.err, "warning")) << same.err;
}

// The OCIO config is the one the file records when it is still there; a changed or
// missing config is a warning, never a silent switch.
TEST(VerifyGates, TheRecordedConfigIsUsedAndItsChangesAreSaid) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png", 24, 16);
    const std::string cfg = d / "my.ocio", exr = d / "out.exr";
    {
        std::ifstream in(std::string(SPECTEX_TEST_DATA_DIR) + "/spectex.ocio");
        std::ofstream out(cfg);
        out << in.rdbuf();
    }
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "--config", cfg, "-q"}).status, 0);
    EXPECT_EQ(read_exr(exr).attr("spectex:config"), cfg);
    EXPECT_EQ(read_exr(exr).attr("spectex:configChecksum").rfind("fnv1a64:", 0), 0u);
    RunResult ok = run_spectex({"verify", exr, "--source", png}, {"OCIO=/nonexistent.ocio"});
    EXPECT_EQ(ok.status, 0) << ok.err;  // the recorded config, not $OCIO
    EXPECT_FALSE(has(ok.err, "warning")) << ok.err;
    {
        std::ofstream out(cfg, std::ios::app);
        out << "\n# edited after the bake\n";
    }
    // A comment changes nothing the file went through: no warning (the file records its colour
    // transform, spectex:colorTransform, and the config still makes the same one).
    RunResult commented = run_spectex({"verify", exr, "--source", png});
    EXPECT_EQ(commented.status, 0) << commented.err;
    EXPECT_FALSE(has(commented.err, "warning")) << commented.err;
    // The sRGB curve's gamma changed: the colours differ, and the warning says why.
    {
        std::ifstream in(cfg);
        std::stringstream text;
        text << in.rdbuf();
        std::string s = text.str();
        const size_t at = s.find("gamma: 2.4, offset: 0.055");
        ASSERT_NE(at, std::string::npos);
        s.replace(at, 10, "gamma: 2.5");
        std::ofstream out(cfg);
        out << s;
    }
    RunResult changed = run_spectex({"verify", exr, "--source", png});
    EXPECT_EQ(changed.status, 1) << changed.err;
    EXPECT_TRUE(has(changed.err, "otherwise than the one this file was baked with")) << changed.err;
    std::remove(cfg.c_str());
    RunResult gone = run_spectex({"verify", exr, "--source", png});
    EXPECT_EQ(gone.status, 0) << gone.err;  // the shipped config is the same
    EXPECT_TRUE(has(gone.err, "is not there")) << gone.err;
}

// The wrong-space file, the out-of-range file and the NaN file fail by default with the
// gate named and by how much; --report-only measures without gating; a correct bake passes every
// gate.
TEST(VerifyGates, DefaultGatesFailWrongFilesAndNameTheGate) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png", 40, 30);
    const std::string p3 = d / "p3.exr", good = d / "good.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", p3, "--colorspace", "display_p3_tx", "-q"}).status,
              0);
    ASSERT_EQ(run_spectex({"bake", png, "-o", good, "-q"}).status, 0);
    RunResult g = run_spectex({"verify", good, "--source", png});
    ASSERT_EQ(g.status, 0) << g.out << g.err;
    EXPECT_TRUE(has(g.out, "gate:                 CIEDE2000 max <= 0.5")) << g.out;
    EXPECT_TRUE(has(g.out, "re-encode to their 8-bit codes >= 100%: 100%")) << g.out;

    // Without provenance (as from another tool), a P3 file is checked as sRGB: wrong colours.
    const std::string foreign = d / "foreign.exr";
    rewrite(p3, foreign, drop_provenance);
    RunResult w = run_spectex({"verify", foreign, "--source", png});
    EXPECT_EQ(w.status, 1) << w.out << w.err;
    EXPECT_TRUE(has(w.err, "spectex: " + foreign + ": CIEDE2000 max: ")) << w.err;
    EXPECT_TRUE(has(w.err, "gate <= 0.5")) << w.err;
    EXPECT_TRUE(has(w.out, "FAILED")) << w.out;

    // 38 % of the samples above 1.
    const std::string over = d / "over.exr";
    rewrite(
        good, over, [](Imf::Header&) {},
        [](const std::string& name, std::vector<float>& v) {
            if (name < "T.530nm")
                for (float& x : v) x = 1.5f;
        });
    RunResult o = run_spectex({"verify", over});
    EXPECT_EQ(o.status, 1);
    EXPECT_TRUE(has(o.err, "samples outside [0, 1] by more than 1e-6: ")) << o.err;
    EXPECT_TRUE(has(o.err, "gate none")) << o.err;
    // ... unless the file records --out-of-range keep.
    const std::string kept = d / "kept.exr";
    rewrite(over, kept,
            [](Imf::Header& h) { h.insert("spectex:outOfRange", Imf::StringAttribute("keep")); });
    EXPECT_EQ(run_spectex({"verify", kept}).status, 0);

    // Every sample NaN.
    const std::string nan = d / "nan.exr";
    rewrite(
        good, nan, [](Imf::Header&) {},
        [](const std::string&, std::vector<float>& v) {
            for (float& x : v) x = std::nanf("");
        });
    RunResult n = run_spectex({"verify", nan, "--source", png});
    EXPECT_EQ(n.status, 1);
    EXPECT_TRUE(
        has(n.err, "non-finite samples: " + std::to_string(40 * 30 * kDefaultBins) + " (100%)"))
        << n.err;
    RunResult r = run_spectex({"verify", nan, "--source", png, "--report-only"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has(r.out, "gates:                none (--report-only)")) << r.out;
}

// 16-bit sources. Float keeps 16-bit codes (gated); half cannot, which is said, and the
// linear RGB error is gated instead.
TEST(VerifyGates, SixteenBitSourcesGetABoundFromTheSampleType) {
    ScratchDir d;
    const std::string tif = make_png(d, "in16.png", 32, 32, 16);
    const std::string h = d / "half.exr", f = d / "float.exr";
    ASSERT_EQ(run_spectex({"bake", tif, "-o", h, "-q"}).status, 0);
    ASSERT_EQ(run_spectex({"bake", tif, "-o", f, "--type", "float", "-q"}).status, 0);
    RunResult rf = run_spectex({"verify", f, "--source", tif});
    EXPECT_EQ(rf.status, 0) << rf.out << rf.err;
    EXPECT_TRUE(has(rf.out, "re-encode to their 16-bit codes >= 100%: 100%")) << rf.out;
    RunResult rh = run_spectex({"verify", h, "--source", tif});
    EXPECT_EQ(rh.status, 0) << rh.out << rh.err;
    // The default bake's coarser grids: the error beyond their 2^-10 share of the value
    // (precision_test.cpp bakes --precision full too, gated on the absolute error).
    EXPECT_TRUE(has(rh.out,
                    "linear RGB error beyond 2^-10 of the value, max (coarser grids) <= "
                    "0.0001"))
        << rh.out;
    EXPECT_FALSE(has(rh.out, "16-bit codes >= 100%")) << rh.out;
}

// Jakob-hanika spectra are not exact: no colour gates by default, thresholds still apply.
TEST(VerifyGatesSlow, InexactMethodsAreMeasuredNotGated) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png", 32, 16);
    const std::string jh = d / "jh.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", jh, "--method", "jakob-hanika", "-q"}).status, 0);
    RunResult v = run_spectex({"verify", jh, "--source", png});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
    EXPECT_TRUE(has(v.out, "colour gates off: jakob-hanika spectra are not exact")) << v.out;
    EXPECT_EQ(run_spectex({"verify", jh, "--source", png, "--max-de", "0.01"}).status, 1);
}

// Many files, --from-list, JSON Lines to a file or stdout, one line each and a summary,
// exit 1 when any fails, --jobs gives the same records; the report is never a file it reads.
TEST(VerifyGates, ManyFilesListsAndJsonLines) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png", 24, 24);
    const std::string a = d / "a.exr", b = d / "b.exr", bad = d / "bad.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", a, "-q"}).status, 0);
    ASSERT_EQ(run_spectex({"bake", png, "-o", b, "--type", "float", "-q"}).status, 0);
    rewrite(
        a, bad, [](Imf::Header&) {},
        [](const std::string&, std::vector<float>& v) { v[0] = std::nanf(""); });
    const std::string list = d / "list.txt";
    std::ofstream(list) << b << "\n" << bad << "\n";

    RunResult ok = run_spectex({"verify", a, b, "--source-from-header"});
    EXPECT_EQ(ok.status, 0) << ok.out << ok.err;
    const std::string bins = std::to_string(kDefaultBins) + " bins";
    EXPECT_TRUE(has(ok.out, a + ": ok (" + bins + ", half, CIEDE2000 max ")) << ok.out;
    EXPECT_TRUE(has(ok.out, b + ": ok (" + bins + ", float, ")) << ok.out;
    EXPECT_TRUE(has(ok.out, "2 files: 2 passed, 0 failed, 0 unreadable")) << ok.out;

    const std::string report = d / "report.jsonl";
    RunResult mixed =
        run_spectex({"verify", a, "--from-list", list, d / "missing.exr", "--json", report});
    EXPECT_EQ(mixed.status, 1);
    EXPECT_TRUE(has(mixed.out, bad + ": FAILED")) << mixed.out;
    EXPECT_TRUE(has(mixed.out, "4 files: 2 passed, 1 failed, 1 unreadable")) << mixed.out;
    const std::string text = read_file(report);
    std::istringstream lines(text);
    std::vector<std::string> rec;
    for (std::string l; std::getline(lines, l);) rec.push_back(l);
    ASSERT_EQ(rec.size(), 4u) << text;
    // In the order given: the paths, then the list's.
    EXPECT_TRUE(has(rec[0], "\"file\":\"" + a + "\"") && has(rec[0], "\"passed\":true")) << rec[0];
    EXPECT_TRUE(has(rec[1], "\"error\":") && has(rec[1], "missing.exr")) << rec[1];
    EXPECT_TRUE(has(rec[2], "\"file\":\"" + b + "\"") && has(rec[2], "\"passed\":true")) << rec[2];
    EXPECT_TRUE(has(rec[3], "\"file\":\"" + bad + "\"") && has(rec[3], "\"passed\":false"))
        << rec[3];
    for (const auto& l : rec) EXPECT_TRUE(has(l, "\"schema_version\":2")) << l;

    RunResult j2 = run_spectex({"verify", a, "--from-list", list, "--json", "-", "--jobs", "2"});
    RunResult j1 = run_spectex({"verify", a, "--from-list", list, "--json", "-", "--jobs", "1"});
    EXPECT_EQ(j1.status, 1);
    EXPECT_EQ(j2.status, 1);
    auto strip_seconds = [](std::string s) {
        for (size_t p; (p = s.find("\"seconds\":")) != std::string::npos;) {
            const size_t e = s.find('}', p);
            s.erase(p, e - p);
        }
        return s;
    };
    EXPECT_EQ(strip_seconds(j1.out), strip_seconds(j2.out));

    // The report may not be a file the command reads.
    const std::string before = read_file(list);
    EXPECT_EQ(run_spectex({"verify", a, "--from-list", list, "--json", list}).status, 2);
    EXPECT_EQ(read_file(list), before);
    EXPECT_EQ(run_spectex({"verify", a, "--json", a}).status, 2);
    EXPECT_EQ(run_spectex({"verify", a, b, "--source", png}).status, 2);
}

// Other lights are reported next to the check light, for a user to compare methods on
// their own texture; with a source the D65 check stays the gate.
TEST(VerifyGates, OtherLightsAreReportedNotGated) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png", 32, 32);
    const std::string basis = d / "basis.exr", lattice = d / "lattice.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", basis, "-q"}).status, 0);
    ASSERT_EQ(run_spectex({"bake", png, "-o", lattice, "--method", "lattice", "-q"}).status, 0);
    RunResult v = run_spectex({"verify", basis, lattice, "--illuminant", "A,FL11", "--json", "-"});
    ASSERT_EQ(v.status, 0) << v.err;
    std::istringstream lines(v.out);
    std::string l1, l2;
    std::getline(lines, l1);
    std::getline(lines, l2);
    for (const auto* l : {&l1, &l2}) {
        EXPECT_TRUE(has(*l, "\"other_lights\":[{\"illuminant\":\"A\",\"adaptation\":\"bradford\""))
            << *l;
        EXPECT_TRUE(has(*l, "{\"illuminant\":\"FL11\"")) << *l;
    }
    // The two methods give the same D65 colours but not the same colours under A.
    EXPECT_NE(l1.substr(l1.find("\"other_lights\"")), l2.substr(l2.find("\"other_lights\"")));
    // With a source: the other light never fails the file.
    RunResult s =
        run_spectex({"verify", basis, "--source", png, "--illuminant", "A", "--max-de", "0.1"});
    EXPECT_EQ(s.status, 0) << s.out << s.err;
    EXPECT_TRUE(has(s.out, "under A (Bradford to D65's white)")) << s.out;
    EXPECT_TRUE(has(s.out, "(reported, not gated)")) << s.out;
    EXPECT_EQ(run_spectex({"verify", basis, "--illuminant", "A,,FL11"}).status, 2);
    // An unknown light is a setting, refused before the file is read: exit 2, naming the option.
    RunResult u = run_spectex({"verify", basis, "--illuminant", "nosuch"});
    EXPECT_EQ(u.status, 2) << u.err;
    EXPECT_TRUE(has(u.err, "--illuminant: unknown illuminant 'nosuch'")) << u.err;
}

// The code-match check re-encodes through the config's own inverse transform,
// never by the names of our config's spaces: a studio config that calls its sRGB texture space
// something else keeps the check (100 % of the 8-bit codes).
TEST(VerifyGates, CodeMatchFollowsTheTransformNotTheSpacesName) {
    ScratchDir d;
    const std::string png = make_png(d, "in.png", 24, 16);
    const std::string cfg = d / "studio.ocio", exr = d / "out.exr";
    std::string text;
    {
        std::ifstream in(std::string(SPECTEX_TEST_DATA_DIR) + "/spectex.ocio");
        text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    auto replace_all = [&text](const std::string& from, const std::string& to) {
        size_t n = 0;
        for (size_t p = text.find(from); p != std::string::npos;
             p = text.find(from, p + to.size())) {
            text.replace(p, from.size(), to);
            ++n;
        }
        return n;
    };
    ASSERT_GT(replace_all("sRGB - Texture", "Studio Albedo 8bit"), 3u);
    ASSERT_EQ(
        replace_all("aliases: [srgb_tx, srgb_texture, Utility - Studio Albedo 8bit, sRGB, srgb, "
                    "sRGB Encoded Rec.709 (sRGB), srgb_encoded_rec709_srgb, srgb_rec709_scene, "
                    "Input - Generic - Studio Albedo 8bit]",
                    "aliases: [albedo8]"),
        1u);
    std::ofstream(cfg) << text;
    RunResult b = run_spectex({"bake", png, "-o", exr, "--config", cfg, "-q"});
    ASSERT_EQ(b.status, 0) << b.err;
    EXPECT_EQ(read_exr(exr).attr("spectex:inputColorSpace"), "Studio Albedo 8bit");
    RunResult v = run_spectex({"verify", exr, "--source", png});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
    EXPECT_TRUE(has(v.out, "re-encode to their 8-bit codes >= 100%: 100%")) << v.out;
}
