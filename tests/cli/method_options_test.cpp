// --method and the options of each method are declared once for bake and plan: both commands take
// the same options, refuse an option of another method the same way, and plan measures the table
// the option asks for.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cli/cli_util.h"

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
