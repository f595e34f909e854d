// examples/Makefile as its header says it works: incremental bakes with plain make, and a changed
// SPECTEX_FLAGS rebuilds every output (make used to see only timestamps and did nothing).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

// Runs make in `dir` with extra variables; its output (stdout and stderr) and status.
RunResult make_in(const std::string& dir, const std::string& vars) {
    return run_shell("make -C '" + dir + "' SPECTEX='" + spectex_binary() + "' " + vars);
}

}  // namespace

TEST(ExamplesMakefile, IncrementalAndAChangedFlagRebuilds) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "textures").c_str(), 0755), 0);
    ASSERT_EQ(std::system(("cp '" + std::string(SPECTEX_TEST_SOURCE_DIR) + "/examples/Makefile' '" +
                           d.path() + "/'")
                              .c_str()),
              0);
    std::vector<uint8_t> px(8 * 4 * 3, 120);
    write_image(d / "textures/a.png", 8, 4, 3, OIIO::TypeDesc::UINT8, px.data());
    RunResult first = make_in(d.path(), "");
    ASSERT_EQ(first.status, 0) << first.out;
    ASSERT_TRUE(file_exists(d / "out/a.exr")) << first.out;
    EXPECT_EQ(read_exr(d / "out/a.exr").types.begin()->second, Imf::HALF);
    // Nothing changed: make runs nothing.
    RunResult again = make_in(d.path(), "");
    EXPECT_EQ(again.status, 0) << again.out;
    EXPECT_EQ(again.out.find(" bake "), std::string::npos) << again.out;
    // A changed flag: every output is rebuilt, with the flag.
    RunResult flt = make_in(d.path(), "SPECTEX_FLAGS='--type float'");
    ASSERT_EQ(flt.status, 0) << flt.out;
    EXPECT_NE(flt.out.find(" bake "), std::string::npos) << flt.out;
    EXPECT_EQ(read_exr(d / "out/a.exr").types.begin()->second, Imf::FLOAT);
    // The same flags again: nothing to do.
    RunResult same = make_in(d.path(), "SPECTEX_FLAGS='--type float'");
    EXPECT_EQ(same.out.find(" bake "), std::string::npos) << same.out;
}
