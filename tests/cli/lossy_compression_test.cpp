// Lossy OpenEXR compressions: b44, b44a, dwaa and dwab (and pxr24 for float) change the stored
// spectra, so bake refuses them unless --allow-lossy is given; an allowed one is recorded in the
// header (spectex:lossyCompression), shown by info and named by verify when it moved samples; and
// bake --help marks which compressions are lossy for which sample type.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;

TEST(LossyCompression, IsRefusedUnlessAllowed) {
    ScratchDir d;
    const std::string in = write_albedo(d);
    for (const std::string& c : {"b44", "b44a", "dwaa", "dwab"}) {
        RunResult r = run_spectex({"bake", in, "-o", d / (c + ".exr"), "--compression", c});
        EXPECT_EQ(r.status, 2) << c << ": " << r.err;
        EXPECT_NE(r.err.find("--compression"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("lossy"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("--allow-lossy"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("zip"), std::string::npos) << "suggests a lossless one: " << r.err;
        EXPECT_FALSE(file_exists(d / (c + ".exr"))) << c;
    }
    // Float: pxr24 rounds float samples, so it is refused there; b44 keeps float whole.
    RunResult f =
        run_spectex({"bake", in, "-o", d / "p.exr", "--type", "float", "--compression", "pxr24"});
    EXPECT_EQ(f.status, 2) << f.err;
    // Lossless for half: pxr24 keeps half samples exactly.
    RunResult h = run_spectex({"bake", in, "-o", d / "h.exr", "--compression", "pxr24", "-q"});
    EXPECT_EQ(h.status, 0) << h.err;
}

TEST(LossyCompression, AnAllowedOneIsRecordedAndNamedByVerify) {
    ScratchDir d;
    const std::string in = write_albedo(d), exr = d / "b.exr";
    RunResult b = run_spectex({"bake", in, "-o", exr, "--compression", "b44", "--allow-lossy"});
    ASSERT_EQ(b.status, 0) << b.err;
    RunResult i = run_spectex({"info", exr});
    EXPECT_NE(i.out.find("spectex:lossyCompression"), std::string::npos) << i.out;
    EXPECT_NE(i.out.find("b44 (lossy for half)"), std::string::npos) << i.out;
    RunResult v = run_spectex({"verify", exr, "--source", in});
    EXPECT_EQ(v.status, 1) << v.out << v.err;  // b44 moves samples out of [0, 1]
    EXPECT_NE(v.out.find("FAILED"), std::string::npos) << v.out;
    EXPECT_NE(v.out.find("compression, b44 (lossy for half), changed the samples"),
              std::string::npos)
        << v.out;
}

TEST(LossyCompression, BakeHelpMarksThem) {
    RunResult r = run_spectex({"bake", "--help"});
    EXPECT_NE(r.out.find("pxr24 (lossy for float)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("dwaa (lossy)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--allow-lossy"), std::string::npos) << r.out;
}
