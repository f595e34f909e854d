// spectex plan: a budget picks a known grid, an impossible one is exit 1 with the best
// achievable figure, --json is JSON, and the usage errors are exit 2.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/exr_read.h"
#include "io/provenance_keys.h"

using namespace spectex_test;
namespace key = spectex::provenance_key;

namespace {

// Three grids under D65 alone for the basis (about 1.2, 0.27 and 0.07 ΔE00 worst, docs/plan.md):
// fast enough. The basis, named: its figures are the documented ones (plan's default is bake's).
const std::vector<std::string> kThree = {"--method", "basis",   "--lights",
                                         "D65",      "--grids", "380:780:20,380:780:10,380:780:5"};

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& more) {
    a.insert(a.end(), more.begin(), more.end());
    return a;
}

size_t count(const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

void write_png(const std::string& path) {
    std::vector<unsigned char> px(8 * 8 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<unsigned char>((i * 37) % 256);
    write_image(path, 8, 8, 3, OIIO::TypeDesc::UINT8, px.data());
}

}  // namespace

TEST(Plan, BudgetPicksTheCheapestGridThatMeetsIt) {
    RunResult r = run_spectex(with(with({"plan"}, kThree), {"--max-de", "0.5"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("* 380:780:10 "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("fails: D65 "), std::string::npos) << r.out;  // 380:780:20 and why
    EXPECT_NE(r.out.find("more bins than 380:780:10"), std::string::npos) << r.out;
    // The chosen grid is checked on all 8-bit colours; the others are on the sample.
    EXPECT_NE(r.out.find("380:780:10         41     82  0.62 cube"), std::string::npos) << r.out;

    RunResult tight =
        run_spectex(with(with({"plan"}, kThree), {"--max-de", "0.15", "--colours", "sample"}));
    ASSERT_EQ(tight.status, 0) << tight.err;
    EXPECT_NE(tight.out.find("* 380:780:5 "), std::string::npos) << tight.out;
}

// Without a method, plan measures bake's default (the LHTSS lattice) and reports the bits its
// bake keeps; a method named is planned at full precision unless --precision auto is asked.
TEST(PlanSlow, WithoutAMethodPlansBakesDefaultWithItsBits) {
    const std::vector<std::string> quick = {
        "plan",   "--lights",        "D65", "--grids", "380:780:10", "--max-de", "5", "--colours",
        "sample", "--sample-stride", "51",  "--json",  "-"};
    RunResult r = run_spectex(quick);
    ASSERT_EQ(r.status, 0) << r.err;
    auto j = nlohmann::json::parse(r.out.substr(0, r.out.find('\n')));
    EXPECT_EQ(j["method"].get<std::string>().rfind("lattice 9, lhtss prior", 0), 0u) << j["method"];
    ASSERT_TRUE(j.contains("precision")) << r.out;
    EXPECT_EQ(j["precision"]["bits"].size(), 41u);
    r = run_spectex(with(quick, {"--method", "basis"}));
    ASSERT_EQ(r.status, 0) << r.err;
    j = nlohmann::json::parse(r.out.substr(0, r.out.find('\n')));
    EXPECT_EQ(j["method"].get<std::string>().rfind("basis", 0), 0u) << j["method"];
    EXPECT_FALSE(j.contains("precision")) << r.out;
    // --type float keeps every bit, the default's too.
    r = run_spectex(with(quick, {"--type", "float"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(nlohmann::json::parse(r.out.substr(0, r.out.find('\n'))).contains("precision"));
}

TEST(Plan, ImpossibleBudgetIsAnErrorWithTheBestAchievable) {
    RunResult r =
        run_spectex(with(with({"plan"}, kThree), {"--max-de", "0.001", "--colours", "sample"}));
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("spectex: no candidate grid meets 0.001"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("the best achievable is 0.0"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(380:780:5, under D65)"), std::string::npos) << r.err;
    // A range the observer does not cover is a clear error too.
    RunResult range = run_spectex(with(with({"plan"}, kThree), {"--range", "300:900"}));
    EXPECT_EQ(range.status, 1);
    EXPECT_NE(range.err.find("observer cie1931-2 covers 360 to 830 nm"), std::string::npos)
        << range.err;
}

TEST(Plan, JsonParses) {
    ScratchDir d;
    RunResult r = run_spectex(
        with(with({"plan"}, kThree), {"--colours", "sample", "--json", d / "plan.json"}));
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string json = read_file(d / "plan.json");
    EXPECT_NE(json.find("\"chosen\":\"380:780:10\""), std::string::npos) << json;
    EXPECT_NE(json.find("\"bytes_per_pixel\":82"), std::string::npos) << json;
    // An independent parser when there is one (python3 is on every Debian).
    if (std::system("python3 -c '' 2>/dev/null") == 0) {
        const std::string check =
            "python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); "
            "assert d[\"chosen\"]==\"380:780:10\" and len(d[\"grids\"])==3 and "
            "all(len(g[\"lights\"])==1 for g in d[\"grids\"])' '" +
            d / "plan.json" + "'";
        EXPECT_EQ(std::system(check.c_str()), 0) << json;
    }
    RunResult out =
        run_spectex(with(with({"plan"}, kThree), {"--colours", "sample", "--json", "-"}));
    ASSERT_EQ(out.status, 0) << out.err;
    EXPECT_EQ(out.out.rfind("{\"schema_version\":1,", 0), 0u) << out.out;
}

TEST(Plan, UsageErrors) {
    EXPECT_EQ(run_spectex({"plan", "--help"}).status, 0);
    EXPECT_EQ(run_spectex({"plan", "--reconstruction", "cubic"}).status, 2);
    EXPECT_EQ(run_spectex({"plan", "--range", "400.5:700"}).status, 2);
    EXPECT_EQ(run_spectex({"plan", "--max-de", "-1"}).status, 2);
    EXPECT_EQ(run_spectex({"plan", "--grids", "400:700:7"}).status, 2);
    EXPECT_EQ(run_spectex({"plan", "--method", "basis", "--lattice-size", "5"}).status, 2);
    EXPECT_EQ(run_spectex({"plan", "--lattice-size", "5", "--objective", "norm"}).status, 2);
}

// In a *Slow* suite: the whole suite runs it; the sanitizer run (minutes of its time under ASan)
// not: the plan search it runs is sanitized in the unit tests, and its bakes in others.
TEST(PlanSlow, BakeAutoRecordsTheChoiceAndUpdateTreatsItAsSettings) {
    ScratchDir d;
    write_png(d / "in.png");
    const std::vector<std::string> bake = {
        "bake", d / "in.png", "-o",  d / "out.exr", "--wavelengths",
        "auto", "--lights",   "D65", "--grids",     "380:780:20,380:780:10,380:780:5"};
    RunResult r = run_spectex(with(bake, {"--max-de", "0.5"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("--wavelengths auto: 380:780:10 (41 bins)"), std::string::npos) << r.err;
    ExrImage img = read_exr(d / "out.exr");
    EXPECT_EQ(img.attr("spectex:wavelengths"), "380:780:10");
    EXPECT_EQ(img.attr("spectex:planLights"), "D65");
    EXPECT_EQ(img.attr("spectex:planMaxDe"), "0.5");
    EXPECT_EQ(img.attr("spectex:planReconstruction"), "linear");
    EXPECT_EQ(img.attr("spectex:planRange"), "360:830");
    const double worst = std::atof(img.attr("spectex:planWorstDe").c_str());
    EXPECT_GT(worst, 0.2);  // 0.29 on the full cube under D65 (docs/plan.md)
    EXPECT_LT(worst, 0.5);

    // Same settings: skipped. Another budget that picks the same grid: rebuilt (the budget is a
    // setting).
    r = run_spectex(with(bake, {"--max-de", "0.5", "--update", "--json", "-"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(count(r.out, "\"status\":\"skipped\""), 1u) << r.out;
    r = run_spectex(with(bake, {"--max-de", "0.45", "--update", "--json", "-"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(count(r.out, "\"status\":\"ok\""), 1u) << r.out;
    img = read_exr(d / "out.exr");
    EXPECT_EQ(img.attr("spectex:wavelengths"), "380:780:10");
    EXPECT_EQ(img.attr("spectex:planMaxDe"), "0.45");
    // Another reconstruction is another setting too.
    r = run_spectex(
        with(bake, {"--max-de", "0.45", "--reconstruction", "box", "--update", "--json", "-"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(count(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_EQ(read_exr(d / "out.exr").attr("spectex:planReconstruction"), "box");

    // A budget no grid meets: exit 1, the best achievable, no file written.
    r = run_spectex({"bake", d / "in.png", "-o", d / "none.exr", "--wavelengths", "auto",
                     "--lights", "D65", "--max-de", "0.001", "--grids", "380:780:20,380:780:10"});
    EXPECT_EQ(r.status, 1);  // the work's answer, as in plan (checked once, before any input)
    EXPECT_NE(r.err.find("the best achievable is"), std::string::npos) << r.err;
    EXPECT_FALSE(file_exists(d / "none.exr"));
    // auto needs its lights and budget; they mean nothing without auto.
    EXPECT_EQ(run_spectex({"bake", d / "in.png", "-o", d / "x.exr", "--wavelengths", "auto",
                           "--lights", "A"})
                  .status,
              2);
    EXPECT_EQ(run_spectex(
                  {"bake", d / "in.png", "-o", d / "x.exr", "--method", "basis", "--max-de", "0.5"})
                  .status,
              2);
    // Without --method, the default bake's --precision auto takes them as its own.
    EXPECT_EQ(
        run_spectex({"bake", d / "in.png", "-o", d / "x.exr", "--max-de", "0.5", "-q"}).status, 0);
    EXPECT_EQ(read_exr(d / "x.exr").attr(key::kPrecisionMaxDe), "0.5");
}

// --nonuniform: under D65 and FL11 at 0.5 the search finds a grid with fewer
// bins than the uniform candidates (20 against 31 when this was written), the plan's own evaluation
// on the dense sample confirms it, --grid-file writes it for bake --wavelengths-file, and bake
// --wavelengths auto --nonuniform records it and treats --nonuniform as a setting. Slow: about 30
// CPU-s.
TEST(PlanSlow, NonuniformGridNeedsFewerBinsAndBakes) {
    ScratchDir d;
    const std::vector<std::string> scene = {
        "--lights", "D65,FL11", "--max-de", "0.5", "--grids", "400:700:10,380:780:10,400:700:20"};
    RunResult r = run_spectex(with(with({"plan", "--nonuniform", "--colours", "sample"}, scene),
                                   {"--json", d / "plan.json", "--grid-file", d / "grid.txt"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("non-uniform search: "), std::string::npos) << r.out;
    // The chosen row is non-uniform, has fewer bins than every uniform row that passes, meets the
    // budget under each light, and the grid file holds exactly its wavelengths.
    const std::string check =
        "python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); g=[r for r in d[\"grids\"] "
        "if r[\"chosen\"]][0]; "
        "u=[r[\"bins\"] for r in d[\"grids\"] if r[\"uniform\"] and r[\"passes\"]]; "
        "assert d[\"nonuniform\"] and not g[\"uniform\"] and g[\"step\"] is None, g; "
        "assert u and g[\"bins\"] < min(u), (g[\"bins\"], u); "
        "assert all(l[\"worst\"] <= 0.5 for l in g[\"lights\"]) and g[\"bins\"] == "
        "len(g[\"wavelengths\"]), g; "
        "w=[float(x) for x in open(sys.argv[2]) if not x.startswith(\"#\")]; "
        "assert w == [float(x) for x in g[\"wavelengths\"]], (w, g[\"wavelengths\"]); "
        "print(g[\"bins\"])' '" +
        d / "plan.json" + "' '" + d / "grid.txt" + "'";
    ASSERT_EQ(std::system(check.c_str()), 0) << read_file(d / "plan.json");

    write_png(d / "in.png");
    r = run_spectex(
        {"bake", d / "in.png", "-o", d / "listed.exr", "--wavelengths-file", d / "grid.txt"});
    ASSERT_EQ(r.status, 0) << r.err;
    const auto listed = spectral_channels(read_exr(d / "listed.exr"));
    std::ifstream grid(d / "grid.txt");
    std::vector<double> want;
    for (std::string line; std::getline(grid, line);)
        if (!line.empty() && line[0] != '#') want.push_back(std::stod(line));
    ASSERT_EQ(listed.size(), want.size());
    for (size_t k = 0; k < want.size(); ++k) EXPECT_NEAR(listed[k].first, want[k], 1e-9);

    // bake --wavelengths auto --nonuniform: the same choice, recorded; --nonuniform is a setting.
    std::vector<std::string> a =
        with({"bake", d / "in.png", "-o", d / "auto.exr", "--wavelengths", "auto"}, scene);
    r = run_spectex(with(a, {"--nonuniform"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("--wavelengths auto: non-uniform "), std::string::npos) << r.err;
    ExrImage img = read_exr(d / "auto.exr");
    EXPECT_EQ(img.attr("spectex:planGrids"), "uniform and non-uniform");
    const auto chosen = spectral_channels(img);
    EXPECT_LT(chosen.size(), 31u);
    r = run_spectex(with(a, {"--nonuniform", "--update", "--json", "-"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(count(r.out, "\"status\":\"skipped\""), 1u) << r.out;
    r = run_spectex(with(a, {"--update", "--json", "-"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(count(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_EQ(read_exr(d / "auto.exr").attr("spectex:planGrids"), "");
}

TEST(Plan, NonuniformUsageErrors) {
    ScratchDir d;
    write_png(d / "in.png");
    EXPECT_EQ(run_spectex({"plan", "--nonuniform", "--method", "lattice"}).status, 2);
    EXPECT_EQ(run_spectex({"bake", d / "in.png", "-o", d / "x.exr", "--nonuniform"}).status, 2);
    EXPECT_EQ(
        run_spectex({"bake", d / "in.png", "-o", d / "x.exr", "--wavelengths", "auto", "--lights",
                     "A", "--max-de", "0.5", "--nonuniform", "--method", "jakob-hanika"})
            .status,
        2);
    // plan's outputs are never a file it reads: a light table given as a file.
    std::ofstream(d / "light.csv") << "wavelength,value\n360,1\n830,1\n";
    EXPECT_EQ(run_spectex({"plan", "--lights", d / "light.csv", "--json", d / "light.csv"}).status,
              2);
    EXPECT_EQ(
        run_spectex({"plan", "--lights", d / "light.csv", "--grid-file", d / "light.csv"}).status,
        2);
    EXPECT_EQ(read_file(d / "light.csv"), "wavelength,value\n360,1\n830,1\n");
}

// --texture: the texture's own colours decide. Greys are flat spectra under the
// basis (S_r + S_g + S_b = 1), which every reconstruction holds exactly, so a grey texture meets a
// budget of 0.05 on the coarsest candidate (only half rounding is left), where the cube needs 5 nm;
// pixels with alpha 0 (here saturated blue, the cube's worst colour) are left out.
// A texture's NaN/Inf pixels and its values outside [0, 1] are taken as a bake takes them (0,
// clamped), which a bake says in a warning and plan said nowhere: the colours line counts them.
TEST(Plan, TextureColoursSayWhatWasReplacedOrClamped) {
    ScratchDir d;
    std::vector<float> px(4 * 4 * 3, 0.5f);
    px[0] = std::numeric_limits<float>::quiet_NaN();
    px[3 * 5 + 1] = std::numeric_limits<float>::infinity();
    px[3 * 10 + 2] = 3.0f;
    write_image(d / "odd.exr", 4, 4, 3, OIIO::TypeDesc::FLOAT, px.data());
    const RunResult r = run_spectex({"plan", "--texture", d / "odd.exr", "--method", "basis",
                                     "--grids", "400:700:20", "--lights", "D65", "--max-de", "5"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(has_text(r.out, "16 pixels, 2 with NaN/Inf taken as 0, 1 clamped into [0, 1]"))
        << r.out;
}

TEST(Plan, TextureColoursDecide) {
    ScratchDir d;
    std::vector<unsigned char> px(16 * 16 * 4);
    for (int i = 0; i < 256; ++i) {
        const bool hole = i % 16 == 0;
        px[4 * static_cast<size_t>(i) + 0] = hole ? 0 : static_cast<unsigned char>(i);
        px[4 * static_cast<size_t>(i) + 1] = hole ? 0 : static_cast<unsigned char>(i);
        px[4 * static_cast<size_t>(i) + 2] = hole ? 255 : static_cast<unsigned char>(i);
        px[4 * static_cast<size_t>(i) + 3] = hole ? 0 : 255;
    }
    write_image(d / "grey.png", 16, 16, 4, OIIO::TypeDesc::UINT8, px.data());
    // The basis: its greys are flat spectra, which 20 nm holds (the default lattice's are not).
    const std::vector<std::string> grids = {
        "--method", "basis", "--lights", "D65,A",
        "--max-de", "0.05",  "--grids",  "400:700:20,400:700:10,400:700:5,380:780:5"};
    RunResult r =
        run_spectex(with(with({"plan", "--texture", d / "grey.png"}, grids), {"--json", "-"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("\"chosen\":\"400:700:20\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"colours\":\"texture\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("240 colours of "), std::string::npos)
        << r.out;  // 256 pixels, 16 with alpha 0
    EXPECT_NE(r.out.find("16 with alpha 0 left out"), std::string::npos) << r.out;
    // The same budget over the cube's sample needs more bins.
    r = run_spectex(with(with({"plan", "--colours", "sample"}, grids), {"--json", "-"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out.find("\"chosen\":\"400:700:20\""), std::string::npos) << r.out;

    // A texture that cannot be read is exit 1 naming it; its options mean nothing without it; plan
    // never writes the texture it reads.
    r = run_spectex(with({"plan", "--texture", d / "missing.png"}, grids));
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("missing.png"), std::string::npos) << r.err;
    EXPECT_EQ(run_spectex({"plan", "--colorspace", "srgb_tx"}).status, 2);
    const std::string before = read_file(d / "grey.png");
    EXPECT_EQ(run_spectex({"plan", "--texture", d / "grey.png", "--json", d / "grey.png"}).status,
              2);
    EXPECT_EQ(read_file(d / "grey.png"), before);
}

// --wavelengths auto plans with the table the bake will use: a Jakob-Hanika bake at
// --jh-resolution 5 records the worst error of a 5³ table, not of the default 33³ one (the plan
// used to build its own method description and leave the resolution out).
TEST(Plan, AutoPlansWithTheMethodTheBakeBuilds) {
    ScratchDir d;
    write_png(d / "in.png");
    std::vector<std::string> worst;
    for (const std::string res : {"5", "9"}) {
        const std::string out = d / ("jh" + res + ".exr");
        RunResult r = run_spectex({"bake", d / "in.png", "-o", out, "--method", "jakob-hanika",
                                   "--jh-resolution", res, "--wavelengths", "auto", "--lights",
                                   "D65", "--max-de", "50", "--grids", "380:780:20", "-q"});
        ASSERT_EQ(r.status, 0) << r.err;
        const ExrImage img = read_exr(out);
        EXPECT_EQ(img.attr("spectex:jhTableResolution"), res);
        worst.push_back(img.attr("spectex:planWorstDe"));
        EXPECT_FALSE(worst.back().empty());
    }
    // A 5³ table misses colours a 9³ table gets: the planned worst error differs (a plan that
    // ignored the option would measure the default 33³ table both times). 9, not 33: the test
    // stays seconds long under the sanitizers.
    EXPECT_NE(worst[0], worst[1]) << "both planned with the same table";
}

TEST(Plan, AnUnmetBudgetIsExitOneInPlanAndBake) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 8, 4);
    const std::vector<std::string> budget = {"--lights", "A",       "--max-de",
                                             "0.0001",   "--grids", "380:780:20"};
    std::vector<std::string> plan = {"plan"},
                             bake = {"bake", png, "-o", d / "o.exr", "--wavelengths", "auto"};
    plan.insert(plan.end(), budget.begin(), budget.end());
    bake.insert(bake.end(), budget.begin(), budget.end());
    RunResult p = run_spectex(plan), b = run_spectex(bake);
    EXPECT_EQ(p.status, 1) << p.err;
    EXPECT_EQ(b.status, p.status) << b.err;
    EXPECT_TRUE(has_text(b.err, "best achievable")) << b.err;
}
