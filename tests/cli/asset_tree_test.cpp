// Asset trees: --base-dir and {reldir} mirror a tree under --output-dir,
// creating folders as needed with the umask's mode; inputs outside the base are refused; {dir}
// under
// --output-dir never doubles a slash or climbs out; a template's folders are created.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

void write_png(const std::string& path) {
    std::vector<unsigned char> px(4 * 4 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<unsigned char>((i * 53) % 256);
    write_image(path, 4, 4, 3, OIIO::TypeDesc::UINT8, px.data());
}

// assets/{a/diffuse, b/diffuse, a/deep/rough, top}.png and a list of them.
void make_tree(const ScratchDir& d) {
    for (const char* dir : {"assets", "assets/a", "assets/b", "assets/a/deep"})
        ASSERT_EQ(::mkdir((d / dir).c_str(), 0755), 0);
    for (const char* f : {"assets/a/diffuse.png", "assets/b/diffuse.png", "assets/a/deep/rough.png",
                          "assets/top.png"})
        write_png(d / f);
    std::ofstream(d / "all.txt") << d / "assets/a/diffuse.png"
                                 << "\n"
                                 << d / "assets/b/diffuse.png"
                                 << "\n"
                                 << d / "assets/a/deep/rough.png"
                                 << "\n"
                                 << d / "assets/top.png"
                                 << "\n";
}

mode_t mode_of(const std::string& p) {
    struct stat st;
    return ::stat(p.c_str(), &st) == 0 ? st.st_mode & 07777 : 0;
}

}  // namespace

TEST(AssetTree, BaseDirMirrorsTheTreeWithTheUmasksModes) {
    ScratchDir d;
    make_tree(d);
    const mode_t old = ::umask(027);
    RunResult r = run_spectex({"bake", "--from-list", d / "all.txt", "--base-dir", d / "assets",
                               "--output-dir", d / "spectral", "-q"});
    ::umask(old);
    ASSERT_EQ(r.status, 0) << r.err;
    for (const char* f : {"spectral/a/diffuse.exr", "spectral/b/diffuse.exr",
                          "spectral/a/deep/rough.exr", "spectral/top.exr"}) {
        ASSERT_TRUE(file_exists(d / f)) << f;
        EXPECT_EQ(read_exr(d / f).width, 4) << f;
        EXPECT_EQ(mode_of(d / f), 0640u) << f;
    }
    for (const char* dir : {"spectral", "spectral/a", "spectral/b", "spectral/a/deep"})
        EXPECT_EQ(mode_of(d / dir), 0750u) << dir;
    EXPECT_FALSE(file_exists(d / "spectral/./top.exr") && !file_exists(d / "spectral/top.exr"));

    // The same tree again with --update: every output is found where the mirror put it.
    r = run_spectex({"bake", "--from-list", d / "all.txt", "--base-dir", d / "assets",
                     "--output-dir", d / "spectral", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    size_t skipped = 0;
    for (size_t at = r.out.find("\"status\":\"skipped\""); at != std::string::npos;
         at = r.out.find("\"status\":\"skipped\"", at + 1))
        ++skipped;
    EXPECT_EQ(skipped, 4u) << r.out;

    // A template with {reldir} mirrors too, beside the sources.
    r = run_spectex({"bake", "--from-list", d / "all.txt", "--base-dir", d / "assets", "-o",
                     d / "tpl/{reldir}/{stem}.spectral.exr", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(file_exists(d / "tpl/a/deep/rough.spectral.exr"));
    EXPECT_TRUE(file_exists(d / "tpl/top.spectral.exr"));
}

TEST(AssetTree, InputsOutsideTheBaseAreRefusedBeforeAnyWork) {
    ScratchDir d;
    make_tree(d);
    write_png(d / "stray.png");
    RunResult r =
        run_spectex({"bake", d / "assets/a/diffuse.png", d / "stray.png", d / "assets/../stray.png",
                     "--base-dir", d / "assets", "--output-dir", d / "spectral"});
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("stray.png: not below the --base-dir"), std::string::npos) << r.err;
    EXPECT_FALSE(file_exists(d / "spectral/a/diffuse.exr"));
    // The base must be a folder; {reldir} needs one.
    EXPECT_EQ(run_spectex(
                  {"bake", d / "assets/top.png", "--base-dir", d / "nope", "--output-dir", d / "o"})
                  .status,
              2);
    r = run_spectex({"bake", d / "assets/top.png", "-o", d / "o/{reldir}/{stem}.exr"});
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("needs --base-dir"), std::string::npos) << r.err;
}

TEST(AssetTree, DirUnderOutputDirStaysInsideIt) {
    ScratchDir d;
    make_tree(d);
    // An absolute input: its folder as a path inside the output folder, no "//".
    RunResult r = run_spectex({"bake", d / "assets/a/diffuse.png", "--output-dir", d / "out", "-o",
                               "{dir}/{stem}.exr", "--json", "-", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out.find("//"), std::string::npos) << r.out;
    EXPECT_TRUE(file_exists(d / "out" + (d / "assets/a/diffuse.exr")));
    // A folder with "..": refused, never written outside the output folder.
    r = run_spectex({"bake", d / "assets/../assets/a/diffuse.png", "--output-dir", d / "out2", "-o",
                     "{dir}/{stem}.exr"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("would climb out of --output-dir"), std::string::npos) << r.err;
}

TEST(AssetTree, TemplateFoldersAreCreatedAndAFileInTheWayIsAnError) {
    ScratchDir d;
    make_tree(d);
    RunResult r =
        run_spectex({"bake", d / "assets/a/diffuse.png", "-o", d / "new/deeper/{stem}.exr", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(file_exists(d / "new/deeper/diffuse.exr"));
    // spectral/a is a file: that input fails naming it, the others are baked, exit 1.
    ASSERT_EQ(::mkdir((d / "spectral").c_str(), 0755), 0);
    std::ofstream(d / "spectral/a") << "mine";
    r = run_spectex({"bake", "--from-list", d / "all.txt", "--base-dir", d / "assets",
                     "--output-dir", d / "spectral", "-q"});
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("spectral/a: cannot create the output folder"), std::string::npos)
        << r.err;
    EXPECT_EQ(read_file(d / "spectral/a"), "mine");
    EXPECT_TRUE(file_exists(d / "spectral/b/diffuse.exr"));
    EXPECT_TRUE(file_exists(d / "spectral/top.exr"));
}
