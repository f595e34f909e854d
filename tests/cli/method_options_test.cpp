// --method and the options of each method are declared once for bake and plan: both commands take
// the same options, refuse an option of another method the same way, and plan measures the table
// the option asks for.
#include <gtest/gtest.h>

#include <string>
#include <tuple>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"
#include "io/provenance_keys.h"

using namespace spectex_test;

namespace {

struct Misuse {
    std::string method, option, value, owner;
};

// Every option that belongs to one method, given with each other method.
const std::vector<Misuse> kMisuses = {
    {"lattice", "--jh-resolution", "5", "jakob-hanika"},
    {"basis", "--jh-resolution", "5", "jakob-hanika"},
    {"jakob-hanika", "--lattice-size", "5", "lattice"},
    {"basis", "--vertex-prior", "lhtss", "lattice"},
    {"lattice", "--objective", "norm", "basis"},
    {"jakob-hanika", "--allow-infeasible", "", "basis"},
};

std::vector<std::string> with_option(std::vector<std::string> args, const Misuse& m) {
    args.insert(args.end(), {"--method", m.method, m.option});
    if (!m.value.empty()) args.push_back(m.value);
    return args;
}

TEST(MethodOptions, AnOptionOfAnotherMethodIsAUsageErrorInBakeAndPlan) {
    ScratchDir d;
    write_pattern_png(d / "in.png", 1);
    for (const auto& m : kMisuses) {
        const std::string want =
            m.option + " belongs to --method " + m.owner + ", not --method " + m.method;
        const RunResult bake =
            run_spectex(with_option({"bake", d / "in.png", "-o", d / "out.exr"}, m));
        EXPECT_EQ(bake.status, 2) << m.option << " " << bake.err;
        EXPECT_NE(bake.err.find(want), std::string::npos) << bake.err;
        EXPECT_FALSE(file_exists(d / "out.exr"));
        const RunResult plan = run_spectex(with_option({"plan", "--lights", "A"}, m));
        EXPECT_EQ(plan.status, 2) << m.option << " " << plan.err;
        EXPECT_NE(plan.err.find(want), std::string::npos) << plan.err;
    }
    // --basis reads a table: bake only.
    const RunResult bake = run_spectex(
        {"bake", d / "in.png", "-o", d / "out.exr", "--method", "lattice", "--basis", "fit"});
    EXPECT_EQ(bake.status, 2);
    EXPECT_NE(bake.err.find("--basis belongs to --method basis, not --method lattice"),
              std::string::npos)
        << bake.err;
}

// An option that only another method takes (--out-of-range keep, --nonuniform: the basis) names
// what chose the method: --method, the method's own option that implied it, or the default, so the
// user sees which of their options to change.
TEST(MethodOptions, AnOptionTheMethodCannotTakeNamesWhatChoseTheMethod) {
    ScratchDir d;
    write_pattern_png(d / "in.png", 1);
    const std::vector<std::string> bake = {"bake", d / "in.png", "-o", d / "out.exr"};
    struct Case {
        std::vector<std::string> args;
        std::string want;
    };
    const std::vector<Case> cases = {
        {{"--jh-resolution", "5", "--out-of-range", "keep"},
         "--jh-resolution (an option of --method jakob-hanika) is defined on linear RGB in [0, 1]"},
        {{"--out-of-range", "keep", "--lattice-size", "5"},
         "--lattice-size (an option of --method lattice) is defined on linear RGB in [0, 1]"},
        {{"--method", "lattice", "--out-of-range", "keep"},
         "--method lattice is defined on linear RGB in [0, 1]"},
        {{"--vertex-prior", "smooth", "--wavelengths", "auto", "--lights", "A", "--max-de", "1",
          "--nonuniform"},
         "--vertex-prior (an option of --method lattice) is not linear"},
    };
    for (const auto& c : cases) {
        std::vector<std::string> args = bake;
        args.insert(args.end(), c.args.begin(), c.args.end());
        const RunResult r = run_spectex(args);
        EXPECT_EQ(r.status, 2) << c.args.front() << " " << r.err;
        EXPECT_NE(r.err.find(c.want), std::string::npos) << r.err;
        EXPECT_FALSE(file_exists(d / "out.exr"));
    }
    const RunResult plan =
        run_spectex({"plan", "--lights", "A", "--jh-resolution", "5", "--nonuniform"});
    EXPECT_EQ(plan.status, 2) << plan.err;
    EXPECT_NE(plan.err.find("--jh-resolution (an option of --method jakob-hanika) is not linear"),
              std::string::npos)
        << plan.err;
}

// One rule for the words every option takes: any case, recorded as the lower-case word (as light
// names and wrap modes always were). --vertex-prior JAKOB-HANIKA was taken while --method LATTICE
// and --type HALF were refused; a word that is none of them is still refused, listing them.
TEST(MethodOptions, EveryOptionsWordsAreTakenInAnyCase) {
    ScratchDir d;
    write_pattern_png(d / "in.png", 1);
    const std::string out = d / "out.exr";
    RunResult r = run_spectex({"bake",       d / "in.png",      "-o",      out,
                               "-q",         "--method",        "Lattice", "--vertex-prior",
                               "LHTSS",      "--type",          "HALF",    "--alpha",
                               "Associated", "--out-of-range",  "CLAMP",   "--nan",
                               "Replace",    "--half-rounding", "COLOUR",  "--precision",
                               "FULL",       "--lattice-size",  "3"});
    ASSERT_EQ(r.status, 0) << r.err;
    const ExrImage img = read_exr(out);
    EXPECT_EQ(img.attr(spectex::provenance_key::kMethod), "lattice");
    EXPECT_EQ(img.attr(spectex::provenance_key::kVertexPrior), "lhtss");
    r = run_spectex({"bake", d / "in.png", "-o", out, "-q", "--method", "BASIS", "--objective",
                     "Norm", "--basis", "FIT"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_exr(out).attr(spectex::provenance_key::kMethod), "basis");
    r = run_spectex({"plan", "--lights", "A", "--max-de", "2", "--grids", "380:780:20", "--method",
                     "BASIS", "--type", "Float", "--colours", "SAMPLE", "--reconstruction",
                     "Linear", "--sample-stride", "51"});
    EXPECT_EQ(r.status, 0) << r.err;
    for (const auto& [option, word, list] :
         std::vector<std::tuple<std::string, std::string, std::string>>{
             {"--method", "latice", "basis, lattice, jakob-hanika"},
             {"--type", "HALFS", "half, float"},
             {"--precision", "Autos", "full, auto"},
             {"--vertex-prior", "LHTS", "jakob-hanika, smooth, blend, lhtss or measured"}}) {
        r = run_spectex({"bake", d / "in.png", "-o", d / "no.exr", option, word});
        EXPECT_EQ(r.status, 2) << option << " " << r.err;
        EXPECT_NE(r.err.find(option + ": '" + word + "' is not one of " + list), std::string::npos)
            << r.err;
        EXPECT_FALSE(file_exists(d / "no.exr"));
    }
}

// The --method help of both commands lists every method, each with what it guarantees.
TEST(MethodOptions, BothCommandsDescribeEveryMethod) {
    for (const std::string command : {"bake", "plan"}) {
        const RunResult r = run_spectex({command, "--help"});
        ASSERT_EQ(r.status, 0);
        for (const std::string option : {"--method basis|lattice|jakob-hanika",
                                         "basis:", "lattice:", "jakob-hanika:", "--lattice-size",
                                         "--vertex-prior", "--jh-resolution", "--objective"})
            EXPECT_NE(r.out.find(option), std::string::npos) << command << ": " << option;
    }
}

// plan takes --jh-resolution (it had no such option, so a Jakob-Hanika plan always measured the
// default 33³ table): the method line names the table asked for, and a coarser table plans a
// larger error.
TEST(MethodOptions, PlanMeasuresTheJakobHanikaTableAskedFor) {
    std::vector<std::string> worst;
    for (const std::string res : {"5", "9"}) {
        const RunResult r = run_spectex({"plan", "--method", "jakob-hanika", "--jh-resolution", res,
                                         "--lights", "D65", "--max-de", "50", "--grids",
                                         "380:780:20", "--no-cache", "--json", "-"});
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_NE(r.out.find("jakob-hanika table " + res +
                             ", srgb primaries, cie1931-2, built "
                             "for D65"),
                  std::string::npos)
            << r.out;
        const size_t at = r.out.find("\"worst\":");
        ASSERT_NE(at, std::string::npos) << r.out;
        worst.push_back(r.out.substr(at, 20));
    }
    EXPECT_NE(worst[0], worst[1]) << "both planned with the same table";
}

}  // namespace
